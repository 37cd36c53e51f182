//! GPU vs mirror for `kernels/voxel_light.wgsl` (direct light into voxels, exact shadow rays), on
//! generated scenes voxelized by the GPU; and the analytic value on the Cornell box floor.
use crate::common;

use common::gpu;
use vxgi::harness::run::run;
use vxgi::kernels::voxel_light::{case_for, DECL};
use vxgi::kernels::voxelize::voxelize_on_gpu;
use vxgi::scene::Scene;
use vxgi::trace::SceneData;
use vxgi_cpu_mirror::morton;

/// A floor voxel in front of the boxes, 64^3: radiance = albedo / pi * I cos / r^2 at the voxel centre
/// (the floor is flat there: mean normal (0, 1, 0)), unshadowed.
#[test]
fn cornell_floor_voxel_has_the_analytic_radiance() {
    let scene = Scene::cornell_box();
    let (grid, list, frame) = voxelize_on_gpu(gpu(), &scene, 64).unwrap();
    let data = SceneData::new(&scene);
    let case = case_for(gpu(), &data, &grid, &list, &frame, "cornell".into(), 0);
    let out = run(
        gpu(),
        &DECL.shader().unwrap(),
        DECL.name,
        &case.resources,
        &case.passes,
        &["vox_radiance"],
    )
    .unwrap();
    let rad: &[[f32; 4]] = bytemuck::cast_slice(&out.buffer("vox_radiance").bytes);
    let v = morton::encode(32, 0, 60);
    let c = frame.origin + (glam::Vec3::new(32.0, 0.0, 60.0) + 0.5) * frame.voxel;
    let l = glam::Vec3::new(0.0, 1.9, 0.0) - c;
    let expected = 0.73f32 * 4096.0;
    let albedo = expected.round() / 4096.0;
    let e = 10.0 * (l.y / l.length()) / l.length_squared();
    let want = albedo / std::f32::consts::PI * e;
    assert!(
        (rad[v as usize][0] - want).abs() < 1e-5 * want,
        "{:?} vs {want}",
        rad[v as usize]
    );
    assert_eq!(rad[v as usize][3], 1.0);
}
