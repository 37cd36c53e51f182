//! Declaration of `kernels/svo_cone_trace.wgsl` (mirror: `vxgi_cpu_mirror::svo_cone_trace`): the cone
//! pass of vct-svo, cone_trace's tracer reading the sparse voxel octree. A case runs the earlier stages
//! on a generated scene (G-buffer, voxelization, voxel lighting on the GPU), builds the octree of the
//! lit voxels with the mirror (the builder is verified on its own) and feeds it in.
use super::cone_trace::{
    bounded_outputs, cone_params, lit_case, shade_all, tracer_case, ConeSettings,
};
use super::sparse_voxel_octree::{to_fixed, SvoError};
use super::voxelize::VoxelFrame;
use crate::trace::SceneData;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::cone_trace::ConeParams;
use vxgi_cpu_mirror::sparse_voxel_octree::{bricks_in_layout, build_fitted, Fragment, Octree};
use vxgi_cpu_mirror::svo_cone_trace::{normal_value, SvoParams, SvoVolume};
use vxgi_harness::prelude::*;

pub static DECL: KernelDecl = BASE;

/// svo_cone_trace's declaration, which [`WINDOWED_DECL`] shares but for its includes.
const BASE: KernelDecl = vxgi_harness::kernel_decl!(
    "svo_cone_trace",
    includes: &[super::SVO_NODE, super::SVO_BRICKS_ONE, super::SVO_ANISO_PAIR, super::TANGENT_BASIS, super::SCENE_TYPES, super::CONE_MARCH],
    inputs: super::march_inputs!["nodes", "bricks", "svo", "aniso", "normal_bricks", "spec_bricks"],
    // The march's bound (`super::march_outputs!`): the march is cone_trace's code; the octree's
    // sample adds the conversion f32(u32) * inv_scale (two correctly rounded operations per voxel)
    // to the ~30 operations per sample the bound already covers, and the sample point's rounding is
    // in the mirror's SampleError as for the pyramid.
    outputs: super::march_outputs![],
    dispatch: DispatchRule::PerItem {
        what: "8x8 screen tile holding a surface (screen_tiles' list, dispatched indirectly)",
    },
    mirror: "vxgi_cpu_mirror::cone_trace::shade_pixel (volume: vxgi_cpu_mirror::svo_cone_trace::SvoVolume)",
    summary: "cone_trace's AO + diffuse + glossy cones marching the sparse voxel octree (quadrilinear brick sampling, VCT 5-7)",
);

/// svo_cone_trace with the octree's pools read in windows of one buffer each (kernels/common/
/// svo_bricks.wgsl, svo_aniso_windows.wgsl): for bricks past one storage binding or directional
/// values past two (Sponza's octree at 512^3), where a branch per window in the march would cost
/// lavapipe about twice the pass of [`DECL`] (bricks in one binding, values in up to two) in every
/// smaller frame. [`decl_for`] picks one.
/// Its bindings, outputs (the windows change which binding holds a value, not the value) and mirror
/// are [`DECL`]'s; the pools' windows past their first (`bricks_1`.., `aniso_1`..) are bound by
/// `svo_anisotropic::bind_pools`.
pub static WINDOWED_DECL: KernelDecl = KernelDecl {
    name: "svo_cone_trace_windowed",
    includes: &[super::SVO_NODE, super::SVO_BRICKS, super::SVO_ANISO_WINDOWS, super::TANGENT_BASIS, super::SCENE_TYPES, super::CONE_MARCH],
    summary: "svo_cone_trace with the octree's bricks and directional values in windows of one buffer (bricks past one storage binding, values past two)",
    ..BASE
};

/// The cone pass's declaration for an octree of `brick_words` words of bricks and `aniso_values`
/// directional values: [`WINDOWED_DECL`] where the bricks are past one binding or the values past
/// two, else [`DECL`] (bricks in one binding, values in up to two).
pub fn decl_for(brick_words: usize, aniso_values: usize) -> &'static KernelDecl {
    let windowed = brick_words as u64 > super::sparse_voxel_octree::BRICK_WINDOW
        || aniso_values as u64 > 2 * super::svo_anisotropic::POOL_WINDOW;
    if windowed {
        &WINDOWED_DECL
    } else {
        &DECL
    }
}

