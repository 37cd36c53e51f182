//! Where lrsm's light goes: the gather's two factors per cone sample, eq. 1's occlusion alpha_i and
//! outgoing radiance L_i, each swapped for a better-known value one at a time, on the mirror frame
//! (`vxgi lrsm-factors`, docs/accuracy/lrsm.md).
//!
//! alpha_i comes from the binary occlusion voxels' mips (the paper's volume coverage, or the surface
//! coverage of `lrsm_surface_coverage`) or from vct-dense's lit-voxel pyramid (surface coverage of
//! the voxels' own fragments). L_i comes from the LRSMs (Algorithm 1 and its variants below, on
//! the frame's LRSMs or on area-weighted ones), from
//! the RSM texels themselves without filtering ([`Footprint`]: the most the light views can give), or
//! from that pyramid (`rgb / alpha`: voxel_light's radiance of the voxels in the sample, with exact shadow
//! rays, averaged over the voxels' coverage: the radiance of the surface the sample holds, which is
//! what eq. 1's L_i asks for). Both sources share the voxel grid, the march and the cone set, so a
//! row differs from another only in the factor it swaps.
// Negated comparisons as in the kernel, so NaN takes the skip branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use crate::kernels::cone_trace::Pyramids;
use crate::lrsm::Rsm;
use glam::{Vec3, Vec4};
use vxgi_cpu_mirror::cone_trace::{
    quadrilinear, trilinear_level, ConeParams, GridPoint, Pyramid, SampleError, Volume,
};
use vxgi_cpu_mirror::gaussian_depth_visibility::{normal_cdf, visibility, Cdf, VisibilityParams};
use vxgi_cpu_mirror::layer_decay::layer_decay;
use vxgi_cpu_mirror::lrsm_cone_trace::{disc_share, LrsmVolume};
use vxgi_cpu_mirror::sample_lrsm::{fetch, taps, Lrsm, SampleParams, CULL_RAMP};

/// Where a sample's occlusion comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Alpha {
    /// The occlusion voxels' mips by the paper's volume coverage (the solid fraction).
    Volume,
    /// The occlusion voxels' mips by CPRC's surface coverage (`lrsm_surface_coverage`).
    Surface,
    /// vct-dense's surface-coverage pyramid of the lit voxels.
    Voxels,
}

/// Where a sample's outgoing radiance comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Radiance {
    /// The LRSMs, Algorithm 1 with the given changes.
    Lrsm(Algorithm),
    /// vct-dense's pyramid: `rgb / alpha` of the lit voxels in the sample.
    Voxels,
}

/// Algorithm 1 (`L += f A R V N` over the layers holding zc) and what may be changed in it. The
/// default is the kernel's default (N only culls); with nothing but `view_weight` set it is the
/// kernel's mirror, otherwise this module's copy of Algorithm 1 with the changes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Algorithm {
    /// N = <n, vc> weighs L, as Algorithm 1 writes it (`lrsm_view_weight`); else it only culls back
    /// faces (a Lambertian surface's radiance does not depend on the direction it is seen from;
    /// eq. 2's w' carries <n.v> in numerator and denominator alike).
    pub view_weight: bool,
    /// V = 1 wherever the layer holds zc (no depth test inside the layer).
    pub v_one: bool,
    /// Divide by the weights' own sum `sum f A V N` (eq. 2's denominator over the surface inside the
    /// sample instead of eq. 3's over the whole projected disc): L is then the mean radiance of what
    /// the sample holds, its coverage left to alpha.
    pub normalized: bool,
    /// With `normalized`: the sum also counts, per layer, the share of its rays that stop in front of
    /// the sample (`f A P_front N`, P_front the Gaussian's mass below zc - rc): what lies in the
    /// sample along them is in shadow (the paper's second assumption, kept where it holds), while a
    /// ray that ends behind the sample saw nothing in it and weighs nothing.
    pub front_shadowed: bool,
    /// Algorithm 1's L is already a premultiplied colour (its `A V` is the coverage seen from the
    /// light): the march reads `(L, alpha)` instead of `(L alpha, alpha)`, so eq. 1's `alpha_i L_i`
    /// is that L, not alpha times it.
    pub premultiplied: bool,
    /// Keep eq. 3's Jacobian: a layer's rays weigh `1 / <n, l>` (its surface's area per solid angle,
    /// n the layer's mean normal, l towards the light), and L is eq. 3's ratio over the whole
    /// projected disc, the rays that miss the sample weighing 1 (the paper's second assumption:
    /// shadowed surface facing the light): `sum f A R V / c / (sum f A V / c + 1 - sum f A V)`.
    pub jacobian: bool,
    /// Weigh each layer's rays by the area of the surface they hit per unit of the light's image,
    /// `1 / <n, l>`, and take L as a sum, not a ratio: with `premultiplied` and `view_weight`,
    /// `alpha_i L_i = sum f (A R) V <n, vc> / <n, l>`, the lit surface in the sample (its area from
    /// the light's footprint, V keeping what lies inside the sample) times its radiance, projected
    /// along the cone, over the cone's cross-section (the footprint's disc is the cone's at the
    /// sample, so the two areas cancel). eq. 1's product with no factor counted twice.
    pub area: bool,
    /// With `premultiplied`: the lit surface the LRSMs find in the sample (`sum f A V N` with the
    /// same weights as L) is at most the surface the occlusion voxels find there (alpha_i): where
    /// it is more, L is scaled down to alpha_i's. A bound, not a fit: light reflected by more
    /// surface than the sample holds is not in the sample.
    pub capped: bool,
    /// Sample every depth layer whose core meets the sample's depth window `[zc - rc, zc + rc]`,
    /// the window clipped to that core, with no decay: eq. 14's sum over every layer, where Algorithm
    /// 1 samples only the layers whose range holds zc (the paper's shortcut, after layered variance
    /// shadow maps). A layer's core is its slice `[d, d + 1] / slices` without the overlaps (the
    /// first and last open-ended), so the cores tile depth and each depth is counted by one layer.
    pub all_layers: bool,
    /// Replace the filtered layers by the exact footprint: every RSM texel inside the sample's disc
    /// in the light's image, the disc centred where the LRSM lookup is (the sample's projection
    /// clamped to the image) and cut to the image; the views' disc shares weigh them as the LRSMs'.
    pub exact: Option<Footprint>,
    /// Read the LRSMs partitioned with area weights (lrsm_partition's `area_weights`: each texel's
    /// radiance and moments weigh `1 / <n, l>`, eq. 3's Jacobian before filtering) instead of the
    /// frame's.
    pub area_lrsm: bool,
    /// Fetch one level finer than `log2` of the disc's diameter in texels: the trilinear fetch's
    /// 2 x 2 taps then span about the disc, where at the default level they span about twice it.
    pub finer: bool,
    /// Replace the light views' lookup by their lit texels in the occlusion pyramid's own cells
    /// ([`Cells`]); read as a premultiplied colour.
    pub cells: Option<Cells>,
}

