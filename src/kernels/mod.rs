//! Kernel declarations: each pairs a WGSL file in `kernels/` with its mirror module in `cpu_mirror/`.
//! To add a kernel: `kernels/<name>.wgsl`, `cpu_mirror/src/<name>.rs`, `src/kernels/<name>.rs` with
//! a `DECL` (`vxgi_harness::kernel_decl!`) and a `Kernel` impl, and one line in [`all`], which gives
//! it the generic tests (tests/every_kernel.rs); its own properties go to `tests/<name>.rs`.
/// The input bindings of a per-pixel cone tracer (a kernel on common/cone_march.wgsl): the march's
/// own (scene, G-buffer, cone set, tile list), then those of the volume it samples.
macro_rules! march_inputs {
    ($($volume:literal),* $(,)?) => {
        &[
            "frame", "triangles", "materials", "gb_position", "gb_normal", "gb_triangle", "gb_albedo",
            "cone", "cone_dirs", "tile_list", $($volume),*
        ]
    };
}
pub(crate) use march_inputs;

/// The outputs of a per-pixel cone tracer, then any of its own: indirect light, AO and irradiance
/// per pixel, each within the mirror's per-element bound (`vxgi_cpu_mirror::cone_trace::MAG`: 4e-4
/// of the accumulated magnitudes, ~30 operations per sample, <= ~64 samples, pow/log2 per WGSL's
/// exp2/log2 rules, plus the whole remainder where a stop is within rounding of its threshold);
/// each declaration says what its volume's sampling adds to it.
macro_rules! march_outputs {
    ($($extra:expr),* $(,)?) => {
        &[
            vxgi_harness::Output { binding: "indirect", tolerance: vxgi_harness::Tolerance::MirrorBound },
            vxgi_harness::Output { binding: "ao", tolerance: vxgi_harness::Tolerance::MirrorBound },
            vxgi_harness::Output { binding: "irradiance", tolerance: vxgi_harness::Tolerance::MirrorBound },
            $($extra),*
        ]
    };
}
pub(crate) use march_outputs;

pub mod cache_creation;
pub mod cache_placement;
pub mod cache_preconvolve;
pub mod cache_records;
pub mod cache_reuse;
pub mod cluster_extract;
pub mod cluster_keys;
pub mod cone_trace;
pub mod cprc_pixels;
pub mod direct_light;
pub mod gather_caches;
pub mod gaussian_depth_visibility;
pub mod gbuffer;
pub mod histogram_axes;
pub mod layer_decay;
pub mod lit_cells;
pub mod lrsm_cone_trace;
pub mod lrsm_partition;
pub mod lrsm_prefilter;
pub mod occlusion_voxels;
pub mod radix_sort;
pub mod reflective_shadow_map;
pub mod sample_lrsm;
pub mod screen_tiles;
pub mod sparse_voxel_octree;
pub mod surface_coverage_mip;
pub mod svo_anisotropic;
pub mod svo_cone_trace;
pub mod svo_fragments;
pub mod svo_photons;
pub mod svo_sample;
pub mod tile_normal_histogram;
pub mod triangle_setup;
pub mod voxel_light;
pub mod voxelize;

use vxgi_harness::Kernel;

/// The voxel grids' Morton order (spread3, compact3, morton3, morton_decode), included by voxelize,
/// voxel_light, svo_fragments, lrsm_cone_trace and before PYRAMID_GRID.
pub const MORTON: (&str, &str) = (
    "kernels/common/morton.wgsl",
    include_str!("../../kernels/common/morton.wgsl"),
);

/// voxelize's lattice triangle (`VoxTriangle`), included by triangle_setup (which writes it) and
/// voxelize (which samples it).
pub const VOX_TRIANGLE: (&str, &str) = (
    "kernels/common/vox_triangle.wgsl",
    include_str!("../../kernels/common/vox_triangle.wgsl"),
);

