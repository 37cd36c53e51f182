//! Rendering a scene: [`DirectRenderer`] records the `gbuffer` and `direct_light` kernels into a
//! caller's encoder, writing into caller-owned buffers (the API for lifting these kernels into
//! another renderer); [`render`], [`render_svo`], [`render_lrsm`], [`render_cprc`] and [`Renderer`]
//! draw frames with the GPU-resident renderer ([`crate::resident::Resident`]); [`Pipeline`] names
//! the pipelines and their declarations; [`VctSvo`] builds vct-svo's octree; [`mirror_frame`] is a
//! frame by the scalar mirrors alone; supersampling and the exposure of bright lights.
use crate::images::RgbImage;
use crate::kernels::cone_trace::{self, ConeSettings};
use crate::kernels::lrsm_cone_trace::LrsmMemory;
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
/// `pipeline`'s frames are rendered at an exposure ([`exposure_for`]) where the lights are very
/// bright, or for vct-svo very dim: every light scaled by the power of two 2^-k, the radiance
/// images scaled back by 2^k (light transport is linear in the lights, and a power of two is exact
/// in floating point). The kernels' f32 sums (up to 4096 texels before cprc's pre-convolution
/// divides, N^4 in the interleaved resolve, 1/r^2 of a point light) and vct-svo's fixed point then
/// stay in range for any finite intensity. Radiance past f32::MAX after scaling back saturates
/// there.
pub(crate) fn supersampled<T>(
    scene: &Scene,
    pipeline: Pipeline,
    frame: impl FnOnce(&Scene) -> Result<(Rendered, T)>,
) -> Result<(Rendered, T)> {
    let k = exposure_for(scene, pipeline);
    if k != 0 {
        let exposed = scene.with_lights_scaled(2f32.powi(-k));
        let (r, extra) = supersampled(&exposed, pipeline, frame)?;
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

/// The lights' typical radiance below which vct-svo renders at an exposure ([`exposure_for`]):
/// 2^-6. Every shipped scene's is above it, so their frames are unchanged bit for bit.
pub const DIM_LIMIT: f32 = 1.0 / 64.0;

/// The k of the exposure 2^-k `pipeline`'s frames of `scene` are rendered at: [`exposure`]'s for
/// bright lights; and for vct-svo, where the lights' typical radiance at that exposure
/// (`lit_cells::typical_radiance`: a white surface's at the far side of the mesh's bounds) is below
/// [`DIM_LIMIT`], the one that brings it into [1/4, 1/2) (keeping the brightest intensity within
/// 2^64). vct-svo's octree holds the light and the voxels' coverage (up to 1) in one fixed point,
/// whose scale the coverage keeps near 2^24 steps a unit at most: in a scene modelled in large units
/// (a room in centimetres, lit by lights of ordinary intensity) the radiance is far below 1, and the
/// photons' shares of a voxel's light rounded to nothing (indirect exactly 0).
pub fn exposure_for(scene: &Scene, pipeline: Pipeline) -> i32 {
    let k = exposure(scene);
    if pipeline != Pipeline::VctSvo || scene.mesh.positions.is_empty() {
        return k;
    }
    let lights = crate::trace::gpu_lights(scene);
    let typical = crate::kernels::lit_cells::typical_radiance(&lights, scene.mesh.bounds());
    if !(typical.is_finite() && typical > 0.0) || typical * 2f32.powi(-k) >= DIM_LIMIT {
        return k;
    }
    (typical.log2().floor() as i32 + 2).max(brightest(scene).log2().floor() as i32 - 64)
}

/// The largest intensity component of `scene`'s lights (0 without lights).
fn brightest(scene: &Scene) -> f32 {
    scene
        .lights
        .iter()
        .flat_map(|l| l.intensity())
        .fold(0.0f32, f32::max)
}

/// The k of the exposure 2^-k a scene is rendered at for its bright lights: 0 where every intensity
/// component is at most [`EXPOSURE_LIMIT`], else the one that brings the largest into [1, 2).
pub fn exposure(scene: &Scene) -> i32 {
    let m = brightest(scene);
    if m <= EXPOSURE_LIMIT || !m.is_finite() {
        0
    } else {
        m.log2().floor() as i32
    }
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
    /// Whether the cones read the normal pyramid (the depth-ordered blend).
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
}

type Stages = Vec<(&'static str, f64)>;

/// Lit voxels `(L * alpha, alpha)`, normals, albedo (voxelize's colour), Morton order, the frame,
/// and how many voxels voxelize listed (the non-empty ones).
type LitVoxels = (
    Vec<[f32; 4]>,
    Vec<[f32; 4]>,
    Vec<[f32; 4]>,
    voxelize::VoxelFrame,
    u32,
);

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
    Ok((rad, grid.normal, grid.colour, frame, list.len() as u32))
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
    /// Every pipeline, in the order the tables list them.
    pub const ALL: [Pipeline; 4] = [
        Pipeline::VctDense,
        Pipeline::VctSvo,
        Pipeline::Lrsm,
        Pipeline::Cprc,
    ];

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

/// One vct-dense frame by a fresh GPU-resident renderer ([`crate::resident::Resident`]: every
/// stage runs, nothing is kept).
pub fn render(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    progress: impl Fn(&str),
) -> Result<Rendered> {
    progress("recording the frame");
    crate::resident::Resident::new(ctx, Pipeline::VctDense)?.render(scene, cones)
}

/// One frame of `pipeline` by a fresh GPU-resident renderer, and what its volume holds.
fn one_frame(
    ctx: &crate::harness::GpuContext,
    pipeline: Pipeline,
    scene: &Scene,
    cones: &ConeSettings,
) -> Result<(Rendered, Option<VolumeMemory>)> {
    let mut r = crate::resident::Resident::new(ctx, pipeline)?;
    let frame = r.render(scene, cones)?;
    Ok((frame, r.memory()))
}

/// One vct-svo frame (sparse voxel octree, VCT 2011) by a fresh GPU-resident renderer, and the
/// octree's memory report (its actual allocation).
pub fn render_svo(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    progress: impl Fn(&str),
) -> Result<(Rendered, crate::kernels::sparse_voxel_octree::MemoryReport)> {
    progress("recording the frame");
    match one_frame(ctx, Pipeline::VctSvo, scene, cones)? {
        (f, Some(VolumeMemory::Octree(m))) => Ok((f, m)),
        _ => anyhow::bail!("vct-svo's frame reports its octree"),
    }
}

/// One lrsm frame (Sugihara et al. 2014) by a fresh GPU-resident renderer, and the bytes of each
/// structure.
pub fn render_lrsm(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    progress: impl Fn(&str),
) -> Result<(Rendered, LrsmMemory)> {
    progress("recording the frame");
    match one_frame(ctx, Pipeline::Lrsm, scene, cones)? {
        (f, Some(VolumeMemory::Lrsm(m))) => Ok((f, m)),
        _ => anyhow::bail!("lrsm's frame reports its structures"),
    }
}

/// One cprc frame (Rehfeld et al. 2014) by a fresh GPU-resident renderer, and what its caches did.
pub fn render_cprc(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    progress: impl Fn(&str),
) -> Result<(Rendered, crate::cprc::CprcStats)> {
    progress("recording the frame");
    match one_frame(ctx, Pipeline::Cprc, scene, cones)? {
        (f, Some(VolumeMemory::Caches(c))) => Ok((f, c)),
        _ => anyhow::bail!("cprc's frame reports its caches"),
    }
}

/// Frames of any of the four pipelines by the GPU-resident renderer, with the reuse rules on (one
/// renderer for every frame: what the last frame built serves the next where the plan says so) or
/// off (a fresh renderer each frame: every stage runs).
///
/// Example: `Renderer::new(Pipeline::Cprc, true).render(&ctx, &scene, &cones, |_| {})`.
pub struct Renderer<'c> {
    pipeline: Pipeline,
    reuse: bool,
    resident: Option<crate::resident::Resident<'c>>,
}

impl<'c> Renderer<'c> {
    pub fn new(pipeline: Pipeline, reuse: bool) -> Self {
        Self {
            pipeline,
            reuse,
            resident: None,
        }
    }

    /// One frame, and what its volume holds (vct-svo, lrsm, cprc).
    pub fn render(
        &mut self,
        ctx: &'c crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
        progress: impl Fn(&str),
    ) -> Result<(Rendered, Option<VolumeMemory>)> {
        progress("recording the frame");
        if !self.reuse || self.resident.is_none() {
            self.resident = Some(crate::resident::Resident::new(ctx, self.pipeline)?);
        }
        let r = self.resident.as_mut().expect("made above");
        let frame = r.render(scene, cones)?;
        Ok((frame, r.memory()))
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

/// vct-svo's octree builder, stage by stage on the GPU with host steps between its passes (the
/// resident renderer's, when it builds its chain): the octree, its directional values and pools
/// for a scene, kept while the scene's geometry, materials, lights and settings are unchanged
/// (the same octree a rebuild would make); with dynamic instances the static part's voxels and
/// subdivisions kept across frames ([`StaticVoxels`]).
pub struct VctSvo {
    /// Replay the static part's recorded octree structure (scenes with dynamic instances; default on).
    replay: bool,
    /// The last octree and what it was built for.
    cache: Option<SvoCache>,
    statics: StaticVoxels,
    /// The plan of the frame that built the last octree, with what the build found (the static
    /// part kept, its subdivisions replayed).
    built_plan: Option<FramePlan>,
}

/// What vct-svo's octree depends on ([`VctSvo::key`]).
type SvoKey = (PyramidKey, u32, bool, bool, u32, Option<String>);

/// vct-svo's octree as the cone pass reads it, and the key it was built for.
pub struct SvoCache {
    key: SvoKey,
    pub built: crate::kernels::sparse_voxel_octree::GpuOctree,
    pub frame: voxelize::VoxelFrame,
    /// How many voxels voxelize listed: the fragments a chain that lights the octree makes.
    pub listed: u32,
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
                .map(|&m| vxgi_cpu_mirror::sparse_voxel_octree::Fragment::point(m))
                .collect();
            let depth = vxgi_cpu_mirror::sparse_voxel_octree::depth_for(frame.side);
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

impl Default for VctSvo {
    fn default() -> Self {
        Self::new()
    }
}

impl VctSvo {
    /// The octree builder, nothing built yet.
    pub fn new() -> Self {
        Self {
            replay: true,
            cache: None,
            statics: StaticVoxels::default(),
            built_plan: None,
        }
    }

    /// Build every frame's octree structure from all its fragments instead of replaying the static
    /// part's (the same octree; for comparisons).
    pub fn without_static_replay(mut self) -> Self {
        self.replay = false;
        self
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
        // Where the voxels give the octree its geometry alone, the occupancy bits' voxels.
        let mut occupied = None;
        let (rad, normal, colour, frame, listed) = match split {
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
            None if crate::pipeline::coverage_alone(scene) => {
                progress("voxelize");
                let t = std::time::Instant::now();
                let side = scene.render.voxels;
                let (bits, frame) = voxelize::occupancy_on_gpu(ctx, scene, side)?;
                stages.push(("voxelize", t.elapsed().as_secs_f64()));
                let list: Vec<u32> =
                    vxgi_cpu_mirror::voxelize::occupied(&bits, (side as u64).pow(3)).collect();
                let listed = list.len() as u32;
                occupied = Some(list);
                (Vec::new(), Vec::new(), Vec::new(), frame, listed)
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
        let values: Vec<_> = match &occupied {
            Some(list) => svo_cone_trace::listed_coverage(list).collect(),
            None => svo_cone_trace::grid_values(&rad).collect(),
        };
        let photon_values = photons.iter().flat_map(|p| p.values());
        let scale = svo_cone_trace::fixed_scale(
            values.iter().copied().chain(photon_values),
            scene.render.bounces,
        );
        let mut frags = svo_cone_trace::values_fragments(values.into_iter(), scale)?;
        // Lit in the resident chain, the structure is the voxels' alone: the chain keeps it while
        // the lights move, so it must not depend on where the photons of this light landed (a
        // photon at a point the voxels lack adds nothing there, whichever light cast it).
        let voxels_only =
            (photons.is_some() && crate::pipeline::lights_in_chain(scene)).then(|| frags.clone());
        // With the lobes, the glossy surfaces' specular photons (their points join the structure).
        let mut spec_frags = Vec::new();
        if let Some(photons) = &photons {
            spec_frags = photons
                .fragments(scale)?
                .join_into(&mut frags, plan.runs("svo_lobes"));
        }
        progress("sparse voxel octree");
        let t = std::time::Instant::now();
        let depth = vxgi_cpu_mirror::sparse_voxel_octree::depth_for(frame.side);
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
        let built = build(voxels_only.as_deref().unwrap_or(&frags))?;
        stages.push(("sparse_voxel_octree", t.elapsed().as_secs_f64()));
        let directional = |built: &svo::GpuOctree, stages: &mut Stages| -> Result<_> {
            if !plan.runs("svo_anisotropic") {
                return Ok(None);
            }
            progress("anisotropic voxels");
            let t = std::time::Instant::now();
            let a = crate::kernels::svo_anisotropic::build_on_gpu(ctx, &built.octree, 1.0 / scale)
                .with_context(|| {
                    format!(
                        "anisotropic voxels ({} bytes per octree node above the leaves, in at most {} bindings of {} bytes): anisotropic_voxels = false or fewer voxels makes them fit",
                        vxgi_cpu_mirror::svo_anisotropic::NODE_VALUES * 16,
                        crate::kernels::svo_anisotropic::POOL_VIEWS.len(),
                        crate::kernels::svo_anisotropic::POOL_WINDOW * 16
                    )
                })?;
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
            listed,
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
    pub fn volume(
        &mut self,
        ctx: &crate::harness::GpuContext,
        scene: &Scene,
        cones: &ConeSettings,
    ) -> Result<(&SvoCache, Stages)> {
        let mut stages = Vec::new();
        let key = Self::key(scene, cones);
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
            self.built_plan = Some(plan);
        }
        Ok((self.cache.as_ref().expect("built above"), stages))
    }

    /// The plan of the frame that built the last octree ([`VctSvo::volume`]), its volume stages
    /// annotated with what the build did.
    pub fn built_plan(&self) -> Option<&FramePlan> {
        self.built_plan.as_ref()
    }

    /// What the octree depends on: the pyramid key, photon_map, anisotropic_voxels, voxel_lobes,
    /// bounces and, with two bounces, the cones that gather the second one.
    fn key(scene: &Scene, cones: &ConeSettings) -> SvoKey {
        let r = &scene.render;
        (
            PyramidKey::of(scene),
            r.photon_map,
            r.anisotropic_voxels,
            r.voxel_lobes,
            r.bounces,
            // ConeSettings is plain data without PartialEq: its Debug text is its value.
            (r.bounces == 2).then(|| format!("{cones:?}")),
        )
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
            let (lo, hi) = mesh.bounds();
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
    supersampled(scene, pipeline, |s| {
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
    // The row's occlusion mips and Algorithm 1's N (and so the row's plan); direct light by exact
    // shadow rays (the diagnostic is about the indirect light).
    let mut scene = scene.clone();
    scene.render.shadow_cone_angle = 0.0;
    match swap.alpha {
        Alpha::Volume => scene.render.lrsm_surface_coverage = false,
        Alpha::Surface => scene.render.lrsm_surface_coverage = true,
        Alpha::Voxels => {}
    }
    if let Radiance::Lrsm(a) = swap.radiance {
        scene.render.lrsm_view_weight = a.view_weight;
    }
    // The frame's LRSMs are Algorithm 1's (read as the paper reads them, not through the lit
    // cells); the rows that read area-weighted ones build their own.
    scene.render.lrsm_area_weights = false;
    scene.render.lrsm_lit_cells = false;
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
    // The exact footprint's, the occlusion cells' and the area-weighted LRSM's rows read each
    // light view's RSM, as the frame's views made them.
    let rsms: Vec<crate::lrsm::Rsm> = match swap.radiance {
        Radiance::Lrsm(a) if a.exact.is_some() || a.cells.is_some() || a.area_lrsm => {
            crate::lrsm::light_views(
                &f.data.lights,
                f.data.bounds,
                f.scene.render.rsm_side,
                f.data.frame.eye[3],
            )?
            .iter()
            .map(|v| crate::kernels::reflective_shadow_map::rsm_mirror(&f.data, v))
            .collect()
        }
        _ => Vec::new(),
    };
    let mut area: [Vec<[f32; 4]>; 3] = Default::default();
    if matches!(swap.radiance, Radiance::Lrsm(a) if a.area_lrsm) {
        // The kernels' partition with area weights (their mirror), whatever the scene says.
        let config = crate::lrsm::PartitionConfig {
            area_weights: true,
            ..crate::kernels::lrsm_cone_trace::LrsmSettings::from(&f.scene.render).partition()
        };
        for rsm in &rsms {
            let view = crate::kernels::sample_lrsm::lrsm_mirror(rsm, &config);
            for (all, v) in area.iter_mut().zip(view) {
                all.extend(v);
            }
        }
    }
    let factors = crate::lrsm_factors::FactorVolume::new(&vol, &rsms, &area, pyramids, swap);
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
