//! Declaration of `kernels/lit_cells.wgsl` (mirror: `vxgi_cpu_mirror::lit_cells`): the light views'
//! lit RSM texels in the occlusion pyramid's own cells, where lrsm's gather reads a sample's light.
//! Level 0 cleared, then injected view by view (each view's RSM as `reflective_shadow_map` wrote
//! it) in fixed point, resolved to floats, then each level above reduced from the one below.
//! Verified level by level: level 0 from the case's RSMs, level k from the GPU's level k - 1.
use super::voxelize::VoxelFrame;
use crate::lrsm::Rsm;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::lit_cells::{inject, reduce, LitGrid, RsmRef};
use vxgi_cpu_mirror::reflective_shadow_map::GpuView;
use vxgi_harness::bound_name;
use vxgi_harness::prelude::*;
use vxgi_harness::run::{Pass, View};

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "lit_cells",
    includes: &[super::reflective_shadow_map::LRSM_VIEW, super::MORTON],
    entry: "inject",
    inputs: &["grid", "view", "rsm_radiance", "rsm_normal", "rsm_depth", "src"],
    // Level 0: exact fixed-point sums, so each piece's arithmetic and quantum, the resolve's
    // roundings and the area weight's product, and whole pieces whose cell the rounding may
    // change, per float by the mirror;
    // levels above: 8 adds of the GPU's level below (8 ULP of the summed magnitudes).
    outputs: &[
        Output {
            binding: "cells",
            tolerance: Tolerance::MirrorBound,
        },
        Output {
            binding: "dst",
            tolerance: Tolerance::MirrorBound,
        },
    ],
    dispatch: DispatchRule::PerElement { binding: "rsm_depth" },
    mirror: "vxgi_cpu_mirror::lit_cells::{inject, reduce}",
    summary: "the light views' lit RSM texels in the occlusion pyramid's cells: per cell area-weighted radiance, area and normal sums (exact 64-bit fixed-point adds, resolved to floats, area and normal weighted by 1 / the lights reaching the cell), summed up the levels (lrsm's light where its occlusion is)",
);

/// Floats a cell holds (two vec4: area-weighted rgb and area, area-weighted normal and 0).
pub const CELL_FLOATS: usize = 8;

/// Host resource of level `l`.
pub fn level_name(l: u32) -> String {
    format!("lit_{l}")
}

/// Cells of level `l` of a grid of side `side`.
pub fn level_cells(side: u32, l: u32) -> usize {
    ((side >> l) as usize).pow(3)
}

/// The finest lit table a pipeline builds: 128^3 cells (64 MiB at level 0, 73 MiB with its levels,
/// within WebGPU's default 128 MiB binding). A finer voxel grid's samples below it read it (their
/// occlusion at the voxels' resolution, their light at this one's).
pub const MAX_SIDE: u32 = 128;

/// The lit table over a voxel grid: its cells those of the grid's occlusion level whose side is at
/// most `max_side` (a power of two); and that level (the gather's `lit_base`).
pub fn grid_of(frame: &VoxelFrame, max_side: u32) -> (LitGrid, u32) {
    let side = table_side(frame.side, max_side);
    let base = (frame.side / side).trailing_zeros();
    let grid = LitGrid {
        origin: [
            frame.origin.x,
            frame.origin.y,
            frame.origin.z,
            frame.voxel * (1u32 << base) as f32,
        ],
        size: [frame.side >> base, 0, 0, 0],
        // Unit 1 until a frame sets its own (`radiance_unit`).
        scale: vxgi_cpu_mirror::lit_cells::radiance_unit(1.0),
    };
    (grid, base)
}

/// The lit table's side over a voxel grid of side `voxels`, its cap `max_side`.
pub fn table_side(voxels: u32, max_side: u32) -> u32 {
    voxels.min(max_side.max(1))
}

/// Bytes of every level of a grid of side `side`.
pub fn pyramid_bytes(side: u32) -> u64 {
    (0..=side.trailing_zeros())
        .map(|l| level_cells(side, l) as u64 * CELL_FLOATS as u64 * 4)
        .sum()
}

