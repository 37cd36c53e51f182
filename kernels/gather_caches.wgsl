// gather_caches — gathering radiance caches per pixel with the weights of Rehfeld et al. 2014, 3.3:
//   w_w = max(0, 1 - |p_w - c_w|^2 / r_w^2)   world space, r_w = cache_pos[c].w (each cache's radius)
//   w_s = max(0, 1 - |p_s - c_s|^2 / r_s^2)   screen space in pixels, r_s = params.radius_px (integer)
//   w   = min(w_w, w_s)
// over the caches of the tiles within r_s (caches are stored tile by tile; tile_ranges[t] = [start,
// end)), visited tile row by tile row, caches in index order. Mirror: cpu_mirror/src/gather_caches.rs.
// Outputs per pixel: gathered = sum(w v) / sum(w) of the per-cache payload v (the caches' radiance once
// they exist; 0 when sum(w) <= 1e-6), weight_sum = sum(w), in_radius = caches with |p_s - c_s| < r_s
// (an integer test on pixel coordinates: exact). Background pixels (positions.w != 1) gather nothing.
// Accuracy: per-element bounds from the WGSL rules (see gather_bound in the mirror).

struct GatherParams {
    width: u32,
    height: u32,
    tile: u32,
    tiles_x: u32,
    tiles_y: u32,
    radius_px: u32,
    _pad0: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: GatherParams;
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> cache_pos: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> cache_pixel: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read> cache_payload: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> tile_ranges: array<vec2<u32>>;
@group(0) @binding(6) var<storage, read_write> gathered: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> weight_sum: array<f32>;
@group(0) @binding(8) var<storage, read_write> in_radius: array<u32>;

const MIN_WEIGHT_SUM: f32 = 1.0e-6;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= params.width * params.height) {
        return;
    }
    let pos = positions[i];
    if (pos.w != 1.0) {
        gathered[i] = vec4<f32>(0.0);
        weight_sum[i] = 0.0;
        in_radius[i] = 0u;
        return;
    }
    let x = i32(i % params.width);
    let y = i32(i / params.width);
    let reach = i32((params.radius_px + params.tile - 1u) / params.tile);
    let tx = x / i32(params.tile);
    let ty = y / i32(params.tile);
    let r2 = i32(params.radius_px * params.radius_px);
    var acc = vec4<f32>(0.0);
    var wsum = 0.0;
    var count = 0u;
    for (var ny = max(ty - reach, 0); ny <= min(ty + reach, i32(params.tiles_y) - 1); ny = ny + 1) {
        for (var nx = max(tx - reach, 0); nx <= min(tx + reach, i32(params.tiles_x) - 1); nx = nx + 1) {
            let range = tile_ranges[u32(ny) * params.tiles_x + u32(nx)];
            for (var c = range.x; c < range.y; c = c + 1u) {
                let cpx = vec2<i32>(cache_pixel[c]);
                let dx = cpx.x - x;
                let dy = cpx.y - y;
                let ds2 = dx * dx + dy * dy;
                if (ds2 >= r2) {
                    continue;
                }
                count = count + 1u;
                let cp = cache_pos[c];
                let d = pos.xyz - cp.xyz;
                let dw2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
                let ww = max(1.0 - dw2 / (cp.w * cp.w), 0.0);
                let ws = max(1.0 - f32(ds2) / f32(r2), 0.0);
                let w = min(ww, ws);
                acc = acc + w * cache_payload[c];
                wsum = wsum + w;
            }
        }
    }
    if (wsum > MIN_WEIGHT_SUM) {
        gathered[i] = acc / wsum;
    } else {
        gathered[i] = vec4<f32>(0.0);
    }
    weight_sum[i] = wsum;
    in_radius[i] = count;
}
