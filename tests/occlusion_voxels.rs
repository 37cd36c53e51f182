//! GPU vs mirror for `kernels/occlusion_voxels.wgsl`: every level bit for bit on generated grids (every
//! family, sides 2..128, random seeds through proptest, both coverage rules); each level's byte
//! against the exact solid fraction of the leaves under it (volume coverage); one-voxel walls opaque
//! at every level (surface coverage); and the memory the paper's Table 2 states.
use crate::common;

use common::{gpu, verified};
use proptest::prelude::*;
use vxgi::grids::{generate, Pattern};
use vxgi::harness::kernel::verify_case;
use vxgi::kernels::occlusion_voxels::{case_for, occlusion_on_gpu, OcclusionVoxels, DECL};
use vxgi_cpu_mirror::morton;
use vxgi_cpu_mirror::occlusion_voxels::{byte, pyramid, pyramid_bytes, Coverage};

#[test]
fn generated_grids_match_the_mirror_bit_for_bit() {
    let rep = verified(&OcclusionVoxels, 24, 5);
    assert_eq!(rep.max_ulp, 0);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// Random sides, families, seeds and coverage rules: GPU == mirror on every level.
    #[test]
    fn random_grids(log_n in 1u32..=6, family in 0usize..64, seed in any::<u64>(), surface in any::<bool>()) {
        let n = 1u32 << log_n;
        let grid = generate(n, Pattern::family(family, n), seed);
        let shader = DECL.shader().unwrap();
        let coverage = if surface { Coverage::Surface } else { Coverage::Volume };
        let case = case_for(&shader, gpu(), &grid, coverage, format!("{n}^3 family {family} {coverage:?}"), seed);
        let (comps, ..) = verify_case(gpu(), &shader, &OcclusionVoxels, &case, None).unwrap();
        for c in &comps {
            prop_assert!(c.passed(), "{}", c.report());
        }
    }
}

/// Each level rounds once (half up), so a byte of level k is within k/2 of 255 x the exact fraction of
/// solid leaves under it — the mips are the paper's averaged occlusion, not a max or an OR.
#[test]
fn mip_bytes_are_the_solid_fraction_of_their_leaves() {
    for (pattern, seed) in [
        (Pattern::RandomSparse { density: 0.3 }, 1),
        (Pattern::TiltedPlane, 2),
        (Pattern::Diagonal { offset: 20 }, 3),
    ] {
        let n = 32u32;
        let grid = generate(n, pattern, seed);
        let levels = occlusion_on_gpu(gpu(), &grid, Coverage::Volume).unwrap();
        assert_eq!(levels, pyramid(&grid.colour, n, false, Coverage::Volume));
        for (k, words) in levels.iter().enumerate() {
            let side = n >> k;
            for m in 0..side.pow(3) {
                let [x, y, z] = morton::decode(m);
                let b = 1u32 << k;
                let mut solid = 0u32;
                for dz in 0..b {
                    for dy in 0..b {
                        for dx in 0..b {
                            let leaf = morton::encode(x * b + dx, y * b + dy, z * b + dz);
                            solid += u32::from(grid.colour[leaf as usize][3] > 0.0);
                        }
                    }
                }
                let exact = 255.0 * solid as f64 / (b as f64).powi(3);
                let got = byte(words, m as usize) as f64;
                assert!(
                    (got - exact).abs() <= 0.5 * k as f64 + 1e-9,
                    "{pattern:?} level {k} voxel ({x},{y},{z}): byte {got}, 255 x fraction {exact}"
                );
            }
        }
    }
}

/// Surface coverage (the lrsm option `lrsm_surface_coverage`): a wall one voxel thick, along any axis
/// at any position, is opaque (255) in every block of every level that holds part of it — four of a
/// block's eight children hold the wall, a quarter of their sum is 255 — where volume coverage halves
/// it per level (within rounding: 255 / 2^k +- k/2), so cones see through it.
#[test]
fn surface_coverage_keeps_one_voxel_walls_opaque_at_every_level() {
    let n = 32u32;
    for (axis, at) in [(0usize, 0u32), (0, 13), (1, 31), (2, 6), (2, 17)] {
        let colour: Vec<[f32; 4]> = (0..n.pow(3))
            .map(|m| {
                let solid = morton::decode(m)[axis] == at;
                [0.0, 0.0, 0.0, if solid { 1.0 } else { 0.0 }]
            })
            .collect();
        let grid = vxgi::grids::Grid {
            n,
            colour,
            normal: vec![[0.0; 4]; n.pow(3) as usize],
        };
        let surface = occlusion_on_gpu(gpu(), &grid, Coverage::Surface).unwrap();
        let volume = occlusion_on_gpu(gpu(), &grid, Coverage::Volume).unwrap();
        assert_eq!(surface, pyramid(&grid.colour, n, false, Coverage::Surface));
        for k in 0..=n.trailing_zeros() as usize {
            let side = n >> k;
            for m in 0..side.pow(3) {
                let holds = morton::decode(m)[axis] == at >> k;
                let (s, v) = (byte(&surface[k], m as usize), byte(&volume[k], m as usize));
                if holds {
                    assert_eq!(s, 255, "wall {axis}={at}: level {k} block {m} surface {s}");
                    let halved = 255.0 / (1u32 << k) as f64;
                    assert!(
                        (v as f64 - halved).abs() <= 0.5 * k as f64 + 0.5,
                        "volume {v} vs {halved}"
                    );
                } else {
                    assert_eq!(
                        (s, v),
                        (0, 0),
                        "wall {axis}={at}: level {k} block {m} is empty"
                    );
                }
            }
        }
    }
}

/// One byte per voxel plus the mips (1/7 more): LRSM Table 2 gives 19.2 MB at 256^3 (= 256^3 x 8/7
/// bytes, 19.17e6: ours) and 156.4 MB at 512^3, 2% above 512^3 x 8/7 = 153.4e6 (ours; the table does
/// not say what the other 3 MB are).
#[test]
fn memory_matches_the_papers_table_2() {
    let mb = |side: u32| pyramid_bytes(side) as f64 / 1e6;
    assert!((mb(256) - 19.2).abs() < 0.05, "{}", mb(256));
    assert!((mb(512) - 153.4).abs() < 0.1, "{}", mb(512));
}
