//! vxgi: WGSL compute kernels for voxel-based global illumination, each verified against a scalar Rust
//! mirror on generated inputs. See ARCHITECTURE.md for the layout and README.md for how to add a kernel.
pub mod bench;
pub mod bisect;
pub mod coverage;
pub mod cprc;
pub mod frames;
pub mod gbuffers;
pub mod grids;
pub mod images;
pub mod kernels;
pub mod limits;
pub mod lrsm;
pub mod lrsm_factors;
mod obj_input;
pub mod pipeline;
pub mod plan;
pub mod quality;
pub mod reference;
pub mod render;
pub mod report;
pub mod resident;
pub mod scene;
pub mod temporal;
pub mod trace;
#[cfg(feature = "view")]
pub mod view;

pub use vxgi_cpu_mirror as cpu_mirror;
pub use vxgi_harness as harness;
