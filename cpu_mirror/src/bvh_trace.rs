//! Mirror of `kernels/common/bvh_trace.wgsl`: rays against triangles through a flattened BVH, in the
//! WGSL's operation order.
//!
//! - Triangles are two-sided for occlusion (back faces block light) and report which side was hit:
//!   the front is the side from which the vertices appear counter-clockwise, i.e. the ray hits the front
//!   when `det = e1 . (d x e2) > 0`.
//! - The BVH is the `bvh` crate's flat layout (stackless: `entry` on a box hit, `exit` on a miss; leaves
//!   have `entry == NONE` and a shape). Boxes are padded on the host (see `vxgi::trace`) so the box test
//!   is conservative under any rounding: GPU and mirror visit a superset of the triangles that matter,
//!   and the result depends only on the triangle tests.
//! - `slack` widens (> 0) or narrows (< 0) the barycentric test: the comparison uses it to tell
//!   pixels whose hit is decided by rounding (ray within `slack` of an edge) from the rest.
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

pub const NONE: u32 = u32::MAX;

/// "No end" for rays: the WGSL has no infinity literal, so both sides use this.
pub const FAR: f32 = 3.0e38;

/// One triangle as the kernels read it: vertices (a.w = material index as f32) and vertex normals.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    pub a: [f32; 4],
    pub b: [f32; 4],
    pub c: [f32; 4],
    pub na: [f32; 4],
    pub nb: [f32; 4],
    pub nc: [f32; 4],
}

impl GpuTriangle {
    pub fn material(&self) -> u32 {
        self.a[3] as u32
    }
}

/// One flat BVH node (48 bytes, the WGSL `BvhNode`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuNode {
    pub lo: [f32; 3],
    pub entry: u32,
    pub hi: [f32; 3],
    pub exit: u32,
    pub shape: u32,
    pub _pad: [u32; 3],
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// A ray-triangle hit: distance, barycentrics of b and c, the determinant (> 0: front face).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub det: f32,
}

/// Two-sided Möller–Trumbore: a hit with `t_min < t < t_max` and barycentrics inside the triangle
/// widened by `slack`.
pub fn intersect(
    o: Vec3,
    d: Vec3,
    tri: &GpuTriangle,
    t_min: f32,
    t_max: f32,
    slack: f32,
) -> Option<TriHit> {
    let a = v3(tri.a);
    let e1 = v3(tri.b) - a;
    let e2 = v3(tri.c) - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if u < -slack || u > 1.0 + slack {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < -slack || u + v > 1.0 + slack {
        return None;
    }
    let t = e2.dot(q) * inv;
    if t > t_min && t < t_max {
        Some(TriHit { t, u, v, det })
    } else {
        None
    }
}

/// Slab test of a padded box against `[0, t_max]`.
pub fn box_hit(o: Vec3, inv_d: Vec3, lo: Vec3, hi: Vec3, t_max: f32) -> bool {
    let t1 = (lo - o) * inv_d;
    let t2 = (hi - o) * inv_d;
    let near = t1.min(t2);
    let far = t1.max(t2);
    let t_near = near.x.max(near.y).max(near.z).max(0.0);
    let t_far = far.x.min(far.y).min(far.z).min(t_max);
    t_near <= t_far
}

/// 1/d with zero components replaced by a tiny value of the same sign, so no 0 * inf appears.
pub fn safe_inverse(d: Vec3) -> Vec3 {
    let f = |x: f32| {
        if x.abs() < 1e-20 {
            1.0 / 1e-20f32.copysign(x)
        } else {
            1.0 / x
        }
    };
    Vec3::new(f(d.x), f(d.y), f(d.z))
}

/// The nearest hit along the ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub tri: u32,
    pub u: f32,
    pub v: f32,
    pub front: bool,
}

/// The stackless walk both queries share (bvh_trace.wgsl's loop): nodes in the flat order, a box
/// entered where the ray meets it before `t_far`, each leaf's triangle index given to `leaf` with
/// the current `t_far`; `leaf` returns the next `t_far` (a hit's t narrows it), or None to end the
/// walk.
fn walk(
    nodes: &[GpuNode],
    o: Vec3,
    d: Vec3,
    mut t_far: f32,
    mut leaf: impl FnMut(u32, f32) -> Option<f32>,
) {
    let inv_d = safe_inverse(d);
    let mut i = 0usize;
    while i < nodes.len() {
        let n = &nodes[i];
        if n.entry == NONE {
            match leaf(n.shape, t_far) {
                Some(t) => t_far = t,
                None => return,
            }
            i = n.exit as usize;
        } else if box_hit(o, inv_d, Vec3::from(n.lo), Vec3::from(n.hi), t_far) {
            i = n.entry as usize;
        } else {
            i = n.exit as usize;
        }
    }
}

/// Nearest hit in `(t_min, t_max)`, visiting nodes in the flat order (ties keep the first visited).
pub fn closest(
    nodes: &[GpuNode],
    tris: &[GpuTriangle],
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    walk(nodes, o, d, t_max, |shape, t_far| {
        let Some(h) = intersect(o, d, &tris[shape as usize], t_min, t_far, 0.0) else {
            return Some(t_far);
        };
        best = Some(Hit {
            t: h.t,
            tri: shape,
            u: h.u,
            v: h.v,
            front: h.det > 0.0,
        });
        Some(h.t)
    });
    best
}

/// Whether anything (either face) lies on the ray in `(t_min, t_max)`.
pub fn occluded(
    nodes: &[GpuNode],
    tris: &[GpuTriangle],
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
) -> bool {
    let mut hit = false;
    walk(nodes, o, d, t_max, |shape, t_far| {
        hit = intersect(o, d, &tris[shape as usize], t_min, t_far, 0.0).is_some();
        (!hit).then_some(t_far)
    });
    hit
}

/// Every triangle (brute force) the ray hits with barycentrics widened by `slack`: the comparison's
/// view of "which triangles could rounding have picked".
pub fn all_hits(
    tris: &[GpuTriangle],
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
    slack: f32,
) -> Vec<(u32, TriHit)> {
    tris.iter()
        .enumerate()
        .filter_map(|(i, t)| intersect(o, d, t, t_min, t_max, slack).map(|h| (i as u32, h)))
        .collect()
}
