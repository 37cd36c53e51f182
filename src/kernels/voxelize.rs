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
    accumulate, occupancy, occupancy_words, resolve, VoxInput, VoxTriangle, FIXED, SUB,
};
use vxgi_harness::prelude::*;
use vxgi_harness::run::{grid_for, Pass, View};

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "voxelize",
    includes: &[super::MORTON],
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
        "triangle {triangle}: its texture coordinates span too many repeats of the texture for the \
         kernel's 32-bit fixed point (1/16 texel) at voxels = {side}"
    )]
    UvRange { triangle: usize, side: u32 },
}

/// Fixed-point texture coordinates (1/16 texel) of a triangle's vertices for a `w` x `h` texture,
/// shifted by whole repeats to start near 0; `None` when interpolating them could overflow i32.
fn fixed_uvs(uv: [glam::Vec2; 3], w: u32, h: u32, samples: i32) -> Option<([i32; 4], [i32; 4])> {
    let axis = |c: [f64; 3], n: u32| -> Option<[i32; 3]> {
        let period = n as i64 * 16;
        let q = c.map(|x| (x * period as f64).round() as i64);
        let shift = q.iter().min()?.div_euclid(period) * period;
        let q = q.map(|x| x - shift);
        let span = (q[1] - q[0]).abs() + (q[2] - q[0]).abs();
        (span * samples as i64 + q[0].abs() < i32::MAX as i64).then(|| q.map(|x| x as i32))
    };
    let u = axis(uv.map(|t| t.x as f64), w)?;
    let v = axis(uv.map(|t| -(t.y as f64)), h)?;
    Some(([u[0], v[0], u[1], v[1]], [u[2], v[2], 0, 0]))
}

/// sRGB8 to linear in the kernel's fixed point (x 4096, rounded).
pub fn fixed_lut() -> Vec<u32> {
    crate::trace::srgb_lut()
        .iter()
        .map(|&l| (l * FIXED).round() as u32)
        .collect()
}

/// The scene's triangles on the kernel's lattice with the texture atlas, and the grid's frame.
/// The grid `prepare` puts around `mesh` at `side`: origin at the bounding box's low corner, a cube of
/// the box's largest extent.
pub fn frame_of(mesh: &crate::scene::Mesh, side: u32) -> VoxelFrame {
    let (lo, hi) = mesh.positions.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let extent = (hi - lo).max_element().max(1e-6);
    VoxelFrame {
        origin: lo,
        voxel: extent / side as f32,
        side,
    }
}

pub fn prepare(scene: &Scene, side: u32) -> Result<(VoxInput, VoxelFrame), VoxelizeError> {
    prepare_in(scene, frame_of(&scene.mesh, side))
}

