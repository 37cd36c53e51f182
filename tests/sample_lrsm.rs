//! GPU vs mirror for `kernels/sample_lrsm.wgsl` (LRSM Algorithm 1) on LRSMs built from synthetic RSMs
//! (its generated cases in lrsm_partition's property test, with the other LRSM kernels').
use crate::common::{gpu, passing_run};
use vxgi::harness::kernel::verify;
use vxgi::harness::{Corruption, VerifyOptions};
use vxgi::kernels::sample_lrsm::{build_lrsm, case_for, cone_samples, BuiltLrsm, SampleLrsm, DECL};
use vxgi::lrsm::PartitionConfig;
use vxgi_cpu_mirror::sample_lrsm::SampleParams;

/// A 64^2 RSM (seed 5) in 2 x 2 layers, partitioned and pre-filtered.
fn lrsm_64() -> (PartitionConfig, BuiltLrsm) {
    let config = PartitionConfig::two_by_two(64);
    (config, build_lrsm(config, 5, 0, true))
}

/// Sample LRSM on the GPU for these samples, checked against the mirror first.
fn gpu_radiance(lrsm: &BuiltLrsm, pos: &[[f32; 4]], dir: &[[f32; 4]]) -> Vec<[f32; 4]> {
    let shader = DECL.shader().unwrap();
    let case = case_for(&shader, gpu(), lrsm, pos, dir, "samples".into(), 0);
    let out = passing_run(&shader, &SampleLrsm, &case, &["radiance"]);
    bytemuck::cast_slice(&out.buffer("radiance").bytes).to_vec()
}

#[test]
fn samples_gather_light_and_only_layers_containing_zc_are_sampled() {
    let (config, lrsm) = lrsm_64();
    let (pos, dir) = cone_samples(&lrsm, 6, 5000);
    let l = &gpu_radiance(&lrsm, &pos, &dir);
    let lit = l.iter().filter(|x| x[0] + x[1] + x[2] > 0.0).count();
    assert!(
        lit > pos.len() / 10,
        "only {lit} of {} samples gathered any light",
        pos.len()
    );
    for (i, (p, x)) in pos.iter().zip(l).enumerate() {
        let containing = lrsm
            .depth_ranges
            .iter()
            .filter(|r| p[3] >= r[0] && p[3] <= r[1])
            .count() as u32
            * config.normal_slices();
        assert_eq!(x[3], containing as f32, "sample {i}: layers sampled");
        if containing == 0 {
            assert_eq!(
                &x[..3],
                &[0.0; 3],
                "sample {i} outside every layer gathers nothing"
            );
        }
        assert!(
            x.iter().all(|c| c.is_finite() && *c >= 0.0),
            "sample {i}: {x:?}"
        );
    }
}

#[test]
fn a_corrupted_sample_fails_verification() {
    let opts = VerifyOptions {
        cases: 1,
        seed: 31,
        corrupt: Some(Corruption {
            resource: "radiance".into(),
            index: 0,
        }),
    };
    let rep = verify(gpu(), &SampleLrsm, &opts, &mut |_| {}).unwrap();
    assert!(!rep.passed());
    // The failure names its case, for `vxgi verify --case`.
    assert_eq!(rep.failed_cases, vec![0]);
}

#[test]
fn params_struct_matches_the_reflected_wgsl_layout() {
    crate::common::assert_layout!(
        DECL.shader().unwrap(),
        SampleParams {
            depth_slices,
            normal_slices,
            levels,
            side0,
            cdf,
            min_variance,
            min_alpha,
            overlap,
            view_weight,
            area,
            lit_cells,
            lit_base,
        }
    );
}

/// The paper fetches "pre-filtered RSM attributes" at `mipLevel = log(d_circle)` (section 5): filtered
/// texture reads, trilinear between the two levels around the continuous mip. So L is continuous in the
/// sample's position and level: a sweep of u across several texels at a fractional mip shows no jumps
/// at texel edges (a nearest-texel lookup jumps by whole texel differences there, blocky light). On
/// the GPU, 2000 samples over 3.2 level-1 texels; each step is 1/625 of a texel, so a continuous L
/// moves by a small share of its range per step.
#[test]
fn the_lookup_is_trilinear_so_light_is_continuous_across_texel_edges() {
    let (_, lrsm) = lrsm_64();
    let n = 2000;
    let (mut pos, mut dir) = (Vec::new(), Vec::new());
    for v in [0.65f32, 0.7, 0.8] {
        for i in 0..n {
            let u = 0.05 + 0.2 * i as f32 / n as f32;
            pos.push([u, v, 1.5, 0.7]);
            dir.push([0.0, 0.0, 1.0, 0.05]);
        }
    }
    let l = gpu_radiance(&lrsm, &pos, &dir);
    for (row, sweep) in l.chunks(n).enumerate() {
        let g: Vec<f32> = sweep.iter().map(|x| x[1]).collect();
        let lo = g.iter().copied().fold(f32::MAX, f32::min);
        let hi = g.iter().copied().fold(f32::MIN, f32::max);
        assert!(
            hi - lo > 1e-3,
            "row {row}: the sweep must see varying light"
        );
        let jump = g.windows(2).fold(0.0f32, |j, w| j.max((w[1] - w[0]).abs()));
        assert!(
            jump < 0.02 * (hi - lo),
            "row {row}: L jumps by {jump} between neighbouring samples (range {lo}..{hi})"
        );
    }
}
