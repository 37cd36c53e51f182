//! Mirror of `kernels/triangle_setup.wgsl`: a mesh's triangles put on voxelize's integer lattice
//! ([`VoxTriangle`]), one invocation per triangle, so that voxelization runs on the GPU from the
//! mesh itself. Every step is exact in WGSL's arithmetic (correctly rounded subtraction and
//! multiplication, `round` half to even, integer arithmetic), so GPU and mirror agree bit for bit,
//! with or without subnormals flushed.
//!
//! Per triangle `(a, b, c, material)`:
//! - vertices: `q = clamp(round((p - origin) * scale), 0, side * 256 - 1)` per axis (`scale` = 256 /
//!   voxel size, given as an f32; lattice steps of 1/256 voxel);
//! - sample count `n = 2 k + 1`, `k` the smallest integer with `(256 k)^2 >= |e|^2` for the longest
//!   edge `e` in lattice steps (`ceil` of its length in voxels, in exact integer arithmetic: samples
//!   at most half a voxel apart);
//! - normals `round(n * 4096)` (clamped to +-2^30), the material's fixed-point albedo and texture;
//! - a textured material's (`texture.y = W > 0`) texture coordinates: per axis (u with W, -v with H;
//!   period `P = 16 W`), `q = clamp(round(u P), -2^30, 2^30)`, shifted by whole periods so that the
//!   smallest is in `[0, P)` (two's complement arithmetic: a triangle spanning more repeats than
//!   voxelize's 32-bit interpolation holds is refused at load, [`uv_range_fits`]).
//!
//! It also writes the indirect dispatch of voxelize's sampling passes: `[ceil(triangles / 64), max
//! n + 1, 1]` (a triangle per invocation on x, its rows on y).
use crate::voxelize::{VoxTriangle, FIXED, SUB};
use bytemuck::{Pod, Zeroable};

/// The kernel's parameters (the WGSL `SetupParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SetupParams {
    /// The grid's low corner (xyz) and lattice steps per world unit (w: 256 / voxel size).
    pub origin: [f32; 4],
    /// Voxels per grid side.
    pub side: u32,
    pub triangles: u32,
    pub _pad: [u32; 2],
}

/// A material as the setup reads it: fixed-point albedo (rgb) and the texture's place in the atlas
/// (first texel, W, H, 0; W = 0: untextured).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SetupMaterial {
    pub albedo: [u32; 4],
    pub texture: [u32; 4],
}

/// The largest magnitude a fixed-point normal or texture coordinate is clamped to before its
/// conversion to i32 (exact in f32).
pub const CLAMP: f32 = (1u32 << 30) as f32;

/// A vertex on the lattice: `clamp(round((p - origin) * scale), 0, side * 256 - 1)` per axis.
pub fn lattice(p: [f32; 4], params: &SetupParams) -> [i32; 3] {
    let max_q = (params.side as i32 * SUB - 1) as f32;
    let scale = params.origin[3];
    [0, 1, 2].map(|k| {
        ((p[k] - params.origin[k]) * scale)
            .round_ties_even()
            .clamp(0.0, max_q) as i32
    })
}

/// `ceil(sqrt(m))`: the smallest `k` with `k^2 >= m`.
pub fn ceil_sqrt(m: u32) -> u32 {
    let mut k = (m as f32).sqrt() as u32;
    while k * k < m {
        k += 1;
    }
    while k > 0 && (k - 1) * (k - 1) >= m {
        k -= 1;
    }
    k
}

/// `ceil(|b - a| / 256)` for lattice points `a`, `b` (an edge's length in voxels, rounded up), in
/// u32 arithmetic: each component `d = 256 h + l` squares to `65536 h^2 + 512 h l + l^2`, so
/// `|b - a|^2 = 65536 A + S` with `A = sum h^2` and `S = sum (512 h l + l^2)` (below 2^28 for
/// components below 2^17: the lattice of a 512^3 grid), and the edge needs `k^2 >= ceil(|b - a|^2 /
/// 65536) = A + ceil(S / 65536)`.
pub fn edge_voxels(a: [i32; 3], b: [i32; 3]) -> u32 {
    let (mut big, mut small) = (0u32, 0u32);
    for k in 0..3 {
        let d = a[k].abs_diff(b[k]);
        let (h, l) = (d >> 8, d & 255);
        big += h * h;
        small += 512 * h * l + l * l;
    }
    ceil_sqrt(big + (small >> 16) + u32::from(small & 0xffff != 0))
}

