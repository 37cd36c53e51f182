//! Mirror of `kernels/sample_lrsm.wgsl`: Algorithm 1 of Sugihara et al. 2014 — the outgoing radiance L
//! of a batch of cone samples, summed over the LRSM layers whose depth range contains the sample.
//!
//! Per sample: `pos = (u, v, mip, zc)` (RSM coordinates in [0, 1], mip level, light-space depth of the
//! cone centre), `dir = (vc, rc)` (unit direction to the view sample, cone radius in depth units).
//! Texel: level `min(trunc(max(mip, 0)), levels - 1)`, nearest texel of (u, v) there (clamped), in
//! every layer. For each layer (d, j) with `zmin_d <= zc <= zmax_d`: `N = <n / A_n, vc>` (normal
//! normalised by its opacity, eq. 8); if `N > 0`: `V` of eq. 12 on the moments with zc and rc warped
//! into the layer; if `V > 0`: `L += f(zc) * r * V * N` (eq. 14; r is the opacity-weighted radiance, f
//! eq. 15). Output `(L, layers whose range contains zc)`.
use crate::gaussian_depth_visibility::{visibility, visibility_bound, VisibilityParams};
use crate::layer_decay::layer_decay;
use crate::{ftz, morton};

/// The kernel's uniform block (`struct SampleParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SampleParams {
    pub depth_slices: u32,
    pub normal_slices: u32,
    pub levels: u32,
    /// Side of LRSM level 0 (a power of two).
    pub side0: u32,
    pub cdf: u32,
    pub min_variance: f32,
    pub min_alpha: f32,
    /// Overlap delta of eq. 15.
    pub overlap: f32,
}

/// The LRSM as the kernel binds it: every level of every layer, levels concatenated.
pub struct Lrsm<'a> {
    pub depth_ranges: &'a [[f32; 4]],
    pub radiance: &'a [[f32; 4]],
    pub normal: &'a [[f32; 4]],
    pub moments: &'a [[f32; 4]],
}

/// Index of (level, layer, texel of (u, v)) in the concatenated streams.
pub fn texel_index(p: &SampleParams, u: f32, v: f32, mip: f32, layer: u32) -> usize {
    let layers = p.depth_slices * p.normal_slices;
    let level = (mip.max(0.0) as u32).min(p.levels - 1);
    let mut base = 0u32;
    for k in 0..level {
        base += layers * (p.side0 >> k) * (p.side0 >> k);
    }
    let s = p.side0 >> level;
    let x = ((u.max(0.0) * s as f32) as u32).min(s - 1);
    let y = ((v.max(0.0) * s as f32) as u32).min(s - 1);
    (base + layer * s * s + morton::encode2(x, y)) as usize
}

fn vis_params(p: &SampleParams) -> VisibilityParams {
    VisibilityParams {
        cdf: p.cdf,
        min_variance: p.min_variance,
        min_alpha: p.min_alpha,
        _pad: 0,
    }
}

/// L for one cone sample, in the kernel's operation order (negated comparisons as in the WGSL, so NaN
/// takes the skip branch).
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn sample(
    lrsm: &Lrsm,
    p: &SampleParams,
    pos: [f32; 4],
    dir: [f32; 4],
    flush: bool,
) -> [f32; 4] {
    let f = |x: f32| ftz(x, flush);
    let [u, v, mip, zc] = pos.map(f);
    let [vx, vy, vz, rc] = dir.map(f);
    let mut l = [0.0f32; 3];
    let mut count = 0.0f32;
    for d in 0..p.depth_slices {
        let range = lrsm.depth_ranges[d as usize].map(f);
        if !(zc >= range[0] && zc <= range[1]) {
            continue;
        }
        for j in 0..p.normal_slices {
            count += 1.0;
            let t = texel_index(p, u, v, mip, d * p.normal_slices + j);
            let nm = lrsm.normal[t].map(f);
            if !(nm[3] > f(p.min_alpha)) {
                continue;
            }
            let n = [f(nm[0] / nm[3]), f(nm[1] / nm[3]), f(nm[2] / nm[3])];
            let big_n = f(f(f(n[0] * vx) + f(n[1] * vy)) + f(n[2] * vz));
            if !(big_n > 0.0) {
                continue;
            }
            let zw = f(f(zc - range[0]) * range[2]);
            let rw = f(rc * range[2]);
            let vis = visibility(lrsm.moments[t], zw, rw, &vis_params(p), flush);
            if !(vis > 0.0) {
                continue;
            }
            let decay = layer_decay(zc, range[0], range[1], f(p.overlap), flush);
            let r = lrsm.radiance[t].map(f);
            let w = f(f(decay * vis) * big_n);
            for c in 0..3 {
                l[c] = f(l[c] + f(r[c] * w));
            }
        }
    }
    [l[0], l[1], l[2], count]
}

