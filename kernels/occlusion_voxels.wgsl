// occlusion_voxels — LRSM's binary occlusion voxels and their mips (Sugihara et al. 2014, sections 3.2
// and 5: one byte per voxel, no atomics). Mirror: cpu_mirror/src/occlusion_voxels.rs. Declaration:
// src/kernels/occlusion_voxels.rs.
//
// 8-bit storage is not core WebGPU: four voxels per u32 word, voxels in 3D Morton order, byte k of word
// w = voxel 4w + k. The children of parent voxel P are then words 2P and 2P + 1 of the level below, and
// one invocation writes one whole word: no two invocations touch a word, so no atomics.
//   binarize (level 0): byte 255 where the voxelized alpha vox_colour[v].w > 0, else 0 (NaN is empty).
//   reduce (level k from k - 1): byte = (sum of its 8 child bytes + 4) >> 3, the mean rounded half up =
//     255 x the solid fraction of the block (volume coverage: the paper's mipmapped occlusion).
//   reduce_surface (the same, CPRC's surface coverage; an lrsm option): byte = min(255, (sum + 2) >> 2),
//     a quarter of the sum rounded half up, capped: a plane through the block (4 of 8 children) stays
//     opaque, where volume coverage halves a one-voxel wall per level.
// Level buffers hold max(voxels / 4, 8) words; child words past the source's end read as 0.
// Accuracy: integers only; exact.

@group(0) @binding(0) var<storage, read> vox_colour: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> occ0: array<u32>;
@group(0) @binding(2) var<storage, read> src: array<u32>;
@group(0) @binding(3) var<storage, read_write> dst: array<u32>;

@compute @workgroup_size(64)
fn binarize(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let w = gid.x + gid.y * groups.x * 64u;
    if (w >= arrayLength(&occ0)) {
        return;
    }
    var word = 0u;
    for (var k = 0u; k < 4u; k++) {
        let v = 4u * w + k;
        if (v < arrayLength(&vox_colour) && vox_colour[v].w > 0.0) {
            word = word | (255u << (8u * k));
        }
    }
    occ0[w] = word;
}

fn byte_sum(w: u32) -> u32 {
    return (w & 255u) + ((w >> 8u) & 255u) + ((w >> 16u) & 255u) + (w >> 24u);
}

// Word q of the parent level from its children in `src`, by volume (surface = false) or surface coverage.
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
        var b = (sum + 4u) >> 3u;
        if (surface) {
            b = min((sum + 2u) >> 2u, 255u);
        }
        word = word | (b << (8u * k));
    }
    return word;
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
