//! Declaration of `kernels/voxelize.wgsl` (mirror: `vxgi_cpu_mirror::voxelize`): surface-sampling
//! voxelization of a scene into the dense Morton grid `surface_coverage_mip` reads, plus the list of
//! non-empty voxels. [`prepare`] puts a scene on the integer lattice the kernel samples; cases are the
//! generated scenes of [`super::gbuffer::generated_scene`] at 8^3..64^3.
use super::gbuffer::generated_scene;
use crate::grids::Grid;
use crate::scene::Scene;
use glam::Vec3;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::voxelize::{
    accumulate, occupancy, occupancy_words, resolve_grid, VoxInput, VoxTriangle, FIXED,
};
use vxgi_harness::prelude::*;
use vxgi_harness::run::{grid_for, Pass, View, Workgroups};

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "voxelize",
    includes: &[super::MORTON, super::VOX_TRIANGLE],
    entry: "splat",
    inputs: &["params", "vox_triangles", "vox_texels", "vox_lut"],
    outputs: &[
        // Integer sums of integer samples: exact in any order of the atomic additions.
        Output { binding: "acc", tolerance: Tolerance::Exact },
        // One division (2.5 ULP) then an exact power-of-two scale; integer-to-float conversions exact
        // below 2^24, one more ULP past that.
        Output { binding: "vox_colour", tolerance: Tolerance::Ulp { ulps: 4, abs_floor: 0.0 } },
        Output { binding: "vox_normal", tolerance: Tolerance::Ulp { ulps: 4, abs_floor: 0.0 } },
        // Exact; the list's order is the GPU's (atomic append): both sides are sorted before comparing.
        Output { binding: "list", tolerance: Tolerance::Exact },
        Output { binding: "list_count", tolerance: Tolerance::Exact },
        // Entry occupancy_bits: integer samples, atomicOr: exact in any order.
        Output { binding: "occupancy", tolerance: Tolerance::Exact },
    ],
    dispatch: DispatchRule::PerElement { binding: "vox_colour" },
    mirror: "vxgi_cpu_mirror::voxelize::{voxelize, occupancy}",
    summary: "surface-sampling voxelization (CPRC 3.1): mean albedo and normal per voxel, alpha 1, non-empty list; or (entry occupancy_bits) one bit per non-empty voxel",
);

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VoxParams {
    pub side: u32,
    pub triangles: u32,
    /// The voxels splat and resolve see: Morton indices from `window_first`, `window_voxels` of them.
    pub window_first: u32,
    pub window_voxels: u32,
}

impl VoxParams {
    /// The parameters for `triangles` triangles into the whole grid of side `side` (one window).
    pub fn whole(side: u32, triangles: usize) -> Self {
        Self {
            side,
            triangles: triangles as u32,
            window_first: 0,
            window_voxels: side.pow(3),
        }
    }
}

/// Where the grid sits: a cube of `side` voxels of size `voxel` from `origin` (the scene's bounding
/// box's minimum corner; the cube's side is the box's longest extent).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoxelFrame {
    pub origin: Vec3,
    pub voxel: f32,
    pub side: u32,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum VoxelizeError {
    #[error("voxels = {0}: must be a power of two in 8..=512")]
    Side(u32),
    #[error(
        "voxels = {side}: the voxel grid (colour or normal, 16 bytes per voxel) needs {bytes} bytes \
         in one buffer, past the device's max_buffer_size ({limit}); use a smaller grid"
    )]
    TooLarge { side: u32, bytes: u64, limit: u64 },
    #[error(
        "voxels = {side}: the occupancy bits need {bytes} bytes in one binding, past the device's \
         max_storage_buffer_binding_size ({limit}); use a smaller grid"
    )]
    OccupancyTooLarge { side: u32, bytes: u64, limit: u64 },
    #[error(
        "triangle {triangle} (material {material}, map_Kd {texture}): its texture coordinates \
         (u {u_span}, v {v_span}) span more texels than voxelize's 32-bit fixed point (1/16 texel) \
         holds over the triangle's samples at voxels = {side}: let one triangle span fewer repeats \
         of the texture (the limit falls as the triangle covers more voxels)"
    )]
    UvRange {
        triangle: usize,
        side: u32,
        material: String,
        texture: String,
        /// The triangle's coordinates' range, `lo..hi`, in u and in v.
        u_span: String,
        v_span: String,
    },
    #[error(
        "{triangles} triangles: voxelize's sampling passes take one invocation per triangle, \
         {groups} workgroups of 64 along x, past the device's max_compute_workgroups_per_dimension \
         ({limit}); split the mesh into [[instances]] or simplify it"
    )]
    TooManyTriangles {
        triangles: usize,
        groups: u64,
        limit: u32,
    },
}

