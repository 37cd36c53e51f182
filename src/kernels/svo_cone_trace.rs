//! Declaration of `kernels/svo_cone_trace.wgsl` (mirror: `vxgi_cpu_mirror::svo_cone_trace`): the cone
//! pass of vct-svo, cone_trace's tracer reading the sparse voxel octree. A case runs the earlier stages
//! on a generated scene (G-buffer, voxelization, voxel lighting on the GPU), builds the octree of the
//! lit voxels with the mirror (the builder is verified on its own) and feeds it in.
use super::cone_trace::{
    bounded_outputs, cone_params, lit_case, shade_all, tracer_case, ConeSettings,
};
use super::sparse_voxel_octree::{to_fixed, SvoError};
use super::voxelize::VoxelFrame;
use crate::trace::SceneData;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::cone_trace::ConeParams;
use vxgi_cpu_mirror::sparse_voxel_octree::{build, capacity_bound, Fragment, Octree};
use vxgi_cpu_mirror::svo_cone_trace::{SvoParams, SvoVolume};
use vxgi_harness::{
    Case, DispatchRule, FloatMode, GpuContext, HostBuffer, HostResource, Kernel, KernelDecl,
    Output, Resources, ScalarKind, Shader, Tolerance,
};

pub static DECL: KernelDecl = KernelDecl {
    name: "svo_cone_trace",
    wgsl_path: "kernels/svo_cone_trace.wgsl",
    wgsl: include_str!("../../kernels/svo_cone_trace.wgsl"),
    includes: &[super::SVO_NODE, super::TANGENT_BASIS, super::CONE_MARCH],
    entry: "main",
    inputs: &[
        "frame", "triangles", "materials", "gb_position", "gb_normal", "gb_triangle", "gb_albedo", "cone", "cone_dirs",
        "nodes", "bricks", "svo", "aniso",
    ],
    outputs: &[
        // cone_trace's bound (see `cone_trace::MAG`): the march is the same code; the octree's sample
        // adds the conversion f32(u32) * inv_scale (two correctly rounded operations per voxel) to the
        // ~30 operations per sample the bound already covers, and the sample point's rounding is in
        // the mirror's SampleError as for the pyramid.
        Output { binding: "indirect", tolerance: Tolerance::MirrorBound },
        Output { binding: "ao", tolerance: Tolerance::MirrorBound },
    ],
    dispatch: DispatchRule::PerElement { binding: "indirect" },
    mirror: "vxgi_cpu_mirror::cone_trace::shade_pixel (volume: vxgi_cpu_mirror::svo_cone_trace::SvoVolume)",
    summary: "cone_trace's AO + diffuse + glossy cones marching the sparse voxel octree (quadrilinear brick sampling, VCT 5-7)",
};

/// Fixed-point scale of the octree's values: 2^16 steps per unit of radiance.
pub const SCALE: f32 = 65536.0;

/// Fragments of a lit voxel grid (Morton order, side `2^(depth + 1)`, voxels `(L * alpha, alpha)` as
/// voxel_light writes them): one per non-empty voxel, at the leaf lattice point of its index.
pub fn grid_fragments(radiance: &[[f32; 4]], scale: f32) -> Result<Vec<Fragment>, SvoError> {
    radiance
        .iter()
        .enumerate()
        .filter(|(_, v)| v.iter().any(|&c| c != 0.0))
        .map(|(m, v)| {
            Ok(Fragment {
                pos: vxgi_cpu_mirror::morton::decode(m as u32),
                _pad: 0,
                value: [
                    to_fixed(v[0], scale)?,
                    to_fixed(v[1], scale)?,
                    to_fixed(v[2], scale)?,
                    to_fixed(v[3], scale)?,
                ],
            })
        })
        .collect()
}

/// Cone parameters for an octree of `depth` over the voxel grid `frame` (side `2^(depth + 1)`): mip
/// levels 0..=depth.
pub fn svo_cone_params(frame: &VoxelFrame, settings: &ConeSettings) -> ConeParams {
    let mut p = cone_params(frame, settings);
    p.levels = frame.side.trailing_zeros(); // depth + 1
    p
}

