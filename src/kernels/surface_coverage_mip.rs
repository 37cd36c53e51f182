//! Declaration of `kernels/surface_coverage_mip.wgsl` (mirror: `vxgi_cpu_mirror::surface_coverage_mip`),
//! its generated cases, and [`MipPipeline`] for running it on a caller's own device and buffers.
use crate::grids::{generate, Grid, Pattern};
use std::collections::BTreeMap;
use vxgi_cpu_mirror::surface_coverage_mip::{reduce_level, Coverage, MipParams};
use vxgi_harness::prelude::*;
use wgpu::util::DeviceExt;

/// The WGSL source; its header comment is the binding contract.
pub const WGSL: &str = include_str!("../../kernels/surface_coverage_mip.wgsl");

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "surface_coverage_mip",
    inputs: &["params", "src_colour", "src_normal"],
    outputs: &[
        // C = sum / max(alpha_sum, 4): the sums are correctly rounded f32 adds in the mirror's order (exact
        // reproduction), the division is within 2.5 ULP (WGSL: x / y for |y| in [2^-126, 2^126], here
        // y >= 4) -> 3 ULP. Alpha (min(sum * 0.25, 1)) and volume coverage (* 0.125) are exact; the
        // property tests assert that bitwise. No absolute floor: the error is relative to the result.
        Output { binding: "dst_colour", tolerance: Tolerance::Ulp { ulps: 3, abs_floor: 0.0 } },
        // N = sum / max(alpha_sum, 4): same operations, same bound.
        Output { binding: "dst_normal", tolerance: Tolerance::Ulp { ulps: 3, abs_floor: 0.0 } },
    ],
    dispatch: DispatchRule::PerElement { binding: "dst_colour" },
    mirror: "vxgi_cpu_mirror::surface_coverage_mip::reduce_level",
    summary: "one mip level of a dense Morton-ordered voxel grid, surface- or volume-coverage alpha (CPRC 3.1)",
);

/// Bytes per voxel per buffer (one vec4<f32>).
const VOXEL_BYTES: u64 = 16;

pub fn colour_name(level: u32) -> String {
    format!("colour_{level}")
}
pub fn normal_name(level: u32) -> String {
    format!("normal_{level}")
}

/// Number of mip levels below level 0 for side `n`.
pub fn levels_below(n: u32) -> u32 {
    n.trailing_zeros()
}

/// The full chain for `grid` as one case: level 0 uploaded, levels 1..=log2(n) produced by one pass per
/// level, split into windows where a level's source is larger than one storage binding may be.
pub fn chain_case(
    shader: &Shader,
    ctx: &GpuContext,
    grid: &Grid,
    coverage: Coverage,
    label: String,
    seed: u64,
) -> Case {
    let levels = levels_below(grid.n) + 1;
    chain_case_to(shader, ctx, grid, coverage, levels, label, seed)
}

/// [`chain_case`] for levels `0..levels` only (1 ..= log2(n) + 1): the levels no cone reads are
/// neither allocated nor built (`cone_trace::pyramid_levels`).
pub fn chain_case_to(
    shader: &Shader,
    ctx: &GpuContext,
    grid: &Grid,
    coverage: Coverage,
    levels: u32,
    label: String,
    seed: u64,
) -> Case {
    let n = grid.n;
    let parents: Vec<u64> = (1..levels.clamp(1, levels_below(n) + 1))
        .map(|k| ((n >> k) as u64).pow(3))
        .collect();
    let streams = [
        super::ChainStream {
            src_binding: "src_colour",
            dst_binding: "dst_colour",
            resource: &colour_name,
        },
        super::ChainStream {
            src_binding: "src_normal",
            dst_binding: "dst_normal",
            resource: &normal_name,
        },
    ];
    let level0 = [&grid.colour, &grid.normal]
        .map(|g| HostBuffer::f32(bytemuck::cast_slice(g)))
        .to_vec();
    let params = HostBuffer::pod(&MipParams {
        coverage: coverage as u32,
    });
    let indexing = |k: u32| Indexing::Morton {
        n: n >> k,
        components: 4,
    };
    super::reduction_chain_case(
        &DECL,
        shader,
        ctx,
        &streams,
        level0,
        &parents,
        (8, VOXEL_BYTES),
        &indexing,
        vec![("params".into(), params)],
        label,
        seed,
    )
}

