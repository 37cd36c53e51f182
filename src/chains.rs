//! Each pipeline's frame as a chain of GPU stages over one set of named resources: the kernels in
//! order, each with its passes (direct or indirect dispatch), and the buffer copies between them.
//! Built from the kernels' own cases (the resources and passes `vxgi verify` checks), so a chain runs
//! exactly the verified kernels. [`crate::render`] runs vct-dense's stage by stage;
//! [`crate::resident::Resident`] prepares a chain once and records it as one submission per frame.
use crate::harness::{Case, HostResource, KernelDecl, Pass, Resources, Shader};
use crate::kernels::cone_trace::{self, ConeSettings};
use crate::kernels::lrsm_cone_trace::{self, LrsmFrame, LrsmMemory, LrsmSettings};
use crate::kernels::{direct_light, screen_tiles, voxel_light, voxelize};
use crate::lrsm::{LightView, PartitionConfig};
use crate::scene::Scene;
use crate::trace::SceneData;
use anyhow::{Context, Result};
use vxgi_cpu_mirror::surface_coverage_mip::Coverage;

/// One kernel's passes in a [`Chain`].
pub(crate) struct ChainStage {
    pub shader: Shader,
    pub kernel: &'static str,
    /// The frame stage it counts to (the plan's and the stage times' name; lrsm's light-view
    /// G-buffers, RSMs and LRSMs are all `reflective_shadow_map`).
    pub stage: &'static str,
    pub passes: Vec<Pass>,
}

/// A buffer copy on the GPU, recorded after the chain's first `after` passes.
#[derive(Clone, Debug)]
pub(crate) struct ChainCopy {
    pub after: usize,
    pub src: String,
    pub dst: String,
    pub offset: u64,
}

/// A pipeline's frame as data (see the module doc).
pub(crate) struct Chain {
    pub resources: Resources,
    pub stages: Vec<ChainStage>,
    pub copies: Vec<ChainCopy>,
    /// The voxel grid's frame.
    pub frame: voxelize::VoxelFrame,
}

impl Chain {
    fn push(&mut self, shader: Shader, kernel: &'static str, passes: Vec<Pass>) {
        self.push_as(shader, kernel, kernel, passes);
    }

    fn push_as(
        &mut self,
        shader: Shader,
        kernel: &'static str,
        stage: &'static str,
        passes: Vec<Pass>,
    ) {
        self.stages.push(ChainStage {
            shader,
            kernel,
            stage,
            passes,
        });
    }

    /// Add `case` as a stage of `decl`'s kernel counted to `stage`: its resources merged
    /// ([`Chain::merge`]), its passes appended.
    fn add(&mut self, decl: &'static KernelDecl, stage: &'static str, case: Case) -> Result<()> {
        self.merge(decl.name, case.resources)?;
        self.push_as(decl.shader()?, decl.name, stage, case.passes);
        Ok(())
    }

    /// Add a case's resources: a name two stages share must hold the same data (it is one GPU
    /// resource); anything else is a wiring error, refused with both stages' view of it.
    fn merge(&mut self, kernel: &str, resources: Resources) -> Result<()> {
        for (name, r) in resources {
            match self.resources.get(&name) {
                None => {
                    self.resources.insert(name, r);
                }
                Some(old) if same_data(old, &r) => {}
                Some(_) => anyhow::bail!(
                    "chain wiring: {kernel}'s resource `{name}` differs from the one an earlier stage binds under that name"
                ),
            }
        }
        Ok(())
    }

    /// How many passes the chain holds so far.
    pub fn pass_count(&self) -> usize {
        self.stages.iter().map(|s| s.passes.len()).sum()
    }

    pub fn harness_stages(&self) -> Vec<crate::harness::Stage<'_>> {
        self.stages
            .iter()
            .map(|s| crate::harness::Stage {
                shader: &s.shader,
                kernel: s.kernel,
                passes: &s.passes,
            })
            .collect()
    }

    /// The copies as [`crate::harness::Prepared::copy_into`] takes them.
    pub fn copy_list(&self) -> Vec<(&str, &str, u64)> {
        self.copies
            .iter()
            .map(|c| (c.src.as_str(), c.dst.as_str(), c.offset))
            .collect()
    }
}

