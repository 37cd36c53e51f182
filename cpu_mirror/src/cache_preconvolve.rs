//! Mirror of `kernels/cache_preconvolve.wgsl`: CPRC 3.1 / PCRC pre-convolution of each radiance cache
//! (texels from `cache_creation`, `res x res` hemi-octahedral, row-major).
//!
//! - `mips`: the cache's mip chain, levels l = 0..levels of side res >> l concatenated (level l at
//!   [`mip_offset`]); a level-l texel is the plain mean of the 2^l x 2^l block of level-0 texels it
//!   covers, summed row by row, left to right, then scaled by 4^-l (a power of two: exact). Level 0 is
//!   the texels themselves. Box filtering like a texture's mips (the texels' solid angles differ by up
//!   to ~2.6x; a glossy lookup averages neighbours of similar size).
//! - `irradiance`: the cosine-folded level, an `irr x irr` hemi-octahedral map of
//!   E(w_k) = sum_t L_t max(0, w_k . w_t) dw_t over the cache's texels t (in index order), with the
//!   weights max(0, w_k . w_t) dw_t a host table (f64, [`irradiance_weights`]) so the kernel only
//!   multiplies and adds. A Lambertian pixel then reflects albedo / pi * E(n).
use crate::cache_creation::texel_directions;
use crate::ftz;
use bytemuck::{Pod, Zeroable};

/// The kernel's uniform block (`struct PreconvolveParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PreconvolveParams {
    pub count: u32,
    /// Cache side in texels (a power of two).
    pub res: u32,
    /// Mip levels: log2(res) + 1.
    pub levels: u32,
    /// Texels of the irradiance map (irr^2).
    pub irr_texels: u32,
}

/// Offset of mip level `l` inside one cache's chain.
pub fn mip_offset(res: u32, l: u32) -> usize {
    (0..l).map(|j| ((res >> j) * (res >> j)) as usize).sum()
}

/// Texels in one cache's whole chain.
pub fn mip_len(res: u32) -> usize {
    mip_offset(res, res.trailing_zeros() + 1)
}

/// Texel `j` (0..mip_len) of the chain of one cache whose level-0 texels are `tex`, in the kernel's
/// operation order; `flush`: subnormals flushed on inputs and every partial result.
pub fn mip_texel(tex: &[[f32; 4]], res: u32, j: usize, flush: bool) -> [f32; 4] {
    let mut l = 0;
    while j >= mip_offset(res, l + 1) {
        l += 1;
    }
    let side = (res >> l) as usize;
    let k = j - mip_offset(res, l);
    let (x, y) = (k % side, k / side);
    let b = 1usize << l;
    let mut acc = [0.0f32; 4];
    for by in 0..b {
        for bx in 0..b {
            let v = tex[(y * b + by) * res as usize + x * b + bx];
            for c in 0..4 {
                acc[c] = ftz(acc[c] + ftz(v[c], flush), flush);
            }
        }
    }
    let scale = 1.0 / (b * b) as f32;
    acc.map(|a| ftz(a * scale, flush))
}

/// Host table: weight[k * res^2 + t] = max(0, w_k . w_t) dw_t, w_k the irradiance map's texel
/// directions (irr x irr), w_t and dw_t the cache's ([`texel_directions`]); f64, rounded once.
pub fn irradiance_weights(res: u32, irr: u32) -> Vec<f32> {
    let tex = texel_directions(res);
    let dirs = texel_directions(irr);
    let mut w = Vec::with_capacity(tex.len() * dirs.len());
    for k in &dirs {
        for t in &tex {
            let c =
                k[0] as f64 * t[0] as f64 + k[1] as f64 * t[1] as f64 + k[2] as f64 * t[2] as f64;
            w.push((c.max(0.0) * t[3] as f64) as f32);
        }
    }
    w
}

/// Irradiance texel `k` of one cache: `sum_t L_t W[k][t]` in t order, and its bound: each of the n
/// steps rounds once (fused or not, <= 1/2 ULP of its partial sum and of its product), so
/// |error| <= (n + 1) u sum |L_t| W, u = 2^-24; doubled. Subnormal products (FTZ GPUs) are below it.
pub fn irradiance_texel(tex: &[[f32; 4]], weights: &[f32], k: usize) -> ([f32; 4], [f32; 4]) {
    let n = tex.len();
    let row = &weights[k * n..(k + 1) * n];
    let mut acc = [0.0f32; 4];
    let mut mag = [0.0f32; 4];
    for (v, &w) in tex.iter().zip(row) {
        for c in 0..3 {
            acc[c] += v[c] * w;
            mag[c] += (v[c] * w).abs();
        }
    }
    let u = f32::EPSILON / 2.0;
    let b = mag.map(|m| 2.0 * (n as f32 + 1.0) * (u * m + f32::MIN_POSITIVE));
    ([acc[0], acc[1], acc[2], 0.0], [b[0], b[1], b[2], 0.0])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_cache_has_constant_mips_and_cosine_irradiance() {
        let res = 8;
        let tex = vec![[2.0f32, 1.0, 0.5, 0.0]; (res * res) as usize];
        for j in 0..mip_len(res) {
            assert_eq!(mip_texel(&tex, res, j, false), [2.0, 1.0, 0.5, 0.0]);
        }
        let w = irradiance_weights(res, 4);
        // Straight up (the centre texels of a 4 x 4 map lean 20 deg off it): E = L pi cos-ish.
        let (e, _) = irradiance_texel(&tex, &w, 5);
        assert!(e[0] > 2.0 * 2.5 && e[0] < 2.0 * 3.3, "{e:?}");
    }

    #[test]
    fn offsets() {
        assert_eq!(mip_offset(16, 0), 0);
        assert_eq!(mip_offset(16, 1), 256);
        assert_eq!(mip_len(16), 256 + 64 + 16 + 4 + 1);
        assert_eq!(mip_len(1), 1);
    }
}
