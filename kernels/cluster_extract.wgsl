// cluster_extract — clusters from pixels sorted by cluster key (Rehfeld et al. 2014, 3.2): heads by
// neighbour comparison, cluster indices by an exclusive prefix sum, per-cluster records.
// Mirror: cpu_mirror/src/cluster_extract.rs. Uses kernels/common/octahedral_bins.wgsl.
//
// Inputs: keys / pixels = the (key, pixel index) pairs sorted by radix_sort (background keys
// 0xffffffff last), normals (snorm16 packed), positions (world position per pixel, xyz).
// Entry points, in order:
//   mark_heads:     heads[i] = 1 where i == 0 or keys[i] != keys[i - 1], and keys[i] is not background
//   scan_blocks, scan_partials_serial, scan_add_partials (kernels/common/block_scan.wgsl): heads ->
//                   exclusive prefix sum in place; cluster_count[0] = total
//   build_clusters: one invocation per sorted position that starts a cluster: walks the run of equal
//                   keys, writes clusters[c] = (start, count, key), sum of snorm16 normals (i32: exact,
//                   |sum| <= 4096 * 32767 for tiles up to 64 x 64), bbox min/max of positions (exact),
//                   and pixel_cluster[pixel] = c for every pixel of the run.
// All integer or min/max: exact. Background pixels keep pixel_cluster = 0xffffffff (host-initialised).

struct Cluster {
    start_count_key: vec4<u32>,
    normal_sum: vec4<i32>,
    bbox_min: vec4<f32>,
    bbox_max: vec4<f32>,
}

struct ExtractParams {
    count: u32,
}

@group(0) @binding(0) var<uniform> params: ExtractParams;
@group(0) @binding(1) var<storage, read> keys: array<u32>;
@group(0) @binding(2) var<storage, read> pixels: array<u32>;
@group(0) @binding(3) var<storage, read> normals: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> heads: array<u32>;
@group(0) @binding(6) var<storage, read_write> cluster_count: array<u32>;
@group(0) @binding(7) var<storage, read_write> clusters: array<Cluster>;
@group(0) @binding(8) var<storage, read_write> pixel_cluster: array<u32>;

fn linear(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

@compute @workgroup_size(64)
fn mark_heads(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(gid, groups);
    if (i >= params.count) {
        return;
    }
    let k = keys[i];
    var head = k != 0xffffffffu;
    if (i > 0u) {
        head = head && k != keys[i - 1u];
    }
    heads[i] = select(0u, 1u, head);
}

// The scan of heads (common/block_scan.wgsl).
fn scan_len() -> u32 {
    return params.count;
}

fn scan_load(i: u32) -> u32 {
    return heads[i];
}

fn scan_store(i: u32, v: u32) {
    heads[i] = v;
}

fn scan_total(total: u32) {
    cluster_count[0] = total;
}

@compute @workgroup_size(64)
fn build_clusters(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(gid, groups);
    if (i >= params.count) {
        return;
    }
    let k = keys[i];
    if (k == 0xffffffffu || (i > 0u && keys[i - 1u] == k)) {
        return;
    }
    let c = heads[i];
    var sum = vec3<i32>(0);
    var lo = vec3<f32>(1.0e38);
    var hi = vec3<f32>(-1.0e38);
    var first = true;
    var j = i;
    while (j < params.count && keys[j] == k) {
        let p = pixels[j];
        let w = normals[p];
        if (oct_is_geometry(w)) {
            sum = sum + oct_unpack(w);
        }
        let x = positions[p].xyz;
        if (first) {
            lo = x;
            hi = x;
            first = false;
        } else {
            lo = min(lo, x);
            hi = max(hi, x);
        }
        pixel_cluster[p] = c;
        j = j + 1u;
    }
    clusters[c] = Cluster(vec4<u32>(i, j - i, k, 0u), vec4<i32>(sum, 0), vec4<f32>(lo, 0.0), vec4<f32>(hi, 0.0));
}
