//! GPU vs mirror for `kernels/cache_reuse.wgsl`, and what reuse is for: a cache made on a pixel
//! centre is kept by the unmoved view (the lowest of its cluster's), and dropped once its surface has
//! moved off it by more than the reach.
use crate::common::{assert_case_passes, gpu, run_case};
use vxgi::harness::Bindings;
use vxgi::kernels::cache_reuse::{generated, passes, CacheReuse, Io, DECL};
use vxgi_cpu_mirror::cache_reuse::NONE;

/// Case 0's view, with the last caches on every fifth front pixel's centre (its normal), shifted
/// along the normal by `lift` pixel footprints; the GPU's (prev_pixel, kept) after the passes, the
/// caches' pixels, and the view.
fn caches_on_centres(lift: f64) -> (Vec<u32>, Vec<u32>, Vec<u32>, Io) {
    let (mut io, _) = generated(7, 0);
    let f = io.frame.0;
    let v = |a: [f32; 4]| glam::DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
    let (eye, fwd, up) = (v(f.eye), v(f.forward), v(f.up));
    let front: Vec<u32> = (0..io.positions.len() as u32)
        .filter(|&p| io.positions[p as usize][3] == 1.0)
        .step_by(5)
        .collect();
    assert!(front.len() > 20, "case 0 shows its planes");
    (io.prev_pos, io.prev_normal) = (Vec::new(), Vec::new());
    for &p in &front {
        let q = vxgi_cpu_mirror::octahedral::unpack(io.normals[p as usize]).unwrap();
        let n = glam::DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64).normalize();
        let at = v(io.positions[p as usize]);
        let footprint = 2.0 * (at - eye).dot(fwd) * up.length() / f.size[1] as f64;
        let x = at + n * footprint * lift;
        io.prev_pos.push([x.x as f32, x.y as f32, x.z as f32, 0.0]);
        io.prev_normal
            .push([n.x as f32, n.y as f32, n.z as f32, 0.0]);
    }
    io.prev_count = vec![front.len() as u32];
    io.prev_pixel = vec![0; front.len()];
    io.reuse_params.0 = vxgi_cpu_mirror::cache_reuse::ReuseParams::DEFAULT;
    let shader = DECL.shader().unwrap();
    let (mut all, keep) = passes(gpu(), io.kept.len(), front.len(), io.cache_pos.len());
    all.push(keep);
    let case = io.case(format!("centres lifted by {lift}"), 7, all);
    assert_case_passes(&shader, &CacheReuse, &case);
    let out = run_case(&shader, DECL.name, &case, &["prev_pixel", "kept"]);
    let (pixels, kept) = (
        out.buffer("prev_pixel").as_u32(),
        out.buffer("kept").as_u32(),
    );
    (pixels.to_vec(), kept.to_vec(), front, io)
}

#[test]
fn an_unmoved_view_keeps_the_lowest_cache_of_each_cluster() {
    let (pixels, kept, front, io) = caches_on_centres(0.0);
    // A pixel centre projects back onto its own pixel (half a pixel from every boundary).
    assert_eq!(pixels, front);
    for (c, &k) in kept.iter().enumerate() {
        let lowest = front
            .iter()
            .position(|&p| io.pixel_cluster[p as usize] == c as u32);
        assert_eq!(k, lowest.map_or(0, |i| NONE - i as u32), "cluster {c}");
    }
}

#[test]
fn a_cache_whose_surface_moved_past_the_reach_is_not_kept() {
    // Reach 3 footprints: at 2 most caches stay, at 4 none (the pixel's surface point is 4 footprints
    // below each).
    let (_, kept, ..) = caches_on_centres(2.0);
    assert!(kept.iter().filter(|&&k| k != 0).count() > 5);
    let (_, kept, ..) = caches_on_centres(4.0);
    assert!(kept.iter().all(|&k| k == 0), "{kept:?}");
}
