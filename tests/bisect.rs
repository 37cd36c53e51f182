//! The bisection switch (`vxgi::bisect`, DESIGN.md section 3): a frame with its first stages on the
//! mirrors and the rest on the GPU. Every split renders; the all-mirror split is the mirror frame;
//! splits that run the G-buffer on the mirror agree with it to 1e-3 everywhere (the later kernels are
//! exact or within ULPs), and the all-GPU split departs only where the G-buffer's triangle pick is
//! decided by rounding (which `vxgi verify` accepts).
use crate::common;

use common::gpu;
use vxgi::bisect::{bisect, render_split, split_after, stages, table};
use vxgi::kernels::cone_trace::ConeSettings;
use vxgi::render::Pipeline;
use vxgi::scene::Scene;

fn small_box() -> Scene {
    let mut scene = Scene::cornell_box();
    scene.camera.width = 48;
    scene.camera.height = 48;
    scene.render.voxels = 32;
    scene
}

/// Each of `rows` agrees with the all-mirror frame (no pixel off by more than 1e-3 of its image's
/// largest value, FLIP < 1e-3).
fn assert_agree(rows: &[vxgi::bisect::SplitRow]) {
    for r in rows {
        for &(name, flip, _, off) in &r.images {
            assert!(
                off == 0 && flip < 1e-3,
                "split {}: {name} FLIP {flip}, {off} pixels off",
                r.split
            );
        }
    }
}

#[test]
fn every_split_renders_and_only_the_gpu_gbuffer_departs() {
    let scene = small_box();
    let cones = ConeSettings::from(&scene.render);
    let rows = bisect(gpu(), &scene, &cones, Pipeline::VctDense, |_| {}).unwrap();
    let order = stages(Pipeline::VctDense, &scene, &cones).unwrap();
    println!("{}", table(&order, &rows));
    assert_eq!(rows.len(), order.len());
    // Every split whose G-buffer came from the mirror.
    assert_agree(&rows[1..]);
    // All on the GPU: the snapshot tests' agreement bound.
    for &(name, flip, _, off) in &rows[0].images {
        assert!(
            flip < 0.02 && off * 50 <= 48 * 48,
            "{name}: FLIP {flip}, {off} pixels off"
        );
    }
}

/// Both are the declaration's steps on the mirrors: with a GPU at hand (bisect) and without one
/// (the snapshot tests' frames), every pipeline's images are the same bit for bit.
#[test]
fn the_all_mirror_split_is_the_mirror_frame() {
    let scene = small_box();
    let cones = ConeSettings::from(&scene.render);
    for pipeline in Pipeline::ALL {
        let all = stages(pipeline, &scene, &cones).unwrap().len();
        let split = render_split(gpu(), &scene, &cones, pipeline, all, |_| {}).unwrap();
        let (mirror, _) = vxgi::render::mirror_frame(pipeline, &scene, &cones).unwrap();
        let name = pipeline.name();
        assert_eq!(split.direct.pixels, mirror.direct.pixels, "{name}");
        assert_eq!(split.indirect.pixels, mirror.indirect.pixels, "{name}");
        assert_eq!(split.ao.pixels, mirror.ao.pixels, "{name}");
        assert!(
            split
                .plan
                .passes
                .iter()
                .filter(|p| p.runs)
                .all(|p| p.why.starts_with("mirror:")),
            "{name}"
        );
    }
}

