//! vct-dense (Crassin et al. 2011 on a dense grid): its declaration, the plan's rules for its stages
//! (cprc, vct-svo and lrsm share the first ones), its chain (the volume: voxelize, voxel_light, the
//! mip chain; the camera's G-buffer and direct light; the cone pass over the screen tiles) and its
//! per-instance hierarchies.
use super::host;
use super::*;

/// vct-dense's frame.
pub static VCT_DENSE: PipelineDecl = PipelineDecl {
    name: "vct-dense",
    stages: &[
        GBUFFER_STAGE,
        DIRECT_LIGHT_STAGE,
        VOXELIZE_STAGE,
        VOXEL_LIGHT_STAGE,
        MIPS_STAGE,
        StageDecl {
            name: "cone_trace",
            kernels: &[
                &screen_tiles::DECL,
                &cone_trace::DECL,
                &cone_trace::INSTANCED_DECL,
            ],
            reuse: Reuse::Camera,
            split: Split::Always,
            plan: cone_trace_plan,
            host: Some(host::cone_trace_step),
        },
    ],
};

/// The camera's G-buffer: the same stage in every pipeline.
pub(crate) const GBUFFER_STAGE: StageDecl = StageDecl {
    name: "gbuffer",
    kernels: &[&crate::kernels::gbuffer::DECL],
    reuse: Reuse::Camera,
    split: Split::Always,
    plan: gbuffer_plan,
    host: Some(host::gbuffer_step),
};

/// Direct light by exact shadow rays (vct-dense, vct-svo, cprc; lrsm's skips it with shadow cones).
pub(crate) const DIRECT_LIGHT_STAGE: StageDecl = StageDecl {
    name: "direct_light",
    kernels: &[&direct_light::DECL],
    reuse: Reuse::Camera,
    split: Split::Always,
    plan: direct_light_plan,
    host: Some(host::direct_light_step),
};

/// Voxelization (the other pipelines' say what they voxelize for: `StageDecl { plan, ..VOXELIZE_STAGE }`).
pub(crate) const VOXELIZE_STAGE: StageDecl = StageDecl {
    name: "voxelize",
    kernels: &[&triangle_setup::DECL, &voxelize::DECL],
    reuse: Reuse::Geometry,
    split: Split::Always,
    plan: voxelize_plan,
    host: Some(host::voxelize_step),
};

/// The radiance pyramid's mip chain (vct-dense, cprc).
pub(crate) const MIPS_STAGE: StageDecl = StageDecl {
    name: "surface_coverage_mip",
    kernels: &[&crate::kernels::surface_coverage_mip::DECL],
    reuse: Reuse::Lights,
    split: Split::Always,
    plan: mips_plan,
    host: Some(host::mips_step),
};

/// Direct light into the voxels (vct-dense, cprc, vct-svo without photons).
pub(crate) const VOXEL_LIGHT_STAGE: StageDecl = StageDecl {
    name: "voxel_light",
    kernels: &[&voxel_light::DECL],
    reuse: Reuse::Lights,
    split: Split::Always,
    plan: voxel_light_plan,
    host: Some(host::voxel_light_step),
};

/// Why a stage of the volume is skipped when the last frame's serves this one.
const CACHED: &str = "skipped: geometry, materials, lights and voxels unchanged since the last frame (its radiance pyramid is reused)";

pub(crate) fn gbuffer_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    vec![PlannedPass::new(
        "gbuffer",
        "gbuffer",
        i.pixels(),
        true,
        "every renderer shades G-buffer texels",
    )]
}

pub(crate) fn direct_light_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let lights = i.scene.lights.len();
    vec![PlannedPass::new(
        "direct_light",
        "direct_light",
        format!("{} x {lights} lights", i.pixels()),
        true,
        if lights > 0 {
            "exact shadow ray per light and texel"
        } else {
            "the scene has no lights: direct is 0"
        },
    )]
}

