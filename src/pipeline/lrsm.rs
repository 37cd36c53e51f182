//! lrsm (Sugihara et al. 2014: layered reflective shadow maps): its declaration, the plan's rules for
//! its stages, and its chain: the binary occlusion voxels and their mips, each light view's
//! G-buffer, RSM and layered RSM, the camera's G-buffer and direct light, the LRSM cone gather.
use super::host::{HostFrame, Side};
use super::*;
use crate::kernels::{
    lit_cells, lrsm_partition, lrsm_prefilter, occlusion_voxels,
    reflective_shadow_map as rsm_kernel,
};

/// lrsm's frame: G-buffer and direct light as vct-dense; the voxel grid becomes binary occlusion
/// voxels and their mips; every light view gets an RSM, then its lit texels go into the occlusion
/// pyramid's cells (`lrsm_lit_cells`, the default) or its layers are built and pre-filtered (the
/// paper's LRSMs); the gather cone-traces occlusion from the voxels and radiance from the lit cells
/// or the LRSMs.
pub static LRSM: PipelineDecl = PipelineDecl {
    name: "lrsm",
    stages: &[
        GBUFFER_STAGE,
        StageDecl {
            plan: lrsm_direct_light_plan,
            ..DIRECT_LIGHT_STAGE
        },
        StageDecl {
            plan: lrsm_voxelize_plan,
            host: Some(lrsm_voxelize_step),
            ..VOXELIZE_STAGE
        },
        StageDecl {
            name: "occlusion_voxels",
            kernels: &[&occlusion_voxels::DECL],
            reuse: Reuse::Geometry,
            split: Split::Always,
            plan: occlusion_plan,
            host: Some(lrsm_volume_step),
        },
        StageDecl {
            name: "reflective_shadow_map",
            // Each light view's G-buffer, then its RSM.
            kernels: &[&crate::kernels::gbuffer::DECL, &rsm_kernel::DECL],
            reuse: Reuse::Lights,
            split: Split::Always,
            plan: |i| light_view_plan(i, "reflective_shadow_map", &["reflective_shadow_map"]),
            // Each view's RSM, then its layers: occlusion_voxels' step.
            host: None,
        },
        StageDecl {
            name: "lrsm_partition",
            kernels: &[&lrsm_partition::DECL, &lrsm_prefilter::DECL],
            reuse: Reuse::Lights,
            split: Split::Always,
            plan: |i| light_view_plan(i, "lrsm_partition", &["lrsm_partition", "lrsm_prefilter"]),
            host: None,
        },
        StageDecl {
            name: "lit_cells",
            kernels: &[&lit_cells::DECL],
            reuse: Reuse::Lights,
            split: Split::Always,
            plan: |i| light_view_plan(i, "lit_cells", &["lit_cells"]),
            host: None,
        },
        StageDecl {
            name: "lrsm_cone_trace",
            kernels: &[&screen_tiles::DECL, &lrsm_cone_trace::DECL],
            reuse: Reuse::Camera,
            split: Split::Always,
            plan: lrsm_cone_trace_plan,
            host: Some(lrsm_cone_trace_step),
        },
    ],
};

const LRSM_CACHED: &str = "skipped: geometry, materials, lights and settings unchanged since the last frame (its occlusion voxels and LRSMs are reused)";

/// With shadow cones (`shadow_cone_angle` > 0) the gather's shadow pass replaces the shadow rays.
fn lrsm_direct_light_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let mut passes = direct_light_plan(i);
    for p in &mut passes {
        if i.lrsm.shadow_cone_angle > 0.0 && p.runs {
            p.runs = false;
            p.why = format!(
                "skipped: shadow cones of {} deg through the occlusion voxels replace the exact shadow rays (lrsm_cone_trace's shadow pass)",
                i.lrsm.shadow_cone_angle
            );
        }
    }
    passes
}

fn lrsm_voxelize_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let mut passes = voxelize_plan(i);
    for p in &mut passes {
        p.why = if p.runs {
            "the occlusion voxels' level 0: a bit per voxel a surface sample lands in (entry occupancy_bits; no accumulators)".into()
        } else {
            LRSM_CACHED.into()
        };
    }
    passes
}