/// Fixed-point scale of the octree's values where they fit it: 2^16 steps per unit of radiance.
/// A frame whose values are brighter gets a smaller one from [`fixed_scale`].
pub const SCALE: f32 = 65536.0;

/// The fixed-point scale of a frame's octree: [`SCALE`], or the largest power of two below it with
/// which no sum of the build can pass u32::MAX, given `values`: every value a fragment will store,
/// with its leaf lattice point (radiance times coverage, coverage, photons' light and specular
/// parts), and `bounces` (headroom of that factor for a second bounce's fragments, which these
/// values bound only roughly: a voxel's bounce is its albedo times the cones' radiance).
///
/// The bound, in the build's terms (the mirror's module doc): a point's value after splat and border
/// transfer is the sum of the fragments at that point, each rounded to the fixed point, so at most
/// `peak scale + n / 2` for its n fragments above 0, `peak` bounding every per-point channel sum; a
/// parent point's share before its rounding is the [1 2 1]^3 weighted sum of child points (weights
/// 64 in all), so at most 64 times a child's value plus 1 for the level's rounding up; after
/// `(S + 32) >> 6` it is again at most a child's. So
/// 64 (bounces (peak scale + most / 2) + 1) <= u32::MAX suffices for one bounce, `most` the largest
/// n. For two, and where the scale would leave f32's normal range, the build's own overflow check
/// still reports an overflow.
///
/// `peak`: per lattice point and channel, n values above 0 (negatives, -0 and NaN count as 0, and a
/// 0 rounds to 0 exactly) whose largest is m, so that channel's sum there is at most n m and its
/// rounding adds at most n / 2; `peak` is the largest over points and channels of n m rounded up to
/// an f32 (`svo_fragments::point_bound`, +inf past f32::MAX), `most` the largest n. A bound, not the
/// sums themselves, because the GPU finds the same scale (kernels/svo_fragments.wgsl) and must
/// reproduce it bit for bit: it has no f64 and no float atomics and adds in any order, while counts,
/// maxima on the bits of non-negative floats and this one product are exact in integer arithmetic.
/// Rounded up, not to nearest: the nearest f32 can lie half an ULP below n m, up to 2 units of the
/// fixed point near the limit (peak scale about 2^26), more than the fit test's slack (its `+ 1` and
/// the sums being integers leave about 1). Per channel, not per point: a point's coverage is one
/// voxel's alpha (up to 1) where thousands of photons may each bring a little light, and the point's
/// largest value times its count would cut the scale by as many halvings where the light's own
/// bound leaves it. Where every point holds one value (voxel_light's fragments) the product is the
/// value itself and the scale the one of the exact sums.
pub fn fixed_scale(values: impl Iterator<Item = ([u32; 3], [f32; 4])>, bounces: u32) -> f32 {
    use vxgi_cpu_mirror::svo_fragments::{clamped_bits, point_bound};
    // Per lattice point and channel: the number of values above 0 and the largest one's bits.
    let mut points: std::collections::HashMap<[u32; 3], [(u32, u32); 4]> = Default::default();
    for (p, v) in values {
        let e = points.entry(p).or_default();
        for (c, x) in v.into_iter().enumerate() {
            let k = clamped_bits(x);
            if k != 0 {
                e[c] = (e[c].0 + 1, e[c].1.max(k));
            }
        }
    }
    let channels = points.values().flatten();
    let peak = channels
        .clone()
        .map(|&(n, m)| f32::from_bits(point_bound(n, m)) as f64)
        .fold(0.0f64, f64::max);
    let most = channels.map(|&(n, _)| n).max().unwrap_or(0) as f64;
    let b = bounces.max(1) as f64;
    let fits = |scale: f64| 64.0 * (b * (peak * scale + most / 2.0) + 1.0) <= u32::MAX as f64;
    let mut scale = SCALE as f64;
    while !fits(scale) && scale > f32::MIN_POSITIVE as f64 {
        scale *= 0.5;
    }
    scale as f32
}

/// The values a lit grid's fragments store ([`grid_fragments`]), with their lattice points.
pub fn grid_values(radiance: &[[f32; 4]]) -> impl Iterator<Item = ([u32; 3], [f32; 4])> + '_ {
    radiance
        .iter()
        .enumerate()
        .filter(|(_, v)| v.iter().any(|&c| c != 0.0))
        .map(|(m, v)| (vxgi_cpu_mirror::morton::decode(m as u32), *v))
}