/// Shared LRSM arithmetic (erfc, Gaussian depth visibility, layer decay), included by the LRSM kernels.
pub const LRSM_MATH: (&str, &str) = (
    "kernels/common/lrsm_math.wgsl",
    include_str!("../../kernels/common/lrsm_math.wgsl"),
);

/// How an LRSM texel is stored (binary16 pairs), included by lrsm_partition, lrsm_prefilter and
/// before LRSM_SAMPLE.
pub const LRSM_TEXEL: (&str, &str) = (
    "kernels/common/lrsm_texel.wgsl",
    include_str!("../../kernels/common/lrsm_texel.wgsl"),
);

/// Algorithm 1 (Sample LRSM) for one cone sample, included by sample_lrsm and lrsm_cone_trace.
pub const LRSM_SAMPLE: (&str, &str) = (
    "kernels/common/lrsm_sample.wgsl",
    include_str!("../../kernels/common/lrsm_sample.wgsl"),
);

/// What reaches a point from one light (point, spot, directional), included by direct_light and
/// voxel_light.
pub const LIGHTS: (&str, &str) = (
    "kernels/common/lights.wgsl",
    include_str!("../../kernels/common/lights.wgsl"),
);

/// The contract's BRDF, included by direct_light and lrsm_cone_trace (shadow cones).
pub const BRDF: (&str, &str) = (
    "kernels/common/brdf.wgsl",
    include_str!("../../kernels/common/brdf.wgsl"),
);

/// The scene's triangle and material records, included with BVH_TRACE and CONE_MARCH and by
/// svo_photons.
pub const SCENE_TYPES: (&str, &str) = (
    "kernels/common/scene_types.wgsl",
    include_str!("../../kernels/common/scene_types.wgsl"),
);

/// The cone tracer (bindings, march, pixel entry), included (after TANGENT_BASIS) by cone_trace,
/// svo_cone_trace, lrsm_cone_trace and cache_creation, which each define the volume it samples.
pub const CONE_MARCH: (&str, &str) = (
    "kernels/common/cone_march.wgsl",
    include_str!("../../kernels/common/cone_march.wgsl"),
);

/// The tangent frame around a normal (cones, radiance caches), included with CONE_MARCH and by
/// gather_caches.
pub const TANGENT_BASIS: (&str, &str) = (
    "kernels/common/tangent_basis.wgsl",
    include_str!("../../kernels/common/tangent_basis.wgsl"),
);

/// Trilinear sampling of a pyramid level in the `pyramid` binding, included after MORTON and before
/// PYRAMID or PLACED_PYRAMIDS.
pub const PYRAMID_GRID: (&str, &str) = (
    "kernels/common/pyramid_grid.wgsl",
    include_str!("../../kernels/common/pyramid_grid.wgsl"),
);

/// Several pyramids placed by rigid transforms as cone_march's volume (per-instance hierarchies),
/// included by cache_creation's instanced declaration.
pub const PLACED_PYRAMIDS: (&str, &str) = (
    "kernels/common/placed_pyramids.wgsl",
    include_str!("../../kernels/common/placed_pyramids.wgsl"),
);

/// The dense radiance pyramid (and its normal pyramid, for the depth-ordered blend) as cone_march's
/// volume, included by cone_trace and cache_creation.
pub const PYRAMID: (&str, &str) = (
    "kernels/common/pyramid.wgsl",
    include_str!("../../kernels/common/pyramid.wgsl"),
);

/// The three-pass exclusive prefix sum of u32, included by cluster_extract and radix_sort.
pub const BLOCK_SCAN: (&str, &str) = (
    "kernels/common/block_scan.wgsl",
    include_str!("../../kernels/common/block_scan.wgsl"),
);

/// Elements per block of common/block_scan.wgsl (its `SCAN_BLOCK`).
pub const SCAN_BLOCK: usize = 1024;

