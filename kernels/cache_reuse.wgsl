// cache_reuse — keeps the last frame's radiance caches on the surfaces they were made on, so that a
// cache follows its surface instead of jumping to whichever pixel of its cluster scores best this
// frame (Rehfeld et al. 2014, sections 5-6: "RCs follow surfaces, but jump"; reusing the last
// frame's caches). Mirror: cpu_mirror/src/cache_reuse.rs (its module comment defines every output).
// Uses kernels/common/octahedral_bins.wgsl (oct_is_geometry, oct_unpack) and common/scene_types.wgsl
// (Frame).
//
// Between cache_placement and cache_records of cprc's distribution, with the last frame's records
// copied into prev_pos, prev_normal, prev_caches, prev_radiance and prev_count before this frame's
// overwrite them:
//   clear (one invocation per cluster slot): kept[c] = 0.
//   claim (one invocation per last-frame cache i < prev_count): the cache's position X projected by
//     this frame's camera to pixel p (prev_pixel[i]; 0xffffffff behind the camera or off the image).
//     It is a candidate for p's cluster c when p gathers (positions[p].w == 1, a geometry normal),
//     the normals agree (dot(q / 32767, prev normal) >= min_cos) and p's surface point lies within
//     reach pixel footprints of X (|positions[p] - X|^2 <= (reach * 2 z |up| / height)^2, z the
//     depth along forward): the surface is still there and not hidden. Each cluster keeps its lowest
//     candidate: kept[c] = max over candidates of 0xffffffff - i (0: none).
// After cache_records:
//   keep (one invocation per cluster slot c < cache_count with kept[c] != 0, i = 0xffffffff -
//     kept[c]): cache c takes the kept cache's position (r_w stays the cluster's), normal, creation
//     record (prev_caches[2i], prev_caches[2i + 1] with w = carry) and cache_pixel = prev_pixel[i]'s
//     (x, y); cache_args[2] (cache_records leaves it 0) counts the kept caches. The kept cache lies
//     on a pixel of cluster c, so in the tile cache_records gave the cluster's range. With
//     reuse_params.carry (the volume is unchanged since the last frame) it also takes its
//     reuse_params.texels radiance texels from prev_radiance, and cache_creation skips it (w != 0):
//     the same record through the same volume would trace the same texels.
// Accuracy: the projection and the two tests round (dot products in any order or fused, division
// 2.5 ULP, sqrt); the mirror derives a bound for each and accepts any outcome within it (a pixel
// beside the boundary, a candidate on the edge of a test). Everything keep writes is copied: exact.

struct ReuseParams {
    reach: f32,
    min_cos: f32,
    carry: u32,
    texels: u32,
}

@group(0) @binding(0) var<storage, read> frame: Frame;
@group(0) @binding(1) var<uniform> reuse_params: ReuseParams;
@group(0) @binding(2) var<storage, read> prev_count: array<u32>;
@group(0) @binding(3) var<storage, read> prev_pos: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> prev_normal: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> prev_caches: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> prev_radiance: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> pixel_cluster: array<u32>;
@group(0) @binding(8) var<storage, read> normals: array<vec2<u32>>;
@group(0) @binding(9) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> cache_count: array<u32>;
@group(0) @binding(11) var<storage, read_write> prev_pixel: array<u32>;
@group(0) @binding(12) var<storage, read_write> kept: array<atomic<u32>>;
@group(0) @binding(13) var<storage, read_write> cache_pos: array<vec4<f32>>;
@group(0) @binding(14) var<storage, read_write> cache_pixel: array<vec2<u32>>;
@group(0) @binding(15) var<storage, read_write> cache_normal: array<vec4<f32>>;
@group(0) @binding(16) var<storage, read_write> caches: array<vec4<f32>>;
@group(0) @binding(17) var<storage, read_write> cache_radiance: array<vec4<f32>>;
@group(0) @binding(18) var<storage, read_write> cache_args: array<atomic<u32>>;

const NONE: u32 = 0xffffffffu;

fn linear(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

@compute @workgroup_size(64)
fn clear(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = linear(gid, groups);
    if (c < arrayLength(&kept)) {
        atomicStore(&kept[c], 0u);
    }
}

@compute @workgroup_size(64)
fn claim(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(gid, groups);
    if (i >= min(prev_count[0], arrayLength(&prev_pixel))) {
        return;
    }
    let x = prev_pos[i].xyz;
    let d = x - frame.eye.xyz;
    let z = dot(d, frame.forward.xyz);
    prev_pixel[i] = NONE;
    // Negated comparisons: where NaN survives (WGSL may assume it does not), it is neither in front
    // nor on the image; the mirror accepts any outcome for non-finite inputs.
    if (!(z > 0.0)) {
        return;
    }
    let r = frame.right.xyz;
    let u = frame.up.xyz;
    let w = f32(frame.size.x);
    let h = f32(frame.size.y);
    let fx = (dot(d, r) / (z * dot(r, r)) + 1.0) * 0.5 * w;
    let fy = (1.0 - dot(d, u) / (z * dot(u, u))) * 0.5 * h;
    if (!(fx >= 0.0 && fx < w && fy >= 0.0 && fy < h)) {
        return;
    }
    let p = min(u32(fy), frame.size.y - 1u) * frame.size.x + min(u32(fx), frame.size.x - 1u);
    if (p >= arrayLength(&pixel_cluster)) {
        return;
    }
    prev_pixel[i] = p;
    let c = pixel_cluster[p];
    if (c >= arrayLength(&kept) || positions[p].w != 1.0 || !oct_is_geometry(normals[p])) {
        return;
    }
    let np = vec3<f32>(oct_unpack(normals[p])) * (1.0 / 32767.0);
    if (!(dot(np, prev_normal[i].xyz) >= reuse_params.min_cos)) {
        return;
    }
    let e = positions[p].xyz - x;
    let reach = reuse_params.reach * 2.0 * z * sqrt(dot(u, u)) / h;
    if (!(dot(e, e) <= reach * reach)) {
        return;
    }
    atomicMax(&kept[c], NONE - i);
}

@compute @workgroup_size(64)
fn keep(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = linear(gid, groups);
    if (c >= min(cache_count[0], arrayLength(&kept))) {
        return;
    }
    let k = atomicLoad(&kept[c]);
    if (k == 0u) {
        return;
    }
    let i = NONE - k;
    let x = prev_pos[i].xyz;
    let n = prev_normal[i].xyz;
    let p = prev_pixel[i];
    cache_pos[c] = vec4<f32>(x, cache_pos[c].w);
    cache_pixel[c] = vec2<u32>(p % frame.size.x, p / frame.size.x);
    cache_normal[c] = vec4<f32>(n, 0.0);
    let carry = reuse_params.carry != 0u;
    caches[2u * c] = prev_caches[2u * i];
    caches[2u * c + 1u] = vec4<f32>(prev_caches[2u * i + 1u].xyz, select(0.0, 1.0, carry));
    if (carry) {
        let t = reuse_params.texels;
        let src = arrayLength(&prev_radiance);
        let dst = arrayLength(&cache_radiance);
        for (var k = 0u; k < t; k++) {
            if (i * t + k < src && c * t + k < dst) {
                cache_radiance[c * t + k] = prev_radiance[i * t + k];
            }
        }
    }
    atomicAdd(&cache_args[2], 1u);
}
