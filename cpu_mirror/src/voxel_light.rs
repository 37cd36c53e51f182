//! Mirror of `kernels/voxel_light.wgsl`: direct light into the non-empty voxels (CPRC 3.1, "Voxel
//! Illumination"), with exact hard shadows (one shadow ray per light through the BVH) instead of the
//! paper's shadow cones, as the light-transport contract asks.
//!
//! Per listed voxel v (Morton index, centre c): albedo and alpha from `vox_colour`, the mean normal m
//! from `vox_normal`; `n = m / |m|` when `|m| > 1e-3`, else the voxel is lit as if facing each light.
//! `L = albedo / pi * sum_lights E * max(n . wi, 0) * visible`, the shadow ray starting one voxel from
//! the centre along n (or towards the light) and ending at the light. Output `(L * alpha, alpha)`: the
//! pre-multiplied input of `surface_coverage_mip`. Unlisted voxels stay 0.
use crate::bvh_trace::{all_hits, occluded, GpuNode, GpuTriangle};
use crate::direct_light::{incident, incident_error, GpuLight};
use crate::morton;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::f32::consts::PI;

/// Grid placement (the WGSL `VoxelGrid`): origin.xyz + voxel size in origin.w; side, light count; and
/// where the grid sits in the world: `model` (rows of a 3x4 world-from-grid transform), `normal_model`
/// (rows of its inverse transpose), `world.x` = a voxel's size in world units (the shadow ray's start
/// and end offsets). Identity (`VoxelGrid::in_world`) for a grid voxelized in world space — then every
/// product is by 1 or 0 and the arithmetic is exactly that of an untransformed grid. A rigidly placed
/// grid (an instance's own voxel hierarchy, CPRC 3.1) is lit where it stands without re-voxelizing.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VoxelGrid {
    pub origin: [f32; 4],
    /// side, light count, 0, 0.
    pub size: [u32; 4],
    pub model: [[f32; 4]; 3],
    pub normal_model: [[f32; 4]; 3],
    /// x: voxel size in world units; y, z, w unused.
    pub world: [f32; 4],
}

const IDENTITY: [[f32; 4]; 3] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
];

impl VoxelGrid {
    /// A grid in world space: origin and voxel size `origin`, `side`, `lights`.
    pub fn in_world(origin: [f32; 4], side: u32, lights: u32) -> Self {
        Self {
            origin,
            size: [side, lights, 0, 0],
            model: IDENTITY,
            normal_model: IDENTITY,
            world: [origin[3], 0.0, 0.0, 0.0],
        }
    }

    /// The grid placed by `m` (world from grid; invertible): its rows, its inverse transpose's, and the
    /// voxel size scaled by the cube root of |det| (exact for a uniform scale).
    pub fn placed(mut self, m: glam::Mat4) -> Self {
        let r = m.transpose().to_cols_array_2d();
        self.model = [r[0], r[1], r[2]];
        let n = glam::Mat3::from_mat4(m).inverse().transpose();
        let nr = n.transpose().to_cols_array_2d();
        self.normal_model = nr.map(|c| [c[0], c[1], c[2], 0.0]);
        let scale = glam::Mat3::from_mat4(m).determinant().abs().cbrt();
        self.world = [self.origin[3] * scale, 0.0, 0.0, 0.0];
        self
    }

    pub fn is_identity(&self) -> bool {
        self.model == IDENTITY && self.normal_model == IDENTITY
    }

    /// Centre of voxel `v` in the grid's own frame.
    pub fn local_centre(&self, v: u32) -> Vec3 {
        let [x, y, z] = morton::decode(v);
        let s = self.origin[3];
        Vec3::new(self.origin[0], self.origin[1], self.origin[2])
            + Vec3::new(x as f32 + 0.5, y as f32 + 0.5, z as f32 + 0.5) * s
    }

    /// Centre of voxel `v` in the world (the kernel's order: one dot per row plus its offset).
    pub fn centre(&self, v: u32) -> Vec3 {
        let c = self.local_centre(v);
        let row = |r: [f32; 4]| Vec3::new(r[0], r[1], r[2]).dot(c) + r[3];
        Vec3::new(row(self.model[0]), row(self.model[1]), row(self.model[2]))
    }