/// sRGB8 to linear in the kernel's fixed point (x 4096, rounded).
pub fn fixed_lut() -> Vec<u32> {
    crate::trace::srgb_lut()
        .iter()
        .map(|&l| (l * FIXED).round() as u32)
        .collect()
}

/// The grid `prepare` puts around `mesh` at `side`: origin at the bounding box's low corner, a cube of
/// the box's largest extent.
pub fn frame_of(mesh: &crate::scene::Mesh, side: u32) -> VoxelFrame {
    let (lo, hi) = mesh.bounds();
    let extent = (hi - lo).max_element().max(1e-6);
    VoxelFrame {
        origin: lo,
        voxel: extent / side as f32,
        side,
    }
}

/// The scene's triangles on the kernel's lattice with the texture atlas, and the grid's frame: the
/// mirror of triangle_setup ([`super::triangle_setup::MeshInput`]) on the host.
pub fn prepare(scene: &Scene, side: u32) -> Result<(VoxInput, VoxelFrame), VoxelizeError> {
    prepare_in(scene, frame_of(&scene.mesh, side))
}

/// [`prepare`] into a given grid (e.g. one fixed across the frames of an animation: geometry outside it
/// lands in its border voxels).
pub fn prepare_in(
    scene: &Scene,
    frame: VoxelFrame,
) -> Result<(VoxInput, VoxelFrame), VoxelizeError> {
    let mesh = checked_mesh(scene, frame)?;
    Ok((mesh.mirror().0, frame))
}

/// `scene`'s mesh as triangle_setup reads it ([`checked_mesh`]) in the grid `prepare` puts around it
/// at `side`, and that grid.
pub fn mesh_input(
    scene: &Scene,
    side: u32,
) -> Result<(super::triangle_setup::MeshInput, VoxelFrame), VoxelizeError> {
    let frame = frame_of(&scene.mesh, side);
    Ok((checked_mesh(scene, frame)?, frame))
}

/// `scene`'s mesh as triangle_setup reads it in the grid `frame`, after the checks voxelize's
/// arithmetic needs: the grid's side, and every textured triangle's texture coordinates within
/// voxelize's 32-bit interpolation (`triangle_setup::uv_range_fits`, on the mirror's setup of the
/// textured triangles alone: untextured ones always fit).
pub fn checked_mesh(
    scene: &Scene,
    frame: VoxelFrame,
) -> Result<super::triangle_setup::MeshInput, VoxelizeError> {
    let side = frame.side;
    if !(8..=512).contains(&side) || !side.is_power_of_two() {
        return Err(VoxelizeError::Side(side));
    }
    let mesh = super::triangle_setup::MeshInput::of(scene, frame);
    if let Some(triangle) = mesh.uv_range_error() {
        return Err(uv_range(scene, triangle, side));
    }
    Ok(mesh)
}

/// The error naming `triangle`'s material, texture and coordinates.
fn uv_range(scene: &Scene, triangle: usize, side: u32) -> VoxelizeError {
    let mesh = &scene.mesh;
    let m = scene.materials.get(mesh.material[triangle] as usize);
    let uvs =
        mesh.triangles[triangle].map(|v| mesh.uvs.get(v as usize).copied().unwrap_or_default());
    let span = |k: usize| {
        let (lo, hi) = uvs
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), uv| {
                (lo.min(uv[k]), hi.max(uv[k]))
            });
        format!("{lo}..{hi}")
    };
    VoxelizeError::UvRange {
        triangle,
        side,
        material: m.map_or("?".into(), |m| m.name.clone()),
        texture: m
            .and_then(|m| m.diffuse_map.as_ref())
            .map_or("?".into(), |t| {
                format!("{} {}x{}", t.path.display(), t.width, t.height)
            }),
        u_span: span(0),
        v_span: span(1),
    }
}

