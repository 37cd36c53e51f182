//! GPU-resident frame sequences: a renderer that keeps its frame's resources, compute pipelines and
//! bind groups on the GPU across frames and records each frame into one command encoder and one
//! submission, reading back only the images it returns.
//!
//! [`Resident`] draws every pipeline's frames from its chain ([`crate::pipeline`]), the verified
//! kernels on the inputs their cases define; cprc's cache stages are dispatched from the cache
//! count the GPU found, in buffers sized for the most caches a frame can place
//! (`crate::pipeline::cache_room`). vct-svo's chain builds its whole octree, the first frame
//! included (`crate::pipeline::builds_in_chain`): the light injection (voxel_light or the photons),
//! `svo_fragments`, the octree's structure and values and its directional values, in room sized at
//! load from the scene's voxels (`crate::pipeline::OctreeRoom`: a frame that outgrows it, as moved
//! instances may, is found from its GPU counts, read back with the frame's small outputs, and drawn
//! again on a chain sized for it by [`Resident::render`]; [`Resident::present`] builds the next
//! frame's). With Gaussian lobes its structure is built by the staged passes
//! ([`crate::render::VctSvo`]) when the chain is built (their host steps between passes run then,
//! once) and the chain lights it; with two bounces, the photons' specular pool or Gaussian lobes
//! with instances the staged passes light it too, and the chain is the camera's stages alone:
//! `crate::pipeline::lights_in_chain`. A chain is prepared once by the harness
//! (`prepare_chain`: every resource checked against reflection and the device limits, then created
//! and uploaded). A frame whose geometry, materials, lights and settings equal the last one's (the
//! camera may move) uploads the camera (one `Frame`, 80 bytes), records the G-buffer, direct light
//! (lrsm with shadow cones: the gather's shadow pass), tile list and cone passes and submits once; the volume stays where the first frame built it. A
//! frame whose lights moved (their number and, for lrsm, their number of light views unchanged) also
//! uploads them (and lrsm's light views) and re-runs what the lights feed over the kept voxels:
//! voxel_light and the mips (vct-dense), every view's RSM and LRSM (lrsm), the light injection
//! and the octree's values over its kept structure (vct-svo, where the chain lights it; else moved
//! lights rebuild its octree). A frame whose instances moved re-lights the kept hierarchies
//! (vct-dense, cprc) or voxelizes the scene again in the kept chain (lrsm; vct-svo, its octree's
//! structure built again too). A frame that differs in the image size or in
//! settings builds a new chain; where that chain's volume passes are the kept chain's over the
//! same inputs (the settings changed are read by the camera's stages alone: the cone count, AO,
//! the image size), it binds the kept volume's buffers instead of computing the volume again (vct-svo
//! with Gaussian lobes uploads the octree its staged passes built, without building it again).
//! Anything else
//! rebuilds the whole chain, and the plan says why.
use crate::harness::HostResource;
use crate::harness::{GpuContext, Prepared, ReadbackSet};
use crate::kernels::cone_trace::ConeSettings;
use crate::kernels::lrsm_cone_trace::LrsmSettings;
use crate::pipeline::{Chain, ChainCopy, Reuse};
use crate::plan::FramePlan;
use crate::render::{image_of, Pipeline, PyramidKey, Rendered, VolumeMemory};
use crate::scene::{RenderSettings, Scene};
use crate::trace::SceneData;
use anyhow::{Context, Result};

/// What shapes the resident resources: a frame with other values rebuilds them. The lights are not
/// part of it (only their number, and lrsm's and vct-svo's photons' number of light views): a frame
/// whose lights moved re-lights the kept voxels (vct-svo's octree where its chain lights it; else
/// its lights are part of the volume's key).
#[derive(Clone, Debug, PartialEq)]
struct Key {
    volume: PyramidKey,
    /// With `[[instances]]`: each voxel hierarchy's mesh (in its own frame) and grid side, and the
    /// sizes of the scene's triangle and BVH buffers; where the instances stand is not part of it (a
    /// frame whose instances moved re-lights the kept hierarchies).
    hierarchies: Vec<(crate::scene::Mesh, u32)>,
    scene_sizes: (usize, usize),
    /// lrsm and vct-svo ([`revoxelizes`]) with `[[instances]]`: the voxel grid's origin and voxel
    /// size (the flattened mesh's extent decides it; within the same grid a frame whose instances
    /// moved re-voxelizes in the chain: triangle_setup sizes voxelize's dispatch on the GPU).
    world: Option<[f32; 4]>,
    lights: usize,
    views: usize,
    render: RenderSettings,
    cones: String,
    size: (u32, u32),
}

impl Key {
    /// Whether `next` differs from `self` at most in the image size and the render and cone
    /// settings: what shapes the volume may be the same, so a chain built for `next` may take the
    /// kept volume's buffers where its volume passes are the kept ones over the same inputs
    /// ([`volume_of`]).
    fn may_keep_volume(&self, next: &Key) -> bool {
        Key {
            size: next.size,
            render: next.render.clone(),
            cones: next.cones.clone(),
            ..self.clone()
        } == *next
    }

    /// What differs from `self` in `next`, in words.
    fn change_to(&self, next: &Key) -> String {
        let mut what = Vec::new();
        if self.size != next.size {
            what.push(format!(
                "the image size changed ({}x{} -> {}x{})",
                self.size.0, self.size.1, next.size.0, next.size.1
            ));
        }
        if self.render.voxels != next.render.voxels {
            what.push(format!(
                "voxels changed ({} -> {})",
                self.render.voxels, next.render.voxels
            ));
        }
        if self.lights != next.lights {
            what.push(format!(
                "the number of lights changed ({} -> {})",
                self.lights, next.lights
            ));
        } else if self.views != next.views {
            what.push(format!(
                "the number of light views changed ({} -> {})",
                self.views, next.views
            ));
        }
        if self.hierarchies != next.hierarchies || self.scene_sizes != next.scene_sizes {
            what.push("the instances' meshes, grid sides or the scene's BVH size changed".into());
        }
        if self.world != next.world {
            what.push("the scene's extent (the voxel grid) changed".into());
        }
        if self.volume != next.volume && self.render.voxels == next.render.voxels {
            if self.volume.unlit() == next.volume.unlit() {
                what.push("the lights moved (vct-svo's octree values hold the light)".into());
            } else {
                what.push(
                    "the geometry, materials or the mip levels the cones read changed".into(),
                );
            }
        }
        if what.is_empty() {
            let pretty = |r: &RenderSettings| format!("{r:#?}");
            let mut changed = debug_diff(&pretty(&self.render), &pretty(&next.render));
            for c in debug_diff(&self.cones, &next.cones) {
                if !changed.contains(&c) {
                    changed.push(c);
                }
            }
            what.push(if changed.is_empty() {
                "the render or cone settings changed".into()
            } else {
                format!("settings changed ({})", changed.join(", "))
            });
        }
        what.join("; ")
    }

