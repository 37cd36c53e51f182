//! GPU vs mirror for `kernels/cone_trace.wgsl` (AO, diffuse and glossy cones through the radiance
//! pyramid) on generated scenes whose earlier stages ran on the GPU; marching stability; and the
//! vct-dense pipeline's accuracy against the reference, printed.
use crate::common;

use common::{cornell, flip, gpu, scene_file, verified};
use vxgi::images::RgbImage;
use vxgi::kernels::cone_trace::ConeSettings;
use vxgi::reference::{render_reference, ReferenceOptions};
use vxgi::scene::Scene;
use vxgi_cpu_mirror::cone_trace::{diffuse_cones, march, ConeParams, Pyramid};

/// Marching stability on a synthetic pyramid: all-opaque (origin inside solid voxels), empty, and a
/// checkerboard of opaque voxels; cones along axes and grazing diagonals, narrow and wide. The result is
/// always finite, radiance within [0, max], occlusion within [0, 1], and the incremental mip level
/// stays within 1e-3 of the exact log2 of the diameter over the longest march.
#[test]
fn marching_is_stable_on_extreme_pyramids() {
    let side = 16u32;
    let len = vxgi_cpu_mirror::cone_trace::pyramid_len(side);
    let params = ConeParams {
        origin: [0.0, 0.0, 0.0, 1.0 / 16.0],
        ao_range: 0.5,
        ao_lambda: 1.0,
        diffuse_tan: 0.577,
        offset_voxels: 1.0,
        diffuse_cones: 5,
        levels: 5,
        side,
        inv_s0: 16.0,
        mip_clamp: 0.0,
        step_factor: 0.5,
        ..Default::default()
    };
    let mut clamped = params;
    clamped.mip_clamp = 1.5;
    let mut long_steps = clamped;
    long_steps.step_factor = 1.0;
    // The finest level bias (cells 1/8 of the diameter: ratio up to 4) with fully correlated
    // coverage (which divides by the step-corrected alpha).
    let mut biased = clamped;
    (biased.level_bias, biased.coverage_correlation) = (-3.0, 1.0);
    let mut half_correlated = long_steps;
    half_correlated.coverage_correlation = 0.5;
    let solid = vec![[2.0, 2.0, 2.0, 1.0]; len];
    let empty = vec![[0.0; 4]; len];
    let checker: Vec<[f32; 4]> = (0..len).map(|i| [solid[0], empty[0]][i % 2]).collect();
    for (voxels, p) in [&solid, &empty, &checker]
        .into_iter()
        .flat_map(|v| [&params, &clamped, &long_steps, &biased, &half_correlated].map(|p| (v, p)))
    {
        let pyr = Pyramid { p, voxels };
        for tan in [0.01f32, 0.2, 0.577, 1.0] {
            for d in [
                glam::Vec3::X,
                glam::Vec3::new(1.0, 1e-7, 0.0).normalize(),
                glam::Vec3::ONE.normalize(),
                -glam::Vec3::Z,
            ] {
                let r = march(&pyr, glam::Vec3::splat(0.5), d, tan, d.z, 2.0);
                assert!(
                    r.radiance.is_finite() && r.occlusion.is_finite(),
                    "tan {tan} d {d}"
                );
                assert!(r.radiance.max_element() <= 2.0 + 1e-4 && r.radiance.min_element() >= 0.0);
                assert!((0.0..=1.0 + 1e-5).contains(&r.occlusion), "{}", r.occlusion);
            }
        }
    }
    // Incremental vs exact mip level over the longest march (narrow cone: most steps).
    let tan = 0.01f32;
    let (mut diam, mut lf) = (0.75f32 / 16.0, 0.75f32.log2());
    let dl = (1.0 + tan).log2();
    for _ in 0..2000 {
        diam *= 1.0 + tan;
        lf += dl;
        let exact = (diam * 16.0).log2();
        assert!((lf - exact).abs() < 1e-3, "{lf} vs {exact}");
    }
    let weights: f32 = diffuse_cones(5, 0.577).iter().map(|c| c[3]).sum();
    assert_eq!(weights.round(), 1.0, "cone weights {weights}");
}

