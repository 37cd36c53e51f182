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
//! each stored as binary16 ([`crate::lrsm_prefilter::quantize`]).
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
    pub _pad: u32,
}

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
            r = ftz4(r + Vec4::new(c.x, c.y, c.z, 1.0), flush);
            n = ftz4(n + Vec4::new(nv.x, nv.y, nv.z, 1.0), flush);
            m = ftz4(
                m + Vec4::new(zw, crate::ftz(zw * zw, flush), 1.0, 0.0),
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
                flush,
            )
        })
        .collect();
    [0, 1, 2].map(|s| texels.iter().map(|x| x[s]).collect())
}