/// The light views' lit RSM texels splatted into the cells of the occlusion pyramid at the
/// sample's two levels and read trilinearly at the sample, exactly as alpha is read: per cell the
/// texels' lit surface over the cell's face (at most 1, as surface coverage caps a cell) and their
/// area-weighted radiance, every view's texels summed (each texel is seen by one view, so no share
/// weights). A texel's surface is its area in the light's image at its depth, `cos` of its ray's
/// angle to the view axis over `<n, l>`. The sample's light then sits in the cells its occlusion
/// does: where a surface's voxels are, its light is, and nowhere else. A diagnostic (every texel
/// near every sample: 20-120 s a frame), not a kernel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cells {
    /// How N culls.
    pub cull: Cull,
    /// Spread each texel over the cells its surface crosses: k x k sub-rays through the texel, each
    /// meeting the plane through its point with its normal (k from the surface's width over the
    /// cell, at most 16); without it a texel's whole surface lands in the cell of its centre's
    /// point (a texel seen at grazing light covers a long strip).
    pub spread: bool,
}

/// How [`Cells`] applies N = `<n, vc>` (the kernel's ramp: full weight from `CULL_RAMP` up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cull {
    /// Per texel, as Algorithm 1 per layer.
    Texel,
    /// Per cell, by the mean normal of its texels (area-weighted): what a table of lit cells that
    /// keeps one normal per cell can do.
    Cell,
    /// Not at all: every lit texel counts, as an isotropic voxel's light does.
    None,
}

/// [`Cells`] at `x`, pyramid level `lf` (clamped and blended between two levels as the occlusion
/// read's [`quadrilinear`]): (premultiplied L, lit coverage).
fn cells(
    rsms: &[Rsm],
    views: &[vxgi_cpu_mirror::reflective_shadow_map::GpuView],
    p: &ConeParams,
    x: Vec3,
    lf: f32,
    vc: Vec3,
    c: Cells,
) -> (Vec3, f32) {
    let (s, _) = quadrilinear(p.levels - 1, lf, |l| {
        (
            cells_level(rsms, views, p, x, l, vc, c),
            SampleError::default(),
        )
    });
    (s.truncate(), s.w)
}