/// vct-dense's voxelize (cprc's; vct-svo's and lrsm's say what they voxelize for).
pub(crate) fn voxelize_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let side = i.scene.render.voxels;
    vec![PlannedPass::new(
        "voxelize",
        "voxelize",
        format!(
            "{} triangles set up (triangle_setup) and voxelized into {side}^3",
            i.scene.mesh.triangles.len()
        ),
        !i.cached,
        if i.cached {
            CACHED
        } else {
            "the radiance pyramid's geometry"
        },
    )]
}

pub(crate) fn voxel_light_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let lights = i.scene.lights.len();
    vec![PlannedPass::new(
        "voxel_light",
        "voxel_light",
        format!("non-empty voxels x {lights} lights"),
        !i.cached,
        if i.cached {
            CACHED
        } else if lights > 0 {
            "direct light into the voxels (work list from voxelize)"
        } else {
            "no lights: the voxels' light is 0, their coverage kept (AO)"
        },
    )]
}

/// The mip chain up to the levels the cones read.
pub(crate) fn mips_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let side = i.scene.render.voxels;
    vec![PlannedPass::new(
        "surface_coverage_mip",
        "surface_coverage_mip",
        crate::plan::mip_levels(side, cone_trace::pyramid_levels(i.scene, i.cones, side)),
        !i.cached,
        if i.cached {
            CACHED
        } else {
            "cones read coarser levels as they widen"
        },
    )]
}

/// vct-dense's cone pass (vct-svo's and lrsm's take its size and add to its reasons).
pub(crate) fn cone_trace_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let cones = i.cones;
    let glossy = i.glossy();
    let size = format!(
        "{} in the 8x8 tiles holding a surface (screen_tiles' list; empty tiles not dispatched) x ({} diffuse{}){}",
        i.pixels(),
        cones.diffuse_cones,
        if glossy > 0 { " + 1 glossy" } else { "" },
        if cones.interleave > 1 {
            format!(
                ", then the resolve over {0}x{0} neighbours (tent weights)",
                2 * cones.interleave - 1
            )
        } else {
            String::new()
        }
    );
    let why = format!(
        "{}{}",
        if glossy > 0 {
            format!("AO + diffuse; glossy cone for the {glossy} glossy material(s)")
        } else {
            "AO + diffuse; no glossy cone: no material has Ks".into()
        },
        if cones.interleave > 1 {
            format!(
                "; interleaved cone sets: {} cones over {1}x{1} classes of a surface",
                cones.diffuse_cones * cones.interleave * cones.interleave,
                cones.interleave
            )
        } else {
            String::new()
        }
    );
    vec![PlannedPass::new(
        "cone_trace",
        "cone_trace",
        size,
        true,
        why,
    )]
}

/// A chain of the scene's voxelization alone (stage `voxelize`): triangle_setup puts the mesh on
/// voxelize's lattice, then voxelize writes the scene's voxel grid (`vox_colour`, `vox_normal`,
/// ...) and the GPU's list of its non-empty voxels (`list`, `list_count`).
pub(crate) fn voxel_chain(ctx: &crate::harness::GpuContext, scene: &Scene) -> Result<Chain> {
    let side = scene.render.voxels;
    let (mesh, frame, setup) = setup_case(ctx, scene)?;
    let mut vox = voxelize::case_for(
        ctx,
        voxelize::Triangles::Setup(&mesh),
        side,
        "render".into(),
        0,
    )?;
    vox.rename_resource("params", "vox_params", false);
    let mut chain = Chain {
        resources: Resources::new(),
        stages: Vec::new(),
        copies: Vec::new(),
        frame,
    };
    chain.add(&triangle_setup::DECL, voxelize::DECL.name, setup)?;
    chain.add(&voxelize::DECL, voxelize::DECL.name, vox)?;
    Ok(chain)
}

