// Octahedral binning of snorm16-quantised normals, shared by tile_normal_histogram.wgsl and
// histogram_axes.wgsl. Mirror: cpu_mirror/src/octahedral.rs. Integers only: exact.
// Packed normal: (x | y << 16, z | geometry << 16), 16-bit two's complement fields; geometry 0 =
// background (also how non-finite or zero-length normals arrive: the host quantiser maps them there).

const OCT_BINS: i32 = 8;
const OCT_BIN_COUNT: u32 = 64u;

fn oct_is_geometry(w: vec2<u32>) -> bool {
    return ((w.y >> 16u) & 1u) == 1u;
}

fn oct_unpack(w: vec2<u32>) -> vec3<i32> {
    let x = bitcast<i32>(w.x << 16u) >> 16u;
    let y = bitcast<i32>(w.x) >> 16u;
    let z = bitcast<i32>(w.y << 16u) >> 16u;
    return vec3<i32>(x, y, z);
}

fn oct_sign(v: i32) -> i32 {
    return select(1, -1, v < 0);
}

fn oct_axis_bin(c: i32, s: i32) -> i32 {
    return min(((c + s) * OCT_BINS) / (2 * s), OCT_BINS - 1);
}

// Bin bv * OCT_BINS + bu of a quantised normal.
fn oct_bin(q: vec3<i32>) -> u32 {
    let s = abs(q.x) + abs(q.y) + abs(q.z);
    var u = q.x;
    var v = q.y;
    if (q.z < 0) {
        u = oct_sign(q.x) * (s - abs(q.y));
        v = oct_sign(q.y) * (s - abs(q.x));
    }
    return u32(oct_axis_bin(v, s) * OCT_BINS + oct_axis_bin(u, s));
}

// Out-of-range bin coordinates mirrored across the octahedral map's border.
fn oct_wrap(uv: vec2<i32>) -> vec2<i32> {
    var u = uv.x;
    var v = uv.y;
    if (u < 0) {
        u = -1 - u;
        v = OCT_BINS - 1 - v;
    } else if (u >= OCT_BINS) {
        u = 2 * OCT_BINS - 1 - u;
        v = OCT_BINS - 1 - v;
    }
    if (v < 0) {
        v = -1 - v;
        u = OCT_BINS - 1 - u;
    } else if (v >= OCT_BINS) {
        v = 2 * OCT_BINS - 1 - v;
        u = OCT_BINS - 1 - u;
    }
    return vec2<i32>(u, v);
}
