//! Mirror of `kernels/svo_fragments.wgsl`: the sparse voxel octree's fragments of a lit voxel grid, or
//! of a voxel grid's coverage and a photon map, built where they lie, with the fixed-point scale the
//! host's `fixed_scale` would choose.
//!
//! Voxel mode, three passes over a list of distinct Morton indices (`count` of them valid, `capacity`
//! slots): `peak`, the largest value of the listed voxels (each channel clamped at 0; NaN counts as 0),
//! as f32 bits; `scale`, [`SCALE`] halved until `peak * scale <= threshold` (or the scale reaches
//! f32::MIN_POSITIVE); `write_fragments`, one per slot: the voxel's lattice point (its Morton decode)
//! and its four values in fixed point (`v * scale` rounded half away from zero), a zero fragment past
//! `count`. A value that does not fit (-0.5 or less after scaling, NaN, infinite, or 2^32 or more
//! after rounding) stores 0 and raises [`ERR_VALUE`].
//!
//! Photon mode (the voxels' coverage and the photons' light, several values per lattice point):
//! `voxel_points` and `photon_points` count, per lattice point and channel, the values above 0 and
//! keep the largest ([`voxel_points`], [`photon_points`]); `lattice_peak` takes the largest
//! [`point_bound`] of a count and its maximum, and the largest count; `lattice_scale` the threshold
//! of that count ([`most_threshold`]) and the same search; `write_fragments` (coverage only) and
//! `write_photon_fragments` ([`photon_fragments`]) the fragments. [`run_photons`] runs them in
//! order.
//!
//! Every operation is exact (integer max on the bits of non-negative floats, integer products and
//! divisions, products with powers of two, floor and comparisons; spec_max's one sum of normal halves,
//! correctly rounded), so the GPU agrees bit for bit. Flushing subnormals changes nothing: a subnormal
//! value times a scale of at most 2^16 rounds to 0 either way, maxima are taken on bits, spec_max
//! meets no subnormal ([`spec_term`]), and a subnormal peak times the scale stays far below the
//! threshold. No `flush` argument.
use crate::morton;
use crate::sparse_voxel_octree::Fragment;

/// The largest scale, `vxgi::kernels::svo_cone_trace::SCALE`.
pub const SCALE: f32 = 65536.0;
/// Words of `scale_state`: the peak's bits, the error bits, the most values at one lattice point and
/// the threshold `lattice_scale` used (f32 bits; the last two photon mode only).
pub const STATE_WORDS: usize = 4;
/// Error bit of `scale_state[1]`: a value did not fit the fixed point.
pub const ERR_VALUE: u32 = 1;
/// Error bit of `scale_state[1]`: a value's point lies outside the lattice (not counted).
pub const ERR_POINT: u32 = 2;
/// Most bounces [`most_threshold`] takes: more are clamped to it (`64 b` and twice a remainder
/// below it fit a u32).
pub const MAX_BOUNCES: u32 = 1 << 20;
/// 2^-32: the scale pass compares `(peak 2^-32) scale` with `threshold 2^-32`, which cannot overflow.
const DOWN: f32 = 1.0 / 4_294_967_296.0;
/// Bits of +inf: the bits of every non-negative, non-NaN f32 are at most this.
const INF_BITS: u32 = 0x7f80_0000;
/// Bits of 2^-125: [`spec_term`]'s operands below it in magnitude count as 0.
const SPEC_SMALL: u32 = 0x0100_0000;

/// The kernel's uniform block (`struct FragmentParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FragmentParams {
    pub capacity: u32,
    /// 1: each voxel's value is `(0, 0, 0, alpha)` (the geometry fragments of photon lighting).
    pub coverage_only: u32,
    /// [`threshold`] of the frame's bounces and fragments per lattice point (voxel mode's `scale`).
    pub threshold: f32,
    pub _pad: u32,
}

/// The photon mode's uniform block (`struct LatticeParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LatticeParams {
    /// The leaf lattice's side: `side + 1` points per axis (side at most 1023, so that
    /// `4 (side + 1)^3` fits a u32), point `x + (side + 1) (y + (side + 1) z)`; the voxel grid's side.
    pub side: u32,
    /// Photon texels.
    pub photons: u32,
    /// The frame's bounces (`lattice_scale`'s threshold).
    pub bounces: u32,
    pub _pad: u32,
}

/// What the three passes leave in the kernel's outputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Fragments {
    /// `[peak's f32 bits, error bits, 0, 0]`.
    pub scale_state: [u32; STATE_WORDS],
    /// `[scale, 1 / scale]`.
    pub svo_scale: [f32; 2],
    pub fragments: Vec<Fragment>,
}

