//! The integration tests, one binary (each test binary links wgpu and naga: one link instead of one per
//! file). A module per area: a kernel's GPU-vs-mirror properties in `tests/<kernel>.rs`, the
//! pipelines' frames, snapshots, the CLI and the harness in their own files; `tests/common` holds
//! the shared steps. `cargo test --test integration <module>::` runs one file's tests.
mod common;

mod bisect;
mod cache_creation;
mod cache_placement;
mod cache_preconvolve;
mod cache_records;
mod cache_reuse;
mod cli;
mod cluster_extract;
mod cluster_keys;
mod cone_trace;
mod coverage_error;
mod cprc;
mod cprc_pixels;
mod direct_light;
mod every_kernel;
mod export;
mod gather_caches;
mod gaussian_depth_visibility;
mod gbuffer;
mod harness;
mod histogram_axes;
mod layer_decay;
mod lrsm_cone_trace;
mod lrsm_partition;
mod lrsm_pipeline;
mod lrsm_prefilter;
mod occlusion_voxels;
mod pipeline;
mod radix_sort;
mod reflective_shadow_map;
mod render;
mod sample_lrsm;
mod scene;
mod screen_tiles;
mod snapshots;
mod sparse_voxel_octree;
mod surface_coverage_mip;
mod svo_anisotropic;
mod svo_cone_trace;
mod svo_fragments;
mod svo_photons;
mod svo_sample;
mod tile_normal_histogram;
mod triangle_setup;
#[cfg(feature = "view")]
mod view;
mod voxel_light;
mod voxelize;
