//! Mirror of `kernels/cache_placement.wgsl`: the placement score of every clustered pixel and, per
//! cluster, the pixel that becomes its radiance cache (CPRC 3.2).
//!
//! With the cluster's normal `n_c = normalize(sum of snorm16 normals)`, box centre
//! `c = (bbox_min + bbox_max) * 0.5`, the pixel's normal `n_p = q / 32767` and position `p`:
//! `score = (n_p . n_c + (p - c) . n_c) / (1 + d_c)`, `d_c = |(p - c) - ((p - c) . n_c) n_c|` (distance
//! of p to the line through c along n_c). The cache is the argmax pixel, lowest pixel index on ties
//! (pixels of a cluster are visited in sorted order, which is increasing pixel index).
use crate::cluster_extract::Cluster;
use crate::octahedral::unpack;
use glam::Vec3;

/// n_c of a cluster, as the kernel computes it (`normalize` of the integer sum converted to f32).
pub fn cluster_normal(cl: &Cluster) -> Vec3 {
    let s = Vec3::new(
        cl.normal_sum[0] as f32,
        cl.normal_sum[1] as f32,
        cl.normal_sum[2] as f32,
    );
    let l2 = s.dot(s);
    if l2 > 0.0 {
        s * (1.0 / l2.sqrt())
    } else {
        Vec3::Z
    }
}

/// Inputs of the score: the pixel's packed normal and position, its cluster.
pub fn score(normal: [u32; 2], position: [f32; 4], cl: &Cluster) -> f32 {
    let q = unpack(normal).unwrap_or([0, 0, 0]);
    let np = Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32) * (1.0 / 32767.0);
    let nc = cluster_normal(cl);
    let c = (Vec3::from_slice(&cl.bbox_min[..3]) + Vec3::from_slice(&cl.bbox_max[..3])) * 0.5;
    let pc = Vec3::from_slice(&position[..3]) - c;
    let along = pc.dot(nc);
    let dc = (pc - nc * along).length();
    (np.dot(nc) + along) / (1.0 + dc)
}

/// A bound on |GPU - mirror| for [`score`] from the WGSL rules: sqrt/inverseSqrt and division (2.5 ULP
/// each), dot products in any order, fused or not (a few ULP of the sum of |terms|), the centre's
/// halving (exact) and difference (0.5 ULP of |p| + |c|): 24 ULP of the magnitudes involved, doubled.
pub fn score_bound(position: [f32; 4], cl: &Cluster, s: f32) -> f32 {
    let u = f32::EPSILON / 2.0;
    let mag: f32 = (0..3)
        .map(|a| position[a].abs() + cl.bbox_min[a].abs().max(cl.bbox_max[a].abs()))
        .sum();
    2.0 * 24.0 * u * (1.0 + mag) * (1.0 + s.abs())
}

/// Per cluster, the index of its best pixel in sorted order and that pixel's index.
pub fn best_pixels(clusters: &[Cluster], pixels: &[u32], scores: &[f32]) -> Vec<u32> {
    clusters
        .iter()
        .map(|cl| {
            let [start, count, _, _] = cl.start_count_key;
            let mut best = pixels[start as usize];
            for j in start..start + count {
                let p = pixels[j as usize];
                if scores[p as usize] > scores[best as usize] {
                    best = p;
                }
            }
            best
        })
        .collect()
}
