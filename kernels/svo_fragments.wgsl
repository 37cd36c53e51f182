// svo_fragments — the sparse voxel octree's fragments of a lit voxel grid, or of a voxel grid's
// coverage and a photon map, and their fixed-point scale, on the GPU (the host's fixed_scale,
// grid_fragments and svo_photons::to_fragments in src/kernels/, without reading anything back).
// Mirror: cpu_mirror/src/svo_fragments.rs. Declaration: src/kernels/svo_fragments.rs.
// Uses kernels/common/morton.wgsl.
//
// Bindings: params (capacity: voxel fragment slots; coverage_only; threshold: T32 below, voxel
// mode's `scale` only); vox_radiance, a Morton voxel grid as voxel_light writes it, (L alpha,
// alpha) (with coverage_only = 1 the colour grid, each voxel read as (0, 0, 0, alpha)); list,
// distinct Morton indices of its non-empty voxels, the first list_count[0] (<= capacity) valid;
// scale_state, [0] the peak's f32 bits, [1] error bits, [2] most (photon mode), [3] the threshold
// photon mode used (f32 bits), zero before the first pass; svo_scale, [scale, 1 / scale];
// fragments, capacity slots (voxel mode) or capacity + lattice_params.photons (photon mode: the
// photons' after the voxels').
// Photon mode adds: lattice_params (side: the leaf lattice has side + 1 points per axis, side <=
// 1023 so that 4 (side + 1)^3 fits a u32; photons: texels; bounces, 1..=2^20); photon_pos,
// photon_value, photon_spec, svo_photons' outputs (pos.xyz a lattice point, pos.w != 0 where the
// texel holds a photon); point_count and point_max, four words per lattice point, one per channel
// (word 4 i + c of point i = x + (side + 1) (y + (side + 1) z)), zero before the first pass.
//
// Voxel mode (every point holds one fragment), entry points in order:
//   peak             one thread per slot i < list_count[0]: atomicMax of the listed voxel's largest
//                    value, each channel clamped at 0 (-0 and NaN give 0), on its bits (for
//                    non-negative floats the integer order is the float order).
//   scale            one thread: scale = 2^16, halved until peak * scale <= params.threshold or it
//                    reaches f32's smallest normal (2^-126).
//   write_fragments  one thread per slot: the listed voxel's lattice point (its Morton decode) and
//                    its values round(v * scale), half away from zero; a zero fragment past
//                    list_count[0]. A value that does not fit (v * scale <= -0.5, NaN, infinite, or
//                    2^32 or more after rounding) stores 0 and sets ERR_VALUE in scale_state[1].
//
// Photon mode (the voxels' coverage, coverage_only = 1, and the photons' light), in order:
//   voxel_points            one thread per slot i < list_count[0]: each channel c of the listed
//                           voxel whose value is > 0 (on bits: -0, negatives and NaN are not, a
//                           subnormal is) counts 1 in point_count[4 i + c] of its point and is
//                           atomicMax'ed on its bits into point_max[4 i + c] (as `peak`).
//   photon_points           one thread per texel t < photons with pos.w != 0: the same with the
//                           values the photon's fragments store, (v.r, v.g, v.b, spec_max)
//                           (spec_max below). A point past the lattice is not counted and sets
//                           ERR_POINT. (voxel_points and photon_points in either order.)
//   lattice_peak            one thread per word k < 4 (side + 1)^3 holding a count n > 0, with
//                           point_max m: atomicMax of point_bound(n, m) into scale_state[0], of n
//                           into [2] (most).
//   lattice_scale           one thread: T32 = most_threshold(bounces, most) into scale_state[3],
//                           then `scale`'s search with it.
//   write_fragments         as in voxel mode, with coverage_only = 1 (slots 0..capacity).
//   write_photon_fragments  one thread per texel t < photons: slot capacity + t, pos.xyz and
//                           round(v * scale) of (v.r, v.g, v.b) with w = 0 where pos.w != 0, else
//                           a zero fragment; values that do not fit as in write_fragments.
//
// The scale is the host's fixed_scale(values, bounces): per lattice point p and channel c, n values
// > 0 whose largest is m; peak = the largest point_bound(n, m), the smallest f32 not below n m
// (exact integer arithmetic: no rounding mode, no flush, no conversion to depend on), and most =
// the largest n. The host accepts x = peak * scale when 64 (b (x + n / 2) + 1) <= u32::MAX in f64
// (b bounces, n = most). Where that outcome is in doubt (x near T below) every f64 operation of it
// is exact for 1 or 2 bounces and T >= 1 (n below 2^27 / b - 2, far past any count at one point),
// and elsewhere monotone rounding cannot cross the bound, so it is x <= T =
// (u32::MAX - 64 - 32 b n) / (64 b), and for an f32 x, x <= T32, the largest f32 not above T:
// params.threshold in voxel mode (svo_fragments::threshold on the host, n = 1), most_threshold in
// photon mode (T's binary expansion cut to 24 significant bits, in u32 arithmetic; -1 where T < 0,
// which no x meets). x is exact: the scale is a power of two. The test runs as
// (peak 2^-32) scale <= T32 2^-32, which cannot overflow (< 2^112) and is exact unless the product
// falls below 2^-126, far under any T32 >= 0 (T >= 1 / (64 b) >= 2^-26: T's numerator is odd, never
// 0). An infinite peak never fits: the scale goes to 2^-126, as on the host (the value itself is an
// error of the writing pass).
//
// spec_max, the largest of e[a] = ((q[a] + q[3]) / 2) clamped at 0 for a < 3 and q[3] clamped at 0
// (q = photon_spec): the host's Photons::values, computed so that nothing depends on how a GPU
// treats subnormals, infinities or NaN. Non-finite operands are decided on bits (NaN, or +inf and
// -inf, give 0; +inf with anything else +inf; -inf 0). Finite ones below 2^-125 in magnitude count
// as 0, and h = q[a] / 2 + q[3] / 2 (exact halves, one correctly rounded sum of normals, no
// overflow) is the host's fl(q[a] + q[3]) / 2 exactly, which overflows (+inf) where h >
// f32::MAX / 2; an h below 2^-126 in magnitude gives 0. So e[a] is the host's except where the
// host's is below 2^-100: no point's bound that matters to the scale (n 2^-100 2^16 is far under
// any T32 >= 0), and a specular fragment of such a value rounds to 0 at any scale.
//
// The fragments are the host's (grid_fragments, to_fragments, to_fixed): y = v * scale is exact, so
// is y - floor(y) (floor(y) is 0 or at least y / 2), and y - floor(y) >= 0.5 rounds half up, which
// for y >= 0 is half away from zero (round() is half to even; floor(y + 0.5) rounds the sum up just
// below 0.5). y <= -0.5 rounds to -1 or below on the host: an error; above it, 0. For a value the
// scale pass has seen, y is finite. A listed voxel whose values are all 0, or a photon whose light
// is 0, gives a fragment of value 0 where the host gives none: the octree's splat adds nothing for
// it, so the non-zero fragments, and the octree, are the same.
//
// Accuracy: exact (integer work, products with powers of two, floor, comparisons, and spec_max's
// sums of normal halves, correctly rounded). Infinities and NaN are recognised on bits and never
// enter a result. Flushing subnormals changes nothing: a subnormal value times a scale of at most
// 2^16 rounds to 0, maxima are taken on bits, and spec_max meets no subnormal.

