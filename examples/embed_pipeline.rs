//! A vxgi pipeline inside your own wgpu program: this program creates its own device and output
//! texture, rasterizes its own G-buffer with a wgpu render pipeline, and records the pipeline's frame
//! into its own command encoder each call (`Resident::encode_with_gbuffer`), then copies the image
//! into its texture. It checks the image against `vxgi render`'s (the ray-cast G-buffer) and exits
//! non-zero where they differ by FLIP 0.02 or more (a raster G-buffer may differ at edges).
//!
//! `cargo run --release --example embed_pipeline [-- vct-dense|vct-svo|lrsm]` (default: every
//! GPU-resident pipeline) on the built-in Cornell box at 256x256. The G-buffer's layouts: docs/contract.md,
//! "Frame buffers". The albedo here is each material's Kd (the Cornell box has no textures; a
//! textured scene's raster samples map_Kd as kernels/gbuffer.wgsl defines).
use anyhow::{Context, Result};
use vxgi::harness::GpuContext;
use vxgi::images::RgbImage;
use vxgi::kernels::cone_trace::ConeSettings;
use vxgi::render::Pipeline;
use vxgi::resident::{GBuffer, Resident};
use vxgi::scene::Scene;
use vxgi::trace::SceneData;
use wgpu::util::DeviceExt;

#[allow(dead_code)]
fn main() {
    let pipelines: Vec<Pipeline> = match std::env::args().nth(1) {
        None => Resident::PIPELINES.to_vec(),
        Some(name) => match Resident::PIPELINES.iter().find(|p| p.name() == name) {
            Some(p) => vec![*p],
            None => {
                let all = Resident::PIPELINES.map(|p| p.name()).join(", ");
                eprintln!("embed_pipeline: `{name}` is not a GPU-resident pipeline ({all})");
                std::process::exit(2);
            }
        },
    };
    for p in pipelines {
        // The quality preset (`balanced`), as `vxgi render` applies it.
        let scene = match vxgi::quality::resolved(&Scene::cornell_box(), p) {
            Ok((scene, _)) => scene,
            Err(e) => {
                eprintln!("{}: {e}", p.name());
                std::process::exit(1);
            }
        };
        match embedded_flip(p, &scene) {
            Ok(flip) if flip < 0.02 => {
                println!(
                    "{}: embedded frame vs vxgi render: FLIP {flip:.4}",
                    p.name()
                )
            }
            Ok(flip) => {
                eprintln!(
                    "{}: embedded frame vs vxgi render: FLIP {flip:.4} (>= 0.02)",
                    p.name()
                );
                std::process::exit(1);
            }
            Err(e) => {
                eprintln!("{}: {e:#}", p.name());
                std::process::exit(1);
            }
        }
    }
}

/// The G-buffer raster: the scene's triangles (as the ray-cast G-buffer indexes them) projected by
/// the camera frame's own basis, two passes of two targets each (WebGPU allows 32 bytes of colour
/// targets per sample): position and distance with the triangle index, then normal and side with
/// the albedo.
const RASTER: &str = r#"
struct Camera {
    eye: vec4<f32>,
    // rows of the projection: x = dot(r, right) / |right|^2, y = dot(r, up) / |up|^2,
    // w = dot(r, forward) / |forward|^2 for r = p - eye; depth (w - near) * far / (far - near) / w.
    right: vec4<f32>,
    up: vec4<f32>,
    forward: vec4<f32>,
    depth: vec4<f32>, // near, far
}
@group(0) @binding(0) var<uniform> camera: Camera;

struct Vertex {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
    @location(3) triangle: u32,
}
struct Varyings {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
    @location(3) @interpolate(flat) triangle: u32,
}

@vertex
fn vs(v: Vertex) -> Varyings {
    let r = v.position - camera.eye.xyz;
    let w = dot(r, camera.forward.xyz);
    let n = camera.depth.x;
    let f = camera.depth.y;
    var out: Varyings;
    out.clip = vec4<f32>(dot(r, camera.right.xyz), dot(r, camera.up.xyz), (w - n) * f / (f - n), w);
    out.world = v.position;
    out.normal = v.normal;
    out.albedo = v.albedo;
    out.triangle = v.triangle;
    return out;
}

struct Surface {
    @location(0) position: vec4<f32>,
    @location(1) triangle: u32,
}
@fragment
fn surface(in: Varyings) -> Surface {
    return Surface(vec4<f32>(in.world, length(in.world - camera.eye.xyz)), in.triangle);
}

struct Shading {
    @location(0) normal: vec4<f32>,
    @location(1) albedo: vec4<f32>,
}
@fragment
fn shading(in: Varyings, @builtin(front_facing) front: bool) -> Shading {
    return Shading(vec4<f32>(normalize(in.normal), select(-1.0, 1.0, front)), vec4<f32>(in.albedo, 0.0));
}
"#;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct RasterVertex {
    position: [f32; 3],
    normal: [f32; 3],
    albedo: [f32; 3],
    triangle: u32,
}