/// The sample count of a triangle with lattice vertices `p`: `2 k + 1` for its longest edge's `k`
/// voxels ([`edge_voxels`]).
pub fn sample_count(p: [[i32; 3]; 3]) -> i32 {
    let k = edge_voxels(p[0], p[1])
        .max(edge_voxels(p[1], p[2]))
        .max(edge_voxels(p[2], p[0]));
    2 * k as i32 + 1
}

/// A value in fixed point (x 4096), rounded half to even and clamped to +-[`CLAMP`].
pub fn fixed(v: f32) -> i32 {
    (v * FIXED).round_ties_even().clamp(-CLAMP, CLAMP) as i32
}

/// One axis of a triangle's texture coordinates in fixed point (1/16 texel of a texture `n` texels
/// wide), shifted by whole periods `16 n` so that the smallest is in `[0, 16 n)`.
pub fn fixed_uv_axis(c: [f32; 3], n: u32) -> [i32; 3] {
    let period = (n * 16) as i32;
    let q = c.map(|x| (x * period as f32).round_ties_even().clamp(-CLAMP, CLAMP) as i32);
    let lo = q[0].min(q[1]).min(q[2]);
    let shift = lo.div_euclid(period) * period;
    q.map(|x| x.wrapping_sub(shift))
}

/// Triangle `t` (`[a, b, c, material]`) of a mesh: its [`VoxTriangle`].
pub fn setup_triangle(
    params: &SetupParams,
    positions: &[[f32; 4]],
    normals: &[[f32; 4]],
    uvs: &[[f32; 2]],
    t: [u32; 4],
    materials: &[SetupMaterial],
) -> VoxTriangle {
    let v = [t[0], t[1], t[2]].map(|i| i as usize);
    let p = v.map(|i| lattice(positions[i], params));
    let n = sample_count(p);
    let nrm = v.map(|i| {
        let m = normals[i];
        [fixed(m[0]), fixed(m[1]), fixed(m[2]), 0]
    });
    let m = materials[(t[3] as usize).min(materials.len() - 1)];
    let (w, h) = (m.texture[1], m.texture[2]);
    let (uv_ab, uv_c) = if w == 0 || h == 0 {
        ([0; 4], [0; 4])
    } else {
        let u = fixed_uv_axis(v.map(|i| uvs[i][0]), w);
        let vv = fixed_uv_axis(v.map(|i| -uvs[i][1]), h);
        ([u[0], vv[0], u[1], vv[1]], [u[2], vv[2], 0, 0])
    };
    let w4 = |a: [i32; 3], w: i32| [a[0], a[1], a[2], w];
    VoxTriangle {
        a: w4(p[0], n),
        b: w4(p[1], 0),
        c: w4(p[2], 0),
        na: nrm[0],
        nb: nrm[1],
        nc: nrm[2],
        albedo: [m.albedo[0], m.albedo[1], m.albedo[2], 0],
        uv_ab,
        uv_c,
        texture: m.texture,
    }
}

/// The whole kernel: every triangle's [`VoxTriangle`] and voxelize's indirect dispatch
/// `[ceil(triangles / 64) (at least 1), max n + 1 (1 without triangles), 1]`.
pub fn setup(
    params: &SetupParams,
    positions: &[[f32; 4]],
    normals: &[[f32; 4]],
    uvs: &[[f32; 2]],
    triangles: &[[u32; 4]],
    materials: &[SetupMaterial],
) -> (Vec<VoxTriangle>, [u32; 3]) {
    let tris: Vec<VoxTriangle> = triangles
        .iter()
        .map(|&t| setup_triangle(params, positions, normals, uvs, t, materials))
        .collect();
    let dispatch = dispatch(&tris);
    (tris, dispatch)
}

/// voxelize's sampling dispatch over `tris`: a triangle per invocation on x (`ceil(n / 64)`, at
/// least 1), its rows on y (the largest sample count + 1, 1 without triangles).
pub fn dispatch(tris: &[VoxTriangle]) -> [u32; 3] {
    let rows = tris.iter().map(|t| t.a[3] as u32 + 1).max().unwrap_or(1);
    [(tris.len() as u32).div_ceil(64).max(1), rows, 1]
}

