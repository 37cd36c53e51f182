//! Mirror of `kernels/cone_trace.wgsl`: per G-buffer pixel, AO and diffuse cones plus one glossy cone
//! marched through the pre-filtered radiance pyramid (CPRC section 4, VCT sections 5-7).
//!
//! Pyramid: levels 0..levels of a Morton grid of side `side` concatenated (level l at
//! `((8^(L+1) - 8^(L-l+1)) / 7`, L = log2 side), each voxel `(L * alpha, alpha)` (pre-multiplied).
//!
//! March (origin o, unit direction d, tan of the half-angle):
//! - diameter starts at 3/4 of a level-0 cell; the first sample is half a step from o;
//! - step = diameter / 2; after each step the diameter grows by the factor (1 + tan) and the mip level
//!   by log2(1 + tan): one addition per step, no logarithm (CPRC 4);
//! - quadrilinear sampling: trilinear in levels floor(lf) and floor(lf) + 1 (voxels outside the grid are
//!   empty), blended by fract(lf); lf < 0 samples level 0, past the top the top level;
//! - alpha corrected for the step: `a' = 1 - (1 - a)^(step / cell)` with cell = max(diameter, s0)
//!   (VCT 5), colour scaled by a'/a; front-to-back `C += (1 - A) c'`, `A += (1 - A) a'`;
//! - AO on the same march: `occ += (1 - A) a' / (1 + lambda t)` while t <= ao_range (VCT 6);
//! - stops when A >= 1 - 1/256 or t > the grid's diagonal;
//! - option `mip_clamp` (0 = off): the level is capped at log2(D / (mip_clamp s0)), D = the sample's
//!   distance from the origin surface's plane (offset + t cos), and the step ratio uses the capped cell.
//!
//! Pixel: origin `p + ng * offset_voxels * s0` (ng the triangle's normal on the side facing the camera);
//! diffuse cones from `cone_dirs` (tangent space, w = weight, weights sum to 1), indirect diffuse =
//! `albedo * sum w C` (albedo: the G-buffer's, Kd or the map_Kd texel), AO = `1 - sum w occ`; glossy (materials with Ks): one cone along the mirror
//! direction of the view with tan = clamp(sqrt(2 / (n + 2)), 0.02, 1), adding `Ks * C`. Back faces get
//! AO (on the camera's side) and no indirect light; background pixels get 0. Every pixel also writes
//! `irradiance` = (`sum w C`, `sum w occ`): its diffuse irradiance before the albedo and its occlusion.
//!
//! Option `interleave` = N > 1 (interleaved sampling, Keller & Heidrich 2001, which CPRC cites for
//! instant radiosity; our addition to the cone tracers): the screen's N x N pixel classes trace
//! disjoint subsets of one spiral of `diffuse_cones` N^2 narrow cones ([`cone_dirs`],
//! [`class_cones`]), and a second pass, the resolve ([`resolve`]; the kernel's entry `resolve`),
//! averages each pixel's irradiance and occlusion with tent weights over the (2N - 1)^2 pixels
//! around it, pixels of the same surface only (the same facing, normals within ~26 deg, within one
//! level-0 cell of the pixel's plane): in a full window every class has the same weight, so a pixel
//! on an open surface gathers all `diffuse_cones` N^2 cones for the price of `diffuse_cones`. The
//! glossy cone stays per pixel.
use crate::bvh_trace::GpuTriangle;
use crate::direct_light::{face_normal, GpuMaterial};
use crate::gbuffer::Frame;
use crate::morton;
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ConeParams {
    /// xyz, w = level-0 cell size s0.
    pub origin: [f32; 4],
    pub ao_range: f32,
    pub ao_lambda: f32,
    /// tan of the diffuse cones' half-angle.
    pub diffuse_tan: f32,
    pub offset_voxels: f32,
    pub diffuse_cones: u32,
    /// Levels in the pyramid (log2 side + 1).
    pub levels: u32,
    pub side: u32,
    /// 1 / s0, computed once on the host (so both sides scale by the same value).
    pub inv_s0: f32,
    /// Surface-aware mip clamp (0 = off, the paper's rule): the sampled cell stays below
    /// 1 / mip_clamp of the sample's distance from the origin surface's plane, so trilinear filtering
    /// does not reach back into the surface's own voxels (which surface coverage keeps opaque).
    pub mip_clamp: f32,
    /// Step as a fraction of the current diameter (CPRC 4: 0.5). The first sample sits half a step
    /// out and the diameter grows by 1 + 2 step_factor tan per step; at 0.5 every expression equals
    /// the paper's exactly (2 x 0.5 = 1 and 0.5 x 0.5 = 0.25 are exact).
    pub step_factor: f32,
    /// Depth-ordered blend (1) or the paper's trilinear (0) in the dense pyramid's cone samples
    /// ([`OrderedPyramid`]); the other volumes ignore it.
    pub depth_order: u32,
    /// Sampled level relative to the paper's `log2(d / s0)`, in [-3, 0] (0 = the paper's rule; our
    /// addition): a trilinear read of a box-filtered mip spreads over about half a cell, a cone's disc
    /// over a quarter of its diameter, so narrow cones match their footprint about one level finer.
    /// The step correction follows the cell actually read (`ratio = step / cell`).
    pub level_bias: f32,
    /// How far a sample's coverage is taken as the rays already blocked, in [0, 1] (0 = the paper's
    /// front-to-back compositing of independent layers; our addition): a sample adds the opacity
    /// `(1 - c) (1 - A) a' + c max(0, a' - A)` (a' the step-corrected alpha, A the opacity so far)
    /// and the radiance `(L alpha / alpha)` times that. At c = 1 the cone's opacity is the largest
    /// a' so far: a box edge's front and top faces, sampled one after the other, block the same rays
    /// instead of compounding.
    pub coverage_correlation: f32,
    /// Side N of the interleaved cone sets (0 and 1 = off, the paper's one set per pixel; else 2, 4
    /// or 8; our addition): see [`cone_dirs`] and [`resolve`].
    pub interleave: u32,
    pub _pad: [u32; 2],
}

pub const OPAQUE: f32 = 1.0 - 1.0 / 256.0;

/// Offset of level `l` in the concatenated pyramid of a grid of side 2^big_l.
pub fn level_offset(side: u32, l: u32) -> usize {
    let big = side.trailing_zeros();
    (((1u64 << (3 * (big + 1))) - (1u64 << (3 * (big + 1 - l)))) / 7) as usize
}

/// Total voxels of the pyramid.
pub fn pyramid_len(side: u32) -> usize {
    level_offset(side, side.trailing_zeros() + 1)
}

/// How many pyramid levels (0, 1, ...) a cone of half-angle tangent `tan` can read, marched with step
/// factor `sf` through a grid of side `side` (at most `log2(side) + 1`, the whole pyramid). The march
/// stops past the grid's diagonal, so its last sample has the largest mip level `lf_max`; a sample reads
/// levels floor(lf) and floor(lf) + 1 (the mip clamp and a level bias, <= 0, only lower it), so levels
/// above floor(lf_max) + 1 are never read and need not be built: with `levels = floor(lf_max) + 2`
/// every sample's blend is the one the whole pyramid gives (its top-level shortcut is never taken), bit
/// for bit. Evaluated in f64 with margins that cover the f32 march's rounding (one more step allowed at
/// the distance limit, lf rounded up by 1e-3).
pub fn levels_read(tan: f32, sf: f32, side: u32) -> u32 {
    let full = side.trailing_zeros() + 1;
    let (tan, sf) = (tan as f64, sf as f64);
    if !(tan > 0.0 && sf > 0.0) {
        return full;
    }
    let grow = 1.0 + 2.0 * sf * tan;
    let max_dist = side as f64 * 3f64.sqrt() * (1.0 + 1e-4);
    let (mut diam, mut t) = (0.75f64, 0.375 * sf);
    let mut lf_max = diam.log2();
    // Units of one level-0 cell; the diameter grows geometrically, so this ends within a few
    // thousand steps for any tan >= 1e-4 (and at once when the cone outgrows the grid).
    while t <= max_dist {
        lf_max = diam.log2();
        t += diam * sf;
        diam *= grow;
        if diam > 4.0 * side as f64 {
            return full;
        }
    }
    (((lf_max + 1e-3).floor().max(0.0) as u32) + 2).min(full)
}

