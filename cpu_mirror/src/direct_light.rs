//! Mirror of `kernels/direct_light.wgsl`: direct light with exact hard shadows (one shadow ray per light
//! through the flattened BVH) at every G-buffer texel, following the light-transport contract:
//!
//! - back faces (side <= 0) and background reflect nothing;
//! - BRDF `kd / pi + ks (n + 2) / (2 pi) max(r . wo, 0)^n`, r = the mirror direction of the light about
//!   the shading normal, wo = towards the eye, n = shininess;
//! - point: irradiance `I cos / r^2`; spot: the same times `spot_factor` (1 inside `falloff`, 0 outside
//!   `cone`, smoothstep in cosine between); directional: `I cos`;
//! - a light below the geometric surface (`ng . wi <= 0`) or the shading normal (`cos <= 0`) adds
//!   nothing; shadow rays start at `p + ng * eps` and end `2 eps` short of the light ([`shadow_end`]) or
//!   run to infinity.
//!
//! The reference renderer (`vxgi::reference`) calls [`shade`] too: one definition of the contract.
use crate::bvh_trace::{all_hits, occluded, GpuNode, GpuTriangle, FAR};
use crate::gbuffer::Frame;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::f32::consts::PI;

pub const POINT: f32 = 0.0;
pub const SPOT: f32 = 1.0;
pub const DIRECTIONAL: f32 = 2.0;

/// One light (the WGSL `Light`): position.w = kind, direction (unit, travel direction).w = cos(cone),
/// intensity.w = cos(falloff).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    pub position: [f32; 4],
    pub direction: [f32; 4],
    pub intensity: [f32; 4],
}

/// diffuse.w = Phong exponent n; texture = (first texel in the atlas, width, height, 0) of the
/// `map_Kd` texture that replaces diffuse.rgb, width 0 when there is none (see `gbuffer::albedo`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    pub diffuse: [f32; 4],
    pub specular: [f32; 4],
    pub texture: [u32; 4],
}

