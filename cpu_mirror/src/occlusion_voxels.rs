//! Mirror of `kernels/occlusion_voxels.wgsl`: LRSM's binary occlusion voxels and their mips (Sugihara
//! et al. 2014, sections 3.2 and 5: "1 byte per voxel", no atomics).
//!
//! Layout: one byte per voxel, four voxels per u32 word, voxels in 3D Morton order, so word `w` holds
//! voxels `4w .. 4w + 4` (byte k = voxel 4w + k, bits 8k .. 8k + 8) and the eight children of parent
//! voxel P (voxels 8P .. 8P + 8 of the level below) are words 2P and 2P + 1. Each level is its own
//! buffer of `max(voxels / 4, 8)` words (padded so that the last levels' reads stay inside it; padding
//! words are 0).
//!
//! * Level 0 (`binarize`): byte 255 where the voxelized alpha is > 0 (a NaN or, on a GPU that flushes
//!   subnormals, a subnormal alpha is empty), else 0.
//! * Level k (`reduce`): byte = (sum of the 8 child bytes + 4) >> 3, the children's mean rounded half up:
//!   the fraction of the block that is solid (volume coverage, the paper's mipmapped occlusion), in
//!   integers — GPU and mirror agree bit for bit. Each level rounds once, so a byte of level k is within
//!   k/2 of 255 x the exact fraction of solid leaves under it.
//! * Or (`reduce_surface`, [`Coverage::Surface`], an option of the lrsm pipeline): byte = min(255, (sum +
//!   2) >> 2), a quarter of the children's sum rounded half up and capped — CPRC's surface coverage
//!   (`surface_coverage_mip`) in bytes: four solid children of eight (a plane through the block) stay
//!   opaque, so a one-voxel wall occludes at every level where volume coverage halves it per level.
//!
//! Occlusion of a voxel: `alpha = byte / 255`.
use crate::ftz;
pub use crate::surface_coverage_mip::Coverage;

/// Words of a level of `voxels` voxels (padded to 8).
pub fn level_words(voxels: u64) -> usize {
    (voxels.div_ceil(4) as usize).max(8)
}

/// Level 0 from the voxelized (colour, alpha) grid: 255 where alpha > 0.
pub fn binarize(colour: &[[f32; 4]], flush: bool) -> Vec<u32> {
    let mut words = vec![0u32; level_words(colour.len() as u64)];
    for (v, c) in colour.iter().enumerate() {
        if ftz(c[3], flush) > 0.0 {
            words[v / 4] |= 255 << (8 * (v % 4));
        }
    }
    words
}

/// Byte of voxel `v` in a level's words.
pub fn byte(words: &[u32], v: usize) -> u32 {
    (words[v / 4] >> (8 * (v % 4))) & 255
}

/// Level k from level k - 1 (`dst_words` words: [`level_words`] of the parent level) by `coverage`'s
/// rule.
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
            let b = match coverage {
                Coverage::Volume => (sum + 4) >> 3,
                Coverage::Surface => ((sum + 2) >> 2).min(255),
            };
            *word |= b << (8 * k);
        }
    }
    dst
}

/// Every level of a grid of side `side` (a power of two): level 0 .. log2(side).
pub fn pyramid(colour: &[[f32; 4]], side: u32, flush: bool, coverage: Coverage) -> Vec<Vec<u32>> {
    let mut levels = vec![binarize(colour, flush)];
    for k in 1..=side.trailing_zeros() {
        let voxels = ((side >> k) as u64).pow(3);
        let next = reduce(
            levels.last().expect("level 0"),
            level_words(voxels),
            coverage,
        );
        levels.push(next);
    }
    levels
}

/// Bytes of the whole pyramid (the memory the pipeline holds for occlusion).
pub fn pyramid_bytes(side: u32) -> u64 {
    (0..=side.trailing_zeros())
        .map(|k| 4 * level_words(((side >> k) as u64).pow(3)) as u64)
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
        assert_eq!(byte(&levels[3], 0), 128);
        for m in 0..8u32 {
            let [_, _, z] = morton::decode(m);
            assert_eq!(byte(&levels[2], m as usize), if z < 1 { 255 } else { 0 });
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
            assert_eq!(byte(&volume[k], 0), [255, 128, 64, 32][k]);
            assert_eq!(byte(&surface[k], 0), 255);
        }
        let mut one = vec![[0.0f32; 4]; 512];
        one[0][3] = 1.0;
        assert_eq!(
            byte(&pyramid(&one, side, false, Coverage::Volume)[1], 0),
            32
        );
        assert_eq!(
            byte(&pyramid(&one, side, false, Coverage::Surface)[1], 0),
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
        assert_eq!(binarize(&colour, false)[0], 255 | (255 << 24));
        assert_eq!(binarize(&colour, true)[0], 255 << 24);
    }
}
