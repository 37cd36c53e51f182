// The sparse voxel octree's brick pool as its readers bind it (svo_sample,
// svo_anisotropic_windowed, svo_cone_trace_windowed, svo_bounce; sparse_voxel_octree.wgsl writes it the same way): up to five windows of one
// buffer, for a pool past one storage binding. Word i is in window i / L, L = arrayLength(&bricks):
// every window but the last is full, and L is a multiple of 4, so a voxel's four words share a
// window; the windows the pool does not reach are one unused word each.
@group(0) @binding(12) var<storage, read> bricks: array<u32>;
@group(0) @binding(21) var<storage, read> bricks_1: array<u32>;
@group(0) @binding(23) var<storage, read> bricks_2: array<u32>;
@group(0) @binding(24) var<storage, read> bricks_3: array<u32>;
@group(0) @binding(25) var<storage, read> bricks_4: array<u32>;

// The four words of a brick voxel from its first, w (a multiple of 4).
fn brick_words(w: u32) -> vec4<u32> {
    let l = arrayLength(&bricks);
    if (w < l) {
        return vec4<u32>(bricks[w], bricks[w + 1u], bricks[w + 2u], bricks[w + 3u]);
    }
    return brick_words_past(w, l);
}

// brick_words past the first window (a pool past one binding).
fn brick_words_past(w: u32, l: u32) -> vec4<u32> {
    var j = w - l;
    if (j < l) {
        return vec4<u32>(bricks_1[j], bricks_1[j + 1u], bricks_1[j + 2u], bricks_1[j + 3u]);
    }
    j -= l;
    if (j < l) {
        return vec4<u32>(bricks_2[j], bricks_2[j + 1u], bricks_2[j + 2u], bricks_2[j + 3u]);
    }
    j -= l;
    if (j < l) {
        return vec4<u32>(bricks_3[j], bricks_3[j + 1u], bricks_3[j + 2u], bricks_3[j + 3u]);
    }
    j -= l;
    return vec4<u32>(bricks_4[j], bricks_4[j + 1u], bricks_4[j + 2u], bricks_4[j + 3u]);
}
