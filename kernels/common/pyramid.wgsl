// common/pyramid.wgsl — the dense radiance pyramid as the volume common/cone_march.wgsl samples: the
// cone's grid (cone.origin, cone.inv_s0, cone.side), trilinear within a level via
// common/pyramid_grid.wgsl (the paper's rule), or, when cone.depth_order is 1, the depth-ordered
// blend, which also reads the normal pyramid (`pyramid_normal`: surface_coverage_mip's normals, level 0
// voxelize's, concatenated like the colours; bind one element when depth_order is 0). Included by
// cone_trace (per pixel) and cache_creation (per radiance-cache texel). Depth-ordered: along the axis k where
// the cone's direction d is largest in magnitude (ties to the lower axis), the trilinear pair's near
// cell (the one the cone reaches first: the lower index where d_k >= 0) hides the far one,
// near (w_n + w_f h) + far w_f (1 - h) with h = a_near a_far (clamped to [0, 1]) where the near cell's
// pre-multiplied normal faces the cone (-N . d > 0), else h = 0; across k the blend stays bilinear.
// Mirror: cpu_mirror/src/cone_trace.rs (`Pyramid`; `OrderedPyramid` for both rules).

@group(0) @binding(16) var<storage, read> pyramid_normal: array<vec4<f32>>;

// The direction of the cone whose sample is being taken (set by sample_cone).
var<private> cone_dir: vec3<f32>;

struct OrderedCell {
    v: vec4<f32>,
    n: vec4<f32>,
}

fn ordered_cell(off: u32, n: i32, i: vec3<i32>) -> OrderedCell {
    if (any(i < vec3<i32>(0)) || any(i >= vec3<i32>(n))) {
        return OrderedCell(vec4<f32>(0.0), vec4<f32>(0.0));
    }
    let u = vec3<u32>(i);
    let m = off + morton3(u);
    return OrderedCell(pyramid_at(m), pyramid_normal[m]);
}

fn ordered_level(x: vec3<f32>, l: u32, d: vec3<f32>) -> vec4<f32> {
    let g = grid_point(x, l, cone.origin.xyz, cone.inv_s0, cone.side);
    let n = g.n;
    let f = g.f;
    let i0 = g.i0;
    let off = grid_level_offset(cone.side, l);
    let ad = abs(d);
    var k = 2u;
    if (ad.x >= ad.y && ad.x >= ad.z) {
        k = 0u;
    } else if (ad.y >= ad.z) {
        k = 1u;
    }
    let a = (k + 1u) % 3u;
    let b = (k + 2u) % 3u;
    var acc = vec4<f32>(0.0);
    for (var c = 0u; c < 4u; c++) {
        let ca = c >> 1u;
        let cb = c & 1u;
        let wa = select(1.0 - f[a], f[a], ca == 1u);
        let wb = select(1.0 - f[b], f[b], cb == 1u);
        var i = i0;
        i[a] += i32(ca);
        i[b] += i32(cb);
        var ih = i;
        ih[k] += 1;
        let lo = ordered_cell(off, n, i);
        let hi = ordered_cell(off, n, ih);
        var near = hi;
        var far = lo;
        var wn = f[k];
        var wf = 1.0 - f[k];
        if (d[k] >= 0.0) {
            near = lo;
            far = hi;
            wn = 1.0 - f[k];
            wf = f[k];
        }
        let nn = near.n;
        let facing = -(nn.x * d.x + nn.y * d.y + nn.z * d.z);
        let hidden = clamp(near.v.w, 0.0, 1.0) * clamp(far.v.w, 0.0, 1.0);
        let h = select(0.0, hidden, facing > 0.0);
        let v = near.v * (wn + wf * h) + far.v * (wf * (1.0 - h));
        acc += v * (wa * wb);
    }
    return acc;
}

fn sample_level(x: vec3<f32>, l: u32) -> vec4<f32> {
    if (cone.depth_order != 0u) {
        return ordered_level(x, l, cone_dir);
    }
    return sample_grid(x, l, cone.origin.xyz, cone.inv_s0, cone.side, 0u);
}

// The march's sample: the volume's own radiance (see common/cone_march.wgsl), blended in depth order
// along the cone's direction when cone.depth_order is 1.
fn sample_cone(x: vec3<f32>, l: f32, diam: f32, d: vec3<f32>, tan_half: f32) -> vec4<f32> {
    cone_dir = d;
    return sample_volume(x, l);
}
