// common/cone_march.wgsl — the cone tracer shared by cone_trace.wgsl (dense radiance pyramid) and
// svo_cone_trace.wgsl (sparse voxel octree): frame, scene and G-buffer bindings, the cone parameters, the
// march (front-to-back, step-corrected alpha, AO falloff, early exit; options: mip clamp, level bias,
// correlated coverage) and the per-pixel entries: `main` (diffuse cones + one glossy cone) and
// `resolve` (interleaved cone sets: the window average, run only when cone.interleave > 1). The including kernel defines the volume the cones read:
//   fn sample_level(x: vec3<f32>, l: u32) -> vec4<f32>
// the pre-multiplied (L * alpha, alpha) at world point x, trilinear in whole mip level l (cell s0 * 2^l,
// l < cone.levels); sample_volume here blends two levels (quadrilinear; lf < 0 reads level 0, past the
// top the top level). The march reads each sample through
//   fn sample_cone(x: vec3<f32>, l: f32, diam: f32, d: vec3<f32>, tan_half: f32) -> vec4<f32>
// also the including kernel's: the dense and octree tracers return sample_volume(x, l); lrsm_cone_trace
// takes its radiance from the LRSMs at the sample's diameter, seen along -d. Mirror: cpu_mirror/src/cone_trace.rs (`march`,
// `shade_pixel`, generic over `Volume`). See cone_trace.wgsl's header for the full definition.
// Needs common/tangent_basis.wgsl (the pixel entry's cone frame) and common/scene_types.wgsl.

