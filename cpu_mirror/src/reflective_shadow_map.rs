//! Mirror of `kernels/reflective_shadow_map.wgsl`: one light view's reflective shadow map (Dachsbacher &
//! Stamminger 2005, as LRSM section 5 renders it) from a G-buffer ray-cast from that view, written in
//! the 2D Morton order `lrsm_partition` reads.
//!
//! A light view (`GpuView`) is a pinhole at the light: a spot light has one (its cone), a point light
//! six 90-degree cube faces. Per RSM texel m (x, y) = Morton decode of m, G-buffer pixel y * side + x:
//! * nothing hit, or a back face (the contract: back faces reflect nothing): radiance (0, 0), normal 0,
//!   depth 1 — coverage 0, so the partition leaves it out;
//! * else, with `incident` of the shared light contract (no shadow ray: the view sees the point):
//!   radiance = (albedo / pi * E * <n.l>, 1), normal = (n, <n.l>), depth = clamp((p - eye) . forward
//!   - near) / (far - near), 0, 1): the light-space depth the gather's cone samples use too.
use crate::direct_light::{incident, incident_error, GpuLight};
use crate::morton;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::f32::consts::PI;

/// One light view (the WGSL `LrsmView`, common/lrsm_view.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuView {
    /// Light position (orthographic: the image plane's centre); w = near.
    pub eye: [f32; 4],
    /// Unit view axis; w = 1 / (far - near).
    pub forward: [f32; 4],
    /// Unit right / tan(half fov): x in [-1, 1] is `dot(p - eye, right) / depth`; w = LRSM level-0
    /// texels per unit of diameter at depth 1, `side0 / (2 tan)`. Orthographic: unit right / half
    /// width, x = `dot(p - eye, right)`, w = `side0 / (2 half width)`.
    pub right: [f32; 4],
    /// Unit up / tan(half fov) (image rows run down: v = (1 - y) / 2); w unused.
    pub up: [f32; 4],
    /// RSM side, light index, first texel of this view's LRSM in the concatenated streams, projection
    /// (0 perspective, 1 orthographic).
    pub info: [u32; 4],
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

impl GpuView {
    /// Light-space depth of `p` normalised by the view's near and far, unclamped, in the kernels'
    /// operation order.
    pub fn depth(&self, p: Vec3) -> f32 {
        (self.axis_depth(p) - self.eye[3]) * self.forward[3]
    }

    /// Distance of `p` along the view's axis (`view_axis_depth`).
    pub fn axis_depth(&self, p: Vec3) -> f32 {
        let rel = p - v3(self.eye);
        let f = v3(self.forward);
        (rel.x * f.x + rel.y * f.y) + rel.z * f.z
    }

    /// Whether the view is orthographic (a directional light's).
    pub fn orthographic(&self) -> bool {
        self.info[3] == 1
    }

    /// `(nx, ny, zv)` of `p` (the gather's projection), or None behind the view. Perspective views
    /// divide by `zv`, orthographic ones do not.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32, f32)> {
        let zv = self.axis_depth(p);
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(zv > 0.0) {
            return None;
        }
        let rel = p - v3(self.eye);
        let (r, u) = (self.right, self.up);
        let nx = (rel.x * r[0] + rel.y * r[1]) + rel.z * r[2];
        let ny = (rel.x * u[0] + rel.y * u[1]) + rel.z * u[2];
        if self.orthographic() {
            Some((nx, ny, zv))
        } else {
            Some((nx / zv, ny / zv, zv))
        }
    }
}

/// One texel: (radiance, normal, depth) and their bounds (radiance per channel, normal's w, depth).
pub struct Texel {
    pub radiance: [f32; 4],
    pub normal: [f32; 4],
    pub depth: f32,
    pub radiance_bound: [f32; 4],
    pub normal_bound: [f32; 4],
    pub depth_bound: f32,
}

