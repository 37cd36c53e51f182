//! Mirror of `kernels/lrsm_partition.wgsl`: splitting an RSM into depth x <n.l> layers at quarter
//! resolution (LRSM section 4.3 and section 5, Table 1).
//!
//! The RSM (side `2s`, 2D Morton order, so RSM texels `4q .. 4q+4` form quad `q`) holds per texel:
//! `radiance = (rho Ld <n.l> / pi, coverage)` (coverage 1 where the light sees geometry, else 0),
//! `normal = (n, <n.l>)`, `depth = z` (light-space depth normalised to [0, 1]).
//! Layer `L = d * normal_slices + j` of depth slice `d` (range `[zmin_d, zmax_d]`, overlapping its
//! neighbours) and <n.l> slice `j = min(trunc(max(<n.l>, 0) * normal_slices), normal_slices - 1)`.
//! For each quad and layer, the member texels (covered, in slice j, zmin_d <= z <= zmax_d) are summed in
//! texel order and the sums scaled by 1/4, i.e. the opacity-weighted box average over the quad
//! ("texels are merged if they are assigned to the same layer"):
//! `radiance = (sum R, count) / 4`, `normal = (sum n, count) / 4`,
//! `moments = (sum z', sum z'^2, count, 0) / 4`, `z' = (z - zmin_d) * inv_range_d` (warped to [0, 1]),
//! each stored as binary16 ([`crate::lrsm_prefilter::quantize`]). With `area_weights` the radiance
//! and moment sums weigh each texel by `a = 1 / max(<n.l>, 1e-3)` (`sum a R`, `sum a`, `sum a z'`,
//! ...; 0 where <n.l> is not above 0); the normal's stay unweighted.
use crate::ftz4;
use glam::Vec4;
use rayon::prelude::*;

/// The kernel's uniform block (`struct PartitionParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PartitionParams {
    pub depth_slices: u32,
    pub normal_slices: u32,
    /// Texels per layer at LRSM level 0: (RSM side / 2)^2.
    pub layer_texels: u32,
    /// 1: each member texel weighs `1 / max(<n.l>, 1e-3)` in the radiance and moment streams
    /// (`lrsm_area_weights`): the area of lit surface it stands for per unit of the light's image,
    /// so that the filtered radiance, opacity and depth moments are area-weighted (the normal
    /// stream stays opacity-weighted); a texel whose stored <n.l> is not above 0 faces away from
    /// the light and weighs 0. 0: every member texel weighs 1.
    pub area_weights: u32,
}

/// The smallest `<n.l>` an area weight divides by: a texel lit at grazing stands for at most 1000
/// times its area in the light's image.
pub const MIN_COSINE: f32 = 1.0e-3;

/// `<n.l>` slice of a texel, as the kernel computes it.
pub fn normal_slice(ndotl: f32, normal_slices: u32) -> u32 {
    ((ndotl.max(0.0) * normal_slices as f32) as u32).min(normal_slices - 1)
}

/// One layer texel of one quad: (radiance, normal, moments).
pub fn quad_layer(
    rsm: (&[[f32; 4]], &[[f32; 4]], &[f32]),
    quad: usize,
    range: [f32; 4],
    slice: u32,
    normal_slices: u32,
    area_weights: bool,
    flush: bool,
) -> [[f32; 4]; 3] {
    let (rad, nrm, depth) = rsm;
    let (mut r, mut n, mut m) = (Vec4::ZERO, Vec4::ZERO, Vec4::ZERO);
    for t in 4 * quad..4 * quad + 4 {
        let z = crate::ftz(depth[t], flush);
        let member = rad[t][3] > 0.5
            && normal_slice(crate::ftz(nrm[t][3], flush), normal_slices) == slice
            && z >= range[0]
            && z <= range[1];
        if member {
            let zw = crate::ftz(crate::ftz(z - range[0], flush) * range[2], flush);
            let c = ftz4(Vec4::from(rad[t]), flush);
            let nv = ftz4(Vec4::from(nrm[t]), flush);
            let cos = crate::ftz(nrm[t][3], flush);
            let a = match (area_weights, cos > 0.0) {
                (false, _) => 1.0,
                // Facing away from the light (the RSM stores max(<n.l>, 0)): no lit surface.
                (true, false) => 0.0,
                (true, true) => crate::ftz(1.0 / cos.max(MIN_COSINE), flush),
            };
            r = ftz4(r + ftz4(Vec4::new(c.x, c.y, c.z, 1.0) * a, flush), flush);
            n = ftz4(n + Vec4::new(nv.x, nv.y, nv.z, 1.0), flush);
            m = ftz4(
                m + ftz4(
                    Vec4::new(zw, crate::ftz(zw * zw, flush), 1.0, 0.0) * a,
                    flush,
                ),
                flush,
            );
        }
    }
    // Stored as binary16 (lrsm_prefilter's storage).
    [r, n, m].map(|s| crate::lrsm_prefilter::quantize(ftz4(s * 0.25, flush).into()))
}

