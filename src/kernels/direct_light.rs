//! Declaration of `kernels/direct_light.wgsl` (mirror: `vxgi_cpu_mirror::direct_light`): direct light
//! with exact hard shadows at every G-buffer texel. A case runs the `gbuffer` kernel on the GPU first and
//! feeds its output in, on the generated scenes of [`super::gbuffer::generated_scene`].
use super::gbuffer::{case_for as gbuffer_case, generated_scene, scene_resources};
use crate::trace::SceneData;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::bvh_trace::{GpuNode, GpuTriangle};
use vxgi_cpu_mirror::direct_light::{shade_with_bound, GpuLight, GpuMaterial};
use vxgi_cpu_mirror::gbuffer::Frame;
use vxgi_harness::prelude::*;

vxgi_harness::bindings! {
    /// direct_light's bindings: the scene (camera frame, BVH, triangles, lights, materials) and its
    /// G-buffer in, the direct radiance per pixel out.
    pub struct Io {
        inputs: {
            frame: Block<Frame>,
            nodes: Structs<GpuNode>,
            // Six vec4<f32> per triangle (`GpuTriangle`), three per light (`GpuLight`).
            triangles: Vec<[f32; 4]>,
            lights: Vec<[f32; 4]>,
            materials: Structs<GpuMaterial>,
            gb_position: Vec<[f32; 4]>,
            gb_normal: Vec<[f32; 4]>,
            gb_triangle: Vec<u32>,
            gb_albedo: Vec<[f32; 4]>,
        }
        outputs: {
            // Per element (see `shade_with_bound`): 64 ULP per light term, 8 ULP absolute on
            // cosines, pow's rule; a term whose shadow or spot edge rounding decides adds its own
            // value.
            radiance: Vec<[f32; 4]> => Tolerance::MirrorBound
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "direct_light",
    includes: &[
        super::SCENE_TYPES,
        super::gbuffer::BVH_TRACE,
        super::LIGHTS,
        super::BRDF,
    ],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement {
        binding: "radiance",
    },
    mirror: "vxgi_cpu_mirror::direct_light::shade_with_bound",
    summary:
        "direct light, one exact shadow ray per light through the BVH, diffuse + normalised Phong",
);

/// The G-buffer of `data` computed on the GPU (the `gbuffer` kernel).
pub fn gpu_gbuffer(ctx: &GpuContext, data: &SceneData) -> Resources {
    let case = gbuffer_case(data, "gbuffer".into(), 0);
    let shader = super::gbuffer::DECL
        .shader()
        .expect("gbuffer.wgsl is valid");
    let out = case
        .run(
            ctx,
            &shader,
            "gbuffer",
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
/// gb_albedo; each one left out is zeroed, for a chain whose gbuffer stage computes it).
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
    // A G-buffer the chain's gbuffer stage computes may be left out: zeroed placeholders.
    let zeroed = |bytes, kind| HostBuffer::zeroed(bytes, kind).into();
    for (name, bytes, kind) in [
        ("gb_position", 16, ScalarKind::F32),
        ("gb_normal", 16, ScalarKind::F32),
        ("gb_triangle", 4, ScalarKind::U32),
        ("gb_albedo", 16, ScalarKind::F32),
        ("radiance", 16, ScalarKind::F32),
    ] {
        let r = gbuffer.get(name).cloned();
        resources.insert(name.into(), r.unwrap_or_else(|| zeroed(n * bytes, kind)));
    }
    let shader = DECL.shader().expect("direct_light.wgsl is valid");
    DECL.case_of(&shader, ctx, &Io::read(&resources), n as u64, label, seed)
        .with_grid([w, h, 1])
        .with_effective_bytes(n as u64 * 52)
}

/// Mirror radiance and bound per pixel.
pub fn mirror_direct(data: &Resources) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let io = Io::read(data);
    let frame = io.frame.0;
    let tris: &[GpuTriangle] = bytemuck::cast_slice(&io.triangles);
    let lights: &[GpuLight] = bytemuck::cast_slice(&io.lights);
    let lights = &lights[..frame.size[2] as usize];
    let (nodes, materials) = (&io.nodes.0, &io.materials.0);
    (0..io.gb_triangle.len())
        .map(|i| {
            let (l, e) = shade_with_bound(
                &frame,
                nodes,
                tris,
                lights,
                materials,
                io.gb_position[i],
                io.gb_normal[i],
                io.gb_triangle[i],
                io.gb_albedo[i],
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
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // Subnormals play no part at scene scales (smallest inputs ~1e-3 units): one mode serves both.
        let (l, e) = mirror_direct(data);
        BTreeMap::from(bounded("radiance", &l, &e))
    }
}
