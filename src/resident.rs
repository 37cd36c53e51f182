//! GPU-resident frame sequences: a renderer that keeps its frame's resources, compute pipelines and
//! bind groups on the GPU across frames and records each frame into one command encoder and one
//! submission, reading back only the images it returns.
//!
//! [`ResidentDense`] is vct-dense's: the same chain of kernels as [`crate::render::VctDense`]'s
//! first frame (voxelize, voxel_light, the surface-coverage mips, the G-buffer and direct light,
//! screen_tiles, the cone pass), prepared once by the harness (`prepare_chain`: every resource
//! checked against reflection and the device limits, then created and uploaded). A frame whose
//! geometry, materials, lights and settings equal the last one's (the camera may move) uploads the
//! camera (one `Frame`, 80 bytes), records the G-buffer, direct light, tile list and cone passes and
//! submits once; the volume stays where the first frame built it. A frame whose lights moved (their
//! number unchanged) also uploads them and re-runs voxel_light and the mips over the kept voxel grid.
//! Anything else rebuilds the whole chain (the plan says so). The same kernels on the same inputs as `VctDense`: the same images.
use crate::harness::{GpuContext, Prepared, ReadbackSet};
use crate::kernels::cone_trace::ConeSettings;
use crate::plan::FramePlan;
use crate::render::{image_of, PyramidKey, Rendered};
use crate::scene::{RenderSettings, Scene};
use crate::trace::SceneData;
use anyhow::{Context, Result};

/// What shapes the resident resources: a frame with other values rebuilds them. The lights are not
/// part of it (only their number): a frame whose lights moved re-lights the kept voxel grid.
#[derive(Clone, Debug, PartialEq)]
struct Key {
    volume: PyramidKey,
    lights: usize,
    render: RenderSettings,
    cones: String,
    size: (u32, u32),
}

impl Key {
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
        }
        if self.volume != next.volume && self.render.voxels == next.render.voxels {
            what.push("the geometry, materials or the mip levels the cones read changed".into());
        }
        if what.is_empty() {
            what.push("the render or cone settings changed".into());
        }
        what.join("; ")
    }

    fn of(scene: &Scene, cones: &ConeSettings) -> Self {
        Self {
            volume: PyramidKey::reading(scene, cones).unlit(),
            lights: scene.lights.len(),
            render: scene.render.clone(),
            // ConeSettings is plain data without PartialEq: its Debug text is its value.
            cones: format!("{cones:?}"),
            size: (scene.camera.width, scene.camera.height),
        }
    }
}

struct Built<'c> {
    key: Key,
    /// The lights the voxel grid is lit by now.
    lights: Vec<crate::scene::Light>,
    prepared: Prepared<'c>,
    reads: ReadbackSet,
    /// The ray epsilon of the scene's camera frames (`Frame::eye.w`, from the mesh's extent).
    eps: f32,
    /// (stage, its passes' range) in chain order.
    stages: Vec<(&'static str, std::ops::Range<usize>)>,
    /// Where the per-frame passes start (the G-buffer) and where the chain ends.
    per_frame: std::ops::Range<usize>,
    /// Where voxel_light's passes start: a frame with moved lights runs from there.
    relight: usize,
    copies: Vec<(String, String, u64)>,
    /// The per-frame outputs zeroed before a frame that reuses the chain (each is zero in a fresh one).
    cleared: Vec<&'static str>,
}

/// A frame's images on the GPU, as [`ResidentDense::encode`] leaves them: `vec4<f32>` per pixel, row
/// by row (rgb, then w): the direct and the indirect light reflected towards the camera (what
/// `vxgi render` writes as direct.exr and indirect.exr) and ambient occlusion. Valid until the next
/// frame is recorded.
pub struct FrameBuffers {
    pub direct: wgpu::Buffer,
    pub indirect: wgpu::Buffer,
    pub ao: wgpu::Buffer,
}

/// vct-dense over a sequence of frames with everything on the GPU (see the module doc).
pub struct ResidentDense<'c> {
    ctx: &'c GpuContext,
    built: Option<Built<'c>>,
    /// Why the last frame rebuilt the chain that an earlier frame had built, for its plan.
    rebuilt: Option<String>,
}