/// [`cells`] at level `l`: (premultiplied rgb, lit coverage).
fn cells_level(
    rsms: &[Rsm],
    views: &[vxgi_cpu_mirror::reflective_shadow_map::GpuView],
    p: &ConeParams,
    x: Vec3,
    l: u32,
    vc: Vec3,
    c: Cells,
) -> Vec4 {
    let s = p.origin[3] * (1u32 << l) as f32;
    let origin = Vec3::new(p.origin[0], p.origin[1], p.origin[2]);
    let last = Vec3::splat(((p.side >> l) - 1) as f32);
    // The trilinear read's 8 cells, base + {0, 1}^3, where the occlusion read finds them.
    let i0 = GridPoint::new(p, x, l).i0;
    let base = Vec3::new(i0[0] as f32, i0[1] as f32, i0[2] as f32);
    let (mut area, mut rad, mut nsum) = ([0.0f32; 8], [Vec3::ZERO; 8], [Vec3::ZERO; 8]);
    for (rsm, v) in rsms.iter().zip(views) {
        let Some((nx, ny, zv)) = v.project(x) else {
            continue;
        };
        let side = rsm.side as i64;
        let (r, u) = (
            Vec3::from_slice(&v.right[..3]),
            Vec3::from_slice(&v.up[..3]),
        );
        let (f, eye) = (
            Vec3::from_slice(&v.forward[..3]),
            Vec3::from_slice(&v.eye[..3]),
        );
        let (rn, un) = (r / r.length_squared(), u / u.length_squared());
        let ortho = v.orthographic();
        // Texels whose points may lie in the 8 cells: within 3 cells of x across the view (at x's
        // depth; a texel's strip may reach further, which `spread` does not follow).
        let world_per_ndc = if ortho { 1.0 } else { zv } / r.length();
        let reach = 3.0 * s / world_per_ndc * side as f32 / 2.0;
        let (cx, cy) = (
            (nx + 1.0) * 0.5 * side as f32,
            (1.0 - ny) * 0.5 * side as f32,
        );
        let span = |c: f32| {
            (
                ((c - reach).floor() as i64).max(0),
                ((c + reach).ceil() as i64).min(side - 1),
            )
        };
        let ((x0, x1), (y0, y1)) = (span(cx), span(cy));
        let texel = 2.0 / side as f32;
        // The point of the ray through image point (a, b) at view depth z, or on `plane` (a point
        // and normal) when given.
        let point = |a: f32, b: f32, z: f32, plane: Option<(Vec3, Vec3)>| {
            let (o, dir) = if ortho {
                (eye + rn * a + un * b, f)
            } else {
                (eye, f + rn * a + un * b)
            };
            match plane {
                Some((pt, n)) if n.dot(dir).abs() > 1e-6 => o + dir * (n.dot(pt - o) / n.dot(dir)),
                _ => o + dir * z,
            }
        };
        for ty in y0..=y1 {
            for tx in x0..=x1 {
                let m = vxgi_cpu_mirror::morton::encode2(tx as u32, ty as u32) as usize;
                let (rr, n) = (rsm.radiance[m], rsm.normal[m]);
                if !(rr[3] > 0.5) {
                    continue;
                }
                let normal = Vec3::from_slice(&n[..3]);
                let big_n = if c.cull == Cull::Texel {
                    normal.dot(vc)
                } else {
                    1.0
                };
                if !(big_n > 0.0) {
                    continue;
                }
                let (a, b) = (
                    (tx as f32 + 0.5) * texel - 1.0,
                    1.0 - (ty as f32 + 0.5) * texel,
                );
                let z = rsm.depth[m] / v.forward[3] + v.eye[3];
                let pt = point(a, b, z, None);
                // The texel's image area at its depth, its ray's cos to the axis, over <n, l>.
                let (plane, cos) = if ortho {
                    (texel * texel / (r.length() * u.length()), 1.0)
                } else {
                    let dir = f + rn * a + un * b;
                    (
                        texel * texel * z * z / (r.length() * u.length()),
                        1.0 / dir.length(),
                    )
                };
                let surface = plane * cos / n[3].max(1e-3) * (big_n / CULL_RAMP).min(1.0);
                let k = if c.spread {
                    ((2.0 * plane.sqrt() / n[3].max(1e-3) / s).ceil() as usize).clamp(1, 16)
                } else {
                    1
                };
                let part = surface / (k * k) as f32;
                for j in 0..k {
                    for i in 0..k {
                        let sub = if k == 1 {
                            pt
                        } else {
                            point(
                                a + ((i as f32 + 0.5) / k as f32 - 0.5) * texel,
                                b - ((j as f32 + 0.5) / k as f32 - 0.5) * texel,
                                z,
                                Some((pt, normal)),
                            )
                        };
                        // The cell holding the point; a point on the grid's high faces (the
                        // scene's bounds: the grid is fitted to them) goes to the last cell, as
                        // voxelize puts it.
                        let cell = ((sub - origin) / s).floor().clamp(Vec3::ZERO, last);
                        let o = cell - base;
                        if o.min_element() < 0.0 || o.max_element() > 1.0 {
                            continue;
                        }
                        let idx = o.x as usize | (o.y as usize) << 1 | (o.z as usize) << 2;
                        area[idx] += part;
                        rad[idx] += Vec3::new(rr[0], rr[1], rr[2]) * part;
                        nsum[idx] += normal * part;
                    }
                }
            }
        }
    }
    // Each cell's (premultiplied rgb, coverage), read with the occlusion read's own weights.
    let cells: Vec<(usize, Vec4)> = (0..8)
        .filter(|&idx| area[idx] > 0.0)
        .map(|idx| {
            let a = area[idx];
            let n_w = match c.cull {
                Cull::Cell => (nsum[idx].dot(vc) / a / CULL_RAMP).clamp(0.0, 1.0),
                _ => 1.0,
            };
            let cov = (a / (s * s)).min(1.0);
            let cell = [0, 1, 2].map(|k| (i0[k] + (idx >> k & 1) as i32) as u32);
            let m = vxgi_cpu_mirror::morton::encode(cell[0], cell[1], cell[2]) as usize;
            (m, (rad[idx] / a * cov).extend(cov) * n_w)
        })
        .collect();
    trilinear_level(p, x, l, |m| {
        cells.iter().find(|c| c.0 == m).map_or(Vec4::ZERO, |c| c.1)
    })
    .0
}

/// What the exact footprint sums over the texels inside the sample's disc whose depth lies in the
/// sample's window `|z - zc| <= rc`, divided by the disc's texels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Footprint {
    /// Their radiance, N only culling: what Algorithm 1's `sum f A R V N` estimates by filtered
    /// layers and a Gaussian depth test.
    Radiance,
    /// Their radiance times `<n, vc> / <n, l>`: each texel's lit surface, its area per unit of
    /// the light's image `1 / <n, l>` (eq. 3's Jacobian, per texel), projected along the cone, over
    /// the cone's cross-section (the disc). eq. 1's premultiplied `alpha_i L_i` of the lit surface
    /// in the sample, exact up to the RSM's resolution.
    Surface,
    /// Their radiance times `1 / <n, l>`, N only culling: the lit surface's radiance times its
    /// area over the cone's cross-section, unprojected, as an isotropic voxel's coverage is (the
    /// occlusion alpha that composites it is the same isotropic coverage).
    Area,
}

