// lrsm_cone_trace — the lrsm pipeline's final gathering (Sugihara et al. 2014, sections 3.2 and 5, eq. 1,
// Algorithm 1): per G-buffer pixel, the cones of common/cone_march.wgsl, whose samples take occlusion
// from the binary occlusion voxels' mips and outgoing radiance from every light view's LRSM.
// Mirror: cpu_mirror/src/lrsm_cone_trace.rs (`LrsmVolume`, a cone_trace `Volume`). Declaration:
// src/kernels/lrsm_cone_trace.rs. Uses common/cone_march.wgsl, common/lrsm_texel.wgsl, common/lrsm_sample.wgsl,
// common/lrsm_math.wgsl and common/lrsm_view.wgsl.
//
// Occlusion: level l of the occlusion pyramid starts at word occ_offsets[l] of `occ` (Morton order,
// occlusion_voxels.wgsl: level 0 a bit per voxel, read as 0 or 255; above it bytes, four per word);
// alpha = byte / 255, trilinear within a level, blended
// between levels by cone_march's sample_volume (so the march's alpha is the paper's alpha_i).
// Radiance of a sample (x, diameter D, cone direction d), where alpha > 0 (a sample with no occlusion
// adds nothing, eq. 1, so its LRSMs are not read): for every view in front of which x lies
//   zv = (x - eye) . forward > 0,  nx = (x - eye) . right / zv,  ny = (x - eye) . up / zv
//   (orthographic views, info.w = 1, a directional light's: no division by zv, here or in the mip),
//   texels = D * right.w / zv (the projected diameter in LRSM level-0 texels), r = clamp(texels /
//   side0, 1e-30, 64) (the projected radius in NDC), weight w = disc_share(nx, r) * disc_share(ny, r)
//   (the share of the projected disc inside the view; views with w = 0 are skipped), Sample LRSM
//   (common/lrsm_sample.wgsl) at the clamped point u = (cx + 1) / 2, v = (1 - cy) / 2 (cx, cy = nx, ny
//   clamped to [-1, 1]; v runs down the RSM's pixel rows), mip = log2(texels), zc = (zv - near) / (far -
//   near), vc = -d (towards the view sample), rc = D / 2 / (far - near), on the view's LRSM (first texel
//   info.z); L = sum over views of w times that. The weights make a sample across the seam of a point
//   light's two cube faces take from both (their shares sum to about 1; taken from the view holding its
//   centre alone, L jumped at the seams and the image showed bands along them); inside a view, a radius
//   from its edges, w = 1. The march then reads (L * alpha, alpha): its colour step
//   C += (1 - A) a' (L alpha) / alpha is eq. 1's alpha_i L_i with cone_march's step correction.
//   With area-weighted LRSMs (params.area = 1, `lrsm_area_weights`): mip = log2(texels) - 1 (the
//   trilinear taps then span about the disc, at log2(texels) about twice it), and L is already eq.
//   1's premultiplied alpha_i L_i (the lit surface in the sample, its area from the light's image,
//   projected along the cone by N, over the cone's cross-section): the march reads (L, alpha).
// Lit cells (params.lit_cells = 1, the default `lrsm_lit_cells`; a deviation from Algorithm 1,
//   docs/accuracy/lrsm.md): where alpha > 0 a sample's colour is the lit cells' (lit_cells.wgsl: the
//   light views' lit texels in the occlusion pyramid's cells) read as alpha is read, at the same
//   level, cells and trilinear weights: per cell its mean radiance times its coverage min(1, area
//   |N|_1 / |N| / 4^l level-0 faces: a tilted surface crosses |N|_1 times the cells an axis-aligned
//   one does, each holding less of it) times N's ramp by its mean normal against vc = -d; premultiplied, as eq. 1's
//   alpha_i L_i (the march reads (L, alpha)). No LRSM is read.
// Shadow cones (entry `shadow`, the option `[render] shadow_cone_angle` > 0; the default direct light is
// direct_light's exact rays): per G-buffer pixel, direct light as direct_light.wgsl computes it (same
// incident light, BRDF and cut-offs) with each light's visibility V = 1 - A of one cone of half-angle
// atan(shadow_params.tan_half) from p + ng * offset towards the light, marched through the occlusion mips with the
// gather's rules (diameter, steps, step-corrected alpha, no mip clamp) up to the light (at most the
// grid's diagonal); soft_direct = (sum brdf E cos V, 0).
// Accuracy: per-element bound from the mirror (the march's, with each sample's LRSM bound: Sample LRSM's
// arithmetic, each view weight's error from the projection's (the disc's centre and radius), and what
// the sample point's rounding may change in the fetch position, level and depth, evaluated at both ends
// of each one's error interval).

