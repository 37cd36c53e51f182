//! Mirror of `kernels/occlusion_voxels.wgsl`: LRSM's binary occlusion voxels and their mips (Sugihara
//! et al. 2014, sections 3.2 and 5), no atomics.
//!
//! Layout, voxels in 3D Morton order, each level its own buffer of u32 words, padded to at least 8
//! words (padding is 0):
//!
//! * Level 0 is binary: one bit per voxel, word `w` bit `k` = voxel `32w + k` (voxelize's `occupancy_bits` entry
//!   writes it: [`crate::voxelize::occupancy`]). The paper stores a byte per voxel (Table 2: 156.4 MB at
//!   512^3 with the mips); a bit holds the same binary value in an eighth of the memory, so that 512^3
//!   (16 MiB at level 0, 34 MiB with the mips) fits one storage binding of any WebGPU device (128 MiB).
//! * Levels k >= 1 hold a byte per voxel, four per word: word `w` byte `b` = voxel `4w + b`. The eight
//!   children of parent voxel P are voxels 8P .. 8P + 8 of the level below: byte `P mod 4` of bit word
//!   `P / 4` at level 0 (so a level-1 word q reads bit word q alone), words 2P and 2P + 1 above it.
//!
//! * Level 1 (`reduce_bits`) and level k >= 2 (`reduce`): byte = (sum of the 8 child bytes + 4) >> 3
//!   (a solid level-0 voxel counts 255), the children's mean rounded half up: the fraction of the block
//!   that is solid (volume coverage, the paper's mipmapped occlusion), in integers: GPU and mirror
//!   agree bit for bit. Each level rounds once, so a byte of level k is within k/2 of 255 x the exact
//!   fraction of solid leaves under it.
//! * Or (`reduce_bits_surface`, `reduce_surface`, [`Coverage::Surface`], an option of the lrsm
//!   pipeline): byte = min(255, (sum + 2) >> 2), a quarter of the children's sum rounded half up and
//!   capped: CPRC's surface coverage (`surface_coverage_mip`) in bytes: four solid children of eight (a
//!   plane through the block) stay opaque, so a one-voxel wall occludes at every level where volume
//!   coverage halves it per level.
//!
//! Occlusion of a voxel: `alpha = level_byte / 255` (level 0: 0 or 255).
use crate::ftz;
pub use crate::surface_coverage_mip::Coverage;
pub use crate::voxelize::occupancy_words;

/// Words of level `k` of a grid of side `side`: bits at level 0, bytes above (padded to 8).
pub fn level_words(side: u32, k: u32) -> usize {
    let voxels = ((side >> k) as u64).pow(3);
    if k == 0 {
        occupancy_words(voxels)
    } else {
        (voxels.div_ceil(4) as usize).max(8)
    }
}

/// Level 0 of a voxelized (colour, alpha) grid: the bit of every voxel whose alpha is > 0 (a NaN or,
/// flushed, a subnormal alpha is empty). Voxelize's `occupancy_bits` writes the same bits from the
/// triangles (a voxel is non-empty when a sample lands in it, and then its alpha is 1).
pub fn binarize(colour: &[[f32; 4]], flush: bool) -> Vec<u32> {
    let mut words = vec![0u32; occupancy_words(colour.len() as u64)];
    for (v, c) in colour.iter().enumerate() {
        if ftz(c[3], flush) > 0.0 {
            words[v / 32] |= 1 << (v % 32);
        }
    }
    words
}

/// The byte (0..=255) of voxel `v` in level `k`'s words: 255 x its bit at level 0.
pub fn level_byte(words: &[u32], k: u32, v: usize) -> u32 {
    if k == 0 {
        ((words[v / 32] >> (v % 32)) & 1) * 255
    } else {
        (words[v / 4] >> (8 * (v % 4))) & 255
    }
}

/// The parent byte of eight children summing to `sum` (of bytes), by `coverage`'s rule.
fn parent_byte(sum: u32, coverage: Coverage) -> u32 {
    match coverage {
        Coverage::Volume => (sum + 4) >> 3,
        Coverage::Surface => ((sum + 2) >> 2).min(255),
    }
}

/// Level 1 from level 0's bits (`dst_words` words: [`level_words`] of level 1).
pub fn reduce_bits(src: &[u32], dst_words: usize, coverage: Coverage) -> Vec<u32> {
    (0..dst_words)
        .map(|q| {
            let bits = src.get(q).copied().unwrap_or(0);
            (0..4).fold(0u32, |word, k| {
                let sum = 255 * ((bits >> (8 * k)) & 255).count_ones();
                word | (parent_byte(sum, coverage) << (8 * k))
            })
        })
        .collect()
}

/// Level k >= 2 from level k - 1's bytes (`dst_words` words: [`level_words`] of level k).
pub fn reduce(src: &[u32], dst_words: usize, coverage: Coverage) -> Vec<u32> {
    let mut dst = vec![0u32; dst_words];
    for (q, word) in dst.iter_mut().enumerate() {
        for k in 0..4 {
            let parent = 4 * q + k;
            let mut sum = 0u32;
            for h in 0..2 {
                let c = 2 * parent + h;
                let w = src.get(c).copied().unwrap_or(0);
                sum += (w & 255) + ((w >> 8) & 255) + ((w >> 16) & 255) + (w >> 24);
            }
            *word |= parent_byte(sum, coverage) << (8 * k);
        }
    }
    dst
}