/// One row of the diagnostic: a frame's two sources.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Swap {
    pub alpha: Alpha,
    pub radiance: Radiance,
}

/// The volume the diagnostic frame marches: alpha and L each from its [`Swap`] source.
pub struct FactorVolume<'a> {
    pub lrsm: &'a LrsmVolume<'a>,
    /// Each light view's RSM, in the views' order (read by [`Algorithm::exact`] alone).
    pub rsms: &'a [Rsm],
    /// Every view's area-weighted LRSM, laid out as the frame's (read by [`Algorithm::area_lrsm`]
    /// alone).
    pub area: &'a [Vec<[f32; 4]>; 3],
    pub voxels: Pyramid<'a>,
    pub swap: Swap,
}

impl<'a> FactorVolume<'a> {
    pub fn new(
        lrsm: &'a LrsmVolume<'a>,
        rsms: &'a [Rsm],
        area: &'a [Vec<[f32; 4]>; 3],
        pyramids: &'a Pyramids,
        swap: Swap,
    ) -> Self {
        Self {
            lrsm,
            rsms,
            area,
            voxels: Pyramid {
                p: lrsm.p,
                voxels: &pyramids.colour,
            },
            swap,
        }
    }

    /// The sample's L and, from the LRSMs by this module's Algorithm 1, the lit coverage its
    /// weights sum to (0 otherwise).
    fn radiance(&self, x: Vec3, lf: f32, diam: f32, d: Vec3) -> (Vec3, f32) {
        match self.swap.radiance {
            Radiance::Voxels => {
                let (s, _) = self.voxels.sample(x, lf);
                if s.w > 0.0 {
                    (s.truncate() / s.w, 0.0)
                } else {
                    (Vec3::ZERO, 0.0)
                }
            }
            Radiance::Lrsm(a) if a.is_kernel() => (self.lrsm.radiance(x, diam, d).0, 0.0),
            Radiance::Lrsm(a) => {
                lrsm_radiance(self.lrsm, (self.rsms, self.area), x, lf, diam, d, a)
            }
        }
    }
}

impl Volume for FactorVolume<'_> {
    fn params(&self) -> &ConeParams {
        self.lrsm.p
    }

    fn level(&self, x: Vec3, l: u32) -> (Vec4, SampleError) {
        match self.swap.alpha {
            Alpha::Volume | Alpha::Surface => self.lrsm.level(x, l),
            Alpha::Voxels => {
                let (s, e) = self.voxels.level(x, l);
                (Vec4::new(0.0, 0.0, 0.0, s.w), e)
            }
        }
    }

    fn sample_cone(
        &self,
        x: Vec3,
        lf: f32,
        diam: f32,
        d: Vec3,
        _tan_half: f32,
    ) -> (Vec4, SampleError) {
        let (s, e) = self.sample(x, lf);
        if !(s.w > 0.0) {
            return (s, e);
        }
        let (l, lit) = self.radiance(x, lf, diam, d);
        if let Radiance::Lrsm(a) = self.swap.radiance {
            if a.premultiplied {
                // Premultiplied: L is the colour the march adds, not alpha times it.
                let l = if a.capped && lit > s.w {
                    l * (s.w / lit)
                } else {
                    l
                };
                return (l.extend(s.w), e);
            }
        }
        ((l * s.w).extend(s.w), e)
    }
}

/// lrsm_cone_trace's per-sample radiance (every view's disc share times its Sample LRSM) with
/// Algorithm 1 changed as `a` says (`rsms`: each view's RSM, for `a.exact` and `a.cells`; `area`: the views'
/// area-weighted LRSMs, for `a.area_lrsm`); no error bound (a diagnostic, not a mirror).
pub fn lrsm_radiance(
    vol: &LrsmVolume,
    (rsms, area): (&[Rsm], &[Vec<[f32; 4]>; 3]),
    x: Vec3,
    lf: f32,
    diam: f32,
    d: Vec3,
    a: Algorithm,
) -> (Vec3, f32) {
    if let Some(c) = a.cells {
        return cells(rsms, vol.views, vol.p, x, lf, -d, c);
    }
    let (mut sum, mut lit) = (Vec3::ZERO, 0.0);
    for (k, v) in vol.views.iter().enumerate() {
        let Some((nx, ny, zv)) = v.project(x) else {
            continue;
        };
        let texels = if v.orthographic() {
            diam * v.right[3]
        } else {
            diam * v.right[3] / zv
        };
        let r = (texels / vol.sp.side0 as f32).clamp(1e-30, 64.0);
        let w = disc_share(nx, r) * disc_share(ny, r);
        if w <= 0.0 {
            continue;
        }
        let base = v.info[2] as usize;
        let [radiance, normal, moments]: [&[[f32; 4]]; 3] = if a.area_lrsm {
            [&area[0], &area[1], &area[2]]
        } else {
            [vol.lrsm.radiance, vol.lrsm.normal, vol.lrsm.moments]
        };
        let lrsm = Lrsm {
            depth_ranges: vol.lrsm.depth_ranges,
            radiance: &radiance[base..],
            normal: &normal[base..],
            moments: &moments[base..],
        };
        let (cx, cy) = (nx.clamp(-1.0, 1.0), ny.clamp(-1.0, 1.0));
        let pos = [
            (cx + 1.0) * 0.5,
            (1.0 - cy) * 0.5,
            texels.log2() - if a.finer { 1.0 } else { 0.0 },
            (zv - v.eye[3]) * v.forward[3],
        ];
        let rc = 0.5 * diam * v.forward[3];
        let eye = Vec3::new(v.eye[0], v.eye[1], v.eye[2]);
        let l = if v.orthographic() {
            -Vec3::new(v.forward[0], v.forward[1], v.forward[2]).normalize()
        } else {
            (eye - x).normalize()
        };
        let (r, c) = match a.exact {
            Some(f) => exact(&rsms[k], pos, texels, -d, rc, f),
            None => sample(&lrsm, vol.sp, pos, -d, rc, l, a),
        };
        sum += r * w;
        lit += c * w;
    }
    (sum, lit)
}