/// The vct-dense pipeline against the reference on the Cornell box at 64x64 (64 spp: the reference's
/// own noise is a large part of these numbers). Printed for the record; the bounds only catch a broken
/// pipeline (an indirect image off by a factor, NaN, black). Measured at 256x256 against a 256-spp
/// reference: combined FLIP 0.24, indirect 0.43 (docs/accuracy/vct-dense.md).
#[test]
fn vct_dense_against_the_reference() {
    let mut scene = Scene::cornell_box();
    scene.camera.width = 64;
    scene.camera.height = 64;
    let r = vxgi::render::render(gpu(), &scene, &ConeSettings::default(), |_| {}).unwrap();
    let reference = render_reference(
        &scene,
        &ReferenceOptions {
            spp: 64,
            seed: 5,
            jitter: true,
            ..Default::default()
        },
        |_| {},
    );
    let rgb = |px: Vec<[f32; 3]>| RgbImage::new(64, 64, px);
    let comb = flip(&rgb(reference.combined()), &r.combined);
    let ind = flip(&rgb(reference.indirect.clone()), &r.indirect);
    let mean =
        |img: &[[f32; 3]]| img.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / img.len() as f32;
    let ratio = mean(&r.indirect.pixels) / mean(&reference.indirect);
    println!(
        "64x64 Cornell box: combined FLIP {:.3} rel MSE {:.3}; indirect FLIP {:.3}; indirect energy ours/reference {ratio:.2}",
        comb.flip_mean, comb.rel_mse, ind.flip_mean
    );
    assert!(comb.flip_mean < 0.45, "{}", comb.flip_mean);
    assert!((0.5..2.0).contains(&ratio), "indirect energy ratio {ratio}");
    assert!(r.ao.pixels.iter().all(|p| (0.0..=1.0).contains(&p[0])));
}

/// vct-dense at the Cornell box's own 256x256 with the default settings against the committed
/// converged reference (references/cornell_box_256_4096spp, 4096 spp: a 256-spp reference is FLIP 0.084
/// from it, so this measures the method, not the reference's noise). Measured on lavapipe: combined
/// FLIP 0.238, indirect 0.419, AO 0.417. A regression guard at the measured values plus margin; the
/// vct-dense issue's goal (combined < 0.1) is met with interleaved narrow cones (next test), not by
/// the defaults (docs/accuracy/vct-dense.md).
#[test]
fn vct_dense_against_the_converged_reference() {
    let dir =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("references/cornell_box_256_4096spp");
    let read = |name: &str| vxgi::images::read_exr(&dir.join(format!("{name}.exr"))).unwrap();
    let scene = Scene::cornell_box();
    let r = vxgi::render::render(gpu(), &scene, &ConeSettings::default(), |_| {}).unwrap();
    let comb = flip(&read("combined"), &r.combined);
    let ind = flip(&read("indirect"), &r.indirect);
    let ao = flip(&read("ao"), &r.ao);
    println!(
        "256x256 Cornell box vs 4096 spp: combined FLIP {:.3} (rel MSE {:.3}), indirect {:.3}, AO {:.3}",
        comb.flip_mean, comb.rel_mse, ind.flip_mean, ao.flip_mean
    );
    assert!(comb.flip_mean < 0.26, "combined FLIP {}", comb.flip_mean);
    assert!(ind.flip_mean < 0.45, "indirect FLIP {}", ind.flip_mean);
    assert!(ao.flip_mean < 0.45, "AO FLIP {}", ao.flip_mean);
}

/// vct-dense meets the goal (combined FLIP < 0.1 against the converged reference at 256x256)
/// with interleaved cone sets (scenes/cornell_box_interleaved.toml: 16 cones of 2.5 deg per sample
/// from an 8 x 8 pattern, resolved over each sample's neighbours on its surface; level bias -1.25; 2 x 2
/// samples per pixel). Measured on lavapipe: 0.0912, indirect energy 0.975 of the reference's; the
/// default settings 0.238 (above). The scene file is docs/accuracy/vct-dense.md's recipe, so test and recipe cannot
/// drift.
#[test]
#[ignore = "about 2 minutes on lavapipe: cargo test --release -- --ignored interleaved_narrow"]
fn interleaved_narrow_cones_meet_the_flip_goal_on_the_cornell_box() {
    let scene = scene_file("cornell_box_interleaved.toml");
    let cones = ConeSettings::from(&scene.render);
    assert_eq!(cones.interleave, 8);
    let r = vxgi::render::render(gpu(), &scene, &cones, |_| {}).unwrap();
    let (flip, ratio) = common::against_converged_cornell(&r);
    println!("interleaved narrow cones: combined FLIP {flip:.4}, indirect energy ours/reference {ratio:.3}");
    assert!(flip < 0.1, "combined FLIP {flip}");
    assert!((0.9..1.1).contains(&ratio), "indirect energy ratio {ratio}");
}

