// gaussian_depth_visibility — LRSM eq. 10-12 (Sugihara et al. 2014, "Layered Reflective Shadow Maps",
// section 4.2 "Depth pre-filtering"). Mirror: cpu_mirror/src/gaussian_depth_visibility.rs.
// Declaration: src/kernels/gaussian_depth_visibility.rs.
//
// Per element i: moments[i] = (A z, A z^2, A, unused), the pre-filtered opacity-weighted depth moments of
// one LRSM layer texel (A = mean opacity over the footprint, depths warped to [0, 1] within the layer),
// and cone[i] = (zc, rc), the cone sample's centre depth and radius in the same warped units. Output:
//   V = Phi((zc + rc - mu) / sigma) - Phi((zc - rc - mu) / sigma)                       (eq. 12)
//   mu = Az / A (eq. 10),  sigma^2 = max(Az^2 / A - mu^2, min_variance) (eq. 11, floored)
// Phi is evaluated through erfc on |t| / sqrt(2) so neither tail cancels (both ends above the mean:
// V = (Q(lo) - Q(hi)) / 2; both below: mirrored; straddling: 1 - (Q(hi) + Q(-lo)) / 2), with Q one of
//   cdf 0: Abramowitz & Stegun 7.1.26  t (a1 + t (a2 + t (a3 + t (a4 + t a5)))) exp(-x^2), t = 1/(1+px)
//   cdf 1: Abramowitz & Stegun 7.1.27  1 / (1 + a1 x + a2 x^2 + a3 x^3 + a4 x^4)^4   (no exp)
// Robustness (every finite input gives a finite V in [0, 1]): A <= min_alpha or NaN -> V = 0 (empty
// texel; normalising by a near-zero opacity is avoided); mu and zc clamped to [-1e6, 1e6], rc to
// [0, 1e6], sigma^2 to [min_variance, 1e12]; V clamped to [0, 1]. NaN inputs other than A are outside the
// contract (the partition kernel refuses NaN at the API boundary).
// Accuracy: a per-element bound from the WGSL rules of every operation on the path (division 2.5 ULP,
// sqrt via inverseSqrt, exp 3 + 2|x| ULP, FMA contraction allowed), propagated through dV/dt = phi(t):
// see visibility_bound in the mirror. WGSL's division rule stops at divisors of 2^126: for A above it
// (outside the contract's [0, 1]) V is only promised finite and in [0, 1] (measured on an H100:
// Az / A = 0 there).
// The arithmetic lives in kernels/common/lrsm_math.wgsl (shared with sample_lrsm.wgsl).

struct VisibilityParams {
    cdf: u32,
    min_variance: f32,
    min_alpha: f32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: VisibilityParams;
@group(0) @binding(1) var<storage, read> moments: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> cone: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read_write> visibility: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= arrayLength(&visibility)) {
        return;
    }
    let c = cone[i];
    visibility[i] = lrsm_depth_visibility(moments[i], c.x, c.y, params.cdf, params.min_variance, params.min_alpha);
}
