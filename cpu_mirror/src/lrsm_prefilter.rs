//! Mirror of `kernels/lrsm_prefilter.wgsl`: one mip level of every LRSM layer at once (LRSM section 4.2,
//! "pre-filter the RSM attributes by using the GPU to generate a mipmap chain", box filter).
//!
//! A level holds `layers` square layers of side `s`, layer-major, each in 2D Morton order, so the four
//! children of parent `P` (any layer) are `4P .. 4P+4` of the finer level. Three streams, all
//! opacity-weighted so that a box filter is the right filter and empty texels cancel (Table 1):
//! `radiance = (A R, A)`, `normal = (A n, A)`, `moments = (A z, A z^2, A, 0)`.
//! Parent = `(c0 + c1 + c2 + c3) * 0.25`, summed left to right: correctly rounded adds and an exact
//! scaling, so the GPU must match bit for bit (or as flushed to zero).
use crate::ftz4;
use glam::Vec4;
use rayon::prelude::*;

/// Layer streams of one level: radiance, normal, moments.
pub type Streams = [Vec<[f32; 4]>; 3];

/// One parent from its four children, in the kernel's operation order.
#[inline]
pub fn box4(children: &[[f32; 4]], flush: bool) -> [f32; 4] {
    let mut s = ftz4(Vec4::from(children[0]), flush);
    for c in &children[1..4] {
        s = ftz4(s + ftz4(Vec4::from(*c), flush), flush);
    }
    ftz4(s * 0.25, flush).into()
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
}