/// The interleaved frame on the GPU (the chain runs the cone pass's resolve entry after `main`) is
/// the mirror frame's (`render_mirror`: class cones per pixel, then `cone_trace::resolve`) to float
/// rounding, for each pattern side.
#[test]
fn interleaved_frames_match_the_mirror_frame() {
    let scene = cornell(48, 40, 64);
    let mut images = Vec::new();
    for n in [2u32, 4, 8] {
        let cones = ConeSettings {
            diffuse_cones: 4,
            diffuse_half_angle_deg: 8.0,
            interleave: n,
            ..ConeSettings::default()
        };
        let r = vxgi::render::render(gpu(), &scene, &cones, |_| {}).unwrap();
        let m = vxgi::render::render_mirror(&scene, &cones).unwrap();
        for (name, a, b) in [("indirect", &m.indirect, &r.indirect), ("ao", &m.ao, &r.ao)] {
            let e = flip(a, b).rel_mse;
            assert!(e < 1e-6, "N {n} {name}: GPU vs mirror rel MSE {e}");
        }
        images.push(r.indirect.pixels);
    }
    assert_ne!(images[0], images[1]);
    assert_ne!(images[1], images[2]);
}

/// thin_wall's leak (indirect energy seen in the dark room / in the lit room; the reference's is
/// exactly 0), printed, with the paper's trilinear and the depth-ordered blend
/// (`[render] depth_ordered_blend`). The wall is one voxel thick at 128^3: the trilinear blend mixes
/// the lit side of the one-voxel wall into the dark room's samples; with the near cell hiding the far
/// one the leak nearly vanishes (measured 128x64: see the printout; 256x128 vs 256 spp: leak 0.032 ->
/// 0.004, combined FLIP 0.232 -> 0.126). The GPU frame is the mirror frame's (`render_mirror`, the
/// snapshot tests' renderer) to float rounding.
#[test]
fn depth_ordered_blend_stops_the_thin_wall_leak() {
    let scene = common::thin_wall(128, 64);
    let pos = vxgi::reference::pixel_positions(&scene);
    let paper = ConeSettings::default();
    let ordered = ConeSettings {
        depth_ordered_blend: true,
        ..paper
    };
    let leak_of = |cones: &ConeSettings| {
        let r = vxgi::render::render(gpu(), &scene, cones, |_| {}).unwrap();
        let leak = vxgi::reference::leak(&r.indirect.pixels, &pos, 0.0, 1.0 / 64.0);
        (leak, r)
    };
    let (leak_paper, _) = leak_of(&paper);
    let (leak_ordered, r) = leak_of(&ordered);
    println!("thin_wall leak: trilinear {leak_paper:.4}, depth-ordered {leak_ordered:.4}");
    assert!(
        leak_ordered < 0.25 * leak_paper,
        "{leak_ordered} vs {leak_paper}"
    );
    let m = vxgi::render::render_mirror(&scene, &ordered).unwrap();
    let c = flip(&m.indirect, &r.indirect);
    assert!(c.rel_mse < 1e-6, "GPU vs mirror: rel MSE {}", c.rel_mse);
    // cprc's caches march through the same pyramid (cache_creation): the same blend, less leak
    // (measured 0.036 -> 0.022; the rest is gathered across the wall from caches on the lit side). At
    // the scene's own 256x128 (at 128x64 its 16-pixel tiles gather across the wall: leak ~0.15 either
    // way).
    let full = common::thin_wall(256, 128);
    let full_pos = vxgi::reference::pixel_positions(&full);
    let cprc_leak = |cones: &ConeSettings| {
        let (r, _) = vxgi::render::render_cprc(gpu(), &full, cones, |_| {}).unwrap();
        vxgi::reference::leak(&r.indirect.pixels, &full_pos, 0.0, 1.0 / 64.0)
    };
    let (cp, co) = (cprc_leak(&paper), cprc_leak(&ordered));
    println!("thin_wall cprc leak: trilinear {cp:.4}, depth-ordered {co:.4}");
    assert!(co < 0.75 * cp, "{co} vs {cp}");
}

