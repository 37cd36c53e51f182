// common/bvh_trace.wgsl — rays against triangles through a flattened BVH (the `bvh` crate's stackless
// layout: `entry` on a box hit, `exit` on a miss, leaves have entry == NONE and a shape).
// Mirror: cpu_mirror/src/bvh_trace.rs. Included by gbuffer.wgsl and direct_light.wgsl, which declare
// the module-scope bindings `nodes: array<BvhNode>` and `triangles: array<Triangle>` used here.
// Needs common/scene_types.wgsl (Triangle, Material).
//
// Triangles are two-sided for occlusion and report the side hit (front: vertices counter-clockwise,
// det > 0). Boxes are padded on the host so the slab test is conservative under any rounding.

const NONE: u32 = 0xffffffffu;

struct BvhNode {
    lo: vec3<f32>,
    entry: u32,
    hi: vec3<f32>,
    exit: u32,
    shape: u32,
}

struct TriHit {
    hit: bool,
    t: f32,
    u: f32,
    v: f32,
    det: f32,
}

// Two-sided Möller–Trumbore, hits with t_min < t < t_max.
fn intersect_triangle(o: vec3<f32>, d: vec3<f32>, tri: Triangle, t_min: f32, t_max: f32) -> TriHit {
    var r = TriHit(false, 0.0, 0.0, 0.0, 0.0);
    let a = tri.a.xyz;
    let e1 = tri.b.xyz - a;
    let e2 = tri.c.xyz - a;
    let p = cross(d, e2);
    let det = dot(e1, p);
    if (det == 0.0) {
        return r;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = dot(s, p) * inv;
    if (u < 0.0 || u > 1.0) {
        return r;
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) {
        return r;
    }
    let t = dot(e2, q) * inv;
    if (t > t_min && t < t_max) {
        r = TriHit(true, t, u, v, det);
    }
    return r;
}

fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    let tiny = select(vec3<f32>(1e-20), vec3<f32>(-1e-20), d < vec3<f32>(0.0));
    return 1.0 / select(d, tiny, abs(d) < vec3<f32>(1e-20));
}

fn box_hit(o: vec3<f32>, inv_d: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>, t_max: f32) -> bool {
    let t1 = (lo - o) * inv_d;
    let t2 = (hi - o) * inv_d;
    let near = min(t1, t2);
    let far = max(t1, t2);
    let t_near = max(max(max(near.x, near.y), near.z), 0.0);
    let t_far = min(min(min(far.x, far.y), far.z), t_max);
    return t_near <= t_far;
}

struct Hit {
    tri: u32,   // NONE: no hit
    t: f32,
    u: f32,
    v: f32,
    det: f32,
}

// Nearest hit in (t_min, t_max), nodes visited in flat order.
fn trace_closest(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> Hit {
    let inv_d = safe_inverse(d);
    var best = Hit(NONE, t_max, 0.0, 0.0, 0.0);
    var i = 0u;
    let count = arrayLength(&nodes);
    while (i < count) {
        let n = nodes[i];
        if (n.entry == NONE) {
            let h = intersect_triangle(o, d, triangles[n.shape], t_min, best.t);
            if (h.hit) {
                best = Hit(n.shape, h.t, h.u, h.v, h.det);
            }
            i = n.exit;
        } else if (box_hit(o, inv_d, n.lo, n.hi, best.t)) {
            i = n.entry;
        } else {
            i = n.exit;
        }
    }
    return best;
}

// Whether any triangle (either face) lies on the ray in (t_min, t_max).
fn trace_occluded(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> bool {
    let inv_d = safe_inverse(d);
    var i = 0u;
    let count = arrayLength(&nodes);
    while (i < count) {
        let n = nodes[i];
        if (n.entry == NONE) {
            if (intersect_triangle(o, d, triangles[n.shape], t_min, t_max).hit) {
                return true;
            }
            i = n.exit;
        } else if (box_hit(o, inv_d, n.lo, n.hi, t_max)) {
            i = n.entry;
        } else {
            i = n.exit;
        }
    }
    return false;
}
