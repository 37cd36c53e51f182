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
use crate::cone_trace::{
    basis, level_offset, march, trilinear_level_moved, ConeParams, SampleError, Volume, MAG,
};
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
    pyr: &(impl Volume + ?Sized),
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

/// One pyramid of [`PlacedPyramids`] (the WGSL `Placed`): `to_local` = rows of grid-from-world (3x4),
/// `origin` = the grid's origin (xyz) and 1 / s0 (w), side / levels / first element in the shared
/// pyramid buffer, `shift[0]` = log2(the march's s0 / this grid's s0 in world units).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Placed {
    pub to_local: [[f32; 4]; 3],
    pub origin: [f32; 4],
    pub side_levels_base: [u32; 4],
    pub shift: [f32; 4],
}

impl Placed {
    /// A grid of `side` (origin xyz, voxel size s0 in its own units) stored from `base`, placed in the
    /// world by `world_from_grid` (rigid, uniform scale), marched with steps of `march_s0` (world).
    pub fn new(
        origin: [f32; 3],
        s0: f32,
        side: u32,
        base: u32,
        world_from_grid: glam::Mat4,
        march_s0: f32,
    ) -> Self {
        let r = world_from_grid.inverse().transpose().to_cols_array_2d();
        let scale = glam::Mat3::from_mat4(world_from_grid)
            .determinant()
            .abs()
            .cbrt();
        Self {
            to_local: [r[0], r[1], r[2]],
            origin: [origin[0], origin[1], origin[2], 1.0 / s0],
            side_levels_base: [side, side.trailing_zeros() + 1, base, 0],
            shift: [
                (march_s0 as f64 / (s0 as f64 * scale as f64)).log2() as f32,
                0.0,
                0.0,
                0.0,
            ],
        }
    }
}

/// Header words of [`placed_cells`]' layout before the cells' offsets.
pub const CELLS_HEADER: usize = 12;

/// Cells per axis [`placed_cells`] aims at for `hierarchies` hierarchies: about 4
/// cbrt(hierarchies) (6 for three hierarchies), at most 32.
pub fn cells_dims(hierarchies: usize) -> u32 {
    ((4.0 * (hierarchies.max(1) as f64).cbrt()).ceil() as u32).min(32)
}

/// Room for list entries in [`placed_cells`]' layout for `hierarchies` hierarchies: one hierarchy
/// in every cell of the aimed-at grid (a room around the instances) and 27 cells for each other.
/// Fixed by the count alone, so a frame whose instances moved keeps its buffer's size; a placement
/// that needs more entries gets a coarser grid.
pub fn cells_room(hierarchies: usize) -> usize {
    (cells_dims(hierarchies) as usize).pow(3) + 27 * hierarchies
}

/// Words of [`placed_cells`] for `hierarchies` hierarchies.
pub fn cells_words(hierarchies: usize) -> usize {
    CELLS_HEADER + (cells_dims(hierarchies) as usize).pow(3) + 1 + cells_room(hierarchies)
}

/// The most loop iterations one sample of [`placed_cells`]' layout `cells` takes in
/// kernels/common/placed_pyramids.wgsl: one per hierarchy its cell lists, in the cell of the layout
/// that lists the most (a sample past the grid takes none).
pub fn sample_iterations(cells: &[u32]) -> u32 {
    let n = (cells[0] as usize).pow(3);
    cells[CELLS_HEADER..=CELLS_HEADER + n]
        .windows(2)
        .map(|w| w[1] - w[0])
        .max()
        .unwrap_or(0)
}

