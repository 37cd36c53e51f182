// sparse_voxel_octree — the sparse voxel octree of voxel cone tracing (Crassin et al. 2011, 4.1-4.2.3
// and 8.2): node pool of 2x2x2 tiles with child, parent and six face-neighbour pointers, one 3x3x3
// vertex-centred brick per node, values splatted in u32 fixed point with integer atomics, brick border
// transfer (add along +axis, copy back; per axis, no atomics) and distribution over levels.
// Mirror: cpu_mirror/src/sparse_voxel_octree.rs (its module doc has the model: lattice, halo rule,
// distribution weights, work lists). Node layout and descent: kernels/common/svo_node.wgsl.
//
// Entry points, in order (params.level / params.variant say which level, axis or class):
//   build, for level l = 1..=depth:
//     flag_static   (a static part recorded: VCT 4.2.2's static/dynamic split, see the mirror's module
//                   doc) one thread per recorded level-(l-1) key: flag that node
//     flag_parents  fragments x 8 threads: flag the level-(l-1) nodes holding the fragment's support
//                   (with a static part: params.fragments counts only the fragments at points it does
//                   not cover, first in the buffer)
//     allocate      one thread per level-(l-1) node (indirect, slot l-1): a flagged node takes a tile
//                   from the atomic counter status[1]; past capacity_tiles: ERR_POOL
//     finish_level  one thread: levels[l+1] = end of level l's tiles; dispatch args of slot l
//     init_nodes    one thread per level-l node (indirect, slot l): key, parent, face neighbours
//   values:
//     splat         one thread per fragment: saturating atomic add into its leaf's brick; leaf active
//   per level l = depth..=0:
//     begin_level   one thread: list counters to zero
//     mark_ring     per level-l node (slot l): active nodes mark themselves and their 26 neighbours
//     compact       per level-l node (slot l): active list, ring list (atomic append: order free)
//     list_args     one thread: counts into stats, dispatch args of the ring and the four classes
//     distribute    (l < depth) per active node and voxel of class params.variant: share from children
//     transfer_add / transfer_copy   per ring node, axis params.variant
//     round_level   (l < depth) per ring node: (S + 32) >> 6, the level's one rounding
//     mark_parents  (l > 0) per ring node: a non-zero brick makes its parent active
// Everything is integer: GPU and mirror agree exactly; the free allocation order is canonicalised
// (records sorted by node key, pointers replaced by keys) before comparing.

const FLAG_SUBDIVIDE: u32 = 1u;
const FLAG_ACTIVE: u32 = 2u;
const FLAG_RING: u32 = 4u;
const ERR_POOL: u32 = 1u;
const ERR_OVERFLOW: u32 = 2u;
const ERR_OUTSIDE: u32 = 4u;
const SLOT_RING: u32 = 10u;
const SLOT_CLASS: u32 = 11u;

struct Fragment {
    pos: vec3<u32>,
    value: vec4<u32>,
}

