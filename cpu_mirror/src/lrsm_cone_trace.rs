//! Mirror of `kernels/lrsm_cone_trace.wgsl`: the lrsm pipeline's final gathering (Sugihara et al. 2014,
//! eq. 1 and Algorithm 1) — cone_trace's march (`cone_trace::march`, `shade_pixel`) over an
//! [`LrsmVolume`]: occlusion from the binary occlusion voxels' mips, radiance from the light views' LRSMs.
//!
//! Bound of one sample's radiance L (what `sample_cone` reports as its colour error): Sample LRSM's own
//! arithmetic bound (`sample_lrsm::sample_bound`), plus what the sample point's rounding may change,
//! evaluated at the perturbed inputs: the trilinear fetch's position (u, v) and level (mip), the depth
//! (zc: layer ranges, decay, Gaussian visibility), each the larger change at its two ends, summed, all
//! times the view's weight; and the view's weight [`disc_share`] (its error from the disc's centre and
//! radius, times the view's |L|: a view the mirror leaves with weight 0 is still evaluated where the
//! GPU's weight may be positive); plus 1e-4 of |L| for the direction vc = -d (a few ULP off the
//! mirror's; N = <n, vc> moves L by as little relatively). The input errors come from the sample
//! point's: 16 ULP of the magnitudes of x and the eye, through the projection's divisions (2.5 ULP) and
//! log2 (absolute 2^-21).
use crate::cone_trace::{trilinear_level, ConeParams, SampleError, Volume};
use crate::occlusion_voxels::level_byte;
use crate::reflective_shadow_map::GpuView;
use crate::sample_lrsm::{sample, sample_bound, Lrsm, SampleParams};
use glam::{Vec3, Vec4};

/// Everything the gather's samples read.
pub struct LrsmVolume<'a> {
    pub p: &'a ConeParams,
    /// The occlusion pyramid's words, levels concatenated; level l from word `occ_offsets[l]`.
    pub occ: &'a [u32],
    pub occ_offsets: &'a [u32],
    pub sp: &'a SampleParams,
    /// Every view's LRSM, concatenated (view k's from texel `views[k].info[2]`).
    pub lrsm: Lrsm<'a>,
    pub views: &'a [GpuView],
    /// The lit cells (`sp.lit_cells`; lit_cells.rs), every level, two vec4 a cell; level l from
    /// cell `lit_offsets[l]`. Empty otherwise.
    pub lit: &'a [[f32; 4]],
    pub lit_offsets: &'a [u32],
    /// Bound on any sample's L (for samples whose alpha the mirror has as 0).
    pub lmax: f32,
}

