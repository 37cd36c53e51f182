// common/block_scan.wgsl — an exclusive prefix sum of u32 in place, in three passes, for kernels whose
// scan used to be one serial invocation (cluster_extract's heads, radix_sort's digit counts).
// One invocation may run at most 65535 loop iterations on lavapipe (llvmpipe's
// LP_MAX_TGSI_LOOP_ITERATIONS, shared by every loop of the shader): past it loops exit silently, so a
// serial scan of more elements returned a wrong sum (seen: 512x512 pixels, 390 clusters for 1402).
// Here no invocation loops more than SCAN_BLOCK times but the one over the block sums, which loops
// n / SCAN_BLOCK times: n up to 65535 * 1024 (67M) elements.
// The including kernel defines:
//   fn scan_len() -> u32                 elements to scan
//   fn scan_load(i: u32) -> u32
//   fn scan_store(i: u32, v: u32)
//   fn scan_total(total: u32)            called once with the sum of all elements
// and binds scan_partials (binding 15: ceil(n / SCAN_BLOCK) u32, scratch).
// Entry points, in order: scan_blocks (one invocation per block: exclusive scan of its elements, block
// sum to scan_partials), scan_partials_serial (one invocation: exclusive scan of the block sums;
// scan_total), scan_add_partials (one invocation per element: add its block's offset).
// Integer adds in a fixed order: exact, the same result as one serial scan.

const SCAN_BLOCK: u32 = 1024u;

@group(0) @binding(15) var<storage, read_write> scan_partials: array<u32>;

fn scan_linear(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

@compute @workgroup_size(64)
fn scan_blocks(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let b = scan_linear(gid, groups);
    let n = scan_len();
    if (b * SCAN_BLOCK >= n) {
        return;
    }
    var acc = 0u;
    let end = min((b + 1u) * SCAN_BLOCK, n);
    for (var i = b * SCAN_BLOCK; i < end; i = i + 1u) {
        let v = scan_load(i);
        scan_store(i, acc);
        acc = acc + v;
    }
    scan_partials[b] = acc;
}

@compute @workgroup_size(1)
fn scan_partials_serial() {
    let blocks = (scan_len() + SCAN_BLOCK - 1u) / SCAN_BLOCK;
    var acc = 0u;
    for (var b = 0u; b < blocks; b = b + 1u) {
        let v = scan_partials[b];
        scan_partials[b] = acc;
        acc = acc + v;
    }
    scan_total(acc);
}

@compute @workgroup_size(64)
fn scan_add_partials(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = scan_linear(gid, groups);
    if (i >= scan_len()) {
        return;
    }
    scan_store(i, scan_load(i) + scan_partials[i / SCAN_BLOCK]);
}
