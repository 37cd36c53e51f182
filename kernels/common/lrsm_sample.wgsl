// common/lrsm_sample.wgsl — Algorithm 1 "Sample LRSM" of Sugihara et al. 2014 for one cone sample,
// shared by sample_lrsm.wgsl and lrsm_cone_trace.wgsl. Mirror: cpu_mirror/src/sample_lrsm.rs (`sample`,
// on the streams from `base` on). The including kernel declares `params: SampleParams`, `depth_ranges`,
// `lrsm_radiance`, `lrsm_normal` and `lrsm_moments` (see sample_lrsm.wgsl's header for the layout) and
// includes common/lrsm_math.wgsl.

struct SampleParams {
    depth_slices: u32,
    normal_slices: u32,
    levels: u32,
    side0: u32,
    cdf: u32,
    min_variance: f32,
    min_alpha: f32,
    overlap: f32,
}

fn spread2(v_in: u32) -> u32 {
    var v = v_in & 0x0000ffffu;
    v = (v | (v << 8u)) & 0x00ff00ffu;
    v = (v | (v << 4u)) & 0x0f0f0f0fu;
    v = (v | (v << 2u)) & 0x33333333u;
    v = (v | (v << 1u)) & 0x55555555u;
    return v;
}

fn texel_index(u: f32, v: f32, mip: f32, layer: u32) -> u32 {
    let layers = params.depth_slices * params.normal_slices;
    let level = min(u32(max(mip, 0.0)), params.levels - 1u);
    var base = 0u;
    for (var k = 0u; k < level; k = k + 1u) {
        base = base + layers * (params.side0 >> k) * (params.side0 >> k);
    }
    let s = params.side0 >> level;
    let x = min(u32(max(u, 0.0) * f32(s)), s - 1u);
    let y = min(u32(max(v, 0.0) * f32(s)), s - 1u);
    return base + layer * s * s + (spread2(x) | (spread2(y) << 1u));
}

// (L, layers whose depth range holds zc) of cone sample pos = (u, v, mip, zc), dir = (vc, rc), from the
// LRSM whose level 0 starts at texel `base` of the streams.
fn lrsm_sample(pos: vec4<f32>, dir: vec4<f32>, base: u32) -> vec4<f32> {
    let zc = pos.w;
    var l = vec3<f32>(0.0);
    var count = 0.0;
    for (var d = 0u; d < params.depth_slices; d = d + 1u) {
        let range = depth_ranges[d];
        if (!(zc >= range.x && zc <= range.y)) {
            continue;
        }
        for (var j = 0u; j < params.normal_slices; j = j + 1u) {
            count = count + 1.0;
            let t = base + texel_index(pos.x, pos.y, pos.z, d * params.normal_slices + j);
            let nm = lrsm_normal[t];
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
            let vis = lrsm_depth_visibility(lrsm_moments[t], zw, rw, params.cdf, params.min_variance, params.min_alpha);
            if (!(vis > 0.0)) {
                continue;
            }
            let decay = lrsm_layer_decay(zc, range.x, range.y, params.overlap);
            let w = (decay * vis) * big_n;
            l = l + lrsm_radiance[t].xyz * w;
        }
    }
    return vec4<f32>(l, count);
}
