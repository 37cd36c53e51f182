//! GPU vs mirror for `kernels/cprc_pixels.wgsl` (cprc's per-pixel inputs and its composed images):
//! generated G-buffers with bad normals, back faces, background and out-of-range triangles, and the
//! quantisation's exact values.

use vxgi_cpu_mirror::cprc_pixels::quantised;

#[test]
fn the_quantisation_is_exact_on_axes_and_drops_bad_normals() {
    // +y: (0, 32767, 0) with the geometry flag; -x: 16-bit two's complement of -32767.
    assert_eq!(quantised([0.0, 1.0, 0.0, 1.0]), [32767 << 16, 1 << 16]);
    assert_eq!(quantised([-1.0, 0.0, 0.0, 1.0]), [0x8001, 1 << 16]);
    // Clamped past unit length; background where not finite or rounding to 0.
    assert_eq!(quantised([0.0, 0.0, 7.0, 1.0]), [0, 32767 | (1 << 16)]);
    assert_eq!(quantised([f32::NAN, 0.0, 1.0, 1.0]), [0, 0]);
    assert_eq!(quantised([1e-6, 0.0, 0.0, 1.0]), [0, 0]);
}