fn occlusion_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let side = i.scene.render.voxels;
    vec![PlannedPass::new(
        "occlusion_voxels",
        "occlusion_voxels",
        format!(
            "{} mip levels over {side}^3 bits (a byte per voxel above level 0)",
            side.trailing_zeros()
        ),
        !i.cached,
        if i.cached {
            LRSM_CACHED
        } else if i.lrsm.surface_coverage {
            "binary occlusion and its surface-coverage mips (lrsm_surface_coverage: thin walls stay opaque; no radiance in the voxels)"
        } else {
            "binary occlusion and its averaged mips (no radiance in the voxels)"
        },
    )]
}

/// A light-view stage's passes, one per kernel: over every view's RSM and layers.
fn light_view_plan(
    i: &PlanInputs,
    stage: &'static str,
    kernels: &[&'static str],
) -> Vec<PlannedPass> {
    let lights = i.scene.lights.len();
    let views = crate::plan::light_views(i.scene);
    let size = if stage == "lit_cells" {
        let cells = lit_cells::table_side(i.scene.render.voxels, i.lrsm.lit_max_side);
        // Several lights casting light add theirs through the cells' area weight (`lit_grid`).
        let casting = (i.scene.lights.iter())
            .filter(|l| crate::plan::views_of(l) > 0)
            .count();
        let weight = if casting <= 1 {
            String::new()
        } else if vxgi_cpu_mirror::lit_cells::weighs_per_cell(i.scene.lights.len()) {
            format!(
                ", each cell's area weighted by the lights reaching it: the {casting} lights add"
            )
        } else {
            format!(", area weighted 1/{casting} (more lights than a cell's mask holds): the {casting} lights add")
        };
        format!(
            "{views} light views x {}^2 RSM into {cells}^3 cells{weight}",
            i.lrsm.rsm_side
        )
    } else {
        format!(
            "{views} light views x {}^2 RSM, {} layers",
            i.lrsm.rsm_side,
            (i.lrsm.depth_splits + 1) * (i.lrsm.normal_splits + 1)
        )
    };
    // Which of the two light structures the gather reads: the other's stage is skipped.
    let lit = i.lrsm.lit_cells;
    let other = match stage {
        "lrsm_partition" if lit => {
            Some("skipped: the gather reads the lit cells (lrsm_lit_cells), not the LRSMs")
        }
        "lit_cells" if !lit => Some("skipped: the gather reads the LRSMs (lrsm_lit_cells = false)"),
        _ => None,
    };
    let why = if i.cached {
        LRSM_CACHED
    } else if lights == 0 {
        "skipped: no lights, no RSM (indirect is 0)"
    } else if let Some(skip) = other {
        skip
    } else {
        match stage {
            "lrsm_partition" => "each view's RSM split into layers and pre-filtered (the paper's LRSMs)",
            "lit_cells" => "each view's lit RSM texels into the occlusion pyramid's level-0 cells, then summed up the levels",
            _ => "each view's RSM from the light (point lights: six cube faces; directional: orthographic)",
        }
    };
    let runs = !i.cached && lights > 0 && other.is_none();
    kernels
        .iter()
        .map(|k| PlannedPass::new(stage, k, size.clone(), runs, why))
        .collect()
}

fn lrsm_cone_trace_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let mut p = cone_trace_plan(i).remove(0);
    p.stage = "lrsm_cone_trace";
    p.kernel = "lrsm_cone_trace";
    let views = crate::plan::light_views(i.scene);
    p.why = format!(
        "{}; radiance from {}, read only where a sample has occlusion{}",
        p.why,
        if i.lrsm.lit_cells {
            format!("the lit cells of {views} light views")
        } else {
            format!("{views} LRSM views")
        },
        if i.lrsm.shadow_cone_angle > 0.0 && !i.scene.lights.is_empty() {
            "; + direct light with one shadow cone per light"
        } else {
            ""
        }
    );
    vec![p]
}

/// lrsm's light views of `lights` (the GPU's lights of the scene; `bounds` and `eps` from its
/// [`SceneData`]), each with its first texel in the concatenated LRSM streams (`view.info[2]`): view
/// `i` starts at `i` times one view's streams ([`crate::lrsm::lrsm_texels`]), as
/// `LrsmFrame::build_with` concatenates them.
pub(crate) fn lrsm_views(
    lights: &[vxgi_cpu_mirror::direct_light::GpuLight],
    bounds: (glam::Vec3, glam::Vec3),
    eps: f32,
    config: &PartitionConfig,
) -> Result<Vec<LightView>> {
    let per_view = crate::lrsm::lrsm_texels(config);
    let mut views = crate::lrsm::light_views(lights, bounds, config.rsm_side, eps)?;
    for (i, v) in views.iter_mut().enumerate() {
        v.view.info[2] = u32::try_from(i as u64 * per_view)
            .context("the LRSM streams of every light view past 2^32 texels")?;
    }
    Ok(views)
}

