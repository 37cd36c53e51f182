//! Declaration of `kernels/cache_creation.wgsl` (mirror: `vxgi_cpu_mirror::cache_creation`): one cone per
//! radiance-cache texel through the radiance pyramid (CPRC 3.1). A case runs the earlier stages on the
//! GPU (G-buffer, voxelization, voxel lighting, mip chain) on a generated scene, as cone_trace's do, and
//! places caches on every k-th geometry pixel, plus caches whose normals are the basis's branch points.
use super::cone_trace::{cone_params, gpu_pyramid, lit_case, max_radiance};
use std::collections::BTreeMap;
use vxgi_cpu_mirror::cache_creation::{cone_tan, create_texel, texel_directions, CacheParams};
use vxgi_cpu_mirror::cone_trace::{ConeParams, Pyramid};
use vxgi_harness::compare::bound_name;
use vxgi_harness::{
    Case, Check, DispatchRule, FloatMode, GpuContext, HostBuffer, HostResource, Indexing, Kernel,
    KernelDecl, Output, Resources, ScalarKind, Shader, Tolerance,
};

pub static DECL: KernelDecl = KernelDecl {
    name: "cache_creation",
    wgsl_path: "kernels/cache_creation.wgsl",
    wgsl: include_str!("../../kernels/cache_creation.wgsl"),
    includes: &[super::TANGENT_BASIS, super::CONE_MARCH, super::PYRAMID],
    entry: "create",
    inputs: &["cone", "pyramid", "cache_params", "caches", "texel_dirs"],
    outputs: &[
        // cone_trace's march bound per texel (see `cone_trace::MAG`): 4e-4 of the accumulated
        // magnitudes plus the remainder where a stop is within rounding of its threshold.
        Output { binding: "cache_radiance", tolerance: Tolerance::MirrorBound },
    ],
    dispatch: DispatchRule::PerElement { binding: "cache_radiance" },
    mirror: "vxgi_cpu_mirror::cache_creation::create_texel",
    summary: "one cone per radiance-cache texel (hemi-octahedral) through the radiance pyramid (CPRC 3.1)",
};

/// The creation pass over `caches` (two vec4s each: origin, normal) at `res x res` texels.
pub fn case_for(
    ctx: &GpuContext,
    pyramid: &[[f32; 4]],
    cone: &ConeParams,
    caches: &[[f32; 4]],
    res: u32,
    label: String,
    seed: u64,
) -> Case {
    let shader = DECL.shader().expect("cache_creation.wgsl is valid");
    let count = caches.len() / 2;
    let texels = res * res;
    let p = CacheParams {
        count: count as u32,
        texels,
        tan_half: cone_tan(res),
        _pad: 0,
    };
    let f4 = |v: &[[f32; 4]]| HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(v)));
    let n = count * texels as usize;
    let mut resources = Resources::new();
    resources.insert("cone".into(), HostResource::Buffer(HostBuffer::pod(cone)));
    resources.insert("pyramid".into(), f4(pyramid));
    resources.insert(
        "cache_params".into(),
        HostResource::Buffer(HostBuffer::pod(&p)),
    );
    let nonempty = if caches.is_empty() {
        vec![[0.0; 4]; 2]
    } else {
        caches.to_vec()
    };
    resources.insert("caches".into(), f4(&nonempty));
    resources.insert("texel_dirs".into(), f4(&texel_directions(res)));
    resources.insert(
        "cache_radiance".into(),
        HostResource::Buffer(HostBuffer::zeroed(n.max(1) * 16, ScalarKind::F32)),
    );
    Case {
        label,
        seed,
        passes: vec![DECL.pass(&shader, ctx, "create".into(), DECL.bind_by_name(), n as u64)],
        resources,
        checks: vec![Check {
            resource: "cache_radiance".into(),
            output: "cache_radiance",
            indexing: Indexing::Grid {
                dims: [texels, count.max(1) as u32, 1],
                components: 4,
            },
        }],
        effective_bytes: n as u64 * 16,
    }
}