/// The resource common/block_scan.wgsl needs for a scan of `len` elements: its `scan_partials`
/// scratch, one u32 per block (at least one).
pub fn scan_partials(len: usize) -> vxgi_harness::HostResource {
    vxgi_harness::HostResource::Buffer(vxgi_harness::HostBuffer::zeroed(
        len.div_ceil(SCAN_BLOCK).max(1) * 4,
        vxgi_harness::ScalarKind::U32,
    ))
}

/// The passes of common/block_scan.wgsl over `len` elements, with the including kernel's `bindings`
/// (which must bind `scan_partials`).
pub fn scan_passes(
    bindings: &[(String, vxgi_harness::View)],
    len: usize,
    max_groups: u32,
    label: &str,
) -> Vec<vxgi_harness::run::Pass> {
    use vxgi_harness::run::{grid_for, Pass};
    [
        (
            "scan_blocks",
            grid_for(len.div_ceil(SCAN_BLOCK) as u64, 64, max_groups),
        ),
        ("scan_partials_serial", [1, 1, 1]),
        ("scan_add_partials", grid_for(len as u64, 64, max_groups)),
    ]
    .into_iter()
    .map(|(entry, groups)| {
        Pass::direct(format!("{label} {entry}"), entry, bindings.to_vec(), groups)
    })
    .collect()
}

/// The octree's brick pool as its readers bind it (in windows), included by svo_sample,
/// svo_anisotropic_windowed, svo_cone_trace_windowed and svo_bounce.
pub const SVO_BRICKS: (&str, &str) = (
    "kernels/common/svo_bricks.wgsl",
    include_str!("../../kernels/common/svo_bricks.wgsl"),
);

/// The octree's directional values in windows, included by svo_cone_trace_windowed and svo_bounce.
pub const SVO_ANISO_WINDOWS: (&str, &str) = (
    "kernels/common/svo_aniso_windows.wgsl",
    include_str!("../../kernels/common/svo_aniso_windows.wgsl"),
);

/// The octree's brick pool in one binding, included by svo_anisotropic and svo_cone_trace.
pub const SVO_BRICKS_ONE: (&str, &str) = (
    "kernels/common/svo_bricks_one.wgsl",
    include_str!("../../kernels/common/svo_bricks_one.wgsl"),
);

/// The octree's brick pool as its build writes it (atomics), in windows: included by
/// sparse_voxel_octree_windowed.
pub const SVO_BRICKS_ATOMIC: (&str, &str) = (
    "kernels/common/svo_bricks_atomic.wgsl",
    include_str!("../../kernels/common/svo_bricks_atomic.wgsl"),
);

/// The octree's brick pool as its build writes it, in one binding: included by sparse_voxel_octree.
pub const SVO_BRICKS_ATOMIC_ONE: (&str, &str) = (
    "kernels/common/svo_bricks_atomic_one.wgsl",
    include_str!("../../kernels/common/svo_bricks_atomic_one.wgsl"),
);

/// The octree's directional values read in one or two bindings, included by svo_cone_trace.
pub const SVO_ANISO_PAIR: (&str, &str) = (
    "kernels/common/svo_aniso_pair.wgsl",
    include_str!("../../kernels/common/svo_aniso_pair.wgsl"),
);

/// The octree's directional values written in windows, included by svo_anisotropic_windowed.
pub const SVO_ANISO_RW: (&str, &str) = (
    "kernels/common/svo_aniso_rw.wgsl",
    include_str!("../../kernels/common/svo_aniso_rw.wgsl"),
);

/// The octree's directional values written in one or two bindings, included by svo_anisotropic.
pub const SVO_ANISO_RW_PAIR: (&str, &str) = (
    "kernels/common/svo_aniso_rw_pair.wgsl",
    include_str!("../../kernels/common/svo_aniso_rw_pair.wgsl"),
);

