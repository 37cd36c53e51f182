//! vxgi-cpu-mirror: scalar Rust mirrors of the vxgi WGSL kernels.
//!
//! One module per kernel, named like its WGSL file (`kernels/<name>.wgsl` <-> `<name>`). Each mirror does
//! the kernel's arithmetic in the kernel's operation order, so that GPU and mirror agree exactly where
//! WGSL's accuracy rules make the operations exact, and within a stated ULP bound elsewhere. A mirror
//! takes `flush: bool`: when set it flushes subnormals to zero on every input, intermediate and output —
//! the other behaviour WGSL allows a GPU — so the comparison can accept exactly that and nothing looser.
//!
//! No wgpu, no naga: a mirror can be used (and read) without a GPU.
pub mod bvh_trace;
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
pub mod morton;
pub mod occlusion_voxels;
pub mod octahedral;
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

/// `x` with a subnormal replaced by zero of the same sign when `flush` is set.
#[inline]
pub fn ftz(x: f32, flush: bool) -> f32 {
    if flush && x.is_subnormal() {
        0.0f32.copysign(x)
    } else {
        x
    }
}

/// Component-wise [`ftz`].
#[inline]
pub fn ftz4(v: glam::Vec4, flush: bool) -> glam::Vec4 {
    if flush {
        glam::Vec4::new(
            ftz(v.x, true),
            ftz(v.y, true),
            ftz(v.z, true),
            ftz(v.w, true),
        )
    } else {
        v
    }
}
