//! Mirror of `kernels/gather_caches.wgsl`: gathering radiance caches per pixel with the weights of CPRC
//! 3.3: `w_w = max(0, 1 - |p_w - c_w|^2 / r_w^2)` (world, r_w per cache in `cache_pos.w`), `w_s = max(0, 1 - |p_s - c_s|^2 / r_s^2)`
//! (screen, pixels), `w = min(w_w, w_s)`, over the caches of the tiles within the screen radius;
//! output `sum(w v) / sum(w)` of a per-cache payload v (the caches' radiance, once they exist), the
//! weight sum, and how many caches lie inside the screen radius (an integer test: exact).

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
    pub _pad: [u32; 2],
}

/// Below this weight sum a pixel gathers nothing (0), on GPU and mirror alike.
pub const MIN_WEIGHT_SUM: f32 = 1.0e-6;

/// What the kernel reads besides its parameters.
pub struct GatherInputs<'a> {
    /// xyz world position, w = 1 for geometry pixels (0: background, gathers nothing).
    pub positions: &'a [[f32; 4]],
    /// xyz world position, w = the cache's world radius r_w.
    pub cache_pos: &'a [[f32; 4]],
    /// Cache pixel coordinates (x, y).
    pub cache_pixel: &'a [[u32; 2]],
    pub cache_payload: &'a [[f32; 4]],
    /// Per tile, the range [start, end) of its caches (caches are stored tile by tile).
    pub tile_ranges: &'a [[u32; 2]],
}

/// (gathered payload, weight sum, caches in radius) of pixel `i`, in the kernel's operation order.
pub fn gather(p: &GatherParams, inp: &GatherInputs, i: usize) -> ([f32; 4], f32, u32) {
    let pos = inp.positions[i];
    if pos[3] != 1.0 {
        return ([0.0; 4], 0.0, 0);
    }
    let (x, y) = ((i as u32 % p.width) as i32, (i as u32 / p.width) as i32);
    let reach = p.radius_px.div_ceil(p.tile) as i32;
    let (tx, ty) = (x / p.tile as i32, y / p.tile as i32);
    let r2 = (p.radius_px * p.radius_px) as i32;
    let (mut acc, mut wsum, mut count) = ([0.0f32; 4], 0.0f32, 0u32);
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
                count += 1;
                let cp = inp.cache_pos[c as usize];
                let d = [pos[0] - cp[0], pos[1] - cp[1], pos[2] - cp[2]];
                let dw2 = (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2];
                let ww = (1.0 - dw2 / (cp[3] * cp[3])).max(0.0);
                let ws = (1.0 - ds2 as f32 / r2 as f32).max(0.0);
                let w = ww.min(ws);
                let v = inp.cache_payload[c as usize];
                for k in 0..4 {
                    acc[k] += w * v[k];
                }
                wsum += w;
            }
        }
    }
    if wsum > MIN_WEIGHT_SUM {
        (acc.map(|a| a / wsum), wsum, count)
    } else {
        ([0.0; 4], wsum, count)
    }
}

/// Bounds on |GPU - mirror| for pixel `i`'s outputs (gathered xyzw, weight sum) from the WGSL rules:
/// per cache, `dw2` (3 products, 2 adds: 3 ULP of dw2, any order or fused), `/ rw2` 2.5 ULP, `1 - x`
/// absolute 0.5 ULP of 1 plus x's error: 4u absolute per weight; the sums add one rounding per term
/// (fused or not). A weight sum near the `MIN_WEIGHT_SUM` threshold may fall on either side: then any
/// value between 0 and the gathered one is accepted. Doubled.
/// `result` is [`gather`]'s for this pixel, `vmax` the largest |payload component| ([`payload_max`]).
pub fn gather_bound(result: ([f32; 4], f32, u32), vmax: f32) -> ([f32; 4], f32) {
    let u = f32::EPSILON / 2.0;
    let (g, wsum, count) = result;
    let k = count as f32;
    let dw = k * 8.0 * u + 2.0 * k * u * wsum;
    let gb = if wsum <= MIN_WEIGHT_SUM + dw {
        g.map(|x| x.abs() + vmax)
    } else {
        g.map(|x| 2.0 * (k * 8.0 * u * (vmax + x.abs()) + dw * x.abs()) / wsum + 8.0 * u * x.abs())
    };
    (gb, 2.0 * dw)
}

/// Largest |component| of any cache payload.
pub fn payload_max(payload: &[[f32; 4]]) -> f32 {
    payload
        .iter()
        .flat_map(|v| v.iter())
        .fold(0.0f32, |m, x| m.max(x.abs()))
}
