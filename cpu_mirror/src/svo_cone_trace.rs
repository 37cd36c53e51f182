//! Mirror of `kernels/svo_cone_trace.wgsl`: `cone_trace`'s march and pixel shading (generic over
//! [`Volume`]) reading the sparse voxel octree. Mip level `l` (cell `s0 2^l`) is octree level
//! `depth - l`, whose vertex lattice points sit at `origin + s0/2 + i s0 2^l` (the voxel centres at
//! level 0, where the octree's leaves hold the voxel grid itself); trilinear over the 8 brick voxels of
//! the cell holding the point, quadrilinear across levels as the pyramid. Outside the lattice and in
//! missing nodes: empty. With anisotropic voxels (`svo.anisotropic = 1`, VCT 7.1) a cone reads, above
//! the leaves, each brick voxel's three directional values facing its direction `d`
//! (`svo_anisotropic`), mixed with weights `d.x^2, d.y^2, d.z^2`.
//!
//! **Voxel shading with Gaussian lobes** (`svo.lobes = 1`, VCT sections 4.3 and 7): a second brick pool
//! in the same node layout holds each voxel's normals pre-multiplied by opacity, filtered as the
//! radiance is, so a sample's averaged normal `N` (length <= 1) describes its normal distribution as a
//! Gaussian lobe of variance `sigma_n^2 = (1 - |N|) / |N|` (Toksvig). The cone's span is a second lobe
//! (Fig. 7): the directions of a cone of half-angle `psi` average to a vector of length
//! `(1 + cos psi) / 2`, so in the same encoding `sigma_v^2 = (1 - cos psi) / (1 + cos psi) =
//! tan^2(psi / 2)` (the paper prints `sigma_v = cos psi`, which grows as the cone narrows; we keep its
//! encoding instead). Convolving the two adds the variances. The voxels are diffuse (photons store
//! outgoing radiance, the cosine already in their flux), so the BRDF's diffuse lobe leaves one question
//! per sample: which share of the voxel's surface faces the cone's origin. With `c` the cosine between
//! the lobe's axis and `-d`, the share of the convolved lobe on the front side is the normal CDF
//! `Phi(c / sigma)`, `sigma^2 = sigma_n^2 + sigma_v^2` (measured along the cosine: a step for a flat
//! surface seen from either side, 1/2 for a voxel whose normals cancel), taken with the logistic
//! approximation `1 / (1 + exp(-1.702 x))` (at most 0.0095 from Phi). The sample's colour is scaled by it;
//! its opacity is not (occlusion is view-independent, section 4.3).
//!
//! **Glossy voxels** (`svo.lobes & 2`): a third pool, same layout, holds the specular photons
//! (`svo_photons`: the light's mirror directions scaled by the Phong lobe's mean length, weighted by
//! their specular flux, encoded `((q + w) / 2, w)`). A sample decodes `q = 2 xyz - w`; its mean length
//! `rbar = |q| / w` gives the reflected light's von Mises-Fisher concentration `kappa_s = rbar /
//! (1 - rbar)` (the inverse of the encoding `m = Ns / (Ns + 1)`; the spread of light directions and
//! normals within the cell shortens it further), convolved with the cone's `kappa_v = 1 /
//! tan^2(psi/2)` as variances add: `kappa = kappa_s kappa_v / (kappa_s + kappa_v)`. The sample's colour
//! gains `w vMF(-d; q / |q|, kappa)` (grey: luminance), the glossy light the voxel sends towards the
//! cone's origin ([`glossy_voxel`]).
use crate::cone_trace::{quadrilinear, ConeParams, SampleError, Volume};
use crate::sparse_voxel_octree::{brick_value, find, voxel_index, Node, NONE};
use crate::svo_anisotropic::{direction, DIRECTIONS};
use glam::{Vec3, Vec4};

/// The kernel's `struct SvoParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SvoParams {
    pub depth: u32,
    pub inv_scale: f32,
    /// 1: directional values above the leaves (`SvoVolume::aniso`).
    pub anisotropic: u32,
    /// Bit 0: voxel shading with Gaussian lobes from the normal pool (`SvoVolume::normals`); bit 1:
    /// glossy voxels from the specular pool (`SvoVolume::spec`).
    pub lobes: u32,
}