/// Algorithm 1 at `pos = (u, v, mip, zc)` seen along `vc`, sample radius `rc` (depth units), with
/// `a`'s changes.
#[allow(clippy::too_many_arguments)]
fn sample(
    lrsm: &Lrsm,
    p: &SampleParams,
    pos: [f32; 4],
    vc: Vec3,
    rc: f32,
    light: Vec3,
    a: Algorithm,
) -> (Vec3, f32) {
    let [u, v, mip, zc] = pos;
    let taps = taps(p, u, v, mip);
    let vp = VisibilityParams {
        cdf: p.cdf,
        min_variance: p.min_variance,
        min_alpha: p.min_alpha,
        _pad: 0,
    };
    let (mut num, mut den) = (Vec3::ZERO, 0.0f32);
    // The Jacobian variant's sums: area-weighted radiance and area, and the rays' share in the sample.
    let (mut jnum, mut jden, mut hit) = (Vec3::ZERO, 0.0f32, 0.0f32);
    for d in 0..p.depth_slices {
        let range = lrsm.depth_ranges[d as usize];
        let (zc, rc) = if a.all_layers {
            match core_window(d, p.depth_slices, zc, rc) {
                Some(w) => w,
                None => continue,
            }
        } else {
            if !(zc >= range[0] && zc <= range[1]) {
                continue;
            }
            (zc, rc)
        };
        for j in 0..p.normal_slices {
            let layer = d * p.normal_slices + j;
            let nm = fetch(lrsm.normal, &taps, layer, false);
            if !(nm[3] > p.min_alpha) {
                continue;
            }
            let n = Vec3::new(nm[0], nm[1], nm[2]) / nm[3];
            let big_n = n.dot(vc);
            if !(big_n > 0.0) {
                continue;
            }
            let moments = fetch(lrsm.moments, &taps, layer, false);
            let (zw, rw) = ((zc - range[0]) * range[2], rc * range[2]);
            let vis = if a.v_one {
                1.0
            } else {
                visibility(moments, zw, rw, &vp, false)
            };
            if !(vis > 0.0) && !a.front_shadowed {
                continue;
            }
            let decay = if a.all_layers {
                1.0
            } else {
                layer_decay(zc, range[0], range[1], p.overlap, false)
            };
            // N's factor: the paper's weight, or the kernel's cull ramp.
            let n_w = if a.view_weight {
                big_n
            } else {
                (big_n / CULL_RAMP).min(1.0)
            };
            let w = decay * vis * n_w;
            let r = fetch(lrsm.radiance, &taps, layer, false);
            let c = n.dot(light).max(1e-3);
            let wr = if a.area { w / c } else { w };
            num += Vec3::new(r[0], r[1], r[2]) * wr;
            den += nm[3] * wr;
            jnum += Vec3::new(r[0], r[1], r[2]) * (w / c);
            jden += nm[3] * (w / c);
            hit += nm[3] * decay * vis;
            if a.front_shadowed {
                let mu = moments[0] / moments[2];
                let sigma = (moments[1] / moments[2] - mu * mu)
                    .max(p.min_variance)
                    .sqrt();
                let front = normal_cdf((zw - rw - mu) / sigma, cdf_of(p), false);
                den += nm[3] * decay * front * n_w;
            }
        }
    }
    if a.jacobian {
        let d = jden + (1.0 - hit).max(0.0);
        return (if d > 0.0 { jnum / d } else { Vec3::ZERO }, den);
    }
    if a.normalized {
        (if den > 0.0 { num / den } else { Vec3::ZERO }, den)
    } else {
        (num, den)
    }
}

/// The part of the depth window `[zc - rc, zc + rc]` inside depth slice `d`'s core (`[d, d + 1] /
/// slices` without the overlaps, the first and last open-ended), as (centre, radius); None where
/// they do not meet. The cores tile depth, so the parts of a window over every slice tile it.
pub fn core_window(d: u32, slices: u32, zc: f32, rc: f32) -> Option<(f32, f32)> {
    let n = slices as f32;
    let core_lo = if d == 0 {
        f32::NEG_INFINITY
    } else {
        d as f32 / n
    };
    let core_hi = if d + 1 == slices {
        f32::INFINITY
    } else {
        (d + 1) as f32 / n
    };
    let (lo, hi) = ((zc - rc).max(core_lo), (zc + rc).min(core_hi));
    (hi > lo).then_some((0.5 * (lo + hi), 0.5 * (hi - lo)))
}

