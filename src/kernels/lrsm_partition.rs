//! Declaration of `kernels/lrsm_partition.wgsl` (mirror: `vxgi_cpu_mirror::lrsm_partition`): an RSM split
//! into depth x <n.l> layers at quarter resolution. Inputs pass [`PartitionConfig::validate`] and
//! [`Rsm::validate`] first: bad partitions and non-finite texels are errors at the API boundary.
use crate::lrsm::{synthetic_rsm, LrsmError, PartitionConfig, Rsm};
use vxgi_cpu_mirror::lrsm_partition::{partition, PartitionParams};
use vxgi_cpu_mirror::lrsm_prefilter::pack_stream;
use vxgi_harness::prelude::*;

vxgi_harness::bindings! {
    /// lrsm_partition's bindings: one RSM in, its layers (each RSM texel's quarter-resolution
    /// texel in every layer) out.
    pub struct Io {
        inputs: {
            params: Block<PartitionParams>,
            depth_ranges: Vec<[f32; 4]>,
            rsm_radiance: Vec<[f32; 4]>,
            rsm_normal: Vec<[f32; 4]>,
            rsm_depth: Vec<f32>,
        }
        outputs: {
            // Texels stored as binary16 pairs (common/lrsm_texel.wgsl). Radiance and normal: selected
            // adds of inputs and an exact * 0.25, bit for bit in f32, then rounded to binary16 either
            // way (WGSL leaves the direction open): 1 binary16 ULP. Moments: z' = (z - zmin) *
            // inv_range is exact to reproduce, but the z'^2 accumulation may fuse into an FMA (WGSL
            // allows contraction), moving each of 3 nonnegative partial sums by at most 1 f32 ULP ->
            // 4 f32 ULP, far less than binary16's spacing (2^13 f32 ULP), so one rounding boundary
            // at most lies between GPU and mirror: still 1 binary16 ULP.
            out_radiance: Vec<[u32; 2]> => Tolerance::Half { ulps: 1 },
            out_normal: Vec<[u32; 2]> => Tolerance::Half { ulps: 1 },
            out_moments: Vec<[u32; 2]> => Tolerance::Half { ulps: 1 },
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "lrsm_partition",
    includes: &[super::LRSM_TEXEL],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerItem { what: "RSM 2x2 quad (params.layer_texels); each writes its texel in every layer" },
    mirror: "vxgi_cpu_mirror::lrsm_partition::partition",
    summary: "RSM split into depth x <n.l> layers at quarter resolution, texels merged per layer (LRSM 4.3, 5)",
);

/// Resources and the pass for `rsm` under `config`; errors on what the kernel must not be given.
pub fn case_for(
    shader: &Shader,
    ctx: &GpuContext,
    rsm: &Rsm,
    config: &PartitionConfig,
    label: String,
    seed: u64,
) -> Result<Case, LrsmError> {
    config.validate(ctx.limits().max_storage_buffer_binding_size)?;
    if rsm.side != config.rsm_side {
        return Err(LrsmError::RsmSize(rsm.side));
    }
    rsm.validate()?;
    let texels = config.layer_texels();
    let params = PartitionParams {
        depth_slices: config.depth_slices(),
        normal_slices: config.normal_slices(),
        layer_texels: texels as u32,
        area_weights: config.area_weights as u32,
    };
    let out = vec![[0; 2]; (config.layers() as u64 * texels) as usize];
    let io = Io {
        params: Block(params),
        depth_ranges: config.depth_ranges(),
        rsm_radiance: rsm.radiance.clone(),
        rsm_normal: rsm.normal.clone(),
        rsm_depth: rsm.depth.clone(),
        out_radiance: out.clone(),
        out_normal: out.clone(),
        out_moments: out,
    };
    let indexing = Indexing::Grid {
        dims: [texels as u32, config.layers(), 1],
        components: 2,
    };
    let mut case = DECL.case_of(shader, ctx, &io, texels, label, seed);
    for o in Io::OUTPUTS {
        case = case.with_indexing(o.binding, indexing.clone());
    }
    Ok(case)
}

pub struct LrsmPartition;

/// The partitions `vxgi verify` cycles through: the paper's 2x2 and 3x2, one slice, wide overlaps.
pub fn config_for(index: usize) -> PartitionConfig {
    let (a, b, overlap) = [
        (1, 1, 0.05),
        (2, 1, 0.02),
        (0, 0, 0.0),
        (3, 2, 0.25),
        (1, 3, 0.5),
    ][index % 5];
    PartitionConfig {
        rsm_side: 4 << (index % 6),
        depth_splits: a,
        normal_splits: b,
        overlap,
        // Every other case by area: with the sides cycling by 6 and the layers by 5, both meet each.
        area_weights: index % 2 == 1,
    }
}

impl Kernel for LrsmPartition {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let config = config_for(index);
        let rsm = synthetic_rsm(config.rsm_side, &config, seed.wrapping_add(index as u64));
        let label = format!(
            "#{index} {}^2 RSM, {} layers, overlap {}",
            config.rsm_side,
            config.layers(),
            config.overlap
        );
        case_for(shader, ctx, &rsm, &config, label, seed)
            .expect("generated configurations are valid")
    }

    fn mirror(&self, _case: &Case, data: &Resources, mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(data);
        [io.out_radiance, io.out_normal, io.out_moments] = partition(
            (&io.rsm_radiance, &io.rsm_normal, &io.rsm_depth),
            &io.depth_ranges,
            &io.params.0,
            mode == FloatMode::FlushToZero,
        )
        .map(|s| pack_stream(&s));
        io.outputs()
    }
}