struct OctreeParams {
    depth: u32,
    level: u32,
    fragments: u32,
    capacity_tiles: u32,
    // transfer axis or distribution class
    variant: u32,
    max_groups: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: OctreeParams;
@group(0) @binding(1) var<storage, read> fragments: array<Fragment>;
@group(0) @binding(2) var<storage, read_write> nodes: array<Node>;
// bricks (binding 3), written through brick_load, brick_store and brick_exchange:
// common/svo_bricks_atomic_one.wgsl, one binding, or past one binding common/svo_bricks_atomic.wgsl
// (declaration sparse_voxel_octree_windowed).
@group(0) @binding(4) var<storage, read_write> flags: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> tile_parent: array<u32>;
@group(0) @binding(6) var<storage, read_write> levels: array<u32>;
@group(0) @binding(7) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(8) var<storage, read_write> stats: array<u32>;
@group(0) @binding(9) var<storage, read_write> args: array<u32>;
@group(0) @binding(10) var<storage, read_write> list_active: array<u32>;
@group(0) @binding(11) var<storage, read_write> list_ring: array<u32>;
// The static part's subdivided nodes: level k's keys are static_keys[static_offsets[k]..static_offsets[k+1]].
@group(0) @binding(12) var<storage, read> static_keys: array<u32>;
@group(0) @binding(13) var<storage, read> static_offsets: array<u32>;

fn linear(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

// Dispatch arguments for `count` threads of 64 in slot `slot`: 1D while it fits, else x * y.
fn write_args(slot: u32, count: u32) {
    let groups = (count + 63u) / 64u;
    var x = groups;
    var y = 1u;
    if (groups > params.max_groups) {
        y = (groups + params.max_groups - 1u) / params.max_groups;
        x = (groups + y - 1u) / y;
    }
    args[slot * 3u] = x;
    args[slot * 3u + 1u] = y;
    args[slot * 3u + 2u] = 1u;
}

// x + y, saturating, with ERR_OVERFLOW set on overflow (the mirror's `add`).
fn add_checked(x: u32, y: u32) -> u32 {
    if (x > 0xffffffffu - y) {
        atomicOr(&status[0], ERR_OVERFLOW);
        return 0xffffffffu;
    }
    return x + y;
}

fn outside(p: vec3<u32>) -> bool {
    let side = 2u << params.depth;
    return any(p > vec3<u32>(side));
}

@compute @workgroup_size(64)
fn flag_static(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let l = params.level;
    let i = static_offsets[l - 1u] + linear(gid, groups);
    if (i >= static_offsets[l]) {
        return;
    }
    let n = find(l - 1u, coords_of(static_keys[i]));
    if (n != NONE) {
        atomicOr(&flags[n], FLAG_SUBDIVIDE);
    }
}

@compute @workgroup_size(64)
fn flag_parents(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(gid, groups);
    if (i >= params.fragments * 8u) {
        return;
    }
    let p = fragments[i / 8u].pos;
    if (outside(p)) {
        if (i % 8u == 0u) {
            atomicOr(&status[0], ERR_OUTSIDE);
        }
        return;
    }
    let l = params.level;
    // The fragment's support at level l: at most two lattice points per axis.
    var lo = p;
    var hi = p;
    for (var k = l; k < params.depth; k = k + 1u) {
        lo = lo / 2u;
        hi = (hi + 1u) / 2u;
    }
    // Level-(l-1) nodes whose closed box (points 4c..=4c+4) holds a support point.
    let last = vec3<u32>((1u << (l - 1u)) - 1u);
    let clo = min((max(lo, vec3<u32>(1u)) - 1u) / 4u, last);
    let chi = min(hi / 4u, last);
    let o = i % 8u;
    let c = clo + vec3<u32>(o & 1u, (o >> 1u) & 1u, o >> 2u);
    if (any(c > chi)) {
        return;
    }
    let n = find(l - 1u, c);
    if (n != NONE) {
        atomicOr(&flags[n], FLAG_SUBDIVIDE);
    }
}

@compute @workgroup_size(64)
fn allocate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let l = params.level;
    let n = levels[l - 1u] * 8u + linear(gid, groups);
    if (n >= levels[l] * 8u) {
        return;
    }
    if ((atomicLoad(&flags[n]) & FLAG_SUBDIVIDE) == 0u) {
        return;
    }
    let t = atomicAdd(&status[1], 1u);
    if (t < params.capacity_tiles) {
        nodes[n].child = t;
        tile_parent[t] = n;
    } else {
        atomicOr(&status[0], ERR_POOL);
    }
}

@compute @workgroup_size(1)
fn finish_level() {
    let l = params.level;
    let end = min(atomicLoad(&status[1]), params.capacity_tiles);
    levels[l + 1u] = end;
    write_args(l, (end - levels[l]) * 8u);
}

@compute @workgroup_size(64)
fn init_nodes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let l = params.level;
    let n = levels[l] * 8u + linear(gid, groups);
    if (n >= levels[l + 1u] * 8u) {
        return;
    }
    let p = tile_parent[n / 8u];
    let ci = n % 8u;
    let c = 2u * coords_of(nodes[p].key) + vec3<u32>(ci & 1u, (ci >> 1u) & 1u, ci >> 2u);
    let last = (1u << l) - 1u;
    var node: Node;
    node.key = key_of(l, c);
    node.parent = p;
    node.child = NONE;
    for (var a = 0u; a < 3u; a = a + 1u) {
        var lo = NONE;
        var hi = NONE;
        if (c[a] > 0u) {
            var m = c;
            m[a] = c[a] - 1u;
            lo = find(l, m);
        }
        if (c[a] < last) {
            var m = c;
            m[a] = c[a] + 1u;
            hi = find(l, m);
        }
        node.neighbours[2u * a] = lo;
        node.neighbours[2u * a + 1u] = hi;
    }
    nodes[n] = node;
}

// Saturating atomic add (a compare-exchange loop): the saturated total min(MAX, sum) does not depend
// on the order of the adds, so it matches the mirror even on overflow (which is an error anyway).
fn atomic_add_saturating(i: u32, v: u32) {
    var old = brick_load(i);
    loop {
        var next = old + v;
        if (old > 0xffffffffu - v) {
            atomicOr(&status[0], ERR_OVERFLOW);
            next = 0xffffffffu;
        }
        let r = brick_exchange(i, old, next);
        if (r.y != 0u) {
            break;
        }
        old = r.x;
    }
}

