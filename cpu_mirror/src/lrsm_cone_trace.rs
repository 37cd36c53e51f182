//! Mirror of `kernels/lrsm_cone_trace.wgsl`: the lrsm pipeline's final gathering (Sugihara et al. 2014,
//! eq. 1 and Algorithm 1) — cone_trace's march (`cone_trace::march`, `shade_pixel`) over an
//! [`LrsmVolume`]: occlusion from the binary occlusion voxels' mips, radiance from the light views' LRSMs.
//!
//! Bound of one sample's radiance L (what `sample_cone` reports as its colour error): Sample LRSM's own
//! arithmetic bound (`sample_lrsm::sample_bound`), plus the choices the sample point's rounding may
//! change, each evaluated at the perturbed input: the texel (u or v within its error of a texel edge at
//! the chosen level), the level (mip within its error of an integer), the depth (zc moved by its error:
//! layer ranges, decay, Gaussian visibility) and the view (|nx| or |ny| within its error of 1: the whole
//! view's L); plus 1e-4 of |L| for the direction vc = -d (a few ULP off the mirror's; N = <n, vc> moves
//! L by as little relatively). The input errors come from the sample point's: 16 ULP of the magnitudes of
//! x and the eye, through the projection's divisions (2.5 ULP) and log2 (absolute 2^-21).
use crate::cone_trace::{trilinear_level, ConeParams, SampleError, Volume};
use crate::occlusion_voxels::byte;
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
            let mip = if v.orthographic() {
                (diam * v.right[3]).log2()
            } else {
                (diam * v.right[3] / zv).log2()
            };
            let zc = (zv - v.eye[3]) * v.forward[3];
            let inside = nx.abs() <= 1.0 && ny.abs() <= 1.0;
            let l0 = at(nx, ny, mip, zc);
            let l0v = Vec3::new(l0[0], l0[1], l0[2]);
            if (nx.abs() - 1.0).abs() <= d_ndc || (ny.abs() - 1.0).abs() <= d_ndc {
                // The GPU may take or leave this view.
                err += l0v.abs().max_element();
            }
            if !inside {
                continue;
            }
            sum += l0v;
            let pos = [(nx + 1.0) * 0.5, (1.0 - ny) * 0.5, mip, zc];
            let dr = [dir[0], dir[1], dir[2], (0.5 * diam) * v.forward[3]];
            let b = sample_bound(&lrsm, self.sp, pos, dr);
            err += b[0].max(b[1]).max(b[2]) + 1e-4 * l0v.abs().max_element();
            // Discrete choices within the inputs' errors.
            let level = (mip.max(0.0) as u32).min(self.sp.levels - 1);
            let s = (self.sp.side0 >> level) as f32;
            let d_mip = (2.0 * dx / div + 8.0 * u) / std::f32::consts::LN_2 + 2f32.powi(-20);
            let d_z = 2.0 * dx * v.forward[3] + 8.0 * u * zc.abs();
            let near_edge = |c: f32| {
                let t = c * s;
                (t - t.round()).abs() <= d_ndc * 0.5 * s
            };
            let mut alts: Vec<[f32; 4]> =
                vec![at(nx, ny, mip, zc + d_z), at(nx, ny, mip, zc - d_z)];
            if near_edge((nx + 1.0) * 0.5) {
                alts.push(at(nx + d_ndc, ny, mip, zc));
                alts.push(at(nx - d_ndc, ny, mip, zc));
            }
            if near_edge((1.0 - ny) * 0.5) {
                alts.push(at(nx, ny + d_ndc, mip, zc));
                alts.push(at(nx, ny - d_ndc, mip, zc));
            }
            if (mip - mip.round()).abs() <= d_mip {
                alts.push(at(nx, ny, mip + d_mip, zc));
                alts.push(at(nx, ny, mip - d_mip, zc));
            }
            let worst = alts
                .iter()
                .map(|a| {
                    (a[0] - l0[0])
                        .abs()
                        .max((a[1] - l0[1]).abs())
                        .max((a[2] - l0[2]).abs())
                })
                .fold(0.0f32, f32::max);
            err += worst;
        }
        (sum, 2.0 * err)
    }
}

impl Volume for LrsmVolume<'_> {
    fn params(&self) -> &ConeParams {
        self.p
    }

    /// (0, 0, 0, occlusion) at `x`, trilinear in occlusion level `l` (byte / 255; the kernel computes
    /// `(f32(b) * (1 / 255)) * weight`, the same products in the same order).
    fn level(&self, x: Vec3, l: u32) -> (Vec4, SampleError) {
        let off = self.occ_offsets[l as usize] as usize;
        trilinear_level(self.p, x, l, |m| {
            Vec4::new(
                0.0,
                0.0,
                0.0,
                byte(&self.occ[off..], m) as f32 * (1.0 / 255.0),
            )
        })
    }

    /// `(L * alpha, alpha)`; where the mirror's alpha is 0 the LRSMs are not read (as in the kernel) and
    /// the colour error is `lmax` times the alpha's.
    fn sample_cone(&self, x: Vec3, lf: f32, diam: f32, d: Vec3) -> (Vec4, SampleError) {
        let (s, serr) = self.sample(x, lf);
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(s.w > 0.0) {
            return (
                s,
                SampleError {
                    rgb: self.lmax * serr.a,
                    a: serr.a,
                },
            );
        }
        let (l, l_err) = self.radiance(x, diam, d);
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
