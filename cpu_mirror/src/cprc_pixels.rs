//! Mirror of `kernels/cprc_pixels.wgsl`: what cprc reads from a frame's G-buffer and what it writes
//! back to the frame's pixels (Rehfeld et al. 2014, 3.2 and 3.3).
//!
//! `inputs`, per pixel `i`: the pixel gathers (is *front*) where `gb_normal.w > 0`, `gb_triangle` is
//! a triangle of the scene and the position is finite. For a front pixel, with `p` its position, `n`
//! its G-buffer normal, `e` the eye and `f` the camera's forward axis:
//! - `nv = n / |n|` (`(0, 0, 1)` where `n . n` is 0 or not finite); `wo = (e - p) / |e - p|` (`nv`
//!   where `e = p`); `r = nv * (2 (nv . wo)) - wo`;
//! - `depth = (p - e) . f`; `positions = (p, 1)`;
//! - `pixel_dirs[2i] = (nv, 0)`, `pixel_dirs[2i + 1] = (r, lobe.w)`, `specular = (lobe.xyz, 0)` where
//!   `lobe = lobes[material]` (the triangle's material, clamped to the table: Ks and the glossy mip
//!   level, -1 without Ks);
//! - `normals`: the snorm16 quantisation `q = round_ties_even(clamp(n, -1, 1) * 32767)` of the
//!   G-buffer's normal as stored (unit to a few ULP: gbuffer.wgsl normalises it) with the geometry
//!   flag, packed as `octahedral::pack`; background where `q = 0` or where `depth` is not a finite
//!   positive number.
//!
//! Other pixels: zeros, `pixel_dirs[2i + 1].w = -1`, `normals` background.
//!
//! `compose`, per pixel: front (`positions.w == 1`): `indirect = albedo * (1 / pi) * diffuse +
//! specular * glossy`, `ao = 1`; else `indirect = 0` and `ao = 1` on any geometry (`gb_normal.w !=
//! 0`), 0 on the background. Rgb, w = 0.
use crate::octahedral::pack;
use glam::Vec3;

/// Unit roundoff of f32.
const U: f32 = f32::EPSILON / 2.0;

/// 1 / pi as the kernel's constant.
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;

/// Whether the bits of `x` are a finite number (the kernel's test: exponent not all ones).
pub fn finite(x: f32) -> bool {
    x.to_bits() & 0x7f80_0000 != 0x7f80_0000
}

/// One pixel's G-buffer as `inputs` reads it.
#[derive(Clone, Copy, Debug)]
pub struct GPixel {
    pub position: [f32; 4],
    pub normal: [f32; 4],
    pub triangle: u32,
}

/// What `inputs` writes for one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelOut {
    pub normal: [u32; 2],
    pub depth: f32,
    pub position: [f32; 4],
    pub dirs: [[f32; 4]; 2],
    pub specular: [f32; 4],
}

/// The scalars `inputs` reads besides the pixel: the eye, the forward axis, how many triangles the
/// scene has, and per triangle its material (`materials[t]`) and per material its lobe.
pub struct Scene<'a> {
    pub eye: [f32; 4],
    pub forward: [f32; 4],
    pub materials: &'a dyn Fn(u32) -> u32,
    pub triangles: u32,
    pub lobes: &'a [[f32; 4]],
}

/// The snorm16 packing of a G-buffer normal (background where it is not finite or quantises to 0).
pub fn quantised(n: [f32; 4]) -> [u32; 2] {
    if !(finite(n[0]) && finite(n[1]) && finite(n[2])) {
        return [0, 0];
    }
    let q = [0, 1, 2].map(|a| (n[a].clamp(-1.0, 1.0) * 32767.0).round_ties_even() as i32);
    if q == [0, 0, 0] {
        return [0, 0];
    }
    pack(Some(q))
}

fn normalize_or(v: Vec3, or: Vec3) -> Vec3 {
    let l2 = v.dot(v);
    if l2 > 0.0 && finite(l2) {
        v / l2.sqrt()
    } else {
        or
    }
}