/// A render target of `format` that is copied into a storage-compatible buffer afterwards.
fn target(device: &wgpu::Device, w: u32, h: u32, format: wgpu::TextureFormat) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("gbuffer target"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

/// This program's own G-buffer: four buffers (the layouts `GBuffer` documents) and the raster that
/// fills them.
struct RasterGBuffer {
    buffers: [wgpu::Buffer; 4],
    targets: [wgpu::Texture; 4],
    depth: wgpu::Texture,
    pipelines: [wgpu::RenderPipeline; 2],
    bind_group: wgpu::BindGroup,
    vertices: wgpu::Buffer,
    count: u32,
    size: (u32, u32),
}

impl RasterGBuffer {
    fn new(device: &wgpu::Device, scene: &Scene) -> Result<Self> {
        let (w, h) = (scene.camera.width, scene.camera.height);
        anyhow::ensure!(
            w % 64 == 0,
            "this example copies its targets to buffers without row padding: the width must be a multiple of 64 (got {w})"
        );
        let data = SceneData::new(scene);
        let f = data.frame;
        let v3 = |a: [f32; 4]| glam::Vec3::new(a[0], a[1], a[2]);
        let scaled = |a: [f32; 4]| {
            let v = v3(a);
            (v / v.length_squared()).extend(0.0).to_array()
        };
        // Depth from just past the eye to past the farthest corner of the scene's bounds.
        let far =
            2.0 * (data.bounds.1 - data.bounds.0).length() + (v3(f.eye) - data.bounds.0).length();
        let camera: [[f32; 4]; 5] = [
            f.eye,
            scaled(f.right),
            scaled(f.up),
            scaled(f.forward),
            [far * 1e-6, far, 0.0, 0.0],
        ];
        let vertices: Vec<RasterVertex> = data
            .triangles
            .iter()
            .enumerate()
            .flat_map(|(i, t)| {
                let m = &data.materials[(t.material() as usize).min(data.materials.len() - 1)];
                let albedo = [m.diffuse[0], m.diffuse[1], m.diffuse[2]];
                [(t.a, t.na), (t.b, t.nb), (t.c, t.nc)].map(|(p, n)| RasterVertex {
                    position: [p[0], p[1], p[2]],
                    normal: [n[0], n[1], n[2]],
                    albedo,
                    triangle: i as u32,
                })
            })
            .collect();
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("gbuffer raster"),
            source: wgpu::ShaderSource::Wgsl(RASTER.into()),
        });
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("camera"),
            contents: bytemuck::cast_slice(&camera),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform.as_entire_binding(),
            }],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        use wgpu::TextureFormat::{Depth32Float, R32Uint, Rgba32Float};
        let attributes =
            wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3, 3 => Uint32];
        let pipeline = |entry: &str, formats: [wgpu::TextureFormat; 2]| {
            let targets = formats.map(|f| Some(wgpu::ColorTargetState::from(f)));
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(entry),
                layout: Some(&pl),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: std::mem::size_of::<RasterVertex>() as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &attributes,
                    })],
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: Depth32Float,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let pipelines = [
            pipeline("surface", [Rgba32Float, R32Uint]),
            pipeline("shading", [Rgba32Float, Rgba32Float]),
        ];
        let n = w as u64 * h as u64;
        let buffer = |label: &str, bytes: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: n * bytes,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        Ok(Self {
            buffers: [
                buffer("gb_position", 16),
                buffer("gb_triangle", 4),
                buffer("gb_normal", 16),
                buffer("gb_albedo", 16),
            ],
            targets: [
                target(device, w, h, Rgba32Float),
                target(device, w, h, R32Uint),
                target(device, w, h, Rgba32Float),
                target(device, w, h, Rgba32Float),
            ],
            depth: target(device, w, h, Depth32Float),
            pipelines,
            bind_group,
            vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("triangles"),
                contents: bytemuck::cast_slice(&vertices),
                usage: wgpu::BufferUsages::VERTEX,
            }),
            count: vertices.len() as u32,
            size: (w, h),
        })
    }

    /// Record the raster passes and the copies of their targets into the G-buffer's buffers.
    fn encode(&self, encoder: &mut wgpu::CommandEncoder) {
        // Nothing seen: position (0, 0, 0, -1), triangle u32::MAX, normal and albedo 0.
        let clears = [
            [0.0, 0.0, 0.0, -1.0],
            [u32::MAX as f64, 0.0, 0.0, 0.0],
            [0.0; 4],
            [0.0; 4],
        ];
        let depth_view = self.depth.create_view(&Default::default());
        for (pass, pipeline) in self.pipelines.iter().enumerate() {
            let views: Vec<_> = (0..2)
                .map(|k| self.targets[2 * pass + k].create_view(&Default::default()))
                .collect();
            let attachments: Vec<_> = views
                .iter()
                .enumerate()
                .map(|(k, view)| {
                    let [r, g, b, a] = clears[2 * pass + k];
                    Some(wgpu::RenderPassColorAttachment {
                        view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a }),
                            store: wgpu::StoreOp::Store,
                        },
                    })
                })
                .collect();
            let mut rpass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("gbuffer raster"),
                color_attachments: &attachments,
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            rpass.set_pipeline(pipeline);
            rpass.set_bind_group(0, &self.bind_group, &[]);
            rpass.set_vertex_buffer(0, self.vertices.slice(..));
            rpass.draw(0..self.count, 0..1);
        }
        let (w, h) = self.size;
        for (t, b) in self.targets.iter().zip(&self.buffers) {
            let texel = t.format().block_copy_size(None).expect("colour format");
            encoder.copy_texture_to_buffer(
                t.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer: b,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(w * texel),
                        rows_per_image: Some(h),
                    },
                },
                t.size(),
            );
        }
    }

    fn gbuffer(&self) -> GBuffer<'_> {
        GBuffer {
            position: &self.buffers[0],
            triangle: &self.buffers[1],
            normal: &self.buffers[2],
            albedo: &self.buffers[3],
        }
    }
}

