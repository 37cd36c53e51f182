//! Declaration of `kernels/gbuffer.wgsl` (mirror: `vxgi_cpu_mirror::gbuffer`): primary rays through
//! the flattened BVH. Cases are generated scenes ([`generated_scene`]): the Cornell box, triangle soups
//! with smooth normals, box stacks with shared edges (rays on edges), and far-from-origin / tiny scenes.
use crate::scene::{CameraDesc, Light, Material, Mesh, RenderSettings, Scene, Texture};
use crate::trace::SceneData;
use glam::{Vec2, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;
use vxgi_cpu_mirror::bvh_trace::GpuNode;
use vxgi_cpu_mirror::direct_light::GpuMaterial;
use vxgi_cpu_mirror::gbuffer::{
    accepted_texel, albedo, albedo_bound, texel_bounds, Frame, Textures,
};
use vxgi_harness::prelude::*;
use vxgi_harness::run::Pass;

pub const BVH_TRACE: (&str, &str) = (
    "kernels/common/bvh_trace.wgsl",
    include_str!("../../kernels/common/bvh_trace.wgsl"),
);

vxgi_harness::bindings! {
    /// gbuffer's bindings: the scene (camera frame, BVH, triangles, materials and their textures)
    /// in, the G-buffer out.
    pub struct Io {
        inputs: {
            frame: Block<Frame>,
            nodes: Structs<GpuNode>,
            // Six vec4<f32> per triangle (`GpuTriangle`).
            triangles: Vec<[f32; 4]>,
            materials: Structs<GpuMaterial>,
            uvs: Vec<[f32; 2]>,
            texels: Vec<u32>,
            srgb_lut: Vec<f32>,
        }
        outputs: {
            // Per element (see `texel_bounds`): t and p are quotients of dots/crosses conditioned by
            // the ray's angle to the triangle; 32 ULP per unit of that condition number.
            gb_position: Vec<[f32; 4]> => Tolerance::MirrorBound,
            gb_normal: Vec<[f32; 4]> => Tolerance::MirrorBound,
            // Exact after acceptance: where rounding decides between triangles (edges, equal
            // depths) the mirror adopts the GPU's pick after checking rounding could have made it
            // (`accepted_texel`).
            gb_triangle: Vec<u32> => Tolerance::Exact,
            // Exact for Kd; from a texture, any texel the uv's rounding could select
            // (`albedo_bound`).
            gb_albedo: Vec<[f32; 4]> => Tolerance::MirrorBound,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "gbuffer",
    includes: &[super::SCENE_TYPES, BVH_TRACE],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "gb_triangle" },
    mirror: "vxgi_cpu_mirror::gbuffer::shade_pixel",
    summary: "primary ray per pixel through the flattened BVH: position + t, shading normal + side, triangle, albedo (Kd or map_Kd)",
);

fn quad(mesh: &mut Mesh, corners: [Vec3; 4], material: u32) {
    // Two CCW triangles; flat normals (unique vertices per triangle); UVs over [0, 2]^2 (the texture
    // repeats twice).
    let uv = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]].map(Vec2::from);
    for [a, b, c] in [[0, 1, 2], [0, 2, 3]] {
        tri(
            mesh,
            [corners[a], corners[b], corners[c]],
            None,
            [uv[a], uv[b], uv[c]],
            material,
        );
    }
}

fn tri(mesh: &mut Mesh, p: [Vec3; 3], normals: Option<[Vec3; 3]>, uv: [Vec2; 3], material: u32) {
    let base = mesh.positions.len() as u32;
    let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
    let n = normals.unwrap_or([face; 3]);
    mesh.positions.extend(p);
    mesh.normals.extend(n);
    mesh.uvs.extend(uv);
    mesh.triangles.push([base, base + 1, base + 2]);
    mesh.material.push(material);
}

