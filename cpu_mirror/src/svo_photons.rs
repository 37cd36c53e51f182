//! Mirror of `kernels/svo_photons.wgsl`: vct-svo's light injection (Crassin et al. 2011, section 8.2,
//! after Dachsbacher & Stamminger's light-view maps): every texel of a map rendered from the light is
//! one photon, landing in the voxel its surface point lies in; `sparse_voxel_octree`'s splat adds the
//! photons of a leaf together.
//!
//! A photon carries the radiance its texel gives the voxel it lands in. The texel's pencil of light has
//! cross-section `d^2 * omega` at the hit (`omega` the texel's solid angle), so it brings the flux
//! `E * d^2 * omega` (`E` the light contract's irradiance across the beam: `incident`'s, without the
//! cosine) over the surface area `d^2 omega / cos` (`cos` between the beam and the normal), and the
//! surface reflects `albedo` of it. The voxel's premultiplied radiance `L * alpha` is what the octree
//! holds, and the voxels' `alpha` is voxelize's, 1 wherever a surface was sampled: so a voxel's photons
//! must add to the radiance of its surface, `albedo * E * cos / pi` where the light reaches all of it,
//! whatever share of the voxel that surface takes. Each photon is its texel's flux over the area `A` of
//! its own plane (the point and its normal) inside its voxel ([`cell_area`]):
//! `value = albedo * E * d^2 omega / (pi * max(A, MIN_AREA h^2))`. Where the texels are finer than
//! the cell's piece of plane, its photons add to that radiance; where they are coarser (a grazing
//! surface, a light far away), a cell gets a photon with the probability `A / (d^2 omega / cos)`, and
//! that photon `L` times its inverse: the same light on average. The floor keeps a sliver a plane
//! cuts off a cell's corner from taking a photon's flux over almost no area: such slivers get less
//! than their surface's light on average, and voxelize, sampling the surface, leaves many of them
//! empty anyway.
//! A plane's area in a cell swings from 0 to `sqrt(2) h^2` with where it crosses the cell; the mean
//! over every offset, `h^2 / |n|_1`, would make a voxel's light depend on that offset instead (at 45
//! degrees a voxel the wall crosses along its diagonal would hold twice its radiance, one whose
//! corner it cuts next to nothing: docs/accuracy/orientation.md).
//!
//! The texel's `d^2 omega`: a perspective view with texel side `s` on the image plane at distance 1 has
//! `omega = s^2 cos^3(a)` (`a` off the axis), and with `zv = d cos(a)` the depth along the axis,
//! `d^2 omega = s^2 zv^3 / d`; an orthographic view's texel is `s^2` in world units.
//!
//! Per texel (row-major, the light-view G-buffer `gbuffer.wgsl` ray-casts with the view's frame):
//! * nothing hit or a back face (`normal.w <= 0`: reflects nothing): pos (0, 0, 0, 0), value 0;
//! * else pos = (voxel of the point, clamped into the grid, 1), value = (radiance above, 0).
//!
//! **Specular photons** (`spec`; surfaces whose material has Ks, else 0): the incoming light as a
//! direction distribution (VCT 7), reflected at injection, where the surface normal is exact:
//! `(m r w, w)` with `r = 2 (n.wi) n - wi` the light's mirror direction, `m = Ns / (Ns + 1)` the mean
//! length of a von Mises-Fisher lobe of concentration ~Ns (the Phong lobe `cos^Ns`), and
//! `w = lum(Ks E) d^2 omega / max(A, MIN_AREA h^2)` (the value's scale without `1 / pi`: the lobe's
//! density is per steradian). Summed over a cell, `|sum m r w| / sum w` encodes the
//! reflected light's spread (the BRDF's, the light's and the normals' at once) as the normal pool's
//! length does (Toksvig); svo_cone_trace evaluates the lobe towards each cone. Luminance only: the
//! glossy light is grey.
use crate::direct_light::{incident, incident_error, GpuLight, GpuMaterial};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::f32::consts::PI;

/// The kernel's `PhotonParams`: one light view and the voxel grid.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PhotonParams {
    /// Light-view eye (orthographic: the image plane's centre); w = texel area `s^2` (perspective: on
    /// the image plane at distance 1; orthographic: in world units).
    pub eye: [f32; 4],
    /// Unit view axis; w unused.
    pub forward: [f32; 4],
    /// Voxel grid origin; w = 1 / voxel size.
    pub grid: [f32; 4],
    /// View side (texels per row), light index, grid side, projection (0 perspective, 1 orthographic).
    pub info: [u32; 4],
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// One photon: its voxel (w = 1 when it exists), its value (rgb, 0) and the value's bound per channel,
/// its specular part `(m r w, w)` and that one's bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photon {
    pub pos: [u32; 4],
    pub value: [f32; 4],
    pub bound: [f32; 4],
    pub spec: [f32; 4],
    pub spec_bound: [f32; 4],
}

pub const NO_PHOTON: Photon = Photon {
    pos: [0; 4],
    value: [0.0; 4],
    bound: [0.0; 4],
    spec: [0.0; 4],
    spec_bound: [0.0; 4],
};

