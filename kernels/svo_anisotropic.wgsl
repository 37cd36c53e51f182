// svo_anisotropic — the sparse voxel octree's anisotropic voxels (Crassin et al. 2011, 7.1): six
// directional values (+x, -x, +y, -y, +z, -z) per brick voxel above the leaves, each the pre-multiplied
// (L * alpha, alpha) a cone travelling that way sees through the voxel's cell, built one level per pass
// from level depth - 1 up to the root. Mirror: cpu_mirror/src/svo_anisotropic.rs (the derivation).
// Declaration: src/kernels/svo_anisotropic.rs. Node layout and descent: common/svo_node.wgsl.
//
// One invocation per (node slot of the level, brick voxel): i = gid, node levels[level] * 8 + i / 27,
// voxel i % 27 (x + 3y + 9z), for the level's (levels[level + 1] - levels[level]) * 8 slots; the
// invocations past them (a pass recorded before the structure was built dispatches over a bound)
// return. Unused slots (key NONE) and empty voxels (isotropic brick value zero: their
// child points are zero, or under 32 fixed-point units where the filter rounded to zero; the mirror's
// module doc) write zeros. For direction +a (or -a) and each of the
// 9 rows of child lattice points along a (weights [1 2 1]^2 / 16 over the other two axes):
//   row = over(half(front), over(middle, half(back))), over(f, b) = f + b (1 - f.a),
//   half(p) = p / (1 + sqrt(1 - p.a))  (an end point shared with the neighbouring parent: half its
//   thickness), front = the point the cone meets first.
// Child point q (level l + 1, lattice 0..=2^(l+2)): node min(q / 2, 2^(l+1) - 1) (the parent's own
// child tile, or found by descent for points in a neighbour's), the isotropic brick (u32 * inv_scale)
// when l + 1 = depth, else its directional value; outside the lattice or in a missing node: 0. The 27
// points are located once per invocation.
// Accuracy: within 48 ULP of the weighted sum of |front| + |middle| + |back| (mirror bound), given the
// same deeper level.

struct AnisoParams {
    depth: u32,
    level: u32,
    inv_scale: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
    _pad4: u32,
}

@group(0) @binding(0) var<storage, read> params: AnisoParams;
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
// bricks, read through brick_words: common/svo_bricks_one.wgsl, or in windows common/svo_bricks.wgsl.
// aniso (binding 3), written and read through aniso_store and aniso_load:
// common/svo_aniso_rw_pair.wgsl, one or two bindings, or past those common/svo_aniso_rw.wgsl
// (declaration svo_anisotropic_windowed, with the bricks in windows).
// The octree's tile ranges per level (sparse_voxel_octree's `levels`): level l's tiles are
// levels[l]..levels[l + 1].
@group(0) @binding(5) var<storage, read> levels: array<u32>;

fn half_slab(p: vec4<f32>) -> vec4<f32> {
    return p / (1.0 + sqrt(max(1.0 - p.w, 0.0)));
}

fn over(f: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return f + b * (1.0 - f.w);
}

// Node (NONE: outside the lattice or missing) and brick voxel of child point q, level l + 1 (lattice
// 0..=2^(l+2)): node min(q / 2, 2^(l+1) - 1), read from the parent's own child tile when it is one of
// its children (most points), else found by descent from the root (the row ends reaching into a
// neighbouring parent's children). The same node either way: nodes are unique per level and place.
fn locate(q: vec3<i32>, parent: u32, pc: vec3<i32>) -> vec2<u32> {
    let cl = params.level + 1u;
    let points = 2i << cl;
    if (any(q < vec3<i32>(0)) || any(q > vec3<i32>(points))) {
        return vec2<u32>(NONE, 0u);
    }
    let c = min(q >> vec3<u32>(1u), vec3<i32>((1i << cl) - 1i));
    var n = NONE;
    let tile = nodes[parent].child;
    if (all((c >> vec3<u32>(1u)) == pc)) {
        if (tile != NONE) {
            let b = vec3<u32>(c & vec3<i32>(1i));
            n = tile * 8u + b.x + 2u * b.y + 4u * b.z;
        }
    } else {
        n = find(cl, vec3<u32>(c));
    }
    return vec2<u32>(n, voxel_index(vec3<u32>(q - 2i * c)));
}

// The value of a located child point in direction dir: the isotropic brick (u32 * inv_scale) at the
// leaves, else its directional value; 0 where there is none.
fn child(at: vec2<u32>, dir: u32) -> vec4<f32> {
    let n = at.x;
    if (n == NONE) {
        return vec4<f32>(0.0);
    }
    if (params.level + 1u == params.depth) {
        let w = n * BRICK_WORDS + at.y * 4u;
        return vec4<f32>(brick_words(w)) * params.inv_scale;
    }
    return aniso_load((n * 27u + at.y) * 6u + dir);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    let first = levels[params.level] * 8u;
    if (i >= (levels[params.level + 1u] * 8u - first) * 27u) {
        return;
    }
    let n = first + i / 27u;
    let vi = i % 27u;
    let base = (n * 27u + vi) * 6u;
    let key = nodes[n].key;
    let bw = n * BRICK_WORDS + vi * 4u;
    if (key == NONE || all(brick_words(bw) == vec4<u32>(0u))) {
        for (var dir = 0u; dir < 6u; dir++) {
            aniso_store(base + dir, vec4<f32>(0.0));
        }
        return;
    }
    let v = vec3<i32>(vec3<u32>(vi % 3u, (vi / 3u) % 3u, vi / 9u));
    let pc = vec3<i32>(coords_of(key));
    let centre = 2i * (2i * pc + v);
    // The 27 child points around the centre, offset o at 9 (oz + 1) + 3 (oy + 1) + ox + 1, located once
    // for all six directions.
    var at: array<vec2<u32>, 27>;
    for (var k = 0u; k < 27u; k++) {
        let o = vec3<i32>(vec3<u32>(k % 3u, (k / 3u) % 3u, k / 9u)) - vec3<i32>(1i);
        at[k] = locate(centre + o, n, pc);
    }
    var w = array<f32, 3>(1.0, 2.0, 1.0);
    for (var dir = 0u; dir < 6u; dir++) {
        let a = dir / 2u;
        let b = (a + 1u) % 3u;
        let c = (a + 2u) % 3u;
        var stride = array<u32, 3>(1u, 3u, 9u);
        var acc = vec4<f32>(0.0);
        for (var ii = 0u; ii < 3u; ii++) {
            for (var jj = 0u; jj < 3u; jj++) {
                // The row's middle point: offset 0 along a, ii - 1 along b, jj - 1 along c.
                let mid = 13u + (ii * stride[b] + jj * stride[c]) - stride[b] - stride[c];
                var f = child(at[mid - stride[a]], dir);
                let m = child(at[mid], dir);
                var bk = child(at[mid + stride[a]], dir);
                if (dir % 2u == 1u) {
                    let t = f;
                    f = bk;
                    bk = t;
                }
                let r = over(half_slab(f), over(m, half_slab(bk)));
                acc += r * (w[ii] * w[jj] * (1.0 / 16.0));
            }
        }
        aniso_store(base + dir, acc);
    }
}