/// Fragments of a lit voxel grid (Morton order, side `2^(depth + 1)`, voxels `(L * alpha, alpha)` as
/// voxel_light writes them): one per non-empty voxel, at the leaf lattice point of its index.
pub fn grid_fragments(radiance: &[[f32; 4]], scale: f32) -> Result<Vec<Fragment>, SvoError> {
    values_fragments(grid_values(radiance), scale)
}

/// The voxels' coverage where it is all an octree's geometry holds (photons carry the light):
/// `(0, 0, 0, 1)` at the lattice point of each voxel of `list` (Morton indices, ascending). The
/// values [`grid_values`] gives of [`coverage_only`] of voxelize's colour grid, in the same order:
/// voxelize lists exactly the voxels its samples land in and gives each alpha 1, so the dense grid
/// is not needed for them (its occupancy bits list the same voxels).
pub fn listed_coverage(list: &[u32]) -> impl Iterator<Item = ([u32; 3], [f32; 4])> + '_ {
    list.iter()
        .map(|&m| (vxgi_cpu_mirror::morton::decode(m), [0.0, 0.0, 0.0, 1.0]))
}

/// Fragments of voxel values at their lattice points (one each, in fixed point with `scale`).
pub fn values_fragments(
    values: impl Iterator<Item = ([u32; 3], [f32; 4])>,
    scale: f32,
) -> Result<Vec<Fragment>, SvoError> {
    values
        .map(|(pos, v)| {
            Ok(Fragment {
                pos,
                _pad: 0,
                value: [
                    to_fixed(v[0], scale)?,
                    to_fixed(v[1], scale)?,
                    to_fixed(v[2], scale)?,
                    to_fixed(v[3], scale)?,
                ],
            })
        })
        .collect()
}

/// A voxel grid's coverage without light, `(0, 0, 0, alpha)` per voxel: the geometry fragments when
/// the light comes from photons.
pub fn coverage_only(voxels: &[[f32; 4]]) -> Vec<[f32; 4]> {
    voxels.iter().map(|v| [0.0, 0.0, 0.0, v[3]]).collect()
}

/// What the octree's readers sample besides its radiance bricks: the anisotropic voxels' directional
/// values (`svo_anisotropic`), the Gaussian lobes' normal pool ([`normal_pool`]) and the glossy
/// voxels' specular pool ([`pool_in_layout`] of `svo_photons`' specular fragments); `None`: that
/// option is off.
#[derive(Clone, Copy, Debug, Default)]
pub struct SvoExtras<'a> {
    pub aniso: Option<&'a [[f32; 4]]>,
    pub normals: Option<&'a [u32]>,
    pub spec: Option<&'a [u32]>,
}

/// `frags`' points with value 0: structure only (a zero value splats nothing).
pub fn points_of(frags: &[Fragment]) -> Vec<Fragment> {
    frags
        .iter()
        .map(|f| Fragment {
            value: [0; 4],
            ..*f
        })
        .collect()
}

/// A second brick pool over `octree`'s points (built from `frags`): the octree build of `values`
/// plus every fragment of `frags` at its point with value 0 (so the structure is `frags`'), on the GPU
/// with `ctx`, by the mirror without, carried into `octree`'s node layout (`bricks_in_layout`; values
/// at points `frags` lacks have no node there and are dropped).
pub fn pool_in_layout(
    ctx: Option<&GpuContext>,
    octree: &Octree,
    frags: &[Fragment],
    values: &[Fragment],
) -> Result<Vec<u32>, SvoError> {
    let mut all = values.to_vec();
    all.extend(points_of(frags));
    let built = match ctx {
        Some(ctx) => {
            super::sparse_voxel_octree::build_on_gpu(ctx, octree.depth, &all, None)?.octree
        }
        None => build_fitted(octree.depth, &all),
    };
    Ok(bricks_in_layout(&octree.nodes, &built))
}

