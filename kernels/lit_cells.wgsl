// lit_cells — the light views' lit RSM texels in the occlusion pyramid's own cells: where lrsm's
// gather finds a sample's light (docs/accuracy/lrsm.md, "The light in the occlusion cells"; a
// deviation from Algorithm 1's light-space lookup, which puts the light of a surface the grid holds
// in its wall's cells half a cell off where its occlusion is). Mirror: cpu_mirror/src/lit_cells.rs.
// Declaration: src/kernels/lit_cells.rs. Uses common/lrsm_view.wgsl and common/morton.wgsl.
//
// A cell holds 8 floats, two vec4: (sum a r, sum a g, sum a b, sum a), (sum a n.x, sum a n.y,
// sum a n.z, 0), a each piece's area in level-0 faces (s0^2; after resolve times the area weight w),
// r g b its RSM radiance, n its normal.
// Cells in Morton order per level; the children of cell P are cells 8P .. 8P + 7 of the level below.
// Level 0 is summed exactly, in any invocation order: each value as 64-bit two's-complement fixed
// point (`fixed`: 24 fraction bits; radiance in units of Q = grid.scale.y, area and normal in faces;
// magnitudes clamped to MAX_PIECE = 2^24 units, so a cell holds 2^15 such pieces), its low word
// added into the cell's own slot of `cells`, the carry and high word into the same index of `hi`;
// `resolve` then turns each slot into its float.
//   clear (one invocation per level-0 cell): its 8 words in `cells` and in `hi` 0.
//   inject (one invocation per texel m of one view's RSM; coverage <= 1/2 returns): the texel
//     (x, y) = 2D Morton decode of m, image point a = (x + 1/2) t - 1, b = 1 - (y + 1/2) t (t = 2 /
//     side), axis depth z = depth / forward.w + eye.w; rn = right / |right|^2, un = up / |up|^2; the
//     ray through (a, b): perspective from the eye along dir = forward + rn a + un b, orthographic
//     from eye + rn a + un b along forward; its point pt at depth z. Its lit surface: the texel's
//     image area at z, t^2 z^2 / (|right| |up|) (orthographic t^2 / (|right| |up|)), times the ray's
//     cosine to the axis 1 / |dir| (orthographic 1), over <n, l> (floored at 1e-3). Spread over the
//     cells it crosses: k x k sub-rays, k = clamp(ceil(2 sqrt(image area) / <n, l> / s0), 1, 16),
//     through image points at the centres of the texel's k x k sub-squares, each meeting the plane
//     through pt with normal n (a sub-ray within 1e-6 of parallel to it takes depth z), each carrying
//     surface / k^2; k = 1 is pt itself. Each piece lands in the cell holding its point, clamped
//     into the grid (a point on the grid's high faces goes to the last cell, as voxelize puts it),
//     and adds its 7 values there ((r / Q) a, (g / Q) a, (b / Q) a, a, n a) in fixed point, and its
//     light's bit (view.info.y mod 32) into word 7.
//   resolve (one invocation per level-0 cell): each of its 7 sums to f32 (the magnitude's high and
//     low words converted, the high scaled by 2^8 and the low by 2^-24, added; radiance times Q,
//     area and normal times the area weight w: where several lights light one cell the mean
//     radiance then adds their light), word 7 0. w is 1 / the lights whose pieces reached the
//     cell (the bits inject set in word 7) where grid.size.y = 1 (at most 32 lights cast light),
//     else grid.scale.z (1 / the lights casting light).
//   reduce (one invocation per cell of the level written, dst's length / 2): each float the sum of
//     its 8 children's, in child order.
// Accuracy: per-element bound from the mirror: each piece's own arithmetic and its quantum, the
// resolve's roundings and the area weight's (1 / k and the product), and in full every piece whose
// cell, sub-ray count or plane test the rounding may change, and so whether its light reaches the
// cell (the weight between the fewest lights and the most). Deterministic: a frame's lit cells are
// the same bits on every run on one device.

