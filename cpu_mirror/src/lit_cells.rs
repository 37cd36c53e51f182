//! Mirror of `kernels/lit_cells.wgsl`: the light views' lit RSM texels in the occlusion pyramid's
//! own cells (lrsm's light where its occlusion is; docs/accuracy/lrsm.md, "The light in the
//! occlusion cells").
//!
//! A cell holds two vec4 of sums over the lit surface that lands in it: `(sum a r, sum a g, sum a
//! b, sum a)` and `(sum a n.x, sum a n.y, sum a n.z, 0)`, `a` each piece's area in level-0 faces
//! (`s0^2`; once resolved, times the area weight of several lights, [`area_weight`]), `rgb` its RSM
//! radiance, `n` its normal. Level 0 is injected ([`inject`]), each level
//! above sums its 8 children ([`reduce`]); the gather reads a cell as [`cell_light`].
//!
//! Level 0 is summed exactly, whatever order the GPU's invocations run in: each piece's seven values
//! as 64-bit fixed point ([`fixed`]: 24 fraction bits; the radiance in units of the grid's
//! `scale.y`, area and normal in level-0 faces), added as two's complement in two `u32` words (the
//! low word in the cell's own float slot, the high word in `hi`, carried from the low word's
//! wrap), then each slot turned into its float in place ([`resolve`]). So two runs of one frame
//! give the same bits, on one GPU; the mirror sums the same integers.
//!
//! Bound (level 0, per float): each piece's own arithmetic (64 ULP of it: the texel's depth,
//! image area, cosine, `<n, l>` and `k^2` divisions, two square roots, the products) and its
//! rounding to the fixed-point quantum (one quantum a piece: either neighbour), the resolve's
//! roundings and the area weight's product (3 ULP of the sum), and every piece whose
//! cell the rounding of its point may change (its point within its error of a cell's face), whose
//! sub-ray count `k` rounding may change (`2 sqrt(plane) / <n, l> / s0` within its error of an
//! integer: the texel's pieces for both counts) or whose plane test may go either way: its whole
//! magnitude in every cell it may land in. Levels above: the children's bounds plus 8 ULP of their
//! summed magnitudes.
use crate::morton;
use crate::reflective_shadow_map::GpuView;
use glam::{Vec3, Vec4};

/// Most sub-rays across a texel (per axis).
pub const MAX_SPREAD: u32 = 16;
/// `|<n, d>|` at or below which a sub-ray is taken as parallel to its texel's plane (it takes the
/// texel's own depth instead).
pub const PARALLEL: f32 = 1e-6;
/// Floor of `<n, l>` (an edge-on texel's area stays finite).
pub const MIN_NDOTL: f32 = 1e-3;
/// With N as a cull, its factor ramps from 0 to 1 over N in [0, CULL_RAMP] (common/lrsm_sample.wgsl's
/// `LRSM_CULL_RAMP`, the same ramp per cell by its mean normal).
pub const CULL_RAMP: f32 = 0.031_25;

/// The voxel grid the cells are the level-0 cells of (the WGSL `LitGrid`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LitGrid {
    /// xyz the grid's low corner, w = s0 (a level-0 cell's side).
    pub origin: [f32; 4],
    /// x = side (cells per axis at level 0); yzw unused.
    pub size: [u32; 4],
    /// The radiance's fixed-point unit: x = 1 / Q, y = Q, Q a power of two ([`radiance_unit`]); z =
    /// the weight `w` of the area and normal sums ([`area_weight`]: 1 for one light); w unused. A
    /// piece's radiance x area is summed in units of Q with 24 fraction bits: at most 2^24 Q a piece
    /// (more is clamped), 2^39 Q a cell, the quantum 2^-24 Q.
    pub scale: [f32; 4],
}

/// Fraction bits of the fixed-point sums.
pub const FRACTION_BITS: u32 = 24;
/// The largest magnitude a piece's value takes in fixed point (2^24, in units of the quantity's
/// unit); larger ones are clamped to it. A cell's sum stays within the 64 bits for 2^15 pieces at
/// this clamp (128 texels of infinite radiance, each split into at most 256 pieces).
pub const MAX_PIECE: f32 = 16_777_216.0;

