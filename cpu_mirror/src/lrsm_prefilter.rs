//! Mirror of `kernels/lrsm_prefilter.wgsl`: one mip level of every LRSM layer at once (LRSM section 4.2,
//! "pre-filter the RSM attributes by using the GPU to generate a mipmap chain", box filter).
//!
//! A level holds `layers` square layers of side `s`, layer-major, each in 2D Morton order, so the four
//! children of parent `P` (any layer) are `4P .. 4P+4` of the finer level. Three streams, all
//! opacity-weighted so that a box filter is the right filter and empty texels cancel (Table 1):
//! `radiance = (A R, A)`, `normal = (A n, A)`, `moments = (A z, A z^2, A, 0)`.
//! Parent = `(c0 + c1 + c2 + c3) * 0.25`, summed left to right: correctly rounded adds and an exact
//! scaling, then stored as binary16.
//!
//! Storage (common/lrsm_texel.wgsl): a texel of a stream is two u32 words of two binary16 values each
//! (`pack2x16float`; x, y in the first word, z, w in the second), values clamped to binary16's finite
//! range first, as the paper's Table 1 stores 16-bit channels: 24 bytes a texel over the three
//! streams. Here a stream is held as the f32 values those halves decode to (exactly); [`quantize`]
//! rounds to nearest, where a GPU may take either neighbour (1 binary16 ULP: the declarations'
//! `Tolerance::Half`).
use crate::ftz4;
use glam::Vec4;
use half::f16;
use rayon::prelude::*;

/// Layer streams of one level: radiance, normal, moments (each value binary16-representable).
pub type Streams = [Vec<[f32; 4]>; 3];

/// The largest finite binary16, to which a stored value is clamped (radiance only can exceed it).
pub const HALF_MAX: f32 = 65504.0;

/// `v` as stored: clamped to +-[`HALF_MAX`], rounded to the nearest binary16 (ties to even).
pub fn quantize(v: [f32; 4]) -> [f32; 4] {
    unpack(pack(v))
}

/// The kernel's `lrsm_pack`: a texel as two `pack2x16float` words.
pub fn pack(v: [f32; 4]) -> [u32; 2] {
    let h = v.map(|x| f16::from_f32(x.clamp(-HALF_MAX, HALF_MAX)).to_bits() as u32);
    [h[0] | (h[1] << 16), h[2] | (h[3] << 16)]
}

/// The kernel's `lrsm_unpack` (exact).
pub fn unpack(w: [u32; 2]) -> [f32; 4] {
    let h = |x: u32| f16::from_bits(x as u16).to_f32();
    [h(w[0]), h(w[0] >> 16), h(w[1]), h(w[1] >> 16)]
}

/// A stream as the GPU stores it (lossless for quantized values).
pub fn pack_stream(s: &[[f32; 4]]) -> Vec<[u32; 2]> {
    s.iter().map(|&v| pack(v)).collect()
}

/// A stored stream's values.
pub fn unpack_stream(s: &[[u32; 2]]) -> Vec<[f32; 4]> {
    s.iter().map(|&w| unpack(w)).collect()
}

/// One parent from its four children, in the kernel's operation order, as stored.
#[inline]
pub fn box4(children: &[[f32; 4]], flush: bool) -> [f32; 4] {
    let mut s = ftz4(Vec4::from(children[0]), flush);
    for c in &children[1..4] {
        s = ftz4(s + ftz4(Vec4::from(*c), flush), flush);
    }
    quantize(ftz4(s * 0.25, flush).into())
}

/// The next coarser level of one stream (length a multiple of 4).
pub fn reduce_stream(src: &[[f32; 4]], flush: bool) -> Vec<[f32; 4]> {
    assert_eq!(
        src.len() % 4,
        0,
        "a level of power-of-two layers holds a multiple of 4 texels per layer"
    );
    src.par_chunks(4)
        .with_min_len(4096)
        .map(|c| box4(c, flush))
        .collect()
}

/// The next coarser level of all three streams.
pub fn reduce_level(src: [&[[f32; 4]]; 3], flush: bool) -> Streams {
    src.map(|s| reduce_stream(s, flush))
}

#[cfg(test)]
mod tests {
    #[test]
    fn empty_texels_cancel_after_normalising_by_opacity() {
        // Two texels of a surface at z = 0.5 with normal +z, two empty: the parent's normalised
        // moments are those of the surface, its opacity one half.
        let full = [0.5, 0.25, 1.0, 0.0];
        let p = super::box4(&[full, [0.0; 4], full, [0.0; 4]], false);
        assert_eq!(p, [0.25, 0.125, 0.5, 0.0]);
        assert_eq!((p[0] / p[2], p[1] / p[2]), (0.5, 0.25));
    }

    #[test]
    fn stored_texels_round_to_binary16_and_clamp_to_its_range() {
        use super::{pack, quantize, unpack, HALF_MAX};
        let v = [0.1, -1.0e6, 1.0e6, 3.0e-8];
        let q = quantize(v);
        assert_eq!(q[1..3], [-HALF_MAX, HALF_MAX]);
        assert!((q[0] - 0.1).abs() <= 0.1 * 2f32.powi(-11));
        assert_eq!(unpack(pack(v)), q);
        assert_eq!(pack(q), pack(v));
    }
}