/// The largest f32 `T32` with `x <= T32` exactly when the host's fit test holds for `x = peak scale`.
///
/// The host (`fixed_scale`) accepts a scale when `64 (b (x + n / 2) + 1) <= u32::MAX` in f64, `b` the
/// bounces (at least 1), `n` the most values above 0 of one channel at one lattice point. Near the
/// bound (`x` about T below, a multiple of the f32 spacing there) every f64 operation of that test
/// is exact for 1 or 2 bounces while T >= 1, and far from it rounding cannot cross it (the
/// operations are monotone), so it is the real inequality
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
        .map(clamped_bits)
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
        scale_state: [peak, errors, 0, 0],
        svo_scale,
        fragments,
    }
}

/// The bits of `v` clamped at 0: negatives, -0 and NaN give 0 (+0's bits). For the others the
/// integer order of the bits is the float order.
pub fn clamped_bits(v: f32) -> u32 {
    let b = v.to_bits();
    if b <= INF_BITS {
        b
    } else {
        0
    }
}

/// Bits of the smallest f32 not below `n m`, `m` the bits of a non-negative float or +inf (as
/// [`clamped_bits`] gives them); +inf past f32::MAX. The kernel's integer arithmetic: `n` times `m`'s
/// significand (56 bits at most) cut to 24 bits rounding up, a carry moving into the exponent.
pub fn point_bound(n: u32, m: u32) -> u32 {
    if n == 0 || m == 0 {
        return 0;
    }
    if m >= INF_BITS {
        return INF_BITS;
    }
    let e = m >> 23;
    // m = sig 2^(ex - 150).
    let (sig, ex) = if e == 0 {
        (m, 1)
    } else {
        ((m & 0x7f_ffff) | 0x80_0000, e)
    };
    let p = n as u64 * sig as u64;
    let len = 64 - p.leading_zeros();
    if len <= 24 {
        // Exact: a subnormal m times n (ex = 1), or n = 1 (len 24).
        return ((ex - 1) << 23) + p as u32;
    }
    let sh = len - 24;
    let q = (p >> sh) as u32 + (p & ((1u64 << sh) - 1) != 0) as u32;
    (((ex - 1 + sh) << 23) + q).min(INF_BITS)
}

/// The index of lattice point `p` (`side + 1` points per axis), or `None` past the lattice. Its
/// channel c's words in `point_count` and `point_max` are `4 index + c`.
pub fn point_index(side: u32, p: [u32; 3]) -> Option<usize> {
    if p.iter().any(|&c| c > side) {
        return None;
    }
    let w = side as usize + 1;
    Some(p[0] as usize + w * (p[1] as usize + w * p[2] as usize))
}

/// One value at point `p`, its channels clamped (bits `k`): each channel above 0 counted and
/// maxed; nothing for a value with none, [`ERR_POINT`] past the lattice.
fn add_value(side: u32, p: [u32; 3], k: [u32; 4], count: &mut [u32], max: &mut [u32]) -> u32 {
    if k == [0; 4] {
        return 0;
    }
    let Some(i) = point_index(side, p) else {
        return ERR_POINT;
    };
    for (c, &k) in k.iter().enumerate() {
        if k != 0 {
            count[4 * i + c] += 1;
            max[4 * i + c] = max[4 * i + c].max(k);
        }
    }
    0
}

/// Pass `voxel_points`: each channel above 0 (on bits: -0, negatives and NaN are not, a subnormal
/// is) of each listed voxel counts at its point and channel, and the largest is kept. Returns the
/// error bits.
#[allow(clippy::too_many_arguments)]
pub fn voxel_points(
    radiance: &[[f32; 4]],
    list: &[u32],
    count: u32,
    coverage_only: bool,
    side: u32,
    point_count: &mut [u32],
    point_max: &mut [u32],
) -> u32 {
    let mut errors = 0;
    for &m in &list[..count as usize] {
        let k = value(radiance, m, coverage_only).map(clamped_bits);
        errors |= add_value(side, morton::decode(m), k, point_count, point_max);
    }
    errors
}

