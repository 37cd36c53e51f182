// screen_tiles — the work list of 8x8 screen tiles that hold a surface, with the indirect dispatch
// arguments of a pass over them (one 64-invocation workgroup per listed tile): the cone passes
// (common/cone_march.wgsl's `tile_pixel`) are dispatched over it, so empty tiles cost nothing.
// Mirror: cpu_mirror/src/screen_tiles.rs (its module comment is the full definition).
//
// One workgroup per tile, dispatched (tiles_x, tiles_y); a tile is listed when any pixel's G-buffer
// normal has w != 0, tested on the bits (NaN is a surface: WGSL lets a float comparison with NaN go
// either way, and a tile the cone pass might shade must not be dropped).
// `tile_list` = [groups_x, groups_y, groups_z, count, tile...], zero on entry: thread 0 of a listed
// tile appends it (atomic counter, so the order is free) and raises the arguments with atomicMax:
// groups_x = min(count, 65535), groups_y = ceil(count / 65535), groups_z = 1. `surface` is workgroup
// memory, which WGSL zero-initialises. Exact (integers). Uses kernels/common/scene_types.wgsl (Frame).

@group(0) @binding(0) var<storage, read> frame: Frame;
@group(0) @binding(4) var<storage, read> gb_normal: array<vec4<f32>>;
@group(0) @binding(30) var<storage, read_write> tile_list: array<atomic<u32>>;

const TILE: u32 = 8u;
const HEADER: u32 = 4u;
const MAX_GROUPS: u32 = 65535u;

var<workgroup> surface: atomic<u32>;

@compute @workgroup_size(8, 8)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>,
        @builtin(local_invocation_index) li: u32) {
    let w = frame.size.x;
    let h = frame.size.y;
    let tiles_x = (w + TILE - 1u) / TILE;
    let x = wg.x * TILE + lid.x;
    let y = wg.y * TILE + lid.y;
    if (x < w && y < h && (bitcast<u32>(gb_normal[x + y * w].w) & 0x7fffffffu) != 0u) {
        atomicOr(&surface, 1u);
    }
    workgroupBarrier();
    // Every invocation reaches the barrier; only thread 0 appends, and only within the tile grid.
    if (li == 0u && atomicLoad(&surface) != 0u && wg.x < tiles_x) {
        let k = atomicAdd(&tile_list[3], 1u);
        if (HEADER + k < arrayLength(&tile_list)) {
            atomicStore(&tile_list[HEADER + k], wg.x + wg.y * tiles_x);
        }
        atomicMax(&tile_list[0], min(k + 1u, MAX_GROUPS));
        atomicMax(&tile_list[1], k / MAX_GROUPS + 1u);
        atomicMax(&tile_list[2], 1u);
    }
}