    /// The key of `scene`'s frame; `data` is the scene's [`SceneData`] where it has instances, `vox`
    /// voxelize's input and grid where the chain re-voxelizes moved instances ([`revoxelized`]).
    fn of(
        pipeline: Pipeline,
        scene: &Scene,
        cones: &ConeSettings,
        data: Option<&SceneData>,
        vox: Option<&Voxelized>,
    ) -> Self {
        let instanced = !scene.instances.list.is_empty();
        let world = vox.map(|(_, f)| [f.origin.x, f.origin.y, f.origin.z, f.voxel]);
        let revoxelizes = revoxelizes(pipeline, scene);
        let (hierarchies, scene_sizes) = match data {
            Some(d) if revoxelizes => (Vec::new(), (d.triangles.len(), d.nodes.len())),
            Some(d) if instanced && pipeline != Pipeline::VctSvo => {
                let (_, parts) = crate::render::hierarchy_parts(scene);
                (
                    parts.into_iter().map(|(m, side, _)| (m, side)).collect(),
                    (d.triangles.len(), d.nodes.len()),
                )
            }
            _ => (Vec::new(), (0, 0)),
        };
        // With instances the voxels depend on the meshes in their own frames, not where they stand
        // (vct-svo's octree, built from the flattened scene where the staged passes light it: moved
        // instances build it again).
        let base;
        let scene = if instanced && (pipeline != Pipeline::VctSvo || revoxelizes) {
            base = Scene {
                mesh: scene.instances.base.clone(),
                ..scene.clone()
            };
            &base
        } else {
            scene
        };
        let (volume, views) = match pipeline {
            // The levels the cones read: the others are not built.
            Pipeline::VctDense => (PyramidKey::reading(scene, cones).unlit(), 0),
            // The octree's values hold the light: moved lights re-light it in the chain where the
            // chain lights it, else rebuild it.
            Pipeline::VctSvo if crate::pipeline::lights_in_chain(scene) => (
                PyramidKey::of(scene).unlit(),
                if scene.render.photon_map > 0 {
                    crate::plan::light_views(scene)
                } else {
                    0
                },
            ),
            Pipeline::VctSvo => (PyramidKey::of(scene), 0),
            // The caches' cones read every level.
            Pipeline::Cprc => (PyramidKey::of(scene).unlit(), 0),
            Pipeline::Lrsm => (
                PyramidKey::of(scene).unlit(),
                crate::plan::light_views(scene),
            ),
        };
        Self {
            volume,
            hierarchies,
            scene_sizes,
            world,
            lights: scene.lights.len(),
            views,
            render: scene.render.clone(),
            // ConeSettings is plain data without PartialEq: its Debug text is its value.
            cones: format!("{cones:#?}"),
            size: (scene.camera.width, scene.camera.height),
        }
    }
}