const SCALE: f32 = 65536.0;
const MIN_NORMAL: f32 = 0x1p-126f;
const DOWN: f32 = 0x1p-32f;
const ERR_VALUE: u32 = 1u;
const ERR_POINT: u32 = 2u;
// Bits of +inf: those of every non-negative, non-NaN f32 are at most this.
const INF_BITS: u32 = 0x7f800000u;
const MAX_BITS: u32 = 0x7f7fffffu;
const ABS: u32 = 0x7fffffffu;
// Bits of 2^-125: spec_max's operands below it count as 0.
const SPEC_SMALL: u32 = 0x01000000u;
// Bits of 2^-126, the smallest normal.
const NORMAL_BITS: u32 = 0x00800000u;
const HALF_MAX: f32 = 0x1.fffffep126f;
// Most bounces most_threshold takes (64 b and twice a remainder below it fit a u32).
const MAX_BOUNCES: u32 = 0x100000u;

struct FragmentParams {
    capacity: u32,
    coverage_only: u32,
    threshold: f32,
    _pad: u32,
}

struct LatticeParams {
    side: u32,
    photons: u32,
    bounces: u32,
    _pad: u32,
}

struct Fragment {
    pos: vec3<u32>,
    value: vec4<u32>,
}

@group(0) @binding(0) var<uniform> params: FragmentParams;
@group(0) @binding(1) var<storage, read> vox_radiance: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> list: array<u32>;
@group(0) @binding(3) var<storage, read> list_count: array<u32>;
@group(0) @binding(4) var<storage, read_write> scale_state: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> svo_scale: array<f32>;
@group(0) @binding(6) var<storage, read_write> fragments: array<Fragment>;
@group(0) @binding(7) var<uniform> lattice_params: LatticeParams;
@group(0) @binding(8) var<storage, read> photon_pos: array<vec4<u32>>;
@group(0) @binding(9) var<storage, read> photon_value: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> photon_spec: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> point_count: array<atomic<u32>>;
@group(0) @binding(12) var<storage, read_write> point_max: array<atomic<u32>>;