/// Mirror of every level of a chain case, each from the level the GPU produced before it.
pub fn chain_mirror(
    case: &Case,
    data: &Resources,
    mode: FloatMode,
) -> BTreeMap<String, HostBuffer> {
    let params: MipParams = *bytemuck::from_bytes(&data["params"].buffer().expect("params").bytes);
    let coverage = if params.coverage == 0 {
        Coverage::Surface
    } else {
        Coverage::Volume
    };
    let mut out = MirrorOutputs::new();
    for k in super::chain_levels(case, 2) {
        let src = |name: String| -> &[[f32; 4]] {
            bytemuck::cast_slice(&data[&name].buffer().expect("buffer").bytes)
        };
        let (c, n) = reduce_level(
            src(colour_name(k - 1)),
            src(normal_name(k - 1)),
            coverage,
            mode == FloatMode::FlushToZero,
        );
        out.insert(colour_name(k), HostBuffer::f32(bytemuck::cast_slice(&c)));
        out.insert(normal_name(k), HostBuffer::f32(bytemuck::cast_slice(&n)));
    }
    out
}

/// The declared kernel for `vxgi verify`: cycles through sizes 2..=64 (index % 6), grid families (index % 8)
/// and both coverages.
pub struct SurfaceCoverageMip;

impl Kernel for SurfaceCoverageMip {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let n = 2u32 << (index % 6);
        let pattern = Pattern::family(index, n);
        let coverage = if (index / 3).is_multiple_of(2) {
            Coverage::Surface
        } else {
            Coverage::Volume
        };
        let case_seed = seed
            .wrapping_mul(0x9e37_79b9_7f4a_7c15)
            .wrapping_add(index as u64);
        let grid = generate(n, pattern, case_seed);
        chain_case(
            shader,
            ctx,
            &grid,
            coverage,
            format!("#{index} {n}^3 {pattern:?} {coverage:?}"),
            seed, // reports name the run seed: `vxgi verify --seed S` reproduces case #i
        )
    }

    fn mirror(&self, case: &Case, data: &Resources, mode: FloatMode) -> MirrorOutputs {
        chain_mirror(case, data, mode)
    }
}

/// The kernel on a caller's own `wgpu::Device`: pipeline and parameter block, nothing else.
///
/// Bindings (group 0, see the WGSL header): 0 uniform `MipParams`, 1/2 `src_colour`/`src_normal`
/// (`array<vec4<f32>>`, Morton order, 8x the voxels of the destination), 3/4 `dst_colour`/`dst_normal`.
pub struct MipPipeline {
    pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    /// The WGSL's @workgroup_size, read through naga reflection (the WGSL is the source of truth).
    workgroup: u32,
}

impl MipPipeline {
    pub fn new(device: &wgpu::Device, coverage: Coverage) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("surface_coverage_mip"),
            source: wgpu::ShaderSource::Wgsl(WGSL.into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("surface_coverage_mip"),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("surface_coverage_mip params"),
            contents: bytemuck::bytes_of(&MipParams {
                coverage: coverage as u32,
            }),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let workgroup = DECL
            .shader()
            .ok()
            .and_then(|s| s.entry(DECL.entry).map(|e| e.workgroup_size[0]))
            .expect("surface_coverage_mip.wgsl parses (tested)");
        Self {
            pipeline,
            params,
            workgroup,
        }
    }

    /// Record one level: `dst` gets the parents of the voxels in `src` (colour, normal pairs).
    /// `dst_voxels` is the number of voxels bound in each `dst` binding.
    pub fn encode_level(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        src: [wgpu::BufferBinding<'_>; 2],
        dst: [wgpu::BufferBinding<'_>; 2],
        dst_voxels: u32,
    ) {
        let [sc, sn] = src;
        let [dc, dn] = dst;
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("surface_coverage_mip"),
            layout: &self.pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Buffer(sc),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Buffer(sn),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::Buffer(dc),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::Buffer(dn),
                },
            ],
        });
        let grid = vxgi_harness::run::grid_for(
            dst_voxels as u64,
            self.workgroup,
            device.limits().max_compute_workgroups_per_dimension,
        );
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("surface_coverage_mip"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(grid[0], grid[1], grid[2]);
    }
}
