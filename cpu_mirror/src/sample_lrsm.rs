//! Mirror of `kernels/sample_lrsm.wgsl`: Algorithm 1 of Sugihara et al. 2014 — the outgoing radiance L
//! of a batch of cone samples, summed over the LRSM layers whose depth range contains the sample.
//!
//! Per sample: `pos = (u, v, mip, zc)` (RSM coordinates in [0, 1], mip level, light-space depth of the
//! cone centre), `dir = (vc, rc)` (unit direction to the view sample, cone radius in depth units).
//! Fetch: trilinear ([`taps`], [`fetch`]: the paper's filtered reads at a continuous mip level), the
//! same taps in every layer. For each layer (d, j) with `zmin_d <= zc <= zmax_d`, on the filtered
//! attributes: `N = <n / A_n, vc>` (normal normalised by its opacity, eq. 8); if `N > 0`: `V` of eq.
//! 12 on the moments with zc and rc warped into the layer; if `V > 0`: `L += f(zc) * r * V * N` (eq.
//! 14; r is the opacity-weighted radiance, f eq. 15). Output `(L, layers whose range contains zc)`.
use crate::gaussian_depth_visibility::{visibility, visibility_bound_inexact, VisibilityParams};
use crate::layer_decay::layer_decay;
use crate::{ftz, morton};

/// With N as a cull, the width of its ramp from 0 to 1 (`LRSM_CULL_RAMP`, see the WGSL): the factor
/// is `min(N / CULL_RAMP, 1)` where N > 0.
pub const CULL_RAMP: f32 = 0.03125;

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
    /// 1: N = <n, vc> weighs each layer's radiance (Algorithm 1 as written); 0: N only culls back
    /// faces (see kernels/common/lrsm_sample.wgsl).
    pub view_weight: u32,
    /// 1: the LRSMs are area-weighted (lrsm_partition's `area_weights`) and the gather reads eq. 1's
    /// premultiplied product: a sample's L is the colour the march adds (not alpha L), fetched one
    /// level finer than log2 of the disc's diameter in texels (the trilinear taps then span about
    /// the disc). Sample LRSM itself does not read it.
    pub area: u32,
    /// 1: lrsm_cone_trace reads each sample's light from the lit cells (lit_cells.wgsl), premultiplied,
    /// and no LRSM. Sample LRSM itself does not read it.
    pub lit_cells: u32,
    /// With `lit_cells`: the occlusion level the lit cells' finest level stands at (0 where the
    /// table is as fine as the voxels; lit_cells.rs caps its side). Samples finer than it read it.
    pub lit_base: u32,
}

/// The LRSM as the kernel binds it: every level of every layer, levels concatenated.
pub struct Lrsm<'a> {
    pub depth_ranges: &'a [[f32; 4]],
    pub radiance: &'a [[f32; 4]],
    pub normal: &'a [[f32; 4]],
    pub moments: &'a [[f32; 4]],
}

/// The 8 taps of a trilinear fetch at `(u, v, mip)` (the kernel's `lrsm_taps`): levels `l0 =
/// min(trunc(max(mip, 0)), levels - 1)` and `min(l0 + 1, levels - 1)` weighted `1 - f` and `f`, `f` the
/// fraction of `max(mip, 0)` above `l0` (0 at the last level); in each level the 2 x 2 texels around
/// `(u s - 1/2, v s - 1/2)`, clamped to the edge, weighted bilinearly. Tap `i`'s texel in layer `L` is
/// `base[i / 4] + L * area[i / 4] + texel[i]`. The weights are exact products of correctly rounded
/// differences (`m - l0` and `u s - 1/2` are exact where they matter), so GPU and mirror weigh alike.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Taps {
    pub base: [u32; 2],
    pub area: [u32; 2],
    pub texel: [u32; 8],
    pub weight: [f32; 8],
}

impl Taps {
    /// Index of tap `i` of layer `layer` in the concatenated streams.
    pub fn index(&self, i: usize, layer: u32) -> usize {
        (self.base[i / 4] + layer * self.area[i / 4] + self.texel[i]) as usize
    }
}

