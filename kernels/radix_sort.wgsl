// radix_sort — stable sort of (key, value) pairs by key: least significant digit first, 4-bit digits,
// three entry points per digit pass (CPRC 3.2 sorts pixels by cluster key; wgpu has no sort of its own).
// Mirror: cpu_mirror/src/radix_sort.rs (each entry point mirrored, and the whole sort).
//
// One pass over the digit at bit params.shift:
//   count_digits: one invocation per block of 256 elements counts its digits in order:
//                 counts[d * blocks + b] (digit-major)
//   scan_blocks, scan_partials_serial, scan_add_partials (kernels/common/block_scan.wgsl): exclusive
//                 prefix sum of the 16 * ceil(n / 256) counts, in place
//   scatter:      one invocation per block walks its elements in order and writes each to the next
//                 slot of its digit: dst[counts[d * blocks + b]++] — stable, hence a unique result
// Digits are taken of key & params.key_mask (the low key_bits bits), so the sort is by exactly those
// bits in ceil(key_bits / 4) passes (the host skips the rest); the stored keys are not changed.
// Passes ping-pong between two (keys, values) buffer pairs. Integers only: exact.

struct SortParams {
    count: u32,
    shift: u32,
    blocks: u32,
    key_mask: u32,
}

@group(0) @binding(0) var<uniform> params: SortParams;
@group(0) @binding(1) var<storage, read> src_keys: array<u32>;
@group(0) @binding(2) var<storage, read> src_values: array<u32>;
@group(0) @binding(3) var<storage, read_write> dst_keys: array<u32>;
@group(0) @binding(4) var<storage, read_write> dst_values: array<u32>;
@group(0) @binding(5) var<storage, read_write> counts: array<u32>;

const BLOCK: u32 = 256u;

fn block_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

@compute @workgroup_size(64)
fn count_digits(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let b = block_index(gid, groups);
    if (b >= params.blocks) {
        return;
    }
    var c: array<u32, 16>;
    let end = min((b + 1u) * BLOCK, params.count);
    for (var i = b * BLOCK; i < end; i = i + 1u) {
        let d = ((src_keys[i] & params.key_mask) >> params.shift) & 15u;
        c[d] = c[d] + 1u;
    }
    for (var d = 0u; d < 16u; d = d + 1u) {
        counts[d * params.blocks + b] = c[d];
    }
}

// The scan of counts (common/block_scan.wgsl).
fn scan_len() -> u32 {
    return 16u * params.blocks;
}

fn scan_load(i: u32) -> u32 {
    return counts[i];
}

fn scan_store(i: u32, v: u32) {
    counts[i] = v;
}

fn scan_total(total: u32) {
}

@compute @workgroup_size(64)
fn scatter(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let b = block_index(gid, groups);
    if (b >= params.blocks) {
        return;
    }
    var next: array<u32, 16>;
    for (var d = 0u; d < 16u; d = d + 1u) {
        next[d] = counts[d * params.blocks + b];
    }
    let end = min((b + 1u) * BLOCK, params.count);
    for (var i = b * BLOCK; i < end; i = i + 1u) {
        let k = src_keys[i];
        let d = ((k & params.key_mask) >> params.shift) & 15u;
        dst_keys[next[d]] = k;
        dst_values[next[d]] = src_values[i];
        next[d] = next[d] + 1u;
    }
}
