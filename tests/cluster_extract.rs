//! GPU vs mirror for `kernels/cluster_extract.wgsl` (CPRC 3.2), and what clusters must satisfy; its
//! generated G-buffers also drive cache_placement's property test.
use crate::common::{assert_case_passes, case_passes, gpu, run_case};
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
    let outputs = ["cluster_count", "clusters", "pixel_cluster"];
    let out = run_case(&shader, DECL.name, &case, &outputs);
    let count = out.buffer("cluster_count").as_u32()[0] as usize;
    let clusters: &[Cluster] = bytemuck::cast_slice(&out.buffer("clusters").bytes);
    let pixel_cluster = out.buffer("pixel_cluster").as_u32();
    let geometry = inp.normals.iter().filter(|n| n[1] >> 16 == 1).count();
    let counted: u32 = clusters[..count].iter().map(|c| c.start_count_key[1]).sum();
    assert_eq!(counted as usize, geometry);
    for (p, (&c, q)) in pixel_cluster.iter().zip(&inp.positions).enumerate() {
        if c != u32::MAX {
            let cl = &clusters[c as usize];
            let inside = (0..3).all(|a| cl.bbox_min[a] <= q[a] && q[a] <= cl.bbox_max[a]);
            assert!(inside, "pixel {p} outside cluster {c}");
        }
    }
    assert!(count > 4, "{count} clusters");
}

/// More pixels than one invocation may loop over on lavapipe (65535 iterations: llvmpipe's
/// LP_MAX_TGSI_LOOP_ITERATIONS; the heads were once scanned serially and silently truncated there,
/// 390 clusters for 1402 at 512x512): 512x384 pixels, exactly the mirror's clusters.
#[test]
fn more_pixels_than_one_invocation_may_loop_over() {
    let inp = distribution_inputs(512, 384, 16, 16, GPattern::family(1), 4);
    let case = case_for(gpu(), &inp, "large".into(), 0);
    assert_case_passes(&DECL.shader().unwrap(), &ClusterExtract, &case);
}
