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
use vxgi_harness::bindings::field;
use vxgi_harness::prelude::*;
use vxgi_harness::run::{Pass, View};

vxgi_harness::bindings! {
    /// voxel_light's bindings: the grid, the scene's BVH, triangles and lights, the voxels' albedo
    /// and normal and the list of non-empty voxels in; their radiance out.
    pub struct Io {
        inputs: {
            grid: Block<VoxelGrid>,
            nodes: Structs<GpuNode>,
            // Six vec4<f32> per triangle (`GpuTriangle`), three per light (`GpuLight`).
            triangles: Vec<[f32; 4]>,
            lights: Vec<[f32; 4]>,
            vox_colour: Vec<[f32; 4]>,
            vox_normal: Vec<[f32; 4]>,
            list: Vec<u32>,
            list_count: Vec<u32>,
        }
        outputs: {
            // Per element (see `light_voxel`): 64 ULP per light term, 8 ULP absolute on the
            // cosine; terms whose shadow ray rounding decides add their value. Alpha is copied:
            // exact (bound 0).
            vox_radiance: Vec<[f32; 4]> => Tolerance::MirrorBound
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "voxel_light",
    includes: &[super::SCENE_TYPES, super::gbuffer::BVH_TRACE, super::LIGHTS, super::MORTON],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "list" },
    mirror: "vxgi_cpu_mirror::voxel_light::light_voxel",
    summary: "direct light into the non-empty voxels, one exact shadow ray per light (CPRC 3.1 voxel illumination)",
);

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
    let scene = scene_resources(data);
    let io = Io {
        grid: Block(voxel_grid(frame, data.lights.len())),
        nodes: field(&scene, "nodes"),
        triangles: field(&scene, "triangles"),
        lights: field(&scene, "lights"),
        vox_colour: grid.colour.clone(),
        vox_normal: grid.normal.clone(),
        list: super::or_one(list),
        list_count: vec![list.len() as u32],
        vox_radiance: vec![[0.0; 4]; grid.colour.len()],
    };
    let shader = DECL.shader().expect("voxel_light.wgsl is valid");
    let elements = io.list.len() as u64;
    DECL.case_of(&shader, ctx, &io, elements, label, seed)
        .with_indexing(
            "vox_radiance",
            Indexing::Morton {
                n: grid.n,
                components: 4,
            },
        )
        .with_effective_bytes(list.len() as u64 * 52)
}

/// The voxels of one window ([`in_windows`]) on a device with this storage-binding limit: the whole
/// grid where its vec4 buffers fit one binding, else the largest power of two whose do.
pub fn window_voxels(side: u32, binding_limit: u64) -> u64 {
    super::grid_window_voxels(side, binding_limit, 16)
}

/// `case` (a whole-grid case of [`case_for`]) dispatched a window of `window` voxels at a time (a
/// power of two dividing the grid): each pass over the whole list, binding its window's part of
/// `vox_colour`, `vox_normal` and `vox_radiance` and the grid with that window (`grid_w<k>`). The
/// same outputs.
pub fn in_windows(mut case: Case, window: u64) -> Case {
    let grid: VoxelGrid =
        *bytemuck::from_bytes(&case.resources["grid"].buffer().expect("grid").bytes);
    let whole = case.passes.remove(0);
    case.passes = window_passes(&whole, grid, &mut case.resources, window);
    if case.passes.len() > 1 {
        case.label
            .push_str(&format!(", {} windows", case.passes.len()));
    }
    case
}

/// The passes of [`in_windows`]: `whole` (a pass over the grid `grid`) once per window of `window`
/// voxels, their grids (`grid_w<k>`) added to `resources`; `whole` itself where one window is the
/// grid.
pub fn window_passes(
    whole: &Pass,
    grid: VoxelGrid,
    resources: &mut Resources,
    window: u64,
) -> Vec<Pass> {
    let voxels = (grid.size[0] as u64).pow(3);
    assert!(
        window.is_power_of_two() && window <= voxels,
        "a window of {window} voxels does not tile the grid"
    );
    if window == voxels {
        return vec![whole.clone()];
    }
    (0..voxels / window)
        .map(|k| {
            let first = k * window;
            let mut g = grid;
            g.size[2] = first as u32;
            g.size[3] = window as u32;
            let name = format!("grid_w{k}");
            resources.insert(name.clone(), HostResource::Buffer(HostBuffer::pod(&g)));
            let mut pass = whole.clone();
            pass.label = format!("{} window {k}", whole.label);
            for (binding, view) in &mut pass.bindings {
                if binding == "grid" {
                    *view = View::Buffer(name.clone());
                }
            }
            let per_voxel = [("vox_colour", 16), ("vox_normal", 16), ("vox_radiance", 16)];
            super::bind_grid_window(&mut pass.bindings, first, window, &per_voxel);
            pass
        })
        .collect()
}

/// Light a voxelized scene on the GPU: the radiance grid (Morton order), the mip chain's input.
pub fn light_on_gpu(
    ctx: &GpuContext,
    data: &SceneData,
    grid: &Grid,
    list: &[u32],
    frame: &VoxelFrame,
) -> anyhow::Result<Vec<[f32; 4]>> {
    let case = case_for(ctx, data, grid, list, frame, "voxel_light".into(), 0);
    let window = window_voxels(grid.n, ctx.limits().max_storage_buffer_binding_size);
    let out = DECL.run(ctx, &in_windows(case, window), &["vox_radiance"])?;
    Ok(bytemuck::cast_slice(&out.buffer("vox_radiance").bytes).to_vec())
}

/// Mirror radiance grid and bounds.
pub fn mirror_radiance(data: &Resources) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let io = Io::read(data);
    let grid = io.grid.0;
    let tris: &[GpuTriangle] = bytemuck::cast_slice(&io.triangles);
    let lights: &[GpuLight] = bytemuck::cast_slice(&io.lights);
    let lights = &lights[..grid.size[1] as usize];
    let (colour, normal) = (&io.vox_colour, &io.vox_normal);
    let mut out = vec![[0.0f32; 4]; colour.len()];
    let mut bound = vec![[0.0f32; 4]; colour.len()];
    for &v in &io.list[..io.list_count[0] as usize] {
        let (l, e) = light_voxel(
            &grid,
            &io.nodes.0,
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
        // One case in eight a window at a time (eight octants), as a grid past one storage
        // binding is: the same outputs.
        if index % 8 == 5 {
            return in_windows(case, (side as u64).pow(3) / 8);
        }
        case
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // Scene-scale arithmetic: no subnormals arise, one mode serves both.
        let (l, e) = mirror_radiance(data);
        BTreeMap::from(bounded("vox_radiance", &l, &e))
    }
}
