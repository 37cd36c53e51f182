//! vct-svo (Crassin et al. 2011: the sparse voxel octree): its declaration, the plan's rules for its
//! stages, and its per-frame chain over an octree built already.
use super::*;
use crate::kernels::{sparse_voxel_octree, svo_anisotropic, svo_cone_trace, svo_photons};

/// vct-svo's frame: vct-dense's G-buffer, direct light and voxelization, light injection by
/// voxel_light or photons, the octree instead of the mip chain (directional values, the lobes'
/// normal pool and a second bounce where the settings ask for them), the octree's cone tracer.
pub static VCT_SVO: PipelineDecl = PipelineDecl {
    name: "vct-svo",
    stages: &[
        GBUFFER_STAGE,
        DIRECT_LIGHT_STAGE,
        StageDecl {
            plan: |i| octree_reasons(voxelize_plan(i)),
            ..VOXELIZE_STAGE
        },
        StageDecl {
            plan: |i| {
                if i.scene.render.photon_map > 0 {
                    Vec::new()
                } else {
                    octree_reasons(voxel_light_plan(i))
                }
            },
            ..VOXEL_LIGHT_STAGE
        },
        StageDecl {
            name: "svo_photons",
            kernels: &[&crate::kernels::gbuffer::DECL, &svo_photons::DECL],
            reuse: Reuse::Lights,
            split: Split::Always,
            plan: photons_plan,
        },
        StageDecl {
            name: "sparse_voxel_octree",
            kernels: &[&sparse_voxel_octree::DECL],
            reuse: Reuse::Lights,
            split: Split::Always,
            plan: octree_plan,
        },
        StageDecl {
            name: "svo_anisotropic",
            kernels: &[&svo_anisotropic::DECL],
            reuse: Reuse::Lights,
            split: Split::WhenRun,
            plan: anisotropic_plan,
        },
        StageDecl {
            name: "svo_lobes",
            kernels: &[&sparse_voxel_octree::DECL],
            reuse: Reuse::Lights,
            split: Split::WhenRun,
            plan: lobes_plan,
        },
        StageDecl {
            name: "svo_bounce",
            kernels: &[&svo_cone_trace::BOUNCE_DECL, &sparse_voxel_octree::DECL],
            reuse: Reuse::Lights,
            split: Split::Never,
            plan: bounce_plan,
        },
        StageDecl {
            name: "svo_cone_trace",
            kernels: &[&screen_tiles::DECL, &svo_cone_trace::DECL],
            reuse: Reuse::Camera,
            split: Split::Always,
            plan: svo_cone_trace_plan,
        },
    ],
};

/// vct-dense's reasons, about the octree.
fn octree_reasons(mut passes: Vec<PlannedPass>) -> Vec<PlannedPass> {
    for p in &mut passes {
        p.why = p.why.replace("radiance pyramid", "octree");
    }
    passes
}

/// The octree's depth over the grid.
fn depth(i: &PlanInputs) -> u32 {
    i.scene.render.voxels.trailing_zeros().saturating_sub(1)
}

/// Light injection by photons instead of voxel_light (`photon_map` > 0).
fn photons_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let map = i.scene.render.photon_map;
    if map == 0 {
        return Vec::new();
    }
    let mut p = octree_reasons(voxel_light_plan(i)).remove(0);
    p.stage = "svo_photons";
    p.kernel = "gbuffer + svo_photons";
    p.size = format!(
        "{} light views x {map}^2 texels",
        crate::plan::light_views(i.scene)
    );
    if p.runs {
        p.why = "light injection: a map ray-cast from each light view, one photon per texel splatted into the leaves".into();
    }
    vec![p]
}

fn octree_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let side = i.scene.render.voxels;
    let depth = depth(i);
    let mut p = octree_reasons(mips_plan(i)).remove(0);
    p.stage = "sparse_voxel_octree";
    p.kernel = "sparse_voxel_octree";
    p.size = format!("depth {depth} over {side}^3 voxels, {} levels", depth + 1);
    if p.runs {
        p.why =
            "build, splat, border transfer, distribution over levels; work lists skip empty nodes"
                .into();
    }
    vec![p]
}

fn anisotropic_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let octree = octree_plan(i).remove(0);
    let on = i.scene.render.anisotropic_voxels;
    vec![PlannedPass::new(
        "svo_anisotropic",
        "svo_anisotropic",
        format!("levels 0..{}, 6 directions x 27 voxels per node", depth(i)),
        octree.runs && on,
        if !on {
            "skipped: anisotropic_voxels = false (isotropic Gaussian average only)".into()
        } else if octree.runs {
            "six directional values per voxel above the leaves, front to back per direction (VCT 7.1)".into()
        } else {
            octree.why
        },
    )]
}