/// Bits of `((x + y) / 2)` clamped at 0 (`x = q[a]`, `y = q[3]`), the host's `Photons::values`
/// term, computed so that no treatment of subnormals, infinities or NaN can change it: non-finite
/// operands on bits (NaN, or +inf and -inf, give 0; +inf with anything else +inf; -inf 0); finite
/// ones below 2^-125 in magnitude count as 0; `h = x / 2 + y / 2` (exact halves, one correctly rounded
/// sum) is the host's `fl(x + y) / 2`, +inf where `h > f32::MAX / 2`, and 0 below 2^-126. It
/// differs from the host's only where the host's is below 2^-100.
pub fn spec_term(x: f32, y: f32) -> u32 {
    let (bx, by) = (x.to_bits(), y.to_bits());
    let (nx, ny) = (bx & INF_BITS == INF_BITS, by & INF_BITS == INF_BITS);
    if nx || ny {
        let ok = |b: u32, n: bool| b == INF_BITS || !n;
        return if ok(bx, nx) && ok(by, ny) {
            INF_BITS
        } else {
            0
        };
    }
    let half = |v: f32, b: u32| {
        if b & 0x7fff_ffff < SPEC_SMALL {
            0.0
        } else {
            v * 0.5
        }
    };
    let h = half(x, bx) + half(y, by);
    if h > f32::MAX / 2.0 {
        return INF_BITS;
    }
    let bh = h.to_bits();
    if (0x0080_0000..=INF_BITS).contains(&bh) {
        bh
    } else {
        0
    }
}

/// Bits of a photon's `spec_max` (`q` its photon_spec): the largest [`spec_term`] of `q[a]` and
/// `q[3]`, and `q[3]` clamped.
pub fn spec_max(q: [f32; 4]) -> u32 {
    (0..3)
        .map(|a| spec_term(q[a], q[3]))
        .fold(clamped_bits(q[3]), u32::max)
}

/// Pass `photon_points`: each texel `t < photons` with `pos.w != 0` adds the value its fragments
/// store, its light's clamped `r, g, b` and [`spec_max`], at its point as `voxel_points` does.
/// Returns the error bits.
#[allow(clippy::too_many_arguments)]
pub fn photon_points(
    pos: &[[u32; 4]],
    value: &[[f32; 4]],
    spec: &[[f32; 4]],
    photons: u32,
    side: u32,
    point_count: &mut [u32],
    point_max: &mut [u32],
) -> u32 {
    let mut errors = 0;
    for t in 0..photons as usize {
        let p = pos[t];
        if p[3] == 0 {
            continue;
        }
        let v = value[t].map(clamped_bits);
        let k = [v[0], v[1], v[2], spec_max(spec[t])];
        errors |= add_value(side, [p[0], p[1], p[2]], k, point_count, point_max);
    }
    errors
}

/// Pass `lattice_peak`: `(peak bits, most)`, the largest [`point_bound`] of a point's channel's
/// count and max, and the largest count (0 and 0 for an empty lattice).
pub fn lattice_peak(point_count: &[u32], point_max: &[u32]) -> (u32, u32) {
    point_count
        .iter()
        .zip(point_max)
        .filter(|(&n, _)| n > 0)
        .fold((0, 0), |(p, most), (&n, &m)| {
            (p.max(point_bound(n, m)), most.max(n))
        })
}

/// The threshold `lattice_scale` takes from the most values at one point, `most`, and `bounces`
/// (clamped to 1..=[`MAX_BOUNCES`]): [`threshold`]`(bounces, most)`, computed exactly in u32: the
/// largest f32 not above `T = (u32::MAX - 64 - 32 b n) / (64 b)`, or -1 where `T < 0` (no scale
/// fits). With `q = floor(T)` and the rest `r / d`: from 2^24 on the f32 are integers, so `q` with
/// its bits past the 24th cleared; below, `T`'s binary expansion by long division until 24 significant
/// bits or an exact end, scaled back by 2^-j (j <= 50, since T >= 1 / d).
pub fn most_threshold(bounces: u32, most: u32) -> f32 {
    let b = bounces.clamp(1, MAX_BOUNCES);
    let limit = u32::MAX - 64;
    if most > limit / 32 / b {
        return -1.0;
    }
    let d = 64 * b;
    let t = limit - 32 * b * most;
    let q = t / d;
    let mut r = t % d;
    if q >= 1 << 24 {
        let drop = 32 - q.leading_zeros() - 24;
        return ((q >> drop) << drop) as f32;
    }
    let (mut s, mut j) = (q, 0u32);
    while 32 - s.leading_zeros() < 24 && r != 0 {
        r *= 2;
        s *= 2;
        if r >= d {
            r -= d;
            s += 1;
        }
        j += 1;
    }
    s as f32 * f32::from_bits((127 - j) << 23)
}

/// Pass `lattice_scale`: `([scale, 1 / scale], threshold)`, [`scale`] with the threshold of the most
/// values at one point ([`most_threshold`]).
pub fn lattice_scale(peak_bits: u32, most: u32, bounces: u32) -> ([f32; 2], f32) {
    let t = most_threshold(bounces, most);
    (scale(peak_bits, t), t)
}