/// Bytes of the high words of level 0's fixed-point sums (`lit_hi`: a word per float of level 0).
pub fn high_word_bytes(side: u32) -> u64 {
    level_cells(side, 0) as u64 * CELL_FLOATS as u64 * 4
}

/// Every buffer the lit cells hold: the levels and level 0's high words.
pub fn table_bytes(side: u32) -> u64 {
    pyramid_bytes(side) + high_word_bytes(side)
}

/// The reflected radiance of a white surface facing the light at the farthest point of `bounds`
/// from it (a directional light's: I / pi everywhere), the largest over `lights`: the scale of the
/// light a frame's surfaces reflect.
pub fn typical_radiance(
    lights: &[vxgi_cpu_mirror::direct_light::GpuLight],
    bounds: (glam::Vec3, glam::Vec3),
) -> f32 {
    use vxgi_cpu_mirror::direct_light::DIRECTIONAL;
    lights
        .iter()
        .map(|l| {
            let i = l.intensity[0].max(l.intensity[1]).max(l.intensity[2]) / std::f32::consts::PI;
            if l.position[3] == DIRECTIONAL {
                return i;
            }
            let p = glam::Vec3::new(l.position[0], l.position[1], l.position[2]);
            let far = (p - bounds.0).abs().max((p - bounds.1).abs()).length();
            i / (far * far).max(f32::MIN_POSITIVE)
        })
        .fold(0.0f32, f32::max)
}

/// The radiance unit of a frame's lit cells (the grid's `scale`) for `lights` over scene `bounds`:
/// [`typical_radiance`]. Nearer surfaces of a point or spot light reflect (far / d)^2 times that: a
/// piece is clamped at 2^24 units (a piece of one face nearer than far / 4096); the quantum, 2^-24
/// of the unit, is far below any light the image shows.
pub fn radiance_unit(
    lights: &[vxgi_cpu_mirror::direct_light::GpuLight],
    bounds: (glam::Vec3, glam::Vec3),
) -> [f32; 4] {
    vxgi_cpu_mirror::lit_cells::radiance_unit(typical_radiance(lights, bounds))
}

/// The names an inject pass binds for one light view: its view and its RSM's three buffers.
pub struct ViewNames {
    pub view: String,
    pub rsm: [String; 3],
}

fn buf(n: &str) -> View {
    View::Buffer(n.to_string())
}

/// Where a grid's levels live: each in its own buffer (`level_name`, the verified cases), or as
/// windows of one buffer, every level in turn (a pipeline's: the gather binds that buffer whole).
#[derive(Clone, Copy)]
pub enum Levels<'a> {
    Own,
    Windows { buffer: &'a str, side: u32 },
}

impl Levels<'_> {
    /// Level `l`'s view.
    pub fn view(&self, l: u32) -> View {
        match *self {
            Levels::Own => buf(&level_name(l)),
            Levels::Windows { buffer, side } => {
                let first: usize = (0..l).map(|k| level_cells(side, k)).sum();
                let bytes = (CELL_FLOATS * 4) as u64;
                View::BufferRange {
                    name: buffer.to_string(),
                    offset: first as u64 * bytes,
                    size: level_cells(side, l) as u64 * bytes,
                }
            }
        }
    }
}

/// Each level's first cell when the levels are windows of one buffer (the gather's `lit_offsets`).
pub fn level_offsets(side: u32) -> Vec<u32> {
    (0..=side.trailing_zeros())
        .map(|l| (0..l).map(|k| level_cells(side, k) as u32).sum())
        .collect()
}

/// The pass that clears level 0 of a grid of side `side`.
pub fn clear_pass(shader: &Shader, ctx: &GpuContext, side: u32, levels: Levels) -> Pass {
    let mut clear = DECL.pass(
        shader,
        ctx,
        "clear level 0".into(),
        vec![
            ("cells".into(), levels.view(0)),
            ("hi".into(), buf(HIGH_WORDS)),
        ],
        level_cells(side, 0) as u64,
    );
    clear.entry = "clear".into();
    clear
}

