//! The cprc pipeline end to end (Rehfeld et al. 2014): its accuracy against the converged reference,
//! and the paper's Fig. 6 argument on rendered scenes — clustered cache placement leaves fewer pixels
//! without a valid cache than an equidistant grid of as many caches.
use crate::common;

use common::gpu;
use vxgi::cprc::{self, CprcSettings};
use vxgi::images::compare;
use vxgi::kernels::cone_trace::ConeSettings;
use vxgi::scene::Scene;
use vxgi::trace::SceneData;

/// cprc at the Cornell box's own 256x256 with the default settings (16^2 caches, 16-pixel tiles)
/// against the committed converged reference (4096 spp). Measured on lavapipe: combined FLIP 0.180,
/// indirect 0.330 (vct-dense: 0.238 / 0.419). A regression guard at the measured values plus margin,
/// the indirect light's energy within 25% of the reference's, and under 0.5% of the pixels without a
/// valid cache.
#[test]
fn cprc_against_the_converged_reference() {
    let dir =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("references/cornell_box_256_4096spp");
    let read = |name: &str| vxgi::images::read_exr(&dir.join(format!("{name}.exr"))).unwrap();
    let scene = Scene::cornell_box();
    let (r, stats) =
        vxgi::render::render_cprc(gpu(), &scene, &ConeSettings::default(), |_| {}).unwrap();
    let p = std::path::Path::new("");
    let comb = compare(&read("combined"), p, &r.combined, p).unwrap();
    let reference = read("indirect");
    let ind = compare(&reference, p, &r.indirect, p).unwrap();
    let mean = |img: &[[f32; 3]]| img.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>();
    let ratio = mean(&r.indirect.pixels) / mean(&reference.pixels);
    println!(
        "256x256 Cornell box, cprc vs 4096 spp: combined FLIP {:.3} (rel MSE {:.3}), indirect {:.3}, indirect energy ours/reference {ratio:.2}; {stats:?}",
        comb.flip_mean, comb.rel_mse, ind.flip_mean
    );
    assert!(comb.flip_mean < 0.21, "combined FLIP {}", comb.flip_mean);
    assert!(ind.flip_mean < 0.36, "indirect FLIP {}", ind.flip_mean);
    assert!(
        (0.75..1.25).contains(&ratio),
        "indirect energy ratio {ratio}"
    );
    // A few pixels in corners see only caches of the other walls (measured: 66 of 61498): the
    // frame stage by stage on the GPU measures it (the resident frame keeps its caches there).
    let (_, staged) = vxgi::pipeline::host::frame(
        &vxgi::pipeline::CPRC,
        Some(gpu()),
        &scene,
        &ConeSettings::default(),
        &|_| false,
        &|_| {},
    )
    .unwrap();
    let staged = staged.expect("cprc's caches");
    assert_eq!(staged.caches, stats.caches, "{staged:?} {stats:?}");
    let (pixels, uncovered) = staged.coverage.expect("measured stage by stage");
    assert!(uncovered * 200 < pixels, "{stats:?}");
}

/// The accuracy goal, mean FLIP of the combined image < 0.1 at 256x256 against the converged reference,
/// met by cprc on vct-dense's voxels and cone march with finer caches
/// (scenes/cornell_box_fine_caches.toml: 4-pixel tiles, 32^2 texels, a 4^2 irradiance map, gathering
/// over 1.5 tiles, cone level bias -1.25, mip clamp 1.5, 2 x 2 samples per pixel). Measured on
/// lavapipe: 0.0864 (0.0981 with one sample per pixel), indirect energy 0.95 of the reference's.
/// `vxgi bisect` on the scene file (one sample per pixel): from the G-buffer on, every GPU stage
/// agrees with its mirror to 4e-7; the GPU G-buffer's 3 edge pixels move a few caches (indirect FLIP
/// 0.0003 between the two frames), so the margin to 0.1 is not a driver's rounding. The scene file is
/// the recipe docs/accuracy/cprc.md gives, so test and recipe cannot drift.
#[test]
#[ignore = "about 1.5 minutes on lavapipe: cargo test --release -- --ignored fine_caches"]
fn fine_caches_meet_the_flip_goal_on_the_cornell_box() {
    let scene = common::scene_file("cornell_box_fine_caches.toml");
    let cones = ConeSettings::from(&scene.render);
    let (r, stats) = vxgi::render::render_cprc(gpu(), &scene, &cones, |_| {}).unwrap();
    let (flip, ratio) = common::against_converged_cornell(&r);
    println!("fine caches: combined FLIP {flip:.4}, indirect energy ours/reference {ratio:.3}; {stats:?}");
    assert!(flip < 0.1, "combined FLIP {flip}");
    assert!((0.9..1.1).contains(&ratio), "indirect energy ratio {ratio}");
}

