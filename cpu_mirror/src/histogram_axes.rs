//! Mirror of `kernels/histogram_axes.wgsl`: three axes per tile from its blurred normal histogram
//! (CPRC 3.2): pick the highest-rated bin (lowest index on ties), re-weight every bin
//! `w = (w + 1) * factor[best][n]` with `factor = round(255 (1 - |n . n_best|^8))` (the paper's
//! `(w + 1)(1 - |n . n_best|^8)` in 8-bit fixed point), repeat until three axes. Integers: exact.
use crate::octahedral::BIN_COUNT;

/// The three axis bins of one tile.
pub fn axes(blurred: &[u32], reweight: &[u32]) -> [u32; 3] {
    let mut w: Vec<u32> = blurred[..BIN_COUNT].to_vec();
    let mut out = [0u32; 3];
    for (k, axis) in out.iter_mut().enumerate() {
        let mut best = 0;
        for n in 1..BIN_COUNT {
            if w[n] > w[best] {
                best = n;
            }
        }
        *axis = best as u32;
        if k < 2 {
            for (n, wn) in w.iter_mut().enumerate() {
                *wn = (*wn + 1) * reweight[best * BIN_COUNT + n];
            }
        }
    }
    out
}

/// Axes of every tile: `(a0, a1, a2, geometry pixels in the tile)` per tile.
pub fn all_axes(blurred: &[u32], raw: &[u32], reweight: &[u32]) -> Vec<[u32; 4]> {
    blurred
        .chunks(BIN_COUNT)
        .zip(raw.chunks(BIN_COUNT))
        .map(|(b, r)| {
            let a = axes(b, reweight);
            [a[0], a[1], a[2], r.iter().sum()]
        })
        .collect()
}
