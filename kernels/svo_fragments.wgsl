// svo_fragments — the sparse voxel octree's fragments of a lit voxel grid and their fixed-point scale,
// on the GPU (the host's fixed_scale and grid_fragments in src/kernels/svo_cone_trace.rs, without
// reading the grid back). Mirror: cpu_mirror/src/svo_fragments.rs. Declaration:
// src/kernels/svo_fragments.rs.
//
// Bindings: params (capacity: fragment slots; coverage_only; threshold: T32 below); vox_radiance, a
// Morton voxel grid as voxel_light writes it, (L alpha, alpha) (with coverage_only = 1 the colour grid,
// each voxel read as (0, 0, 0, alpha)); list, distinct Morton indices of its non-empty voxels, the first
// list_count[0] (<= capacity) valid; scale_state, [0] the peak's f32 bits, [1] error bits, zero before
// `peak`; svo_scale, [scale, 1 / scale]; fragments, capacity slots.
//
// Entry points, in order:
//   peak             one thread per slot i < list_count[0]: atomicMax of the listed voxel's largest
//                    value, each channel clamped at 0 (-0 and NaN give 0), on its bits (for
//                    non-negative floats the integer order is the float order).
//   scale            one thread: scale = 2^16, halved until peak * scale <= threshold or it reaches
//                    f32's smallest normal (2^-126).
//   write_fragments  one thread per slot: the listed voxel's lattice point (its Morton decode) and its
//                    values round(v * scale), half away from zero; a zero fragment past list_count[0].
//                    A value that does not fit (v * scale <= -0.5, NaN, infinite, or 2^32 or more
//                    after rounding) stores 0 and sets ERR_VALUE in scale_state[1].
//
// The scale is the host's fixed_scale(values, bounces) where each lattice point holds one fragment: the
// host accepts x = peak * scale when 64 (b (x + n / 2) + 1) <= u32::MAX in f64 (b bounces, n = 1
// fragments per point). Where that outcome is in doubt (x near 2^26 / b) every f64 operation of it is
// exact, and elsewhere monotone rounding cannot cross the bound, so it is x <= T = (u32::MAX / 64 - 1)
// / b - n / 2, and for an f32 x, x <= T32, the largest f32 not above T (params.threshold, from
// svo_fragments::threshold on the host). x is exact: the scale is a power of two. The test runs as
// (peak 2^-32) scale <= T32 2^-32, which cannot overflow (< 2^112) and is exact unless the product
// falls below 2^-126, far under the threshold. An infinite peak never fits: the scale goes to 2^-126,
// as on the host (the value itself is an error of write_fragments).
//
// The fragments are the host's (grid_fragments, to_fixed): y = v * scale is exact, so is y - floor(y)
// (floor(y) is 0 or at least y / 2), and y - floor(y) >= 0.5 rounds half up, which for y >= 0 is half
// away from zero (round() is half to even; floor(y + 0.5) rounds the sum up just below 0.5). y <= -0.5
// rounds to -1 or below on the host: an error; above it, 0. For a value the scale pass has seen, y is
// finite. A listed voxel whose values are all 0 gives a fragment of value 0 where the host gives none:
// the octree's splat adds nothing for it, so the non-zero fragments, and the octree, are the same.
//
// Accuracy: exact (integer work, products with powers of two, floor, comparisons). Infinities and NaN
// are recognised on bits, never computed with. Flushing subnormals changes nothing: a subnormal value
// times a scale of at most 2^16 rounds to 0, and the peak is taken on bits.

const SCALE: f32 = 65536.0;
const MIN_NORMAL: f32 = 0x1p-126f;
const DOWN: f32 = 0x1p-32f;
const ERR_VALUE: u32 = 1u;
// Bits of +inf: those of every non-negative, non-NaN f32 are at most this.
const INF_BITS: u32 = 0x7f800000u;
const MAX_BITS: u32 = 0x7f7fffffu;

struct FragmentParams {
    capacity: u32,
    coverage_only: u32,
    threshold: f32,
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

fn compact3(v: u32) -> u32 {
    var x = v & 0x09249249u;
    x = (x | (x >> 2u)) & 0x030c30c3u;
    x = (x | (x >> 4u)) & 0x0300f00fu;
    x = (x | (x >> 8u)) & 0x030000ffu;
    x = (x | (x >> 16u)) & 0x000003ffu;
    return x;
}

// The bits of voxel m's four values as the kernel reads them.
fn voxel_bits(m: u32) -> vec4<u32> {
    let b = bitcast<vec4<u32>>(vox_radiance[m]);
    return select(b, vec4<u32>(0u, 0u, 0u, b.w), params.coverage_only != 0u);
}

@compute @workgroup_size(64)
fn peak(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= min(list_count[0], params.capacity)) {
        return;
    }
    let b = voxel_bits(list[i]);
    let k = select(vec4<u32>(0u), b, b <= vec4<u32>(INF_BITS));
    atomicMax(&scale_state[0], max(max(k.x, k.y), max(k.z, k.w)));
}

@compute @workgroup_size(1)
fn scale() {
    let bits = atomicLoad(&scale_state[0]);
    let finite = bits < INF_BITS;
    let p = bitcast<f32>(min(bits, MAX_BITS)) * DOWN;
    let t = params.threshold * DOWN;
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
    let b = voxel_bits(m);
    let y = bitcast<vec4<f32>>(b) * svo_scale[0];
    let z = max(y, vec4<f32>(0.0));
    let r = floor(z);
    let q = select(r, r + 1.0, z - r >= vec4<f32>(0.5));
    let bad = (b & vec4<u32>(INF_BITS)) == vec4<u32>(INF_BITS) | y <= vec4<f32>(-0.5)
        | q >= vec4<f32>(4294967296.0);
    let pos = vec3<u32>(compact3(m), compact3(m >> 1u), compact3(m >> 2u));
    fragments[i] = Fragment(pos, select(vec4<u32>(q), vec4<u32>(0u), bad));
    if (any(bad)) {
        atomicOr(&scale_state[1], ERR_VALUE);
    }
}