impl<'c> ResidentDense<'c> {
    pub fn new(ctx: &'c GpuContext) -> Self {
        Self {
            ctx,
            built: None,
            rebuilt: None,
        }
    }

    /// Whether `scene` is one this renderer draws: no instances (their hierarchies are
    /// [`crate::render::VctDense`]'s) and at least one light (voxel_light runs).
    pub fn serves(scene: &Scene) -> bool {
        scene.instances.list.is_empty() && !scene.lights.is_empty()
    }

    /// One frame (supersampling and bright lights as every pipeline's, see `render::supersampled`).
    pub fn render(&mut self, scene: &Scene, cones: &ConeSettings) -> Result<Rendered> {
        self.check(scene)?;
        crate::render::supersampled(scene, |s| Ok((self.render_samples(s, cones)?, ())))
            .map(|(r, ())| r)
    }

    /// What every frame must pass before anything is recorded: a scene this renderer draws, within
    /// the device's limits.
    fn check(&self, scene: &Scene) -> Result<()> {
        anyhow::ensure!(
            Self::serves(scene),
            "the resident vct-dense renderer draws scenes without instances and with lights"
        );
        crate::limits::check(scene, crate::render::Pipeline::VctDense, &self.ctx.limits())
            .map_err(anyhow::Error::msg)
    }

    /// Record the frame for `scene` into the caller's `encoder`; the caller submits it. The images
    /// stay on the GPU in the returned buffers. The camera's pixels as they are: `supersample` and
    /// the exposure of very bright lights are [`ResidentDense::render`]'s, refused here. Submit the
    /// encoder before the next `encode`: the frame's camera and lights are written with
    /// `queue.write_buffer`, which takes effect at the next submission.
    pub fn encode(
        &mut self,
        scene: &Scene,
        cones: &ConeSettings,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<FrameBuffers> {
        self.check(scene)?;
        anyhow::ensure!(
            scene.render.supersample == 1 && crate::render::exposure(scene) == 0,
            "encode draws the camera's pixels: supersample = 1 and light intensities up to {} (render() does the rest)",
            crate::render::EXPOSURE_LIMIT
        );
        if let Err(e) = self.record(scene, cones, encoder) {
            // Nothing half-recorded is reused: the next frame builds the chain again.
            self.built = None;
            return Err(e);
        }
        let p = &self.built.as_ref().expect("recorded").prepared;
        let buffer = |n: &str| p.buffer(n).cloned().expect("the chain's output");
        Ok(FrameBuffers {
            direct: buffer("radiance"),
            indirect: buffer("indirect"),
            ao: buffer("ao"),
        })
    }

    /// Build (or keep) the chain for `scene` and record its frame into `encoder`: (reused, re-lit,
    /// the passes recorded).
    fn record(
        &mut self,
        scene: &Scene,
        cones: &ConeSettings,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<(bool, bool, std::ops::Range<usize>)> {
        let key = Key::of(scene, cones);
        let reuse = self.built.as_ref().is_some_and(|b| b.key == key);
        self.rebuilt = self
            .built
            .as_ref()
            .filter(|_| !reuse)
            .map(|b| b.key.change_to(&key));
        if !reuse {
            self.built = None;
            self.built = Some(self.build(scene, cones, key)?);
        }
        let b = self.built.as_mut().expect("built above");
        let relit = reuse && b.lights != scene.lights;
        b.lights = scene.lights.clone();
        let b = &*b;
        let p = &b.prepared;
        let copies = crate::render::copy_refs(&b.copies);
        let timed = if reuse {
            // The camera (and where they moved, the lights): the inputs that differ from the last
            // frame.
            let frame = crate::trace::camera_frame(scene, b.eps);
            p.write_buffer("frame", bytemuck::bytes_of(&frame))?;
            // As fresh: the tile list is appended to, the cone pass writes the listed tiles only.
            p.encode_clear(encoder, &b.cleared)?;
            if relit {
                let lights = crate::trace::gpu_lights(scene);
                p.write_buffer("lights", bytemuck::cast_slice(&lights))?;
                // voxel_light and the mips over the kept voxel grid, into the kept pyramid.
                p.encode_steps(encoder, b.relight..b.per_frame.start);
                p.encode_copies(encoder, &copies)?;
            }
            p.encode_steps(encoder, b.per_frame.clone());
            if relit {
                b.relight..b.per_frame.end
            } else {
                b.per_frame.clone()
            }
        } else {
            p.encode_steps(encoder, 0..b.per_frame.start);
            p.encode_copies(encoder, &copies)?;
            p.encode_steps(encoder, b.per_frame.clone());
            0..b.per_frame.end
        };
        Ok((reuse, relit, timed))
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
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("vct-dense frame"),
            });
        let (reuse, relit, timed) = self.record(scene, cones, &mut encoder)?;
        let b = self.built.as_ref().expect("recorded");
        let p = &b.prepared;
        p.encode_read(&mut encoder, &b.reads, timed.clone());
        p.submit(encoder).context("vct-dense frame")?;
        let (out, pass_ns) = p.finish_read(&b.reads, timed.len())?;
        let bytes = |n: &str| &out[n].buffer().expect("a buffer").bytes;
        let (w, h) = (scene.camera.width, scene.camera.height);
        // Per stage: the GPU time of its passes (timestamps), where it ran this frame.
        let stages = b
            .stages
            .iter()
            .filter(|(_, r)| r.start >= timed.start && r.end <= timed.end)
            .map(|(name, r)| {
                let ns: f64 = pass_ns
                    .get(r.start - timed.start..r.end - timed.start)
                    .map_or(0.0, |v| v.iter().sum());
                (*name, ns * 1e-9)
            })
            .collect();
        let mut plan = FramePlan::vct_dense_after(scene, cones, reuse && !relit);
        if relit {
            // The voxel grid is kept; its light and mips are redone.
            plan = plan.with_voxels_kept();
        }
        if let Some(why) = &self.rebuilt {
            plan = plan.with_note(
                "voxelize",
                &format!("every GPU resource of the frame made again: {why}"),
            );
        }
        Ok(Rendered::assemble(
            image_of(w, h, bytes("radiance")),
            image_of(w, h, bytes("indirect")),
            image_of(w, h, bytes("ao")),
            stages,
            plan,
        )
        .with_cone_tiles(bytemuck::cast_slice(bytes("tile_list"))))
    }