/// An axis-aligned box as 6 outward-facing quads.
fn cuboid(mesh: &mut Mesh, lo: Vec3, hi: Vec3, material: u32) {
    let c = |x: bool, y: bool, z: bool| {
        Vec3::new(
            if x { hi.x } else { lo.x },
            if y { hi.y } else { lo.y },
            if z { hi.z } else { lo.z },
        )
    };
    let (f, t) = (false, true);
    for corners in [
        [c(f, f, t), c(t, f, t), c(t, t, t), c(f, t, t)], // +z
        [c(t, f, f), c(f, f, f), c(f, t, f), c(t, t, f)], // -z
        [c(t, f, t), c(t, f, f), c(t, t, f), c(t, t, t)], // +x
        [c(f, f, f), c(f, f, t), c(f, t, t), c(f, t, f)], // -x
        [c(f, t, t), c(t, t, t), c(t, t, f), c(f, t, f)], // +y
        [c(f, f, f), c(t, f, f), c(t, f, t), c(f, f, t)], // -y
    ] {
        quad(mesh, corners, material);
    }
}

/// A small random texture (sides 1 to 16 texels, not powers of two only).
fn random_texture(rng: &mut ChaCha8Rng, i: usize) -> Texture {
    let (width, height) = (rng.random_range(1..=16u32), rng.random_range(1..=16u32));
    Texture {
        path: format!("generated texture {i}").into(),
        width,
        height,
        rgb: (0..width * height).map(|_| rng.random()).collect(),
    }
}

/// Four materials: diffuse and glossy, materials 2 and 3 textured.
fn random_materials(rng: &mut ChaCha8Rng) -> Vec<Material> {
    (0..4)
        .map(|i| Material {
            name: format!("m{i}"),
            diffuse: [rng.random(), rng.random(), rng.random()],
            specular: if i % 2 == 1 {
                [rng.random::<f32>() * 0.5; 3]
            } else {
                [0.0; 3]
            },
            shininess: [1.0, 8.0, 32.0, 128.0][i],
            diffuse_map: (i >= 2).then(|| Arc::new(random_texture(rng, i))),
        })
        .collect()
}

fn random_lights(rng: &mut ChaCha8Rng, centre: Vec3, size: f32) -> Vec<Light> {
    let mut pos = || {
        (centre
            + Vec3::new(
                rng.random::<f32>() - 0.5,
                rng.random::<f32>() * 0.5 + 0.6,
                rng.random::<f32>() - 0.5,
            ) * size)
            .to_array()
    };
    let (p0, p1) = (pos(), pos());
    vec![
        Light::Point {
            position: p0,
            intensity: [size * size * 2.0, size * size * 1.5, size * size],
        },
        Light::Spot {
            position: p1,
            direction: (centre - Vec3::from(p1)).to_array(),
            intensity: [size * size * 3.0; 3],
            cone_deg: 35.0,
            falloff_deg: Some(20.0),
        },
        Light::Directional {
            direction: [0.3, -1.0, 0.2],
            intensity: [0.5, 0.6, 0.7],
        },
    ]
}