/// What the cones read: pre-multiplied (L * alpha, alpha) at a world point and fractional mip level
/// (cell s0 * 2^lf; below 0 level 0, past the top the top level), with the error its sample point's
/// rounding allows. The dense pyramid here; the sparse voxel octree in `svo_cone_trace`.
pub trait Volume {
    fn params(&self) -> &ConeParams;

    /// Trilinear sample of whole level `l` (0..levels), and its error from the sample point's rounding.
    fn level(&self, x: Vec3, l: u32) -> (Vec4, SampleError);

    /// Quadrilinear sample at mip level `lf`: levels floor(lf) and floor(lf) + 1 blended by the
    /// fraction; below 0 level 0, from the top level up the top level alone.
    fn sample(&self, x: Vec3, lf: f32) -> (Vec4, SampleError) {
        quadrilinear(self.params().levels - 1, lf, |l| self.level(x, l))
    }

    /// What the march reads at sample point `x` (level `lf`, cone diameter `diam`, cone direction `d`,
    /// the cone's half-angle tangent `tan_half`): the volume's own sample unless the volume takes
    /// radiance from elsewhere (lrsm_cone_trace: the LRSMs, at the sample's diameter, seen along -d)
    /// or shades it for the cone (svo_cone_trace's Gaussian lobes).
    fn sample_cone(
        &self,
        x: Vec3,
        lf: f32,
        _diam: f32,
        _d: Vec3,
        _tan_half: f32,
    ) -> (Vec4, SampleError) {
        self.sample(x, lf)
    }
}

/// Levels floor(lf) and floor(lf) + 1 of `level` blended by the fraction (the kernels'
/// `sample_volume`); below 0 level 0, from `top` up `top` alone.
pub fn quadrilinear(
    top: u32,
    lf: f32,
    level: impl Fn(u32) -> (Vec4, SampleError),
) -> (Vec4, SampleError) {
    let lf = lf.max(0.0);
    let l0 = lf.floor();
    if l0 >= top as f32 {
        return level(top);
    }
    let a = lf - l0;
    let l0 = l0 as u32;
    let ((s0, e0), (s1, e1)) = (level(l0), level(l0 + 1));
    let err = SampleError {
        rgb: e0.rgb * (1.0 - a) + e1.rgb * a,
        a: e0.a * (1.0 - a) + e1.a * a,
    };
    (s0 * (1.0 - a) + s1 * a, err)
}

pub struct Pyramid<'a> {
    pub p: &'a ConeParams,
    pub voxels: &'a [[f32; 4]],
}

/// Error of a sample from where it is taken: the GPU's sample point differs from the mirror's by the
/// rounding of `o + d t` (d from a basis of crosses and square roots, a few ULP relative, fused or
/// not) and of `(x - origin) / cell`: 8 ULP of the coordinates' magnitudes in cells (`dq`). A
/// fractional coordinate moving by `dq` moves the trilinear value by `dq` times its partial
/// derivative, bounded per corner by `|v|` times the product of the other two axes' weights — large
/// relative to the value where it is a corner's small tail (a bright voxel barely reached), which is
/// where 4e-4 of the magnitudes alone fell short (CI, seed 1). `rgb` and `a`: bounds on |Δ colour|
/// (any channel) and |Δ alpha|.
#[derive(Clone, Copy, Debug, Default)]
pub struct SampleError {
    pub rgb: f32,
    pub a: f32,
}

impl SampleError {
    /// The sample point's coordinate error in cells of the sampled level (`dq` above): 8 ULP of the
    /// magnitudes in `q = (x - origin) * inv - offset`.
    pub fn coordinate_error(x: Vec3, origin: Vec3, inv: f32, q: Vec3) -> f32 {
        8.0 * f32::EPSILON
            * ((x.abs().max_element() + origin.abs().max_element()) * inv
                + q.abs().max_element()
                + 1.0)
    }

    /// Add one trilinear corner of value `v` and weights `w` (per axis): its value moves by `dq`
    /// times its partial derivative, at most `|v|` times the product of the other two axes' weights.
    pub fn add_corner(&mut self, dq: f32, w: [f32; 3], v: Vec4) {
        let slope = dq * (w[1] * w[2] + w[0] * w[2] + w[0] * w[1]);
        self.rgb += slope * v.x.abs().max(v.y.abs()).max(v.z.abs());
        self.a += slope * v.w.abs();
    }
}

impl Pyramid<'_> {
    /// Quadrilinear sample at mip level `lf`, and its error from the sample point's rounding.
    pub fn sample(&self, x: Vec3, lf: f32) -> (Vec4, SampleError) {
        Volume::sample(self, x, lf)
    }
}

impl Volume for Pyramid<'_> {
    fn params(&self) -> &ConeParams {
        self.p
    }

    fn level(&self, x: Vec3, l: u32) -> (Vec4, SampleError) {
        let off = level_offset(self.p.side, l);
        trilinear_level(self.p, x, l, |m| Vec4::from_array(self.voxels[off + m]))
    }
}

/// The dense pyramid with its normal pyramid (`surface_coverage_mip`'s normals, level 0 voxelize's,
/// concatenated like the colours), sampled by cones with the **depth-ordered blend** when
/// `p.depth_order` is 1 (else exactly as [`Pyramid`]). Along the axis `k` where the cone's direction
/// `d` is largest in magnitude (ties to the lower axis), the trilinear pair's near cell (the one the
/// cone reaches first: lower index where `d_k >= 0`) hides the far one: with linear weights `w_n`,
/// `w_f`, the pair gives `near (w_n + w_f h) + far w_f (1 - h)`, `h = a_near a_far` (alphas clamped
/// to [0, 1]) where the near cell's mean surface faces the cone (`-N_near . d > 0`, N the
/// pre-multiplied normal), else 0 (then it is the linear blend). Across `k` the blend stays bilinear.
/// So an opaque wall's far side stays behind its near side: the trilinear blend no longer mixes the
/// lit side of a one-voxel wall into a dark room's samples (thin_wall leak 0.032 -> 0.004), while the
/// back of a surface (a floor seen from above by cones leaving it) hides nothing.
///
/// Bound ([`SampleError`]): the trilinear bound of the same corners (the pair's slope in its fraction
/// is `(1 - h)(far - near)`, within the linear one's `|near| + |far|`), plus, where rounding may
/// decide differently on the GPU, the difference the other decision makes: the facing test within 16
/// ULP of `|N|_1` of 0 (`w_f h |near - far|`), the pair's fraction within `dq` of 0 or 1 (the
/// neighbouring pair's value at that boundary differs by `h |near - far|`: the blend is not continuous
/// there), and the dominant axis where the two largest `|d|` components are within 4 ULP.
pub struct OrderedPyramid<'a> {
    pub p: &'a ConeParams,
    pub voxels: &'a [[f32; 4]],
    pub normals: &'a [[f32; 4]],
}