/// Equal bytes (buffers: the scalar kind only tells the comparison how to read them) or equal
/// textures.
fn same_data(a: &HostResource, b: &HostResource) -> bool {
    match (a, b) {
        (HostResource::Buffer(x), HostResource::Buffer(y)) => x.bytes == y.bytes,
        _ => a == b,
    }
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
    use crate::harness::run::{grid_for, Pass, Workgroups};
    use crate::harness::{HostBuffer, HostResource, ScalarKind};
    use crate::kernels::surface_coverage_mip::{self as scm, colour_name};
    use vxgi_cpu_mirror::cone_trace::{level_offset, pyramid_len};
    let side = scene.render.voxels;
    let v = (side as u64).pow(3);
    let max = ctx.limits().max_compute_workgroups_per_dimension;
    let (input, vframe) = voxelize::prepare(scene, side)?;
    let mut vox = voxelize::case_for(ctx, &input, side, "render".into(), 0)?;
    vox.rename_resource("params", "vox_params", false);
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
    let light_passes = vec![Pass {
        label: "voxel_light".into(),
        entry: "main".into(),
        bindings: voxel_light::DECL.bind_by_name(),
        workgroups: Workgroups::Direct(grid_for(v, 64, max)),
    }];
    // The mip chain from voxel_light's radiance and voxelize's normals, up to the levels the cones
    // read (all of them without a cone pass: the pyramid is kept for other cones).
    let levels = cone_pass.map_or(side.trailing_zeros() + 1, |(_, _, l)| l);
    let mip_shader = scm::DECL.shader()?;
    let shell = crate::grids::Grid {
        n: side,
        colour: Vec::new(),
        normal: Vec::new(),
    };
    let mut mips = scm::chain_case_to(
        &mip_shader,
        ctx,
        &shell,
        Coverage::Surface,
        levels,
        "render".into(),
        0,
    );
    mips.rename_resource("params", "mip_params", false);
    mips.rename_resource(&colour_name(0), "vox_radiance", true);
    mips.rename_resource(&scm::normal_name(0), "vox_normal", true);
    let mut resources = vox.resources;
    resources.extend(light_res);
    resources.extend(mips.resources);
    // The cone pass, dispatched over the tiles screen_tiles lists on the GPU from the G-buffer (the
    // case's host-built list replaced by an empty one the chain fills).
    let (tiles, cone) = match cone_pass {
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
            (vec![screen_tiles::pass(w, h)], c.passes)
        }
        None => (Vec::new(), Vec::new()),
    };
    // The pyramid and its normal pyramid (the depth-ordered blend reads it; kept with the pyramid),
    // filled below from the chain's levels.
    for name in ["pyramid", "pyramid_normal"] {
        resources.insert(
            name.into(),
            HostResource::Buffer(HostBuffer::zeroed(pyramid_len(side) * 16, ScalarKind::F32)),
        );
    }
    let mut chain = Chain {
        resources,
        stages: Vec::new(),
        copies: Vec::new(),
        frame: vframe,
    };
    chain.push(voxelize::DECL.shader()?, voxelize::DECL.name, vox.passes);
    chain.push(
        voxel_light::DECL.shader()?,
        voxel_light::DECL.name,
        light_passes,
    );
    chain.push(mip_shader, scm::DECL.name, mips.passes);
    let after_mips = chain.pass_count();
    // The G-buffer and direct light after the volume (they do not read it): a frame that reuses the
    // volume runs one contiguous range of passes.
    if gbuffer_in_chain {
        let g = crate::kernels::gbuffer::case_for(data, "render".into(), 0);
        let d = direct_light::case_with_gbuffer(ctx, data, &Default::default(), "render".into(), 0);
        for (k, v) in g.resources.into_iter().chain(d.resources) {
            chain.resources.entry(k).or_insert(v);
        }
        let gbuffer = &crate::kernels::gbuffer::DECL;
        chain.push(gbuffer.shader()?, gbuffer.name, g.passes);
        chain.push(
            direct_light::DECL.shader()?,
            direct_light::DECL.name,
            d.passes,
        );
    }
    chain.push(screen_tiles::DECL.shader()?, screen_tiles::DECL.name, tiles);
    chain.push(cone_trace::DECL.shader()?, cone_trace::DECL.name, cone);
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
            after: after_mips,
            src,
            dst: to.to_string(),
            offset: level_offset(side, l as u32) as u64 * 16,
        })
        .collect();
    Ok(chain)
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

