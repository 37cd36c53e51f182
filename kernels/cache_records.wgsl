// cache_records — the radiance caches' records from the clusters and the pixels cache_placement
// picked (Rehfeld et al. 2014, 3.2: one cache per cluster), and the indirect dispatch arguments of
// the per-texel cache stages: creation, pre-convolution and the gather follow the distribution on the
// GPU. Mirror: cpu_mirror/src/cache_records.rs (its module comment defines every output).
// Uses kernels/common/octahedral_bins.wgsl (oct_is_geometry, oct_unpack).
//
// One invocation per cache slot c < capacity: count = min(cluster_count, capacity) caches. Invocation
// 0 also writes cache_count (copied into the cache stages' uniform blocks) and cache_args (count, clusters
// past the capacity, then per stage the workgroups (x, y, 1) of 64 covering count * per invocations).
// Accuracy: pixels, ranges, counts and arguments exact (integers); positions copied; the normal,
// r_w and the creation origin within the mirror's per-element bounds.

// Mirror: vxgi_cpu_mirror::cache_records::RecordsParams.
struct RecordsParams {
    width: u32,
    tile: u32,
    tiles_x: u32,
    capacity: u32,
    per: vec3<u32>,
    max_groups: u32,
    offset: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct Cluster {
    start_count_key: vec4<u32>,
    normal_sum: vec4<i32>,
    bbox_min: vec4<f32>,
    bbox_max: vec4<f32>,
}

@group(0) @binding(0) var<uniform> records_params: RecordsParams;
@group(0) @binding(1) var<storage, read> clusters: array<Cluster>;
@group(0) @binding(2) var<storage, read> cluster_count: array<u32>;
@group(0) @binding(3) var<storage, read> picks: array<u32>;
@group(0) @binding(4) var<storage, read> normals: array<vec2<u32>>;
@group(0) @binding(5) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> cache_pos: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> cache_pixel: array<vec2<u32>>;
@group(0) @binding(8) var<storage, read_write> cache_normal: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> caches: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> tile_ranges: array<vec2<u32>>;
@group(0) @binding(11) var<storage, read_write> cache_count: array<u32>;
@group(0) @binding(12) var<storage, read_write> cache_args: array<u32>;

fn groups_for(n: u32) -> vec3<u32> {
    let g = (n + 63u) / 64u;
    let x = min(g, records_params.max_groups);
    var y = 0u;
    if (x > 0u) {
        y = (g + x - 1u) / x;
    }
    return vec3<u32>(x, y, 1u);
}

fn tile_of(pixel: u32) -> u32 {
    let x = pixel % records_params.width;
    let y = pixel / records_params.width;
    return (y / records_params.tile) * records_params.tiles_x + x / records_params.tile;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = gid.x + gid.y * groups.x * 64u;
    let total = cluster_count[0];
    let count = min(total, records_params.capacity);
    if (c == 0u) {
        cache_count[0] = count;
        cache_args[0] = count;
        cache_args[1] = total - count;
        cache_args[2] = 0u;
        cache_args[3] = 0u;
        for (var k = 0u; k < 3u; k++) {
            let g = groups_for(count * records_params.per[k]);
            cache_args[4u * (k + 1u)] = g.x;
            cache_args[4u * (k + 1u) + 1u] = g.y;
            cache_args[4u * (k + 1u) + 2u] = g.z;
            cache_args[4u * (k + 1u) + 3u] = 0u;
        }
    }
    if (c >= count) {
        return;
    }
    let p = picks[c];
    let cl = clusters[c];
    let d = cl.bbox_max.xyz - cl.bbox_min.xyz;
    let rw = max(1.5 * sqrt(dot(d, d)), 1.0e-3);
    let wp = positions[p];
    var q = vec3<i32>(0, 0, 32767);
    if (oct_is_geometry(normals[p])) {
        q = oct_unpack(normals[p]);
    }
    let v = vec3<f32>(q);
    let n = v / sqrt(dot(v, v));
    cache_pos[c] = vec4<f32>(wp.xyz, rw);
    cache_pixel[c] = vec2<u32>(p % records_params.width, p / records_params.width);
    cache_normal[c] = vec4<f32>(n, 0.0);
    caches[2u * c] = vec4<f32>(wp.xyz + n * records_params.offset, 0.0);
    caches[2u * c + 1u] = vec4<f32>(n, 0.0);
    let t = tile_of(p);
    if (c == 0u || tile_of(picks[c - 1u]) != t) {
        tile_ranges[t].x = c;
    }
    if (c + 1u == count || tile_of(picks[c + 1u]) != t) {
        tile_ranges[t].y = c + 1u;
    }
}
