//! A scene as the ray-tracing kernels read it ([`SceneData`]: triangles, a flattened BVH, lights,
//! materials, the camera frame) and a CPU [`Tracer`] for the reference renderer.
//!
//! The BVH is built by the `bvh` crate (SAH); the GPU kernels walk its stackless flat form, the
//! reference walks the crate's own tree with the crate's iterator — two traversals, one triangle test
//! (`vxgi_cpu_mirror::bvh_trace::intersect`). Boxes are padded by [`BOX_PAD`] of the scene's extent (and
//! of each coordinate's magnitude) so that rounding in any slab test never drops a triangle lying on a
//! box face (axis-aligned walls make boxes of zero thickness).
use crate::scene::{Light, Scene};
use bvh::aabb::{Aabb, Bounded};
use bvh::bounding_hierarchy::BHShape;
use bvh::bvh::Bvh;
use glam::Vec3;
use nalgebra::{Point3, Vector3};
use vxgi_cpu_mirror::bvh_trace::{intersect, GpuNode, GpuTriangle, Hit, NONE};
use vxgi_cpu_mirror::direct_light::{GpuLight, GpuMaterial, DIRECTIONAL, POINT, SPOT};
use vxgi_cpu_mirror::gbuffer::Frame;

/// Relative padding of BVH boxes.
pub const BOX_PAD: f32 = 1e-5;
/// Ray offset off surfaces, relative to the scene's bounding-box diagonal.
pub const RAY_EPS: f32 = 1e-4;

#[derive(Clone, Debug)]
struct TriShape {
    lo: Vec3,
    hi: Vec3,
    index: usize,
    node: usize,
}

impl Bounded<f32, 3> for TriShape {
    fn aabb(&self) -> Aabb<f32, 3> {
        Aabb::with_bounds(
            Point3::new(self.lo.x, self.lo.y, self.lo.z),
            Point3::new(self.hi.x, self.hi.y, self.hi.z),
        )
    }
}

impl BHShape<f32, 3> for TriShape {
    fn set_bh_node_index(&mut self, i: usize) {
        self.node = i;
    }
    fn bh_node_index(&self) -> usize {
        self.node
    }
}

/// Everything the ray-tracing kernels bind, built from a [`Scene`].
#[derive(Clone, Debug)]
pub struct SceneData {
    pub frame: Frame,
    pub nodes: Vec<GpuNode>,
    pub triangles: Vec<GpuTriangle>,
    pub lights: Vec<GpuLight>,
    pub materials: Vec<GpuMaterial>,
    /// Texture coordinates, three per triangle (`uvs[3 t + k]`).
    pub uvs: Vec<[f32; 2]>,
    /// Every material's `map_Kd` texture, one after another, packed sRGB8 `r | g << 8 | b << 16`
    /// (one black texel when there are none: bindings cannot be empty).
    pub texels: Vec<u32>,
    /// sRGB8 to linear ([`srgb_lut`]).
    pub srgb_lut: Vec<f32>,
    /// Scene bounding box.
    pub bounds: (Vec3, Vec3),
    /// The `bvh` crate's tree the flat nodes came from, and its shapes (for [`Tracer`]; none for a
    /// scene without triangles).
    tree: Option<(Bvh<f32, 3>, Vec<TriShape>)>,
}

/// The most texels the texture atlas holds: 4 bytes each in one storage binding of WebGPU's default
/// limit (128 MiB), so that every device binds it. The loader reads larger sets of textures at lower
/// resolution to fit (`scene::fit_textures`).
pub const ATLAS_TEXELS: usize = (128 << 20) / 4;

/// The scene's `map_Kd` textures one after another, each distinct texture once, texels packed sRGB8
/// `r | g << 8 | b << 16` (one black texel when there are none: bindings cannot be empty), and per
/// material (first texel, width, height, 0), zeros for a material without texture.
pub fn texture_atlas(scene: &Scene) -> (Vec<u32>, Vec<[u32; 4]>) {
    let mut texels: Vec<u32> = Vec::new();
    let mut placed: Vec<(*const crate::scene::Texture, u32)> = Vec::new();
    let placement = scene
        .materials
        .iter()
        .map(|m| {
            m.diffuse_map.as_ref().map_or([0; 4], |t| {
                let key = std::sync::Arc::as_ptr(t);
                let offset = match placed.iter().find(|(k, _)| *k == key) {
                    Some(&(_, o)) => o,
                    None => {
                        let o = texels.len() as u32;
                        texels.extend(
                            t.rgb
                                .iter()
                                .map(|c| c[0] as u32 | (c[1] as u32) << 8 | (c[2] as u32) << 16),
                        );
                        placed.push((key, o));
                        o
                    }
                };
                [offset, t.width, t.height, 0]
            })
        })
        .collect();
    if texels.is_empty() {
        texels.push(0);
    }
    (texels, placement)
}

