// common/placed_pyramids.wgsl — several radiance pyramids, each placed in the world by a rigid
// transform, as one volume for common/cone_march.wgsl (CPRC 3.1 "Multiple Voxel Hierarchies": one
// hierarchy per instance, cones marched through all of them). Mirror: cpu_mirror/src/cache_creation.rs
// (`PlacedPyramids`).
//
// placed[h]: to_local = rows of grid-from-world (3x4); origin (xyz, w = 1 / s0, computed on the host
// like cone.inv_s0) and side / levels / base
// (first element of its pyramid in `pyramid`); shift = log2 of (the march's s0, cone.origin.w, over
// this grid's s0 in world units): the march's level lf reads this grid's level lf + shift.
// A sample at world point x reads every hierarchy at its local point (quadrilinear, clamped to its
// levels as sample_volume) and combines them front to back in the march's own order: alpha
// 1 - prod(1 - a_h), premultiplied radiance sum_h c_h (one hierarchy holds a point almost always;
// where two overlap their light adds, as two surfaces in one voxel would). The march's stepping (start
// diameter, steps, the alpha's step correction, the far end) follows `cone`: set it to a grid covering
// all hierarchies.
// placed_cells (host: cpu_mirror cache_creation::placed_cells): a world grid of D^3 cells over the
// hierarchies' influence boxes, each cell a list of the hierarchies that can add to a sample in it
// (words 0..4: D, entries; 4..7: the grid's low corner; 8..11: cells per world unit per axis, f32
// bits; then D^3 + 1 offsets, cell x + D (y + D z) listing entries offsets[cell]..offsets[cell + 1];
// then the entries, ascending within a cell). A sample reads its cell's hierarchies in ascending
// order; the others add exactly zero, so the result is the loop over all of them bit for bit, at
// the cost of the ones near the sample.

struct Placed {
    to_local: array<vec4<f32>, 3>,
    origin: vec4<f32>,
    side_levels_base: vec4<u32>,
    shift: vec4<f32>,
}

@group(0) @binding(16) var<storage, read> placed: array<Placed>;
@group(0) @binding(17) var<storage, read> placed_cells: array<u32>;

fn placed_level(h: Placed, x: vec3<f32>, l: u32) -> vec4<f32> {
    return sample_grid(x, l, h.origin.xyz, h.origin.w, h.side_levels_base.x, h.side_levels_base.z);
}

fn placed_sample(h: Placed, xw: vec3<f32>, lf_in: f32) -> vec4<f32> {
    let x = vec3<f32>(
        dot(h.to_local[0].xyz, xw) + h.to_local[0].w,
        dot(h.to_local[1].xyz, xw) + h.to_local[1].w,
        dot(h.to_local[2].xyz, xw) + h.to_local[2].w,
    );
    let top = h.side_levels_base.y - 1u;
    let lf = max(lf_in + h.shift.x, 0.0);
    let l0 = floor(lf);
    if (l0 >= f32(top)) {
        return placed_level(h, x, top);
    }
    let a = lf - l0;
    let l = u32(l0);
    return placed_level(h, x, l) * (1.0 - a) + placed_level(h, x, l + 1u) * a;
}

fn placed_combined(x: vec3<f32>, lf: f32) -> vec4<f32> {
    var c = vec3<f32>(0.0);
    var keep = 1.0;
    let dims = placed_cells[0];
    let low = vec3<f32>(bitcast<f32>(placed_cells[4]), bitcast<f32>(placed_cells[5]), bitcast<f32>(placed_cells[6]));
    let per = vec3<f32>(bitcast<f32>(placed_cells[8]), bitcast<f32>(placed_cells[9]), bitcast<f32>(placed_cells[10]));
    let q = floor((x - low) * per);
    if (all(q >= vec3<f32>(0.0)) && all(q < vec3<f32>(f32(dims)))) {
        let cell = u32(q.x) + dims * (u32(q.y) + dims * u32(q.z));
        let first = 13u + dims * dims * dims;
        for (var i = placed_cells[12u + cell]; i < placed_cells[13u + cell]; i++) {
            let s = placed_sample(placed[placed_cells[first + i]], x, lf);
            c += s.xyz;
            keep *= 1.0 - clamp(s.w, 0.0, 1.0);
        }
    }
    return vec4<f32>(c, 1.0 - keep);
}

// sample_volume (common/cone_march.wgsl) reads whole levels through this; the march itself reads
// sample_cone.
fn sample_level(x: vec3<f32>, l: u32) -> vec4<f32> {
    return placed_combined(x, f32(l));
}

fn sample_cone(x: vec3<f32>, l: f32, diam: f32, d: vec3<f32>, tan_half: f32) -> vec4<f32> {
    return placed_combined(x, l);
}
