// common/lrsm_sample.wgsl — Algorithm 1 "Sample LRSM" of Sugihara et al. 2014 for one cone sample,
// shared by sample_lrsm.wgsl and lrsm_cone_trace.wgsl. Mirror: cpu_mirror/src/sample_lrsm.rs (`sample`,
// on the streams from `base` on). The including kernel declares `params: SampleParams`, `depth_ranges`,
// `lrsm_radiance`, `lrsm_normal` and `lrsm_moments` (see sample_lrsm.wgsl's header for the layout) and
// includes common/lrsm_math.wgsl; common/lrsm_texel.wgsl comes before this file.

// With N as a cull, its factor ramps from 0 to 1 over N in [0, LRSM_CULL_RAMP] (surfaces within 1.8
// degrees of edge-on fade out) instead of stepping at 0: continuous in N, so a sample whose N rounds
// to either side of 0 (a cone parallel to a wall: exactly 0 in exact arithmetic) is not a whole term
// apart on two GPUs. An edge-on surface's projected area is 0, so the ramp removes nothing visible.
const LRSM_CULL_RAMP: f32 = 0.03125;

struct SampleParams {
    depth_slices: u32,
    normal_slices: u32,
    levels: u32,
    side0: u32,
    cdf: u32,
    min_variance: f32,
    min_alpha: f32,
    overlap: f32,
    // 1: N = <n, vc> weighs each layer's radiance, as Algorithm 1 writes it; 0: N only culls back
    // faces (eq. 2's w' holds <n.v> in its numerator and denominator alike, so for one surface it
    // cancels: a Lambertian surface's radiance does not depend on where it is seen from).
    view_weight: u32,
    // 1: the LRSMs are area-weighted (lrsm_partition's area_weights) and lrsm_cone_trace reads eq. 1's
    // premultiplied product: a sample's L is the colour its march adds (not alpha L), fetched one
    // level finer than log2 of the disc's diameter in texels. Sample LRSM itself does not read it.
    area: u32,
    // 1: lrsm_cone_trace reads each sample's light from the lit cells (lit_cells.wgsl), premultiplied,
    // and no LRSM. Sample LRSM itself does not read it.
    lit_cells: u32,
    // With lit_cells: the occlusion level the lit cells' finest level stands at (0 where the table
    // is as fine as the voxels; lit_cells.wgsl's grid caps its side). Samples finer than it read it.
    lit_base: u32,
}

fn spread2(v_in: u32) -> u32 {
    var v = v_in & 0x0000ffffu;
    v = (v | (v << 8u)) & 0x00ff00ffu;
    v = (v | (v << 4u)) & 0x0f0f0f0fu;
    v = (v | (v << 2u)) & 0x33333333u;
    v = (v | (v << 1u)) & 0x55555555u;
    return v;
}

// The 8 taps of a trilinear fetch at (u, v, mip): levels l0 = min(u32(max(mip, 0)), levels - 1) and
// min(l0 + 1, levels - 1) weighted 1 - f and f (f the fraction of max(mip, 0) above l0; 0 at the last
// level), in each the 2 x 2 texels around (u s - 1/2, v s - 1/2) clamped to the edge, weighted
// bilinearly. Tap i of layer L is texel base[i / 4] + L * area[i / 4] + texel[i]. Mirror: `taps`.
struct Taps {
    base: array<u32, 2>,
    area: array<u32, 2>,
    texel: array<u32, 8>,
    weight: array<f32, 8>,
}

fn lrsm_taps(u: f32, v: f32, mip: f32) -> Taps {
    var t: Taps;
    let layers = params.depth_slices * params.normal_slices;
    let top = params.levels - 1u;
    // Clamped to the chain before the conversion (WGSL saturates out-of-range conversions, but the
    // back ends only do by a polyfill; in range, nothing depends on it).
    let m = min(max(mip, 0.0), f32(top));
    let l0 = u32(m);
    let l1 = min(l0 + 1u, top);
    // Exact: m - l0 is in [0, 1) with l0 <= m < l0 + 1 (Sterbenz for l0 >= 1).
    let fl = select(0.0, m - f32(l0), l0 < top);
    var base = 0u;
    for (var k = 0u; k < l0; k = k + 1u) {
        base = base + layers * (params.side0 >> k) * (params.side0 >> k);
    }
    t.base[0] = base;
    t.base[1] = base;
    for (var j = 0u; j < 2u; j = j + 1u) {
        let k = select(l0, l1, j == 1u);
        let s = params.side0 >> k;
        if (j == 1u && l1 > l0) {
            t.base[1] = base + layers * (params.side0 >> l0) * (params.side0 >> l0);
        }
        t.area[j] = s * s;
        // u s is exact (s a power of two); - 1/2 exact where u s >= 1/4, and below that both taps
        // clamp to texel 0, so how it rounds does not choose texels.
        let x = clamp(u * f32(s) - 0.5, -1.0, f32(s));
        let y = clamp(v * f32(s) - 0.5, -1.0, f32(s));
        let x0 = floor(x);
        let y0 = floor(y);
        let fx = x - x0;
        let fy = y - y0;
        let wl = select(1.0 - fl, fl, j == 1u);
        for (var c = 0u; c < 4u; c = c + 1u) {
            let cx = c & 1u;
            let cy = c >> 1u;
            let ix = u32(clamp(i32(x0) + i32(cx), 0, i32(s) - 1));
            let iy = u32(clamp(i32(y0) + i32(cy), 0, i32(s) - 1));
            let wx = select(1.0 - fx, fx, cx == 1u);
            let wy = select(1.0 - fy, fy, cy == 1u);
            t.texel[4u * j + c] = spread2(ix) | (spread2(iy) << 1u);
            t.weight[4u * j + c] = wl * (wy * wx);
        }
    }
    return t;
}