/// The lobes' normal pool of `octree` (built from `frags`): [`pool_in_layout`] of the fragments
/// over the voxel grid `radiance` (Morton order, alpha in w) whose mean normals are `normal` (xyz),
/// each voxel with alpha > 0 its [`normal_value`].
pub fn normal_pool(
    ctx: Option<&GpuContext>,
    octree: &Octree,
    frags: &[Fragment],
    radiance: &[[f32; 4]],
    normal: &[[f32; 4]],
    scale: f32,
) -> Result<Vec<u32>, SvoError> {
    let values: Vec<[f32; 4]> = std::iter::zip(radiance, normal)
        .map(|(r, n)| match r[3] > 0.0 {
            true => normal_value(glam::Vec3::from_slice(&n[..3]), r[3]),
            false => [0.0; 4],
        })
        .collect();
    pool_in_layout(ctx, octree, frags, &grid_fragments(&values, scale)?)
}

/// The lobes' pools of `octree` (built from `frags`): the normal pool, and the specular pool where
/// there are specular photons (`spec`) — on the GPU with `ctx`, by the mirror without.
pub fn lobe_pools(
    ctx: Option<&GpuContext>,
    octree: &Octree,
    frags: &[Fragment],
    [radiance, normal]: [&[[f32; 4]]; 2],
    spec: &[Fragment],
    scale: f32,
) -> Result<(Vec<u32>, Option<Vec<u32>>), SvoError> {
    let normals = normal_pool(ctx, octree, frags, radiance, normal, scale)?;
    let spec = if spec.is_empty() {
        None
    } else {
        Some(pool_in_layout(ctx, octree, frags, spec)?)
    };
    Ok((normals, spec))
}

/// Cone parameters for an octree of `depth` over the voxel grid `frame` (side `2^(depth + 1)`): mip
/// levels 0..=depth.
pub fn svo_cone_params(frame: &VoxelFrame, settings: &ConeSettings) -> ConeParams {
    let mut p = cone_params(frame, settings);
    p.levels = frame.side.trailing_zeros(); // depth + 1
    p
}

/// The cone pass over a scene whose G-buffer and octree are given (values in fixed point with `scale`);
/// `extras`: what the options read besides the octree.
#[allow(clippy::too_many_arguments)]
pub fn case_for(
    data: &SceneData,
    gbuffer: &Resources,
    octree: &Octree,
    extras: SvoExtras,
    scale: f32,
    params: &ConeParams,
    label: String,
    seed: u64,
) -> Case {
    let aniso = extras.aniso.map_or(0, |a| a.len());
    let decl = decl_for(octree.bricks.len(), aniso);
    case_in(
        decl, data, gbuffer, octree, extras, scale, params, label, seed,
    )
}

/// [`case_for`] with the declaration given, its pools bound in windows of [`WHOLE`]
/// ([`super::svo_anisotropic::bind_pools`]: [`DECL`]'s values in two, [`WINDOWED_DECL`]'s pools in up to six).
#[allow(clippy::too_many_arguments)]
pub fn case_in(
    decl: &'static KernelDecl,
    data: &SceneData,
    gbuffer: &Resources,
    octree: &Octree,
    extras: SvoExtras,
    scale: f32,
    params: &ConeParams,
    label: String,
    seed: u64,
) -> Case {
    let volume = octree_resources(octree, extras, scale);
    let mut case = tracer_case(decl, data, gbuffer, params, volume, label, seed);
    let windowed = std::ptr::eq(decl, &WINDOWED_DECL);
    super::svo_anisotropic::bind_pools(&mut case.passes, &mut case.resources, windowed, WHOLE)
        .expect("the octree's limits keep its pools in its bindings");
    case
}

/// The bricks' and the directional values' windows where a pool is past one binding.
pub const WHOLE: [u64; 2] = [
    super::sparse_voxel_octree::BRICK_WINDOW,
    super::svo_anisotropic::POOL_WINDOW,
];