/// The taps of `(u, v, mip)` (see [`Taps`]), in the kernel's operation order.
pub fn taps(p: &SampleParams, u: f32, v: f32, mip: f32) -> Taps {
    let layers = p.depth_slices * p.normal_slices;
    let top = p.levels - 1;
    let m = mip.max(0.0).min(top as f32);
    let l0 = m as u32;
    let l1 = (l0 + 1).min(top);
    let fl = if l0 < top { m - l0 as f32 } else { 0.0 };
    let mut base = 0u32;
    for k in 0..l0 {
        base += layers * (p.side0 >> k) * (p.side0 >> k);
    }
    let mut t = Taps {
        base: [base; 2],
        area: [0; 2],
        texel: [0; 8],
        weight: [0.0; 8],
    };
    for j in 0..2 {
        let k = if j == 1 { l1 } else { l0 };
        let s = p.side0 >> k;
        if j == 1 && l1 > l0 {
            t.base[1] = base + layers * (p.side0 >> l0) * (p.side0 >> l0);
        }
        t.area[j] = s * s;
        let x = (u * s as f32 - 0.5).clamp(-1.0, s as f32);
        let y = (v * s as f32 - 0.5).clamp(-1.0, s as f32);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let wl = if j == 1 { fl } else { 1.0 - fl };
        for c in 0..4u32 {
            let (cx, cy) = (c & 1, c >> 1);
            let ix = (x0 as i32 + cx as i32).clamp(0, s as i32 - 1) as u32;
            let iy = (y0 as i32 + cy as i32).clamp(0, s as i32 - 1) as u32;
            let wx = if cx == 1 { fx } else { 1.0 - fx };
            let wy = if cy == 1 { fy } else { 1.0 - fy };
            t.texel[4 * j + c as usize] = morton::encode2(ix, iy);
            t.weight[4 * j + c as usize] = wl * (wy * wx);
        }
    }
    t
}

/// The filtered value of `stream` at `taps` in `layer`: `sum w_i t_i` in tap order, taps of weight 0
/// not read (as the kernel: an unread texel cannot turn the sum into NaN).
pub fn fetch(stream: &[[f32; 4]], taps: &Taps, layer: u32, flush: bool) -> [f32; 4] {
    let f = |x: f32| ftz(x, flush);
    let mut acc = [0.0f32; 4];
    for i in 0..8 {
        let w = taps.weight[i];
        if w == 0.0 {
            continue;
        }
        let t = stream[taps.index(i, layer)];
        for c in 0..4 {
            acc[c] = f(acc[c] + f(f(t[c]) * w));
        }
    }
    acc
}

/// How far a conforming GPU's [`fetch`] may be from the mirror's, per component: the weights are the
/// same bits on both (exact products), and the 8-term sum rounds each product and add, or fuses them
/// (FMA contraction is allowed): within 2 roundings per term of the running sum, which is below the sum
/// of |w_i t_i|, so 16 u of it; plus 16 flushed subnormals (a product or a partial sum each).
pub fn fetch_error(stream: &[[f32; 4]], taps: &Taps, layer: u32) -> [f64; 4] {
    let u = f64::from(f32::EPSILON) / 2.0;
    let mut abs = [0.0f64; 4];
    for i in 0..8 {
        let w = taps.weight[i] as f64;
        if w == 0.0 {
            continue;
        }
        let t = stream[taps.index(i, layer)];
        for c in 0..4 {
            abs[c] += (t[c] as f64 * w).abs();
        }
    }
    abs.map(|a| 16.0 * u * a + 16.0 * f64::from(f32::MIN_POSITIVE))
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
    let taps = taps(p, u, v, mip);
    let mut l = [0.0f32; 3];
    let mut count = 0.0f32;
    for d in 0..p.depth_slices {
        let range = lrsm.depth_ranges[d as usize].map(f);
        if !(zc >= range[0] && zc <= range[1]) {
            continue;
        }
        for j in 0..p.normal_slices {
            count += 1.0;
            let layer = d * p.normal_slices + j;
            let nm = fetch(lrsm.normal, &taps, layer, flush);
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
            let moments = fetch(lrsm.moments, &taps, layer, flush);
            let vis = visibility(moments, zw, rw, &vis_params(p), flush);
            if !(vis > 0.0) {
                continue;
            }
            let decay = layer_decay(zc, range[0], range[1], f(p.overlap), flush);
            let r = fetch(lrsm.radiance, &taps, layer, flush);
            let n_w = if p.view_weight == 1 {
                big_n
            } else {
                f(big_n * (1.0 / CULL_RAMP)).min(1.0)
            };
            let w = f(f(decay * vis) * n_w);
            for c in 0..3 {
                l[c] = f(l[c] + f(r[c] * w));
            }
        }
    }
    [l[0], l[1], l[2], count]
}