/// The names of light view `v`'s own inputs: its G-buffer frame and its projection.
pub(crate) fn light_view_names(v: usize) -> (String, String) {
    (format!("light_frame_{v}"), format!("light_view_{v}"))
}

/// The LRSM streams the gather reads, in the order of the prefilter's streams.
const LRSM_STREAMS: [&str; 3] = ["lrsm_radiance", "lrsm_normal", "lrsm_moments"];

/// lrsm's chain (Sugihara et al. 2014): voxelize's occupancy bits and occlusion_voxels' mips over them
/// (every level copied into `occ`);
/// per light view the G-buffer ray-cast from the light, reflective_shadow_map, lrsm_partition and
/// lrsm_prefilter (its levels copied into the three LRSM streams at the view's offset; every view
/// reuses one set of RSM buffers: one RSM at a time); then the camera's
/// gbuffer, direct_light (exact shadow rays; not with shadow cones, whose soft direct light the
/// gather's shadow pass writes), screen_tiles and lrsm_cone_trace. Needs lights.
pub(crate) fn lrsm_chain(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    data: &SceneData,
    cones: &ConeSettings,
) -> Result<(Chain, LrsmMemory)> {
    use crate::kernels::{
        gbuffer, lrsm_partition, lrsm_prefilter, occlusion_voxels as occv,
        reflective_shadow_map as rsmk,
    };
    use vxgi_cpu_mirror::occlusion_voxels::level_words;
    let settings = LrsmSettings::from(&scene.render);
    let config = settings.partition();
    config.validate(ctx.limits().max_storage_buffer_binding_size)?;
    let side = scene.render.voxels;
    let (mesh, vframe, setup) = super::vct_dense::setup_case(ctx, scene)?;
    let mut chain = Chain {
        resources: Resources::new(),
        stages: Vec::new(),
        copies: Vec::new(),
        frame: vframe,
    };
    // The mesh on voxelize's lattice (triangle_setup), then voxelize's occupancy bits: level 0 of
    // the occlusion voxels (the same resource), their mips follow; every level is copied into `occ`.
    chain.add(&triangle_setup::DECL, voxelize::DECL.name, setup)?;
    let tris = voxelize::Triangles::Setup(&mesh);
    let mut vox = voxelize::occupancy_case(ctx, tris, side, "render".into(), 0)?;
    vox.rename_resource("params", "vox_params", false);
    vox.rename_resource("occupancy", &occv::level_name(0), false);
    chain.add(&voxelize::DECL, voxelize::DECL.name, vox)?;
    let coverage = if settings.surface_coverage {
        vxgi_cpu_mirror::occlusion_voxels::Coverage::Surface
    } else {
        vxgi_cpu_mirror::occlusion_voxels::Coverage::Volume
    };
    let zero_bits = vec![0u32; level_words(side, 0)];
    let occ_shader = occv::DECL.shader()?;
    let occ = occv::case_for(
        &occ_shader,
        ctx,
        &zero_bits,
        side,
        coverage,
        "render".into(),
        0,
    );
    chain.add(&occv::DECL, occv::DECL.name, occ)?;
    let mut occ_offsets = Vec::new();
    let mut words = 0u32;
    for k in 0..=side.trailing_zeros() {
        occ_offsets.push(words);
        chain.copies.push(ChainCopy {
            src_range: None,
            after: chain.pass_count(),
            src: occv::level_name(k),
            dst: "occ".into(),
            offset: words as u64 * 4,
        });
        words += level_words(side, k) as u32;
    }
    // Every light view: its G-buffer, RSM and LRSM, into the streams at its offset.
    let views = lrsm_views(&data.lights, data.bounds, data.frame.eye[3], &config)?;
    let per_view = crate::lrsm::lrsm_texels(&config);
    let rsm_side = config.rsm_side;
    let texels = (rsm_side as usize).pow(2);
    let side0 = rsm_side / 2;
    let levels = side0.trailing_zeros() + 1;
    let rsm_gb = |n: &str| format!("rsm_{n}");
    // One parsed shader per stage (a stage owns its shader); the cases read these for reflection.
    let (rshader, pshader) = (rsmk::DECL.shader()?, lrsm_partition::DECL.shader()?);
    let fshader = lrsm_prefilter::DECL.shader()?;
    const RSM: &str = "reflective_shadow_map";
    const PARTITION: &str = "lrsm_partition";
    const LIT: &str = "lit_cells";
    // With lit cells: level 0 cleared before the first view, each view injected after its RSM,
    // the levels above reduced after the last, every level a window of the gather's `lit`. No
    // light view, no lit cell: the gather reads the zeroed table.
    let lit_shader = lit_cells::DECL.shader()?;
    let (lit_grid, _) = settings.lit_grid(&vframe, &data.lights, data.bounds);
    let lit_side = lit_grid.size[0];
    let lit_levels = lit_cells::Levels::Windows {
        buffer: "lit",
        side: lit_side,
    };
    let injects = settings.lit_cells && !views.is_empty();
    if injects {
        chain.merge(lit_cells::DECL.name, lit_cells::grid_resource(&lit_grid))?;
        chain.push_as(
            lit_cells::DECL.shader()?,
            lit_cells::DECL.name,
            LIT,
            vec![lit_cells::clear_pass(
                &lit_shader,
                ctx,
                lit_side,
                lit_levels,
            )],
        );
    }
    for (v, view) in views.iter().enumerate() {
        let (frame_name, view_name) = light_view_names(v);
        let mut d = data.clone();
        d.frame = view.frame;
        let mut g = gbuffer::case_for(&d, "light view".into(), 0);
        g.rename_resource("frame", &frame_name, false);
        for n in ["gb_position", "gb_normal", "gb_triangle", "gb_albedo"] {
            g.rename_resource(n, &rsm_gb(n), false);
        }
        let zero_gb: Resources = ["gb_position", "gb_normal", "gb_albedo"]
            .into_iter()
            .map(|n| (n.to_string(), g.resources[&rsm_gb(n)].clone()))
            .collect();
        chain.add(&gbuffer::DECL, RSM, g)?;
        let mut r = rsmk::case_for(
            &rshader,
            ctx,
            &data.lights,
            view,
            &zero_gb,
            "render".into(),
            0,
        );
        r.rename_resource("view", &view_name, false);
        for n in ["gb_position", "gb_normal", "gb_albedo"] {
            r.rename_resource(n, &rsm_gb(n), false);
        }
        chain.add(&rsmk::DECL, RSM, r)?;
        if injects {
            let names = lit_cells::ViewNames {
                view: view_name,
                rsm: ["rsm_radiance", "rsm_normal", "rsm_depth"].map(String::from),
            };
            let pass = lit_cells::inject_pass(&lit_shader, ctx, v, &names, rsm_side, lit_levels);
            chain.push_as(
                lit_cells::DECL.shader()?,
                lit_cells::DECL.name,
                LIT,
                vec![pass],
            );
            continue;
        }
        let zero_rsm = crate::lrsm::Rsm {
            side: rsm_side,
            radiance: vec![[0.0; 4]; texels],
            normal: vec![[0.0; 4]; texels],
            depth: vec![0.0; texels],
        };
        let mut p =
            lrsm_partition::case_for(&pshader, ctx, &zero_rsm, &config, "render".into(), 0)?;
        p.rename_resource("params", "partition_params", false);
        for (s, out) in ["out_radiance", "out_normal", "out_moments"]
            .iter()
            .enumerate()
        {
            p.rename_resource(out, &lrsm_prefilter::stream_name(s, 0), false);
        }
        chain.add(&lrsm_partition::DECL, PARTITION, p)?;
        if levels > 1 {
            let n0 = (config.layers() as u64 * (side0 as u64).pow(2)) as usize;
            let level0: [Vec<[f32; 4]>; 3] = std::array::from_fn(|_| vec![[0.0; 4]; n0]);
            let f = lrsm_prefilter::chain_case(
                &fshader,
                ctx,
                &level0,
                config.layers(),
                side0,
                "render".into(),
                0,
            );
            chain.add(&lrsm_prefilter::DECL, PARTITION, f)?;
        }
        let after = chain.pass_count();
        let mut first = v as u64 * per_view;
        for k in 0..levels {
            for (s, dst) in LRSM_STREAMS.iter().enumerate() {
                chain.copies.push(ChainCopy {
                    src_range: None,
                    after,
                    src: lrsm_prefilter::stream_name(s, k),
                    dst: dst.to_string(),
                    offset: first * lrsm_prefilter::TEXEL_BYTES,
                });
            }
            first += config.layers() as u64 * ((side0 >> k) as u64).pow(2);
        }
    }
    let mut lit_offsets = Vec::new();
    if settings.lit_cells {
        if injects {
            let mut passes = vec![lit_cells::resolve_pass(
                &lit_shader,
                ctx,
                lit_side,
                lit_levels,
            )];
            passes.extend(lit_cells::reduce_passes(
                &lit_shader,
                ctx,
                lit_side,
                lit_levels,
            ));
            chain.push_as(lit_shader, lit_cells::DECL.name, LIT, passes);
        }
        lit_offsets = lit_cells::level_offsets(lit_side);
    }
    // The camera's G-buffer and direct light, then the gather over the tiles screen_tiles lists.
    let g = gbuffer::case_for(data, "render".into(), 0);
    let camera_gb = g.resources.clone();
    chain.add(&gbuffer::DECL, gbuffer::DECL.name, g)?;
    let soft = settings.shadow_cone_angle > 0.0;
    if !soft {
        let d = direct_light::case_with_gbuffer(ctx, data, &Default::default(), "render".into(), 0);
        chain.add(&direct_light::DECL, direct_light::DECL.name, d)?;
    }
    let streams = if settings.lit_cells {
        0
    } else {
        views.len() as u64
    };
    let stream = vec![[0.0f32; 4]; (per_view * streams) as usize];
    let frame = LrsmFrame {
        voxels: vframe,
        occ: vec![0; words as usize],
        occ_offsets,
        views: views.iter().map(|v| v.view).collect(),
        params: settings.sample_params(&vframe),
        depth_ranges: config.depth_ranges(),
        streams: [stream.clone(), stream.clone(), stream],
        memory: LrsmMemory::default(),
        lit_offsets,
        // The table is the chain's own zeroed buffer (below), not a host copy.
        lit: Vec::new(),
    };
    let memory = LrsmMemory::of(&frame, rsm_side);
    let params = cone_trace::cone_params(&vframe, cones);
    let tan = if soft {
        settings.shadow_cone_angle.to_radians().tan()
    } else {
        0.0
    };
    let mut c =
        lrsm_cone_trace::case_for(data, &camera_gb, &frame, &params, tan, "render".into(), 0);
    if settings.lit_cells {
        c.resources
            .insert("lit".into(), lit_cells::zeroed_table(lit_side).into());
    }
    push_tiled_cone_pass(
        &mut chain,
        data,
        &lrsm_cone_trace::DECL,
        lrsm_cone_trace::DECL.name,
        c,
    )?;
    Ok((chain, memory))
}