/// The 256-entry sRGB-to-linear table (IEC 61966-2-1, evaluated in f64): the GPU and the mirrors
/// read the same table, so decoding is exact.
pub fn srgb_lut() -> Vec<f32> {
    (0..256)
        .map(|i| {
            let c = i as f64 / 255.0;
            (if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }) as f32
        })
        .collect()
}

fn v4(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

/// Camera basis as the kernels use it: forward unit, right and up scaled by tan(fov/2) (and aspect).
pub fn camera_frame(scene: &Scene, eps: f32) -> Frame {
    let c = &scene.camera;
    let eye = Vec3::from(c.eye);
    let forward = (Vec3::from(c.target) - eye).normalize();
    let right = forward.cross(Vec3::from(c.up)).normalize();
    let up = right.cross(forward);
    let tan = (c.fov_y_deg.to_radians() * 0.5).tan();
    let aspect = c.width as f32 / c.height as f32;
    Frame {
        eye: v4(eye, eps),
        forward: v4(forward, 0.0),
        right: v4(right * (tan * aspect), 0.0),
        up: v4(up * tan, 0.0),
        size: [c.width, c.height, scene.lights.len() as u32, 0],
    }
}

pub fn gpu_lights(scene: &Scene) -> Vec<GpuLight> {
    scene
        .lights
        .iter()
        .map(|l| match l {
            Light::Point {
                position,
                intensity,
            } => GpuLight {
                position: v4(Vec3::from(*position), POINT),
                direction: [0.0, -1.0, 0.0, -1.0],
                intensity: v4(Vec3::from(*intensity), 1.0),
            },
            Light::Spot {
                position,
                direction,
                intensity,
                cone_deg,
                falloff_deg,
            } => GpuLight {
                position: v4(Vec3::from(*position), SPOT),
                direction: v4(
                    Vec3::from(*direction).normalize(),
                    cone_deg.to_radians().cos(),
                ),
                intensity: v4(
                    Vec3::from(*intensity),
                    falloff_deg.unwrap_or(*cone_deg).to_radians().cos(),
                ),
            },
            Light::Directional {
                direction,
                intensity,
            } => GpuLight {
                position: [0.0, 0.0, 0.0, DIRECTIONAL],
                direction: v4(Vec3::from(*direction).normalize(), -1.0),
                intensity: v4(Vec3::from(*intensity), 1.0),
            },
        })
        .collect()
}

/// Padded bounds of three points.
fn padded(points: [Vec3; 3], extent: f32) -> (Vec3, Vec3) {
    let lo = points[0].min(points[1]).min(points[2]);
    let hi = points[0].max(points[1]).max(points[2]);
    let pad = |v: Vec3| Vec3::splat(BOX_PAD * extent) + v.abs() * BOX_PAD;
    (lo - pad(lo), hi + pad(hi))
}

impl SceneData {
    pub fn new(scene: &Scene) -> Self {
        let mesh = &scene.mesh;
        let (lo, hi) = mesh.bounds();
        let (lo, hi) = if mesh.positions.is_empty() {
            (Vec3::ZERO, Vec3::ONE)
        } else {
            (lo, hi)
        };
        let extent = (hi - lo).length().max(1e-6);
        let triangles: Vec<GpuTriangle> = mesh
            .triangles
            .iter()
            .zip(&mesh.material)
            .map(|(t, &m)| {
                let p = |i: usize| mesh.positions[t[i] as usize];
                let n = |i: usize| mesh.normals[t[i] as usize];
                GpuTriangle {
                    a: v4(p(0), m as f32),
                    b: v4(p(1), 0.0),
                    c: v4(p(2), 0.0),
                    na: v4(n(0), 0.0),
                    nb: v4(n(1), 0.0),
                    nc: v4(n(2), 0.0),
                }
            })
            .collect();
        let (nodes, triangles, tree) = if triangles.is_empty() {
            // Bindings cannot be empty: one degenerate triangle (det = 0: never hit) in one leaf.
            (
                vec![GpuNode {
                    entry: NONE,
                    exit: 1,
                    shape: 0,
                    ..Default::default()
                }],
                vec![GpuTriangle::default()],
                None,
            )
        } else {
            let mut shapes = shapes_of(&triangles, extent);
            let bvh = Bvh::build(&mut shapes);
            let nodes = bvh.flatten_custom(&|aabb: &Aabb<f32, 3>, entry, exit, shape| GpuNode {
                lo: [aabb.min.x, aabb.min.y, aabb.min.z],
                entry,
                hi: [aabb.max.x, aabb.max.y, aabb.max.z],
                exit,
                shape,
                _pad: [0; 3],
            });
            (nodes, triangles, Some((bvh, shapes)))
        };
        let (texels, placement) = texture_atlas(scene);
        let materials = scene
            .materials
            .iter()
            .zip(placement)
            .map(|(m, texture)| GpuMaterial {
                diffuse: [m.diffuse[0], m.diffuse[1], m.diffuse[2], m.shininess],
                specular: [m.specular[0], m.specular[1], m.specular[2], 0.0],
                texture,
            })
            .chain(std::iter::once(GpuMaterial {
                diffuse: [0.8, 0.8, 0.8, 1.0],
                specular: [0.0; 4],
                texture: [0; 4],
            }))
            .collect();
        let mut uvs: Vec<[f32; 2]> = mesh
            .triangles
            .iter()
            .flat_map(|t| {
                t.map(|v| {
                    mesh.uvs
                        .get(v as usize)
                        .map_or([0.0; 2], |uv| uv.to_array())
                })
            })
            .collect();
        if uvs.is_empty() {
            uvs = vec![[0.0; 2]; 3];
        }
        Self {
            frame: camera_frame(scene, RAY_EPS * extent),
            nodes,
            triangles,
            lights: gpu_lights(scene),
            materials,
            uvs,
            texels,
            srgb_lut: srgb_lut(),
            bounds: (lo, hi),
            tree,
        }
    }

    pub fn width(&self) -> u32 {
        self.frame.size[0]
    }
    pub fn height(&self) -> u32 {
        self.frame.size[1]
    }
    pub fn eps(&self) -> f32 {
        self.frame.eye[3]
    }
    /// The textures as the mirrors read them.
    pub fn textures(&self) -> vxgi_cpu_mirror::gbuffer::Textures<'_> {
        vxgi_cpu_mirror::gbuffer::Textures {
            uvs: &self.uvs,
            texels: &self.texels,
            lut: &self.srgb_lut,
        }
    }
}

