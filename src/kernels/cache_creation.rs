//! Declaration of `kernels/cache_creation.wgsl` (mirror: `vxgi_cpu_mirror::cache_creation`): one cone per
//! radiance-cache texel through the radiance pyramid (CPRC 3.1). A case runs the earlier stages on the
//! GPU (G-buffer, voxelization, voxel lighting, mip chain) on a generated scene, as cone_trace's do, and
//! places caches on every k-th geometry pixel, plus caches whose normals are the basis's branch points.
use super::cone_trace::{cone_params, gpu_pyramid, lit_case, max_radiance, Pyramids};
use std::collections::BTreeMap;
use vxgi_cpu_mirror::cache_creation::{
    cone_tan, create_texel, texel_directions, CacheParams, Placed, PlacedPyramids,
};
use vxgi_cpu_mirror::cone_trace::{ConeParams, Volume};
use vxgi_harness::prelude::*;

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "cache_creation",
    includes: &[super::TANGENT_BASIS, super::SCENE_TYPES, super::CONE_MARCH, super::MORTON, super::PYRAMID_GRID, super::PYRAMID],
    entry: "create",
    inputs: &["cone", "pyramid", "pyramid_1", "pyramid_2", "pyramid_normal", "cache_params", "caches", "texel_dirs"],
    outputs: &[
        // cone_trace's march bound per texel (see `cone_trace::MAG`): 4e-4 of the accumulated
        // magnitudes plus the remainder where a stop is within rounding of its threshold.
        Output { binding: "cache_radiance", tolerance: Tolerance::MirrorBound },
    ],
    dispatch: DispatchRule::PerElement { binding: "cache_radiance" },
    mirror: "vxgi_cpu_mirror::cache_creation::create_texel",
    summary: "one cone per radiance-cache texel (hemi-octahedral) through the radiance pyramid (CPRC 3.1)",
);

/// cache_creation with the per-instance hierarchies of CPRC 3.1 as its volume: the same kernel file and
/// entry, the pyramids placed by rigid transforms (common/placed_pyramids.wgsl) instead of one.
pub static INSTANCED_DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "cache_creation_instanced" in "cache_creation",
    includes: &[
        super::TANGENT_BASIS,
        super::SCENE_TYPES,
        super::CONE_MARCH,
        super::MORTON,
        super::PYRAMID_GRID,
        super::PLACED_PYRAMIDS,
    ],
    entry: "create",
    inputs: &["cone", "pyramid", "pyramid_1", "pyramid_2", "placed", "placed_cells", "cache_params", "caches", "texel_dirs"],
    outputs: &[
        // cone_trace's march bound, each sample's error the sum of its hierarchies' (their local
        // points' rounding included) plus a rounding per combined factor.
        Output { binding: "cache_radiance", tolerance: Tolerance::MirrorBound },
    ],
    dispatch: DispatchRule::PerElement { binding: "cache_radiance" },
    mirror: "vxgi_cpu_mirror::cache_creation::create_texel (PlacedPyramids)",
    summary: "cache_creation through several voxel hierarchies placed by rigid transforms (CPRC 3.1 multiple hierarchies)",
);

/// The creation pass over `caches` (two vec4s each: origin, normal) at `res x res` texels. The
/// normal pyramid is bound only where `cone` asks for the depth-ordered blend (else one element).
pub fn case_for(
    ctx: &GpuContext,
    pyramids: &Pyramids,
    cone: &ConeParams,
    caches: &[[f32; 4]],
    res: u32,
    label: String,
    seed: u64,
) -> Case {
    let mut case = case_with(
        ctx,
        &DECL,
        &pyramids.colour,
        None,
        cone,
        caches,
        res,
        label,
        seed,
    );
    let normal: &[[f32; 4]] = if cone.depth_order != 0 {
        &pyramids.normal
    } else {
        &[[0.0; 4]]
    };
    case.resources
        .insert("pyramid_normal".into(), HostBuffer::of(normal).into());
    case
}

