//! Declaration of `kernels/svo_anisotropic.wgsl` (mirror: `vxgi_cpu_mirror::svo_anisotropic`): the
//! octree's anisotropic voxels, one level per pass. A case builds an octree of generated fragments
//! (sparse_voxel_octree's families) with the mirror, fills every other level's directional values with
//! the mirror and runs one level's pass on the GPU: the kernel's contract given exact inputs.
use super::sparse_voxel_octree::generated;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::sparse_voxel_octree::{build_fitted, Octree};
use vxgi_cpu_mirror::svo_anisotropic::{self as mirror, AnisoParams, NODE_VALUES};
use vxgi_harness::compare::bound_name;
use vxgi_harness::run::run;
use vxgi_harness::{
    Case, Check, DispatchRule, FloatMode, GpuContext, HostBuffer, HostResource, Indexing, Kernel,
    KernelDecl, Output, Resources, ScalarKind, Shader, Tolerance,
};

pub static DECL: KernelDecl = KernelDecl {
    name: "svo_anisotropic",
    wgsl_path: "kernels/svo_anisotropic.wgsl",
    wgsl: include_str!("../../kernels/svo_anisotropic.wgsl"),
    includes: &[super::SVO_NODE],
    entry: "main",
    inputs: &["params", "nodes", "bricks"],
    // Non-negative values composited front to back (sqrt, a division, products and sums): within 48
    // ULP of the rows' magnitudes (the mirror's per-element bound); other levels untouched (bound 0).
    outputs: &[Output {
        binding: "aniso",
        tolerance: Tolerance::MirrorBound,
    }],
    dispatch: DispatchRule::PerElement { binding: "aniso" },
    mirror: "vxgi_cpu_mirror::svo_anisotropic::level_pass",
    summary: "anisotropic voxels of the sparse voxel octree: six directional values per brick voxel by front-to-back compositing of child rows, one level per pass (VCT 7.1)",
};

/// Fixed-point scale of the octree's values (svo_cone_trace's).
const SCALE: f32 = super::svo_cone_trace::SCALE;

/// Directional values of the first `levels[depth] * 8` nodes (the levels above the leaves).
pub fn values(o: &Octree) -> usize {
    o.levels[o.depth as usize] as usize * 8 * NODE_VALUES
}

fn params_buffer(p: &AnisoParams) -> HostResource {
    // Mixed: u32 fields must not be flushed as if they were subnormal f32s.
    HostResource::Buffer(HostBuffer {
        bytes: bytemuck::bytes_of(p).to_vec(),
        scalar: ScalarKind::Mixed,
    })
}

fn octree_resources(o: &Octree, aniso: &[[f32; 4]]) -> Resources {
    let mut r = super::sparse_voxel_octree::reader_resources(o);
    r.insert(
        "aniso".to_string(),
        HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(aniso))),
    );
    r
}

/// The octree's directional values by the mirror (every level), as `build_on_gpu` returns them.
pub fn build_mirror(o: &Octree, inv_scale: f32) -> Vec<[f32; 4]> {
    mirror::build(&o.nodes, &o.bricks, o.depth, &o.levels, inv_scale)
}

/// Every level's directional values of `o` on the GPU: one pass per level, depth - 1 first.
pub fn build_on_gpu(ctx: &GpuContext, o: &Octree, inv_scale: f32) -> anyhow::Result<Vec<[f32; 4]>> {
    let n = values(o).max(1);
    let mut resources = octree_resources(o, &vec![[0.0; 4]; n]);
    let shader = DECL.shader()?;
    let mut passes = Vec::new();
    for p in mirror::passes(o.depth, &o.levels, inv_scale) {
        let name = format!("params_{}", p.level);
        resources.insert(name.clone(), params_buffer(&p));
        let mut bindings = DECL.bind_by_name();
        bindings.retain(|(b, _)| b != "params");
        bindings.push(("params".into(), vxgi_harness::run::View::Buffer(name)));
        passes.push(DECL.pass(
            &shader,
            ctx,
            format!("level {}", p.level),
            bindings,
            p.nodes as u64 * 27,
        ));
    }
    if passes.is_empty() {
        return Ok(vec![]);
    }
    let out = run(ctx, &shader, DECL.name, &resources, &passes, &["aniso"])?;
    Ok(bytemuck::cast_slice(&out.buffer("aniso").bytes).to_vec())
}

pub struct SvoAnisotropic;

impl Kernel for SvoAnisotropic {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    /// sparse_voxel_octree's fragment families at depths 1..=5; the level built cycles through
    /// depth - 1 (reading the leaves' bricks) up to the root.
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (depth, frags, family) = (index..)
            .map(|k| generated(seed, k))
            .find(|g| g.0 <= 5)
            .expect("the generator has depths up to 5");
        let o = build_fitted(depth, &frags);
        let mut aniso = mirror::build(&o.nodes, &o.bricks, depth, &o.levels, 1.0 / SCALE);
        let level = depth - 1 - (index / 8) as u32 % depth;
        let p = mirror::passes(depth, &o.levels, 1.0 / SCALE)
            .into_iter()
            .find(|p| p.level == level)
            .expect("a pass per level");
        for n in p.first_node..p.first_node + p.nodes {
            let at = n as usize * NODE_VALUES;
            aniso[at..at + NODE_VALUES].fill([0.0; 4]);
        }
        let mut resources = octree_resources(&o, &aniso);
        resources.insert("params".into(), params_buffer(&p));
        let shader = DECL.shader().expect("svo_anisotropic validates");
        let pass = DECL.pass(
            &shader,
            ctx,
            format!("level {level}"),
            DECL.bind_by_name(),
            p.nodes as u64 * 27,
        );
        Case {
            label: format!(
                "{family}, depth {depth}, {} fragments, level {level} ({} node slots)",
                frags.len(),
                p.nodes
            ),
            seed,
            passes: vec![pass],
            resources,
            checks: vec![Check {
                resource: "aniso".into(),
                output: "aniso",
                indexing: Indexing::Grid {
                    dims: [aniso.len() as u32, 1, 1],
                    components: 4,
                },
            }],
            effective_bytes: p.nodes as u64 * 27 * (6 * 16 + 27 * 16),
        }
    }

    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        // Values of scene scale, alphas in [0, 1]: no subnormals arise from non-zero inputs
        // (accepted flushed by the harness anyway).
        let b = |n: &str| data[n].buffer().expect("buffer");
        let p: AnisoParams = *bytemuck::from_bytes(&b("params").bytes);
        let nodes = bytemuck::cast_slice(&b("nodes").bytes);
        let mut aniso: Vec<[f32; 4]> = bytemuck::cast_slice(&b("aniso").bytes).to_vec();
        let bound = mirror::level_pass(nodes, b("bricks").as_u32(), &mut aniso, &p);
        BTreeMap::from([
            (
                "aniso".to_string(),
                HostBuffer::f32(bytemuck::cast_slice(&aniso)),
            ),
            (
                bound_name("aniso"),
                HostBuffer::f32(bytemuck::cast_slice(&bound)),
            ),
        ])
    }
}
