//! GPU vs mirror for `kernels/lrsm_prefilter.wgsl`: every level of every layer, bit for bit; and the point
//! of carrying opacity: normalised moments of a coarse texel are the moments of the covered texels.
use crate::common;
use crate::common::run_case;

use common::{case_passes, gpu};
use vxgi::harness::kernel::verify_case;
use vxgi::kernels::lrsm_prefilter::{chain_case, generate, stream_name, LrsmPrefilter, DECL};

#[test]
fn normalised_coarse_moments_are_the_covered_texels_moments() {
    let (layers, side) = (4u32, 16u32);
    let level0 = generate(layers, side, 3);
    let shader = DECL.shader().unwrap();
    let case = chain_case(
        &shader,
        gpu(),
        &level0,
        layers,
        side,
        "4 layers 16^2".into(),
        3,
    );
    let (comps, ..) = verify_case(gpu(), &shader, &LrsmPrefilter, &case, None).unwrap();
    assert!(comps.iter().all(|c| c.passed()));
    let out = run_case(&shader, DECL.name, &case, &[&stream_name(2, 2)]);
    let coarse: &[[f32; 4]] = bytemuck::cast_slice(&out.buffer(&stream_name(2, 2)).bytes);
    // Level 2 texel P covers level-0 texels 16P .. 16P+16 (Morton order, per layer).
    for (p, m) in coarse.iter().enumerate() {
        let fine = &level0[2][16 * p..16 * p + 16];
        let a: f64 = fine.iter().map(|t| t[2] as f64).sum();
        if m[2] < 1e-3 {
            continue;
        }
        let mean_z = fine.iter().map(|t| t[0] as f64).sum::<f64>() / a;
        let mean_z2 = fine.iter().map(|t| t[1] as f64).sum::<f64>() / a;
        assert!(((m[0] / m[2]) as f64 - mean_z).abs() < 1e-5, "texel {p}");
        assert!(((m[1] / m[2]) as f64 - mean_z2).abs() < 1e-5, "texel {p}");
        assert!(
            (m[2] as f64 - a / 16.0).abs() < 1e-6,
            "texel {p}: opacity is the covered fraction"
        );
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 12, ..proptest::prelude::ProptestConfig::default() })]

    /// Proptest drives the generator: any seed, any of its configuration families.
    #[test]
    fn proptest_generated_cases_match_the_mirror(seed in proptest::prelude::any::<u64>(), index in 0usize..60) {
        let shader = DECL.shader().unwrap();
        let case = vxgi::harness::Kernel::case(&LrsmPrefilter, &shader, gpu(), seed, index);
        case_passes(&shader, &LrsmPrefilter, &case)?;
    }
}
