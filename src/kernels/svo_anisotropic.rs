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
            // The whole pool, whichever windows of it the pass binds (`bind_pool_windows`).
            aniso: Vec<[f32; 4]> => Tolerance::MirrorBound,
        }
    }
}

pub static DECL: KernelDecl = BASE;

/// svo_anisotropic's declaration, which [`WINDOWED_DECL`] shares but for its includes.
const BASE: KernelDecl = vxgi_harness::kernel_decl!(
    "svo_anisotropic",
    includes: &[super::SVO_NODE, super::SVO_BRICKS_ONE, super::SVO_ANISO_RW_PAIR],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "aniso" },
    mirror: "vxgi_cpu_mirror::svo_anisotropic::level_pass",
    summary: "anisotropic voxels of the sparse voxel octree: six directional values per brick voxel by front-to-back compositing of child rows, one level per pass (VCT 7.1)",
);

/// svo_anisotropic with the octree's pools in windows of one buffer (kernels/common/svo_bricks.wgsl,
/// svo_aniso_rw.wgsl): for bricks past one storage binding or directional values past two
/// (Sponza's octree at 512^3), where a branch per window would cost lavapipe about twice the pass
/// of [`DECL`] (bricks in one binding, the values in up to two) in every smaller octree.
/// [`decl_for`] picks one.
/// Its bindings, outputs (the windows change which binding holds a value, not the value) and mirror
/// are [`DECL`]'s; the pools' windows past their first (`bricks_1`.., `aniso_1`..) are bound by
/// `bind_pools`.
pub static WINDOWED_DECL: KernelDecl = KernelDecl {
    name: "svo_anisotropic_windowed",
    includes: &[super::SVO_NODE, super::SVO_BRICKS, super::SVO_ANISO_RW],
    summary: "svo_anisotropic with the octree's bricks and directional values in windows of one buffer (bricks past one storage binding, values past two)",
    ..BASE
};

/// The pass's declaration for an octree of `brick_words` words of bricks and `values` directional
/// values: [`WINDOWED_DECL`] where the bricks are past one binding or the values past two, else
/// [`DECL`].
pub fn decl_for(brick_words: usize, values: usize) -> &'static KernelDecl {
    let windowed = brick_words as u64 > super::sparse_voxel_octree::BRICK_WINDOW
        || values as u64 > 2 * POOL_WINDOW;
    if windowed {
        &WINDOWED_DECL
    } else {
        &DECL
    }
}

/// Directional values per binding of the pool: WebGPU's default max_storage_buffer_binding_size
/// (128 MiB) of vec4s, which every device binds; a larger pool is bound in windows of this
/// ([`POOL_VIEWS`]: kernels/common/svo_aniso_rw.wgsl, svo_aniso_windows.wgsl).
pub const POOL_WINDOW: u64 = 1 << 23;

/// The pool's bindings, each a window of its buffer.
pub const POOL_VIEWS: [&str; 6] = [
    "aniso", "aniso_1", "aniso_2", "aniso_3", "aniso_4", "aniso_5",
];

/// Bind the directional values' pool (resource `resource`) of `passes` in windows of `window`
/// values, bound as `views` (the first of [`POOL_VIEWS`] the shader declares: all six in the
/// `_windowed` declarations, two in the others; [`POOL_WINDOW`] where it is past one binding).
pub fn bind_pool_windows(
    passes: &mut [vxgi_harness::run::Pass],
    resources: &mut Resources,
    resource: &str,
    views: &[&str],
    window: u64,
) -> Result<(), String> {
    super::bind_windows(passes, resources, resource, views, 16, window)
}

