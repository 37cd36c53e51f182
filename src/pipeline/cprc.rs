//! cprc (Rehfeld et al. 2014: clustered pre-convolved radiance caching): its declaration, the plan's
//! rules for its stages, and its chain: vct-dense's volume and camera passes, the cache
//! distribution, the cache records, creation and pre-convolution dispatched indirectly, the gather;
//! and how many caches it holds.
use super::host::{HostFrame, Side};
use super::*;
use crate::kernels::{
    cache_creation, cache_placement, cache_preconvolve, cache_records, cache_reuse,
    cluster_extract, cluster_keys, cprc_pixels, gather_caches, histogram_axes, radix_sort,
    tile_normal_histogram,
};

/// cprc's frame: vct-dense's stages up to the radiance pyramid (with its reuse rule), then the
/// cache distribution, creation, pre-convolution and the gather instead of per-pixel cones. The
/// caches follow the view, so they are made again every frame (with `cache_reuse`, a cache whose
/// surface is still in view in its cluster keeps its place).
pub static CPRC: PipelineDecl = PipelineDecl {
    name: "cprc",
    stages: &[
        GBUFFER_STAGE,
        DIRECT_LIGHT_STAGE,
        StageDecl {
            plan: |i| unlit_volume(i, voxelize_plan(i)),
            ..VOXELIZE_STAGE
        },
        VOXEL_LIGHT_STAGE,
        StageDecl {
            plan: cprc_mips_plan,
            ..MIPS_STAGE
        },
        StageDecl {
            name: "cache_distribution",
            kernels: &[
                &cprc_pixels::DECL,
                &tile_normal_histogram::DECL,
                &histogram_axes::DECL,
                &cluster_keys::DECL,
                &radix_sort::DECL,
                &cluster_extract::DECL,
                &cache_placement::DECL,
                &cache_reuse::DECL,
                &cache_records::DECL,
            ],
            reuse: Reuse::Camera,
            split: Split::Always,
            plan: distribution_plan,
            host: Some(distribution_step),
        },
        StageDecl {
            name: "cache_creation",
            kernels: &[&cache_creation::DECL, &cache_creation::INSTANCED_DECL],
            reuse: Reuse::Camera,
            split: Split::Always,
            plan: |i| {
                lit(
                    i,
                    PlannedPass::new(
                        "cache_creation",
                        "cache_creation",
                        format!("caches x {}^2 texels", i.cprc.res),
                        true,
                        "one cone per cache texel through the radiance pyramid",
                    ),
                )
            },
            host: Some(creation_step),
        },
        StageDecl {
            name: "cache_preconvolve",
            kernels: &[&cache_preconvolve::DECL],
            reuse: Reuse::Camera,
            split: Split::Never,
            plan: preconvolve_plan,
            // One GPU chain with the creation: cache_creation's step.
            host: None,
        },
        StageDecl {
            name: "gather_caches",
            kernels: &[&gather_caches::DECL, &cprc_pixels::DECL],
            reuse: Reuse::Camera,
            split: Split::Never,
            plan: gather_plan,
            host: None,
        },
    ],
};

/// The volume's passes, said to compute no light where the scene has none (they run, as in a lit
/// scene).
fn unlit_volume(i: &PlanInputs, mut passes: Vec<PlannedPass>) -> Vec<PlannedPass> {
    if i.scene.lights.is_empty() {
        for p in &mut passes {
            p.why = format!("{}; no lights: the caches will hold no radiance", p.why);
        }
    }
    passes
}

/// `pass`, said to give indirect light 0 where the scene has no lights (it runs).
fn lit(i: &PlanInputs, mut pass: PlannedPass) -> Vec<PlannedPass> {
    if i.scene.lights.is_empty() {
        pass.why = format!("{}; no lights: indirect is 0", pass.why);
    }
    vec![pass]
}

/// The caches' cones read the pyramid: every level is built.
fn cprc_mips_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let mut passes = mips_plan(i);
    let side = i.scene.render.voxels;
    for p in &mut passes {
        p.size = crate::plan::mip_levels(side, side.trailing_zeros() + 1);
    }
    unlit_volume(i, passes)
}

