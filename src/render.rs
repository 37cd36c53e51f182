//! Rendering a scene on the GPU: [`DirectRenderer`] records the `gbuffer` and `direct_light` kernels
//! into a caller's encoder, writing into caller-owned buffers (the API for lifting these kernels into
//! another renderer); [`render`] runs the whole vct-dense pipeline for the CLI (own context, images).
use crate::images::RgbImage;
use crate::kernels::cone_trace::{self, ConeSettings};
use crate::kernels::lrsm_cone_trace::{self, LrsmFrame, LrsmMemory, LrsmSettings};
use crate::kernels::{direct_light, gbuffer, voxel_light, voxelize};
use crate::plan::FramePlan;
use crate::scene::Scene;
use crate::trace::SceneData;
use anyhow::{Context, Result};
use wgpu::util::DeviceExt;

/// G-buffer and radiance buffers sized for a frame (row-major pixels), owned by whoever renders.
pub struct FrameTargets {
    /// `vec4<f32>` per pixel: position and distance (w = -1: nothing hit).
    pub gb_position: wgpu::Buffer,
    /// `vec4<f32>` per pixel: shading normal and side (1 front, -1 back, 0 none).
    pub gb_normal: wgpu::Buffer,
    /// u32 per pixel: triangle index or u32::MAX.
    pub gb_triangle: wgpu::Buffer,
    /// `vec4<f32>` per pixel: albedo (Kd or the map_Kd texel; rgb, 0).
    pub gb_albedo: wgpu::Buffer,
    /// `vec4<f32>` per pixel: direct radiance (rgb, 0).
    pub radiance: wgpu::Buffer,
}

impl FrameTargets {
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Self {
        let n = width as u64 * height as u64;
        let buf = |label: &str, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        Self {
            gb_position: buf("gb_position", n * 16),
            gb_normal: buf("gb_normal", n * 16),
            gb_triangle: buf("gb_triangle", n * 4),
            gb_albedo: buf("gb_albedo", n * 16),
            radiance: buf("radiance", n * 16),
        }
    }
}

/// The scene uploaded once and both pipelines; `encode` records a frame.
pub struct DirectRenderer {
    gbuffer: wgpu::ComputePipeline,
    direct: wgpu::ComputePipeline,
    scene: [wgpu::Buffer; 8],
    width: u32,
    height: u32,
}

fn pipeline(device: &wgpu::Device, decl: &crate::harness::KernelDecl) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(decl.name),
        source: wgpu::ShaderSource::Wgsl(decl.composed_source().into()),
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(decl.name),
        layout: None,
        module: &module,
        entry_point: Some(decl.entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

impl DirectRenderer {
    pub fn new(device: &wgpu::Device, data: &SceneData) -> Self {
        let upload = |label: &str, bytes: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let lights = if data.lights.is_empty() {
            vec![Default::default()]
        } else {
            data.lights.clone()
        };
        Self {
            gbuffer: pipeline(device, &gbuffer::DECL),
            direct: pipeline(device, &direct_light::DECL),
            scene: [
                upload("frame", bytemuck::bytes_of(&data.frame)),
                upload("nodes", bytemuck::cast_slice(&data.nodes)),
                upload("triangles", bytemuck::cast_slice(&data.triangles)),
                upload("lights", bytemuck::cast_slice(&lights)),
                upload("materials", bytemuck::cast_slice(&data.materials)),
                upload("uvs", bytemuck::cast_slice(&data.uvs)),
                upload("texels", bytemuck::cast_slice(&data.texels)),
                upload("srgb_lut", bytemuck::cast_slice(&data.srgb_lut)),
            ],
            width: data.width(),
            height: data.height(),
        }
    }

    /// Record the G-buffer and direct-light passes writing into `targets` (sized for this scene's
    /// camera: [`FrameTargets::new`] with its width and height).
    pub fn encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        targets: &FrameTargets,
    ) {
        let [frame, nodes, triangles, lights, materials, uvs, texels, lut] = &self.scene;
        let bind = |p: &wgpu::ComputePipeline, buffers: &[&wgpu::Buffer]| {
            let entries: Vec<_> = buffers
                .iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry {
                    binding: i as u32,
                    resource: b.as_entire_binding(),
                })
                .collect();
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &p.get_bind_group_layout(0),
                entries: &entries,
            })
        };
        let g = bind(
            &self.gbuffer,
            &[
                frame,
                nodes,
                triangles,
                &targets.gb_position,
                &targets.gb_normal,
                &targets.gb_triangle,
                materials,
                uvs,
                texels,
                lut,
                &targets.gb_albedo,
            ],
        );
        let d = bind(
            &self.direct,
            &[
                frame,
                nodes,
                triangles,
                lights,
                materials,
                &targets.gb_position,
                &targets.gb_normal,
                &targets.gb_triangle,
                &targets.radiance,
                &targets.gb_albedo,
            ],
        );
        let n = self.width as u64 * self.height as u64;
        let grid = vxgi_harness::run::grid_for(
            n,
            64,
            device.limits().max_compute_workgroups_per_dimension,
        );
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("direct"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.gbuffer);
        pass.set_bind_group(0, &g, &[]);
        pass.dispatch_workgroups(self.width.div_ceil(8), self.height.div_ceil(8), 1);
        pass.set_pipeline(&self.direct);
        pass.set_bind_group(0, &d, &[]);
        pass.dispatch_workgroups(grid[0], grid[1], grid[2]);
    }
}

/// The four images of a frame (linear, row-major), and where the time went.
pub struct Rendered {
    pub direct: RgbImage,
    pub indirect: RgbImage,
    pub combined: RgbImage,
    pub ao: RgbImage,
    /// (stage, wall-clock seconds including readback) of the stages that ran.
    pub stages: Vec<(&'static str, f64)>,
    /// What the frame ran and skipped.
    pub plan: FramePlan,
    /// The cone pass's 8x8 screen tiles: (listed, all). Tiles without a surface are not in
    /// screen_tiles' list and not dispatched. None where no per-pixel cone pass ran (cprc gathers).
    pub cone_tiles: Option<(u32, u32)>,
}

impl Rendered {
    /// A frame from its direct and indirect light and AO: combined = direct + indirect.
    pub fn assemble(
        direct: RgbImage,
        indirect: RgbImage,
        ao: RgbImage,
        stages: Vec<(&'static str, f64)>,
        plan: FramePlan,
    ) -> Self {
        let (w, h) = (direct.width, direct.height);
        let combined = RgbImage::new(w, h, crate::images::add(&direct.pixels, &indirect.pixels));
        Self {
            direct,
            indirect,
            combined,
            ao,
            stages,
            plan,
            cone_tiles: None,
        }
    }

    /// Each image box-filtered over `s` x `s` pixels (see [`RgbImage::downsampled`]); combined is
    /// still direct + indirect (the filter is linear).
    pub fn downsampled(self, s: u32) -> Self {
        Self {
            direct: self.direct.downsampled(s),
            indirect: self.indirect.downsampled(s),
            combined: self.combined.downsampled(s),
            ao: self.ao.downsampled(s),
            ..self
        }
    }

    /// Direct, indirect and combined times 2^k (in f64, saturating at f32::MAX); AO is unitless.
    pub fn radiance_scaled(self, k: i32) -> Self {
        let f = 2f64.powi(k);
        let scale = |mut img: RgbImage| {
            for p in &mut img.pixels {
                // Saturating at f32::MAX; a NaN stays NaN (f64::min would turn it into MAX).
                *p = p.map(|c| {
                    if c.is_nan() {
                        c
                    } else {
                        (c as f64 * f).min(f32::MAX as f64) as f32
                    }
                });
            }
            img
        };
        Self {
            direct: scale(self.direct),
            indirect: scale(self.indirect),
            combined: scale(self.combined),
            ..self
        }
    }

    /// The frame with the cone pass's tile counts, from its screen_tiles list buffer.
    pub fn with_cone_tiles(mut self, list: &[u32]) -> Self {
        self.cone_tiles = Some(cone_tiles_of(list));
        self
    }
}

/// The cone pass's 8x8 screen tiles in screen_tiles' list buffer: (listed, all).
pub(crate) fn cone_tiles_of(list: &[u32]) -> (u32, u32) {
    use vxgi_cpu_mirror::screen_tiles::HEADER;
    (list[3], (list.len() - HEADER) as u32)
}

/// `frame` run on [`Scene::supersampled`] (the camera's `supersample` x `supersample` samples per
/// pixel as pixels of their own) and box-filtered back to the camera's pixels; as is where
/// `supersample` is 1. What else the frame reports (memory, caches, tile counts) is the samples'.
///
/// Light intensities past [`EXPOSURE_LIMIT`] are rendered at an exposure: every light scaled by the
/// power of two 2^-k that brings the largest intensity component into [1, 2), the radiance images
/// scaled back by 2^k (light transport is linear in the lights, and a power of two is exact in
/// floating point). The kernels' f32 sums (up to 4096 texels before cprc's pre-convolution divides,
/// N^4 in the interleaved resolve, 1/r^2 of a point light) and vct-svo's fixed point then stay in
/// range for any finite intensity. Radiance past f32::MAX after scaling back saturates there.
pub(crate) fn supersampled<T>(
    scene: &Scene,
    frame: impl FnOnce(&Scene) -> Result<(Rendered, T)>,
) -> Result<(Rendered, T)> {
    let k = exposure(scene);
    if k != 0 {
        let exposed = scene.with_lights_scaled(2f32.powi(-k));
        let (r, extra) = supersampled(&exposed, frame)?;
        return Ok((r.radiance_scaled(k), extra));
    }
    let s = scene.render.supersample;
    if s <= 1 {
        return frame(scene);
    }
    let samples = scene.supersampled().map_err(anyhow::Error::msg)?;
    let (r, extra) = frame(&samples)?;
    Ok((r.downsampled(s), extra))
}

/// The largest light intensity component rendered as it is; brighter scenes are rendered at an
/// exposure (see `supersampled`). Every shipped scene's lights are far below it, so their frames are
/// unchanged bit for bit.
pub const EXPOSURE_LIMIT: f32 = 65536.0;

/// The k of the exposure 2^-k a scene is rendered at: 0 where every intensity component is at most
/// [`EXPOSURE_LIMIT`], else the one that brings the largest into [1, 2).
pub fn exposure(scene: &Scene) -> i32 {
    let m = scene
        .lights
        .iter()
        .flat_map(|l| l.intensity())
        .fold(0.0f32, f32::max);
    if m <= EXPOSURE_LIMIT || !m.is_finite() {
        0
    } else {
        m.log2().floor() as i32
    }
}

/// The vct-dense pipeline: G-buffer and direct light with exact shadows, voxelization, voxel lighting,
/// surface-coverage mips, cone tracing (AO, diffuse, glossy). Every stage is a verified kernel; stages
/// hand over through host memory for now (simple, and each hand-over is what `vxgi verify` checks).
/// `progress(stage)` is called before each stage. One frame, nothing kept: [`VctDense`] renders
/// sequences of frames.
pub fn render(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    progress: impl Fn(&str),
) -> Result<Rendered> {
    VctDense::new(false).render(ctx, scene, cones, progress)
}

/// What the radiance pyramid depends on; the camera and the cone settings are not part of it, except
/// through `levels`, the levels built (vct-dense builds only the levels its cones can read).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PyramidKey {
    mesh: crate::scene::Mesh,
    materials: Vec<crate::scene::Material>,
    lights: Vec<crate::scene::Light>,
    voxels: u32,
    pub(crate) levels: u32,
    /// Whether the normal pyramid is kept too (only the depth-ordered blend reads it: 38 MB at 128^3
    /// not read back otherwise).
    normals: bool,
}

impl PyramidKey {
    /// The key of `scene`'s whole pyramid.
    pub(crate) fn of(scene: &Scene) -> Self {
        Self {
            mesh: scene.mesh.clone(),
            materials: scene.materials.clone(),
            lights: scene.lights.clone(),
            voxels: scene.render.voxels,
            levels: scene.render.voxels.trailing_zeros() + 1,
            normals: true,
        }
    }

