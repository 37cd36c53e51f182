//! Declaration of `kernels/occlusion_voxels.wgsl` (mirror: `vxgi_cpu_mirror::occlusion_voxels`): the
//! mips of LRSM's binary occlusion voxels (level 0 one bit per voxel, written by voxelize's
//! `occupancy_bits`; levels above a byte per voxel, four per u32 word). Verified level by level:
//! level 1 from the given bits, level k from the GPU's level k - 1.
use crate::grids::{generate, Pattern};
use std::collections::BTreeMap;
use vxgi_cpu_mirror::occlusion_voxels::{binarize, level_words, reduce, reduce_bits, Coverage};
use vxgi_harness::prelude::*;
use vxgi_harness::run::View;

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "occlusion_voxels",
    entry: "reduce_bits",
    inputs: &["src"],
    // Integers only: bit for bit.
    outputs: &[Output {
        binding: "dst",
        tolerance: Tolerance::Exact,
    }],
    dispatch: DispatchRule::PerElement { binding: "dst" },
    mirror: "vxgi_cpu_mirror::occlusion_voxels::{reduce_bits, reduce}",
    summary: "mips of LRSM's binary occlusion voxels (level 0 a bit per voxel, above a byte, 4 per u32; no atomics): mean of 8 children rounded half up = solid fraction (LRSM 3.2, 5), or (entries *_surface) CPRC's surface coverage min(1, sum/4)",
);

/// Host resource of level `k`.
pub fn level_name(k: u32) -> String {
    format!("occ_{k}")
}

/// The entry point that builds level `k` (>= 1) by a coverage rule.
pub fn reduce_entry(k: u32, coverage: Coverage) -> &'static str {
    match (k, coverage) {
        (1, Coverage::Volume) => "reduce_bits",
        (1, Coverage::Surface) => "reduce_bits_surface",
        (_, Coverage::Volume) => "reduce",
        (_, Coverage::Surface) => "reduce_surface",
    }
}

/// Resources and passes for the mips of a grid of side `side` (>= 2, a power of two) whose level 0 is
/// `bits` (`vxgi_cpu_mirror::occlusion_voxels::level_words(side, 0)` words), mips by `coverage`'s
/// rule.
pub fn case_for(
    shader: &Shader,
    ctx: &GpuContext,
    bits: &[u32],
    side: u32,
    coverage: Coverage,
    label: String,
    seed: u64,
) -> Case {
    let levels = side.trailing_zeros();
    let words: Vec<usize> = (0..=levels).map(|k| level_words(side, k)).collect();
    let mut resources = Resources::from([(level_name(0), HostBuffer::of(bits).into())]);
    for (k, &w) in (1u32..).zip(&words[1..]) {
        let zero = HostBuffer::zeroed(w * 4, ScalarKind::U32);
        resources.insert(level_name(k), zero.into());
    }
    let mut passes = Vec::new();
    let mut checks = Vec::new();
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
        pass.entry = reduce_entry(k, coverage).into();
        passes.push(pass);
        checks.push(Check {
            resource: level_name(k),
            ..Check::of("dst", Indexing::Linear)
        });
    }
    let effective = words.iter().map(|&w| w as u64 * 4).sum::<u64>() * 2;
    Case {
        label,
        seed,
        resources,
        passes,
        checks,
        effective_bytes: effective,
    }
}

/// The occlusion pyramid on the GPU of a grid of side `side` whose level 0 is `bits`, mips by
/// `coverage`'s rule: every level's words (level 0 the bits as given).
pub fn occlusion_on_gpu(
    ctx: &GpuContext,
    bits: &[u32],
    side: u32,
    coverage: Coverage,
) -> anyhow::Result<Vec<Vec<u32>>> {
    let shader = DECL.shader()?;
    let case = case_for(&shader, ctx, bits, side, coverage, "occlusion".into(), 0);
    let names: Vec<String> = (1..=side.trailing_zeros()).map(level_name).collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let out = case.run(ctx, &shader, DECL.name, &refs)?;
    Ok(std::iter::once(bits.to_vec())
        .chain(names.iter().map(|n| out.buffer(n).as_u32().to_vec()))
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
            &binarize(&grid.colour, false),
            n,
            coverage,
            format!("#{index} {n}^3 {pattern:?} {coverage:?} coverage"),
            seed,
        )
    }

    /// Level 1 from the case's bits, level k from the GPU's level k - 1 (integers: no float mode).
    fn mirror(&self, case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // The rule the case's reduce passes run.
        let coverage = if case.passes.iter().any(|p| p.entry.ends_with("_surface")) {
            Coverage::Surface
        } else {
            Coverage::Volume
        };
        let mut out = BTreeMap::new();
        for k in 1..=case.checks.len() as u32 {
            let src = data[&level_name(k - 1)].buffer().expect("level").as_u32();
            let words = data[&level_name(k)].buffer().expect("level").as_u32().len();
            let level = if k == 1 {
                reduce_bits(src, words, coverage)
            } else {
                reduce(src, words, coverage)
            };
            out.insert(level_name(k), HostBuffer::u32(&level));
        }
        out
    }
}
