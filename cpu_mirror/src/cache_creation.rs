//! Mirror of `kernels/cache_creation.wgsl`: CPRC 3.1 "Creation" — one cone per radiance-cache texel,
//! cone-marched through the pre-filtered voxel pyramid with the section 4 rules (cone_trace's `march`).
//!
//! Parameterisation (hemi-octahedral, the same for every cache): a `res x res` texel grid over
//! (u, v) in [-1, 1]^2; texel (i, j) has its centre at u = (i + 1/2) 2 / res - 1 (v likewise, j the row).
//! (u, v) maps to the tangent-space direction normalize(p.x, p.y, 1 - |p.x| - |p.y|) with
//! p = ((u + v) / 2, (u - v) / 2): the square covers the upper hemisphere (z >= 0, z = the cache
//! normal) without seams, every texel's solid angle within a factor ~2.6 of the mean 2 pi / res^2.
//! The inverse, for lookups: p = (x, y) / (|x| + |y| + z), (u, v) = (p.x + p.y, p.x - p.y).
//! Tangent frame: [`crate::cone_trace::basis`] of the cache normal (the pixel entry's).
//!
//! A cache is two vec4s: (origin xyz = the cache pixel's position + offset_voxels * s0 along its
//! normal, 0), (normal xyz, 0). Texel t of cache c (output index c * res^2 + t) marches one cone from
//! the origin along texel t's direction with half-angle tan = `cone_tan(res)` (a cone of the mean
//! texel solid angle 2 pi / res^2). Output: (radiance rgb, 0).
use crate::cone_trace::{basis, march, Volume, MAG};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// The kernel's uniform block (`struct CacheParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CacheParams {
    /// Caches.
    pub count: u32,
    /// Texels per cache (res^2).
    pub texels: u32,
    /// tan of every texel cone's half-angle ([`cone_tan`]).
    pub tan_half: f32,
    pub _pad: u32,
}

/// Tangent-space direction of hemi-octahedral coordinates (u, v) in [-1, 1]^2, in f64.
pub fn hemi_direction(u: f64, v: f64) -> [f64; 3] {
    let (px, py) = ((u + v) * 0.5, (u - v) * 0.5);
    let d = [px, py, 1.0 - px.abs() - py.abs()];
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    [d[0] / l, d[1] / l, d[2] / l]
}

/// Centre of texel `i` of `res` along one axis, in [-1, 1].
pub fn texel_centre(i: u32, res: u32) -> f64 {
    (i as f64 + 0.5) * 2.0 / res as f64 - 1.0
}

/// The host table the kernels read: per texel (row-major, row = v), its tangent-space direction (xyz)
/// and solid angle (w). Computed in f64: solid angles by an 8 x 8 midpoint rule of the map's Jacobian
/// dw = du dv / (2 |(p.x, p.y, 1 - |p.x| - |p.y|)|^3), then scaled so they sum to exactly 2 pi.
pub fn texel_directions(res: u32) -> Vec<[f32; 4]> {
    let sub = 8;
    let mut out = Vec::with_capacity((res * res) as usize);
    let mut omega = Vec::with_capacity((res * res) as usize);
    let h = 2.0 / res as f64;
    for j in 0..res {
        for i in 0..res {
            let mut w = 0.0;
            for sj in 0..sub {
                for si in 0..sub {
                    let u = texel_centre(i, res) + h * ((si as f64 + 0.5) / sub as f64 - 0.5);
                    let v = texel_centre(j, res) + h * ((sj as f64 + 0.5) / sub as f64 - 0.5);
                    let (px, py) = ((u + v) * 0.5, (u - v) * 0.5);
                    let z = 1.0 - px.abs() - py.abs();
                    let l = (px * px + py * py + z * z).sqrt();
                    w += (h / sub as f64).powi(2) / (2.0 * l * l * l);
                }
            }
            omega.push(w);
            out.push(hemi_direction(texel_centre(i, res), texel_centre(j, res)));
        }
    }
    let total: f64 = omega.iter().sum();
    let scale = std::f64::consts::TAU / total;
    out.iter()
        .zip(&omega)
        .map(|(d, w)| [d[0] as f32, d[1] as f32, d[2] as f32, (w * scale) as f32])
        .collect()
}

/// tan of the half-angle of a cone whose solid angle is the mean texel's, 2 pi / res^2:
/// 2 pi (1 - cos) = 2 pi / res^2.
pub fn cone_tan(res: u32) -> f32 {
    let c = 1.0 - 1.0 / (res as f64 * res as f64);
    ((1.0 - c * c).sqrt() / c) as f32
}

/// One texel: (radiance rgb, 0) and its bound (cone_trace's march bound: `MAG` of the accumulated
/// magnitudes plus the allowances for rounding-decided stops). `cache` = the cache's two vec4s, `dir`
/// = the texel's table entry, `lmax` = the pyramid's largest radiance.
pub fn create_texel(
    pyr: &impl Volume,
    cache: [[f32; 4]; 2],
    dir: [f32; 4],
    tan: f32,
    lmax: f32,
) -> ([f32; 4], [f32; 4]) {
    let o = Vec3::new(cache[0][0], cache[0][1], cache[0][2]);
    let n = Vec3::new(cache[1][0], cache[1][1], cache[1][2]);
    let (bt, bb) = basis(n);
    let d = bt * dir[0] + bb * dir[1] + n * dir[2];
    let r = march(pyr, o, d, tan, dir[2], lmax);
    let b = r.magnitude * MAG + r.allowance;
    (
        [r.radiance.x, r.radiance.y, r.radiance.z, 0.0],
        [b, b, b, 0.0],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texel_directions_cover_the_hemisphere() {
        for res in [1, 2, 8, 16, 32] {
            let t = texel_directions(res);
            let sum: f64 = t.iter().map(|d| d[3] as f64).sum();
            assert!((sum - std::f64::consts::TAU).abs() < 1e-4, "{res}: {sum}");
            // Cosine-weighted: integral of cos over the hemisphere is pi (the midpoint rule's error
            // shrinks with res).
            let cos: f64 = t.iter().map(|d| (d[2] * d[3]) as f64).sum();
            if res >= 8 {
                assert!((cos - std::f64::consts::PI).abs() < 0.03, "{res}: {cos}");
            }
            assert!(t.iter().all(|d| d[2] >= 0.0));
        }
    }

    #[test]
    fn the_encoding_inverts_the_table() {
        let res = 16;
        for (k, d) in texel_directions(res).iter().enumerate() {
            let s = d[0].abs() + d[1].abs() + d[2];
            let (px, py) = (d[0] / s, d[1] / s);
            let (u, v) = (px + py, px - py);
            let (i, j) = ((k as u32) % res, (k as u32) / res);
            assert!((u as f64 - texel_centre(i, res)).abs() < 1e-5);
            assert!((v as f64 - texel_centre(j, res)).abs() < 1e-5);
        }
    }
}
