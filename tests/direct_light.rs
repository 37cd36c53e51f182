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

/// A point light lying in a surface's plane (the Cornell box's light moved up onto the ceiling)
/// lights the walls as one just below the ceiling does. A shadow ray starts `eps` off its surface
/// and ends `2 eps` short of the light, so the plane the light sits in cannot shadow it within
/// rounding; a ray ending at the light itself hit that plane at t within rounding of r, and about
/// a quarter of these pixels were black, speckled over the walls and the floor, in the GPU's image
/// and in the mirror's alike. The case with
/// the light on the ceiling also matches the mirror.
#[test]
fn a_light_in_a_surfaces_plane_lights_the_walls_without_speckles() {
    use vxgi::scene::{Light, Scene};
    use vxgi::trace::SceneData;
    let shader = DECL.shader().unwrap();
    let top = Scene::cornell_box()
        .mesh
        .positions
        .iter()
        .map(|p| p[1])
        .fold(f32::MIN, f32::max);
    let direct = |y: f32| {
        let mut scene = Scene::cornell_box();
        scene.camera.width = 64;
        scene.camera.height = 64;
        let Light::Point { position, .. } = &mut scene.lights[0] else {
            panic!("the Cornell box has a point light")
        };
        position[1] = y;
        let data = SceneData::new(&scene);
        let case =
            vxgi::kernels::direct_light::case_for(gpu(), &data, format!("light at y = {y}"), 0);
        let out = case
            .run(gpu(), &shader, DECL.name, &["radiance", "gb_normal"])
            .unwrap();
        let radiance: Vec<[f32; 4]> = bytemuck::cast_slice(&out.buffer("radiance").bytes).to_vec();
        let normal: Vec<[f32; 4]> = bytemuck::cast_slice(&out.buffer("gb_normal").bytes).to_vec();
        (case, radiance, normal)
    };
    let (case, on, normal) = direct(top);
    let (_, below, _) = direct(top - 0.01);
    // Pixels lit by the light just below the ceiling, not on the ceiling itself (which the light in
    // its plane meets edge-on).
    let lit: Vec<usize> = (0..on.len())
        .filter(|&i| normal[i][3] != 0.0 && normal[i][1] > -0.5 && below[i][0] > 0.0)
        .collect();
    let dark = lit.iter().filter(|&&i| on[i][0] == 0.0).count();
    println!(
        "{dark} of {} lit pixels dark with the light on the ceiling",
        lit.len()
    );
    assert!(lit.len() > 1000, "{} lit pixels", lit.len());
    assert!(
        dark * 1000 < lit.len(),
        "{dark} of {} pixels that a light 0.01 below the ceiling lights are dark with it on the ceiling",
        lit.len()
    );
    assert_case_passes(&shader, &DirectLight, &case);
}
