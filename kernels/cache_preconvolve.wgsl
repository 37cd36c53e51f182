// cache_preconvolve — pre-convolution of radiance caches (Rehfeld et al. 2014, 3.1, after Scherzer et
// al. 2012 "Pre-convolved Radiance Caching"): each cache's mip chain for glossy lookups and its
// cosine-folded irradiance map for diffuse lookups. Mirror: cpu_mirror/src/cache_preconvolve.rs.
//
// cache_radiance: count caches of res x res texels (cache_creation's output, row-major).
// Entry points:
//   mips:       one invocation per chain texel (c * mip_len + j): level l (side res >> l, levels
//               concatenated) texel = the mean of its 2^l x 2^l block of level-0 texels, summed row
//               by row then scaled by 4^-l with ldexp (exact: adds in the mirror's order, a power-of-two scale).
//   irradiance: one invocation per irradiance texel (c * irr_texels + k): E_k = sum_t L_t W[k][t] in t
//               order, W = irr_weights (host table, f64: max(0, w_k . w_t) dw_t).
// Accuracy: mips exact; irradiance within (n + 1) u sum |L W| (one rounding per step, fused or not).

struct PreconvolveParams {
    count: u32,
    res: u32,
    levels: u32,
    irr_texels: u32,
}

@group(0) @binding(0) var<uniform> params: PreconvolveParams;
@group(0) @binding(1) var<storage, read> cache_radiance: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> irr_weights: array<f32>;
@group(0) @binding(3) var<storage, read_write> cache_mips: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> cache_irradiance: array<vec4<f32>>;

fn mip_offset(l: u32) -> u32 {
    var off = 0u;
    for (var j = 0u; j < l; j++) {
        let s = params.res >> j;
        off += s * s;
    }
    return off;
}

@compute @workgroup_size(64)
fn mips(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    let len = mip_offset(params.levels);
    if (i >= params.count * len) {
        return;
    }
    let c = i / len;
    let j = i % len;
    var l = 0u;
    while (j >= mip_offset(l + 1u)) {
        l++;
    }
    let side = params.res >> l;
    let k = j - mip_offset(l);
    let x = k % side;
    let y = k / side;
    let b = 1u << l;
    let base = c * params.res * params.res;
    var acc = vec4<f32>(0.0);
    for (var by = 0u; by < b; by++) {
        for (var bx = 0u; bx < b; bx++) {
            acc += cache_radiance[base + (y * b + by) * params.res + x * b + bx];
        }
    }
    cache_mips[i] = ldexp(acc, vec4<i32>(-2 * i32(l)));
}

@compute @workgroup_size(64)
fn irradiance(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= params.count * params.irr_texels) {
        return;
    }
    let c = i / params.irr_texels;
    let k = i % params.irr_texels;
    let n = params.res * params.res;
    var acc = vec3<f32>(0.0);
    for (var t = 0u; t < n; t++) {
        acc += cache_radiance[c * n + t].xyz * irr_weights[k * n + t];
    }
    cache_irradiance[i] = vec4<f32>(acc, 0.0);
}
