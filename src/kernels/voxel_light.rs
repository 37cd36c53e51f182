//! Declaration of `kernels/voxel_light.wgsl` (mirror: `vxgi_cpu_mirror::voxel_light`): direct light
//! into the non-empty voxels with exact shadow rays. A case voxelizes a generated scene on the GPU (the
//! `voxelize` kernel) and feeds its grid and list in.
use super::gbuffer::{generated_scene, scene_resources};
use super::voxelize::{voxelize_on_gpu, VoxelFrame};
use crate::grids::Grid;
use crate::trace::SceneData;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::bvh_trace::{GpuNode, GpuTriangle};
use vxgi_cpu_mirror::direct_light::GpuLight;
use vxgi_cpu_mirror::voxel_light::{light_voxel, VoxelGrid};
use vxgi_harness::compare::bound_name;
use vxgi_harness::run::{grid_for, run, Pass, Workgroups};
use vxgi_harness::{
    Case, Check, DispatchRule, FloatMode, GpuContext, HostBuffer, HostResource, Indexing, Kernel,
    KernelDecl, Output, Resources, ScalarKind, Shader, Tolerance,
};

pub static DECL: KernelDecl = KernelDecl {
    name: "voxel_light",
    wgsl_path: "kernels/voxel_light.wgsl",
    wgsl: include_str!("../../kernels/voxel_light.wgsl"),
    includes: &[super::SCENE_TYPES, super::gbuffer::BVH_TRACE, super::LIGHTS],
    entry: "main",
    inputs: &[
        "grid", "nodes", "triangles", "lights", "vox_colour", "vox_normal", "list", "list_count",
    ],
    outputs: &[
        // Per element (see `light_voxel`): 64 ULP per light term, 8 ULP absolute on the cosine; terms
        // whose shadow ray rounding decides add their value. Alpha is copied: exact (bound 0).
        Output { binding: "vox_radiance", tolerance: Tolerance::MirrorBound },
    ],
    dispatch: DispatchRule::PerElement { binding: "list" },
    mirror: "vxgi_cpu_mirror::voxel_light::light_voxel",
    summary: "direct light into the non-empty voxels, one exact shadow ray per light (CPRC 3.1 voxel illumination)",
};

pub fn voxel_grid(frame: &VoxelFrame, lights: usize) -> VoxelGrid {
    VoxelGrid::in_world(
        [frame.origin.x, frame.origin.y, frame.origin.z, frame.voxel],
        frame.side,
        lights as u32,
    )
}

/// Lighting pass over a voxelized scene.
pub fn case_for(
    ctx: &GpuContext,
    data: &SceneData,
    grid: &Grid,
    list: &[u32],
    frame: &VoxelFrame,
    label: String,
    seed: u64,
) -> Case {
    let mut resources = scene_resources(data);
    resources.remove("frame");
    resources.remove("materials");
    resources.insert(
        "grid".into(),
        HostResource::Buffer(HostBuffer::pod(&voxel_grid(frame, data.lights.len()))),
    );
    let f4 = |v: &[[f32; 4]]| HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(v)));
    resources.insert("vox_colour".into(), f4(&grid.colour));
    resources.insert("vox_normal".into(), f4(&grid.normal));
    let padded: Vec<u32> = if list.is_empty() {
        vec![0]
    } else {
        list.to_vec()
    };
    resources.insert(
        "list".into(),
        HostResource::Buffer(HostBuffer::u32(&padded)),
    );
    resources.insert(
        "list_count".into(),
        HostResource::Buffer(HostBuffer::u32(&[list.len() as u32])),
    );
    resources.insert(
        "vox_radiance".into(),
        HostResource::Buffer(HostBuffer::zeroed(grid.colour.len() * 16, ScalarKind::F32)),
    );
    let max = ctx.limits().max_compute_workgroups_per_dimension;
    Case {
        label,
        seed,
        resources,
        passes: vec![Pass {
            label: "voxel_light".into(),
            entry: "main".into(),
            bindings: DECL.bind_by_name(),
            workgroups: Workgroups::Direct(grid_for(padded.len() as u64, 64, max)),
        }],
        checks: vec![Check {
            resource: "vox_radiance".into(),
            output: "vox_radiance",
            indexing: Indexing::Morton {
                n: grid.n,
                components: 4,
            },
        }],
        effective_bytes: list.len() as u64 * 52,
    }
}

/// Light a voxelized scene on the GPU: the radiance grid (Morton order), the mip chain's input.
pub fn light_on_gpu(
    ctx: &GpuContext,
    data: &SceneData,
    grid: &Grid,
    list: &[u32],
    frame: &VoxelFrame,
) -> anyhow::Result<Vec<[f32; 4]>> {
    light_placed_on_gpu(ctx, data, grid, list, frame, glam::Mat4::IDENTITY)
}

