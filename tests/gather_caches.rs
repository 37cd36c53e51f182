//! GPU vs mirror for `kernels/gather_caches.wgsl` (CPRC 3.3: weights and cache evaluation), the
//! evaluation's meaning on known maps, and the distribution's quality as the paper's Fig. 6 argues it:
//! clustered placement vs an equidistant grid of caches.
use crate::common::{case_passes, gpu, run_case};
use vxgi::gbuffers::GPattern;
use vxgi::kernels::cluster_extract::{distribution_inputs, DistributionInputs};
use vxgi::kernels::gather_caches::{case_for, generated_data, place_caches, GatherCaches, DECL};
use vxgi_cpu_mirror::octahedral::unpack;

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 8, ..proptest::prelude::ProptestConfig::default() })]

    #[test]
    fn proptest_g_buffers(w in 1u32..120, h in 1u32..80, tile in 4u32..=32, family in 0usize..8, log_res in 0u32..6, log_irr in 0u32..4, seed in proptest::prelude::any::<u64>()) {
        let shader = DECL.shader().unwrap();
        let inp = distribution_inputs(w, h, tile, 16, GPattern::family(family), seed);
        let d = generated_data(&inp, 1 << log_res, 1 << log_irr, seed);
        let case = case_for(&shader, gpu(), &d, "prop".into(), seed);
        case_passes(&shader, &GatherCaches, &case)?;
    }
}

/// A pixel whose caches all hold the same maps reads them back: the irradiance map's value at the
/// pixel normal (a constant map: exactly it), and the mip chain's level at the reflection vector.
#[test]
fn uniform_caches_gather_their_own_values() {
    use vxgi_cpu_mirror::cache_preconvolve::{mip_len, mip_offset};
    let inp = distribution_inputs(64, 48, 16, 4, GPattern::family(0), 3);
    let mut d = generated_data(&inp, 8, 4, 3);
    let count = d.cache_pos.len();
    assert!(count > 0);
    d.cache_irradiance.fill([3.0, 2.0, 1.0, 0.0]);
    // Level l of every chain holds l + 1: a glossy level lf reads 1 + lf (blended), up to the top.
    let res = d.params.res;
    for c in 0..count {
        for l in 0..d.params.levels {
            let off = c * mip_len(res) + mip_offset(res, l);
            d.cache_mips[off..off + ((res >> l) * (res >> l)) as usize].fill([l as f32 + 1.0; 4]);
        }
    }
    let shader = DECL.shader().unwrap();
    let case = case_for(&shader, gpu(), &d, "uniform".into(), 3);
    let outputs = ["diffuse", "glossy", "weight_sum"];
    let out = run_case(&shader, DECL.name, &case, &outputs);
    let diffuse: &[[f32; 4]] = bytemuck::cast_slice(&out.buffer("diffuse").bytes);
    let glossy: &[[f32; 4]] = bytemuck::cast_slice(&out.buffer("glossy").bytes);
    let ws = out.buffer("weight_sum").as_f32();
    let top = d.params.levels as f32 - 1.0;
    let mut checked = 0;
    for i in (0..diffuse.len()).filter(|&i| ws[i] > 1e-3) {
        checked += 1;
        // One division of sum w v by sum w, v constant: a few ULP.
        assert!(
            (diffuse[i][0] - 3.0).abs() < 1e-5 && (diffuse[i][2] - 1.0).abs() < 1e-5,
            "{i}: {:?}",
            diffuse[i]
        );
        let lf = d.pixel_dirs[2 * i + 1][3];
        let want = if lf < 0.0 { 0.0 } else { lf.min(top) + 1.0 };
        assert!(
            (glossy[i][0] - want).abs() < 1e-5 * want.max(1.0),
            "{i}: lf {lf} -> {:?}",
            glossy[i]
        );
    }
    assert!(checked > 100, "{checked} pixels with weight");
}