// The bits of voxel m's four values as the kernel reads them.
fn voxel_bits(m: u32) -> vec4<u32> {
    let b = bitcast<vec4<u32>>(vox_radiance[m]);
    return select(b, vec4<u32>(0u, 0u, 0u, b.w), params.coverage_only != 0u);
}

// Bits of each value clamped at 0: negatives, -0 and NaN give 0 (+0's bits); for the others the
// integer order is the float order.
fn clamped(b: vec4<u32>) -> vec4<u32> {
    return select(vec4<u32>(0u), b, b <= vec4<u32>(INF_BITS));
}

fn max4(k: vec4<u32>) -> u32 {
    return max(max(k.x, k.y), max(k.z, k.w));
}

fn bit_length(x: u32) -> u32 {
    return 32u - countLeadingZeros(x);
}

@compute @workgroup_size(64)
fn peak(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= min(list_count[0], params.capacity)) {
        return;
    }
    atomicMax(&scale_state[0], max4(clamped(voxel_bits(list[i]))));
}

// svo_scale from the peak's bits and T32: 2^16, halved until (peak 2^-32) scale <= T32 2^-32 or it
// reaches 2^-126 (an infinite peak never fits).
fn write_scale(bits: u32, threshold: f32) {
    let finite = bits < INF_BITS;
    let p = bitcast<f32>(min(bits, MAX_BITS)) * DOWN;
    let t = threshold * DOWN;
    var s = SCALE;
    var inv = 1.0 / SCALE;
    loop {
        if ((finite && p * s <= t) || s <= MIN_NORMAL) {
            break;
        }
        s = s * 0.5;
        inv = inv * 2.0;
    }
    svo_scale[0] = s;
    svo_scale[1] = inv;
}

@compute @workgroup_size(1)
fn scale() {
    write_scale(atomicLoad(&scale_state[0]), params.threshold);
}

struct Fixed {
    value: vec4<u32>,
    bad: bool,
}

// The values of bits b in fixed point at svo_scale[0], 0 where one does not fit (bad).
fn to_fixed(b: vec4<u32>) -> Fixed {
    let y = bitcast<vec4<f32>>(b) * svo_scale[0];
    let z = max(y, vec4<f32>(0.0));
    let r = floor(z);
    let q = select(r, r + 1.0, z - r >= vec4<f32>(0.5));
    let bad = (b & vec4<u32>(INF_BITS)) == vec4<u32>(INF_BITS) | y <= vec4<f32>(-0.5)
        | q >= vec4<f32>(4294967296.0);
    return Fixed(select(vec4<u32>(q), vec4<u32>(0u), bad), any(bad));
}

