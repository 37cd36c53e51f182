// common/svo_node.wgsl — the sparse voxel octree's node layout and descent, shared by
// sparse_voxel_octree.wgsl (which builds it) and svo_sample.wgsl (which reads it). The including kernel
// declares the global `nodes: array<Node>` (read or read_write). Mirror: cpu_mirror/src/sparse_voxel_octree.rs
// (`Node`, `key`, `unkey`, `Octree::find`).

const NONE: u32 = 0xffffffffu;
// u32 words per brick: 27 voxels (i + 3j + 9k) x 4 channels.
const BRICK_WORDS: u32 = 108u;

struct Node {
    key: u32,
    parent: u32,
    child: u32,
    // -x, +x, -y, +y, -z, +z
    neighbours: array<u32, 6>,
}

// Level in bits 27..31, x, y, z in 9 bits each.
fn key_of(level: u32, c: vec3<u32>) -> u32 {
    return (level << 27u) | (c.x << 18u) | (c.y << 9u) | c.z;
}

fn coords_of(k: u32) -> vec3<u32> {
    return vec3<u32>((k >> 18u) & 511u, (k >> 9u) & 511u, k & 511u);
}

// The node at (level, c), descending from the root along child pointers; NONE where a tile is missing.
fn find(level: u32, c: vec3<u32>) -> u32 {
    var n = 0u;
    for (var k = 1u; k <= level; k = k + 1u) {
        let t = nodes[n].child;
        if (t == NONE) {
            return NONE;
        }
        let s = level - k;
        let b = (c >> vec3<u32>(s)) & vec3<u32>(1u);
        n = t * 8u + b.x + 2u * b.y + 4u * b.z;
    }
    return n;
}

fn voxel_index(v: vec3<u32>) -> u32 {
    return v.x + 3u * v.y + 9u * v.z;
}
