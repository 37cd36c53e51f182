//! GPU vs mirror for `kernels/svo_anisotropic.wgsl` (sparse_voxel_octree's fragment families, one level
//! per case given the mirror's other levels), and its parameter struct against the reflected WGSL.
//! What the directional values mean (walls stay opaque, media integrate exactly, the front layer is
//! what a cone sees) is tested on the mirror (cpu_mirror/src/svo_anisotropic.rs); their effect on
//! images (leak, accuracy) in tests/svo_cone_trace.rs.

use vxgi::kernels::svo_anisotropic::DECL;
use vxgi_cpu_mirror::svo_anisotropic::AnisoParams;

#[test]
fn params_struct_matches_the_reflected_wgsl_layout() {
    crate::common::assert_layout!(
        DECL.shader().unwrap(),
        AnisoParams {
            depth,
            level,
            inv_scale,
            _pad as "_pad0",
            _pad as "_pad1" + 4,
            _pad as "_pad2" + 8,
            _pad as "_pad3" + 12,
            _pad as "_pad4" + 16,
        }
    );
}