fn distribution_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    const STAGE: &str = "cache_distribution";
    let s = &i.cprc;
    let (w, h) = (i.scene.camera.width, i.scene.camera.height);
    let tiles = w.div_ceil(s.tile) * h.div_ceil(s.tile);
    let mut passes = lit(
        i,
        PlannedPass::new(
            STAGE,
            "cprc_pixels",
            i.pixels(),
            true,
            "the distribution's and the gather's per-pixel inputs from the G-buffer (entry inputs)",
        ),
    );
    for kernel in [
        "tile_normal_histogram",
        "histogram_axes",
        "cluster_keys",
        "radix_sort",
        "cluster_extract",
        "cache_placement",
    ] {
        passes.extend(lit(
            i,
            PlannedPass::new(
                STAGE,
                kernel,
                format!(
                    "{w}x{h} pixels, {tiles} tiles of {}^2, {} depth slices",
                    s.tile, s.slices
                ),
                true,
                "one cache per cluster of the view's pixels (tile x normal axis x depth slice)",
            ),
        ));
    }
    if i.scene.render.cache_reuse {
        passes.extend(lit(
            i,
            PlannedPass::new(
                STAGE,
                "cache_reuse",
                "the last frame's caches",
                true,
                "each cluster keeps the last frame's cache still on its surface, if any (entries clear, claim; none in a renderer's first frame)",
            ),
        ));
    }
    passes.extend(lit(
        i,
        PlannedPass::new(
            STAGE,
            "cache_records",
            "one per cluster",
            true,
            "each cluster's cache record, and the cache stages' workgroups from the count",
        ),
    ));
    if i.scene.render.cache_reuse {
        passes.extend(lit(
            i,
            PlannedPass::new(
                STAGE,
                "cache_reuse",
                "one per cluster",
                true,
                "a kept cache's record takes its last position, normal, creation record and pixel, and (cache_carry) while the volume is unchanged its radiance texels, which cache_creation then skips (entry keep)",
            ),
        ));
    }
    passes
}

fn preconvolve_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    const STAGE: &str = "cache_preconvolve";
    let glossy = i.glossy();
    let levels = i.cprc.res.trailing_zeros() + 1;
    let mut passes = lit(
        i,
        PlannedPass::new(
            STAGE,
            "cache_preconvolve",
            format!("caches x {}^2 irradiance texels", i.cprc.irr),
            true,
            "cosine-folded irradiance for diffuse (entry irradiance)",
        ),
    );
    passes.extend(lit(
        i,
        PlannedPass::new(
            STAGE,
            "cache_preconvolve",
            format!("caches x {levels} mip levels"),
            glossy > 0,
            if glossy > 0 {
                format!("mip chain for the {glossy} glossy material(s) (entry mips; skipped at run time if none is in view)")
            } else {
                "skipped: no material has Ks, no pixel reads a mip chain (entry mips)".into()
            },
        ),
    ));
    passes
}

fn gather_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    const STAGE: &str = "gather_caches";
    let mut passes = lit(
        i,
        PlannedPass::new(
            STAGE,
            "gather_caches",
            format!("{}, radius {} px", i.pixels(), i.cprc.radius_px),
            true,
            if i.glossy() > 0 {
                "irradiance by normal; glossy lookups only for pixels with Ks"
            } else {
                "irradiance by normal; no glossy lookups: no material has Ks"
            },
        ),
    );
    passes.extend(lit(
        i,
        PlannedPass::new(
            STAGE,
            "cprc_pixels",
            i.pixels(),
            true,
            "indirect = albedo / pi x irradiance + Ks x glossy; AO 1 on geometry (entry compose)",
        ),
    ));
    passes
}

/// What a cprc chain holds besides its stages: how many caches its buffers have room for, and
/// whether it builds the caches' mip chains (a glossy material in the scene).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CacheRoom {
    pub capacity: u32,
    pub mips: bool,
    /// cache_records' parameters as the chain was built (a frame whose instances moved rewrites its
    /// offset: the world grid's voxel follows the scene's extent).
    pub records: vxgi_cpu_mirror::cache_records::RecordsParams,
}

/// The most bytes a cprc chain spends on its caches' texels, mip chains and irradiance maps: the
/// capacity stops there even where the device's bindings would hold more (the frame's actual count is
/// usually a small part of the worst case: 447 of 12288 on the Cornell box at 256x256).
pub(crate) const CACHE_BUDGET: u64 = 256 << 20;

