//! Mirror of `kernels/gbuffer.wgsl`: one primary ray per pixel centre through the flattened BVH
//! (`bvh_trace`), writing position + distance, shading normal + side, and the triangle hit.
//!
//! Pixel (x, y), y down: `ndc = ((x + 0.5) / w * 2 - 1, 1 - (y + 0.5) / h * 2)`,
//! `d = normalize(forward + right * ndc.x + up * ndc.y)` (right and up pre-scaled by the field of view
//! and aspect on the host), origin = eye. Shading normal: `normalize(na (1-u-v) + nb u + nc v)`.
//! Where the interpolated normal has squared length <= 1e-12 (vertex normals that cancel) the face
//! normal is used. Side: 1 front, -1 back, 0 no hit (then position = (0,0,0,-1), normal = 0, triangle = NONE).
//!
//! Albedo (`gb_albedo`, rgb + 0): the material's Kd, or where it has a `map_Kd` texture the nearest
//! texel at `uv = uv_a (1-u-v) + uv_b u + uv_c v`, repeating: `f = uv - floor(uv)`, column
//! `min(u32(f.x W), W-1)`, row `min(u32((1 - f.y) H), H-1)` (row 0 is the image's top, OBJ's v = 1).
//! Texels are packed sRGB8 (`r | g << 8 | b << 16`) decoded through a 256-entry table to linear.
use crate::bvh_trace::{closest, intersect, GpuNode, GpuTriangle, Hit, FAR, NONE};
use crate::direct_light::GpuMaterial;
use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

/// Camera and frame constants (the WGSL `Frame`). `eye.w` = the scene's ray offset epsilon.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Frame {
    pub eye: [f32; 4],
    pub forward: [f32; 4],
    pub right: [f32; 4],
    pub up: [f32; 4],
    /// width, height, light count, projection (0 perspective; 1 orthographic: rays along `forward`
    /// from `eye + right * ndc.x + up * ndc.y`).
    pub size: [u32; 4],
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// The primary ray of pixel `(x, y)` (through its centre).
pub fn primary_ray(frame: &Frame, x: u32, y: u32) -> (Vec3, Vec3) {
    ray_through(frame, x as f32 + 0.5, y as f32 + 0.5)
}

/// The camera ray through image point `(fx, fy)` in pixel units (y down); the reference renderer
/// jitters it over the pixel.
pub fn ray_through(frame: &Frame, fx: f32, fy: f32) -> (Vec3, Vec3) {
    let w = frame.size[0] as f32;
    let h = frame.size[1] as f32;
    let nx = fx / w * 2.0 - 1.0;
    let ny = 1.0 - fy / h * 2.0;
    if frame.size[3] == 1 {
        // Orthographic (a directional light's RSM): parallel rays from the image plane.
        return (
            v3(frame.eye) + v3(frame.right) * nx + v3(frame.up) * ny,
            v3(frame.forward),
        );
    }
    let d = v3(frame.forward) + v3(frame.right) * nx + v3(frame.up) * ny;
    let d = d * (1.0 / d.dot(d).sqrt());
    (v3(frame.eye), d)
}

/// One pixel of the G-buffer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Texel {
    pub position: [f32; 4],
    pub normal: [f32; 4],
    pub triangle: u32,
    /// Barycentrics (u, v) of the hit (not an output: what the albedo lookup uses).
    pub bary: [f32; 2],
}

pub const MISS: Texel = Texel {
    position: [0.0, 0.0, 0.0, -1.0],
    normal: [0.0; 4],
    triangle: NONE,
    bary: [0.0; 2],
};

/// The diffuse textures as the kernels bind them: per-triangle vertex UVs (`uvs[3 t + k]`), the atlas
/// of packed sRGB8 texels, and the sRGB-to-linear table (256 entries).
#[derive(Clone, Copy, Debug)]
pub struct Textures<'a> {
    pub uvs: &'a [[f32; 2]],
    pub texels: &'a [u32],
    pub lut: &'a [f32],
}

