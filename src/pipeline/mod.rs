//! The four pipelines, each declared once ([`PipelineDecl`]: its stages, their kernels, reuse and
//! plan rules), and each one's frame as a chain of GPU stages over one set of named resources: the
//! kernels in order, each with its passes (direct or indirect dispatch), and the buffer copies
//! between them.
//! Built from the kernels' own cases (the resources and passes `vxgi verify` checks), so a chain runs
//! exactly the verified kernels. [`crate::resident::Resident`] prepares a chain once and records it
//! as one submission per frame; [`host`] runs a declaration stage by stage through host memory
//! (the mirror frames, `vxgi bisect`).
//! One file per pipeline (`vct_dense.rs`, `vct_svo.rs`, `lrsm.rs`, `cprc.rs`); this file holds the
//! chain itself and what several pipelines share (per-instance hierarchies, the camera's passes).
use crate::harness::{Case, HostResource, KernelDecl, Pass, Resources, Shader};
use crate::kernels::cone_trace::{self, ConeSettings};
use crate::kernels::lrsm_cone_trace::{self, LrsmFrame, LrsmMemory, LrsmSettings};
use crate::kernels::{direct_light, screen_tiles, triangle_setup, voxel_light, voxelize};
use crate::lrsm::{LightView, PartitionConfig};
use crate::plan::PlannedPass;
use crate::scene::Scene;
use crate::trace::SceneData;
use anyhow::{Context, Result};
use vxgi_cpu_mirror::surface_coverage_mip::Coverage;

/// One kernel's passes in a [`Chain`].
pub(crate) struct ChainStage {
    pub shader: Shader,
    pub kernel: &'static str,
    /// The declared frame stage it counts to (the plan's and the stage times' name; lrsm's
    /// light-view G-buffers and RSMs are `reflective_shadow_map`, their layers `lrsm_partition`).
    pub stage: &'static str,
    pub passes: Vec<Pass>,
}

/// A buffer copy on the GPU, recorded after the chain's first `after` passes.
#[derive(Clone, Debug)]
pub(crate) struct ChainCopy {
    /// The bytes of `src` copied; `None`: all of it.
    pub src_range: Option<std::ops::Range<u64>>,
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
}

/// Equal bytes (buffers: the scalar kind only tells the comparison how to read them) or equal
/// textures.
fn same_data(a: &HostResource, b: &HostResource) -> bool {
    match (a, b) {
        (HostResource::Buffer(x), HostResource::Buffer(y)) => x.bytes == y.bytes,
        _ => a == b,
    }
}

pub(crate) mod cprc;
mod declaration;
pub mod host;
mod lrsm;
mod vct_dense;
mod vct_svo;
pub use cprc::CPRC;
pub(crate) use cprc::*;
pub use declaration::*;
pub use lrsm::LRSM;
pub(crate) use lrsm::*;
pub use vct_dense::VCT_DENSE;
pub(crate) use vct_dense::*;
pub(crate) use vct_svo::*;
pub use vct_svo::{
    builds_in_chain, coverage_alone, lights_in_chain, OctreeRoom, LIT_IN_CHAIN_VOXELS, VCT_SVO,
};

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
    let (mut setups, mut vox, mut light, mut mips, mut frames) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut base = 0usize;
    let mut levels_at = Vec::new();
    let first = voxelized_by(&parts);
    for (k, (mesh, side, _)) in parts.iter().enumerate() {
        let d = first[k];
        let frame = if d < k {
            frames[d]
        } else {
            // The hierarchy's mesh set up on the GPU (triangle_setup), then voxelized, every
            // resource of the two named for the hierarchy.
            let local = scene.with_mesh_alone(mesh.clone());
            let (m, frame) = voxelize::mesh_input(&local, *side)?;
            let mut t = triangle_setup::case_for(ctx, &m, "render".into(), 0);
            let tris = voxelize::Triangles::Setup(&m);
            let mut v = voxelize::case_for(ctx, tris, *side, "render".into(), 0)?;
            v.rename_resource("params", "vox_params", false);
            let own: Vec<String> = v
                .resources
                .keys()
                .chain(t.resources.keys())
                .cloned()
                .collect();
            for name in own {
                v.rename_resource(&name, &hierarchy_name(&name, k), false);
                t.rename_resource(&name, &hierarchy_name(&name, k), false);
            }
            setups.push(t);
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
        let mut m = volume_mips(
            &mip_shader,
            ctx,
            *side,
            side.trailing_zeros() + 1,
            &hierarchy_name("vox_radiance", k),
            &hierarchy_name("vox_normal", d),
        );
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
    // One stage per kernel (triangle_setup's counted to voxelize), its passes every hierarchy's in
    // order (one shader each).
    for (decl, stage, cases) in [
        (&triangle_setup::DECL, voxelize::DECL.name, setups),
        (&voxelize::DECL, voxelize::DECL.name, vox),
        (&voxel_light::DECL, voxel_light::DECL.name, light),
        (&scm::DECL, scm::DECL.name, mips),
    ] {
        let mut passes = Vec::new();
        for c in cases {
            chain.merge(decl.name, c.resources)?;
            passes.extend(c.passes);
        }
        chain.push_as(decl.shader()?, decl.name, stage, passes);
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
                src_range: None,
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

/// A cone pass (`decl`'s `case`, counted to `stage` with the tile list) as the chain's last stages: screen_tiles lists
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
    chain.push_as(
        screen_tiles::DECL.shader()?,
        screen_tiles::DECL.name,
        stage,
        vec![screen_tiles::pass(w, h)],
    );
    chain.push_as(decl.shader()?, decl.name, stage, case.passes);
    Ok(())
}

/// The surface-coverage mip chain's case over a `side`^3 volume up to `levels` levels, level 0
/// bound to `radiance` (voxel_light's) and `normal` (voxelize's), its parameters as `mip_params`.
fn volume_mips(
    shader: &Shader,
    ctx: &crate::harness::GpuContext,
    side: u32,
    levels: u32,
    radiance: &str,
    normal: &str,
) -> Case {
    use crate::kernels::surface_coverage_mip as scm;
    let shell = crate::grids::Grid {
        n: side,
        colour: Vec::new(),
        normal: Vec::new(),
    };
    let mut mips = scm::chain_case_to(
        shader,
        ctx,
        &shell,
        Coverage::Surface,
        levels,
        "render".into(),
        0,
    );
    mips.rename_resource("params", "mip_params", false);
    mips.rename_resource(&scm::colour_name(0), radiance, true);
    mips.rename_resource(&scm::normal_name(0), normal, true);
    mips
}

/// The texels (rgba32f) of the chain's concatenated radiance pyramid.
fn pyramid_texels(chain: &Chain) -> usize {
    chain.resources["pyramid"]
        .buffer()
        .expect("a buffer")
        .bytes
        .len()
        / 16
}