/// The most caches a frame of `scene` can place (one per cluster: clusters are keyed by tile, normal
/// axis and depth slice, so at most `tiles * 3 * slices` of them, and no more than pixels), within
/// what one storage binding holds of each cache buffer (texels, mip chains where built, irradiance
/// maps) and within [`CACHE_BUDGET`] for all of them. A frame with more clusters than that keeps the
/// first and counts the rest (`CprcStats::dropped`, warned by `vxgi render`).
pub(crate) fn cache_room(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    s: &crate::cprc::CprcSettings,
) -> CacheRoom {
    use vxgi_cpu_mirror::cache_preconvolve::mip_len;
    let (w, h) = (scene.camera.width as u64, scene.camera.height as u64);
    let tiles = w.div_ceil(s.tile as u64) * h.div_ceil(s.tile as u64);
    let mips = scene.materials.iter().any(|m| m.is_glossy());
    let limit = ctx.limits().max_storage_buffer_binding_size;
    let mut per = vec![(s.res * s.res) as u64, (s.irr * s.irr) as u64];
    if mips {
        per.push(mip_len(s.res) as u64);
    }
    let fit = per.iter().map(|t| limit / (t * 16)).min().unwrap_or(0);
    let budget = CACHE_BUDGET / (per.iter().sum::<u64>() * 16);
    let capacity = (tiles * 3 * s.slices as u64)
        .min(w * h)
        .min(fit)
        .min(budget)
        .max(1);
    CacheRoom {
        capacity: capacity as u32,
        mips,
        records: Default::default(),
    }
}

/// cache_reuse's parameters for `scene`'s caches: `carry` where the frame's volume is the last
/// frame's (a renderer's frame that re-lit or moved nothing) and `cache_carry` allows it.
pub fn reuse_params(scene: &Scene, carry: bool) -> vxgi_cpu_mirror::cache_reuse::ReuseParams {
    let res = crate::cprc::CprcSettings::from(&scene.render).res;
    vxgi_cpu_mirror::cache_reuse::ReuseParams {
        carry: u32::from(carry && scene.render.cache_carry),
        texels: res * res,
        ..vxgi_cpu_mirror::cache_reuse::ReuseParams::DEFAULT
    }
}

