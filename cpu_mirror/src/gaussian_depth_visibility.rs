//! Mirror of `kernels/gaussian_depth_visibility.wgsl`: LRSM eq. 10-12 (Sugihara et al. 2014).
//!
//! From pre-filtered, opacity-weighted depth moments `(A z, A z^2, A)` of one LRSM layer texel and a cone
//! sample `(zc, rc)` in the layer's warped depth, the fraction of RSM samples inside the cone sample:
//! `V = Phi((zc + rc - mu) / sigma) - Phi((zc - rc - mu) / sigma)`, `mu = Az / A`,
//! `sigma^2 = max(Az^2 / A - mu^2, min_variance)` (the floor keeps sigma > 0 where all samples share one
//! depth and `z^2 - mu^2` cancels to rounding noise, as variance shadow maps do).
//!
//! Phi is evaluated through the complementary error function so that neither tail cancels:
//! `Phi(t) = 1 - Q(t / sqrt 2) / 2` for `t >= 0`, `Q(t / sqrt 2) / 2` for `t < 0`, with
//! `Q(x) ~ erfc(x)` for `x >= 0` by one of two approximations (Abramowitz & Stegun):
//! * [`Cdf::AS7126`]: 7.1.26, `Q(x) = t (a1 + t (a2 + ... + t a5)) exp(-x^2)`, `t = 1 / (1 + p x)`,
//!   `|error| <= 1.5e-7`;
//! * [`Cdf::AS7127`]: 7.1.27, `Q(x) = 1 / (1 + a1 x + a2 x^2 + a3 x^3 + a4 x^4)^4`, no exp,
//!   `|error| <= 5e-4`.
//!
//! Domain: every finite input gives a finite V in [0, 1]: A <= min_alpha (or NaN) gives 0; mu, zc are
//! clamped to [-DEPTH_LIMIT, DEPTH_LIMIT], rc to [0, DEPTH_LIMIT], sigma^2 to
//! [min_variance, DEPTH_LIMIT^2], so no intermediate overflows.
use crate::ftz;

/// Largest depth magnitude the kernel works with; the contract's depths are warped to [0, 1].
pub const DEPTH_LIMIT: f32 = 1.0e6;

/// Which erfc approximation the kernel uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Cdf {
    AS7126 = 0,
    AS7127 = 1,
}

/// The kernel's uniform block (`struct VisibilityParams`; layout checked against naga in a test).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VisibilityParams {
    /// `Cdf as u32`.
    pub cdf: u32,
    /// Floor of sigma^2 in warped depth units squared.
    pub min_variance: f32,
    /// Texels whose mean opacity A is not above this hold no surface: V = 0.
    pub min_alpha: f32,
    pub _pad: u32,
}

impl Default for VisibilityParams {
    fn default() -> Self {
        // sigma >= 0.01 of a layer's depth range: above f32 cancellation noise in z^2 - mu^2 (~1e-7) and
        // 16-bit UNORM moment quantisation (1.5e-5), small against a layer.
        Self {
            cdf: Cdf::AS7126 as u32,
            min_variance: 1.0e-4,
            min_alpha: 1.0e-6,
            _pad: 0,
        }
    }
}

/// 2^126: the largest divisor WGSL's 2.5-ULP division rule covers.
const MAX_DIVISOR: f64 = 8.507_059_173_023_462e37;

const FRAC_1_SQRT_2: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// erfc(x) for x >= 0, in the kernel's operation order; x capped at 16 (0 in f32 for 7.1.26,
/// 1.4e-15 for 7.1.27) so 7.1.27's divisor stays below 2^126, inside WGSL's division rule.
pub fn erfc_approx(x: f32, cdf: Cdf, flush: bool) -> f32 {
    let f = |v: f32| ftz(v, flush);
    let x = x.min(16.0);
    match cdf {
        Cdf::AS7126 => {
            let t = f(1.0 / f(1.0 + f(0.327_591_1 * x)));
            let mut poly = 1.061_405_4f32;
            poly = f(-1.453_152_1 + f(t * poly));
            poly = f(1.421_413_8 + f(t * poly));
            poly = f(-0.284_496_74 + f(t * poly));
            poly = f(0.254_829_6 + f(t * poly));
            f(f(t * poly) * f((-x * x).exp()))
        }
        Cdf::AS7127 => {
            let mut d = 0.078_108f32;
            d = f(0.000_972 + f(x * d));
            d = f(0.230_389 + f(x * d));
            d = f(0.278_393 + f(x * d));
            d = f(1.0 + f(x * d));
            let d2 = f(d * d);
            f(1.0 / f(d2 * d2))
        }
    }
}

