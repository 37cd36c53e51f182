//! GPU vs mirror for `kernels/lrsm_partition.wgsl`, bad input refused at the API boundary, and what a
//! partition must conserve; the property test over generated cases covers lrsm_prefilter and
//! sample_lrsm too.
use crate::common::{case_passes, gpu, passing_run};
use vxgi::harness::Kernel;
use vxgi::kernels::lrsm_partition::{case_for, LrsmPartition, DECL};
use vxgi::kernels::lrsm_prefilter::values;
use vxgi::lrsm::{synthetic_rsm, LrsmError, PartitionConfig};

fn config(side: u32, a: u32, b: u32, overlap: f32) -> PartitionConfig {
    PartitionConfig {
        rsm_side: side,
        depth_splits: a,
        normal_splits: b,
        overlap,
        area_weights: false,
    }
}

#[test]
fn bad_partitions_and_rsms_are_errors_not_panics() {
    let shader = DECL.shader().unwrap();
    let good = config(16, 1, 1, 0.05);
    let rsm = synthetic_rsm(16, &good, 1);
    let err = |c: PartitionConfig, r: &vxgi::lrsm::Rsm| {
        case_for(&shader, gpu(), r, &c, "bad".into(), 0).unwrap_err()
    };

    assert_eq!(err(config(6, 1, 1, 0.05), &rsm), LrsmError::RsmSize(6));
    assert_eq!(err(config(1, 1, 1, 0.05), &rsm), LrsmError::RsmSize(1));
    let e = err(config(16, 8, 7, 0.01), &rsm);
    assert!(matches!(e, LrsmError::TooManyLayers { layers: 72, .. }));
    let e = err(config(8192, 7, 7, 0.01), &rsm);
    assert!(matches!(e, LrsmError::LayerArrayTooLarge { .. }));
    for overlap in [0.6, -0.1, f32::NAN, f32::INFINITY] {
        let e = err(config(16, 1, 1, overlap), &rsm);
        assert!(matches!(e, LrsmError::Overlap { .. }), "{overlap}: {e}");
    }
    let mut nan = rsm.clone();
    nan.depth[vxgi_cpu_mirror::morton::encode2(3, 5) as usize] = f32::NAN;
    let e = err(good, &nan);
    let at = matches!(
        e,
        LrsmError::NonFinite {
            x: 3,
            y: 5,
            what: "depth",
            ..
        }
    );
    assert!(at && e.to_string().contains("x=3, y=5"), "{e}");
    let mut inf = rsm.clone();
    inf.normal[0][3] = f32::INFINITY;
    let e = err(good, &inf);
    assert!(matches!(e, LrsmError::NonFinite { what: "normal", .. }));
    let mut short = rsm.clone();
    short.depth.pop();
    assert!(matches!(err(good, &short), LrsmError::Length { .. }));
    // The good one goes through.
    assert!(case_for(&shader, gpu(), &rsm, &good, "good".into(), 0).is_ok());
}

#[test]
fn every_covered_texel_lands_in_its_layers_with_warped_depth_in_unit_range() {
    let shader = DECL.shader().unwrap();
    let c = config(32, 2, 1, 0.04);
    let rsm = synthetic_rsm(32, &c, 4);
    let case = case_for(&shader, gpu(), &rsm, &c, "conservation".into(), 4).unwrap();
    let out = passing_run(&shader, &LrsmPartition, &case, &["out_moments"]);
    let m = values(out.buffer("out_moments"));
    let ranges = c.depth_ranges();
    let texels = c.layer_texels() as usize;
    for q in 0..texels {
        // Expected total count over layers: each covered texel once per depth slice containing it.
        let mut expect = 0;
        for t in 4 * q..4 * q + 4 {
            if rsm.radiance[t][3] > 0.5 {
                expect += ranges
                    .iter()
                    .filter(|r| rsm.depth[t] >= r[0] && rsm.depth[t] <= r[1])
                    .count();
            }
        }
        // Counts / 4 are multiples of 1/4: binary16 holds them exactly.
        let got: f32 = (0..c.layers() as usize)
            .map(|l| m[l * texels + q][2] * 4.0)
            .sum();
        assert_eq!(got as usize, expect, "quad {q}");
        for l in 0..c.layers() as usize {
            let t = m[l * texels + q];
            if t[2] > 0.0 {
                // Each binary16 value within 2^-10 of its own size (either rounding).
                let (mu, mu2) = (t[0] / t[2], t[1] / t[2]);
                assert!(
                    (0.0..=1.0 + 2e-3).contains(&mu) && (0.0..=1.0 + 2e-3).contains(&mu2),
                    "quad {q} layer {l}: {t:?}"
                );
            }
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 12, ..proptest::prelude::ProptestConfig::default() })]

    /// Proptest drives the generators of the three LRSM kernels (this one, lrsm_prefilter and
    /// sample_lrsm): any seed, any of their configuration families; each kernel gets every case.
    #[test]
    fn proptest_generated_cases_match_the_mirror(seed in proptest::prelude::any::<u64>(), index in 0usize..60) {
        use vxgi::kernels::{lrsm_prefilter::LrsmPrefilter, sample_lrsm::SampleLrsm};
        for kernel in [&LrsmPartition as &dyn Kernel, &LrsmPrefilter, &SampleLrsm] {
            let shader = kernel.decl().shader().unwrap();
            case_passes(&shader, kernel, &kernel.case(&shader, gpu(), seed, index))?;
        }
    }
}

/// The paper's Table 2 LRSM memory (1024^2 RSM -> 512^2 LRSM, 16-bit channels): 33.6 MB for 2x2 layers
/// and 50.4 MB for 3x2; ours stores binary16 too.
#[test]
fn lrsm_memory_matches_table_2() {
    for (a, b, paper_mb) in [(2u32, 2u32, 33.6f64), (3, 2, 50.4)] {
        let ours = vxgi::lrsm::lrsm_bytes(&config(1024, a - 1, b - 1, 0.05)) as f64 / 1e6;
        eprintln!("LRSM {a}x{b} layers of 512^2: {ours:.1} MB (paper: {paper_mb} MB)");
        assert!(
            (ours - paper_mb).abs() < 0.1,
            "{ours} MB vs paper {paper_mb} MB"
        );
    }
}

/// Radiance past binary16's range is stored as its largest finite value (65504), on the GPU as in the
/// mirror, not as infinity or an indeterminate word: a quad of four covered texels of radiance 1e6
/// averages to 1e6, past the clamp; one texel of 9.6e4 averages to 2.4e4, within it (and exact).
#[test]
fn radiance_past_binary16_is_clamped_to_its_largest_value() {
    let shader = DECL.shader().unwrap();
    let c = config(4, 0, 0, 0.0);
    let mut rsm = synthetic_rsm(4, &c, 1);
    for t in 0..16 {
        rsm.radiance[t] = [1.0e6, 1.0e6, 1.0e6, 1.0];
        rsm.depth[t] = 0.5;
    }
    rsm.radiance[4] = [9.6e4, 0.0, 0.0, 1.0];
    for t in 5..8 {
        rsm.radiance[t][3] = 0.0;
    }
    let case = case_for(&shader, gpu(), &rsm, &c, "clamp".into(), 0).unwrap();
    let out = passing_run(&shader, &LrsmPartition, &case, &["out_radiance"]);
    let r = values(out.buffer("out_radiance"));
    assert_eq!(r[0], [65504.0, 65504.0, 65504.0, 1.0]);
    assert_eq!(r[1], [24000.0, 0.0, 0.0, 0.25]);
}