impl OrderedPyramid<'_> {
    fn fetch(&self, off: usize, n: i32, i: [i32; 3]) -> (Vec4, Vec4) {
        if i.iter().any(|&c| c < 0 || c >= n) {
            return (Vec4::ZERO, Vec4::ZERO);
        }
        let m = off + morton::encode(i[0] as u32, i[1] as u32, i[2] as u32) as usize;
        (
            Vec4::from_array(self.voxels[m]),
            Vec4::from_array(self.normals[m]),
        )
    }

    /// The pair along `k` at lower index `i` (the other two axes' indices set), fraction `f` (weight
    /// of the upper cell), for direction component `dk`: its value and the allowance of its facing
    /// test.
    fn pair(&self, off: usize, n: i32, i: [i32; 3], k: usize, f: f32, d: Vec3) -> (Vec4, Vec4) {
        let mut hi = i;
        hi[k] += 1;
        let ((lo_v, lo_n), (hi_v, hi_n)) = (self.fetch(off, n, i), self.fetch(off, n, hi));
        let ((near, nn), far, wn, wf) = if d[k] >= 0.0 {
            ((lo_v, lo_n), hi_v, 1.0 - f, f)
        } else {
            ((hi_v, hi_n), lo_v, f, 1.0 - f)
        };
        let facing = -(nn.x * d.x + nn.y * d.y + nn.z * d.z);
        let hidden = near.w.clamp(0.0, 1.0) * far.w.clamp(0.0, 1.0);
        let h = if facing > 0.0 { hidden } else { 0.0 };
        let v = near * (wn + wf * h) + far * (wf * (1.0 - h));
        let slack = 16.0 * f32::EPSILON * (nn.x.abs() + nn.y.abs() + nn.z.abs());
        let flip = if facing.abs() <= slack {
            (near - far).abs() * (wf * hidden)
        } else {
            Vec4::ZERO
        };
        (v, flip)
    }

    /// The ordered blend of level `l` at `x` along axis `k`, and its bound.
    fn ordered(&self, x: Vec3, l: u32, d: Vec3, k: usize) -> (Vec4, SampleError) {
        let GridPoint { n, dq, f, i0, .. } = GridPoint::new(self.p, x, l);
        let off = level_offset(self.p.side, l);
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        let mut acc = Vec4::ZERO;
        let mut err = SampleError::default();
        let mut jump = Vec4::ZERO;
        for ca in 0..2 {
            for cb in 0..2 {
                let wa = if ca == 1 { f[a] } else { 1.0 - f[a] };
                let wb = if cb == 1 { f[b] } else { 1.0 - f[b] };
                let mut i = i0;
                i[a] += ca;
                i[b] += cb;
                let (v, flip) = self.pair(off, n, i, k, f[k], d);
                acc += v * (wa * wb);
                jump += flip * (wa * wb);
                // The trilinear bound of this pair's two corners.
                let mut w = [0.0f32; 3];
                w[a] = wa;
                w[b] = wb;
                for (c, wk) in [(0, 1.0 - f[k]), (1, f[k])] {
                    let mut ic = i;
                    ic[k] += c;
                    w[k] = wk;
                    err.add_corner(dq, w, self.fetch(off, n, ic).0);
                }
                // Near the pair's ends the neighbouring pair (rounding may pick it) differs by up to
                // h |near - far| of the two pairs meeting there.
                if f[k] <= dq || f[k] >= 1.0 - dq {
                    let mut j = i;
                    j[k] += if f[k] <= dq { -1 } else { 1 };
                    let (lo_v, hi_v) = (self.fetch(off, n, j).0, {
                        let mut jh = j;
                        jh[k] += 1;
                        self.fetch(off, n, jh).0
                    });
                    let (cur_lo, cur_hi) = (self.fetch(off, n, i).0, {
                        let mut ih = i;
                        ih[k] += 1;
                        self.fetch(off, n, ih).0
                    });
                    jump += ((lo_v - hi_v).abs() + (cur_lo - cur_hi).abs()) * (wa * wb);
                }
            }
        }
        err.rgb += jump.x.max(jump.y).max(jump.z);
        err.a += jump.w;
        (acc, err)
    }

    /// Level `l` at `x` for a cone along `d`: the depth-ordered blend (with the other axis's value as
    /// an allowance where the dominant axis is a near tie), or trilinear when off.
    pub fn level_along(&self, x: Vec3, l: u32, d: Vec3) -> (Vec4, SampleError) {
        if self.p.depth_order == 0 {
            return self.level(x, l);
        }
        let ad = d.abs();
        let k = dominant_axis(ad);
        let (v, mut err) = self.ordered(x, l, d, k);
        let tie = 4.0 * f32::EPSILON * ad.max_element();
        for other in 0..3 {
            if other != k && (ad[other] - ad[k]).abs() <= tie {
                let (w, e) = self.ordered(x, l, d, other);
                let diff = (v - w).abs();
                err.rgb += diff.x.max(diff.y).max(diff.z) + e.rgb;
                err.a += diff.w + e.a;
            }
        }
        (v, err)
    }
}

/// The axis of the largest component of `ad` (non-negative), ties to the lower axis (the kernel's
/// `select` order).
pub fn dominant_axis(ad: Vec3) -> usize {
    if ad.x >= ad.y && ad.x >= ad.z {
        0
    } else if ad.y >= ad.z {
        1
    } else {
        2
    }
}

impl Volume for OrderedPyramid<'_> {
    fn params(&self) -> &ConeParams {
        self.p
    }

    /// The paper's trilinear ([`Pyramid`]'s).
    fn level(&self, x: Vec3, l: u32) -> (Vec4, SampleError) {
        Pyramid {
            p: self.p,
            voxels: self.voxels,
        }
        .level(x, l)
    }

    fn sample_cone(
        &self,
        x: Vec3,
        lf: f32,
        _diam: f32,
        d: Vec3,
        _tan_half: f32,
    ) -> (Vec4, SampleError) {
        quadrilinear(self.p.levels - 1, lf, |l| self.level_along(x, l, d))
    }
}

/// Trilinear sample of whole level `l` (side `p.side >> l`, Morton order) at world point `x`, with
/// `fetch(morton index)` reading a voxel of that level; voxels outside the grid are empty. Its error
/// from the sample point's rounding ([`SampleError`]). The dense pyramid's and lrsm_cone_trace's
/// occlusion levels.
pub fn trilinear_level(
    p: &ConeParams,
    x: Vec3,
    l: u32,
    fetch: impl Fn(usize) -> Vec4,
) -> (Vec4, SampleError) {
    trilinear_level_moved(p, x, l, 0.0, fetch)
}

/// Where world point `x` falls in whole level `l` of the cone's grid (the kernels' order of
/// operations): the level's side `n`, its inverse cell size `inv`, the cell coordinates' rounding
/// error `dq` ([`SampleError::coordinate_error`]), the fractions `f` and the lower corner `i0` of the
/// trilinear cell.
pub struct GridPoint {
    pub n: i32,
    pub inv: f32,
    pub dq: f32,
    pub f: Vec3,
    pub i0: [i32; 3],
}

impl GridPoint {
    pub fn new(p: &ConeParams, x: Vec3, l: u32) -> Self {
        let inv = p.inv_s0 * (1.0 / (1u32 << l) as f32);
        let origin = Vec3::from_slice(&p.origin[..3]);
        let q = (x - origin) * inv - Vec3::splat(0.5);
        let fl = q.floor();
        Self {
            n: (p.side >> l) as i32,
            inv,
            dq: SampleError::coordinate_error(x, origin, inv, q),
            f: q - fl,
            i0: [fl.x as i32, fl.y as i32, fl.z as i32],
        }
    }
}

/// [`trilinear_level`] at a point `x` that is itself computed (a world point taken into a placed
/// grid's frame: `PlacedPyramids`), off by up to `dx` in the grid's units beyond its own rounding.
pub fn trilinear_level_moved(
    p: &ConeParams,
    x: Vec3,
    l: u32,
    dx: f32,
    fetch: impl Fn(usize) -> Vec4,
) -> (Vec4, SampleError) {
    let GridPoint { n, inv, dq, f, i0 } = GridPoint::new(p, x, l);
    let dq = dq + dx * inv;
    let mut acc = Vec4::ZERO;
    let mut err = SampleError::default();
    for corner in 0..8u32 {
        let (cx, cy, cz) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        let wx = if cx == 1 { f.x } else { 1.0 - f.x };
        let wy = if cy == 1 { f.y } else { 1.0 - f.y };
        let wz = if cz == 1 { f.z } else { 1.0 - f.z };
        let (ix, iy, iz) = (i0[0] + cx as i32, i0[1] + cy as i32, i0[2] + cz as i32);
        if ix < 0 || iy < 0 || iz < 0 || ix >= n || iy >= n || iz >= n {
            continue;
        }
        let v = fetch(morton::encode(ix as u32, iy as u32, iz as u32) as usize);
        acc += v * (wx * wy * wz);
        err.add_corner(dq, [wx, wy, wz], v);
    }
    (acc, err)
}

/// Result of one cone: radiance, AO occlusion, and the mirror's bound on the radiance.
#[derive(Clone, Copy, Debug, Default)]
pub struct ConeResult {
    pub radiance: Vec3,
    pub occlusion: f32,
    /// Accumulated magnitude the bound is proportional to, and allowances for rounding-decided stops.
    pub magnitude: f32,
    pub allowance: f32,
    /// The same for the occlusion.
    pub occ_magnitude: f32,
    pub occ_allowance: f32,
}