/// Bind the buffer resource `resource` (elements of `elem` bytes) to the WGSL bindings `views` of
/// every pass that binds `views[0]`, `views[k]` its k-th window of `window` elements: a kernel finds
/// element i in window i / L, L the length of `views[0]` (every window but the last is full). Windows
/// past its end get one unused element of their own, named after the binding (writable bindings
/// must not alias). An error, naming the resource, when it takes more windows than `views`.
pub fn bind_windows(
    passes: &mut [vxgi_harness::run::Pass],
    resources: &mut vxgi_harness::Resources,
    resource: &str,
    views: &[&str],
    elem: u64,
    window: u64,
) -> Result<(), String> {
    use vxgi_harness::run::View;
    assert!(
        window > 0 && (window * elem).is_multiple_of(256),
        "windows of {window} elements of {elem} bytes: binding offsets are 256-byte aligned"
    );
    let b = resources[resource].buffer().expect("a buffer");
    let (len, scalar) = (b.bytes.len() as u64 / elem, b.scalar);
    let count = len.div_ceil(window).max(1);
    if count > views.len() as u64 {
        return Err(format!(
            "`{resource}` holds {len} elements, past {} bindings of {window}",
            views.len()
        ));
    }
    for &name in &views[count as usize..] {
        let unused = vxgi_harness::HostBuffer::zeroed(elem as usize, scalar);
        resources.insert(name.to_string(), unused.into());
    }
    for pass in passes {
        if !pass.bindings.iter().any(|(b, _)| b == views[0]) {
            continue;
        }
        pass.bindings.retain(|(b, _)| !views.contains(&b.as_str()));
        for (k, &name) in (0u64..).zip(views) {
            let view = match k < count {
                true if count == 1 => View::Buffer(resource.to_string()),
                true => View::BufferRange {
                    name: resource.to_string(),
                    offset: k * window * elem,
                    size: window.min(len - k * window) * elem,
                },
                false => View::Buffer(name.to_string()),
            };
            pass.bindings.push((name.to_string(), view));
        }
    }
    Ok(())
}

/// The sparse voxel octree's node layout and descent, included by sparse_voxel_octree and svo_sample.
pub const SVO_NODE: (&str, &str) = (
    "kernels/common/svo_node.wgsl",
    include_str!("../../kernels/common/svo_node.wgsl"),
);

/// `values`, or one default element where there are none (a storage binding cannot be empty).
pub fn or_one<T: Clone + Default>(values: &[T]) -> Vec<T> {
    if values.is_empty() {
        vec![T::default()]
    } else {
        values.to_vec()
    }
}

/// Every declared kernel, in the order `vxgi verify` runs them.
pub fn all() -> Vec<&'static dyn Kernel> {
    vec![
        &surface_coverage_mip::SurfaceCoverageMip,
        &gaussian_depth_visibility::GaussianDepthVisibility,
        &layer_decay::LayerDecay,
        &lrsm_partition::LrsmPartition,
        &lrsm_prefilter::LrsmPrefilter,
        &occlusion_voxels::OcclusionVoxels,
        &sample_lrsm::SampleLrsm,
        &lit_cells::LitCells,
        &reflective_shadow_map::ReflectiveShadowMap,
        &tile_normal_histogram::TileNormalHistogram,
        &histogram_axes::HistogramAxes,
        &radix_sort::RadixSort,
        &cluster_keys::ClusterKeys,
        &cluster_extract::ClusterExtract,
        &cache_placement::CachePlacement,
        &gather_caches::GatherCaches,
        &cache_creation::CacheCreation,
        &cache_creation::CacheCreationInstanced,
        &cache_preconvolve::CachePreconvolve,
        &cprc_pixels::CprcPixels,
        &cache_records::CacheRecords,
        &cache_reuse::CacheReuse,
        &gbuffer::Gbuffer,
        &direct_light::DirectLight,
        &triangle_setup::TriangleSetup,
        &voxelize::Voxelize,
        &voxel_light::VoxelLight,
        &screen_tiles::ScreenTiles,
        &cone_trace::ConeTrace,
        &cone_trace::ConeTraceInstanced,
        &svo_fragments::SvoFragments,
        &sparse_voxel_octree::SparseVoxelOctree,
        &sparse_voxel_octree::SparseVoxelOctreeWindowed,
        &svo_sample::SvoSample,
        &svo_photons::SvoPhotons,
        &svo_anisotropic::SvoAnisotropic,
        &svo_anisotropic::SvoAnisotropicWindowed,
        &svo_cone_trace::SvoConeTrace,
        &svo_cone_trace::SvoConeTraceWindowed,
        &svo_cone_trace::SvoBounce,
        &lrsm_cone_trace::LrsmConeTrace,
    ]
}