/// `[1 / Q, Q, 1, 0]` for Q the power of two at or above `typical` (a positive finite radiance;
/// anything else gives Q = 1): the grid's `scale`, its area weight 1 ([`area_weight`] sets another).
pub fn radiance_unit(typical: f32) -> [f32; 4] {
    let q = if typical.is_finite() && typical > 0.0 {
        let e = typical.log2().ceil().clamp(-120.0, 120.0) as i32;
        2f32.powi(e)
    } else {
        1.0
    };
    [1.0 / q, q, 1.0, 0.0]
}

/// The area weight `w` of every cell of a frame lit by `casting` lights (those with light views),
/// where the scene has more lights than the cells' masks hold ([`weigh_lights`]): `1 / casting` (1
/// for none or one).
///
/// A cell's light is its mean radiance times its coverage, `S / A * min(1, A / face)` (`S` the sum of
/// area x radiance, `A` of area): a surface's radiance, not the sum of its pieces'. Where several
/// lights light one cell, each light's views bring the same surface again, so `A` counts it once
/// per light and the mean averages their light instead of adding it. With `A` (and the normal
/// sums, whose direction alone is read) weighted by `1 / casting`, the cell gives `S / face` while
/// `w A <= face`: each light's own `S_l / face`, added. A cell holding more than a face of surface
/// lit by fewer than all the lights (`A_l > face`: a surface crossing a level-0 cell at a slant, two
/// surfaces meeting; at coarser levels several surfaces, lit by one room's light alone) reads up to
/// `min(casting, A_l / face)` times its light there; [`cell_weight`] weighs each cell by the lights
/// that reach it instead.
pub fn area_weight(casting: usize) -> f32 {
    1.0 / casting.max(1) as f32
}

/// The most lights whose reach a cell's word 7 counts (a bit each).
pub const MASK_LIGHTS: usize = 32;

/// The grid of a frame of `lights` lights, `casting` of them casting light: per-cell weights
/// ([`cell_weight`]) where every light has its own bit in the cells' masks (at most
/// [`MASK_LIGHTS`]; a light's bit is its index's), else the one weight [`area_weight`] for every
/// cell.
pub fn weigh_lights(g: &mut LitGrid, casting: usize, lights: usize) {
    g.size[1] = weighs_per_cell(lights) as u32;
    g.scale[2] = area_weight(casting);
}

/// Whether a frame of `lights` lights weighs each cell by the lights reaching it: each light has a
/// bit of its own in the cells' masks.
pub fn weighs_per_cell(lights: usize) -> bool {
    lights <= MASK_LIGHTS
}

/// The area weight of a cell that the lights of bits `mask` reach (the kernel's `resolve`): `1 / k`
/// for the k lights that reached it where the grid weighs per cell (`size[1] = 1`), so a cell one
/// light reaches keeps its single-light light whatever else lights the scene; else `scale[2]`.
pub fn cell_weight(g: &LitGrid, mask: u32) -> f32 {
    if g.size[1] == 1 {
        1.0 / mask.count_ones().max(1) as f32
    } else {
        g.scale[2]
    }
}

/// `v` (in its unit) as 64-bit two's-complement fixed point with [`FRACTION_BITS`] fraction bits:
/// its magnitude clamped to [`MAX_PIECE`] (infinities too), the fraction rounded to the nearest
/// quantum (ties to even), in the kernel's operations (`floor`, an exact subtraction and scaling,
/// `round`); NaN 0 (an RSM texel whose radiance is NaN adds no light).
pub fn fixed(v: f32) -> i64 {
    let a = magnitude(v);
    let h = a.floor();
    let l = ((a - h) * 16_777_216.0).round_ties_even();
    let q = ((h as i64) << FRACTION_BITS) + l as i64;
    if v < 0.0 {
        -q
    } else {
        q
    }
}

/// The magnitude [`fixed`] holds of `v` (in its unit): NaN 0, at most [`MAX_PIECE`].
fn magnitude(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.abs().min(MAX_PIECE)
    }
}

/// A cell's sum in fixed point back to its float, in the kernel's operations: the magnitude's high
/// and low words each converted (rounded to nearest), the high scaled by 2^8 and the low by 2^-24,
/// added.
pub fn resolve(q: i64) -> f32 {
    let m = q.unsigned_abs();
    let f = (m >> 32) as u32 as f32 * 256.0 + (m as u32) as f32 * (1.0 / 16_777_216.0);
    if q < 0 {
        -f
    } else {
        f
    }
}

