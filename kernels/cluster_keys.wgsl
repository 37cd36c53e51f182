// cluster_keys — each pixel's cluster key from its screen tile, the tile axis its normal is best aligned
// with, and its depth slice (Rehfeld et al. 2014, 3.2; depth slices as in clustered shading).
// Mirror: cpu_mirror/src/cluster_keys.rs. Uses kernels/common/octahedral_bins.wgsl.
//
// Inputs: normals (snorm16 packed, background = geometry 0; the host maps non-finite depths and
// normals to background), depth (view depth per pixel), tile_axes[t] = (a0, a1, a2, pixels) from
// histogram_axes, axis_dirs[b] = bin-centre direction of bin b quantised to snorm10 (host table),
// slice_bounds = slices - 1 ascending depth bounds (host: exponential between near and far).
// key = (tile * 3 + axis) * slices + slice, background 0xffffffff (sorts last), where
//   axis  = argmax_k dot(normal_snorm16, axis_dirs[a_k]) in i32 (|dot| <= 3 * 32767 * 511), lowest k on
//           ties;
//   slice = number of bounds <= depth (comparisons only).
// Integers and comparisons: exact. One invocation per pixel, row-major.

struct KeyParams {
    width: u32,
    height: u32,
    tile: u32,
    tiles_x: u32,
    slices: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: KeyParams;
@group(0) @binding(1) var<storage, read> normals: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> depth: array<f32>;
@group(0) @binding(3) var<storage, read> tile_axes: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read> axis_dirs: array<vec4<i32>>;
@group(0) @binding(5) var<storage, read> slice_bounds: array<f32>;
@group(0) @binding(6) var<storage, read_write> keys: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= params.width * params.height) {
        return;
    }
    let w = normals[i];
    if (!oct_is_geometry(w)) {
        keys[i] = 0xffffffffu;
        return;
    }
    let q = oct_unpack(w);
    let x = i % params.width;
    let y = i / params.width;
    let tile = (y / params.tile) * params.tiles_x + x / params.tile;
    let axes = tile_axes[tile];
    var best = 0u;
    var best_dot = -2147483647 - 1;
    for (var k = 0u; k < 3u; k = k + 1u) {
        let a = axis_dirs[axes[k]];
        let d = q.x * a.x + q.y * a.y + q.z * a.z;
        if (d > best_dot) {
            best_dot = d;
            best = k;
        }
    }
    var slice = 0u;
    let z = depth[i];
    for (var b = 0u; b + 1u < params.slices; b = b + 1u) {
        if (z >= slice_bounds[b]) {
            slice = slice + 1u;
        }
    }
    keys[i] = (tile * 3u + best) * params.slices + slice;
}