/// Per-component bound on |GPU - mirror| for [`sample`], from the WGSL accuracy rules (u = 2^-24):
/// the normal's divisions (2.5 ULP each) and the dot product (any order, fused or not: 3 ULP of the sum
/// of |terms|) bound |dN|; `V`'s own bound; `f` within 8 ULP; the products `f V N r` 3 roundings; the
/// sum over layers 1 rounding per add. A branch taken differently (N or V near 0) changes the sum by
/// at most the term with N or V at its bound, which the same expression covers. Doubled; the `w`
/// component (a count) is exact.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn sample_bound(lrsm: &Lrsm, p: &SampleParams, pos: [f32; 4], dir: [f32; 4]) -> [f32; 4] {
    let u = f64::from(f32::EPSILON) / 2.0;
    let [su, sv, mip, zc] = pos;
    let [vx, vy, vz, rc] = dir;
    let mut bound = [0.0f64; 3];
    let mut total = [0.0f64; 3];
    for d in 0..p.depth_slices {
        let range = lrsm.depth_ranges[d as usize];
        if !(zc >= range[0] && zc <= range[1]) {
            continue;
        }
        for j in 0..p.normal_slices {
            let t = texel_index(p, su, sv, mip, d * p.normal_slices + j);
            let nm = lrsm.normal[t].map(f64::from);
            if !(nm[3] > p.min_alpha as f64) {
                continue;
            }
            let n = [nm[0] / nm[3], nm[1] / nm[3], nm[2] / nm[3]];
            let terms = [n[0] * vx as f64, n[1] * vy as f64, n[2] * vz as f64];
            let big_n = terms.iter().sum::<f64>();
            let abs_terms: f64 = terms.iter().map(|x| x.abs()).sum();
            let d_n = (2.5 + 3.0) * u * abs_terms + 2.0 * u * big_n.abs();
            if big_n + d_n <= 0.0 {
                continue; // N <= 0 on every conforming GPU: no contribution anywhere
            }
            let zw = ((zc - range[0]) * range[2]) as f64;
            let rw = (rc * range[2]) as f64;
            // zw and rw round (0.5 ULP each): shifts of the window edges by that much move V by at most
            // phi_max * shift / sigma_min; fold them into V's bound.
            let sigma_min = (p.min_variance as f64).sqrt();
            let d_window = (zw.abs() + rw.abs()) * 1.5 * u / sigma_min;
            let vis =
                visibility(lrsm.moments[t], zw as f32, rw as f32, &vis_params(p), false) as f64;
            let d_vis = visibility_bound(lrsm.moments[t], zw as f32, rw as f32, &vis_params(p))
                as f64
                + d_window;
            let decay = layer_decay(zc, range[0], range[1], p.overlap, false) as f64;
            let d_decay = 8.0 * u * decay;
            let (bn, bv) = (big_n.max(0.0) + d_n, vis + d_vis);
            let dw =
                d_decay * bv * bn + (decay + d_decay) * d_vis * bn + (decay + d_decay) * bv * d_n;
            let w = decay * vis * big_n.max(0.0);
            for c in 0..3 {
                let r = (lrsm.radiance[t][c] as f64).abs();
                bound[c] += r * dw + 4.0 * u * r * w;
                total[c] += r * (w + dw);
            }
        }
    }
    [0, 1, 2]
        .map(|c| {
            (2.0 * (bound[c] + 4.0 * u * total[c] * p.depth_slices as f64 * p.normal_slices as f64))
                as f32
        })
        .into_iter()
        .chain([0.0])
        .collect::<Vec<_>>()
        .try_into()
        .expect("4 components")
}
