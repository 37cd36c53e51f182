//! The cprc stages like the paper's Fig. 4 (distribution, creation, evaluation) on the Cornell box at
//! 256x256 and 512x512 (16-pixel tiles, 16^2 caches): for creation, pre-convolution and the gather,
//! the GPU's kernel time (timestamps where the adapter has them) against the mirror's (rayon) on the
//! same inputs; for the distribution (six kernels chained on GPU-resident buffers), wall clock of the
//! chain (upload and readback included) against the mirrors' (`cargo bench --bench distribution` times
//! its kernels one by one). The paper:
//! 31 ms distribution, 39 ms creation, 33.5 ms evaluation at 2 Mpx with 4096 caches on a GTX 670.
//!
//! `cargo bench --bench cprc_stages`
mod common;

use common::{gpu_ms, timed};
use vxgi::cprc::{self, CprcSettings};
use vxgi::harness::GpuContext;
use vxgi::kernels::cone_trace::{cone_params, gpu_pyramid, ConeSettings};
use vxgi::kernels::{cache_creation, cache_preconvolve, gather_caches, voxel_light, voxelize};
use vxgi::scene::Scene;
use vxgi::trace::SceneData;

fn main() {
    let ctx = GpuContext::new().expect("GPU adapter (see README: install mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.describe());
    for side in [256u32, 512] {
        let mut scene = Scene::cornell_box();
        scene.camera.width = side;
        scene.camera.height = side;
        let s = CprcSettings::from(&scene.render);
        let data = SceneData::new(&scene);
        let gb = vxgi::kernels::direct_light::gpu_gbuffer(&ctx, &data);
        let (grid, list, frame) =
            voxelize::voxelize_on_gpu(&ctx, &scene, scene.render.voxels).expect("voxelize");
        let lit = voxel_light::light_on_gpu(&ctx, &data, &grid, &list, &frame).expect("light");
        let pyramid = gpu_pyramid(&ctx, &lit, &grid.normal, frame.side).expect("mips");
        let cone = cone_params(&frame, &ConeSettings::from(&scene.render));
        let offset = cone.offset_voxels * cone.origin[3];
        let (pos, nrm, tri, alb) = cprc::gbuffer_arrays(&gb);
        let px = cprc::pixel_inputs(&data, &pos, &nrm, &tri, &alb, s.res);

        cprc::distribute_gpu(&ctx, &px, &s, offset).expect("warm-up");
        let (set, d_gpu) = timed(|| cprc::distribute_gpu(&ctx, &px, &s, offset).expect("GPU"));
        let (_, d_mirror) = timed(|| cprc::distribute_mirror(&px, &s, offset).expect("mirror"));

        let creation = cache_creation::case_for(
            &ctx,
            &pyramid,
            &cone,
            &set.creation,
            s.res,
            "bench".into(),
            0,
        );
        let c_gpu = gpu_ms(&ctx, &cache_creation::DECL, &creation);
        let (radiance, c_mirror) = timed(|| cache_creation::mirror_texels(&creation.resources).0);

        let pre = cache_preconvolve::case_for(&ctx, &radiance, s.res, s.irr, "bench".into(), 0);
        let p_gpu = gpu_ms(&ctx, &cache_preconvolve::DECL, &pre);
        let (maps, p_mirror) = timed(|| {
            use vxgi::harness::Kernel;
            cache_preconvolve::CachePreconvolve.mirror(
                &pre,
                &pre.resources,
                vxgi::harness::FloatMode::Ieee,
            )
        });
        let f4 = |name: &str| -> Vec<[f32; 4]> { bytemuck::cast_slice(&maps[name].bytes).to_vec() };
        let gdata = cprc::gather_data(&px, &set, &s, f4("cache_irradiance"), f4("cache_mips"));
        let gshader = gather_caches::DECL.shader().expect("WGSL");
        let gcase = gather_caches::case_for(&gshader, &ctx, &gdata, "bench".into(), 0);
        let g_gpu = gpu_ms(&ctx, &gather_caches::DECL, &gcase);
        let (_, g_mirror) = timed(|| gather_caches::mirror_outputs(&gcase.resources).len());

        eprintln!(
            "\n{side}x{side} Cornell box, {} caches of {}^2 texels ({}^2 irradiance), tiles {}^2, radius {} px:",
            set.caches.pos.len(),
            s.res,
            s.irr,
            s.tile,
            s.radius_px
        );
        eprintln!("  {:<32} {:>10} {:>11}", "stage", "GPU ms", "mirror ms");
        for (name, g, m) in [
            ("distribution (wall clock, chain)", d_gpu, d_mirror),
            ("creation (cache_creation)", c_gpu, c_mirror),
            ("pre-convolution", p_gpu, p_mirror),
            ("evaluation (gather_caches)", g_gpu, g_mirror),
        ] {
            eprintln!("  {name:<32} {g:>10.2} {m:>11.2}");
        }
        eprintln!(
            "  (GPU timing: {}; mirrors on {} threads)",
            if ctx.timestamps {
                "timestamps"
            } else {
                "wall clock"
            },
            rayon::current_num_threads()
        );
    }
}