/// The creation pass through several hierarchies (`INSTANCED_DECL`): `pyramid` holds them all,
/// `placed` says where each is and where its levels start.
#[allow(clippy::too_many_arguments)]
pub fn instanced_case_for(
    ctx: &GpuContext,
    pyramid: &[[f32; 4]],
    placed: &[Placed],
    cone: &ConeParams,
    caches: &[[f32; 4]],
    res: u32,
    label: String,
    seed: u64,
) -> Case {
    case_with(
        ctx,
        &INSTANCED_DECL,
        pyramid,
        Some(placed),
        cone,
        caches,
        res,
        label,
        seed,
    )
}

#[allow(clippy::too_many_arguments)]
fn case_with(
    ctx: &GpuContext,
    decl: &'static KernelDecl,
    pyramid: &[[f32; 4]],
    placed: Option<&[Placed]>,
    cone: &ConeParams,
    caches: &[[f32; 4]],
    res: u32,
    label: String,
    seed: u64,
) -> Case {
    let shader = decl.shader().expect("cache_creation.wgsl is valid");
    let count = caches.len() / 2;
    let texels = res * res;
    let p = CacheParams {
        count: count as u32,
        texels,
        tan_half: cone_tan(res),
        _pad: 0,
    };
    let n = count * texels as usize;
    let nonempty = if caches.is_empty() {
        vec![[0.0; 4]; 2]
    } else {
        caches.to_vec()
    };
    let mut resources = buffers([
        ("cone", HostBuffer::pod(cone)),
        ("pyramid", HostBuffer::of(pyramid)),
        ("cache_params", HostBuffer::pod(&p)),
        ("caches", HostBuffer::of(&nonempty)),
        ("texel_dirs", HostBuffer::of(&texel_directions(res))),
        (
            "cache_radiance",
            HostBuffer::zeroed(n.max(1) * 16, ScalarKind::F32),
        ),
    ]);
    if let Some(placed) = placed {
        resources.extend(super::cone_trace::placed_resources(placed));
    }
    let grid = Indexing::Grid {
        dims: [texels, count.max(1) as u32, 1],
        components: 4,
    };
    let mut case = Case {
        label,
        seed,
        passes: vec![decl.pass(&shader, ctx, "create".into(), decl.bind_by_name(), n as u64)],
        resources,
        checks: vec![Check::of("cache_radiance", grid)],
        effective_bytes: n as u64 * 16,
    };
    super::cone_trace::bind_pyramid_windows(&mut case, super::cone_trace::PYRAMID_WINDOW)
        .expect("the voxel limits keep the pyramid within its bindings");
    case
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
        let half = 0.5 * params.side as f32 * params.origin[3];
        let mid = [0, 1, 2, 3].map(|k| if k < 3 { params.origin[k] + half } else { 0.0 });
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
        let order = if params.depth_order != 0 {
            ", depth-ordered"
        } else {
            ""
        };
        let label = format!("{}, {} caches of {res}^2{order}", c.label, caches.len() / 2);
        let case = case_for(ctx, &pyr, &params, &caches, res, label, seed);
        super::cone_trace::with_pyramid_split(with_carried(case, index), index)
    }
    fn mirror(&self, case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // Radiance-scale arithmetic, as cone_trace's: one mode serves both.
        mirror_outputs(case, data)
    }
}

pub struct CacheCreationInstanced;

impl Kernel for CacheCreationInstanced {
    fn decl(&self) -> &'static KernelDecl {
        &INSTANCED_DECL
    }
    /// cache_creation's cases with the scene's pyramid as hierarchy 0 (in place) and again as one or
    /// two more placed by `cone_trace::random_placement`: instances of one mesh.
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let p = super::cone_trace::placed_case(ctx, seed, 0xca5e, index, 1 + index % 2);
        let (c, params, placed) = (p.lit, p.params, p.placed);
        let res = RES[index % RES.len()];
        let caches = caches_on_pixels(&c.gbuffer, &params, 97);
        let label = format!(
            "{}, {} hierarchies, {} caches of {res}^2",
            c.label,
            placed.len(),
            caches.len() / 2
        );
        let case = instanced_case_for(ctx, &p.pyramid, &placed, &params, &caches, res, label, seed);
        super::cone_trace::with_pyramid_split(case, index)
    }
    fn mirror(&self, case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        mirror_outputs(case, data)
    }
}