/// Pass `write_photon_fragments`: one fragment per texel `t < photons` (slot `capacity + t` of the
/// kernel's buffer): its point and light `(r, g, b, 0)` in fixed point where `pos.w != 0` (0 where a
/// value does not fit), else a zero fragment; and the error bits. The non-zero ones are the host's
/// `svo_photons::to_fragments`.
pub fn photon_fragments(
    pos: &[[u32; 4]],
    value: &[[f32; 4]],
    photons: u32,
    scale: f32,
) -> (Vec<Fragment>, u32) {
    let mut errors = 0;
    let out = (0..photons as usize)
        .map(|t| {
            let p = pos[t];
            if p[3] == 0 {
                return bytemuck::Zeroable::zeroed();
            }
            let v = value[t];
            Fragment {
                pos: [p[0], p[1], p[2]],
                _pad: 0,
                value: [v[0], v[1], v[2], 0.0].map(|c| {
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

/// What the photon mode's passes leave in the kernel's outputs.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotonFragments {
    /// `[peak's f32 bits, error bits, most, threshold's f32 bits]`.
    pub scale_state: [u32; STATE_WORDS],
    /// `[scale, 1 / scale]`.
    pub svo_scale: [f32; 2],
    /// `capacity` voxel slots, then one per photon texel.
    pub fragments: Vec<Fragment>,
    pub point_count: Vec<u32>,
    pub point_max: Vec<u32>,
}

/// The photon mode's passes in order, from zeroed state: the coverage of `colour`'s listed voxels
/// (`list[..count]`, `capacity` slots) and the photons `pos`, `value`, `spec` (`lattice.photons`
/// texels) on the lattice of `lattice.side`.
#[allow(clippy::too_many_arguments)]
pub fn run_photons(
    colour: &[[f32; 4]],
    list: &[u32],
    count: u32,
    capacity: u32,
    pos: &[[u32; 4]],
    value: &[[f32; 4]],
    spec: &[[f32; 4]],
    lattice: &LatticeParams,
) -> PhotonFragments {
    let words = 4 * (lattice.side as usize + 1).pow(3);
    let (mut point_count, mut point_max) = (vec![0; words], vec![0; words]);
    let side = lattice.side;
    let mut errors = voxel_points(
        colour,
        list,
        count,
        true,
        side,
        &mut point_count,
        &mut point_max,
    );
    errors |= photon_points(
        pos,
        value,
        spec,
        lattice.photons,
        side,
        &mut point_count,
        &mut point_max,
    );
    let (peak, most) = lattice_peak(&point_count, &point_max);
    let (svo_scale, t) = lattice_scale(peak, most, lattice.bounces);
    let (mut out, e) = fragments(colour, list, count, capacity, true, svo_scale[0]);
    let (photon, f) = photon_fragments(pos, value, lattice.photons, svo_scale[0]);
    out.extend(photon);
    PhotonFragments {
        scale_state: [peak, errors | e | f, most, t.to_bits()],
        svo_scale,
        fragments: out,
        point_count,
        point_max,
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

    /// `a 2^x` against `b 2^y` exactly (a, b below 2^64).
    fn cmp_dyadic(a: u128, x: i32, b: u128, y: i32) -> std::cmp::Ordering {
        let k = x.min(y);
        let (sa, sb) = ((x - k) as u32, (y - k) as u32);
        if sa >= 64 || sb >= 64 {
            // The shifted side is at least 2^64 > the other (unless it is 0).
            return match (a, b) {
                (0, 0) => std::cmp::Ordering::Equal,
                (0, _) => std::cmp::Ordering::Less,
                (_, 0) => std::cmp::Ordering::Greater,
                _ if sa >= 64 => std::cmp::Ordering::Greater,
                _ => std::cmp::Ordering::Less,
            };
        }
        (a << sa).cmp(&(b << sb))
    }

    /// A finite non-negative f32 as `(significand, exponent)`.
    fn dyadic(v: f32) -> (u128, i32) {
        let b = v.to_bits();
        let e = (b >> 23) as i32;
        if e == 0 {
            (b as u128, -149)
        } else {
            (((b & 0x7f_ffff) | 0x80_0000) as u128, e - 150)
        }
    }

    #[test]
    fn point_bound_is_the_product_rounded_up() {
        let ms = [
            0.0f32,
            f32::from_bits(1),
            f32::from_bits(0x7f_ffff),
            f32::MIN_POSITIVE,
            1.0,
            1.5,
            0.1,
            1.0f32.next_down(),
            3.0e38,
            f32::MAX,
            16_777_215.0,
            0.3333,
        ];
        let ns = [
            1u32,
            2,
            3,
            5,
            7,
            255,
            1000,
            65_537,
            1 << 24,
            (1 << 24) + 1,
            0x7fff_ffff,
            u32::MAX,
        ];
        for &m in &ms {
            for &n in &ns {
                let r = point_bound(n, m.to_bits());
                let (b, y) = dyadic(m);
                let at = format!("{n} * {m:e}: {:e}", f32::from_bits(r));
                if r == INF_BITS {
                    // n m above f32::MAX.
                    let (a, x) = dyadic(f32::MAX);
                    assert_eq!(
                        cmp_dyadic(a, x, n as u128 * b, y),
                        std::cmp::Ordering::Less,
                        "{at}"
                    );
                    continue;
                }
                let (a, x) = dyadic(f32::from_bits(r));
                assert_ne!(
                    cmp_dyadic(a, x, n as u128 * b, y),
                    std::cmp::Ordering::Less,
                    "{at}"
                );
                if r > 0 {
                    let (a, x) = dyadic(f32::from_bits(r - 1));
                    assert_eq!(
                        cmp_dyadic(a, x, n as u128 * b, y),
                        std::cmp::Ordering::Less,
                        "{at}"
                    );
                }
                if n < 1 << 29 {
                    // The f64 product is exact.
                    let p = n as f64 * m as f64;
                    let up = if (p as f32) as f64 >= p {
                        p as f32
                    } else {
                        (p as f32).next_up()
                    };
                    assert_eq!(r, up.to_bits(), "{at}");
                }
            }
            assert_eq!(point_bound(1, m.to_bits()), m.to_bits());
        }
        assert_eq!(point_bound(3, INF_BITS), INF_BITS);
        assert_eq!(point_bound(0, 1.0f32.to_bits()), 0);
    }

    #[test]
    fn most_threshold_is_the_hosts_threshold() {
        let mut ns: Vec<u32> = (0..2000).collect();
        for k in 0..32 {
            let p = 1u32 << k;
            ns.extend([p - 1, p, p + 1, p.saturating_add(p / 3)]);
        }
        // Spread over the whole range (xorshift).
        let mut x = 0x9e37_79b9u32;
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            ns.push(x >> (x % 24));
        }
        let limit = u32::MAX - 64;
        for b in [1u32, 2, 3] {
            let mut ns = ns.clone();
            // Around T = 2^24, T = 1 and the guard (T < 0).
            for c in [
                (limit - (b << 30)) / (32 * b),
                (limit - 64 * b) / (32 * b),
                limit / 32 / b,
            ] {
                ns.extend(c - 4..=c + 4);
            }
            for &n in &ns {
                let t = most_threshold(b, n);
                let host = threshold(b, n);
                if host < 0.0 {
                    assert_eq!(t, -1.0, "b {b} n {n}");
                } else {
                    assert_eq!(t.to_bits(), host.to_bits(), "b {b} n {n}: {t} {host}");
                }
            }
        }
        assert_eq!(most_threshold(0, 1), most_threshold(1, 1));
    }

    #[test]
    fn spec_term_is_the_hosts_but_for_tiny_terms() {
        let vals = [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            0.25,
            -0.75,
            3.0e38,
            -3.0e38,
            f32::MAX,
            f32::from_bits(1),
            -f32::from_bits(5),
            f32::MIN_POSITIVE,
            f32::MIN_POSITIVE * 1.5,
            2.0 * f32::MIN_POSITIVE,
            1.0e-35,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1.0 + f32::EPSILON,
        ];
        for &x in &vals {
            for &y in &vals {
                let host = clamped_bits(((x + y) * 0.5).max(0.0));
                let t = spec_term(x, y);
                if f32::from_bits(host) >= 1.0e-30 || host == 0 && t == 0 {
                    assert_eq!(t, host, "{x:e} {y:e}");
                } else {
                    assert!(
                        f32::from_bits(host) < 1.0e-30 && f32::from_bits(t) < 1.0e-30,
                        "{x:e} {y:e}"
                    );
                }
            }
        }
        assert_eq!(
            spec_max([-1.0, 0.9, f32::NAN, 0.5]),
            ((0.9f32 + 0.5) * 0.5).to_bits()
        );
        assert_eq!(spec_max([-1.0, 0.5, f32::NAN, 1.0]), 1.0f32.to_bits());
        assert_eq!(spec_max([-1.0, -1.0, -1.0, 0.0]), 0);
        assert_eq!(spec_max([0.0, 0.0, 0.0, f32::from_bits(3)]), 3);
    }
}