/// [`prepare`] into a given grid (e.g. one fixed across the frames of an animation: geometry outside it
/// lands in its border voxels).
pub fn prepare_in(
    scene: &Scene,
    frame: VoxelFrame,
) -> Result<(VoxInput, VoxelFrame), VoxelizeError> {
    let side = frame.side;
    if !(8..=512).contains(&side) || !side.is_power_of_two() {
        return Err(VoxelizeError::Side(side));
    }
    let mesh = &scene.mesh;
    let (lo, voxel) = (frame.origin, frame.voxel);
    let max_q = side as i32 * SUB - 1;
    let lattice = |p: Vec3| -> [i32; 3] {
        ((p - lo) / voxel * SUB as f32)
            .round()
            .to_array()
            .map(|c| (c as i32).clamp(0, max_q))
    };
    let fixed = |v: Vec3| (v * FIXED).round().to_array().map(|c| c as i32);
    let (texels, placement) = crate::trace::texture_atlas(scene);
    let tris = mesh
        .triangles
        .iter()
        .zip(&mesh.material)
        .enumerate()
        .map(|(index, (t, &m))| {
            let p = t.map(|i| lattice(mesh.positions[i as usize]));
            let n = t.map(|i| fixed(mesh.normals[i as usize]));
            let len = |a: [i32; 3], b: [i32; 3]| {
                let d = Vec3::new(
                    (b[0] - a[0]) as f32,
                    (b[1] - a[1]) as f32,
                    (b[2] - a[2]) as f32,
                );
                d.length() / SUB as f32
            };
            let longest = len(p[0], p[1]).max(len(p[1], p[2])).max(len(p[2], p[0]));
            let samples = 2 * longest.ceil() as i32 + 1;
            let kd = scene
                .materials
                .get(m as usize)
                .map(|m| m.diffuse)
                .unwrap_or([0.8; 3]);
            let texture = placement.get(m as usize).copied().unwrap_or([0; 4]);
            let (uv_ab, uv_c) = if texture[1] == 0 {
                ([0; 4], [0; 4])
            } else {
                let uv = t.map(|i| mesh.uvs.get(i as usize).copied().unwrap_or_default());
                fixed_uvs(uv, texture[1], texture[2], samples).ok_or(VoxelizeError::UvRange {
                    triangle: index,
                    side,
                })?
            };
            let w = |a: [i32; 3], w: i32| [a[0], a[1], a[2], w];
            Ok(VoxTriangle {
                a: w(p[0], samples),
                b: w(p[1], 0),
                c: w(p[2], 0),
                na: w(n[0], 0),
                nb: w(n[1], 0),
                nc: w(n[2], 0),
                albedo: [
                    (kd[0].clamp(0.0, 1.0) * FIXED).round() as u32,
                    (kd[1].clamp(0.0, 1.0) * FIXED).round() as u32,
                    (kd[2].clamp(0.0, 1.0) * FIXED).round() as u32,
                    0,
                ],
                uv_ab,
                uv_c,
                texture,
            })
        })
        .collect::<Result<Vec<_>, VoxelizeError>>()?;
    Ok((
        VoxInput {
            tris,
            texels,
            lut: fixed_lut(),
        },
        VoxelFrame {
            origin: lo,
            voxel,
            side,
        },
    ))
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

/// Resources and passes voxelizing `input` into a grid of side `side`, in windows that fit the
/// device's storage bindings ([`window_voxels`]).
pub fn case_for(
    ctx: &GpuContext,
    input: &VoxInput,
    side: u32,
    label: String,
    seed: u64,
) -> Result<Case, VoxelizeError> {
    let window = window_voxels(side, ctx.limits().max_storage_buffer_binding_size);
    case_windowed(ctx, input, side, window, label, seed)
}

/// [`case_for`] with windows of `window` voxels (a power of two, at most side^3): splat and resolve
/// once per window, into the one window of accumulators `acc` (window x 32 bytes, left zero by each
/// resolve) and the window's part of `vox_colour` and `vox_normal` (their parameters `params_w<k>`);
/// one window binds the buffers whole under `params`, as a chain does.
pub fn case_windowed(
    ctx: &GpuContext,
    input: &VoxInput,
    side: u32,
    window: u64,
    label: String,
    seed: u64,
) -> Result<Case, VoxelizeError> {
    let tris = &input.tris;
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
    let mut resources = sampling_inputs(tris, side);
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
        ("vox_texels", HostBuffer::of(&super::or_one(&input.texels))),
        ("vox_lut", HostBuffer::of(&input.lut)),
    ]));
    let max_rows = tris.iter().map(|t| t.a[3] + 1).max().unwrap_or(1) as u32;
    let max = ctx.limits().max_compute_workgroups_per_dimension;
    let mut passes = Vec::new();
    for k in 0..voxels / window {
        let mut bindings = DECL.bind_by_name();
        if window < voxels {
            let first = k * window;
            let params = VoxParams {
                window_first: first as u32,
                window_voxels: window as u32,
                ..VoxParams::whole(side, tris.len())
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
        let splat = splat_groups(tris, max_rows);
        passes.push(Pass::direct(
            format!("splat{at}"),
            "splat",
            bindings.clone(),
            splat,
        ));
        let resolve = grid_for(window, 64, max);
        passes.push(Pass::direct(
            format!("resolve{at}"),
            "resolve",
            bindings,
            resolve,
        ));
    }
    passes.push(occupancy_pass(tris, max_rows));
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

/// The `occupancy_bits` pass over `tris`, dispatched as splat (a triangle's rows on y).
fn occupancy_pass(tris: &[VoxTriangle], max_rows: u32) -> Pass {
    let bindings = vxgi_harness::run::bind_same_names(["params", "vox_triangles", "occupancy"]);
    Pass::direct(
        "occupancy",
        "occupancy_bits",
        bindings,
        splat_groups(tris, max_rows),
    )
}

/// The sampling passes' grid: a triangle per invocation on x, its rows (at most `max_rows`) on y.
fn splat_groups(tris: &[VoxTriangle], max_rows: u32) -> [u32; 3] {
    [(tris.len() as u32).div_ceil(64).max(1), max_rows, 1]
}

/// What every entry's sampling binds: the parameters and the triangles (one zero triangle when there
/// are none: a binding is never empty).
fn sampling_inputs(tris: &[VoxTriangle], side: u32) -> Resources {
    buffers([
        (
            "params",
            HostBuffer::pod(&VoxParams::whole(side, tris.len())),
        ),
        ("vox_triangles", HostBuffer::structs(&super::or_one(tris))),
    ])
}

/// Resources and the one pass that write `input`'s occupancy bits (entry `occupancy_bits`) for a grid
/// of side `side`: binary occlusion voxels without the accumulators, which is what lets lrsm reach
/// 512^3 (16 MiB of bits where the accumulators would take 4 GiB).
pub fn occupancy_case(
    ctx: &GpuContext,
    input: &VoxInput,
    side: u32,
    label: String,
    seed: u64,
) -> Result<Case, VoxelizeError> {
    let tris = &input.tris;
    let voxels = (side as u64).pow(3);
    let bytes = occupancy_words(voxels) as u64 * 4;
    let limit = ctx.limits().max_storage_buffer_binding_size;
    if bytes > limit {
        return Err(VoxelizeError::OccupancyTooLarge { side, bytes, limit });
    }
    let mut resources = sampling_inputs(tris, side);
    let zero = HostBuffer::zeroed(bytes as usize, ScalarKind::U32);
    resources.insert("occupancy".into(), zero.into());
    let max_rows = tris.iter().map(|t| t.a[3] + 1).max().unwrap_or(1) as u32;
    Ok(Case {
        label,
        seed,
        resources,
        passes: vec![occupancy_pass(tris, max_rows)],
        checks: vec![Check::of("occupancy", Indexing::Linear)],
        effective_bytes: tris.len() as u64 * 160 + bytes,
    })
}

/// `scene`'s occupancy bits on the GPU in the grid `prepare` puts around it at `side` (level 0 of
/// lrsm's occlusion voxels), and the grid's frame.
pub fn occupancy_on_gpu(
    ctx: &GpuContext,
    scene: &Scene,
    side: u32,
) -> anyhow::Result<(Vec<u32>, VoxelFrame)> {
    let (input, frame) = prepare(scene, side)?;
    Ok((occupancy_of_input(ctx, &input, side)?, frame))
}

/// [`occupancy_on_gpu`] of an input [`prepare`]d already (at `side`).
pub fn occupancy_of_input(
    ctx: &GpuContext,
    input: &VoxInput,
    side: u32,
) -> anyhow::Result<Vec<u32>> {
    let case = occupancy_case(ctx, input, side, "occupancy".into(), 0)?;
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

/// [`voxelize_on_gpu`] into a given grid ([`prepare_in`]).
pub fn voxelize_in_on_gpu(
    ctx: &GpuContext,
    scene: &Scene,
    frame: VoxelFrame,
) -> anyhow::Result<(Grid, Vec<u32>, VoxelFrame)> {
    let side = frame.side;
    let (input, frame) = prepare_in(scene, frame)?;
    let case = case_for(ctx, &input, side, "voxelize".into(), 0)?;
    let out = DECL.run(
        ctx,
        &case,
        &["vox_colour", "vox_normal", "list", "list_count"],
    )?;
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
            return case_windowed(ctx, &input, side, (side as u64).pow(3) / 8, label, seed)
                .expect("generated grids fit");
        }
        case_for(ctx, &input, side, format!("{label}, {side}^3"), seed)
            .expect("generated grids fit")
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // No subnormal can arise: the smallest non-zero value is 1 / count / 4096 >= 2^-36, so the
        // flush-to-zero mode computes the same.
        let b = |n: &str| data[n].buffer().expect("buffer");
        let p: VoxParams = *bytemuck::from_bytes(&b("params").bytes);
        let tris: &[VoxTriangle] = bytemuck::cast_slice(&b("vox_triangles").bytes);
        let acc = accumulate(
            &tris[..p.triangles as usize],
            b("vox_texels").as_u32(),
            b("vox_lut").as_u32(),
            p.side,
        );
        let mut colour = Vec::with_capacity(acc.len());
        let mut normal = Vec::with_capacity(acc.len());
        let mut list = Vec::new();
        for (v, a) in acc.iter().enumerate() {
            let (c, n) = resolve(a);
            colour.push(c);
            normal.push(n);
            if a.count > 0 {
                list.push(v as u32);
            }
        }
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