    /// The key without the lights: what the voxel grid itself depends on (the lights only light it).
    pub(crate) fn unlit(&self) -> Self {
        Self {
            lights: Vec::new(),
            ..self.clone()
        }
    }

    /// The key of the levels `cones` can read (`cone_trace::pyramid_levels`), with the normal pyramid
    /// where the cones blend depth-ordered.
    pub(crate) fn reading(scene: &Scene, cones: &ConeSettings) -> Self {
        let levels = cone_trace::pyramid_levels(scene, cones, scene.render.voxels);
        Self {
            levels,
            normals: cones.depth_ordered_blend,
            ..Self::of(scene)
        }
    }

    /// Whether a pyramid kept under `self` serves a frame that wants `want`: the same volume, and the
    /// normal pyramid kept if it is wanted.
    fn serves(&self, want: &PyramidKey) -> bool {
        (self.normals || !want.normals)
            && Self {
                normals: want.normals,
                ..self.clone()
            } == *want
    }

    /// What a frame building the pyramid under this key reads back for later frames.
    fn keep(&self, reuse: bool) -> Keep {
        match (reuse, self.normals) {
            (false, _) => Keep::Nothing,
            (true, false) => Keep::Colour,
            (true, true) => Keep::ColourAndNormals,
        }
    }
}

/// What a chain reads back of the pyramid it built.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Keep {
    Nothing,
    Colour,
    ColourAndNormals,
}

/// The vct-dense pipeline over a sequence of frames. With the planner's reuse rule on, a frame whose
/// geometry, materials, lights and voxel grid equal the last frame's and whose cones read the same
/// pyramid levels (only the camera or the cone settings changed; a frame turning the depth-ordered
/// blend on also needs the normal pyramid kept) skips voxelize, voxel_light and the mips and
/// cone-traces the last frame's radiance pyramid: the same pyramid a rebuild would make, so the same
/// image, sooner.
pub struct VctDense {
    pyramid: PyramidCache,
    instances: InstanceVoxels,
}

/// The last frame's radiance pyramid and what it was built from, kept while the reuse rule is on
/// (vct-dense and cprc).
struct PyramidCache {
    reuse: bool,
    last: Option<(PyramidKey, cone_trace::Pyramids, voxelize::VoxelFrame)>,
}

impl PyramidCache {
    fn new(reuse: bool) -> Self {
        Self { reuse, last: None }
    }

    /// Whether the kept pyramid serves `key` (the rule on; [`PyramidKey::serves`]); if not, it is
    /// dropped.
    fn holds(&mut self, key: &PyramidKey) -> bool {
        let cached = self.reuse && self.last.as_ref().is_some_and(|c| c.0.serves(key));
        if !cached {
            self.last = None;
        }
        cached
    }
}

impl VctDense {
    /// `reuse`: the planner's rule on (true) or every pass every frame (false).
    pub fn new(reuse: bool) -> Self {
        Self {
            pyramid: PyramidCache::new(reuse),
            instances: InstanceVoxels::default(),
        }
    }

    /// Render one frame (see [`render`]); its plan says what was skipped and why.
    pub fn render(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
        progress: impl Fn(&str),
    ) -> Result<Rendered> {
        crate::limits::check(scene, Pipeline::VctDense, &ctx.limits())
            .map_err(anyhow::Error::msg)?;
        supersampled(scene, |s| {
            Ok((self.render_samples(ctx, s, cones, &progress)?, ()))
        })
        .map(|(r, ())| r)
    }

    /// One frame at the scene's own resolution (`render` handles `supersample`).
    fn render_samples(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
        progress: impl Fn(&str),
    ) -> Result<Rendered> {
        refuse_ordered_instances(scene, cones)?;
        let key = PyramidKey::reading(scene, cones);
        let cached = self.pyramid.holds(&key);
        let plan = Pipeline::VctDense.plan(scene, cones, cached);
        if !scene.instances.list.is_empty() && plan.runs("voxel_light") {
            // One voxel hierarchy per instance (CPRC 3.1), cones through all of them.
            let data = SceneData::new(scene);
            let mut stages = Vec::new();
            let (gb, direct) = gbuffer_and_direct(ctx, &data, &plan, &mut stages, &progress)?;
            let (pyramids, placed, world) =
                self.instances
                    .hierarchies(ctx, scene, &data, &mut stages, &progress)?;
            let plan = plan.with_hierarchies(placed.len(), self.instances.voxelized_now);
            progress("cone tracing");
            let t = std::time::Instant::now();
            let params = cone_trace::cone_params(&world, cones);
            let case = cone_trace::instanced_case_for(
                &data,
                &gb,
                &pyramids,
                &placed,
                &params,
                "render".into(),
                0,
            );
            return cone_pass_frame(
                ctx,
                &cone_trace::INSTANCED_DECL,
                &case,
                direct,
                stages,
                plan,
                t,
            );
        }
        render_frame(
            ctx,
            scene,
            cones,
            plan,
            &mut self.pyramid.last,
            key,
            self.pyramid.reuse,
            progress,
        )
    }
}

#[allow(clippy::too_many_arguments)]
fn render_frame(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    plan: FramePlan,
    cache: &mut Option<(PyramidKey, cone_trace::Pyramids, voxelize::VoxelFrame)>,
    key: PyramidKey,
    keep: bool,
    progress: impl Fn(&str),
) -> Result<Rendered> {
    let data = SceneData::new(scene);
    let mut stages = Vec::new();
    let (gb, direct) = gbuffer_and_direct(ctx, &data, &plan, &mut stages, &progress)?;
    if plan.runs("voxelize") && plan.runs("voxel_light") {
        // The whole pyramid and the cone pass on the GPU in one chain.
        let (frame, built) = chained_frame(
            ctx,
            scene,
            cones,
            key.levels,
            &data,
            &gb,
            direct,
            stages,
            plan,
            key.keep(keep),
            &progress,
        )?;
        *cache = built.map(|(pyramid, vf)| (key, pyramid, vf));
        return Ok(frame);
    }
    let levels = key.levels;
    let (_, pyramid, frame) =
        radiance_pyramid(ctx, scene, &data, &plan, cache, key, &mut stages, &progress)?;
    progress("cone tracing");
    let t = std::time::Instant::now();
    // The cached pyramid holds at least these levels (its key says so); a pyramid built here holds
    // all of them. Either way the cones read the same values.
    let mut params = cone_trace::cone_params(frame, cones);
    params.levels = levels;
    let case = cone_trace::case_for(&data, &gb, pyramid, &params, "render".into(), 0);
    cone_pass_frame(ctx, &cone_trace::DECL, &case, direct, stages, plan, t)
}