/// The pass that injects light view `k` (`names`: what it reads; its RSM of side `rsm_side`).
pub fn inject_pass(
    shader: &Shader,
    ctx: &GpuContext,
    k: usize,
    names: &ViewNames,
    rsm_side: u32,
    levels: Levels,
) -> Pass {
    DECL.pass(
        shader,
        ctx,
        format!("inject light view {k}"),
        vec![
            ("grid".into(), buf("lit_grid")),
            ("view".into(), buf(&names.view)),
            ("rsm_radiance".into(), buf(&names.rsm[0])),
            ("rsm_normal".into(), buf(&names.rsm[1])),
            ("rsm_depth".into(), buf(&names.rsm[2])),
            ("cells".into(), levels.view(0)),
            ("hi".into(), buf(HIGH_WORDS)),
        ],
        (rsm_side as u64).pow(2),
    )
}

/// The pass that turns level 0's fixed-point sums into floats (after the last inject).
pub fn resolve_pass(shader: &Shader, ctx: &GpuContext, side: u32, levels: Levels) -> Pass {
    let mut resolve = DECL.pass(
        shader,
        ctx,
        "resolve level 0".into(),
        vec![
            ("grid".into(), buf("lit_grid")),
            ("cells".into(), levels.view(0)),
            ("hi".into(), buf(HIGH_WORDS)),
        ],
        level_cells(side, 0) as u64,
    );
    resolve.entry = "resolve".into();
    resolve
}

/// The passes that reduce every level above 0 of a grid of side `side`.
pub fn reduce_passes(shader: &Shader, ctx: &GpuContext, side: u32, levels: Levels) -> Vec<Pass> {
    let mut out = Vec::new();
    for l in 1..=side.trailing_zeros() {
        let mut pass = DECL.pass(
            shader,
            ctx,
            format!("reduce level {l}"),
            vec![
                ("src".into(), levels.view(l - 1)),
                ("dst".into(), levels.view(l)),
            ],
            level_cells(side, l) as u64,
        );
        pass.entry = "reduce".into();
        out.push(pass);
    }
    out
}

/// Every level of a grid of side `side` in one buffer, zeroed (a pipeline's table before its passes
/// fill it; `Levels::Windows` names its levels).
pub fn zeroed_table(side: u32) -> HostBuffer {
    HostBuffer::zeroed(pyramid_bytes(side) as usize, ScalarKind::F32)
}

/// Host resource of level 0's high words.
pub const HIGH_WORDS: &str = "lit_hi";

/// The grid itself (`lit_grid`) and level 0's high words (`lit_hi`, zeroed).
pub fn grid_resource(grid: &LitGrid) -> Resources {
    let hi = HostBuffer::zeroed(high_word_bytes(grid.size[0]) as usize, ScalarKind::U32);
    Resources::from([
        ("lit_grid".to_string(), HostBuffer::pod(grid).into()),
        (HIGH_WORDS.to_string(), hi.into()),
    ])
}

/// The grid's resources: `lit_grid` and every level zeroed, each its own buffer.
pub fn resources(grid: &LitGrid) -> Resources {
    let side = grid.size[0];
    let mut r = grid_resource(grid);
    for l in 0..=side.trailing_zeros() {
        let n = level_cells(side, l) * CELL_FLOATS;
        r.insert(
            level_name(l),
            HostBuffer::zeroed(n * 4, ScalarKind::F32).into(),
        );
    }
    r
}