impl GpuMaterial {
    /// The material with its diffuse albedo replaced by `albedo` (a G-buffer texel's, which is the
    /// texture's where the material has one).
    pub fn with_albedo(&self, albedo: [f32; 4]) -> Self {
        Self {
            diffuse: [albedo[0], albedo[1], albedo[2], self.diffuse[3]],
            ..*self
        }
    }
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// 1 at or inside the falloff cone, 0 outside the cone, smoothstep in cosine between.
pub fn spot_factor(cos_a: f32, cos_cone: f32, cos_falloff: f32) -> f32 {
    if cos_a >= cos_falloff {
        1.0
    } else if cos_a < cos_cone {
        0.0
    } else {
        let t = ((cos_a - cos_cone) / (cos_falloff - cos_cone)).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    }
}

/// What reaches a surface point from one light: unit direction to it, irradiance scale (intensity
/// times falloff over r^2, without the cosine), and the shadow ray's end.
pub struct Incident {
    pub wi: Vec3,
    pub irradiance: Vec3,
    pub t_max: f32,
    /// For spots: how far (in cosine) the point is from the cone's hard edge (inf otherwise).
    pub edge: f32,
}

pub fn incident(light: &GpuLight, p: Vec3) -> Incident {
    let kind = light.position[3];
    let dir = v3(light.direction);
    let i = v3(light.intensity);
    if kind == DIRECTIONAL {
        return Incident {
            wi: -dir,
            irradiance: i,
            t_max: FAR,
            edge: f32::INFINITY,
        };
    }
    let l = v3(light.position) - p;
    let r2 = l.dot(l);
    let r = r2.sqrt();
    let wi = l / r;
    let mut e = i / r2;
    let mut edge = f32::INFINITY;
    if kind == SPOT {
        let cos_a = -wi.dot(dir);
        e *= spot_factor(cos_a, light.direction[3], light.intensity[3]);
        if light.direction[3] == light.intensity[3] {
            edge = (cos_a - light.direction[3]).abs();
        }
    }
    Incident {
        wi,
        irradiance: e,
        t_max: r,
        edge,
    }
}

/// How far a conforming GPU's [`incident`] at `p` may be from the mirror's when its point may differ by
/// `dp` (absolute, per component; 0 where `p` is an input): `(irradiance, direction)`, bounds on
/// |Δ irradiance| per channel and on |Δ wi| per component (so on any cosine with a unit vector).
/// * direction: `lv / r` with `lv = light - p` carries `dp / r`, plus 8 ULP for `sqrt` (via
///   inverseSqrt) and WGSL's 2.5-ULP division (an H100 computes `lv * rcp(r)`);
/// * `I / r^2`: relative `2 dp / r` from the point (the rounding of `r^2` and the division sit in the
///   term's 64-ULP budget);
/// * spot: the cosine to the axis moves by the direction's error, and the smoothstep's change over
///   that interval is taken exactly (it is monotone): near the cone's edge the factor `3t^2` has a large
///   *relative* error, and past it the mirror's 0 may be the GPU's `3t^2` (both seen on an H100: 2358
///   ULP where t ~ 1e-2, 3e-9 against 0).
///
/// Each part is doubled, since it is first order.
pub fn incident_error(light: &GpuLight, p: Vec3, dp: f32) -> (Vec3, f32) {
    let u = f32::EPSILON;
    if light.position[3] == DIRECTIONAL {
        return (Vec3::ZERO, 0.0);
    }
    let lv = v3(light.position) - p;
    let r2 = lv.dot(lv);
    let r = r2.sqrt();
    if r2 <= 0.0 || !r2.is_finite() {
        return (Vec3::ZERO, 0.0);
    }
    let e_dir = 2.0 * (dp / r + 8.0 * u);
    let i = v3(light.intensity) / r2;
    let mut e = i * (2.0 * 2.0 * dp / r);
    if light.position[3] == SPOT {
        let dir = v3(light.direction);
        let cos_a = -(lv / r).dot(dir);
        let (cc, cf) = (light.direction[3], light.intensity[3]);
        let f = spot_factor(cos_a, cc, cf);
        let df = (spot_factor(cos_a + e_dir, cc, cf) - f)
            .abs()
            .max((f - spot_factor(cos_a - e_dir, cc, cf)).abs());
        e = e * f + i * (2.0 * df);
    }
    (e, e_dir)
}

/// BRDF value for light from `wi`, seen from `wo`, shading normal `n` (cos = n . wi > 0).
pub fn brdf(m: &GpuMaterial, n: Vec3, wi: Vec3, wo: Vec3, cos: f32) -> Vec3 {
    let kd = v3(m.diffuse) * (1.0 / PI);
    let ks = v3(m.specular);
    if ks == Vec3::ZERO {
        return kd;
    }
    let shin = m.diffuse[3];
    let r = n * (2.0 * cos) - wi;
    let x = r.dot(wo);
    let lobe = if x > 0.0 { x.powf(shin) } else { 0.0 };
    kd + ks * ((shin + 2.0) * (0.5 / PI) * lobe)
}

/// Bound on the specular lobe's error in [`brdf`] (per channel; 0 without Ks): `pow`'s rule,
/// inherited from exp2(y log2 x) (log2 absolute 2^-21 near 1, exp2 3 + 2|y log2 x| ULP), plus the
/// propagated error of x.
pub fn brdf_error(m: &GpuMaterial, n: Vec3, wi: Vec3, wo: Vec3, cos: f32) -> Vec3 {
    let u = f32::EPSILON;
    let ks = v3(m.specular);
    if ks == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let shin = m.diffuse[3];
    let r = n * (2.0 * cos) - wi;
    let x = r.dot(wo);
    if x <= 0.0 {
        return Vec3::ZERO;
    }
    let xn = x.powf(shin);
    let pow_err = xn
        * (std::f32::consts::LN_2 * shin * 2f32.powi(-21)
            + (3.0 + 2.0 * (shin * x.log2()).abs()) * u)
        + shin * x.powf((shin - 1.0).max(0.0)) * 8.0 * u;
    ks * ((shin + 2.0) * (0.5 / PI) * pow_err)
}

/// Reflected direct radiance at `p` (shading normal `n`, geometric front normal `ng`) towards `wo`,
/// with shadow rays through the flattened BVH.
#[allow(clippy::too_many_arguments)]
pub fn shade(
    nodes: &[GpuNode],
    tris: &[GpuTriangle],
    lights: &[GpuLight],
    m: &GpuMaterial,
    p: Vec3,
    n: Vec3,
    ng: Vec3,
    wo: Vec3,
    eps: f32,
) -> Vec3 {
    shade_with(
        |o, d, t0, t1| occluded(nodes, tris, o, d, t0, t1),
        lights,
        m,
        p,
        n,
        ng,
        wo,
        eps,
    )
}

/// [`shade`] with any exact occlusion query `occluded(origin, direction, t_min, t_max)`.
#[allow(clippy::too_many_arguments)]
pub fn shade_with(
    occluded: impl Fn(Vec3, Vec3, f32, f32) -> bool,
    lights: &[GpuLight],
    m: &GpuMaterial,
    p: Vec3,
    n: Vec3,
    ng: Vec3,
    wo: Vec3,
    eps: f32,
) -> Vec3 {
    let origin = p + ng * eps;
    let mut sum = Vec3::ZERO;
    for light in lights {
        let inc = incident(light, p);
        let cos = n.dot(inc.wi);
        if cos <= 0.0 || ng.dot(inc.wi) <= 0.0 || inc.irradiance == Vec3::ZERO {
            continue;
        }
        if occluded(origin, inc.wi, 0.0, shadow_end(inc.t_max, eps)) {
            continue;
        }
        sum += brdf(m, n, inc.wi, wo, cos) * inc.irradiance * cos;
    }
    sum
}

/// Where a shadow ray towards a light at distance `t_light` from the surface point (3e38 for a
/// directional light) ends: `2 eps` short of it. The ray starts `eps` off the surface, which may
/// bring it up to `eps` nearer the light, and ends `eps` before that, so that a light lying in a
/// surface's plane (a point light placed on a ceiling) is not shadowed by that plane within
/// rounding, as the point is not by its own surface; 0 for a light nearer than `2 eps`. A product
/// by 2 and one correctly rounded subtraction: the GPU's value is this one.
pub fn shadow_end(t_light: f32, eps: f32) -> f32 {
    (t_light - 2.0 * eps).max(0.0)
}

/// Geometric front normal of a triangle (normalised cross of its edges).
pub fn face_normal(tri: &GpuTriangle) -> Vec3 {
    let a = v3(tri.a);
    let c = (v3(tri.b) - a).cross(v3(tri.c) - a);
    c * (1.0 / c.dot(c).sqrt())
}

/// The mirror's radiance for one G-buffer texel and its bound |GPU - mirror|.
///
/// Bound, per light term: 64 ULP of the term (about 20 correctly rounded or 2.5-ULP operations from the
/// G-buffer texel to the sum, each contributing relative error), 8 ULP absolute on the cosines times the
/// term's scale (cosines near 0 have large relative but small absolute error), and `pow`'s rule
/// (inherited from exp2(y log2 x): log2 absolute 2^-21 near 1, exp2 3 + 2|y log2 x| ULP, plus the
/// propagated error of x). Terms whose visibility or spot edge is decided by rounding (a shadow ray
/// within 1e-4 barycentric of an occluder's edge, a light within 1e-5 of grazing the geometric surface,
/// a point within 1e-5 in cosine of a hard spot edge) add their whole value: the GPU may have either.
/// Plus [`incident_error`]: the spot factor's change over the cosine's error (near a soft edge, and
/// just past it where the mirror has 0).
#[allow(clippy::too_many_arguments)]
pub fn shade_with_bound(
    frame: &Frame,
    nodes: &[GpuNode],
    tris: &[GpuTriangle],
    lights: &[GpuLight],
    materials: &[GpuMaterial],
    position: [f32; 4],
    normal: [f32; 4],
    triangle: u32,
    albedo: [f32; 4],
) -> (Vec3, Vec3) {
    if normal[3] <= 0.0 || triangle as usize >= tris.len() {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let tri = &tris[triangle as usize];
    let m = &materials[(tri.material() as usize).min(materials.len() - 1)].with_albedo(albedo);
    let p = v3(position);
    let n = v3(normal);
    let ng = face_normal(tri);
    let eye = v3(frame.eye);
    let eps = frame.eye[3];
    let wo = eye - p;
    let wo = wo * (1.0 / wo.dot(wo).sqrt());
    let origin = p + ng * eps;
    let u = f32::EPSILON;
    let mut sum = Vec3::ZERO;
    let mut bound = Vec3::ZERO;
    for light in lights {
        let inc = incident(light, p);
        let (e_irr, e_dir) = incident_error(light, p, 0.0);
        let cos = n.dot(inc.wi);
        let geo = ng.dot(inc.wi);
        // Full term without the cut-offs, for the ambiguity allowance.
        let scale = |c: f32| brdf(m, n, inc.wi, wo, c.max(0.0)) * inc.irradiance;
        let ambiguous_geo = geo.abs() < 1e-5 && cos > 0.0;
        let ambiguous_edge = inc.edge < 1e-5;
        if cos <= 0.0 || geo <= 0.0 || inc.irradiance == Vec3::ZERO {
            if ambiguous_geo || ambiguous_edge {
                bound += scale(cos) * cos.max(0.0) + scale(1.0) * (8.0 * u);
            }
            // Past a soft spot's edge the GPU's factor may be a small 3t^2 instead of 0; cosines
            // within their error of 0 may be the GPU's small positive ones.
            let e_cos = e_dir + 8.0 * u;
            if cos > -e_cos && geo > -e_cos {
                bound += brdf(m, n, inc.wi, wo, cos.max(0.0))
                    * (e_irr + inc.irradiance)
                    * (cos.max(0.0) + e_cos);
            }
            continue;
        }
        let t_end = shadow_end(inc.t_max, eps);
        let strict = occluded(nodes, tris, origin, inc.wi, 0.0, t_end);
        let term = brdf(m, n, inc.wi, wo, cos) * inc.irradiance * cos;
        let t_lo = -eps * 0.01;
        let t_hi = (t_end * (1.0 + 1e-5)).min(FAR);
        let wide = !all_hits(tris, origin, inc.wi, t_lo, t_hi, 1e-4).is_empty();
        let narrow = !all_hits(
            tris,
            origin,
            inc.wi,
            eps * 0.01,
            t_end * (1.0 - 1e-5),
            -1e-4,
        )
        .is_empty();
        let ambiguous = wide != narrow || ambiguous_geo || ambiguous_edge;
        if !strict {
            sum += term;
        }
        if ambiguous {
            bound += term;
        }
        // Arithmetic error of the term.
        let b = term * (64.0 * u)
            + scale(1.0) * (8.0 * u)
            + brdf(m, n, inc.wi, wo, cos) * e_irr * (cos + e_dir)
            + brdf_error(m, n, inc.wi, wo, cos) * inc.irradiance * cos
            // Flush to zero: WGSL lets a GPU flush subnormal intermediates, and the term is a chain
            // of products (kd, E, cos) whose order and fusion the GPU chooses; a partial product
            // below f32::MIN_POSITIVE may become 0 and take the term with it, and what follows it is
            // at most max(1, |E|) (cos <= 1), with a factor 8 for the roundings around it. Seen on
            // lavapipe (verify seed 57): a generated albedo near the bottom of the normal range, the
            // mirror's term 4.0e-38, the GPU's 0 (lrsm_cone_trace's shadow cones allow the same).
            + Vec3::splat(8.0 * f32::MIN_POSITIVE * inc.irradiance.abs().max_element().max(1.0));
        bound += b;
    }
    (sum, bound)
}
