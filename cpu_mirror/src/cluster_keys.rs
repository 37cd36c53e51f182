//! Mirror of `kernels/cluster_keys.wgsl`: each pixel's cluster key from its tile, the tile axis its
//! normal is best aligned with, and its depth slice (CPRC 3.2; depth slicing as clustered shading does).
//! Integer and comparison-only arithmetic: exact.
//!
//! `key = (tile * 3 + axis) * slices + slice`; background pixels get [`BACKGROUND`] (sorted last).
//! axis = argmax over k of the integer dot product of the snorm16 normal and the tile's axis k
//! (bin-centre directions quantised to snorm10), lowest k on ties; slice = number of slice bounds
//! <= depth.
use crate::octahedral::{bin_direction, unpack, BIN_COUNT};

pub const BACKGROUND: u32 = u32::MAX;

/// The kernel's uniform block (`struct KeyParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct KeyParams {
    pub width: u32,
    pub height: u32,
    pub tile: u32,
    pub tiles_x: u32,
    pub slices: u32,
    pub _pad: [u32; 3],
}

/// Bin-centre directions quantised to snorm10 (integers for exact dot products with snorm16 normals:
/// |sum| <= 3 * 32767 * 511 fits i32).
pub fn axis_directions() -> Vec<[i32; 4]> {
    (0..BIN_COUNT)
        .map(|b| {
            let d = bin_direction(b);
            [
                (d[0] * 511.0).round() as i32,
                (d[1] * 511.0).round() as i32,
                (d[2] * 511.0).round() as i32,
                0,
            ]
        })
        .collect()
}

/// `slices - 1` ascending bounds of exponential depth slices between `near` and `far`.
pub fn slice_bounds(near: f32, far: f32, slices: u32) -> Vec<f32> {
    let (n, f) = (near as f64, far as f64);
    (1..slices)
        .map(|i| (n * (f / n).powf(i as f64 / slices as f64)) as f32)
        .collect()
}

/// What the kernel reads besides its parameters.
pub struct KeyInputs<'a> {
    pub normals: &'a [[u32; 2]],
    pub depth: &'a [f32],
    pub tile_axes: &'a [[u32; 4]],
    pub axis_dirs: &'a [[i32; 4]],
    pub slice_bounds: &'a [f32],
}

/// The key of pixel (x, y).
pub fn key(p: &KeyParams, inp: &KeyInputs, x: u32, y: u32) -> u32 {
    let i = (y * p.width + x) as usize;
    let Some(q) = unpack(inp.normals[i]) else {
        return BACKGROUND;
    };
    let tile = (y / p.tile) * p.tiles_x + x / p.tile;
    let axes = inp.tile_axes[tile as usize];
    let mut best = 0u32;
    let mut best_dot = i32::MIN;
    for (k, &axis) in axes.iter().take(3).enumerate() {
        let a = inp.axis_dirs[axis as usize];
        let d = q[0] * a[0] + q[1] * a[1] + q[2] * a[2];
        if d > best_dot {
            best_dot = d;
            best = k as u32;
        }
    }
    let depth = inp.depth[i];
    let slice = inp.slice_bounds[..p.slices as usize - 1]
        .iter()
        .filter(|&&b| depth >= b)
        .count() as u32;
    (tile * 3 + best) * p.slices + slice
}

/// Keys of every pixel, row-major.
pub fn keys(p: &KeyParams, inp: &KeyInputs) -> Vec<u32> {
    (0..p.height)
        .flat_map(|y| (0..p.width).map(move |x| (x, y)))
        .map(|(x, y)| key(p, inp, x, y))
        .collect()
}
