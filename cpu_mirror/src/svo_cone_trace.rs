//! Mirror of `kernels/svo_cone_trace.wgsl`: `cone_trace`'s march and pixel shading (generic over
//! [`Volume`]) reading the sparse voxel octree. Mip level `l` (cell `s0 2^l`) is octree level
//! `depth - l`, whose vertex lattice points sit at `origin + s0/2 + i s0 2^l` (the voxel centres at
//! level 0, where the octree's leaves hold the voxel grid itself); trilinear over the 8 brick voxels of
//! the cell holding the point, quadrilinear across levels as the pyramid. Outside the lattice and in
//! missing nodes: empty.
use crate::cone_trace::{ConeParams, SampleError, Volume};
use crate::sparse_voxel_octree::{find, voxel_index, Node, BRICK_WORDS, CHANNELS, NONE};
use glam::{Vec3, Vec4};

/// The kernel's `struct SvoParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SvoParams {
    pub depth: u32,
    pub inv_scale: f32,
    pub _pad: [u32; 2],
}

pub struct SvoVolume<'a> {
    /// `levels` = depth + 1, `side` = 2^(depth + 1).
    pub p: &'a ConeParams,
    pub svo: &'a SvoParams,
    pub nodes: &'a [Node],
    pub bricks: &'a [u32],
}

impl Volume for SvoVolume<'_> {
    fn params(&self) -> &ConeParams {
        self.p
    }

    fn level(&self, x: Vec3, l: u32) -> (Vec4, SampleError) {
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
            let b = n as usize * BRICK_WORDS + voxel_index(local.map(|v| v as u32)) * CHANNELS;
            let v = Vec4::new(
                self.bricks[b] as f32,
                self.bricks[b + 1] as f32,
                self.bricks[b + 2] as f32,
                self.bricks[b + 3] as f32,
            ) * self.svo.inv_scale;
            acc += v * (w[0] * w[1] * w[2]);
            err.add_corner(dq, w, v);
        }
        (acc, err)
    }
}