/// The octree's bindings (nodes, bricks, svo, aniso, normal_bricks) for the cone kernels.
pub fn octree_resources<'a>(octree: &Octree, extras: SvoExtras<'a>, scale: f32) -> Resources {
    let svo = SvoParams {
        depth: octree.depth,
        inv_scale: 1.0 / scale,
        anisotropic: extras.aniso.is_some() as u32,
        lobes: extras.normals.is_some() as u32 | (extras.spec.is_some() as u32) << 1,
    };
    // Unused when an option is off, but bound: one empty element.
    let aniso = match extras.aniso {
        Some(a) if !a.is_empty() => a,
        _ => &[[0.0f32; 4]][..],
    };
    let pool = |p: Option<&'a [u32]>| match p {
        Some(n) if !n.is_empty() => n,
        _ => &[0u32][..],
    };
    let (normals, spec) = (pool(extras.normals), pool(extras.spec));
    let mut r = super::sparse_voxel_octree::reader_resources(octree);
    r.extend(buffers([
        ("svo", HostBuffer::pod(&svo)),
        ("normal_bricks", HostBuffer::of(normals)),
        ("spec_bricks", HostBuffer::of(spec)),
        ("aniso", HostBuffer::of(aniso)),
    ]));
    r
}

/// Largest radiance the octree holds (allowances for rounding-decided stops scale with it).
pub fn max_radiance(bricks: &[u32], inv_scale: f32) -> f32 {
    bricks
        .chunks_exact(4)
        .map(|v| v[0].max(v[1]).max(v[2]))
        .max()
        .unwrap_or(0) as f32
        * inv_scale
}

/// The directional values a cone case binds.
fn pool_of(data: &Resources) -> Vec<[f32; 4]> {
    bytemuck::cast_slice(&data["aniso"].buffer().expect("the pool").bytes).to_vec()
}

pub fn mirror_cones(data: &Resources) -> Vec<vxgi_cpu_mirror::cone_trace::PixelOut> {
    let b = |n: &str| data[n].buffer().expect("buffer");
    let params: ConeParams = *bytemuck::from_bytes(&b("cone").bytes);
    let svo: SvoParams = *bytemuck::from_bytes(&b("svo").bytes);
    let bricks = b("bricks").as_u32();
    let aniso = pool_of(data);
    let volume = SvoVolume {
        p: &params,
        svo: &svo,
        nodes: bytemuck::cast_slice(&b("nodes").bytes),
        bricks,
        aniso: &aniso,
        normals: b("normal_bricks").as_u32(),
        spec: b("spec_bricks").as_u32(),
    };
    shade_all(data, &volume, max_radiance(bricks, svo.inv_scale))
}

/// A generated lit scene (cone_trace's `lit_case`) and the mirror's octree of its voxels (the builder
/// is verified on its own), with its options by `index % 4`: 0 none, 1 anisotropic voxels, 2 Gaussian
/// lobes and glossy voxels, 3 all (the directional values and the pools the mirror's; the specular
/// photons made up: light from one direction reflected about each voxel's normal, lobe length 0.9,
/// weight half the voxel's luminance).
pub struct GeneratedOctree {
    pub lit: super::cone_trace::LitCase,
    pub octree: Octree,
    pub params: ConeParams,
    pub aniso: Option<Vec<[f32; 4]>>,
    pub normals: Option<Vec<u32>>,
    pub spec: Option<Vec<u32>>,
}

impl GeneratedOctree {
    pub fn new(ctx: &GpuContext, seed: u64, index: usize) -> GeneratedOctree {
        let c = lit_case(ctx, seed, index);
        let depth = vxgi_cpu_mirror::sparse_voxel_octree::depth_for(c.frame.side);
        let frags =
            grid_fragments(&c.radiance, SCALE).expect("generated radiance fits the fixed point");
        let octree = build_fitted(depth, &frags);
        let params = svo_cone_params(&c.frame, &c.settings);
        let aniso = (index % 2 == 1)
            .then(|| crate::kernels::svo_anisotropic::build_mirror(&octree, 1.0 / SCALE));
        let normals = (index % 4 >= 2).then(|| {
            normal_pool(None, &octree, &frags, &c.radiance, &c.normal, SCALE)
                .expect("generated normals fit the fixed point")
        });
        let spec = (index % 4 >= 2).then(|| {
            let l = glam::Vec3::new(0.3, 1.0, 0.2).normalize();
            let (mut pos, mut q) = (Vec::new(), Vec::new());
            for (m, (r, n)) in c.radiance.iter().zip(&c.normal).enumerate() {
                let n = glam::Vec3::from_slice(&n[..3]);
                if r[3] <= 0.0 || n.length() < 0.1 {
                    continue;
                }
                let n = n.normalize();
                let w =
                    0.5 * vxgi_cpu_mirror::svo_photons::luminance(glam::Vec3::from_slice(&r[..3]));
                let d = (n * (2.0 * n.dot(l)) - l) * (0.9 * w);
                let p = vxgi_cpu_mirror::morton::decode(m as u32);
                pos.push([p[0], p[1], p[2], 1]);
                q.push([d.x, d.y, d.z, w]);
            }
            let sf = super::svo_photons::spec_fragments(&pos, &q, SCALE)
                .expect("generated specular fits the fixed point");
            pool_in_layout(None, &octree, &frags, &sf).expect("fits")
        });
        GeneratedOctree {
            lit: c,
            octree,
            params,
            aniso,
            normals,
            spec,
        }
    }

