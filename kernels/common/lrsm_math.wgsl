// Shared LRSM arithmetic (Sugihara et al. 2014), included by gaussian_depth_visibility.wgsl,
// layer_decay.wgsl and sample_lrsm.wgsl. Mirrors: cpu_mirror/src/gaussian_depth_visibility.rs
// (erfc_approx, visibility) and cpu_mirror/src/layer_decay.rs (falloff, layer_decay); the kernel headers
// state the contracts and accuracy.

const LRSM_DEPTH_LIMIT: f32 = 1.0e6;
const LRSM_FRAC_1_SQRT_2: f32 = 0.70710677;

// erfc(x) for x >= 0: cdf 0 = Abramowitz & Stegun 7.1.26, cdf 1 = 7.1.27. x is capped at 16 (erfc(16)
// ~ 1e-113, 0 in f32; 7.1.27 gives 1.4e-15 there) so 1 / (d2 d2) keeps its divisor below 2^126, inside
// WGSL's division rule (past it a GPU may return anything: the H100 returns 0).
fn lrsm_erfc(x_in: f32, cdf: u32) -> f32 {
    let x = min(x_in, 16.0);
    if (cdf == 1u) {
        var d = 0.078108;
        d = 0.000972 + x * d;
        d = 0.230389 + x * d;
        d = 0.278393 + x * d;
        d = 1.0 + x * d;
        let d2 = d * d;
        return 1.0 / (d2 * d2);
    }
    let t = 1.0 / (1.0 + 0.3275911 * x);
    var poly = 1.0614054;
    poly = -1.4531521 + t * poly;
    poly = 1.4214138 + t * poly;
    poly = -0.28449674 + t * poly;
    poly = 0.2548296 + t * poly;
    return (t * poly) * exp(-x * x);
}

// Eq. 10-12: fraction of the samples with moments m = (A z, A z^2, A, _) inside [zc - rc, zc + rc].
fn lrsm_depth_visibility(m: vec4<f32>, zc_in: f32, rc_in: f32, cdf: u32, min_variance: f32, min_alpha: f32) -> f32 {
    let a = m.z;
    if (!(a > min_alpha)) {
        return 0.0;
    }
    let mu = clamp(m.x / a, -LRSM_DEPTH_LIMIT, LRSM_DEPTH_LIMIT);
    let variance = clamp(m.y / a - mu * mu, min_variance, LRSM_DEPTH_LIMIT * LRSM_DEPTH_LIMIT);
    let sigma = sqrt(variance);
    let zc = clamp(zc_in, -LRSM_DEPTH_LIMIT, LRSM_DEPTH_LIMIT);
    let rc = clamp(rc_in, 0.0, LRSM_DEPTH_LIMIT);
    let hi = ((zc + rc) - mu) / sigma;
    let lo = ((zc - rc) - mu) / sigma;
    var v: f32;
    if (lo >= 0.0) {
        v = 0.5 * (lrsm_erfc(lo * LRSM_FRAC_1_SQRT_2, cdf) - lrsm_erfc(hi * LRSM_FRAC_1_SQRT_2, cdf));
    } else if (hi <= 0.0) {
        v = 0.5 * (lrsm_erfc(-hi * LRSM_FRAC_1_SQRT_2, cdf) - lrsm_erfc(-lo * LRSM_FRAC_1_SQRT_2, cdf));
    } else {
        v = 1.0 - 0.5 * (lrsm_erfc(hi * LRSM_FRAC_1_SQRT_2, cdf) + lrsm_erfc(-lo * LRSM_FRAC_1_SQRT_2, cdf));
    }
    return clamp(v, 0.0, 1.0);
}

// The smooth falloff k of eq. 15: smoothstep of x clamped to [0, 1].
fn lrsm_falloff(x: f32) -> f32 {
    let t = clamp(x, 0.0, 1.0);
    return (t * t) * (3.0 - 2.0 * t);
}

// Eq. 15: weight of the layer [zmin, zmax] with overlap delta at depth zc.
fn lrsm_layer_decay(zc: f32, zmin: f32, zmax: f32, delta: f32) -> f32 {
    if (delta <= 0.0) {
        return select(0.0, 1.0, zc >= zmin && zc <= zmax);
    }
    return min(lrsm_falloff((zc - zmin) / delta), lrsm_falloff((zmax - zc) / delta));
}