/// lrsm's chain (Sugihara et al. 2014), the same kernels on the same inputs as
/// [`crate::render::VctLrsm`]'s frame: voxelize's occupancy bits and occlusion_voxels' mips over them
/// (every level copied into `occ`);
/// per light view the G-buffer ray-cast from the light, reflective_shadow_map, lrsm_partition and
/// lrsm_prefilter (its levels copied into the three LRSM streams at the view's offset; every view
/// reuses one set of RSM buffers, as the staged frame holds one RSM at a time); then the camera's
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
    anyhow::ensure!(!data.lights.is_empty(), "lrsm's chain needs lights");
    let settings = LrsmSettings::from(&scene.render);
    let config = settings.partition();
    config.validate(ctx.limits().max_storage_buffer_binding_size)?;
    let side = scene.render.voxels;
    let (input, vframe) = voxelize::prepare(scene, side)?;
    let mut chain = Chain {
        resources: Resources::new(),
        stages: Vec::new(),
        copies: Vec::new(),
        frame: vframe,
    };
    // Voxelize's occupancy bits are level 0 of the occlusion voxels (the same resource), their mips
    // follow; every level is copied into `occ`.
    let mut vox = voxelize::occupancy_case(ctx, &input, side, "render".into(), 0)?;
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
        chain.add(&lrsm_partition::DECL, RSM, p)?;
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
            chain.add(&lrsm_prefilter::DECL, RSM, f)?;
        }
        let after = chain.pass_count();
        let mut first = v as u64 * per_view;
        for k in 0..levels {
            for (s, dst) in LRSM_STREAMS.iter().enumerate() {
                chain.copies.push(ChainCopy {
                    after,
                    src: lrsm_prefilter::stream_name(s, k),
                    dst: dst.to_string(),
                    offset: first * 16,
                });
            }
            first += config.layers() as u64 * ((side0 >> k) as u64).pow(2);
        }
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
    let stream = vec![[0.0f32; 4]; (per_view * views.len() as u64) as usize];
    let frame = LrsmFrame {
        voxels: vframe,
        occ: vec![0; words as usize],
        occ_offsets,
        views: views.iter().map(|v| v.view).collect(),
        params: crate::kernels::sample_lrsm::sample_params(&config, 0, settings.view_weight),
        depth_ranges: config.depth_ranges(),
        streams: [stream.clone(), stream.clone(), stream],
        memory: LrsmMemory::default(),
    };
    let memory = LrsmMemory {
        occlusion: words as u64 * 4,
        rsm: texels as u64 * 36,
        lrsm: per_view * views.len() as u64 * 48,
        views: views.len() as u32,
    };
    let params = cone_trace::cone_params(&vframe, cones);
    let tan = if soft {
        settings.shadow_cone_angle.to_radians().tan()
    } else {
        0.0
    };
    let c = lrsm_cone_trace::case_for(data, &camera_gb, &frame, &params, tan, "render".into(), 0);
    push_tiled_cone_pass(
        &mut chain,
        data,
        &lrsm_cone_trace::DECL,
        lrsm_cone_trace::DECL.name,
        c,
    )?;
    Ok((chain, memory))
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
    use crate::kernels::{cache_records, cprc_pixels};
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
    let after_records = chain.pass_count();
    // Creation, pre-convolution and the gather over every slot, dispatched from the arguments.
    let len = chain.resources["pyramid"]
        .buffer()
        .expect("a buffer")
        .bytes
        .len()
        / 16;
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
            after: after_records,
            src: "cache_count".into(),
            dst: dst.into(),
            offset: 0,
        });
    }
    Ok((chain, room, hierarchies.map(|(frames, _)| frames)))
}

/// Where a scene's voxel hierarchies stand this frame (CPRC 3.1): what the cones read (`placed`, one
/// record per hierarchy) and what voxel_light lights each hierarchy with (its grid record, placed by
/// the instance's transform), in [`instanced_volume`]'s order; the march's world grid.
pub(crate) struct Placement {
    pub placed: Vec<vxgi_cpu_mirror::cache_creation::Placed>,
    pub grids: Vec<vxgi_cpu_mirror::voxel_light::VoxelGrid>,
    pub world: voxelize::VoxelFrame,
}

/// The name of hierarchy `k`'s copy of a per-hierarchy resource.
pub(crate) fn hierarchy_name(name: &str, k: usize) -> String {
    format!("{name}#{k}")
}

/// [`Placement`] of `scene`'s hierarchies whose grids are `frames` (each in its own frame, as
/// [`instanced_volume`] voxelized them), stored in the concatenated pyramid one after another.
pub(crate) fn placement(scene: &Scene, frames: &[voxelize::VoxelFrame]) -> Result<Placement> {
    use vxgi_cpu_mirror::cache_creation::Placed;
    use vxgi_cpu_mirror::cone_trace::pyramid_len;
    let (world, parts) = crate::render::hierarchy_parts(scene);
    anyhow::ensure!(
        parts.len() == frames.len(),
        "{} voxel hierarchies where the chain holds {}",
        parts.len(),
        frames.len()
    );
    let (mut placed, mut grids, mut base) = (Vec::new(), Vec::new(), 0usize);
    for ((_, _, m), f) in parts.iter().zip(frames) {
        placed.push(Placed::new(
            f.origin.to_array(),
            f.voxel,
            f.side,
            base as u32,
            *m,
            world.voxel,
        ));
        let grid = voxel_light::voxel_grid(f, scene.lights.len());
        grids.push(if *m != glam::Mat4::IDENTITY {
            grid.placed(*m)
        } else {
            grid
        });
        base += pyramid_len(f.side);
    }
    Ok(Placement {
        placed,
        grids,
        world,
    })
}