@group(0) @binding(8) var<storage, read> occ: array<u32>;
@group(0) @binding(12) var<storage, read> occ_offsets: array<u32>;
@group(0) @binding(13) var<uniform> params: SampleParams;
@group(0) @binding(14) var<storage, read> depth_ranges: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read> lrsm_radiance: array<vec2<u32>>;
@group(0) @binding(16) var<storage, read> lrsm_normal: array<vec2<u32>>;
@group(0) @binding(17) var<storage, read> lrsm_moments: array<vec2<u32>>;
@group(0) @binding(18) var<storage, read> views: array<LrsmView>;
@group(0) @binding(19) var<storage, read> lights: array<Light>;
@group(0) @binding(20) var<storage, read> shadow_params: ShadowParams;
@group(0) @binding(21) var<storage, read_write> soft_direct: array<vec4<f32>>;
// The lit cells (lit_cells.wgsl), every level, two vec4 a cell; level l from cell lit_offsets[l].
@group(0) @binding(23) var<storage, read> lit: array<vec4<f32>>;
@group(0) @binding(24) var<storage, read> lit_offsets: array<u32>;

struct ShadowParams {
    tan_half: f32,      // tan of the shadow cones' half-angle
    light_count: u32,
    _pad0: u32,
    _pad1: u32,
}

const PI: f32 = 3.14159265358979;

// (0, 0, 0, occlusion) at x, trilinear in occlusion level l.
fn sample_level(x: vec3<f32>, l: u32) -> vec4<f32> {
    let g = grid_point(x, l, cone.origin.xyz, cone.inv_s0, cone.side);
    let off = occ_offsets[l];
    var acc = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let c = grid_corner(g, corner);
        if (!c.inside) {
            continue;
        }
        let m = morton3(c.u);
        var b: u32;
        if (l == 0u) {
            b = ((occ[off + (m >> 5u)] >> (m & 31u)) & 1u) * 255u;
        } else {
            b = (occ[off + (m >> 2u)] >> (8u * (m & 3u))) & 255u;
        }
        acc += (f32(b) * (1.0 / 255.0)) * c.w;
    }
    return vec4<f32>(0.0, 0.0, 0.0, acc);
}

// The share of a projected disc (centre c, radius r, along one NDC axis) inside [-1, 1]: its span
// [|c| - r, |c| + r] inside over its diameter — 1 well inside, 1/2 centred on an edge, 0 a radius past
// it (mirror: lrsm_cone_trace::disc_share).
fn disc_share(c: f32, r: f32) -> f32 {
    let a = abs(c);
    let span = min(a + r, 1.0) - max(a - r, -1.0);
    return min(max(span / (2.0 * r), 0.0), 1.0);
}