impl LrsmVolume<'_> {
    fn view_lrsm(&self, k: usize) -> Lrsm<'_> {
        let base = self.views[k].info[2] as usize;
        Lrsm {
            depth_ranges: self.lrsm.depth_ranges,
            radiance: &self.lrsm.radiance[base..],
            normal: &self.lrsm.normal[base..],
            moments: &self.lrsm.moments[base..],
        }
    }

    /// The lit cells' premultiplied L at `x`, level `lf` (cone direction `d`), read with the
    /// occlusion read's cells and weights, and its bound (largest channel): the sample point's
    /// rounding (as alpha's, `trilinear_level`), each cell's own arithmetic
    /// (`lit_cells::cell_light_bound`) weighted as the cell is, and the level's drift (the march
    /// adds log2's rounding, 2^-21, at every step: at most 2^-14 over its samples; the larger
    /// change at its two ends).
    pub fn lit_radiance(&self, x: Vec3, lf: f32, d: Vec3) -> (Vec3, f32) {
        use crate::lit_cells::{cell_light, cell_light_bound};
        let vc = -d;
        // Occlusion level l is the lit table's level l - base; finer samples read level base.
        let base = self.sp.lit_base;
        let lf = lf.max(base as f32);
        let cell = |l: u32, m: usize| {
            let c = 2 * (self.lit_offsets[(l - base) as usize] as usize + m);
            let (a, b) = (self.lit[c], self.lit[c + 1]);
            [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]]
        };
        let top = self.p.levels - 1;
        let at = |lf: f32| {
            crate::cone_trace::quadrilinear(top, lf, |l| {
                trilinear_level(self.p, x, l, |m| cell_light(&cell(l, m), l - base, vc))
            })
        };
        let (s, e) = at(lf);
        let (b, _) = crate::cone_trace::quadrilinear(top, lf, |l| {
            trilinear_level(self.p, x, l, |m| {
                Vec4::splat(cell_light_bound(&cell(l, m), l - base))
            })
        });
        let drift = 2f32.powi(-14);
        let change = |o: Vec4| (o - s).truncate().abs().max_element();
        let d_level = change(at(lf + drift).0).max(change(at((lf - drift).max(base as f32)).0));
        let l = s.truncate();
        (
            l,
            e.rgb + b.x + d_level + 8.0 * f32::EPSILON * l.abs().max_element(),
        )
    }

    /// L at `x` (diameter `diam`, cone direction `d`) and its bound (largest channel).
    pub fn radiance(&self, x: Vec3, diam: f32, d: Vec3) -> (Vec3, f32) {
        let u = f32::EPSILON;
        let mut sum = Vec3::ZERO;
        let mut err = 0.0f32;
        let dir = [-d.x, -d.y, -d.z, 0.0];
        for (k, v) in self.views.iter().enumerate() {
            let lrsm = self.view_lrsm(k);
            let eye = Vec3::new(v.eye[0], v.eye[1], v.eye[2]);
            let dx = 16.0 * u * (x.abs().max_element() + eye.abs().max_element());
            let Some((nx, ny, zv)) = v.project(x) else {
                continue;
            };
            // Orthographic views do not divide by depth: their errors do not grow with 1 / zv.
            let div = if v.orthographic() { 1.0 } else { zv };
            let rnorm = Vec3::new(v.right[0], v.right[1], v.right[2]).length();
            let d_ndc = 2.0 * dx * rnorm / div + 8.0 * u * (nx.abs().max(ny.abs()) + 1.0);
            let at = |nx: f32, ny: f32, mip: f32, zc: f32| -> [f32; 4] {
                let pos = [(nx + 1.0) * 0.5, (1.0 - ny) * 0.5, mip, zc];
                let dr = [dir[0], dir[1], dir[2], (0.5 * diam) * v.forward[3]];
                sample(&lrsm, self.sp, pos, dr, false)
            };
            // The projected diameter in LRSM level-0 texels.
            let texels = if v.orthographic() {
                diam * v.right[3]
            } else {
                diam * v.right[3] / zv
            };
            // Area-weighted LRSMs one level finer; the subtraction rounds once, within d_mip's
            // allowance for log2's own rounding.
            let mip = texels.log2() - self.sp.area as f32;
            let zc = (zv - v.eye[3]) * v.forward[3];
            // The share of the sample's projected disc (radius texels / side0 in NDC, capped at 64 so
            // that it stays finite as zv -> 0, floored at 1e-30 so that the share's division stays
            // defined) inside the view (disc_share); the lookup at the clamped point. Where zv is
            // within its error of 0, d_ndc (divided by zv) makes dw 1: the GPU may take or leave the
            // view.
            let r = (texels * (1.0 / self.sp.side0 as f32)).clamp(1e-30, 64.0);
            let (wx, wy) = (disc_share(nx, r), disc_share(ny, r));
            let w = wx * wy;
            // Its error: each share's numerator 1 - |c| + r moves with c (d_ndc) and r (relative
            // e_rel: diam * right.w / zv, as the mip's), its denominator 2r by e_rel; 8 ULP of the rest.
            let e_rel = 2.0 * dx / div + 8.0 * u;
            let d_share = |c: f32| {
                let a = c.abs();
                let q = span_ratio(c, r);
                // Each end of the span moves with c (d_ndc) and r (r e_rel), plus its roundings.
                let d_span = 2.0 * (d_ndc + r * e_rel) + 4.0 * u * (a + r + 1.0);
                let dq = d_span / (2.0 * r) + q.abs() * e_rel + 8.0 * u;
                // Clamped to [0, 1]: only an unclamped value within its error of that range moves.
                if q > -dq && q < 1.0 + dq {
                    dq.min(1.0)
                } else {
                    0.0
                }
            };
            let (dwx, dwy) = (d_share(nx), d_share(ny));
            let dw = (dwx * wy + wx * dwy + dwx * dwy + 2.0 * u * w).min(1.0);
            if w + dw <= 0.0 {
                continue;
            }
            let (cx, cy) = (nx.clamp(-1.0, 1.0), ny.clamp(-1.0, 1.0));
            let l0 = at(cx, cy, mip, zc);
            let l0v = Vec3::new(l0[0], l0[1], l0[2]);
            // The GPU's weight may differ by dw (and take a view this one leaves).
            err += l0v.abs().max_element() * dw;
            if w <= 0.0 {
                continue;
            }
            sum += l0v * w;
            let (nx, ny) = (cx, cy);
            let pos = [(nx + 1.0) * 0.5, (1.0 - ny) * 0.5, mip, zc];
            let dr = [dir[0], dir[1], dir[2], (0.5 * diam) * v.forward[3]];
            let b = sample_bound(&lrsm, self.sp, pos, dr);
            err += w * (b[0].max(b[1]).max(b[2]) + 1e-4 * l0v.abs().max_element());
            // The inputs' errors: L is continuous in (u, v, mip) (trilinear fetches) and piecewise
            // smooth in zc (layer ranges, decay, V), so per input the larger change at its two
            // perturbed ends bounds it first order (a kink inside the interval changes L by less than
            // the steeper side's end does); the four inputs' errors add.
            let d_mip = (2.0 * dx / div + 8.0 * u) / std::f32::consts::LN_2 + 2f32.powi(-20);
            let d_z = 2.0 * dx * v.forward[3] + 8.0 * u * zc.abs();
            let change = |a: [f32; 4]| {
                (a[0] - l0[0])
                    .abs()
                    .max((a[1] - l0[1]).abs())
                    .max((a[2] - l0[2]).abs())
            };
            let ends = [
                [at(nx + d_ndc, ny, mip, zc), at(nx - d_ndc, ny, mip, zc)],
                [at(nx, ny + d_ndc, mip, zc), at(nx, ny - d_ndc, mip, zc)],
                [at(nx, ny, mip + d_mip, zc), at(nx, ny, mip - d_mip, zc)],
                [at(nx, ny, mip, zc + d_z), at(nx, ny, mip, zc - d_z)],
            ];
            err += w * ends
                .iter()
                .map(|[a, b]| change(*a).max(change(*b)))
                .sum::<f32>();
        }
        (sum, 2.0 * err)
    }
}

