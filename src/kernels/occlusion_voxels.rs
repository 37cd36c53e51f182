//! Declaration of `kernels/occlusion_voxels.wgsl` (mirror: `vxgi_cpu_mirror::occlusion_voxels`): LRSM's
//! binary occlusion voxels (one byte per voxel, four per u32 word) and their mips, from the voxelized
//! grid. Verified level by level: level 0 from the grid, level k from the GPU's level k - 1.
use crate::grids::{generate, Grid, Pattern};
use std::collections::BTreeMap;
use vxgi_cpu_mirror::occlusion_voxels::{binarize, level_words, reduce, Coverage};
use vxgi_harness::run::{run, View};
use vxgi_harness::{
    Case, Check, DispatchRule, FloatMode, GpuContext, HostBuffer, HostResource, Indexing, Kernel,
    KernelDecl, Output, Resources, ScalarKind, Shader, Tolerance,
};

pub const WGSL: &str = include_str!("../../kernels/occlusion_voxels.wgsl");

pub static DECL: KernelDecl = KernelDecl {
    name: "occlusion_voxels",
    wgsl_path: "kernels/occlusion_voxels.wgsl",
    wgsl: WGSL,
    includes: &[],
    entry: "binarize",
    inputs: &["vox_colour", "src"],
    // Integers only: bit for bit.
    outputs: &[
        Output {
            binding: "occ0",
            tolerance: Tolerance::Exact,
        },
        Output {
            binding: "dst",
            tolerance: Tolerance::Exact,
        },
    ],
    dispatch: DispatchRule::PerElement { binding: "occ0" },
    mirror: "vxgi_cpu_mirror::occlusion_voxels::{binarize, reduce}",
    summary: "LRSM binary occlusion voxels, 1 byte per voxel packed 4 per u32 (no atomics), and their mips: mean of 8 children rounded half up = solid fraction (LRSM 3.2, 5), or (entry reduce_surface) CPRC's surface coverage min(1, sum/4)",
};

/// Host resource of level `k`.
pub fn level_name(k: u32) -> String {
    format!("occ_{k}")
}

/// The reduce entry point of a coverage rule.
pub fn reduce_entry(coverage: Coverage) -> &'static str {
    match coverage {
        Coverage::Volume => "reduce",
        Coverage::Surface => "reduce_surface",
    }
}

/// Resources and passes for the whole pyramid of `grid` (side >= 2, a power of two), mips by
/// `coverage`'s rule.
pub fn case_for(
    shader: &Shader,
    ctx: &GpuContext,
    grid: &Grid,
    coverage: Coverage,
    label: String,
    seed: u64,
) -> Case {
    let n = grid.n;
    let mut resources = Resources::new();
    resources.insert(
        "vox_colour".into(),
        HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(&grid.colour))),
    );
    let levels = n.trailing_zeros();
    let words: Vec<usize> = (0..=levels)
        .map(|k| level_words(((n >> k) as u64).pow(3)))
        .collect();
    for (k, &w) in (0u32..).zip(&words) {
        resources.insert(
            level_name(k),
            HostResource::Buffer(HostBuffer::zeroed(w * 4, ScalarKind::U32)),
        );
    }
    let mut passes = vec![DECL.pass(
        shader,
        ctx,
        "binarize".into(),
        vec![
            ("vox_colour".into(), View::Buffer("vox_colour".into())),
            ("occ0".into(), View::Buffer(level_name(0))),
        ],
        words[0] as u64,
    )];
    let mut checks = vec![Check {
        resource: level_name(0),
        output: "occ0",
        indexing: Indexing::Linear,
    }];
    for k in 1..=levels {
        let mut pass = DECL.pass(
            shader,
            ctx,
            format!("reduce level {k}"),
            vec![
                ("src".into(), View::Buffer(level_name(k - 1))),
                ("dst".into(), View::Buffer(level_name(k))),
            ],
            words[k as usize] as u64,
        );
        pass.entry = reduce_entry(coverage).into();
        passes.push(pass);
        checks.push(Check {
            resource: level_name(k),
            output: "dst",
            indexing: Indexing::Linear,
        });
    }
    let effective =
        (grid.colour.len() * 16) as u64 + words.iter().map(|&w| w as u64 * 4).sum::<u64>() * 2;
    Case {
        label,
        seed,
        resources,
        passes,
        checks,
        effective_bytes: effective,
    }
}

/// The occlusion pyramid of `grid` on the GPU, mips by `coverage`'s rule: every level's words.
pub fn occlusion_on_gpu(
    ctx: &GpuContext,
    grid: &Grid,
    coverage: Coverage,
) -> anyhow::Result<Vec<Vec<u32>>> {
    let shader = DECL.shader()?;
    let case = case_for(&shader, ctx, grid, coverage, "occlusion".into(), 0);
    let names: Vec<String> = (0..=grid.n.trailing_zeros()).map(level_name).collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let out = run(
        ctx,
        &shader,
        DECL.name,
        &case.resources,
        &case.passes,
        &refs,
    )?;
    Ok(names
        .iter()
        .map(|n| out.buffer(n).as_u32().to_vec())
        .collect())
}

pub struct OcclusionVoxels;

impl Kernel for OcclusionVoxels {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let n = 2u32 << (index % 7); // 2 .. 128
        let pattern = Pattern::family(index, n);
        let case_seed = seed
            .wrapping_mul(0x9e37_79b9_7f4a_7c15)
            .wrapping_add(index as u64);
        let grid = generate(n, pattern, case_seed);
        // Every other case by surface coverage (the sides cycle by 7, so both rules meet every side).
        let coverage = if index % 2 == 1 {
            Coverage::Surface
        } else {
            Coverage::Volume
        };
        case_for(
            shader,
            ctx,
            &grid,
            coverage,
            format!("#{index} {n}^3 {pattern:?} {coverage:?} coverage"),
            seed,
        )
    }

    fn mirror(
        &self,
        case: &Case,
        data: &Resources,
        mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        let colour: &[[f32; 4]] =
            bytemuck::cast_slice(&data["vox_colour"].buffer().expect("vox_colour").bytes);
        let mut out = BTreeMap::new();
        out.insert(
            level_name(0),
            HostBuffer::u32(&binarize(colour, mode == FloatMode::FlushToZero)),
        );
        // The rule the case's reduce passes run.
        let coverage = if case.passes.iter().any(|p| p.entry == "reduce_surface") {
            Coverage::Surface
        } else {
            Coverage::Volume
        };
        for k in 1..case.checks.len() as u32 {
            let src = data[&level_name(k - 1)].buffer().expect("level").as_u32();
            let words = data[&level_name(k)].buffer().expect("level").as_u32().len();
            out.insert(
                level_name(k),
                HostBuffer::u32(&reduce(src, words, coverage)),
            );
        }
        out
    }
}