/// lrsm's voxelization: occupancy bits alone (binary voxels, no accumulators).
pub(crate) fn lrsm_voxelize_step(f: &mut HostFrame) -> Result<()> {
    let side = f.scene.render.voxels;
    let (input, frame) = voxelize::prepare(f.scene, side)?;
    f.bits = match f.side("voxelize") {
        Side::Mirror => vxgi_cpu_mirror::voxelize::occupancy(&input.tris, side),
        Side::Gpu(ctx) => voxelize::occupancy_of_input(ctx, &input, side)?,
    };
    f.frame = frame;
    Ok(())
}

/// The occlusion voxels' mips, then each light view's RSM and its layers in turn (the steps of
/// `occlusion_voxels`, `reflective_shadow_map` and `lrsm_partition`, each on its own side).
pub(crate) fn lrsm_volume_step(f: &mut HostFrame) -> Result<()> {
    let settings = LrsmSettings::from(&f.scene.render);
    f.lrsm = Some(LrsmFrame::build_with(
        f.ctx,
        f.on_mirror,
        &f.data,
        &f.bits,
        f.frame,
        &settings,
        f.progress,
        &mut f.stages,
    )?);
    Ok(())
}

/// The gather: occlusion from the voxels, radiance from the LRSMs.
pub(crate) fn lrsm_cone_trace_step(f: &mut HostFrame) -> Result<()> {
    let built = f.lrsm.as_ref().expect("the LRSMs before the gather");
    let params = cone_trace::cone_params(&built.voxels, f.cones);
    f.cones_out = Some(match f.side("lrsm_cone_trace") {
        Side::Mirror => {
            let vol = built.volume(&params);
            f.shade(&vol, vol.lmax)
        }
        Side::Gpu(ctx) => {
            let case =
                lrsm_cone_trace::case_for(&f.data, &f.gb, built, &params, 0.0, "host".into(), 0);
            super::host::gpu_cones(ctx, &lrsm_cone_trace::DECL, &case)?
        }
    });
    Ok(())
}