/// A verifiable case: `views` with their RSMs, each its own resources.
pub fn case_for(
    shader: &Shader,
    ctx: &GpuContext,
    grid: &LitGrid,
    views: &[GpuView],
    rsms: &[Rsm],
    label: String,
    seed: u64,
) -> Case {
    let side = grid.size[0];
    let mut resources = resources(grid);
    let mut names = Vec::new();
    for (k, (v, rsm)) in views.iter().zip(rsms).enumerate() {
        let n = ViewNames {
            view: format!("view_{k}"),
            rsm: ["radiance", "normal", "depth"].map(|s| format!("rsm_{s}_{k}")),
        };
        resources.insert(n.view.clone(), HostBuffer::pod(v).into());
        resources.insert(
            n.rsm[0].clone(),
            HostBuffer::f32(bytemuck::cast_slice(&rsm.radiance)).into(),
        );
        resources.insert(
            n.rsm[1].clone(),
            HostBuffer::f32(bytemuck::cast_slice(&rsm.normal)).into(),
        );
        resources.insert(n.rsm[2].clone(), HostBuffer::f32(&rsm.depth).into());
        names.push((n, rsm.side));
    }
    let mut passes = vec![clear_pass(shader, ctx, side, Levels::Own)];
    for (k, (n, rsm_side)) in names.iter().enumerate() {
        passes.push(inject_pass(shader, ctx, k, n, *rsm_side, Levels::Own));
    }
    passes.push(resolve_pass(shader, ctx, side, Levels::Own));
    passes.extend(reduce_passes(shader, ctx, side, Levels::Own));
    let mut checks = vec![Check {
        resource: level_name(0),
        ..Check::of("cells", Indexing::Linear)
    }];
    for l in 1..=side.trailing_zeros() {
        checks.push(Check {
            resource: level_name(l),
            ..Check::of("dst", Indexing::Linear)
        });
    }
    let texels: u64 = rsms.iter().map(|r| (r.side as u64).pow(2)).sum();
    Case {
        label,
        seed,
        resources,
        passes,
        checks,
        effective_bytes: texels * 36 + pyramid_bytes(side) * 2 + high_word_bytes(side) * 2,
    }
}

fn rsm_refs(rsms: &[Rsm]) -> Vec<RsmRef<'_>> {
    rsms.iter()
        .map(|r| RsmRef {
            side: r.side,
            radiance: &r.radiance,
            normal: &r.normal,
            depth: &r.depth,
        })
        .collect()
}

/// Every level (level 0 first, 8 floats a cell) by the mirror.
pub fn lit_mirror(grid: &LitGrid, views: &[GpuView], rsms: &[Rsm]) -> Vec<Vec<f32>> {
    vxgi_cpu_mirror::lit_cells::pyramid(grid, views, &rsm_refs(rsms)).0
}

/// Every level (level 0 first) on the GPU.
pub fn lit_on_gpu(
    ctx: &GpuContext,
    grid: &LitGrid,
    views: &[GpuView],
    rsms: &[Rsm],
) -> anyhow::Result<Vec<Vec<f32>>> {
    let shader = DECL.shader()?;
    let case = case_for(&shader, ctx, grid, views, rsms, "lit cells".into(), 0);
    let names: Vec<String> = (0..=grid.size[0].trailing_zeros())
        .map(level_name)
        .collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let out = case.run(ctx, &shader, DECL.name, &refs)?;
    Ok(names
        .iter()
        .map(|n| out.buffer(n).as_f32().to_vec())
        .collect())
}

pub struct LitCells;

