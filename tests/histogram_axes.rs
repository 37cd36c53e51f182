//! `kernels/histogram_axes.wgsl` (CPRC 3.2): degenerate histograms. GPU vs mirror over generated
//! G-buffers runs in tests/tile_normal_histogram.rs, on the histograms that kernel produces.
use crate::common::{gpu, run_case};
use vxgi::gbuffers::{normals, packed, GPattern};
use vxgi::kernels::histogram_axes::{axes_case, DECL as AXES_DECL};
use vxgi::kernels::tile_normal_histogram::params;
use vxgi_cpu_mirror::octahedral::BIN_COUNT;
use vxgi_cpu_mirror::tile_normal_histogram::histograms;

#[test]
fn identical_normals_still_give_three_distinct_axes() {
    let (w, h, tile) = (64, 64, 32);
    let n = packed(&normals(w, h, GPattern::IdenticalNormals, 3));
    let (raw, blurred) = histograms(&n, &params(w, h, tile).unwrap());
    let shader = AXES_DECL.shader().unwrap();
    let case = axes_case(&shader, gpu(), &raw, &blurred, "identical".into(), 3);
    let out = run_case(&shader, AXES_DECL.name, &case, &["axes"]);
    let axes: &[[u32; 4]] = bytemuck::cast_slice(&out.buffer("axes").bytes);
    for a in axes {
        assert!(a[0] != a[1] && a[1] != a[2] && a[0] != a[2], "{a:?}");
        assert!(a[..3].iter().all(|&b| (b as usize) < BIN_COUNT));
        assert_eq!(a[3], (tile * tile), "every pixel is geometry");
    }
}