/// The world box outside which hierarchy `h` adds exactly zero to any sample: its grid's local box
/// grown by half its top level's voxel (trilinear reaches half a voxel past a level's last centre; no
/// coarser level exists, finer ones reach less) and one level-0 voxel more (the kernel's local point
/// carries rounding far below a voxel), taken into the world (corners through the inverse of
/// `to_local`, in f64) and grown by a relative margin for the kernel's rounding of world points.
pub fn influence_box(h: &Placed) -> ([f64; 3], [f64; 3]) {
    let [side, _, _, _] = h.side_levels_base;
    let s0 = 1.0 / h.origin[3] as f64;
    let extent = side as f64 * s0;
    let reach = 0.5 * extent + s0;
    let lo = [0, 1, 2].map(|k| h.origin[k] as f64 - reach);
    let hi = [0, 1, 2].map(|k| h.origin[k] as f64 + extent + reach);
    let r = glam::DMat3::from_cols_array_2d(
        &[0, 1, 2].map(|c| [0, 1, 2].map(|row| h.to_local[row][c] as f64)),
    );
    let t = glam::DVec3::new(
        h.to_local[0][3] as f64,
        h.to_local[1][3] as f64,
        h.to_local[2][3] as f64,
    );
    let inv = r.inverse();
    let (mut wlo, mut whi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for corner in 0..8 {
        let local = glam::DVec3::new(
            if corner & 1 == 0 { lo[0] } else { hi[0] },
            if corner & 2 == 0 { lo[1] } else { hi[1] },
            if corner & 4 == 0 { lo[2] } else { hi[2] },
        );
        let w = inv * (local - t);
        for k in 0..3 {
            wlo[k] = wlo[k].min(w[k]);
            whi[k] = whi[k].max(w[k]);
        }
    }
    let margin = 1e-4 * (0..3).fold(0.0f64, |m, k| m.max(wlo[k].abs()).max(whi[k].abs()));
    (wlo.map(|v| v - margin), whi.map(|v| v + margin))
}

/// Which hierarchies may add to a sample in each cell of a world grid over their influence boxes
/// (kernels/common/placed_pyramids.wgsl's `placed_cells`), [`cells_words`] long: words 0..4 =
/// (cells per axis D, list entries, 0, 0); 4..8 = the grid's low corner (f32 bits, then 0); 8..12 =
/// cells per world unit along each axis (f32 bits, then 0); then D^3 + 1 offsets, cell `x + D (y +
/// D z)` listing entries `offsets[cell]..offsets[cell + 1]`; then the entries, each a hierarchy k
/// whose [`influence_box`] meets the cell (grown by a hundredth of a cell, for the kernel's rounding
/// of the cell index), ascending within a cell. D is [`cells_dims`], or less where the entries
/// would pass [`cells_room`]. A sample reads only its cell's hierarchies, in ascending order; the
/// others add exactly zero (radiance + 0, keep x 1), so the result is the loop over every
/// hierarchy's, bit for bit. A point outside the grid is outside every influence box.
pub fn placed_cells(placed: &[Placed]) -> Vec<u32> {
    let boxes: Vec<_> = placed.iter().map(influence_box).collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for (blo, bhi) in &boxes {
        for k in 0..3 {
            lo[k] = lo[k].min(blo[k]);
            hi[k] = hi[k].max(bhi[k]);
        }
    }
    if placed.is_empty() {
        (lo, hi) = ([0.0; 3], [1.0; 3]);
    }
    let room = cells_room(placed.len());
    let mut dims = cells_dims(placed.len());
    loop {
        let d = dims as f64;
        let size = [0, 1, 2].map(|k| (hi[k] - lo[k]).max(1e-6) / d);
        // Each box's cells, grown by a hundredth of a cell.
        let ranges: Vec<[std::ops::RangeInclusive<u32>; 3]> = boxes
            .iter()
            .map(|(blo, bhi)| {
                [0, 1, 2].map(|k| {
                    let a = ((blo[k] - lo[k]) / size[k] - 0.01).floor().max(0.0) as u32;
                    let b = ((bhi[k] - lo[k]) / size[k] + 0.01).floor().min(d - 1.0) as u32;
                    a..=b
                })
            })
            .collect();
        let entries: usize = ranges
            .iter()
            .map(|r| r.iter().map(|a| a.clone().count()).product::<usize>())
            .sum();
        if entries > room && dims > 1 {
            dims -= 1;
            continue;
        }
        let n = (dims as usize).pow(3);
        let mut count = vec![0u32; n + 1];
        let cells_of = |r: &[std::ops::RangeInclusive<u32>; 3]| {
            let [rx, ry, rz] = r.clone();
            rz.flat_map(move |z| {
                let rx = rx.clone();
                ry.clone().flat_map(move |y| {
                    rx.clone()
                        .map(move |x| (x + dims * (y + dims * z)) as usize)
                })
            })
        };
        for r in &ranges {
            for cell in cells_of(r) {
                count[cell + 1] += 1;
            }
        }
        for c in 0..n {
            count[c + 1] += count[c];
        }
        let mut out = vec![0u32; cells_words(placed.len())];
        out[0] = dims;
        out[1] = entries as u32;
        for k in 0..3 {
            out[4 + k] = (lo[k] as f32).to_bits();
            out[8 + k] = ((1.0 / size[k]) as f32).to_bits();
        }
        out[CELLS_HEADER..=CELLS_HEADER + n].copy_from_slice(&count);
        let first = CELLS_HEADER + n + 1;
        let mut next = count;
        for (h, r) in ranges.iter().enumerate() {
            for cell in cells_of(r) {
                out[first + next[cell] as usize] = h as u32;
                next[cell] += 1;
            }
        }
        return out;
    }
}

/// The hierarchies `cells` ([`placed_cells`]) lists for world point `x`, as the kernel finds its cell.
pub fn cell_hierarchies(cells: &[u32], x: Vec3) -> Vec<usize> {
    let dims = cells[0];
    let f = |w: usize| f32::from_bits(cells[w]);
    let o = Vec3::new(f(4), f(5), f(6));
    let inv = Vec3::new(f(8), f(9), f(10));
    let q = ((x - o) * inv).floor();
    if q.min_element() < 0.0 || q.max_element() >= dims as f32 {
        return Vec::new();
    }
    let cell = (q.x as u32 + dims * (q.y as u32 + dims * q.z as u32)) as usize;
    let first = CELLS_HEADER + (dims as usize).pow(3) + 1;
    let (a, b) = (cells[CELLS_HEADER + cell], cells[CELLS_HEADER + cell + 1]);
    cells[first + a as usize..first + b as usize]
        .iter()
        .map(|&k| k as usize)
        .collect()
}

/// Several pyramids placed in the world by rigid transforms, as one [`Volume`] (the mirror of
/// kernels/common/placed_pyramids.wgsl): a world point reads every hierarchy at its local point
/// (quadrilinear at the march's level plus the hierarchy's shift, clamped to its levels) and the
/// samples combine as alpha 1 - prod(1 - a_h), premultiplied radiance sum c_h. `p` is the march's
/// (its grid covers all hierarchies); `voxels` holds every pyramid (`Placed::side_levels_base.z`).
pub struct PlacedPyramids<'a> {
    pub p: &'a ConeParams,
    pub placed: &'a [Placed],
    pub voxels: &'a [[f32; 4]],
}

