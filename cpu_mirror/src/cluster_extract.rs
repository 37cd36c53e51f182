//! Mirror of `kernels/cluster_extract.wgsl`: clusters from pixels sorted by cluster key (CPRC 3.2):
//! heads by neighbour comparison, cluster indices by an exclusive prefix sum, then per cluster its
//! first sorted position, pixel count, key, the integer sum of its snorm16 normals (an exact average
//! direction: normalise the sum) and its world-space bounding box (min/max: exact).
use crate::cluster_keys::BACKGROUND;
use crate::octahedral::unpack;

/// One cluster as the kernel writes it (`struct Cluster` in the WGSL, 64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Cluster {
    /// First index in the sorted arrays, pixel count, key, unused.
    pub start_count_key: [u32; 4],
    /// Sum of the pixels' snorm16 normals (xyz), unused.
    pub normal_sum: [i32; 4],
    pub bbox_min: [f32; 4],
    pub bbox_max: [f32; 4],
}

/// `mark_heads`: 1 where a cluster starts in the sorted keys.
pub fn heads(keys: &[u32]) -> Vec<u32> {
    (0..keys.len())
        .map(|i| ((i == 0 || keys[i] != keys[i - 1]) && keys[i] != BACKGROUND) as u32)
        .collect()
}

/// Clusters and, per pixel, its cluster index (`u32::MAX` for background).
pub fn extract(
    keys: &[u32],
    pixels: &[u32],
    normals: &[[u32; 2]],
    positions: &[[f32; 4]],
) -> (Vec<Cluster>, Vec<u32>) {
    let mut clusters = Vec::new();
    let mut pixel_cluster = vec![u32::MAX; normals.len()];
    let h = heads(keys);
    for i in 0..keys.len() {
        if h[i] == 0 {
            continue;
        }
        let c = clusters.len() as u32;
        let mut cl = Cluster {
            start_count_key: [i as u32, 0, keys[i], 0],
            normal_sum: [0; 4],
            bbox_min: [f32::INFINITY; 4],
            bbox_max: [f32::NEG_INFINITY; 4],
        };
        let mut j = i;
        while j < keys.len() && keys[j] == keys[i] {
            let p = pixels[j] as usize;
            let q = unpack(normals[p]).unwrap_or([0; 3]);
            for a in 0..3 {
                cl.normal_sum[a] += q[a];
                cl.bbox_min[a] = cl.bbox_min[a].min(positions[p][a]);
                cl.bbox_max[a] = cl.bbox_max[a].max(positions[p][a]);
            }
            pixel_cluster[p] = c;
            j += 1;
        }
        cl.start_count_key[1] = (j - i) as u32;
        cl.bbox_min[3] = 0.0;
        cl.bbox_max[3] = 0.0;
        clusters.push(cl);
    }
    (clusters, pixel_cluster)
}