    fn build(&self, scene: &Scene, cones: &ConeSettings, key: Key) -> Result<Built<'c>> {
        let data = SceneData::new(scene);
        let levels = key.volume.levels;
        // The G-buffer the cone pass binds, computed in the chain (zeroed here).
        let gb = crate::kernels::gbuffer::case_for(&data, "render".into(), 0).resources;
        let chain =
            crate::render::dense_chain(self.ctx, scene, &data, Some((&gb, cones, levels)), true)?;
        let prepared =
            crate::harness::prepare_chain(self.ctx, &chain.harness_stages(), &chain.resources)
                .context("vct-dense chain")?;
        let mut stages = Vec::new();
        let mut first = 0;
        for (_, name, passes) in &chain.stages {
            stages.push((*name, first..first + passes.len()));
            first += passes.len();
        }
        let gbuffer = stages
            .iter()
            .find(|(n, _)| *n == crate::kernels::gbuffer::DECL.name)
            .map(|(_, r)| r.start)
            .expect("the chain holds the G-buffer");
        let reads = prepared.readback_set(&["radiance", "indirect", "ao", "tile_list"])?;
        let cleared = ["tile_list", "indirect", "ao", "irradiance"]
            .into_iter()
            .filter(|n| chain.resources.contains_key(*n))
            .collect();
        let relight = stages
            .iter()
            .find(|(n, _)| *n == crate::kernels::voxel_light::DECL.name)
            .map(|(_, r)| r.start)
            .expect("the chain holds voxel_light");
        Ok(Built {
            key,
            lights: scene.lights.clone(),
            relight,
            eps: data.frame.eye[3],
            stages,
            per_frame: gbuffer..first,
            copies: chain.copies.clone(),
            cleared,
            prepared,
            reads,
        })
    }
}
