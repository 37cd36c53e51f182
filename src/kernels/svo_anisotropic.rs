//! Declaration of `kernels/svo_anisotropic.wgsl` (mirror: `vxgi_cpu_mirror::svo_anisotropic`): the
//! octree's anisotropic voxels, one level per pass. A case builds an octree of generated fragments
//! (sparse_voxel_octree's families) with the mirror, fills every other level's directional values with
//! the mirror and runs one level's pass on the GPU: the kernel's contract given exact inputs.
use super::sparse_voxel_octree::generated;
use vxgi_cpu_mirror::sparse_voxel_octree::{build_fitted, Node, Octree};
use vxgi_cpu_mirror::svo_anisotropic::{self as mirror, AnisoParams, NODE_VALUES};
use vxgi_harness::prelude::*;
use vxgi_harness::run::run;

vxgi_harness::bindings! {
    /// svo_anisotropic's bindings: the level's parameters and the octree in (its `levels`: each
    /// level's tile range, where the pass finds its nodes), directional values (every level's; the
    /// pass writes its own) in and out.
    pub struct Io {
        inputs: {
            params: Block<AnisoParams>,
            nodes: Vec<[u32; 9]>,
            bricks: Vec<u32>,
            levels: Vec<u32>,
        }
        outputs: {
            // Non-negative values composited front to back (sqrt, a division, products and sums):
            // within 48 ULP of the rows' magnitudes (the mirror's per-element bound); other levels
            // untouched (bound 0).
            aniso: Vec<[f32; 4]> => Tolerance::MirrorBound,
            // The pool past `aniso` (the same values and bounds), or one unused element.
            aniso_hi: Vec<[f32; 4]> => Tolerance::MirrorBound,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "svo_anisotropic",
    includes: &[super::SVO_NODE],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "aniso" },
    mirror: "vxgi_cpu_mirror::svo_anisotropic::level_pass",
    summary: "anisotropic voxels of the sparse voxel octree: six directional values per brick voxel by front-to-back compositing of child rows, one level per pass (VCT 7.1)",
);

/// Directional values per binding of the pool: WebGPU's default max_storage_buffer_binding_size
/// (128 MiB) of vec4s, which every device binds; a larger pool is bound as `aniso` and `aniso_hi`
/// (kernels/svo_anisotropic.wgsl, svo_cone_trace.wgsl), up to twice this.
pub const POOL_WINDOW: usize = 1 << 23;

/// The pool as its two bindings: its first `window` values and the rest, or (no rest) one unused
/// zero element, a binding being never empty.
pub fn split_pool(values: &[[f32; 4]], window: usize) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    if values.len() <= window {
        (values.to_vec(), vec![[0.0; 4]])
    } else {
        (values[..window].to_vec(), values[window..].to_vec())
    }
}

/// Fixed-point scale of the octree's values (svo_cone_trace's).
const SCALE: f32 = super::svo_cone_trace::SCALE;

/// Directional values of the first `levels[depth] * 8` nodes (the levels above the leaves).
pub fn values(o: &Octree) -> usize {
    values_of(o.depth, &o.levels)
}

/// [`values`] of an octree of `depth` whose tile ranges per level are `levels`.
pub fn values_of(depth: u32, levels: &[u32]) -> usize {
    levels[depth as usize] as usize * 8 * NODE_VALUES
}

/// The bindings of a pass of `p` over `o` with these directional values, the pool split at `window`.
fn io(o: &Octree, p: AnisoParams, aniso: &[[f32; 4]], window: usize) -> Io {
    let (aniso, aniso_hi) = split_pool(aniso, window);
    Io {
        params: Block(p),
        nodes: bytemuck::cast_slice(&o.nodes).to_vec(),
        bricks: o.bricks.clone(),
        levels: o.levels.clone(),
        aniso,
        aniso_hi,
    }
}

/// The octree's directional values by the mirror (every level), as `build_on_gpu` returns them.
pub fn build_mirror(o: &Octree, inv_scale: f32) -> Vec<[f32; 4]> {
    mirror::build(&o.nodes, &o.bricks, o.depth, &o.levels, inv_scale)
}

