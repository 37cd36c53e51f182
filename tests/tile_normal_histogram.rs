//! GPU vs mirror for `kernels/tile_normal_histogram.wgsl` (CPRC 3.2), with `histogram_axes` on its
//! output in the same property test; stress cases and bad input.
use crate::common::{case_passes, gpu, run_case};
use vxgi::gbuffers::{normals, packed, GPattern};
use vxgi::kernels::histogram_axes::{axes_case, HistogramAxes, DECL as AXES_DECL};
use vxgi::kernels::tile_normal_histogram::{
    case_for, params, TileError, TileNormalHistogram, DECL,
};
use vxgi_cpu_mirror::tile_normal_histogram::histograms;

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 12, ..proptest::prelude::ProptestConfig::default() })]

    #[test]
    fn proptest_g_buffers(w in 1u32..200, h in 1u32..120, tile in 1u32..=64, family in 0usize..8, seed in proptest::prelude::any::<u64>()) {
        let shader = DECL.shader().unwrap();
        let n = packed(&normals(w, h, GPattern::family(family), seed));
        let case = case_for(&n, params(w, h, tile).unwrap(), format!("{w}x{h} tile {tile}"), seed).unwrap();
        case_passes(&shader, &TileNormalHistogram, &case)?;
        let (raw, blurred) = histograms(&n, &params(w, h, tile).unwrap());
        let ashader = AXES_DECL.shader().unwrap();
        let acase = axes_case(&ashader, gpu(), &raw, &blurred, "axes".into(), seed);
        case_passes(&ashader, &HistogramAxes, &acase)?;
    }
}

#[test]
fn bad_normals_count_as_background_and_bad_sizes_are_errors() {
    let (w, h) = (40, 30);
    let n = packed(&normals(w, h, GPattern::BadNormals, 9));
    let geometry = n.iter().filter(|x| x[1] >> 16 == 1).count() as u32;
    assert!(
        geometry < w * h,
        "NaN, infinite and zero normals must become background"
    );
    let case = case_for(&n, params(w, h, 16).unwrap(), "bad normals".into(), 9).unwrap();
    let shader = DECL.shader().unwrap();
    let out = run_case(&shader, DECL.name, &case, &["histogram"]);
    let binned: u32 = out.buffer("histogram").as_u32().iter().sum();
    assert_eq!(binned, geometry);

    assert_eq!(params(10, 10, 0), Err(TileError::TileSize(0)));
    assert_eq!(params(10, 10, 65), Err(TileError::TileSize(65)));
    let empty = TileError::Empty {
        width: 0,
        height: 10,
    };
    assert_eq!(params(0, 10, 8), Err(empty));
    assert!(matches!(
        case_for(&n[1..], params(w, h, 16).unwrap(), "short".into(), 0),
        Err(TileError::Length { .. })
    ));
}
