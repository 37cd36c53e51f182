//! Rendering a scene on the GPU: [`DirectRenderer`] records the `gbuffer` and `direct_light` kernels
//! into a caller's encoder, writing into caller-owned buffers (the API for lifting these kernels into
//! another renderer); [`render`] is the convenience path the CLI uses (own context, read back, images).
//!
//! Cone-traced indirect light and AO are not computed yet (issue 7): [`Rendered`] says so.
use crate::images::RgbImage;
use crate::kernels::{direct_light, gbuffer};
use crate::scene::Scene;
use crate::trace::SceneData;
use anyhow::{Context, Result};
use wgpu::util::DeviceExt;

/// G-buffer and radiance buffers sized for a frame (row-major pixels), owned by whoever renders.
pub struct FrameTargets {
    /// vec4<f32> per pixel: position and distance (w = -1: nothing hit).
    pub gb_position: wgpu::Buffer,
    /// vec4<f32> per pixel: shading normal and side (1 front, -1 back, 0 none).
    pub gb_normal: wgpu::Buffer,
    /// u32 per pixel: triangle index or u32::MAX.
    pub gb_triangle: wgpu::Buffer,
    /// vec4<f32> per pixel: direct radiance (rgb, 0).
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
            radiance: buf("radiance", n * 16),
        }
    }
}

/// The scene uploaded once and both pipelines; `encode` records a frame.
pub struct DirectRenderer {
    gbuffer: wgpu::ComputePipeline,
    direct: wgpu::ComputePipeline,
    scene: [wgpu::Buffer; 5],
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
        let [frame, nodes, triangles, lights, materials] = &self.scene;
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

/// What `vxgi render` produces so far.
pub struct Rendered {
    pub direct: RgbImage,
    /// Images not computed yet, with why.
    pub missing: Vec<(&'static str, &'static str)>,
}

/// Render `scene` on `ctx`'s device and read the direct image back.
pub fn render(ctx: &crate::harness::GpuContext, scene: &Scene) -> Result<Rendered> {
    let data = SceneData::new(scene);
    let (w, h) = (data.width(), data.height());
    let limit = ctx.limits().max_storage_buffer_binding_size;
    let need = w as u64 * h as u64 * 16;
    if need > limit {
        anyhow::bail!(
            "{w}x{h} needs {need} bytes per G-buffer binding, past the device's \
             max_storage_buffer_binding_size ({limit})"
        );
    }
    let device = &ctx.device;
    let renderer = DirectRenderer::new(device, &data);
    let targets = FrameTargets::new(device, w, h);
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("radiance readback"),
        size: need,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    renderer.encode(device, &mut encoder, &targets);
    encoder.copy_buffer_to_buffer(&targets.radiance, 0, &staging, 0, need);
    ctx.queue.submit([encoder.finish()]);
    staging.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .context("waiting for the direct-light passes")?;
    let bytes = staging
        .slice(..)
        .get_mapped_range()
        .map_err(|e| anyhow::anyhow!("mapping the radiance readback: {e:?}"))?
        .to_vec();
    let px: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
    Ok(Rendered {
        direct: RgbImage::new(w, h, px.iter().map(|p| [p[0], p[1], p[2]]).collect()),
        missing: vec![
            (
                "indirect",
                "cone-traced indirect light is not computed yet (issue 7)",
            ),
            ("combined", "needs indirect"),
            (
                "ao",
                "cone-traced ambient occlusion is not computed yet (issue 7)",
            ),
        ],
    })
}