/// The step-corrected alpha `1 - (1 - a)^ratio` of a sample alpha `a` (clamped to [0, 1]), in the
/// kernels' operation order (cone_march.wgsl, lrsm_cone_trace.wgsl's shadow cones).
pub fn step_alpha(a: f32, ratio: f32) -> f32 {
    let a = a.clamp(0.0, 1.0);
    if a > 0.0 {
        let keep = 1.0 - a;
        1.0 - if keep > 0.0 { keep.powf(ratio) } else { 0.0 }
    } else {
        0.0
    }
}

/// How far [`step_alpha`] moves when `a` moves by up to `da`: taken exactly over the interval (it is
/// monotone), since its slope is unbounded as a -> 1 when ratio < 1.
pub fn step_alpha_error(a: f32, ratio: f32, da: f32) -> f32 {
    let a2 = step_alpha(a, ratio);
    (step_alpha(a + da, ratio) - a2)
        .abs()
        .max((a2 - step_alpha(a - da, ratio)).abs())
}

/// `cos_n`: cosine between the cone and the origin surface's normal (for the mip clamp).
pub fn march(
    pyr: &(impl Volume + ?Sized),
    o: Vec3,
    d: Vec3,
    tan: f32,
    cos_n: f32,
    lmax: f32,
) -> ConeResult {
    let p = pyr.params();
    let s0 = p.origin[3];
    let inv_s0 = p.inv_s0;
    let max_dist = p.side as f32 * s0 * 1.732_050_8;
    let sf = p.step_factor;
    let grow = 1.0 + 2.0 * sf * tan;
    let dl = grow.log2();
    let mut diam = 0.75 * s0;
    let mut lf: f32 = -0.415_037_5; // log2(0.75)
    let mut t = diam * (0.5 * sf);
    let mut c_acc = Vec3::ZERO;
    let mut a_acc = 0.0f32;
    let mut occ = 0.0f32;
    // Bound on |GPU A - mirror A| so far (sample points, pow, arithmetic), for the stop decision.
    let mut a_err = 0.0f32;
    let mut r = ConeResult::default();
    let off = p.offset_voxels * s0;
    let corr = p.coverage_correlation;
    while t <= max_dist && a_acc < OPAQUE {
        let mut l = lf + p.level_bias;
        if p.mip_clamp > 0.0 {
            let plane = off + t * cos_n.max(0.0);
            l = l.min((plane * inv_s0 / p.mip_clamp).log2());
        }
        let (s, serr) = pyr.sample_cone(o + d * t, l, diam, d, tan);
        let step = diam * sf;
        // step / cell, cell = s0 * 2^max(l, 0) (= diam while the level follows the diameter).
        let ratio = if l < lf {
            step * inv_s0 / l.max(0.0).exp2()
        } else {
            sf * (diam * inv_s0).min(1.0)
        };
        let a = s.w.clamp(0.0, 1.0);
        let a2 = step_alpha(a, ratio);
        let c2 = if a > 0.0 {
            s.truncate() * (a2 / a)
        } else {
            Vec3::ZERO
        };
        let mut vis = 1.0 - a_acc;
        if corr > 0.0 && a2 > 0.0 {
            // The sample's share of the cone (ConeParams::coverage_correlation): what it adds,
            // (1 - c)(1 - A) a2 + c max(0, a2 - A), over a2 (in [0, 1]).
            vis = (1.0 - corr) * vis + corr * ((a2 - a_acc).max(0.0) / a2);
        }
        c_acc += c2 * vis;
        if t <= p.ao_range {
            let o = vis * a2 / (1.0 + p.ao_lambda * t);
            occ += o;
            r.occ_magnitude += o + 1e-3 * vis * a2;
        }
        // The weight of this sample's input errors below: `vis`, or with correlated coverage the
        // share's slope in a2, (1 - c)(1 - A) + c, which bounds the share too. (A's own error moves
        // the colour of this and every later sample by at most lmax in all: the opacity after each
        // sample is monotone in the one before, with slope in [0, 1], so each source of error is
        // still counted once for this sample and once for the rest, as without correlation.)
        let wb = if corr > 0.0 {
            (1.0 - corr) * (1.0 - a_acc) + corr
        } else {
            vis
        };
        a_acc += vis * a2;
        r.magnitude += wb * (c2.abs().max_element() + lmax * 1e-3 * a2);
        // The sample point's rounding (SampleError): colour error scaled like c2 (a2 / a <= g), alpha
        // error through a2 (slope <= g away from opacity) into this and every later sample (<= lmax),
        // and through a2 / a into c2 (slope <= g^2 times the premultiplied colour <= lmax).
        let g = ratio.max(1.0);
        // Near opacity the step correction is steep: d(1 - (1 - a)^ratio)/da is unbounded as a -> 1
        // when ratio < 1, so there the alpha error (the sample point's plus 8 ULP of the trilinear
        // blend) is carried through a2 exactly, over the interval (a2 is monotone in a). Seen on an
        // H100: a = 1 - 2^-24 there, 1 here, ratio 1/3: a2 = 1 - 2^-8 against 1.
        let da2 = step_alpha_error(a, ratio, serr.a + 8.0 * f32::EPSILON);
        r.allowance += wb * (g * serr.rgb + 2.0 * g * g * lmax * serr.a + 2.0 * lmax * da2);
        r.occ_allowance += wb * (2.0 * g * serr.a + da2);
        a_err += wb * (2.0 * g * serr.a + da2) + MAG * wb * a2;
        // pow(keep, ratio) is exp2(ratio * log2(keep)) by WGSL's accuracy rule, and log2 has an
        // *absolute* error of 2^-21 on [0.5, 2]: where keep is near 1 (a small alpha, common where
        // opacity is averaged, e.g. the octree's Gaussian mips) a2 may be off by ~ratio * 2^-21
        // whatever its size (measured: 2% of a small channel, svo_cone_trace seed 2). That error
        // reaches this sample's colour (times its radiance, <= lmax) and every later sample through
        // (1 - A) (their radiance summed, <= lmax).
        if a > 0.0 && a < 1.0 {
            let e_pow = g * (2.0f32).powi(-21) + 8.0 * f32::EPSILON;
            r.allowance += wb * 2.0 * lmax * e_pow;
            r.occ_allowance += wb * 2.0 * e_pow;
            a_err += wb * 2.0 * e_pow;
        }
        // Where the GPU's accumulated alpha may sit on the other side of OPAQUE (within its own
        // error `a_err`, not a fixed window: seen on an H100, a cone stopped one sample earlier than
        // the mirror's, AO off by w / 256), the rest of the cone, at most (1 - A) + a_err, is either side's.
        if (a_acc - OPAQUE).abs() < 1e-4 + a_err
            || (t - max_dist).abs() < 1e-5 * max_dist
            || (t - p.ao_range).abs() < 1e-5 * p.ao_range.max(s0)
        {
            r.allowance += (vis.max(1.0 - a_acc) + a_err) * lmax;
            r.occ_allowance += vis.max(1.0 - a_acc) + a_err;
        }
        t += step;
        diam *= grow;
        lf += dl;
    }
    r.radiance = c_acc;
    r.occlusion = occ;
    r
}

/// Tangent basis the kernel uses: t = normalize(cross(z or x, n)), b = cross(n, t).
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let up = if n.z.abs() < 0.999 { Vec3::Z } else { Vec3::X };
    let t = up.cross(n);
    let t = t * (1.0 / t.dot(t).sqrt());
    (t, n.cross(t))
}

/// Host-side diffuse cone set, tangent space (z = normal), w = weight, weights summing to 1.
///
/// - Up to [`RING_MAX`] cones (the usual 5-, 6- and 9-cone sets): one along the normal and `count - 1`
///   in a ring at polar angle 90 deg - 1.5 x the half-angle (so the ring's cones stay half a half-angle
///   clear of the surface's own plane, which they would otherwise sample as occluder and light),
///   weights proportional to cos(polar angle).
/// - More: a ring leaves every cone at one of two polar angles, so more cones only crowd the ring.
///   They follow [`spiral_cones`] instead, which spreads them over the hemisphere.
///
/// Measured (Cornell box 256x256 vs the 4096-spp reference, combined FLIP, vct-dense on lavapipe):
/// ring 5 / 7 / 8 / 9 cones 0.238 / 0.225 / 0.224 / 0.222, spiral 0.244 / 0.232 / 0.228 / 0.219 (a
/// tie at 9); ring 16 x 30 deg 0.220, spiral 16 x 25 deg 0.204; ring 32 x 30 deg 0.222, spiral 32 x 18
/// deg 0.201. With exact visibility and radiance (`vxgi reference --ideal-cones`): ring 5 x 30 deg
/// 0.172, spiral 16 x 25 deg 0.103, spiral 64 x 12 deg 0.078.
pub fn diffuse_cones(count: u32, tan: f32) -> Vec<[f32; 4]> {
    let count = count.max(1);
    if count > RING_MAX {
        return spiral_cones(count, tan);
    }
    let ring = count - 1;
    let theta = (std::f32::consts::FRAC_PI_2 - 1.5 * tan.atan()).max(0.0);
    let mut dirs = vec![[0.0, 0.0, 1.0, 1.0]];
    for k in 0..ring {
        let phi = k as f32 / ring as f32 * std::f32::consts::TAU;
        dirs.push([
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
            theta.cos(),
        ]);
    }
    let sum: f32 = dirs.iter().map(|d| d[3]).sum();
    for d in &mut dirs {
        d[3] /= sum;
    }
    dirs
}