/// Every level of a grid of side `side` (a power of two >= 2) from its level-0 bits: level 0 ..
/// log2(side).
pub fn pyramid_of_bits(bits: Vec<u32>, side: u32, coverage: Coverage) -> Vec<Vec<u32>> {
    let mut levels = vec![bits];
    for k in 1..=side.trailing_zeros() {
        let src = levels.last().expect("level 0");
        let next = if k == 1 {
            reduce_bits(src, level_words(side, 1), coverage)
        } else {
            reduce(src, level_words(side, k), coverage)
        };
        levels.push(next);
    }
    levels
}

/// Every level of a voxelized grid of side `side` ([`binarize`], then [`pyramid_of_bits`]).
pub fn pyramid(colour: &[[f32; 4]], side: u32, flush: bool, coverage: Coverage) -> Vec<Vec<u32>> {
    pyramid_of_bits(binarize(colour, flush), side, coverage)
}

/// Bytes of the whole pyramid (the memory the pipeline holds for occlusion).
pub fn pyramid_bytes(side: u32) -> u64 {
    (0..=side.trailing_zeros())
        .map(|k| 4 * level_words(side, k) as u64)
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::morton;

    #[test]
    fn a_half_solid_block_is_half_occluding_at_every_level() {
        // Solid below z = side / 2: every block of every level but the top is all or nothing, the top
        // is exactly half (8 children: 4 x 255 + 4 x 0 -> (1020 + 4) >> 3 = 128).
        let side = 8u32;
        let colour: Vec<[f32; 4]> = (0..512u32)
            .map(|m| {
                let [_, _, z] = morton::decode(m);
                [0.0, 0.0, 0.0, if z < side / 2 { 1.0 } else { 0.0 }]
            })
            .collect();
        let levels = pyramid(&colour, side, false, Coverage::Volume);
        assert_eq!(levels.len(), 4);
        assert_eq!(level_byte(&levels[3], 3, 0), 128);
        for m in 0..8u32 {
            let [_, _, z] = morton::decode(m);
            assert_eq!(
                level_byte(&levels[2], 2, m as usize),
                if z < 1 { 255 } else { 0 }
            );
        }
    }

    #[test]
    fn surface_coverage_keeps_a_one_voxel_wall_opaque_at_every_level() {
        // A wall one voxel thick (x = 0) through the whole grid: volume coverage halves it per level
        // (255 -> 128 -> 64 -> 32), surface coverage (a quarter of the children's sum, capped) keeps it
        // 255; a single solid voxel is 1/8 of its parent by volume (32) and 1/4 by surface (64).
        let side = 8u32;
        let wall: Vec<[f32; 4]> = (0..512u32)
            .map(|m| {
                [
                    0.0,
                    0.0,
                    0.0,
                    if morton::decode(m)[0] == 0 { 1.0 } else { 0.0 },
                ]
            })
            .collect();
        let volume = pyramid(&wall, side, false, Coverage::Volume);
        let surface = pyramid(&wall, side, false, Coverage::Surface);
        for k in 1..=3 {
            assert_eq!(level_byte(&volume[k], k as u32, 0), [255, 128, 64, 32][k]);
            assert_eq!(level_byte(&surface[k], k as u32, 0), 255);
        }
        let mut one = vec![[0.0f32; 4]; 512];
        one[0][3] = 1.0;
        assert_eq!(
            level_byte(&pyramid(&one, side, false, Coverage::Volume)[1], 1, 0),
            32
        );
        assert_eq!(
            level_byte(&pyramid(&one, side, false, Coverage::Surface)[1], 1, 0),
            64
        );
    }

    #[test]
    fn subnormal_and_nan_alphas() {
        let colour = [
            [0.0, 0.0, 0.0, f32::from_bits(1)],
            [0.0, 0.0, 0.0, f32::NAN],
            [0.0, 0.0, 0.0, -1.0],
            [0.0, 0.0, 0.0, 1e-30],
        ];
        assert_eq!(binarize(&colour, false)[0], 1 | (1 << 3));
        assert_eq!(binarize(&colour, true)[0], 1 << 3);
    }

    #[test]
    fn level_one_from_bits_equals_level_one_from_bytes() {
        // The byte layout the paper describes (255 per solid voxel) reduced by `reduce` gives the same
        // level 1 as the bits reduced by `reduce_bits`, for both rules.
        let side = 16u32;
        let voxels = side.pow(3) as usize;
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let colour: Vec<[f32; 4]> = (0..voxels)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                [
                    0.0,
                    0.0,
                    0.0,
                    if state.is_multiple_of(3) { 1.0 } else { 0.0 },
                ]
            })
            .collect();
        let mut bytes = vec![0u32; voxels / 4];
        for (v, c) in colour.iter().enumerate() {
            if c[3] > 0.0 {
                bytes[v / 4] |= 255 << (8 * (v % 4));
            }
        }
        let bits = binarize(&colour, false);
        for coverage in [Coverage::Volume, Coverage::Surface] {
            let words = level_words(side, 1);
            assert_eq!(
                reduce_bits(&bits, words, coverage),
                reduce(&bytes, words, coverage)
            );
        }
        for v in 0..voxels {
            assert_eq!(
                level_byte(&bits, 0, v),
                (bytes[v / 4] >> (8 * (v % 4))) & 255
            );
        }
    }
}
