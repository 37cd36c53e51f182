//! A pipeline's frame stage by stage through host memory, each stage on the scalar mirrors or on the
//! GPU (DESIGN.md section 3, after Vello's CPU/GPU stage switch): the loop over a declaration's
//! stages ([`StageDecl::host`](super::StageDecl::host)) that gives both the mirror frames (every stage on the mirrors: what
//! the snapshot tests store) and `vxgi bisect`'s split frames (the mirrors up to a stage, the GPU
//! after it, each GPU stage fed what the mirrors produced). Not the renderer: frames that stay on
//! the GPU are [`crate::resident::Resident`]'s.
//!
//! A stage's step reads what earlier steps left in the [`HostFrame`] and adds its own products. A
//! stage without a step ([`StageDecl::host`](super::StageDecl::host) `None`) is run by an earlier stage's step, which
//! interleaves them (lrsm's RSM and layers per light view; cprc's creation, pre-convolution and
//! gather, one GPU chain). Stages the frame's plan does not run are not stepped.
use super::declaration::{PipelineDecl, PlanInputs};
use crate::harness::{GpuContext, HostBuffer, HostResource, Resources};
use crate::images::RgbImage;
use crate::kernels::cone_trace::{self, ConeSettings};
use crate::kernels::{direct_light, voxel_light, voxelize};
use crate::plan::FramePlan;
use crate::render::Rendered;
use crate::scene::Scene;
use crate::trace::SceneData;
use anyhow::Result;

/// Where a stage runs.
#[derive(Clone, Copy)]
pub enum Side<'a> {
    Mirror,
    Gpu(&'a GpuContext),
}

impl<'a> Side<'a> {
    /// The GPU, or `None` on the mirror side (the helpers that take `Option<&GpuContext>`).
    pub fn gpu(self) -> Option<&'a GpuContext> {
        match self {
            Side::Mirror => None,
            Side::Gpu(ctx) => Some(ctx),
        }
    }
}

