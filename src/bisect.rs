//! The bisection switch (DESIGN.md section 3, after Vello's CPU/GPU stage switch): a vct-dense or
//! vct-svo frame whose first stages run on the scalar mirrors and the rest on the GPU, each GPU stage
//! fed what the mirrors produced. `vxgi bisect` renders the frame at every split and compares each with the
//! all-mirror frame: the first split whose image departs names the kernel to look at, on the real
//! scene rather than on generated cases.
use crate::harness::{GpuContext, HostBuffer, HostResource, Resources, ScalarKind};
use crate::images::RgbImage;
use crate::kernels::cone_trace::{self, ConeSettings};
use crate::kernels::{direct_light, voxel_light, voxelize};
use crate::kernels::{sparse_voxel_octree as svo, svo_anisotropic, svo_cone_trace, svo_photons};
use crate::pipeline::Split;
use crate::render::{Pipeline, Rendered};
use crate::scene::Scene;
use crate::trace::SceneData;
use anyhow::{Context, Result};

/// The stages of `pipeline`'s frame for `scene` at which bisect splits, in order: `render_split(..,
/// k)` runs the first `k` on the mirrors. Its declaration's stages that split ([`Split`]) and that
/// the frame's plan lists (vct-svo: photons or voxel_light, directional values and lobes only where
/// they run).
pub fn stages(
    pipeline: Pipeline,
    scene: &Scene,
    cones: &ConeSettings,
) -> Result<Vec<&'static str>> {
    match pipeline {
        Pipeline::VctSvo => anyhow::ensure!(
            scene.render.bounces == 1,
            "bisect follows one bounce (bounces = {})",
            scene.render.bounces
        ),
        Pipeline::Lrsm => anyhow::ensure!(
            scene.render.shadow_cone_angle == 0.0,
            "bisect follows lrsm with exact shadow rays (shadow_cone_angle = {}; set it to 0)",
            scene.render.shadow_cone_angle
        ),
        _ => {}
    }
    let plan = pipeline.plan(scene, cones, false);
    Ok(pipeline
        .decl()
        .stages
        .iter()
        .filter(|s| match s.split {
            Split::Always => plan.passes.iter().any(|p| p.stage == s.name),
            Split::WhenRun => plan.runs(s.name),
            Split::Never => false,
        })
        .map(|s| s.name)
        .collect())
}

/// The split that runs the mirrors up to and including `stage`, or an error naming the stages.
pub fn split_after(stages: &[&str], stage: &str) -> Result<usize> {
    stages
        .iter()
        .position(|s| *s == stage)
        .map(|k| k + 1)
        .with_context(|| {
            format!(
                "no stage `{stage}` in this frame; stages: {}",
                stages.join(", ")
            )
        })
}