/// vct-dense on scenes/instances.toml: one voxel hierarchy per instance (CPRC 3.1's scheme, shared
/// with cprc), cone-traced through all of them (cone_trace_instanced); the second frame keeps every
/// voxelization and re-lights the moved box's hierarchy; against a reference of the first frame
/// within 0.05 of one hierarchy of the flattened scene.
#[test]
fn vct_dense_traces_instances_through_their_own_hierarchies() {
    let mut scene = scene_file("instances.toml");
    scene.camera.width = 64;
    scene.camera.height = 64;
    scene.render.voxels = 64;
    let cones = ConeSettings::from(&scene.render);
    let mut r = vxgi::render::Renderer::new(vxgi::render::Pipeline::VctDense, true);
    let (f0, _) = r.render(gpu(), &scene, &cones, |_| {}).unwrap();
    let (f1, _) = r.render(gpu(), &scene.at_frame(3), &cones, |_| {}).unwrap();
    assert!(f0.stages.iter().any(|s| s.0 == "voxelize"));
    assert!(
        f1.stages.iter().all(|s| s.0 != "voxelize"),
        "{:?}",
        f1.stages
    );
    assert!(f1.stages.iter().any(|s| s.0 == "cone_trace"));
    assert_ne!(f0.indirect.pixels, f1.indirect.pixels);
    assert!(f0.ao.pixels.iter().all(|p| (0.0..=1.0).contains(&p[0])));
    let flat = Scene {
        instances: Default::default(),
        ..scene.clone()
    };
    let one = vxgi::render::render(gpu(), &flat, &cones, |_| {}).unwrap();
    let reference = render_reference(&scene, &ReferenceOptions::spp(32), |_| {});
    let reference = RgbImage::new(64, 64, reference.combined());
    let ours = flip(&reference, &f0.combined);
    let single = flip(&reference, &one.combined);
    println!(
        "instances, vct-dense: combined FLIP {:.3} with per-instance hierarchies, {:.3} with one",
        ours.flip_mean, single.flip_mean
    );
    assert!(ours.flip_mean < single.flip_mean + 0.05);
}

#[test]
fn instanced_cones_match_the_mirror() {
    verified(&vxgi::kernels::cone_trace::ConeTraceInstanced, 4, 13);
}

