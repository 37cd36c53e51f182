//! Mirror of `kernels/svo_fragments.wgsl`: the sparse voxel octree's fragments of a lit voxel grid,
//! built where the grid lies, with the fixed-point scale the host's `fixed_scale` would choose.
//!
//! Three passes over a list of distinct Morton indices (`count` of them valid, `capacity` slots):
//! `peak`, the largest value of the listed voxels (each channel clamped at 0; NaN counts as 0), as
//! f32 bits; `scale`, [`SCALE`] halved until `peak * scale <= threshold` (or the scale reaches
//! f32::MIN_POSITIVE); `write_fragments`, one per slot: the voxel's lattice point (its Morton decode) and
//! its four values in fixed point (`v * scale` rounded half away from zero), a zero fragment past
//! `count`. A value that does not fit (-0.5 or less after scaling, NaN, infinite, or 2^32 or more
//! after rounding) stores 0 and raises [`ERR_VALUE`].
//!
//! Every operation is exact (integer max on the bits of non-negative floats, products with powers of
//! two, floor and comparisons), so the GPU agrees bit for bit. Flushing subnormals changes nothing:
//! a subnormal value times a scale of at most 2^16 rounds to 0 either way, and a subnormal peak times
//! the scale stays far below the threshold. No `flush` argument.
use crate::morton;
use crate::sparse_voxel_octree::Fragment;

/// The largest scale, `vxgi::kernels::svo_cone_trace::SCALE`.
pub const SCALE: f32 = 65536.0;
/// Words of `scale_state`: the peak's bits and the error bits.
pub const STATE_WORDS: usize = 2;
/// Error bit of `scale_state[1]`: a value did not fit the fixed point.
pub const ERR_VALUE: u32 = 1;
/// 2^-32: the scale pass compares `(peak 2^-32) scale` with `threshold 2^-32`, which cannot overflow.
const DOWN: f32 = 1.0 / 4_294_967_296.0;
/// Bits of +inf: the bits of every non-negative, non-NaN f32 are at most this.
const INF_BITS: u32 = 0x7f80_0000;

/// The kernel's uniform block (`struct FragmentParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FragmentParams {
    pub capacity: u32,
    /// 1: each voxel's value is `(0, 0, 0, alpha)` (the geometry fragments of photon lighting).
    pub coverage_only: u32,
    /// [`threshold`] of the frame's bounces and fragments per lattice point.
    pub threshold: f32,
    pub _pad: u32,
}

/// What the three passes leave in the kernel's outputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Fragments {
    /// `[peak's f32 bits, error bits]`.
    pub scale_state: [u32; 2],
    /// `[scale, 1 / scale]`.
    pub svo_scale: [f32; 2],
    pub fragments: Vec<Fragment>,
}

/// The largest f32 `T32` with `x <= T32` exactly when the host's fit test holds for `x = peak scale`.
///
/// The host (`fixed_scale`) accepts a scale when `64 (b (x + n / 2) + 1) <= u32::MAX` in f64, `b` the
/// bounces (at least 1), `n` the most fragments at one lattice point. Near the bound (`x` about
/// 2^26 / b, a multiple of the f32 spacing there) every f64 operation of that test is exact, and far
/// from it rounding cannot cross it (the operations are monotone), so it is the real inequality
/// `x <= T = (u32::MAX / 64 - 1) / b - n / 2`; for an f32 `x` that is `x <= T32`, T32 the largest
/// f32 not above T. T is computed in f64 (exactly for 1 and 2 bounces, otherwise within an f64
/// rounding, far closer than any f32 other than T itself) and rounded down.
pub fn threshold(bounces: u32, most: u32) -> f32 {
    let t = (u32::MAX as f64 / 64.0 - 1.0) / bounces.max(1) as f64 - most as f64 / 2.0;
    let t32 = t as f32;
    if t32 as f64 > t {
        t32.next_down()
    } else {
        t32
    }
}

