//! Octahedral binning of quantised normals, shared by `tile_normal_histogram` and `histogram_axes`
//! (WGSL side: `kernels/common/octahedral_bins.wgsl`). Integers only, so GPU and mirror agree exactly.
//!
//! A normal arrives quantised to snorm16 (`q = round(n / |n| * 32767)`, done once on the host,
//! [`quantise`]). With `s = |x| + |y| + |z|`, the octahedral coordinates scaled by `s` are `(x, y)` on the
//! upper hemisphere and `(sign(x) (s - |y|), sign(y) (s - |x|))` on the lower (sign(0) = +1); bin
//! `b = (u + s) * BINS / (2 s)` per axis (integer division, clamped to BINS - 1).

/// Bins per axis of the octahedral histogram (BINS x BINS bins).
pub const BINS: i32 = 8;
/// BINS * BINS.
pub const BIN_COUNT: usize = (BINS * BINS) as usize;

/// snorm16 quantisation of a normal, or `None` for what the histograms treat as background: non-finite
/// or (near) zero-length normals.
pub fn quantise(n: [f32; 3]) -> Option<[i32; 3]> {
    let v = n.map(f64::from);
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if !len.is_finite() || len < 1e-6 {
        return None;
    }
    Some(v.map(|c| (c / len * 32767.0).round() as i32))
}

/// Pack a quantised normal as the kernels read it: `(x | y << 16, z | geometry << 16)`, 16-bit two's
/// complement fields; `None` packs as background (geometry flag 0).
pub fn pack(q: Option<[i32; 3]>) -> [u32; 2] {
    match q {
        Some([x, y, z]) => [
            (x as u32 & 0xffff) | ((y as u32 & 0xffff) << 16),
            (z as u32 & 0xffff) | (1 << 16),
        ],
        None => [0, 0],
    }
}

/// Unpack: the quantised normal, or `None` for background.
pub fn unpack(w: [u32; 2]) -> Option<[i32; 3]> {
    if (w[1] >> 16) & 1 == 0 {
        return None;
    }
    let s = |v: u32| (v & 0xffff) as u16 as i16 as i32;
    Some([s(w[0]), s(w[0] >> 16), s(w[1])])
}

/// Bin index `bv * BINS + bu` of a quantised normal.
pub fn bin(q: [i32; 3]) -> usize {
    let [x, y, z] = q;
    let s = x.abs() + y.abs() + z.abs();
    let sgn = |v: i32| if v < 0 { -1 } else { 1 };
    let (u, v) = if z >= 0 {
        (x, y)
    } else {
        (sgn(x) * (s - y.abs()), sgn(y) * (s - x.abs()))
    };
    let b = |c: i32| (((c + s) * BINS) / (2 * s)).min(BINS - 1);
    (b(v) * BINS + b(u)) as usize
}

/// The bin across the octahedral map's border: out-of-range (u, v) mirrored as the map folds.
pub fn wrap(mut u: i32, mut v: i32) -> (i32, i32) {
    if u < 0 {
        u = -1 - u;
        v = BINS - 1 - v;
    } else if u >= BINS {
        u = 2 * BINS - 1 - u;
        v = BINS - 1 - v;
    }
    if v < 0 {
        v = -1 - v;
        u = BINS - 1 - u;
    } else if v >= BINS {
        v = 2 * BINS - 1 - v;
        u = BINS - 1 - u;
    }
    (u, v)
}

/// Unit direction of a bin's centre.
pub fn bin_direction(bin: usize) -> [f64; 3] {
    let (bu, bv) = ((bin as i32 % BINS) as f64, (bin as i32 / BINS) as f64);
    let (u, v) = (
        (bu + 0.5) / BINS as f64 * 2.0 - 1.0,
        (bv + 0.5) / BINS as f64 * 2.0 - 1.0,
    );
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z >= 0.0 {
        (u, v)
    } else {
        ((1.0 - v.abs()) * u.signum(), (1.0 - u.abs()) * v.signum())
    };
    let l = (x * x + y * y + z * z).sqrt();
    [x / l, y / l, z / l]
}

/// Re-weighting factors of axis extraction, `round(255 (1 - |n_a . n_b|^8))`, row `a` = the picked axis.
/// 8 bits so that two rounds of `(w + 1) * factor` stay inside u32 for tiles up to 64 x 64.
pub fn reweight_table() -> Vec<u32> {
    let dirs: Vec<[f64; 3]> = (0..BIN_COUNT).map(bin_direction).collect();
    let mut t = Vec::with_capacity(BIN_COUNT * BIN_COUNT);
    for a in &dirs {
        for b in &dirs {
            let d = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).abs();
            t.push((255.0 * (1.0 - d.powi(8))).round() as u32);
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_normals_land_in_the_expected_bins_and_borders_wrap() {
        assert_eq!(
            bin(quantise([0.0, 0.0, 1.0]).unwrap()),
            (BINS / 2 * BINS + BINS / 2) as usize
        );
        let down = bin(quantise([0.0, 0.0, -1.0]).unwrap());
        assert!(
            [0, BINS - 1, BINS * (BINS - 1), BINS * BINS - 1].contains(&(down as i32)),
            "{down}"
        );
        assert_eq!(wrap(-1, 2), (0, BINS - 3));
        assert_eq!(wrap(BINS, 0), (BINS - 1, BINS - 1));
        for b in 0..BIN_COUNT {
            let d = bin_direction(b);
            let q = quantise([d[0] as f32, d[1] as f32, d[2] as f32]).unwrap();
            assert_eq!(bin(q), b, "bin centre maps back to its bin");
        }
    }

    #[test]
    fn background_and_packing() {
        assert_eq!(quantise([f32::NAN, 0.0, 1.0]), None);
        assert_eq!(quantise([0.0, 0.0, 0.0]), None);
        let q = quantise([-0.3, 0.5, -0.8]);
        assert_eq!(unpack(pack(q)), q);
        assert_eq!(unpack(pack(None)), None);
    }
}