/// Where the sampling passes' triangles come from: the host's (`prepare`, uploaded as
/// `vox_triangles`) or triangle_setup's on the GPU (`vox_triangles` and the passes' indirect
/// dispatch `vox_dispatch` written by its pass before them, in the same chain).
#[derive(Clone, Copy)]
pub enum Triangles<'a> {
    Host(&'a VoxInput),
    Setup(&'a super::triangle_setup::MeshInput),
}

impl Triangles<'_> {
    fn count(&self) -> usize {
        match self {
            Triangles::Host(i) => i.tris.len(),
            Triangles::Setup(m) => m.triangles.len(),
        }
    }

    fn texels_lut(&self) -> (&[u32], &[u32]) {
        match self {
            Triangles::Host(i) => (&i.texels, &i.lut),
            Triangles::Setup(m) => (&m.texels, &m.lut),
        }
    }

    /// That the sampling passes' workgroups along x (a triangle per invocation) are within the
    /// device's limit: an indirect dispatch (triangle_setup's) is not checked when it is recorded.
    fn check_groups(&self, ctx: &GpuContext) -> Result<(), VoxelizeError> {
        let limit = ctx.limits().max_compute_workgroups_per_dimension;
        let groups = (self.count() as u64).div_ceil(64);
        if groups > limit as u64 {
            return Err(VoxelizeError::TooManyTriangles {
                triangles: self.count(),
                groups,
                limit,
            });
        }
        Ok(())
    }

    /// The sampling passes' grid: a triangle per invocation on x, its rows on y (the largest
    /// sample count + 1): from the host's triangles, or triangle_setup's indirect dispatch.
    fn sampling_groups(&self) -> Workgroups {
        match self {
            Triangles::Host(i) => {
                Workgroups::Direct(vxgi_cpu_mirror::triangle_setup::dispatch(&i.tris))
            }
            Triangles::Setup(_) => Workgroups::Indirect {
                buffer: "vox_dispatch".into(),
                offset: 0,
            },
        }
    }

    /// What every entry's sampling binds: the parameters and (from the host) the triangles (one
    /// zero triangle when there are none: a binding is never empty).
    fn sampling_inputs(&self, side: u32) -> Resources {
        let mut r = buffers([(
            "params",
            HostBuffer::pod(&VoxParams::whole(side, self.count())),
        )]);
        if let Triangles::Host(i) = self {
            r.insert(
                "vox_triangles".into(),
                HostBuffer::structs(&super::or_one(&i.tris)).into(),
            );
        }
        r
    }
}

/// Bytes of accumulators per voxel of a window (`acc`: eight u32).
pub const ACC_BYTES: u64 = 32;

/// Bytes per voxel of each of the grids voxelize writes whole (`vox_colour`, `vox_normal`: a
/// `vec4<f32>`).
pub const GRID_BYTES: u64 = 16;

/// The voxels of one window ([`case_windowed`]) on a device with this storage-binding limit: the
/// whole grid where its accumulators fit one binding, else the largest power of two whose do (a
/// power of two divides the grid's side^3).
pub fn window_voxels(side: u32, binding_limit: u64) -> u64 {
    super::grid_window_voxels(side, binding_limit, ACC_BYTES)
}

/// Resources and passes voxelizing `tris` into a grid of side `side`, in windows that fit the
/// device's storage bindings ([`window_voxels`]).
pub fn case_for(
    ctx: &GpuContext,
    tris: Triangles,
    side: u32,
    label: String,
    seed: u64,
) -> Result<Case, VoxelizeError> {
    let window = window_voxels(side, ctx.limits().max_storage_buffer_binding_size);
    case_windowed(ctx, tris, side, window, label, seed)
}