    /// A grid-frame normal in the world (not normalised).
    pub fn world_normal(&self, m: Vec3) -> Vec3 {
        let row = |r: [f32; 4]| Vec3::new(r[0], r[1], r[2]).dot(m);
        Vec3::new(
            row(self.normal_model[0]),
            row(self.normal_model[1]),
            row(self.normal_model[2]),
        )
    }
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// Radiance (pre-multiplied, alpha) of voxel `v` and its bound |GPU - mirror| (per channel; alpha
/// exact). Bound per light term: 64 ULP of the term plus 8 ULP absolute on the cosine times the term's
/// scale (as in `direct_light`), and `direct_light::incident_error` with the centre's rounding (a spot's
/// factor near its soft edge; the distance and direction from a centre far from the origin); a term
/// whose shadow ray passes within 1e-4 barycentric of an occluder's edge (or ends within 1e-5 of one)
/// adds its value — rounding decides it.
#[allow(clippy::too_many_arguments)]
pub fn light_voxel(
    grid: &VoxelGrid,
    nodes: &[GpuNode],
    tris: &[GpuTriangle],
    lights: &[GpuLight],
    colour: [f32; 4],
    normal: [f32; 4],
    v: u32,
) -> ([f32; 4], [f32; 4]) {
    let alpha = colour[3];
    let albedo = v3(colour);
    let m = grid.world_normal(v3(normal));
    let len = m.dot(m).sqrt();
    let c = grid.centre(v);
    let s = grid.world[0];
    let u = f32::EPSILON;
    // The centre `origin + (xyz + 0.5) s` may be fused on the GPU: up to one ULP of its largest
    // coordinate from the mirror's (seen on an H100 with the grid 1000 units from the origin).
    let mut dp = 2.0 * u * c.abs().max_element();
    // A placed grid: each world coordinate is a 3-term dot plus an offset (any order, fused or not:
    // 4 roundings of the terms' magnitudes), after the local centre's own rounding carried through the
    // rows; the normal's rows the same, which moves the cosine by up to 8 ULP more.
    let mut cos_extra = 0.0;
    if !grid.is_identity() {
        let cl = grid.local_centre(v).abs();
        let mag = grid
            .model
            .iter()
            .map(|r| Vec3::new(r[0].abs(), r[1].abs(), r[2].abs()).dot(cl) + r[3].abs())
            .fold(0.0f32, f32::max);
        let row_norm = grid
            .model
            .iter()
            .map(|r| r[0].abs() + r[1].abs() + r[2].abs())
            .fold(0.0f32, f32::max);
        dp += 4.0 * u * mag + 2.0 * u * row_norm * cl.max_element();
        cos_extra = 8.0 * u;
    }
    let mut sum = Vec3::ZERO;
    let mut bound = Vec3::ZERO;
    for light in lights {
        let inc = incident(light, c);
        let (e_irr, e_dir) = incident_error(light, c, dp);
        let (n, cos) = if len > 1e-3 {
            let n = m * (1.0 / len);
            (n, n.dot(inc.wi))
        } else {
            (inc.wi, 1.0)
        };
        if cos <= 0.0 || inc.irradiance == Vec3::ZERO {
            // Past a soft spot's edge the GPU's factor may be a small 3t^2 instead of 0; a cosine
            // within its error of 0 may be the GPU's small positive one (seen on an H100: a normal
            // exactly perpendicular to a directional light, cos 0 here, ~1e-9 there).
            let e_cos = e_dir + 8.0 * u + cos_extra;
            if cos > -e_cos {
                bound += albedo * (1.0 / PI) * (e_irr + inc.irradiance) * (cos.max(0.0) + e_cos);
            }
            continue;
        }
        let o = c + n * s;
        let t_max = crate::direct_light::shadow_end(inc.t_max, s);
        let term = albedo * (1.0 / PI) * inc.irradiance * cos;
        let wide = !all_hits(tris, o, inc.wi, -s * 0.01, t_max * (1.0 + 1e-5), 1e-4).is_empty();
        let narrow = !all_hits(tris, o, inc.wi, s * 0.01, t_max * (1.0 - 1e-5), -1e-4).is_empty();
        if !occluded(nodes, tris, o, inc.wi, 0.0, t_max) {
            sum += term;
        }
        if wide != narrow || inc.edge < 1e-5 {
            bound += term;
        }
        bound += term * (64.0 * u)
            + albedo * (1.0 / PI) * inc.irradiance * (8.0 * u + cos_extra)
            + albedo * (1.0 / PI) * (e_irr * (cos + e_dir) + inc.irradiance * e_dir);
    }
    (
        [sum.x * alpha, sum.y * alpha, sum.z * alpha, alpha],
        [bound.x, bound.y, bound.z, 0.0],
    )
}
