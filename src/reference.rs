//! The yardstick: a CPU Monte Carlo renderer of the light-transport contract (docs/contract.md),
//! direct + exactly one bounce (two with `[render] bounces = 2`), kept separate, plus ambient
//! occlusion.
//!
//! Per sample: a primary ray through a uniformly jittered point of the pixel (the pixel centre when
//! `jitter` is off); at a front-face hit
//! - direct: [`shade_with`] — every light, one exact shadow ray each (the same contract code the
//!   `direct_light` kernel mirrors);
//! - indirect: one direction drawn from a mixture of a cosine lobe (weight ∝ the diffuse albedo's
//!   luminance) and the Phong lobe around the mirror direction (∝ the specular's), weighted by the
//!   mixture pdf; the surface it reaches (front face) contributes its direct radiance (with
//!   `bounces = 2`, plus its own indirect radiance, drawn the same way one level deeper);
//! - AO: one cosine-distributed direction; an occluder at distance r < ao_range occludes by
//!   1 / (1 + ao_lambda r); AO = 1 - mean occlusion (1 = open). AO is geometric: at back faces it is taken
//!   on the side facing the camera.
//!
//! Back faces reflect nothing (direct = indirect = 0 there); pixels that see nothing are 0 in all images.
//! Every pixel has its own ChaCha stream seeded from (seed, pixel): results do not depend on threads.
use crate::scene::Scene;
use crate::trace::{SceneData, Tracer};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::f32::consts::PI;
use vxgi_cpu_mirror::bvh_trace::FAR;
use vxgi_cpu_mirror::direct_light::{brdf, face_normal, shade_with, GpuMaterial};
use vxgi_cpu_mirror::gbuffer::{albedo, ray_through, texel};

/// The (indirect, combined) images a frame of `scene` is compared against: read from `dir` (its
/// `indirect.exr` and `combined.exr`, at the scene camera's size, e.g. a converged one such as
/// references/cornell_box_256_4096spp), or without one rendered at `spp` samples per pixel.
pub fn images_for(
    scene: &Scene,
    spp: u32,
    dir: Option<&std::path::Path>,
) -> anyhow::Result<(crate::images::RgbImage, crate::images::RgbImage)> {
    use crate::images::RgbImage;
    let (w, h) = (scene.camera.width, scene.camera.height);
    match dir {
        Some(dir) => {
            let read = |name: &str| -> anyhow::Result<RgbImage> {
                let path = dir.join(name);
                let img = crate::images::read_exr(&path)?;
                if (img.width, img.height) != (w, h) {
                    anyhow::bail!(
                        "{}: {}x{}, the scene's camera is {w}x{h}",
                        path.display(),
                        img.width,
                        img.height
                    );
                }
                // A reference every error is measured against: radiance, finite and not
                // negative, and some light (against black every ratio is undefined).
                if let Some((x, y)) = img.first_non_finite() {
                    anyhow::bail!("{}: non-finite pixel at ({x}, {y})", path.display());
                }
                if let Some((x, y)) = img.first_negative() {
                    anyhow::bail!("{}: negative radiance at ({x}, {y})", path.display());
                }
                Ok(img)
            };
            let (indirect, combined) = (read("indirect.exr")?, read("combined.exr")?);
            let black = |img: &RgbImage| img.pixels.iter().flatten().all(|&c| c == 0.0);
            if black(&combined) {
                anyhow::bail!(
                    "{}: black everywhere: errors against it are undefined",
                    dir.join("combined.exr").display()
                );
            }
            if black(&indirect) {
                // A scene with nothing to bounce light (a lone lit plane) has none.
                eprintln!(
                    "warning: {}: black everywhere: the indirect image's relative errors and energy are undefined",
                    dir.join("indirect.exr").display()
                );
            }
            Ok((indirect, combined))
        }
        None => {
            let r = render_reference(scene, &ReferenceOptions::spp(spp), |_| {});
            Ok((
                RgbImage::new(w, h, r.indirect.clone()),
                RgbImage::new(w, h, r.combined()),
            ))
        }
    }
}

/// Linear RGB images of one view, row-major, y down.
#[derive(Clone, Debug, Default)]
pub struct Images {
    pub width: u32,
    pub height: u32,
    pub direct: Vec<[f32; 3]>,
    pub indirect: Vec<[f32; 3]>,
    pub ao: Vec<[f32; 3]>,
}