/// [`case_for`] with windows of `window` voxels (a power of two, at most side^3): splat and resolve
/// once per window, into the one window of accumulators `acc` (window x 32 bytes, left zero by each
/// resolve) and the window's part of `vox_colour` and `vox_normal` (their parameters `params_w<k>`);
/// one window binds the buffers whole under `params`, as a chain does.
pub fn case_windowed(
    ctx: &GpuContext,
    tris: Triangles,
    side: u32,
    window: u64,
    label: String,
    seed: u64,
) -> Result<Case, VoxelizeError> {
    let voxels = (side as u64).pow(3);
    assert!(
        window.is_power_of_two() && window <= voxels,
        "a window of {window} voxels does not tile {side}^3"
    );
    let limit = ctx.limits().max_buffer_size;
    if voxels * GRID_BYTES > limit {
        return Err(VoxelizeError::TooLarge {
            side,
            bytes: voxels * GRID_BYTES,
            limit,
        });
    }
    tris.check_groups(ctx)?;
    let mut resources = tris.sampling_inputs(side);
    let (texels, lut) = tris.texels_lut();
    let v = voxels as usize;
    let (f32s, u32s) = (
        |n: usize| HostBuffer::zeroed(n * 4, ScalarKind::F32),
        |n: usize| HostBuffer::zeroed(n * 4, ScalarKind::U32),
    );
    resources.extend(buffers([
        // One window's accumulators, bound whole for every window: resolve leaves them zero.
        ("acc", u32s((window * ACC_BYTES / 4) as usize)),
        ("vox_colour", f32s(v * 4)),
        ("vox_normal", f32s(v * 4)),
        ("list", u32s(v)),
        ("list_count", u32s(1)),
        ("occupancy", u32s(occupancy_words(voxels))),
        ("vox_texels", HostBuffer::of(&super::or_one(texels))),
        ("vox_lut", HostBuffer::of(lut)),
    ]));
    let max = ctx.limits().max_compute_workgroups_per_dimension;
    let sampling = tris.sampling_groups();
    let mut passes = Vec::new();
    for k in 0..voxels / window {
        let mut bindings = DECL.bind_by_name();
        if window < voxels {
            let first = k * window;
            let params = VoxParams {
                window_first: first as u32,
                window_voxels: window as u32,
                ..VoxParams::whole(side, tris.count())
            };
            let name = format!("params_w{k}");
            resources.insert(name.clone(), HostBuffer::pod(&params).into());
            for (binding, view) in &mut bindings {
                if binding == "params" {
                    *view = View::Buffer(name.clone());
                }
            }
            let per_voxel = [("vox_colour", GRID_BYTES), ("vox_normal", GRID_BYTES)];
            super::bind_grid_window(&mut bindings, first, window, &per_voxel);
        }
        let at = if window < voxels {
            format!(" window {k}")
        } else {
            String::new()
        };
        passes.push(Pass {
            label: format!("splat{at}"),
            entry: "splat".into(),
            bindings: bindings.clone(),
            workgroups: sampling.clone(),
        });
        let resolve = grid_for(window, 64, max);
        passes.push(Pass::direct(
            format!("resolve{at}"),
            "resolve",
            bindings,
            resolve,
        ));
    }
    passes.push(occupancy_pass(sampling));
    let morton = Indexing::Morton {
        n: side,
        components: 4,
    };
    Ok(Case {
        label,
        seed,
        resources,
        passes,
        checks: vec![
            Check::of("acc", Indexing::Linear),
            Check::of("vox_colour", morton.clone()),
            Check::of("vox_normal", morton),
            Check::of("list", Indexing::Linear),
            Check::of("list_count", Indexing::Linear),
            Check::of("occupancy", Indexing::Linear),
        ],
        effective_bytes: voxels * 36 + window * ACC_BYTES + occupancy_words(voxels) as u64 * 4,
    })
}

