//! Declaration of `kernels/direct_light.wgsl` (mirror: `vxgi_cpu_mirror::direct_light`): direct light
//! with exact hard shadows at every G-buffer texel. A case runs the `gbuffer` kernel on the GPU first and
//! feeds its output in, on the generated scenes of [`super::gbuffer::generated_scene`].
use super::gbuffer::{case_for as gbuffer_case, generated_scene, scene_resources};
use crate::trace::SceneData;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::bvh_trace::{GpuNode, GpuTriangle};
use vxgi_cpu_mirror::direct_light::{shade_with_bound, GpuLight, GpuMaterial};
use vxgi_cpu_mirror::gbuffer::Frame;
use vxgi_harness::compare::bound_name;
use vxgi_harness::run::{grid_for, run, Pass, Workgroups};
use vxgi_harness::{
    Case, Check, DispatchRule, FloatMode, GpuContext, HostBuffer, HostResource, Indexing, Kernel,
    KernelDecl, Output, Resources, ScalarKind, Shader, Tolerance,
};

pub static DECL: KernelDecl = KernelDecl {
    name: "direct_light",
    wgsl_path: "kernels/direct_light.wgsl",
    wgsl: include_str!("../../kernels/direct_light.wgsl"),
    includes: &[
        super::SCENE_TYPES,
        super::gbuffer::BVH_TRACE,
        super::LIGHTS,
        super::BRDF,
    ],
    entry: "main",
    inputs: &[
        "frame",
        "nodes",
        "triangles",
        "lights",
        "materials",
        "gb_position",
        "gb_normal",
        "gb_triangle",
        "gb_albedo",
    ],
    outputs: &[
        // Per element (see `shade_with_bound`): 64 ULP per light term, 8 ULP absolute on cosines, pow's
        // rule; a term whose shadow or spot edge rounding decides adds its own value.
        Output {
            binding: "radiance",
            tolerance: Tolerance::MirrorBound,
        },
    ],
    dispatch: DispatchRule::PerElement {
        binding: "radiance",
    },
    mirror: "vxgi_cpu_mirror::direct_light::shade_with_bound",
    summary:
        "direct light, one exact shadow ray per light through the BVH, diffuse + normalised Phong",
};

/// The G-buffer of `data` computed on the GPU (the `gbuffer` kernel).
pub fn gpu_gbuffer(ctx: &GpuContext, data: &SceneData) -> Resources {
    let case = gbuffer_case(data, "gbuffer".into(), 0);
    let shader = super::gbuffer::DECL
        .shader()
        .expect("gbuffer.wgsl is valid");
    let out = run(
        ctx,
        &shader,
        "gbuffer",
        &case.resources,
        &case.passes,
        &["gb_position", "gb_normal", "gb_triangle", "gb_albedo"],
    )
    .expect("gbuffer runs");
    out.resources
}

/// Direct-light pass over a scene whose G-buffer the GPU has computed.
pub fn case_for(ctx: &GpuContext, data: &SceneData, label: String, seed: u64) -> Case {
    case_with_gbuffer(ctx, data, &gpu_gbuffer(ctx, data), label, seed)
}

/// Direct-light pass over a scene with the given G-buffer (gb_position, gb_normal, gb_triangle,
/// gb_albedo).
pub fn case_with_gbuffer(
    ctx: &GpuContext,
    data: &SceneData,
    gbuffer: &Resources,
    label: String,
    seed: u64,
) -> Case {
    let (w, h) = (data.width(), data.height());
    let n = w as usize * h as usize;
    let mut resources = scene_resources(data);
    resources.extend(gbuffer.clone());
    resources.insert(
        "radiance".into(),
        HostResource::Buffer(HostBuffer::zeroed(n * 16, ScalarKind::F32)),
    );
    let max = ctx.limits().max_compute_workgroups_per_dimension;
    Case {
        label,
        seed,
        resources,
        passes: vec![Pass {
            label: "direct_light".into(),
            entry: "main".into(),
            bindings: DECL.bind_by_name(),
            workgroups: Workgroups::Direct(grid_for(n as u64, 64, max)),
        }],
        checks: vec![Check {
            resource: "radiance".into(),
            output: "radiance",
            indexing: Indexing::Grid {
                dims: [w, h, 1],
                components: 4,
            },
        }],
        effective_bytes: n as u64 * 52,
    }
}

/// Mirror radiance and bound per pixel.
pub fn mirror_direct(data: &Resources) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let b = |n: &str| data[n].buffer().expect("buffer");
    let frame: Frame = *bytemuck::from_bytes(&b("frame").bytes);
    let nodes: &[GpuNode] = bytemuck::cast_slice(&b("nodes").bytes);
    let tris: &[GpuTriangle] = bytemuck::cast_slice(&b("triangles").bytes);
    let lights: &[GpuLight] = bytemuck::cast_slice(&b("lights").bytes);
    let lights = &lights[..frame.size[2] as usize];
    let materials: &[GpuMaterial] = bytemuck::cast_slice(&b("materials").bytes);
    let pos: &[[f32; 4]] = bytemuck::cast_slice(&b("gb_position").bytes);
    let nrm: &[[f32; 4]] = bytemuck::cast_slice(&b("gb_normal").bytes);
    let tri = b("gb_triangle").as_u32();
    let alb: &[[f32; 4]] = bytemuck::cast_slice(&b("gb_albedo").bytes);
    (0..tri.len())
        .map(|i| {
            let (l, e) = shade_with_bound(
                &frame, nodes, tris, lights, materials, pos[i], nrm[i], tri[i], alb[i],
            );
            ([l.x, l.y, l.z, 0.0], [e.x, e.y, e.z, 0.0])
        })
        .unzip()
}

pub struct DirectLight;

impl Kernel for DirectLight {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (scene, label) = generated_scene(seed, index);
        case_for(ctx, &SceneData::new(&scene), label, seed)
    }
    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        // Subnormals play no part at scene scales (smallest inputs ~1e-3 units): one mode serves both.
        let (l, e) = mirror_direct(data);
        let f = |v: &[[f32; 4]]| HostBuffer::f32(bytemuck::cast_slice(v));
        BTreeMap::from([
            ("radiance".to_string(), f(&l)),
            (bound_name("radiance"), f(&e)),
        ])
    }
}