type Stages = Vec<(&'static str, f64)>;

/// [`crate::limits::check_ordered_instances`] for the cones a frame traces.
fn refuse_ordered_instances(scene: &Scene, cones: &ConeSettings) -> Result<()> {
    crate::limits::check_ordered_instances(scene, cones.depth_ordered_blend)
        .map_err(anyhow::Error::msg)
}

/// vct-dense's frame with voxelize, voxel_light, the surface-coverage mips and the cone pass as one
/// chain on GPU-resident buffers ([`chained_pyramid`]). With `keep` other than `Nothing` (the reuse
/// rule on) the pyramid (and with `ColourAndNormals` its normal pyramid) is read back for the next
/// frames. Only the pyramid's first `levels` levels are built (the ones the cones can read).
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn chained_frame(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    levels: u32,
    data: &SceneData,
    gb: &crate::harness::Resources,
    direct: RgbImage,
    mut stages: Stages,
    plan: FramePlan,
    keep: Keep,
    progress: &impl Fn(&str),
) -> Result<(
    Rendered,
    Option<(cone_trace::Pyramids, voxelize::VoxelFrame)>,
)> {
    let out = chained_pyramid(
        ctx,
        scene,
        data,
        Some((gb, cones, levels)),
        keep,
        &mut stages,
        progress,
    )?;
    let bytes = |n: &str| &out.read[n].buffer().expect("buffer").bytes;
    let (w, h) = (direct.width, direct.height);
    let indirect = image_of(w, h, bytes("indirect"));
    let ao = image_of(w, h, bytes("ao"));
    let kept = (keep != Keep::Nothing).then(|| (out.pyramid(), out.frame));
    let frame = Rendered::assemble(direct, indirect, ao, stages, plan)
        .with_cone_tiles(bytemuck::cast_slice(bytes("tile_list")));
    Ok((frame, kept))
}

/// What [`chained_pyramid`] read back, and the voxel grid's frame.
struct ChainOut {
    read: crate::harness::Resources,
    frame: voxelize::VoxelFrame,
}

impl ChainOut {
    fn pyramid(&self) -> cone_trace::Pyramids {
        let read = |n: &str| -> Vec<[f32; 4]> {
            bytemuck::cast_slice(&self.read[n].buffer().expect("buffer").bytes).to_vec()
        };
        // The normal pyramid is empty where it was not read back (no depth-ordered blend).
        cone_trace::Pyramids {
            colour: read("pyramid"),
            normal: if self.read.contains_key("pyramid_normal") {
                read("pyramid_normal")
            } else {
                Vec::new()
            },
        }
    }
}

/// Voxelize, voxel_light and the surface-coverage mips as one chain on GPU-resident buffers
/// (`vxgi_harness::prepare_chain`): the voxel grid, its radiance and its mips never travel through the
/// host; the mip levels are copied into the pyramid buffer on the GPU. With `cone_pass` (a G-buffer,
/// the cone settings and the levels its cones read: the others are not built) cone_trace follows in the same chain and its `indirect` and `ao` are read back;
/// the pyramid is read back as `keep` says. The same kernels on the same inputs as the stage-by-
/// stage path, so the same results. Stage times are wall clock: the upload counts to voxelize, the
/// readback to the last stage. Needs lights (voxel_light runs).
#[allow(clippy::too_many_arguments)]
fn chained_pyramid(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    data: &SceneData,
    cone_pass: Option<(&crate::harness::Resources, &ConeSettings, u32)>,
    keep: Keep,
    stages: &mut Stages,
    progress: &impl Fn(&str),
) -> Result<ChainOut> {
    use crate::harness::prepare_chain;
    progress("voxelize");
    let mut t = std::time::Instant::now();
    let built = crate::pipeline::dense_chain(ctx, scene, data, cone_pass, false)?;
    let vframe = built.frame;
    let chain = built.harness_stages();
    // Without a cone pass the chain ends with the mips (stages 0-2); with one, screen_tiles and
    // the cone pass follow (3, 4).
    let cone_passes = built.stages.get(4).map_or(0, |s| s.passes.len());
    let prepared = prepare_chain(ctx, &chain, &built.resources).context("voxel chain")?;
    let mut first = 0;
    let mut run_stage = |k: usize| -> Result<()> {
        let n = chain[k].passes.len();
        prepared.dispatch_steps(first..first + n)?;
        first += n;
        Ok(())
    };
    run_stage(0).context("voxelize")?;
    stages.push(("voxelize", t.elapsed().as_secs_f64()));
    progress("voxel light");
    t = std::time::Instant::now();
    run_stage(1).context("voxel light")?;
    stages.push(("voxel_light", t.elapsed().as_secs_f64()));
    progress("mip chain");
    t = std::time::Instant::now();
    run_stage(2).context("mip chain")?;
    prepared
        .copy_into(&built.copy_list())
        .context("mip chain")?;
    let mut names = Vec::new();
    match keep {
        Keep::Nothing => {}
        Keep::Colour => names.push("pyramid"),
        Keep::ColourAndNormals => names.extend(["pyramid", "pyramid_normal"]),
    }
    if cone_passes == 0 {
        let read = prepared.read(&names).context("mip chain")?;
        stages.push(("surface_coverage_mip", t.elapsed().as_secs_f64()));
        return Ok(ChainOut {
            read,
            frame: vframe,
        });
    }
    stages.push(("surface_coverage_mip", t.elapsed().as_secs_f64()));
    progress("cone tracing");
    t = std::time::Instant::now();
    // The tile list counts to the cone pass it serves (the plan's and the bench's stage).
    run_stage(3).context("screen tiles")?;
    run_stage(4).context("cone tracing")?;
    names.extend(["indirect", "ao", "tile_list"]);
    let read = prepared.read(&names).context("cone tracing")?;
    stages.push(("cone_trace", t.elapsed().as_secs_f64()));
    Ok(ChainOut {
        read,
        frame: vframe,
    })
}

/// The radiance pyramid of vct-dense and cprc: built (voxelize, voxel light, surface-coverage mips)
/// where the plan runs voxelize, else the cached one.
#[allow(clippy::too_many_arguments)]
fn radiance_pyramid<'c>(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    data: &SceneData,
    plan: &FramePlan,
    cache: &'c mut Option<(PyramidKey, cone_trace::Pyramids, voxelize::VoxelFrame)>,
    key: PyramidKey,
    stages: &mut Stages,
    progress: &impl Fn(&str),
) -> Result<&'c (PyramidKey, cone_trace::Pyramids, voxelize::VoxelFrame)> {
    if !plan.runs("voxelize") {
        progress("radiance pyramid: reused");
    } else if plan.runs("voxel_light") {
        // Built on the GPU in one chain, read back once.
        let out = chained_pyramid(ctx, scene, data, None, key.keep(true), stages, progress)?;
        *cache = Some((key, out.pyramid(), out.frame));
    } else {
        let (rad, normal, _, frame) = lit_voxels(ctx, scene, data, plan, stages, progress)?;
        progress("mip chain");
        let t = std::time::Instant::now();
        let pyramid = cone_trace::gpu_pyramid(ctx, &rad, &normal, frame.side)?;
        stages.push(("surface_coverage_mip", t.elapsed().as_secs_f64()));
        *cache = Some((key, pyramid, frame));
    }
    Ok(cache.as_ref().expect("built or reused above"))
}

/// The lit voxel grid `(L * alpha, alpha)` (Morton order), its normals, its frame.
/// Lit voxels `(L * alpha, alpha)`, normals, albedo (voxelize's colour), Morton order, and the frame.
type LitVoxels = (
    Vec<[f32; 4]>,
    Vec<[f32; 4]>,
    Vec<[f32; 4]>,
    voxelize::VoxelFrame,
);

/// The G-buffer and, where the plan runs it, direct light (exact shadow rays): the first stages of
/// every pipeline.
fn gbuffer_and_direct(
    ctx: &crate::harness::GpuContext,
    data: &SceneData,
    plan: &FramePlan,
    stages: &mut Stages,
    progress: &impl Fn(&str),
) -> Result<(crate::harness::Resources, RgbImage)> {
    let (w, h) = (data.width(), data.height());
    let limit = ctx.limits().max_storage_buffer_binding_size;
    let need = w as u64 * h as u64 * 16;
    if need > limit {
        anyhow::bail!(
            "{w}x{h} needs {need} bytes per G-buffer binding, past the device's \
             max_storage_buffer_binding_size ({limit})"
        );
    }
    progress("G-buffer");
    let t = std::time::Instant::now();
    let gb = direct_light::gpu_gbuffer(ctx, data);
    stages.push(("gbuffer", t.elapsed().as_secs_f64()));
    let direct = if plan.runs("direct_light") {
        progress("direct light");
        let t = std::time::Instant::now();
        let case = direct_light::case_with_gbuffer(ctx, data, &gb, "render".into(), 0);
        let shader = direct_light::DECL.shader()?;
        let out = crate::harness::run::run(
            ctx,
            &shader,
            "direct_light",
            &case.resources,
            &case.passes,
            &["radiance"],
        )
        .context("direct light")?;
        stages.push(("direct_light", t.elapsed().as_secs_f64()));
        image_of(w, h, &out.buffer("radiance").bytes)
    } else {
        RgbImage::new(w, h, vec![[0.0; 3]; w as usize * h as usize])
    };
    Ok((gb, direct))
}