/// The `occupancy_bits` pass, dispatched as splat (`sampling`: a triangle's rows on y).
fn occupancy_pass(sampling: Workgroups) -> Pass {
    Pass {
        label: "occupancy".into(),
        entry: "occupancy_bits".into(),
        bindings: vxgi_harness::run::bind_same_names(["params", "vox_triangles", "occupancy"]),
        workgroups: sampling,
    }
}

/// Resources and the one pass that write `tris`' occupancy bits (entry `occupancy_bits`) for a grid
/// of side `side`: binary occlusion voxels without the accumulators, which is what lets lrsm reach
/// 512^3 (16 MiB of bits where the accumulators would take 4 GiB).
pub fn occupancy_case(
    ctx: &GpuContext,
    tris: Triangles,
    side: u32,
    label: String,
    seed: u64,
) -> Result<Case, VoxelizeError> {
    let voxels = (side as u64).pow(3);
    let bytes = occupancy_words(voxels) as u64 * 4;
    let limit = ctx.limits().max_storage_buffer_binding_size;
    if bytes > limit {
        return Err(VoxelizeError::OccupancyTooLarge { side, bytes, limit });
    }
    tris.check_groups(ctx)?;
    let mut resources = tris.sampling_inputs(side);
    let zero = HostBuffer::zeroed(bytes as usize, ScalarKind::U32);
    resources.insert("occupancy".into(), zero.into());
    Ok(Case {
        label,
        seed,
        resources,
        passes: vec![occupancy_pass(tris.sampling_groups())],
        checks: vec![Check::of("occupancy", Indexing::Linear)],
        effective_bytes: tris.count() as u64 * 160 + bytes,
    })
}

/// `scene`'s occupancy bits on the GPU in the grid `prepare` puts around it at `side` (level 0 of
/// lrsm's occlusion voxels), from its mesh (triangle_setup first), and the grid's frame.
pub fn occupancy_on_gpu(
    ctx: &GpuContext,
    scene: &Scene,
    side: u32,
) -> anyhow::Result<(Vec<u32>, VoxelFrame)> {
    let (mesh, frame) = mesh_input(scene, side)?;
    let case = occupancy_case(ctx, Triangles::Setup(&mesh), side, "occupancy".into(), 0)?;
    let out = run_from_mesh(ctx, &mesh, case, &["occupancy"])?;
    Ok((out.buffer("occupancy").as_u32().to_vec(), frame))
}

/// triangle_setup over `mesh`, then `case` (voxelize's over [`Triangles::Setup`] of it), in one
/// submission; `readback` read back.
fn run_from_mesh(
    ctx: &GpuContext,
    mesh: &super::triangle_setup::MeshInput,
    case: Case,
    readback: &[&str],
) -> anyhow::Result<vxgi_harness::run::RunOutput> {
    use vxgi_harness::run::{run_chain, Stage};
    let setup = super::triangle_setup::case_for(ctx, mesh, "setup".into(), 0);
    let (setup_shader, shader) = (super::triangle_setup::DECL.shader()?, DECL.shader()?);
    let mut resources = setup.resources;
    resources.extend(case.resources);
    let stages = [
        Stage {
            shader: &setup_shader,
            kernel: super::triangle_setup::DECL.name,
            passes: &setup.passes,
        },
        Stage {
            shader: &shader,
            kernel: DECL.name,
            passes: &case.passes,
        },
    ];
    Ok(run_chain(ctx, &stages, &resources, readback)?)
}

/// [`occupancy_on_gpu`] of an input [`prepare`]d already (at `side`).
pub fn occupancy_of_input(
    ctx: &GpuContext,
    input: &VoxInput,
    side: u32,
) -> anyhow::Result<Vec<u32>> {
    let case = occupancy_case(ctx, Triangles::Host(input), side, "occupancy".into(), 0)?;
    let out = DECL.run(ctx, &case, &["occupancy"])?;
    Ok(out.buffer("occupancy").as_u32().to_vec())
}