/// Fig. 6 on rendered G-buffers (GPU G-buffer and GPU distribution): the Cornell box and both thin-wall
/// scenes at 128x128 with 8- and 16-pixel tiles; the equidistant grid gets as many caches and the same
/// mean world radius. Clustered placement never leaves more pixels without a valid cache (weight > 0
/// and facing the pixel's hemisphere).
#[test]
fn clustered_placement_leaves_fewer_pixels_without_a_cache_than_a_grid() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    println!(
        "scene             tile  caches  clustered: uncovered   equidistant: caches  uncovered"
    );
    for (name, mut scene) in [
        ("cornell_box", Scene::cornell_box()),
        (
            "thin_wall",
            Scene::load(root.join("scenes/thin_wall.toml")).unwrap(),
        ),
        (
            "thin_wall_glossy",
            Scene::load(root.join("scenes/thin_wall_glossy.toml")).unwrap(),
        ),
    ] {
        scene.camera.width = 128;
        scene.camera.height = 128;
        let data = SceneData::new(&scene);
        let gb = vxgi::kernels::direct_light::gpu_gbuffer(gpu(), &data);
        let (pos, nrm, tri, alb) = cprc::gbuffer_arrays(&gb);
        for tile in [8, 16] {
            scene.render.cache_tile = tile;
            let s = CprcSettings::from(&scene.render);
            let px = cprc::pixel_inputs(&data, &pos, &nrm, &tri, &alb, s.res);
            let clustered = cprc::distribute_gpu(gpu(), &px, &s, 0.0).unwrap();
            let grid = cprc::distribute_equidistant(&px, &clustered, &s, 0.0);
            let cov = |set: &cprc::CacheSet| {
                cprc::coverage(&cprc::gather_data(&px, set, &s, Vec::new(), Vec::new()))
            };
            let ((pixels, c_unc), (_, g_unc)) = (cov(&clustered), cov(&grid));
            println!(
                "{name:<17} {tile:>4} {:>7} {:>9} ({:.2}%) {:>18} {:>10} ({:.2}%)",
                clustered.caches.pos.len(),
                c_unc,
                100.0 * c_unc as f64 / pixels as f64,
                grid.caches.pos.len(),
                g_unc,
                100.0 * g_unc as f64 / pixels as f64
            );
            assert!(pixels > 1000);
            assert!(
                c_unc <= g_unc,
                "{name} tile {tile}: clustered {c_unc} > grid {g_unc}"
            );
            // The grid has about as many caches (its cells are square: within 25%).
            let (a, b) = (
                clustered.caches.pos.len() as f64,
                grid.caches.pos.len() as f64,
            );
            assert!((b / a - 1.0).abs() < 0.25, "{a} vs {b}");
        }
    }
}

