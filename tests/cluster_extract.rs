//! GPU vs mirror for `kernels/cluster_extract.wgsl` (CPRC 3.2), and what clusters must satisfy; its
//! generated G-buffers also drive cache_placement's property test.
use crate::common;
use crate::common::run_case;

use common::{case_passes, gpu};
use vxgi::gbuffers::GPattern;
use vxgi::kernels::cluster_extract::{case_for, distribution_inputs, ClusterExtract, DECL};
use vxgi_cpu_mirror::cluster_extract::Cluster;

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 10, ..proptest::prelude::ProptestConfig::default() })]

    #[test]
    fn proptest_g_buffers(w in 1u32..160, h in 1u32..90, tile in 1u32..=64, slices in 1u32..40, family in 0usize..8, seed in proptest::prelude::any::<u64>()) {
        // cluster_extract's clusters, and cache_placement's scores and picks over them.
        use vxgi::kernels::cache_placement::{self, CachePlacement};
        let inp = distribution_inputs(w, h, tile, slices, GPattern::family(family), seed);
        let case = case_for(gpu(), &inp, "prop".into(), seed);
        case_passes(&DECL.shader().unwrap(), &ClusterExtract, &case)?;
        let case = cache_placement::case_for(gpu(), &inp, "prop".into(), seed);
        case_passes(&cache_placement::DECL.shader().unwrap(), &CachePlacement, &case)?;
    }
}

#[test]
fn clusters_partition_the_geometry_pixels_and_bound_them() {
    let inp = distribution_inputs(128, 72, 32, 16, GPattern::Spheres, 4);
    let shader = DECL.shader().unwrap();
    let case = case_for(gpu(), &inp, "spheres".into(), 4);
    let out = run_case(
        &shader,
        DECL.name,
        &case,
        &["cluster_count", "clusters", "pixel_cluster"],
    );
    let count = out.buffer("cluster_count").as_u32()[0] as usize;
    let clusters: &[Cluster] = bytemuck::cast_slice(&out.buffer("clusters").bytes);
    let pixel_cluster = out.buffer("pixel_cluster").as_u32();
    let geometry = inp.normals.iter().filter(|n| n[1] >> 16 == 1).count();
    assert_eq!(
        clusters[..count]
            .iter()
            .map(|c| c.start_count_key[1] as usize)
            .sum::<usize>(),
        geometry
    );
    for (p, &c) in pixel_cluster.iter().enumerate() {
        if c == u32::MAX {
            continue;
        }
        let cl = &clusters[c as usize];
        for a in 0..3 {
            assert!(
                cl.bbox_min[a] <= inp.positions[p][a] && inp.positions[p][a] <= cl.bbox_max[a],
                "pixel {p} outside cluster {c}"
            );
        }
    }
    assert!(count > 4, "{count} clusters");
}

/// More pixels than one invocation may loop over on lavapipe (65535 iterations: llvmpipe's
/// LP_MAX_TGSI_LOOP_ITERATIONS; the heads were once scanned serially and silently truncated there,
/// 390 clusters for 1402 at 512x512): 512x384 pixels, exactly the mirror's clusters.
#[test]
fn more_pixels_than_one_invocation_may_loop_over() {
    let inp = vxgi::kernels::cluster_extract::distribution_inputs(
        512,
        384,
        16,
        16,
        vxgi::gbuffers::GPattern::family(1),
        4,
    );
    let case = vxgi::kernels::cluster_extract::case_for(gpu(), &inp, "large".into(), 0);
    let shader = vxgi::kernels::cluster_extract::DECL.shader().unwrap();
    let (comps, ..) = vxgi::harness::kernel::verify_case(
        gpu(),
        &shader,
        &vxgi::kernels::cluster_extract::ClusterExtract,
        &case,
        None,
    )
    .unwrap();
    for c in comps {
        assert!(c.passed(), "{}", c.report());
    }
}