/// A stage's step: run it on the side `frame.side(stage)` says, reading and adding to `frame`.
pub type HostStep = fn(&mut HostFrame<'_>) -> Result<()>;

/// What a frame's stages hand each other through host memory (see the module doc). Fields are
/// filled by the steps that produce them; a step that needs one an earlier step did not fill is a
/// wiring error of the declaration.
pub struct HostFrame<'a> {
    pub(crate) scene: &'a Scene,
    pub(crate) cones: &'a ConeSettings,
    pub(crate) plan: FramePlan,
    pub(crate) data: SceneData,
    pub(crate) ctx: Option<&'a GpuContext>,
    pub(crate) on_mirror: &'a dyn Fn(&str) -> bool,
    /// Told what a step is doing (a stage's parts: lrsm's light views, cprc's chains).
    pub(crate) progress: &'a dyn Fn(&str),
    /// The camera's G-buffer: `gb_position`, `gb_normal`, `gb_triangle`, `gb_albedo`.
    pub(crate) gb: Resources,
    /// Direct light per pixel (0 where the plan does not run direct_light).
    pub(crate) direct: Vec<[f32; 4]>,
    /// The voxel grid (colour with coverage in w, normals; Morton order), its occupied voxels and
    /// frame; lrsm's binary voxels are `bits` instead.
    pub(crate) grid: crate::grids::Grid,
    pub(crate) list: Vec<u32>,
    pub(crate) frame: voxelize::VoxelFrame,
    pub(crate) bits: Vec<u32>,
    /// Lit voxels `(L * alpha, alpha)` (voxel_light).
    pub(crate) radiance: Vec<[f32; 4]>,
    /// The radiance pyramid and its normals (surface_coverage_mip).
    pub(crate) pyramid: Option<cone_trace::Pyramids>,
    pub(crate) svo: Option<super::vct_svo::SvoParts>,
    pub(crate) lrsm: Option<crate::kernels::lrsm_cone_trace::LrsmFrame>,
    pub(crate) cprc: Option<super::cprc::CprcParts>,
    /// The cone pass's (indirect, ao) per pixel.
    pub(crate) cones_out: Option<[Vec<[f32; 4]>; 2]>,
    pub(crate) cprc_stats: Option<crate::cprc::CprcStats>,
    /// (stage, wall-clock seconds) of the stages stepped.
    pub(crate) stages: Vec<(&'static str, f64)>,
}

impl<'a> HostFrame<'a> {
    /// The side stage `stage` runs on: the mirrors where `on_mirror` says so or no GPU is given.
    pub(crate) fn side(&self, stage: &str) -> Side<'a> {
        match self.ctx {
            Some(ctx) if !(self.on_mirror)(stage) => Side::Gpu(ctx),
            _ => Side::Mirror,
        }
    }

    /// Cone-trace every texel of the G-buffer through `volume` by the mirror (cone_trace's pixel
    /// entry, the interleaved resolve where the cones are interleaved): (indirect, ao).
    pub(crate) fn shade(
        &self,
        volume: &(impl vxgi_cpu_mirror::cone_trace::Volume + Sync),
        lmax: f32,
    ) -> [Vec<[f32; 4]>; 2] {
        use rayon::prelude::*;
        use vxgi_cpu_mirror::cone_trace as ct;
        let p = volume.params();
        let dirs = ct::cone_dirs(p);
        let d = &self.data;
        let w = d.width();
        let (pos, nrm, tri, alb) = crate::cprc::gbuffer_arrays(&self.gb);
        let shaded: Vec<ct::PixelOut> = (0..tri.len())
            .into_par_iter()
            .map(|i| {
                let cones = ct::class_cones(&dirs, p, i as u32 % w, i as u32 / w);
                ct::shade_pixel(
                    volume,
                    &d.frame,
                    &d.triangles,
                    &d.materials,
                    &cones,
                    pos[i],
                    nrm[i],
                    tri[i],
                    alb[i],
                    lmax,
                )
            })
            .collect();
        let shaded = if p.interleave > 1 {
            ct::resolve(p, w, &pos, &nrm, &alb, &shaded)
        } else {
            shaded
        };
        cone_trace::indirect_and_ao(&shaded)
    }

    /// The frame's images, its stage times and plan.
    pub(crate) fn rendered(self) -> Rendered {
        let (w, h) = (self.data.width(), self.data.height());
        let rgb =
            |v: &[[f32; 4]]| RgbImage::new(w, h, v.iter().map(|p| [p[0], p[1], p[2]]).collect());
        let [indirect, ao] = self.cones_out.unwrap_or_else(|| {
            [
                vec![[0.0; 4]; (w * h) as usize],
                vec![[0.0; 4]; (w * h) as usize],
            ]
        });
        Rendered::assemble(
            rgb(&self.direct),
            rgb(&indirect),
            rgb(&ao),
            self.stages,
            self.plan,
        )
    }
}

/// `decl`'s frame for `scene`, each stage on the side `on_mirror` says (all on the mirrors without
/// `ctx`), `progress(stage)` before each: the images, the plan of a first frame, the stage times,
/// and cprc's cache statistics.
pub fn frame(
    decl: &PipelineDecl,
    ctx: Option<&GpuContext>,
    scene: &Scene,
    cones: &ConeSettings,
    on_mirror: &dyn Fn(&str) -> bool,
    progress: &dyn Fn(&str),
) -> Result<(Rendered, Option<crate::cprc::CprcStats>)> {
    let mut f = run(decl, ctx, scene, cones, on_mirror, progress, None)?;
    let stats = f.cprc_stats.take();
    Ok((f.rendered(), stats))
}

