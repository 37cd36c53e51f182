// gather_caches — evaluating radiance caches per pixel by gathering (Rehfeld et al. 2014, 3.3):
//   w_w = max(0, 1 - |p_w - c_w|^2 / r_w^2)   world space, r_w = cache_pos[c].w (each cache's radius)
//   w_s = max(0, 1 - |p_s - c_s|^2 / r_s^2)   screen space in pixels, r_s = params.radius_px (integer)
//   w_n = max(0, n_p . n_c)                  the cosine between the pixel's and the cache's normals
//   w   = min(w_w, w_s) w_n                 (params.angle = 1; 0: w = min(w_w, w_s), CPRC's alone)
// (PCRC weighs by distance and a maximum angle; CPRC's two weights have no angle term. A cache
// holds only the hemisphere above its normal, and a pixel whose normal leans away reads its
// horizon: w_n, the angle term, fades such a cache out continuously, to nothing at 90 degrees)
// over the caches of the tiles within r_s (caches are stored tile by tile; tile_ranges[t] = [start,
// end)), visited tile row by tile row, caches in index order. Each cache is evaluated for the pixel:
// diffuse = its cosine-folded irradiance map (cache_preconvolve) at the pixel's normal; glossy = its
// mip chain at the pixel's reflection vector, levels floor(lf) and floor(lf) + 1 blended (lf from the
// Phong lobe's solid angle, host; lf < 0: no glossy); both bilinear, clamp to edge, in the cache's
// hemi-octahedral frame (cache_creation; directions below the cache's horizon read its horizon).
// Mirror: cpu_mirror/src/gather_caches.rs.
// Outputs per pixel: diffuse, glossy = sum(w v) / sum(w) (rgb, 0; 0 when sum(w) <= 1e-6), weight_sum,
// in_radius = caches with |p_s - c_s| < r_s (an integer test on pixel coordinates: exact). Pixels with
// positions.w != 1 (background, back faces) gather nothing.
// Accuracy: per-element bounds from the WGSL rules (see gather_bound in the mirror).

struct GatherParams {
    width: u32,
    height: u32,
    tile: u32,
    tiles_x: u32,
    tiles_y: u32,
    radius_px: u32,
    res: u32,
    levels: u32,
    irr: u32,
    angle: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: GatherParams;
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> pixel_dirs: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> cache_pos: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> cache_pixel: array<vec2<u32>>;
@group(0) @binding(5) var<storage, read> cache_normal: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> cache_irradiance: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> cache_mips: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> tile_ranges: array<vec2<u32>>;
@group(0) @binding(9) var<storage, read_write> diffuse: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> glossy: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> weight_sum: array<f32>;
@group(0) @binding(12) var<storage, read_write> in_radius: array<u32>;

const MIN_WEIGHT_SUM: f32 = 1.0e-6;

// (u, v) of direction d in the hemi-octahedral frame of cache normal n.
fn hemi_uv(n: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    let basis = tangent_basis(n);
    let bt = basis.t;
    let bb = basis.b;
    let x = dot(d, bt);
    let y = dot(d, bb);
    let z = max(dot(d, n), 0.0);
    let s = abs(x) + abs(y) + z;
    if (s <= 0.0) {
        return vec2<f32>(0.0);
    }
    let px = x / s;
    let py = y / s;
    return vec2<f32>(px + py, px - py);
}

fn fetch(mips: bool, i: u32) -> vec4<f32> {
    if (mips) {
        return cache_mips[i];
    }
    return cache_irradiance[i];
}

// Bilinear lookup, clamp to edge, in the m x m map at base of cache_mips (mips) or cache_irradiance.
fn bilinear(mips: bool, base: u32, m: u32, uv: vec2<f32>) -> vec4<f32> {
    let top = f32(m - 1u);
    let f = clamp((uv * 0.5 + 0.5) * f32(m) - 0.5, vec2<f32>(0.0), vec2<f32>(top));
    let fl = floor(f);
    let i0 = vec2<u32>(fl);
    let i1 = min(i0 + 1u, vec2<u32>(m - 1u));
    let a = f - fl;
    let v00 = fetch(mips, base + i0.y * m + i0.x);
    let v10 = fetch(mips, base + i0.y * m + i1.x);
    let v01 = fetch(mips, base + i1.y * m + i0.x);
    let v11 = fetch(mips, base + i1.y * m + i1.x);
    let r0 = v00 * (1.0 - a.x) + v10 * a.x;
    let r1 = v01 * (1.0 - a.x) + v11 * a.x;
    return r0 * (1.0 - a.y) + r1 * a.y;
}

fn mip_offset(l: u32) -> u32 {
    var off = 0u;
    for (var j = 0u; j < l; j++) {
        let s = params.res >> j;
        off += s * s;
    }
    return off;
}

fn glossy_lookup(c: u32, uv: vec2<f32>, lf: f32) -> vec4<f32> {
    let top = params.levels - 1u;
    let l0 = min(floor(lf), f32(top));
    var a = 0.0;
    if (l0 < f32(top)) {
        a = lf - l0;
    }
    let l = u32(l0);
    let base = c * mip_offset(params.levels);
    let v0 = bilinear(true, base + mip_offset(l), params.res >> l, uv);
    if (a <= 0.0) {
        return v0;
    }
    let v1 = bilinear(true, base + mip_offset(l + 1u), params.res >> (l + 1u), uv);
    return v0 * (1.0 - a) + v1 * a;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= params.width * params.height) {
        return;
    }
    let pos = positions[i];
    if (pos.w != 1.0) {
        diffuse[i] = vec4<f32>(0.0);
        glossy[i] = vec4<f32>(0.0);
        weight_sum[i] = 0.0;
        in_radius[i] = 0u;
        return;
    }
    let nrm = pixel_dirs[2u * i].xyz;
    let refl = pixel_dirs[2u * i + 1u];
    let x = i32(i % params.width);
    let y = i32(i / params.width);
    let reach = i32((params.radius_px + params.tile - 1u) / params.tile);
    let tx = x / i32(params.tile);
    let ty = y / i32(params.tile);
    let r2 = i32(params.radius_px * params.radius_px);
    let irr_len = params.irr * params.irr;
    var dacc = vec4<f32>(0.0);
    var gacc = vec4<f32>(0.0);
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
                let cn = cache_normal[c].xyz;
                var w = min(ww, ws);
                if (params.angle != 0u) {
                    w = w * max(dot(nrm, cn), 0.0);
                }
                let vd = bilinear(false, c * irr_len, params.irr, hemi_uv(cn, nrm));
                var vg = vec4<f32>(0.0);
                if (refl.w >= 0.0) {
                    vg = glossy_lookup(c, hemi_uv(cn, refl.xyz), refl.w);
                }
                dacc = dacc + w * vd;
                gacc = gacc + w * vg;
                wsum = wsum + w;
            }
        }
    }
    if (wsum > MIN_WEIGHT_SUM) {
        diffuse[i] = dacc / wsum;
        glossy[i] = gacc / wsum;
    } else {
        diffuse[i] = vec4<f32>(0.0);
        glossy[i] = vec4<f32>(0.0);
    }
    weight_sum[i] = wsum;
    in_radius[i] = count;
}