impl PlacedPyramids<'_> {
    fn one(&self, h: &Placed, xw: Vec3, lf_in: f32) -> (glam::Vec4, SampleError) {
        let row = |r: [f32; 4]| Vec3::new(r[0], r[1], r[2]).dot(xw) + r[3];
        let x = Vec3::new(row(h.to_local[0]), row(h.to_local[1]), row(h.to_local[2]));
        // The local point's rounding beyond the sampler's own: each coordinate is a 3-term dot plus
        // an offset (any order, fused or not): 4 ULP of the terms' magnitudes, doubled.
        let mag = h
            .to_local
            .iter()
            .map(|r| Vec3::new(r[0].abs(), r[1].abs(), r[2].abs()).dot(xw.abs()) + r[3].abs())
            .fold(0.0f32, f32::max);
        let dx = 8.0 * f32::EPSILON * mag;
        let [side, levels, base, _] = h.side_levels_base;
        let hp = ConeParams {
            origin: [h.origin[0], h.origin[1], h.origin[2], 1.0 / h.origin[3]],
            inv_s0: h.origin[3],
            side,
            levels,
            ..*self.p
        };
        let level = |l: u32| {
            let off = base as usize + level_offset(side, l);
            trilinear_level_moved(&hp, x, l, dx, |m| {
                glam::Vec4::from_array(self.voxels[off + m])
            })
        };
        crate::cone_trace::quadrilinear(levels - 1, lf_in + h.shift[0], level)
    }

    fn combined(&self, x: Vec3, lf: f32) -> (glam::Vec4, SampleError) {
        let mut c = Vec3::ZERO;
        let mut keep = 1.0f32;
        let mut err = SampleError::default();
        for h in self.placed {
            let (s, e) = self.one(h, x, lf);
            c += s.truncate();
            keep *= 1.0 - s.w.clamp(0.0, 1.0);
            // alpha's error through 1 - prod(1 - a): at most the sum of the parts' (each factor <= 1),
            // plus a rounding per factor; radiance adds.
            err.rgb += e.rgb + 4.0 * f32::EPSILON * s.truncate().abs().max_element();
            err.a += e.a + 4.0 * f32::EPSILON;
        }
        (c.extend(1.0 - keep), err)
    }
}