/// `pipeline`'s frame with its first `split` [`stages`] on the mirrors and the rest on the GPU (0: all
/// GPU, stage by stage; all: all mirror). `plan`'s reasons say which side ran each stage (`mirror:` /
/// `GPU:`). No reuse, no chain, every level built: every split computes the same quantities. A scene
/// with instances is voxelized as its flattened mesh (the per-instance hierarchies of vct-dense and
/// cprc frames are not split).
pub fn render_split(
    ctx: &GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    pipeline: Pipeline,
    split: usize,
    progress: impl Fn(&str),
) -> Result<Rendered> {
    let order = stages(pipeline, scene, cones)?;
    anyhow::ensure!(
        split <= order.len(),
        "split {split} past the {} stages",
        order.len()
    );
    let on_mirror = |stage: &str| order[..split].contains(&stage);
    let data = SceneData::new(scene);
    let (w, h) = (data.width(), data.height());
    let mut stages = Vec::new();
    let mut timed = |name: &'static str, secs: f64| stages.push((name, secs));
    let f4 = |v: &[[f32; 4]]| HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(v)));

    progress("gbuffer");
    let t = std::time::Instant::now();
    let gb: Resources = if on_mirror("gbuffer") {
        let (texels, albedo) = crate::render::mirror_texels(&data);
        let field = |f: fn(&vxgi_cpu_mirror::gbuffer::Texel) -> [f32; 4]| {
            f4(&texels.iter().map(f).collect::<Vec<_>>())
        };
        let triangles: Vec<u32> = texels.iter().map(|t| t.triangle).collect();
        Resources::from([
            ("gb_position".to_string(), field(|t| t.position)),
            ("gb_normal".to_string(), field(|t| t.normal)),
            (
                "gb_triangle".to_string(),
                HostResource::Buffer(HostBuffer::u32(&triangles)),
            ),
            ("gb_albedo".to_string(), f4(&albedo)),
        ])
    } else {
        direct_light::gpu_gbuffer(ctx, &data)
    };
    timed("gbuffer", t.elapsed().as_secs_f64());

    progress("direct_light");
    let t = std::time::Instant::now();
    let dcase = direct_light::case_with_gbuffer(ctx, &data, &gb, "bisect".into(), 0);
    let direct: Vec<[f32; 4]> = if on_mirror("direct_light") {
        direct_light::mirror_direct(&dcase.resources).0
    } else {
        run_one(ctx, &direct_light::DECL, &dcase, "radiance")?
    };
    timed("direct_light", t.elapsed().as_secs_f64());

    progress("voxelize");
    let t = std::time::Instant::now();
    let side = scene.render.voxels;
    // lrsm's voxels are binary: its voxelize stage writes occupancy bits alone (no accumulators).
    let mut bits = Vec::new();
    let (grid, list, frame) = if pipeline == Pipeline::Lrsm {
        let (input, frame) = voxelize::prepare(scene, side)?;
        bits = if on_mirror("voxelize") {
            vxgi_cpu_mirror::voxelize::occupancy(&input.tris, side)
        } else {
            voxelize::occupancy_of_input(ctx, &input, side)?
        };
        let empty = crate::grids::Grid {
            n: side,
            colour: Vec::new(),
            normal: Vec::new(),
        };
        (empty, Vec::new(), frame)
    } else if on_mirror("voxelize") {
        let (input, frame) = voxelize::prepare(scene, side)?;
        let (colour, normal, list) = vxgi_cpu_mirror::voxelize::voxelize(&input, side);
        let grid = crate::grids::Grid {
            n: side,
            colour,
            normal,
        };
        (grid, list, frame)
    } else {
        voxelize::voxelize_on_gpu(ctx, scene, side)?
    };
    timed("voxelize", t.elapsed().as_secs_f64());

    let [indirect, ao] = match pipeline {
        Pipeline::VctSvo => svo_tail(
            ctx, scene, cones, &order, &data, &gb, &grid, &list, &frame, &on_mirror, &mut timed,
            &progress,
        )?,
        Pipeline::Lrsm => {
            let settings = crate::kernels::lrsm_cone_trace::LrsmSettings::from(&scene.render);
            let mut lrsm_stages = Vec::new();
            let built = crate::kernels::lrsm_cone_trace::LrsmFrame::build_with(
                Some(ctx),
                &on_mirror,
                &data,
                &bits,
                frame,
                &settings,
                &progress,
                &mut lrsm_stages,
            )?;
            for (name, secs) in lrsm_stages {
                timed(name, secs);
            }
            progress("lrsm_cone_trace");
            let t = std::time::Instant::now();
            let params = cone_trace::cone_params(&built.voxels, cones);
            let case = crate::kernels::lrsm_cone_trace::case_for(
                &data,
                &gb,
                &built,
                &params,
                0.0,
                "bisect".into(),
                0,
            );
            let decl = &crate::kernels::lrsm_cone_trace::DECL;
            let out = cones_of(ctx, decl, &case, on_mirror("lrsm_cone_trace"), || {
                let vol = built.volume(&params);
                cone_trace::shade_all(&case.resources, &vol, vol.lmax)
            })?;
            timed("lrsm_cone_trace", t.elapsed().as_secs_f64());
            out
        }
        _ => {
            progress("voxel_light");
            let t = std::time::Instant::now();
            let radiance = lit(ctx, &data, &grid, &list, &frame, on_mirror("voxel_light"))?;
            timed("voxel_light", t.elapsed().as_secs_f64());

            progress("surface_coverage_mip");
            let t = std::time::Instant::now();
            let pyramid = if on_mirror("surface_coverage_mip") {
                cone_trace::mirror_pyramid(&radiance, &grid.normal)
            } else {
                cone_trace::gpu_pyramid(ctx, &radiance, &grid.normal, side)?
            };
            timed("surface_coverage_mip", t.elapsed().as_secs_f64());

            if pipeline == Pipeline::Cprc {
                cprc_tail(
                    ctx, scene, cones, &data, &gb, &pyramid, &frame, &on_mirror, &mut timed,
                    &progress,
                )?
            } else {
                progress("cone_trace");
                let t = std::time::Instant::now();
                let params = cone_trace::cone_params(&frame, cones);
                let ccase = cone_trace::case_for(&data, &gb, &pyramid, &params, "bisect".into(), 0);
                let out = cones_of(
                    ctx,
                    &cone_trace::DECL,
                    &ccase,
                    on_mirror("cone_trace"),
                    || cone_trace::mirror_cones(&ccase.resources),
                )?;
                timed("cone_trace", t.elapsed().as_secs_f64());
                out
            }
        }
    };

    let rgb = |v: &[[f32; 4]]| RgbImage::new(w, h, v.iter().map(|p| [p[0], p[1], p[2]]).collect());
    let mut plan = pipeline.plan(scene, cones, false);
    for p in &mut plan.passes {
        let side = if on_mirror(p.stage) { "mirror" } else { "GPU" };
        p.why = format!("{side}: {}", p.why);
    }
    Ok(Rendered::assemble(
        rgb(&direct),
        rgb(&indirect),
        rgb(&ao),
        stages,
        plan,
    ))
}