/// Voxelize `scene` on the GPU: the level-0 grid for `surface_coverage_mip`, the non-empty voxels
/// (sorted) and the grid's frame.
pub fn voxelize_on_gpu(
    ctx: &GpuContext,
    scene: &Scene,
    side: u32,
) -> anyhow::Result<(Grid, Vec<u32>, VoxelFrame)> {
    voxelize_in_on_gpu(ctx, scene, frame_of(&scene.mesh, side))
}

/// [`voxelize_on_gpu`] into a given grid ([`prepare_in`]), from the mesh (triangle_setup first).
pub fn voxelize_in_on_gpu(
    ctx: &GpuContext,
    scene: &Scene,
    frame: VoxelFrame,
) -> anyhow::Result<(Grid, Vec<u32>, VoxelFrame)> {
    let side = frame.side;
    let mesh = checked_mesh(scene, frame)?;
    let case = case_for(ctx, Triangles::Setup(&mesh), side, "voxelize".into(), 0)?;
    let readback = ["vox_colour", "vox_normal", "list", "list_count"];
    let out = run_from_mesh(ctx, &mesh, case, &readback)?;
    let count = out.buffer("list_count").as_u32()[0] as usize;
    let mut list = out.buffer("list").as_u32()[..count].to_vec();
    list.sort_unstable();
    let grid = Grid {
        n: side,
        colour: bytemuck::cast_slice(&out.buffer("vox_colour").bytes).to_vec(),
        normal: bytemuck::cast_slice(&out.buffer("vox_normal").bytes).to_vec(),
    };
    Ok((grid, list, frame))
}

pub struct Voxelize;

const SIDES: [u32; 4] = [8, 16, 32, 64];

impl Kernel for Voxelize {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (scene, label) = generated_scene(seed, index);
        let side = SIDES[(index / 4) % SIDES.len()];
        let (input, _) = prepare(&scene, side).expect("generated sides are valid");
        // One case in eight a window at a time (eight octants), as a grid past one storage
        // binding is: the same outputs.
        if index % 8 == 5 {
            let label = format!("{label}, {side}^3 in 8 windows");
            let window = (side as u64).pow(3) / 8;
            return case_windowed(ctx, Triangles::Host(&input), side, window, label, seed)
                .expect("generated grids fit");
        }
        case_for(
            ctx,
            Triangles::Host(&input),
            side,
            format!("{label}, {side}^3"),
            seed,
        )
        .expect("generated grids fit")
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // No subnormal can arise: the smallest non-zero value is 1 / count / 4096 >= 2^-36, so the
        // flush-to-zero mode computes the same.
        let b = |n: &str| data[n].buffer().expect("buffer");
        let p: VoxParams = *bytemuck::from_bytes(&b("params").bytes);
        let tris: &[VoxTriangle] = bytemuck::cast_slice(&b("vox_triangles").bytes);
        let (colour, normal, mut list) = resolve_grid(&accumulate(
            &tris[..p.triangles as usize],
            b("vox_texels").as_u32(),
            b("vox_lut").as_u32(),
            p.side,
        ));
        // Resolve leaves every window's accumulators zero (the next window's splat, and the next
        // frame's, start from them).
        let raw = vec![0u32; b("acc").as_u32().len()];
        let count = list.len() as u32;
        list.resize(b("list").as_u32().len(), 0);
        let bits = occupancy(&tris[..p.triangles as usize], p.side);
        mirror_outputs([
            ("acc", HostBuffer::of(&raw)),
            ("vox_colour", HostBuffer::of(&colour)),
            ("vox_normal", HostBuffer::of(&normal)),
            ("list", HostBuffer::of(&list)),
            ("list_count", HostBuffer::of(&[count])),
            ("occupancy", HostBuffer::of(&bits)),
        ])
    }
    fn canonicalise(
        &self,
        resource: &str,
        data: &mut HostBuffer,
        _all: &BTreeMap<String, HostBuffer>,
    ) {
        if resource == "list" {
            let v: &mut [u32] = bytemuck::cast_slice_mut(&mut data.bytes);
            v.sort_unstable();
        }
    }
}
