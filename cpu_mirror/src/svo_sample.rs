//! Mirror of `kernels/svo_sample.wgsl`: quadrilinear sampling of the sparse voxel octree (VCT 5: "we
//! use quadrilinear interpolation"): a point of the unit volume and a fractional level; per level, the
//! node holding the point is found by descending child pointers and its 3x3x3 brick is sampled
//! trilinearly (the point's half-node cell: 8 brick voxels); the two levels around the fractional level
//! are blended linearly. Brick values are u32 fixed point, read as `f32(v) * inv_scale`.
//!
//! A missing node reads as zero, which is exact: the octree's halo rule allocates every node holding a
//! non-zero lattice point, so all eight corners of a missing node's cells are zero. Sampling the octree
//! at an integer level therefore equals trilinear interpolation of the dense lattice of that level
//! (`sparse_voxel_octree::dense_reference`), tested in `tests/svo_sample.rs`.
//!
//! The position arithmetic is exact (scaling by a power of two, subtracting nearby integers: Sterbenz),
//! so GPU and mirror pick the same node, cell and weights; only the interpolation's roundings (and their
//! FMA contraction, which WGSL allows) differ.
use crate::sparse_voxel_octree::{find, Node, BRICK_WORDS, CHANNELS, NONE};

/// The kernel's uniform block (`struct SampleParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SampleParams {
    pub depth: u32,
    pub count: u32,
    /// 1 / the fixed-point scale of the brick values.
    pub inv_scale: f32,
    pub _pad: u32,
}

/// Trilinear sample of level `level` at unit-volume point `x` (clamped to [0, 1]).
pub fn sample_level(
    nodes: &[Node],
    bricks: &[u32],
    x: [f32; 3],
    level: u32,
    inv_scale: f32,
) -> [f32; 4] {
    let side = (2u32 << level) as f32; // lattice intervals across the volume: exact power of two
    let last = (1u32 << level) - 1;
    let mut c = [0u32; 3];
    let mut cell = [0u32; 3];
    let mut f = [0f32; 3];
    for a in 0..3 {
        let u = x[a].clamp(0.0, 1.0) * side; // exact
        c[a] = ((u * 0.5).floor() as u32).min(last);
        let local = u - 2.0 * c[a] as f32; // exact (Sterbenz), in [0, 2]
        cell[a] = (local.floor() as u32).min(1);
        f[a] = local - cell[a] as f32; // exact, in [0, 1]
    }
    let n = find(nodes, level, c);
    if n == NONE {
        return [0.0; 4];
    }
    let base = n as usize * BRICK_WORDS;
    let v = |i: u32, j: u32, k: u32, ch: usize| {
        let vi = (cell[0] + i) + 3 * (cell[1] + j) + 9 * (cell[2] + k);
        bricks[base + vi as usize * CHANNELS + ch] as f32 * inv_scale
    };
    let lerp = |a: f32, b: f32, t: f32| a * (1.0 - t) + b * t;
    let mut out = [0f32; 4];
    for (ch, o) in out.iter_mut().enumerate() {
        let x00 = lerp(v(0, 0, 0, ch), v(1, 0, 0, ch), f[0]);
        let x10 = lerp(v(0, 1, 0, ch), v(1, 1, 0, ch), f[0]);
        let x01 = lerp(v(0, 0, 1, ch), v(1, 0, 1, ch), f[0]);
        let x11 = lerp(v(0, 1, 1, ch), v(1, 1, 1, ch), f[0]);
        let y0 = lerp(x00, x10, f[1]);
        let y1 = lerp(x01, x11, f[1]);
        *o = lerp(y0, y1, f[2]);
    }
    out
}

/// Quadrilinear sample: query `q` = (x, y, z, level), level clamped to [0, depth]; levels floor(l) and
/// floor(l) + 1 blended by the fraction (a whole level samples one level only).
pub fn sample(nodes: &[Node], bricks: &[u32], p: &SampleParams, q: [f32; 4]) -> [f32; 4] {
    let l = q[3].clamp(0.0, p.depth as f32);
    let l0 = l.floor();
    let a = l - l0; // exact
    let x = [q[0], q[1], q[2]];
    let s0 = sample_level(nodes, bricks, x, l0 as u32, p.inv_scale);
    if a == 0.0 {
        return s0;
    }
    let s1 = sample_level(nodes, bricks, x, l0 as u32 + 1, p.inv_scale);
    [0, 1, 2, 3].map(|ch| s0[ch] * (1.0 - a) + s1[ch] * a)
}

/// Every query of a kernel run.
pub fn sample_all(
    nodes: &[Node],
    bricks: &[u32],
    p: &SampleParams,
    queries: &[[f32; 4]],
) -> Vec<[f32; 4]> {
    queries
        .iter()
        .map(|&q| sample(nodes, bricks, p, q))
        .collect()
}