@compute @workgroup_size(64)
fn write_fragments(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= params.capacity) {
        return;
    }
    if (i >= list_count[0]) {
        fragments[i] = Fragment(vec3<u32>(0u), vec4<u32>(0u));
        return;
    }
    let m = list[i];
    let f = to_fixed(voxel_bits(m));
    fragments[i] = Fragment(morton_decode(m), f.value);
    if (f.bad) {
        atomicOr(&scale_state[1], ERR_VALUE);
    }
}

// One value at lattice point p, its channels clamped (bits k): each channel > 0 counted and maxed.
fn add_value(p: vec3<u32>, k: vec4<u32>) {
    if (all(k == vec4<u32>(0u))) {
        return;
    }
    let side = lattice_params.side;
    if (any(p > vec3<u32>(side))) {
        atomicOr(&scale_state[1], ERR_POINT);
        return;
    }
    let w = side + 1u;
    let i = 4u * (p.x + w * (p.y + w * p.z));
    for (var c = 0u; c < 4u; c = c + 1u) {
        if (k[c] != 0u) {
            atomicAdd(&point_count[i + c], 1u);
            atomicMax(&point_max[i + c], k[c]);
        }
    }
}

@compute @workgroup_size(64)
fn voxel_points(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= min(list_count[0], params.capacity)) {
        return;
    }
    let m = list[i];
    add_value(morton_decode(m), clamped(voxel_bits(m)));
}

// Bits of ((x + y) / 2) clamped at 0 as the header states (x = q[a], y = q[3]).
fn spec_term(x: f32, y: f32) -> u32 {
    let bx = bitcast<u32>(x);
    let by = bitcast<u32>(y);
    let nx = (bx & INF_BITS) == INF_BITS;
    let ny = (by & INF_BITS) == INF_BITS;
    if (nx || ny) {
        // +inf with a finite value or +inf: +inf; anything with NaN or -inf: 0.
        let ok_x = bx == INF_BITS || !nx;
        let ok_y = by == INF_BITS || !ny;
        return select(0u, INF_BITS, ok_x && ok_y);
    }
    let hx = select(x * 0.5, 0.0, (bx & ABS) < SPEC_SMALL);
    let hy = select(y * 0.5, 0.0, (by & ABS) < SPEC_SMALL);
    let h = hx + hy;
    if (h > HALF_MAX) {
        return INF_BITS;
    }
    let bh = bitcast<u32>(h);
    return select(0u, bh, bh >= NORMAL_BITS && bh <= INF_BITS);
}

// Bits of spec_max of q (photon_spec).
fn spec_max(q: vec4<f32>) -> u32 {
    let e = vec4<u32>(spec_term(q.x, q.w), spec_term(q.y, q.w), spec_term(q.z, q.w), 0u);
    return max(max4(e), clamped(bitcast<vec4<u32>>(q)).w);
}

@compute @workgroup_size(64)
fn photon_points(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = gid.x + gid.y * groups.x * 64u;
    if (t >= lattice_params.photons) {
        return;
    }
    let p = photon_pos[t];
    if (p.w == 0u) {
        return;
    }
    let v = clamped(bitcast<vec4<u32>>(photon_value[t]));
    add_value(p.xyz, vec4<u32>(v.xyz, spec_max(photon_spec[t])));
}