/// The largest count [`diffuse_cones`] lays out as centre + ring.
pub const RING_MAX: u32 = 9;

/// `count` cones spread over the hemisphere with a cosine-weighted density, all of weight 1 / count:
/// cone k's axis projects onto the tangent disk at radius `sqrt((k + 1/2) / count)` and golden-angle
/// azimuth `k x pi (3 - sqrt 5)` (a Fibonacci spiral: equal-area cells of the disk, and a disk's area
/// element is the hemisphere's cos-weighted solid angle). Polar angles are capped at 90 deg - the
/// half-angle, so no cone reaches below the surface's own plane; the capped cones stand for the
/// grazing band's share of the cosine lobe (the cap's area outside the disk of radius sin(cap)).
pub fn spiral_cones(count: u32, tan: f32) -> Vec<[f32; 4]> {
    let count = count.max(1);
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let cap = (std::f32::consts::FRAC_PI_2 - tan.atan()).max(0.0);
    let w = 1.0 / count as f32;
    (0..count)
        .map(|k| {
            let r = ((k as f32 + 0.5) * w).sqrt();
            let theta = r.asin().min(cap);
            let phi = golden * k as f32;
            [
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
                w,
            ]
        })
        .collect()
}

/// The `cone_dirs` buffer of `p`: [`diffuse_cones`] where `p.interleave` <= 1; else one
/// [`spiral_cones`] of `diffuse_cones` N^2 cones, each of weight 1 / `diffuse_cones` (a class's
/// subset sums to 1), of which pixel class j takes cones j, j + N^2, j + 2 N^2, ... ([`class_cones`]):
/// each class spreads over the whole hemisphere, and the N^2 classes together are the spiral.
pub fn cone_dirs(p: &ConeParams) -> Vec<[f32; 4]> {
    let n = p.interleave.max(1);
    if n == 1 {
        return diffuse_cones(p.diffuse_cones, p.diffuse_tan);
    }
    let count = p.diffuse_cones.max(1);
    let mut dirs = spiral_cones(count * n * n, p.diffuse_tan);
    for d in &mut dirs {
        d[3] = 1.0 / count as f32;
    }
    dirs
}

/// The interleaving class of pixel (x, y): `(x mod N) + N (y mod N)` (0 when N <= 1).
pub fn pixel_class(p: &ConeParams, x: u32, y: u32) -> u32 {
    let n = p.interleave.max(1);
    x % n + n * (y % n)
}

/// The cones pixel (x, y) traces: `dirs[k N^2 + class]` for k < `diffuse_cones` (the kernel's
/// `cone_dirs[k * n * n + cls]`; all of `dirs` up to `diffuse_cones` when N <= 1).
pub fn class_cones(dirs: &[[f32; 4]], p: &ConeParams, x: u32, y: u32) -> Vec<[f32; 4]> {
    let n2 = p.interleave.max(1).pow(2) as usize;
    let c = pixel_class(p, x, y) as usize;
    (0..p.diffuse_cones as usize)
        .filter_map(|k| dirs.get(k * n2 + c).copied())
        .collect()
}

/// The resolve's same-surface test: a neighbour's (signed) normal within this cosine of the pixel's.
pub const RESOLVE_COS: f32 = 0.9;

/// One pixel's cone-pass outputs and their bounds (each the shape of its value).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelOut {
    /// Indirect radiance (rgb, 0).
    pub indirect: [f32; 4],
    /// AO (a, a, a, 0).
    pub ao: [f32; 4],
    /// (sum w C, sum w occ) of the diffuse cones: irradiance before the albedo, and occlusion.
    pub irradiance: [f32; 4],
    pub indirect_bound: [f32; 4],
    pub ao_bound: [f32; 4],
    pub irradiance_bound: [f32; 4],
}

/// The resolve pass of interleaved cone sets (the kernel's entry `resolve`; run only when
/// `p.interleave` > 1): each surface pixel's irradiance and occlusion averaged with tent weights
/// `(N - |dx|) (N - |dy|)` over the (2N - 1)^2 pixels around it (inside the image) — in a full
/// window every class weighs the same, N^2 of N^4, as in an N x N box, and a class's sample fades in
/// and out as the window slides instead of jumping, which an N x N box shows as an N-periodic
/// pattern where the classes' estimates differ (the hot spot's glow) — over the window's pixels of
/// the same surface: a surface pixel (`normal.w != 0`) facing the camera as the pixel does (front or
/// back, the sign of `w`) whose signed normal (`xyz * sign(w)`) is within [`RESOLVE_COS`] of the
/// pixel's and whose position lies within one level-0 cell (`s0`) of the pixel's plane (the pixel
/// itself always counts). Then AO = `clamp(1 - mean occ, 0, 1)` and, on front faces, indirect +=
/// albedo (mean irradiance - own irradiance): the glossy cone's share stays the pixel's own. Sums run
/// in the kernel's order (rows, then columns) in f32; the weights are small integers, exact.
///
/// Bounds: the mean's error is at most the weighted mean of its terms' bounds plus (terms + 5) ULP
/// (2^-23) of the weighted mean of their magnitudes (a product and an addition per term, a division
/// within 2.5 ULP, WGSL's rule); where a neighbour's test is within rounding of its threshold
/// (either side may decide), its whole share `w_q (|v_q| + max |v|) / k` is added, k the certain
/// members' weight. The final additions add an ULP each of their operands.
pub fn resolve(
    p: &ConeParams,
    width: u32,
    position: &[[f32; 4]],
    normal: &[[f32; 4]],
    albedo: &[[f32; 4]],
    px: &[PixelOut],
) -> Vec<PixelOut> {
    let n = p.interleave.max(1) as i64;
    let (w, h) = (width as i64, (px.len() as i64) / (width.max(1) as i64));
    let s0 = p.origin[3];
    let ulp = f32::EPSILON; // 2^-23
    let signed = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]) * if v[3] > 0.0 { 1.0 } else { -1.0 };
    (0..px.len())
        .map(|i| {
            let mut out = px[i];
            let nrm = normal[i];
            if n <= 1 || nrm[3] == 0.0 {
                return out;
            }
            let (x, y) = (i as i64 % w, i as i64 / w);
            let np = signed(nrm);
            let pp = Vec3::from_slice(&position[i][..3]);
            let mut sum = Vec4::ZERO;
            let mut sum_b = Vec4::ZERO;
            let mut sum_mag = Vec4::ZERO;
            let mut k = 0.0f32;
            let mut terms = 0.0f32;
            let mut unsure: Vec<(f32, Vec4)> = Vec::new();
            let mut vmax = Vec4::ZERO;
            for yy in (y - n + 1).max(0)..(y + n).min(h) {
                for xx in (x - n + 1).max(0)..(x + n).min(w) {
                    let j = (yy * w + xx) as usize;
                    let v = Vec4::from_array(px[j].irradiance);
                    let wt = ((n - (xx - x).abs()) * (n - (yy - y).abs())) as f32;
                    let take = if j == i {
                        true
                    } else {
                        let nq = normal[j];
                        if nq[3] == 0.0 || (nq[3] > 0.0) != (nrm[3] > 0.0) {
                            continue;
                        }
                        let q = Vec3::from_slice(&position[j][..3]);
                        let cos = np.dot(signed(nq));
                        let dist = (q - pp).dot(np).abs();
                        let take = cos >= RESOLVE_COS && dist <= s0;
                        // Rounding of the two dot products (three products and two sums of values
                        // up to |q| + |p|, unit normals): a few ULP each; 8 ULP of margin.
                        let eps =
                            8.0 * ulp * (1.0 + pp.abs().max_element() + q.abs().max_element());
                        if (cos - RESOLVE_COS).abs() <= 8.0 * ulp || (dist - s0).abs() <= eps {
                            unsure.push((wt, v.abs()));
                            vmax = vmax.max(v.abs());
                            continue;
                        }
                        take
                    };
                    if take {
                        sum += v * wt;
                        sum_b += Vec4::from_array(px[j].irradiance_bound) * wt;
                        sum_mag += v.abs() * wt;
                        vmax = vmax.max(v.abs());
                        k += wt;
                        terms += 1.0;
                    }
                }
            }
            // The mirror leaves the unsure neighbours out; the bound covers the GPU's taking any
            // (taking one of weight w_q moves the mean by at most w_q (|v_q| + max |v|) / k).
            let mean = sum / k;
            let mut mean_b = sum_b / k + sum_mag / k * ((terms + 5.0) * ulp);
            for (wt, u) in &unsure {
                mean_b += (*u + vmax) * (*wt / k);
            }
            let occ = mean.w;
            let a = (1.0 - occ).clamp(0.0, 1.0);
            out.ao = [a, a, a, 0.0];
            let ab = mean_b.w + ulp;
            out.ao_bound = [ab, ab, ab, 0.0];
            if nrm[3] > 0.0 {
                let own = Vec4::from_array(px[i].irradiance);
                let own_b = Vec4::from_array(px[i].irradiance_bound);
                let kd = Vec4::new(albedo[i][0], albedo[i][1], albedo[i][2], 0.0);
                let ind = Vec4::from_array(px[i].indirect);
                let diff = mean - own;
                let v = ind + kd * diff;
                out.indirect = [v.x, v.y, v.z, 0.0];
                let b = Vec4::from_array(px[i].indirect_bound)
                    + kd * (mean_b + own_b + (mean.abs() + own.abs()) * ulp)
                    + (ind.abs() + kd * (mean.abs() + own.abs())) * (2.0 * ulp);
                out.indirect_bound = [b.x, b.y, b.z, 0.0];
            }
            out
        })
        .collect()
}