/// `scene`'s mesh in its voxel grid, checked ([`voxelize::mesh_input`]), the grid, and
/// triangle_setup's case over the mesh: the first pass of a chain's voxelization.
pub(crate) fn setup_case(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
) -> Result<(
    triangle_setup::MeshInput,
    voxelize::VoxelFrame,
    crate::harness::Case,
)> {
    let (mesh, frame) = voxelize::mesh_input(scene, scene.render.voxels)?;
    let case = triangle_setup::case_for(ctx, &mesh, "render".into(), 0);
    Ok((mesh, frame, case))
}

/// The voxels lit in a chain: voxelize (stage `voxelize`) and voxel_light over every entry the
/// GPU's list could hold (stage `voxel_light`), its radiance in `vox_radiance`; the grid's frame.
pub(crate) fn lit_voxel_chain(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    data: &SceneData,
) -> Result<(Chain, voxelize::VoxelFrame)> {
    use crate::harness::run::{grid_for, Pass, Workgroups};
    use crate::harness::{HostBuffer, HostResource, ScalarKind};
    let side = scene.render.voxels;
    let v = (side as u64).pow(3);
    let max = ctx.limits().max_compute_workgroups_per_dimension;
    let mut chain = voxel_chain(ctx, scene)?;
    let vframe = chain.frame;
    // voxel_light over every entry the list could hold: the kernel stops at the GPU's count.
    let mut light_res = crate::kernels::gbuffer::scene_resources(data);
    light_res.remove("frame");
    light_res.remove("materials");
    light_res.insert(
        "grid".into(),
        HostResource::Buffer(HostBuffer::pod(&voxel_light::voxel_grid(
            &vframe,
            data.lights.len(),
        ))),
    );
    light_res.insert(
        "vox_radiance".into(),
        HostResource::Buffer(HostBuffer::zeroed(v as usize * 16, ScalarKind::F32)),
    );
    // A window of the grid at a time where its buffers pass one binding.
    let light_pass = Pass {
        label: "voxel_light".into(),
        entry: "main".into(),
        bindings: voxel_light::DECL.bind_by_name(),
        workgroups: Workgroups::Direct(grid_for(v, 64, max)),
    };
    let light_passes = voxel_light::window_passes(
        &light_pass,
        voxel_light::voxel_grid(&vframe, data.lights.len()),
        &mut light_res,
        voxel_light::window_voxels(side, ctx.limits().max_storage_buffer_binding_size),
    );
    chain.resources.extend(light_res);
    chain.push(
        voxel_light::DECL.shader()?,
        voxel_light::DECL.name,
        light_passes,
    );
    Ok((chain, vframe))
}