/// For each voxel hierarchy of `parts` (`hierarchy_parts`' order), the first hierarchy with the same
/// mesh and grid side: instances of one mesh share one voxelization, since in their own frame it
/// does not depend on where they stand (only their lighting and mips are per hierarchy).
pub(crate) fn voxelized_by(parts: &[(crate::scene::Mesh, u32, glam::Mat4)]) -> Vec<usize> {
    let mut distinct: Vec<usize> = Vec::new();
    parts
        .iter()
        .enumerate()
        .map(|(k, (mesh, side, _))| {
            let same = |&&d: &&usize| {
                let (m, s, _) = &parts[d];
                s == side && m == mesh
            };
            match distinct.iter().find(same) {
                Some(&d) => d,
                None => {
                    distinct.push(k);
                    k
                }
            }
        })
        .collect()
}

/// The voxel hierarchies of a scene with `[[instances]]` as stages of a new chain: each distinct
/// mesh voxelized once in its own frame (the instance's mesh alone, [`voxelized_by`]; its outputs
/// named after the first hierarchy of that mesh), each hierarchy lit where it stands (voxel_light with its
/// placed grid record: shadows from the whole scene), its surface-coverage mips built, and its levels
/// copied into the concatenated `pyramid` (what the instanced cone passes read with `placed`). Every
/// per-hierarchy resource is named `name#k`; the chain holds one stage per kernel (every
/// hierarchy's passes): voxelize first, then voxel_light, then the mips, so that re-lighting is one
/// range of passes. Returns the chain, each
/// hierarchy's grid frame and where the hierarchies stand (their `grid#k` records are in the chain).
pub(crate) fn instanced_volume(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    data: &SceneData,
) -> Result<(Chain, Vec<voxelize::VoxelFrame>, Placement)> {
    use crate::harness::run::{grid_for, Pass, Workgroups};
    use crate::harness::{HostBuffer, ScalarKind};
    use crate::kernels::surface_coverage_mip::{self as scm, colour_name};
    use vxgi_cpu_mirror::cone_trace::{level_offset, pyramid_len};
    let (world, parts) = crate::render::hierarchy_parts(scene);
    let max = ctx.limits().max_compute_workgroups_per_dimension;
    let mut chain = Chain {
        resources: Resources::new(),
        stages: Vec::new(),
        copies: Vec::new(),
        frame: world,
    };
    let mip_shader = scm::DECL.shader()?;
    let (mut vox, mut light, mut mips, mut frames) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut base = 0usize;
    let mut levels_at = Vec::new();
    let first = voxelized_by(&parts);
    for (k, (mesh, side, _)) in parts.iter().enumerate() {
        let d = first[k];
        let frame = if d < k {
            frames[d]
        } else {
            let local = scene.with_mesh_alone(mesh.clone());
            let (input, frame) = voxelize::prepare(&local, *side)?;
            let mut v = voxelize::case_for(ctx, &input, *side, "render".into(), 0)?;
            v.rename_resource("params", "vox_params", false);
            let own: Vec<String> = v.resources.keys().cloned().collect();
            for name in own {
                v.rename_resource(&name, &hierarchy_name(&name, k), false);
            }
            vox.push(v);
            frame
        };
        let cells = (*side as u64).pow(3);
        let mut l = Case {
            label: "render".into(),
            seed: 0,
            resources: Resources::from([
                (
                    "grid".to_string(),
                    HostResource::Buffer(HostBuffer::pod(&voxel_light::voxel_grid(
                        &frame,
                        data.lights.len(),
                    ))),
                ),
                (
                    "vox_radiance".to_string(),
                    HostResource::Buffer(HostBuffer::zeroed(cells as usize * 16, ScalarKind::F32)),
                ),
            ]),
            passes: vec![Pass {
                label: "voxel_light".into(),
                entry: "main".into(),
                bindings: voxel_light::DECL.bind_by_name(),
                workgroups: Workgroups::Direct(grid_for(cells, 64, max)),
            }],
            checks: Vec::new(),
            effective_bytes: 0,
        };
        for name in ["grid", "vox_radiance"] {
            l.rename_resource(name, &hierarchy_name(name, k), false);
        }
        for name in ["vox_colour", "vox_normal", "list", "list_count"] {
            l.rename_resource(name, &hierarchy_name(name, d), false);
        }
        let shell = crate::grids::Grid {
            n: *side,
            colour: Vec::new(),
            normal: Vec::new(),
        };
        let levels = side.trailing_zeros() + 1;
        let mut m = scm::chain_case_to(
            &mip_shader,
            ctx,
            &shell,
            Coverage::Surface,
            levels,
            "render".into(),
            0,
        );
        m.rename_resource("params", "mip_params", false);
        m.rename_resource(&colour_name(0), &hierarchy_name("vox_radiance", k), true);
        m.rename_resource(&scm::normal_name(0), &hierarchy_name("vox_normal", d), true);
        let own: Vec<String> = m.resources.keys().cloned().collect();
        for name in own {
            m.rename_resource(&name, &hierarchy_name(&name, k), false);
        }
        levels_at.push((k, *side, base));
        base += pyramid_len(*side);
        frames.push(frame);
        light.push(l);
        mips.push(m);
    }
    let mut light_res = crate::kernels::gbuffer::scene_resources(data);
    light_res.remove("frame");
    light_res.remove("materials");
    chain.merge(voxel_light::DECL.name, light_res)?;
    chain.resources.insert(
        "pyramid".into(),
        HostResource::Buffer(HostBuffer::zeroed(base.max(1) * 16, ScalarKind::F32)),
    );
    // One stage per kernel, its passes every hierarchy's in order (one shader each).
    for (decl, cases) in [
        (&voxelize::DECL, vox),
        (&voxel_light::DECL, light),
        (&scm::DECL, mips),
    ] {
        let mut passes = Vec::new();
        for c in cases {
            chain.merge(decl.name, c.resources)?;
            passes.extend(c.passes);
        }
        chain.push(decl.shader()?, decl.name, passes);
    }
    let after_mips = chain.pass_count();
    for (k, side, base) in levels_at {
        for l in 0..side.trailing_zeros() + 1 {
            let src = if l == 0 {
                hierarchy_name("vox_radiance", k)
            } else {
                hierarchy_name(&colour_name(l), k)
            };
            chain.copies.push(ChainCopy {
                after: after_mips,
                src,
                dst: "pyramid".into(),
                offset: (base + level_offset(side, l) as usize) as u64 * 16,
            });
        }
    }
    let at = placement(scene, &frames)?;
    for (k, grid) in at.grids.iter().enumerate() {
        chain.resources.insert(
            hierarchy_name("grid", k),
            HostResource::Buffer(HostBuffer::pod(grid)),
        );
    }
    Ok((chain, frames, at))
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
    let len = chain.resources["pyramid"]
        .buffer()
        .expect("a buffer")
        .bytes
        .len()
        / 16;
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

/// The camera's G-buffer and direct light as the next stages of `chain`.
fn push_camera_gbuffer(
    ctx: &crate::harness::GpuContext,
    data: &SceneData,
    chain: &mut Chain,
) -> Result<()> {
    let g = crate::kernels::gbuffer::case_for(data, "render".into(), 0);
    let d = direct_light::case_with_gbuffer(ctx, data, &Default::default(), "render".into(), 0);
    chain.merge(crate::kernels::gbuffer::DECL.name, g.resources)?;
    chain.merge(direct_light::DECL.name, d.resources)?;
    let gbuffer = &crate::kernels::gbuffer::DECL;
    chain.push(gbuffer.shader()?, gbuffer.name, g.passes);
    chain.push(
        direct_light::DECL.shader()?,
        direct_light::DECL.name,
        d.passes,
    );
    Ok(())
}

/// A cone pass (`decl`'s `case`, counted to `stage`) as the chain's last stages: screen_tiles lists
/// the tiles holding a surface on the GPU (the case's host-built list replaced by an empty one it
/// fills), then the pass is dispatched over them.
fn push_tiled_cone_pass(
    chain: &mut Chain,
    data: &SceneData,
    decl: &'static KernelDecl,
    stage: &'static str,
    mut case: Case,
) -> Result<()> {
    let (w, h) = (data.width(), data.height());
    case.resources
        .insert("tile_list".into(), screen_tiles::empty_list(w, h));
    chain.merge(decl.name, case.resources)?;
    chain.push(
        screen_tiles::DECL.shader()?,
        screen_tiles::DECL.name,
        vec![screen_tiles::pass(w, h)],
    );
    chain.push_as(decl.shader()?, decl.name, stage, case.passes);
    Ok(())
}