/// The lit voxel grid `(L * alpha, alpha)`: voxel_light on the mirror or the GPU.
fn lit(
    ctx: &GpuContext,
    data: &SceneData,
    grid: &crate::grids::Grid,
    list: &[u32],
    frame: &voxelize::VoxelFrame,
    mirror: bool,
) -> Result<Vec<[f32; 4]>> {
    if mirror {
        let case = voxel_light::case_for(ctx, data, grid, list, frame, "bisect".into(), 0);
        Ok(voxel_light::mirror_radiance(&case.resources).0)
    } else {
        voxel_light::light_on_gpu(ctx, data, grid, list, frame)
    }
}

/// A cone pass's (indirect, ao): its mirror, or `decl` on the GPU.
fn cones_of(
    ctx: &GpuContext,
    decl: &crate::harness::KernelDecl,
    case: &crate::harness::Case,
    mirror: bool,
    on_mirror: impl FnOnce() -> Vec<vxgi_cpu_mirror::cone_trace::PixelOut>,
) -> Result<[Vec<[f32; 4]>; 2]> {
    if mirror {
        Ok(cone_trace::indirect_and_ao(&on_mirror()))
    } else {
        Ok(cone_trace::run_case(ctx, decl, case)?.map(|b| bytemuck::cast_slice(&b).to_vec()))
    }
}