// A lit cell's light seen along vc at level l (mirror: lit_cells::cell_light): its mean radiance
// times its coverage min(1, area |N|_1 / |N| / 4^l) (N its area-weighted normal sum), times the
// cull by its mean normal (N's ramp); 0 where no surface is.
fn cell_light(c0: vec4<f32>, c1: vec4<f32>, l: u32, vc: vec3<f32>) -> vec3<f32> {
    let area = c0.w;
    if (!(area > 0.0)) {
        return vec3<f32>(0.0);
    }
    let inv = 1.0 / area;
    // The cells a surface crosses per unit of its area grow with |n|_1 (1 axis-aligned, up to
    // sqrt(3)): a crossed cell holds 4^l / |n|_1 of a tilted surface on average, which covers it as
    // an axis-aligned wall filling its face does (the occlusion voxels mark every crossed cell).
    let m = c1.xyz;
    let ml = length(m);
    let crossing = select(1.0, ((abs(m.x) + abs(m.y)) + abs(m.z)) / ml, ml > 0.0);
    let cov = min((area * crossing) * (1.0 / f32(1u << (2u * l))), 1.0);
    let nw = clamp(((c1.x * vc.x + c1.y * vc.y) + c1.z * vc.z) * inv * (1.0 / LRSM_CULL_RAMP), 0.0, 1.0);
    let w = (inv * cov) * nw;
    return c0.xyz * w;
}

// The lit cells at x, trilinear in occlusion level l (>= params.lit_base) with the occlusion read's
// cells and weights: the lit table's level l - lit_base has the same cells.
fn lit_level(x: vec3<f32>, l: u32, vc: vec3<f32>) -> vec3<f32> {
    let g = grid_point(x, l, cone.origin.xyz, cone.inv_s0, cone.side);
    let ll = l - params.lit_base;
    let off = lit_offsets[ll];
    var acc = vec3<f32>(0.0);
    for (var corner = 0u; corner < 8u; corner++) {
        let c = grid_corner(g, corner);
        if (!c.inside) {
            continue;
        }
        let k = 2u * (off + morton3(c.u));
        acc += cell_light(lit[k], lit[k + 1u], ll, vc) * c.w;
    }
    return acc;
}

// The lit cells blended between two levels as sample_volume blends occlusion; a sample finer than
// the lit table's finest level reads that level.
fn lit_volume(x: vec3<f32>, lf_in: f32, vc: vec3<f32>) -> vec3<f32> {
    let top = cone.levels - 1u;
    let lf = max(lf_in, f32(params.lit_base));
    let l0 = floor(lf);
    if (l0 >= f32(top)) {
        return lit_level(x, top, vc);
    }
    let a = lf - l0;
    let l = u32(l0);
    return lit_level(x, l, vc) * (1.0 - a) + lit_level(x, l + 1u, vc) * a;
}

// The march's sample: occlusion from the voxels, radiance from the LRSMs or the lit cells (see the
// header).
fn sample_cone(x: vec3<f32>, l: f32, diam: f32, d: vec3<f32>, tan_half: f32) -> vec4<f32> {
    let s = sample_volume(x, l);
    if (!(s.w > 0.0)) {
        return s;
    }
    if (params.lit_cells != 0u) {
        // Premultiplied: the lit surface in the sample's cells over their faces, as alpha_i L_i.
        return vec4<f32>(lit_volume(x, l, -d), s.w);
    }
    var lsum = vec3<f32>(0.0);
    for (var k = 0u; k < arrayLength(&views); k++) {
        let v = views[k];
        let zv = view_axis_depth(v, x);
        if (!(zv > 0.0)) {
            continue;
        }
        let rel = x - v.eye.xyz;
        var nx = (rel.x * v.right.x + rel.y * v.right.y) + rel.z * v.right.z;
        var ny = (rel.x * v.up.x + rel.y * v.up.y) + rel.z * v.up.z;
        var texels = diam * v.right.w;
        if (v.info.w == 0u) {
            // Perspective: divide by depth (an orthographic view, a directional light's, does not).
            nx = nx / zv;
            ny = ny / zv;
            texels = texels / zv;
        }
        // The share of the sample's projected disc inside the view (radius in NDC; capped so that it
        // stays finite as zv -> 0, for a sample at the light itself, and floored so that the share's
        // division stays defined however far the view's depth puts it).
        let r = clamp(texels * (1.0 / f32(params.side0)), 1e-30, 64.0);
        let w = disc_share(nx, r) * disc_share(ny, r);
        if (!(w > 0.0)) {
            continue;
        }
        let cx = clamp(nx, -1.0, 1.0);
        let cy = clamp(ny, -1.0, 1.0);
        // Area-weighted LRSMs are fetched one level finer: the trilinear taps then span about the disc.
        let mip = log2(texels) - f32(params.area);
        let pos = vec4<f32>((cx + 1.0) * 0.5, (1.0 - cy) * 0.5, mip, (zv - v.eye.w) * v.forward.w);
        let dir = vec4<f32>(-d, (0.5 * diam) * v.forward.w);
        lsum += lrsm_sample(pos, dir, v.info.z).xyz * w;
    }
    // Area-weighted LRSMs give eq. 1's premultiplied alpha_i L_i: the lit surface in the sample
    // projected along the cone over its cross-section, which alpha must not scale again.
    return vec4<f32>(select(lsum * s.w, lsum, params.area != 0u), s.w);
}

