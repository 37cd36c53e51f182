// The sparse voxel octree's brick pool as its readers bind it where it fits one storage binding
// (svo_anisotropic, svo_cone_trace); past one, common/svo_bricks.wgsl, through the same function.
@group(0) @binding(12) var<storage, read> bricks: array<u32>;

// The four words of a brick voxel from its first, w.
fn brick_words(w: u32) -> vec4<u32> {
    return vec4<u32>(bricks[w], bricks[w + 1u], bricks[w + 2u], bricks[w + 3u]);
}
