// tile_normal_histogram — per screen tile, the 8x8 octahedral histogram of the pixels' normals and its
// binomial 3x3 blur ([1 2 1] x [1 2 1], a discrete Gaussian) with the octahedral border folding
// (Rehfeld et al. 2014, "Clustered Pre-convolved Radiance Caching", 3.2 "Clustered Cache Distribution").
// Mirror: cpu_mirror/src/tile_normal_histogram.rs. Uses kernels/common/octahedral_bins.wgsl.
//
// Input: normals[y * width + x] = snorm16-quantised normal packed as in octahedral_bins.wgsl (background
// pixels have geometry 0 and are not counted). Tiles of params.tile^2 pixels (1..=64), tiles_x per row;
// edge tiles of images that are not a multiple of the tile count only their pixels inside the image.
// Output per tile t (tile-major, 64 bins each): histogram[64 t + b] raw counts, blurred[64 t + b]
// = sum over the 3x3 neighbourhood (wrapped) of count * (2 - |du|) (2 - |dv|).
// One workgroup of 64 invocations per tile (workgroup (tx, ty)); counts by workgroup atomics
// (integer adds commute: the result is exact whatever the order).

struct HistogramParams {
    width: u32,
    height: u32,
    tile: u32,
    tiles_x: u32,
}

@group(0) @binding(0) var<uniform> params: HistogramParams;
@group(0) @binding(1) var<storage, read> normals: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read_write> histogram: array<u32>;
@group(0) @binding(3) var<storage, read_write> blurred: array<u32>;

var<workgroup> counts: array<atomic<u32>, 64>;

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    atomicStore(&counts[lid], 0u);
    workgroupBarrier();
    let pixels = params.tile * params.tile;
    for (var k = lid; k < pixels; k = k + 64u) {
        let x = wg.x * params.tile + k % params.tile;
        let y = wg.y * params.tile + k / params.tile;
        if (x < params.width && y < params.height) {
            let w = normals[y * params.width + x];
            if (oct_is_geometry(w)) {
                atomicAdd(&counts[oct_bin(oct_unpack(w))], 1u);
            }
        }
    }
    workgroupBarrier();
    let tile = wg.y * params.tiles_x + wg.x;
    histogram[tile * OCT_BIN_COUNT + lid] = atomicLoad(&counts[lid]);
    let u = i32(lid) % OCT_BINS;
    let v = i32(lid) / OCT_BINS;
    var sum = 0u;
    for (var dv = -1; dv <= 1; dv = dv + 1) {
        for (var du = -1; du <= 1; du = du + 1) {
            let n = oct_wrap(vec2<i32>(u + du, v + dv));
            sum = sum + atomicLoad(&counts[n.y * OCT_BINS + n.x]) * u32((2 - abs(du)) * (2 - abs(dv)));
        }
    }
    blurred[tile * OCT_BIN_COUNT + lid] = sum;
}