/// vct-svo after voxelize: light (photons or voxel_light), the octree, its directional values (which of
/// them: the frame's stages `order`), the cone pass, each on the side `on_mirror` says.
#[allow(clippy::too_many_arguments)]
fn svo_tail(
    ctx: &GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    order: &[&str],
    data: &SceneData,
    gb: &Resources,
    grid: &crate::grids::Grid,
    list: &[u32],
    frame: &voxelize::VoxelFrame,
    on_mirror: &impl Fn(&str) -> bool,
    timed: &mut impl FnMut(&'static str, f64),
    progress: &impl Fn(&str),
) -> Result<[Vec<[f32; 4]>; 2]> {
    use svo_cone_trace::{grid_fragments, svo_cone_params};
    let lobes = order.contains(&"svo_lobes");
    let mut spec_frags = Vec::new();
    let (grid_values, photons) = if order.contains(&"svo_photons") {
        progress("svo_photons");
        let t = std::time::Instant::now();
        // The voxels' coverage; the light comes from the photons.
        let map = scene.render.photon_map;
        let photons = if on_mirror("svo_photons") {
            svo_photons::mirror_photons(data, frame, map)?
        } else {
            svo_photons::photons_on_gpu(ctx, data, frame, map)?
        };
        timed("svo_photons", t.elapsed().as_secs_f64());
        (svo_cone_trace::coverage_only(&grid.colour), Some(photons))
    } else {
        progress("voxel_light");
        let t = std::time::Instant::now();
        let radiance = lit(ctx, data, grid, list, frame, on_mirror("voxel_light"))?;
        timed("voxel_light", t.elapsed().as_secs_f64());
        (radiance, None)
    };
    // The fixed point of the frames bisected: the one every split's values fit (as render's).
    let scale = svo_cone_trace::fixed_scale(
        svo_cone_trace::grid_values(&grid_values).chain(photons.iter().flat_map(|p| p.values())),
        scene.render.bounces,
    );
    let mut frags = grid_fragments(&grid_values, scale)?;
    if let Some(photons) = &photons {
        spec_frags = photons.fragments(scale)?.join_into(&mut frags, lobes);
    }

    progress("sparse_voxel_octree");
    let t = std::time::Instant::now();
    let depth = frame.side.trailing_zeros() - 1;
    let octree = if on_mirror("sparse_voxel_octree") {
        vxgi_cpu_mirror::sparse_voxel_octree::build_fitted(depth, &frags)
    } else {
        svo::build_on_gpu(ctx, depth, &frags, None)?.octree
    };
    timed("sparse_voxel_octree", t.elapsed().as_secs_f64());

    let aniso = if order.contains(&"svo_anisotropic") {
        progress("svo_anisotropic");
        let t = std::time::Instant::now();
        let a = if on_mirror("svo_anisotropic") {
            crate::kernels::svo_anisotropic::build_mirror(&octree, 1.0 / scale)
        } else {
            svo_anisotropic::build_on_gpu(ctx, &octree, 1.0 / scale)?
        };
        timed("svo_anisotropic", t.elapsed().as_secs_f64());
        Some(a)
    } else {
        None
    };

    let (normals, spec) = if lobes {
        progress("svo_lobes");
        let t = std::time::Instant::now();
        // The voxels' coverage (alpha) and mean normals; the specular photons.
        let (coverage, normal) = (&grid.colour, &grid.normal);
        let side = (!on_mirror("svo_lobes")).then_some(ctx);
        let (n, g) = svo_cone_trace::lobe_pools(
            side,
            &octree,
            &frags,
            [coverage, normal],
            &spec_frags,
            scale,
        )?;
        timed("svo_lobes", t.elapsed().as_secs_f64());
        (Some(n), g)
    } else {
        (None, None)
    };

    progress("svo_cone_trace");
    let t = std::time::Instant::now();
    let params = svo_cone_params(frame, cones);
    let extras = svo_cone_trace::SvoExtras {
        aniso: aniso.as_deref(),
        normals: normals.as_deref(),
        spec: spec.as_deref(),
    };
    let case = svo_cone_trace::case_for(
        data,
        gb,
        &octree,
        extras,
        scale,
        &params,
        "bisect".into(),
        0,
    );
    let out = cones_of(
        ctx,
        &svo_cone_trace::DECL,
        &case,
        on_mirror("svo_cone_trace"),
        || svo_cone_trace::mirror_cones(&case.resources),
    )?;
    timed("svo_cone_trace", t.elapsed().as_secs_f64());
    Ok(out)
}

/// cprc after the radiance pyramid: the cache distribution (six kernels, one GPU chain), then the
/// caches' creation, pre-convolution and the gather (one GPU chain: stage `cache_creation`), each on
/// the side `on_mirror` says; (indirect, ao) composed as the frame does.
#[allow(clippy::too_many_arguments)]
fn cprc_tail(
    ctx: &GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    data: &SceneData,
    gb: &Resources,
    pyramid: &cone_trace::Pyramids,
    frame: &voxelize::VoxelFrame,
    on_mirror: &impl Fn(&str) -> bool,
    timed: &mut impl FnMut(&'static str, f64),
    progress: &impl Fn(&str),
) -> Result<[Vec<[f32; 4]>; 2]> {
    use crate::cprc;
    let settings = cprc::CprcSettings::from(&scene.render);
    let params = cone_trace::cone_params(frame, cones);
    let (pos, nrm, tri, alb) = cprc::gbuffer_arrays(gb);
    let px = cprc::pixel_inputs(data, &pos, &nrm, &tri, &alb, settings.res);
    let offset = params.offset_voxels * params.origin[3];
    progress("cache_distribution");
    let t = std::time::Instant::now();
    let set = if on_mirror("cache_distribution") {
        cprc::distribute_mirror(&px, &settings, offset)?
    } else {
        cprc::distribute_gpu(ctx, &px, &settings, offset)?
    };
    timed("cache_distribution", t.elapsed().as_secs_f64());
    progress("cache_creation");
    let t = std::time::Instant::now();
    let gathered = if on_mirror("cache_creation") {
        cprc::evaluate_mirror(&px, &set, &settings, pyramid, &params)
    } else {
        let volume = cprc::CacheVolume::One(pyramid);
        cprc::evaluate_gpu(
            ctx,
            &px,
            &set,
            &settings,
            volume,
            &params,
            &mut Vec::new(),
            progress,
        )?
    };
    timed("cache_creation", t.elapsed().as_secs_f64());
    let (indirect, ao, _) = cprc::compose(&px, &gathered);
    let vec4 = |img: &RgbImage| img.pixels.iter().map(|p| [p[0], p[1], p[2], 0.0]).collect();
    Ok([vec4(&indirect), vec4(&ao)])
}

/// One output of a one-kernel case run on the GPU, as vec4s.
fn run_one(
    ctx: &GpuContext,
    decl: &crate::harness::KernelDecl,
    case: &crate::harness::Case,
    output: &str,
) -> Result<Vec<[f32; 4]>> {
    let out = decl
        .run(ctx, case, &[output])
        .with_context(|| decl.name.to_string())?;
    let buf = out.buffer(output);
    anyhow::ensure!(buf.scalar == ScalarKind::F32, "{output} is not f32");
    Ok(bytemuck::cast_slice(&buf.bytes).to_vec())
}

/// One row of `vxgi bisect`: the split and how far its images are from the all-mirror frame.
#[derive(Clone, Debug)]
pub struct SplitRow {
    /// Stages on the mirrors: the first `split` of the frame's [`stages`].
    pub split: usize,
    /// (image, mean FLIP vs the all-mirror image, largest absolute channel difference, pixels whose
    /// largest channel difference is above 1e-3 of the image's largest value).
    pub images: Vec<(&'static str, f32, f32, usize)>,
}

/// Render every split (all GPU .. all mirror) and compare each with the all-mirror frame.
pub fn bisect(
    ctx: &GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    pipeline: Pipeline,
    progress: impl Fn(&str),
) -> Result<Vec<SplitRow>> {
    let order = stages(pipeline, scene, cones)?;
    let mirror = render_split(ctx, scene, cones, pipeline, order.len(), &progress)?;
    let mut rows = Vec::new();
    for split in 0..order.len() {
        let r = render_split(ctx, scene, cones, pipeline, split, &progress)?;
        let mut images = Vec::new();
        for (name, a, b) in [
            ("direct", &mirror.direct, &r.direct),
            ("indirect", &mirror.indirect, &r.indirect),
            ("ao", &mirror.ao, &r.ao),
        ] {
            // The images are in memory: name them by frame and image in errors.
            let reference = std::path::PathBuf::from(format!("all-mirror frame, {name} image"));
            let split_name = std::path::PathBuf::from(format!(
                "frame with the mirrors up to stage {split} ({}), {name} image",
                order.get(split).copied().unwrap_or("none")
            ));
            let c = crate::images::compare(a, &reference, b, &split_name)?;
            let diff: Vec<f32> = a
                .pixels
                .iter()
                .zip(&b.pixels)
                .map(|(x, y)| (0..3).map(|k| (x[k] - y[k]).abs()).fold(0.0f32, f32::max))
                .collect();
            let top = a
                .pixels
                .iter()
                .flatten()
                .fold(0.0f32, |m, v| m.max(v.abs()));
            let off = diff.iter().filter(|&&d| d > 1e-3 * top).count();
            images.push((
                name,
                c.flip_mean,
                diff.iter().fold(0.0f32, |m, &d| m.max(d)),
                off,
            ));
        }
        rows.push(SplitRow { split, images });
    }
    Ok(rows)
}

/// `vxgi bisect`'s table for a frame of `stages`.
pub fn table(stages: &[&str], rows: &[SplitRow]) -> String {
    let mut s = String::from(
        "| mirror up to | GPU from | direct: FLIP, max diff, pixels off | indirect | ao |\n|---|---|---|---|---|\n",
    );
    for r in rows {
        let (m, g) = (
            r.split.checked_sub(1).map_or("-", |k| stages[k]),
            stages.get(r.split).copied().unwrap_or("-"),
        );
        let cells: Vec<String> = r
            .images
            .iter()
            .map(|(_, f, d, n)| format!("{f:.5}, {d:.2e}, {n}"))
            .collect();
        s += &format!("| {m} | {g} | {} |\n", cells.join(" | "));
    }
    // The bisection's answer: the latest GPU stage whose split still departs from the mirrors. A
    // split runs the GPU from its stage on, so the departure starts at the first GPU stage of the
    // last departing row whose successor agrees.
    let departs = |r: &SplitRow| r.images.iter().any(|i| i.3 > 0);
    match rows.iter().rposition(departs) {
        Some(k) => {
            s += &format!(
                "first stage whose GPU result departs from its mirror (pixels off by > 1e-3 of the image's largest value): {}\n",
                stages[rows[k].split]
            )
        }
        None => s += "every split agrees with the all-mirror frame to 1e-3 of each image's largest value\n",
    }
    s
}
