//! GPU vs mirror for `kernels/cache_preconvolve.wgsl` (radiance caches' mip chains, exact, and their
//! cosine-folded irradiance maps) on generated caches, and what the irradiance means.

use vxgi_cpu_mirror::cache_creation::texel_directions;
use vxgi_cpu_mirror::cache_preconvolve::{irradiance_texel, irradiance_weights};

/// Irradiance of known radiance fields against their integrals: a uniform sky L gives E(n) = L pi at
/// the normal and L pi (1 + cos theta) / 2 for a direction theta off it (the part of its cosine lobe
/// inside the cache's hemisphere); a sky L cos(theta) gives E(n) = 2 pi L / 3.
#[test]
fn irradiance_integrates_known_skies() {
    let (res, irr) = (32u32, 8u32);
    let tex = texel_directions(res);
    let w = irradiance_weights(res, irr);
    let dirs = texel_directions(irr);
    let uniform = vec![[1.0f32, 1.0, 1.0, 0.0]; tex.len()];
    let cosine: Vec<[f32; 4]> = tex.iter().map(|d| [d[2], d[2], d[2], 0.0]).collect();
    for (k, d) in dirs.iter().enumerate() {
        let (e, _) = irradiance_texel(&uniform, &w, k);
        let want = std::f32::consts::PI * (1.0 + d[2]) / 2.0;
        // Midpoint rule over 32^2 texels of a kink (max(0, cos)) and the table's f32 rounding: 2%.
        assert!((e[0] - want).abs() < 0.02 * want, "{k}: {} vs {want}", e[0]);
    }
    // The centre texels of an 8^2 map lean off the normal: compare at the most upright one.
    let k = (0..dirs.len())
        .max_by(|&a, &b| dirs[a][2].total_cmp(&dirs[b][2]))
        .unwrap();
    let (e, _) = irradiance_texel(&cosine, &w, k);
    let c = dirs[k][2];
    // E(w) for L = cos(theta): integral of cos(theta) max(0, w . x) over the hemisphere, which for w
    // near the normal is 2 pi / 3 to first order in (1 - c).
    let want = 2.0 * std::f32::consts::PI / 3.0;
    assert!(
        (e[0] - want).abs() < 0.05 * want + (1.0 - c),
        "{} vs {want} (cos {c})",
        e[0]
    );
}
