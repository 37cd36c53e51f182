//! Approximation error of mip alpha (DESIGN.md section 5, kind 2): how well a coarse voxel's alpha
//! predicts the fraction of axis-aligned rays through its block that a fine, full voxel stops.
use crate::grids::Grid;
use vxgi_cpu_mirror::morton;
use vxgi_cpu_mirror::surface_coverage_mip::{mip_chain, Coverage};

/// The truth alpha approximates: for the block of `2^level` fine voxels per side at coarse (cx, cy, cz),
/// the fraction of the 3 * (2^level)^2 axis-aligned rays (one per fine column, along x, y and z) that
/// meet at least one fine voxel with alpha >= 1.
pub fn ray_coverage(grid: &Grid, level: u32, c: [u32; 3]) -> f32 {
    let b = 1u32 << level;
    let origin = [c[0] * b, c[1] * b, c[2] * b];
    let mut hits = 0u32;
    for axis in 0..3 {
        let (u_axis, v_axis) = ((axis + 1) % 3, (axis + 2) % 3);
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
    }
    hits as f32 / (3 * b * b) as f32
}

/// Mean and max |alpha - ray coverage| over the non-empty blocks of one level.
#[derive(Clone, Copy, Debug, Default)]
pub struct CoverageError {
    pub level: u32,
    pub blocks: usize,
    pub mean: f32,
    pub max: f32,
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
            let mut sum = 0.0f64;
            for (m, c) in colour.iter().enumerate() {
                if c[3] <= 0.0 {
                    continue;
                }
                let err = (c[3] - ray_coverage(grid, level, morton::decode(m as u32))).abs();
                sum += err as f64;
                e.max = e.max.max(err);
                e.blocks += 1;
            }
            e.mean = if e.blocks > 0 {
                (sum / e.blocks as f64) as f32
            } else {
                0.0
            };
            e
        })
        .collect()
}
