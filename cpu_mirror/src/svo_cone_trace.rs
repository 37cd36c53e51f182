//! Mirror of `kernels/svo_cone_trace.wgsl`: `cone_trace`'s march and pixel shading (generic over
//! [`Volume`]) reading the sparse voxel octree. Mip level `l` (cell `s0 2^l`) is octree level
//! `depth - l`, whose vertex lattice points sit at `origin + s0/2 + i s0 2^l` (the voxel centres at
//! level 0, where the octree's leaves hold the voxel grid itself); trilinear over the 8 brick voxels of
//! the cell holding the point, quadrilinear across levels as the pyramid. Outside the lattice and in
//! missing nodes: empty. With anisotropic voxels (`svo.anisotropic = 1`, VCT 7.1) a cone reads, above
//! the leaves, each brick voxel's three directional values facing its direction `d`
//! (`svo_anisotropic`), mixed with weights `d.x^2, d.y^2, d.z^2`.
use crate::cone_trace::{quadrilinear, ConeParams, SampleError, Volume};
use crate::sparse_voxel_octree::{brick_value, find, voxel_index, Node, NONE};
use crate::svo_anisotropic::{direction, DIRECTIONS};
use glam::{Vec3, Vec4};

/// The kernel's `struct SvoParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SvoParams {
    pub depth: u32,
    pub inv_scale: f32,
    /// 1: directional values above the leaves (`SvoVolume::aniso`).
    pub anisotropic: u32,
    pub _pad: u32,
}

pub struct SvoVolume<'a> {
    /// `levels` = depth + 1, `side` = 2^(depth + 1).
    pub p: &'a ConeParams,
    pub svo: &'a SvoParams,
    pub nodes: &'a [Node],
    pub bricks: &'a [u32],
    /// `svo_anisotropic`'s directional values (read when `svo.anisotropic` = 1).
    pub aniso: &'a [[f32; 4]],
}

impl SvoVolume<'_> {
    /// Trilinear sample of mip level `l`; with `d`, the directional values along it where the level
    /// has them (above the leaves).
    fn level_dir(&self, x: Vec3, l: u32, d: Option<Vec3>) -> (Vec4, SampleError) {
        let s = self.svo.depth - l;
        let inv = self.p.inv_s0 * (1.0 / (1u32 << l) as f32);
        let origin = Vec3::from_slice(&self.p.origin[..3]);
        let q = (x - origin) * inv - Vec3::splat(0.5 / (1u32 << l) as f32);
        // The sample point's rounding, as cone_trace's Pyramid::level (see SampleError).
        let dq = SampleError::coordinate_error(x, origin, inv, q);
        let fl = q.floor();
        let f = q - fl;
        let i0 = [fl.x as i32, fl.y as i32, fl.z as i32];
        let points = (2u32 << s) as i32;
        let last = (1i32 << s) - 1;
        let c = i0.map(|i| (i >> 1).clamp(0, last));
        let n = find(self.nodes, s, c.map(|v| v as u32));
        let mut acc = Vec4::ZERO;
        let mut err = SampleError::default();
        if n == NONE {
            return (acc, err);
        }
        for corner in 0..8u32 {
            let cc = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let w = [0, 1, 2].map(|a| if cc[a] == 1 { f[a] } else { 1.0 - f[a] });
            let i = [0, 1, 2].map(|a| i0[a] + cc[a] as i32);
            let local = [0, 1, 2].map(|a| i[a] - 2 * c[a]);
            if (0..3).any(|a| i[a] < 0 || i[a] > points || local[a] < 0 || local[a] > 2) {
                continue;
            }
            let vi = voxel_index(local.map(|v| v as u32));
            let v = match d {
                Some(d) if s < self.svo.depth => {
                    let base = (n as usize * 27 + vi) * DIRECTIONS;
                    let pick =
                        |a: usize, c: f32| Vec4::from_array(self.aniso[base + direction(a, c)]);
                    let (ax, ay, az) = (pick(0, d.x), pick(1, d.y), pick(2, d.z));
                    let w2 = d * d;
                    // The mixing weights' error: d differs from the GPU's by a few ULP (16 of a unit
                    // vector's components), so d_a^2 by 2 |d_a| 16 u + 3 u (its own roundings); a
                    // component within 16 u of 0 may pick the other sign, at weight (16 u)^2.
                    let ed = 16.0 * f32::EPSILON;
                    let tw = w[0] * w[1] * w[2];
                    for (a, da) in [(0, d.x), (1, d.y), (2, d.z)] {
                        let both = pick(a, da).abs().max(pick(a, -da).abs());
                        let dw = 2.0 * da.abs() * ed + 3.0 * f32::EPSILON + ed * ed;
                        err.rgb += tw * dw * both.x.max(both.y).max(both.z);
                        err.a += tw * dw * both.w;
                    }
                    (ax * w2.x + ay * w2.y) + az * w2.z
                }
                _ => brick_value(self.bricks, n, vi, self.svo.inv_scale),
            };
            acc += v * (w[0] * w[1] * w[2]);
            err.add_corner(dq, w, v);
        }
        (acc, err)
    }
}

impl Volume for SvoVolume<'_> {
    fn params(&self) -> &ConeParams {
        self.p
    }

    fn level(&self, x: Vec3, l: u32) -> (Vec4, SampleError) {
        self.level_dir(x, l, None)
    }

    /// Anisotropic: quadrilinear as [`Volume::sample`] over the directional levels.
    fn sample_cone(&self, x: Vec3, lf: f32, _diam: f32, d: Vec3) -> (Vec4, SampleError) {
        if self.svo.anisotropic == 0 {
            return self.sample(x, lf);
        }
        quadrilinear(self.p.levels - 1, lf, |l| self.level_dir(x, l, Some(d)))
    }
}