/// [`light_on_gpu`] for a grid placed in the world by `world_from_grid` (an instance's own hierarchy,
/// lit where it stands without re-voxelizing); the identity is a world-space grid.
pub fn light_placed_on_gpu(
    ctx: &GpuContext,
    data: &SceneData,
    grid: &Grid,
    list: &[u32],
    frame: &VoxelFrame,
    world_from_grid: glam::Mat4,
) -> anyhow::Result<Vec<[f32; 4]>> {
    let mut case = case_for(ctx, data, grid, list, frame, "voxel_light".into(), 0);
    if world_from_grid != glam::Mat4::IDENTITY {
        let placed = voxel_grid(frame, data.lights.len()).placed(world_from_grid);
        case.resources.insert(
            "grid".into(),
            HostResource::Buffer(HostBuffer::pod(&placed)),
        );
    }
    let out = run(
        ctx,
        &DECL.shader()?,
        DECL.name,
        &case.resources,
        &case.passes,
        &["vox_radiance"],
    )?;
    Ok(bytemuck::cast_slice(&out.buffer("vox_radiance").bytes).to_vec())
}

/// Mirror radiance grid and bounds.
pub fn mirror_radiance(data: &Resources) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let b = |n: &str| data[n].buffer().expect("buffer");
    let grid: VoxelGrid = *bytemuck::from_bytes(&b("grid").bytes);
    let nodes: &[GpuNode] = bytemuck::cast_slice(&b("nodes").bytes);
    let tris: &[GpuTriangle] = bytemuck::cast_slice(&b("triangles").bytes);
    let lights: &[GpuLight] = bytemuck::cast_slice(&b("lights").bytes);
    let lights = &lights[..grid.size[1] as usize];
    let colour: &[[f32; 4]] = bytemuck::cast_slice(&b("vox_colour").bytes);
    let normal: &[[f32; 4]] = bytemuck::cast_slice(&b("vox_normal").bytes);
    let count = b("list_count").as_u32()[0] as usize;
    let mut out = vec![[0.0f32; 4]; colour.len()];
    let mut bound = vec![[0.0f32; 4]; colour.len()];
    for &v in &b("list").as_u32()[..count] {
        let (l, e) = light_voxel(
            &grid,
            nodes,
            tris,
            lights,
            colour[v as usize],
            normal[v as usize],
            v,
        );
        out[v as usize] = l;
        bound[v as usize] = e;
    }
    (out, bound)
}

pub struct VoxelLight;

const SIDES: [u32; 3] = [16, 32, 64];

impl Kernel for VoxelLight {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (scene, label) = generated_scene(seed, index);
        let side = SIDES[(index / 4) % SIDES.len()];
        let (grid, list, frame) =
            voxelize_on_gpu(ctx, &scene, side).expect("generated grids voxelize");
        let data = SceneData::new(&scene);
        let mut case = case_for(
            ctx,
            &data,
            &grid,
            &list,
            &frame,
            format!("{label}, {side}^3"),
            seed,
        );
        if index % 4 == 3 {
            // The grid placed by a rigid transform about its centre (rotation up to ~30 degrees about
            // a seeded axis, uniform scale 0.9-1.1, a shift of up to a tenth of the grid): an
            // instance's own hierarchy lit where it stands.
            use rand::{Rng, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x51ac ^ index as u64);
            let extent = frame.voxel * frame.side as f32;
            let centre = frame.origin + glam::Vec3::splat(0.5 * extent);
            let axis = glam::Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(0.1..1.0),
            )
            .normalize();
            let m = glam::Mat4::from_translation(
                centre
                    + glam::Vec3::new(
                        rng.random_range(-0.1..0.1),
                        rng.random_range(-0.1..0.1),
                        rng.random_range(-0.1..0.1),
                    ) * extent,
            ) * glam::Mat4::from_axis_angle(axis, rng.random_range(0.1..0.5))
                * glam::Mat4::from_scale(glam::Vec3::splat(rng.random_range(0.9..1.1)))
                * glam::Mat4::from_translation(-centre);
            let placed = voxel_grid(&frame, data.lights.len()).placed(m);
            case.resources.insert(
                "grid".into(),
                HostResource::Buffer(HostBuffer::pod(&placed)),
            );
            case.label.push_str(", placed by a rigid transform");
        }
        case
    }
    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        // Scene-scale arithmetic: no subnormals arise, one mode serves both.
        let (l, e) = mirror_radiance(data);
        let f = |v: &[[f32; 4]]| HostBuffer::f32(bytemuck::cast_slice(v));
        BTreeMap::from([
            ("vox_radiance".to_string(), f(&l)),
            (bound_name("vox_radiance"), f(&e)),
        ])
    }
}
