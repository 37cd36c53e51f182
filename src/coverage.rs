//! Approximation error of mip alpha (DESIGN.md section 5, kind 2): how well a coarse voxel's alpha
//! predicts the fraction of axis-aligned rays through its block that a fine, full voxel stops.
use crate::grids::Grid;
use vxgi_cpu_mirror::morton;
use vxgi_cpu_mirror::surface_coverage_mip::{mip_chain, Coverage};

/// The truth alpha approximates, per axis: for the block of `2^level` fine voxels per side at coarse
/// (cx, cy, cz), the fraction of the (2^level)^2 rays along x (then y, z), one per fine column, that
/// meet at least one fine voxel with alpha >= 1.
pub fn ray_coverage(grid: &Grid, level: u32, c: [u32; 3]) -> [f32; 3] {
    let b = 1u32 << level;
    let origin = [c[0] * b, c[1] * b, c[2] * b];
    let mut frac = [0.0f32; 3];
    for (axis, f) in frac.iter_mut().enumerate() {
        let (u_axis, v_axis) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut hits = 0u32;
        for u in 0..b {
            for v in 0..b {
                let hit = (0..b).any(|t| {
                    let mut p = origin;
                    p[axis] += t;
                    p[u_axis] += u;
                    p[v_axis] += v;
                    grid.alpha(p[0], p[1], p[2]) >= 1.0
                });
                hits += hit as u32;
            }
        }
        *f = hits as f32 / (b * b) as f32;
    }
    frac
}

/// |alpha - ray coverage| over the non-empty blocks of one level, against two readings of the truth:
/// `facing` = coverage along the axis that sees the most (the rays that cross the surface: what light
/// passing through a wall meets), `all_axes` = coverage averaged over the three axes (grazing rays
/// included, which no isotropic alpha can also get right: that is what VCT's anisotropic voxels are for).
#[derive(Clone, Copy, Debug, Default)]
pub struct CoverageError {
    pub level: u32,
    pub blocks: usize,
    pub facing_mean: f32,
    pub facing_max: f32,
    pub all_axes_mean: f32,
    pub all_axes_max: f32,
}

/// Per level (1..=log2 n) error of `coverage` alpha against [`ray_coverage`], over non-empty blocks.
pub fn coverage_error(grid: &Grid, coverage: Coverage) -> Vec<CoverageError> {
    let chain = mip_chain(&grid.colour, &grid.normal, coverage);
    chain
        .iter()
        .enumerate()
        .map(|(i, (colour, _))| {
            let level = i as u32 + 1;
            let mut e = CoverageError {
                level,
                ..Default::default()
            };
            let (mut facing, mut all) = (0.0f64, 0.0f64);
            for (m, c) in colour.iter().enumerate() {
                if c[3] <= 0.0 {
                    continue;
                }
                let f = ray_coverage(grid, level, morton::decode(m as u32));
                let ef = (c[3] - f[0].max(f[1]).max(f[2])).abs();
                let ea = (c[3] - (f[0] + f[1] + f[2]) / 3.0).abs();
                facing += ef as f64;
                all += ea as f64;
                e.facing_max = e.facing_max.max(ef);
                e.all_axes_max = e.all_axes_max.max(ea);
                e.blocks += 1;
            }
            if e.blocks > 0 {
                e.facing_mean = (facing / e.blocks as f64) as f32;
                e.all_axes_mean = (all / e.blocks as f64) as f32;
            }
            e
        })
        .collect()
}
