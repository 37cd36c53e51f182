//! GPU vs mirror for `kernels/direct_light.wgsl` (exact hard shadows, diffuse + normalised Phong, point /
//! spot / directional lights) on generated scenes, fed the GPU's own G-buffer.
use crate::common::{assert_case_passes, gpu};
use vxgi::harness::Kernel;
use vxgi::kernels::direct_light::{DirectLight, DECL};

/// Regression (found by a 40-seed `vxgi verify` sweep, seed 57): a generated albedo near the bottom of
/// the normal range made a term of 4.0e-38 that the GPU returned as 0 (a product flushed on the way:
/// WGSL allows flushing subnormal intermediates); the bound now covers what flushing can remove. The
/// seed's "box stack 48x48" cases, generated again and checked on their own.
#[test]
fn a_term_at_the_bottom_of_the_normal_range_may_flush() {
    let shader = DECL.shader().unwrap();
    for index in [22usize, 34, 50, 62] {
        let case = DirectLight.case(&shader, gpu(), 57, index);
        assert!(case.label.contains("box stack 48x48"), "{}", case.label);
        assert_case_passes(&shader, &DirectLight, &case);
    }
}