/// One case in three (`index % 3 == 1`) with every third cache carried (`caches[2c + 1].w = 1`, as
/// cache_reuse's keep marks a cache whose texels it copied): its texels hold values the pass must
/// leave as they are.
fn with_carried(mut case: Case, index: usize) -> Case {
    if index % 3 != 1 {
        return case;
    }
    let params = &case.resources["cache_params"]
        .buffer()
        .expect("buffer")
        .bytes;
    let p: CacheParams = *bytemuck::from_bytes(params);
    let t = p.texels as usize;
    let f4 = |n: &str| -> Vec<[f32; 4]> {
        bytemuck::pod_collect_to_vec(&case.resources[n].buffer().expect("buffer").bytes)
    };
    let (mut caches, mut radiance) = (f4("caches"), f4("cache_radiance"));
    for c in (0..p.count as usize).step_by(3) {
        caches[2 * c + 1][3] = 1.0;
        for k in 0..t {
            radiance[c * t + k] = [c as f32 + 0.25, k as f32, 0.5, 0.0];
        }
    }
    for (name, v) in [("caches", caches), ("cache_radiance", radiance)] {
        case.resources
            .insert(name.into(), HostBuffer::of(&v).into());
    }
    case.label.push_str(", every third cache carried");
    case
}

/// The mirror's outputs (radiance and bound by resource name) for a creation case, either volume:
/// a carried cache's texels as the case gave them (exact), the others traced.
fn mirror_outputs(case: &Case, data: &Resources) -> BTreeMap<String, HostBuffer> {
    let (mut out, mut bound) = mirror_texels(data);
    let b = |n: &str| case.resources[n].buffer().expect("buffer");
    let p: CacheParams = *bytemuck::from_bytes(&b("cache_params").bytes);
    let caches: &[[f32; 4]] = bytemuck::cast_slice(&b("caches").bytes);
    let before: &[[f32; 4]] = bytemuck::cast_slice(&b("cache_radiance").bytes);
    let t = p.texels as usize;
    for c in (0..p.count as usize).filter(|&c| caches[2 * c + 1][3] != 0.0) {
        for i in c * t..(c + 1) * t {
            (out[i], bound[i]) = (before[i], [0.0; 4]);
        }
    }
    BTreeMap::from(bounded("cache_radiance", &out, &bound))
}

/// Every texel of a creation case's resources by the mirror: radiance and bound.
pub fn mirror_texels(data: &Resources) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let b = |n: &str| data[n].buffer().expect("buffer");
    let cone: ConeParams = *bytemuck::from_bytes(&b("cone").bytes);
    let voxels: &[[f32; 4]] = bytemuck::cast_slice(&b("pyramid").bytes);
    let lmax = max_radiance(voxels, cone.side);
    match data.get("placed") {
        None => texels_through(data, &super::cone_trace::dense_volume(data, &cone), lmax),
        Some(r) => {
            let placed: &[Placed] = bytemuck::cast_slice(&r.buffer().expect("buffer").bytes);
            let vol = PlacedPyramids {
                p: &cone,
                placed,
                voxels,
            };
            // The largest radiance of any hierarchy's level 0.
            let lmax = placed
                .iter()
                .map(|h| {
                    let [side, _, base, _] = h.side_levels_base;
                    max_radiance(&voxels[base as usize..], side)
                })
                .fold(0.0, f32::max);
            texels_through(data, &vol, lmax)
        }
    }
}

fn texels_through(
    data: &Resources,
    pyr: &(impl Volume + Sync),
    lmax: f32,
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    use rayon::prelude::*;
    let b = |n: &str| data[n].buffer().expect("buffer");
    let p: CacheParams = *bytemuck::from_bytes(&b("cache_params").bytes);
    let caches: &[[f32; 4]] = bytemuck::cast_slice(&b("caches").bytes);
    let dirs: &[[f32; 4]] = bytemuck::cast_slice(&b("texel_dirs").bytes);
    let n = (p.count * p.texels) as usize;
    let texels: Vec<([f32; 4], [f32; 4])> = (0..n)
        .into_par_iter()
        .map(|i| {
            let c = i / p.texels as usize;
            let t = i % p.texels as usize;
            create_texel(
                pyr,
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
