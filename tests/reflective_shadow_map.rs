//! GPU vs mirror for `kernels/reflective_shadow_map.wgsl` (generated scenes, every view of their lights),
//! and what an RSM of the Cornell box's ceiling light must hold: the six cube faces see the whole room
//! (but its open front), the face looking down sees the floor lit at <n.l> near 1, depths inside [0, 1].
use crate::common::gpu;
use vxgi::kernels::reflective_shadow_map::rsm_on_gpu;
use vxgi::lrsm::light_views;
use vxgi::scene::{Light, Scene};
use vxgi::trace::SceneData;

#[test]
fn the_cornell_box_light_sees_the_room_through_six_faces() {
    let scene = Scene::cornell_box();
    let data = SceneData::new(&scene);
    let views = light_views(&data.lights, data.bounds, 32, data.frame.eye[3]).unwrap();
    assert_eq!(views.len(), 6, "a point light: six cube faces");
    let (mut covered, mut lit_floor) = (0, false);
    for v in &views {
        let rsm = rsm_on_gpu(gpu(), &data, v).unwrap();
        assert_eq!(rsm.radiance.len(), 32 * 32);
        for ((r, n), d) in rsm.radiance.iter().zip(&rsm.normal).zip(&rsm.depth) {
            assert!((0.0..=1.0).contains(d));
            if r[3] > 0.0 {
                covered += 1;
                assert!(r[..3].iter().all(|c| c.is_finite() && *c >= 0.0));
                // Facing down (-y): the floor under the light, lit nearly head-on.
                if v.view.forward[1] < -0.9 && n[1] > 0.99 && n[3] > 0.95 {
                    lit_floor = true;
                }
            }
        }
    }
    // The light hangs inside a box open only at the front (the camera's side): five faces see walls
    // almost everywhere, the sixth partly (measured: 5381 of 6144 texels).
    assert!(covered > 5 * 32 * 32 * 9 / 10, "{covered}");
    assert!(lit_floor);
}

#[test]
fn a_narrow_spot_gets_one_view_and_a_directional_light_an_orthographic_one() {
    let mut scene = Scene::cornell_box();
    scene.lights = vec![Light::Spot {
        position: [0.0, 0.9, 0.0],
        direction: [0.0, -1.0, 0.0],
        intensity: [5.0; 3],
        cone_deg: 30.0,
        falloff_deg: None,
    }];
    let data = SceneData::new(&scene);
    let views = light_views(&data.lights, data.bounds, 16, 1e-4).unwrap();
    assert_eq!(views.len(), 1);
    // Straight down, the orthographic view would see the ceiling's outside (a back face: coverage 0):
    // light the box through its open front instead, along -z and a little down.
    scene.lights = vec![Light::Directional {
        direction: [0.0, -0.3, -1.0],
        intensity: [1.0; 3],
    }];
    let data = SceneData::new(&scene);
    let views = light_views(&data.lights, data.bounds, 32, 1e-4).unwrap();
    assert_eq!(views.len(), 1);
    assert!(views[0].view.orthographic() && views[0].frame.size[3] == 1);
    let rsm = rsm_on_gpu(gpu(), &data, &views[0]).unwrap();
    // Parallel rays: the back wall (normal +z, facing the light) is seen and lit head-on.
    let lit_back = rsm
        .radiance
        .iter()
        .zip(&rsm.normal)
        .filter(|(r, n)| r[3] > 0.0 && n[2] > 0.99 && n[3] > 0.9)
        .count();
    assert!(lit_back > 32 * 32 / 10, "{lit_back}");
    assert!(rsm.depth.iter().all(|d| (0.0..=1.0).contains(d)));
}
