//! Mirror of `kernels/svo_photons.wgsl`: vct-svo's light injection (Crassin et al. 2011, section 8.2,
//! after Dachsbacher & Stamminger's light-view maps): every texel of a map rendered from the light is
//! one photon, landing in the voxel its surface point lies in; `sparse_voxel_octree`'s splat adds the
//! photons of a leaf together.
//!
//! A photon carries the radiance its texel gives the voxel it lands in. The texel's pencil of light has
//! cross-section `d^2 * omega` at the hit (`omega` the texel's solid angle), so it brings the flux
//! `E * d^2 * omega` (`E` the light contract's irradiance across the beam: `incident`'s, without the
//! cosine, which the surface area it spreads over cancels) and the surface reflects `albedo` of it.
//! Spread over the surface area a voxel holds, that is outgoing radiance
//! `L = albedo * E * d^2 * omega / (pi * A)`. A planar surface with unit normal `n` crosses, per unit of
//! its area, `(|nx| + |ny| + |nz|) / h^2` cells of size `h` (the cells a plane passes through), so the
//! mean area per crossed cell is `A = h^2 / |n|_1`; the photon stores
//! `albedo * E * d^2 omega * |n|_1 / (pi h^2)`. Summed over a cell this is `L` times the cell's share of
//! area over the mean: the premultiplied `L * alpha` the octree holds, `alpha` the surface's coverage
//! of the cell.
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
//! `w = lum(Ks E) d^2 omega |n|_1 / h^2` the specular flux per mean cell area (the value's scale without
//! `1 / pi`: the lobe's density is per steradian). Summed over a cell, `|sum m r w| / sum w` encodes the
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

/// The photon of a light-view G-buffer pixel (position, normal, albedo), in the kernel's operation
/// order.
///
/// Bounds (WGSL rules, u = 2^-24): the voxel is exact (`(p - origin) * inv_h`: one correctly rounded
/// subtraction and one multiplication per axis, no contraction possible, then floor and clamp). The
/// value is a product of about a dozen correctly rounded or 2.5-ULP operations plus `sqrt` (via
/// inverseSqrt, 8 ULP?) and `dot` (any order): 64 ULP of it, plus the depth's cancellation — `zv` is a
/// dot product, off by up to 4 ULP of `|rel| . |forward|`, and enters cubed, so `3 e_zv / zv` relative —
/// plus `incident_error`'s irradiance (a spot's soft edge) times the rest.
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
    let l1 = (n.x.abs() + n.y.abs()) + n.z.abs();
    let scale = area * (l1 * (inv_h * inv_h * (1.0 / PI)));
    let kd = v3(albedo);
    let value = kd * inc.irradiance * scale;
    let bound = value * rel_err + kd * e_irr * (scale * (1.0 + rel_err));
    // Specular: the same scale without 1/pi, the mirror direction (unit vectors: a few ULP, plus the
    // light direction's error), the lobe's mean length.
    let ks = v3(material.specular);
    let (mut spec, mut spec_bound) = ([0.0; 4], [0.0; 4]);
    if ks != Vec3::ZERO {
        let ns = material.diffuse[3].max(0.0);
        let m = ns / (ns + 1.0);
        let ke = ks * inc.irradiance;
        let s = area * (l1 * (inv_h * inv_h));
        let w = luminance(ke) * s;
        let r = n * (2.0 * n.dot(inc.wi)) - inc.wi;
        let q = r * (m * w);
        let (_, e_dir) = incident_error(light, x, 0.0);
        let e_w = w.abs() * (rel_err + 8.0 * u)
            + luminance(ks) * e_irr.max_element() * s * (1.0 + rel_err);
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
    /// floor's radiance albedo * E / pi (texels nest in cells: 4 x 4 of them per cell).
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
        let p = params(
            eye,
            side,
            2.0 * half / side as f32,
            true,
            Vec3::new(-8.0, -0.5, -8.0),
            1.0,
            16,
        );
        let pos = floor_view(eye, side, Some(half));
        let nrm = vec![[0.0, 1.0, 0.0, 1.0]; pos.len()];
        let alb = vec![[0.5, 0.5, 0.5, 1.0]; pos.len()];
        let ph = diffuse_photons(&p, light, [&pos, &nrm, &alb]);
        let mut cells = std::collections::HashMap::<[u32; 3], Vec3>::new();
        for q in &ph {
            assert_eq!(q.pos[3], 1);
            assert_eq!(q.pos[1], 0);
            *cells.entry([q.pos[0], q.pos[1], q.pos[2]]).or_default() += v3(q.value);
        }
        assert_eq!(cells.len(), 256);
        let want = Vec3::new(2.0, 1.0, 0.5) * 0.5 / PI;
        for (c, v) in cells {
            assert!(
                (v - want).abs().max_element() < 1e-6,
                "{c:?}: {v} vs {want}"
            );
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
        // Flux back from the stored radiance: value * pi * h^2 / |n|_1 per photon.
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