impl Kernel for LitCells {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    /// A generated scene's light views (one to three of them, RSM side 16..64) over a grid of side
    /// 4..32 fitted to the scene's bounds; the radiance unit at the brightest texel, or far below it;
    /// the area weight of one light or of three; a NaN and an infinite radiance in every fifth case.
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        use super::reflective_shadow_map::{case_views, rsm_mirror};
        let (scene, label) = super::gbuffer::generated_scene(seed, index);
        let data = crate::trace::SceneData::new(&scene);
        let rsm_side = [16u32, 32, 64][index % 3];
        let side = 4u32 << (index % 4);
        let (_, all) = case_views(&data, rsm_side);
        let count = 1 + index % 3.min(all.len());
        let views: Vec<_> = all
            .iter()
            .cycle()
            .skip(index)
            .take(count.min(all.len()))
            .collect();
        let mut rsms: Vec<Rsm> = views.iter().map(|v| rsm_mirror(&data, v)).collect();
        // Hard values in every fifth case: a lit texel whose red is NaN (it adds no light) and one
        // whose green is infinite (clamped as the largest piece).
        if index % 5 == 4 {
            let lit: Vec<usize> = (0..rsms[0].radiance.len())
                .filter(|&m| rsms[0].radiance[m][3] > 0.5)
                .take(2)
                .collect();
            if let [a, b] = lit[..] {
                rsms[0].radiance[a][0] = f32::NAN;
                rsms[0].radiance[b][1] = f32::INFINITY;
            }
        }
        let (lo, hi) = data.bounds;
        let extent = (hi - lo).max_element().max(1e-3);
        let frame = VoxelFrame {
            origin: lo,
            voxel: extent / side as f32,
            side,
        };
        let mut gpu_views: Vec<GpuView> = views.iter().map(|v| v.view).collect();
        // The radiance unit at the RSMs' brightest texel; every fourth case 2^-20 of it, so that the
        // sums pass the low word and carry into the high one.
        let peak = rsms
            .iter()
            .flat_map(|r| r.radiance.iter())
            .map(|c| c[0].max(c[1]).max(c[2]))
            .filter(|c| c.is_finite())
            .fold(0.0f32, f32::max);
        let mut grid = grid_of(&frame, side).0;
        grid.scale = vxgi_cpu_mirror::lit_cells::radiance_unit(if index % 4 == 3 {
            peak * 2f32.powi(-20)
        } else {
            peak
        });
        // Every third case weighs area and normal as a frame of more lights than the cells' masks
        // hold does (one weight, 1/3: not a power of two, so the resolve rounds once more); every
        // other third per cell, each view a light of its own (up to three lights reaching a cell).
        match index % 3 {
            1 => vxgi_cpu_mirror::lit_cells::weigh_lights(&mut grid, 3, 40),
            2 => {
                vxgi_cpu_mirror::lit_cells::weigh_lights(
                    &mut grid,
                    gpu_views.len(),
                    gpu_views.len(),
                );
                for (j, v) in gpu_views.iter_mut().enumerate() {
                    v.info[1] = j as u32;
                }
            }
            _ => {}
        }
        case_for(
            shader,
            ctx,
            &grid,
            &gpu_views,
            &rsms,
            format!(
                "{label}, {count} light views of {rsm_side}^2 into {side}^3, area weight {}",
                if grid.size[1] == 1 {
                    "per cell".to_string()
                } else {
                    grid.scale[2].to_string()
                }
            ),
            seed,
        )
    }

    /// Level 0 from the case's RSMs; level k from the GPU's level k - 1.
    fn mirror(&self, case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let f32s = |n: &str| data[n].buffer().expect("buffer").as_f32().to_vec();
        let f4s = |n: &str| -> Vec<[f32; 4]> { bytemuck::cast_slice(&f32s(n)).to_vec() };
        let grid: LitGrid = bytemuck::pod_read_unaligned(&data["lit_grid"].buffer().unwrap().bytes);
        let mut views = Vec::new();
        let mut rsms = Vec::new();
        for k in 0.. {
            let name = format!("view_{k}");
            let Some(v) = data.get(&name) else { break };
            let v: GpuView = bytemuck::pod_read_unaligned(&v.buffer().unwrap().bytes);
            views.push(v);
            rsms.push(Rsm {
                side: v.info[0],
                radiance: f4s(&format!("rsm_radiance_{k}")),
                normal: f4s(&format!("rsm_normal_{k}")),
                depth: f32s(&format!("rsm_depth_{k}")),
            });
        }
        let (l0, b0) = inject(&grid, &views, &rsm_refs(&rsms));
        let mut out = BTreeMap::new();
        out.insert(level_name(0), HostBuffer::f32(&l0));
        out.insert(bound_name(&level_name(0)), HostBuffer::f32(&b0));
        for l in 1..case.checks.len() as u32 {
            let below = f32s(&level_name(l - 1));
            let (level, b) = reduce(&below, &vec![0.0; below.len()]);
            out.insert(level_name(l), HostBuffer::f32(&level));
            out.insert(bound_name(&level_name(l)), HostBuffer::f32(&b));
        }
        out
    }
}