/// Voxelize and light the scene: the lit voxel grid `(L * alpha, alpha)` (Morton order), its normals,
/// albedo and its frame. Without lights (the plan skips voxel_light) the voxels keep their alpha and hold no
/// radiance, so AO still sees the geometry.
fn lit_voxels(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    data: &SceneData,
    plan: &FramePlan,
    stages: &mut Stages,
    progress: &impl Fn(&str),
) -> Result<LitVoxels> {
    progress("voxelize");
    let t = std::time::Instant::now();
    let (grid, list, frame) = voxelize::voxelize_on_gpu(ctx, scene, scene.render.voxels)?;
    stages.push(("voxelize", t.elapsed().as_secs_f64()));
    light_grid(ctx, data, plan, grid, &list, frame, stages, progress)
}

/// [`lit_voxels`] after voxelization: voxel_light where the plan runs it, else alpha alone.
#[allow(clippy::too_many_arguments)]
fn light_grid(
    ctx: &crate::harness::GpuContext,
    data: &SceneData,
    plan: &FramePlan,
    grid: crate::grids::Grid,
    list: &[u32],
    frame: voxelize::VoxelFrame,
    stages: &mut Stages,
    progress: &impl Fn(&str),
) -> Result<LitVoxels> {
    let rad = if plan.runs("voxel_light") {
        progress("voxel light");
        let t = std::time::Instant::now();
        let rad =
            voxel_light::light_on_gpu(ctx, data, &grid, list, &frame).context("voxel light")?;
        stages.push(("voxel_light", t.elapsed().as_secs_f64()));
        rad
    } else {
        crate::kernels::svo_cone_trace::coverage_only(&grid.colour)
    };
    Ok((rad, grid.normal, grid.colour, frame))
}

/// The vct-svo pipeline (Crassin et al. 2011): G-buffer and direct light as vct-dense; the lit voxels
/// become fragments of a sparse voxel octree of depth log2(voxels) - 1 (leaf lattice = the voxel grid),
/// built, splatted, border-transferred and filtered over its levels on the GPU (`sparse_voxel_octree`),
/// then cone-traced through the octree (`svo_cone_trace`: cone_trace's tracer on quadrilinear brick
/// samples). Returns the frame and the octree's memory report (its actual allocation).
pub fn render_svo(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    progress: impl Fn(&str),
) -> Result<(Rendered, crate::kernels::sparse_voxel_octree::MemoryReport)> {
    VctSvo::new(false).render(ctx, scene, cones, progress)
}

/// The pipelines `vxgi render --pipeline` (and `vxgi bench --pipeline`) choose from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Pipeline {
    /// Dense voxel grid + surface-coverage mips + cone tracing (Crassin 2011 / Rehfeld 2014 section 4).
    VctDense,
    /// Sparse voxel octree (3x3x3 vertex-centred bricks, border transfer, Gaussian distribution over
    /// levels) + cone tracing through it (Crassin 2011). Octree depth log2(voxels) - 1.
    VctSvo,
    /// Binary occlusion voxels + layered reflective shadow maps per light view (Sugihara 2014): cones
    /// take occlusion from the voxels and radiance from the LRSMs. Point and spot lights.
    Lrsm,
    /// Clustered pre-convolved radiance caching (Rehfeld 2014): caches placed on clusters of the
    /// view's pixels, filled by cones through the radiance pyramid, pre-convolved, gathered.
    Cprc,
}

impl Pipeline {
    /// The pipeline named `name` (its `--pipeline` value).
    pub fn from_name(name: &str) -> Option<Self> {
        [
            Pipeline::VctDense,
            Pipeline::VctSvo,
            Pipeline::Lrsm,
            Pipeline::Cprc,
        ]
        .into_iter()
        .find(|p| p.name() == name)
    }

    /// Its declaration: the stages, their kernels, reuse and plan rules.
    pub fn decl(self) -> &'static crate::pipeline::PipelineDecl {
        match self {
            Pipeline::VctDense => &crate::pipeline::VCT_DENSE,
            Pipeline::VctSvo => &crate::pipeline::VCT_SVO,
            Pipeline::Lrsm => &crate::pipeline::LRSM,
            Pipeline::Cprc => &crate::pipeline::CPRC,
        }
    }

    pub fn name(self) -> &'static str {
        self.decl().name
    }

    /// The stages of a frame, in its declaration's order (those a frame skips included): the
    /// names of the stage times, the plan's stages and bisect's split points.
    pub fn stages(self) -> Vec<&'static str> {
        self.decl().stage_names()
    }

    /// The frame plan of a first frame (`cached` false) or of a frame after an unchanged one.
    pub fn plan(self, scene: &Scene, cones: &ConeSettings, cached: bool) -> FramePlan {
        FramePlan::of(
            self.decl(),
            &crate::pipeline::PlanInputs::new(scene, cones, cached),
        )
    }
}

/// What a frame's volume holds, for the pipelines that report it.
#[derive(Clone, Debug)]
pub enum VolumeMemory {
    Octree(crate::kernels::sparse_voxel_octree::MemoryReport),
    Lrsm(LrsmMemory),
    /// cprc: what its caches did (count, pixels without a valid cache).
    Caches(crate::cprc::CprcStats),
}

/// Frames of any of the four pipelines (staged), with the planner's reuse rule on or off.
///
/// Example: `Renderer::new(Pipeline::Cprc, true).render(&ctx, &scene, &cones, |_| {})` draws a frame
/// and keeps what the next frame may reuse; tests/render.rs and `vxgi render` use it this way.
pub enum Renderer {
    Dense(VctDense),
    Svo(VctSvo),
    Lrsm(VctLrsm),
    Cprc(VctCprc),
}

impl Renderer {
    pub fn new(pipeline: Pipeline, reuse: bool) -> Self {
        match pipeline {
            Pipeline::VctDense => Renderer::Dense(VctDense::new(reuse)),
            Pipeline::VctSvo => Renderer::Svo(VctSvo::new(reuse)),
            Pipeline::Lrsm => Renderer::Lrsm(VctLrsm::new(reuse)),
            Pipeline::Cprc => Renderer::Cprc(VctCprc::new(reuse)),
        }
    }

    /// One frame, and for vct-svo and lrsm what their volume holds.
    pub fn render(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
        progress: impl Fn(&str),
    ) -> Result<(Rendered, Option<VolumeMemory>)> {
        match self {
            Renderer::Dense(r) => Ok((r.render(ctx, scene, cones, progress)?, None)),
            Renderer::Svo(r) => r
                .render(ctx, scene, cones, progress)
                .map(|(f, m)| (f, Some(VolumeMemory::Octree(m)))),
            Renderer::Lrsm(r) => r
                .render(ctx, scene, cones, progress)
                .map(|(f, m)| (f, Some(VolumeMemory::Lrsm(m)))),
            Renderer::Cprc(r) => r
                .render(ctx, scene, cones, progress)
                .map(|(f, m)| (f, Some(VolumeMemory::Caches(m)))),
        }
    }
}

/// The vct-svo pipeline over a sequence of frames, with vct-dense's reuse rule: a frame whose geometry,
/// materials, lights and voxel grid equal the last frame's skips voxelize, voxel_light and the octree
/// and cone-traces the last frame's octree (the same octree a rebuild would make: the same image).
pub struct VctSvo {
    reuse: bool,
    /// Replay the static part's recorded octree structure (scenes with dynamic instances; default on).
    replay: bool,
    /// The last octree and what it was built for.
    cache: Option<SvoCache>,
    statics: StaticVoxels,
}

/// What vct-svo's octree depends on ([`VctSvo::key`]).
type SvoKey = (PyramidKey, u32, bool, bool, u32);

/// vct-svo's octree as the cone pass reads it, and the key it was built for.
pub(crate) struct SvoCache {
    key: SvoKey,
    pub built: crate::kernels::sparse_voxel_octree::GpuOctree,
    pub frame: voxelize::VoxelFrame,
    /// Directional values (anisotropic voxels).
    pub aniso: Option<Vec<[f32; 4]>>,
    /// The Gaussian lobes' normal pool, in `built`'s node layout.
    pub normals: Option<Vec<u32>>,
    /// The glossy voxels' specular pool (lobes on and glossy photons), in `built`'s node layout.
    pub spec: Option<Vec<u32>>,
    /// The fixed-point scale of every pool (`svo_cone_trace::fixed_scale`).
    pub scale: f32,
}