impl Images {
    /// direct + indirect (AO is not multiplied in).
    pub fn combined(&self) -> Vec<[f32; 3]> {
        crate::images::add(&self.direct, &self.indirect)
    }
}

#[derive(Clone, Copy, Debug)]
pub struct ReferenceOptions {
    /// Samples per pixel.
    pub spp: u32,
    pub seed: u64,
    /// Jitter primary rays over the pixel (off: every sample through the pixel centre).
    pub jitter: bool,
    /// Trace the indirect light (off: the indirect image stays 0 and only direct light and AO are
    /// estimated — `vxgi reference --ideal-cones` replaces the indirect image, so it skips the paths).
    pub indirect: bool,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        Self {
            spp: 64,
            seed: 1,
            jitter: true,
            indirect: true,
        }
    }
}

impl ReferenceOptions {
    /// `spp` samples per pixel, the other options at their defaults (jittered, seed 1).
    pub fn spp(spp: u32) -> Self {
        Self {
            spp,
            ..Default::default()
        }
    }
}

/// An orthonormal basis around `n` (Duff et al. 2017).
fn basis(n: Vec3) -> (Vec3, Vec3) {
    n.any_orthonormal_pair()
}

fn cosine_direction(n: Vec3, r1: f32, r2: f32) -> Vec3 {
    let (t, b) = basis(n);
    let phi = 2.0 * PI * r1;
    let s = r2.sqrt();
    (t * (phi.cos() * s) + b * (phi.sin() * s) + n * (1.0 - r2).max(0.0).sqrt()).normalize()
}

fn phong_direction(axis: Vec3, shininess: f32, r1: f32, r2: f32) -> Vec3 {
    let (t, b) = basis(axis);
    let phi = 2.0 * PI * r1;
    let c = r2.powf(1.0 / (shininess + 1.0));
    let s = (1.0 - c * c).max(0.0).sqrt();
    (t * (phi.cos() * s) + b * (phi.sin() * s) + axis * c).normalize()
}

fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

struct Ctx<'a> {
    data: &'a SceneData,
    tracer: Tracer<'a>,
    ao_range: f32,
    ao_lambda: f32,
    bounces: u32,
}

struct Surface {
    p: Vec3,
    n: Vec3,
    ng: Vec3,
    front: bool,
    material: GpuMaterial,
}

impl<'a> Ctx<'a> {
    fn new(data: &'a SceneData, scene: &Scene, bounces: u32) -> Self {
        Self {
            tracer: Tracer::new(data),
            data,
            ao_range: scene.render.ao_range,
            ao_lambda: scene.render.ao_lambda,
            bounces,
        }
    }

    fn surface(&self, o: Vec3, d: Vec3) -> Option<Surface> {
        let h = self.tracer.closest(o, d, 0.0, FAR)?;
        let tri = &self.data.triangles[h.tri as usize];
        // The G-buffer's definition of position and shading normal (face normal where vertex
        // normals cancel), and its albedo (Kd or the map_Kd texel).
        let t = texel(o, d, tri, &h);
        let m = (tri.material() as usize).min(self.data.materials.len() - 1);
        let alb = albedo(
            &self.data.materials,
            &self.data.triangles,
            &self.data.textures(),
            &t,
        );
        Some(Surface {
            p: Vec3::from_slice(&t.position[..3]),
            n: Vec3::from_slice(&t.normal[..3]),
            ng: face_normal(tri),
            front: h.front,
            material: self.data.materials[m].with_albedo(alb),
        })
    }

    fn direct(&self, s: &Surface, wo: Vec3) -> Vec3 {
        shade_with(
            |o, d, t0, t1| self.tracer.occluded(o, d, t0, t1),
            &self.data.lights,
            &s.material,
            s.p,
            s.n,
            s.ng,
            wo,
            self.data.eps(),
        )
    }