/// A voxel's four values as the kernel reads them.
fn value(radiance: &[[f32; 4]], m: u32, coverage_only: bool) -> [f32; 4] {
    let v = radiance[m as usize];
    if coverage_only {
        [0.0, 0.0, 0.0, v[3]]
    } else {
        v
    }
}

/// Pass `peak`: the largest of the listed voxels' values, each clamped at 0 (NaN and -0 give 0), as
/// f32 bits. On bits, the order of non-negative floats is the integer order.
pub fn peak(radiance: &[[f32; 4]], list: &[u32], count: u32, coverage_only: bool) -> u32 {
    list[..count as usize]
        .iter()
        .flat_map(|&m| value(radiance, m, coverage_only))
        .map(|c| {
            let b = c.to_bits();
            if b <= INF_BITS {
                b
            } else {
                0
            }
        })
        .max()
        .unwrap_or(0)
}

/// Pass `scale`: `[scale, 1 / scale]`, [`SCALE`] halved while `peak * scale > threshold` and
/// `scale > f32::MIN_POSITIVE` (an infinite peak halves it to the end). The products are exact: the
/// scale is a power of two, `peak 2^-32` is exact unless below 2^-126 (then every product is far
/// below the threshold), and `(peak 2^-32) scale < 2^96 2^16` cannot overflow.
pub fn scale(peak_bits: u32, threshold: f32) -> [f32; 2] {
    let finite = peak_bits < INF_BITS;
    // No infinity enters the arithmetic (f32::MAX in its place).
    let p = f32::from_bits(peak_bits.min(0x7f7f_ffff)) * DOWN;
    let t = threshold * DOWN;
    let (mut s, mut inv) = (SCALE, 1.0 / SCALE);
    while !(finite && p * s <= t) && s > f32::MIN_POSITIVE {
        s *= 0.5;
        inv *= 2.0;
    }
    [s, inv]
}

/// One value in fixed point: `Some(round(v scale))`, half away from zero, or `None` where it does
/// not fit (the host's `to_fixed` refuses the same values).
pub fn to_fixed(v: f32, scale: f32) -> Option<u32> {
    if v.to_bits() & INF_BITS == INF_BITS {
        return None; // NaN or infinite
    }
    // Exact: a power-of-two scale; finite for a value the scale pass has seen.
    let y = v * scale;
    if y <= -0.5 {
        return None; // rounds to -1 or below
    }
    let y = y.max(0.0);
    let r = y.floor();
    // y - r is exact (r = 0, or r >= y / 2); r + 1 too where it is taken (below 2^24).
    let q = if y - r >= 0.5 { r + 1.0 } else { r };
    (q < 4_294_967_296.0).then_some(q as u32)
}

/// Pass `write_fragments`: one fragment per slot of `capacity`, the listed voxel's lattice point and
/// fixed-point values (0 where one does not fit), a zero fragment past `count`; and the error bits.
///
/// A listed voxel whose values are all 0 gives a fragment of value 0 at its point, where the host
/// (`grid_fragments`) gives none: the octree's splat adds nothing for it, so the non-zero fragments,
/// and the octree, are the same.
pub fn fragments(
    radiance: &[[f32; 4]],
    list: &[u32],
    count: u32,
    capacity: u32,
    coverage_only: bool,
    scale: f32,
) -> (Vec<Fragment>, u32) {
    let mut errors = 0;
    let zero = Fragment {
        pos: [0; 3],
        _pad: 0,
        value: [0; 4],
    };
    let out = (0..capacity)
        .map(|i| {
            if i >= count {
                return zero;
            }
            let m = list[i as usize];
            let v = value(radiance, m, coverage_only);
            Fragment {
                pos: morton::decode(m),
                _pad: 0,
                value: v.map(|c| {
                    to_fixed(c, scale).unwrap_or_else(|| {
                        errors |= ERR_VALUE;
                        0
                    })
                }),
            }
        })
        .collect();
    (out, errors)
}

