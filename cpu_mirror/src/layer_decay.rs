//! Mirror of `kernels/layer_decay.wgsl`: LRSM eq. 15, the weight of a layer at cone-sample depth zc.
//!
//! `f(zc) = min(k((zc - zmin) / delta), k((zmax - zc) / delta))`, `k(x) = t^2 (3 - 2t)`,
//! `t = clamp(x, 0, 1)` (smoothstep: smooth, clamped to [0, 1], and `k(x) + k(1 - x) = 1`, so two layers
//! overlapping by exactly `delta` have weights summing to one across the overlap). For
//! `zmax - zmin >= 2 delta` this is eq. 15 piece by piece; for narrower layers the min keeps it defined.
//! `delta <= 0` is the step `zmin <= zc <= zmax`.
use crate::ftz;

/// The smooth falloff k, in the kernel's operation order.
pub fn falloff(x: f32, flush: bool) -> f32 {
    let f = |v: f32| ftz(v, flush);
    let t = f(x).clamp(0.0, 1.0);
    f(f(t * t) * f(3.0 - f(2.0 * t)))
}

/// f(zc) for the layer [zmin, zmax] with overlap delta.
pub fn layer_decay(zc: f32, zmin: f32, zmax: f32, delta: f32, flush: bool) -> f32 {
    let f = |v: f32| ftz(v, flush);
    let (zc, zmin, zmax, delta) = (f(zc), f(zmin), f(zmax), f(delta));
    if delta <= 0.0 {
        return if zc >= zmin && zc <= zmax { 1.0 } else { 0.0 };
    }
    let lo = falloff(f(f(zc - zmin) / delta), flush);
    let hi = falloff(f(f(zmax - zc) / delta), flush);
    lo.min(hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plateau_ramps_and_outside() {
        assert_eq!(layer_decay(0.5, 0.0, 1.0, 0.1, false), 1.0);
        assert_eq!(layer_decay(-0.1, 0.0, 1.0, 0.1, false), 0.0);
        assert_eq!(layer_decay(1.2, 0.0, 1.0, 0.1, false), 0.0);
        assert!((layer_decay(0.05, 0.0, 1.0, 0.1, false) - 0.5).abs() < 1e-6);
        assert_eq!(layer_decay(0.3, 0.0, 1.0, 0.0, false), 1.0);
    }

    #[test]
    fn overlapping_layers_sum_to_one() {
        // Layers [0, 0.55] and [0.45, 1] overlap by delta = 0.1.
        for i in 0..=100 {
            let z = 0.45 + 0.1 * i as f32 / 100.0;
            let s = layer_decay(z, 0.0, 0.55, 0.1, false) + layer_decay(z, 0.45, 1.0, 0.1, false);
            assert!((s - 1.0).abs() < 1e-5, "{z}: {s}");
        }
    }
}