/// The exact footprint at `pos = (u, v, mip, zc)`: the RSM texels whose centres lie within the
/// disc of diameter `texels` (level-0 LRSM texels, so its radius in RSM texels) around (u, v),
/// summed as `f` says over those in the window `|z - zc| <= rc` and facing `vc`, over the disc's
/// texels inside the image. Returns (L, the same sum of the weights alone, over the same count: for
/// `Radiance` the share of the disc they cover, for the others their lit surface's measure, which
/// the capped rows compare with alpha).
fn exact(rsm: &Rsm, pos: [f32; 4], texels: f32, vc: Vec3, rc: f32, f: Footprint) -> (Vec3, f32) {
    let side = rsm.side as i64;
    let [u, v, _, zc] = pos;
    // At least the texel under the centre.
    let rad = texels.max(0.5);
    let (cx, cy) = (u * side as f32, v * side as f32);
    let span = |c: f32| {
        (
            ((c - rad).floor() as i64).max(0),
            ((c + rad).ceil() as i64).min(side - 1),
        )
    };
    let ((x0, x1), (y0, y1)) = (span(cx), span(cy));
    let (mut sum, mut lit, mut count) = (Vec3::ZERO, 0.0f32, 0u32);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (dx, dy) = (x as f32 + 0.5 - cx, y as f32 + 0.5 - cy);
            if dx * dx + dy * dy > rad * rad {
                continue;
            }
            count += 1;
            let m = vxgi_cpu_mirror::morton::encode2(x as u32, y as u32) as usize;
            let r = rsm.radiance[m];
            if !(r[3] > 0.5 && (rsm.depth[m] - zc).abs() <= rc) {
                continue;
            }
            let n = rsm.normal[m];
            let big_n = Vec3::new(n[0], n[1], n[2]).dot(vc);
            if !(big_n > 0.0) {
                continue;
            }
            let w = match f {
                Footprint::Radiance => (big_n / CULL_RAMP).min(1.0),
                // <n, l> as the RSM stores it; 1e-3 bounds a texel seen edge-on from the light.
                Footprint::Surface => big_n / n[3].max(1e-3),
                Footprint::Area => (big_n / CULL_RAMP).min(1.0) / n[3].max(1e-3),
            };
            sum += Vec3::new(r[0], r[1], r[2]) * w;
            lit += w;
        }
    }
    if count == 0 {
        return (Vec3::ZERO, 0.0);
    }
    (sum / count as f32, lit / count as f32)
}

fn cdf_of(p: &SampleParams) -> Cdf {
    if p.cdf == 1 {
        Cdf::AS7127
    } else {
        Cdf::AS7126
    }
}

impl Algorithm {
    /// Algorithm 1 as the paper writes it.
    pub const PAPER: Self = Self {
        view_weight: true,
        v_one: false,
        normalized: false,
        front_shadowed: false,
        premultiplied: false,
        jacobian: false,
        area: false,
        capped: false,
        all_layers: false,
        exact: None,
        area_lrsm: false,
        finer: false,
        cells: None,
    };

    /// Whether the kernel computes this L (its mirror, `lrsm_cone_trace`'s, gives it); the
    /// premultiplied reading changes only how the march takes it.
    fn is_kernel(&self) -> bool {
        Self {
            view_weight: false,
            premultiplied: false,
            ..*self
        } == Self::default()
    }
}