/// One light view's RSM as the kernel binds it (2D Morton order).
#[derive(Clone, Copy)]
pub struct RsmRef<'a> {
    pub side: u32,
    pub radiance: &'a [[f32; 4]],
    pub normal: &'a [[f32; 4]],
    pub depth: &'a [f32],
}

/// One piece of a texel's surface: where it lands (its candidate cells: the nominal first) and its
/// eight sums.
struct Piece {
    cells: Vec<u32>,
    sums: [f32; 8],
}

/// The texel's image quantities (the kernel's `texel_frame`), in its operation order.
struct TexelFrame {
    pt: Vec3,
    plane: f32,
    cosv: f32,
    /// Error of `pt` (world units).
    d_pt: f32,
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

fn dot(a: Vec3, b: Vec3) -> f32 {
    (a.x * b.x + a.y * b.y) + a.z * b.z
}

/// `rn`, `un`: right and up over their squared lengths (an image offset `a` moves a ray by `rn a`).
fn axes(v: &GpuView) -> (Vec3, Vec3, f32) {
    let (r, u) = (v3(v.right), v3(v.up));
    let (r2, u2) = (dot(r, r), dot(u, u));
    (r * (1.0 / r2), u * (1.0 / u2), (r2 * u2).sqrt())
}

/// Ray origin and direction through image point (a, b).
fn ray(v: &GpuView, rn: Vec3, un: Vec3, a: f32, b: f32) -> (Vec3, Vec3) {
    let (eye, f) = (v3(v.eye), v3(v.forward));
    if v.orthographic() {
        (eye + rn * a + un * b, f)
    } else {
        (eye, f + rn * a + un * b)
    }
}

fn texel_frame(v: &GpuView, rsm: RsmRef, m: usize) -> TexelFrame {
    let u = f32::EPSILON;
    let [tx, ty] = morton::decode2(m as u32);
    let texel = 2.0 / rsm.side as f32;
    let a = (tx as f32 + 0.5) * texel - 1.0;
    let b = 1.0 - (ty as f32 + 0.5) * texel;
    let z = rsm.depth[m] / v.forward[3] + v.eye[3];
    let (rn, un, rl_ul) = axes(v);
    let (o, dir) = ray(v, rn, un, a, b);
    let (plane, cosv) = if v.orthographic() {
        ((texel * texel) / rl_ul, 1.0)
    } else {
        (
            ((texel * texel) * (z * z)) / rl_ul,
            1.0 / dot(dir, dir).sqrt(),
        )
    };
    let pt = o + dir * z;
    let d_pt = 16.0 * u * (o.abs().max_element() + dir.abs().max_element() * z.abs());
    TexelFrame {
        pt,
        plane,
        cosv,
        d_pt,
    }
}

/// The cells a point within `dp` (world units) of `p` may land in (clamped into the grid as
/// voxelize clamps): the nominal cell first.
fn candidate_cells(g: &LitGrid, p: Vec3, dp: f32) -> Vec<u32> {
    let u = f32::EPSILON;
    let s0 = g.origin[3];
    let inv = 1.0 / s0;
    let last = (g.size[0] - 1) as f32;
    let q = (p - v3(g.origin)) * inv;
    let dq = dp * inv + 8.0 * u * (q.abs().max_element() + 1.0);
    let cell = |q: f32| q.floor().clamp(0.0, last) as u32;
    let per_axis: Vec<Vec<u32>> = (0..3)
        .map(|k| {
            let mut c = vec![cell(q[k])];
            for e in [q[k] - dq, q[k] + dq] {
                let o = cell(e);
                if !c.contains(&o) {
                    c.push(o);
                }
            }
            c
        })
        .collect();
    let mut out = Vec::new();
    for &x in &per_axis[0] {
        for &y in &per_axis[1] {
            for &z in &per_axis[2] {
                out.push(morton::encode(x, y, z));
            }
        }
    }
    out
}

/// The sub-ray count across texel `m` by the kernel's rule, and the other count its rounding may
/// give (None when it cannot differ).
fn spread(plane: f32, ndl: f32, s0: f32) -> (u32, Option<u32>) {
    let kf = 2.0 * plane.sqrt() / ndl / s0;
    let k = |kf: f32| kf.ceil().clamp(1.0, MAX_SPREAD as f32) as u32;
    let e = 32.0 * f32::EPSILON * kf.abs();
    let (lo, hi) = (k(kf - e), k(kf + e));
    let nominal = k(kf);
    let other = [lo, hi].into_iter().find(|&o| o != nominal);
    (nominal, other)
}

/// Texel `m`'s pieces with `k` sub-rays per axis.
fn pieces(g: &LitGrid, v: &GpuView, rsm: RsmRef, m: usize, k: u32) -> Vec<Piece> {
    let u = f32::EPSILON;
    let rr = rsm.radiance[m];
    let nrm = rsm.normal[m];
    let n = v3(nrm);
    let ndl = nrm[3].max(MIN_NDOTL);
    let t = texel_frame(v, rsm, m);
    let s0 = g.origin[3];
    let surface = t.plane * t.cosv / ndl;
    let part = surface / (k * k) as f32 * (1.0 / (s0 * s0));
    let inv_q = g.scale[0];
    let sums = [
        (rr[0] * inv_q) * part,
        (rr[1] * inv_q) * part,
        (rr[2] * inv_q) * part,
        part,
        n.x * part,
        n.y * part,
        n.z * part,
        0.0,
    ];
    let texel = 2.0 / rsm.side as f32;
    let [tx, ty] = morton::decode2(m as u32);
    let a = (tx as f32 + 0.5) * texel - 1.0;
    let b = 1.0 - (ty as f32 + 0.5) * texel;
    let (rn, un, _) = axes(v);
    let z = rsm.depth[m] / v.forward[3] + v.eye[3];
    let mut out = Vec::new();
    for j in 0..k {
        for i in 0..k {
            if k == 1 {
                out.push(Piece {
                    cells: candidate_cells(g, t.pt, t.d_pt),
                    sums,
                });
                continue;
            }
            let kf = k as f32;
            let sa = a + ((i as f32 + 0.5) / kf - 0.5) * texel;
            let sb = b - ((j as f32 + 0.5) / kf - 0.5) * texel;
            let (o2, d2) = ray(v, rn, un, sa, sb);
            let den = dot(n, d2);
            let d_den = 8.0 * u * d2.abs().max_element();
            let at_depth = o2 + d2 * z;
            let d_depth =
                t.d_pt + 8.0 * u * (o2.abs().max_element() + d2.abs().max_element() * z.abs());
            let on_plane = |den: f32| {
                let tt = dot(n, t.pt - o2) / den;
                let p = o2 + d2 * tt;
                let rel = d2.abs().max_element() / den.abs();
                let dp = rel
                    * (t.d_pt + 8.0 * u * (t.pt.abs().max_element() + o2.abs().max_element()))
                    + 16.0
                        * u
                        * (o2.abs().max_element() + d2.abs().max_element() * tt.abs())
                        * (1.0 + rel * d2.abs().max_element());
                (p, dp)
            };
            let mut cells;
            if den.abs() > PARALLEL {
                let (p, dp) = on_plane(den);
                cells = candidate_cells(g, p, dp);
            } else {
                cells = candidate_cells(g, at_depth, d_depth);
            }
            // The plane test within its error of its threshold: either point.
            if (den.abs() - PARALLEL).abs() <= d_den {
                let alt = if den.abs() > PARALLEL {
                    candidate_cells(g, at_depth, d_depth)
                } else {
                    let den2 = if den >= 0.0 {
                        PARALLEL * 2.0
                    } else {
                        -PARALLEL * 2.0
                    };
                    let (p, dp) = on_plane(den2);
                    // The GPU's den may be just past the threshold: its point is anywhere along the
                    // sub-ray past the plane's reach; every cell is possible.
                    let _ = (p, dp);
                    (0..g.size[0].pow(3)).collect()
                };
                for c in alt {
                    if !cells.contains(&c) {
                        cells.push(c);
                    }
                }
            }
            out.push(Piece { cells, sums });
        }
    }
    out
}

/// Level 0 of the lit cells (8 floats a cell, `side^3` cells in Morton order) from every light
/// view's RSM (`views[i]` with `rsms[i]`): each piece's values in fixed point, summed exactly per
/// cell, resolved to floats; and the per-float bound (see the module doc).
pub fn inject(g: &LitGrid, views: &[GpuView], rsms: &[RsmRef]) -> (Vec<f32>, Vec<f32>) {
    let u = f32::EPSILON;
    let cells = (g.size[0] as usize).pow(3);
    let mut acc = vec![0i64; cells * 8];
    let mut mag = vec![0.0f32; cells * 8];
    let mut count = vec![0u32; cells];
    let mut loose = vec![0.0f32; cells * 8];
    // The lights reaching each cell (bit: light index mod 32): by the nominal pieces, by pieces that
    // can land nowhere else, and by any piece that may land there.
    let (mut lights, mut sure, mut maybe) =
        (vec![0u32; cells], vec![0u32; cells], vec![0u32; cells]);
    for (v, rsm) in views.iter().zip(rsms) {
        let bit = 1u32 << (v.info[1] & 31);
        for m in 0..(rsm.side as usize).pow(2) {
            // Unlit texels (and NaN flags) are skipped, as the WGSL's negated test skips them.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            if !(rsm.radiance[m][3] > 0.5) {
                continue;
            }
            let t = texel_frame(v, *rsm, m);
            let ndl = rsm.normal[m][3].max(MIN_NDOTL);
            let (k, other) = spread(t.plane, ndl, g.origin[3]);
            for p in pieces(g, v, *rsm, m, k) {
                let c = p.cells[0] as usize;
                count[c] += 1;
                lights[c] |= bit;
                // Sure where the GPU takes the same sub-ray count and the piece one cell.
                if p.cells.len() == 1 && other.is_none() {
                    sure[c] |= bit;
                }
                for &o in &p.cells {
                    maybe[o as usize] |= bit;
                }
                for f in 0..8 {
                    acc[c * 8 + f] = acc[c * 8 + f].wrapping_add(fixed(p.sums[f]));
                    mag[c * 8 + f] += magnitude(p.sums[f]);
                }
                if p.cells.len() > 1 {
                    for &o in &p.cells {
                        for f in 0..8 {
                            loose[o as usize * 8 + f] += magnitude(p.sums[f]);
                        }
                    }
                }
            }
            if let Some(k2) = other {
                // The other count's pieces may land anywhere its sub-rays do; the nominal ones may
                // be missing: both in full.
                for p in pieces(g, v, *rsm, m, k)
                    .into_iter()
                    .chain(pieces(g, v, *rsm, m, k2))
                {
                    for &o in &p.cells {
                        maybe[o as usize] |= bit;
                        for f in 0..8 {
                            loose[o as usize * 8 + f] += magnitude(p.sums[f]);
                        }
                    }
                }
            }
        }
    }
    let quantum = 1.0 / 16_777_216.0f32;
    let mut sums = vec![0.0f32; cells * 8];
    let mut bound = vec![0.0f32; cells * 8];
    let weight = |mask: u32| cell_weight(g, mask);
    for i in 0..cells * 8 {
        if i % 8 == 7 {
            continue;
        }
        let c = i / 8;
        // The radiance's unit is Q (exact: a power of two), the others' a level-0 face times the
        // area weight: the resolve's two roundings, the weight's (1 / k: 2.5 ULP, WGSL's division)
        // and its product, 6 ULP. Where a piece that may land elsewhere decides whether a light
        // reaches the cell, the weight is any between the fewest lights and the most: all of it.
        let raw = resolve(acc[i]);
        let (unit, spread) = if i % 8 < 3 {
            (g.scale[1], 0.0)
        } else {
            let (most, fewest) = (weight(sure[c]), weight(maybe[c] | lights[c]));
            (weight(lights[c]), raw.abs() * (most - fewest))
        };
        let top = if i % 8 < 3 { unit } else { weight(sure[c]) };
        sums[i] = raw * unit;
        bound[i] = (mag[i] * 64.0 * u + count[c] as f32 * quantum + loose[i]) * top
            + 6.0 * u * sums[i].abs()
            + spread;
    }
    (sums, bound)
}