/// Fraction of geometry pixels with at least one cache of non-zero weight min(w_w, w_s) whose normal
/// faces the pixel's hemisphere (n_p . n_c > 0: a cache holds only its upper hemisphere).
fn coverage(
    inp: &DistributionInputs,
    caches: &[([f32; 4], [i32; 2], [f32; 3])],
    radius_px: f32,
) -> f64 {
    let (mut covered, mut geometry) = (0usize, 0usize);
    for (i, n) in inp.normals.iter().enumerate() {
        let Some(q) = unpack(*n) else { continue };
        geometry += 1;
        let np = [q[0] as f32, q[1] as f32, q[2] as f32];
        let (x, y) = ((i as u32 % inp.width) as i32, (i as u32 / inp.width) as i32);
        let p = inp.positions[i];
        let hit = caches.iter().any(|(cp, cpx, cn)| {
            let ds2 = ((cpx[0] - x).pow(2) + (cpx[1] - y).pow(2)) as f32;
            let dw2 = (p[0] - cp[0]).powi(2) + (p[1] - cp[1]).powi(2) + (p[2] - cp[2]).powi(2);
            let w = (1.0 - dw2 / (cp[3] * cp[3])).min(1.0 - ds2 / (radius_px * radius_px));
            w > 0.0 && np[0] * cn[0] + np[1] * cn[1] + np[2] * cn[2] > 0.0
        });
        covered += hit as usize;
    }
    if geometry == 0 {
        1.0
    } else {
        covered as f64 / geometry as f64
    }
}

#[test]
fn clustered_distribution_covers_more_than_an_equidistant_grid() {
    let (w, h, tile) = (256u32, 144u32, 32u32);
    let radius_px = (2 * tile) as f32;
    eprintln!("G-buffer      caches  clustered coverage  grid caches  grid coverage   (r_s = 2 tiles; r_w: see below)");
    for pattern in [
        GPattern::FlatWalls,
        GPattern::Spheres,
        GPattern::ThinFeatures,
        GPattern::IdenticalNormals,
    ] {
        let inp = distribution_inputs(w, h, tile, 16, pattern, 7);
        // r_w: clustered caches carry 1.5 x their cluster's box diagonal (place_caches); grid caches,
        // having no cluster, get the mean of those radii, so both distributions spend the same reach.
        let c = place_caches(&inp);
        let clustered: Vec<_> = c
            .pos
            .iter()
            .zip(&c.pixel)
            .zip(&c.normal)
            .map(|((p, px), n)| (*p, [px[0] as i32, px[1] as i32], [n[0], n[1], n[2]]))
            .collect();
        let r_w = clustered.iter().map(|c| c.0[3] as f64).sum::<f64>() as f32
            / clustered.len().max(1) as f32;
        // Equidistant grid with about as many caches, on the geometry pixels it hits.
        let n = clustered.len().max(1);
        let step = ((w * h) as f64 / n as f64).sqrt().max(1.0);
        let mut grid = Vec::new();
        let mut gy = step / 2.0;
        while gy < h as f64 {
            let mut gx = step / 2.0;
            while gx < w as f64 {
                let i = (gy as u32 * w + gx as u32) as usize;
                if let Some(q) = unpack(inp.normals[i]) {
                    let p = inp.positions[i];
                    grid.push((
                        [p[0], p[1], p[2], r_w],
                        [gx as i32, gy as i32],
                        [q[0] as f32, q[1] as f32, q[2] as f32],
                    ));
                }
                gx += step;
            }
            gy += step;
        }
        let cc = coverage(&inp, &clustered, radius_px);
        let gc = coverage(&inp, &grid, radius_px);
        eprintln!(
            "{:<13} {:>6} {:>19.3} {:>12} {:>14.3}",
            format!("{pattern:?}"),
            clustered.len(),
            cc,
            grid.len(),
            gc
        );
        assert!(cc >= gc - 1e-9, "{pattern:?}: clustered {cc} < grid {gc}");
        assert!(cc > 0.97, "{pattern:?}: clustered coverage {cc}");
    }
}
