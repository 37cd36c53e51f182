//! Mirror of `kernels/voxelize.wgsl`: surface-sampling voxelization (CPRC 3.1, "Voxelization": sample
//! all surfaces uniformly, write each sample to its cell, average albedo and normal per cell, list the
//! non-empty cells), in integer arithmetic so GPU and mirror agree exactly whatever the order of the
//! atomic additions.
//!
//! Host preparation (`vxgi::kernels::voxelize::prepare`): vertices on a lattice of 1/256 voxel
//! (`q = round((p - origin) / voxel * 256)`, clamped to the grid), albedo and vertex normals in fixed
//! point (x 4096), and per triangle the sample count `n = 2 * ceil(longest edge in voxels) + 1`, so
//! neighbouring samples are at most half a voxel apart.
//!
//! Samples: `P(i, j) = A + ((B - A) i + (C - A) j) / n` for `i + j <= n` (i32, division truncating
//! toward zero, as in WGSL); voxel `P >> 8`. Normal of a sample: `(na (n - i - j) + nb i + nc j) / n`.
//! Per voxel (Morton index) the sums of albedo, normal and the sample count are accumulated; then
//! `colour = (sum_albedo / count / 4096, 1)`, `normal = (sum_normal / count / 4096, 0)` (the mean normal,
//! not renormalised: the mip kernel's convention) and the voxel joins the list.
//!
//! Textured triangles (`texture.y = W > 0`: a `map_Kd` of W x H texels at `texture.x` in the atlas)
//! take each sample's albedo from the texture: texture coordinates in fixed point (1/16 texel,
//! `U = round(u W 16)`, `V = round(-v H 16)` so that rows run down the image, each triangle's shifted
//! by whole texture repeats to start near 0) interpolate like positions, `Us = Ua + ((Ub - Ua) i +
//! (Uc - Ua) j) / n`; the texel is column `(Us >> 4) mod W`, row `(Vs >> 4) mod H` (nearest,
//! repeating), its packed sRGB8 channels mapped through `lut` (linear x 4096, rounded, on the host).
use crate::morton;
use bytemuck::{Pod, Zeroable};

/// Fixed-point scale of albedo and normals.
pub const FIXED: f32 = 4096.0;
/// Lattice steps per voxel.
pub const SUB: i32 = 256;

/// One triangle prepared for voxelization (the WGSL `VoxTriangle`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VoxTriangle {
    /// Lattice vertices; a.w = sample count n.
    pub a: [i32; 4],
    pub b: [i32; 4],
    pub c: [i32; 4],
    /// Fixed-point vertex normals.
    pub na: [i32; 4],
    pub nb: [i32; 4],
    pub nc: [i32; 4],
    /// Fixed-point albedo (rgb), w unused.
    pub albedo: [u32; 4],
    /// Fixed-point texture coordinates (Ua, Va, Ub, Vb) and (Uc, Vc, 0, 0).
    pub uv_ab: [i32; 4],
    pub uv_c: [i32; 4],
    /// (first atlas texel, width, height, 0); width 0: `albedo` for every sample.
    pub texture: [u32; 4],
}

/// The kernel's inputs besides the grid: triangles, the texture atlas (packed sRGB8
/// `r | g << 8 | b << 16`) and the sRGB-to-fixed-point table.
#[derive(Clone, Debug, Default)]
pub struct VoxInput {
    pub tris: Vec<VoxTriangle>,
    pub texels: Vec<u32>,
    pub lut: Vec<u32>,
}

/// Accumulators of one voxel (the WGSL keeps 8 u32 per voxel; normals wrap as two's complement).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Acc {
    pub albedo: [u32; 3],
    pub normal: [i32; 3],
    pub count: u32,
}