/// Whether voxelize's texture-coordinate interpolation of `t` stays in i32: `Us = Ua + ((Ub - Ua)
/// i + (Uc - Ua) j) / n` for `i + j <= n` needs `(|Ub - Ua| + |Uc - Ua|) n + |Ua| < 2^31 - 1`
/// (and the same for V). Untextured triangles always fit.
pub fn uv_range_fits(t: &VoxTriangle) -> bool {
    if t.texture[1] == 0 || t.texture[2] == 0 {
        return true;
    }
    let n = t.a[3] as i64;
    let fits = |a: i32, b: i32, c: i32| {
        let (a, b, c) = (a as i64, b as i64, c as i64);
        ((b - a).abs() + (c - a).abs()) * n + a.abs() < i32::MAX as i64
    };
    fits(t.uv_ab[0], t.uv_ab[2], t.uv_c[0]) && fits(t.uv_ab[1], t.uv_ab[3], t.uv_c[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ceil_sqrt_is_exact() {
        for m in (0..5000).chain([786_432, 786_433, 887 * 887, 887 * 887 + 1]) {
            let k = ceil_sqrt(m);
            assert!(k * k >= m && (k == 0 || (k - 1) * (k - 1) < m), "{m}: {k}");
        }
    }

    #[test]
    fn edges_round_their_length_in_voxels_up() {
        let o = [0, 0, 0];
        assert_eq!(edge_voxels(o, o), 0);
        assert_eq!(edge_voxels(o, [256, 0, 0]), 1);
        assert_eq!(edge_voxels(o, [257, 0, 0]), 2);
        // 3-4-5: exactly 5 voxels, then one lattice step more.
        assert_eq!(edge_voxels(o, [768, 1024, 0]), 5);
        assert_eq!(edge_voxels(o, [768, 1025, 0]), 6);
        // The far corner of a 512^3 grid: sqrt(3) 512 = 886.8 voxels.
        let m = 512 * 256 - 1;
        assert_eq!(edge_voxels(o, [m, m, m]), 887);
        // Against f64 on a sweep of edges.
        for i in 0..2000i32 {
            let b = [i * 37 % 131_071, i * 101 % 65_536, i * 7 % 3000];
            let d = ((b[0] as f64).powi(2) + (b[1] as f64).powi(2) + (b[2] as f64).powi(2)).sqrt();
            let k = edge_voxels(o, b) as f64;
            assert!(
                k * 256.0 >= d && (k - 1.0) * 256.0 < d,
                "{b:?}: {k} for {d}"
            );
        }
    }

    #[test]
    fn lattice_rounds_half_to_even_and_clamps_to_the_grid() {
        let params = SetupParams {
            origin: [0.0, 0.0, 0.0, 256.0],
            side: 8,
            ..Default::default()
        };
        assert_eq!(
            lattice([0.5 / 256.0, 1.5 / 256.0, -1.0, 1.0], &params),
            [0, 2, 0]
        );
        assert_eq!(lattice([100.0, 7.99, 0.0, 1.0], &params), [2047, 2045, 0]);
    }

    #[test]
    fn texture_coordinates_shift_by_whole_repeats() {
        // u in [10.25, 10.75] of a 4-texel texture: 1/16 texel units, period 64.
        let q = fixed_uv_axis([10.25, 10.5, 10.75], 4);
        assert_eq!(q, [16, 32, 48]);
        let q = fixed_uv_axis([-0.25, 0.0, 1.5], 4);
        assert_eq!(q, [48, 64, 160]);
    }

    #[test]
    fn the_dispatch_covers_every_triangles_rows() {
        let params = SetupParams {
            origin: [0.0, 0.0, 0.0, 256.0],
            side: 16,
            triangles: 2,
            _pad: [0; 2],
        };
        let pos = [
            [0.0, 0.0, 0.0, 1.0],
            [3.0, 0.0, 0.0, 1.0],
            [0.0, 4.0, 0.0, 1.0],
        ];
        let nrm = [[0.0, 0.0, 1.0, 0.0]; 3];
        let mats = [SetupMaterial::default()];
        let (tris, dispatch) = setup(
            &params,
            &pos,
            &nrm,
            &[[0.0; 2]; 3],
            &[[0, 1, 2, 0], [0, 0, 0, 0]],
            &mats,
        );
        // Longest edge 5 voxels: n = 11; the degenerate triangle one sample.
        assert_eq!((tris[0].a[3], tris[1].a[3]), (11, 1));
        assert_eq!(dispatch, [1, 12, 1]);
        assert_eq!(tris[0].na, [0, 0, 4096, 0]);
    }
}