fn tap_index(t: ptr<function, Taps>, i: u32, layer: u32, first: u32) -> u32 {
    let j = i >> 2u;
    return first + (*t).base[j] + layer * (*t).area[j] + (*t).texel[i];
}

// The filtered attributes: sum of w_i texel_i in tap order; taps of weight 0 are not read.
fn fetch_normal(t: ptr<function, Taps>, layer: u32, first: u32) -> vec4<f32> {
    var acc = vec4<f32>(0.0);
    for (var i = 0u; i < 8u; i = i + 1u) {
        let w = (*t).weight[i];
        if (w != 0.0) {
            acc = acc + lrsm_unpack(lrsm_normal[tap_index(t, i, layer, first)]) * w;
        }
    }
    return acc;
}

fn fetch_moments(t: ptr<function, Taps>, layer: u32, first: u32) -> vec4<f32> {
    var acc = vec4<f32>(0.0);
    for (var i = 0u; i < 8u; i = i + 1u) {
        let w = (*t).weight[i];
        if (w != 0.0) {
            acc = acc + lrsm_unpack(lrsm_moments[tap_index(t, i, layer, first)]) * w;
        }
    }
    return acc;
}

fn fetch_radiance(t: ptr<function, Taps>, layer: u32, first: u32) -> vec4<f32> {
    var acc = vec4<f32>(0.0);
    for (var i = 0u; i < 8u; i = i + 1u) {
        let w = (*t).weight[i];
        if (w != 0.0) {
            acc = acc + lrsm_unpack(lrsm_radiance[tap_index(t, i, layer, first)]) * w;
        }
    }
    return acc;
}

// (L, layers whose depth range holds zc) of cone sample pos = (u, v, mip, zc), dir = (vc, rc), from the
// LRSM whose level 0 starts at texel `base` of the streams.
fn lrsm_sample(pos: vec4<f32>, dir: vec4<f32>, base: u32) -> vec4<f32> {
    let zc = pos.w;
    var taps = lrsm_taps(pos.x, pos.y, pos.z);
    var l = vec3<f32>(0.0);
    var count = 0.0;
    for (var d = 0u; d < params.depth_slices; d = d + 1u) {
        let range = depth_ranges[d];
        if (!(zc >= range.x && zc <= range.y)) {
            continue;
        }
        for (var j = 0u; j < params.normal_slices; j = j + 1u) {
            count = count + 1.0;
            let layer = d * params.normal_slices + j;
            let nm = fetch_normal(&taps, layer, base);
            if (!(nm.w > params.min_alpha)) {
                continue;
            }
            let n = vec3<f32>(nm.x / nm.w, nm.y / nm.w, nm.z / nm.w);
            let big_n = (n.x * dir.x + n.y * dir.y) + n.z * dir.z;
            if (!(big_n > 0.0)) {
                continue;
            }
            let zw = (zc - range.x) * range.z;
            let rw = dir.w * range.z;
            let moments = fetch_moments(&taps, layer, base);
            let vis = lrsm_depth_visibility(moments, zw, rw, params.cdf, params.min_variance, params.min_alpha);
            if (!(vis > 0.0)) {
                continue;
            }
            let decay = lrsm_layer_decay(zc, range.x, range.y, params.overlap);
            let w = (decay * vis) * select(min(big_n * (1.0 / LRSM_CULL_RAMP), 1.0), big_n, params.view_weight == 1u);
            l = l + fetch_radiance(&taps, layer, base).xyz * w;
        }
    }
    return vec4<f32>(l, count);
}
