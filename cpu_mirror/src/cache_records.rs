//! Mirror of `kernels/cache_records.wgsl`: the radiance caches' records from the clusters and the
//! pixels cache_placement picked (Rehfeld et al. 2014, 3.2: one cache per cluster), and the indirect
//! dispatch arguments of the stages that run per cache texel, so that cache creation,
//! pre-convolution and the gather follow the distribution on the GPU without the host.
//!
//! `count = min(cluster_count, capacity)` caches (the clusters past the capacity get none, and
//! `cache_args[1]` counts them). Cache `c`, at pixel `p = picks[c]` (`x = p % width`, `y = p / width`):
//! - `cache_pos[c] = (position of p, r_w)`, `r_w = max(1.5 |bbox_max - bbox_min|, 1e-3)` (every pixel
//!   of the cluster lies within the box's diagonal of the cache, which is one of them);
//! - `cache_pixel[c] = (x, y)`;
//! - `cache_normal[c] = (normalize(q), 0)`, `q` the pixel's snorm16 normal (`(0, 0, 1)` on background);
//! - `caches[2c] = (position + normal * offset, 0)`, `caches[2c + 1] = (normal, 0)`: what
//!   cache_creation marches from;
//! - `tile_ranges[t] = [first, last + 1)` of the caches of screen tile `t` (the pick's tile): cache `c`
//!   starts its tile's range where cache `c - 1` lies in another tile and ends it where `c + 1` does.
//!   Clusters come tile-major (the keys start with the tile), so each tile's caches are one range.
//!   Tiles without caches keep what the buffer held (0: the caller clears it).
//! - `cache_count[0] = count`; `cache_args = [count, clusters - count, 0, 0]` then, per stage with `per`
//!   invocations per cache (creation: texels; mips: the chain's texels, 0 without glossy pixels;
//!   irradiance: the map's texels), the workgroups `(x, y, 1)` of 64 covering `count * per`
//!   invocations, `x <= max_groups` (the kernels index `gid.x + gid.y * groups.x * 64`), and a pad.
use crate::cluster_extract::Cluster;
use crate::octahedral::unpack;
use glam::Vec3;

const U: f32 = f32::EPSILON / 2.0;

/// The kernel's uniform block (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RecordsParams {
    pub width: u32,
    pub tile: u32,
    pub tiles_x: u32,
    pub capacity: u32,
    /// Invocations per cache of cache_creation, cache_preconvolve's `mips` and its `irradiance`.
    pub per: [u32; 3],
    pub max_groups: u32,
    /// How far along its normal a cache's cones start (offset_voxels * the finest voxel).
    pub offset: f32,
    pub _pad: [u32; 3],
}

/// Elements of `cache_args`: the header and three stages' (x, y, z, pad).
pub const ARGS_LEN: usize = 16;

/// Byte offset in `cache_args` of stage `k`'s indirect arguments (0 creation, 1 mips, 2 irradiance).
pub const fn args_offset(k: usize) -> u64 {
    16 * (k as u64 + 1)
}

/// Every output, by binding.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Records {
    pub cache_pos: Vec<[f32; 4]>,
    pub cache_pixel: Vec<[u32; 2]>,
    pub cache_normal: Vec<[f32; 4]>,
    pub caches: Vec<[f32; 4]>,
    pub tile_ranges: Vec<[u32; 2]>,
    pub count: u32,
    pub args: [u32; ARGS_LEN],
}

/// The workgroups of 64 covering `n` invocations, at most `max` in x.
pub fn groups(n: u32, max: u32) -> [u32; 3] {
    let g = n.div_ceil(64);
    let x = g.min(max);
    let y = if x > 0 { g.div_ceil(x) } else { 0 };
    [x, y, 1]
}

fn tile_of(p: &RecordsParams, pixel: u32) -> usize {
    let (x, y) = (pixel % p.width, pixel / p.width);
    ((y / p.tile) * p.tiles_x + x / p.tile) as usize
}

/// The normal of a cache at a pixel with packed normal `w`.
pub fn cache_normal(w: [u32; 2]) -> Vec3 {
    let q = unpack(w).unwrap_or([0, 0, 32767]);
    let v = Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32);
    v / v.dot(v).sqrt()
}

/// The kernel's outputs; `tile_ranges` starts as `ranges` (what the buffer held).
pub fn records(
    p: &RecordsParams,
    clusters: &[Cluster],
    cluster_count: u32,
    picks: &[u32],
    normals: &[[u32; 2]],
    positions: &[[f32; 4]],
    ranges: &[[u32; 2]],
) -> Records {
    let count = cluster_count.min(p.capacity);
    let mut r = Records {
        tile_ranges: ranges.to_vec(),
        count,
        ..Default::default()
    };
    for c in 0..count as usize {
        let px = picks[c];
        let cl = &clusters[c];
        let d = Vec3::from_slice(&cl.bbox_max[..3]) - Vec3::from_slice(&cl.bbox_min[..3]);
        let rw = (1.5 * d.dot(d).sqrt()).max(1.0e-3);
        let wp = positions[px as usize];
        let n = cache_normal(normals[px as usize]);
        let o = Vec3::from_slice(&wp[..3]) + n * p.offset;
        r.cache_pos.push([wp[0], wp[1], wp[2], rw]);
        r.cache_pixel.push([px % p.width, px / p.width]);
        r.cache_normal.push([n.x, n.y, n.z, 0.0]);
        r.caches
            .extend([[o.x, o.y, o.z, 0.0], [n.x, n.y, n.z, 0.0]]);
        let t = tile_of(p, px);
        if c == 0 || tile_of(p, picks[c - 1]) != t {
            r.tile_ranges[t][0] = c as u32;
        }
        if c + 1 == count as usize || tile_of(p, picks[c + 1]) != t {
            r.tile_ranges[t][1] = c as u32 + 1;
        }
    }
    r.args[0] = count;
    r.args[1] = cluster_count - count;
    for (k, &per) in p.per.iter().enumerate() {
        let [x, y, z] = groups(count * per, p.max_groups);
        r.args[4 * (k + 1)..4 * (k + 1) + 3].copy_from_slice(&[x, y, z]);
    }
    r
}

/// Bounds on |GPU - mirror| for cache `c`'s normal (each component), `r_w` and creation origin (each
/// component), from the WGSL rules. The normal: `v / sqrt(v . v)` of an exact integer vector: the
/// dot's 3 u, sqrt as 1 / inverseSqrt (2 + 2.5 ULP) and the division's 2.5 ULP: (1.5 + 9 + 5) u,
/// 16 u taken. r_w: three rounded differences, squares and sums (4 u), the same sqrt (9 u) and the
/// product (u), of r_w. The origin: the normal's error times |offset|, two roundings of |p| +
/// |offset|. All doubled.
pub fn bounds(p: &RecordsParams, cl: &Cluster, position: [f32; 4]) -> (f32, f32, [f32; 3]) {
    let n = 16.0 * U;
    let d = Vec3::from_slice(&cl.bbox_max[..3]) - Vec3::from_slice(&cl.bbox_min[..3]);
    let rw = 1.5 * d.dot(d).sqrt() * 14.0 * U;
    let off = p.offset.abs();
    let o = [0, 1, 2].map(|a| 2.0 * (n * off + 2.0 * U * (position[a].abs() + off)));
    (2.0 * n, 2.0 * rw, o)
}