/// Phi(t), the standard normal CDF, without cancellation in either tail.
pub fn normal_cdf(t: f32, cdf: Cdf, flush: bool) -> f32 {
    let q = ftz(
        0.5 * erfc_approx(ftz(t.abs() * FRAC_1_SQRT_2, flush), cdf, flush),
        flush,
    );
    if t >= 0.0 {
        ftz(1.0 - q, flush)
    } else {
        q
    }
}

/// V for one texel and one cone sample (eq. 12), in the kernel's operation order.
pub fn visibility(moments: [f32; 4], zc: f32, rc: f32, p: &VisibilityParams, flush: bool) -> f32 {
    let f = |v: f32| ftz(v, flush);
    let cdf = if p.cdf == 1 { Cdf::AS7127 } else { Cdf::AS7126 };
    let [az, az2, a, _] = moments.map(f);
    // Written as in the WGSL: NaN opacity must take the empty branch too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(a > f(p.min_alpha)) {
        return 0.0;
    }
    let mu = f(az / a).clamp(-DEPTH_LIMIT, DEPTH_LIMIT);
    let var = f(f(az2 / a) - f(mu * mu)).clamp(f(p.min_variance), DEPTH_LIMIT * DEPTH_LIMIT);
    let sigma = f(var.sqrt());
    let zc = f(zc).clamp(-DEPTH_LIMIT, DEPTH_LIMIT);
    let rc = f(rc).clamp(0.0, DEPTH_LIMIT);
    let hi = f(f(f(zc + rc) - mu) / sigma);
    let lo = f(f(f(zc - rc) - mu) / sigma);
    let v = if lo >= 0.0 {
        // Both ends in the upper tail: V = (Q(lo) - Q(hi)) / 2.
        f(0.5
            * f(erfc_approx(f(lo * FRAC_1_SQRT_2), cdf, flush)
                - erfc_approx(f(hi * FRAC_1_SQRT_2), cdf, flush)))
    } else if hi <= 0.0 {
        f(0.5
            * f(erfc_approx(f(-hi * FRAC_1_SQRT_2), cdf, flush)
                - erfc_approx(f(-lo * FRAC_1_SQRT_2), cdf, flush)))
    } else {
        f(1.0
            - f(0.5
                * f(erfc_approx(f(hi * FRAC_1_SQRT_2), cdf, flush)
                    + erfc_approx(f(-lo * FRAC_1_SQRT_2), cdf, flush))))
    };
    v.clamp(0.0, 1.0)
}

/// How far a conforming GPU may be from [`visibility`] on the same input: a first-order error bound
/// built from the WGSL accuracy rules of the operations used (f32, u = 2^-24):
/// * `mu = Az / A`, `Az^2 / A`: division, 2.5 ULP each;
/// * `var = Az^2/A - mu^2`: the product and difference each round (0.5 ULP), or fuse (FMA contraction is
///   allowed) — the bound covers both; the error is absolute in `|Az^2/A| + mu^2`, which is what makes
///   sigma^2 -> 0 hard and why `min_variance` exists;
/// * `sqrt`: inherited from `1 / inverseSqrt` (2 + 2.5 ULP);
/// * `t = (z - mu) / sigma`: sub 0.5 + div 2.5 ULP; `dV/dt <= phi(t)`;
/// * erfc evaluation: `exp` is 3 + 2|x| ULP (absolute in exp(-x^2) (3 + 2x^2) u <= 3.3 u), Horner's
///   multiply-adds (fused or not) a few ULP of values <= 1: 16 u per erfc, two per V, plus the final
///   subtraction.
///
/// Returned doubled, since it is first order; never below 4e-7 (a few ULP of 1).
///
/// WGSL's division rule holds only for divisors in [2^-126, 2^126]; an opacity A above 2^126 (outside
/// the contract's [0, 1], reachable with arbitrary bit patterns) leaves `Az / A` unbounded — the
/// H100 returns 0 there, as `x * rcp(A)` with rcp flushed — so V is promised only finite and in
/// [0, 1]: bound 1.
pub fn visibility_bound(moments: [f32; 4], zc: f32, rc: f32, p: &VisibilityParams) -> f32 {
    visibility_bound_inexact(moments, [0.0; 3], zc, rc, p)
}