/// RSM texel from G-buffer pixel (position, normal, albedo) of `view`, lit by `light`.
///
/// Bounds (WGSL rules, u = 2^-24): radiance as `direct_light`'s term (64 ULP of the term, the cosine's
/// error `incident_error` + 8 ULP absolute times the term's scale, `incident_error`'s irradiance, e.g. a
/// spot's soft edge); <n.l> the cosine's error; depth 8 ULP of the magnitudes it is computed from, times
/// 1 / (far - near), plus one ULP of 1. Coverage, normal xyz: copies, exact.
pub fn texel(
    view: &GpuView,
    light: &GpuLight,
    position: [f32; 4],
    normal: [f32; 4],
    albedo: [f32; 4],
) -> Texel {
    let u = f32::EPSILON;
    if normal[3] <= 0.0 {
        return Texel {
            radiance: [0.0; 4],
            normal: [0.0; 4],
            depth: 1.0,
            radiance_bound: [0.0; 4],
            normal_bound: [0.0; 4],
            depth_bound: 0.0,
        };
    }
    let p = v3(position);
    let n = v3(normal);
    let inc = incident(light, p);
    let (e_irr, e_dir) = incident_error(light, p, 0.0);
    let e_cos = e_dir + 8.0 * u;
    let cos = n.dot(inc.wi);
    let ndotl = cos.max(0.0);
    let kd = v3(albedo) * (1.0 / PI);
    let rad = kd * inc.irradiance * ndotl;
    let rb = if cos > -e_cos {
        rad * (64.0 * u) + kd * inc.irradiance * e_cos + kd * e_irr * (ndotl + e_cos)
    } else {
        Vec3::ZERO
    };
    let d = view.depth(p);
    let rel = p - v3(view.eye);
    let mag = rel.abs().dot(v3(view.forward).abs()) + view.eye[3].abs();
    Texel {
        radiance: [rad.x, rad.y, rad.z, 1.0],
        normal: [n.x, n.y, n.z, ndotl],
        depth: d.clamp(0.0, 1.0),
        radiance_bound: [rb.x, rb.y, rb.z, 0.0],
        normal_bound: [0.0, 0.0, 0.0, if cos > -e_cos { e_cos } else { 0.0 }],
        depth_bound: 8.0 * u * mag * view.forward[3] + u,
    }
}

/// The whole RSM of `view` from its row-major G-buffer: Morton-ordered (radiance, normal, depth) and
/// the bounds, as the kernel writes them.
pub struct Rsm {
    pub radiance: Vec<[f32; 4]>,
    pub normal: Vec<[f32; 4]>,
    pub depth: Vec<f32>,
    pub radiance_bound: Vec<[f32; 4]>,
    pub normal_bound: Vec<[f32; 4]>,
    pub depth_bound: Vec<f32>,
}

pub fn rsm(
    view: &GpuView,
    lights: &[GpuLight],
    position: &[[f32; 4]],
    normal: &[[f32; 4]],
    albedo: &[[f32; 4]],
) -> Rsm {
    let side = view.info[0];
    let light = &lights[view.info[1] as usize];
    let n = (side * side) as usize;
    let mut out = Rsm {
        radiance: Vec::with_capacity(n),
        normal: Vec::with_capacity(n),
        depth: Vec::with_capacity(n),
        radiance_bound: Vec::with_capacity(n),
        normal_bound: Vec::with_capacity(n),
        depth_bound: Vec::with_capacity(n),
    };
    for m in 0..n as u32 {
        let [x, y] = morton::decode2(m);
        let pix = (y * side + x) as usize;
        let t = texel(view, light, position[pix], normal[pix], albedo[pix]);
        out.radiance.push(t.radiance);
        out.normal.push(t.normal);
        out.depth.push(t.depth);
        out.radiance_bound.push(t.radiance_bound);
        out.normal_bound.push(t.normal_bound);
        out.depth_bound.push(t.depth_bound);
    }
    out
}