/// Level `l + 1` from level `l` (`child`: 8 floats a cell, Morton order): each float the sum of the
/// 8 children's, in child order; and its bound from the children's.
pub fn reduce(child: &[f32], child_bound: &[f32]) -> (Vec<f32>, Vec<f32>) {
    let cells = child.len() / 64;
    let mut out = vec![0.0f32; cells * 8];
    let mut bound = vec![0.0f32; cells * 8];
    for c in 0..cells {
        for f in 0..8 {
            let (mut s, mut m, mut b) = (0.0f32, 0.0f32, 0.0f32);
            for k in 0..8 {
                let i = (8 * c + k) * 8 + f;
                s += child[i];
                m += child[i].abs();
                b += child_bound[i];
            }
            out[c * 8 + f] = s;
            bound[c * 8 + f] = b + 8.0 * f32::EPSILON * m;
        }
    }
    (out, bound)
}

/// Every level (level 0 first) and their bounds.
pub fn pyramid(g: &LitGrid, views: &[GpuView], rsms: &[RsmRef]) -> (Vec<Vec<f32>>, Vec<Vec<f32>>) {
    let (l0, b0) = inject(g, views, rsms);
    let (mut levels, mut bounds) = (vec![l0], vec![b0]);
    while levels.last().unwrap().len() > 8 {
        let (l, b) = reduce(levels.last().unwrap(), bounds.last().unwrap());
        levels.push(l);
        bounds.push(b);
    }
    (levels, bounds)
}

