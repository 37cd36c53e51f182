//! GPU vs mirror for `kernels/gbuffer.wgsl`: primary rays through the flattened BVH on generated scenes
//! (Cornell box, smooth-normal triangle soups, box stacks with rays on shared edges, scenes far from the
//! origin and tiny ones).
use crate::common::{passing_run, run_case};
use vxgi::kernels::gbuffer::{case_for, generated_scene, mirror_gbuffer, Gbuffer, DECL};
use vxgi::trace::SceneData;

/// Where rounding decides which triangle a ray hits (shared edges of the box stacks), the mirror
/// accepts the GPU's pick only after checking it; print how often that happens and keep it rare.
#[test]
fn rays_on_shared_edges_rarely_need_acceptance() {
    let shader = DECL.shader().unwrap();
    let (mut accepted, mut pixels) = (0, 0);
    for i in 0..8 {
        let (scene, label) = generated_scene(5, 2 + 4 * i); // box-stack family
        let case = case_for(&SceneData::new(&scene), label, 5);
        let out = passing_run(&shader, &Gbuffer, &case, &["gb_triangle"]);
        let tri = out.buffer("gb_triangle").as_u32();
        accepted += mirror_gbuffer(&case.resources, tri).accepted_differences;
        pixels += tri.len();
    }
    println!("GPU triangle picks differing from the mirror's and accepted: {accepted} of {pixels} pixels");
    assert!(accepted * 100 < pixels, "{accepted} of {pixels}");
}

/// An empty scene still binds (one degenerate triangle that is never hit) and sees nothing.
#[test]
fn a_scene_without_triangles_sees_nothing() {
    let (mut scene, _) = generated_scene(1, 0);
    scene.mesh.triangles.clear();
    scene.mesh.material.clear();
    let data = SceneData::new(&scene);
    let case = case_for(&data, "empty".into(), 0);
    let shader = DECL.shader().unwrap();
    let out = run_case(&shader, DECL.name, &case, &["gb_triangle", "gb_position"]);
    let tri = out.buffer("gb_triangle").as_u32();
    assert!(tri.iter().all(|&t| t == u32::MAX));
    let pos = out.buffer("gb_position").as_f32();
    assert!(pos.chunks(4).all(|p| p[3] == -1.0));
}

/// Vertex normals that cancel (or are zero) give the face normal, never a NaN.
#[test]
fn zero_vertex_normals_fall_back_to_the_face_normal() {
    let (scene, _) = generated_scene(1, 0);
    let mut data = SceneData::new(&scene);
    for t in &mut data.triangles {
        (t.na, t.nb, t.nc) = ([0.0; 4], [0.0; 4], [0.0; 4]);
    }
    let case = case_for(&data, "zero normals".into(), 0);
    let shader = DECL.shader().unwrap();
    let out = passing_run(&shader, &Gbuffer, &case, &["gb_normal"]);
    let n = out.buffer("gb_normal").as_f32();
    assert!(n.iter().all(|x| x.is_finite()));
    let unit =
        |c: &[f32]| c[3] != 0.0 && (c[0] * c[0] + c[1] * c[1] + c[2] * c[2] - 1.0).abs() < 1e-5;
    assert!(n.chunks(4).any(unit));
}
