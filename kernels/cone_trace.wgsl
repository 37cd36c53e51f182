// cone_trace — per G-buffer pixel: AO and diffuse cones plus one glossy cone marched through the
// pre-filtered radiance pyramid (Rehfeld et al. 2014 section 4; Crassin et al. 2011 sections 5-7).
// Mirror: cpu_mirror/src/cone_trace.rs (its module comment is the full definition). The march and the
// pixel entry are in kernels/common/cone_march.wgsl (shared with svo_cone_trace); this file is the volume.
//
// Pyramid: levels of a Morton grid of side 2^L concatenated, level l at (8^(L+1) - 8^(L-l+1)) / 7, each
// voxel (L * alpha, alpha) — voxel_light's output and its surface_coverage_mip levels.
// March: diameter from 3/4 of a level-0 cell, first sample half a step out, step = diameter / 2,
// diameter *= 1 + tan and mip level += log2(1 + tan) per step (no logarithm in the loop), quadrilinear
// sampling (outside the grid = empty), alpha corrected for the step (a' = 1 - (1 - a)^(step / cell)),
// front-to-back accumulation, AO weighted 1 / (1 + lambda t) within ao_range, stop when A >= 1 - 1/256
// or past the grid's diagonal. Option mip_clamp (0 = off): level capped at log2(D / (mip_clamp s0)),
// D = the sample's distance from the origin surface's plane (offset + t cos), step ratio per capped cell.
// Pixel: origin p + ng * offset_voxels * s0; diffuse cones from cone_dirs (tangent space, w = weight);
// indirect = albedo (gb_albedo) * sum w C (+ Ks * C of a glossy cone along the mirror direction, tan = clamp(
// sqrt(2 / (n + 2)), 0.02, 1)); AO = 1 - sum w occ. Back faces: AO only. Background: 0.
// Outputs per pixel (row-major): indirect (rgb, 0), ao (a, a, a, 0).
// Accuracy: per-element bound (see cone_trace::MAG): 4e-4 of the accumulated magnitudes, plus the
// whole remainder where a stop (opacity, distance, AO range) is within rounding of its threshold.

@group(0) @binding(8) var<storage, read> pyramid: array<vec4<f32>>;

fn spread3(v: u32) -> u32 {
    var x = v & 0x3ffu;
    x = (x | (x << 16u)) & 0x030000ffu;
    x = (x | (x << 8u)) & 0x0300f00fu;
    x = (x | (x << 4u)) & 0x030c30c3u;
    x = (x | (x << 2u)) & 0x09249249u;
    return x;
}

fn level_offset(l: u32) -> u32 {
    let big = countTrailingZeros(cone.side);
    return ((1u << (3u * (big + 1u))) - (1u << (3u * (big + 1u - l)))) / 7u;
}

fn sample_level(x: vec3<f32>, l: u32) -> vec4<f32> {
    let n = i32(cone.side >> l);
    let inv = cone.inv_s0 * (1.0 / f32(1u << l));
    let q = (x - cone.origin.xyz) * inv - vec3<f32>(0.5);
    let fl = floor(q);
    let f = q - fl;
    let i0 = vec3<i32>(fl);
    let off = level_offset(l);
    var acc = vec4<f32>(0.0);
    for (var corner = 0u; corner < 8u; corner++) {
        let cc = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
        let w = select(vec3<f32>(1.0) - f, f, cc == vec3<u32>(1u));
        let i = i0 + vec3<i32>(cc);
        if (any(i < vec3<i32>(0)) || any(i >= vec3<i32>(n))) {
            continue;
        }
        let u = vec3<u32>(i);
        let v = pyramid[off + (spread3(u.x) | (spread3(u.y) << 1u) | (spread3(u.z) << 2u))];
        acc += v * (w.x * w.y * w.z);
    }
    return acc;
}

// The march's sample: the volume's own radiance (see common/cone_march.wgsl).
fn sample_cone(x: vec3<f32>, l: f32, diam: f32, d: vec3<f32>) -> vec4<f32> {
    return sample_volume(x, l);
}