/// The steps of `decl`'s stages up to (not including) `until`, or all: the frame as the steps left
/// it (for diagnostics that trace the cones through a volume of their own).
pub(crate) fn run<'a>(
    decl: &PipelineDecl,
    ctx: Option<&'a GpuContext>,
    scene: &'a Scene,
    cones: &'a ConeSettings,
    on_mirror: &'a dyn Fn(&str) -> bool,
    progress: &'a dyn Fn(&str),
    until: Option<&str>,
) -> Result<HostFrame<'a>> {
    anyhow::ensure!(
        scene.render.shadow_cone_angle == 0.0 || decl.name != super::LRSM.name,
        "the stage-by-stage lrsm frame traces exact shadow rays (shadow_cone_angle = {}; set it to 0)",
        scene.render.shadow_cone_angle
    );
    let plan = FramePlan::of(decl, &PlanInputs::new(scene, cones, false));
    let data = SceneData::new(scene);
    let n = data.width() as usize * data.height() as usize;
    let mut f = HostFrame {
        scene,
        cones,
        plan,
        data,
        ctx,
        on_mirror,
        progress,
        gb: Resources::new(),
        direct: vec![[0.0; 4]; n],
        grid: crate::grids::Grid {
            n: 0,
            colour: Vec::new(),
            normal: Vec::new(),
        },
        list: Vec::new(),
        frame: voxelize::frame_of(&scene.mesh, scene.render.voxels),
        bits: Vec::new(),
        radiance: Vec::new(),
        pyramid: None,
        svo: None,
        lrsm: None,
        cprc: None,
        cones_out: None,
        cprc_stats: None,
        stages: Vec::new(),
    };
    for s in decl.stages {
        if Some(s.name) == until {
            break;
        }
        let Some(step) = s.host else { continue };
        if !f.plan.runs(s.name) {
            continue;
        }
        progress(s.name);
        let t = std::time::Instant::now();
        let before = f.stages.len();
        step(&mut f)?;
        // A step that times the stages it runs itself (lrsm's light views) has pushed them.
        if f.stages.len() == before {
            f.stages.push((s.name, t.elapsed().as_secs_f64()));
        }
    }
    Ok(f)
}

/// The camera's G-buffer: the mirror's primary hits, or the gbuffer kernel.
pub(crate) fn gbuffer_step(f: &mut HostFrame) -> Result<()> {
    f.gb = match f.side("gbuffer") {
        Side::Mirror => {
            let (texels, albedo) = crate::render::mirror_texels(&f.data);
            let f4 =
                |v: Vec<[f32; 4]>| HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(&v)));
            let triangles: Vec<u32> = texels.iter().map(|t| t.triangle).collect();
            Resources::from([
                (
                    "gb_position".to_string(),
                    f4(texels.iter().map(|t| t.position).collect()),
                ),
                (
                    "gb_normal".to_string(),
                    f4(texels.iter().map(|t| t.normal).collect()),
                ),
                (
                    "gb_triangle".to_string(),
                    HostResource::Buffer(HostBuffer::u32(&triangles)),
                ),
                ("gb_albedo".to_string(), f4(albedo)),
            ])
        }
        Side::Gpu(ctx) => direct_light::gpu_gbuffer(ctx, &f.data),
    };
    Ok(())
}

/// Direct light by exact shadow rays at every texel of the G-buffer.
pub(crate) fn direct_light_step(f: &mut HostFrame) -> Result<()> {
    f.direct = match f.side("direct_light") {
        Side::Mirror => {
            use rayon::prelude::*;
            use vxgi_cpu_mirror::direct_light as dl;
            let (pos, nrm, tri, alb) = crate::cprc::gbuffer_arrays(&f.gb);
            let d = &f.data;
            (0..tri.len())
                .into_par_iter()
                .map(|i| {
                    let (l, _) = dl::shade_with_bound(
                        &d.frame,
                        &d.nodes,
                        &d.triangles,
                        &d.lights,
                        &d.materials,
                        pos[i],
                        nrm[i],
                        tri[i],
                        alb[i],
                    );
                    [l.x, l.y, l.z, 0.0]
                })
                .collect()
        }
        Side::Gpu(ctx) => {
            let case = direct_light::case_with_gbuffer(ctx, &f.data, &f.gb, "host".into(), 0);
            let out = direct_light::DECL.run(ctx, &case, &["radiance"])?;
            bytemuck::cast_slice(&out.buffer("radiance").bytes).to_vec()
        }
    };
    Ok(())
}