/// cprc's chain: vct-dense's volume (every pyramid level: the caches' cones read them all), gbuffer
/// and direct_light; then cprc_pixels' `inputs`, the distribution's six kernels, cache_records (its
/// count copied into creation's and pre-convolution's uniform blocks), cache creation and
/// pre-convolution dispatched from the GPU-built arguments, the gather, and cprc_pixels' `compose`
/// (`indirect`, `ao`). Nothing between the G-buffer and the images goes through the host. With
/// `[[instances]]` the volume is [`instanced_volume`]'s hierarchies (their grid frames returned) and
/// creation marches through all of them.
pub(crate) fn cprc_chain(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    data: &SceneData,
    cones: &ConeSettings,
) -> Result<(Chain, CacheRoom, Option<Vec<voxelize::VoxelFrame>>)> {
    use crate::cprc::{self, CacheSet, CacheVolume, CprcSettings, PixelInputs};
    use crate::harness::run::Workgroups;
    use vxgi_cpu_mirror::cache_records::args_offset;
    let (mut chain, hierarchies) = if scene.instances.list.is_empty() {
        (dense_chain(ctx, scene, data, None, true)?, None)
    } else {
        let (mut chain, frames, at) = instanced_volume(ctx, scene, data)?;
        push_camera_gbuffer(ctx, data, &mut chain)?;
        (chain, Some((frames, at.placed)))
    };
    let s = CprcSettings::from(&scene.render);
    let mut room = cache_room(ctx, scene, &s);
    let (w, h) = (data.width(), data.height());
    let n = (w * h) as usize;
    // The per-pixel inputs, computed by `inputs` from the G-buffer (zeroed here).
    let px = PixelInputs {
        width: w,
        height: h,
        normals: vec![[0; 2]; n],
        depth: vec![0.0; n],
        positions: vec![[0.0; 4]; n],
        pixel_dirs: vec![[0.0; 4]; 2 * n],
        albedo: vec![[0.0; 4]; n],
        specular: vec![[0.0; 4]; n],
        geometry: vec![false; n],
        depth_unit: crate::cprc::depth_unit(data.bounds),
    };
    let mut pixels = cprc_pixels::outputs(n);
    pixels.insert(
        "lobes".into(),
        HostResource::Buffer(crate::harness::HostBuffer::f32(bytemuck::cast_slice(
            &cprc_pixels::lobes(&data.materials, s.res),
        ))),
    );
    for name in ["indirect", "ao"] {
        pixels.insert(
            name.into(),
            HostResource::Buffer(crate::harness::HostBuffer::zeroed(
                n * 16,
                crate::harness::ScalarKind::F32,
            )),
        );
    }
    chain.merge(cprc_pixels::DECL.name, pixels)?;
    let pixel_shader = cprc_pixels::DECL.shader()?;
    chain.push_as(
        cprc_pixels::DECL.shader()?,
        cprc_pixels::DECL.name,
        "cache_distribution",
        vec![cprc_pixels::pass(ctx, "inputs", n)],
    );
    let (mut dist, stages) = cprc::distribution_stages(ctx, &px, &s)?;
    // The distribution reads the pixel inputs `inputs` writes.
    for name in ["normals", "depth", "positions"] {
        dist.remove(name);
    }
    chain.merge("the cache distribution", dist)?;
    for (decl, passes) in stages {
        chain.push_as(decl.shader()?, decl.name, "cache_distribution", passes);
    }
    // With reuse: the last frame's records, copied before this frame's overwrite them (zeros, no
    // caches, in a new chain), claimed by the clusters whose surface still holds them.
    // One slot per entry of the clusters buffer (pixel_cluster's values index it).
    let slots = chain.resources["clusters"].buffer().map_or(1, |b| {
        b.bytes.len() / std::mem::size_of::<vxgi_cpu_mirror::cluster_extract::Cluster>()
    });
    let reuse = scene.render.cache_reuse.then(|| {
        let capacity = room.capacity as usize;
        cache_reuse::passes(ctx, slots, capacity, capacity)
    });
    if let Some((claim, _)) = &reuse {
        chain.merge(
            cache_reuse::DECL.name,
            cache_reuse::resources(slots, room.capacity as usize, reuse_params(scene, false)),
        )?;
        let after = chain.pass_count();
        for (src, dst) in [
            ("cache_pos", "prev_pos"),
            ("cache_normal", "prev_normal"),
            ("caches", "prev_caches"),
            ("cache_radiance", "prev_radiance"),
            ("cache_count", "prev_count"),
        ] {
            chain.copies.push(ChainCopy {
                src_range: None,
                after,
                src: src.into(),
                dst: dst.into(),
                offset: 0,
            });
        }
        chain.push_as(
            cache_reuse::DECL.shader()?,
            cache_reuse::DECL.name,
            "cache_distribution",
            claim.clone(),
        );
    }
    // The records of every cache slot and the cache stages' arguments.
    let cone = cone_trace::cone_params(&chain.frame, cones);
    let params = vxgi_cpu_mirror::cache_records::RecordsParams {
        width: w,
        tile: s.tile,
        tiles_x: w.div_ceil(s.tile),
        capacity: room.capacity,
        per: [
            s.res * s.res,
            if room.mips {
                vxgi_cpu_mirror::cache_preconvolve::mip_len(s.res) as u32
            } else {
                0
            },
            s.irr * s.irr,
        ],
        max_groups: ctx.limits().max_compute_workgroups_per_dimension,
        offset: cone.offset_voxels * cone.origin[3],
        _pad: [0; 3],
    };
    room.records = params;
    let tiles = (params.tiles_x * h.div_ceil(s.tile)) as usize;
    let mut records = cache_records::outputs(room.capacity as usize, tiles);
    records.insert(
        "records_params".into(),
        HostResource::Buffer(crate::harness::HostBuffer::pod(&params)),
    );
    chain.merge(cache_records::DECL.name, records)?;
    chain.push_as(
        cache_records::DECL.shader()?,
        cache_records::DECL.name,
        "cache_distribution",
        vec![cache_records::pass(ctx, &params)],
    );
    if let Some((_, keep)) = reuse {
        chain.push_as(
            cache_reuse::DECL.shader()?,
            cache_reuse::DECL.name,
            "cache_distribution",
            vec![keep],
        );
    }
    let after_records = chain.pass_count();
    // Creation, pre-convolution and the gather over every slot, dispatched from the arguments.
    let len = pyramid_texels(&chain);
    let zeros = cone_trace::Pyramids {
        colour: vec![[0.0; 4]; len],
        normal: Vec::new(),
    };
    let volume = match &hierarchies {
        None => CacheVolume::One(&zeros),
        Some((_, placed)) => CacheVolume::Placed(&zeros.colour, placed),
    };
    let (mut caches, parts) = cprc::cache_stages(
        ctx,
        &px,
        &CacheSet::empty(),
        room.capacity as usize,
        &s,
        volume,
        &cone,
        room.mips,
    )?;
    // The pyramid and its normals are the volume's (the case's normal pyramid is a placeholder where
    // the cones do not read it); the pixel inputs are `inputs`'.
    for name in ["pyramid_normal", "positions", "pixel_dirs"] {
        caches.remove(name);
    }
    chain.merge("the cache stages", caches)?;
    for (decl, mut passes) in parts {
        if decl.inputs.contains(&"pyramid") {
            // The windows of the chain's pyramids (the case's normal pyramid was a placeholder).
            cone_trace::bind_pyramid_views(
                &mut passes,
                &mut chain.resources,
                cone_trace::PYRAMID_WINDOW,
            )
            .map_err(anyhow::Error::msg)?;
        }
        let stage = match decl.name {
            "gather_caches" => "gather_caches",
            "cache_preconvolve" => "cache_preconvolve",
            _ => "cache_creation",
        };
        for p in &mut passes {
            let k = match p.entry.as_str() {
                "create" => Some(0),
                "mips" => Some(1),
                "irradiance" => Some(2),
                _ => None,
            };
            if let Some(k) = k {
                p.workgroups = Workgroups::Indirect {
                    buffer: "cache_args".into(),
                    offset: args_offset(k),
                };
            }
        }
        chain.push_as(decl.shader()?, decl.name, stage, passes);
    }
    chain.push_as(
        pixel_shader,
        cprc_pixels::DECL.name,
        "gather_caches",
        vec![cprc_pixels::pass(ctx, "compose", n)],
    );
    // The GPU's cache count into the uniform blocks of creation and pre-convolution (`count` is the
    // first field of both).
    for dst in ["cache_params", "pre_params"] {
        chain.copies.push(ChainCopy {
            src_range: None,
            after: after_records,
            src: "cache_count".into(),
            dst: dst.into(),
            offset: 0,
        });
    }
    Ok((chain, room, hierarchies.map(|(frames, _)| frames)))
}