    pub fn extras(&self) -> SvoExtras<'_> {
        SvoExtras {
            aniso: self.aniso.as_deref(),
            normals: self.normals.as_deref(),
            spec: self.spec.as_deref(),
        }
    }

    /// ", anisotropic", ", lobes", ", glossy voxels": the options on, for a case's label.
    pub fn options(&self) -> String {
        let on = [
            (self.aniso.is_some(), ", anisotropic"),
            (self.normals.is_some(), ", lobes"),
            (self.spec.is_some(), ", glossy voxels"),
        ];
        on.iter().filter(|o| o.0).map(|o| o.1).collect()
    }
}

pub struct SvoConeTrace;

impl Kernel for SvoConeTrace {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let mut case = generated_case(&DECL, ctx, seed, index);
        // One case in eight (with anisotropic voxels) reads the values from two bindings, as
        // values past one binding are read.
        let values = case.resources["aniso"].buffer().expect("aniso").bytes.len() as u64 / 16;
        if index % 8 == 5 && values > 16 {
            let half = values.div_ceil(2).div_ceil(16) * 16;
            super::svo_anisotropic::bind_pools(
                &mut case.passes,
                &mut case.resources,
                false,
                [WHOLE[0], half],
            )
            .expect("two windows hold them");
            case.label.push_str(", values in two bindings");
        }
        case
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        bounded_outputs(&mirror_cones(data))
    }
}

/// The cone pass of `decl` over case `index`'s generated octree ([`GeneratedOctree`]).
fn generated_case(decl: &'static KernelDecl, ctx: &GpuContext, seed: u64, index: usize) -> Case {
    let g = GeneratedOctree::new(ctx, seed, index);
    let label = format!(
        "{}, octree depth {}{}",
        g.lit.label,
        g.octree.depth,
        g.options()
    );
    let (data, gb) = (&g.lit.data, &g.lit.gbuffer);
    case_in(
        decl,
        data,
        gb,
        &g.octree,
        g.extras(),
        SCALE,
        &g.params,
        label,
        seed,
    )
}

/// svo_cone_trace_windowed on svo_cone_trace's generated cases, every pool in three bindings.
pub struct SvoConeTraceWindowed;

impl Kernel for SvoConeTraceWindowed {
    fn decl(&self) -> &'static KernelDecl {
        &WINDOWED_DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        super::svo_anisotropic::with_pools_split(generated_case(&WINDOWED_DECL, ctx, seed, index))
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        bounded_outputs(&mirror_cones(data))
    }
}

pub static BOUNCE_DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "svo_bounce" in "svo_cone_trace",
    includes: &[super::SVO_NODE, super::SVO_BRICKS, super::SVO_ANISO_WINDOWS, super::TANGENT_BASIS, super::SCENE_TYPES, super::CONE_MARCH],
    entry: "voxel_main",
    inputs: &[
        "cone", "cone_dirs", "nodes", "bricks", "svo", "aniso", "normal_bricks", "spec_bricks", "vx_position", "vx_normal", "vx_albedo",
    ],
    // The pixel entry's diffuse cones and their bound (see DECL).
    outputs: &[Output {
        binding: "vx_indirect",
        tolerance: Tolerance::MirrorBound,
    }],
    dispatch: DispatchRule::PerElement {
        binding: "vx_indirect",
    },
    mirror: "vxgi_cpu_mirror::cone_trace::shade_voxel (volume: vxgi_cpu_mirror::svo_cone_trace::SvoVolume)",
    summary: "second bounce of vct-svo: diffuse cones from every non-empty voxel's centre along its mean normal through the octree, times its albedo",
);