@compute @workgroup_size(64)
fn splat(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(gid, groups);
    if (i >= params.fragments) {
        return;
    }
    let f = fragments[i];
    if (outside(f.pos) || all(f.value == vec4<u32>(0u))) {
        return;
    }
    let leaf = min(f.pos / 2u, vec3<u32>((1u << params.depth) - 1u));
    let n = find(params.depth, leaf);
    if (n == NONE) {
        return;
    }
    let base = n * BRICK_WORDS + voxel_index(f.pos - 2u * leaf) * 4u;
    for (var ch = 0u; ch < 4u; ch = ch + 1u) {
        atomic_add_saturating(base + ch, f.value[ch]);
    }
    atomicOr(&flags[n], FLAG_ACTIVE);
}

@compute @workgroup_size(1)
fn begin_level() {
    atomicStore(&status[2], 0u);
    atomicStore(&status[3], 0u);
}

fn level_node(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    let n = levels[params.level] * 8u + linear(gid, groups);
    if (n >= levels[params.level + 1u] * 8u) {
        return NONE;
    }
    return n;
}

// One step from n along axis (dir 0, 1, 2 = -1, 0, +1); NONE past the structure.
fn step_to(n: u32, axis: u32, dir: u32) -> u32 {
    if (n == NONE || dir == 1u) {
        return n;
    }
    return nodes[n].neighbours[2u * axis + dir / 2u];
}

@compute @workgroup_size(64)
fn mark_ring(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let n = level_node(gid, groups);
    if (n == NONE || (atomicLoad(&flags[n]) & FLAG_ACTIVE) == 0u) {
        return;
    }
    for (var dx = 0u; dx < 3u; dx = dx + 1u) {
        let a = step_to(n, 0u, dx);
        for (var dy = 0u; dy < 3u; dy = dy + 1u) {
            let b = step_to(a, 1u, dy);
            for (var dz = 0u; dz < 3u; dz = dz + 1u) {
                let c = step_to(b, 2u, dz);
                if (c != NONE) {
                    atomicOr(&flags[c], FLAG_RING);
                }
            }
        }
    }
}

@compute @workgroup_size(64)
fn compact(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let n = level_node(gid, groups);
    if (n == NONE) {
        return;
    }
    let f = atomicLoad(&flags[n]);
    if ((f & FLAG_ACTIVE) != 0u) {
        list_active[atomicAdd(&status[2], 1u)] = n;
    }
    if ((f & FLAG_RING) != 0u) {
        list_ring[atomicAdd(&status[3], 1u)] = n;
    }
}

@compute @workgroup_size(1)
fn list_args() {
    let l = params.level;
    let a = atomicLoad(&status[2]);
    let r = atomicLoad(&status[3]);
    stats[2u * l] = a;
    stats[2u * l + 1u] = r;
    write_args(SLOT_RING, r);
    write_args(SLOT_CLASS, a);
    write_args(SLOT_CLASS + 1u, a * 6u);
    write_args(SLOT_CLASS + 2u, a * 12u);
    write_args(SLOT_CLASS + 3u, a * 8u);
}

fn class_size(cls: u32) -> u32 {
    return select(select(select(8u, 12u, cls == 2u), 6u, cls == 1u), 1u, cls == 0u);
}

// The `which`-th voxel (index order) with `cls` coordinates on the brick's boundary.
fn class_voxel(cls: u32, which: u32) -> vec3<u32> {
    var seen = 0u;
    for (var i = 0u; i < 27u; i = i + 1u) {
        let v = vec3<u32>(i % 3u, (i / 3u) % 3u, i / 9u);
        let b = select(0u, 1u, v.x != 1u) + select(0u, 1u, v.y != 1u) + select(0u, 1u, v.z != 1u);
        if (b == cls) {
            if (seen == which) {
                return v;
            }
            seen = seen + 1u;
        }
    }
    return vec3<u32>(1u);
}