/// The views of [`POOL_VIEWS`] a declaration binds: all six for [`WINDOWED_DECL`] (`windowed`),
/// two for [`DECL`].
pub fn pool_views(windowed: bool) -> &'static [&'static str] {
    if windowed {
        &POOL_VIEWS
    } else {
        &POOL_VIEWS[..2]
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

/// The bindings of a pass of `p` over `o` with these directional values.
fn io(o: &Octree, p: AnisoParams, aniso: &[[f32; 4]]) -> Io {
    Io {
        params: Block(p),
        nodes: bytemuck::cast_slice(&o.nodes).to_vec(),
        bricks: o.bricks.clone(),
        levels: o.levels.clone(),
        aniso: aniso.to_vec(),
    }
}

/// Both pools of `passes` bound in windows: for [`WINDOWED_DECL`] the bricks' of `bricks` words
/// and the directional values' of `values`; for [`DECL`] the values' alone, in two.
pub fn bind_pools(
    passes: &mut [vxgi_harness::run::Pass],
    resources: &mut Resources,
    windowed: bool,
    [bricks, values]: [u64; 2],
) -> Result<(), String> {
    if windowed {
        super::sparse_voxel_octree::bind_brick_windows(passes, resources, "bricks", bricks)?;
    }
    bind_pool_windows(passes, resources, "aniso", pool_views(windowed), values)
}

/// The octree's directional values by the mirror (every level), as `build_on_gpu` returns them.
pub fn build_mirror(o: &Octree, inv_scale: f32) -> Vec<[f32; 4]> {
    mirror::build(&o.nodes, &o.bricks, o.depth, &o.levels, inv_scale)
}

/// Every level's directional values of `o` on the GPU: one pass per level, depth - 1 first.
pub fn build_on_gpu(ctx: &GpuContext, o: &Octree, inv_scale: f32) -> anyhow::Result<Vec<[f32; 4]>> {
    let n = values(o).max(1);
    let pool = vec![[0.0; 4]; n];
    let mut resources = io(o, AnisoParams::default(), &pool).resources();
    let decl = decl_for(o.bricks.len(), n);
    let shader = decl.shader()?;
    let mut passes = Vec::new();
    for p in mirror::passes(o.depth, inv_scale) {
        let name = format!("params_{}", p.level);
        resources.insert(name.clone(), HostBuffer::pod(&p).into());
        let mut bindings = decl.bind_by_name();
        bindings.retain(|(b, _)| b != "params");
        bindings.push(("params".into(), vxgi_harness::run::View::Buffer(name)));
        passes.push(decl.pass(
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
    let windows = [super::sparse_voxel_octree::BRICK_WINDOW, POOL_WINDOW];
    let windowed = std::ptr::eq(decl, &WINDOWED_DECL);
    bind_pools(&mut passes, &mut resources, windowed, windows).map_err(anyhow::Error::msg)?;
    let out = run(ctx, &shader, decl.name, &resources, &passes, &["aniso"])?;
    let mut values: Vec<[f32; 4]> = bytemuck::cast_slice(&out.buffer("aniso").bytes).to_vec();
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
        // One case in eight with the values in two bindings, as values past one binding are.
        let window = match index % 8 {
            5 => {
                label.push_str(", values in two bindings");
                (aniso.len() as u64).div_ceil(2).div_ceil(16).max(1) * 16
            }
            _ => POOL_WINDOW,
        };
        let mut case = io(&o, p, &aniso)
            .case(label, seed, vec![pass])
            .with_effective_bytes(slots.len() as u64 * 27 * (6 * 16 + 27 * 16));
        let windows = [super::sparse_voxel_octree::BRICK_WINDOW, window];
        bind_pools(&mut case.passes, &mut case.resources, false, windows)
            .expect("two windows hold them");
        case
    }

    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // Values of scene scale, alphas in [0, 1]: no subnormals arise from non-zero inputs
        // (accepted flushed by the harness anyway).
        let mut io = Io::read(data);
        let nodes: &[Node] = bytemuck::cast_slice(&io.nodes);
        let bounds = mirror::level_pass(nodes, &io.bricks, &io.levels, &mut io.aniso, &io.params.0);
        let mut out = io.outputs();
        out.extend([bound("aniso", &bounds)]);
        out
    }
}

/// `case` (of a windowed declaration) with both pools in up to three bindings each, as pools past
/// their bindings are: the same outputs.
pub fn with_pools_split(mut case: Case) -> Case {
    let len = |n: &str, elem: u64| case.resources[n].buffer().expect(n).bytes.len() as u64 / elem;
    let third = |n: u64, per: u64| n.div_ceil(3).div_ceil(per).max(1) * per;
    let windows = [third(len("bricks", 4), 64), third(len("aniso", 16), 16)];
    bind_pools(&mut case.passes, &mut case.resources, true, windows)
        .expect("three windows hold them");
    case.label.push_str(", pools in up to three bindings each");
    case
}

/// svo_anisotropic_windowed on svo_anisotropic's generated cases, both pools in three bindings.
pub struct SvoAnisotropicWindowed;

impl Kernel for SvoAnisotropicWindowed {
    fn decl(&self) -> &'static KernelDecl {
        &WINDOWED_DECL
    }
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        with_pools_split(SvoAnisotropic.case(shader, ctx, seed, index))
    }
    fn mirror(&self, case: &Case, data: &Resources, mode: FloatMode) -> MirrorOutputs {
        SvoAnisotropic.mirror(case, data, mode)
    }
}