/// The non-empty voxels of a grid as the bounce pass reads them.
pub struct BounceVoxels {
    /// Morton index of each voxel.
    pub index: Vec<u32>,
    pub position: Vec<[f32; 4]>,
    pub normal: Vec<[f32; 4]>,
    pub albedo: Vec<[f32; 4]>,
}

/// The voxels with alpha > 0 of `radiance` (Morton order, `(L * alpha, alpha)`), with their centres in
/// `frame`, unit mean normals and albedo (`colour`, voxelize's). A mean normal shorter than 1/2 (the
/// voxel's samples face opposite ways, e.g. both sides of a thin wall) gives none (w = 0): such a voxel
/// reflects no second bounce.
pub fn bounce_voxels(
    radiance: &[[f32; 4]],
    normal: &[[f32; 4]],
    colour: &[[f32; 4]],
    frame: &VoxelFrame,
) -> BounceVoxels {
    let mut out = BounceVoxels {
        index: vec![],
        position: vec![],
        normal: vec![],
        albedo: vec![],
    };
    for (m, v) in radiance.iter().enumerate() {
        if v[3] <= 0.0 {
            continue;
        }
        let c = vxgi_cpu_mirror::morton::decode(m as u32);
        let p = frame.origin
            + (glam::Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) + 0.5) * frame.voxel;
        let n = glam::Vec3::from_slice(&normal[m][..3]);
        let len = n.length();
        let n = if len >= 0.5 {
            let u = n / len;
            [u.x, u.y, u.z, 1.0]
        } else {
            [0.0; 4]
        };
        out.index.push(m as u32);
        out.position.push([p.x, p.y, p.z, 1.0]);
        out.normal.push(n);
        out.albedo.push(colour[m]);
    }
    out
}

/// The bounce pass over `voxels` through the octree (and what its options read).
#[allow(clippy::too_many_arguments)]
pub fn bounce_case(
    shader: &Shader,
    octree: &Octree,
    extras: SvoExtras,
    scale: f32,
    params: &ConeParams,
    voxels: &BounceVoxels,
    ctx: &GpuContext,
    label: String,
    seed: u64,
) -> Case {
    let n = voxels.index.len().max(1);
    let mut resources = octree_resources(octree, extras, scale);
    let f4 = |v: &[[f32; 4]]| HostBuffer::of(if v.is_empty() { &[[0.0f32; 4]] } else { v });
    resources.extend(buffers([
        ("cone", HostBuffer::pod(params)),
        (
            "cone_dirs",
            f4(&vxgi_cpu_mirror::cone_trace::cone_dirs(params)),
        ),
        ("vx_position", f4(&voxels.position)),
        ("vx_normal", f4(&voxels.normal)),
        ("vx_albedo", f4(&voxels.albedo)),
        ("vx_indirect", HostBuffer::zeroed(n * 16, ScalarKind::F32)),
    ]));
    let mut case = Case {
        label,
        seed,
        passes: vec![BOUNCE_DECL.pass(
            shader,
            ctx,
            "bounce".into(),
            BOUNCE_DECL.bind_by_name(),
            n as u64,
        )],
        resources,
        checks: vec![Check::of(
            "vx_indirect",
            Indexing::Grid {
                dims: [n as u32, 1, 1],
                components: 4,
            },
        )],
        effective_bytes: n as u64 * 64,
    };
    super::svo_anisotropic::bind_pools(&mut case.passes, &mut case.resources, true, WHOLE)
        .expect("the octree's limits keep its pools in their bindings");
    case
}

/// The second bounce's fragments: each voxel's reflected indirect light (from the bounce pass's
/// `indirect`, times its alpha) at its leaf lattice point, in fixed point with `scale`.
pub fn bounce_fragments(
    voxels: &BounceVoxels,
    indirect: &[[f32; 4]],
    radiance: &[[f32; 4]],
    scale: f32,
) -> Result<Vec<Fragment>, SvoError> {
    let mut out = Vec::new();
    for (&m, v) in voxels.index.iter().zip(indirect) {
        let a = radiance[m as usize][3];
        let value = [
            to_fixed(v[0] * a, scale)?,
            to_fixed(v[1] * a, scale)?,
            to_fixed(v[2] * a, scale)?,
            0,
        ];
        if value != [0; 4] {
            out.push(Fragment {
                pos: vxgi_cpu_mirror::morton::decode(m),
                _pad: 0,
                value,
            });
        }
    }
    Ok(out)
}