struct LitGrid {
    origin: vec4<f32>,  // xyz the grid's low corner, w = s0
    size: vec4<u32>,    // x = side at level 0; y = 1: the area weight per cell (resolve); zw unused
    scale: vec4<f32>,   // x = 1 / Q, y = Q (a power of two): the radiance's fixed-point unit; z = the
                        // area weight of every cell where size.y = 0 (1 / lights casting light); w unused
}

@group(0) @binding(0) var<storage, read> grid: LitGrid;
@group(0) @binding(1) var<storage, read> view: LrsmView;
@group(0) @binding(2) var<storage, read> rsm_radiance: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> rsm_normal: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> rsm_depth: array<f32>;
@group(0) @binding(5) var<storage, read_write> cells: array<atomic<u32>>;
// read_write although reduce only reads it: a pipeline binds src and dst as windows of one buffer,
// which a dispatch may bind twice only as writable storage.
@group(0) @binding(6) var<storage, read_write> src: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> dst: array<vec4<f32>>;
// The high words of level 0's fixed-point sums, one per word of `cells`.
@group(0) @binding(8) var<storage, read_write> hi: array<atomic<u32>>;

const MAX_SPREAD: f32 = 16.0;
const PARALLEL: f32 = 1e-6;
const MIN_NDOTL: f32 = 1e-3;
const MAX_PIECE: f32 = 16777216.0;
const TWO_24: f32 = 16777216.0;

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return (a.x * b.x + a.y * b.y) + a.z * b.z;
}

// -q of a 64-bit two's-complement q = (low word, high word).
fn negate64(q: vec2<u32>) -> vec2<u32> {
    let lo = ~q.x + 1u;
    return vec2<u32>(lo, ~q.y + select(0u, 1u, lo == 0u));
}

// v in its unit as 64-bit two's complement with 24 fraction bits: (low word, high word); NaN 0
// (the negated test: a NaN fails every comparison), infinities clamped as the finite values.
fn fixed(v: f32) -> vec2<u32> {
    if (!(abs(v) >= 0.0)) {
        return vec2<u32>(0u);
    }
    let a = min(abs(v), MAX_PIECE);
    let h = floor(a);
    let hu = u32(h);
    // h 2^24 + l, l < 2^24: the low word's top byte is h's low byte.
    let q = vec2<u32>((hu << 24u) | u32(round((a - h) * TWO_24)), hu >> 8u);
    if (v < 0.0) {
        return negate64(q);
    }
    return q;
}

fn add_fixed(i: u32, v: f32) {
    let q = fixed(v);
    if (q.x == 0u && q.y == 0u) {
        return;
    }
    let old = atomicAdd(&cells[i], q.x);
    let h = q.y + select(0u, 1u, old + q.x < old);
    if (h != 0u) {
        atomicAdd(&hi[i], h);
    }
}

struct Ray {
    o: vec3<f32>,
    d: vec3<f32>,
}

fn ray_at(rn: vec3<f32>, un: vec3<f32>, a: f32, b: f32) -> Ray {
    if (view.info.w == 1u) {
        return Ray(view.eye.xyz + rn * a + un * b, view.forward.xyz);
    }
    return Ray(view.eye.xyz, view.forward.xyz + rn * a + un * b);
}

fn add_piece(p: vec3<f32>, rad: vec3<f32>, n: vec3<f32>, part: f32) {
    let last = f32(grid.size.x - 1u);
    let q = (p - grid.origin.xyz) * (1.0 / grid.origin.w);
    let c = vec3<u32>(clamp(floor(q), vec3<f32>(0.0), vec3<f32>(last)));
    let base = 8u * morton3(c);
    let r = rad * grid.scale.x;
    add_fixed(base, r.x * part);
    add_fixed(base + 1u, r.y * part);
    add_fixed(base + 2u, r.z * part);
    add_fixed(base + 3u, part);
    add_fixed(base + 4u, n.x * part);
    add_fixed(base + 5u, n.y * part);
    add_fixed(base + 6u, n.z * part);
    // The lights reaching the cell: bit (light index mod 32) of word 7 (read by resolve).
    atomicOr(&cells[base + 7u], 1u << (view.info.y & 31u));
}

@compute @workgroup_size(64)
fn clear(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = gid.x + gid.y * groups.x * 64u;
    if (8u * c >= arrayLength(&cells)) {
        return;
    }
    for (var k = 0u; k < 8u; k++) {
        atomicStore(&cells[8u * c + k], 0u);
        atomicStore(&hi[8u * c + k], 0u);
    }
}