/// The planner's rule "mip levels no cone reaches are not built": a narrow cone's pass over a pyramid
/// whose unread levels are zero (and `levels` says so) gives the image the whole pyramid gives, bit
/// for bit; the plan builds fewer levels for it and every level for the default cones.
#[test]
fn mip_levels_no_cone_reaches_are_not_built_and_not_missed() {
    use vxgi::harness::{buffer_as, buffers, HostBuffer};
    use vxgi::kernels::cone_trace::{pyramid_levels, run_case, scene_case};
    use vxgi_cpu_mirror::cone_trace::level_offset;
    let scene = cornell(48, 48, 64);
    let default = ConeSettings::from(&scene.render);
    assert_eq!(
        pyramid_levels(&scene, &default, 64),
        7,
        "30-degree cones read every level"
    );
    let narrow = ConeSettings {
        diffuse_half_angle_deg: 1.0,
        ..default
    };
    let levels = pyramid_levels(&scene, &narrow, 64);
    assert!(levels < 7, "a 1-degree cone reads {levels} of 7 levels");
    let plan = vxgi::render::Pipeline::VctDense.plan(&scene, &narrow, false);
    let mips = plan
        .passes
        .iter()
        .find(|p| p.stage == "surface_coverage_mip")
        .unwrap();
    assert!(mips.size.contains("not built"), "{}", mips.size);
    // A glossy material with a wide lobe (n = 0: tan 1) brings every level back.
    let mut wide = scene.clone();
    wide.materials[0].specular = [0.5; 3];
    wide.materials[0].shininess = 0.0;
    assert_eq!(pyramid_levels(&wide, &narrow, 64), 7);

    let whole = scene_case(gpu(), &scene, &narrow).unwrap();
    let mut partial = whole.clone();
    let mut pyramid: Vec<[f32; 4]> = buffer_as(&whole.resources, "pyramid").unwrap().into();
    pyramid[level_offset(64, levels)..].fill([f32::NAN; 4]);
    let mut params: ConeParams = buffer_as(&whole.resources, "cone").unwrap()[0];
    assert_eq!(params.levels, 7);
    params.levels = levels;
    partial.resources.extend(buffers([
        ("pyramid", HostBuffer::of(&pyramid[..])),
        ("cone", HostBuffer::structs(&[params])),
    ]));
    // NaN in the unbuilt levels: any read of them would show.
    assert_eq!(
        run_case(gpu(), &vxgi::kernels::cone_trace::DECL, &whole).unwrap(),
        run_case(gpu(), &vxgi::kernels::cone_trace::DECL, &partial).unwrap()
    );
    // The frame's chain builds only those levels; its image agrees with the mirror frame's, which
    // builds all of them.
    let ours = vxgi::render::render(gpu(), &scene, &narrow, |_| {}).unwrap();
    let mirror = vxgi::render::render_mirror(&scene, &narrow).unwrap();
    let f = flip(&mirror.indirect, &ours.indirect).flip_mean;
    assert!(f < 0.01, "GPU vs mirror indirect FLIP {f}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
    /// The resolve (mirror) on random images, any size (also smaller than the window), any pattern
    /// side, surfaces on a few planes with background holes: every output finite, AO in [0, 1], and
    /// a resolved irradiance (albedo 1, no glossy share) within the range of the inputs on the
    /// pixel's plane (a mean over some of them); a uniform irradiance resolves to itself.
    #[test]
    fn resolve_is_a_mean_over_the_pixels_own_surface(
        w in 1u32..20,
        h in 1u32..20,
        n in proptest::sample::select(vec![2u32, 4, 8]),
        seed in 0u64..1_000_000,
    ) {
        use vxgi_cpu_mirror::cone_trace::{resolve, PixelOut};
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let p = ConeParams { origin: [0.0, 0.0, 0.0, 0.05], interleave: n, diffuse_cones: 4, ..Default::default() };
        let len = (w * h) as usize;
        let (mut pos, mut nrm, mut px) = (vec![[0.0f32; 4]; len], vec![[0.0f32; 4]; len], vec![PixelOut::default(); len]);
        let mut plane = vec![usize::MAX; len];
        for i in 0..len {
            let r = next();
            if r < 0.1 {
                continue; // background
            }
            let k = (r * 3.0) as usize % 3;
            plane[i] = k;
            let (x, y) = ((i as u32 % w) as f32 * 0.01, (i as u32 / w) as f32 * 0.01);
            // Three planes: z = 0 facing +z, z = 0.3 facing +z (a step), x = 0 facing +x.
            let (q, m) = match k {
                0 => ([x, y, 0.0], [0.0, 0.0, 1.0]),
                1 => ([x, y, 0.3], [0.0, 0.0, 1.0]),
                _ => ([0.0, y, x], [1.0, 0.0, 0.0]),
            };
            let front = if next() < 0.8 { 1.0 } else { -1.0 };
            pos[i] = [q[0], q[1], q[2], 1.0];
            nrm[i] = [m[0] * front, m[1] * front, m[2] * front, front];
            let irr = [next() * 4.0, next(), next() * 0.1, next()];
            px[i].irradiance = irr;
            px[i].irradiance_bound = [1e-6; 4];
            if front > 0.0 {
                px[i].indirect = [irr[0], irr[1], irr[2], 0.0];
            }
        }
        let albedo = vec![[1.0f32, 1.0, 1.0, 1.0]; len];
        let out = resolve(&p, w, &pos, &nrm, &albedo, &px);
        for i in 0..len {
            let o = &out[i];
            proptest::prop_assert!(o.indirect.iter().chain(&o.ao).chain(&o.indirect_bound).all(|v| v.is_finite()));
            proptest::prop_assert!((0.0..=1.0).contains(&o.ao[0]));
            if plane[i] == usize::MAX || nrm[i][3] < 0.0 {
                continue;
            }
            for c in 0..3 {
                let same = (0..len).filter(|&j| plane[j] == plane[i] && nrm[j][3] > 0.0);
                let lo = same.clone().map(|j| px[j].irradiance[c]).fold(f32::MAX, f32::min);
                let hi = same.map(|j| px[j].irradiance[c]).fold(f32::MIN, f32::max);
                let v = o.indirect[c];
                proptest::prop_assert!(v >= lo - 1e-5 && v <= hi + 1e-5, "pixel {i} channel {c}: {v} not in [{lo}, {hi}]");
            }
        }
        // A uniform irradiance resolves to itself (to the rounding of a mean).
        let uniform: Vec<PixelOut> = px.iter().map(|q| PixelOut { irradiance: [0.7, 0.2, 0.1, 0.4], indirect: if q.indirect == [0.0; 4] { [0.0; 4] } else { [0.7, 0.2, 0.1, 0.0] }, ..*q }).collect();
        for (i, o) in resolve(&p, w, &pos, &nrm, &albedo, &uniform).iter().enumerate() {
            if plane[i] != usize::MAX {
                proptest::prop_assert!((o.ao[0] - 0.6).abs() < 1e-6);
                if nrm[i][3] > 0.0 {
                    proptest::prop_assert!((o.indirect[0] - 0.7).abs() < 1e-6);
                }
            }
        }
    }
}
