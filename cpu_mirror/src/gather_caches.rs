//! Mirror of `kernels/gather_caches.wgsl`: evaluating radiance caches per pixel by gathering with the
//! weights of CPRC 3.3: `w_w = max(0, 1 - |p_w - c_w|^2 / r_w^2)` (world, r_w per cache in
//! `cache_pos.w`), `w_s = max(0, 1 - |p_s - c_s|^2 / r_s^2)` (screen, pixels), times the normal
//! weight `w_n = max(0, n_p . n_c)` where `params.angle` is set: `w = min(w_w, w_s) w_n`, over the
//! caches of the tiles within the screen radius. PCRC weighs its caches by distance and a maximum
//! angle; CPRC's two weights have no angle term. A cache holds only the hemisphere above its normal,
//! and a pixel whose normal leans away from it reads that hemisphere's horizon, light the pixel's
//! own hemisphere does not see: w_n, the angle term, fades such a cache out continuously, to nothing
//! at 90 degrees. Each cache is evaluated for the pixel (3.3):
//! diffuse = its cosine-folded irradiance map (`cache_preconvolve`) at the pixel's normal, glossy =
//! its pre-convolved mip chain at the pixel's reflection vector and mip level (levels floor(lf) and
//! floor(lf) + 1 blended; lf < 0: no glossy), both bilinear with clamp to edge in the cache's
//! hemi-octahedral frame (`cache_creation`; directions below the cache's horizon read its horizon).
//! Outputs: `sum(w v) / sum(w)` of both (0 when sum(w) <= 1e-6), the weight sum, and how many caches
//! lie inside the screen radius (an integer test: exact).
use crate::cache_preconvolve::mip_offset;
use crate::cone_trace::basis;
use glam::Vec3;

/// The kernel's uniform block (`struct GatherParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GatherParams {
    pub width: u32,
    pub height: u32,
    pub tile: u32,
    pub tiles_x: u32,
    pub tiles_y: u32,
    /// Screen radius in pixels (an integer, so "inside" is an exact integer test).
    pub radius_px: u32,
    /// Cache side in texels (mip level 0) and its mip levels.
    pub res: u32,
    pub levels: u32,
    /// Side of the irradiance maps.
    pub irr: u32,
    /// 1: each weight times the angle term w_n; 0: CPRC's min(w_w, w_s) alone.
    pub angle: u32,
    pub _pad: [u32; 2],
}

/// Below this weight sum a pixel gathers nothing (0), on GPU and mirror alike.
pub const MIN_WEIGHT_SUM: f32 = 1.0e-6;

/// What the kernel reads besides its parameters.
pub struct GatherInputs<'a> {
    /// xyz world position, w = 1 for pixels that gather (0: background or back faces: nothing).
    pub positions: &'a [[f32; 4]],
    /// Two per pixel: (normal xyz, 0), (reflection vector xyz, glossy mip level; < 0: no glossy).
    pub pixel_dirs: &'a [[f32; 4]],
    /// xyz world position, w = the cache's world radius r_w.
    pub cache_pos: &'a [[f32; 4]],
    /// Cache pixel coordinates (x, y).
    pub cache_pixel: &'a [[u32; 2]],
    /// (normal xyz, 0) per cache: its hemi-octahedral frame.
    pub cache_normal: &'a [[f32; 4]],
    /// irr^2 texels per cache.
    pub cache_irradiance: &'a [[f32; 4]],
    /// `mip_len(res)` texels per cache.
    pub cache_mips: &'a [[f32; 4]],
    /// Per tile, the range [start, end) of its caches (caches are stored tile by tile).
    pub tile_ranges: &'a [[u32; 2]],
}

/// One pixel's result: gathered diffuse irradiance and glossy radiance (rgb, 0), weight sum, caches in
/// radius, and the largest lookup errors over its caches (for [`gather_bound`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct Gathered {
    pub diffuse: [f32; 4],
    pub glossy: [f32; 4],
    pub weight_sum: f32,
    pub in_radius: u32,
    pub lookup_error: [f32; 2],
}

