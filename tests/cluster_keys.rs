//! GPU vs mirror for `kernels/cluster_keys.wgsl`, and keys through the GPU radix sort (CPRC 3.2).
use crate::common::{case_passes, gpu, passing_run, run_case};
use vxgi::gbuffers::{normals, packed, GPattern};
use vxgi::kernels::cluster_keys::{case_for, depths, sanitise, ClusterKeys, DECL};
use vxgi::kernels::radix_sort;
use vxgi_cpu_mirror::cluster_keys::BACKGROUND;

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 10, ..proptest::prelude::ProptestConfig::default() })]

    #[test]
    fn proptest_g_buffers(w in 1u32..160, h in 1u32..90, tile in 1u32..=64, slices in 1u32..40, family in 0usize..8, seed in proptest::prelude::any::<u64>()) {
        let shader = DECL.shader().unwrap();
        let mut n = packed(&normals(w, h, GPattern::family(family), seed));
        let d = depths(w, h, slices, seed);
        sanitise(&mut n, &d);
        let case = case_for(&shader, gpu(), &n, &d, w, h, tile, slices, "prop".into(), seed);
        case_passes(&shader, &ClusterKeys, &case)?;
    }
}

#[test]
fn bad_depths_become_background_and_keys_sort_into_clusters_on_the_gpu() {
    let (w, h, tile, slices, label) = (96u32, 64u32, 32u32, 16u32, "spheres");
    let mut n = packed(&normals(w, h, GPattern::Spheres, 1));
    let d = depths(w, h, slices, 1);
    sanitise(&mut n, &d);
    let shader = DECL.shader().unwrap();
    let case = case_for(&shader, gpu(), &n, &d, w, h, tile, slices, label.into(), 1);
    let out = run_case(&shader, DECL.name, &case, &["keys"]);
    let keys = out.buffer("keys").as_u32().to_vec();
    for (i, (k, z)) in keys.iter().zip(&d).enumerate() {
        if !(z.is_finite() && *z > 0.0) {
            assert_eq!(*k, BACKGROUND, "pixel {i} (depth {z}) must be background");
        }
    }
    // GPU keys -> GPU sort; the stable order must equal the mirror's and group equal keys.
    let values: Vec<u32> = (0..keys.len() as u32).collect();
    let (sort_case, names) =
        radix_sort::case_for(gpu(), &keys, &values, 32, "sort keys".into(), 1).unwrap();
    let sshader = radix_sort::DECL.shader().unwrap();
    let sorted = passing_run(&sshader, &radix_sort::RadixSort, &sort_case, &[&names[0]]);
    let sk = sorted.buffer(&names[0]).as_u32();
    assert!(sk.windows(2).all(|p| p[0] <= p[1]));
    let clusters = 1 + sk
        .windows(2)
        .filter(|p| p[0] != p[1] && p[1] != BACKGROUND)
        .count();
    assert!(
        clusters > 6 && clusters < keys.len() / 4,
        "{clusters} clusters for {} pixels",
        keys.len()
    );
}