/// Rec. 709 luminance, in the kernel's operation order.
pub fn luminance(c: Vec3) -> f32 {
    (0.2126 * c.x + 0.7152 * c.y) + 0.0722 * c.z
}

/// The least area of a plane in its cell a photon's flux is spread over, in units of the cell's face:
/// an eighth (a 45-degree plane holds `1 / sqrt(2)` of a face in a cell on average). See the module's
/// documentation.
pub const MIN_AREA: f32 = 0.125;

/// Defines `strip` at one float width: one body for the kernel's f32 and the bound's f64.
macro_rules! strip_at {
    ($(#[$doc:meta])* $name:ident, $t:ty) => {
        $(#[$doc])*
        pub fn $name(s: $t, a: $t, b: $t) -> $t {
            if s >= a + b {
                1.0
            } else if s <= 0.0 {
                0.0
            } else if s < a {
                s * s / (2.0 * a * b)
            } else if s <= b {
                (s - 0.5 * a) / b
            } else {
                let t = (a + b) - s;
                1.0 - t * t / (2.0 * a * b)
            }
        }
    };
}

strip_at!(
    /// `strip(s, a, b)` for `0 <= a <= b`, `b > 0`: the area of `{(x, y) in [0, 1]^2 : a x + b y <= s}`,
    /// in the kernel's operation order. Piecewise, each piece free of cancellation: `s^2 / 2ab` up
    /// to `s = a`, then linear up to `b`, then `1 - (a + b - s)^2 / 2ab`.
    strip,
    f32
);
strip_at!(
    /// [`strip`] in f64, for [`cell_area_range`] (monotone in `s`).
    strip64,
    f64
);

/// Below this largest component a normal is no plane's (the G-buffer's normals are unit vectors,
/// whose largest component is at least `1 / sqrt(3)`): the area is 0. It keeps the products that
/// matter (`2ab`) out of the subnormal range, where a GPU may flush.
pub const LEAST_COMPONENT: f32 = 1.0 / 256.0;
/// A plane whose two smaller components add to at most `2^-16` of its largest is along a face: over
/// the whole grid (at most 2^10 cells a side) it rises less than a 64th of a cell, and its area in
/// its cell is the face's over the cosine. Deciding it exactly keeps a tilt of a rounding (an
/// interpolated normal) on a face from an ill-conditioned area, and keeps subnormal components,
/// which a GPU may flush, out of the strip.
pub const ALONG_A_FACE: f32 = 65536.0;
/// A smaller component at most `2^-24` of the middle one is dropped (the strip's area moves by at most
/// `a / 2b <= 2^-25`), so that `2ab` is never below normal.
pub const NEGLIGIBLE: f32 = 1.0 / 16777216.0;

/// What [`cell_area`] makes of a normal, by the exact decisions the kernel takes in the same order:
/// its components `|n|` sorted `a <= b <= c` (min and max: exact).
enum Plane {
    /// The largest component below [`LEAST_COMPONENT`]: no plane, area 0.
    Degenerate,
    /// Within [`ALONG_A_FACE`] of a face: the face's area over the cosine `c / |n|`.
    AlongAFace { c: f32 },
    /// Any other: the strip's, `a` dropped to 0 where [`NEGLIGIBLE`] beside `b`.
    Tilted { a: f32, b: f32, c: f32 },
}

fn plane(n: Vec3) -> Plane {
    let m = n.abs();
    let a = m.x.min(m.y).min(m.z);
    let c = m.x.max(m.y).max(m.z);
    let b = m.x.min(m.y).max(m.x.max(m.y).min(m.z));
    if c < LEAST_COMPONENT {
        Plane::Degenerate
    } else if (a + b) * ALONG_A_FACE <= c {
        Plane::AlongAFace { c }
    } else {
        let a = if a <= b * NEGLIGIBLE { 0.0 } else { a };
        Plane::Tilted { a, b, c }
    }
}

/// `q` mirrored so that every normal component counts `>= 0`: `q'_k = q_k`, or `1 - q_k` where
/// `n_k < 0`.
fn mirrored(q: Vec3, n: Vec3) -> Vec3 {
    let f = |q: f32, n: f32| if n < 0.0 { 1.0 - q } else { q };
    Vec3::new(f(q.x, n.x), f(q.y, n.y), f(q.z, n.z))
}

/// The plane's offset `d` in the mirrored cell: `sum |n_k| q'_k`, in the kernel's order.
fn offset(q: Vec3, n: Vec3) -> f32 {
    let (m, p) = (n.abs(), mirrored(q, n));
    (m.x * p.x + m.y * p.y) + m.z * p.z
}

/// The area of the plane through `q` with normal `n` inside the unit cell `[0, 1]^3`, in the kernel's
/// operation order (0 for `n = 0`). Seen along the normal's largest component `c`, the plane's piece of
/// the cell projects onto the strip `d - c <= a x + b y <= d` of the unit square, and the area is that
/// strip's over the cosine `c / |n|`: `|n| / c * (strip(d) - strip(d - c))`. `q` is in the cell (the
/// caller clamps it). A plane along a face ([`ALONG_A_FACE`]) has the face's area over the cosine
/// wherever it lies in the cell, on either face included: a photon on a face lands in the cell floor
/// gives it, and that cell must hold the plane it lands with.
pub fn cell_area(q: Vec3, n: Vec3) -> f32 {
    let len = ((n.x * n.x + n.y * n.y) + n.z * n.z).sqrt();
    match plane(n) {
        Plane::Degenerate => 0.0,
        Plane::AlongAFace { c } => len / c,
        Plane::Tilted { a, b, c } => {
            let d = offset(q, n);
            (len / c) * (strip(d, a, b) - strip(d - c, a, b))
        }
    }
}

/// Bounds on what a GPU's [`cell_area`] of the same `q` and `n` gives, `(lo, hi)` (`u = 2^-24`, an
/// ULP is `2u` at 1). The decisions (least component, along a face, negligible component) compare
/// the same correctly rounded values on both, and flushing a subnormal does not change them. `q` is the
/// same there (exact or correctly rounded operations); the offset `d` is three products and two
/// sums, which may contract into fused operations and round in another order: within
/// `6 u sum |n_k q'_k|` of the mirror's, and `d - c` one more rounding each side. `strip` is
/// monotone, so its range over those intervals bounds it, and its own arithmetic (a square, a
/// product, a 2.5-ULP division, `1 -` a value `<= 1/2`) is within `8 u` absolute; the subtraction of
/// the two `u`. `|n| / c`: a dot product (3 ULP, halved by the root), sqrt (via 1 / inverseSqrt,
/// 4.5 ULP), a division (2.5 ULP) and the product with the strip: within `24 u` of itself.
pub fn cell_area_range(q: Vec3, n: Vec3) -> (f64, f64) {
    let u = f32::EPSILON as f64 / 2.0;
    let len = n.as_dvec3().length();
    let (a, b, c) = match plane(n) {
        Plane::Degenerate => return (0.0, 0.0),
        Plane::AlongAFace { c } => {
            let k = len / c as f64;
            return (k * (1.0 - 24.0 * u), k * (1.0 + 24.0 * u));
        }
        Plane::Tilted { a, b, c } => (a, b, c),
    };
    let k = len / c as f64;
    let mag = n.abs().dot(mirrored(q, n).abs()) as f64;
    let d = offset(q, n) as f64;
    let e_d = 6.0 * u * mag;
    let e_dc = e_d + 2.0 * u * (d - c as f64).abs();
    let (a, b, c) = (a as f64, b as f64, c as f64);
    let lo = strip64(d - e_d, a, b) - strip64(d - c + e_dc, a, b) - 17.0 * u;
    let hi = strip64(d + e_d, a, b) - strip64(d - c - e_dc, a, b) + 17.0 * u;
    // lo may be a little below 0: two strips of a rounding below 1 apart.
    (
        k * lo * (1.0 + 24.0 * u.copysign(-lo)),
        k * hi * (1.0 + 24.0 * u),
    )
}

/// The photon of a light-view G-buffer pixel (position, normal, albedo), in the kernel's operation
/// order.
///
/// Bounds (WGSL rules, u = 2^-24): the voxel is exact (`(p - origin) * inv_h`: one correctly rounded
/// subtraction and one multiplication per axis, no contraction possible, then floor and clamp). The
/// value is a product of about a dozen correctly rounded or 2.5-ULP operations plus `sqrt` (via
/// 1 / inverseSqrt, 4.5 ULP) and `dot` (any order): 64 ULP of it, plus the depth's cancellation — `zv` is a
/// dot product, off by up to 4 ULP of `|rel| . |forward|`, and enters cubed, so `3 e_zv / zv` relative —
/// plus `incident_error`'s irradiance (a spot's soft edge) times the rest, plus the share's range (its
/// cell area within [`cell_area_range`]) times the irradiance.
pub fn photon(
    p: &PhotonParams,
    light: &GpuLight,
    position: [f32; 4],
    normal: [f32; 4],
    albedo: [f32; 4],
    material: &GpuMaterial,
) -> Photon {
    let u = f32::EPSILON;
    if normal[3] <= 0.0 {
        return NO_PHOTON;
    }
    let x = v3(position);
    let n = v3(normal);
    let inv_h = p.grid[3];
    let cell = (x - v3(p.grid)) * inv_h;
    let top = (p.info[2] - 1) as f32;
    let c = |t: f32| t.floor().clamp(0.0, top) as u32;
    let pos = [c(cell.x), c(cell.y), c(cell.z), 1];

    let inc = incident(light, x);
    let (e_irr, _) = incident_error(light, x, 0.0);
    let rel = x - v3(p.eye);
    let f = v3(p.forward);
    let zv = (rel.x * f.x + rel.y * f.y) + rel.z * f.z;
    let d = rel.dot(rel).sqrt();
    let mut rel_err = 64.0 * u;
    let area = if p.info[3] == 1 {
        p.eye[3]
    } else if zv > 0.0 && d > 0.0 {
        let e_zv = 4.0 * u * rel.abs().dot(f.abs());
        rel_err += 3.0 * e_zv / zv;
        p.eye[3] * (zv * zv * zv) / d
    } else {
        0.0
    };
    // The texel's share: its flux over its plane's area in the cell, that area at least MIN_AREA.
    // A point past the grid (a hit a rounding outside it) is taken onto the cell it is clamped to.
    let q = (cell - Vec3::new(pos[0] as f32, pos[1] as f32, pos[2] as f32))
        .clamp(Vec3::ZERO, Vec3::ONE);
    let share = area * (inv_h * inv_h) / cell_area(q, n).max(MIN_AREA);
    // Its range on a GPU: the cell's area within `cell_area_range`, `max` monotone, then a product,
    // a square and a division (4.5 ULP).
    let share_err = {
        let u64 = u as f64 / 2.0;
        let (lo, hi) = cell_area_range(q, n);
        let k = area as f64 * (inv_h as f64 * inv_h as f64);
        let s_lo = k / hi.max(MIN_AREA as f64) * (1.0 - 10.0 * u64);
        let s_hi = k / lo.max(MIN_AREA as f64) * (1.0 + 10.0 * u64);
        (share as f64 - s_lo).max(s_hi - share as f64) as f32
    };
    let scale = share * (1.0 / PI);
    let kd = v3(albedo);
    let value = kd * inc.irradiance * scale;
    let bound = value * rel_err
        + kd * e_irr * (scale * (1.0 + rel_err))
        + kd * (inc.irradiance + e_irr) * (share_err * (1.0 / PI) * (1.0 + rel_err));
    // Specular: the same share without 1/pi, the mirror direction (unit vectors: a few ULP, plus the
    // light direction's error), the lobe's mean length.
    let ks = v3(material.specular);
    let (mut spec, mut spec_bound) = ([0.0; 4], [0.0; 4]);
    if ks != Vec3::ZERO {
        let ns = material.diffuse[3].max(0.0);
        let m = ns / (ns + 1.0);
        let ke = ks * inc.irradiance;
        let w = luminance(ke) * share;
        let r = n * (2.0 * n.dot(inc.wi)) - inc.wi;
        let q = r * (m * w);
        let (_, e_dir) = incident_error(light, x, 0.0);
        let e_w = w.abs() * (rel_err + 8.0 * u)
            + luminance(ks) * e_irr.max_element() * share * (1.0 + rel_err)
            + luminance(ks) * (inc.irradiance + e_irr).max_element() * share_err * (1.0 + rel_err);
        let e_q = (r.abs() * m) * e_w + Vec3::splat(m * w.abs() * (3.0 * e_dir + 16.0 * u));
        spec = [q.x, q.y, q.z, w];
        spec_bound = [e_q.x, e_q.y, e_q.z, e_w];
    }
    Photon {
        pos,
        value: [value.x, value.y, value.z, 0.0],
        bound: [bound.x, bound.y, bound.z, 0.0],
        spec,
        spec_bound,
    }
}

/// Every photon of a light view's row-major G-buffer (`triangle`: the texel's triangle, whose
/// material, `materials[triangles[t].a.w]` clamped, gives Ks and Ns).
pub fn photons(
    p: &PhotonParams,
    lights: &[GpuLight],
    [position, normal, albedo]: [&[[f32; 4]]; 3],
    triangle: &[u32],
    triangles: &[crate::bvh_trace::GpuTriangle],
    materials: &[GpuMaterial],
) -> Vec<Photon> {
    let light = &lights[p.info[1] as usize];
    (0..position.len())
        .map(|i| {
            let m = if normal[i][3] > 0.0 {
                let t = &triangles[triangle[i] as usize];
                materials[(t.a[3] as u32).min(materials.len() as u32 - 1) as usize]
            } else {
                GpuMaterial::default()
            };
            photon(p, light, position[i], normal[i], albedo[i], &m)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::direct_light::{DIRECTIONAL, POINT};

    /// The light-view G-buffer positions of a floor y = 0 seen from `eye` looking
    /// down with a 90-degree perspective view (or orthographic, half width `half`).
    fn floor_view(eye: Vec3, side: u32, ortho: Option<f32>) -> Vec<[f32; 4]> {
        let mut pos = Vec::new();
        for y in 0..side {
            for x in 0..side {
                let u = 2.0 * (x as f32 + 0.5) / side as f32 - 1.0;
                let v = 1.0 - 2.0 * (y as f32 + 0.5) / side as f32;
                let p = match ortho {
                    Some(h) => Vec3::new(eye.x + u * h, 0.0, eye.z + v * h),
                    None => {
                        let dir = Vec3::new(u, -1.0, v);
                        eye + dir * (eye.y / 1.0)
                    }
                };
                pos.push([p.x, p.y, p.z, 1.0]);
            }
        }
        pos
    }

    /// [`photons`] of a G-buffer whose every texel has the default (diffuse, no Ks) material.
    fn diffuse_photons(p: &PhotonParams, light: GpuLight, gb: [&[[f32; 4]]; 3]) -> Vec<Photon> {
        let tri = vec![0; gb[0].len()];
        photons(
            p,
            &[light],
            gb,
            &tri,
            &[Default::default()],
            &[Default::default()],
        )
    }

    fn params(
        eye: Vec3,
        side: u32,
        s: f32,
        ortho: bool,
        origin: Vec3,
        h: f32,
        grid: u32,
    ) -> PhotonParams {
        PhotonParams {
            eye: [eye.x, eye.y, eye.z, s * s],
            forward: [0.0, -1.0, 0.0, 0.0],
            grid: [origin.x, origin.y, origin.z, 1.0 / h],
            info: [side, 0, grid, ortho as u32],
        }
    }

    /// A directional light straight down on a floor: every cell the texels tile gets exactly the
    /// floor's radiance albedo * E / pi (texels nest in cells: 4 x 4 of them per cell), wherever the
    /// floor lies in its cells, its normal up or down (a thin wall's two sides).
    #[test]
    fn uniform_light_gives_the_surface_radiance_per_cell() {
        let side = 64;
        let half = 8.0; // world [-8, 8]^2; texel 0.25, cell 1
        let eye = Vec3::new(0.0, 10.0, 0.0);
        let light = GpuLight {
            position: [0.0, 0.0, 0.0, DIRECTIONAL],
            direction: [0.0, -1.0, 0.0, 0.0],
            intensity: [2.0, 1.0, 0.5, 0.0],
        };
        // The floor inside its cells, on their lower and upper faces, and a rounding below the
        // grid (clamped into its first layer).
        for (origin_y, cell_y) in [(-0.5, 0), (0.0, 0), (-1.0, 1), (1e-6, 0)] {
            for up in [1.0, -1.0] {
                let p = params(
                    eye,
                    side,
                    2.0 * half / side as f32,
                    true,
                    Vec3::new(-8.0, origin_y, -8.0),
                    1.0,
                    16,
                );
                let pos = floor_view(eye, side, Some(half));
                let nrm = vec![[0.0, up, 0.0, 1.0]; pos.len()];
                let alb = vec![[0.5, 0.5, 0.5, 1.0]; pos.len()];
                let ph = diffuse_photons(&p, light, [&pos, &nrm, &alb]);
                let mut cells = std::collections::HashMap::<[u32; 3], Vec3>::new();
                for q in &ph {
                    assert_eq!(q.pos[3], 1);
                    assert_eq!(q.pos[1], cell_y);
                    *cells.entry([q.pos[0], q.pos[1], q.pos[2]]).or_default() += v3(q.value);
                }
                assert_eq!(cells.len(), 256);
                let want = Vec3::new(2.0, 1.0, 0.5) * 0.5 / PI;
                for (c, v) in cells {
                    assert!(
                        (v - want).abs().max_element() < 1e-6,
                        "origin {origin_y}, normal {up}: {c:?}: {v} vs {want}"
                    );
                }
            }
        }
    }

    /// A point light above an infinite floor, one 90-degree cube face looking down: the photons carry
    /// the flux through the face, I * 4 pi / 6, times albedo (the midpoint rule's error is O(1/side^2)).
    #[test]
    fn point_light_photons_carry_the_flux_of_the_face() {
        let side = 256;
        let eye = Vec3::new(0.3, 2.0, -0.2);
        let light = GpuLight {
            position: [eye.x, eye.y, eye.z, POINT],
            direction: [0.0, -1.0, 0.0, 0.0],
            intensity: [3.0, 3.0, 3.0, 0.0],
        };
        let h = 0.125;
        let p = params(
            eye,
            side,
            2.0 / side as f32,
            false,
            Vec3::new(-4.0, -0.06, -4.0),
            h,
            64,
        );
        let pos = floor_view(eye, side, None);
        let nrm = vec![[0.0, 1.0, 0.0, 1.0]; pos.len()];
        let alb = vec![[0.8, 0.8, 0.8, 1.0]; pos.len()];
        let ph = diffuse_photons(&p, light, [&pos, &nrm, &alb]);
        // Flux back from the stored radiance: value * pi * A per photon, A = h^2 (a floor's area in
        // its cell).
        let flux: f64 = ph
            .iter()
            .map(|q| q.value[0] as f64 * std::f64::consts::PI * (h * h) as f64)
            .sum();
        let want = 0.8 * 3.0 * 4.0 * std::f64::consts::PI / 6.0;
        assert!((flux / want - 1.0).abs() < 1e-3, "{flux} vs {want}");
        // Bounds are small and positive where there is a value.
        assert!(ph
            .iter()
            .all(|q| q.bound[0] > 0.0 && q.bound[0] < 1e-4 * q.value[0]));
    }

    /// The plane's area in the unit cell by inclusion-exclusion over the cube's corners (f64): for
    /// `n > 0` componentwise, the volume below `n.x = d` is `sum_v (-1)^|v| max(0, d - n.v)^3 / 6 n1 n2 n3`,
    /// and the area its derivative in `d` times `|n|`. Independent of [`cell_area`]'s projection.
    fn corner_area(q: [f64; 3], n: [f64; 3]) -> f64 {
        let d = q[0] * n[0] + q[1] * n[1] + q[2] * n[2];
        let mut sum = 0.0;
        for v in 0..8 {
            let c = [(v & 1) as f64, ((v >> 1) & 1) as f64, ((v >> 2) & 1) as f64];
            let sign = if (v as u32).count_ones() % 2 == 0 {
                1.0
            } else {
                -1.0
            };
            let t = (d - (c[0] * n[0] + c[1] * n[1] + c[2] * n[2])).max(0.0);
            sum += sign * t * t;
        }
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        len * sum / (2.0 * n[0] * n[1] * n[2])
    }

    #[test]
    fn a_planes_area_in_a_cell() {
        let r2 = 2f32.sqrt();
        let cases = [
            // Axis-aligned anywhere in the cell, and on its faces.
            ([0.3, 0.5, 0.7], [0.0, 1.0, 0.0], 1.0),
            ([0.3, 0.0, 0.7], [0.0, 1.0, 0.0], 1.0),
            ([0.3, 0.0, 0.7], [0.0, -1.0, 0.0], 1.0),
            ([0.3, 1.0, 0.7], [0.0, -1.0, 0.0], 1.0),
            // The diagonal rectangle, and one through a corner region.
            ([0.5, 0.5, 0.5], [1.0, 1.0, 0.0], r2),
            ([0.25, 0.0, 0.5], [1.0, 1.0, 0.0], 0.25 * r2),
            ([0.0, 0.0, 0.0], [1.0, 1.0, 0.0], 0.0),
            // Along a face within a tilt of a rounding (an interpolated normal), or with a subnormal
            // component: the face's area, on either face.
            ([0.3, 0.0, 0.7], [1e-6, 1.0, 0.0], 1.0),
            ([0.3, 0.0, 0.7], [1e-6, -1.0, 1e-6], 1.0),
            ([0.3, 1.0, 0.7], [0.0, 1.0, 1e-40], 1.0),
            // The regular hexagon through the centre, the triangle through three corners.
            ([0.5, 0.5, 0.5], [1.0, 1.0, 1.0], 0.75 * 3f32.sqrt()),
            ([1.0, 0.0, 0.0], [-1.0, -1.0, -1.0], 0.5 * 3f32.sqrt()),
            ([0.3, 0.3, 0.3], [0.0, 0.0, 0.0], 0.0),
        ];
        for (q, n, want) in cases {
            let got = cell_area(Vec3::from(q), Vec3::from(n));
            assert!((got - want).abs() < 1e-6, "{q:?} {n:?}: {got} vs {want}");
            // Scale-free in n.
            let got3 = cell_area(Vec3::from(q), Vec3::from(n) * 3.0);
            assert!((got3 - want).abs() < 1e-6);
        }
    }

    /// Uniform numbers in [0, 1) from a seed (xorshift64).
    fn uniform(mut state: u64) -> impl FnMut() -> f32 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    #[test]
    fn a_planes_area_agrees_with_inclusion_exclusion() {
        let mut next = uniform(0x9e37_79b9_7f4a_7c15);
        for _ in 0..20000 {
            let n: [f32; 3] = std::array::from_fn(|_| {
                let m = 0.05 + 0.95 * next();
                if next() < 0.5 {
                    -m
                } else {
                    m
                }
            });
            let q: [f32; 3] = std::array::from_fn(|_| next());
            // Mirror q with n to the all-positive normal the formula takes.
            let qp = std::array::from_fn(|k| {
                if n[k] < 0.0 {
                    1.0 - q[k] as f64
                } else {
                    q[k] as f64
                }
            });
            let np = n.map(|c| c.abs() as f64);
            let want = corner_area(qp, np);
            let got = cell_area(Vec3::from(q), Vec3::from(n)) as f64;
            // The f32 offset's rounding (about 2u of |n|_1 < 3) times the strip's slope (at most
            // 1 / b <= 20 with components >= 0.05) times |n| / c (<= sqrt(3)): about 1.3e-5; the
            // f64 reference's cancellation (terms up to |n|_1^2 / 2 n1 n2 n3 < 36000) is far below.
            assert!((got - want).abs() < 2e-5, "{q:?} {n:?}: {got} vs {want}");
        }
    }

    /// What a GPU may compute for [`cell_area`] stays inside [`cell_area_range`]: the offset with its
    /// products fused and summed in other orders, `|n| / c` 9 ULP off, each strip `8 u` off, and the
    /// inputs' subnormals flushed; on normals with zero, subnormal, tiny, equal and near-the-face
    /// components and points on the cell's faces.
    #[test]
    fn a_gpus_cell_area_stays_in_its_range() {
        let mut next = uniform(0x2545_f491_4f6c_dd1d);
        let ulps = |x: f32, k: i32| f32::from_bits((x.to_bits() as i32 + k).max(0) as u32);
        let flush = |v: Vec3| {
            Vec3::from_array(v.to_array().map(|x| {
                if x.abs() < f32::MIN_POSITIVE {
                    0.0f32.copysign(x)
                } else {
                    x
                }
            }))
        };
        let u = f32::EPSILON as f64 / 2.0;
        let mut checked = 0;
        for _ in 0..20000 {
            let mut pick = || match (next() * 10.0) as u32 {
                0 => 0.0,
                1 => 1e-40,
                2 => 1e-7,
                3 => 1e-3,
                // About the face decision's threshold beside a largest component near 1.
                4 => 7.6e-6,
                5 => 1.6e-5,
                _ => 0.05 + 0.95 * next(),
            };
            let mut n = Vec3::new(pick(), pick(), pick());
            if next() < 0.2 {
                n.y = n.x;
            }
            let n = (n / n.length()) * Vec3::new(1.0, if next() < 0.5 { -1.0 } else { 1.0 }, 1.0);
            if !n.is_finite() {
                continue;
            }
            let q = Vec3::from_array(std::array::from_fn(|_| match (next() * 6.0) as u32 {
                0 => 0.0,
                1 => 1.0,
                2 => 1.0 - f32::EPSILON / 2.0,
                _ => next(),
            }));
            let (lo, hi) = cell_area_range(q, n);
            let inside = |area: f64, what: &str| {
                assert!(
                    lo <= area && area <= hi,
                    "{q} {n}: {what} {area} outside [{lo}, {hi}]"
                )
            };
            inside(cell_area(q, n) as f64, "the mirror's");
            inside(cell_area(flush(q), flush(n)) as f64, "flushed");
            let (a, b, c) = match plane(n) {
                Plane::Degenerate => continue,
                Plane::AlongAFace { c } => {
                    for dk in [-9, 9] {
                        inside(ulps(n.length() / c, dk) as f64, "along a face");
                    }
                    continue;
                }
                Plane::Tilted { a, b, c } => (a, b, c),
            };
            let k = n.length() / c;
            let m = n.abs();
            let p = mirrored(q, n).to_array();
            let offsets = [
                (m.x * p[0] + m.y * p[1]) + m.z * p[2],
                m.x.mul_add(p[0], m.y * p[1]) + m.z * p[2],
                m.z.mul_add(p[2], m.x.mul_add(p[0], m.y * p[1])),
                m.z.mul_add(p[2], m.y.mul_add(p[1], m.x * p[0])),
                (m.z * p[2] + m.y * p[1]) + m.x * p[0],
            ];
            for d in offsets {
                for (dk, ds) in [(-9, -8.0), (9, 8.0), (-9, 8.0), (9, -8.0)] {
                    let strips =
                        (strip(d, a, b) as f64 + ds * u) - (strip(d - c, a, b) as f64 - ds * u);
                    inside(ulps(k, dk) as f64 * strips, "a GPU's");
                    checked += 1;
                }
            }
        }
        assert!(checked > 100000, "{checked}");
    }

    /// A directional light on a wall at 45 degrees to the grid, at offsets from through the cells'
    /// corners to their middles: every cell its photons fill gets the wall's radiance, where the
    /// texels cover it (cells near the wall's ends are left out, and those it only clips, whose few
    /// texels miscount their area the most).
    #[test]
    fn a_tilted_wall_gives_its_radiance_to_every_cell_at_any_offset() {
        // Texels of 1/64. A cell's piece of this wall is a rectangle, 1 high and `a` wide (its
        // area): its photons miscount it by at most a row of texels each way, `1 / 64a + 1 / 64`.
        let side = 768;
        let half = 6.0;
        let s2 = 0.5f32.sqrt();
        let dir = Vec3::new(-s2, 0.0, -s2); // the light shines along -n
        let light = GpuLight {
            position: [0.0, 0.0, 0.0, DIRECTIONAL],
            direction: [dir.x, dir.y, dir.z, 0.0],
            intensity: [1.0, 1.0, 1.0, 0.0],
        };
        let want = 0.5 / PI; // albedo 0.5, E 1, cos 1
        for phase in [0.0f32, 0.1, 0.28, 0.5, 0.75] {
            // The wall x + z = phase * sqrt(2)... through (phase, 0, 0) in cells of size 1.
            let n = Vec3::new(s2, 0.0, s2);
            let t = Vec3::new(s2, 0.0, -s2);
            let mut pos = Vec::new();
            for y in 0..side {
                for x in 0..side {
                    let u = 2.0 * (x as f32 + 0.5) / side as f32 - 1.0;
                    let v = 2.0 * (y as f32 + 0.5) / side as f32 - 1.0;
                    let p = Vec3::new(phase, 0.0, 0.0) + t * (u * half) + Vec3::Y * (v * half);
                    pos.push([p.x, p.y, p.z, 1.0]);
                }
            }
            let eye = Vec3::new(phase, 0.0, 0.0) + n * 10.0;
            let p = PhotonParams {
                eye: [eye.x, eye.y, eye.z, (2.0 * half / side as f32).powi(2)],
                forward: [-n.x, -n.y, -n.z, 0.0],
                grid: [-8.0, -8.0, -8.0, 1.0],
                info: [side, 0, 16, 1],
            };
            let nrm = vec![[n.x, n.y, n.z, 1.0]; pos.len()];
            let alb = vec![[0.5, 0.5, 0.5, 1.0]; pos.len()];
            let ph = diffuse_photons(&p, light, [&pos, &nrm, &alb]);
            let mut cells = std::collections::HashMap::<[u32; 3], f32>::new();
            for q in &ph {
                *cells.entry([q.pos[0], q.pos[1], q.pos[2]]).or_default() += q.value[0];
            }
            // Cells well inside the wall, whose plane piece is at least a quarter of a face.
            let mut checked = 0;
            for (c, v) in &cells {
                let corner = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) - Vec3::splat(8.0);
                let inside = (corner + Vec3::splat(0.5) - Vec3::new(phase, 0.0, 0.0))
                    .dot(t)
                    .abs()
                    < half - 1.5
                    && (corner.y + 0.5).abs() < half - 1.5;
                let a = cell_area(Vec3::new(phase, 0.0, 0.0) - corner, n);
                if inside && a > 0.25 {
                    checked += 1;
                    let tolerance = 1.0 / (64.0 * a) + 1.0 / 64.0 + 1e-3;
                    assert!(
                        (v / want - 1.0).abs() < tolerance,
                        "phase {phase}, cell {c:?} (area {a}): {v} vs {want}"
                    );
                }
            }
            assert!(checked > 20, "phase {phase}: {checked} cells checked");
        }
    }

    /// A one-texel view and a point light 5 units above the origin, looking down; grid of 8 voxels of
    /// size 1 from `origin`.
    fn overhead(origin: [f32; 3]) -> (PhotonParams, GpuLight) {
        let p = PhotonParams {
            info: [1, 0, 8, 0],
            grid: [origin[0], origin[1], origin[2], 1.0],
            eye: [0.0, 5.0, 0.0, 1.0],
            forward: [0.0, -1.0, 0.0, 0.0],
        };
        let l = GpuLight {
            position: [0.0, 5.0, 0.0, POINT],
            direction: [0.0, -1.0, 0.0, 0.0],
            intensity: [1.0; 4],
        };
        (p, l)
    }

    /// A glossy floor lit from straight above: the specular photon points back up along the mirror
    /// direction (the normal here) with the lobe's mean length Ns / (Ns + 1), and its weight is the
    /// diffuse value's luminance times pi Ks / Kd.
    #[test]
    fn a_glossy_photon_reflects_the_light_about_the_normal() {
        let (p, l) = overhead([-4.0, -4.0, -4.0]);
        let m = GpuMaterial {
            diffuse: [0.5, 0.5, 0.5, 9.0],
            specular: [0.25, 0.25, 0.25, 0.0],
            texture: [0; 4],
        };
        let shoot = |m: &GpuMaterial| {
            photon(
                &p,
                &l,
                [0.0, 0.0, 0.0, 1.0],
                [0.0, 1.0, 0.0, 1.0],
                [0.5; 4],
                m,
            )
        };
        let q = shoot(&m);
        let w = q.spec[3];
        assert!(w > 0.0);
        assert!((q.spec[1] / w - 0.9).abs() < 1e-6, "{:?}", q.spec);
        assert!(q.spec[0].abs() < 1e-6 && q.spec[2].abs() < 1e-6);
        let expect = luminance(Vec3::from_slice(&q.value[..3])) * PI * 0.25 / 0.5;
        assert!((w - expect).abs() < 1e-5 * expect, "{w} vs {expect}");
        assert!(q.spec_bound.iter().all(|&b| b > 0.0 && b < 1e-4 * w));
        // No Ks: no specular photon.
        let diffuse = GpuMaterial {
            specular: [0.0; 4],
            ..m
        };
        let q = shoot(&diffuse);
        assert_eq!(q.spec, [0.0; 4]);
    }

    #[test]
    fn back_faces_and_misses_carry_nothing() {
        let (p, l) = overhead([0.0; 3]);
        for w in [0.0, -1.0] {
            let q = photon(
                &p,
                &l,
                [1.0, 1.0, 1.0, 1.0],
                [0.0, 1.0, 0.0, w],
                [1.0; 4],
                &GpuMaterial::default(),
            );
            assert_eq!(q, NO_PHOTON);
        }
        // A point outside the grid lands in the nearest cell.
        let q = photon(
            &p,
            &l,
            [-3.0, 1.5, 99.0, 1.0],
            [0.0, 1.0, 0.0, 1.0],
            [1.0; 4],
            &GpuMaterial::default(),
        );
        assert_eq!(q.pos, [0, 1, 7, 1]);
    }
}
