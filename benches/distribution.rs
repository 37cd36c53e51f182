//! The clustered cache distribution (CPRC 3.2-3.3) at 1280x720 and 1920x1080: GPU time per kernel (each
//! kernel run on the exact inputs the previous stage produces; the stages are exact, so the mirror's
//! intermediates are the GPU's) against the mirror's time per stage. The paper reports 31 ms for the
//! distribution at 2 Mpx on a GTX 670.
//!
//! `cargo bench --bench distribution`
mod common;

use common::{gpu_ms, timed};
use vxgi::gbuffers::GPattern;
use vxgi::harness::GpuContext;
use vxgi::kernels::{
    cache_placement, cluster_extract, cluster_keys, gather_caches, histogram_axes, radix_sort,
    tile_normal_histogram,
};
use vxgi_cpu_mirror as m;

fn main() {
    let ctx = GpuContext::new().expect("GPU adapter (see README: install mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.describe());
    let (tile, slices) = (32u32, 16u32);
    for (w, h) in [(1280u32, 720u32), (1920, 1080)] {
        // Smooth depths (a floor receding from 1 to 40 units, spheres 2 units in front): the stress
        // values of the test generator would only multiply clusters.
        let depth: Vec<f32> = (0..w * h)
            .map(|i| {
                let (u, v) = ((i % w) as f32 / w as f32, (i / w) as f32 / h as f32);
                let (cx, cy) = ((u * 4.0).fract() - 0.5, (v * 3.0).fract() - 0.5);
                let floor = 1.0 + 39.0 * v;
                if cx * cx + cy * cy < 0.16 {
                    floor - 2.0
                } else {
                    floor
                }
            })
            .collect();
        let ((inp, normals), t_gen) = timed(|| {
            let inp = cluster_extract::distribution_inputs_with_depth(
                w,
                h,
                tile,
                slices,
                GPattern::Spheres,
                1,
                depth.clone(),
            );
            let normals = inp.normals.clone();
            (inp, normals)
        });
        let hp = tile_normal_histogram::params(w, h, tile).expect("sizes");
        let ((raw, blurred), m_hist) =
            timed(|| m::tile_normal_histogram::histograms(&normals, &hp));
        let table = m::octahedral::reweight_table();
        let (tile_axes, m_axes) = timed(|| m::histogram_axes::all_axes(&blurred, &raw, &table));
        let kp = m::cluster_keys::KeyParams {
            width: w,
            height: h,
            tile,
            tiles_x: hp.tiles_x,
            slices,
            _pad: [0; 3],
        };
        let mut bounds = m::cluster_keys::slice_bounds(
            cluster_keys::SLICE_NEAR,
            cluster_keys::SLICE_FAR,
            slices,
        );
        bounds.push(f32::INFINITY);
        let dirs = m::cluster_keys::axis_directions();
        let kin = m::cluster_keys::KeyInputs {
            normals: &normals,
            depth: &depth,
            tile_axes: &tile_axes,
            axis_dirs: &dirs,
            slice_bounds: &bounds,
        };
        let (_, m_keys) = timed(|| m::cluster_keys::keys(&kp, &kin));
        let keys: Vec<u32> = inp.sorted_keys.clone();
        let (_, m_sort) = timed(|| m::radix_sort::sort(&keys, &inp.sorted_pixels, 32));
        let (_, m_extract) = timed(|| {
            m::cluster_extract::extract(
                &inp.sorted_keys,
                &inp.sorted_pixels,
                &inp.normals,
                &inp.positions,
            )
        });
        let (caches, m_place) = timed(|| gather_caches::place_caches(&inp));

        let mut rows: Vec<(&str, f64, f64)> = Vec::new();
        let hcase = tile_normal_histogram::case_for(&normals, hp, "bench".into(), 0).expect("case");
        rows.push((
            "tile_normal_histogram",
            gpu_ms(&ctx, &tile_normal_histogram::DECL, &hcase),
            m_hist,
        ));
        let ashader = histogram_axes::DECL.shader().expect("WGSL");
        let acase = histogram_axes::axes_case(&ashader, &ctx, &raw, &blurred, "bench".into(), 0);
        rows.push((
            "histogram_axes",
            gpu_ms(&ctx, &histogram_axes::DECL, &acase),
            m_axes,
        ));
        let kshader = cluster_keys::DECL.shader().expect("WGSL");
        let kcase = cluster_keys::case_for(
            &kshader,
            &ctx,
            &normals,
            &depth,
            w,
            h,
            tile,
            slices,
            "bench".into(),
            0,
        );
        rows.push((
            "cluster_keys",
            gpu_ms(&ctx, &cluster_keys::DECL, &kcase),
            m_keys,
        ));
        // Sort only the bits real keys use; background (all ones) stays above every masked real key.
        let max_key = keys
            .iter()
            .copied()
            .filter(|&k| k != u32::MAX)
            .max()
            .unwrap_or(0);
        let key_bits = (32 - (max_key + 1).leading_zeros()).max(1);
        let unsorted: Vec<u32> = {
            let mut k = vec![0u32; keys.len()];
            for (key, p) in inp.sorted_keys.iter().zip(&inp.sorted_pixels) {
                k[*p as usize] = *key;
            }
            k
        };
        let pixels: Vec<u32> = (0..unsorted.len() as u32).collect();
        let (scase, _) =
            radix_sort::case_for(&ctx, &unsorted, &pixels, key_bits, "bench".into(), 0)
                .expect("case");
        rows.push((
            "radix_sort",
            gpu_ms(&ctx, &radix_sort::DECL, &scase),
            m_sort,
        ));
        let ecase = cluster_extract::case_for(&ctx, &inp, "bench".into(), 0);
        rows.push((
            "cluster_extract",
            gpu_ms(&ctx, &cluster_extract::DECL, &ecase),
            m_extract,
        ));
        let pcase = cache_placement::case_for(&ctx, &inp, "bench".into(), 0);
        rows.push((
            "cache_placement",
            gpu_ms(&ctx, &cache_placement::DECL, &pcase),
            m_place,
        ));
        let gshader = gather_caches::DECL.shader().expect("WGSL");
        // The gather evaluates 16^2 caches (irradiance maps 8^2) of generated radiance.
        let gdata = gather_caches::generated_data(&inp, 16, 8, 0);
        let gcase = gather_caches::case_for(&gshader, &ctx, &gdata, "bench".into(), 0);
        let (_, m_gather) = timed(|| gather_caches::mirror_outputs(&gcase.resources).len());
        rows.push((
            "gather_caches",
            gpu_ms(&ctx, &gather_caches::DECL, &gcase),
            m_gather,
        ));

        eprintln!("\n{w}x{h}, tiles {tile}^2, {slices} depth slices, {} caches (input generation {t_gen:.0} ms):", caches.pos.len());
        eprintln!("  {:<24} {:>10} {:>11}", "stage", "GPU ms", "mirror ms");
        for (name, g, mm) in &rows {
            eprintln!("  {name:<24} {g:>10.2} {mm:>11.2}");
        }
        let total: f64 = rows.iter().map(|r| r.1).sum();
        let mtotal: f64 = rows.iter().map(|r| r.2).sum();
        eprintln!(
            "  {:<24} {:>10.2} {:>11.2}   (GPU timing: {}; mirrors single-threaded but the gather's, rayon)",
            "distribution total",
            total,
            mtotal,
            if ctx.timestamps {
                "timestamps"
            } else {
                "wall clock"
            }
        );
    }
}