/// The kernel named `name`, or an error listing the known names.
pub fn find(name: &str) -> Result<&'static dyn Kernel, String> {
    all()
        .into_iter()
        .find(|k| k.decl().name == name)
        .ok_or_else(|| {
            let names: Vec<_> = all().iter().map(|k| k.decl().name).collect();
            format!(
                "no kernel named `{name}`; declared kernels: {}",
                names.join(", ")
            )
        })
}

use vxgi_harness::run::{Pass, View};
use vxgi_harness::{GpuContext, KernelDecl, Shader};

/// One buffer stream of a reduction chain: the WGSL bindings it is read and written through, and the
/// host resource holding level `k`.
pub struct ChainStream<'a> {
    pub src_binding: &'a str,
    pub dst_binding: &'a str,
    pub resource: &'a dyn Fn(u32) -> String,
}

/// The voxels of one window of a dense Morton grid of side `side` whose buffers take `bytes_per_voxel`
/// (the largest per binding) on a device binding `binding_limit` bytes: the whole grid where it fits
/// one binding, else the largest power of two that does (a power of two tiles the grid, and an
/// aligned power-of-two Morton range is a box of voxels).
pub fn grid_window_voxels(side: u32, binding_limit: u64, bytes_per_voxel: u64) -> u64 {
    let voxels = (side as u64).pow(3);
    voxels.min(1 << (binding_limit / bytes_per_voxel).max(1).ilog2())
}

/// Point the bindings of `per_voxel` (binding, bytes per voxel) at the voxels `first ..
/// first + count` of the resources they view now: the window of a grid a pass dispatched a window
/// at a time sees (voxelize, voxel_light).
pub fn bind_grid_window(
    bindings: &mut [(String, vxgi_harness::run::View)],
    first: u64,
    count: u64,
    per_voxel: &[(&str, u64)],
) {
    use vxgi_harness::run::View;
    for (binding, view) in bindings {
        let Some(&(_, per)) = per_voxel.iter().find(|(b, _)| b == binding) else {
            continue;
        };
        let name = match view {
            View::Buffer(n) | View::BufferRange { name: n, .. } => n.clone(),
            _ => panic!("`{binding}` is not a buffer binding"),
        };
        *view = View::BufferRange {
            name,
            offset: first * per,
            size: count * per,
        };
    }
}