pub struct SvoVolume<'a> {
    /// `levels` = depth + 1, `side` = 2^(depth + 1).
    pub p: &'a ConeParams,
    pub svo: &'a SvoParams,
    pub nodes: &'a [Node],
    pub bricks: &'a [u32],
    /// `svo_anisotropic`'s directional values (read when `svo.anisotropic` = 1).
    pub aniso: &'a [[f32; 4]],
    /// The normal pool (read when `svo.lobes` = 1): bricks in `nodes`' layout, per voxel
    /// `((n + 1) alpha / 2, alpha)` in fixed point ([`normal_value`]), `n` the surface's mean normal.
    pub normals: &'a [u32],
    /// The specular pool (read when `svo.lobes & 2`): bricks in `nodes`' layout, per voxel the sum of
    /// its specular photons' `((q + w) / 2, w)` in fixed point (`svo_photons`).
    pub spec: &'a [u32],
}

/// The glossy light a specular-pool sample `e` sends towards the origin of a cone along `d` (half-angle
/// tangent `tan_half`), `w vMF(-d; q / |q|, kappa)` (module doc), in the kernel's operation order, and
/// its bound given the sample's error `err`.
///
/// Bound: the density lies in `[0, D(kappa_v)]` (`kappa < kappa_v`, the vMF peak `kappa / (2 pi (1 -
/// e^-2kappa))` grows with `kappa`), so the term is within `(w + e_w) D(kappa_v)` of anything; within
/// that, the first-order terms: `e_w D(kappa_v)`, and `w` times the density's change — `|d ln D / d
/// kappa| <= 3` (`1/kappa - 2 / (e^2kappa - 1)` is in [0, 1] and `|c - 1| <= 2`) times kappa's (through
/// `rbar`: `d kappa / d kappa_s = (kappa_v / (kappa_s + kappa_v))^2`, `d kappa_s / d rbar = 1 / (1 -
/// rbar)^2`), `kappa` times the cosine's (the axis moves by `sqrt 3 e_q / |q|`, `d` by 16 ULP), and
/// exp's `3 + 2 |kappa (c - 1)|` ULP plus 64 ULP of the rest.
pub fn glossy_voxel(e: Vec4, d: Vec3, tan_half: f32, err: SampleError) -> (f32, f32) {
    use std::f32::consts::PI;
    let u = f32::EPSILON;
    let w = e.w;
    if w <= 0.0 {
        return (0.0, 0.0);
    }
    let q = 2.0 * e.truncate() - Vec3::splat(w);
    let ql = q.length();
    let rbar = (ql / w).min(0.999);
    let ks = rbar / (1.0 - rbar);
    let t2 = tan_half * tan_half;
    let r = (1.0 + t2).sqrt();
    let s = t2 / ((1.0 + r) * (1.0 + r));
    let kv = 1.0 / s.max(1e-6);
    let k = ks * kv / (ks + kv);
    let c = if ql > 0.0 { -q.dot(d) / ql } else { 0.0 };
    let peak = |k: f32| {
        if k > 1e-4 {
            k / (2.0 * PI * (1.0 - (-2.0 * k).exp()))
        } else {
            1.0 / (4.0 * PI)
        }
    };
    let dens = if k > 1e-4 {
        k / (2.0 * PI * (1.0 - (-2.0 * k).exp())) * (k * (c - 1.0)).exp()
    } else {
        1.0 / (4.0 * PI)
    };
    let t = w * dens;
    // Bound.
    let dm = peak(kv) * (1.0 + 1e-3);
    let e_q = 2.0 * err.rgb + err.a + 4.0 * u * (2.0 * e.truncate().abs().max_element()).max(w);
    let e_w = err.a;
    let cap = (w + e_w) * dm;
    if w <= e_w || ql <= 3f32.sqrt() * e_q {
        return (t, cap);
    }
    let e_rbar = (3f32.sqrt() * e_q + 8.0 * u * ql + rbar * e_w) / (w - e_w);
    let lo = (rbar + e_rbar).min(0.999);
    let e_ks = e_rbar / ((1.0 - lo) * (1.0 - lo));
    let e_k = e_ks * (kv / (ks + kv)).powi(2);
    let e_c = 2.0 * 3f32.sqrt() * e_q / (ql - 3f32.sqrt() * e_q) + 24.0 * u;
    let rel = 3.0 * e_k + k * e_c + (67.0 + 2.0 * (k * (c - 1.0)).abs()) * u;
    let first = e_w * dm + w * dens * (rel.exp() - 1.0 + rel);
    (t, first.min(cap))
}

/// Logistic slope approximating the normal CDF: `Phi(x) ~ 1 / (1 + exp(-1.702 x))`.
pub const LOGISTIC: f32 = 1.702;