    /// Indirect radiance at `s` towards `wo`: `bounces` bounces of light (1: the direct light of the
    /// surfaces it sees).
    fn indirect(&self, s: &Surface, wo: Vec3, rng: &mut ChaCha8Rng, bounces: u32) -> Vec3 {
        let m = &s.material;
        let kd = Vec3::from_slice(&m.diffuse[..3]);
        let ks = Vec3::from_slice(&m.specular[..3]);
        let shin = m.diffuse[3];
        let (ld, ls) = (luminance(kd), luminance(ks));
        if ld + ls <= 0.0 {
            return Vec3::ZERO;
        }
        let p_spec = ls / (ld + ls);
        let mirror = s.n * (2.0 * s.n.dot(wo)) - wo;
        let (r0, r1, r2): (f32, f32, f32) = (rng.random(), rng.random(), rng.random());
        let wi = if r0 < p_spec {
            phong_direction(mirror, shin, r1, r2)
        } else {
            cosine_direction(s.n, r1, r2)
        };
        let cos = s.n.dot(wi);
        if cos <= 0.0 || s.ng.dot(wi) <= 0.0 {
            return Vec3::ZERO;
        }
        let lobe = mirror.dot(wi).max(0.0);
        let pdf = (1.0 - p_spec) * cos / PI
            + if p_spec > 0.0 {
                p_spec * (shin + 1.0) * (0.5 / PI) * lobe.powf(shin)
            } else {
                0.0
            };
        if pdf <= 0.0 {
            return Vec3::ZERO;
        }
        let origin = s.p + s.ng * self.data.eps();
        match self.surface(origin, wi) {
            Some(s2) if s2.front => {
                let mut l = self.direct(&s2, -wi);
                if bounces > 1 {
                    l += self.indirect(&s2, -wi, rng, bounces - 1);
                }
                brdf(m, s.n, wi, wo, cos) * l * (cos / pdf)
            }
            _ => Vec3::ZERO,
        }
    }

    fn occlusion(&self, s: &Surface, toward_eye: Vec3, rng: &mut ChaCha8Rng) -> f32 {
        let (n, ng) = if s.ng.dot(toward_eye) >= 0.0 {
            (s.n, s.ng)
        } else {
            (-s.n, -s.ng)
        };
        let n = if n.dot(ng) > 0.0 { n } else { ng };
        let wi = cosine_direction(n, rng.random(), rng.random());
        if ng.dot(wi) <= 0.0 {
            return 1.0; // into the surface itself
        }
        let origin = s.p + ng * self.data.eps();
        match self.tracer.closest(origin, wi, 0.0, self.ao_range) {
            Some(h) => 1.0 / (1.0 + self.ao_lambda * h.t),
            None => 0.0,
        }
    }
}

/// Render the reference images. `progress(rows)` is called as rows finish (from worker threads).
pub fn render_reference(
    scene: &Scene,
    opts: &ReferenceOptions,
    progress: impl Fn(u64) + Sync,
) -> Images {
    // Lights past the exposure limit: rendered at 2^-k, scaled back (as the pipelines' frames).
    let k = crate::render::exposure(scene);
    if k != 0 {
        let mut out = render_reference(&scene.with_lights_scaled(2f32.powi(-k)), opts, progress);
        let f = 2f64.powi(k);
        for img in [&mut out.direct, &mut out.indirect] {
            for p in img.iter_mut() {
                *p = p.map(|c| {
                    if c.is_nan() {
                        c
                    } else {
                        (c as f64 * f).min(f32::MAX as f64) as f32
                    }
                });
            }
        }
        return out;
    }
    let data = SceneData::new(scene);
    let ctx = Ctx::new(&data, scene, scene.render.bounces);
    let (w, h) = (data.width(), data.height());
    let spp = opts.spp.max(1);
    let rows: Vec<Vec<[[f32; 3]; 3]>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let row = (0..w)
                .map(|x| {
                    let pixel = y as u64 * w as u64 + x as u64;
                    let mut rng = ChaCha8Rng::seed_from_u64(
                        opts.seed ^ pixel.wrapping_mul(0x9E37_79B9_7F4A_7C15),
                    );
                    // The indirect paths draw from their own stream, so the primary rays and AO
                    // (and so the direct image) are the same whether or not paths are traced.
                    let mut paths = rng.clone();
                    paths.set_stream(1);
                    let (mut d, mut i, mut a) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
                    for _ in 0..spp {
                        let (jx, jy) = if opts.jitter {
                            (rng.random::<f32>(), rng.random::<f32>())
                        } else {
                            (0.5, 0.5)
                        };
                        let (o, dir) = ray_through(&data.frame, x as f32 + jx, y as f32 + jy);
                        let Some(s) = ctx.surface(o, dir) else {
                            continue;
                        };
                        let wo = -dir;
                        if s.front {
                            d += ctx.direct(&s, wo);
                            if opts.indirect {
                                i += ctx.indirect(&s, wo, &mut paths, ctx.bounces);
                            }
                        }
                        a += 1.0 - ctx.occlusion(&s, wo, &mut rng);
                    }
                    let k = 1.0 / spp as f32;
                    [(d * k).to_array(), (i * k).to_array(), [a * k; 3]]
                })
                .collect();
            progress(1);
            row
        })
        .collect();
    let mut out = Images {
        width: w,
        height: h,
        ..Default::default()
    };
    for px in rows.into_iter().flatten() {
        out.direct.push(px[0]);
        out.indirect.push(px[1]);
        out.ao.push(px[2]);
    }
    out
}

