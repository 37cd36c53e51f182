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

/// Grid placement (the WGSL `VoxelGrid`): origin.xyz + voxel size in origin.w; side, light count.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VoxelGrid {
    pub origin: [f32; 4],
    /// side, light count, 0, 0.
    pub size: [u32; 4],
}

impl VoxelGrid {
    pub fn centre(&self, v: u32) -> Vec3 {
        let [x, y, z] = morton::decode(v);
        let s = self.origin[3];
        Vec3::new(self.origin[0], self.origin[1], self.origin[2])
            + Vec3::new(x as f32 + 0.5, y as f32 + 0.5, z as f32 + 0.5) * s
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
    let m = v3(normal);
    let len = m.dot(m).sqrt();
    let c = grid.centre(v);
    let s = grid.origin[3];
    let u = f32::EPSILON;
    // The centre `origin + (xyz + 0.5) s` may be fused on the GPU: up to one ULP of its largest
    // coordinate from the mirror's (seen on an H100 with the grid 1000 units from the origin).
    let dp = 2.0 * u * c.abs().max_element();
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
            let e_cos = e_dir + 8.0 * u;
            if cos > -e_cos {
                bound += albedo * (1.0 / PI) * (e_irr + inc.irradiance) * (cos.max(0.0) + e_cos);
            }
            continue;
        }
        let o = c + n * s;
        let t_max = (inc.t_max - s).max(0.0);
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
            + albedo * (1.0 / PI) * inc.irradiance * (8.0 * u)
            + albedo * (1.0 / PI) * (e_irr * (cos + e_dir) + inc.irradiance * e_dir);
    }
    (
        [sum.x * alpha, sum.y * alpha, sum.z * alpha, alpha],
        [bound.x, bound.y, bound.z, 0.0],
    )
}