/// Per-component bound on |GPU - mirror| for [`sample`], from the WGSL accuracy rules (u = 2^-24):
/// each filtered attribute within [`fetch_error`] of the mirror's (the same weights, the sum's
/// roundings), carried first order through what reads it; the normal's divisions (2.5 ULP each) and
/// the dot product (any order, fused or not: 3 ULP of the sum of |terms|) bound |dN|; `V`'s own bound
/// with its moments' errors; `f` within 8 ULP; the products `f V N r` 3 roundings; the sum over layers
/// 1 rounding per add. A branch taken differently (N or V near 0) changes the sum by at most the term
/// with N or V at its bound, which the same expression covers; an opacity within its error of
/// `min_alpha` may take the whole term (`|n| |r|`, n at its largest). Doubled; the `w` component (a
/// count) is exact.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn sample_bound(lrsm: &Lrsm, p: &SampleParams, pos: [f32; 4], dir: [f32; 4]) -> [f32; 4] {
    let u = f64::from(f32::EPSILON) / 2.0;
    let [su, sv, mip, zc] = pos;
    let [vx, vy, vz, rc] = dir;
    let taps = taps(p, su, sv, mip);
    let min_alpha = p.min_alpha as f64;
    let mut bound = [0.0f64; 3];
    let mut total = [0.0f64; 3];
    for d in 0..p.depth_slices {
        let range = lrsm.depth_ranges[d as usize];
        if !(zc >= range[0] && zc <= range[1]) {
            continue;
        }
        for j in 0..p.normal_slices {
            let layer = d * p.normal_slices + j;
            let nm = fetch(lrsm.normal, &taps, layer, false).map(f64::from);
            let e_nm = fetch_error(lrsm.normal, &taps, layer);
            let r = fetch(lrsm.radiance, &taps, layer, false).map(|x| (x as f64).abs());
            let e_r = fetch_error(lrsm.radiance, &taps, layer);
            if (nm[3] - min_alpha).abs() <= e_nm[3] || !(nm[3] > min_alpha) {
                if nm[3] + e_nm[3] > min_alpha {
                    // The GPU may take this layer where the mirror does not, or leave it: the whole
                    // term, decay and V at most 1, |n| at most |A n| over the opacity's floor.
                    // (Where N only culls, its factor is at most 1.)
                    let n_max = if p.view_weight == 1 {
                        (0..3).map(|c| nm[c].abs() + e_nm[c]).sum::<f64>()
                            / (nm[3] - e_nm[3]).max(min_alpha)
                    } else {
                        1.0
                    };
                    for c in 0..3 {
                        bound[c] += n_max * (r[c] + e_r[c]);
                        total[c] += n_max * (r[c] + e_r[c]);
                    }
                }
                if !(nm[3] > min_alpha) {
                    continue;
                }
            }
            let n = [nm[0] / nm[3], nm[1] / nm[3], nm[2] / nm[3]];
            let e_n = [0, 1, 2].map(|c| (e_nm[c] + n[c].abs() * e_nm[3]) / (nm[3] - e_nm[3]));
            let v = [vx as f64, vy as f64, vz as f64];
            let terms = [n[0] * v[0], n[1] * v[1], n[2] * v[2]];
            let big_n = terms.iter().sum::<f64>();
            let abs_terms: f64 = terms.iter().map(|x| x.abs()).sum();
            let d_n = (2.5 + 3.0) * u * abs_terms
                + 2.0 * u * big_n.abs()
                + (0..3).map(|c| v[c].abs() * e_n[c]).sum::<f64>();
            // Where N only culls, its ramp also moves with the gather's vc = -d, a few ULP off the
            // mirror's (lrsm_cone_trace's bound takes that relative change of L for the weight, not
            // for the ramp's steeper slope): 1e-4 of |n|_1 more.
            let d_branch = if p.view_weight == 1 {
                d_n
            } else {
                d_n + 1e-4 * n.iter().map(|c| c.abs()).sum::<f64>()
            };
            if big_n + d_branch <= 0.0 {
                continue; // N <= 0 on every conforming GPU: no contribution anywhere
            }
            let zw = ((zc - range[0]) * range[2]) as f64;
            let rw = (rc * range[2]) as f64;
            // zw and rw round (0.5 ULP each): shifts of the window edges by that much move V by at most
            // phi_max * shift / sigma_min; fold them into V's bound.
            let sigma_min = (p.min_variance as f64).sqrt();
            let d_window = (zw.abs() + rw.abs()) * 1.5 * u / sigma_min;
            let moments = fetch(lrsm.moments, &taps, layer, false);
            let e_m = fetch_error(lrsm.moments, &taps, layer);
            let vis = visibility(moments, zw as f32, rw as f32, &vis_params(p), false) as f64;
            let d_vis = visibility_bound_inexact(
                moments,
                [e_m[0], e_m[1], e_m[2]],
                zw as f32,
                rw as f32,
                &vis_params(p),
            ) as f64
                + d_window;
            let decay = layer_decay(zc, range[0], range[1], p.overlap, false) as f64;
            let d_decay = 8.0 * u * decay;
            // N's factor in the weight and its error: with the view weight N itself; as a cull the
            // ramp min(N / CULL_RAMP, 1), which moves by at most d_branch / CULL_RAMP (its
            // product 0.5 ULP more), at most 1.
            let ramp = f64::from(CULL_RAMP);
            let (n_w, d_nw) = if p.view_weight == 1 {
                (big_n.max(0.0), d_n)
            } else {
                (
                    (big_n / ramp).clamp(0.0, 1.0),
                    (d_branch / ramp + u).min(1.0),
                )
            };
            let (bn, bv) = (n_w + d_nw, vis + d_vis);
            let dw =
                d_decay * bv * bn + (decay + d_decay) * d_vis * bn + (decay + d_decay) * bv * d_nw;
            let w = decay * vis * n_w;
            for c in 0..3 {
                bound[c] += r[c] * dw + 4.0 * u * r[c] * w + e_r[c] * (w + dw);
                total[c] += (r[c] + e_r[c]) * (w + dw);
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

#[cfg(test)]
mod tests {
    use super::*;

    fn params(levels: u32) -> SampleParams {
        SampleParams {
            depth_slices: 1,
            normal_slices: 2,
            levels,
            side0: 1 << (levels - 1),
            cdf: 0,
            min_variance: 1e-4,
            min_alpha: 1e-6,
            overlap: 0.05,
            view_weight: 1,
            area: 0,
            lit_cells: 0,
            lit_base: 0,
        }
    }

    /// Two layers, every level: texel value = (level, layer, x, y).
    fn stream(p: &SampleParams) -> Vec<[f32; 4]> {
        let mut out = Vec::new();
        for k in 0..p.levels {
            let s = p.side0 >> k;
            for layer in 0..2 {
                for i in 0..s * s {
                    let [x, y] = morton::decode2(i);
                    out.push([k as f32, layer as f32, x as f32, y as f32]);
                }
            }
        }
        out
    }

    #[test]
    fn texel_centres_at_integer_levels_read_one_texel() {
        let p = params(4);
        let st = stream(&p);
        // Level 1 (side 4): texel (2, 1)'s centre.
        let t = taps(&p, 2.5 / 4.0, 1.5 / 4.0, 1.0);
        assert_eq!(t.weight.iter().filter(|w| **w != 0.0).count(), 1);
        assert_eq!(fetch(&st, &t, 1, false), [1.0, 1.0, 2.0, 1.0]);
    }

    #[test]
    fn between_texels_and_levels_the_blend_is_linear() {
        let p = params(4);
        let st = stream(&p);
        // Half-way between level-0 texels x = 3 and 4, at texel row 5's centre, mip 0.25.
        let t = taps(&p, 4.0 / 8.0, 5.5 / 8.0, 0.25);
        assert!((t.weight.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        let v = fetch(&st, &t, 0, false);
        // Level 0 gives x = 3.5, y = 5; level 1 (side 4) at (2 - 1/2, 2.75 - 1/2): x 1.5, y 2.25.
        let want = [0.25, 0.0, 0.75 * 3.5 + 0.25 * 1.5, 0.75 * 5.0 + 0.25 * 2.25];
        for c in 0..4 {
            assert!((v[c] - want[c]).abs() < 1e-5, "{v:?} vs {want:?}");
        }
    }

    #[test]
    fn past_the_chain_and_the_edges_the_fetch_clamps() {
        let p = params(3);
        let st = stream(&p);
        // Past the last level: level 2 (side 1) alone, whatever u, v.
        let t = taps(&p, -3.0, 7.0, 9.5);
        assert_eq!(fetch(&st, &t, 1, false), [2.0, 1.0, 0.0, 0.0]);
        // Below level 0 and outside [0, 1]: level 0, corner texel (3, 0).
        let t = taps(&p, 1.7, -0.2, -4.0);
        assert_eq!(fetch(&st, &t, 0, false), [0.0, 0.0, 3.0, 0.0]);
    }
}