/// World position (w = distance, -1: nothing) of every pixel centre, from the CPU mirror of the
/// `gbuffer` kernel.
pub fn pixel_positions(scene: &Scene) -> Vec<[f32; 4]> {
    let data = SceneData::new(scene);
    let (w, h) = (data.width(), data.height());
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            vxgi_cpu_mirror::gbuffer::shade_pixel(&data.frame, &data.nodes, &data.triangles, x, y)
                .position
        })
        .collect()
}

/// Light leak of `scenes/thin_wall.toml`: indirect energy (summed luminance) over pixels that see the
/// dark room (x > split_x) divided by that over pixels that see the lit room (x < split_x). Pixels
/// seeing nothing, or the wall's front edge (|x - split_x| <= half_thickness), count for neither.
pub fn leak(
    indirect: &[[f32; 3]],
    positions: &[[f32; 4]],
    split_x: f32,
    half_thickness: f32,
) -> f64 {
    let (mut dark, mut lit) = (0.0f64, 0.0f64);
    for (c, p) in indirect.iter().zip(positions) {
        if p[3] < 0.0 || (p[0] - split_x).abs() <= half_thickness {
            continue;
        }
        let l = luminance(Vec3::from(*c)) as f64;
        if p[0] > split_x {
            dark += l;
        } else {
            lit += l;
        }
    }
    if lit > 0.0 {
        dark / lit
    } else {
        0.0
    }
}

/// Strata per axis of an ideal cone's directions: the least `k` with `k x k >= rays` (at least 1).
pub fn ideal_cone_strata(rays: u32) -> u32 {
    let k = rays.max(1).isqrt();
    if k * k < rays {
        k + 1
    } else {
        k
    }
}

/// The diffuse cones a frame with `render`'s settings gathers, with their half-angle tangent: the
/// kernels' `cone_dirs` (the plain set without interleaving; with N x N interleaved classes the
/// spiral of cones x N^2 they take together), each weight divided by N^2 so that the set's weights
/// sum to 1: the set whose mean the resolve's neighbourhood average converges to, so the ideal cones
/// of an interleaved frame are of the whole set, not of one class.
pub fn cone_set(render: &crate::scene::RenderSettings) -> (Vec<[f32; 4]>, f32) {
    use vxgi_cpu_mirror::cone_trace::{cone_dirs, ConeParams};
    let tan = render.cone_half_angle.to_radians().tan();
    let params = ConeParams {
        diffuse_cones: render.cones,
        diffuse_tan: tan,
        interleave: render.cone_interleave,
        ..Default::default()
    };
    // A power of two: the division is exact.
    let classes = render.cone_interleave.max(1).pow(2) as f32;
    let set = cone_dirs(&params)
        .into_iter()
        .map(|[x, y, z, w]| [x, y, z, w / classes])
        .collect();
    (set, tan)
}