/// The device this program owns, with the adapter's limits (the cone passes bind up to 20 storage
/// buffers; WebGPU's default is 8).
fn own_device() -> Result<(wgpu::Device, wgpu::Queue, wgpu::AdapterInfo)> {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .context("no GPU adapter; on Debian: apt-get install -y mesa-vulkan-drivers")?;
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("embedding program"),
        required_limits: adapter.limits(),
        ..Default::default()
    }))?;
    Ok((device, queue, adapter.get_info()))
}

/// Read an `Rgba32Float` texture back as an image (rgb).
fn read_texture(device: &wgpu::Device, queue: &wgpu::Queue, t: &wgpu::Texture) -> Result<RgbImage> {
    let (w, h) = (t.width(), t.height());
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: w as u64 * h as u64 * 16,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        t.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(w * 16),
                rows_per_image: Some(h),
            },
        },
        t.size(),
    );
    queue.submit([encoder.finish()]);
    staging.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    device.poll(wgpu::PollType::wait_indefinitely())?;
    let bytes = staging.slice(..).get_mapped_range()?.to_vec();
    let px: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
    Ok(RgbImage::new(
        w,
        h,
        px.iter().map(|p| [p[0], p[1], p[2]]).collect(),
    ))
}

/// Two frames of `pipeline` on `scene`, embedded (own device, raster G-buffer, own encoder per
/// frame, the direct and indirect light copied into own textures), against `vxgi render`'s combined
/// image of the same scene: the mean FLIP of the last frame's combined image.
pub fn embedded_flip(pipeline: Pipeline, scene: &Scene) -> Result<f32> {
    let (device, queue, info) = own_device()?;
    let ctx = GpuContext::from_device(device.clone(), queue.clone(), info);
    let cones = ConeSettings::from(&scene.render);
    let raster = RasterGBuffer::new(&device, scene)?;
    let (w, h) = (scene.camera.width, scene.camera.height);
    let output = [
        target(&device, w, h, wgpu::TextureFormat::Rgba32Float),
        target(&device, w, h, wgpu::TextureFormat::Rgba32Float),
    ];
    let mut vxgi = Resident::new(&ctx, pipeline)?;
    for _ in 0..2 {
        let mut encoder = device.create_command_encoder(&Default::default());
        raster.encode(&mut encoder);
        let frame = vxgi.encode_with_gbuffer(scene, &cones, &raster.gbuffer(), &mut encoder)?;
        for (src, dst) in [&frame.direct, &frame.indirect].into_iter().zip(&output) {
            encoder.copy_buffer_to_texture(
                wgpu::TexelCopyBufferInfo {
                    buffer: src,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(w * 16),
                        rows_per_image: Some(h),
                    },
                },
                dst.as_image_copy(),
                dst.size(),
            );
        }
        queue.submit([encoder.finish()]);
        // vct-svo's octree lives in room sized at load; whether this frame fit it is known once
        // it has run (Ok at once for the other pipelines).
        vxgi.check_encoded()?;
    }
    let direct = read_texture(&device, &queue, &output[0])?;
    let indirect = read_texture(&device, &queue, &output[1])?;
    let ours = RgbImage::new(w, h, vxgi::images::add(&direct.pixels, &indirect.pixels));
    // `vxgi render`'s frame: the same renderer with its ray-cast G-buffer.
    let want = Resident::new(&ctx, pipeline)?.render(scene, &cones)?;
    let path = std::path::Path::new;
    let c = vxgi::images::compare(&want.combined, path("vxgi render"), &ours, path("embedded"))?;
    Ok(c.flip_mean)
}