// Bits of the smallest f32 not below n m (m the bits of a non-negative float or +inf), +inf past
// f32::MAX: n times m's significand as a 64-bit integer (16-bit limbs), cut to 24 bits rounding up.
fn point_bound(n: u32, m: u32) -> u32 {
    if (n == 0u || m == 0u) {
        return 0u;
    }
    if (m >= INF_BITS) {
        return INF_BITS;
    }
    let e = m >> 23u;
    // m = sig 2^(ex - 150).
    let sig = select((m & 0x7fffffu) | 0x800000u, m, e == 0u);
    let ex = max(e, 1u);
    let a0 = n & 0xffffu;
    let a1 = n >> 16u;
    let b0 = sig & 0xffffu;
    let b1 = sig >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    let lo = (p00 & 0xffffu) | (mid << 16u);
    let hi = a1 * b1 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
    let len = select(bit_length(lo), 32u + bit_length(hi), hi != 0u);
    if (len <= 24u) {
        // Exact: a subnormal m times n (ex = 1), or n = 1 (len 24).
        return ((ex - 1u) << 23u) + lo;
    }
    // 1 <= sh <= 32: drop sh bits, rounding up; q in [2^23, 2^24], a carry moving to the exponent.
    let sh = len - 24u;
    var q: u32;
    var rest: u32;
    if (sh == 32u) {
        q = hi;
        rest = lo;
    } else {
        q = (lo >> sh) | (hi << (32u - sh));
        rest = lo & ((1u << sh) - 1u);
    }
    q = q + select(0u, 1u, rest != 0u);
    let bits = ((ex - 1u + sh) << 23u) + q;
    return min(bits, INF_BITS);
}

@compute @workgroup_size(64)
fn lattice_peak(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    let w = lattice_params.side + 1u;
    if (i >= 4u * w * w * w) {
        return;
    }
    let n = atomicLoad(&point_count[i]);
    if (n == 0u) {
        return;
    }
    atomicMax(&scale_state[0], point_bound(n, atomicLoad(&point_max[i])));
    atomicMax(&scale_state[2], n);
}

// T32 for b bounces (clamped to 1..=MAX_BOUNCES) and most = n: the largest f32 not above
// T = (u32::MAX - 64 - 32 b n) / (64 b), or -1 where T < 0. With q = floor(T) and r / d the rest:
// from 2^24 on the f32 are integers (q with its bits past the 24th cleared); below, T's binary
// expansion by long division until 24 significant bits or an exact end, scaled back by 2^-j
// (j <= 50: T >= 1 / d). Every conversion to f32 is of an integer below 2^24 or with at most 24
// significant bits: exact.
fn most_threshold(bounces: u32, n: u32) -> f32 {
    let b = clamp(bounces, 1u, MAX_BOUNCES);
    let limit = 0xffffffffu - 64u;
    if (n > (limit / 32u) / b) {
        return -1.0;
    }
    let d = 64u * b;
    let t = limit - 32u * b * n;
    let q = t / d;
    var r = t % d;
    if (q >= 0x1000000u) {
        let drop = bit_length(q) - 24u;
        return f32((q >> drop) << drop);
    }
    var s = q;
    var j = 0u;
    loop {
        if (bit_length(s) >= 24u || r == 0u) {
            break;
        }
        r = r * 2u;
        s = s * 2u;
        if (r >= d) {
            r = r - d;
            s = s + 1u;
        }
        j = j + 1u;
    }
    return f32(s) * bitcast<f32>((127u - j) << 23u);
}

@compute @workgroup_size(1)
fn lattice_scale() {
    let t = most_threshold(lattice_params.bounces, atomicLoad(&scale_state[2]));
    atomicStore(&scale_state[3], bitcast<u32>(t));
    write_scale(atomicLoad(&scale_state[0]), t);
}

@compute @workgroup_size(64)
fn write_photon_fragments(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let t = gid.x + gid.y * groups.x * 64u;
    if (t >= lattice_params.photons) {
        return;
    }
    let slot = params.capacity + t;
    let p = photon_pos[t];
    if (p.w == 0u) {
        fragments[slot] = Fragment(vec3<u32>(0u), vec4<u32>(0u));
        return;
    }
    let v = bitcast<vec4<u32>>(photon_value[t]);
    let f = to_fixed(vec4<u32>(v.xyz, 0u));
    fragments[slot] = Fragment(p.xyz, f.value);
    if (f.bad) {
        atomicOr(&scale_state[1], ERR_VALUE);
    }
}