impl SvoCache {
    /// The octree's bytes, its directional values and pools included.
    pub fn memory(&self) -> crate::kernels::sparse_voxel_octree::MemoryReport {
        use crate::kernels::sparse_voxel_octree as svo;
        let mut memory = svo::MemoryReport::of(&self.built.octree);
        memory.anisotropic_bytes = self.aniso.as_ref().map_or(0, |a| a.len() as u64 * 16);
        // The normal and specular pools: one more brick per node each (their buffers end at the
        // last used node).
        memory.normal_bytes = (self.normals.is_some() as u64 + self.spec.is_some() as u64)
            * memory.bricks
            * svo::BRICK_BYTES;
        memory.bytes += memory.anisotropic_bytes + memory.normal_bytes;
        memory
    }

    /// The directional values and pools as the cone pass binds them.
    pub fn extras(&self) -> crate::kernels::svo_cone_trace::SvoExtras<'_> {
        crate::kernels::svo_cone_trace::SvoExtras {
            aniso: self.aniso.as_deref(),
            normals: self.normals.as_deref(),
            spec: self.spec.as_deref(),
        }
    }
}

/// vct-svo's voxels across the frames of an animation with dynamic instances: the static part (the
/// `[mesh]` and the static instances) is voxelized once into a grid kept for the sequence (the first
/// frame's, while every later frame's geometry fits in it) and kept; each frame voxelizes the dynamic
/// instances alone into the same grid and merges them in (a voxel both fill gets the mean of the two
/// albedos and of the two normals). The octree's structure follows VCT 4.2.2's static/dynamic split:
/// the static voxels' subdivisions are recorded once
/// ([`StaticStructure`](vxgi_cpu_mirror::sparse_voxel_octree::StaticStructure)) and replayed each
/// frame, so only fragments at points the static part does not cover (the dynamic instances' voxels,
/// photons landing on them) flag nodes; the values are rebuilt from every fragment (light moves with
/// the instances).
#[derive(Default)]
pub struct StaticVoxels {
    #[allow(clippy::type_complexity)]
    kept: Option<
        Box<(
            crate::scene::Mesh,
            voxelize::VoxelFrame,
            crate::grids::Grid,
            Vec<u32>,
            vxgi_cpu_mirror::sparse_voxel_octree::StaticStructure,
        )>,
    >,
    /// Whether the last frame kept the static part, and how many dynamic triangles it voxelized.
    pub reused: bool,
    pub dynamic_triangles: usize,
}

impl StaticVoxels {
    /// The merged voxels of `scene` (grid, sorted list, frame, seconds spent), or `None` when it has
    /// no dynamic instance (voxelized whole, as before).
    #[allow(clippy::type_complexity)]
    fn voxels(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        progress: &impl Fn(&str),
    ) -> Result<Option<(crate::grids::Grid, Vec<u32>, voxelize::VoxelFrame, f64)>> {
        let inst = &scene.instances;
        if !inst.list.iter().any(|i| i.dynamic) {
            self.kept = None;
            return Ok(None);
        }
        let t = std::time::Instant::now();
        let mut fixed = inst.base.clone();
        let mut moving = crate::scene::Mesh::default();
        for i in &inst.list {
            let placed = i.placed(inst.frame);
            if i.dynamic {
                moving.append(&placed);
            } else {
                fixed.append(&placed);
            }
        }
        let side = scene.render.voxels;
        let fits = |f: &voxelize::VoxelFrame| {
            let hi = f.origin + glam::Vec3::splat(f.voxel * f.side as f32);
            let slack = glam::Vec3::splat(f.voxel * 1e-3);
            scene
                .mesh
                .positions
                .iter()
                .all(|p| p.cmpge(f.origin - slack).all() && p.cmple(hi + slack).all())
        };
        self.reused = matches!(self.kept.as_deref(), Some((m, f, ..)) if *m == fixed && f.side == side && fits(f));
        let only = |mesh: crate::scene::Mesh| scene.with_mesh_alone(mesh);
        if !self.reused {
            progress("voxelize (static part, kept)");
            let frame = voxelize::frame_of(&scene.mesh, side);
            let (grid, list) = if fixed.triangles.is_empty() {
                let n = (side as usize).pow(3);
                (
                    crate::grids::Grid {
                        n: side,
                        colour: vec![[0.0; 4]; n],
                        normal: vec![[0.0; 4]; n],
                    },
                    vec![],
                )
            } else {
                let (g, l, _) = voxelize::voxelize_in_on_gpu(ctx, &only(fixed.clone()), frame)?;
                (g, l)
            };
            // The static voxels' octree structure, recorded once: their points (the value does not
            // decide the structure).
            let points: Vec<vxgi_cpu_mirror::sparse_voxel_octree::Fragment> = list
                .iter()
                .map(|&m| vxgi_cpu_mirror::sparse_voxel_octree::Fragment {
                    pos: vxgi_cpu_mirror::morton::decode(m),
                    _pad: 0,
                    value: [0; 4],
                })
                .collect();
            let depth = frame.side.trailing_zeros() - 1;
            let statics =
                vxgi_cpu_mirror::sparse_voxel_octree::StaticStructure::record(depth, &points);
            self.kept = Some(Box::new((fixed, frame, grid, list, statics)));
        }
        let (_, frame, grid, list, _) = self.kept.as_deref().expect("kept above");
        let (mut grid, mut list, frame) = (grid.clone(), list.clone(), *frame);
        self.dynamic_triangles = moving.triangles.len();
        if !moving.triangles.is_empty() {
            progress("voxelize (dynamic instances)");
            let (dg, dl, _) = voxelize::voxelize_in_on_gpu(ctx, &only(moving), frame)?;
            for &v in &dl {
                let v = v as usize;
                if grid.colour[v][3] > 0.0 {
                    let mean = |a: [f32; 4], b: [f32; 4]| {
                        [
                            (a[0] + b[0]) * 0.5,
                            (a[1] + b[1]) * 0.5,
                            (a[2] + b[2]) * 0.5,
                            a[3],
                        ]
                    };
                    grid.colour[v] = mean(grid.colour[v], dg.colour[v]);
                    grid.normal[v] = mean(grid.normal[v], dg.normal[v]);
                } else {
                    grid.colour[v] = dg.colour[v];
                    grid.normal[v] = dg.normal[v];
                    list.push(v as u32);
                }
            }
            list.sort_unstable();
        }
        Ok(Some((grid, list, frame, t.elapsed().as_secs_f64())))
    }

    /// The kept static part's recorded octree structure (after `voxels` returned voxels).
    pub fn structure(&self) -> Option<&vxgi_cpu_mirror::sparse_voxel_octree::StaticStructure> {
        self.kept.as_deref().map(|k| &k.4)
    }
}

impl VctSvo {
    /// `reuse`: the planner's rule on (true) or every pass every frame (false).
    pub fn new(reuse: bool) -> Self {
        Self {
            reuse,
            replay: true,
            cache: None,
            statics: StaticVoxels::default(),
        }
    }

    /// Build every frame's octree structure from all its fragments instead of replaying the static
    /// part's (the same octree; for comparisons).
    pub fn without_static_replay(mut self) -> Self {
        self.replay = false;
        self
    }

    /// Render one frame (see [`render_svo`]); its plan says what was skipped and why.
    pub fn render(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
        progress: impl Fn(&str),
    ) -> Result<(Rendered, crate::kernels::sparse_voxel_octree::MemoryReport)> {
        crate::limits::check(scene, Pipeline::VctSvo, &ctx.limits()).map_err(anyhow::Error::msg)?;
        supersampled(scene, |s| self.render_samples(ctx, s, cones, &progress))
    }

    /// One frame at the scene's own resolution (`render` handles `supersample`).
    fn render_samples(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
        progress: impl Fn(&str),
    ) -> Result<(Rendered, crate::kernels::sparse_voxel_octree::MemoryReport)> {
        use crate::kernels::svo_cone_trace;
        let key = Self::key(scene);
        let cached = self.reuse && self.cache.as_ref().is_some_and(|c| c.key == key);
        let mut plan = Pipeline::VctSvo.plan(scene, cones, cached);
        let data = SceneData::new(scene);
        let mut stages = Vec::new();
        let (gb, direct) = gbuffer_and_direct(ctx, &data, &plan, &mut stages, &progress)?;
        if cached {
            progress("octree: reused");
        } else {
            self.build_volume(
                ctx,
                scene,
                cones,
                &data,
                key,
                &mut plan,
                &mut stages,
                &progress,
            )?;
        }
        let c = self.cache.as_ref().expect("built or reused above");
        let memory = c.memory();
        progress("cone tracing");
        let t = std::time::Instant::now();
        let params = svo_cone_trace::svo_cone_params(&c.frame, cones);
        let case = svo_cone_trace::case_for(
            &data,
            &gb,
            &c.built.octree,
            c.extras(),
            c.scale,
            &params,
            "render".into(),
            0,
        );
        let frame = cone_pass_frame(ctx, &svo_cone_trace::DECL, &case, direct, stages, plan, t)?;
        Ok((frame, memory))
    }