/// [`bounce_case`] on the GPU: each voxel's reflected indirect light.
pub fn bounce_on_gpu(
    ctx: &GpuContext,
    octree: &Octree,
    extras: SvoExtras,
    scale: f32,
    params: &ConeParams,
    voxels: &BounceVoxels,
) -> anyhow::Result<Vec<[f32; 4]>> {
    if voxels.index.is_empty() {
        return Ok(vec![]);
    }
    let shader = BOUNCE_DECL.shader()?;
    let case = bounce_case(
        &shader,
        octree,
        extras,
        scale,
        params,
        voxels,
        ctx,
        "bounce".into(),
        0,
    );
    let out = case.run(ctx, &shader, BOUNCE_DECL.name, &["vx_indirect"])?;
    Ok(bytemuck::cast_slice(&out.buffer("vx_indirect").bytes).to_vec())
}

/// The bounce pass by the mirror over the voxels' (position, normal, albedo): each voxel's value and
/// bound. `aniso` and `normals` are read where `svo` turns them on.
pub fn bounce_mirror(
    octree_nodes: &[vxgi_cpu_mirror::sparse_voxel_octree::Node],
    bricks: &[u32],
    aniso: &[[f32; 4]],
    [normals, spec]: [&[u32]; 2],
    svo: &SvoParams,
    params: &ConeParams,
    [position, normal, albedo]: [&[[f32; 4]]; 3],
) -> Vec<([f32; 4], [f32; 4])> {
    use rayon::prelude::*;
    let volume = SvoVolume {
        p: params,
        svo,
        nodes: octree_nodes,
        bricks,
        aniso,
        normals,
        spec,
    };
    // A voxel takes interleaving class 0's cones (the kernel's cone_dirs[k * N * N]).
    let dirs = vxgi_cpu_mirror::cone_trace::class_cones(
        &vxgi_cpu_mirror::cone_trace::cone_dirs(params),
        params,
        0,
        0,
    );
    let lmax = max_radiance(bricks, svo.inv_scale);
    (0..position.len())
        .into_par_iter()
        .map(|i| {
            vxgi_cpu_mirror::cone_trace::shade_voxel(
                &volume,
                &dirs,
                position[i],
                normal[i],
                albedo[i],
                lmax,
            )
        })
        .collect()
}

pub struct SvoBounce;

impl Kernel for SvoBounce {
    fn decl(&self) -> &'static KernelDecl {
        &BOUNCE_DECL
    }

    /// svo_cone_trace's generated scenes ([`GeneratedOctree`]: the octree of their lit voxels and
    /// its options), the bounce from every non-empty voxel.
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let g = GeneratedOctree::new(ctx, seed, index);
        let c = &g.lit;
        let voxels = bounce_voxels(&c.radiance, &c.normal, &c.albedo, &c.frame);
        let label = format!(
            "{}, octree depth {}, {} voxels{}",
            c.label,
            g.octree.depth,
            voxels.index.len(),
            g.options()
        );
        bounce_case(
            shader,
            &g.octree,
            g.extras(),
            SCALE,
            &g.params,
            &voxels,
            ctx,
            label,
            seed,
        )
    }

    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let b = |n: &str| data[n].buffer().expect("buffer");
        let params: ConeParams = *bytemuck::from_bytes(&b("cone").bytes);
        let svo: SvoParams = *bytemuck::from_bytes(&b("svo").bytes);
        let f4 = |n: &str| -> &[[f32; 4]] { bytemuck::cast_slice(&b(n).bytes) };
        let out = bounce_mirror(
            bytemuck::cast_slice(&b("nodes").bytes),
            b("bricks").as_u32(),
            &pool_of(data),
            [b("normal_bricks").as_u32(), b("spec_bricks").as_u32()],
            &svo,
            &params,
            [f4("vx_position"), f4("vx_normal"), f4("vx_albedo")],
        );
        let v: Vec<[f32; 4]> = out.iter().map(|o| o.0).collect();
        let bd: Vec<[f32; 4]> = out.iter().map(|o| o.1).collect();
        BTreeMap::from(bounded("vx_indirect", &v, &bd))
    }
}