/// Generated scene `index` of a run seeded with `seed`, and a label naming its family.
pub fn generated_scene(seed: u64, index: usize) -> (Scene, String) {
    let mut rng =
        ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ index as u64);
    let family = index % 4;
    let (w, h) = (
        40 + rng.random_range(0..3u32) * 8,
        32 + rng.random_range(0..3u32) * 8,
    );
    let mut mesh = Mesh::default();
    let (label, centre, size) = match family {
        0 => {
            let mut s = Scene::cornell_box();
            s.camera.width = w;
            s.camera.height = h;
            return (s, format!("cornell box {w}x{h}"));
        }
        1 => {
            // Soup: random triangles with smooth (perturbed) normals, some facing away.
            let n = rng.random_range(40..160);
            for _ in 0..n {
                let c = Vec3::new(rng.random(), rng.random(), rng.random());
                let p = [0, 1, 2]
                    .map(|_| c + Vec3::new(rng.random(), rng.random(), rng.random()) * 0.4 - 0.2);
                let face = (p[1] - p[0]).cross(p[2] - p[0]);
                if face.length() < 1e-4 {
                    continue;
                }
                let face = face.normalize();
                let nrm = [0, 1, 2].map(|_| {
                    (face + Vec3::new(rng.random(), rng.random(), rng.random()) * 0.4 - 0.2)
                        .normalize()
                });
                // UVs anywhere in [-3, 3]: repeats, negative coordinates.
                let uv = [0, 1, 2]
                    .map(|_| Vec2::new(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0)));
                tri(&mut mesh, p, Some(nrm), uv, rng.random_range(0..4));
            }
            (
                format!("triangle soup ({n}) {w}x{h}"),
                Vec3::splat(0.5),
                1.0,
            )
        }
        2 => {
            // Stacked unit boxes on a floor: shared edges and coplanar faces (rays on edges).
            quad(
                &mut mesh,
                [
                    Vec3::new(-2.0, 0.0, 2.0),
                    Vec3::new(2.0, 0.0, 2.0),
                    Vec3::new(2.0, 0.0, -2.0),
                    Vec3::new(-2.0, 0.0, -2.0),
                ],
                0,
            );
            for i in 0..rng.random_range(3..8) {
                let x = rng.random_range(-2..2) as f32;
                let z = rng.random_range(-2..2) as f32;
                let y = (i % 3) as f32 * 0.5;
                cuboid(
                    &mut mesh,
                    Vec3::new(x, y, z) * 0.5,
                    Vec3::new(x + 1.0, y + 1.0, z + 1.0) * 0.5,
                    rng.random_range(0..4),
                );
            }
            (format!("box stack {w}x{h}"), Vec3::new(0.0, 0.5, 0.0), 2.0)
        }
        _ => {
            // The box stack far from the origin or tiny: relative precision of positions.
            let (scale, offset) = if rng.random::<bool>() {
                (1.0, Vec3::new(1000.0, -500.0, 250.0))
            } else {
                (1e-3, Vec3::ZERO)
            };
            for i in 0..4 {
                let x = i as f32 * 0.5 - 1.0;
                cuboid(
                    &mut mesh,
                    Vec3::new(x, 0.0, -0.25) * scale + offset,
                    Vec3::new(x + 0.5, 0.5 + 0.25 * i as f32, 0.25) * scale + offset,
                    i,
                );
            }
            (
                format!("boxes at scale {scale} offset {offset} {w}x{h}"),
                offset + Vec3::new(0.0, 0.25, 0.0) * scale,
                2.0 * scale,
            )
        }
    };
    let az: f32 = rng.random_range(-1.2..1.2);
    let el: f32 = rng.random_range(0.1..0.9);
    let eye = centre + Vec3::new(az.sin() * el.cos(), el.sin(), az.cos() * el.cos()) * (2.5 * size);
    let scene = Scene {
        mesh,
        materials: random_materials(&mut rng),
        camera: CameraDesc {
            eye: eye.to_array(),
            target: centre.to_array(),
            up: [0.0, 1.0, 0.0],
            fov_y_deg: rng.random_range(30.0..60.0),
            width: w,
            height: h,
        },
        lights: random_lights(&mut rng, centre, size),
        render: RenderSettings::default(),
        warnings: vec![],
        instances: Default::default(),
        explicit_render: Default::default(),
    };
    (scene, label)
}

/// The scene's buffers, named as the ray-tracing kernels bind them.
pub fn scene_resources(data: &SceneData) -> Resources {
    let f = |b: &[u8]| HostBuffer::f32(bytemuck::cast_slice(b));
    buffers([
        ("frame", HostBuffer::pod(&data.frame)),
        ("nodes", HostBuffer::structs(&data.nodes)),
        ("triangles", f(bytemuck::cast_slice(&data.triangles))),
        (
            "lights",
            f(bytemuck::cast_slice(&super::or_one(&data.lights))),
        ),
        ("materials", HostBuffer::structs(&data.materials)),
        ("uvs", f(bytemuck::cast_slice(&data.uvs))),
        ("texels", HostBuffer::of(&data.texels)),
        ("srgb_lut", f(bytemuck::cast_slice(&data.srgb_lut))),
    ])
}

/// The G-buffer pass over a scene: resources (inputs plus zeroed outputs) and the pass.
pub fn case_for(data: &SceneData, label: String, seed: u64) -> Case {
    let (w, h) = (data.width(), data.height());
    let n = w as usize * h as usize;
    let mut resources = scene_resources(data);
    let f4 = |n: usize| HostBuffer::zeroed(n * 16, ScalarKind::F32);
    resources.extend(buffers([
        ("gb_position", f4(n)),
        ("gb_normal", f4(n)),
        ("gb_triangle", HostBuffer::zeroed(n * 4, ScalarKind::U32)),
        ("gb_albedo", f4(n)),
    ]));
    let groups = [w.div_ceil(8), h.div_ceil(8), 1];
    let pass = Pass::direct("gbuffer", "main", DECL.bind_by_name(), groups);
    Io::read(&resources)
        .case(label, seed, vec![pass])
        .with_effective_bytes(n as u64 * 52)
        .with_grid([w, h, 1])
}