/// vct-dense's chain: voxelize, voxel_light, the surface-coverage mips (each level copied into
/// `pyramid` and `pyramid_normal` after them), then (with `gbuffer_in_chain`) gbuffer and
/// direct_light, screen_tiles and cone_trace. `cone_pass`: the G-buffer the cone pass reads (zeroed
/// where the chain computes it), the cone settings and the pyramid levels the cones read (the others
/// are not built); without it the chain ends with the mips and builds every level.
/// `gbuffer_in_chain`: the G-buffer and direct light are stages of the chain, after the mips
/// (computed on the GPU, never read back), instead of inputs in `cone_pass`'s resources.
pub(crate) fn dense_chain(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    data: &SceneData,
    cone_pass: Option<(&crate::harness::Resources, &ConeSettings, u32)>,
    gbuffer_in_chain: bool,
) -> Result<Chain> {
    use crate::harness::{HostBuffer, HostResource, ScalarKind};
    use crate::kernels::surface_coverage_mip::{self as scm, colour_name};
    use vxgi_cpu_mirror::cone_trace::{level_offset, pyramid_len};
    let side = scene.render.voxels;
    let (mut chain, vframe) = lit_voxel_chain(ctx, scene, data)?;
    // The mip chain from voxel_light's radiance and voxelize's normals, up to the levels the cones
    // read (all of them without a cone pass: the pyramid is kept for other cones).
    let levels = cone_pass.map_or(side.trailing_zeros() + 1, |(_, _, l)| l);
    let mip_shader = scm::DECL.shader()?;
    let mips = volume_mips(&mip_shader, ctx, side, levels, "vox_radiance", "vox_normal");
    let mut resources = std::mem::take(&mut chain.resources);
    resources.extend(mips.resources);
    let mut cone_stages = match cone_pass {
        Some((gb, cones, _)) => {
            let mut params = cone_trace::cone_params(&vframe, cones);
            params.levels = levels;
            let c = cone_trace::case_for(
                data,
                gb,
                &cone_trace::Pyramids::default(),
                &params,
                "render".into(),
                0,
            );
            resources.extend(c.resources);
            let (w, h) = (data.width(), data.height());
            resources.insert("tile_list".into(), screen_tiles::empty_list(w, h));
            Some((vec![screen_tiles::pass(w, h)], c.passes))
        }
        None => None,
    };
    // The pyramid and its normal pyramid (the depth-ordered blend reads it; kept with the pyramid),
    // filled below from the chain's levels.
    for name in ["pyramid", "pyramid_normal"] {
        resources.insert(
            name.into(),
            HostResource::Buffer(HostBuffer::zeroed(pyramid_len(side) * 16, ScalarKind::F32)),
        );
    }
    if let Some((_, passes)) = &mut cone_stages {
        cone_trace::bind_pyramid_views(passes, &mut resources, cone_trace::PYRAMID_WINDOW)
            .map_err(anyhow::Error::msg)?;
    }
    chain.resources = resources;
    chain.push(mip_shader, scm::DECL.name, mips.passes);
    let after_mips = chain.pass_count();
    // The G-buffer and direct light after the volume (they do not read it): a frame that reuses the
    // volume runs one contiguous range of passes.
    if gbuffer_in_chain {
        push_camera_gbuffer(ctx, data, &mut chain)?;
    }
    if let Some((tiles, cone)) = cone_stages {
        // screen_tiles' list is the cone pass's dispatch: both count to the cone_trace stage.
        chain.push_as(
            screen_tiles::DECL.shader()?,
            screen_tiles::DECL.name,
            cone_trace::DECL.name,
            tiles,
        );
        chain.push(cone_trace::DECL.shader()?, cone_trace::DECL.name, cone);
    }
    let names = |base: &str, f: &dyn Fn(u32) -> String| -> Vec<String> {
        (0..levels)
            .map(|l| if l == 0 { base.to_string() } else { f(l) })
            .collect()
    };
    chain.copies = names("vox_radiance", &colour_name)
        .into_iter()
        .map(|n| (n, "pyramid"))
        .enumerate()
        .chain(
            names("vox_normal", &scm::normal_name)
                .into_iter()
                .map(|n| (n, "pyramid_normal"))
                .enumerate(),
        )
        .map(|(l, (src, to))| ChainCopy {
            src_range: None,
            after: after_mips,
            src,
            dst: to.to_string(),
            offset: level_offset(side, l as u32) as u64 * 16,
        })
        .collect();
    Ok(chain)
}

/// vct-dense's chain for a scene with `[[instances]]`: [`instanced_volume`], gbuffer, direct_light,
/// screen_tiles and the instanced cone pass through every hierarchy.
pub(crate) fn instanced_dense_chain(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    data: &SceneData,
    cones: &ConeSettings,
) -> Result<(Chain, Vec<voxelize::VoxelFrame>)> {
    let (mut chain, frames, at) = instanced_volume(ctx, scene, data)?;
    push_camera_gbuffer(ctx, data, &mut chain)?;
    let g = crate::kernels::gbuffer::case_for(data, "render".into(), 0).resources;
    let params = cone_trace::cone_params(&at.world, cones);
    let len = pyramid_texels(&chain);
    let c = cone_trace::instanced_case_for(
        data,
        &g,
        &vec![[0.0; 4]; len],
        &at.placed,
        &params,
        "render".into(),
        0,
    );
    push_tiled_cone_pass(
        &mut chain,
        data,
        &cone_trace::INSTANCED_DECL,
        cone_trace::DECL.name,
        c,
    )?;
    Ok((chain, frames))
}
