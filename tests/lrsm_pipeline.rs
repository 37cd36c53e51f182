//! The LRSM kernels composed on the GPU: lrsm_partition -> lrsm_prefilter (every level) -> sample_lrsm,
//! each stage fed with the previous stage's GPU output, ends where the mirrors end (the first two stages
//! exactly, up to the z^2 moment's contraction allowance, Sample LRSM within its bounds).
use crate::common;

use common::gpu;
use vxgi::harness::kernel::verify_case;
use vxgi::harness::run::run;
use vxgi::kernels::{lrsm_partition, lrsm_prefilter, sample_lrsm};
use vxgi::lrsm::{synthetic_rsm, PartitionConfig};

#[test]
fn partition_prefilter_sample_compose_on_the_gpu() {
    let config = PartitionConfig::two_by_two(64);
    let rsm = synthetic_rsm(64, &config, 3);

    // 1. Partition on the GPU.
    let pshader = lrsm_partition::DECL.shader().unwrap();
    let pcase =
        lrsm_partition::case_for(&pshader, gpu(), &rsm, &config, "partition".into(), 3).unwrap();
    let (comps, ..) = verify_case(
        gpu(),
        &pshader,
        &lrsm_partition::LrsmPartition,
        &pcase,
        None,
    )
    .unwrap();
    assert!(comps.iter().all(|c| c.passed()));
    let level0 = run(
        gpu(),
        &pshader,
        "lrsm_partition",
        &pcase.resources,
        &pcase.passes,
        &["out_radiance", "out_normal", "out_moments"],
    )
    .unwrap();
    let streams: [Vec<[f32; 4]>; 3] = ["out_radiance", "out_normal", "out_moments"]
        .map(|n| lrsm_prefilter::values(level0.buffer(n)));

    // 2. Pre-filter the GPU's level 0 on the GPU, every level verified on its GPU input.
    let side0 = config.rsm_side / 2;
    let fshader = lrsm_prefilter::DECL.shader().unwrap();
    let fcase = lrsm_prefilter::chain_case(
        &fshader,
        gpu(),
        &streams,
        config.layers(),
        side0,
        "prefilter".into(),
        3,
    );
    let (comps, ..) = verify_case(
        gpu(),
        &fshader,
        &lrsm_prefilter::LrsmPrefilter,
        &fcase,
        None,
    )
    .unwrap();
    assert!(comps.iter().all(|c| c.passed()));
    let levels = side0.trailing_zeros() + 1;
    let names: Vec<String> = (1..levels)
        .flat_map(|k| (0..3).map(move |s| lrsm_prefilter::stream_name(s, k)))
        .collect();
    let name_refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let chain = run(
        gpu(),
        &fshader,
        "lrsm_prefilter",
        &fcase.resources,
        &fcase.passes,
        &name_refs,
    )
    .unwrap();

    // 3. Sample the GPU-built LRSM; the CPU-built one (mirrors throughout) must agree with it.
    let mut built = sample_lrsm::build_lrsm(config, 3, 0, true);
    let mut gpu_streams = streams.clone();
    for k in 1..levels {
        for (s, stream) in gpu_streams.iter_mut().enumerate() {
            stream.extend(lrsm_prefilter::values(
                chain.buffer(&lrsm_prefilter::stream_name(s, k)),
            ));
        }
    }
    // Every texel is stored as binary16, which GPU and mirror may round to different neighbours (1
    // binary16 ULP, at most 2^-10 of the value); a pre-filter level averages children that differ
    // by that relative amount of the texel's largest value and rounds once more, so level k is
    // within k + 1 such steps of the texel's largest component (its opacity bounds a normal's).
    for (gs, ms) in gpu_streams.iter().zip(&built.streams) {
        for (g, m) in gs.iter().zip(ms) {
            let scale = m.iter().fold(0.0f32, |a, x| a.max(x.abs()));
            for c in 0..4 {
                assert!(
                    (g[c] - m[c]).abs() <= (levels + 1) as f32 * scale / 1024.0 + 6.0e-8,
                    "{g:?} vs {m:?}"
                );
            }
        }
    }
    built.streams = gpu_streams;
    let (pos, dir) = sample_lrsm::cone_samples(&built, 4, 2000);
    let sshader = sample_lrsm::DECL.shader().unwrap();
    let scase = sample_lrsm::case_for(&sshader, gpu(), &built, &pos, &dir, "sample".into(), 4);
    let (comps, ..) = verify_case(gpu(), &sshader, &sample_lrsm::SampleLrsm, &scase, None).unwrap();
    assert!(comps[0].passed(), "{}", comps[0].report());
}