/// The sample (lattice point and fixed-point normal) of row `i`, column `j` of a triangle.
pub fn sample(t: &VoxTriangle, i: i32, j: i32) -> ([i32; 3], [i32; 3]) {
    let n = t.a[3];
    let mut p = [0; 3];
    let mut nrm = [0; 3];
    for k in 0..3 {
        p[k] = t.a[k] + ((t.b[k] - t.a[k]) * i + (t.c[k] - t.a[k]) * j) / n;
        nrm[k] = (t.na[k] * (n - i - j) + t.nb[k] * i + t.nc[k] * j) / n;
    }
    (p, nrm)
}

/// Fixed-point albedo of sample (i, j): the triangle's, or its texture's texel.
pub fn sample_albedo(t: &VoxTriangle, texels: &[u32], lut: &[u32], i: i32, j: i32) -> [u32; 3] {
    let [offset, w, h, _] = t.texture;
    if w == 0 || h == 0 {
        return [t.albedo[0], t.albedo[1], t.albedo[2]];
    }
    let n = t.a[3];
    let at = |a: i32, b: i32, c: i32| a + ((b - a) * i + (c - a) * j) / n;
    let us = at(t.uv_ab[0], t.uv_ab[2], t.uv_c[0]);
    let vs = at(t.uv_ab[1], t.uv_ab[3], t.uv_c[1]);
    let x = (us >> 4).rem_euclid(w as i32) as u32;
    let y = (vs >> 4).rem_euclid(h as i32) as u32;
    let texel = texels[(offset + y * w + x) as usize];
    [0, 8, 16].map(|s| lut[((texel >> s) & 255) as usize])
}

/// The surface samples (voxel fragments) the kernel's passes take of `tris`: rows `i` in `0..=n`,
/// columns `j` in `0..=n - i` of each triangle, (n + 1)(n + 2) / 2 for its `n` = `a.w`.
pub fn sample_count(tris: &[VoxTriangle]) -> u64 {
    tris.iter()
        .map(|t| {
            let n = t.a[3].max(0) as u64;
            (n + 1) * (n + 2) / 2
        })
        .sum()
}

/// Accumulate every sample of every triangle into a grid of side `side` (Morton order).
pub fn accumulate(tris: &[VoxTriangle], texels: &[u32], lut: &[u32], side: u32) -> Vec<Acc> {
    let mut acc = vec![Acc::default(); (side as usize).pow(3)];
    for t in tris {
        let n = t.a[3];
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (p, nrm) = sample(t, i, j);
                let albedo = sample_albedo(t, texels, lut, i, j);
                let v = p.map(|c| (c / SUB).clamp(0, side as i32 - 1) as u32);
                let a = &mut acc[morton::encode(v[0], v[1], v[2]) as usize];
                for (k, n) in nrm.iter().enumerate() {
                    a.albedo[k] = a.albedo[k].wrapping_add(albedo[k]);
                    a.normal[k] = a.normal[k].wrapping_add(*n);
                }
                a.count += 1;
            }
        }
    }
    acc
}

/// Words of the occupancy bits of `voxels` voxels: one bit per voxel, word `w` bit `k` = voxel
/// `32w + k` (Morton order), at least 8 words (the occlusion pyramid's padding).
pub fn occupancy_words(voxels: u64) -> usize {
    (voxels.div_ceil(32) as usize).max(8)
}

/// The voxels (Morton indices, ascending) whose bits are set in `bits`, of a grid of `voxels`.
pub fn occupied(bits: &[u32], voxels: u64) -> impl Iterator<Item = u32> + '_ {
    bits.iter()
        .enumerate()
        .flat_map(|(w, &b)| {
            (0..32u64)
                .filter(move |k| b >> k & 1 == 1)
                .map(move |k| w as u64 * 32 + k)
        })
        .take_while(move |&m| m < voxels)
        .map(|m| m as u32)
}