/// All layers of LRSM level 0: three streams of `layers * layer_texels` texels, layer-major.
pub fn partition(
    rsm: (&[[f32; 4]], &[[f32; 4]], &[f32]),
    depth_ranges: &[[f32; 4]],
    p: &PartitionParams,
    flush: bool,
) -> [Vec<[f32; 4]>; 3] {
    let layers = (p.depth_slices * p.normal_slices) as usize;
    let t = p.layer_texels as usize;
    let texels: Vec<[[f32; 4]; 3]> = (0..layers * t)
        .into_par_iter()
        .with_min_len(4096)
        .map(|i| {
            let (layer, quad) = (i / t, i % t);
            let (d, j) = (
                layer as u32 / p.normal_slices,
                layer as u32 % p.normal_slices,
            );
            quad_layer(
                rsm,
                quad,
                depth_ranges[d as usize],
                j,
                p.normal_slices,
                p.area_weights != 0,
                flush,
            )
        })
        .collect();
    [0, 1, 2].map(|s| texels.iter().map(|x| x[s]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where every texel has <n.l> = 1/2, area weights double the radiance and moment streams (a
    /// power of two: exact, in binary16 too) and leave the normal stream as it is.
    #[test]
    fn area_weights_of_equal_cosines_scale_radiance_and_moments() {
        let side = 8usize;
        let rad: Vec<[f32; 4]> = (0..side * side)
            .map(|i| [0.1 * (i % 7) as f32, 0.5, 0.25, (i % 5 != 0) as u32 as f32])
            .collect();
        let nrm: Vec<[f32; 4]> = (0..side * side).map(|_| [0.6, 0.0, 0.8, 0.5]).collect();
        let depth: Vec<f32> = (0..side * side).map(|i| (i % 11) as f32 / 11.0).collect();
        let ranges = [
            [-0.05, 0.525, 1.0 / 0.575, 0.0],
            [0.475, 1.05, 1.0 / 0.575, 0.0],
        ];
        let p = |area_weights| PartitionParams {
            depth_slices: 2,
            normal_slices: 2,
            layer_texels: (side * side / 4) as u32,
            area_weights,
        };
        let plain = partition((&rad, &nrm, &depth), &ranges, &p(0), false);
        let area = partition((&rad, &nrm, &depth), &ranges, &p(1), false);
        for s in [0, 2] {
            for (a, b) in plain[s].iter().zip(&area[s]) {
                assert_eq!(a.map(|v| 2.0 * v), *b);
            }
        }
        assert_eq!(plain[1], area[1]);
        assert!(plain[0].iter().any(|t| t[3] > 0.0));
        // Facing away from the light (<n.l> stored as 0 or below): no lit surface, weight 0.
        for c in [0.0, -0.2] {
            let away: Vec<[f32; 4]> = nrm.iter().map(|n| [n[0], n[1], n[2], c]).collect();
            let area = partition((&rad, &away, &depth), &ranges, &p(1), false);
            for s in [0, 2] {
                assert!(area[s].iter().all(|t| *t == [0.0; 4]));
            }
        }
    }
}