/// The cone pass over a scene whose G-buffer and octree are given (values in fixed point with `scale`);
/// `aniso`: the octree's directional values (`svo_anisotropic`) for anisotropic voxels, or `None`.
#[allow(clippy::too_many_arguments)]
pub fn case_for(
    ctx: &GpuContext,
    data: &SceneData,
    gbuffer: &Resources,
    octree: &Octree,
    aniso: Option<&[[f32; 4]]>,
    scale: f32,
    params: &ConeParams,
    label: String,
    seed: u64,
) -> Case {
    let svo = SvoParams {
        depth: octree.depth,
        inv_scale: 1.0 / scale,
        anisotropic: aniso.is_some() as u32,
        _pad: 0,
    };
    // Unused when isotropic, but bound: one empty element.
    let aniso = match aniso {
        Some(a) if !a.is_empty() => a,
        _ => &[[0.0f32; 4]][..],
    };
    let volume = Resources::from([
        (
            "nodes".to_string(),
            HostResource::Buffer(HostBuffer {
                bytes: bytemuck::cast_slice(&octree.nodes).to_vec(),
                scalar: ScalarKind::U32,
            }),
        ),
        (
            "bricks".to_string(),
            HostResource::Buffer(HostBuffer::u32(&octree.bricks)),
        ),
        (
            "svo".to_string(),
            HostResource::Buffer(HostBuffer::pod(&svo)),
        ),
        (
            "aniso".to_string(),
            HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(aniso))),
        ),
    ]);
    tracer_case(ctx, &DECL, data, gbuffer, params, volume, label, seed)
}

/// Largest radiance the octree holds (allowances for rounding-decided stops scale with it).
pub fn max_radiance(bricks: &[u32], inv_scale: f32) -> f32 {
    bricks
        .chunks_exact(4)
        .map(|v| v[0].max(v[1]).max(v[2]))
        .max()
        .unwrap_or(0) as f32
        * inv_scale
}

pub fn mirror_cones(data: &Resources) -> [Vec<[f32; 4]>; 4] {
    let b = |n: &str| data[n].buffer().expect("buffer");
    let params: ConeParams = *bytemuck::from_bytes(&b("cone").bytes);
    let svo: SvoParams = *bytemuck::from_bytes(&b("svo").bytes);
    let bricks = b("bricks").as_u32();
    let volume = SvoVolume {
        p: &params,
        svo: &svo,
        nodes: bytemuck::cast_slice(&b("nodes").bytes),
        bricks,
        aniso: bytemuck::cast_slice(&b("aniso").bytes),
    };
    shade_all(data, &volume, max_radiance(bricks, svo.inv_scale))
}

pub struct SvoConeTrace;

impl Kernel for SvoConeTrace {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let c = lit_case(ctx, seed, index);
        let depth = c.frame.side.trailing_zeros() - 1;
        let frags =
            grid_fragments(&c.radiance, SCALE).expect("generated radiance fits the fixed point");
        let octree = build(depth, capacity_bound(depth, frags.len()) as u32, &frags);
        let params = svo_cone_params(&c.frame, &c.settings);
        // Every other case with anisotropic voxels (the mirror's directional values: the builder is
        // verified on its own).
        let aniso = (index % 2 == 1).then(|| {
            vxgi_cpu_mirror::svo_anisotropic::build(
                &octree.nodes,
                &octree.bricks,
                depth,
                &octree.levels,
                1.0 / SCALE,
            )
        });
        let label = format!(
            "{}, octree depth {depth}{}",
            c.label,
            if aniso.is_some() { ", anisotropic" } else { "" }
        );
        case_for(
            ctx,
            &c.data,
            &c.gbuffer,
            &octree,
            aniso.as_deref(),
            SCALE,
            &params,
            label,
            seed,
        )
    }
    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        bounded_outputs(mirror_cones(data))
    }
}
