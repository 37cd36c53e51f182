//! The pipelines' declarations (`vxgi::pipeline`): each frame's plan, stage list and bisect split
//! points come from one declaration per pipeline, so they agree by construction; these tests check
//! what construction leaves open (a plan rule naming another kernel, passes out of order, a chain
//! recorded against its declaration). The resident tests record every pipeline's chain, which
//! `PipelineDecl::check_chain` checks at each build. No GPU needed.
use vxgi::kernels::cone_trace::ConeSettings;
use vxgi::pipeline::{Reuse, Split};
use vxgi::render::Pipeline;
use vxgi::scene::Scene;

/// Scenes whose plans take every branch of the rules: no lights, photons, lobes, directional
/// values, two bounces, soft shadows, glossy materials, interleaved cones.
fn scenes() -> Vec<(String, Scene)> {
    let base = Scene::cornell_box();
    let mut out = vec![("cornell_box".to_string(), base.clone())];
    let mut dark = base.clone();
    dark.lights.clear();
    out.push(("no lights".into(), dark));
    let mut svo = base.clone();
    svo.render.photon_map = 64;
    svo.render.voxel_lobes = true;
    svo.render.anisotropic_voxels = true;
    svo.render.bounces = 2;
    out.push(("photons, lobes, anisotropic, two bounces".into(), svo));
    let mut soft = base.clone();
    soft.render.shadow_cone_angle = 3.0;
    soft.render.cone_interleave = 2;
    out.push(("shadow cones, interleaved".into(), soft));
    let glossy = Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/thin_wall_glossy.toml"
    ))
    .expect("thin_wall_glossy loads");
    out.push(("thin_wall_glossy".into(), glossy));
    out
}

/// The kernel names a plan line lists ("gbuffer + svo_photons", "sparse_voxel_octree (normals)").
fn kernels_of(line: &str) -> Vec<&str> {
    line.split(" + ")
        .map(|k| k.split(" (").next().unwrap_or(k))
        .collect()
}

#[test]
fn every_planned_pass_runs_a_kernel_its_stage_declares_in_the_declared_order() {
    for (what, scene) in scenes() {
        let cones = ConeSettings::from(&scene.render);
        for pipeline in Pipeline::ALL {
            let decl = pipeline.decl();
            for cached in [false, true] {
                let plan = pipeline.plan(&scene, &cones, cached);
                assert_eq!(plan.pipeline, pipeline.name());
                let mut at = 0;
                for p in &plan.passes {
                    let s = decl.stage(p.stage).unwrap_or_else(|| {
                        panic!("{what}, {}: undeclared stage {}", decl.name, p.stage)
                    });
                    let k = decl.stages.iter().position(|d| d.name == p.stage).unwrap();
                    assert!(
                        k >= at,
                        "{what}, {}: {} planned after {}",
                        decl.name,
                        p.stage,
                        decl.stages[at].name
                    );
                    at = k;
                    for kernel in kernels_of(p.kernel) {
                        assert!(
                            s.kernels.iter().any(|d| d.name == kernel),
                            "{what}, {}: stage {} plans kernel {kernel}, not among its declared kernels",
                            decl.name,
                            p.stage
                        );
                    }
                }
                // A cached frame skips exactly the stages of the volume that it plans.
                if cached && !scene.lights.is_empty() {
                    for p in &plan.passes {
                        let reuse = decl.stage(p.stage).unwrap().reuse;
                        if reuse != Reuse::Camera {
                            assert!(!p.runs, "{what}, {}: {} runs cached", decl.name, p.stage);
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn bisect_splits_at_declared_stages_in_frame_order() {
    for (what, mut scene) in scenes() {
        scene.render.bounces = 1;
        scene.render.shadow_cone_angle = 0.0;
        let cones = ConeSettings::from(&scene.render);
        for pipeline in Pipeline::ALL {
            let order = vxgi::bisect::stages(pipeline, &scene, &cones).unwrap();
            let all = pipeline.stages();
            let mut at = 0;
            for s in &order {
                let k = all.iter().position(|n| n == s).expect("declared");
                assert!(k >= at, "{what}, {}: {order:?}", pipeline.name());
                at = k;
                assert_ne!(pipeline.decl().stage(s).unwrap().split, Split::Never);
            }
            // The first split is the G-buffer, the last the stage that shades the pixels'
            // indirect light (cprc: creation; its pre-convolution and gather follow on the GPU).
            assert_eq!(order[0], "gbuffer");
            let last = match pipeline {
                Pipeline::VctDense => "cone_trace",
                Pipeline::VctSvo => "svo_cone_trace",
                Pipeline::Lrsm => "lrsm_cone_trace",
                Pipeline::Cprc => "cache_creation",
            };
            assert_eq!(*order.last().unwrap(), last, "{what}: {order:?}");
        }
    }
}

#[test]
fn a_chain_out_of_its_declaration_is_refused() {
    let decl = Pipeline::VctDense.decl();
    let ok = [
        ("voxelize", "voxelize"),
        ("voxel_light", "voxel_light"),
        ("surface_coverage_mip", "surface_coverage_mip"),
        ("gbuffer", "gbuffer"),
        ("direct_light", "direct_light"),
        ("cone_trace", "screen_tiles"),
        ("cone_trace", "cone_trace"),
    ];
    decl.check_chain(ok).unwrap();
    let mut camera_first = ok;
    camera_first.swap(0, 3);
    let e = decl.check_chain(camera_first).unwrap_err().to_string();
    assert!(
        e.contains("`voxel_light`") && e.contains("after `gbuffer`"),
        "{e}"
    );
    let mut other_kernel = ok;
    other_kernel[6] = ("cone_trace", "svo_cone_trace");
    let e = decl.check_chain(other_kernel).unwrap_err().to_string();
    assert!(
        e.contains("svo_cone_trace") && e.contains("declares"),
        "{e}"
    );
    let mut undeclared = ok;
    undeclared[2] = ("mips", "surface_coverage_mip");
    let e = decl.check_chain(undeclared).unwrap_err().to_string();
    assert!(
        e.contains("`mips`") && e.contains("surface_coverage_mip"),
        "{e}"
    );
}
