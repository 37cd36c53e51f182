//! Kernel declarations: each pairs a WGSL file in `kernels/` with its mirror module in `cpu_mirror/`.
//! To add a kernel: `kernels/<name>.wgsl`, `cpu_mirror/src/<name>.rs`, `src/kernels/<name>.rs` with a
//! `DECL` and a `Kernel` impl, one line in [`all`], and tests in `tests/<name>.rs`.
pub mod gaussian_depth_visibility;
pub mod layer_decay;
pub mod surface_coverage_mip;

use vxgi_harness::Kernel;

/// Every declared kernel, in the order `vxgi verify` runs them.
pub fn all() -> Vec<&'static dyn Kernel> {
    vec![
        &surface_coverage_mip::SurfaceCoverageMip,
        &gaussian_depth_visibility::GaussianDepthVisibility,
        &layer_decay::LayerDecay,
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