/// Texel index of `uv` in a `w` x `h` texture (nearest, repeating), as the WGSL computes it: every
/// step is exact or correctly rounded (x - floor(x) is exact), so equal `uv` give equal indices.
pub fn texel_index(uv: Vec2, w: u32, h: u32) -> u32 {
    let f = uv - uv.floor();
    let x = ((f.x * w as f32) as u32).min(w - 1);
    let y = (((1.0 - f.y) * h as f32) as u32).min(h - 1);
    y * w + x
}

fn decode(texel: u32, lut: &[f32]) -> [f32; 4] {
    let c = |s: u32| lut[((texel >> s) & 255) as usize];
    [c(0), c(8), c(16), 0.0]
}

/// Interpolated texture coordinate of a hit (barycentrics `bary`) on triangle `t`.
pub fn hit_uv(tex: &Textures, t: u32, bary: [f32; 2]) -> Vec2 {
    let uv = |k: usize| Vec2::from(tex.uvs[3 * t as usize + k]);
    let (u, v) = (bary[0], bary[1]);
    uv(0) * (1.0 - u - v) + uv(1) * u + uv(2) * v
}

/// The material of a texel's triangle (None for a miss).
fn material_of<'a>(
    materials: &'a [GpuMaterial],
    tris: &[GpuTriangle],
    t: &Texel,
) -> Option<&'a GpuMaterial> {
    let tri = tris.get(t.triangle as usize)?;
    Some(&materials[(tri.material() as usize).min(materials.len() - 1)])
}

/// The albedo of a texel (see the module documentation); zeros for a miss.
pub fn albedo(
    materials: &[GpuMaterial],
    tris: &[GpuTriangle],
    tex: &Textures,
    t: &Texel,
) -> [f32; 4] {
    let Some(m) = material_of(materials, tris, t) else {
        return [0.0; 4];
    };
    let [offset, w, h, _] = m.texture;
    if w == 0 || h == 0 {
        return [m.diffuse[0], m.diffuse[1], m.diffuse[2], 0.0];
    }
    let i = texel_index(hit_uv(tex, t.triangle, t.bary), w, h);
    decode(tex.texels[(offset + i) as usize], tex.lut)
}

/// Bound |GPU - mirror| of a texel's albedo: 0 where it is Kd; where it comes from a texture, the
/// largest difference to any texel the GPU's uv could select. That uv differs from the mirror's by the
/// barycentrics' error (`duv`, from [`texel_bounds`]' analysis) times the UV edges, plus the
/// interpolation's own rounding (three products and two sums, possibly fused: 8 ULP of the terms).
pub fn albedo_bound(
    materials: &[GpuMaterial],
    tris: &[GpuTriangle],
    tex: &Textures,
    t: &Texel,
    duv: f32,
) -> [f32; 4] {
    let [offset, w, h, _] = material_of(materials, tris, t).map_or([0; 4], |m| m.texture);
    if w == 0 || h == 0 {
        return [0.0; 4];
    }
    let uv = |k: usize| Vec2::from(tex.uvs[3 * t.triangle as usize + k]);
    let eps = f32::EPSILON;
    let centre = hit_uv(tex, t.triangle, t.bary);
    let err = ((uv(1) - uv(0)).abs() + (uv(2) - uv(0)).abs()) * (2.0 * duv)
        + (uv(0).abs() + uv(1).abs() + uv(2).abs() + centre.abs()) * (8.0 * eps);
    let own = decode(
        tex.texels[(offset + texel_index(centre, w, h)) as usize],
        tex.lut,
    );
    // Columns/rows reachable within the error (wrapping), all of them when the error spans the texture.
    let reach = |c: f32, e: f32, n: u32| -> Vec<u32> {
        let lo = ((c - e) * n as f32).floor() as i64 - 1;
        let hi = ((c + e) * n as f32).floor() as i64 + 1;
        if hi - lo + 1 >= n as i64 {
            (0..n).collect()
        } else {
            (lo..=hi).map(|k| k.rem_euclid(n as i64) as u32).collect()
        }
    };
    let mut bound = [0.0f32; 4];
    for y in reach(-centre.y, err.y, h) {
        for x in reach(centre.x, err.x, w) {
            let other = decode(tex.texels[(offset + y * w + x) as usize], tex.lut);
            for c in 0..3 {
                bound[c] = bound[c].max((other[c] - own[c]).abs());
            }
        }
    }
    bound
}