    /// The octree (and its directional values and pools) `scene` and `cones` need, built on the GPU
    /// with the host steps between its passes; kept for later frames under `key`.
    #[allow(clippy::too_many_arguments)]
    fn build_volume(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
        data: &SceneData,
        key: SvoKey,
        plan: &mut FramePlan,
        stages: &mut Stages,
        progress: &impl Fn(&str),
    ) -> Result<()> {
        use crate::kernels::{sparse_voxel_octree as svo, svo_cone_trace};
        self.cache = None;
        let split = self.statics.voxels(ctx, scene, &progress)?;
        // With dynamic instances: the static part's octree structure, replayed (VCT 4.2.2).
        let replay = self.replay && split.is_some();
        let (rad, normal, colour, frame) = match split {
            Some((grid, list, frame, secs)) => {
                stages.push(("voxelize", secs));
                let p = plan.passes.iter_mut().find(|p| p.stage == "voxelize");
                if let Some(p) = p {
                    p.size = format!(
                        "{} dynamic triangles into {}^3 (static part {})",
                        self.statics.dynamic_triangles,
                        frame.side,
                        if self.statics.reused {
                            "kept"
                        } else {
                            "voxelized now"
                        }
                    );
                    p.why = "static part voxelized once into a grid kept for the sequence; dynamic instances each frame, merged in".into();
                }
                light_grid(ctx, data, plan, grid, &list, frame, stages, &progress)?
            }
            None => lit_voxels(ctx, scene, data, plan, stages, &progress)?,
        };
        // Geometry fragments: the lit voxels, or with photon injection their coverage alone
        // (voxel_light did not run) and the photons carrying the light.
        let photons = if plan.runs("svo_photons") {
            progress("photons");
            let t = std::time::Instant::now();
            let photons = crate::kernels::svo_photons::photons_on_gpu(
                ctx,
                data,
                &frame,
                scene.render.photon_map,
            )
            .context("photon injection")?;
            stages.push(("svo_photons", t.elapsed().as_secs_f64()));
            Some(photons)
        } else {
            None
        };
        // The fixed point from the values it must hold (any finite light fits).
        let scale = svo_cone_trace::fixed_scale(
            svo_cone_trace::grid_values(&rad).chain(photons.iter().flat_map(|p| p.values())),
            scene.render.bounces,
        );
        let mut frags = svo_cone_trace::grid_fragments(&rad, scale)?;
        // With the lobes, the glossy surfaces' specular photons (their points join the structure).
        let mut spec_frags = Vec::new();
        if let Some(photons) = &photons {
            spec_frags = photons
                .fragments(scale)?
                .join_into(&mut frags, plan.runs("svo_lobes"));
        }
        progress("sparse voxel octree");
        let t = std::time::Instant::now();
        let depth = frame.side.trailing_zeros() - 1;
        let statics = self.statics.structure().filter(|_| replay);
        if statics.is_some() {
            if let Some(p) = plan
                .passes
                .iter_mut()
                .find(|p| p.stage == "sparse_voxel_octree")
            {
                p.why.push_str("; the static part's subdivisions replayed (recorded once, VCT 4.2.2): only fragments off its points flag nodes");
            }
        }
        let build = |frags: &[vxgi_cpu_mirror::sparse_voxel_octree::Fragment]| {
            svo::build_on_gpu_replayed(ctx, depth, frags, None, statics)
                .context("sparse voxel octree")
        };
        let built = build(&frags)?;
        stages.push(("sparse_voxel_octree", t.elapsed().as_secs_f64()));
        let directional = |built: &svo::GpuOctree, stages: &mut Stages| -> Result<_> {
            if !plan.runs("svo_anisotropic") {
                return Ok(None);
            }
            progress("anisotropic voxels");
            let t = std::time::Instant::now();
            let a = crate::kernels::svo_anisotropic::build_on_gpu(ctx, &built.octree, 1.0 / scale)
                .context("anisotropic voxels")?;
            stages.push(("svo_anisotropic", t.elapsed().as_secs_f64()));
            Ok(Some(a))
        };
        // The Gaussian lobes' normal pool and the glossy voxels' specular pool: more builds over
        // the fragments' points.
        let lobes = |built: &svo::GpuOctree,
                     frags: &[vxgi_cpu_mirror::sparse_voxel_octree::Fragment],
                     stages: &mut Stages|
         -> Result<_> {
            if !plan.runs("svo_lobes") {
                return Ok((None, None));
            }
            progress("normal pool (Gaussian lobes)");
            let t = std::time::Instant::now();
            let pools = svo_cone_trace::lobe_pools(
                Some(ctx),
                &built.octree,
                frags,
                [&rad, &normal],
                &spec_frags,
                scale,
            )
            .context("normal and specular pools")?;
            stages.push(("svo_lobes", t.elapsed().as_secs_f64()));
            Ok((Some(pools.0), pools.1))
        };
        let mut aniso = directional(&built, stages)?;
        let (mut normals, mut spec) = lobes(&built, &frags, stages)?;
        let mut built = built;
        if plan.runs("svo_bounce") {
            // Second bounce: every non-empty voxel gathers through the octree of the first, its
            // reflected light joins the fragments, and the octree is built again.
            progress("second bounce");
            let t = std::time::Instant::now();
            let voxels = svo_cone_trace::bounce_voxels(&rad, &normal, &colour, &frame);
            let params = svo_cone_trace::svo_cone_params(&frame, cones);
            let extras = svo_cone_trace::SvoExtras {
                aniso: aniso.as_deref(),
                normals: normals.as_deref(),
                spec: spec.as_deref(),
            };
            let ind =
                svo_cone_trace::bounce_on_gpu(ctx, &built.octree, extras, scale, &params, &voxels)
                    .context("second bounce")?;
            frags.extend(svo_cone_trace::bounce_fragments(
                &voxels, &ind, &rad, scale,
            )?);
            built = build(&frags)?;
            stages.push(("svo_bounce", t.elapsed().as_secs_f64()));
            aniso = directional(&built, stages)?;
            (normals, spec) = lobes(&built, &frags, stages)?;
        }
        self.cache = Some(SvoCache {
            key,
            built,
            frame,
            aniso,
            normals,
            spec,
            scale,
        });
        Ok(())
    }

    /// The octree for `scene`'s frames (built now unless the last one serves): what a GPU-resident
    /// frame's cone pass binds, and the wall clock of each stage that built it (none if kept). The
    /// caller has checked `scene` against the device's limits (`limits::check`, as `render` does).
    pub(crate) fn volume(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
    ) -> Result<(&SvoCache, Stages)> {
        let mut stages = Vec::new();
        let key = Self::key(scene);
        if !self.cache.as_ref().is_some_and(|c| c.key == key) {
            let mut plan = Pipeline::VctSvo.plan(scene, cones, false);
            let data = SceneData::new(scene);
            self.build_volume(
                ctx,
                scene,
                cones,
                &data,
                key,
                &mut plan,
                &mut stages,
                &|_| {},
            )?;
        }
        Ok((self.cache.as_ref().expect("built above"), stages))
    }

    /// What the octree depends on: the pyramid key, photon_map, anisotropic_voxels, voxel_lobes and
    /// bounces.
    fn key(scene: &Scene) -> SvoKey {
        let r = &scene.render;
        (
            PyramidKey::of(scene),
            r.photon_map,
            r.anisotropic_voxels,
            r.voxel_lobes,
            r.bounces,
        )
    }
}

/// The lrsm pipeline (Sugihara et al. 2014): G-buffer and direct light as vct-dense; voxelize into
/// binary occlusion voxels and their mips (`occlusion_voxels`); per light view (a spot's cone, a point
/// light's six cube faces) an RSM ray-cast from the light (`gbuffer` + `reflective_shadow_map`), split
/// into depth x <n.l> layers (`lrsm_partition`) and pre-filtered (`lrsm_prefilter`); then the gather
/// (`lrsm_cone_trace`). Returns the frame and the bytes of each structure.
pub fn render_lrsm(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    progress: impl Fn(&str),
) -> Result<(Rendered, LrsmMemory)> {
    VctLrsm::new(false).render(ctx, scene, cones, progress)
}

/// The lrsm pipeline over a sequence of frames, with the reuse rule of the others: a frame whose
/// geometry, materials, lights and voxel grid equal the last frame's reuses its occlusion voxels and
/// LRSMs (the same ones a rebuild would make).
pub struct VctLrsm {
    reuse: bool,
    cache: Option<(PyramidKey, LrsmSettings, LrsmFrame)>,
}

impl VctLrsm {
    pub fn new(reuse: bool) -> Self {
        Self { reuse, cache: None }
    }

    pub fn render(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
        progress: impl Fn(&str),
    ) -> Result<(Rendered, LrsmMemory)> {
        crate::limits::check(scene, Pipeline::Lrsm, &ctx.limits()).map_err(anyhow::Error::msg)?;
        supersampled(scene, |s| self.render_samples(ctx, s, cones, &progress))
    }