/// Mirror G-buffer given the GPU's triangle picks: texels, their bounds, and how many GPU picks
/// differing from the mirror's own were accepted.
#[derive(Default)]
pub struct MirrorGbuffer {
    pub position: Vec<[f32; 4]>,
    pub normal: Vec<[f32; 4]>,
    pub triangle: Vec<u32>,
    pub position_bound: Vec<[f32; 4]>,
    pub normal_bound: Vec<[f32; 4]>,
    pub albedo: Vec<[f32; 4]>,
    pub albedo_bound: Vec<[f32; 4]>,
    pub accepted_differences: usize,
}

pub fn mirror_gbuffer(data: &Resources, gpu_triangle: &[u32]) -> MirrorGbuffer {
    let b = |n: &str| data[n].buffer().expect("buffer");
    let frame: Frame = *bytemuck::from_bytes(&b("frame").bytes);
    let nodes: &[vxgi_cpu_mirror::bvh_trace::GpuNode] = bytemuck::cast_slice(&b("nodes").bytes);
    let tris: &[vxgi_cpu_mirror::bvh_trace::GpuTriangle] =
        bytemuck::cast_slice(&b("triangles").bytes);
    let materials: &[vxgi_cpu_mirror::direct_light::GpuMaterial] =
        bytemuck::cast_slice(&b("materials").bytes);
    let tex = Textures {
        uvs: bytemuck::cast_slice(&b("uvs").bytes),
        texels: b("texels").as_u32(),
        lut: bytemuck::cast_slice(&b("srgb_lut").bytes),
    };
    let (w, h) = (frame.size[0], frame.size[1]);
    let mut out = MirrorGbuffer::default();
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let g = gpu_triangle.get(i).copied().unwrap_or(u32::MAX);
            let (t, differs) = accepted_texel(&frame, nodes, tris, x, y, g);
            let (bp, bn, duv) = texel_bounds(&frame, tris, x, y, &t);
            out.albedo.push(albedo(materials, tris, &tex, &t));
            out.albedo_bound
                .push(albedo_bound(materials, tris, &tex, &t, duv));
            out.accepted_differences += differs as usize;
            out.position.push(t.position);
            out.normal.push(t.normal);
            out.triangle.push(t.triangle);
            out.position_bound.push(bp);
            out.normal_bound.push(bn);
        }
    }
    out
}

pub struct Gbuffer;

impl Kernel for Gbuffer {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    /// Generated scenes; every fourth through an orthographic frame (parallel rays along the camera's
    /// axis, over the scene's bounding sphere: what a directional light's RSM uses).
    fn case(&self, _shader: &Shader, _ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (scene, label) = generated_scene(seed, index);
        let mut data = SceneData::new(&scene);
        if index % 4 == 3 {
            let f = data.frame.forward;
            let light = vxgi_cpu_mirror::direct_light::GpuLight {
                direction: [f[0], f[1], f[2], 0.0],
                ..Default::default()
            };
            let (w, h) = (data.width(), data.height());
            let view = crate::lrsm::orthographic_view(
                &light,
                0,
                data.lights.len(),
                data.bounds,
                w,
                data.frame.eye[3],
            );
            data.frame = view.frame;
            data.frame.size = [w, h, data.lights.len() as u32, 1];
            return case_for(&data, format!("{label}, orthographic"), seed);
        }
        case_for(&data, label, seed)
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // Subnormals play no part in ray-triangle arithmetic at scene scales: one mode serves both.
        let m = mirror_gbuffer(
            data,
            data["gb_triangle"].buffer().expect("gb_triangle").as_u32(),
        );
        let mut io = Io::read(data);
        (io.gb_position, io.gb_normal) = (m.position, m.normal);
        (io.gb_triangle, io.gb_albedo) = (m.triangle, m.albedo);
        let mut out = io.outputs();
        out.extend([
            bound("gb_position", &m.position_bound),
            bound("gb_normal", &m.normal_bound),
            bound("gb_albedo", &m.albedo_bound),
        ]);
        out
    }
}