/// Hemi-octahedral (u, v) of direction `d` in the frame of cache normal `n`, in the kernel's order,
/// and the bound on its rounding (`du`, in units of u and v): the frame's dots (a basis of crosses and
/// a square root, a few ULP, fused or not) ~8 ULP per component, divided by s = |x| + |y| + z (>= 1
/// for unit d above the horizon, smaller only below it): 32 ULP / s, plus the division's 2.5 ULP.
pub fn hemi_uv(n: Vec3, d: Vec3) -> ([f32; 2], f32) {
    let (bt, bb) = basis(n);
    let (x, y, z) = (d.dot(bt), d.dot(bb), d.dot(n).max(0.0));
    let s = x.abs() + y.abs() + z;
    let u = f32::EPSILON / 2.0;
    if s <= 0.0 {
        return ([0.0, 0.0], 2.0);
    }
    let (px, py) = (x / s, y / s);
    ([px + py, px - py], (64.0 * u / s + 8.0 * u).min(2.0))
}

/// Bilinear lookup (clamp to edge) in an m x m map stored row-major at `map[base..]`, in the kernel's
/// order.
pub fn bilinear(map: &[[f32; 4]], base: usize, m: u32, uv: [f32; 2]) -> [f32; 4] {
    let top = (m - 1) as f32;
    let f = uv.map(|c| ((c * 0.5 + 0.5) * m as f32 - 0.5).clamp(0.0, top));
    let i0 = f.map(|c| c.floor() as u32);
    let i1 = i0.map(|i| (i + 1).min(m - 1));
    let a = [f[0] - f[0].floor(), f[1] - f[1].floor()];
    let at = |x: u32, y: u32| map[base + (y * m + x) as usize];
    let (v00, v10, v01, v11) = (
        at(i0[0], i0[1]),
        at(i1[0], i0[1]),
        at(i0[0], i1[1]),
        at(i1[0], i1[1]),
    );
    let mut out = [0.0f32; 4];
    for c in 0..4 {
        let r0 = v00[c] * (1.0 - a[0]) + v10[c] * a[0];
        let r1 = v01[c] * (1.0 - a[0]) + v11[c] * a[0];
        out[c] = r0 * (1.0 - a[1]) + r1 * a[1];
    }
    out
}

/// Error of a [`bilinear`] lookup whose (u, v) is off by `du`, in a map whose |texels| are <= `vmax`:
/// the texel coordinates move by m du / 2 (+ 4 ULP of m for the fused or unfused scale), which moves
/// the blend by at most that times the difference of neighbours (<= 2 vmax) per axis; plus 8 ULP of
/// vmax for the blend's own roundings.
pub fn bilinear_error(m: u32, du: f32, vmax: f32) -> f32 {
    let u = f32::EPSILON / 2.0;
    let df = m as f32 * (0.5 * du + 4.0 * u);
    (4.0 * df.min(1.0) + 8.0 * u) * vmax
}

/// The pixel's glossy lookup: mip level `lf` of cache `c`'s chain at (u, v).
fn glossy_lookup(p: &GatherParams, mips: &[[f32; 4]], c: usize, uv: [f32; 2], lf: f32) -> [f32; 4] {
    let top = p.levels - 1;
    let l0 = lf.floor().min(top as f32);
    let a = if l0 >= top as f32 { 0.0 } else { lf - l0 };
    let l = l0 as u32;
    let base = c * crate::cache_preconvolve::mip_len(p.res);
    let v0 = bilinear(mips, base + mip_offset(p.res, l), p.res >> l, uv);
    if a <= 0.0 {
        return v0;
    }
    let v1 = bilinear(mips, base + mip_offset(p.res, l + 1), p.res >> (l + 1), uv);
    [0, 1, 2, 3].map(|k| v0[k] * (1.0 - a) + v1[k] * a)
}