/// The rows `vxgi lrsm-factors` renders, with their names: the frame as built, then each factor
/// swapped alone, then the combinations that isolate L's terms over the voxels' alpha.
pub fn rows() -> Vec<(&'static str, Swap)> {
    use Alpha::{Surface, Volume, Voxels};
    let paper = Radiance::Lrsm(Algorithm::PAPER);
    let lrsm = |a| Radiance::Lrsm(a);
    let default = Algorithm::default();
    let s = |alpha, radiance| Swap { alpha, radiance };
    vec![
        (
            "the paper: volume-coverage alpha, Algorithm 1 (N weighs L)",
            s(Volume, paper),
        ),
        (
            "alpha <- the occlusion voxels' surface coverage",
            s(Surface, paper),
        ),
        (
            "alpha <- the lit voxels' surface coverage (vct-dense's)",
            s(Voxels, paper),
        ),
        (
            "L <- the lit voxels' radiance, volume-coverage alpha",
            s(Volume, Radiance::Voxels),
        ),
        (
            "L <- the lit voxels' radiance, surface-coverage alpha",
            s(Surface, Radiance::Voxels),
        ),
        (
            "both <- the lit voxels' (vct-dense's sample)",
            s(Voxels, Radiance::Voxels),
        ),
        (
            "**the default: surface coverage, N only culls**",
            s(Surface, lrsm(default)),
        ),
        ("volume coverage, N only culls", s(Volume, lrsm(default))),
        (
            "the default with V = 1 (no depth test)",
            s(
                Surface,
                lrsm(Algorithm {
                    v_one: true,
                    ..default
                }),
            ),
        ),
        (
            "the default, L normalized by sum f A V",
            s(
                Surface,
                lrsm(Algorithm {
                    normalized: true,
                    ..default
                }),
            ),
        ),
        (
            "the default, normalized, rays stopped in front as shadow",
            s(
                Surface,
                lrsm(Algorithm {
                    normalized: true,
                    front_shadowed: true,
                    ..default
                }),
            ),
        ),
        (
            "the default with eq. 3's Jacobian",
            s(
                Surface,
                lrsm(Algorithm {
                    jacobian: true,
                    ..default
                }),
            ),
        ),
        (
            "the default, L premultiplied (alpha L = L)",
            s(
                Surface,
                lrsm(Algorithm {
                    premultiplied: true,
                    ..default
                }),
            ),
        ),
        (
            "L premultiplied, N weighs L",
            s(
                Surface,
                lrsm(Algorithm {
                    premultiplied: true,
                    view_weight: true,
                    ..default
                }),
            ),
        ),
        (
            "L premultiplied, N weighs L, rays weighed by their area 1 / <n.l>",
            s(
                Surface,
                lrsm(Algorithm {
                    premultiplied: true,
                    view_weight: true,
                    area: true,
                    ..default
                }),
            ),
        ),
        (
            "L premultiplied, N weighs L, area 1 / <n.l>, lit coverage at most alpha",
            s(
                Surface,
                lrsm(Algorithm {
                    premultiplied: true,
                    view_weight: true,
                    area: true,
                    capped: true,
                    ..default
                }),
            ),
        ),
        (
            "L premultiplied, N weighs L, lit coverage at most alpha",
            s(
                Surface,
                lrsm(Algorithm {
                    premultiplied: true,
                    view_weight: true,
                    capped: true,
                    ..default
                }),
            ),
        ),
        (
            "the default, every layer the sample's depth window meets (eq. 14's sum)",
            s(
                Surface,
                lrsm(Algorithm {
                    all_layers: true,
                    ..default
                }),
            ),
        ),
        (
            "exact footprint: the RSM texels in the disc and the depth window, N only culls",
            s(
                Surface,
                lrsm(Algorithm {
                    exact: Some(Footprint::Radiance),
                    ..default
                }),
            ),
        ),
        (
            "exact footprint, premultiplied: their lit surface <n, vc> / <n, l>",
            s(
                Surface,
                lrsm(Algorithm {
                    exact: Some(Footprint::Surface),
                    premultiplied: true,
                    view_weight: true,
                    ..default
                }),
            ),
        ),
        (
            "exact footprint, premultiplied: their lit surface 1 / <n, l>, N only culls",
            s(
                Surface,
                lrsm(Algorithm {
                    exact: Some(Footprint::Area),
                    premultiplied: true,
                    ..default
                }),
            ),
        ),
        (
            "exact footprint, premultiplied, 1 / <n, l>, N only culls, lit coverage at most alpha",
            s(
                Surface,
                lrsm(Algorithm {
                    exact: Some(Footprint::Area),
                    premultiplied: true,
                    capped: true,
                    ..default
                }),
            ),
        ),
        (
            "area-weighted LRSM, premultiplied, N weighs L",
            s(
                Surface,
                lrsm(Algorithm {
                    area_lrsm: true,
                    premultiplied: true,
                    view_weight: true,
                    ..default
                }),
            ),
        ),
        (
            "area-weighted LRSM, premultiplied, N weighs L, fetched one level finer",
            s(
                Surface,
                lrsm(Algorithm {
                    area_lrsm: true,
                    premultiplied: true,
                    view_weight: true,
                    finer: true,
                    ..default
                }),
            ),
        ),
        (
            "the default fetched one level finer",
            s(
                Surface,
                lrsm(Algorithm {
                    finer: true,
                    ..default
                }),
            ),
        ),
        (
            "the light views' texels in the occlusion cells, N culls",
            s(Surface, lrsm(in_cells(Cull::Texel, true))),
        ),
        (
            "the light views' texels in the occlusion cells, isotropic (no N)",
            s(Surface, lrsm(in_cells(Cull::None, true))),
        ),
        (
            "the light views' texels, each at its centre's point, in the occlusion cells, N culls",
            s(Surface, lrsm(in_cells(Cull::Texel, false))),
        ),
        (
            "the light views' texels in the occlusion cells, N culls each cell by its mean normal",
            s(Surface, lrsm(in_cells(Cull::Cell, true))),
        ),
        (
            "the light views' texels in the occlusion cells, N culls by the mean normal, alpha <- the lit voxels' surface coverage",
            s(Voxels, lrsm(in_cells(Cull::Cell, true))),
        ),
    ]
}