impl Volume for PlacedPyramids<'_> {
    fn params(&self) -> &ConeParams {
        self.p
    }

    fn level(&self, x: Vec3, l: u32) -> (glam::Vec4, SampleError) {
        self.combined(x, l as f32)
    }

    fn sample(&self, x: Vec3, lf: f32) -> (glam::Vec4, SampleError) {
        self.combined(x, lf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sample_iterates_its_cells_listed_hierarchies() {
        // Two cells per axis: eight cells, the first listing hierarchy 3, the second 0, 33 and 40.
        let mut cells = vec![0u32; CELLS_HEADER + 9 + 4];
        cells[0] = 2;
        cells[1] = 4;
        let offsets = [0, 1, 4, 4, 4, 4, 4, 4, 4];
        cells[CELLS_HEADER..CELLS_HEADER + 9].copy_from_slice(&offsets);
        cells[CELLS_HEADER + 9..].copy_from_slice(&[3, 0, 33, 40]);
        assert_eq!(sample_iterations(&cells), 3);
    }

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

    /// Every hierarchy that adds anything at a point is among its cell's (`placed_cells`): placements
    /// rotated, scaled and spread apart, pyramids solid at every level, points all over and just
    /// outside the influence boxes, at every level.
    #[test]
    fn the_cells_list_every_hierarchy_that_adds_to_a_sample() {
        let mut state = 0x853c_49e6_748f_ea9bu64;
        let mut rand = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut placed = Vec::new();
        let mut voxels = Vec::new();
        for k in 0..70u32 {
            let side = 8u32 << (k % 3);
            let base = voxels.len() as u32;
            let levels = side.trailing_zeros() + 1;
            voxels.extend(std::iter::repeat_n([1.0f32; 4], level_offset(side, levels)));
            let rot = glam::Quat::from_euler(
                glam::EulerRot::YXZ,
                rand() as f32 * 6.3,
                rand() as f32 * 6.3,
                0.0,
            );
            let world = glam::Mat4::from_scale_rotation_translation(
                glam::Vec3::splat(0.05 + rand() as f32 * 0.2),
                rot,
                glam::Vec3::new(
                    rand() as f32 * 4.0 - 2.0,
                    rand() as f32,
                    rand() as f32 * 4.0 - 2.0,
                ),
            );
            let s0 = 1.0 / side as f32;
            placed.push(Placed::new([0.0; 3], s0, side, base, world, 0.01));
        }
        let cells = placed_cells(&placed);
        assert_eq!(cells.len(), cells_words(placed.len()));
        let p = ConeParams {
            origin: [-3.0, -1.0, -3.0, 0.01],
            inv_s0: 100.0,
            side: 512,
            levels: 10,
            ..ConeParams::default()
        };
        let vol = PlacedPyramids {
            p: &p,
            placed: &placed,
            voxels: &voxels,
        };
        let mut listed = 0;
        for _ in 0..20000 {
            let x = Vec3::new(
                rand() as f32 * 6.0 - 3.0,
                rand() as f32 * 2.0 - 0.5,
                rand() as f32 * 6.0 - 3.0,
            );
            let near = cell_hierarchies(&cells, x);
            listed += near.len();
            for lf in [0.0f32, 1.5, 3.0, 9.0] {
                for (k, h) in placed.iter().enumerate() {
                    let (s, _) = vol.one(h, x, lf);
                    if s != glam::Vec4::ZERO {
                        assert!(
                            near.contains(&k),
                            "hierarchy {k} adds {s} at {x} (lf {lf}), not listed"
                        );
                    }
                }
            }
        }
        // The lists are short: a point's cell holds a few of the 70.
        assert!(listed < 20000 * 10, "{listed}");
    }
}
