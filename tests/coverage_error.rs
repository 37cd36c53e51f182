//! Approximation error of mip alpha (DESIGN.md section 5, kind 2), mirror only: surface coverage vs
//! volume coverage against the brute-force fraction of axis-aligned rays a full fine voxel stops.
//! Prints the table; asserts what the paper (CPRC 3.1) claims: across a surface, surface coverage keeps
//! coarse levels as opaque as the fine surface, volume coverage fades them as 1/2^level.
use vxgi::coverage::{coverage_error, CoverageError};
use vxgi::grids::{generate, Pattern};
use vxgi_cpu_mirror::surface_coverage_mip::Coverage;

fn table(name: &str, surface: &[CoverageError], volume: &[CoverageError]) {
    eprintln!("{name}");
    eprintln!("  level  blocks | facing mean/max: surface   volume   | all-axes mean/max: surface   volume");
    for (s, v) in surface.iter().zip(volume) {
        eprintln!(
            "  {:>5} {:>7} |        {:.3}/{:.3}  {:.3}/{:.3} |            {:.3}/{:.3}  {:.3}/{:.3}",
            s.level,
            s.blocks,
            s.facing_mean,
            s.facing_max,
            v.facing_mean,
            v.facing_max,
            s.all_axes_mean,
            s.all_axes_max,
            v.all_axes_mean,
            v.all_axes_max
        );
    }
}

#[test]
fn surface_coverage_keeps_slabs_and_tilted_planes_opaque() {
    let n = 32;
    let mut cases = vec![];
    for axis in 0..3u8 {
        for offset in [0, 5, 16, 31] {
            cases.push((
                format!("slab axis {axis} offset {offset}"),
                Pattern::Slab { axis, offset },
                0,
            ));
        }
    }
    for seed in 0..4 {
        cases.push((
            format!("tilted plane seed {seed}"),
            Pattern::TiltedPlane,
            seed,
        ));
    }
    for (name, pattern, seed) in cases {
        let grid = generate(n, pattern, seed);
        let s = coverage_error(&grid, Coverage::Surface);
        let v = coverage_error(&grid, Coverage::Volume);
        table(&name, &s, &v);
        for (sl, vl) in s.iter().zip(&v) {
            assert!(
                sl.facing_mean < vl.facing_mean,
                "{name} level {}: surface {sl:?} vs volume {vl:?}",
                sl.level
            );
        }
        if matches!(pattern, Pattern::Slab { .. }) {
            // Exact for an axis-aligned slab: every coarse block it touches stays fully opaque.
            assert!(s.iter().all(|l| l.facing_max == 0.0), "{name}: {s:?}");
            // Volume coverage fades as 1 / 2^level: error 1 - 2^-level.
            for l in &v {
                assert!(
                    (l.facing_mean - (1.0 - 0.5f32.powi(l.level as i32))).abs() < 1e-6,
                    "{name}: {l:?}"
                );
            }
        }
    }
}
