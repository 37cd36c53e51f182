//! Mirror of `kernels/tile_normal_histogram.wgsl`: per screen tile, the octahedral histogram of its
//! pixels' quantised normals, and that histogram blurred by the binomial 3x3 kernel [1 2 1] x [1 2 1]
//! (a discrete Gaussian) with the octahedral map's border folding (CPRC 3.2, "Clustered Cache
//! Distribution"). Integer counts: exact.
use crate::octahedral::{bin, unpack, wrap, BINS, BIN_COUNT};

/// The kernel's uniform block (`struct HistogramParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct HistogramParams {
    pub width: u32,
    pub height: u32,
    /// Tile side in pixels (1..=64).
    pub tile: u32,
    /// Tiles per row: ceil(width / tile).
    pub tiles_x: u32,
}

/// Raw histogram of tile (tx, ty): counts per bin of the geometry pixels inside the image.
pub fn tile_histogram(
    normals: &[[u32; 2]],
    p: &HistogramParams,
    tx: u32,
    ty: u32,
) -> [u32; BIN_COUNT] {
    let mut h = [0u32; BIN_COUNT];
    for py in ty * p.tile..((ty + 1) * p.tile).min(p.height) {
        for px in tx * p.tile..((tx + 1) * p.tile).min(p.width) {
            if let Some(q) = unpack(normals[(py * p.width + px) as usize]) {
                h[bin(q)] += 1;
            }
        }
    }
    h
}

/// The 3x3 binomial blur with octahedral wrap-around.
pub fn blur(h: &[u32; BIN_COUNT]) -> [u32; BIN_COUNT] {
    let mut out = [0u32; BIN_COUNT];
    for (b, o) in out.iter_mut().enumerate() {
        let (u, v) = (b as i32 % BINS, b as i32 / BINS);
        let mut sum = 0u32;
        for dv in -1..=1i32 {
            for du in -1..=1i32 {
                let (wu, wv) = wrap(u + du, v + dv);
                sum += h[(wv * BINS + wu) as usize] * ((2 - du.abs()) * (2 - dv.abs())) as u32;
            }
        }
        *o = sum;
    }
    out
}

/// Raw and blurred histograms of every tile, tile-major (`tiles_x` per row).
pub fn histograms(normals: &[[u32; 2]], p: &HistogramParams) -> (Vec<u32>, Vec<u32>) {
    let tiles_y = p.height.div_ceil(p.tile);
    let (mut raw, mut blurred) = (Vec::new(), Vec::new());
    for ty in 0..tiles_y {
        for tx in 0..p.tiles_x {
            let h = tile_histogram(normals, p, tx, ty);
            raw.extend_from_slice(&h);
            blurred.extend_from_slice(&blur(&h));
        }
    }
    (raw, blurred)
}