// Visibility 1 - A of a shadow cone from o along d up to t_end (the gather's march rules).
fn shadow_visibility(o: vec3<f32>, d: vec3<f32>, tan_half: f32, t_end: f32) -> f32 {
    let s0 = cone.origin.w;
    let sf = cone.step_factor;
    let grow = 1.0 + 2.0 * sf * tan_half;
    let dl = log2(grow);
    let t_stop = min(t_end, f32(cone.side) * s0 * 1.7320508);
    var diam = 0.75 * s0;
    var lf = -0.4150375;
    var t = diam * (0.5 * sf);
    var a_acc = 0.0;
    while (t <= t_stop && a_acc < OPAQUE) {
        let s = sample_volume(o + d * t, lf);
        let ratio = sf * min(diam * cone.inv_s0, 1.0);
        let a = clamp(s.w, 0.0, 1.0);
        var a2 = 0.0;
        if (a > 0.0) {
            let keep = 1.0 - a;
            var kept = 0.0;
            if (keep > 0.0) {
                kept = pow(keep, ratio);
            }
            a2 = 1.0 - kept;
        }
        a_acc += (1.0 - a_acc) * a2;
        t += diam * sf;
        diam *= grow;
        lf += dl;
    }
    return clamp(1.0 - a_acc, 0.0, 1.0);
}

@compute @workgroup_size(64)
fn shadow_main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let pix = tile_pixel(wg, li);
    if (pix >= arrayLength(&soft_direct)) {
        return;
    }
    let nrm = gb_normal[pix];
    let ti = gb_triangle[pix];
    if (nrm.w <= 0.0 || ti >= arrayLength(&triangles)) {
        soft_direct[pix] = vec4<f32>(0.0);
        return;
    }
    let tri = triangles[ti];
    var m = materials[min(u32(tri.a.w), arrayLength(&materials) - 1u)];
    m.diffuse = vec4<f32>(gb_albedo[pix].xyz, m.diffuse.w);
    let p = gb_position[pix].xyz;
    let n = nrm.xyz;
    let fc = cross(tri.b.xyz - tri.a.xyz, tri.c.xyz - tri.a.xyz);
    let ng = fc * (1.0 / sqrt(dot(fc, fc)));
    let wv = frame.eye.xyz - p;
    let wo = wv * (1.0 / sqrt(dot(wv, wv)));
    let o = p + ng * (cone.offset_voxels * cone.origin.w);
    var sum = vec3<f32>(0.0);
    for (var l = 0u; l < shadow_params.light_count; l++) {
        let inc = incident(lights[l], p);
        let cos = dot(n, inc.wi);
        if (cos <= 0.0 || dot(ng, inc.wi) <= 0.0 || all(inc.e == vec3<f32>(0.0))) {
            continue;
        }
        let vis = shadow_visibility(o, inc.wi, shadow_params.tan_half, inc.t_max);
        sum += brdf(m, n, inc.wi, wo, cos) * inc.e * cos * vis;
    }
    soft_direct[pix] = vec4<f32>(sum, 0.0);
}
