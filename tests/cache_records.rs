//! GPU vs mirror for `kernels/cache_records.wgsl` (the caches' records and the cache stages' indirect
//! arguments), and its capacity rule: clusters past the capacity get no cache and are counted.
use crate::common;
use crate::common::run_case;

use common::gpu;
use vxgi::gbuffers::GPattern;
use vxgi::harness::kernel::verify_case;
use vxgi::kernels::cache_records::{case_for, params, CacheRecords, DECL};
use vxgi::kernels::cluster_extract::distribution_inputs;
use vxgi_cpu_mirror::cache_records::groups;

#[test]
fn clusters_past_the_capacity_are_counted_and_get_no_cache() {
    let shader = DECL.shader().unwrap();
    let inp = distribution_inputs(64, 48, 16, 4, GPattern::Spheres, 3);
    for capacity in [1000, 5, 0] {
        let p = params(gpu(), &inp, capacity, [256, 0, 64], 0.01);
        let case = case_for(gpu(), &inp, p, format!("capacity {capacity}"), 0);
        let (comps, ..) = verify_case(gpu(), &shader, &CacheRecords, &case, None).unwrap();
        assert!(comps.iter().all(|c| c.passed()), "capacity {capacity}");
        let out = run_case(&shader, DECL.name, &case, &["cache_args"]);
        let args = out.buffer("cache_args").as_u32().to_vec();
        let clusters = case.resources["cluster_count"].buffer().unwrap().as_u32()[0];
        assert!(
            clusters > 5,
            "the case needs more clusters than the small capacity"
        );
        let count = clusters.min(capacity);
        assert_eq!(args[..2], [count, clusters - count], "capacity {capacity}");
        assert_eq!(args[4..7], groups(count * 256, p.max_groups));
        // No mip chain: no workgroups.
        assert_eq!(args[8..11], [0, 0, 1]);
    }
}

#[test]
fn arguments_split_past_the_workgroup_limit() {
    assert_eq!(groups(0, 65535), [0, 0, 1]);
    assert_eq!(groups(64, 65535), [1, 1, 1]);
    assert_eq!(groups(65, 65535), [2, 1, 1]);
    // 70000 workgroups: two rows of 65535 (the last partly used; the kernels stop at their count).
    assert_eq!(groups(70000 * 64, 65535), [65535, 2, 1]);
}