#[test]
fn stages_are_named_and_a_typo_is_an_error() {
    let dense = Pipeline::VctDense.stages();
    assert_eq!(split_after(&dense, "gbuffer").unwrap(), 1);
    assert_eq!(split_after(&dense, "cone_trace").unwrap(), dense.len());
    let e = split_after(&dense, "voxelise").unwrap_err().to_string();
    assert!(e.contains("voxelize") && e.contains("voxelise"), "{e}");
    let (scene, cones) = (small_box(), ConeSettings::default());
    assert!(render_split(gpu(), &scene, &cones, Pipeline::VctDense, 7, |_| {}).is_err());
    // vct-svo's frame follows its plan; cprc's cache stages are two GPU chains.
    let svo = stages(Pipeline::VctSvo, &scene, &cones).unwrap();
    assert_eq!(
        svo,
        [
            "gbuffer",
            "direct_light",
            "voxelize",
            "svo_photons",
            "sparse_voxel_octree",
            "svo_anisotropic",
            "svo_cone_trace"
        ]
    );
    let cprc = stages(Pipeline::Cprc, &scene, &cones).unwrap();
    assert_eq!(&cprc[5..], ["cache_distribution", "cache_creation"]);
}

/// Supersampled 3x, the G-buffer's samples at thirds of a pixel meet the Cornell box's edges, where
/// the GPU may pick the other triangle of a tie: the table names gbuffer as the departure, and says
/// that the G-buffer is within its verification's bounds on the frame (the answer read as a kernel
/// error before).
#[test]
fn a_gbuffer_departure_on_ties_is_said_to_be_one() {
    let mut scene = common::cornell(24, 24, 32);
    scene.render.supersample = 3;
    let cones = ConeSettings::from(&scene.render);
    let order = stages(Pipeline::VctDense, &scene, &cones).unwrap();
    let rows = bisect(gpu(), &scene, &cones, Pipeline::VctDense, |_| {}).unwrap();
    let t = table(&order, &rows);
    println!("{t}");
    assert_agree(&rows[1..]);
    let ties = (rows[0].gbuffer_ties.as_ref()).expect("the all-GPU split checks the G-buffer");
    assert!(
        ties.failure.is_none()
            && ties.unexplained == 0
            && ties.accepted > 0
            && ties.samples == 72 * 72,
        "{ties:?}"
    );
    assert!(
        t.contains("gbuffer, within its verification's bounds on this frame"),
        "{t}"
    );
}

/// vct-svo here with Gaussian lobes, so its normal pool is a stage of its own.
#[test]
fn vct_svo_and_cprc_splits_agree_after_the_gpu_gbuffer() {
    let mut scene = small_box();
    scene.render.voxel_lobes = true;
    let cones = ConeSettings::from(&scene.render);
    for pipeline in [Pipeline::VctSvo, Pipeline::Cprc] {
        let order = stages(pipeline, &scene, &cones).unwrap();
        assert_eq!(
            order.contains(&"svo_lobes"),
            pipeline == Pipeline::VctSvo,
            "{order:?}"
        );
        let rows = bisect(gpu(), &scene, &cones, pipeline, |_| {}).unwrap();
        println!("{}\n{}", pipeline.name(), table(&order, &rows));
        assert_eq!(rows.len(), order.len());
        assert_agree(&rows[1..]);
    }
}

#[test]
fn lrsm_splits_depart_only_where_a_gbuffer_picks_a_triangle() {
    let scene = small_box();
    let cones = ConeSettings::from(&scene.render);
    let order = stages(Pipeline::Lrsm, &scene, &cones).unwrap();
    let rows = bisect(gpu(), &scene, &cones, Pipeline::Lrsm, |_| {}).unwrap();
    println!("{}", table(&order, &rows));
    // The camera's G-buffer and the light views' G-buffers (inside reflective_shadow_map) are the
    // stages whose GPU result may pick another triangle where rounding decides; with both on the
    // mirror, every later kernel agrees with its mirror.
    let rsm = split_after(&order, "reflective_shadow_map").unwrap();
    assert_agree(&rows[rsm..]);
    for r in &rows[1..] {
        assert!(r.images.iter().all(|i| i.1 < 1e-3), "split {}", r.split);
    }
    let mut soft = scene.clone();
    soft.render.shadow_cone_angle = 10.0;
    assert!(stages(Pipeline::Lrsm, &soft, &cones).is_err());
}