@compute @workgroup_size(64)
fn distribute(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let cls = params.variant;
    let per = class_size(cls);
    let i = linear(gid, groups);
    if (i >= atomicLoad(&status[2]) * per) {
        return;
    }
    let n = list_active[i / per];
    let v = class_voxel(cls, i % per);
    let t = nodes[n].child;
    let pc = coords_of(nodes[n].key);
    let last = (1u << params.level) - 1u;
    for (var ch = 0u; ch < 4u; ch = ch + 1u) {
        var s = 0u;
        // Child lattice points q = 2v + d within the node (0..=4 per axis), z, y, x order as the mirror.
        for (var dz = 0u; dz < 3u; dz = dz + 1u) {
            for (var dy = 0u; dy < 3u; dy = dy + 1u) {
                for (var dx = 0u; dx < 3u; dx = dx + 1u) {
                    let qi = vec3<i32>(2u * v) + vec3<i32>(vec3<u32>(dx, dy, dz)) - vec3<i32>(1);
                    if (any(qi < vec3<i32>(0)) || any(qi > vec3<i32>(4))) {
                        continue;
                    }
                    let q = vec3<u32>(qi);
                    // Weight per axis: 1 at distance one; 2 at distance zero, 1 on a face shared with
                    // another node of this level (it counts the other half). Units of 1/64.
                    var w = 1u;
                    for (var a = 0u; a < 3u; a = a + 1u) {
                        if (q[a] == 2u * v[a]) {
                            let on_shared_face = (q[a] == 0u && pc[a] > 0u) || (q[a] == 4u && pc[a] < last);
                            w = w * select(2u, 1u, on_shared_face);
                        }
                    }
                    let c = min(q / 2u, vec3<u32>(1u));
                    let child = t * 8u + c.x + 2u * c.y + 4u * c.z;
                    let x = brick_load(child * BRICK_WORDS + voxel_index(q - 2u * c) * 4u + ch);
                    var prod = x * w;
                    if (x > 0xffffffffu / w) {
                        atomicOr(&status[0], ERR_OVERFLOW);
                        prod = 0xffffffffu;
                    }
                    s = add_checked(s, prod);
                }
            }
        }
        brick_store(n * BRICK_WORDS + voxel_index(v) * 4u + ch, s);
    }
}

// Voxel index of (u, v) on the face of `axis` at coordinate `at` (u, v on the other axes in order).
fn face_voxel(axis: u32, at: u32, u: u32, v: u32) -> u32 {
    var c = vec3<u32>(0u);
    let a = (axis + 1u) % 3u;
    let b = (axis + 2u) % 3u;
    c[min(a, b)] = u;
    c[max(a, b)] = v;
    c[axis] = at;
    return voxel_index(c);
}

fn ring_node(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    let i = linear(gid, groups);
    if (i >= atomicLoad(&status[3])) {
        return NONE;
    }
    return list_ring[i];
}

// Brick border transfer along params.variant (Fig. 9 left): pass 1 (`add`) adds each ring node's +axis
// face into its +axis neighbour's -axis face, pass 2 copies that face (now the sum) back. Each face has
// one writer per pass: no atomic read-modify-write (the atomic type is the splat's).
fn transfer(gid: vec3<u32>, groups: vec3<u32>, add: bool) {
    let n = ring_node(gid, groups);
    if (n == NONE) {
        return;
    }
    let axis = params.variant;
    let r = nodes[n].neighbours[2u * axis + 1u];
    if (r == NONE) {
        return;
    }
    for (var v = 0u; v < 3u; v = v + 1u) {
        for (var u = 0u; u < 3u; u = u + 1u) {
            let hi = n * BRICK_WORDS + face_voxel(axis, 2u, u, v) * 4u;
            let lo = r * BRICK_WORDS + face_voxel(axis, 0u, u, v) * 4u;
            for (var ch = 0u; ch < 4u; ch = ch + 1u) {
                if (add) {
                    let s = add_checked(brick_load(lo + ch), brick_load(hi + ch));
                    brick_store(lo + ch, s);
                } else {
                    brick_store(hi + ch, brick_load(lo + ch));
                }
            }
        }
    }
}

@compute @workgroup_size(64)
fn transfer_add(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    transfer(gid, groups, true);
}

@compute @workgroup_size(64)
fn transfer_copy(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    transfer(gid, groups, false);
}

@compute @workgroup_size(64)
fn round_level(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let n = ring_node(gid, groups);
    if (n == NONE) {
        return;
    }
    for (var w = 0u; w < BRICK_WORDS; w = w + 1u) {
        let i = n * BRICK_WORDS + w;
        brick_store(i, add_checked(brick_load(i), 32u) >> 6u);
    }
}

@compute @workgroup_size(64)
fn mark_parents(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let n = ring_node(gid, groups);
    if (n == NONE) {
        return;
    }
    for (var w = 0u; w < BRICK_WORDS; w = w + 1u) {
        if (brick_load(n * BRICK_WORDS + w) != 0u) {
            atomicOr(&flags[nodes[n].parent], FLAG_ACTIVE);
            return;
        }
    }
}