/// Ideal cones: the indirect light a cone tracer would gather with exact visibility and radiance.
/// It separates a cone set's own error (directions, apertures, weights) from the voxels' (filtering,
/// coverage, self-occlusion): compare it with the Monte Carlo reference for the first, with a
/// pipeline's render for the second.
///
/// Per pixel centre (front faces; 0 elsewhere), in the kernels' tangent frame
/// (`cone_trace::basis` of the shading normal): each cone of `cones` (axis xyz, weight w; half-angle
/// tangent `tan`; [`cone_set`] is a frame's) gets as radiance `C` the mean of the direct radiance seen
/// along `k x k` directions ([`ideal_cone_strata`]) stratified uniformly over its spherical cap
/// (directions below the triangle's plane count, seeing 0); indirect = albedo x sum w C. Materials
/// with Ks add Ks x the glossy cone's mean (the view's mirror direction, tan = clamp(sqrt(2 / (Ns +
/// 2)), 0.02, 1)), as `cone_trace` does. Deterministic (no random numbers). `progress(rows)` as rows
/// finish.
pub fn ideal_cones(
    scene: &Scene,
    cones: &[[f32; 4]],
    tan: f32,
    rays: u32,
    progress: impl Fn(u64) + Sync,
) -> Vec<[f32; 3]> {
    use vxgi_cpu_mirror::cone_trace::basis as tangent_frame;
    let data = SceneData::new(scene);
    let ctx = Ctx::new(&data, scene, 1);
    let k = ideal_cone_strata(rays);
    // Mean direct radiance over the cap of half-angle atan(tan) about `axis`, seen from `s`.
    let cap_mean = |s: &Surface, axis: Vec3, tan: f32| -> Vec3 {
        let cos_a = 1.0 / (1.0 + tan * tan).sqrt();
        let (at, ab) = basis(axis);
        let origin = s.p + s.ng * ctx.data.eps();
        let mut sum = Vec3::ZERO;
        for i in 0..k {
            for j in 0..k {
                // Uniform over the cap: cos(polar) uniform in [cos_a, 1], azimuth uniform.
                let ct = 1.0 - (i as f32 + 0.5) / k as f32 * (1.0 - cos_a);
                let st = (1.0 - ct * ct).max(0.0).sqrt();
                let phi = (j as f32 + 0.5) / k as f32 * 2.0 * PI;
                let wi = at * (st * phi.cos()) + ab * (st * phi.sin()) + axis * ct;
                if s.ng.dot(wi) <= 0.0 {
                    continue;
                }
                if let Some(s2) = ctx.surface(origin, wi) {
                    if s2.front {
                        sum += ctx.direct(&s2, -wi);
                    }
                }
            }
        }
        sum / (k * k) as f32
    };
    let (w, h) = (data.width(), data.height());
    let rows: Vec<Vec<[f32; 3]>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let row = (0..w)
                .map(|x| {
                    let (o, dir) = ray_through(&ctx.data.frame, x as f32 + 0.5, y as f32 + 0.5);
                    let Some(s) = ctx.surface(o, dir).filter(|s| s.front) else {
                        return [0.0; 3];
                    };
                    let (bt, bb) = tangent_frame(s.n);
                    let mut diffuse = Vec3::ZERO;
                    for c in cones {
                        let axis = (bt * c[0] + bb * c[1] + s.n * c[2]).normalize();
                        diffuse += cap_mean(&s, axis, tan) * c[3];
                    }
                    let m = &s.material;
                    let mut out = Vec3::from_slice(&m.diffuse[..3]) * diffuse;
                    let ks = Vec3::from_slice(&m.specular[..3]);
                    if ks != Vec3::ZERO {
                        let wo = -dir;
                        let refl = s.n * (2.0 * s.n.dot(wo)) - wo;
                        let tan_g = (2.0 / (m.diffuse[3] + 2.0)).sqrt().clamp(0.02, 1.0);
                        out += ks * cap_mean(&s, refl.normalize(), tan_g);
                    }
                    out.to_array()
                })
                .collect();
            progress(1);
            row
        })
        .collect();
    rows.into_iter().flatten().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An interleaved frame's ideal set is the spiral its N^2 classes take together, every cone of
    /// weight 1 / (cones N^2); a plain frame's is `diffuse_cones`.
    #[test]
    fn a_frames_cone_set_is_its_classes_together() {
        use vxgi_cpu_mirror::cone_trace::{diffuse_cones, spiral_cones};
        let mut r = crate::scene::RenderSettings {
            cones: 2,
            cone_half_angle: 5.0,
            cone_interleave: 8,
            ..Default::default()
        };
        let (set, tan) = cone_set(&r);
        assert_eq!(set, spiral_cones(128, tan));
        r.cone_interleave = 1;
        assert_eq!(cone_set(&r).0, diffuse_cones(2, tan));
    }
}