/// Bound factor on accumulated magnitudes: ~30 dependent operations per sample (each correctly rounded
/// or within 2.5 ULP; pow and log2 per WGSL's exp2/log2 rules), over at most ~64 samples per cone:
/// 30 x 2.5 x 64 ULP ~ 5e3 ULP ~ 6e-4, and the samples' errors are damped by the (1 - A) factors, so
/// 4e-4 of the accumulated |terms| (each padded by 1e-3 of the sample's alpha times the largest radiance,
/// for pow's absolute error near alpha = 0).
pub const MAG: f32 = 4e-4;

/// One voxel of a second bounce (svo_cone_trace.wgsl's `voxel_main`): the pixel's diffuse cones from
/// the voxel's centre `position` offset along its unit mean `normal` (w = 0: none, gives 0), times
/// `albedo`: (rgb, 0) and its bound.
pub fn shade_voxel(
    pyr: &(impl Volume + ?Sized),
    cones: &[[f32; 4]],
    position: [f32; 4],
    normal: [f32; 4],
    albedo: [f32; 4],
    lmax: f32,
) -> ([f32; 4], [f32; 4]) {
    let p = pyr.params();
    if normal[3] == 0.0 {
        return ([0.0; 4], [0.0; 4]);
    }
    let n = Vec3::new(normal[0], normal[1], normal[2]);
    let o = Vec3::from_slice(&position[..3]) + n * (p.offset_voxels * p.origin[3]);
    let (bt, bb) = basis(n);
    let mut diffuse = Vec3::ZERO;
    let mut mag = 0.0f32;
    for c in &cones[..p.diffuse_cones as usize] {
        let dir = bt * c[0] + bb * c[1] + n * c[2];
        let r = march(pyr, o, dir, p.diffuse_tan, c[2], lmax);
        diffuse += r.radiance * c[3];
        mag += (r.magnitude * MAG + r.allowance) * c[3];
    }
    let kd = Vec3::from_slice(&albedo[..3]);
    let v = kd * diffuse;
    let b = kd * mag;
    ([v.x, v.y, v.z, 0.0], [b.x, b.y, b.z, 0.0])
}