/// Entry `occupancy_bits`: the bit of every voxel a sample lands in (the voxels `accumulate` counts), for
/// a grid of side `side`. The same samples as [`accumulate`], no albedo or normal: binary occlusion
/// voxels at an eighth of a byte per voxel, where the accumulators take 32 bytes.
pub fn occupancy(tris: &[VoxTriangle], side: u32) -> Vec<u32> {
    let mut bits = vec![0u32; occupancy_words((side as u64).pow(3))];
    for t in tris {
        let n = t.a[3];
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (p, _) = sample(t, i, j);
                let v = p.map(|c| (c / SUB).clamp(0, side as i32 - 1) as u32);
                let m = morton::encode(v[0], v[1], v[2]) as usize;
                bits[m / 32] |= 1 << (m % 32);
            }
        }
    }
    bits
}

/// Colour (albedo, alpha) and mean normal of one voxel.
pub fn resolve(a: &Acc) -> ([f32; 4], [f32; 4]) {
    if a.count == 0 {
        return ([0.0; 4], [0.0; 4]);
    }
    let c = a.count as f32;
    let s = 1.0 / FIXED;
    (
        [
            a.albedo[0] as f32 / c * s,
            a.albedo[1] as f32 / c * s,
            a.albedo[2] as f32 / c * s,
            1.0,
        ],
        [
            a.normal[0] as f32 / c * s,
            a.normal[1] as f32 / c * s,
            a.normal[2] as f32 / c * s,
            0.0,
        ],
    )
}

/// The whole kernel: colour and normal grids (Morton order) and the sorted list of non-empty voxels.
pub fn voxelize(input: &VoxInput, side: u32) -> (Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<u32>) {
    resolve_grid(&accumulate(&input.tris, &input.texels, &input.lut, side))
}

/// Every voxel's accumulators resolved: the colour and normal grids (the accumulators' order) and
/// the sorted list of the voxels any sample landed in.
pub fn resolve_grid(acc: &[Acc]) -> (Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<u32>) {
    let mut colour = Vec::with_capacity(acc.len());
    let mut normal = Vec::with_capacity(acc.len());
    let mut list = Vec::new();
    for (v, a) in acc.iter().enumerate() {
        let (c, n) = resolve(a);
        colour.push(c);
        normal.push(n);
        if a.count > 0 {
            list.push(v as u32);
        }
    }
    (colour, normal, list)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles across an 8^3 grid, one clamped at the far corner.
    fn two_triangles() -> [VoxTriangle; 2] {
        let v = |x: i32, y: i32, z: i32, w: i32| [x, y, z, w];
        let tri = |a: [i32; 4], b, c| VoxTriangle {
            a,
            b,
            c,
            ..Default::default()
        };
        [
            tri(
                v(0, 0, 0, 17),
                v(8 * SUB - 1, 0, 0, 0),
                v(0, 5 * SUB, 3 * SUB, 0),
            ),
            tri(
                v(7 * SUB, 7 * SUB, 7 * SUB, 3),
                v(9 * SUB, 7 * SUB, 7 * SUB, 0),
                v(7 * SUB, 9 * SUB, 8 * SUB, 0),
            ),
        ]
    }

    #[test]
    fn sample_count_is_what_accumulate_counts() {
        let tris = two_triangles();
        let acc = accumulate(&tris, &[], &[], 8);
        let counted: u64 = acc.iter().map(|a| a.count as u64).sum();
        assert_eq!(sample_count(&tris), counted);
        assert!(counted > 0);
    }

    #[test]
    fn occupancy_sets_the_bits_of_the_voxels_the_samples_count() {
        let tris = two_triangles();
        let side = 8;
        let acc = accumulate(&tris, &[], &[], side);
        let bits = occupancy(&tris, side);
        assert_eq!(bits.len(), 16);
        for (m, a) in acc.iter().enumerate() {
            assert_eq!(
                (bits[m / 32] >> (m % 32)) & 1 == 1,
                a.count > 0,
                "voxel {m}"
            );
        }
        assert!(acc.iter().filter(|a| a.count > 0).count() > 8);
    }
}