/// A Morton-ordered mip chain as one case: level 0 of each stream given (`level0`, in `streams`'
/// order), levels `1..=parents.len()` zeroed, produced by [`reduction_chain_passes`] and each checked
/// against the declared output its stream writes, named by `indexing(k)`; `fixed` are resources every
/// pass binds by their own name (parameters). The mirror of level `k` reads the GPU's level `k - 1`.
#[allow(clippy::too_many_arguments)]
pub fn reduction_chain_case(
    decl: &KernelDecl,
    shader: &Shader,
    ctx: &GpuContext,
    streams: &[ChainStream],
    level0: Vec<vxgi_harness::HostBuffer>,
    parents: &[u64],
    (factor, elem_bytes): (u64, u64),
    indexing: &dyn Fn(u32) -> vxgi_harness::Indexing,
    fixed: Vec<(String, vxgi_harness::HostBuffer)>,
    label: String,
    seed: u64,
) -> vxgi_harness::Case {
    use vxgi_harness::{Check, HostBuffer, HostResource, Resources};
    let mut resources = Resources::new();
    let mut bound = Vec::new();
    for (name, b) in fixed {
        bound.push((name.clone(), View::Buffer(name.clone())));
        resources.insert(name, HostResource::Buffer(b));
    }
    let scalars: Vec<_> = level0.iter().map(|b| b.scalar).collect();
    for (s, b) in streams.iter().zip(level0) {
        resources.insert((s.resource)(0), HostResource::Buffer(b));
    }
    let outputs: Vec<&'static str> = streams
        .iter()
        .map(|s| {
            let o = decl.outputs.iter().find(|o| o.binding == s.dst_binding);
            o.unwrap_or_else(|| panic!("`{}` is not an output of {}", s.dst_binding, decl.name))
                .binding
        })
        .collect();
    let mut checks = Vec::new();
    for (k, &count) in (1u32..).zip(parents) {
        for ((s, &scalar), &output) in streams.iter().zip(&scalars).zip(&outputs) {
            let zero = HostBuffer::zeroed((count * elem_bytes) as usize, scalar);
            resources.insert((s.resource)(k), HostResource::Buffer(zero));
            checks.push(Check {
                resource: (s.resource)(k),
                output,
                indexing: indexing(k),
            });
        }
    }
    // Each parent reads its `factor` children and writes itself, in every stream.
    let effective = parents.iter().sum::<u64>() * (factor + 1) * streams.len() as u64 * elem_bytes;
    vxgi_harness::Case {
        label,
        seed,
        passes: reduction_chain_passes(
            decl, shader, ctx, parents, factor, elem_bytes, streams, &bound,
        ),
        resources,
        checks,
        effective_bytes: effective,
    }
}

/// The levels `1..=n` a [`reduction_chain_case`] of `streams` streams checks.
pub fn chain_levels(case: &vxgi_harness::Case, streams: usize) -> std::ops::RangeInclusive<u32> {
    1..=(case.checks.len() / streams) as u32
}

/// Passes for levels `1..=parents.len()` of a Morton-ordered mip chain: element `p` of level `k`
/// reduces elements `factor * p .. factor * (p + 1)` of level `k - 1` (8 children in 3D, 4 in 2D), so
/// any run of parents reads one contiguous window. A level whose source is larger than one storage
/// binding may be (`max_storage_buffer_binding_size`) is split into windows bound as buffer ranges.
/// `parents[k - 1]` is the element count of level `k`; `elem_bytes` the size of one element per stream;
/// `fixed` are bindings every pass shares (parameters).
#[allow(clippy::too_many_arguments)]
pub fn reduction_chain_passes(
    decl: &KernelDecl,
    shader: &Shader,
    ctx: &GpuContext,
    parents: &[u64],
    factor: u64,
    elem_bytes: u64,
    streams: &[ChainStream],
    fixed: &[(String, View)],
) -> Vec<Pass> {
    let max_binding = ctx.limits().max_storage_buffer_binding_size;
    // Parents per window: all of them, or the largest power of two whose children fit one binding
    // (a power of two keeps window offsets aligned to the 256-byte binding offset rule).
    let fit = (max_binding / (factor * elem_bytes)).max(1);
    let mut passes = Vec::new();
    for (k, &count_k) in (1u32..).zip(parents) {
        let window = if count_k <= fit {
            count_k
        } else {
            1u64 << (63 - fit.leading_zeros())
        };
        for w in 0..count_k.div_ceil(window) {
            let (p0, count) = (w * window, window.min(count_k - w * window));
            let range = |name: String, first: u64, len: u64| View::BufferRange {
                name,
                offset: first * elem_bytes,
                size: len * elem_bytes,
            };
            let mut bindings = fixed.to_vec();
            for s in streams {
                bindings.push((
                    s.src_binding.to_string(),
                    range((s.resource)(k - 1), factor * p0, factor * count),
                ));
                bindings.push((s.dst_binding.to_string(), range((s.resource)(k), p0, count)));
            }
            passes.push(decl.pass(
                shader,
                ctx,
                format!("level {k} window {w}"),
                bindings,
                count,
            ));
        }
    }
    passes
}