/// A voxel's normal-pool value before fixed point: `((n + 1) alpha / 2, alpha)` (non-negative, as the
/// octree's u32 channels need; the mean normal `n` is clamped to length 1). Filtering is linear, so a
/// sample decodes as `N alpha = 2 xyz - w` at any level.
pub fn normal_value(n: Vec3, alpha: f32) -> [f32; 4] {
    let len = n.length();
    let n = if len > 1.0 { n / len } else { n };
    [
        (n.x + 1.0) * alpha * 0.5,
        (n.y + 1.0) * alpha * 0.5,
        (n.z + 1.0) * alpha * 0.5,
        alpha,
    ]
}

/// The lobe shading factor of a normal-pool sample `e` (encoded, see [`normal_value`]) for a cone
/// along `d` with half-angle tangent `tan_half`, in the kernel's operation order, and its bound given
/// the sample's own error `err` (`rgb` per encoded channel, `a` for `w`).
///
/// With `P = N alpha = 2 e.xyz - e.w`, `A = e.w`, `m = min(|P|, A)` and `s = tan^2(psi/2) =
/// t^2 / (1 + sqrt(1 + t^2))^2` (the cancellation-free form), `c / sigma` is
/// `x = -P.d / sqrt(m (A - m) + m^2 s)` (numerator and denominator of the definition times `A |N|`):
/// no division by a small alpha. `m = 0` (no normal left): `x = 0`, the factor 1/2.
///
/// Bound: the logistic's slope is at most `1.702 / 4`, so `|dV| <= 0.43 |dx|`; `x`'s error is the
/// numerator's (the sample's `2 rgb + a` per component of `P` over `|d|_1 <= sqrt 3`, `d`'s 16 ULP per
/// component, `dot`'s 4 ULP) plus `|x|` times the denominator's relative error (the squared
/// denominator moves by its partial derivatives times `m`'s and `A`'s errors, plus 8 ULP of its
/// terms; halved by the square root) plus 4 ULP of `x`; the logistic itself (exp: 3 + 2|x| ULP, then
/// an addition and a division) adds 64 ULP. Where the denominator's error reaches the denominator,
/// any factor in [0, 1] is possible: bound 1.
pub fn lobe_visibility(e: Vec4, d: Vec3, tan_half: f32, err: SampleError) -> (f32, f32) {
    let u = f32::EPSILON;
    let p = 2.0 * e.truncate() - Vec3::splat(e.w);
    let a = e.w;
    let m = p.length().min(a);
    let t2 = tan_half * tan_half;
    let r = (1.0 + t2).sqrt();
    let s = t2 / ((1.0 + r) * (1.0 + r));
    let den2 = m * (a - m) + m * m * s;
    let num = -p.dot(d);
    let x = if den2 > 0.0 {
        (num / den2.sqrt()).clamp(-40.0, 40.0)
    } else {
        0.0
    };
    let v = 1.0 / (1.0 + (-LOGISTIC * x).exp());
    // Bound.
    let e_p =
        2.0 * err.rgb + err.a + 4.0 * u * (2.0 * e.truncate().abs().max_element()).max(a.abs());
    let p1 = p.abs().element_sum();
    let e_num = 3f32.sqrt() * e_p + 20.0 * u * p1;
    let e_m = (3f32.sqrt() * e_p + 8.0 * u * p.length()).max(err.a);
    let e_den2 = (a - 2.0 * m + 2.0 * m * s).abs() * e_m
        + m * err.a
        + 16.0 * u * (m * a.abs() + m * m + m * m * s);
    if den2 <= e_den2 {
        return (v, 1.0);
    }
    let den = den2.sqrt();
    let e_x = (e_num + x.abs() * e_den2 / (2.0 * (den2 - e_den2).sqrt())) / den + 4.0 * u * x.abs();
    (v, (0.43 * e_x + 64.0 * u).min(1.0))
}

