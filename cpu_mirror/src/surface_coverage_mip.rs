//! Mirror of `kernels/surface_coverage_mip.wgsl`: one mip level of a dense voxel grid (Morton order).
//!
//! Storage per voxel (see the WGSL header for the full contract): `colour = (C.rgb, alpha)` with C the
//! colour pre-multiplied by alpha, `normal = (N.xyz, w)` with N the average normal pre-multiplied by
//! alpha and w a free channel filtered like N. Parent `p` of children `c_0..c_7` (indices 8p..8p+8):
//!
//! * `sc = c_0 + c_1 + ... + c_7`, `sn = n_0 + ... + n_7`, summed left to right as vec4s;
//! * surface coverage (CPRC 3.1): `alpha_p = min(sc.a * 0.25, 1)`, `C_p = sc.rgb / max(sc.a, 4)`,
//!   `N_p = sn / max(sc.a, 4)`. Since `min(1, s/4) / s = 1 / max(s, 4)`, this is the alpha-weighted mean
//!   of the children pre-multiplied with the clamped alpha, as the paper says;
//! * volume coverage (the naive mean): everything `* 0.125`.
use crate::ftz4;
use glam::Vec4;
use rayon::prelude::*;

/// Which alpha rule the parent level gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Coverage {
    /// alpha = min(1, sum / 4): surfaces stay opaque in coarse levels (the paper's choice).
    Surface = 0,
    /// alpha = sum / 8: the plain average.
    Volume = 1,
}

/// The kernel's uniform block (`struct MipParams` in the WGSL; layout checked against naga in a test).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MipParams {
    /// `Coverage as u32`.
    pub coverage: u32,
}

/// One parent from its eight children, in the kernel's operation order.
#[inline]
pub fn reduce_parent(
    colour: &[[f32; 4]],
    normal: &[[f32; 4]],
    coverage: Coverage,
    flush: bool,
) -> ([f32; 4], [f32; 4]) {
    let mut sc = ftz4(Vec4::from(colour[0]), flush);
    let mut sn = ftz4(Vec4::from(normal[0]), flush);
    for k in 1..8 {
        sc = ftz4(sc + ftz4(Vec4::from(colour[k]), flush), flush);
        sn = ftz4(sn + ftz4(Vec4::from(normal[k]), flush), flush);
    }
    let (c, n) = match coverage {
        Coverage::Volume => (sc * 0.125, sn * 0.125),
        Coverage::Surface => {
            let d = sc.w.max(4.0);
            let c = sc.truncate() / d;
            (c.extend((sc.w * 0.25).min(1.0)), sn / d)
        }
    };
    (ftz4(c, flush).into(), ftz4(n, flush).into())
}

/// The next coarser level of a level given in Morton order (`colour.len()` a multiple of 8).
pub fn reduce_level(
    colour: &[[f32; 4]],
    normal: &[[f32; 4]],
    coverage: Coverage,
    flush: bool,
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    assert_eq!(colour.len(), normal.len());
    assert_eq!(
        colour.len() % 8,
        0,
        "a level of a power-of-two grid holds a multiple of 8 voxels"
    );
    colour
        .par_chunks(8)
        .zip(normal.par_chunks(8))
        .with_min_len(4096)
        .map(|(c, n)| reduce_parent(c, n, coverage, flush))
        .unzip()
}

/// One level: (colour, normal) per voxel in Morton order.
pub type Level = (Vec<[f32; 4]>, Vec<[f32; 4]>);

/// The whole chain from level 0 (side `n`, a power of two) down to 1^3; `result[0]` is level 1.
pub fn mip_chain(colour: &[[f32; 4]], normal: &[[f32; 4]], coverage: Coverage) -> Vec<Level> {
    let mut levels: Vec<Level> = Vec::new();
    while levels.last().map_or(colour.len(), |l| l.0.len()) > 1 {
        let (c, n) = match levels.last() {
            Some((c, n)) => (c.as_slice(), n.as_slice()),
            None => (colour, normal),
        };
        levels.push(reduce_level(c, n, coverage, false));
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_full_block_stays_opaque_with_surface_coverage() {
        let mut c = [[0.0f32; 4]; 8];
        let mut n = [[0.0f32; 4]; 8];
        for k in 0..4 {
            c[k] = [0.5, 0.25, 1.0, 1.0];
            n[k] = [0.0, 1.0, 0.0, 0.0];
        }
        let (pc, pn) = reduce_parent(&c, &n, Coverage::Surface, false);
        assert_eq!(pc, [0.5, 0.25, 1.0, 1.0]);
        assert_eq!(pn, [0.0, 1.0, 0.0, 0.0]);
        let (vc, _) = reduce_parent(&c, &n, Coverage::Volume, false);
        assert_eq!(vc, [0.25, 0.125, 0.5, 0.5]);
    }

    #[test]
    fn full_block_colour_is_the_mean() {
        let c: Vec<[f32; 4]> = (0..8).map(|k| [k as f32, 1.0, 2.0, 1.0]).collect();
        let n = vec![[0.0f32; 4]; 8];
        let (pc, _) = reduce_parent(&c, &n, Coverage::Surface, false);
        assert_eq!(pc, [28.0 / 8.0, 1.0, 2.0, 1.0]);
    }

    #[test]
    fn flush_mode_zeroes_subnormal_alpha() {
        let mut c = [[0.0f32; 4]; 8];
        c[0][3] = f32::from_bits(100);
        let n = [[0.0f32; 4]; 8];
        let (ieee, _) = reduce_parent(&c, &n, Coverage::Volume, false);
        let (flushed, _) = reduce_parent(&c, &n, Coverage::Volume, true);
        assert!(ieee[3] > 0.0);
        assert_eq!(flushed[3], 0.0);
    }
}
