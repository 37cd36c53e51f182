//! vct-svo (Crassin et al. 2011: the sparse voxel octree): its declaration, the plan's rules for its
//! stages, and its chain: the whole octree where [`builds_in_chain`], else over an octree structure
//! its staged passes built (lighting it where [`lights_in_chain`]).
use super::host::{HostFrame, Side};
use super::*;
use crate::kernels::sparse_voxel_octree::BRICK_WINDOW;
use crate::kernels::svo_anisotropic::POOL_WINDOW;
use crate::kernels::{sparse_voxel_octree, svo_anisotropic, svo_cone_trace, svo_photons};
use vxgi_cpu_mirror::sparse_voxel_octree::{Fragment, Octree};

/// vct-svo's frame: vct-dense's G-buffer, direct light and voxelization, light injection by
/// voxel_light or photons, the octree instead of the mip chain (directional values, the lobes'
/// normal pool and a second bounce where the settings ask for them), the octree's cone tracer.
pub static VCT_SVO: PipelineDecl = PipelineDecl {
    name: "vct-svo",
    stages: &[
        GBUFFER_STAGE,
        DIRECT_LIGHT_STAGE,
        StageDecl {
            plan: svo_voxelize_plan,
            host: Some(svo_voxelize_step),
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
            host: Some(photons_step),
        },
        StageDecl {
            name: "sparse_voxel_octree",
            kernels: &[
                &crate::kernels::svo_fragments::DECL,
                &sparse_voxel_octree::DECL,
                &sparse_voxel_octree::WINDOWED_DECL,
            ],
            reuse: Reuse::Lights,
            split: Split::Always,
            plan: octree_plan,
            host: Some(octree_step),
        },
        StageDecl {
            name: "svo_anisotropic",
            kernels: &[&svo_anisotropic::DECL, &svo_anisotropic::WINDOWED_DECL],
            reuse: Reuse::Lights,
            split: Split::WhenRun,
            plan: anisotropic_plan,
            host: Some(anisotropic_step),
        },
        StageDecl {
            name: "svo_lobes",
            kernels: &[&sparse_voxel_octree::DECL],
            reuse: Reuse::Lights,
            split: Split::WhenRun,
            plan: lobes_plan,
            host: Some(lobes_step),
        },
        StageDecl {
            name: "svo_bounce",
            kernels: &[&svo_cone_trace::BOUNCE_DECL, &sparse_voxel_octree::DECL],
            reuse: Reuse::Lights,
            split: Split::Never,
            plan: bounce_plan,
            host: Some(bounce_step),
        },
        StageDecl {
            name: "svo_cone_trace",
            kernels: &[
                &screen_tiles::DECL,
                &svo_cone_trace::DECL,
                &svo_cone_trace::WINDOWED_DECL,
            ],
            reuse: Reuse::Camera,
            split: Split::Always,
            plan: svo_cone_trace_plan,
            host: Some(svo_cone_trace_step),
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

/// vct-dense's voxelization, about the octree; into occupancy bits where the staged build takes
/// its geometry from them ([`coverage_alone`]).
fn svo_voxelize_plan(i: &PlanInputs) -> Vec<PlannedPass> {
    let mut passes = octree_reasons(voxelize_plan(i));
    if coverage_alone(i.scene) && !builds_in_chain(i.scene) {
        for p in passes.iter_mut().filter(|p| p.runs) {
            p.why = "the octree's geometry: a bit per voxel a surface sample lands in (entry occupancy_bits; no accumulators, no colour or normal grid: photons carry the light)".into();
        }
    }
    passes
}

/// The octree's depth over the grid.
fn depth(i: &PlanInputs) -> u32 {
    vxgi_cpu_mirror::sparse_voxel_octree::depth_for(i.scene.render.voxels)
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

/// Whether `scene`'s frames light vct-svo's octree in the chain: voxel_light, the fragments
/// (`svo_fragments`: the fixed-point scale and the fragments, on the GPU), the octree's value
/// passes and its directional values, over the structure the chain builds ([`builds_in_chain`]:
/// in room sized at load, [`OctreeRoom`]) or, with Gaussian lobes, the staged build made; with
/// photon injection the photons too
/// (svo_photons per light view). Moved lights, and moved instances, then re-light it in the
/// frame's one submission. A second bounce, the glossy photons' specular pool (photons with
/// Gaussian lobes), the lobes' normal pool with instances (kept in the staged build's node layout,
/// which a structure built again does not keep) and grids past [`LIT_IN_CHAIN_VOXELS`] still build
/// the octree's values with the staged passes (host steps between them).
pub fn lights_in_chain(scene: &Scene) -> bool {
    let r = &scene.render;
    let specular_pool = r.photon_map > 0 && r.voxel_lobes;
    let lobes_with_instances = r.voxel_lobes && !scene.instances.list.is_empty();
    // svo_fragments binds the voxel grid (16 bytes a voxel) and the lattice's counts and largest
    // values (16 bytes a lattice point each) whole: up to 128^3 they fit WebGPU's default 128 MiB
    // storage binding, at 256^3 they do not.
    !(specular_pool || lobes_with_instances) && r.bounces == 1 && r.voxels <= LIT_IN_CHAIN_VOXELS
}

/// The largest grid side whose octree [`lights_in_chain`] lights.
pub const LIT_IN_CHAIN_VOXELS: u32 = 128;

/// Whether the voxels give vct-svo's octree its geometry alone: photons carry the light, and neither
/// the lobes' normal pool nor a second bounce reads the voxels' colour or normals. Then the staged
/// build voxelizes into occupancy bits (a bit a voxel, lrsm's) and lists their voxels, each of
/// coverage 1 ([`svo_cone_trace::listed_coverage`]), instead of voxelize's dense colour and normal
/// grids (32 bytes a voxel, and 32 more of accumulators): the same fragments. Not with dynamic
/// instances, whose static part the staged build keeps as a dense grid to merge them into.
pub fn coverage_alone(scene: &Scene) -> bool {
    let r = &scene.render;
    let dynamic = scene.instances.list.iter().any(|i| i.dynamic);
    r.photon_map > 0 && !r.voxel_lobes && r.bounces == 1 && !dynamic
}

/// Whether vct-svo's chain builds its octree's structure itself, the first frame included (no staged
/// passes at all): where [`lights_in_chain`], except with Gaussian lobes (their normal pool is
/// built by the staged passes, in the staged structure's node layout). Its room is sized at load
/// ([`OctreeRoom::at_load`]).
pub fn builds_in_chain(scene: &Scene) -> bool {
    lights_in_chain(scene) && !scene.render.voxel_lobes
}

/// What a chain that builds vct-svo's octree structure itself ([`builds_in_chain`]) holds for it,
/// sized at load from the scene as it stands with [`OctreeRoom::HEADROOM`] times its counts: voxel
/// fragment slots, node pool tiles and directional values. A later frame that needs more (moved
/// instances) is found after it ran ([`OctreeRoom::check`] on the GPU's counts, read back with the
/// frame's small outputs) and the renderer builds its chain again for it, sized from that frame.
#[derive(Clone, Debug, PartialEq)]
pub struct OctreeRoom {
    pub depth: u32,
    /// Voxel fragment slots (`svo_fragments`' capacity: the voxels voxelize may list).
    pub slots: u32,
    /// The node pool, in tiles of 8 nodes.
    pub tiles: u32,
    /// Directional values (0 without anisotropic voxels): nodes above the leaves x 162.
    pub aniso_values: usize,
}

impl OctreeRoom {
    /// Room for moving instances' voxels to grow: twice the counts at load. A scene without
    /// instances keeps its voxels and structure (moved lights change only their values), so its
    /// room is its counts.
    pub const HEADROOM: u32 = 2;
    /// The chain's buffers [`OctreeRoom::check`] reads after a frame.
    pub const READ: [&'static str; 3] = ["list_count", "octree_status", "octree_levels"];

    /// The room for `scene` as it stands, from the counts its frame will have, found on the host
    /// without the GPU: the voxels voxelize lists are those its samples land in (the mirror's
    /// `occupancy`, the same samples), one structure fragment each; the octree's structure over
    /// them (the mirror's structure pass: integer, the GPU's up to tile order) gives the node tiles
    /// and the nodes above the leaves. With the octree's memory at those counts.
    pub fn at_load(
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
    ) -> Result<(Self, sparse_voxel_octree::MemoryReport)> {
        use vxgi_cpu_mirror::sparse_voxel_octree::{capacity_bound, depth_for, STATUS_TILES};
        let side = scene.render.voxels;
        let (input, _) = crate::kernels::voxelize::prepare(scene, side)?;
        let bits = vxgi_cpu_mirror::voxelize::occupancy(&input.tris, side);
        let frags: Vec<Fragment> = vxgi_cpu_mirror::voxelize::occupied(&bits, (side as u64).pow(3))
            .map(Fragment::point)
            .collect();
        let depth = depth_for(side);
        let mut o = Octree::empty(depth, capacity_bound(depth, frags.len()) as u32);
        o.build_structure(&frags);
        let h = if scene.instances.list.is_empty() {
            1
        } else {
            Self::HEADROOM
        };
        let aniso = if scene.render.anisotropic_voxels {
            svo_anisotropic::values_of(depth, &o.levels)
        } else {
            0
        };
        let room = Self {
            depth,
            slots: (frags.len() as u32).max(1).saturating_mul(h),
            tiles: o.status[STATUS_TILES]
                .max(1)
                .saturating_mul(h)
                .min(sparse_voxel_octree::max_capacity(ctx)),
            aniso_values: aniso * h as usize,
        };
        let mut memory = sparse_voxel_octree::MemoryReport::of(&o);
        memory.anisotropic_bytes = aniso as u64 * 16;
        memory.bytes += memory.anisotropic_bytes;
        Ok((room, memory))
    }

    /// The room in words, for the plan.
    pub fn describe(&self) -> String {
        format!(
            "{} voxel fragments, {} octree tiles, {} directional values",
            self.slots, self.tiles, self.aniso_values,
        )
    }

    /// Whether the frame whose GPU counts these are fit: voxelize's `list_count`, the octree's
    /// `status` and `levels` (the node pool's overflow bit, the tiles above the leaves).
    pub fn check(&self, list_count: u32, status: &[u32], levels: &[u32]) -> Result<()> {
        use vxgi_cpu_mirror::sparse_voxel_octree::{ERR_POOL, STATUS_ERRORS, STATUS_TILES};
        anyhow::ensure!(
            list_count <= self.slots,
            "vct-svo's chain holds {} voxel fragments; this frame listed {list_count} voxels",
            self.slots
        );
        anyhow::ensure!(
            status[STATUS_ERRORS] & ERR_POOL == 0,
            "vct-svo's chain holds {} octree tiles; this frame's structure asked for {}",
            self.tiles,
            status[STATUS_TILES]
        );
        let above = svo_anisotropic::values_of(self.depth, levels);
        anyhow::ensure!(
            self.aniso_values == 0 || above <= self.aniso_values,
            "vct-svo's chain holds {} directional values; this frame's octree has {above}",
            self.aniso_values
        );
        Ok(())
    }

    /// [`OctreeRoom::check`] on the [`OctreeRoom::READ`] buffers of a frame's read-back outputs.
    pub fn check_read(&self, out: &crate::harness::Resources) -> Result<()> {
        let words = |n: &str| -> Vec<u32> {
            bytemuck::cast_slice(&out[n].buffer().expect("a buffer").bytes).to_vec()
        };
        let [count, status, levels] = Self::READ.map(words);
        self.check(count[0], &status, &levels)
    }
}

/// vct-svo's chain. Where [`builds_in_chain`] (`volume` None): voxelize, the light injection, the
/// fragments, the octree's structure (in room sized at load: [`OctreeRoom`]), its values and
/// directional values, then the camera's stages: the whole frame, the first one included. Else over
/// an octree built already (`volume`, by [`crate::render::VctSvo`]'s GPU passes with the host steps
/// between them): where [`lights_in_chain`], voxelize, voxel_light, the fragments, the octree's
/// values and directional values over the kept structure, then the camera's stages; else the
/// camera's stages alone (gbuffer, direct_light, screen_tiles, svo_cone_trace) over the octree's
/// nodes, bricks and pools as they are. With the room (and the octree's memory at load) where the
/// chain builds the structure.
pub(crate) fn svo_chain(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    data: &SceneData,
    cones: &ConeSettings,
    volume: Option<&crate::render::SvoCache>,
) -> Result<(
    Chain,
    Option<(OctreeRoom, sparse_voxel_octree::MemoryReport)>,
)> {
    use crate::kernels::gbuffer;
    let in_chain = lights_in_chain(scene);
    anyhow::ensure!(
        volume.is_none() == builds_in_chain(scene),
        "vct-svo's chain builds its octree where builds_in_chain, else binds the staged build's"
    );
    let room = match volume {
        None => Some(OctreeRoom::at_load(ctx, scene)?),
        Some(_) => None,
    };
    let anisotropic = volume.map_or(scene.render.anisotropic_voxels, |v| v.aniso.is_some());
    // The octree the chain lights and the cone pass reads: its own, in the room, or the staged
    // build's.
    let lit = match (&room, volume) {
        (Some((r, _)), _) => Lit::Built(r, anisotropic),
        (None, v) => Lit::Kept(v.expect("a staged build where the chain builds no octree")),
    };
    let g = gbuffer::case_for(data, "render".into(), 0);
    let d = direct_light::case_with_gbuffer(ctx, data, &Default::default(), "render".into(), 0);
    let mut chain = Chain {
        resources: Resources::new(),
        stages: Vec::new(),
        copies: Vec::new(),
        frame: volume.map_or_else(
            || crate::kernels::voxelize::frame_of(&scene.mesh, scene.render.voxels),
            |v| v.frame,
        ),
    };
    if in_chain {
        let photons = match scene.render.photon_map {
            0 => {
                chain = lit_voxel_chain(ctx, scene, data)?.0;
                None
            }
            map => {
                chain = voxel_chain(ctx, scene)?;
                Some(photon_passes(ctx, &mut chain, data, map)?)
            }
        };
        light_octree(ctx, &mut chain, lit, scene.render.bounces, photons)?;
    }
    let params = svo_cone_trace::svo_cone_params(&chain.frame, cones);
    // Where the chain builds the octree, the cone pass's case binds placeholders the chain's
    // buffers replace (its parameters' `inv_scale` copied in once the scale is found).
    let unbuilt;
    // The cone pass reads the pools in windows where the bricks are past one binding or the values
    // past two (`decl_for`).
    let cone = match lit {
        Lit::Kept(v) => svo_cone_trace::decl_for(
            v.built.octree.bricks.len(),
            v.aniso.as_ref().map_or(0, |a| a.len()),
        ),
        Lit::Built(r, _) => svo_cone_trace::decl_for(
            r.tiles as usize * 8 * vxgi_cpu_mirror::sparse_voxel_octree::BRICK_WORDS,
            r.aniso_values,
        ),
    };
    let (octree, extras, scale) = match lit {
        Lit::Kept(v) => (&v.built.octree, v.extras(), v.scale),
        Lit::Built(r, _) => {
            unbuilt = vxgi_cpu_mirror::sparse_voxel_octree::Octree::empty(r.depth, 1);
            let extras = svo_cone_trace::SvoExtras {
                aniso: anisotropic.then_some(&[][..]),
                normals: None,
                spec: None,
            };
            (&unbuilt, extras, 1.0)
        }
    };
    let mut c = svo_cone_trace::case_in(
        cone,
        data,
        &g.resources,
        octree,
        extras,
        scale,
        &params,
        "render".into(),
        0,
    );
    // The G-buffer the later stages bind is gbuffer's output (zeroed here, computed in the chain);
    // the cone pass runs over the tiles screen_tiles lists from it on the GPU (the case's host-built
    // list replaced by an empty one the chain fills). `nodes` is the ray caster's BVH in gbuffer and
    // direct_light, the octree's in the cone pass.
    let (w, h) = (data.width(), data.height());
    c.rename_resource("nodes", "octree_nodes", false);
    c.rename_resource("bricks", "octree_bricks", false);
    if in_chain {
        // Lit in the chain: the cone pass binds the octree and directional values the chain
        // computes, not the staged build's.
        c.resources.remove("octree_nodes");
        c.resources.remove("octree_bricks");
        if anisotropic {
            c.resources.remove("aniso");
        }
    }
    c.resources
        .insert("tile_list".into(), screen_tiles::empty_list(w, h));
    chain.merge(gbuffer::DECL.name, g.resources)?;
    chain.merge(direct_light::DECL.name, d.resources)?;
    chain.merge(cone.name, c.resources)?;
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
    let stage = svo_cone_trace::DECL.name;
    chain.push_as(cone.shader()?, cone.name, stage, c.passes);
    // The octree's pools in the windows each pass's kernel declares (the windowed declarations:
    // bricks in five, values in six; the others: values in two), where the pools are past them.
    for stage in &mut chain.stages {
        let has = |name: &str| stage.shader.bindings.iter().any(|b| b.name == name);
        let bricks = has("bricks_1");
        let views: Vec<&str> = svo_anisotropic::POOL_VIEWS
            .into_iter()
            .filter(|v| has(v))
            .collect();
        let (passes, r) = (&mut stage.passes, &mut chain.resources);
        if bricks {
            sparse_voxel_octree::bind_brick_windows(passes, r, "octree_bricks", BRICK_WINDOW)
                .map_err(anyhow::Error::msg)?;
        }
        if views.len() > 1 {
            svo_anisotropic::bind_pool_windows(passes, r, "aniso", &views, POOL_WINDOW)
                .map_err(anyhow::Error::msg)?;
        }
    }
    Ok((chain, room))
}

/// The names of light view `v`'s G-buffer frame and photon parameters in vct-svo's chain: what a
/// frame whose lights moved writes again.
pub(crate) fn photon_view_names(v: usize) -> (String, String) {
    (format!("photon_frame_{v}"), format!("photon_params_{v}"))
}

/// Photon injection in `chain` (stage `svo_photons`): per light view of `data`'s lights, the
/// G-buffer ray-cast from the light (`map`^2 texels, one set of view buffers every view reuses) and
/// svo_photons over it, its photons copied into `photon_pos`, `photon_value` and `photon_spec` at
/// the view's offset. The photon texels in all.
fn photon_passes(
    ctx: &crate::harness::GpuContext,
    chain: &mut Chain,
    data: &SceneData,
    map: u32,
) -> Result<u32> {
    use crate::harness::{HostBuffer, ScalarKind};
    use crate::kernels::gbuffer;
    const STAGE: &str = "svo_photons";
    let views = crate::lrsm::light_views(&data.lights, data.bounds, map, data.frame.eye[3])?;
    let per_view = map as usize * map as usize;
    let texels = per_view * views.len();
    let shader = svo_photons::DECL.shader()?;
    let view_gb = |n: &str| format!("photon_{n}");
    for (v, view) in views.iter().enumerate() {
        let (frame_name, params_name) = photon_view_names(v);
        let mut d = data.clone();
        d.frame = view.frame;
        let mut g = gbuffer::case_for(&d, "light view".into(), 0);
        g.rename_resource("frame", &frame_name, false);
        for n in ["gb_position", "gb_normal", "gb_triangle", "gb_albedo"] {
            g.rename_resource(n, &view_gb(n), false);
        }
        let zero_gb: Resources = ["gb_position", "gb_normal", "gb_triangle", "gb_albedo"]
            .into_iter()
            .map(|n| (n.to_string(), g.resources[&view_gb(n)].clone()))
            .collect();
        chain.add(&gbuffer::DECL, STAGE, g)?;
        let params = svo_photons::params_for(view, &chain.frame);
        let mut p = svo_photons::case_for(
            &shader,
            ctx,
            data,
            &data.lights,
            &params,
            &zero_gb,
            "render".into(),
            0,
        );
        p.rename_resource("params", &params_name, false);
        for n in ["gb_position", "gb_normal", "gb_triangle", "gb_albedo"] {
            p.rename_resource(n, &view_gb(n), false);
        }
        for n in ["photon_pos", "photon_value", "photon_spec"] {
            p.rename_resource(n, &format!("view_{n}"), false);
        }
        chain.add(&svo_photons::DECL, STAGE, p)?;
        for n in ["photon_pos", "photon_value", "photon_spec"] {
            chain.copies.push(ChainCopy {
                src_range: None,
                after: chain.pass_count(),
                src: format!("view_{n}"),
                dst: n.into(),
                offset: (v * per_view * 16) as u64,
            });
        }
    }
    for (n, kind) in [
        ("photon_pos", ScalarKind::U32),
        ("photon_value", ScalarKind::F32),
        ("photon_spec", ScalarKind::F32),
    ] {
        chain.resources.insert(
            n.into(),
            HostResource::Buffer(HostBuffer::zeroed(texels.max(1) * 16, kind)),
        );
    }
    Ok(texels as u32)
}

/// The octree [`light_octree`] lights.
#[derive(Clone, Copy)]
enum Lit<'a> {
    /// The staged build's structure, kept: its values computed again over it.
    Kept(&'a crate::render::SvoCache),
    /// Built by the chain in this room; whether with directional values.
    Built(&'a OctreeRoom, bool),
}

/// The octree lit in `chain` after its light injection (`photons`: the photon texels
/// [`photon_passes`] cast; `None`: voxel_light's `vox_radiance`): `svo_fragments` (the frame's
/// fixed-point scale and one fragment per listed voxel: its light, or with photons its coverage
/// from `vox_colour`, then one per photon texel), the octree's value passes (splat, border
/// transfer, distribution) over the structure `volume` kept (its buffers `octree_*`, the bricks
/// zero) or, with a `room`, over the structure the chain builds first in it from the voxels'
/// fragments, and the directional values level by level. `1 / scale` is copied into the cone
/// pass's and the directional passes' parameters after the scale is found. The normal pool
/// (Gaussian lobes without photons) keeps the staged build's scale: its lobes read ratios of its
/// channels, which a power-of-two scale leaves exact. svo_fragments' error bits (`scale_state[1]`)
/// are not read back: the scale makes every finite value fit, and a photon at a lattice point the
/// structure lacks adds nothing. The octree's `status` is read back where a `room` can be
/// outgrown ([`OctreeRoom::check`]).
fn light_octree(
    ctx: &crate::harness::GpuContext,
    chain: &mut Chain,
    octree: Lit,
    bounces: u32,
    photons: Option<u32>,
) -> Result<()> {
    use crate::harness::run::{grid_for, Workgroups};
    use crate::harness::{HostBuffer, ScalarKind};
    use crate::kernels::{sparse_voxel_octree as svo, svo_fragments as sf};
    use vxgi_cpu_mirror::svo_anisotropic::{level_nodes, passes as aniso_passes, AnisoParams};
    let (depth, capacity, scale) = match octree {
        Lit::Kept(v) => (v.built.octree.depth, v.listed.max(1), v.scale),
        // The scale is found on the GPU and copied in: 1 until then.
        Lit::Built(r, _) => (r.depth, r.slots, 1.0),
    };
    // The directional values' count, where the octree has them.
    let aniso = match octree {
        Lit::Kept(v) => v.aniso.as_ref().map(|a| a.len()),
        Lit::Built(r, on) => on.then_some(r.aniso_values),
    };
    let texels = photons.unwrap_or(0);
    let side = chain.frame.side;
    let max = ctx.limits().max_compute_workgroups_per_dimension;
    let buf = |b: HostBuffer| HostResource::Buffer(b);
    let zeroed = |bytes: usize, kind| buf(HostBuffer::zeroed(bytes.max(16), kind));
    // The fragments: one per listed voxel (with photons its coverage alone, then one per photon
    // texel), in the octree's fixed point. Voxel light holds one value per lattice point (`most` =
    // 1, the threshold known here); with photons the lattice's counts give the threshold.
    let fparams = sf::FragmentParams {
        capacity,
        coverage_only: photons.is_some() as u32,
        threshold: vxgi_cpu_mirror::svo_fragments::threshold(bounces, 1),
        _pad: 0,
    };
    let lattice = sf::LatticeParams {
        side,
        photons: texels,
        bounces,
        _pad: 0,
    };
    let points = if photons.is_some() {
        4 * (side as usize + 1).pow(3)
    } else {
        0
    };
    let mut res = Resources::new();
    res.insert("fragment_params".into(), buf(HostBuffer::pod(&fparams)));
    res.insert("lattice_params".into(), buf(HostBuffer::pod(&lattice)));
    res.insert(
        "scale_state".into(),
        zeroed(sf::STATE_WORDS * 4, ScalarKind::U32),
    );
    res.insert("svo_scale".into(), zeroed(8, ScalarKind::F32));
    res.insert(
        "octree_fragments".into(),
        zeroed((capacity + texels) as usize * 32, ScalarKind::U32),
    );
    for n in ["point_count", "point_max"] {
        res.insert(n.into(), zeroed(points * 4, ScalarKind::U32));
    }
    if photons.is_none() {
        for (n, kind) in [
            ("photon_pos", ScalarKind::U32),
            ("photon_value", ScalarKind::F32),
            ("photon_spec", ScalarKind::F32),
        ] {
            res.insert(n.into(), zeroed(16, kind));
        }
    }
    chain.merge(sf::DECL.name, res)?;
    let shader = sf::DECL.shader()?;
    // With photons the voxels' coverage alone: the colour grid read as `vox_radiance`.
    let grid = if photons.is_some() {
        "vox_colour"
    } else {
        "vox_radiance"
    };
    let bindings: Vec<(String, crate::harness::run::View)> = sf::DECL
        .bind_by_name()
        .into_iter()
        .map(|(b, v)| {
            let to = match b.as_str() {
                "params" => "fragment_params",
                "fragments" => "octree_fragments",
                "vox_radiance" => grid,
                _ => return (b, v),
            };
            (b, crate::harness::run::View::Buffer(to.into()))
        })
        .collect();
    let over = |n: u64| Workgroups::Direct(grid_for(n.max(1), 64, max));
    let one = Workgroups::Direct([1, 1, 1]);
    let entries = match photons {
        None => vec![
            ("peak", over(capacity as u64)),
            ("scale", one),
            ("write_fragments", over(capacity as u64)),
        ],
        Some(t) => vec![
            ("voxel_points", over(capacity as u64)),
            ("photon_points", over(t as u64)),
            ("lattice_peak", over(points as u64)),
            ("lattice_scale", one),
            ("write_fragments", over(capacity as u64)),
            ("write_photon_fragments", over(t as u64)),
        ],
    };
    let passes = entries
        .into_iter()
        .map(|(entry, workgroups)| Pass {
            label: format!("svo_fragments {entry}"),
            entry: entry.into(),
            bindings: bindings.clone(),
            workgroups,
        })
        .collect();
    chain.push_as(shader, sf::DECL.name, "sparse_voxel_octree", passes);
    let scaled = chain.pass_count();
    let mut case = match octree {
        Lit::Built(room, _) => {
            // The octree over every fragment slot: its structure from the voxels' fragments (the
            // first `list_count` slots: with photons too the structure is the voxels' alone, whichever
            // light cast them; a photon at a point the voxels lack adds nothing), then its values.
            for level in 1..=depth {
                chain.copies.push(ChainCopy {
                    after: scaled,
                    src_range: Some(0..4),
                    src: "list_count".into(),
                    dst: format!("octree_{}", svo::flagging_params(level)),
                    offset: std::mem::offset_of!(
                        vxgi_cpu_mirror::sparse_voxel_octree::OctreeParams,
                        fragments
                    ) as u64,
                });
            }
            svo::case_in_chain(
                ctx,
                depth,
                room.tiles,
                capacity + texels,
                capacity,
                "render".into(),
                0,
            )
        }
        Lit::Kept(volume) => {
            let o = &volume.built.octree;
            // The octree's value passes over the kept structure: every fragment slot, the bricks zero.
            let frags = vec![bytemuck::Zeroable::zeroed(); (capacity + texels) as usize];
            let mut case = svo::case_replayed(
                ctx,
                o.depth,
                o.capacity_tiles,
                &frags,
                None,
                false,
                "render".into(),
                0,
            );
            case.passes.retain(|p| svo::phase_of(&p.entry) != "build");
            for (name, b) in &volume.built.structure {
                case.resources.insert(name.clone(), buf(b.clone()));
            }
            case
        }
    };
    // The windows' placeholders keep their names (the chain binds the windows: svo_chain).
    let names: Vec<String> = case.resources.keys().cloned().collect();
    for n in names
        .iter()
        .filter(|n| !svo::BRICK_VIEWS[1..].contains(&n.as_str()))
    {
        case.rename_resource(n, &format!("octree_{n}"), false);
    }
    // The build reads its brick pool in windows where it is past one binding.
    let tiles = match octree {
        Lit::Kept(v) => v.built.octree.capacity_tiles,
        Lit::Built(r, _) => r.tiles,
    };
    chain.add(svo::decl_for(tiles), "sparse_voxel_octree", case)?;
    // svo_cone_trace's `SvoParams::inv_scale`.
    chain.copies.push(ChainCopy {
        after: scaled,
        src_range: Some(4..8),
        src: "svo_scale".into(),
        dst: "svo".into(),
        offset: std::mem::offset_of!(vxgi_cpu_mirror::svo_cone_trace::SvoParams, inv_scale) as u64,
    });
    // The directional values, a pass per level (depth - 1 first), into the cone pass's pool.
    if let Some(values) = aniso {
        use crate::kernels::svo_anisotropic as sa;
        // Each level's node slots: as the kept structure has them, or (a structure the chain
        // builds) as many as the level can have in the pool: the pass finds its own in `levels`.
        let slots = |level: u32| match octree {
            Lit::Kept(v) => level_nodes(&v.built.octree.levels, level).len() as u64,
            Lit::Built(r, _) => {
                let most = if level == 0 {
                    1
                } else {
                    1u64 << (3 * (level - 1))
                };
                most.min(r.tiles as u64) * 8
            }
        };
        let mut res = Resources::new();
        res.insert("aniso".into(), zeroed(values.max(1) * 16, ScalarKind::F32));
        let words = tiles as usize * 8 * vxgi_cpu_mirror::sparse_voxel_octree::BRICK_WORDS;
        let decl = sa::decl_for(words, values);
        let shader = decl.shader()?;
        let mut passes = Vec::new();
        for p in aniso_passes(depth, 1.0 / scale) {
            let name = format!("aniso_params_{}", p.level);
            res.insert(name.clone(), buf(HostBuffer::pod(&p)));
            let bindings = decl
                .bind_by_name()
                .into_iter()
                .map(|(b, v)| {
                    let to = match b.as_str() {
                        "params" => name.clone(),
                        "nodes" => "octree_nodes".into(),
                        "bricks" => "octree_bricks".into(),
                        "levels" => "octree_levels".into(),
                        _ => return (b, v),
                    };
                    (b, crate::harness::run::View::Buffer(to))
                })
                .collect();
            passes.push(decl.pass(
                &shader,
                ctx,
                format!("level {}", p.level),
                bindings,
                slots(p.level) * 27,
            ));
            chain.copies.push(ChainCopy {
                after: scaled,
                src_range: Some(4..8),
                src: "svo_scale".into(),
                dst: name,
                offset: std::mem::offset_of!(AnisoParams, inv_scale) as u64,
            });
        }
        chain.merge(decl.name, res)?;
        chain.push_as(shader, decl.name, "svo_anisotropic", passes);
    }
    Ok(())
}

/// What vct-svo's stages hand each other in a frame stage by stage ([`super::host`]).
#[derive(Default)]
pub(crate) struct SvoParts {
    photons: Option<svo_photons::Photons>,
    /// The fixed point of the octree's values (the one every split's values fit, as the frame's).
    scale: f32,
    frags: Vec<Fragment>,
    spec_frags: Vec<Fragment>,
    octree: Option<Octree>,
    aniso: Option<Vec<[f32; 4]>>,
    normals: Option<Vec<u32>>,
    spec: Option<Vec<u32>>,
}

impl SvoParts {
    fn octree(&self) -> &Octree {
        self.octree
            .as_ref()
            .expect("the octree before its directional values")
    }
}

/// The octree's depth for the frame's grid: 2^(depth+1) voxels a side.
fn depth_of(f: &HostFrame) -> u32 {
    vxgi_cpu_mirror::sparse_voxel_octree::depth_for(f.frame.side)
}

/// vct-svo's voxelization: where the voxels give the octree its geometry alone ([`coverage_alone`]),
/// occupancy bits and their voxels listed, with no dense grid; else voxelize's grids.
pub(crate) fn svo_voxelize_step(f: &mut HostFrame) -> Result<()> {
    if !coverage_alone(f.scene) {
        return super::host::voxelize_step(f);
    }
    let side = f.scene.render.voxels;
    let (input, frame) = crate::kernels::voxelize::prepare(f.scene, side)?;
    let bits = match f.side("voxelize") {
        Side::Mirror => vxgi_cpu_mirror::voxelize::occupancy(&input.tris, side),
        Side::Gpu(ctx) => crate::kernels::voxelize::occupancy_of_input(ctx, &input, side)?,
    };
    f.list = vxgi_cpu_mirror::voxelize::occupied(&bits, (side as u64).pow(3)).collect();
    f.grid = crate::grids::Grid {
        n: side,
        colour: Vec::new(),
        normal: Vec::new(),
    };
    f.frame = frame;
    Ok(())
}

/// The light by photons: their values, and the voxels' coverage alone.
pub(crate) fn photons_step(f: &mut HostFrame) -> Result<()> {
    let map = f.scene.render.photon_map;
    let photons = match f.side("svo_photons") {
        Side::Mirror => svo_photons::mirror_photons(&f.data, &f.frame, map)?,
        Side::Gpu(ctx) => svo_photons::photons_on_gpu(ctx, &f.data, &f.frame, map)?,
    };
    f.svo.get_or_insert_with(Default::default).photons = Some(photons);
    Ok(())
}

/// The octree of the lit voxels (or the voxels' coverage and the photons).
pub(crate) fn octree_step(f: &mut HostFrame) -> Result<()> {
    let lobes = f.plan.runs("svo_lobes");
    let depth = depth_of(f);
    let side = f.side("sparse_voxel_octree");
    let bounces = f.scene.render.bounces;
    let svo = f.svo.get_or_insert_with(Default::default);
    // With photons the voxels' coverage alone, from the list of them.
    let values: Vec<_> = match &svo.photons {
        Some(_) => svo_cone_trace::listed_coverage(&f.list).collect(),
        None => svo_cone_trace::grid_values(&f.radiance).collect(),
    };
    let photon_values = svo.photons.iter().flat_map(|p| p.values());
    svo.scale = svo_cone_trace::fixed_scale(values.iter().copied().chain(photon_values), bounces);
    svo.frags = svo_cone_trace::values_fragments(values.into_iter(), svo.scale)?;
    if let Some(photons) = &svo.photons {
        svo.spec_frags = photons
            .fragments(svo.scale)?
            .join_into(&mut svo.frags, lobes);
    }
    svo.octree = Some(match side {
        Side::Mirror => vxgi_cpu_mirror::sparse_voxel_octree::build_fitted(depth, &svo.frags),
        Side::Gpu(ctx) => sparse_voxel_octree::build_on_gpu(ctx, depth, &svo.frags, None)?.octree,
    });
    Ok(())
}

/// The octree's anisotropic (directional) values.
pub(crate) fn anisotropic_step(f: &mut HostFrame) -> Result<()> {
    let side = f.side("svo_anisotropic");
    let svo = f.svo.as_mut().expect("the octree before its values");
    let inv = 1.0 / svo.scale;
    svo.aniso = Some(match side {
        Side::Mirror => svo_anisotropic::build_mirror(svo.octree(), inv),
        Side::Gpu(ctx) => svo_anisotropic::build_on_gpu(ctx, svo.octree(), inv)?,
    });
    Ok(())
}

/// The lobes' pools: the voxels' coverage and mean normals, the specular photons.
pub(crate) fn lobes_step(f: &mut HostFrame) -> Result<()> {
    let side = f.side("svo_lobes");
    let svo = f.svo.as_mut().expect("the octree before its lobes");
    let (n, g) = svo_cone_trace::lobe_pools(
        side.gpu(),
        svo.octree(),
        &svo.frags,
        [&f.grid.colour, &f.grid.normal],
        &svo.spec_frags,
        svo.scale,
    )?;
    (svo.normals, svo.spec) = (Some(n), g);
    Ok(())
}

/// The octree's parameters for the cone tracers.
fn svo_params(f: &HostFrame, svo: &SvoParts) -> vxgi_cpu_mirror::svo_cone_trace::SvoParams {
    let lobes = f.plan.runs("svo_lobes");
    vxgi_cpu_mirror::svo_cone_trace::SvoParams {
        depth: depth_of(f),
        inv_scale: 1.0 / svo.scale,
        anisotropic: f.plan.runs("svo_anisotropic") as u32,
        lobes: lobes as u32 | ((lobes && !svo.spec_frags.is_empty()) as u32) << 1,
    }
}

/// A second bounce, by the mirrors alone: each lit voxel's indirect light through the octree becomes
/// fragments of its own, and the octree and its values are built again from all of them.
pub(crate) fn bounce_step(f: &mut HostFrame) -> Result<()> {
    use svo_cone_trace as sct;
    anyhow::ensure!(
        matches!(f.side("svo_bounce"), Side::Mirror),
        "the second bounce runs on the mirrors only in a frame stage by stage (bounces = 1 on the GPU)"
    );
    if f.radiance.is_empty() {
        f.radiance = super::host::lit_voxels(&f.data, &f.grid, &f.list, &f.frame);
    }
    let params = svo_cone_trace::svo_cone_params(&f.frame, f.cones);
    let svo = f.svo.take().expect("the octree before the bounce");
    let sp = svo_params(f, &svo);
    let voxels = sct::bounce_voxels(&f.radiance, &f.grid.normal, &f.grid.colour, &f.frame);
    let empty: Vec<u32> = Vec::new();
    let ind: Vec<[f32; 4]> = sct::bounce_mirror(
        &svo.octree().nodes,
        &svo.octree().bricks,
        svo.aniso.as_deref().unwrap_or(&[]),
        [
            svo.normals.as_deref().unwrap_or(&empty),
            svo.spec.as_deref().unwrap_or(&empty),
        ],
        &sp,
        &params,
        [&voxels.position, &voxels.normal, &voxels.albedo],
    )
    .into_iter()
    .map(|v| v.0)
    .collect();
    let mut svo = svo;
    svo.frags.extend(sct::bounce_fragments(
        &voxels,
        &ind,
        &f.radiance,
        svo.scale,
    )?);
    svo.octree = Some(vxgi_cpu_mirror::sparse_voxel_octree::build_fitted(
        depth_of(f),
        &svo.frags,
    ));
    let (anisotropic, lobes) = (f.plan.runs("svo_anisotropic"), f.plan.runs("svo_lobes"));
    f.svo = Some(svo);
    if anisotropic {
        anisotropic_step(f)?;
    }
    if lobes {
        lobes_step(f)?;
    }
    Ok(())
}

/// The octree's cone pass.
pub(crate) fn svo_cone_trace_step(f: &mut HostFrame) -> Result<()> {
    let svo = f.svo.as_ref().expect("the octree before the cones");
    let params = svo_cone_trace::svo_cone_params(&f.frame, f.cones);
    let octree = svo.octree();
    f.cones_out = Some(match f.side("svo_cone_trace") {
        Side::Mirror => {
            let sp = svo_params(f, svo);
            let volume = vxgi_cpu_mirror::svo_cone_trace::SvoVolume {
                p: &params,
                svo: &sp,
                nodes: &octree.nodes,
                bricks: &octree.bricks,
                aniso: svo.aniso.as_deref().unwrap_or(&[]),
                normals: svo.normals.as_deref().unwrap_or(&[]),
                spec: svo.spec.as_deref().unwrap_or(&[]),
            };
            let lmax = svo_cone_trace::max_radiance(&octree.bricks, sp.inv_scale);
            f.shade(&volume, lmax)
        }
        Side::Gpu(ctx) => {
            let extras = svo_cone_trace::SvoExtras {
                aniso: svo.aniso.as_deref(),
                normals: svo.normals.as_deref(),
                spec: svo.spec.as_deref(),
            };
            let case = svo_cone_trace::case_for(
                &f.data,
                &f.gb,
                octree,
                extras,
                svo.scale,
                &params,
                "host".into(),
                0,
            );
            let decl =
                svo_cone_trace::decl_for(octree.bricks.len(), extras.aniso.map_or(0, |a| a.len()));
            super::host::gpu_cones(ctx, decl, &case)?
        }
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::OctreeRoom;
    use vxgi_cpu_mirror::sparse_voxel_octree::{ERR_POOL, LEVELS_WORDS};
    use vxgi_cpu_mirror::svo_anisotropic::NODE_VALUES;

    /// A frame fits its room up to each bound and not one past it: the voxels listed, the pool's
    /// overflow bit and the directional values of the nodes above the leaves.
    #[test]
    fn a_frame_outgrows_the_room_at_each_bound() {
        let room = OctreeRoom {
            depth: 3,
            slots: 100,
            tiles: 50,
            aniso_values: 10 * 8 * NODE_VALUES,
        };
        let mut levels = vec![0u32; LEVELS_WORDS];
        levels[3] = 10;
        let ok = [0, 40, 0, 0];
        assert!(room.check(100, &ok, &levels).is_ok());
        let e = room.check(101, &ok, &levels).unwrap_err().to_string();
        assert!(
            e.contains("100 voxel fragments") && e.contains("101"),
            "{e}"
        );
        let e = room
            .check(100, &[ERR_POOL, 61, 0, 0], &levels)
            .unwrap_err()
            .to_string();
        assert!(e.contains("50 octree tiles") && e.contains("61"), "{e}");
        levels[3] = 11;
        assert!(room.check(100, &ok, &levels).is_err());
        // Without directional values their bound does not apply.
        let isotropic = OctreeRoom {
            aniso_values: 0,
            ..room
        };
        assert!(isotropic.check(100, &ok, &levels).is_ok());
    }
}
