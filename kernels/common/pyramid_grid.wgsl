// common/pyramid_grid.wgsl — trilinear sampling of one level of a dense radiance pyramid stored in the
// `pyramid` binding: the levels of a Morton grid of side 2^L concatenated from element `base` (level l
// at base + (8^(L+1) - 8^(L-l+1)) / 7), each voxel (L * alpha, alpha); outside the grid = empty.
// Used by common/pyramid.wgsl (one pyramid, the cone's grid) and common/placed_pyramids.wgsl (several
// pyramids placed by rigid transforms), after common/morton.wgsl. Mirror: cpu_mirror/src/cone_trace.rs
// (`trilinear_level`).

@group(0) @binding(8) var<storage, read> pyramid: array<vec4<f32>>;
// A pyramid larger than one storage binding is bound in up to three consecutive windows of one
// buffer: element i is pyramid[i], else pyramid_1[i - len0], else pyramid_2[i - len0 - len1] (len the
// windows' lengths); windows it does not need are bound to one unused element.
@group(0) @binding(18) var<storage, read> pyramid_1: array<vec4<f32>>;
@group(0) @binding(19) var<storage, read> pyramid_2: array<vec4<f32>>;

fn pyramid_at(i: u32) -> vec4<f32> {
    let len0 = arrayLength(&pyramid);
    if (i < len0) {
        return pyramid[i];
    }
    let len1 = arrayLength(&pyramid_1);
    if (i - len0 < len1) {
        return pyramid_1[i - len0];
    }
    return pyramid_2[i - len0 - len1];
}

fn grid_level_offset(side: u32, l: u32) -> u32 {
    let big = countTrailingZeros(side);
    return ((1u << (3u * (big + 1u))) - (1u << (3u * (big + 1u - l)))) / 7u;
}


// Level l of the grid with this origin, 1 / s0 and side, stored from `base`, at point x (the grid's
// own frame; `grid_point` in common/morton.wgsl).
fn sample_grid(x: vec3<f32>, l: u32, origin: vec3<f32>, inv_s0: f32, side: u32, base: u32) -> vec4<f32> {
    let g = grid_point(x, l, origin, inv_s0, side);
    let off = base + grid_level_offset(side, l);
    var acc = vec4<f32>(0.0);
    for (var corner = 0u; corner < 8u; corner++) {
        let c = grid_corner(g, corner);
        if (!c.inside) {
            continue;
        }
        acc += pyramid_at(off + morton3(c.u)) * c.w;
    }
    return acc;
}