impl SvoVolume<'_> {
    /// Trilinear sample of mip level `l`; with `d`, the directional values along it where the level
    /// has them (above the leaves).
    fn level_dir(&self, x: Vec3, l: u32, d: Option<Vec3>) -> (Vec4, SampleError) {
        self.level_in(self.bricks, x, l, d)
    }

    /// [`Self::level_dir`] reading the brick pool `pool` (the radiance's or the normals').
    fn level_in(&self, pool: &[u32], x: Vec3, l: u32, d: Option<Vec3>) -> (Vec4, SampleError) {
        let s = self.svo.depth - l;
        let inv = self.p.inv_s0 * (1.0 / (1u32 << l) as f32);
        let origin = Vec3::from_slice(&self.p.origin[..3]);
        let q = (x - origin) * inv - Vec3::splat(0.5 / (1u32 << l) as f32);
        // The sample point's rounding, as cone_trace's Pyramid::level (see SampleError).
        let dq = SampleError::coordinate_error(x, origin, inv, q);
        let fl = q.floor();
        let f = q - fl;
        let i0 = [fl.x as i32, fl.y as i32, fl.z as i32];
        let points = (2u32 << s) as i32;
        let last = (1i32 << s) - 1;
        let c = i0.map(|i| (i >> 1).clamp(0, last));
        let n = find(self.nodes, s, c.map(|v| v as u32));
        let mut acc = Vec4::ZERO;
        let mut err = SampleError::default();
        if n == NONE {
            return (acc, err);
        }
        for corner in 0..8u32 {
            let cc = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let w = [0, 1, 2].map(|a| if cc[a] == 1 { f[a] } else { 1.0 - f[a] });
            let i = [0, 1, 2].map(|a| i0[a] + cc[a] as i32);
            let local = [0, 1, 2].map(|a| i[a] - 2 * c[a]);
            if (0..3).any(|a| i[a] < 0 || i[a] > points || local[a] < 0 || local[a] > 2) {
                continue;
            }
            let vi = voxel_index(local.map(|v| v as u32));
            let v = match d {
                Some(d) if s < self.svo.depth => {
                    let base = (n as usize * 27 + vi) * DIRECTIONS;
                    let pick =
                        |a: usize, c: f32| Vec4::from_array(self.aniso[base + direction(a, c)]);
                    let (ax, ay, az) = (pick(0, d.x), pick(1, d.y), pick(2, d.z));
                    let w2 = d * d;
                    // The mixing weights' error: d differs from the GPU's by a few ULP (16 of a unit
                    // vector's components), so d_a^2 by 2 |d_a| 16 u + 3 u (its own roundings); a
                    // component within 16 u of 0 may pick the other sign, at weight (16 u)^2.
                    let ed = 16.0 * f32::EPSILON;
                    let tw = w[0] * w[1] * w[2];
                    for (a, da) in [(0, d.x), (1, d.y), (2, d.z)] {
                        let both = pick(a, da).abs().max(pick(a, -da).abs());
                        let dw = 2.0 * da.abs() * ed + 3.0 * f32::EPSILON + ed * ed;
                        err.rgb += tw * dw * both.x.max(both.y).max(both.z);
                        err.a += tw * dw * both.w;
                    }
                    (ax * w2.x + ay * w2.y) + az * w2.z
                }
                _ => brick_value(pool, n, vi, self.svo.inv_scale),
            };
            acc += v * (w[0] * w[1] * w[2]);
            err.add_corner(dq, w, v);
        }
        (acc, err)
    }
}

impl Volume for SvoVolume<'_> {
    fn params(&self) -> &ConeParams {
        self.p
    }

    fn level(&self, x: Vec3, l: u32) -> (Vec4, SampleError) {
        self.level_dir(x, l, None)
    }

    /// Anisotropic: quadrilinear as [`Volume::sample`] over the directional levels. Lobes: the colour
    /// times [`lobe_visibility`] of the normal pool's quadrilinear sample.
    fn sample_cone(
        &self,
        x: Vec3,
        lf: f32,
        _diam: f32,
        d: Vec3,
        tan_half: f32,
    ) -> (Vec4, SampleError) {
        let (s, err) = if self.svo.anisotropic == 0 {
            self.sample(x, lf)
        } else {
            quadrilinear(self.p.levels - 1, lf, |l| self.level_dir(x, l, Some(d)))
        };
        if self.svo.lobes == 0 {
            return (s, err);
        }
        let (mut rgb, mut e_rgb) = (s.truncate(), err.rgb);
        if self.svo.lobes & 1 != 0 {
            let (e, e_err) = quadrilinear(self.p.levels - 1, lf, |l| {
                self.level_in(self.normals, x, l, None)
            });
            let (v, v_err) = lobe_visibility(e, d, tan_half, e_err);
            rgb *= v;
            e_rgb = err.rgb * v
                + s.truncate().abs().max_element() * v_err
                + f32::EPSILON * rgb.abs().max_element();
        }
        if self.svo.lobes & 2 != 0 {
            let (e, e_err) = quadrilinear(self.p.levels - 1, lf, |l| {
                self.level_in(self.spec, x, l, None)
            });
            let (t, t_err) = glossy_voxel(e, d, tan_half, e_err);
            rgb += Vec3::splat(t);
            e_rgb += t_err + f32::EPSILON * rgb.abs().max_element();
        }
        (
            rgb.extend(s.w),
            SampleError {
                rgb: e_rgb,
                a: err.a,
            },
        )
    }
}