/// Pixel `i`, in the kernel's operation order. `vmax` = (largest |irradiance texel|, largest |mip
/// texel|) for the lookup errors.
pub fn gather(p: &GatherParams, inp: &GatherInputs, i: usize, vmax: [f32; 2]) -> Gathered {
    let pos = inp.positions[i];
    if pos[3] != 1.0 {
        return Gathered::default();
    }
    let v3 = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]);
    let (nrm, refl) = (v3(inp.pixel_dirs[2 * i]), inp.pixel_dirs[2 * i + 1]);
    let (x, y) = ((i as u32 % p.width) as i32, (i as u32 / p.width) as i32);
    let reach = p.radius_px.div_ceil(p.tile) as i32;
    let (tx, ty) = (x / p.tile as i32, y / p.tile as i32);
    let r2 = (p.radius_px * p.radius_px) as i32;
    let mut g = Gathered::default();
    let (mut dacc, mut gacc, mut wsum) = ([0.0f32; 4], [0.0f32; 4], 0.0f32);
    let irr_len = (p.irr * p.irr) as usize;
    for ny in (ty - reach).max(0)..=(ty + reach).min(p.tiles_y as i32 - 1) {
        for nx in (tx - reach).max(0)..=(tx + reach).min(p.tiles_x as i32 - 1) {
            let [start, end] = inp.tile_ranges[(ny as u32 * p.tiles_x + nx as u32) as usize];
            for c in start..end {
                let [cx, cy] = inp.cache_pixel[c as usize];
                let (dx, dy) = (cx as i32 - x, cy as i32 - y);
                let ds2 = dx * dx + dy * dy;
                if ds2 >= r2 {
                    continue;
                }
                g.in_radius += 1;
                let cp = inp.cache_pos[c as usize];
                let d = [pos[0] - cp[0], pos[1] - cp[1], pos[2] - cp[2]];
                let dw2 = (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2];
                let ww = (1.0 - dw2 / (cp[3] * cp[3])).max(0.0);
                let ws = (1.0 - ds2 as f32 / r2 as f32).max(0.0);
                let cn = v3(inp.cache_normal[c as usize]);
                let mut w = ww.min(ws);
                if p.angle != 0 {
                    w *= ((nrm.x * cn.x + nrm.y * cn.y) + nrm.z * cn.z).max(0.0);
                }
                let (uv, du) = hemi_uv(cn, nrm);
                let vd = bilinear(inp.cache_irradiance, c as usize * irr_len, p.irr, uv);
                g.lookup_error[0] = g.lookup_error[0].max(bilinear_error(p.irr, du, vmax[0]));
                let mut vg = [0.0f32; 4];
                if refl[3] >= 0.0 {
                    let (uvg, dug) = hemi_uv(cn, v3(refl));
                    vg = glossy_lookup(p, inp.cache_mips, c as usize, uvg, refl[3]);
                    g.lookup_error[1] = g.lookup_error[1].max(bilinear_error(p.res, dug, vmax[1]));
                }
                for k in 0..4 {
                    dacc[k] += w * vd[k];
                    gacc[k] += w * vg[k];
                }
                wsum += w;
            }
        }
    }
    g.weight_sum = wsum;
    if wsum > MIN_WEIGHT_SUM {
        g.diffuse = dacc.map(|a| a / wsum);
        g.glossy = gacc.map(|a| a / wsum);
    }
    g
}

