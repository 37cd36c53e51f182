//! The vct-dense pipeline on the Cornell box (one box made glossy, so the glossy cone runs): GPU time per
//! stage against the mirror's, at 256x256 and 512x512, 128^3 voxels, 5 diffuse + 1 glossy cone; and the
//! frame's error against a Monte Carlo reference (combined FLIP) beside its time; and the skip rule for
//! empty screen tiles: the cone pass over screen_tiles' list vs over every tile, on a sparse view.
//!
//! `cargo bench --bench vct`
mod common;

use common::{gpu_ms, timed};
use vxgi::harness::GpuContext;
use vxgi::kernels::cone_trace::{self, ConeSettings};
use vxgi::kernels::{direct_light, surface_coverage_mip, voxel_light, voxelize};
use vxgi::scene::Scene;
use vxgi::trace::SceneData;
use vxgi_cpu_mirror::surface_coverage_mip::Coverage;

fn main() {
    let ctx = GpuContext::new().expect("GPU adapter (see README: install mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.describe());
    let cones = ConeSettings::default();
    println!(
        "{:<10} {:<22} {:>10} {:>11}",
        "size", "stage", "GPU ms", "mirror ms"
    );
    for size in [256u32, 512] {
        let mut scene = Scene::cornell_box();
        scene.camera.width = size;
        scene.camera.height = size;
        scene.materials[0].specular = [0.3; 3];
        scene.materials[0].shininess = 64.0;
        let data = SceneData::new(&scene);
        let gb = direct_light::gpu_gbuffer(&ctx, &data);
        let gcase = vxgi::kernels::gbuffer::case_for(&data, "bench".into(), 0);
        let dcase = direct_light::case_with_gbuffer(&ctx, &data, &gb, "bench".into(), 0);
        let (grid, list, frame) = voxelize::voxelize_on_gpu(&ctx, &scene, 128).expect("voxelize");
        let (vtris, _) = voxelize::prepare(&scene, 128).expect("prepare");
        let vcase = voxelize::case_for(
            &ctx,
            voxelize::Triangles::Host(&vtris),
            128,
            "bench".into(),
            0,
        )
        .expect("fits");
        let lcase = voxel_light::case_for(&ctx, &data, &grid, &list, &frame, "bench".into(), 0);
        let (mirror_rad, _) = voxel_light::mirror_radiance(&lcase.resources);
        let pyramid = cone_trace::gpu_pyramid(&ctx, &mirror_rad, &grid.normal, 128).expect("mips");
        let mip_grid = vxgi::grids::Grid {
            n: 128,
            colour: mirror_rad.clone(),
            normal: grid.normal.clone(),
        };
        let mshader = surface_coverage_mip::DECL.shader().expect("WGSL validates");
        let mcase = surface_coverage_mip::chain_case(
            &mshader,
            &ctx,
            &mip_grid,
            Coverage::Surface,
            "bench".into(),
            0,
        );
        let mirror_mips = || {
            let (mut c, mut n) = (mirror_rad.clone(), grid.normal.clone());
            while c.len() > 1 {
                (c, n) = vxgi_cpu_mirror::surface_coverage_mip::reduce_level(
                    &c,
                    &n,
                    Coverage::Surface,
                    false,
                );
            }
        };
        let params = cone_trace::cone_params(&frame, &cones);
        let ccase = cone_trace::case_for(&data, &gb, &pyramid, &params, "bench".into(), 0);
        let rows: Vec<(&str, f64, f64)> = vec![
            (
                "gbuffer",
                gpu_ms(&ctx, &vxgi::kernels::gbuffer::DECL, &gcase),
                timed(|| {
                    vxgi::kernels::gbuffer::mirror_gbuffer(
                        &gcase.resources,
                        gb["gb_triangle"].buffer().unwrap().as_u32(),
                    )
                })
                .1,
            ),
            (
                "direct_light",
                gpu_ms(&ctx, &direct_light::DECL, &dcase),
                timed(|| direct_light::mirror_direct(&dcase.resources)).1,
            ),
            (
                "voxelize",
                gpu_ms(&ctx, &voxelize::DECL, &vcase),
                timed(|| vxgi_cpu_mirror::voxelize::voxelize(&vtris, 128)).1,
            ),
            (
                "voxel_light",
                gpu_ms(&ctx, &voxel_light::DECL, &lcase),
                timed(|| voxel_light::mirror_radiance(&lcase.resources)).1,
            ),
            (
                "surface_coverage_mip",
                gpu_ms(&ctx, &surface_coverage_mip::DECL, &mcase),
                timed(mirror_mips).1,
            ),
            (
                "cone_trace",
                gpu_ms(&ctx, &cone_trace::DECL, &ccase),
                timed(|| cone_trace::mirror_cones(&ccase.resources)).1,
            ),
        ];
        let (mut g, mut m) = (0.0, 0.0);
        for (stage, gpu, mirror) in &rows {
            println!(
                "{:<10} {:<22} {:>10.1} {:>11.1}",
                format!("{size}x{size}"),
                stage,
                gpu,
                mirror
            );
            g += gpu;
            m += mirror;
        }
        println!(
            "{:<10} {:<22} {:>10.1} {:>11.1}  (mip chain not included)",
            format!("{size}x{size}"),
            "total",
            g,
            m
        );
    }
    empty_tiles(&ctx, &cones);
    // Error beside time: the frame at 256x256 against a 64-spp reference (whose own noise is part of it).
    let mut scene = Scene::cornell_box();
    scene.materials[0].specular = [0.3; 3];
    scene.materials[0].shininess = 64.0;
    let (r, ms) = timed(|| vxgi::render::render(&ctx, &scene, &cones, |_| {}).expect("render"));
    let reference = vxgi::reference::render_reference(
        &scene,
        &vxgi::reference::ReferenceOptions {
            spp: 64,
            seed: 1,
            jitter: true,
            ..Default::default()
        },
        |_| {},
    );
    let p = std::path::Path::new("");
    let c = vxgi::images::compare(
        &vxgi::images::RgbImage::new(256, 256, reference.combined()),
        p,
        &r.combined,
        p,
    )
    .expect("compare");
    println!("256x256 frame {ms:.0} ms wall clock (transfers included): combined FLIP {:.3}, relative MSE {:.3} vs 64 spp", c.flip_mean, c.rel_mse);
}

/// The planner's empty-tile rule on a sparse view (the Cornell box seen from 3x as far: most of the
/// screen is background): cone_trace dispatched over screen_tiles' list vs over a list of every tile
/// (what a plain dispatch runs), same pyramid, same image.
fn empty_tiles(ctx: &GpuContext, cones: &ConeSettings) {
    let mut scene = Scene::cornell_box();
    scene.camera.eye = [0.0, 1.0, 11.0];
    let listed = cone_trace::scene_case(ctx, &scene, cones).expect("cone pass");
    let every = vxgi::kernels::screen_tiles::every_tile(&listed);
    let count = |c: &vxgi::harness::Case| c.resources["tile_list"].buffer().unwrap().as_u32()[3];
    let image = |case| cone_trace::run_case(ctx, &cone_trace::DECL, case).unwrap();
    assert_eq!(image(&listed), image(&every), "same image either way");
    let (on, off) = (
        gpu_ms(ctx, &cone_trace::DECL, &listed),
        gpu_ms(ctx, &cone_trace::DECL, &every),
    );
    let (w, h) = (scene.camera.width, scene.camera.height);
    println!(
        "empty tiles, Cornell box from 11 units ({w}x{h}, {} of {} tiles hold a surface): cone_trace {on:.1} ms over the list vs {off:.1} ms over every tile (same image)",
        count(&listed),
        count(&every)
    );
}