/// The share of a sample's projected disc (centre `c`, radius `r`, NDC units along one axis of a view)
/// inside the view's [-1, 1]: the length of its span `[|c| - r, |c| + r]` inside, over its diameter
/// — 1 well inside, 1/2 centred on an edge, 0 a radius past it (and less than 1 for a disc wider than
/// the view). Per axis, multiplied, it weighs each view's radiance, so a sample across the seam of a
/// point light's two cube faces takes from both (their shares sum to about 1) instead of from the one
/// its centre falls in. In the kernel's operation order; finite inputs.
pub fn disc_share(c: f32, r: f32) -> f32 {
    span_ratio(c, r).clamp(0.0, 1.0)
}

/// [`disc_share`] before its clamp to [0, 1] (the bound needs where it lies against that range).
fn span_ratio(c: f32, r: f32) -> f32 {
    let a = c.abs();
    let span = (a + r).min(1.0) - (a - r).max(-1.0);
    span / (2.0 * r)
}

impl Volume for LrsmVolume<'_> {
    fn params(&self) -> &ConeParams {
        self.p
    }

    /// (0, 0, 0, occlusion) at `x`, trilinear in occlusion level `l` (byte / 255, level 0's bits as 0
    /// or 255; the kernel computes `(f32(b) * (1 / 255)) * weight`, the same products in the same
    /// order).
    fn level(&self, x: Vec3, l: u32) -> (Vec4, SampleError) {
        let off = self.occ_offsets[l as usize] as usize;
        trilinear_level(self.p, x, l, |m| {
            Vec4::new(
                0.0,
                0.0,
                0.0,
                level_byte(&self.occ[off..], l, m) as f32 * (1.0 / 255.0),
            )
        })
    }

    /// `(L * alpha, alpha)`, or `(L, alpha)` with area-weighted LRSMs (`sp.area`: L is then eq. 1's
    /// premultiplied product); where the mirror's alpha is 0 the LRSMs are not read (as in the
    /// kernel) and the colour error is `lmax` times the alpha's, or `lmax` itself when premultiplied
    /// and the alpha may be above 0 on the GPU (which then adds L whole).
    fn sample_cone(
        &self,
        x: Vec3,
        lf: f32,
        diam: f32,
        d: Vec3,
        _tan_half: f32,
    ) -> (Vec4, SampleError) {
        let (s, serr) = self.sample(x, lf);
        let premultiplied = self.sp.area != 0 || self.sp.lit_cells != 0;
        // With premultiplied L a GPU whose alpha is above 0 where the mirror's is 0, or 0 where the
        // mirror's is within its error of it, adds or leaves L whole.
        let flip = if premultiplied { self.lmax } else { 0.0 };
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(s.w > 0.0) {
            return (
                s,
                SampleError {
                    rgb: if serr.a > 0.0 { flip } else { 0.0 } + self.lmax * serr.a,
                    a: serr.a,
                },
            );
        }
        let (l, l_err) = if self.sp.lit_cells != 0 {
            self.lit_radiance(x, lf, d)
        } else {
            self.radiance(x, diam, d)
        };
        if premultiplied {
            return (
                l.extend(s.w),
                SampleError {
                    // The march's own roundings of the colour it adds, as for L alpha below.
                    rgb: l_err
                        + 8.0 * f32::EPSILON * l.abs().max_element()
                        + if s.w <= serr.a { flip } else { 0.0 },
                    a: serr.a,
                },
            );
        }
        let rgb = l * s.w;
        (
            Vec4::new(rgb.x, rgb.y, rgb.z, s.w),
            SampleError {
                rgb: s.w * l_err
                    + (l.abs().max_element() + l_err) * serr.a
                    + 8.0 * f32::EPSILON * rgb.abs().max_element(),
                a: serr.a,
            },
        )
    }
}