    /// One frame at the scene's own resolution (`render` handles `supersample`).
    fn render_samples(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
        progress: impl Fn(&str),
    ) -> Result<(Rendered, LrsmMemory)> {
        let key = PyramidKey::of(scene);
        let settings = LrsmSettings::from(&scene.render);
        let cached = self.reuse
            && self
                .cache
                .as_ref()
                .is_some_and(|c| c.0 == key && c.1 == settings);
        let plan = Pipeline::Lrsm.plan(scene, cones, cached);
        let data = SceneData::new(scene);
        let mut stages = Vec::new();
        let (gb, direct) = gbuffer_and_direct(ctx, &data, &plan, &mut stages, &progress)?;
        if cached {
            progress("occlusion voxels and LRSMs: reused");
        } else {
            self.cache = None;
            let built = LrsmFrame::build(
                ctx,
                scene,
                &data,
                scene.render.voxels,
                &settings,
                &progress,
                &mut stages,
            )?;
            self.cache = Some((key, settings, built));
        }
        let (_, _, built) = self.cache.as_ref().expect("built or reused above");
        progress("cone tracing");
        let t = std::time::Instant::now();
        let params = cone_trace::cone_params(&built.voxels, cones);
        let tan = settings.shadow_cone_angle.to_radians().tan();
        let case = lrsm_cone_trace::case_for(&data, &gb, built, &params, tan, "render".into(), 0);
        let frame = cone_pass_frame(ctx, &lrsm_cone_trace::DECL, &case, direct, stages, plan, t)?;
        Ok((frame, built.memory))
    }
}

/// The cprc pipeline (Rehfeld et al. 2014, see [`crate::cprc`]): one frame, nothing kept.
pub fn render_cprc(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    progress: impl Fn(&str),
) -> Result<(Rendered, crate::cprc::CprcStats)> {
    VctCprc::new(false).render(ctx, scene, cones, progress)
}

/// The cprc pipeline over a sequence of frames, with vct-dense's reuse rule for the radiance pyramid
/// (the caches follow the view and are rebuilt every frame).
pub struct VctCprc {
    pyramid: PyramidCache,
    instances: InstanceVoxels,
}

/// The per-instance voxel hierarchies of a scene with `[[instances]]` (CPRC 3.1), kept across frames.
#[derive(Default)]
struct InstanceVoxels {
    /// Voxelizations in their own frames (an instance's mesh and grid side are its key): (local
    /// mesh, side, grid, list, frame).
    voxelized: Vec<(
        crate::scene::Mesh,
        u32,
        crate::grids::Grid,
        Vec<u32>,
        voxelize::VoxelFrame,
    )>,
    /// How many hierarchies the last frame voxelized (the rest were kept).
    voxelized_now: usize,
}

impl InstanceVoxels {
    /// The scene's voxel hierarchies for this frame: `[mesh]` (in place) and every instance (placed
    /// by its transform at the scene's frame), each voxelized once in its own frame at the world
    /// voxel size (grid side the power of two that covers it, 8 to `voxels`), re-lit where it stands
    /// (voxel_light with the placement: shadows from the whole scene as it is now), its mips built;
    /// the pyramids concatenated.
    fn hierarchies(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        data: &SceneData,
        stages: &mut Stages,
        progress: &impl Fn(&str),
    ) -> Result<Hierarchies> {
        use vxgi_cpu_mirror::cache_creation::Placed;
        let (world, parts) = hierarchy_parts(scene);
        let (mut vox_t, mut light_t, mut mip_t) = (0.0, 0.0, 0.0);
        self.voxelized_now = 0;
        let mut pyramids = Vec::new();
        let mut placed = Vec::new();
        for (mesh, side, m) in parts {
            progress("voxelize (per instance, once)");
            let t = std::time::Instant::now();
            let k = match self
                .voxelized
                .iter()
                .position(|v| v.0 == mesh && v.1 == side)
            {
                Some(k) => k,
                None => {
                    let local = scene.with_mesh_alone(mesh.clone());
                    let (grid, list, frame) = voxelize::voxelize_on_gpu(ctx, &local, side)?;
                    self.voxelized.push((mesh, side, grid, list, frame));
                    self.voxelized_now += 1;
                    self.voxelized.len() - 1
                }
            };
            vox_t += t.elapsed().as_secs_f64();
            let (_, _, grid, list, frame) = &self.voxelized[k];
            progress("voxel light (placed)");
            let t = std::time::Instant::now();
            let rad = voxel_light::light_placed_on_gpu(ctx, data, grid, list, frame, m)
                .context("voxel light")?;
            light_t += t.elapsed().as_secs_f64();
            let t = std::time::Instant::now();
            let pyr = cone_trace::gpu_pyramid(ctx, &rad, &grid.normal, frame.side)?;
            mip_t += t.elapsed().as_secs_f64();
            placed.push(Placed::new(
                frame.origin.to_array(),
                frame.voxel,
                frame.side,
                pyramids.len() as u32,
                m,
                world.voxel,
            ));
            pyramids.extend(pyr.colour);
        }
        let limit = ctx.limits().max_storage_buffer_binding_size;
        if pyramids.len() as u64 * 16 > limit {
            anyhow::bail!(
                "the {} voxel hierarchies need {} bytes in one binding, past the device's \
                 max_storage_buffer_binding_size ({limit}): lower voxels",
                placed.len(),
                pyramids.len() * 16
            );
        }
        if self.voxelized_now > 0 {
            stages.push(("voxelize", vox_t));
        }
        stages.push(("voxel_light", light_t));
        stages.push(("surface_coverage_mip", mip_t));
        Ok((pyramids, placed, world))
    }
}

/// The voxel hierarchies of a scene with `[[instances]]` (CPRC 3.1): the march's world grid and, per
/// hierarchy, its mesh in its own frame, its grid side and where it stands (`[mesh]` in place, then
/// every instance at the scene's frame). The side is the world's voxel size with the instance's
/// scale applied, a power of two in 8..=voxels.
pub(crate) fn hierarchy_parts(
    scene: &Scene,
) -> (
    voxelize::VoxelFrame,
    Vec<(crate::scene::Mesh, u32, glam::Mat4)>,
) {
    let world = voxelize::frame_of(&scene.mesh, scene.render.voxels);
    let inst = &scene.instances;
    let mut parts: Vec<(crate::scene::Mesh, glam::Mat4)> = Vec::new();
    if !inst.base.triangles.is_empty() {
        parts.push((inst.base.clone(), glam::Mat4::IDENTITY));
    }
    for i in &inst.list {
        parts.push((i.local.clone(), i.transform_at(inst.frame).matrix()));
    }
    let parts = parts
        .into_iter()
        .map(|(mesh, m)| {
            let (lo, hi) = mesh.positions.iter().fold(
                (
                    glam::Vec3::splat(f32::INFINITY),
                    glam::Vec3::splat(f32::NEG_INFINITY),
                ),
                |(lo, hi), p| (lo.min(*p), hi.max(*p)),
            );
            let scale = glam::Mat3::from_mat4(m).determinant().abs().cbrt();
            let cells = ((hi - lo).max_element() * scale / world.voxel)
                .ceil()
                .max(8.0) as u32;
            let side = cells.next_power_of_two().min(scene.render.voxels);
            (mesh, side, m)
        })
        .collect();
    (world, parts)
}

/// A hierarchy's pyramids concatenated, where each is placed, and the march's world grid.
type Hierarchies = (
    Vec<[f32; 4]>,
    Vec<vxgi_cpu_mirror::cache_creation::Placed>,
    voxelize::VoxelFrame,
);

impl VctCprc {
    pub fn new(reuse: bool) -> Self {
        Self {
            pyramid: PyramidCache::new(reuse),
            instances: InstanceVoxels::default(),
        }
    }

    pub fn render(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
        progress: impl Fn(&str),
    ) -> Result<(Rendered, crate::cprc::CprcStats)> {
        crate::limits::check(scene, Pipeline::Cprc, &ctx.limits()).map_err(anyhow::Error::msg)?;
        supersampled(scene, |s| self.render_samples(ctx, s, cones, &progress))
    }

