// occlusion_voxels — the mips of LRSM's binary occlusion voxels (Sugihara et al. 2014, sections 3.2 and
// 5), no atomics. Mirror: cpu_mirror/src/occlusion_voxels.rs. Declaration: src/kernels/occlusion_voxels.rs.
//
// Voxels in 3D Morton order. Level 0 is binary, one bit per voxel (written by voxelize.wgsl's
// occupancy_bits): word w bit k = voxel 32w + k. The paper stores a byte per voxel; a bit holds the
// same value in an eighth of the memory, so 512^3 fits one storage binding. Levels k >= 1 hold a byte
// per voxel (8-bit storage is not core WebGPU: four per u32 word, byte b of word w = voxel 4w + b).
// The children of parent voxel P are voxels 8P .. 8P + 7 of the level below: byte P mod 4 of bit word
// P / 4 at level 0, words 2P and 2P + 1 above. One invocation writes one whole word: no atomics.
//   reduce_bits (level 1 from level 0's bits), reduce (level k >= 2 from k - 1): byte = (sum of its 8
//     child bytes + 4) >> 3 (a set bit counts 255), the mean rounded half up = 255 x the solid fraction
//     of the block (volume coverage: the paper's mipmapped occlusion).
//   reduce_bits_surface, reduce_surface (CPRC's surface coverage; an lrsm option): byte =
//     min(255, (sum + 2) >> 2), a quarter of the sum rounded half up, capped: a plane through the block
//     (4 of 8 children) stays opaque, where volume coverage halves a one-voxel wall per level.
// Level buffers hold at least 8 words; words past the source's end read as 0.
// Accuracy: integers only; exact.

@group(0) @binding(0) var<storage, read> src: array<u32>;
@group(0) @binding(1) var<storage, read_write> dst: array<u32>;

fn parent_byte(sum: u32, surface: bool) -> u32 {
    if (surface) {
        return min((sum + 2u) >> 2u, 255u);
    }
    return (sum + 4u) >> 3u;
}

// Word q of level 1 from bit word q of level 0 (its four parents' 32 children).
fn reduce_bits_word(q: u32, surface: bool) -> u32 {
    var bits = 0u;
    if (q < arrayLength(&src)) {
        bits = src[q];
    }
    var word = 0u;
    for (var k = 0u; k < 4u; k++) {
        let sum = 255u * countOneBits((bits >> (8u * k)) & 255u);
        word = word | (parent_byte(sum, surface) << (8u * k));
    }
    return word;
}

fn byte_sum(w: u32) -> u32 {
    return (w & 255u) + ((w >> 8u) & 255u) + ((w >> 16u) & 255u) + (w >> 24u);
}

// Word q of the parent level from its children's bytes in `src`.
fn reduce_word(q: u32, surface: bool) -> u32 {
    var word = 0u;
    for (var k = 0u; k < 4u; k++) {
        let c = 2u * (4u * q + k);
        var sum = 0u;
        for (var h = 0u; h < 2u; h++) {
            if (c + h < arrayLength(&src)) {
                sum = sum + byte_sum(src[c + h]);
            }
        }
        word = word | (parent_byte(sum, surface) << (8u * k));
    }
    return word;
}

@compute @workgroup_size(64)
fn reduce_bits(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let q = gid.x + gid.y * groups.x * 64u;
    if (q >= arrayLength(&dst)) {
        return;
    }
    dst[q] = reduce_bits_word(q, false);
}

@compute @workgroup_size(64)
fn reduce_bits_surface(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let q = gid.x + gid.y * groups.x * 64u;
    if (q >= arrayLength(&dst)) {
        return;
    }
    dst[q] = reduce_bits_word(q, true);
}

@compute @workgroup_size(64)
fn reduce(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let q = gid.x + gid.y * groups.x * 64u;
    if (q >= arrayLength(&dst)) {
        return;
    }
    dst[q] = reduce_word(q, false);
}

@compute @workgroup_size(64)
fn reduce_surface(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let q = gid.x + gid.y * groups.x * 64u;
    if (q >= arrayLength(&dst)) {
        return;
    }
    dst[q] = reduce_word(q, true);
}