/// Every level's directional values of `o` on the GPU: one pass per level, depth - 1 first.
pub fn build_on_gpu(ctx: &GpuContext, o: &Octree, inv_scale: f32) -> anyhow::Result<Vec<[f32; 4]>> {
    let n = values(o).max(1);
    let pool = vec![[0.0; 4]; n];
    let mut resources = io(o, AnisoParams::default(), &pool, POOL_WINDOW).resources();
    let shader = DECL.shader()?;
    let mut passes = Vec::new();
    for p in mirror::passes(o.depth, inv_scale) {
        let name = format!("params_{}", p.level);
        resources.insert(name.clone(), HostBuffer::pod(&p).into());
        let mut bindings = DECL.bind_by_name();
        bindings.retain(|(b, _)| b != "params");
        bindings.push(("params".into(), vxgi_harness::run::View::Buffer(name)));
        passes.push(DECL.pass(
            &shader,
            ctx,
            format!("level {}", p.level),
            bindings,
            mirror::level_nodes(&o.levels, p.level).len() as u64 * 27,
        ));
    }
    if passes.is_empty() {
        return Ok(vec![]);
    }
    let out = run(
        ctx,
        &shader,
        DECL.name,
        &resources,
        &passes,
        &["aniso", "aniso_hi"],
    )?;
    let mut values: Vec<[f32; 4]> = bytemuck::cast_slice(&out.buffer("aniso").bytes).to_vec();
    values.extend_from_slice(bytemuck::cast_slice(&out.buffer("aniso_hi").bytes));
    values.truncate(n);
    Ok(values)
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
        // The case dispatched past its level's nodes (below) builds a level above depth - 1 where
        // there is one: the slots past it are the next level's, whose values it must not touch.
        let past = index % 8 == 3;
        let level = depth - 1 - ((index / 8) as u32 + past as u32) % depth;
        let p = mirror::passes(depth, 1.0 / SCALE)
            .into_iter()
            .find(|p| p.level == level)
            .expect("a pass per level");
        let slots = mirror::level_nodes(&o.levels, level);
        for n in slots.clone() {
            let at = n as usize * NODE_VALUES;
            aniso[at..at + NODE_VALUES].fill([0.0; 4]);
        }
        let shader = DECL.shader().expect("svo_anisotropic validates");
        let mut label = format!(
            "{family}, depth {depth}, {} fragments, level {level} ({} node slots)",
            frags.len(),
            slots.len()
        );
        // One case in eight dispatched past the level's nodes, as a pass recorded before the
        // structure exists is (over a bound): the extra invocations write nothing.
        let mut threads = slots.len() as u64 * 27;
        if past {
            threads += 27 * 8 * 3 + 5;
            label.push_str(", dispatched past its nodes");
        }
        let pass = DECL.pass(
            &shader,
            ctx,
            format!("level {level}"),
            DECL.bind_by_name(),
            threads,
        );
        // One case in eight with the pool in two bindings, as a pool past one binding is.
        let (window, label) = if index % 8 == 5 {
            (
                aniso.len().div_ceil(2),
                format!("{label}, pool in two bindings"),
            )
        } else {
            (POOL_WINDOW, label)
        };
        let mut case = io(&o, p, &aniso, window)
            .case(label, seed, vec![pass])
            .with_effective_bytes(slots.len() as u64 * 27 * (6 * 16 + 27 * 16));
        // An unsplit pool's `aniso_hi` is one element no pass writes: nothing to check.
        if window >= aniso.len() {
            case.checks.retain(|c| c.resource != "aniso_hi");
        }
        case
    }

    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // Values of scene scale, alphas in [0, 1]: no subnormals arise from non-zero inputs
        // (accepted flushed by the harness anyway).
        let mut io = Io::read(data);
        let nodes: &[Node] = bytemuck::cast_slice(&io.nodes);
        // The pool whole (its unused element, if any, past every node's values), split back after.
        let lo = io.aniso.len();
        let mut pool = [io.aniso.as_slice(), &io.aniso_hi].concat();
        let bounds = mirror::level_pass(nodes, &io.bricks, &io.levels, &mut pool, &io.params.0);
        io.aniso_hi = pool.split_off(lo);
        io.aniso = pool;
        let mut out = io.outputs();
        out.extend([
            bound("aniso", &bounds[..lo]),
            bound("aniso_hi", &bounds[lo..]),
        ]);
        out
    }
}