/// The shadow cones' parameters (the WGSL `ShadowParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShadowParams {
    pub tan_half: f32,
    pub light_count: u32,
    pub _pad: [u32; 2],
}

/// Visibility `1 - A` of a shadow cone from `o` along `d` up to `t_end` (the kernel's
/// `shadow_visibility`), and a bound on |GPU - mirror|: per sample the alpha error carried exactly
/// through the step correction (the sample point's error, 8 ULP of the blend, the level's drift of
/// 2^-21 per step from log2), pow's absolute error, 4e-4 of the accumulated alpha; plus the rest of
/// the cone where a stop (opacity, the end) is within that error of its threshold.
pub fn shadow_visibility(vol: &LrsmVolume, o: Vec3, d: Vec3, tan: f32, t_end: f32) -> (f32, f32) {
    use crate::cone_trace::{step_alpha, step_alpha_error, MAG, OPAQUE};
    let p = vol.p;
    let s0 = p.origin[3];
    let sf = p.step_factor;
    let grow = 1.0 + 2.0 * sf * tan;
    let dl = grow.log2();
    let t_stop = t_end.min(p.side as f32 * s0 * 1.732_050_8);
    let mut diam = 0.75 * s0;
    let mut lf: f32 = -0.415_037_5;
    let mut t = diam * (0.5 * sf);
    let mut a_acc = 0.0f32;
    let mut a_err = 0.0f32;
    let mut allowance = 0.0f32;
    let mut step = 0u32;
    while t <= t_stop && a_acc < OPAQUE {
        let (s, serr) = vol.sample(o + d * t, lf);
        let ratio = sf * (diam * p.inv_s0).min(1.0);
        let a = s.w.clamp(0.0, 1.0);
        let a2 = step_alpha(a, ratio);
        let vis = 1.0 - a_acc;
        let da = serr.a + 8.0 * f32::EPSILON + step as f32 * 2f32.powi(-21);
        let da2 = step_alpha_error(a, ratio, da);
        let e_pow = if a > 0.0 && a < 1.0 {
            ratio.max(1.0) * 2f32.powi(-21) + 8.0 * f32::EPSILON
        } else {
            0.0
        };
        a_acc += vis * a2;
        a_err += vis * (da2 + 2.0 * e_pow) + MAG * vis * a2;
        if (a_acc - OPAQUE).abs() < 1e-4 + a_err || (t - t_stop).abs() < 1e-5 * t_stop.max(s0) {
            allowance += vis.max(1.0 - a_acc) + a_err;
        }
        t += diam * sf;
        diam *= grow;
        lf += dl;
        step += 1;
    }
    ((1.0 - a_acc).clamp(0.0, 1.0), (a_err + allowance).min(1.0))
}

