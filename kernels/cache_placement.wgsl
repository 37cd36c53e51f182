// cache_placement — placement score per clustered pixel and, per cluster, the pixel that becomes its
// radiance cache (Rehfeld et al. 2014, 3.2). Mirror: cpu_mirror/src/cache_placement.rs.
// Uses kernels/common/octahedral_bins.wgsl.
//
// Inputs from cluster_extract: clusters (start, count, key; snorm16 normal sum; bbox), cluster_count,
// pixel_cluster; the sorted pixel indices; G-buffer normals (snorm16 packed) and positions.
//   score_pixels (one invocation per pixel): for clustered pixels,
//     n_c = normalize(f32(normal_sum)), c = (bbox_min + bbox_max) * 0.5, n_p = q / 32767,
//     score = (dot(n_p, n_c) + dot(p - c, n_c)) / (1 + d_c),  d_c = length((p - c) - dot(p - c, n_c) n_c)
//     (0 for background pixels)
//   pick_caches (one invocation per cluster): the pixel of highest score, visiting the cluster's
//     pixels in sorted (= increasing pixel index) order with a strict >, so ties go to the lowest index.
// Output: scores (per pixel), picks[c] = chosen pixel index (the cache's position and normal are that
// pixel's).
// Accuracy: scores within a per-element bound (sqrt/division 2.5 ULP, dots in any order or fused);
// picks are argmaxes over those scores, so a pick is accepted when the mirror's score for it is within
// the bounds of the mirror's best (the mirror reports how often picks differ).

struct Cluster {
    start_count_key: vec4<u32>,
    normal_sum: vec4<i32>,
    bbox_min: vec4<f32>,
    bbox_max: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> clusters: array<Cluster>;
@group(0) @binding(1) var<storage, read> cluster_count: array<u32>;
@group(0) @binding(2) var<storage, read> pixel_cluster: array<u32>;
@group(0) @binding(3) var<storage, read> pixels: array<u32>;
@group(0) @binding(4) var<storage, read> normals: array<vec2<u32>>;
@group(0) @binding(5) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> scores: array<f32>;
@group(0) @binding(7) var<storage, read_write> picks: array<u32>;

fn linear(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

fn cluster_normal(cl: Cluster) -> vec3<f32> {
    let s = vec3<f32>(cl.normal_sum.xyz);
    let l2 = dot(s, s);
    if (l2 > 0.0) {
        return s * (1.0 / sqrt(l2));
    }
    return vec3<f32>(0.0, 0.0, 1.0);
}

@compute @workgroup_size(64)
fn score_pixels(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = linear(gid, groups);
    if (p >= arrayLength(&scores)) {
        return;
    }
    let c = pixel_cluster[p];
    if (c == 0xffffffffu) {
        scores[p] = 0.0;
        return;
    }
    let cl = clusters[c];
    var q = vec3<i32>(0);
    if (oct_is_geometry(normals[p])) {
        q = oct_unpack(normals[p]);
    }
    let np = vec3<f32>(q) * (1.0 / 32767.0);
    let nc = cluster_normal(cl);
    let centre = (cl.bbox_min.xyz + cl.bbox_max.xyz) * 0.5;
    let pc = positions[p].xyz - centre;
    let along = dot(pc, nc);
    let dc = length(pc - nc * along);
    scores[p] = (dot(np, nc) + along) / (1.0 + dc);
}

@compute @workgroup_size(64)
fn pick_caches(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = linear(gid, groups);
    if (c >= cluster_count[0]) {
        return;
    }
    let sck = clusters[c].start_count_key;
    var best = pixels[sck.x];
    for (var j = sck.x; j < sck.x + sck.y; j = j + 1u) {
        let p = pixels[j];
        if (scores[p] > scores[best]) {
            best = p;
        }
    }
    picks[c] = best;
}
