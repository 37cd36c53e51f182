//! GPU vs mirror for `kernels/triangle_setup.wgsl` on whole scenes, beside the generated cases of
//! `vxgi verify`: the GPU puts a scene's mesh on voxelize's lattice exactly as the host's `prepare`
//! does (the mirror), and sizes voxelize's dispatch from it.
use crate::common::{gpu, passing_run, scene_file};
use vxgi::kernels::triangle_setup::{case_for, MeshInput, TriangleSetup, DECL};
use vxgi::kernels::voxelize::{frame_of, prepare};
use vxgi::scene::Scene;
use vxgi_cpu_mirror::voxelize::VoxTriangle;

/// The Cornell box, the textured box (texture coordinates and atlas placements) and the instance
/// scene (two meshes, materials past the first), at 64^3 and 512^3: every triangle word for word
/// as `prepare` gives it, and the dispatch covering the most rows.
#[test]
fn the_gpu_sets_up_a_scene_as_prepare_does() {
    for scene in [
        Scene::cornell_box(),
        scene_file("textured_cornell.toml"),
        scene_file("instances.toml"),
    ] {
        for side in [64, 512] {
            let mesh = MeshInput::of(&scene, frame_of(&scene.mesh, side));
            let shader = DECL.shader().unwrap();
            let case = case_for(gpu(), &mesh, format!("{side}^3"), 0);
            let out = passing_run(
                &shader,
                &TriangleSetup,
                &case,
                &["vox_triangles", "vox_dispatch"],
            );
            let got: &[VoxTriangle] = bytemuck::cast_slice(&out.buffer("vox_triangles").bytes);
            let (input, _) = prepare(&scene, side).unwrap();
            assert_eq!(got, &input.tris[..], "{side}^3");
            let rows = input.tris.iter().map(|t| t.a[3] as u32 + 1).max().unwrap();
            let groups = (input.tris.len() as u32).div_ceil(64);
            assert_eq!(out.buffer("vox_dispatch").as_u32(), &[groups, rows, 1]);
            // Finer grids take more samples per triangle.
            assert!(side == 64 || rows > 64, "{side}^3: {rows} rows");
        }
    }
}

/// A mesh whose triangles need more workgroups along x than the device dispatches is refused by name
/// before anything is allocated: voxelize's passes are dispatched indirectly from triangle_setup's
/// output, which the device does not check when the pass is recorded.
#[test]
fn too_many_triangles_for_one_dispatch_are_refused() {
    use vxgi::kernels::voxelize::{case_for, Triangles, VoxelizeError};
    let mut mesh = MeshInput::of(
        &Scene::cornell_box(),
        frame_of(&Scene::cornell_box().mesh, 8),
    );
    let limit = gpu().limits().max_compute_workgroups_per_dimension as usize;
    mesh.triangles = vec![[0, 1, 2, 0]; limit * 64 + 1];
    mesh.params.triangles = mesh.triangles.len() as u32;
    let err = case_for(gpu(), Triangles::Setup(&mesh), 8, "too many".into(), 0).unwrap_err();
    assert!(
        matches!(err, VoxelizeError::TooManyTriangles { groups, .. } if groups == limit as u64 + 1),
        "{err}"
    );
    assert!(
        err.to_string()
            .contains("max_compute_workgroups_per_dimension"),
        "{err}"
    );
}