/// What the gather reads of one cell at level `l` for cone direction `d` (the view sample's
/// direction vc = -d): its mean radiance times its coverage `min(1, area / face)` (`face` = 4^l
/// level-0 faces), times the cull by its mean normal `clamp(<sum a n, vc> / sum a / CULL_RAMP, 0,
/// 1)`; zero where no surface is. `c`: the cell's 8 floats. In the kernel's operation order.
pub fn cell_light(c: &[f32], l: u32, vc: Vec3) -> Vec4 {
    let area = c[3];
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(area > 0.0) {
        return Vec4::ZERO;
    }
    let inv = 1.0 / area;
    let cov = (area * crossing(c) * (1.0 / (1u32 << (2 * l)) as f32)).min(1.0);
    let nw = ((c[4] * vc.x + c[5] * vc.y + c[6] * vc.z) * inv * (1.0 / CULL_RAMP)).clamp(0.0, 1.0);
    let w = (inv * cov) * nw;
    Vec4::new(c[0] * w, c[1] * w, c[2] * w, 0.0)
}

/// How many cells a surface with the cell's mean normal `N` (its area-weighted normal sum, `c[4..7]`)
/// crosses per unit of its area, relative to an axis-aligned surface: `|N|_1 / |N|`, 1 for an
/// axis-aligned wall, sqrt(2) at 45 degrees about an axis, sqrt(3) along a diagonal (1 where the
/// normals cancel to 0). A plane crossing cells of side `h` holds `h^2 / |n|_1` of itself in a crossed
/// cell on average; the occlusion voxels mark every crossed cell, so a cell's coverage is its area
/// times this over its face. Without it a wall turned 45 degrees about an axis read 1 / sqrt(2) of
/// its light (docs/accuracy/orientation.md).
pub fn crossing(c: &[f32]) -> f32 {
    let m = Vec3::new(c[4], c[5], c[6]);
    let ml = m.length();
    if ml > 0.0 {
        ((m.x.abs() + m.y.abs()) + m.z.abs()) / ml
    } else {
        1.0
    }
}

