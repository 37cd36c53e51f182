//! Declaration of `kernels/lrsm_partition.wgsl` (mirror: `vxgi_cpu_mirror::lrsm_partition`): an RSM split
//! into depth x <n.l> layers at quarter resolution. Inputs pass [`PartitionConfig::validate`] and
//! [`Rsm::validate`] first: bad partitions and non-finite texels are errors at the API boundary.
use crate::lrsm::{synthetic_rsm, LrsmError, PartitionConfig, Rsm};
use std::collections::BTreeMap;
use vxgi_cpu_mirror::lrsm_partition::{partition, PartitionParams};
use vxgi_harness::{
    Case, Check, DispatchRule, FloatMode, GpuContext, HostBuffer, HostResource, Indexing, Kernel,
    KernelDecl, Output, Resources, ScalarKind, Shader, Tolerance,
};

pub const WGSL: &str = include_str!("../../kernels/lrsm_partition.wgsl");

pub static DECL: KernelDecl = KernelDecl {
    name: "lrsm_partition",
    wgsl_path: "kernels/lrsm_partition.wgsl",
    wgsl: WGSL,
    includes: &[],
    entry: "main",
    inputs: &["params", "depth_ranges", "rsm_radiance", "rsm_normal", "rsm_depth"],
    outputs: &[
        // Selected adds of inputs and an exact * 0.25: bit for bit.
        Output { binding: "out_radiance", tolerance: Tolerance::Exact },
        Output { binding: "out_normal", tolerance: Tolerance::Exact },
        // z' = (z - zmin) * inv_range is exact to reproduce (no add after the product), but the z'^2
        // accumulation may fuse into an FMA (WGSL allows contraction): each of 3 nonnegative partial
        // sums moves by at most 1 ULP -> 4 ULP.
        Output { binding: "out_moments", tolerance: Tolerance::Ulp { ulps: 4, abs_floor: 0.0 } },
    ],
    dispatch: DispatchRule::PerItem { what: "RSM 2x2 quad (params.layer_texels); each writes its texel in every layer" },
    mirror: "vxgi_cpu_mirror::lrsm_partition::partition",
    summary: "RSM split into depth x <n.l> layers at quarter resolution, texels merged per layer (LRSM 4.3, 5)",
};

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
        _pad: 0,
    };
    let out_len = (config.layers() as u64 * texels * 16) as usize;
    let mut resources = Resources::new();
    resources.insert(
        "params".into(),
        HostResource::Buffer(HostBuffer::pod(&params)),
    );
    resources.insert(
        "depth_ranges".into(),
        HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(
            &config.depth_ranges(),
        ))),
    );
    resources.insert(
        "rsm_radiance".into(),
        HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(&rsm.radiance))),
    );
    resources.insert(
        "rsm_normal".into(),
        HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(&rsm.normal))),
    );
    resources.insert(
        "rsm_depth".into(),
        HostResource::Buffer(HostBuffer::f32(&rsm.depth)),
    );
    for out in ["out_radiance", "out_normal", "out_moments"] {
        resources.insert(
            out.into(),
            HostResource::Buffer(HostBuffer::zeroed(out_len, ScalarKind::F32)),
        );
    }
    let bindings = DECL.bind_by_name();
    let indexing = Indexing::Grid {
        dims: [texels as u32, config.layers(), 1],
        components: 4,
    };
    Ok(Case {
        label,
        seed,
        passes: vec![DECL.pass(shader, ctx, "partition".into(), bindings, texels)],
        checks: DECL
            .outputs
            .iter()
            .map(|o| Check {
                resource: o.binding.into(),
                output: o.binding,
                indexing: indexing.clone(),
            })
            .collect(),
        effective_bytes: (rsm.radiance.len() * 36) as u64 + 3 * out_len as u64,
        resources,
    })
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

    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        let f = |n: &str| -> &[f32] { data[n].buffer().expect("buffer").as_f32() };
        let params: PartitionParams =
            *bytemuck::from_bytes(&data["params"].buffer().expect("params").bytes);
        let v4 = |n: &str| -> &[[f32; 4]] { bytemuck::cast_slice(f(n)) };
        let out = partition(
            (v4("rsm_radiance"), v4("rsm_normal"), f("rsm_depth")),
            v4("depth_ranges"),
            &params,
            mode == FloatMode::FlushToZero,
        );
        DECL.outputs
            .iter()
            .zip(out)
            .map(|(o, v)| {
                (
                    o.binding.to_string(),
                    HostBuffer::f32(bytemuck::cast_slice(&v)),
                )
            })
            .collect()
    }
}