/// Without lights the frame runs every stage (the plan says their light is 0), and its direct and
/// indirect light are 0.
#[test]
fn without_lights_the_indirect_light_is_zero() {
    let mut scene = Scene::cornell_box();
    scene.camera.width = 32;
    scene.camera.height = 32;
    scene.lights.clear();
    let plan = vxgi::render::Pipeline::Cprc.plan(&scene, &ConeSettings::default(), false);
    assert!(plan.skipped().is_empty(), "{plan}");
    assert!(
        plan.to_string().contains("no lights: indirect is 0"),
        "{plan}"
    );
    let (r, _) =
        vxgi::render::render_cprc(gpu(), &scene, &ConeSettings::default(), |_| {}).unwrap();
    for (stage, _) in &r.stages {
        assert!(r.plan.runs(stage), "{stage} ran, the plan skips it");
    }
    assert!(r.indirect.pixels.iter().all(|p| *p == [0.0; 3]));
    assert!(r.direct.pixels.iter().all(|p| *p == [0.0; 3]));
}

/// CPRC 3.1's multiple voxel hierarchies on scenes/instances.toml (room, a static box, a dynamic box):
/// three hierarchies, voxelized in the first frame only; the moved box's hierarchy is re-lit where it
/// stands, so the next frame's indirect light differs. Against a reference of the first frame the
/// result is as good as one hierarchy of the flattened scene (measured on lavapipe at 256x256, 64 spp:
/// combined FLIP 0.227 vs 0.218); here at 64x64 within 0.05 of it.
#[test]
fn instances_get_their_own_hierarchies() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut scene = Scene::load(root.join("scenes/instances.toml")).unwrap();
    scene.camera.width = 64;
    scene.camera.height = 64;
    scene.render.voxels = 64;
    scene.render.cache_tile = 8;
    let cones = ConeSettings::from(&scene.render);
    let mut r = vxgi::render::Renderer::new(vxgi::render::Pipeline::Cprc, true);
    let (f0, _) = r.render(gpu(), &scene, &cones, |_| {}).unwrap();
    let (f1, _) = r.render(gpu(), &scene.at_frame(3), &cones, |_| {}).unwrap();
    let voxelize = |f: &vxgi::render::Rendered| {
        f.plan
            .passes
            .iter()
            .find(|p| p.stage == "voxelize")
            .unwrap()
            .clone()
    };
    assert!(voxelize(&f0).runs && voxelize(&f0).size.starts_with("3 hierarchies"));
    assert!(!voxelize(&f1).runs, "{:?}", voxelize(&f1));
    assert!(f1.stages.iter().all(|s| s.0 != "voxelize"));
    assert_ne!(f0.indirect.pixels, f1.indirect.pixels);
    assert!(f0
        .indirect
        .pixels
        .iter()
        .flatten()
        .all(|x| x.is_finite() && *x >= 0.0));
    // One hierarchy of the flattened scene, for comparison.
    let flat = Scene {
        instances: Default::default(),
        ..scene.clone()
    };
    let (one, _) = vxgi::render::render_cprc(gpu(), &flat, &cones, |_| {}).unwrap();
    let reference = vxgi::reference::render_reference(
        &scene,
        &vxgi::reference::ReferenceOptions::spp(32),
        |_| {},
    );
    let p = std::path::Path::new("");
    let rgb = |px: Vec<[f32; 3]>| vxgi::images::RgbImage::new(64, 64, px);
    let ours = compare(&rgb(reference.combined()), p, &f0.combined, p).unwrap();
    let flat_c = compare(&rgb(reference.combined()), p, &one.combined, p).unwrap();
    println!(
        "instances: combined FLIP {:.3} with per-instance hierarchies, {:.3} with one",
        ours.flip_mean, flat_c.flip_mean
    );
    assert!(ours.flip_mean < flat_c.flip_mean + 0.05);
}