/// The texel a hit on triangle `h.tri` produces.
pub fn texel(o: Vec3, d: Vec3, tri: &GpuTriangle, h: &Hit) -> Texel {
    let p = o + d * h.t;
    let w = 1.0 - h.u - h.v;
    let mut n = v3(tri.na) * w + v3(tri.nb) * h.u + v3(tri.nc) * h.v;
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN must take the fallback too, as in the WGSL
    if !(n.dot(n) > 1e-12) {
        n = (v3(tri.b) - v3(tri.a)).cross(v3(tri.c) - v3(tri.a));
    }
    let n = n * (1.0 / n.dot(n).sqrt());
    Texel {
        position: [p.x, p.y, p.z, h.t],
        normal: [n.x, n.y, n.z, if h.front { 1.0 } else { -1.0 }],
        triangle: h.tri,
        bary: [h.u, h.v],
    }
}

/// The mirror's texel for pixel `(x, y)`.
pub fn shade_pixel(
    frame: &Frame,
    nodes: &[GpuNode],
    tris: &[GpuTriangle],
    x: u32,
    y: u32,
) -> Texel {
    let (o, d) = primary_ray(frame, x, y);
    match closest(nodes, tris, o, d, 0.0, FAR) {
        Some(h) => texel(o, d, &tris[h.tri as usize], &h),
        None => MISS,
    }
}

/// Barycentric slack within which a hit is decided by rounding rather than by geometry: the
/// barycentrics are quotients of cross/dot products whose absolute error is a few ULP of the
/// products' magnitudes; 1e-4 is ~800 ULP of a unit barycentric, far above that for any ray that is
/// not grazing (grazing rays are accepted through the distance test below).
pub const EDGE_SLACK: f32 = 1e-4;

/// The texel the GPU must have produced at `(x, y)`, given what it did produce (`gpu_triangle`):
/// the mirror's own when the GPU hit the same triangle; the GPU's pick (recomputed by the mirror) when
/// rounding could have decided between them — the GPU's triangle is hit within [`EDGE_SLACK`] and not
/// measurably farther than the mirror's, or the mirror's own hit lies within the slack of an edge.
/// The flag says whether the GPU's differing pick was accepted.
pub fn accepted_texel(
    frame: &Frame,
    nodes: &[GpuNode],
    tris: &[GpuTriangle],
    x: u32,
    y: u32,
    gpu_triangle: u32,
) -> (Texel, bool) {
    let (o, d) = primary_ray(frame, x, y);
    let mine = closest(nodes, tris, o, d, 0.0, FAR);
    let own = match &mine {
        Some(h) => texel(o, d, &tris[h.tri as usize], h),
        None => MISS,
    };
    if own.triangle == gpu_triangle {
        return (own, false);
    }
    // Is the mirror's own hit (if any) itself borderline?
    let own_borderline = match &mine {
        Some(h) => intersect(o, d, &tris[h.tri as usize], 0.0, FAR, -EDGE_SLACK).is_none(),
        None => true,
    };
    if gpu_triangle == NONE {
        return if own_borderline {
            (MISS, true)
        } else {
            (own, false)
        };
    }
    let Some(tri) = tris.get(gpu_triangle as usize) else {
        return (own, false);
    };
    let Some(g) = intersect(o, d, tri, 0.0, FAR, EDGE_SLACK) else {
        return (own, false);
    };
    let near_enough = match &mine {
        // Same distance up to rounding (coplanar or meeting triangles), or the mirror's pick is
        // borderline and the GPU's is the next surface behind an edge.
        Some(h) => g.t <= h.t * (1.0 + 1e-4) || own_borderline,
        None => true,
    };
    if !near_enough {
        return (own, false);
    }
    let hit = Hit {
        t: g.t,
        tri: gpu_triangle,
        u: g.u,
        v: g.v,
        front: g.det > 0.0,
    };
    (texel(o, d, tri, &hit), true)
}