    /// One frame at the scene's own resolution (`render` handles `supersample`).
    fn render_samples(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
        progress: impl Fn(&str),
    ) -> Result<(Rendered, crate::cprc::CprcStats)> {
        use crate::cprc;
        let key = PyramidKey {
            normals: cones.depth_ordered_blend,
            ..PyramidKey::of(scene)
        };
        let cached = self.pyramid.holds(&key);
        let settings = cprc::CprcSettings::from(&scene.render);
        let plan = Pipeline::Cprc.plan(scene, cones, cached);
        let data = SceneData::new(scene);
        let mut stages = Vec::new();
        let (gb, direct) = gbuffer_and_direct(ctx, &data, &plan, &mut stages, &progress)?;
        let (pos, nrm, tri, alb) = cprc::gbuffer_arrays(&gb);
        let px = cprc::pixel_inputs(&data, &pos, &nrm, &tri, &alb, settings.res);
        if !plan.runs("gather_caches") {
            // No lights: indirect is 0 (the plan says why); the AO image as cprc's always is.
            let empty = cprc::gather_data(&px, &cprc::CacheSet::empty(), &settings, vec![], vec![]);
            let n = px.positions.len();
            let zeros = vec![[0.0f32; 4]; n];
            let (indirect, ao, stats) = cprc::compose(&px, &(zeros.clone(), zeros, empty));
            return Ok((
                Rendered::assemble(direct, indirect, ao, stages, plan),
                stats,
            ));
        }
        // With [[instances]]: one voxel hierarchy per instance (and one for [mesh]), voxelized once
        // in its own frame and re-lit where it stands every frame (CPRC 3.1); else the one pyramid.
        refuse_ordered_instances(scene, cones)?;
        let instanced = if scene.instances.list.is_empty() {
            None
        } else {
            Some(
                self.instances
                    .hierarchies(ctx, scene, &data, &mut stages, &progress)?,
            )
        };
        let (volume, params) = match &instanced {
            Some((pyramids, placed, world)) => (
                cprc::CacheVolume::Placed(pyramids, placed),
                cone_trace::cone_params(world, cones),
            ),
            None => {
                let (_, pyramid, frame) = radiance_pyramid(
                    ctx,
                    scene,
                    &data,
                    &plan,
                    &mut self.pyramid.last,
                    key,
                    &mut stages,
                    &progress,
                )?;
                (
                    cprc::CacheVolume::One(pyramid),
                    cone_trace::cone_params(frame, cones),
                )
            }
        };
        let plan = match &instanced {
            Some((_, placed, _)) => {
                plan.with_hierarchies(placed.len(), self.instances.voxelized_now)
            }
            None => plan,
        };
        progress("cache distribution");
        let t = std::time::Instant::now();
        let offset = params.offset_voxels * params.origin[3];
        let set = cprc::distribute_gpu(ctx, &px, &settings, offset)?;
        stages.push(("cache_distribution", t.elapsed().as_secs_f64()));
        let count = set.caches.pos.len() as u64;
        let need = count * (settings.res * settings.res) as u64 * 16;
        let limit = ctx.limits().max_storage_buffer_binding_size;
        if need > limit {
            anyhow::bail!(
                "{count} caches of {r}^2 texels need {need} bytes in one binding, past the device's \
                 max_storage_buffer_binding_size ({limit}): lower cache_resolution or raise cache_tile",
                r = settings.res
            );
        }
        let gathered = cprc::evaluate_gpu(
            ctx,
            &px,
            &set,
            &settings,
            volume,
            &params,
            &mut stages,
            &progress,
        )?;
        let (indirect, ao, stats) = cprc::compose(&px, &gathered);
        Ok((
            Rendered::assemble(direct, indirect, ao, stages, plan),
            stats,
        ))
    }
}

/// Run a cone pass (`decl`: a kernel on common/cone_march.wgsl, `case` from its case_for, started at
/// `started`) and assemble the frame: indirect and AO from it, combined = direct + indirect. A case
/// with lrsm's shadow-cone pass replaces `direct` (the plan skipped direct_light) by its soft direct
/// light.
fn cone_pass_frame(
    ctx: &crate::harness::GpuContext,
    decl: &'static crate::harness::KernelDecl,
    case: &crate::harness::Case,
    direct: RgbImage,
    mut stages: Stages,
    plan: FramePlan,
    started: std::time::Instant,
) -> Result<Rendered> {
    let (w, h) = (direct.width, direct.height);
    // A case with lrsm's shadow-cone pass also returns its soft direct light.
    let soft = case.checks.iter().any(|c| c.resource == "soft_direct");
    let mut names = vec!["indirect", "ao"];
    if soft {
        names.push("soft_direct");
    }
    let out = decl.run(ctx, case, &names).context("cone tracing")?;
    let indirect = image_of(w, h, &out.buffer("indirect").bytes);
    let ao = image_of(w, h, &out.buffer("ao").bytes);
    let direct = if soft {
        image_of(w, h, &out.buffer("soft_direct").bytes)
    } else {
        direct
    };
    // The instanced cone pass is the frame's cone_trace stage (the plan's and the bench's name).
    let stage = if decl.name == cone_trace::INSTANCED_DECL.name {
        cone_trace::DECL.name
    } else {
        decl.name
    };
    stages.push((stage, started.elapsed().as_secs_f64()));
    let tiles = case.resources["tile_list"].buffer().expect("tile_list");
    Ok(Rendered::assemble(direct, indirect, ao, stages, plan).with_cone_tiles(tiles.as_u32()))
}

pub(crate) fn image_of(w: u32, h: u32, bytes: &[u8]) -> RgbImage {
    let px: &[[f32; 4]] = bytemuck::cast_slice(bytes);
    RgbImage::new(w, h, px.iter().map(|p| [p[0], p[1], p[2]]).collect())
}

/// `pipeline`'s frame computed by the scalar mirrors alone (no GPU), stage by stage as its
/// declaration's steps run ([`crate::pipeline::host`]): deterministic, so it is what the snapshot
/// tests store; the GPU image is then compared to it numerically (DESIGN.md section 8). With cprc,
/// what its caches did.
pub fn mirror_frame(
    pipeline: Pipeline,
    scene: &Scene,
    cones: &ConeSettings,
) -> Result<(Rendered, Option<crate::cprc::CprcStats>)> {
    supersampled(scene, |s| {
        crate::pipeline::host::frame(pipeline.decl(), None, s, cones, &|_| true, &|_| {})
    })
}

/// vct-dense's [`mirror_frame`].
pub fn render_mirror(scene: &Scene, cones: &ConeSettings) -> Result<Rendered> {
    Ok(mirror_frame(Pipeline::VctDense, scene, cones)?.0)
}

/// lrsm's [`mirror_frame`] (the snapshot tests' lrsm images): occlusion voxels of the mirror's
/// voxelization, the mirrors' RSMs and LRSMs of every light view, the gather's mirror.
pub fn render_lrsm_mirror(scene: &Scene, cones: &ConeSettings) -> Result<Rendered> {
    Ok(mirror_frame(Pipeline::Lrsm, scene, cones)?.0)
}

/// The lrsm mirror frame with each cone sample's alpha and L taken as `swap` says
/// ([`crate::lrsm_factors`]): the per-factor diagnostic's frames. One sample per pixel.
pub fn render_lrsm_factors(
    scene: &Scene,
    cones: &ConeSettings,
    swap: crate::lrsm_factors::Swap,
) -> Result<Rendered> {
    use crate::lrsm_factors::{Alpha, Radiance};
    use crate::pipeline::host;
    // The row's occlusion mips and Algorithm 1's N (and so the row's plan).
    let mut scene = scene.clone();
    match swap.alpha {
        Alpha::Volume => scene.render.lrsm_surface_coverage = false,
        Alpha::Surface => scene.render.lrsm_surface_coverage = true,
        Alpha::Voxels => {}
    }
    if let Radiance::Lrsm(a) = swap.radiance {
        scene.render.lrsm_view_weight = a.view_weight;
    }
    let mirror = |_: &str| true;
    let mut f = host::run(
        &crate::pipeline::LRSM,
        None,
        &scene,
        cones,
        &mirror,
        &|_| {},
        Some("lrsm_cone_trace"),
    )?;
    // vct-dense's lit-voxel pyramid, the stand-in for the exact factors.
    host::voxelize_step(&mut f)?;
    host::voxel_light_step(&mut f)?;
    host::mips_step(&mut f)?;
    let built = f.lrsm.as_ref().expect("the LRSMs");
    let params = cone_trace::cone_params(&built.voxels, cones);
    let vol = built.volume(&params);
    let pyramids = f.pyramid.as_ref().expect("the pyramid");
    let factors = crate::lrsm_factors::FactorVolume::new(&vol, pyramids, swap);
    let out = f.shade(&factors, vol.lmax);
    f.cones_out = Some(out);
    Ok(f.rendered())
}

/// cprc's [`mirror_frame`] (the snapshot tests' cprc images): the mirror's pyramid, distribution,
/// cache creation, pre-convolution and gather, and what its caches did.
pub fn render_cprc_mirror(
    scene: &Scene,
    cones: &ConeSettings,
) -> Result<(Rendered, crate::cprc::CprcStats)> {
    let (r, stats) = mirror_frame(Pipeline::Cprc, scene, cones)?;
    Ok((r, stats.unwrap_or_default()))
}

/// vct-svo's [`mirror_frame`] (the snapshot tests' vct-svo images): the mirror's octree of the lit
/// voxels, then cone_trace's mirror through it.
pub fn render_svo_mirror(scene: &Scene, cones: &ConeSettings) -> Result<Rendered> {
    Ok(mirror_frame(Pipeline::VctSvo, scene, cones)?.0)
}

/// The G-buffer by the mirror (each pixel's own primary hit, no GPU pick to accept) and its albedo.
pub fn mirror_texels(data: &SceneData) -> (Vec<vxgi_cpu_mirror::gbuffer::Texel>, Vec<[f32; 4]>) {
    use rayon::prelude::*;
    use vxgi_cpu_mirror::gbuffer as gbm;
    let w = data.width();
    let texels: Vec<gbm::Texel> = (0..w * data.height())
        .into_par_iter()
        .map(|i| gbm::shade_pixel(&data.frame, &data.nodes, &data.triangles, i % w, i / w))
        .collect();
    let tex = data.textures();
    let albedo = texels
        .iter()
        .map(|t| gbm::albedo(&data.materials, &data.triangles, &tex, t))
        .collect();
    (texels, albedo)
}