/// What cprc's distribution hands its creation in a frame stage by stage ([`super::host`]).
pub(crate) struct CprcParts {
    px: crate::cprc::PixelInputs,
    set: crate::cprc::CacheSet,
}

/// The caches' placement over the G-buffer's clusters.
pub(crate) fn distribution_step(f: &mut HostFrame) -> Result<()> {
    use crate::cprc;
    let settings = cprc::CprcSettings::from(&f.scene.render);
    let params = cone_trace::cone_params(&f.frame, f.cones);
    let (pos, nrm, tri, alb) = cprc::gbuffer_arrays(&f.gb);
    let px = cprc::pixel_inputs(&f.data, &pos, &nrm, &tri, &alb, settings.res);
    let offset = params.offset_voxels * params.origin[3];
    let set = match f.side("cache_distribution") {
        Side::Mirror => cprc::distribute_mirror(&px, &settings, offset)?,
        Side::Gpu(ctx) => cprc::distribute_gpu(ctx, &px, &settings, offset)?,
    };
    f.cprc = Some(CprcParts { px, set });
    Ok(())
}

/// The caches' creation through the radiance pyramid, their pre-convolution and the gather (the
/// steps of `cache_creation`, `cache_preconvolve` and `gather_caches`: one GPU chain); (indirect,
/// ao) composed as the frame does.
pub(crate) fn creation_step(f: &mut HostFrame) -> Result<()> {
    use crate::cprc;
    let settings = cprc::CprcSettings::from(&f.scene.render);
    let params = cone_trace::cone_params(&f.frame, f.cones);
    let CprcParts { px, set } = f.cprc.as_ref().expect("the caches before their creation");
    let pyramid = f.pyramid.as_ref().expect("the pyramid before the caches");
    let gathered = match f.side("cache_creation") {
        Side::Mirror => cprc::evaluate_mirror(px, set, &settings, pyramid, &params),
        Side::Gpu(ctx) => cprc::evaluate_gpu(
            ctx,
            px,
            set,
            &settings,
            cprc::CacheVolume::One(pyramid),
            &params,
            &mut Vec::new(),
            &f.progress,
        )?,
    };
    let (indirect, ao, stats) = cprc::compose(px, &gathered);
    let vec4 = |img: &crate::images::RgbImage| {
        img.pixels.iter().map(|p| [p[0], p[1], p[2], 0.0]).collect()
    };
    f.cones_out = Some([vec4(&indirect), vec4(&ao)]);
    f.cprc_stats = Some(stats);
    Ok(())
}