@compute @workgroup_size(64)
fn inject(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let m = gid.x + gid.y * groups.x * 64u;
    let side = view.info.x;
    if (m >= side * side || m >= arrayLength(&rsm_depth)) {
        return;
    }
    let rr = rsm_radiance[m];
    if (!(rr.w > 0.5)) {
        return;
    }
    let nrm = rsm_normal[m];
    let n = nrm.xyz;
    let ndl = max(nrm.w, MIN_NDOTL);
    let t = 2.0 / f32(side);
    let a = (f32(compact2(m)) + 0.5) * t - 1.0;
    let b = 1.0 - (f32(compact2(m >> 1u)) + 0.5) * t;
    let z = rsm_depth[m] / view.forward.w + view.eye.w;
    let r = view.right.xyz;
    let u = view.up.xyz;
    let r2 = dot3(r, r);
    let u2 = dot3(u, u);
    let rn = r * (1.0 / r2);
    let un = u * (1.0 / u2);
    let rl_ul = sqrt(r2 * u2);
    let ray = ray_at(rn, un, a, b);
    var plane = (t * t) / rl_ul;
    var cosv = 1.0;
    if (view.info.w != 1u) {
        plane = ((t * t) * (z * z)) / rl_ul;
        cosv = 1.0 / sqrt(dot3(ray.d, ray.d));
    }
    let pt = ray.o + ray.d * z;
    let s0 = grid.origin.w;
    let surface = plane * cosv / ndl;
    let kf = clamp(ceil(2.0 * sqrt(plane) / ndl / s0), 1.0, MAX_SPREAD);
    let k = u32(kf);
    let part = surface / f32(k * k) * (1.0 / (s0 * s0));
    if (k == 1u) {
        add_piece(pt, rr.xyz, n, part);
        return;
    }
    for (var j = 0u; j < k; j++) {
        for (var i = 0u; i < k; i++) {
            let sa = a + ((f32(i) + 0.5) / kf - 0.5) * t;
            let sb = b - ((f32(j) + 0.5) / kf - 0.5) * t;
            let sub = ray_at(rn, un, sa, sb);
            let den = dot3(n, sub.d);
            var p = sub.o + sub.d * z;
            if (abs(den) > PARALLEL) {
                p = sub.o + sub.d * (dot3(n, pt - sub.o) / den);
            }
            add_piece(p, rr.xyz, n, part);
        }
    }
}

@compute @workgroup_size(64)
fn resolve(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = gid.x + gid.y * groups.x * 64u;
    if (8u * c >= arrayLength(&cells)) {
        return;
    }
    var w = grid.scale.z;
    if (grid.size.y == 1u) {
        w = 1.0 / f32(max(countOneBits(atomicLoad(&cells[8u * c + 7u])), 1u));
    }
    for (var k = 0u; k < 7u; k++) {
        let i = 8u * c + k;
        var q = vec2<u32>(atomicLoad(&cells[i]), atomicLoad(&hi[i]));
        let negative = (q.y & 0x80000000u) != 0u;
        if (negative) {
            q = negate64(q);
        }
        var f = f32(q.y) * 256.0 + f32(q.x) * (1.0 / TWO_24);
        if (negative) {
            f = -f;
        }
        if (k < 3u) {
            f = f * grid.scale.y;
        } else {
            f = f * w;
        }
        atomicStore(&cells[i], bitcast<u32>(f));
    }
    atomicStore(&cells[8u * c + 7u], 0u);
}

@compute @workgroup_size(64)
fn reduce(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = gid.x + gid.y * groups.x * 64u;
    if (2u * c + 1u >= arrayLength(&dst)) {
        return;
    }
    var s = vec4<f32>(0.0);
    var nsum = vec4<f32>(0.0);
    for (var k = 0u; k < 8u; k++) {
        s = s + src[2u * (8u * c + k)];
        nsum = nsum + src[2u * (8u * c + k) + 1u];
    }
    dst[2u * c] = s;
    dst[2u * c + 1u] = nsum;
}
