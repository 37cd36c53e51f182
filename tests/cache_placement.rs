//! GPU vs mirror for `kernels/cache_placement.wgsl` (CPRC 3.2): scores within their bounds, picks
//! accepted by score, and how often the picks differ (its property test over generated G-buffers is
//! cluster_extract's, which builds the clusters it scores).
use crate::common::{gpu, passing_run};
use vxgi::gbuffers::GPattern;
use vxgi::kernels::cache_placement::{accepted_picks, case_for, CachePlacement, DECL};
use vxgi::kernels::cluster_extract::distribution_inputs;

/// Stress: clusters of one pixel (d_c = 0, the pixel is its own box centre), identical normals, thin
/// features; and the pick-difference rate, printed.
#[test]
fn one_pixel_clusters_and_pick_agreement() {
    let shader = DECL.shader().unwrap();
    let (mut differ, mut total) = (0, 0);
    for (i, pattern) in [
        GPattern::OnePixelPerTile { tile: 16 },
        GPattern::IdenticalNormals,
        GPattern::ThinFeatures,
        GPattern::Spheres,
    ]
    .into_iter()
    .enumerate()
    {
        let inp = distribution_inputs(96, 64, 16, 16, pattern, i as u64);
        let case = case_for(gpu(), &inp, format!("{pattern:?}"), 0);
        let out = passing_run(&shader, &CachePlacement, &case, &["picks", "scores"]);
        let mut data = case.resources.clone();
        data.extend(out.resources.clone());
        let count = data["cluster_count"].buffer().unwrap().as_u32()[0] as usize;
        let (_, d) = accepted_picks(&data, out.buffer("picks").as_u32());
        differ += d;
        total += count;
        assert!(
            out.buffer("scores").as_f32().iter().all(|s| s.is_finite()),
            "{pattern:?}: non-finite score"
        );
    }
    eprintln!("cache picks differing from the mirror's (within score bounds): {differ} of {total}");
    assert!(total > 0);
}