/// Direct light at one G-buffer texel with shadow cones instead of shadow rays (the kernel's
/// `shadow_main`) and its bound: per light term `T V` with `T` direct_light's term (its bound as
/// there: 64 ULP, the cosines' and the incident light's errors, pow's) and `V` [`shadow_visibility`]
/// (its bound); terms whose cut-offs rounding decides (a light within 1e-5 of grazing, a hard spot
/// edge) add their whole value.
#[allow(clippy::too_many_arguments)]
pub fn soft_direct(
    vol: &LrsmVolume,
    frame: &crate::gbuffer::Frame,
    tris: &[crate::bvh_trace::GpuTriangle],
    lights: &[crate::direct_light::GpuLight],
    materials: &[crate::direct_light::GpuMaterial],
    texel: ([f32; 4], [f32; 4], u32, [f32; 4]),
    tan: f32,
) -> (Vec3, Vec3) {
    use crate::direct_light::{brdf, brdf_error, face_normal, incident, incident_error};
    let (position, normal, triangle, albedo) = texel;
    if normal[3] <= 0.0 || triangle as usize >= tris.len() {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let u = f32::EPSILON;
    let tri = &tris[triangle as usize];
    let m = &materials[(tri.material() as usize).min(materials.len() - 1)].with_albedo(albedo);
    let p = Vec3::new(position[0], position[1], position[2]);
    let n = Vec3::new(normal[0], normal[1], normal[2]);
    let ng = face_normal(tri);
    let eye = Vec3::new(frame.eye[0], frame.eye[1], frame.eye[2]);
    let wv = eye - p;
    let wo = wv * (1.0 / wv.dot(wv).sqrt());
    let o = p + ng * (vol.p.offset_voxels * vol.p.origin[3]);
    let mut sum = Vec3::ZERO;
    let mut bound = Vec3::ZERO;
    for light in lights {
        let inc = incident(light, p);
        let (e_irr, e_dir) = incident_error(light, p, 0.0);
        let e_cos = e_dir + 8.0 * u;
        let cos = n.dot(inc.wi);
        let geo = ng.dot(inc.wi);
        let ambiguous = geo.abs() < 1e-5 || inc.edge < 1e-5;
        if cos <= 0.0 || geo <= 0.0 || inc.irradiance == Vec3::ZERO {
            if (cos > -e_cos && geo > -e_cos) || ambiguous {
                bound += brdf(m, n, inc.wi, wo, cos.max(0.0))
                    * (e_irr + inc.irradiance)
                    * (cos.max(0.0) + e_cos);
            }
            continue;
        }
        let (v, bv) = shadow_visibility(vol, o, inc.wi, tan, inc.t_max);
        let f = brdf(m, n, inc.wi, wo, cos);
        let term = f * inc.irradiance * cos;
        sum += term * v;
        let bt = term * (64.0 * u)
            + f * inc.irradiance * (8.0 * u)
            + f * e_irr * (cos + e_dir)
            + brdf_error(m, n, inc.wi, wo, cos) * inc.irradiance * cos;
        bound += (term + bt) * bv + bt * v + term * v * (4.0 * u);
        // Flush to zero: WGSL lets a GPU flush subnormal intermediates, and the term is a chain of
        // products (kd, E, cos, V) whose order and fusion the GPU chooses; a partial product below
        // f32::MIN_POSITIVE may become 0 and take the term with it. The factors after it are cos, V
        // (<= 1) and E, so what can go is below MIN_POSITIVE x max(1, |E|), with a factor 8 for the
        // chain's roundings around it. Seen on lavapipe (verify seed 19): kd.x = 4.9e-38 (a generated
        // albedo near the bottom of the normal range), E.x = 0.5, the mirror's term 2.3e-38, the GPU's 0.
        bound += Vec3::splat(8.0 * f32::MIN_POSITIVE * inc.irradiance.abs().max_element().max(1.0));
        if ambiguous {
            bound += term;
        }
    }
    (sum, bound)
}

#[cfg(test)]
mod tests {
    use super::disc_share;

    /// The share's landmarks (exact: every operation's result is a small dyadic rational), and two
    /// faces meeting at a seam share every disc between them: on one face the disc's centre is at
    /// `1 - e`, on the other at `1 + e` (the other face's coordinate of a point past its edge).
    #[test]
    fn disc_share_is_the_part_of_the_disc_inside_the_view() {
        assert_eq!(disc_share(0.0, 0.25), 1.0);
        assert_eq!(disc_share(-0.75, 0.25), 1.0);
        assert_eq!(disc_share(1.0, 0.25), 0.5);
        assert_eq!(disc_share(-1.0, 0.25), 0.5);
        assert_eq!(disc_share(1.25, 0.25), 0.0);
        assert_eq!(disc_share(2.0, 0.25), 0.0);
        assert_eq!(disc_share(0.875, 0.25), 0.75);
        // A disc wider than the view: the view's width over the diameter.
        assert_eq!(disc_share(0.0, 2.0), 0.5);
        for i in 0..=16 {
            let e = 0.25 * i as f32 / 16.0;
            let total = disc_share(1.0 - e, 0.25) + disc_share(1.0 + e, 0.25);
            assert!(
                (total - 1.0).abs() <= 2.0 * f32::EPSILON,
                "e = {e}: {total}"
            );
        }
    }
}