struct Built<'c> {
    key: Key,
    /// The lights the kept voxels are lit by now.
    lights: Vec<crate::scene::Light>,
    /// The scene's mesh as the last frame placed it (with instances: where they stood).
    mesh: crate::scene::Mesh,
    /// With instances: each voxel hierarchy's grid frame, in the chain's order.
    hierarchies: Option<Vec<crate::kernels::voxelize::VoxelFrame>>,
    /// lrsm and vct-svo with instances ([`revoxelizes`]): what a frame whose instances moved resets
    /// before re-running the volume passes from voxelize on ([`written_in`]: cleared, restored).
    revoxelize: Option<Resets>,
    /// vct-svo lit in the chain: what a frame with moved lights resets before re-running the passes
    /// the lights feed ([`written_in`]: cleared, restored).
    relight_resets: Option<Resets>,
    /// vct-svo whose chain builds the octree's structure (instances): the room it holds, checked
    /// after every frame against the GPU's counts.
    octree_room: Option<crate::pipeline::OctreeRoom>,
    prepared: Prepared<'c>,
    /// The frame's images and the small outputs its plan reads ([`Resident::render`]).
    reads: ReadbackSet,
    /// The small outputs alone: the tile list and cprc's cache counts ([`Resident::present`]).
    counts: ReadbackSet,
    /// The ray epsilon of the scene's camera frames (`Frame::eye.w`, from the mesh's extent) and
    /// the mesh's bounds: what lrsm's light views are made from besides the lights.
    eps: f32,
    bounds: (glam::Vec3, glam::Vec3),
    /// The chain's voxel grid (vct-svo's photons are placed in it).
    voxels: crate::kernels::voxelize::VoxelFrame,
    /// (stage, its passes' range) in chain order; a stage of several kernels appears once per kernel.
    stages: Vec<(&'static str, std::ops::Range<usize>)>,
    /// Where the per-frame passes start (the camera's G-buffer) and where the chain ends.
    per_frame: std::ops::Range<usize>,
    /// Where the camera's G-buffer passes end: a frame with the caller's G-buffer starts there.
    gbuffer_end: usize,
    /// Where the passes the lights feed start: a frame with moved lights runs from there.
    relight: usize,
    /// The buffers the volume's passes (those before the camera's G-buffer) write, and the copies
    /// between them fill: what a chain built for another image size or other settings takes from
    /// this one ([`volume_of`]).
    volume: Vec<String>,
    /// [`passes_fingerprint`] of the volume's passes, as the chain was built.
    volume_inputs: u64,
    copies: Vec<ChainCopy>,
    /// The per-frame outputs zeroed before a frame that reuses the chain (each is zero in a fresh one).
    cleared: Vec<&'static str>,
    /// The per-frame outputs a frame reads before it has written all of them, restored before a
    /// frame that reuses the chain from a copy of their first contents: (copy, output).
    restored: Vec<(String, String)>,
    /// cprc: the cache buffers' capacity.
    room: Option<crate::pipeline::CacheRoom>,
    /// The buffer holding the direct light the camera sees.
    direct: &'static str,
    /// Wall clock of the stages that ran outside the chain to build it (vct-svo's octree), counted
    /// to the frame that built it.
    build_stages: Vec<(&'static str, f64)>,
    memory: Option<VolumeMemory>,
    /// The chain's GPU bytes by the stage that writes each resource ([`stage_memory`]).
    stage_memory: Vec<(&'static str, u64)>,
}

/// A frame's images on the GPU, as [`Resident::encode`] leaves them: `vec4<f32>` per pixel, row by
/// row (rgb, then w): the direct and the indirect light reflected towards the camera (what `vxgi
/// render` writes as direct.exr and indirect.exr) and ambient occlusion. Valid until the next frame
/// is recorded.
pub struct FrameBuffers {
    pub direct: wgpu::Buffer,
    pub indirect: wgpu::Buffer,
    pub ao: wgpu::Buffer,
}

/// A G-buffer the caller made (e.g. by rasterizing the scene), for [`Resident::encode_with_gbuffer`]:
/// one element per pixel of the scene's camera, row by row from the top, in `gbuffer.wgsl`'s layouts
/// (docs/contract.md, "Frame buffers"). Each buffer needs `COPY_SRC` usage and exactly
/// `width * height` elements.
pub struct GBuffer<'a> {
    /// `vec4<f32>`: the world position of the surface seen and its distance from the eye; `(0, 0, 0,
    /// -1)` where nothing is seen.
    pub position: &'a wgpu::Buffer,
    /// `vec4<f32>`: the unit shading normal and the side seen (1 front, -1 back, 0 nothing).
    pub normal: &'a wgpu::Buffer,
    /// `u32`: the index of the triangle seen in [`SceneData::triangles`] of the scene, `u32::MAX`
    /// where none.
    pub triangle: &'a wgpu::Buffer,
    /// `vec4<f32>`: the diffuse albedo (rgb, 0).
    pub albedo: &'a wgpu::Buffer,
}

impl GBuffer<'_> {
    /// Whether these buffers fit the camera of `scene` (sizes and `COPY_SRC` usage): checked before
    /// anything of the frame is built or recorded.
    fn check(&self, scene: &Scene) -> Result<()> {
        let pixels = scene.camera.width as u64 * scene.camera.height as u64;
        for (src, name, bytes) in self.parts() {
            anyhow::ensure!(
                src.size() == pixels * bytes,
                "the caller's {name} holds {} bytes; the camera's image needs {}",
                src.size(),
                pixels * bytes
            );
            anyhow::ensure!(
                src.usage().contains(wgpu::BufferUsages::COPY_SRC),
                "the caller's {name} needs COPY_SRC usage (it is copied into the frame's G-buffer)"
            );
        }
        Ok(())
    }

    /// Each buffer with the chain's name for it and its bytes per pixel.
    fn parts(&self) -> [(&wgpu::Buffer, &'static str, u64); 4] {
        [
            (self.position, "gb_position", 16),
            (self.normal, "gb_normal", 16),
            (self.triangle, "gb_triangle", 4),
            (self.albedo, "gb_albedo", 16),
        ]
    }

    /// Record the copies of these buffers into the chain's G-buffer ([`GBuffer::check`]ed).
    fn copy_into(&self, p: &Prepared, encoder: &mut wgpu::CommandEncoder) -> Result<()> {
        for (src, name, _) in self.parts() {
            let dst = p.buffer(name).context("the chain's G-buffer")?;
            anyhow::ensure!(
                src.size() == dst.size(),
                "the caller's {name}: size changed"
            );
            encoder.copy_buffer_to_buffer(src, 0, dst, 0, src.size());
        }
        Ok(())
    }
}

/// What a caller records after a frame's passes, over its images, into the frame's encoder (e.g. a
/// display pass into a window's surface texture): [`Resident::present`].
pub type Draw<'a> = &'a mut dyn FnMut(&mut wgpu::CommandEncoder, &FrameBuffers) -> Result<()>;

/// What a frame ran: its stages' GPU time (timestamp queries; a frame that built the chain first
/// also the stages that built it outside the chain, by wall clock), its plan, and the cone pass's
/// screen tiles (listed, all) where it has one.
pub struct FrameReport {
    pub stages: Vec<(&'static str, f64)>,
    pub plan: FramePlan,
    pub cone_tiles: Option<(u32, u32)>,
}

/// A pipeline's frames with everything on the GPU (see the module doc).
///
/// Example: `examples/embed_pipeline.rs` records a pipeline's frame into its own program's command
/// encoder over a G-buffer it rasterized itself (`cargo run --release --example embed_pipeline`).
pub struct Resident<'c> {
    ctx: &'c GpuContext,
    pipeline: Pipeline,
    built: Option<Built<'c>>,
    /// cprc: what the last frame's caches did.
    caches: Option<crate::cprc::CprcStats>,
    /// Why the last frame rebuilt the chain that an earlier frame had built, for its plan.
    rebuilt: Option<String>,
    /// Whether the last frame's new chain took the volume of the chain before it (a new image size
    /// or settings the volume does not read).
    kept_volume: bool,
    /// Whether the last frame's chain was timed pass by pass (timestamp queries).
    timed: bool,
    /// vct-svo: the staged passes that build the octree, holding the last one and what it was
    /// built for (a chain at another image size uploads it again instead of building it).
    svo: crate::render::VctSvo,
    /// Why the last frame's octree did not fit its chain's room ([`crate::pipeline::OctreeRoom`]):
    /// the chain was dropped, the next frame builds it again.
    outgrown: Option<String>,
    /// vct-svo in a room: the last `encode` copied the octree's counts out with its frame, for
    /// [`Resident::check_encoded`] to read once the caller has submitted it.
    encoded_counts: bool,
}

impl<'c> Resident<'c> {
    /// The pipelines with GPU-resident frames.
    pub const PIPELINES: [Pipeline; 4] = [
        Pipeline::VctDense,
        Pipeline::VctSvo,
        Pipeline::Lrsm,
        Pipeline::Cprc,
    ];

    /// A renderer of `pipeline`'s frames on `ctx`; refused for a pipeline without resident frames
    /// ([`Resident::PIPELINES`]). It draws a scene's `render` settings as they are: the scene's
    /// quality preset (`scene.render.quality`, `balanced` by default) is applied by
    /// [`crate::quality::resolved`], as `vxgi render` does, before the scene is handed to it.
    ///
    /// ```no_run
    /// # fn main() -> anyhow::Result<()> {
    /// use vxgi::{kernels::cone_trace::ConeSettings, render::Pipeline, resident::Resident};
    /// let ctx = vxgi::harness::GpuContext::new()?;
    /// let scene = vxgi::scene::Scene::cornell_box();
    /// let (scene, _) = vxgi::quality::resolved(&scene, Pipeline::Lrsm).map_err(anyhow::Error::msg)?;
    /// let frame = Resident::new(&ctx, Pipeline::Lrsm)?.render(&scene, &ConeSettings::from(&scene.render))?;
    /// println!("{} x {}", frame.combined.width, frame.combined.height);
    /// # Ok(())
    /// # }
    /// ```
    pub fn new(ctx: &'c GpuContext, pipeline: Pipeline) -> Result<Self> {
        anyhow::ensure!(
            Self::PIPELINES.contains(&pipeline),
            "{} has no GPU-resident frames (those are {})",
            pipeline.name(),
            Self::PIPELINES.map(|p| p.name()).join(", ")
        );
        Ok(Self {
            ctx,
            pipeline,
            built: None,
            caches: None,
            rebuilt: None,
            kept_volume: false,
            timed: true,
            svo: crate::render::VctSvo::new(),
            outgrown: None,
            encoded_counts: false,
        })
    }

    /// The pipeline whose frames this renderer draws.
    pub fn pipeline(&self) -> Pipeline {
        self.pipeline
    }

    /// What the last frame's volume holds (vct-svo: the octree's bytes; lrsm: its structures'
    /// bytes; cprc: its caches); `None` for vct-dense.
    pub fn memory(&self) -> Option<VolumeMemory> {
        if let Some(c) = self.caches {
            return Some(VolumeMemory::Caches(c));
        }
        self.built.as_ref().and_then(|b| b.memory.clone())
    }

    /// The bytes the last frame's chain holds on the GPU (buffers and textures; `None` before the
    /// first frame).
    pub fn gpu_bytes(&self) -> Option<u64> {
        self.built.as_ref().map(|b| b.prepared.gpu_bytes())
    }

    /// The last frame's chain's GPU bytes by declared stage, in chain order: each resource counted
    /// to the stage whose passes write it first (or whose passes a GPU copy into it follows), what
    /// no pass writes (the scene, parameters, and structures built outside the chain such as
    /// vct-svo's octree) as `uploaded`, first. The bytes add up to [`Resident::gpu_bytes`]; `None`
    /// before the first frame.
    pub fn memory_by_stage(&self) -> Option<&[(&'static str, u64)]> {
        self.built.as_ref().map(|b| b.stage_memory.as_slice())
    }

    /// Whether the last frame's chain was timed pass by pass by timestamp queries: a chain with more
    /// passes than a query set holds, or an adapter without timestamps, is timed by the wall clock
    /// around its submission, and its stages report no time.
    pub fn timed(&self) -> bool {
        self.timed
    }

    /// One frame (supersampling and bright lights as every pipeline's, see `render::supersampled`).
    pub fn render(&mut self, scene: &Scene, cones: &ConeSettings) -> Result<Rendered> {
        self.check(scene)?;
        crate::render::supersampled(scene, self.pipeline, |s| {
            Ok((self.render_samples(s, cones)?, ()))
        })
        .map(|(r, ())| r)
    }

    /// What every frame must pass before anything is recorded: the scene within the device's limits.
    fn check(&self, scene: &Scene) -> Result<()> {
        crate::limits::check(scene, self.pipeline, &self.ctx.limits()).map_err(anyhow::Error::msg)
    }

    /// One frame, submitted and waited for, with `draw`'s passes recorded after the frame's in the
    /// same encoder and submission: the images stay on the GPU (`draw` reads them); only the plan's
    /// small outputs and the timestamps are read back. The camera's pixels as they are, as
    /// [`Resident::encode`]'s.
    pub fn present(
        &mut self,
        scene: &Scene,
        cones: &ConeSettings,
        draw: Draw<'_>,
    ) -> Result<FrameReport> {
        self.check_pixels(scene)?;
        let frame = self.submitted(scene, cones, false, Some(draw));
        if frame.is_err() {
            // As render's: a frame that failed part way leaves nothing the next one would trust.
            self.built = None;
        }
        frame.map(|(_, report)| report)
    }

    /// After the caller has submitted the encoder of the last [`Resident::encode`] (or
    /// [`Resident::encode_with_gbuffer`]): whether that frame fit vct-svo's octree room. An error
    /// names what outgrew it; that frame's indirect light and AO are then incomplete, and the next
    /// `encode` builds the chain again, sized from the scene it is given. Ok for every other
    /// pipeline and chain, which have no room to outgrow. Reads a few words back; waits for the
    /// submission.
    pub fn check_encoded(&mut self) -> Result<()> {
        if !std::mem::take(&mut self.encoded_counts) {
            return Ok(());
        }
        let Some(b) = self.built.as_ref() else {
            return Ok(());
        };
        let Some(room) = b.octree_room.as_ref() else {
            return Ok(());
        };
        let (out, _) = b.prepared.finish_read(&b.counts, 0)?;
        if let Err(e) = room.check_read(&out) {
            self.built = None;
            anyhow::bail!(
                "the frame encoded last outgrew vct-svo's octree room ({e}): its indirect light is \
                 incomplete; the next encode builds the chain again, sized from its scene"
            );
        }
        Ok(())
    }

    /// [`Resident::check`], and a scene whose pixels are the camera's: what `encode` and `present`
    /// draw (supersampling and the exposure of very bright lights are [`Resident::render`]'s).
    fn check_pixels(&self, scene: &Scene) -> Result<()> {
        self.check(scene)?;
        anyhow::ensure!(
            scene.render.supersample == 1 && crate::render::exposure_for(scene, self.pipeline) == 0,
            "encode and present draw the camera's pixels: supersample = 1, light intensities up to {} and for vct-svo a typical radiance of at least {} (render() does the rest: `render::exposure_for`)",
            crate::render::EXPOSURE_LIMIT,
            crate::render::DIM_LIMIT
        );
        Ok(())
    }

    /// Record the frame for `scene` into the caller's `encoder`; the caller submits it. The images
    /// stay on the GPU in the returned buffers. The camera's pixels as they are: `supersample` and
    /// the exposure of very bright lights are [`Resident::render`]'s, refused here. Submit the
    /// encoder before the next `encode`: the frame's camera and lights are written with
    /// `queue.write_buffer`, which takes effect at the next submission. vct-svo, whose chain builds
    /// its octree in room sized at load: whether a frame outgrew it (moving instances can) is
    /// known only once the frame has run, so `encode` records a copy of the octree's counts (a
    /// few words) and [`Resident::check_encoded`], called after the caller's submission, reads
    /// them; [`Resident::render`] and [`Resident::present`] check by themselves.
    pub fn encode(
        &mut self,
        scene: &Scene,
        cones: &ConeSettings,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<FrameBuffers> {
        self.encode_frame(scene, cones, None, encoder)
    }

    /// [`Resident::encode`] with the caller's G-buffer (e.g. from its raster pass) in place of the
    /// chain's ray-cast `gbuffer` stage: copied into the chain's G-buffer on the GPU in `encoder`,
    /// then direct light, the tile list and the cone pass read it. Everything else (the camera of
    /// `scene`, the lights, the reuse rules) as `encode`.
    pub fn encode_with_gbuffer(
        &mut self,
        scene: &Scene,
        cones: &ConeSettings,
        gbuffer: &GBuffer,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<FrameBuffers> {
        self.encode_frame(scene, cones, Some(gbuffer), encoder)
    }

    fn encode_frame(
        &mut self,
        scene: &Scene,
        cones: &ConeSettings,
        gbuffer: Option<&GBuffer>,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<FrameBuffers> {
        self.check_pixels(scene)?;
        if let Some(g) = gbuffer {
            g.check(scene)?;
        }
        if let Err(e) = self.record(scene, cones, gbuffer, encoder) {
            // Nothing half-recorded is reused: the next frame builds the chain again.
            self.built = None;
            return Err(e);
        }
        let b = self.built.as_ref().expect("recorded");
        self.encoded_counts = b.octree_room.is_some();
        if self.encoded_counts {
            b.prepared.encode_read(encoder, &b.counts, 0..0);
        }
        let buffer = |n: &str| b.prepared.buffer(n).cloned().expect("the chain's output");
        Ok(FrameBuffers {
            direct: buffer(b.direct),
            indirect: buffer("indirect"),
            ao: buffer("ao"),
        })
    }

    /// Build (or keep) the chain for `scene` and record its frame into `encoder` (with `gbuffer`,
    /// the caller's G-buffer copied in place of the chain's): (reused, re-lit, the range of passes
    /// the frame spans; with the caller's G-buffer the camera's G-buffer pass in it is not recorded).
    fn record(
        &mut self,
        scene: &Scene,
        cones: &ConeSettings,
        gbuffer: Option<&GBuffer>,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<(bool, bool, std::ops::Range<usize>)> {
        crate::limits::check_ordered_instances(scene, cones.depth_ordered_blend)
            .map_err(anyhow::Error::msg)?;
        // With instances: the scene as the ray caster binds it this frame (where they stand).
        let data = (!scene.instances.list.is_empty()).then(|| SceneData::new(scene));
        let vox = revoxelized(self.pipeline, scene)?;
        let key = Key::of(self.pipeline, scene, cones, data.as_ref(), vox.as_ref());
        let reuse = self.built.as_ref().is_some_and(|b| b.key == key);
        self.rebuilt = self
            .built
            .as_ref()
            .filter(|_| !reuse)
            .map(|b| b.key.change_to(&key));
        self.kept_volume = false;
        if !reuse {
            // A new image size or new settings keep the old chain until the new one has taken its
            // volume where it can; any other change frees it first.
            let old = self.built.take().filter(|b| b.key.may_keep_volume(&key));
            let (built, took) = self.build(scene, cones, key, old.as_ref())?;
            // A vct-svo chain over an octree the staged passes lit has no volume passes: its octree
            // is kept where they found it built for this scene already.
            self.kept_volume = took && built.build_stages.is_empty();
            drop(old);
            self.built = Some(built);
        }
        let b = self.built.as_mut().expect("built above");
        // Moved instances re-light the kept hierarchies where they stand now, as moved lights do.
        let moved = reuse && b.mesh != scene.mesh;
        let relit = reuse && (b.lights != scene.lights || moved);
        b.lights = scene.lights.clone();
        b.mesh = scene.mesh.clone();
        if let (true, Some(d)) = (moved, &data) {
            b.eps = d.frame.eye[3];
            b.bounds = d.bounds;
        }
        let b = &*b;
        let p = &b.prepared;
        if reuse {
            // The camera (and where they moved, the lights): the inputs that differ from the last
            // frame.
            let frame = crate::trace::camera_frame(scene, b.eps);
            p.write_buffer("frame", bytemuck::bytes_of(&frame))?;
            // As fresh: the tile list is appended to, the cone pass writes the listed tiles only.
            p.encode_clear(encoder, &b.cleared)?;
            let restore: Vec<_> = b
                .restored
                .iter()
                .map(|(src, dst)| (src.as_str(), dst.as_str(), 0))
                .collect();
            p.encode_copies(encoder, &restore)?;
            if relit {
                for (name, bytes) in light_inputs(self.pipeline, b, scene)? {
                    p.write_buffer(&name, &bytes)?;
                }
                if let Some((zero, first)) = &b.relight_resets {
                    encode_resets(p, encoder, zero, first)?;
                }
            }
            if let (true, Some(d), Some(frames)) = (moved, &data, &b.hierarchies) {
                for (name, bytes) in placed_inputs(d, scene, cones, frames, b.room.as_ref())? {
                    p.write_buffer(&name, &bytes)?;
                }
            }
            if let (true, Some(d), Some((zero, first))) = (moved, &data, &b.revoxelize) {
                // The volume as a fresh chain holds it, then the moved scene voxelized into it.
                encode_resets(p, encoder, zero, first)?;
                let mesh = &vox.as_ref().expect("lrsm with instances prepares it").0;
                for (name, bytes) in voxelize_inputs(d, mesh) {
                    p.write_buffer(&name, &bytes)?;
                }
            }
        }
        // The volume (a new chain that did not take the last one's), or what the lights feed over
        // the kept voxels (moved lights).
        let first = match (reuse, relit) {
            (false, _) if self.kept_volume => None,
            (false, _) => Some(0),
            (true, true) if moved && b.revoxelize.is_some() => Some(0),
            (true, true) => Some(b.relight),
            (true, false) => None,
        };
        if let Some(first) = first {
            encode_range(p, encoder, first..b.per_frame.start, &b.copies)?;
        }
        if self.pipeline == Pipeline::Cprc && scene.render.cache_reuse {
            // Kept caches carry their texels where the volume is the last frame's: a reused chain
            // that re-lit or moved nothing (its volume passes not encoded this frame).
            let params = crate::pipeline::cprc::reuse_params(scene, reuse && !relit);
            p.write_buffer("reuse_params", bytemuck::bytes_of(&params))?;
        }
        let camera = match gbuffer {
            None => b.per_frame.clone(),
            Some(g) => {
                g.copy_into(p, encoder)?;
                b.gbuffer_end..b.per_frame.end
            }
        };
        encode_range(p, encoder, camera, &b.copies)?;
        Ok((
            reuse,
            relit,
            first.unwrap_or(b.per_frame.start)..b.per_frame.end,
        ))
    }

    fn render_samples(&mut self, scene: &Scene, cones: &ConeSettings) -> Result<Rendered> {
        let frame = self.frame(scene, cones);
        if frame.is_err() {
            // A frame that failed part way leaves nothing the next one would trust: rebuild.
            self.built = None;
        }
        frame
    }

    fn frame(&mut self, scene: &Scene, cones: &ConeSettings) -> Result<Rendered> {
        let (mut out, mut report) = self.submitted(scene, cones, true, None)?;
        if let Some(why) = self.outgrown.take() {
            // The frame's octree did not fit the chain's room: the frame again, on a chain sized
            // for it.
            (out, report) = self.submitted(scene, cones, true, None)?;
            // A chain sized from this very frame holds it; were it not so, say so rather than
            // return the frame.
            if let Some(again) = self.outgrown.take() {
                anyhow::bail!("vct-svo's octree outgrew a chain sized for its frame: {again}");
            }
            report.plan = report.plan.with_note(
                "sparse_voxel_octree",
                &format!("the last chain's room was too small ({why}): built again, sized from this frame"),
            );
        }
        let bytes = |n: &str| &out[n].buffer().expect("a buffer").bytes;
        let (w, h) = (scene.camera.width, scene.camera.height);
        let b = self.built.as_ref().expect("recorded");
        let frame = Rendered::assemble(
            image_of(w, h, bytes(b.direct)),
            image_of(w, h, bytes("indirect")),
            image_of(w, h, bytes("ao")),
            report.stages,
            report.plan,
        );
        Ok(Rendered {
            cone_tiles: report.cone_tiles,
            ..frame
        })
    }

    /// Record the frame (then `draw`'s passes over its images), submit it once and wait: the
    /// outputs read back (the images where `images`, else only the small ones the plan reads) and
    /// what the frame ran.
    fn submitted(
        &mut self,
        scene: &Scene,
        cones: &ConeSettings,
        images: bool,
        draw: Option<Draw<'_>>,
    ) -> Result<(crate::harness::Resources, FrameReport)> {
        // This frame reads its counts itself: nothing is left for check_encoded.
        self.encoded_counts = false;
        let name = self.pipeline.name();
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(name) });
        let (reuse, relit, timed) = self.record(scene, cones, None, &mut encoder)?;
        let b = self.built.as_ref().expect("recorded");
        let p = &b.prepared;
        if let Some(draw) = draw {
            let buffer = |n: &str| b.prepared.buffer(n).cloned().context("the chain's output");
            let frame = FrameBuffers {
                direct: buffer(b.direct)?,
                indirect: buffer("indirect")?,
                ao: buffer("ao")?,
            };
            draw(&mut encoder, &frame)?;
        }
        let reads = if images { &b.reads } else { &b.counts };
        p.encode_read(&mut encoder, reads, timed.clone());
        p.submit(encoder).with_context(|| format!("{name} frame"))?;
        let (out, pass_ns) = p.finish_read(reads, timed.len())?;
        let bytes = |n: &str| &out[n].buffer().expect("a buffer").bytes;
        // vct-svo whose chain builds the octree's structure: whether this frame's fit its room.
        let outgrown = b
            .octree_room
            .as_ref()
            .and_then(|room| room.check_read(&out).err());
        // Per stage: the GPU time of its passes (timestamps), where it ran this frame; a frame that
        // built the chain first the stages that built it outside the chain.
        let mut stages: Vec<(&'static str, f64)> = if reuse {
            Vec::new()
        } else {
            b.build_stages.clone()
        };
        // A chain with more passes than a query set holds is not timed: its stages report nothing
        // rather than zero.
        self.timed = !pass_ns.is_empty() || timed.is_empty();
        let chain_stages = if self.timed { &b.stages[..] } else { &[] };
        for (name, r) in chain_stages {
            // Stages outside this frame's passes, and those without passes (cprc's chain keeps
            // vct-dense's empty cone stages), report no time.
            if r.is_empty() || r.start < timed.start || r.end > timed.end {
                continue;
            }
            let ns: f64 = pass_ns
                .get(r.start - timed.start..r.end - timed.start)
                .map_or(0.0, |v| v.iter().sum());
            match stages.iter_mut().find(|(n, _)| n == name) {
                Some((_, s)) => *s += ns * 1e-9,
                None => stages.push((name, ns * 1e-9)),
            }
        }
        let cached = (reuse && !relit) || self.kept_volume;
        let mut plan = match self.pipeline {
            Pipeline::Cprc => {
                let a = bytemuck::cast_slice::<u8, u32>(bytes("cache_args"));
                self.caches = Some(crate::cprc::CprcStats {
                    caches: a[0] as usize,
                    dropped: a[1] as usize,
                    kept: a[2] as usize,
                    // The reuse_params `record` wrote for this frame.
                    carried: scene.render.cache_reuse
                        && crate::pipeline::cprc::reuse_params(scene, reuse && !relit).carry != 0,
                    coverage: None,
                });
                let mut plan = Pipeline::Cprc.plan(scene, cones, cached);
                if let Some(room) = b.room {
                    plan = plan.with_note(
                        "cache_creation",
                        &format!(
                            "{} caches this frame{}, in buffers for {} (indirect dispatch from the GPU's count{})",
                            a[0],
                            if scene.render.cache_reuse {
                                let carried = if self.caches.is_some_and(|c| c.carried) {
                                    ", their texels carried, not traced"
                                } else {
                                    ""
                                };
                                format!(" ({} kept from the last frame{carried})", a[2])
                            } else {
                                String::new()
                            },
                            room.capacity,
                            if a[1] > 0 {
                                format!("; {} clusters past the capacity got none", a[1])
                            } else {
                                String::new()
                            }
                        ),
                    );
                }
                plan
            }
            // The frame whose chain builds the octree's structure itself: its room sized at load.
            Pipeline::VctSvo if !reuse && b.octree_room.is_some() => {
                Pipeline::VctSvo.plan(scene, cones, cached).with_note(
                    "sparse_voxel_octree",
                    &format!(
                        "the chain's room sized at load from the scene's voxels and octree structure (counted on the host): {}",
                        b.octree_room
                            .as_ref()
                            .map_or(String::new(), |r| r.describe())
                    ),
                )
            }
            // The frame that built the octree: the build's own notes (static part kept, its
            // subdivisions replayed).
            Pipeline::VctSvo if !reuse && !b.build_stages.is_empty() => self
                .svo
                .built_plan()
                .cloned()
                .unwrap_or_else(|| Pipeline::VctSvo.plan(scene, cones, cached)),
            p => p.plan(scene, cones, cached),
        };
        match &b.hierarchies {
            // Each distinct mesh voxelized by the chain's first frame, every hierarchy re-lit where
            // it stands in every frame that ran the volume.
            Some(h) if !cached => {
                let voxelized = if reuse {
                    0
                } else {
                    let first =
                        crate::pipeline::voxelized_by(&crate::render::hierarchy_parts(scene).1);
                    first.iter().enumerate().filter(|&(k, &d)| k == d).count()
                };
                plan = plan.with_hierarchies(h.len(), voxelized);
            }
            // lrsm's and vct-svo's moved instances: the whole volume again, in the kept chain.
            _ if reuse && timed.start == 0 => {
                plan = plan.with_note(
                    "voxelize",
                    "again: the instances moved (the chain's resources kept)",
                );
            }
            // The voxels are kept; what the lights feed is redone.
            _ if relit => plan = plan.with_voxels_kept(),
            _ => {}
        }
        match &self.rebuilt {
            Some(why) if self.kept_volume => {
                plan = plan.with_note(
                    "voxelize",
                    &format!(
                        "the frame's GPU resources made again ({why}); the volume kept from the last frame's chain (its buffers bound by the new one), not computed again"
                    ),
                );
            }
            Some(why) => {
                plan = plan.with_note(
                    "voxelize",
                    &format!("every GPU resource of the frame made again: {why}"),
                );
            }
            None => {}
        }
        if let Some(e) = &outgrown {
            plan = plan.with_note(
                "sparse_voxel_octree",
                &format!("{e}: the chain is built again, sized from this frame"),
            );
            self.built = None;
        }
        self.outgrown = outgrown.map(|e| e.to_string());
        let cone_tiles = out.get("tile_list").map(|t| {
            crate::render::cone_tiles_of(bytemuck::cast_slice(&t.buffer().expect("a buffer").bytes))
        });
        Ok((
            out,
            FrameReport {
                stages,
                plan,
                cone_tiles,
            },
        ))
    }

    /// Build the chain for `scene`, binding `old`'s volume buffers instead of new ones where
    /// [`volume_of`] says they hold what this chain's volume passes would compute: (the chain,
    /// whether it took them).
    fn build(
        &mut self,
        scene: &Scene,
        cones: &ConeSettings,
        key: Key,
        old: Option<&Built>,
    ) -> Result<(Built<'c>, bool)> {
        let data = SceneData::new(scene);
        let mut build_stages = Vec::new();
        let mut room = None;
        let mut hierarchies = None;
        let mut octree_room = None;
        let instanced = !scene.instances.list.is_empty();
        let (mut chain, memory, direct): (Chain, _, _) = match self.pipeline {
            Pipeline::Cprc => {
                let (chain, r, frames) =
                    crate::pipeline::cprc_chain(self.ctx, scene, &data, cones)?;
                room = Some(r);
                hierarchies = frames;
                (chain, None, "radiance")
            }
            Pipeline::Lrsm => {
                let (chain, memory) = crate::pipeline::lrsm_chain(self.ctx, scene, &data, cones)?;
                // With shadow cones the gather's shadow pass writes the direct light.
                let soft = scene.render.shadow_cone_angle > 0.0;
                let direct = if soft { "soft_direct" } else { "radiance" };
                (chain, Some(VolumeMemory::Lrsm(memory)), direct)
            }
            // The whole octree in the chain, in room sized at load (moved lights and instances
            // re-run it from their first stage).
            Pipeline::VctSvo if crate::pipeline::builds_in_chain(scene) => {
                let (chain, room) =
                    crate::pipeline::svo_chain(self.ctx, scene, &data, cones, None)?;
                let (room, memory) = room.context("vct-svo's chain sizes its room")?;
                octree_room = Some(room);
                (chain, Some(VolumeMemory::Octree(memory)), "radiance")
            }
            Pipeline::VctSvo => {
                // The octree's structure by the staged passes (their host steps run once, here);
                // the chain lights it where `lights_in_chain` (moved lights re-run that), else
                // binds the staged octree and records only the camera's stages over it (moved
                // lights rebuild: the key holds them). An octree already built for this scene is
                // uploaded again, not built.
                let (volume, built) = self.svo.volume(self.ctx, scene, cones)?;
                build_stages = built;
                let (chain, _) =
                    crate::pipeline::svo_chain(self.ctx, scene, &data, cones, Some(volume))?;
                let memory = VolumeMemory::Octree(volume.memory());
                (chain, Some(memory), "radiance")
            }
            Pipeline::VctDense if instanced => {
                let (chain, frames) =
                    crate::pipeline::instanced_dense_chain(self.ctx, scene, &data, cones)?;
                hierarchies = Some(frames);
                (chain, None, "radiance")
            }
            Pipeline::VctDense => {
                // The G-buffer the cone pass binds, computed in the chain (zeroed here).
                let gb = crate::kernels::gbuffer::case_for(&data, "render".into(), 0).resources;
                let levels = key.volume.levels;
                let cone_pass = Some((&gb, cones, levels));
                let chain = crate::pipeline::dense_chain(self.ctx, scene, &data, cone_pass, true)?;
                (chain, None, "radiance")
            }
        };
        let name = self.pipeline.name();
        let decl = self.pipeline.decl();
        decl.check_chain(chain.stages.iter().map(|s| (s.stage, s.kernel)))?;
        let mut stages = Vec::new();
        let mut first = 0;
        for s in &chain.stages {
            stages.push((s.stage, first..first + s.passes.len()));
            first += s.passes.len();
        }
        // The declaration's reuse classes say where the passes a reused frame re-runs start (the
        // chain records them in that order: `check_chain`).
        let start_of = |reuse: Reuse| {
            stages
                .iter()
                .find(|(n, _)| decl.stage(n).is_some_and(|s| s.reuse == reuse))
                .map(|(_, r)| r.start)
        };
        let gbuffer = start_of(Reuse::Camera)
            .with_context(|| format!("{name}'s chain holds none of the camera's stages"))?;
        let gbuffer_end = gbuffer
            + chain
                .stages
                .iter()
                .find(|s| s.stage == crate::kernels::gbuffer::DECL.name)
                .map_or(0, |s| s.passes.len());
        // Moved lights re-run the volume from its first stage the lights feed (a vct-svo chain over an
        // octree the staged passes lit has none: its octree, built outside the chain, is rebuilt).
        let relight = start_of(Reuse::Lights).unwrap_or(gbuffer);
        // What the camera's passes also write starts each reused frame as a fresh chain has it
        // (cleared or restored), so a new chain keeps its own.
        let per_frame = written(&chain, gbuffer..usize::MAX);
        let mut volume = written(&chain, 0..gbuffer);
        for c in &chain.copies {
            if c.after <= gbuffer && !volume.contains(&c.dst) {
                volume.push(c.dst.clone());
            }
        }
        volume.retain(|n| !per_frame.contains(n));
        let volume_inputs = passes_fingerprint(&chain, gbuffer);
        let adopted = old.and_then(|o| volume_of(o, scene, &chain, &volume, volume_inputs));
        let took = adopted.is_some();
        let adopted = adopted.unwrap_or_default();
        let (_, restored) = written_in(&mut chain, gbuffer..usize::MAX);
        let revoxelize =
            revoxelizes(self.pipeline, scene).then(|| written_in(&mut chain, 0..gbuffer));
        // vct-svo's octree lit in the chain: its value passes add into the kept structure's
        // buffers, which a moved light's frame first resets to what the structure left.
        let relight_resets = (self.pipeline == Pipeline::VctSvo && relight < gbuffer)
            .then(|| written_in(&mut chain, relight..gbuffer));
        let prepared = crate::harness::prepare_chain_adopting(
            self.ctx,
            &chain.harness_stages(),
            &chain.resources,
            &adopted,
        )
        .with_context(|| format!("{name} chain"))?;
        let mut outputs = vec![direct, "indirect", "ao"];
        let room_reads = octree_room
            .as_ref()
            .map_or(&[][..], |_| &crate::pipeline::OctreeRoom::READ[..]);
        for &extra in ["tile_list", "cache_args"].iter().chain(room_reads) {
            if chain.resources.contains_key(extra) {
                outputs.push(extra);
            }
        }
        let stage_memory = stage_memory(&chain, &stages, &prepared);
        let reads = prepared.readback_set(&outputs)?;
        let counts = prepared.readback_set(&outputs[3..])?;
        // Appended to (tile_list), written where listed (indirect, ao, irradiance, soft_direct), or
        // written per cache (cprc's tile_ranges): zero at the start of every frame.
        let cleared = [
            "tile_list",
            "indirect",
            "ao",
            "irradiance",
            "soft_direct",
            "tile_ranges",
        ]
        .into_iter()
        .filter(|n| chain.resources.contains_key(*n))
        .collect();
        let built = Built {
            key,
            lights: scene.lights.clone(),
            mesh: scene.mesh.clone(),
            hierarchies,
            revoxelize,
            octree_room,
            relight_resets,
            relight,
            volume,
            volume_inputs,
            eps: data.frame.eye[3],
            bounds: data.bounds,
            voxels: chain.frame,
            stages,
            per_frame: gbuffer..first,
            gbuffer_end,
            copies: chain.copies,
            cleared,
            restored,
            room,
            direct,
            build_stages,
            memory,
            stage_memory,
            prepared,
            reads,
            counts,
        };
        Ok((built, took))
    }
}

/// `old`'s volume buffers, by name, for a new chain (`chain`, its volume's buffers `volume` and
/// their [`passes_fingerprint`] `inputs`) built for `scene` at another image size or with other
/// settings: only where the lights and the mesh are the ones `old`'s volume holds, the volume's
/// passes are the same passes over the same inputs in both (a setting the volume reads changes
/// them) and every buffer they write has its size in both (a buffer sized by the image there would
/// be the volume's passes' to write). The new chain binds them: nothing is computed or copied again.
fn volume_of(
    old: &Built,
    scene: &Scene,
    chain: &Chain,
    volume: &[String],
    inputs: u64,
) -> Option<std::collections::BTreeMap<String, wgpu::Buffer>> {
    if old.lights != scene.lights
        || old.mesh != scene.mesh
        || old.volume != volume
        || old.volume_inputs != inputs
    {
        return None;
    }
    volume
        .iter()
        .map(|name| {
            let buffer = old.prepared.buffer(name)?;
            let Some(HostResource::Buffer(b)) = chain.resources.get(name) else {
                return None;
            };
            (buffer.size() == b.bytes.len() as u64).then(|| (name.clone(), buffer.clone()))
        })
        .collect()
}

/// The buffers a re-run of passes clears, and those it restores from a copy: (copy, buffer).
type Resets = (Vec<String>, Vec<(String, String)>);

/// What a frame that re-runs the passes `range` of a reused chain must reset first, so that they see
/// what they saw in the fresh chain: the buffers they write (writable storage bindings) that start as
/// zeros (`.0`, cleared) and those that do not (`.1`, restored from a copy of their first contents
/// added to the chain here: e.g. cprc's sort values 0..n, which the sort's ping-pong overwrites, and
/// its "no cluster" marks, which clusters overwrite only where they lie; (copy, buffer) pairs).
fn written_in(chain: &mut Chain, range: std::ops::Range<usize>) -> Resets {
    let (mut zero, mut first): (Vec<String>, Vec<(String, String)>) = (Vec::new(), Vec::new());
    for name in written(chain, range) {
        let Some(HostResource::Buffer(b)) = chain.resources.get(&name) else {
            continue;
        };
        if b.bytes.iter().any(|&x| x != 0) {
            first.push((format!("{name}@first"), name));
        } else {
            zero.push(name);
        }
    }
    for (copy, name) in &first {
        let contents = chain.resources[name].clone();
        chain.resources.insert(copy.clone(), contents);
    }
    (zero, first)
}

/// One line of [`Resident::memory_by_stage`]: the total, then each stage that holds any bytes.
pub fn memory_line(by_stage: &[(&str, u64)]) -> String {
    let mb = |b: u64| b as f64 / 1e6;
    let total: u64 = by_stage.iter().map(|(_, b)| b).sum();
    let parts: Vec<String> = by_stage
        .iter()
        .filter(|(_, b)| *b > 0)
        .map(|(s, b)| format!("{s} {:.1}", mb(*b)))
        .collect();
    format!(
        "GPU memory {:.1} MB by stage (MB): {}",
        mb(total),
        parts.join(", ")
    )
}

/// [`Resident::memory_by_stage`] of `chain` (its `stages`: (declared stage, passes) in chain
/// order) as `prepared` holds it. A restore copy `X@first` counts with `X`.
fn stage_memory(
    chain: &Chain,
    stages: &[(&'static str, std::ops::Range<usize>)],
    prepared: &crate::harness::Prepared,
) -> Vec<(&'static str, u64)> {
    let mut owner: std::collections::BTreeMap<String, &'static str> = Default::default();
    let mut out: Vec<(&'static str, u64)> = vec![("uploaded", 0)];
    for (stage, range) in stages {
        if !out.iter().any(|(s, _)| s == stage) {
            out.push((stage, 0));
        }
        for name in written(chain, range.clone()) {
            owner.entry(name).or_insert(stage);
        }
        for c in &chain.copies {
            if c.after > 0 && range.contains(&(c.after - 1)) {
                owner.entry(c.dst.clone()).or_insert(stage);
            }
        }
    }
    for name in chain.resources.keys() {
        let base = name.strip_suffix("@first").unwrap_or(name);
        let stage = owner.get(base).copied().unwrap_or("uploaded");
        let bytes = prepared.resource_bytes(name).unwrap_or(0);
        if let Some(e) = out.iter_mut().find(|(s, _)| *s == stage) {
            e.1 += bytes;
        }
    }
    out
}

/// The buffers the passes `range` of `chain` bind as writable storage, each once, in chain order.
fn written(chain: &Chain, range: std::ops::Range<usize>) -> Vec<String> {
    use crate::harness::{BindingKind, View};
    let mut out: Vec<String> = Vec::new();
    // Membership by hash: a chain of thousands of hierarchies writes tens of thousands of buffers.
    let mut seen: std::collections::HashSet<&str> = std::collections::HashSet::new();
    let mut at = 0;
    for st in &chain.stages {
        for pass in &st.passes {
            at += 1;
            if !range.contains(&(at - 1)) {
                continue;
            }
            for (binding, view) in &pass.bindings {
                let writable = st.shader.bindings.iter().any(|b| {
                    b.name == *binding
                        && matches!(
                            b.kind,
                            BindingKind::Storage {
                                read_only: false,
                                ..
                            }
                        )
                });
                let (View::Buffer(name) | View::BufferRange { name, .. }) = view else {
                    continue;
                };
                let buffer = matches!(chain.resources.get(name), Some(HostResource::Buffer(_)));
                if writable && buffer && seen.insert(name.as_str()) {
                    out.push(name.clone());
                }
            }
        }
    }
    out
}

/// The fields whose values differ between `a` and `b`, the pretty `Debug` texts (`{:#?}`) of two
/// values of one plain struct, as `name old -> new`, line by line.
fn debug_diff(a: &str, b: &str) -> Vec<String> {
    let (a, b): (Vec<&str>, Vec<&str>) = (a.lines().collect(), b.lines().collect());
    if a.len() != b.len() {
        return Vec::new();
    }
    a.iter()
        .zip(&b)
        .filter(|(x, y)| x != y)
        .filter_map(|(x, y)| {
            let (name, old) = x.trim().trim_end_matches(',').split_once(": ")?;
            let (_, new) = y.trim().trim_end_matches(',').split_once(": ")?;
            Some(format!("{name} {old} -> {new}"))
        })
        .collect()
}

/// A fingerprint of what the chain's passes `..end` compute from: each pass (its kernel, entry,
/// bindings and dispatch), the copies recorded among them, and the first contents of every
/// resource they bind or copy (all-zero contents by their length alone, so that large zeroed
/// accumulators cost nothing to hash). Two chains with equal fingerprints run the same dispatches
/// over the same inputs there: one may take the other's results instead of computing them again.
fn passes_fingerprint(chain: &Chain, end: usize) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    let mut bound: Vec<&str> = Vec::new();
    let mut at = 0;
    for st in &chain.stages {
        for pass in &st.passes {
            if at >= end {
                break;
            }
            at += 1;
            (st.kernel, &pass.entry, format!("{:?}", pass.workgroups)).hash(&mut h);
            for (binding, view) in &pass.bindings {
                (binding, format!("{view:?}")).hash(&mut h);
                bound.extend(view.resource());
            }
        }
    }
    for c in chain.copies.iter().filter(|c| c.after <= end) {
        (c.after, &c.src, &c.src_range, &c.dst, c.offset).hash(&mut h);
        bound.extend([c.src.as_str(), c.dst.as_str()]);
    }
    bound.sort_unstable();
    bound.dedup();
    let contents = |bytes: &[u8], h: &mut std::collections::hash_map::DefaultHasher| {
        // OR-folded in blocks: vectorised, unlike a short-circuiting scan.
        if bytes
            .chunks(1 << 16)
            .all(|c| c.iter().fold(0u8, |a, &b| a | b) == 0)
        {
            (0u8, bytes.len()).hash(h);
        } else {
            (1u8, bytes).hash(h);
        }
    };
    for name in bound {
        name.hash(&mut h);
        match chain.resources.get(name) {
            Some(HostResource::Buffer(b)) => {
                format!("{:?}", b.scalar).hash(&mut h);
                contents(&b.bytes, &mut h);
            }
            Some(HostResource::Texture(t)) => {
                format!("{:?} {:?} {:?}", t.format, t.dimension, t.size).hash(&mut h);
                for level in &t.levels {
                    contents(level, &mut h);
                }
            }
            None => 2u8.hash(&mut h),
        }
    }
    h.finish()
}

/// The buffers a frame whose instances moved rewrites: the scene's triangles and BVH (the ray caster's,
/// the same sizes: the key holds them), each hierarchy's placed voxel_light grid, the cone passes'
/// placements and their march parameters, and (cprc, `room`) cache_records' cone offset: the world
/// grid follows the scene's extent.
fn placed_inputs(
    data: &SceneData,
    scene: &Scene,
    cones: &ConeSettings,
    frames: &[crate::kernels::voxelize::VoxelFrame],
    room: Option<&crate::pipeline::CacheRoom>,
) -> Result<Vec<(String, Vec<u8>)>> {
    let at = crate::pipeline::placement(scene, frames)?;
    let cone = crate::kernels::cone_trace::cone_params(&at.world, cones);
    let mut out = vec![
        (
            "triangles".to_string(),
            bytemuck::cast_slice(&data.triangles).to_vec(),
        ),
        (
            "nodes".to_string(),
            bytemuck::cast_slice(&data.nodes).to_vec(),
        ),
        (
            "placed".to_string(),
            bytemuck::cast_slice(&at.placed).to_vec(),
        ),
        (
            "placed_cells".to_string(),
            bytemuck::cast_slice(&vxgi_cpu_mirror::cache_creation::placed_cells(&at.placed))
                .to_vec(),
        ),
        ("cone".to_string(), bytemuck::bytes_of(&cone).to_vec()),
    ];
    if let Some(room) = room {
        let records = vxgi_cpu_mirror::cache_records::RecordsParams {
            offset: cone.offset_voxels * cone.origin[3],
            ..room.records
        };
        out.push((
            "records_params".to_string(),
            bytemuck::bytes_of(&records).to_vec(),
        ));
    }
    for (k, g) in at.grids.iter().enumerate() {
        out.push((
            crate::pipeline::hierarchy_name("grid", k),
            bytemuck::bytes_of(g).to_vec(),
        ));
    }
    Ok(out)
}

/// The buffers a frame that re-voxelizes moved instances rewrites ([`revoxelizes`]): the mesh as it
/// stands, which the chain's triangle_setup puts on voxelize's lattice (the same grid and counts: the
/// key holds them), and the ray caster's triangles and BVH.
fn voxelize_inputs(
    data: &SceneData,
    mesh: &crate::kernels::triangle_setup::MeshInput,
) -> Vec<(String, Vec<u8>)> {
    // As triangle_setup's case writes them (an empty list's one zero element included).
    let io = mesh.io();
    let bytes = |b: crate::harness::HostBuffer| b.bytes;
    use crate::harness::bindings::Field;
    vec![
        (
            "setup_params".to_string(),
            bytes(io.setup_params.to_buffer()),
        ),
        (
            "mesh_positions".to_string(),
            bytes(io.mesh_positions.to_buffer()),
        ),
        (
            "mesh_normals".to_string(),
            bytes(io.mesh_normals.to_buffer()),
        ),
        ("mesh_uvs".to_string(), bytes(io.mesh_uvs.to_buffer())),
        (
            "mesh_triangles".to_string(),
            bytes(io.mesh_triangles.to_buffer()),
        ),
        (
            "triangles".to_string(),
            bytemuck::cast_slice(&data.triangles).to_vec(),
        ),
        (
            "nodes".to_string(),
            bytemuck::cast_slice(&data.nodes).to_vec(),
        ),
    ]
}

/// Whether `pipeline`'s chain voxelizes `scene` again where its instances moved (lrsm; vct-svo
/// where its chain lights the octree): the chain is kept, its volume re-run from voxelize.
fn revoxelizes(pipeline: Pipeline, scene: &Scene) -> bool {
    !scene.instances.list.is_empty()
        && match pipeline {
            Pipeline::Lrsm => true,
            Pipeline::VctSvo => crate::pipeline::lights_in_chain(scene),
            Pipeline::VctDense | Pipeline::Cprc => false,
        }
}

/// The mesh as triangle_setup reads it and the grid for `scene` as it stands, once per frame, where
/// the chain re-voxelizes moved instances ([`revoxelizes`]: its key holds the grid; a moved frame
/// uploads the mesh).
type Voxelized = (
    crate::kernels::triangle_setup::MeshInput,
    crate::kernels::voxelize::VoxelFrame,
);

fn revoxelized(pipeline: Pipeline, scene: &Scene) -> Result<Option<Voxelized>> {
    if !revoxelizes(pipeline, scene) {
        return Ok(None);
    }
    Ok(Some(crate::kernels::voxelize::mesh_input(
        scene,
        scene.render.voxels,
    )?))
}

/// The buffers a frame with moved lights rewrites: the lights, and lrsm's light views (each view's
/// G-buffer frame and projection, and the gather's list of them) and its lit cells' grid (their
/// radiance unit follows the lights), by the rule the chain was built with.
fn light_inputs(pipeline: Pipeline, b: &Built, scene: &Scene) -> Result<Vec<(String, Vec<u8>)>> {
    let lights = crate::trace::gpu_lights(scene);
    let mut out = vec![("lights".to_string(), bytemuck::cast_slice(&lights).to_vec())];
    if pipeline == Pipeline::Lrsm {
        let settings = LrsmSettings::from(&scene.render);
        let config = settings.partition();
        let views = crate::pipeline::lrsm_views(&lights, b.bounds, b.eps, &config)?;
        if settings.lit_cells && !views.is_empty() {
            let (grid, _) = settings.lit_grid(&b.voxels, &lights, b.bounds);
            out.push(("lit_grid".into(), bytemuck::bytes_of(&grid).to_vec()));
        }
        for (v, view) in views.iter().enumerate() {
            let (frame, projection) = crate::pipeline::light_view_names(v);
            out.push((frame, bytemuck::bytes_of(&view.frame).to_vec()));
            out.push((projection, bytemuck::bytes_of(&view.view).to_vec()));
        }
        let all: Vec<_> = views.iter().map(|v| v.view).collect();
        out.push(("views".into(), bytemuck::cast_slice(&all).to_vec()));
    }
    let map = scene.render.photon_map;
    if pipeline == Pipeline::VctSvo && map > 0 {
        use crate::kernels::svo_photons::params_for;
        let views = crate::lrsm::light_views(&lights, b.bounds, map, b.eps)?;
        for (v, view) in views.iter().enumerate() {
            let (frame, params) = crate::pipeline::photon_view_names(v);
            out.push((frame, bytemuck::bytes_of(&view.frame).to_vec()));
            let p = params_for(view, &b.voxels);
            out.push((params, bytemuck::bytes_of(&p).to_vec()));
        }
    }
    Ok(out)
}

/// Record [`written_in`]'s resets: `zero` cleared, each `(copy, buffer)` of `first` restored.
fn encode_resets(
    p: &Prepared,
    encoder: &mut wgpu::CommandEncoder,
    zero: &[String],
    first: &[(String, String)],
) -> Result<()> {
    let zero: Vec<&str> = zero.iter().map(String::as_str).collect();
    p.encode_clear(encoder, &zero)?;
    let first: Vec<_> = first
        .iter()
        .map(|(src, dst)| (src.as_str(), dst.as_str(), 0))
        .collect();
    p.encode_copies(encoder, &first)?;
    Ok(())
}

/// Record the passes `range` of `p` into `encoder` with the chain's copies that follow a pass in it
/// (a copy after pass `k` with `range.start < k <= range.end`), each where it falls.
fn encode_range(
    p: &Prepared,
    encoder: &mut wgpu::CommandEncoder,
    range: std::ops::Range<usize>,
    copies: &[ChainCopy],
) -> Result<()> {
    let mut at = range.start;
    for c in copies
        .iter()
        .filter(|c| c.after > range.start && c.after <= range.end)
    {
        p.encode_steps(encoder, at..c.after.max(at));
        at = at.max(c.after);
        p.encode_copy_range(encoder, &c.src, c.src_range.clone(), &c.dst, c.offset)?;
    }
    p.encode_steps(encoder, at..range.end);
    Ok(())
}