/// Bound on [`cell_light`]'s rgb (largest channel) from its arithmetic (16 ULP, and 16 more for
/// [`crossing`]'s sum, length and division) and the direction's error (vc a few ULP off: N's ramp
/// moves by 1e-4 of the unculled light at most). Where the normal sum nearly cancels (its length
/// below 1e-6 of the area, whose fixed-point sums round each component by up to 2^-24 faces and
/// so turn its direction anywhere) or is small enough for a GPU to flush its squares to 0 (below
/// 1e-18), the crossing factor may be anything from 1 to sqrt(3): the bound is the light at
/// sqrt(3).
pub fn cell_light_bound(c: &[f32], l: u32) -> f32 {
    let area = c[3];
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(area > 0.0) {
        return 0.0;
    }
    let face = (1u32 << (2 * l)) as f32;
    let peak = c[0].abs().max(c[1].abs()).max(c[2].abs()) / area;
    let ml = Vec3::new(c[4], c[5], c[6]).length();
    if ml <= 1e-6 * area || ml < 1e-18 {
        return peak * (area * 3f32.sqrt() / face).min(1.0) * (1.0 + 1e-4);
    }
    let cov = (area * crossing(c) / face).min(1.0);
    peak * cov * (32.0 * f32::EPSILON + 1e-4)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An 8^3 grid of cells of 0.25 over [0, 2]^3, and an orthographic 16^2 view of it over x, z in
    /// [0, 2], looking down -y from y = 3 (near 0, far 4): an RSM depth of 0.75 is the floor y = 0.
    fn floor_grid_and_view() -> (LitGrid, GpuView) {
        let g = LitGrid {
            origin: [0.0, 0.0, 0.0, 0.25],
            size: [8, 0, 0, 0],
            scale: radiance_unit(1.0),
        };
        let v = GpuView {
            eye: [1.0, 3.0, 1.0, 0.0],
            forward: [0.0, -1.0, 0.0, 0.25],
            right: [1.0, 0.0, 0.0, 4.0],
            up: [0.0, 0.0, -1.0, 0.0],
            info: [16, 0, 0, 1],
        };
        (g, v)
    }

    /// A cell's coverage is its area times how many cells its surface crosses per unit of area: a
    /// wall turned 45 degrees about an axis, which holds 1 / sqrt(2) of a face in a crossed cell on
    /// average, covers it as an axis-aligned wall filling its face does; an axis-aligned half face
    /// covers half. The light is the mean radiance times that coverage.
    #[test]
    fn a_tilted_wall_covers_the_cells_it_crosses() {
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let cell = |area: f32, n: [f32; 3]| {
            [
                0.5 * area,
                0.5 * area,
                0.5 * area,
                area,
                n[0] * area,
                n[1] * area,
                n[2] * area,
            ]
        };
        let up = Vec3::Y;
        let tilted = cell(h, [h, 0.0, h]);
        assert!((crossing(&tilted) - 2f32.sqrt()).abs() < 1e-6);
        let lit = cell_light(&tilted, 0, Vec3::new(h, 0.0, h));
        assert!((lit.x - 0.5).abs() < 1e-5, "{lit}");
        assert_eq!(cell_light(&cell(0.5, [0.0, 1.0, 0.0]), 0, up).x, 0.25);
        assert_eq!(cell_light(&cell(1.0, [0.0, 1.0, 0.0]), 0, up).x, 0.5);
        // Normals that cancel: read as an axis-aligned surface's area.
        assert_eq!(crossing(&cell(1.0, [0.0, 0.0, 0.0])), 1.0);
    }

    /// One orthographic view straight down onto a floor at y = 0, every texel lit: the floor's
    /// whole lit surface lands in the cells the floor lies in, each with its area over s0^2.
    #[test]
    fn a_floor_seen_from_above_fills_its_cells_with_its_area() {
        let (g, v) = floor_grid_and_view();
        let n = 16usize * 16;
        let radiance = vec![[0.5, 0.25, 1.0, 1.0]; n];
        let normal = vec![[0.0, 1.0, 0.0, 1.0]; n];
        let depth = vec![0.75; n]; // axis depth 3: y = 0
        let rsm = RsmRef {
            side: 16,
            radiance: &radiance,
            normal: &normal,
            depth: &depth,
        };
        let (levels, _) = pyramid(&g, &[v], &[rsm]);
        // The floor's 2 x 2 area is 64 level-0 faces of 0.25^2, spread over the 8 x 8 bottom cells.
        let top = levels.last().unwrap();
        assert!((top[3] - 64.0).abs() < 1e-3, "{}", top[3]);
        assert!((top[0] - 32.0).abs() < 1e-3 && (top[5] - 64.0).abs() < 1e-3);
        let floor_cell = morton::encode(3, 0, 5) as usize;
        assert!((levels[0][floor_cell * 8 + 3] - 1.0).abs() < 1e-5);
        let above = morton::encode(3, 1, 5) as usize;
        assert_eq!(levels[0][above * 8 + 3], 0.0);
        // Read from above: its mean radiance, fully covered; from below: culled.
        let lit = cell_light(&levels[0][floor_cell * 8..floor_cell * 8 + 8], 0, Vec3::Y);
        assert!(
            (lit - Vec4::new(0.5, 0.25, 1.0, 0.0)).length() < 1e-5,
            "{lit}"
        );
        let back = cell_light(&levels[0][floor_cell * 8..floor_cell * 8 + 8], 0, -Vec3::Y);
        assert_eq!(back, Vec4::ZERO);
    }

    /// Two lights lighting one floor: with the area weight 1/2 (the grid's, or each cell's from the
    /// two lights reaching it) the cells give the sum of their radiances, as one light of that
    /// radiance does; with weight 1, their mean. Weighed per cell, the cells the second light does
    /// not reach (its RSM's left half unlit) keep the first light's alone.
    #[test]
    fn two_lights_on_one_surface_add_their_light_with_the_area_weight() {
        let (grid, va) = floor_grid_and_view();
        let mut vb = va;
        vb.info[1] = 1;
        let n = 16usize * 16;
        let normal = vec![[0.0, 1.0, 0.0, 1.0]; n];
        let depth = vec![0.75; n];
        let ra = vec![[0.5, 0.25, 1.0, 1.0]; n];
        // Light b lights the texels with x >= 8 (2D Morton order: bit 0 of x is bit 0 of m).
        let rb: Vec<[f32; 4]> = (0..n as u32)
            .map(|m| {
                let lit = morton::decode2(m)[0] >= 8;
                [0.25, 0.75, 0.0, if lit { 1.0 } else { 0.0 }]
            })
            .collect();
        let rsm = |radiance| RsmRef {
            side: 16,
            radiance,
            normal: &normal,
            depth: &depth,
        };
        // A cell both lights reach (x >= 1 in world units), one that light a alone reaches.
        let (both, one) = (
            morton::encode(5, 0, 5) as usize * 8,
            morton::encode(2, 0, 5) as usize * 8,
        );
        let light = |g: LitGrid, vb: GpuView| {
            let (levels, _) = pyramid(&g, &[va, vb], &[rsm(&ra), rsm(&rb)]);
            let at = |c: usize| cell_light(&levels[0][c..c + 8], 0, Vec3::Y);
            (at(both), at(one))
        };
        let (a, sum) = (
            Vec4::new(0.5, 0.25, 1.0, 0.0),
            Vec4::new(0.75, 1.0, 1.0, 0.0),
        );
        let mut per_cell = grid;
        weigh_lights(&mut per_cell, 2, 2);
        let (b2, b1) = light(per_cell, vb);
        assert!(
            (b2 - sum).length() < 1e-5 && (b1 - a).length() < 1e-5,
            "{b2} {b1}"
        );
        let mut global = grid;
        weigh_lights(&mut global, 2, 40);
        let (g2, _) = light(global, vb);
        assert!((g2 - sum).length() < 1e-5, "{g2}");
        // Both views counted as one light: weight 1, the two lights' mean where both reach.
        let (mean, _) = light(per_cell, va);
        assert!(
            (mean - (a + Vec4::new(0.25, 0.75, 0.0, 0.0)) * 0.5).length() < 1e-5,
            "{mean}"
        );
    }

    /// Fixed point holds a value to its quantum (2^-24 of its unit), either sign, up to the clamp;
    /// a sum of pieces of both signs, carried across the low word, resolves to the exact sum's float.
    #[test]
    fn fixed_point_round_trips_and_sums_exactly() {
        for v in [
            0.0f32, 1e-12, 0.3, -0.3, 1.0, -1.0, 12345.678, -7.5e6, 3e9, -3e9,
        ] {
            let back = resolve(fixed(v));
            let want = v.clamp(-MAX_PIECE, MAX_PIECE);
            assert!(
                (back - want).abs() <= 2f32.powi(-25) + want.abs() * 2.0 * f32::EPSILON,
                "{v}: {back}"
            );
        }
        // 200 + 100 passes 256 units (2^32 quanta): the low word wraps and carries into the high
        // word; -299.75 borrows back; 1e-6 is 17 quanta.
        let sum = [200.0f32, 100.0, -299.75, 1e-6]
            .iter()
            .fold(0i64, |a, &v| a.wrapping_add(fixed(v)));
        assert_eq!(sum, (1i64 << 22) + 17);
        assert_eq!(resolve(sum), 4_194_321.0 / 16_777_216.0);
        assert_eq!(resolve(-sum), -resolve(sum));
        assert_eq!(fixed(f32::NAN), 0);
        assert_eq!(fixed(f32::INFINITY), fixed(MAX_PIECE));
        assert_eq!(fixed(f32::NEG_INFINITY), -fixed(MAX_PIECE));
        assert_eq!(radiance_unit(3.0), [0.25, 4.0, 1.0, 0.0]);
        assert_eq!(radiance_unit(4.0), [0.25, 4.0, 1.0, 0.0]);
        assert_eq!(radiance_unit(f32::NAN), [1.0, 1.0, 1.0, 0.0]);
    }
}