/// The [`Cells`] rows' Algorithm: read premultiplied.
fn in_cells(cull: Cull, spread: bool) -> Algorithm {
    Algorithm {
        premultiplied: true,
        cells: Some(Cells { cull, spread }),
        ..Algorithm::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vxgi_cpu_mirror::reflective_shadow_map::GpuView;

    #[test]
    fn the_cores_tile_every_window() {
        for slices in [1, 2, 3, 8] {
            for (zc, rc) in [
                (0.5, 0.01),
                (0.49, 0.3),
                (-0.2, 0.5),
                (0.9, 2.0),
                (0.25, 0.25),
            ] {
                let parts: Vec<(f32, f32)> = (0..slices)
                    .filter_map(|d| core_window(d, slices, zc, rc))
                    .collect();
                let width: f32 = parts.iter().map(|p| 2.0 * p.1).sum();
                assert!(
                    (width - 2.0 * rc).abs() < 1e-5,
                    "{slices} {zc} {rc}: {parts:?}"
                );
                for p in &parts {
                    assert!(p.0 - p.1 >= zc - rc - 1e-6 && p.0 + p.1 <= zc + rc + 1e-6);
                }
            }
        }
        assert_eq!(core_window(1, 2, 0.2, 0.1), None);
    }

    /// An RSM of side 8 whose texels all face the cone at <n, l> = 1/2, at depth 0.5 with radiance
    /// 1, except the right half, at depth 0.9.
    fn rsm() -> Rsm {
        let side = 8u32;
        let (mut radiance, mut normal, mut depth) = (vec![], vec![], vec![]);
        for m in 0..side * side {
            let [x, _] = vxgi_cpu_mirror::morton::decode2(m);
            radiance.push([1.0, 1.0, 1.0, 1.0]);
            normal.push([0.0, 0.0, 1.0, 0.5]);
            depth.push(if x < side / 2 { 0.5 } else { 0.9 });
        }
        Rsm {
            side,
            radiance,
            normal,
            depth,
        }
    }

    #[test]
    fn the_exact_footprint_counts_the_texels_in_the_disc_and_the_window() {
        let rsm = rsm();
        let vc = Vec3::Z;
        // A disc of radius 1.5 texels inside the left half: every texel counts.
        let pos = [2.0 / 8.0, 4.0 / 8.0, 0.0, 0.5];
        let (l, lit) = exact(&rsm, pos, 1.5, vc, 0.05, Footprint::Radiance);
        assert_eq!((l, lit), (Vec3::ONE, 1.0));
        // Premultiplied surface: <n, vc> / <n, l> = 2 per texel.
        let (l, _) = exact(&rsm, pos, 1.5, vc, 0.05, Footprint::Surface);
        assert_eq!(l, Vec3::splat(2.0));
        // Centred on the halves' edge: half the disc's texels lie at 0.9, outside the window.
        let (l, lit) = exact(
            &rsm,
            [0.5, 0.5, 0.0, 0.5],
            2.0,
            vc,
            0.05,
            Footprint::Radiance,
        );
        assert_eq!((l, lit), (Vec3::splat(0.5), 0.5));
        // Seen from behind: nothing.
        let (l, _) = exact(&rsm, pos, 1.5, -vc, 0.05, Footprint::Radiance);
        assert_eq!(l, Vec3::ZERO);
    }

    /// A sun straight down -z onto the plane z = 9/16 of an 8^3 grid over the unit cube: a 16^2 RSM
    /// whose texels all hold it, radiance 2, <n, l> = 1.
    fn sun_on_a_plane() -> (Rsm, GpuView, ConeParams) {
        let side = 16u32;
        let n = (side * side) as usize;
        let (far, z0) = (4.0f32, 9.0f32 / 16.0);
        let rsm = Rsm {
            side,
            radiance: vec![[2.0, 2.0, 2.0, 1.0]; n],
            normal: vec![[0.0, 0.0, 1.0, 1.0]; n],
            depth: vec![(2.0 - z0) / far; n],
        };
        let view = GpuView {
            eye: [0.5, 0.5, 2.0, 0.0],
            forward: [0.0, 0.0, -1.0, 1.0 / far],
            right: [2.0, 0.0, 0.0, 8.0],
            up: [0.0, 2.0, 0.0, 0.0],
            info: [side, 0, 0, 1],
        };
        let p = ConeParams {
            origin: [0.0, 0.0, 0.0, 1.0 / 8.0],
            side: 8,
            levels: 4,
            inv_s0: 8.0,
            ..Default::default()
        };
        (rsm, view, p)
    }

    #[test]
    fn the_occlusion_cells_hold_the_light_where_their_surface_is() {
        let (rsm, view, p) = sun_on_a_plane();
        let lit = Cells {
            cull: Cull::Texel,
            spread: true,
        };
        let at = |x: Vec3, vc: Vec3, c: Cells| {
            cells(std::slice::from_ref(&rsm), &[view], &p, x, 0.0, vc, c)
        };
        // At the centre of a cell the plane crosses: its surface fills the cell's face (four
        // texels of 1/16^2 over 1/8^2), so coverage 1 and the texels' radiance.
        let centre = Vec3::splat(9.0 / 16.0);
        assert_eq!(at(centre, Vec3::Z, lit), (Vec3::splat(2.0), 1.0));
        // Halfway to the empty cell above: half of it, as the trilinear occlusion read.
        let (l, c) = at(centre + Vec3::Z / 16.0, Vec3::Z, lit);
        assert!((c - 0.5).abs() < 1e-6 && (l - Vec3::ONE).abs().max_element() < 1e-6);
        // Two cells away: nothing.
        assert_eq!(at(centre + Vec3::Z / 4.0, Vec3::Z, lit).1, 0.0);
        // Seen from behind, N culls it, unless isotropic.
        assert_eq!(at(centre, -Vec3::Z, lit).1, 0.0);
        let iso = Cells {
            cull: Cull::None,
            ..lit
        };
        assert_eq!(at(centre, -Vec3::Z, iso), (Vec3::splat(2.0), 1.0));
        // By the cell's mean normal: the same here, one surface a cell.
        let cell = Cells {
            cull: Cull::Cell,
            ..lit
        };
        assert_eq!(at(centre, Vec3::Z, cell), (Vec3::splat(2.0), 1.0));
        assert_eq!(at(centre, -Vec3::Z, cell).1, 0.0);
    }
}