/// Caches on every `stride`-th front-facing geometry pixel of a G-buffer: origin = position moved
/// `offset_voxels * s0` along the shading normal, normal = the shading normal on the camera's side.
pub fn caches_on_pixels(gbuffer: &Resources, cone: &ConeParams, stride: usize) -> Vec<[f32; 4]> {
    let b = |n: &str| gbuffer[n].buffer().expect("buffer");
    let pos: &[[f32; 4]] = bytemuck::cast_slice(&b("gb_position").bytes);
    let nrm: &[[f32; 4]] = bytemuck::cast_slice(&b("gb_normal").bytes);
    let off = cone.offset_voxels * cone.origin[3];
    let mut out = Vec::new();
    for (i, (p, n)) in pos.iter().zip(nrm).enumerate() {
        if i % stride != 0 || n[3] <= 0.0 {
            continue;
        }
        out.push([p[0] + n[0] * off, p[1] + n[1] * off, p[2] + n[2] * off, 0.0]);
        out.push([n[0], n[1], n[2], 0.0]);
    }
    out
}

pub struct CacheCreation;

/// Cache sides of the generated cases (small: every texel is a whole cone march).
const RES: [u32; 3] = [4, 2, 8];

impl Kernel for CacheCreation {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let c = lit_case(ctx, seed, index);
        let pyr = gpu_pyramid(ctx, &c.radiance, &c.normal, c.frame.side).expect("mip chain runs");
        let params = cone_params(&c.frame, &c.settings);
        let res = RES[index % RES.len()];
        let mut caches = caches_on_pixels(&c.gbuffer, &params, 97);
        // The tangent basis switches its helper axis at |n.z| = 0.999: normals on and around it, from
        // the middle of the grid.
        let mid = [
            params.origin[0] + 0.5 * params.side as f32 * params.origin[3],
            params.origin[1] + 0.5 * params.side as f32 * params.origin[3],
            params.origin[2] + 0.5 * params.side as f32 * params.origin[3],
            0.0,
        ];
        let z = 0.999f32;
        let r = (1.0 - z * z).sqrt();
        for n in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [r, 0.0, z],
            [1.0, 0.0, 0.0],
        ] {
            caches.push(mid);
            caches.push([n[0], n[1], n[2], 0.0]);
        }
        let label = format!("{}, {} caches of {res}^2", c.label, caches.len() / 2);
        case_for(ctx, &pyr, &params, &caches, res, label, seed)
    }
    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        // Radiance-scale arithmetic, as cone_trace's: one mode serves both.
        let (out, bound) = mirror_texels(data);
        let f = |v: &[[f32; 4]]| HostBuffer::f32(bytemuck::cast_slice(v));
        BTreeMap::from([
            ("cache_radiance".to_string(), f(&out)),
            (bound_name("cache_radiance"), f(&bound)),
        ])
    }
}

/// Every texel of a creation case's resources by the mirror: radiance and bound.
pub fn mirror_texels(data: &Resources) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    use rayon::prelude::*;
    let b = |n: &str| data[n].buffer().expect("buffer");
    let cone: ConeParams = *bytemuck::from_bytes(&b("cone").bytes);
    let p: CacheParams = *bytemuck::from_bytes(&b("cache_params").bytes);
    let voxels: &[[f32; 4]] = bytemuck::cast_slice(&b("pyramid").bytes);
    let caches: &[[f32; 4]] = bytemuck::cast_slice(&b("caches").bytes);
    let dirs: &[[f32; 4]] = bytemuck::cast_slice(&b("texel_dirs").bytes);
    let pyr = Pyramid { p: &cone, voxels };
    let lmax = max_radiance(voxels, cone.side);
    let n = (p.count * p.texels) as usize;
    let texels: Vec<([f32; 4], [f32; 4])> = (0..n)
        .into_par_iter()
        .map(|i| {
            let c = i / p.texels as usize;
            let t = i % p.texels as usize;
            create_texel(
                &pyr,
                [caches[2 * c], caches[2 * c + 1]],
                dirs[t],
                p.tan_half,
                lmax,
            )
        })
        .collect();
    let mut out: Vec<[f32; 4]> = texels.iter().map(|t| t.0).collect();
    let mut bound: Vec<[f32; 4]> = texels.iter().map(|t| t.1).collect();
    if out.is_empty() {
        out.push([0.0; 4]);
        bound.push([0.0; 4]);
    }
    (out, bound)
}
