// sample_lrsm — Algorithm 1 "Sample LRSM" of Sugihara et al. 2014 ("Layered Reflective Shadow Maps"):
// the outgoing radiance of cone samples from the layers of a pre-filtered LRSM (eq. 5, 8, 12, 14, 15).
// Mirror: cpu_mirror/src/sample_lrsm.rs. Declaration: src/kernels/sample_lrsm.rs.
// Uses kernels/common/lrsm_math.wgsl (lrsm_depth_visibility, lrsm_layer_decay).
//
// LRSM (written by lrsm_partition + lrsm_prefilter): levels 0..levels-1 concatenated; level k holds
// layers = depth_slices * normal_slices layers of side s_k = side0 >> k, layer-major, 2D Morton order
// within a layer. Streams radiance = (A R, A), normal = (A n, A), moments = (A z', A z'^2, A, 0), z' the
// depth warped into the layer by depth_ranges[d] = (zmin, zmax, 1 / (zmax - zmin), 0).
// Per cone sample i: cone_pos[i] = (u, v, mip, zc): the cone sample projected into the RSM ([0, 1]^2),
// its mip level (log2 of the projected diameter in level-0 texels), and its light-space depth;
// cone_dir[i] = (vc, rc): unit direction from the sample towards the view sample, and the sample's
// radius in light-space depth units.
// Fetch: level = min(u32(max(mip, 0)), levels - 1), the texel containing (u, v) there (clamped to the
// edge); nearest texel, no filtering (the mirror reproduces it exactly; bilinear/trilinear in WGSL
// arithmetic is a later refinement).
// For every layer (d, j) whose depth range contains zc (Algorithm 1's test; layers outside are not
// sampled):  N = dot(n / A_n, vc) (eq. 8, normal normalised by opacity; skipped when A_n <= min_alpha);
// if N > 0: V = eq. 12 on the layer's moments with zc, rc warped into the layer; if V > 0:
// L += f(zc) * r * V * N with r = A R (already opacity-weighted = A of eq. 14) and f of eq. 15.
// Output radiance[i] = (L, number of layers whose depth range contains zc).
// Accuracy: a per-element bound from the WGSL rules on this path (see sample_bound in the mirror).

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

@group(0) @binding(0) var<uniform> params: SampleParams;
@group(0) @binding(1) var<storage, read> depth_ranges: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> lrsm_radiance: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> lrsm_normal: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> lrsm_moments: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> cone_pos: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> cone_dir: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> radiance: array<vec4<f32>>;

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

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= arrayLength(&radiance)) {
        return;
    }
    let pos = cone_pos[i];
    let dir = cone_dir[i];
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
            let t = texel_index(pos.x, pos.y, pos.z, d * params.normal_slices + j);
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
    radiance[i] = vec4<f32>(l, count);
}