/// `inputs` for one pixel (see the module doc).
pub fn pixel(s: &Scene, g: &GPixel) -> PixelOut {
    let p = Vec3::from_slice(&g.position[..3]);
    let front =
        g.normal[3] > 0.0 && g.triangle < s.triangles && (0..3).all(|a| finite(g.position[a]));
    if !front {
        return PixelOut {
            dirs: [[0.0; 4], [0.0, 0.0, 0.0, -1.0]],
            ..Default::default()
        };
    }
    let eye = Vec3::from_slice(&s.eye[..3]);
    let fwd = Vec3::from_slice(&s.forward[..3]);
    let nv = normalize_or(Vec3::from_slice(&g.normal[..3]), Vec3::Z);
    let wo = normalize_or(eye - p, nv);
    let r = nv * (2.0 * nv.dot(wo)) - wo;
    let depth = (p - eye).dot(fwd);
    let m = ((s.materials)(g.triangle) as usize).min(s.lobes.len() - 1);
    let lobe = s.lobes[m];
    let normal = if finite(depth) && depth > 0.0 {
        quantised(g.normal)
    } else {
        [0, 0]
    };
    PixelOut {
        normal,
        depth,
        position: [p.x, p.y, p.z, 1.0],
        dirs: [[nv.x, nv.y, nv.z, 0.0], [r.x, r.y, r.z, lobe[3]]],
        specular: [lobe[0], lobe[1], lobe[2], 0.0],
    }
}

/// Bounds on |GPU - mirror| for a front pixel's `depth`, `nv` (each component) and `r` (each
/// component), from the WGSL rules: `normalize` is `x / length(x)`, `length` is `sqrt(dot(x, x))`,
/// `sqrt` is `1 / inverseSqrt` (inverseSqrt 2 ULP, each division 2.5 ULP), products and sums
/// correctly rounded or fused. A unit vector's components then differ by at most 1.5 u (the dot,
/// halved by the root) plus 2 u (inverseSqrt) plus twice 2.5 u (the divisions) plus 1 u: 9.5 u, 12 u
/// taken. `wo` also carries the rounding of `e - p` (u per component relative to |e - p|): 14 u.
/// `nv . wo` has both factors' errors summed over three components and 3 u of its own; `r` is twice
/// `nv` times that dot, minus `wo`, with 2 u of its own rounding. Depth: the difference's rounding (u
/// of |p| + |e| per component) and the dot's (3 u of the sum of |terms|, 4 u taken). All doubled.
pub fn pixel_bounds(s: &Scene, g: &GPixel) -> (f32, f32, f32) {
    let p = Vec3::from_slice(&g.position[..3]);
    let eye = Vec3::from_slice(&s.eye[..3]);
    let fwd = Vec3::from_slice(&s.forward[..3]);
    let d = p - eye;
    let terms = d.abs().dot(fwd.abs());
    let depth = 2.0 * (4.0 * U * terms + U * (p.abs() + eye.abs()).dot(fwd.abs()));
    let (b_n, b_wo) = (12.0 * U, 14.0 * U);
    let b_dot = 3f32.sqrt() * (b_n + b_wo) + 3.0 * U;
    let b_r = 2.0 * (b_n + b_dot) + b_wo + 2.0 * U;
    (depth, 2.0 * b_n, 2.0 * b_r)
}

/// `compose` for one pixel: (indirect, ao).
pub fn compose(
    position: [f32; 4],
    gb_normal: [f32; 4],
    albedo: [f32; 4],
    specular: [f32; 4],
    diffuse: [f32; 4],
    glossy: [f32; 4],
) -> ([f32; 4], [f32; 4]) {
    if position[3] != 1.0 {
        let g = if gb_normal[3] != 0.0 { 1.0 } else { 0.0 };
        return ([0.0; 4], [g, g, g, 0.0]);
    }
    let c = |k: usize| albedo[k] * INV_PI * diffuse[k] + specular[k] * glossy[k];
    ([c(0), c(1), c(2), 0.0], [1.0, 1.0, 1.0, 0.0])
}

/// Bound on |GPU - mirror| per component of `compose`'s indirect: three products and a sum, each
/// rounded once or fused: 3 u of the sum of |terms|, doubled (0 off the front pixels: exact zeros).
pub fn compose_bound(
    position: [f32; 4],
    albedo: [f32; 4],
    specular: [f32; 4],
    diffuse: [f32; 4],
    glossy: [f32; 4],
) -> [f32; 4] {
    if position[3] != 1.0 {
        return [0.0; 4];
    }
    let b = |k: usize| {
        2.0 * 3.0 * U * ((albedo[k] * INV_PI * diffuse[k]).abs() + (specular[k] * glossy[k]).abs())
    };
    [b(0), b(1), b(2), 0.0]
}
