//! GPU vs mirror for `kernels/lrsm_prefilter.wgsl`: every level of every layer, bit for bit; and the point
//! of carrying opacity: normalised moments of a coarse texel are the moments of the covered texels.
//! Its generated cases run in lrsm_partition's property test, with the other LRSM kernels'.
use crate::common::{gpu, passing_run};
use vxgi::kernels::lrsm_prefilter::{chain_case, generate, stream_name, LrsmPrefilter, DECL};

#[test]
fn normalised_coarse_moments_are_the_covered_texels_moments() {
    let (layers, side, label) = (4u32, 16u32, "4 layers 16^2");
    let level0 = generate(layers, side, 3);
    let shader = DECL.shader().unwrap();
    let case = chain_case(&shader, gpu(), &level0, layers, side, label.into(), 3);
    let out = passing_run(&shader, &LrsmPrefilter, &case, &[&stream_name(2, 2)]);
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