/// `cache_reuse`: a renderer's frames after the first keep the last frame's caches where their
/// surface is still in their cluster. A still view keeps every cache and draws the first frame again,
/// bit for bit; a slow orbit keeps most of them, and its frames differ from a renderer's that places
/// every frame's caches anew (the same first frame: nothing to keep yet).
#[test]
fn cache_reuse_keeps_the_caches_of_a_still_view_and_most_under_a_slow_orbit() {
    use vxgi::render::{Pipeline, VolumeMemory};
    use vxgi::resident::Resident;
    let mut scene = Scene::cornell_box();
    (scene.camera.width, scene.camera.height) = (64, 64);
    scene.render.voxels = 32;
    scene.render.cache_tile = 8;
    let cones = ConeSettings::from(&scene.render);
    let stats = |r: &Resident| match r.memory() {
        Some(VolumeMemory::Caches(c)) => (c.caches, c.kept),
        other => panic!("cprc's caches: {other:?}"),
    };
    let frames = |reuse: bool, degrees: f32| {
        let mut s = scene.clone();
        s.render.cache_reuse = reuse;
        let mut r = Resident::new(gpu(), Pipeline::Cprc).unwrap();
        (0..3)
            .map(|k| {
                let f = r.render(&s.orbited(degrees * k as f32), &cones).unwrap();
                (f.indirect, stats(&r))
            })
            .collect::<Vec<_>>()
    };
    let still = frames(true, 0.0);
    assert_eq!(still[0].1 .1, 0, "nothing to keep in the first frame");
    for (k, (img, (caches, kept))) in still.iter().enumerate().skip(1) {
        assert!(
            *caches > 20 && kept == caches,
            "frame {k}: {kept} of {caches} kept"
        );
        assert!(img == &still[0].0, "frame {k} differs from frame 0");
    }
    let (kept, anew) = (frames(true, 1.0), frames(false, 1.0));
    assert!(kept[0].0 == anew[0].0, "the first frames differ");
    for k in 1..3 {
        let (caches, n) = kept[k].1;
        assert!(
            n * 10 >= caches * 7 && n < caches,
            "frame {k}: {n} of {caches} kept"
        );
        assert!(kept[k].0 != anew[k].0, "frame {k}: reuse changed nothing");
    }
}

/// `cache_carry`: with `cache_reuse`, a kept cache keeps its radiance texels (cache_creation skips
/// it) in the frames whose volume is the last frame's. Over a slow orbit, a moving light (which
/// re-lights the voxels: nothing is carried) and the orbit again, the frames are bit for bit those
/// of a renderer that traces every kept cache again, and the plan says which frames carried.
#[test]
fn carried_caches_give_the_frames_that_traced_caches_give() {
    use vxgi::render::Pipeline;
    use vxgi::resident::Resident;
    use vxgi::temporal::Motion;
    let mut scene = Scene::cornell_box();
    (scene.camera.width, scene.camera.height) = (64, 64);
    scene.render.voxels = 32;
    scene.render.cache_tile = 8;
    scene.render.cache_reuse = true;
    let cones = ConeSettings::from(&scene.render);
    // Frames 2 and 3 move the light; 0, 1 and 4 share one light.
    let view = |k: u32| {
        let lit = Motion::Light { step: 0.05 }.at(&scene, k.clamp(1, 3) - 1);
        lit.orbited(1.0 * k as f32)
    };
    let frames = |carry: bool| {
        let mut r = Resident::new(gpu(), Pipeline::Cprc).unwrap();
        (0..5u32)
            .map(|k| {
                let mut s = view(k);
                s.render.cache_carry = carry;
                let f = r.render(&s, &cones).unwrap();
                (f.indirect, f.plan.to_string().contains("texels carried"))
            })
            .collect::<Vec<_>>()
    };
    let (carried, traced) = (frames(true), frames(false));
    let said: Vec<bool> = carried.iter().map(|f| f.1).collect();
    assert_eq!(
        said,
        [false, true, false, false, true],
        "frames that carried"
    );
    assert!(
        traced.iter().all(|f| !f.1),
        "cache_carry = false carries nothing"
    );
    for (k, (a, b)) in carried.iter().zip(&traced).enumerate() {
        assert!(a.0 == b.0, "frame {k}: carried and traced caches differ");
    }
}
