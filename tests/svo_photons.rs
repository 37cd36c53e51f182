//! GPU vs mirror for `kernels/svo_photons.wgsl` (generated scenes, every view of their lights), and what
//! the photons of the Cornell box must carry: the light voxel_light computes per voxel, in total.
use crate::common;

use common::gpu;
use vxgi::kernels::svo_photons::photon_fragments;
use vxgi::kernels::voxelize::voxelize_on_gpu;
use vxgi::render::Pipeline;
use vxgi::scene::Scene;
use vxgi::trace::SceneData;

/// The Cornell box at 64^3 voxels: the photons of the ceiling light's six 256^2 views, summed per
/// voxel, hold as much light in total as voxel_light's per-voxel direct light (the two estimate the same
/// L * alpha: photons by density over the cells a surface crosses, voxel_light by one shadowed sample
/// per voxel), and land only in voxels the voxelization filled or their neighbours.
#[test]
fn cornell_box_photons_carry_the_voxels_direct_light() {
    let scene = Scene::cornell_box();
    let data = SceneData::new(&scene);
    let (grid, list, frame) = voxelize_on_gpu(gpu(), &scene, 64).unwrap();
    let lit = vxgi::kernels::voxel_light::light_on_gpu(gpu(), &data, &grid, &list, &frame).unwrap();
    let scale = 65536.0;
    let pf = photon_fragments(gpu(), &data, &frame, 256, scale).unwrap();
    let (photons, texels) = (pf.light, pf.texels);
    assert_eq!(texels, 6 * 256 * 256);
    let total_photons: f64 = photons
        .iter()
        .map(|f| (f.value[0] + f.value[1] + f.value[2]) as f64 / scale as f64)
        .sum();
    let total_voxels: f64 = lit.iter().map(|v| (v[0] + v[1] + v[2]) as f64).sum();
    let ratio = total_photons / total_voxels;
    println!(
        "{} photon fragments of {texels} texels; photons / voxel_light total radiance {ratio:.3}",
        photons.len()
    );
    // Measured 0.986.
    assert!((0.9..1.1).contains(&ratio), "{ratio}");
    let filled = |p: [i64; 3]| {
        let side = frame.side as i64;
        p.iter().all(|&c| (0..side).contains(&c))
            && grid.colour
                [vxgi_cpu_mirror::morton::encode(p[0] as u32, p[1] as u32, p[2] as u32) as usize][3]
                > 0.0
    };
    let stray = photons
        .iter()
        .filter(|f| {
            let p = f.pos.map(|c| c as i64);
            !(-1..=1).any(|dx| {
                (-1..=1).any(|dy| (-1..=1).any(|dz| filled([p[0] + dx, p[1] + dy, p[2] + dz])))
            })
        })
        .count();
    assert_eq!(stray, 0, "photons far from any filled voxel");
}

/// The plan names the injection it runs: photons by default, voxel_light with photon_map = 0, neither
/// without lights.
#[test]
fn the_plan_names_the_injection() {
    let cones = vxgi::kernels::cone_trace::ConeSettings::default();
    let mut scene = Scene::cornell_box();
    let plan = Pipeline::VctSvo.plan(&scene, &cones, false);
    assert!(
        plan.runs("svo_photons") && !plan.runs("voxel_light"),
        "{plan}"
    );
    assert!(
        plan.to_string().contains("6 light views x 256^2 texels"),
        "{plan}"
    );
    scene.render.photon_map = 0;
    let plan = Pipeline::VctSvo.plan(&scene, &cones, false);
    assert!(
        !plan.runs("svo_photons") && plan.runs("voxel_light"),
        "{plan}"
    );
    scene.render.photon_map = 256;
    // Without lights the injection still runs (no light view, no photon): the octree takes the
    // voxels' coverage from it, for the AO.
    scene.lights.clear();
    let plan = Pipeline::VctSvo.plan(&scene, &cones, false);
    assert!(
        plan.runs("svo_photons")
            && !plan.runs("voxel_light")
            && plan.to_string().contains("0 light views"),
        "{plan}"
    );
}

#[test]
fn params_struct_matches_the_reflected_wgsl_layout() {
    use vxgi_cpu_mirror::svo_photons::PhotonParams;
    let shader = vxgi::kernels::svo_photons::DECL.shader().unwrap();
    crate::common::assert_layout!(
        shader,
        PhotonParams {
            eye,
            forward,
            grid,
            info
        }
    );
}
