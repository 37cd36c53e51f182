//! vct-svo's per-frame chain over an octree built already.
use super::*;

/// vct-svo's per-frame chain over an octree built already (`volume`, by [`crate::render::VctSvo`]'s
/// GPU passes with the host steps between them): gbuffer, direct_light, screen_tiles and
/// svo_cone_trace, the octree's nodes, bricks and pools bound as they are.
pub(crate) fn svo_chain(
    ctx: &crate::harness::GpuContext,
    data: &SceneData,
    cones: &ConeSettings,
    volume: &crate::render::SvoCache,
) -> Result<Chain> {
    use crate::kernels::{gbuffer, svo_cone_trace};
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
    chain.push(
        screen_tiles::DECL.shader()?,
        screen_tiles::DECL.name,
        vec![screen_tiles::pass(w, h)],
    );
    chain.push(
        svo_cone_trace::DECL.shader()?,
        svo_cone_trace::DECL.name,
        c.passes,
    );
    Ok(chain)
}