/// [`visibility_bound`] where the GPU's moments `(Az, Az^2, A)` may differ from the mirror's by up to
/// `err` each (filtered attributes: `sample_lrsm::fetch_error`), carried first order into mu and
/// sigma^2: `d mu += (e_Az + |mu| e_A) / A`, `d m2 = (e_Az2 + |m2| e_A) / A`, `d var += d m2 + 2 |mu|
/// d mu`. An opacity within `e_A` of `min_alpha` (either branch) or of 0 relative to its error (A
/// less than twice it) is bound 1: V is in [0, 1] either way.
pub fn visibility_bound_inexact(
    moments: [f32; 4],
    err: [f64; 3],
    zc: f32,
    rc: f32,
    p: &VisibilityParams,
) -> f32 {
    let u = f64::from(f32::EPSILON) / 2.0;
    let [az, az2, a, _] = moments.map(f64::from);
    let [e_az, e_az2, e_a] = err;
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(a > p.min_alpha as f64) {
        return if a + e_a > p.min_alpha as f64 {
            1.0
        } else {
            0.0
        };
    }
    if a > MAX_DIVISOR || a - e_a <= p.min_alpha as f64 || a <= 2.0 * e_a {
        return 1.0;
    }
    let lim = DEPTH_LIMIT as f64;
    let mu = (az / a).clamp(-lim, lim);
    let m2 = az2 / a;
    let var_raw = m2 - mu * mu;
    let var = var_raw.clamp(p.min_variance as f64, lim * lim);
    let in_mu = (e_az + mu.abs() * e_a) / (a - e_a);
    let in_m2 = (e_az2 + m2.abs() * e_a) / (a - e_a);
    let d_mu = 2.5 * u * mu.abs() + in_mu;
    let d_var =
        u * (3.0 * m2.abs() + 6.0 * mu * mu + var_raw.abs()) + in_m2 + 2.0 * mu.abs() * in_mu;
    let rel_sigma = if var_raw > lim * lim {
        0.0
    } else {
        0.5 * d_var / var
    } + 5.0 * u;
    let sigma = var.sqrt();
    let zc = (zc as f64).clamp(-lim, lim);
    let rc = (rc as f64).clamp(0.0, lim);
    let phi = |t: f64| (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let mut bound = 0.0;
    for z in [zc + rc, zc - rc] {
        let t = (z - mu) / sigma;
        let dt = (d_mu + 0.5 * u * z.abs()) / sigma + t.abs() * (rel_sigma + 3.5 * u);
        bound += phi(t) * dt;
    }
    bound += 2.0 * 16.0 * u + u;
    (2.0 * bound).max(4.0e-7) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdf_matches_known_values() {
        // Phi(0) = 0.5, Phi(1) = 0.841344746, Phi(-2) = 0.022750132.
        for (t, want) in [
            (0.0f32, 0.5f64),
            (1.0, 0.841_344_746),
            (-2.0, 0.022_750_132),
            (4.0, 0.999_968_33),
        ] {
            assert!(
                (normal_cdf(t, Cdf::AS7126, false) as f64 - want).abs() < 3e-7,
                "{t}"
            );
            assert!(
                (normal_cdf(t, Cdf::AS7127, false) as f64 - want).abs() < 3e-4,
                "{t}"
            );
        }
    }

    #[test]
    fn visibility_of_a_single_depth_is_a_window() {
        let p = VisibilityParams::default();
        let m = [0.5, 0.25, 1.0, 0.0]; // all samples at z = 0.5, sigma floored to 0.01
        assert!(visibility(m, 0.5, 0.1, &p, false) > 0.999_999);
        assert!(visibility(m, 0.8, 0.1, &p, false) < 1e-6);
        // Half the distribution when the window edge sits on the mean.
        assert!((visibility(m, 0.6, 0.1, &p, false) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn empty_and_extreme_inputs_stay_finite_and_in_range() {
        let p = VisibilityParams::default();
        for m in [
            [0.0, 0.0, 0.0, 0.0],
            [3e38, 3e38, 1e-5, 0.0],
            [-3e38, 3e38, 2e-6, 0.0],
            [1.0, -5.0, 1.0, 0.0],
        ] {
            for (zc, rc) in [(0.0, 0.0), (3e38, 3e38), (-3e38, 3e38), (0.5, -1.0)] {
                let v = visibility(m, zc, rc, &p, false);
                assert!(
                    v.is_finite() && (0.0..=1.0).contains(&v),
                    "{m:?} {zc} {rc}: {v}"
                );
                assert!(visibility_bound(m, zc, rc, &p).is_finite());
            }
        }
    }
}