/// Bounds on |GPU - mirror| for a pixel's outputs (diffuse and glossy per component, weight sum) from
/// the WGSL rules: per cache, `dw2` (3 products, 2 adds: 3 ULP of dw2, any order or fused), `/ rw2`
/// 2.5 ULP, `1 - x` absolute 0.5 ULP of 1 plus x's error: 4u absolute for min(w_w, w_s) <= 1; the
/// normal weight, a dot product of unit vectors (3 products, 2 adds, any order or fused: 3u times
/// the sum of |products| <= 1), 3u absolute; their product one rounding more: 8u absolute per
/// weight; the sums add one rounding per term (fused or not). A weight sum near the
/// `MIN_WEIGHT_SUM` threshold may fall on either side: then any value between 0 and the gathered one
/// is accepted. The lookups' own errors pass through the normalised mean unchanged (sum w dv / sum w
/// <= max dv). Doubled.
pub fn gather_bound(r: &Gathered, vmax: [f32; 2]) -> ([f32; 4], [f32; 4], f32) {
    let u = f32::EPSILON / 2.0;
    let (wsum, k) = (r.weight_sum, r.in_radius as f32);
    // Each weight's error, doubled.
    let ew = 2.0 * 8.0 * u;
    let dw = k * ew + 2.0 * k * u * wsum;
    let one = |g: [f32; 4], vmax: f32, dv: f32| {
        if wsum <= MIN_WEIGHT_SUM + dw {
            g.map(|x| x.abs() + vmax)
        } else {
            g.map(|x| {
                2.0 * (k * ew * (vmax + x.abs()) + dw * x.abs()) / wsum
                    + 8.0 * u * x.abs()
                    + 2.0 * dv
            })
        }
    };
    (
        one(r.diffuse, vmax[0], r.lookup_error[0]),
        one(r.glossy, vmax[1], r.lookup_error[1]),
        2.0 * dw,
    )
}

/// Largest |component| of any texel of a set of maps.
pub fn payload_max(maps: &[[f32; 4]]) -> f32 {
    maps.iter()
        .flat_map(|v| v.iter())
        .fold(0.0f32, |m, x| m.max(x.abs()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two caches at the pixel's own position and pixel, with constant irradiance maps a and b:
    /// the pixel reads their mean weighted by the cosines between its normal and theirs, and a cache
    /// facing away (cosine <= 0) adds nothing, its weight included.
    #[test]
    fn caches_weigh_by_the_cosine_of_their_normal_and_none_facing_away() {
        let mut p = GatherParams {
            width: 1,
            height: 1,
            tile: 4,
            tiles_x: 1,
            tiles_y: 1,
            radius_px: 4,
            res: 1,
            levels: 1,
            irr: 1,
            angle: 1,
            _pad: [0; 2],
        };
        let gather_with = |p: &GatherParams, second: [f32; 3]| {
            let normals = [[0.0, 0.0, 1.0, 0.0], [second[0], second[1], second[2], 0.0]];
            let inp = GatherInputs {
                positions: &[[0.0, 0.0, 0.0, 1.0]],
                pixel_dirs: &[[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 1.0, -1.0]],
                cache_pos: &[[0.0, 0.0, 0.0, 1.0]; 2],
                cache_pixel: &[[0, 0]; 2],
                cache_normal: &normals,
                cache_irradiance: &[[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]],
                cache_mips: &[[0.0; 4]; 2],
                tile_ranges: &[[0, 2]],
            };
            gather(p, &inp, 0, [1.0, 0.0])
        };
        let c = 0.6f32;
        let tilted = gather_with(&p, [0.8, 0.0, c]);
        assert_eq!(tilted.weight_sum, 1.0 + c);
        assert_eq!(tilted.diffuse, [1.0 / (1.0 + c), c / (1.0 + c), 0.0, 0.0]);
        for away in [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0]] {
            let g = gather_with(&p, away);
            assert_eq!((g.weight_sum, g.diffuse), (1.0, [1.0, 0.0, 0.0, 0.0]));
            assert_eq!(g.in_radius, 2, "counted in the radius all the same");
        }
        p.angle = 0;
        let g = gather_with(&p, [1.0, 0.0, 0.0]);
        assert_eq!(
            g.weight_sum, 2.0,
            "without the angle term every cache weighs min(w_w, w_s)"
        );
    }
}