/// The voxel grid of the scene's mesh (colour, coverage, normals) and its occupied voxels. A
/// scene with instances is voxelized as its flattened mesh.
pub(crate) fn voxelize_step(f: &mut HostFrame) -> Result<()> {
    let side = f.scene.render.voxels;
    (f.grid, f.list, f.frame) = match f.side("voxelize") {
        Side::Mirror => {
            let (input, frame) = voxelize::prepare(f.scene, side)?;
            let (colour, normal, list) = vxgi_cpu_mirror::voxelize::voxelize(&input, side);
            let grid = crate::grids::Grid {
                n: side,
                colour,
                normal,
            };
            (grid, list, frame)
        }
        Side::Gpu(ctx) => voxelize::voxelize_on_gpu(ctx, f.scene, side)?,
    };
    Ok(())
}

/// Direct light into the occupied voxels, by exact shadow rays: `(L * alpha, alpha)`.
pub(crate) fn voxel_light_step(f: &mut HostFrame) -> Result<()> {
    f.radiance = match f.side("voxel_light") {
        Side::Mirror => lit_voxels(&f.data, &f.grid, &f.list, &f.frame),
        Side::Gpu(ctx) => voxel_light::light_on_gpu(ctx, &f.data, &f.grid, &f.list, &f.frame)?,
    };
    Ok(())
}

/// voxel_light's mirror over the occupied voxels `list` of `grid`.
pub(crate) fn lit_voxels(
    data: &SceneData,
    grid: &crate::grids::Grid,
    list: &[u32],
    frame: &voxelize::VoxelFrame,
) -> Vec<[f32; 4]> {
    use rayon::prelude::*;
    use vxgi_cpu_mirror::voxel_light as vl;
    let g = voxel_light::voxel_grid(frame, data.lights.len());
    let lit: Vec<(u32, [f32; 4])> = list
        .par_iter()
        .map(|&v| {
            let (l, _) = vl::light_voxel(
                &g,
                &data.nodes,
                &data.triangles,
                &data.lights,
                grid.colour[v as usize],
                grid.normal[v as usize],
                v,
            );
            (v, l)
        })
        .collect();
    let mut out = vec![[0.0f32; 4]; grid.colour.len()];
    for (v, l) in lit {
        out[v as usize] = l;
    }
    out
}

/// The surface-coverage pyramid of the lit voxels and its normals.
pub(crate) fn mips_step(f: &mut HostFrame) -> Result<()> {
    f.pyramid = Some(match f.side("surface_coverage_mip") {
        Side::Mirror => cone_trace::mirror_pyramid(&f.radiance, &f.grid.normal),
        Side::Gpu(ctx) => {
            cone_trace::gpu_pyramid(ctx, &f.radiance, &f.grid.normal, f.scene.render.voxels)?
        }
    });
    Ok(())
}

/// vct-dense's cone pass through the radiance pyramid.
pub(crate) fn cone_trace_step(f: &mut HostFrame) -> Result<()> {
    let pyramid = f.pyramid.as_ref().expect("the pyramid before the cones");
    let params = cone_trace::cone_params(&f.frame, f.cones);
    f.cones_out = Some(match f.side("cone_trace") {
        Side::Mirror => {
            let lmax = cone_trace::max_radiance(&pyramid.colour, f.frame.side);
            // The paper's trilinear where params.depth_order is 0, the depth-ordered blend where 1.
            let pyr = vxgi_cpu_mirror::cone_trace::OrderedPyramid {
                p: &params,
                voxels: &pyramid.colour,
                normals: &pyramid.normal,
            };
            f.shade(&pyr, lmax)
        }
        Side::Gpu(ctx) => {
            let case = cone_trace::case_for(&f.data, &f.gb, pyramid, &params, "host".into(), 0);
            gpu_cones(ctx, &cone_trace::DECL, &case)?
        }
    });
    Ok(())
}

/// A cone pass's (indirect, ao) on the GPU.
pub(crate) fn gpu_cones(
    ctx: &GpuContext,
    decl: &crate::harness::KernelDecl,
    case: &crate::harness::Case,
) -> Result<[Vec<[f32; 4]>; 2]> {
    Ok(cone_trace::run_case(ctx, decl, case)?.map(|b| bytemuck::cast_slice(&b).to_vec()))
}