/// The three passes in order, from a zeroed `scale_state`.
pub fn run(radiance: &[[f32; 4]], list: &[u32], count: u32, params: &FragmentParams) -> Fragments {
    let cov = params.coverage_only != 0;
    let peak = peak(radiance, list, count, cov);
    let svo_scale = scale(peak, params.threshold);
    let (fragments, errors) = fragments(radiance, list, count, params.capacity, cov, svo_scale[0]);
    Fragments {
        scale_state: [peak, errors],
        svo_scale,
        fragments,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_point_rounds_half_away_from_zero_and_refuses_what_does_not_fit() {
        let s = SCALE;
        assert_eq!(to_fixed(2.5 / s, s), Some(3));
        assert_eq!(to_fixed(0.5 / s, s), Some(1));
        // Just below 0.5 after scaling: floor(y + 0.5) would round the sum up to 1.
        assert_eq!(to_fixed(0.5f32.next_down() / s, s), Some(0));
        assert_eq!(to_fixed(-0.0, s), Some(0));
        assert_eq!(to_fixed(f32::from_bits(1), s), Some(0));
        assert_eq!(to_fixed(-0.4 / s, s), Some(0));
        assert_eq!(to_fixed(-0.5 / s, s), None);
        assert_eq!(to_fixed(f32::NAN, s), None);
        assert_eq!(to_fixed(f32::INFINITY, s), None);
        assert_eq!(to_fixed(4_294_967_040.0, 1.0), Some(4_294_967_040));
        assert_eq!(to_fixed(4_294_967_296.0, 1.0), None);
        for k in [0u32, 1, 7, 65_535, 1 << 20] {
            let v = (k as f32 + 0.5) / s;
            assert_eq!(
                to_fixed(v, s),
                Some((v as f64 * s as f64).round() as u32),
                "{k}"
            );
        }
    }

    #[test]
    fn threshold_is_the_largest_f32_the_host_test_accepts() {
        for (b, n) in [(1u32, 1u32), (2, 1), (3, 1), (1, 5), (7, 2)] {
            let t = threshold(b, n);
            let fits =
                |x: f32| 64.0 * (b as f64 * (x as f64 + n as f64 / 2.0) + 1.0) <= u32::MAX as f64;
            assert!(fits(t) && !fits(t.next_up()), "b {b} n {n}: {t}");
        }
    }

    #[test]
    fn peak_ignores_negatives_and_nan_and_the_scale_halves_past_it() {
        let r = [[1.0, -5.0, f32::NAN, 0.5], [-0.0, 2.0, 0.0, 0.0], [9.0; 4]];
        assert_eq!(peak(&r, &[0, 1, 2], 2, false), 2.0f32.to_bits());
        assert_eq!(peak(&r, &[0, 1], 2, true), 0.5f32.to_bits());
        assert_eq!(peak(&r, &[0], 0, false), 0);
        let t = threshold(1, 1);
        assert_eq!(scale(0, t), [SCALE, 1.0 / SCALE]);
        assert_eq!(scale((t / SCALE).to_bits(), t)[0], SCALE);
        assert_eq!(scale((t / SCALE).next_up().to_bits(), t)[0], SCALE / 2.0);
        let [s, inv] = scale(3.0e38f32.to_bits(), t);
        assert!(3.0e38 * (s as f64) <= t as f64 && 3.0e38 * 2.0 * s as f64 > t as f64);
        assert_eq!(s * inv, 1.0);
        assert_eq!(scale(f32::INFINITY.to_bits(), t)[0], f32::MIN_POSITIVE);
    }

    #[test]
    fn fragments_past_the_count_are_zero_and_bad_values_flag() {
        let r = [[1.0, 0.0, 0.0, 1.0], [-1.0, 0.0, 0.0, 1.0]];
        let (f, e) = fragments(&r, &[1, 0], 1, 3, false, 2.0);
        assert_eq!(e, ERR_VALUE);
        assert_eq!(f[0].value, [0, 0, 0, 2]);
        assert_eq!(f[0].pos, morton::decode(1));
        assert_eq!(f[1].value, [0; 4]);
        let (f, e) = fragments(&r, &[1, 0], 1, 1, true, 2.0);
        assert_eq!((f[0].value, e), ([0, 0, 0, 2], 0));
    }
}