/// One pixel (`cones`: its class's, [`class_cones`]): indirect radiance, AO, irradiance and their bounds.
#[allow(clippy::too_many_arguments)]
pub fn shade_pixel(
    pyr: &(impl Volume + ?Sized),
    frame: &Frame,
    tris: &[GpuTriangle],
    materials: &[GpuMaterial],
    cones: &[[f32; 4]],
    position: [f32; 4],
    normal: [f32; 4],
    triangle: u32,
    albedo: [f32; 4],
    lmax: f32,
) -> PixelOut {
    let p = pyr.params();
    if normal[3] == 0.0 || triangle as usize >= tris.len() {
        return PixelOut::default();
    }
    let front = normal[3] > 0.0;
    let tri = &tris[triangle as usize];
    let m = &materials[(tri.material() as usize).min(materials.len() - 1)];
    let sign = if front { 1.0 } else { -1.0 };
    let n = Vec3::new(normal[0], normal[1], normal[2]) * sign;
    let ng = face_normal(tri) * sign;
    let pos = Vec3::new(position[0], position[1], position[2]);
    let s0 = p.origin[3];
    let o = pos + ng * (p.offset_voxels * s0);
    let (bt, bb) = basis(n);
    let mut diffuse = Vec3::ZERO;
    let mut occ = 0.0f32;
    let mut mag = 0.0f32;
    let mut occ_b = 0.0f32;
    for c in &cones[..p.diffuse_cones as usize] {
        let dir = bt * c[0] + bb * c[1] + n * c[2];
        let r = march(pyr, o, dir, p.diffuse_tan, c[2], lmax);
        diffuse += r.radiance * c[3];
        occ += r.occlusion * c[3];
        mag += (r.magnitude * MAG + r.allowance) * c[3];
        occ_b += (r.occ_magnitude * MAG + r.occ_allowance) * c[3];
    }
    let ao = (1.0 - occ).clamp(0.0, 1.0);
    let ao_out = [ao, ao, ao, 0.0];
    // Plus one ULP at 1 for the final `1 - occ`: correctly rounded, but occ's own error can carry it
    // across a rounding boundary of the result (seen: occ ~ 2e-7, AO off by one ULP below 1).
    let occ_b = occ_b + f32::EPSILON;
    let ao_bound = [occ_b, occ_b, occ_b, 0.0];
    let unlit = PixelOut {
        ao: ao_out,
        ao_bound,
        irradiance: [diffuse.x, diffuse.y, diffuse.z, occ],
        irradiance_bound: [mag, mag, mag, occ_b],
        ..Default::default()
    };
    if !front {
        return unlit;
    }
    let kd = Vec3::from_slice(&albedo[..3]);
    let ks = Vec3::from_slice(&m.specular[..3]);
    let mut indirect = kd * diffuse;
    let mut bound = kd * mag;
    if ks != Vec3::ZERO {
        let e = Vec3::from_slice(&frame.eye[..3]) - pos;
        let wo = e * (1.0 / e.dot(e).sqrt());
        let refl = n * (2.0 * n.dot(wo)) - wo;
        let tan = (2.0 / (m.diffuse[3] + 2.0)).sqrt().clamp(0.02, 1.0);
        let r = march(pyr, o, refl, tan, refl.dot(n), lmax);
        indirect += ks * r.radiance;
        bound += ks * (r.magnitude * MAG + r.allowance);
    }
    PixelOut {
        indirect: [indirect.x, indirect.y, indirect.z, 0.0],
        indirect_bound: [bound.x, bound.y, bound.z, 0.0],
        ..unlit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// A 4^3 grid: the cells at x = 1 dark and opaque with normal (`dark_normal`, 0, 0), those at
    /// x = 2 lit and opaque, the rest empty (the samples read level 0).
    fn wall(dark_normal: f32) -> (ConeParams, Vec<[f32; 4]>, Vec<[f32; 4]>) {
        let p = ConeParams {
            origin: [0.0, 0.0, 0.0, 1.0],
            side: 4,
            levels: 3,
            inv_s0: 1.0,
            step_factor: 0.5,
            depth_order: 1,
            ..Default::default()
        };
        let mut c = vec![[0.0f32; 4]; pyramid_len(4)];
        let mut n = vec![[0.0f32; 4]; pyramid_len(4)];
        for y in 0..4 {
            for z in 0..4 {
                let d = morton::encode(1, y, z) as usize;
                c[d] = [0.0, 0.0, 0.0, 1.0];
                n[d] = [dark_normal, 0.0, 0.0, 0.0];
                let l = morton::encode(2, y, z) as usize;
                c[l] = [5.0, 5.0, 5.0, 1.0];
                n[l] = [1.0, 0.0, 0.0, 0.0];
            }
        }
        (p, c, n)
    }

    /// The depth-ordered blend: a cone reaching the dark side of an opaque wall first (the dark cell
    /// faces it) sees none of the lit cell behind, where the trilinear blend mixes in 40%; from the
    /// back of the dark cell (its surface facing away) it is the trilinear blend; off, exactly
    /// `Pyramid`'s sample.
    #[test]
    fn depth_ordered_blend_keeps_a_walls_far_side_hidden() {
        let x = Vec3::new(2.1, 2.0, 2.0); // 0.6 of the way from cell 1's centre to cell 2's
        let d = Vec3::new(1.0, 0.1, 0.0).normalize();
        let (p, c, n) = wall(-1.0);
        let ordered = OrderedPyramid {
            p: &p,
            voxels: &c,
            normals: &n,
        };
        let (v, e) = ordered.sample_cone(x, 0.0, 1.0, d, 0.5);
        assert_eq!(v.truncate(), Vec3::ZERO, "{v}");
        assert!((v.w - 1.0).abs() < 1e-6, "{v}");
        assert!(e.rgb < 1e-3, "{e:?}");
        let lin = Pyramid { p: &p, voxels: &c }.sample(x, 0.0).0;
        assert!((lin.x - 3.0).abs() < 1e-5, "{lin}");
        // The dark surface facing away from the cone: it hides nothing.
        let (p2, c2, n2) = wall(1.0);
        let back = OrderedPyramid {
            p: &p2,
            voxels: &c2,
            normals: &n2,
        };
        assert!(
            (back.sample_cone(x, 0.0, 1.0, d, 0.5).0 - lin)
                .abs()
                .max_element()
                < 1e-6
        );
        // Off: the paper's trilinear, bit for bit.
        let off = ConeParams {
            depth_order: 0,
            ..p
        };
        let plain = OrderedPyramid {
            p: &off,
            voxels: &c,
            normals: &n,
        };
        for lf in [0.0f32, 0.4, 1.3, 2.0] {
            assert_eq!(
                plain.sample_cone(x, lf, 1.0, d, 0.5).0,
                Pyramid {
                    p: &off,
                    voxels: &c
                }
                .sample(x, lf)
                .0
            );
        }
        // At the pair's far end the blend jumps to the next pair: the bound says so.
        let at_end = Vec3::new(2.5 - 1e-7, 2.0, 2.0);
        let (_, e) = ordered.sample_cone(at_end, 0.0, 1.0, d, 0.5);
        assert!(e.rgb >= 5.0, "{e:?}");
    }

    /// Interleaved cone sets: each of the N^2 classes takes `diffuse_cones` cones of weight summing to
    /// 1, spread over the hemisphere (its mean cosine near the lobe's 2/3), and the classes together
    /// are the whole spiral, each cone once; N = 1 is the plain set.
    #[test]
    fn interleaved_classes_partition_one_spiral() {
        for (n, cones) in [(2u32, 16u32), (4, 16), (8, 4), (4, 1)] {
            let p = ConeParams {
                diffuse_cones: cones,
                diffuse_tan: 0.05,
                interleave: n,
                ..Default::default()
            };
            let dirs = cone_dirs(&p);
            assert_eq!(dirs.len() as u32, cones * n * n);
            let mut seen = vec![0u32; dirs.len()];
            for y in 0..n {
                for x in 0..n {
                    let set = class_cones(&dirs, &p, x + 8, y + 16);
                    assert_eq!(set, class_cones(&dirs, &p, x, y), "the pattern repeats");
                    assert_eq!(set.len() as u32, cones);
                    let w: f32 = set.iter().map(|d| d[3]).sum();
                    assert!((w - 1.0).abs() < 1e-5, "N {n}: class weights sum to {w}");
                    if cones >= 16 {
                        let mean_cos: f32 = set.iter().map(|d| d[2] * d[3]).sum();
                        assert!(
                            (mean_cos - 2.0 / 3.0).abs() < 0.05,
                            "N {n}: mean cos {mean_cos}"
                        );
                    }
                    for d in &set {
                        let k = dirs.iter().position(|e| e == d).expect("from the spiral");
                        seen[k] += 1;
                    }
                }
            }
            assert!(
                seen.iter().all(|&c| c == 1),
                "N {n}: every cone once: {seen:?}"
            );
        }
        let plain = ConeParams {
            diffuse_cones: 5,
            diffuse_tan: 0.5,
            ..Default::default()
        };
        assert_eq!(cone_dirs(&plain), diffuse_cones(5, 0.5));
        assert_eq!(
            class_cones(&cone_dirs(&plain), &plain, 3, 7),
            diffuse_cones(5, 0.5)
        );
    }

    /// An 8 x 6 image: a floor (normal +y) whose irradiance is the pixel's class, and in columns 6-7 a
    /// step 0.5 up (another plane); row 5 background.
    type ResolveScene = (ConeParams, Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<PixelOut>);

    fn resolve_scene(n: u32) -> ResolveScene {
        let p = ConeParams {
            origin: [0.0, 0.0, 0.0, 0.1],
            interleave: n,
            diffuse_cones: 4,
            ..Default::default()
        };
        let (w, h) = (8u32, 6u32);
        let mut pos = vec![[0.0; 4]; (w * h) as usize];
        let mut nrm = vec![[0.0; 4]; (w * h) as usize];
        let mut px = vec![PixelOut::default(); (w * h) as usize];
        for y in 0..h - 1 {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let up = if x >= 6 { 0.5 } else { 0.0 };
                pos[i] = [x as f32 * 0.05, up, y as f32 * 0.05, 1.0];
                nrm[i] = [0.0, 1.0, 0.0, 1.0];
                let c = pixel_class(&p, x, y) as f32;
                px[i].irradiance = [c, 2.0 * c, 1.0, 0.1 * c];
                px[i].indirect = [0.5 * c, c, 0.5, 0.0];
            }
        }
        (p, pos, nrm, px)
    }

    #[test]
    fn resolve_averages_each_surface_over_its_window() {
        let albedo = vec![[0.5, 0.5, 0.5, 1.0]; 48];
        // N = 1: nothing to resolve.
        let (p, pos, nrm, px) = resolve_scene(1);
        assert_eq!(resolve(&p, 8, &pos, &nrm, &albedo, &px), px);
        let (p, pos, nrm, px) = resolve_scene(2);
        let out = resolve(&p, 8, &pos, &nrm, &albedo, &px);
        // Tent weights (2 - |dx|)(2 - |dy|) over 3 x 3. A floor pixel away from the step: its
        // window weighs each of the classes 0..3 by 4 of 16, mean 1.5.
        let i = (2 * 8 + 2) as usize;
        assert_eq!(out[i].indirect, [0.75, 1.5, 0.5, 0.0]);
        let a = 1.0 - 0.15;
        assert!((out[i].ao[0] - a).abs() < 1e-6, "{:?}", out[i].ao);
        let near = |v: f32, e: f32| (v - e).abs() < 1e-6;
        // (5, 2): column 6 is the step, left out: classes 2, 3, 0, 1, 2, 3 of columns 4-5, rows 1-3,
        // weights 1, 2, 2, 4, 1, 2: mean 20 / 12; own class 1.
        let j = (2 * 8 + 5) as usize;
        assert!(
            near(out[j].indirect[0], 0.5 + 0.5 * (20.0 / 12.0 - 1.0)),
            "{:?}",
            out[j]
        );
        // (2, 4): row 5 is background: rows 3-4, classes 3, 2, 3 / 1, 0, 1, weights 1, 2, 1 / 2,
        // 4, 2: mean 14 / 12; own class 0.
        let k = (4 * 8 + 2) as usize;
        assert!(near(out[k].indirect[0], 0.5 * 14.0 / 12.0), "{:?}", out[k]);
        assert!(near(out[k].indirect[1], 0.5 * 28.0 / 12.0), "{:?}", out[k]);
        assert!(near(out[k].indirect[2], 0.5), "{:?}", out[k]);
        // (7, 2), the image's last column on the step: columns 6-7, rows 1-3 (the floor's column 5
        // is another plane), as (5, 2) on the floor: channel 1 (2 x class) mean 40 / 12, own 2.
        let e = (2 * 8 + 7) as usize;
        assert!(
            near(out[e].indirect[1], 1.0 + 0.5 * (40.0 / 12.0 - 2.0)),
            "{:?}",
            out[e]
        );
        // Background stays as it was.
        assert_eq!(out[5 * 8], px[5 * 8]);
        // Every bound is positive where there is a value.
        assert!(out[i].indirect_bound[0] > 0.0 && out[i].ao_bound[0] > 0.0);
        // Back faces: AO resolved, indirect left at 0.
        let mut back = nrm.clone();
        for v in &mut back {
            if v[3] != 0.0 {
                *v = [0.0, -1.0, 0.0, -1.0];
            }
        }
        let mut unlit = px.clone();
        for q in &mut unlit {
            q.indirect = [0.0; 4];
        }
        let out = resolve(&p, 8, &pos, &back, &albedo, &unlit);
        assert_eq!(out[i].indirect, [0.0; 4]);
        assert!((out[i].ao[0] - a).abs() < 1e-6);
    }

    /// Cone sets: unit axes in the upper hemisphere, weights summing to 1 (a uniform environment is
    /// gathered exactly); the spiral's axes within the cap that keeps each cone above the surface's
    /// plane, and its weighted mean cosine that of the cosine lobe (2/3) up to the cap's share.
    #[test]
    fn cone_sets_are_normalised_and_spread_over_the_hemisphere() {
        for count in [1u32, 5, 8, 9, 16, 32, 64] {
            for deg in [10.0f32, 25.0, 30.0, 45.0] {
                let tan = deg.to_radians().tan();
                let set = diffuse_cones(count, tan);
                assert_eq!(set.len(), count as usize);
                let sum: f32 = set.iter().map(|c| c[3]).sum();
                assert!((sum - 1.0).abs() < 1e-5, "{count} {deg}: {sum}");
                for c in &set {
                    let len = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
                    assert!((len - 1.0).abs() < 1e-5 && c[2] >= 0.0, "{c:?}");
                    if count > RING_MAX {
                        let polar = c[2].acos().to_degrees();
                        assert!(polar <= 90.0 - deg + 1e-3, "{count} {deg}: {polar}");
                    }
                }
            }
        }
        let set = spiral_cones(64, 10f32.to_radians().tan());
        let mean_cos: f32 = set.iter().map(|c| c[2] * c[3]).sum();
        assert!((mean_cos - 2.0 / 3.0).abs() < 0.02, "{mean_cos}");
    }

    /// The f32 march's largest level index read (floor(lf) + 1 of its last sample), stepping as
    /// `march` does.
    fn f32_highest_read(tan: f32, sf: f32, side: u32) -> u32 {
        let max_dist = side as f32 * 1.732_050_8;
        let grow = 1.0 + 2.0 * sf * tan;
        let dl = grow.log2();
        let (mut diam, mut lf) = (0.75f32, -0.415_037_5f32);
        let mut t = diam * (0.5 * sf);
        let mut top = 0;
        while t <= max_dist {
            top = lf.max(0.0).floor() as u32 + 1;
            t += diam * sf;
            diam *= grow;
            lf += dl;
        }
        top
    }

    /// A medium of one (L alpha, alpha) everywhere; records the levels the march asks for.
    struct Fog {
        p: ConeParams,
        v: Vec4,
        levels: std::cell::RefCell<Vec<f32>>,
    }

    impl Volume for Fog {
        fn params(&self) -> &ConeParams {
            &self.p
        }
        fn level(&self, _x: Vec3, _l: u32) -> (Vec4, SampleError) {
            (self.v, SampleError::default())
        }
        fn sample_cone(&self, _: Vec3, lf: f32, _: f32, _: Vec3, _: f32) -> (Vec4, SampleError) {
            self.levels.borrow_mut().push(lf);
            (self.v, SampleError::default())
        }
    }

    /// One cone of 30 degrees through a uniform medium of alpha 0.3 and radiance 2, 64 cells deep.
    fn through_fog(level_bias: f32, coverage_correlation: f32) -> (ConeResult, Vec<f32>) {
        let fog = Fog {
            p: ConeParams {
                origin: [0.0, 0.0, 0.0, 1.0],
                side: 64,
                levels: 7,
                inv_s0: 1.0,
                step_factor: 0.5,
                level_bias,
                coverage_correlation,
                ..Default::default()
            },
            v: Vec4::new(0.6, 0.6, 0.6, 0.3),
            levels: Default::default(),
        };
        let tan = 30f32.to_radians().tan();
        let r = march(&fog, Vec3::splat(1.0), Vec3::X, tan, 1.0, 2.0);
        (r, fog.levels.into_inner())
    }

    #[test]
    fn fully_correlated_coverage_is_as_opaque_as_the_densest_sample() {
        // Fully correlated: every sample covers the same rays, so the cone's opacity is the largest
        // step-corrected alpha, 1 - 0.7^(1/2) at the paper's step (half a cell of this level's size).
        let (r, _) = through_fog(0.0, 1.0);
        let a = 1.0 - 0.7f32.sqrt();
        assert_relative_eq!(r.radiance.x, 2.0 * a, max_relative = 1e-5);
        // Independent layers (the paper's compositing) compound the samples' alphas: the cone sees
        // 1 - prod(1 - a') of the radiance, far more; half correlated lies between.
        let (indep, _) = through_fog(0.0, 0.0);
        let (half, _) = through_fog(0.0, 0.5);
        assert!(
            indep.radiance.x > half.radiance.x + 0.1,
            "{indep:?} {half:?}"
        );
        assert!(half.radiance.x > r.radiance.x + 0.1, "{half:?} {r:?}");
        assert!(indep.radiance.x > 1.5, "{indep:?}");
    }

    #[test]
    fn a_level_bias_reads_finer_cells_and_corrects_alpha_for_them() {
        let (_, paper) = through_fog(0.0, 1.0);
        let (r, finer) = through_fog(-1.0, 1.0);
        assert_eq!(paper.len(), finer.len());
        for (p, f) in paper.iter().zip(&finer) {
            assert_relative_eq!(*f, p - 1.0, epsilon = 1e-5);
        }
        // Cells half the diameter: a step of half the diameter crosses one whole cell, so the step
        // correction leaves the sample's alpha as it is (ratio 1) and the densest sample is 0.3.
        assert_relative_eq!(r.radiance.x, 2.0 * 0.3, max_relative = 1e-4);
    }

    #[test]
    fn levels_read_cover_every_level_the_march_reads() {
        for side in [8u32, 32, 128, 256] {
            let full = side.trailing_zeros() + 1;
            for deg in [0.5f32, 1.0, 2.0, 3.5, 5.0, 8.0, 8.5, 12.0, 30.0, 60.0, 85.0] {
                for sf in [0.25f32, 0.5, 1.0] {
                    let tan = deg.to_radians().tan();
                    let n = levels_read(tan, sf, side);
                    let read = f32_highest_read(tan, sf, side);
                    assert!(n <= full);
                    // Every level read is built, and below the whole pyramid the top-level shortcut
                    // (l0 >= levels - 1) is never taken.
                    assert!(
                        read < n || n == full,
                        "side {side} {deg} deg sf {sf}: reads {read}, {n} built"
                    );
                    assert!(
                        n <= read + 2,
                        "side {side} {deg} deg sf {sf}: {n} for {read}"
                    );
                }
            }
        }
        // docs/performance.md's numbers: at 128^3 a 30-degree cone reads every level, a 2-degree one up to 4.
        assert_eq!(levels_read(30f32.to_radians().tan(), 0.5, 128), 8);
        assert_eq!(levels_read(2f32.to_radians().tan(), 0.5, 128), 5);
    }
}