fn shapes_of(triangles: &[GpuTriangle], extent: f32) -> Vec<TriShape> {
    triangles
        .iter()
        .enumerate()
        .map(|(index, t)| {
            let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
            let (lo, hi) = padded([v(t.a), v(t.b), v(t.c)], extent);
            TriShape {
                lo,
                hi,
                index,
                node: 0,
            }
        })
        .collect()
}

/// The share of the camera's view that meets the back of a face (its winding turned away from the
/// camera), from a 32 x 32 grid of camera rays; `None` where fewer than a twentieth of the rays meet
/// anything (too little of the view to judge). Back faces reflect nothing (the light-transport
/// contract: surfaces are one-sided), so where most of the view is back faces either the camera is
/// behind them or the mesh is inside out (a room modelled with its faces turned outwards).
pub fn back_face_share(data: &SceneData) -> Option<f32> {
    const GRID: u32 = 32;
    let tracer = Tracer::new(data);
    let (w, h) = (data.frame.size[0] as f32, data.frame.size[1] as f32);
    let (mut hits, mut back) = (0u32, 0u32);
    for j in 0..GRID {
        for i in 0..GRID {
            let fx = (i as f32 + 0.5) / GRID as f32 * w;
            let fy = (j as f32 + 0.5) / GRID as f32 * h;
            let (o, d) = vxgi_cpu_mirror::gbuffer::ray_through(&data.frame, fx, fy);
            if let Some(hit) = tracer.closest(o, d, 0.0, f32::INFINITY) {
                hits += 1;
                back += u32::from(!hit.front);
            }
        }
    }
    (hits * 20 >= GRID * GRID).then(|| back as f32 / hits as f32)
}

/// CPU ray queries over the `bvh` crate's own tree (the reference renderer's traversal): the tree
/// [`SceneData::new`] built and flattened for the kernels, not a second build.
pub struct Tracer<'a> {
    data: &'a SceneData,
}

impl<'a> Tracer<'a> {
    pub fn new(data: &'a SceneData) -> Self {
        Self { data }
    }

    /// The shapes the tree's traversal yields for `ray` (none without triangles).
    fn candidates<'r>(
        &'r self,
        ray: &'r bvh::ray::Ray<f32, 3>,
    ) -> impl Iterator<Item = &'r TriShape> + 'r {
        self.data
            .tree
            .iter()
            .flat_map(move |(bvh, shapes)| bvh.traverse_iterator(ray, shapes))
    }

    fn ray(o: Vec3, d: Vec3) -> bvh::ray::Ray<f32, 3> {
        bvh::ray::Ray::new(Point3::new(o.x, o.y, o.z), Vector3::new(d.x, d.y, d.z))
    }

    /// Nearest hit in `(t_min, t_max)`.
    pub fn closest(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<Hit> {
        let ray = Self::ray(o, d);
        let mut best: Option<Hit> = None;
        let mut t_best = t_max;
        for shape in self.candidates(&ray) {
            let i = shape.index;
            if let Some(h) = intersect(o, d, &self.data.triangles[i], t_min, t_best, 0.0) {
                t_best = h.t;
                best = Some(Hit {
                    t: h.t,
                    tri: i as u32,
                    u: h.u,
                    v: h.v,
                    front: h.det > 0.0,
                });
            }
        }
        best
    }

    /// Whether anything lies on the ray in `(t_min, t_max)`.
    pub fn occluded(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> bool {
        let ray = Self::ray(o, d);
        let hit = self.candidates(&ray).any(|s| {
            let i = s.index;
            intersect(o, d, &self.data.triangles[i], t_min, t_max, 0.0).is_some()
        });
        hit
    }
}
