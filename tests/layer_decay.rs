//! GPU vs mirror for `kernels/layer_decay.wgsl` (LRSM eq. 15), its range property, and the partition of
//! unity across an overlap.
use crate::common::{gpu, passing_run};
use proptest::prelude::*;
use vxgi::kernels::layer_decay::{case_for, LayerDecay, DECL};

fn gpu_decay(samples: &[[f32; 4]]) -> Vec<f32> {
    let shader = DECL.shader().unwrap();
    let case = case_for(&shader, gpu(), samples, "direct".into(), 0);
    let out = passing_run(&shader, &LayerDecay, &case, &["decay"]);
    out.buffer("decay").as_f32().to_vec()
}

#[test]
fn overlapping_layers_sum_to_one_on_the_gpu() {
    // Layers [0, 0.55] and [0.45, 1]: overlap delta = 0.1.
    let zs: Vec<f32> = (0..=200).map(|i| 0.4 + 0.2 * i as f32 / 200.0).collect();
    let mut samples: Vec<[f32; 4]> = zs.iter().map(|&z| [z, 0.0, 0.55, 0.1]).collect();
    samples.extend(zs.iter().map(|&z| [z, 0.45, 1.0, 0.1]));
    let d = gpu_decay(&samples);
    let (lower, upper) = d.split_at(zs.len());
    for ((z, a), b) in zs.iter().zip(lower).zip(upper) {
        let s = a + b;
        // Each weight is within 8 ULP of k(x) and k(1 - x), whose exact sum is 1; the two divisions
        // by delta differ in rounding, so allow a few ULP of 1 beyond that.
        assert!((s - 1.0).abs() < 2e-6, "z = {z}: {a} + {b} = {s}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    #[test]
    fn every_finite_input_gives_a_weight_in_unit_range(
        rows in proptest::collection::vec((-10.0f32..10.0, -10.0f32..10.0, 0.0f32..5.0, -1.0f32..2.0), 1..300),
    ) {
        let samples: Vec<[f32; 4]> = rows.iter().map(|r| [r.0, r.1, r.1 + r.2, r.3]).collect();
        for (s, d) in samples.iter().zip(gpu_decay(&samples)) {
            prop_assert!(d.is_finite() && (0.0..=1.0).contains(&d), "{s:?}: {d}");
            if s[0] < s[1] || s[0] > s[2] {
                prop_assert_eq!(d, 0.0, "outside the layer: {:?}", s);
            }
        }
    }
}