fn lobes_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let lobes = i.scene.render.voxel_lobes;
    vec![PlannedPass::new(
        "svo_lobes",
        "sparse_voxel_octree (normals)",
        format!("depth {}: normal pool over the octree's points", depth(i)),
        !i.cached && lobes,
        if !lobes {
            "skipped: voxel_lobes = false (voxels emit alike in every direction)"
        } else if i.cached {
            "skipped: the octree is reused (with its normal pool)"
        } else {
            "normals pre-multiplied by opacity, filtered as the light (a second build over the same points), for the Gaussian lobes (VCT 4.3, 7); with glossy surfaces and photons, their specular photons in a third pool (the incoming light as a direction distribution, VCT 7)"
        },
    )]
}

fn bounce_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let lights = !i.scene.lights.is_empty();
    let two = i.scene.render.bounces == 2;
    vec![PlannedPass::new(
        "svo_bounce",
        "svo_bounce + sparse_voxel_octree",
        format!(
            "non-empty voxels x {} diffuse cones, then the octree again",
            i.cones.diffuse_cones
        ),
        !i.cached && two && lights,
        if !two {
            "skipped: bounces = 1"
        } else if i.cached {
            "skipped: the octree is reused (it holds both bounces)"
        } else if !lights {
            "skipped: no lights, nothing to bounce"
        } else {
            "second bounce: every voxel gathers the first through the octree, its light added to the fragments, octree rebuilt"
        },
    )]
}

fn svo_cone_trace_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let mut p = cone_trace_plan(i).remove(0);
    p.stage = "svo_cone_trace";
    p.kernel = "svo_cone_trace";
    if i.scene.render.anisotropic_voxels {
        p.why.push_str("; anisotropic voxels above the leaves");
    }
    if i.scene.render.voxel_lobes {
        p.why.push_str("; voxel shading with Gaussian lobes");
    }
    vec![p]
}

/// vct-svo's per-frame chain over an octree built already (`volume`, by [`crate::render::VctSvo`]'s
/// GPU passes with the host steps between them): gbuffer, direct_light, screen_tiles and
/// svo_cone_trace, the octree's nodes, bricks and pools bound as they are.
pub(crate) fn svo_chain(
    ctx: &crate::harness::GpuContext,
    data: &SceneData,
    cones: &ConeSettings,
    volume: &crate::render::SvoCache,
) -> Result<Chain> {
    use crate::kernels::gbuffer;
    let g = gbuffer::case_for(data, "render".into(), 0);
    let d = direct_light::case_with_gbuffer(ctx, data, &Default::default(), "render".into(), 0);
    let params = svo_cone_trace::svo_cone_params(&volume.frame, cones);
    let mut c = svo_cone_trace::case_for(
        data,
        &g.resources,
        &volume.built.octree,
        volume.extras(),
        volume.scale,
        &params,
        "render".into(),
        0,
    );
    let mut chain = Chain {
        resources: Resources::new(),
        stages: Vec::new(),
        copies: Vec::new(),
        frame: volume.frame,
    };
    // The G-buffer the later stages bind is gbuffer's output (zeroed here, computed in the chain);
    // the cone pass runs over the tiles screen_tiles lists from it on the GPU (the case's host-built
    // list replaced by an empty one the chain fills). `nodes` is the ray caster's BVH in gbuffer and
    // direct_light, the octree's in the cone pass.
    let (w, h) = (data.width(), data.height());
    c.rename_resource("nodes", "octree_nodes", false);
    c.resources
        .insert("tile_list".into(), screen_tiles::empty_list(w, h));
    chain.merge(gbuffer::DECL.name, g.resources)?;
    chain.merge(direct_light::DECL.name, d.resources)?;
    chain.merge(svo_cone_trace::DECL.name, c.resources)?;
    chain.push(gbuffer::DECL.shader()?, gbuffer::DECL.name, g.passes);
    chain.push(
        direct_light::DECL.shader()?,
        direct_light::DECL.name,
        d.passes,
    );
    chain.push_as(
        screen_tiles::DECL.shader()?,
        screen_tiles::DECL.name,
        svo_cone_trace::DECL.name,
        vec![screen_tiles::pass(w, h)],
    );
    chain.push(
        svo_cone_trace::DECL.shader()?,
        svo_cone_trace::DECL.name,
        c.passes,
    );
    Ok(chain)
}
