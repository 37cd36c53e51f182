//! GPU vs mirror for `kernels/occlusion_voxels.wgsl`: every mip level bit for bit on generated grids
//! (every family, sides 2..128, random seeds through proptest, both coverage rules); each level's byte
//! against the exact solid fraction of the leaves under it (volume coverage); one-voxel walls opaque
//! at every level (surface coverage); the memory against the paper's Table 2; a 512^3 grid.
use crate::common::{case_passes, gpu};
use proptest::prelude::*;
use vxgi::grids::{generate, Pattern};
use vxgi::kernels::occlusion_voxels::{case_for, occlusion_on_gpu, OcclusionVoxels, DECL};
use vxgi_cpu_mirror::morton;
use vxgi_cpu_mirror::occlusion_voxels::{binarize, level_byte, pyramid, pyramid_bytes, Coverage};

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// Random sides, families, seeds and coverage rules: GPU == mirror on every level.
    #[test]
    fn random_grids(log_n in 1u32..=6, family in 0usize..64, seed in any::<u64>(), surface in any::<bool>()) {
        let n = 1u32 << log_n;
        let grid = generate(n, Pattern::family(family, n), seed);
        let shader = DECL.shader().unwrap();
        let coverage = if surface { Coverage::Surface } else { Coverage::Volume };
        let case = case_for(&shader, gpu(), &binarize(&grid.colour, false), n, coverage, format!("{n}^3 family {family} {coverage:?}"), seed);
        case_passes(&shader, &OcclusionVoxels, &case)?;
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
        let levels =
            occlusion_on_gpu(gpu(), &binarize(&grid.colour, false), n, Coverage::Volume).unwrap();
        assert_eq!(levels, pyramid(&grid.colour, n, false, Coverage::Volume));
        for (k, words) in levels.iter().enumerate() {
            for m in 0..(n >> k).pow(3) {
                let [x, y, z] = morton::decode(m);
                let b = 1u32 << k;
                let solid: u32 = (0..b.pow(3))
                    .map(|d| morton::encode(x * b + d % b, y * b + d / b % b, z * b + d / b / b))
                    .map(|leaf| u32::from(grid.colour[leaf as usize][3] > 0.0))
                    .sum();
                let exact = 255.0 * solid as f64 / (b as f64).powi(3);
                let got = level_byte(words, k as u32, m as usize) as f64;
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
            .map(|m| [0.0, 0.0, 0.0, (morton::decode(m)[axis] == at) as u8 as f32])
            .collect();
        let bits = binarize(&colour, false);
        let surface = occlusion_on_gpu(gpu(), &bits, n, Coverage::Surface).unwrap();
        let volume = occlusion_on_gpu(gpu(), &bits, n, Coverage::Volume).unwrap();
        assert_eq!(surface, pyramid(&colour, n, false, Coverage::Surface));
        for k in 0..=n.trailing_zeros() as usize {
            for m in 0..(n >> k).pow(3) {
                let holds = morton::decode(m)[axis] == at >> k;
                let byte = |levels: &[Vec<u32>]| level_byte(&levels[k], k as u32, m as usize);
                let (s, v) = (byte(&surface), byte(&volume));
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

/// LRSM Table 2 gives 19.2 MB at 256^3 and 156.4 MB at 512^3: a byte per voxel plus the mips (256^3
/// x 8/7 = 19.17e6; 153.4e6 at 512^3, the table's other 3 MB unexplained). Level 0 here is a bit
/// per voxel (binary, the same values), the mips above it bytes: 256^3 / 8 + 256^3 / 7 = 4.49e6 at
/// 256^3, 35.9e6 at 512^3, within one 128 MiB binding.
#[test]
fn memory_against_the_papers_table_2() {
    let mb = |side: u32| pyramid_bytes(side) as f64 / 1e6;
    let expected = |side: u32| (side as f64).powi(3) * (1.0 / 8.0 + 1.0 / 7.0) / 1e6;
    for side in [256, 512] {
        assert!(
            (mb(side) - expected(side)).abs() < 0.01,
            "{side}: {}",
            mb(side)
        );
    }
    assert!(pyramid_bytes(512) <= 128 << 20);
}

/// The 512^3 pyramid the lrsm pipeline builds at `voxels = 512`, every level GPU vs mirror on a grid
/// with walls, a sphere shell and random voxels: 16 MiB of bits at level 0, 18 MiB of mips.
#[test]
fn a_512_cubed_pyramid_matches_the_mirror() {
    let n = 512u32;
    let words = vxgi_cpu_mirror::occlusion_voxels::level_words(n, 0);
    let mut bits = vec![0u32; words];
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    for m in 0..n.pow(3) {
        let [x, y, z] = morton::decode(m);
        let (dx, dy, dz) = (x as f64 - 256.0, y as f64 - 200.0, z as f64 - 300.0);
        let r = (dx * dx + dy * dy + dz * dz).sqrt();
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let solid = x == 17 || y == 400 || (r - 150.0).abs() < 1.0 || state.is_multiple_of(997);
        if solid {
            bits[m as usize / 32] |= 1 << (m % 32);
        }
    }
    for coverage in [Coverage::Volume, Coverage::Surface] {
        let gpu_levels = occlusion_on_gpu(gpu(), &bits, n, coverage).unwrap();
        let mirror = vxgi_cpu_mirror::occlusion_voxels::pyramid_of_bits(bits.clone(), n, coverage);
        assert_eq!(gpu_levels.len(), 10);
        for (k, (g, m)) in gpu_levels.iter().zip(&mirror).enumerate() {
            assert!(g == m, "{coverage:?} level {k} differs");
        }
    }
}
