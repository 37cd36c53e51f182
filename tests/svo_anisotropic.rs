//! GPU vs mirror for `kernels/svo_anisotropic.wgsl` (sparse_voxel_octree's fragment families, one level
//! per case given the mirror's other levels), and its parameter struct against the reflected WGSL.
//! What the directional values mean (walls stay opaque, media integrate exactly, the front layer is
//! what a cone sees) is tested on the mirror (cpu_mirror/src/svo_anisotropic.rs); their effect on
//! images (leak, accuracy) in tests/svo_cone_trace.rs.

use vxgi::kernels::svo_anisotropic::DECL;
use vxgi_cpu_mirror::svo_anisotropic::AnisoParams;

#[test]
fn params_struct_matches_the_reflected_wgsl_layout() {
    let (size, members) = DECL.shader().unwrap().struct_layout("AnisoParams").unwrap();
    assert_eq!(size as usize, std::mem::size_of::<AnisoParams>());
    let want: Vec<(String, u32)> = [
        ("depth", std::mem::offset_of!(AnisoParams, depth)),
        ("level", std::mem::offset_of!(AnisoParams, level)),
        ("inv_scale", std::mem::offset_of!(AnisoParams, inv_scale)),
    ]
    .into_iter()
    .map(|(n, o)| (n.to_string(), o as u32))
    .collect();
    assert_eq!(&members[..want.len()], &want[..]);
}