/// Per-element bounds |GPU - mirror| for position (xyz and t) and normal of a texel, from the WGSL
/// rules: +, -, * correctly rounded, division and inverseSqrt 2.5 / 2 ULP, dots and crosses in any order
/// and possibly fused. The distance t = (e2 . q) / det is a quotient of sums whose cancellation is
/// measured by `cond` (sum of |terms| over |result| for numerator and denominator); the ray direction
/// itself carries ~8 ULP from the camera basis and the normalisation. 32 ULP per unit of condition
/// covers those with margin; bound use is reported by the tests. The third value bounds the
/// barycentrics' error (what [`albedo_bound`] takes).
pub fn texel_bounds(
    frame: &Frame,
    tris: &[GpuTriangle],
    x: u32,
    y: u32,
    t: &Texel,
) -> ([f32; 4], [f32; 4], f32) {
    if t.triangle == NONE {
        return ([0.0; 4], [0.0; 4], 0.0);
    }
    let eps = f32::EPSILON;
    let (o, d) = primary_ray(frame, x, y);
    let tri = &tris[t.triangle as usize];
    let a = v3(tri.a);
    let e1 = v3(tri.b) - a;
    let e2 = v3(tri.c) - a;
    let s = o - a;
    let p = d.cross(e2);
    let q = s.cross(e1);
    let pa = d.abs().cross_abs(e2.abs());
    let qa = s.abs().cross_abs(e1.abs());
    let det = e1.dot(p);
    let num = e2.dot(q);
    let cond_det = e1.abs().dot(pa) / det.abs().max(f32::MIN_POSITIVE);
    let cond_num = e2.abs().dot(qa) / num.abs().max(f32::MIN_POSITIVE);
    let cond = 1.0 + cond_det + cond_num;
    let dist = t.position[3].abs();
    // An orthographic ray's origin `eye + right nx + up ny` is computed (fused or not: one ULP of its
    // magnitudes apart), a perspective ray's is the exact eye. Seen on an H100 with the scene 1000
    // units from the origin: t off by 3e-5. The origin moving by `d_o` moves t by d_o / |cos|
    // (bounded by `1 + cond_det` times it) and the barycentrics by d_o |p| / |det|.
    let d_o = if frame.size[3] == 1 {
        eps * (v3(frame.eye).abs().max_element() + v3(frame.right).length() + v3(frame.up).length())
    } else {
        0.0
    };
    let bt = 32.0 * eps * dist * cond + 2.0 * d_o * 1.8 * (1.0 + cond_det);
    let scale = o.abs().max_element() + dist;
    let bp = 32.0 * eps * scale * cond + 2.0 * d_o * 1.8 * (2.0 + cond_det);
    // Barycentric error ~ the same relative error as t, in units of the barycentric (<= 1 + slack).
    let duv = 32.0
        * eps
        * (1.0
            + cond_det
            + e1.abs().dot(qa).max(s.abs().dot(pa)) / det.abs().max(f32::MIN_POSITIVE))
        + 2.0 * d_o * (pa.element_sum() + d.abs().cross_abs(e1.abs()).element_sum())
            / det.abs().max(f32::MIN_POSITIVE);
    let spread = (v3(tri.nb) - v3(tri.na)).length() + (v3(tri.nc) - v3(tri.na)).length();
    let bn = 16.0 * eps + 4.0 * duv * spread;
    ([bp, bp, bp, bt], [bn, bn, bn, 0.0], duv)
}

trait CrossAbs {
    fn cross_abs(self, o: Self) -> Self;
}
impl CrossAbs for Vec3 {
    /// |a| x |b| with every product added: bounds the magnitude of each term of a cross product.
    fn cross_abs(self, o: Vec3) -> Vec3 {
        Vec3::new(
            self.y * o.z + self.z * o.y,
            self.z * o.x + self.x * o.z,
            self.x * o.y + self.y * o.x,
        )
    }
}