struct ConeParams {
    origin: vec4<f32>,   // xyz, w = s0
    ao_range: f32,
    ao_lambda: f32,
    diffuse_tan: f32,
    offset_voxels: f32,
    diffuse_cones: u32,
    levels: u32,
    side: u32,
    inv_s0: f32,
    mip_clamp: f32,     // 0 = off; else cap the level at log2(D / (mip_clamp s0)), D = distance from the origin plane
    step_factor: f32,   // step = diameter * step_factor (CPRC 4: 0.5); first sample half a step out
    depth_order: u32,   // the dense pyramid (common/pyramid.wgsl): 1 = depth-ordered blend
    level_bias: f32,    // in [-3, 0]: the sampled level is log2(d / s0) + level_bias (0 = the paper's)
    coverage_correlation: f32,  // c in [0, 1]: a sample adds (1 - c)(1 - A) a' + c max(0, a' - A) (0 = the paper's)
    interleave: u32,    // N: pixel classes (x % N) + N (y % N) trace disjoint cone subsets (0, 1 = off)
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<storage, read> frame: Frame;
@group(0) @binding(1) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(3) var<storage, read> gb_position: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> gb_normal: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> gb_triangle: array<u32>;
@group(0) @binding(6) var<storage, read> cone: ConeParams;
@group(0) @binding(7) var<storage, read> cone_dirs: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> indirect: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> ao: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read> gb_albedo: array<vec4<f32>>;
// Per pixel (sum w C, sum w occ) of the diffuse cones: irradiance before the albedo, and occlusion
// (what `resolve` averages).
@group(0) @binding(22) var<storage, read_write> irradiance: array<vec4<f32>>;
// screen_tiles.wgsl's work list: [groups_x, groups_y, groups_z, count, tile...]; the pixel entries are
// dispatched indirectly from its first three words, one workgroup per listed 8x8 tile.
@group(0) @binding(30) var<storage, read> tile_list: array<u32>;

const OPAQUE: f32 = 0.99609375;  // 1 - 1/256
const NO_PIXEL: u32 = 0xffffffffu;

// The pixel (row-major) that invocation `li` of indirect workgroup `wg` shades: tile k = wg.x + 65535
// wg.y of the list, its pixel (li % 8, li / 8); NO_PIXEL past the list's count or outside the image.
// Mirror: vxgi_cpu_mirror::screen_tiles::tile_pixel.
fn tile_pixel(wg: vec3<u32>, li: u32) -> u32 {
    let k = wg.x + wg.y * 65535u;
    if (k >= tile_list[3]) {
        return NO_PIXEL;
    }
    let t = tile_list[4u + k];
    let w = frame.size.x;
    let tiles_x = (w + 7u) / 8u;
    let x = (t % tiles_x) * 8u + li % 8u;
    let y = (t / tiles_x) * 8u + li / 8u;
    if (x >= w || y >= frame.size.y) {
        return NO_PIXEL;
    }
    return x + y * w;
}

fn sample_volume(x: vec3<f32>, lf_in: f32) -> vec4<f32> {
    let top = cone.levels - 1u;
    let lf = max(lf_in, 0.0);
    let l0 = floor(lf);
    if (l0 >= f32(top)) {
        return sample_level(x, top);
    }
    let a = lf - l0;
    let l = u32(l0);
    return sample_level(x, l) * (1.0 - a) + sample_level(x, l + 1u) * a;
}

struct ConeOut {
    radiance: vec3<f32>,
    occlusion: f32,
}

fn march(o: vec3<f32>, d: vec3<f32>, tan_half: f32, cos_n: f32) -> ConeOut {
    let s0 = cone.origin.w;
    let max_dist = f32(cone.side) * s0 * 1.7320508;
    let sf = cone.step_factor;
    let grow = 1.0 + 2.0 * sf * tan_half;
    let dl = log2(grow);
    var diam = 0.75 * s0;
    var lf = -0.4150375;
    var t = diam * (0.5 * sf);
    var c_acc = vec3<f32>(0.0);
    var a_acc = 0.0;
    var occ = 0.0;
    let off = cone.offset_voxels * s0;
    let corr = cone.coverage_correlation;
    while (t <= max_dist && a_acc < OPAQUE) {
        var l = lf + cone.level_bias;
        if (cone.mip_clamp > 0.0) {
            let plane = off + t * max(cos_n, 0.0);
            l = min(l, log2(plane * cone.inv_s0 / cone.mip_clamp));
        }
        let s = sample_cone(o + d * t, l, diam, d, tan_half);
        let step = diam * sf;
        var ratio = sf * min(diam * cone.inv_s0, 1.0);
        if (l < lf) {
            ratio = step * cone.inv_s0 / exp2(max(l, 0.0));
        }
        let a = clamp(s.w, 0.0, 1.0);
        var a2 = 0.0;
        var c2 = vec3<f32>(0.0);
        if (a > 0.0) {
            let keep = 1.0 - a;
            var kept = 0.0;
            if (keep > 0.0) {
                kept = pow(keep, ratio);
            }
            a2 = 1.0 - kept;
            c2 = s.xyz * (a2 / a);
        }
        var vis = 1.0 - a_acc;
        if (corr > 0.0 && a2 > 0.0) {
            // Correlated coverage: the share of the cone this sample adds, over a2.
            vis = (1.0 - corr) * vis + corr * (max(a2 - a_acc, 0.0) / a2);
        }
        c_acc += c2 * vis;
        if (t <= cone.ao_range) {
            occ += vis * a2 / (1.0 + cone.ao_lambda * t);
        }
        a_acc += vis * a2;
        t += step;
        diam *= grow;
        lf += dl;
    }
    return ConeOut(c_acc, occ);
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let pix = tile_pixel(wg, li);
    if (pix >= arrayLength(&indirect)) {
        return;
    }
    let nrm = gb_normal[pix];
    let ti = gb_triangle[pix];
    if (nrm.w == 0.0 || ti >= arrayLength(&triangles)) {
        indirect[pix] = vec4<f32>(0.0);
        ao[pix] = vec4<f32>(0.0);
        irradiance[pix] = vec4<f32>(0.0);
        return;
    }
    let front = nrm.w > 0.0;
    let tri = triangles[ti];
    let m = materials[min(u32(tri.a.w), arrayLength(&materials) - 1u)];
    let sgn = select(-1.0, 1.0, front);
    let n = nrm.xyz * sgn;
    let fc = cross(tri.b.xyz - tri.a.xyz, tri.c.xyz - tri.a.xyz);
    let ng = fc * (1.0 / sqrt(dot(fc, fc))) * sgn;
    let pos = gb_position[pix].xyz;
    let s0 = cone.origin.w;
    let o = pos + ng * (cone.offset_voxels * s0);
    let basis = tangent_basis(n);
    let bt = basis.t;
    let bb = basis.b;
    var diffuse = vec3<f32>(0.0);
    var occ = 0.0;
    // Interleaved sets: this pixel's class takes cones cls, cls + N^2, ... of the spiral.
    let ni = max(cone.interleave, 1u);
    let w = frame.size.x;
    let cls = (pix % w) % ni + ni * ((pix / w) % ni);
    for (var k = 0u; k < cone.diffuse_cones; k++) {
        let c = cone_dirs[k * ni * ni + cls];
        let dir = bt * c.x + bb * c.y + n * c.z;
        let r = march(o, dir, cone.diffuse_tan, c.z);
        diffuse += r.radiance * c.w;
        occ += r.occlusion * c.w;
    }
    let a = clamp(1.0 - occ, 0.0, 1.0);
    ao[pix] = vec4<f32>(a, a, a, 0.0);
    irradiance[pix] = vec4<f32>(diffuse, occ);
    if (!front) {
        indirect[pix] = vec4<f32>(0.0);
        return;
    }
    var result = gb_albedo[pix].xyz * diffuse;   // Kd or the map_Kd texel
    let ks = m.specular.xyz;
    if (any(ks != vec3<f32>(0.0))) {
        let e = frame.eye.xyz - pos;
        let wo = e * (1.0 / sqrt(dot(e, e)));
        let refl = n * (2.0 * dot(n, wo)) - wo;
        let tan_g = clamp(sqrt(2.0 / (m.diffuse.w + 2.0)), 0.02, 1.0);
        result += ks * march(o, refl, tan_g, dot(refl, n)).radiance;
    }
    indirect[pix] = vec4<f32>(result, 0.0);
}

const RESOLVE_COS: f32 = 0.9;

fn signed_normal(v: vec4<f32>) -> vec3<f32> {
    return v.xyz * select(-1.0, 1.0, v.w > 0.0);
}

// Interleaved cone sets' resolve (after `main`, same tiles): a surface pixel's irradiance and
// occlusion averaged with tent weights (N - |dx|)(N - |dy|) over the (2N - 1)^2 pixels around it
// (each class's share is the same in a full window, and a class's sample fades in and out as the
// window slides, so no N-periodic pattern), over the window's pixels of the same surface (the same
// facing, signed normals within RESOLVE_COS, positions within one level-0 cell of the pixel's plane;
// the pixel itself always); AO = 1 - mean occ, and on front faces indirect += albedo (mean - own
// irradiance). Reads `irradiance` only, writes each pixel's own
// indirect and ao: no pixel reads what another writes. Mirror: cone_trace::resolve.
@compute @workgroup_size(64)
fn resolve(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let pix = tile_pixel(wg, li);
    if (pix >= arrayLength(&indirect)) {
        return;
    }
    let nrm = gb_normal[pix];
    if (nrm.w == 0.0) {
        return;
    }
    let n = i32(max(cone.interleave, 1u));
    let w = i32(frame.size.x);
    let h = i32(frame.size.y);
    let x = i32(pix % frame.size.x);
    let y = i32(pix / frame.size.x);
    let np = signed_normal(nrm);
    let pp = gb_position[pix].xyz;
    let s0 = cone.origin.w;
    var sum = vec4<f32>(0.0);
    var k = 0.0;
    for (var yy = max(y - n + 1, 0); yy < min(y + n, h); yy++) {
        for (var xx = max(x - n + 1, 0); xx < min(x + n, w); xx++) {
            let j = u32(yy * w + xx);
            var take = j == pix;
            if (!take) {
                let nq = gb_normal[j];
                if (nq.w != 0.0 && (nq.w > 0.0) == (nrm.w > 0.0)) {
                    let dist = abs(dot(gb_position[j].xyz - pp, np));
                    take = dot(np, signed_normal(nq)) >= RESOLVE_COS && dist <= s0;
                }
            }
            if (take) {
                // Tent weights (N - |dx|)(N - |dy|): every class weighs N^2 in a full window.
                let wt = f32((n - abs(xx - x)) * (n - abs(yy - y)));
                sum += irradiance[j] * wt;
                k += wt;
            }
        }
    }
    let mean = sum / k;
    let a = clamp(1.0 - mean.w, 0.0, 1.0);
    ao[pix] = vec4<f32>(a, a, a, 0.0);
    if (nrm.w > 0.0) {
        let own = irradiance[pix];
        let v = indirect[pix].xyz + gb_albedo[pix].xyz * (mean.xyz - own.xyz);
        indirect[pix] = vec4<f32>(v, 0.0);
    }
}
