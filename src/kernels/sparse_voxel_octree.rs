//! Declaration of `kernels/sparse_voxel_octree.wgsl` (mirror: `vxgi_cpu_mirror::sparse_voxel_octree`):
//! the sparse voxel octree of voxel cone tracing: build from fragments (atomic tile allocation), splat,
//! brick border transfer and distribution over levels, all integer and exact. The GPU hands out tiles in
//! a free order; nodes, bricks and flags are compared after canonicalising (sorted by node key, pointers
//! replaced by keys). [`build_on_gpu`] is the own-device API.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;
use thiserror::Error;
use vxgi_cpu_mirror::sparse_voxel_octree::{
    build, canonical_bricks, canonical_nodes, capacity_bound, key, Fragment, Node, Octree,
    OctreeParams, StaticStructure, ARGS_SLOTS, BRICK_WORDS, ERR_OUTSIDE, ERR_OVERFLOW, ERR_POOL,
    LEVELS_WORDS, MAX_DEPTH, SLOT_CLASS, SLOT_RING, STATS_WORDS, STATUS_ERRORS, STATUS_TILES,
};
use vxgi_harness::prelude::*;
use vxgi_harness::run::{grid_for, Pass, View, Workgroups};
use vxgi_harness::HarnessError;

pub static DECL: KernelDecl = BASE;

/// sparse_voxel_octree's declaration, which [`WINDOWED_DECL`] shares but for its includes.
const BASE: KernelDecl = vxgi_harness::kernel_decl!(
    "sparse_voxel_octree",
    includes: &[super::SVO_NODE, super::SVO_BRICKS_ATOMIC_ONE],
    entry: "flag_parents",
    inputs: &["params", "fragments"],
    // Integer arithmetic only (atomic adds, shifts, saturating checks): exact. Nodes, bricks and flags
    // after canonicalising the atomic allocation order.
    outputs: &[
        Output { binding: "nodes", tolerance: Tolerance::Exact },
        Output { binding: "bricks", tolerance: Tolerance::Exact },
        Output { binding: "flags", tolerance: Tolerance::Exact },
        Output { binding: "levels", tolerance: Tolerance::Exact },
        Output { binding: "status", tolerance: Tolerance::Exact },
        Output { binding: "stats", tolerance: Tolerance::Exact },
    ],
    dispatch: DispatchRule::PerItem { what: "fragment (x 8 in flag_parents); node of a level, list entry or list entry x class voxel (indirect, GPU-written arguments)" },
    mirror: "vxgi_cpu_mirror::sparse_voxel_octree::build",
    summary: "sparse voxel octree, 3x3x3 vertex-centred bricks: build (atomic tiles), splat, border transfer (add, copy), Gaussian distribution over levels (VCT 4.1-4.2.3, 8.2)",
);

/// sparse_voxel_octree with its brick pool in windows of one buffer (kernels/common/
/// svo_bricks_atomic.wgsl): for a pool past one storage binding (Sponza's octree at 512^3), where a
/// branch per window would cost lavapipe about twice the build of [`DECL`] in every smaller one.
/// [`decl_for`] picks one.
/// Its bindings, outputs (the windows change which binding holds a word, not the word) and mirror
/// are [`DECL`]'s; `bricks`' windows past its first (`bricks_1`..) are bound by
/// `bind_brick_windows`.
pub static WINDOWED_DECL: KernelDecl = KernelDecl {
    name: "sparse_voxel_octree_windowed",
    includes: &[super::SVO_NODE, super::SVO_BRICKS_ATOMIC],
    summary: "sparse_voxel_octree with its brick pool in windows of one buffer (a pool past one storage binding)",
    ..BASE
};

/// The build's declaration for a node pool of `capacity` tiles: [`WINDOWED_DECL`] where its bricks
/// are past one binding, else [`DECL`].
pub fn decl_for(capacity: u32) -> &'static KernelDecl {
    if capacity as u64 * 8 * BRICK_WORDS as u64 > BRICK_WINDOW {
        &WINDOWED_DECL
    } else {
        &DECL
    }
}

/// Bytes of one node record and one brick.
pub const NODE_BYTES: u64 = std::mem::size_of::<Node>() as u64;
pub const BRICK_BYTES: u64 = BRICK_WORDS as u64 * 4;

#[derive(Debug, Error)]
pub enum SvoError {
    #[error("octree depth {0}: must be 1..={MAX_DEPTH} (1 = 2^3 leaves, 9 = 512^3)")]
    Depth(u32),
    #[error(
        "the static structure was recorded at depth {recorded}, this build is at depth {depth}"
    )]
    StaticDepth { recorded: u32, depth: u32 },
    #[error("fragment {index} at lattice point {pos:?} is outside the volume (0..={side} per axis at depth {depth})")]
    Outside {
        index: usize,
        pos: [u32; 3],
        side: u32,
        depth: u32,
    },
    #[error("node pool of {capacity} tiles is too small: the structure asked for at least {needed} tiles{hint}")]
    Pool {
        capacity: u32,
        needed: u32,
        hint: String,
    },
    #[error(
        "fixed-point overflow: a sum of brick values passed u32::MAX (lower the fixed-point scale)"
    )]
    Overflow,
    #[error("value {value} cannot be stored in u32 fixed point with scale {scale}")]
    Value { value: f32, scale: f32 },
    #[error(transparent)]
    Harness(Box<HarnessError>),
}

impl From<HarnessError> for SvoError {
    fn from(e: HarnessError) -> Self {
        SvoError::Harness(Box::new(e))
    }
}

/// `v * scale` rounded, as u32 fixed point; an error for negative, non-finite or too large values.
pub fn to_fixed(v: f32, scale: f32) -> Result<u32, SvoError> {
    let x = (v as f64 * scale as f64).round();
    if !x.is_finite() || x < 0.0 || x > u32::MAX as f64 {
        return Err(SvoError::Value { value: v, scale });
    }
    Ok(x as u32)
}

/// The brick pool's bindings, each a window of [`BRICK_WINDOW`] words of its buffer (the kernels'
/// `bricks`, `bricks_1`, ...: kernels/common/svo_bricks.wgsl).
pub const BRICK_VIEWS: [&str; 5] = ["bricks", "bricks_1", "bricks_2", "bricks_3", "bricks_4"];

/// Words of the brick pool per binding: WebGPU's default max_storage_buffer_binding_size (128 MiB),
/// which every device binds.
pub const BRICK_WINDOW: u64 = 1 << 25;

/// Largest node pool (tiles) whose brick pool this device holds: [`BRICK_VIEWS`] windows of
/// [`BRICK_WINDOW`] words, in one buffer of at most its max_buffer_size.
pub fn max_capacity(ctx: &GpuContext) -> u32 {
    let views = BRICK_VIEWS.len() as u64 * BRICK_WINDOW * 4;
    let bytes = views.min(ctx.limits().max_buffer_size);
    (bytes / (8 * BRICK_BYTES)).min(u32::MAX as u64 / 8) as u32
}

/// Bind the brick pool (resource `resource`) of `passes` in windows of `window` words
/// ([`BRICK_VIEWS`]; [`BRICK_WINDOW`] where it is past one binding).
pub fn bind_brick_windows(
    passes: &mut [Pass],
    resources: &mut Resources,
    resource: &str,
    window: u64,
) -> Result<(), String> {
    super::bind_windows(passes, resources, resource, &BRICK_VIEWS, 4, window)
}

/// `case` with its brick pool in three windows, as a pool past one binding is: the same outputs.
pub fn with_brick_split(mut case: Case) -> Case {
    let words = case.resources["bricks"]
        .buffer()
        .expect("bricks")
        .bytes
        .len() as u64
        / 4;
    let window = words.div_ceil(3).div_ceil(64).max(1) * 64;
    bind_brick_windows(&mut case.passes, &mut case.resources, "bricks", window)
        .expect("three windows hold it");
    if words > window {
        case.label.push_str(", bricks in three bindings");
    }
    case
}

/// The tile pool a build of `fragments` gets when the caller does not choose one: the bound of
/// [`capacity_bound`] (never too small), or the largest a binding allows.
pub fn default_capacity(ctx: &GpuContext, depth: u32, fragments: usize) -> u32 {
    capacity_bound(depth, fragments).min(max_capacity(ctx) as u64) as u32
}

/// Resources and the pass sequence of a whole build: structure, splat, then transfer and distribution
/// level by level from the leaves up ([`phase_of`] names the phase of each pass, for timing).
pub fn case_for(
    ctx: &GpuContext,
    depth: u32,
    capacity: u32,
    fragments: &[Fragment],
    label: String,
    seed: u64,
) -> Case {
    case_replayed(ctx, depth, capacity, fragments, None, false, label, seed)
}

/// [`case_for`] with a static part's structure replayed (`statics`: `flag_static` per level, and
/// `flag_parents` only for the fragments at points it does not cover, which go first in the buffer)
/// and, with `distinct`, one flagging fragment per point.
#[allow(clippy::too_many_arguments)]
pub fn case_replayed(
    ctx: &GpuContext,
    depth: u32,
    capacity: u32,
    fragments: &[Fragment],
    statics: Option<&StaticStructure>,
    distinct: bool,
    label: String,
    seed: u64,
) -> Case {
    // Flagging fragments first; `flag_parents` reads the first `flagging` of them: those at points
    // the static part does not cover and, with `distinct`, one per point (the structure depends on
    // the points alone; photons pile up on the voxels' points).
    let (fragments, flagging): (std::borrow::Cow<[Fragment]>, u32) = if statics.is_none()
        && !distinct
    {
        (fragments.into(), fragments.len() as u32)
    } else {
        let mut seen = std::collections::HashSet::new();
        let (mut first, rest): (Vec<Fragment>, Vec<Fragment>) = fragments.iter().partition(|f| {
            !statics.is_some_and(|st| st.covers(f.pos)) && (!distinct || seen.insert(f.pos))
        });
        let k = first.len() as u32;
        first.extend(rest);
        (first.into(), k)
    };
    case_flagging(
        ctx, depth, capacity, &fragments, flagging, false, statics, label, seed,
    )
}

/// A whole build's case in a frame's chain, before its fragments exist: `slots` fragment slots
/// (zero here; a kernel before the octree writes them), the first `flagging` of which flag nodes.
/// `flag_parents` binds parameters of its own, `params_l{level}_v0_flagging` for each level
/// ([`flagging_params`]), whose `fragments` the chain overwrites with the count its GPU found
/// before the build runs (the slots past that count are not read); it dispatches over all
/// `flagging` slots.
pub fn case_in_chain(
    ctx: &GpuContext,
    depth: u32,
    capacity: u32,
    slots: u32,
    flagging: u32,
    label: String,
    seed: u64,
) -> Case {
    let zero = vec![bytemuck::Zeroable::zeroed(); slots as usize];
    case_flagging(
        ctx, depth, capacity, &zero, flagging, true, None, label, seed,
    )
}

/// The parameters `flag_parents` of level `level` binds in [`case_in_chain`]'s case.
pub fn flagging_params(level: u32) -> String {
    format!("params_l{level}_v0_flagging")
}

/// [`case_replayed`] over `fragments` as given, the first `flagging` of them flagging nodes;
/// `own_flag_params`: flag_parents binds [`flagging_params`] even where every fragment flags.
#[allow(clippy::too_many_arguments)]
fn case_flagging(
    ctx: &GpuContext,
    depth: u32,
    capacity: u32,
    fragments: &[Fragment],
    flagging: u32,
    own_flag_params: bool,
    statics: Option<&StaticStructure>,
    label: String,
    seed: u64,
) -> Case {
    let n = capacity as usize * 8;
    let mut nodes = vec![Node::UNUSED; n];
    nodes[0] = Node {
        key: key(0, [0; 3]),
        ..Node::UNUSED
    };
    let mut levels = vec![0u32; LEVELS_WORDS];
    levels[1] = 1; // tile 0: the root
                   // A binding cannot be empty: one unused fragment when there are none (params.fragments says 0).
    let frag_data: Vec<Fragment> = if fragments.is_empty() {
        vec![bytemuck::Zeroable::zeroed()]
    } else {
        fragments.to_vec()
    };
    let words = |n: usize| HostBuffer::zeroed(n * 4, ScalarKind::U32);
    let mut args = vec![0u32; ARGS_SLOTS * 3];
    args[..3].copy_from_slice(&[1, 1, 1]); // level 0: the root's tile
    let mut resources = buffers([
        (
            "fragments",
            HostBuffer::u32(bytemuck::cast_slice(&frag_data)),
        ),
        ("nodes", HostBuffer::u32(bytemuck::cast_slice(&nodes))),
        ("bricks", words(n * BRICK_WORDS)),
        ("flags", words(n)),
        (
            "tile_parent",
            HostBuffer::of(&vec![u32::MAX; capacity as usize]),
        ),
        ("levels", HostBuffer::of(&levels)),
        // Errors, tiles handed out (the root's), list counters.
        ("status", HostBuffer::of(&[0u32, 1, 0, 0])),
        ("stats", words(STATS_WORDS)),
        ("args", HostBuffer::of(&args)),
        ("list_active", words(n)),
        ("list_ring", words(n)),
    ]);
    if let Some(st) = statics {
        resources.extend(buffers([
            ("static_keys", HostBuffer::of(&super::or_one(&st.keys))),
            ("static_offsets", HostBuffer::of(&st.offsets)),
        ]));
    }
    let max_groups = ctx.limits().max_compute_workgroups_per_dimension;
    let total = fragments.len() as u32;
    let mut passes = Vec::new();
    // `f`: the fragment count the pass reads (flag_parents: the flagging ones; splat: all).
    let mut push = |resources: &mut Resources,
                    entry: &str,
                    level: u32,
                    variant: u32,
                    f: u32,
                    w: Workgroups| {
        // flag_parents with a static part reads fewer fragments than the other passes.
        let pname = if f == total && !(own_flag_params && entry == "flag_parents") {
            format!("params_l{level}_v{variant}")
        } else {
            format!("params_l{level}_v{variant}_flagging")
        };
        resources.entry(pname.clone()).or_insert_with(|| {
            let p = OctreeParams {
                depth,
                level,
                fragments: f,
                capacity_tiles: capacity,
                variant,
                max_groups,
                _pad: [0; 2],
            };
            HostBuffer::pod(&p).into()
        });
        let mut bindings = vxgi_harness::run::bind_same_names(SHARED);
        if entry == "flag_static" {
            bindings.extend(vxgi_harness::run::bind_same_names([
                "static_keys",
                "static_offsets",
            ]));
        }
        bindings.push(("params".into(), View::Buffer(pname)));
        passes.push(Pass {
            label: format!("{entry} level {level} variant {variant}"),
            entry: entry.into(),
            bindings,
            workgroups: w,
        });
    };
    let slot = |s: usize| Workgroups::Indirect {
        buffer: "args".into(),
        offset: s as u64 * 12,
    };
    let one = Workgroups::Direct([1, 1, 1]);
    let f = total;
    for l in 1..=depth {
        if let Some(st) = statics {
            let count = st.keys(l - 1).len() as u64;
            if count > 0 {
                let g = Workgroups::Direct(grid_for(count, 64, max_groups));
                push(&mut resources, "flag_static", l, 0, f, g);
            }
        }
        if flagging > 0 {
            let g = Workgroups::Direct(grid_for(flagging as u64 * 8, 64, max_groups));
            push(&mut resources, "flag_parents", l, 0, flagging, g);
        }
        push(&mut resources, "allocate", l, 0, f, slot(l as usize - 1));
        push(&mut resources, "finish_level", l, 0, f, one.clone());
        push(&mut resources, "init_nodes", l, 0, f, slot(l as usize));
    }
    push(
        &mut resources,
        "splat",
        depth,
        0,
        f,
        Workgroups::Direct(grid_for(f as u64, 64, max_groups)),
    );
    for l in (0..=depth).rev() {
        push(&mut resources, "begin_level", l, 0, f, one.clone());
        push(&mut resources, "mark_ring", l, 0, f, slot(l as usize));
        push(&mut resources, "compact", l, 0, f, slot(l as usize));
        push(&mut resources, "list_args", l, 0, f, one.clone());
        if l < depth {
            for class in 0..4 {
                push(
                    &mut resources,
                    "distribute",
                    l,
                    class,
                    f,
                    slot(SLOT_CLASS + class as usize),
                );
            }
        }
        for axis in 0..3 {
            push(&mut resources, "transfer_add", l, axis, f, slot(SLOT_RING));
            push(&mut resources, "transfer_copy", l, axis, f, slot(SLOT_RING));
        }
        if l < depth {
            push(&mut resources, "round_level", l, 0, f, slot(SLOT_RING));
        }
        if l > 0 {
            push(&mut resources, "mark_parents", l, 0, f, slot(SLOT_RING));
        }
    }
    if std::ptr::eq(decl_for(capacity), &WINDOWED_DECL) {
        bind_brick_windows(&mut passes, &mut resources, "bricks", BRICK_WINDOW)
            .expect("the pool's capacity is within max_capacity");
    }
    Case {
        label,
        seed,
        resources,
        passes,
        checks: CHECKED.map(|r| Check::of(r, Indexing::Linear)).to_vec(),
        effective_bytes: n as u64 * (NODE_BYTES + BRICK_BYTES) + fragments.len() as u64 * 32,
    }
}

/// Storage bindings every pass binds under their own names.
const SHARED: [&str; 11] = [
    "fragments",
    "nodes",
    "bricks",
    "flags",
    "tile_parent",
    "levels",
    "status",
    "stats",
    "args",
    "list_active",
    "list_ring",
];
const CHECKED: [&str; 6] = ["nodes", "bricks", "flags", "levels", "status", "stats"];

/// Which phase a pass of [`case_for`] belongs to, by its entry point.
pub fn phase_of(entry: &str) -> &'static str {
    match entry {
        "flag_static" | "flag_parents" | "allocate" | "finish_level" | "init_nodes" => "build",
        "splat" => "splat",
        "transfer_add" | "transfer_copy" => "transfer",
        "distribute" | "round_level" => "distribution",
        _ => "work lists",
    }
}

/// A fragment set of the generator's families, and its label.
pub fn generated(seed: u64, index: usize) -> (u32, Vec<Fragment>, String) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(index as u64));
    let family = index % 8;
    let depth = match family {
        5 => MAX_DEPTH,
        _ => 1 + (index / 8 + index) as u32 % 5,
    };
    let side = 2u32 << depth; // lattice points 0..=side per axis
    let value = |rng: &mut ChaCha8Rng| -> [u32; 4] {
        [
            rng.random_range(0..1 << 20),
            rng.random_range(0..1 << 20),
            rng.random_range(0..1 << 16),
            1 << 16,
        ]
    };
    let point = |rng: &mut ChaCha8Rng| [0, 1, 2].map(|_| rng.random_range(0..=side));
    let frag = |pos: [u32; 3], value: [u32; 4]| Fragment {
        pos,
        _pad: 0,
        value,
    };
    let mut out = Vec::new();
    let name = match family {
        0 => {
            out.push(frag(point(&mut rng), value(&mut rng)));
            "single point"
        }
        1 => {
            // A full slab one lattice point thick, at a random height (on a node boundary half the time).
            let z = rng.random_range(0..=side);
            let step = if side > 16 { 2 } else { 1 };
            for y in (0..=side).step_by(step) {
                for x in (0..=side).step_by(step) {
                    out.push(frag([x, y, z], value(&mut rng)));
                }
            }
            "slab"
        }
        2 => {
            for _ in 0..rng.random_range(1..200) {
                out.push(frag(point(&mut rng), value(&mut rng)));
            }
            "scattered points"
        }
        3 => {
            // Every corner of every leaf-level octant boundary: points on node faces, edges, corners.
            let s = (side / 4).max(1);
            for z in (0..=side).step_by(s as usize) {
                for y in (0..=side).step_by(s as usize) {
                    for x in (0..=side).step_by(s as usize) {
                        out.push(frag([x, y, z], value(&mut rng)));
                    }
                }
            }
            "octree boundaries and corners"
        }
        4 => {
            // Many fragments on few points: atomic adds collide.
            let p = point(&mut rng);
            for _ in 0..300 {
                out.push(frag(p, value(&mut rng)));
            }
            "colliding splats"
        }
        5 => {
            for _ in 0..8 {
                out.push(frag(point(&mut rng), value(&mut rng)));
            }
            out.push(frag([side; 3], value(&mut rng)));
            out.push(frag([0; 3], value(&mut rng)));
            "maximum depth"
        }
        6 => {
            // Geometry everywhere, light on a few fragments: most nodes receive nothing (skipped).
            for _ in 0..150 {
                let lit = rng.random_range(0..10) == 0;
                let v = if lit { value(&mut rng) } else { [0; 4] };
                out.push(frag(point(&mut rng), v));
            }
            "mostly unlit"
        }
        _ => {
            // Values near u32::MAX: the saturating sums and the overflow bit must agree too.
            for _ in 0..4 {
                let p = [0, 1, 2].map(|_| rng.random_range(0..=side.min(4)));
                out.push(frag(
                    p,
                    [u32::MAX - rng.random_range(0..1000), 7, 0, 1 << 30],
                ));
            }
            "overflowing values"
        }
    };
    let label = format!("#{index} {name}, depth {depth}, {} fragments", out.len());
    (depth, out, label)
}

pub struct SparseVoxelOctree;

impl Kernel for SparseVoxelOctree {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (depth, frags, label) = generated(seed, index);
        let cap = default_capacity(ctx, depth, frags.len());
        case_for(ctx, depth, cap, &frags, label, seed)
    }
    fn mirror(&self, case: &Case, _data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let b = |n: &str| case.resources[n].buffer().expect("buffer");
        let p: OctreeParams = *bytemuck::from_bytes(&b("params_l1_v0").bytes);
        let frags: &[Fragment] = bytemuck::cast_slice(&b("fragments").bytes);
        let o = build(p.depth, p.capacity_tiles, &frags[..p.fragments as usize]);
        octree_buffers(&o)
    }
    fn canonicalise(
        &self,
        resource: &str,
        data: &mut HostBuffer,
        all: &BTreeMap<String, HostBuffer>,
    ) {
        let nodes: &[Node] = bytemuck::cast_slice(&all["nodes"].bytes);
        match resource {
            "nodes" => data.bytes = bytemuck::cast_slice(&canonical_nodes(nodes).0).to_vec(),
            "bricks" => {
                data.bytes = bytemuck::cast_slice(&canonical_bricks(nodes, data.as_u32())).to_vec()
            }
            "flags" => {
                let (_, order) = canonical_nodes(nodes);
                let f = data.as_u32();
                let v: Vec<u32> = order.iter().map(|&i| f[i]).collect();
                data.bytes = bytemuck::cast_slice(&v).to_vec();
            }
            _ => {}
        }
    }
}

/// sparse_voxel_octree_windowed on sparse_voxel_octree's generated cases, every pool in three
/// bindings.
pub struct SparseVoxelOctreeWindowed;

impl Kernel for SparseVoxelOctreeWindowed {
    fn decl(&self) -> &'static KernelDecl {
        &WINDOWED_DECL
    }
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        with_brick_split(SparseVoxelOctree.case(shader, ctx, seed, index))
    }
    fn mirror(&self, case: &Case, data: &Resources, mode: FloatMode) -> MirrorOutputs {
        SparseVoxelOctree.mirror(case, data, mode)
    }
    fn canonicalise(
        &self,
        resource: &str,
        data: &mut HostBuffer,
        all: &BTreeMap<String, HostBuffer>,
    ) {
        SparseVoxelOctree.canonicalise(resource, data, all)
    }
}

/// The checked buffers of an octree, by binding name.
pub fn octree_buffers(o: &Octree) -> BTreeMap<String, HostBuffer> {
    mirror_outputs([
        ("nodes", HostBuffer::u32(bytemuck::cast_slice(&o.nodes))),
        ("bricks", HostBuffer::of(&o.bricks)),
        ("flags", HostBuffer::of(&o.flags)),
        ("levels", HostBuffer::of(&o.levels)),
        ("status", HostBuffer::of(&o.status)),
        ("stats", HostBuffer::of(&o.stats)),
    ])
}

/// The two buffers the octree's readers bind (svo_anisotropic, svo_cone_trace): `nodes` and `bricks`.
pub fn reader_resources(o: &Octree) -> Resources {
    octree_buffers(o)
        .into_iter()
        .filter(|(name, _)| name == "nodes" || name == "bricks")
        .map(|(name, b)| (name, HostResource::Buffer(b)))
        .collect()
}

/// What a GPU build produced, with its per-phase GPU time (timestamps, or one wall-clock total).
#[derive(Debug)]
pub struct GpuOctree {
    pub octree: Octree,
    /// The buffers the structure's passes left (`nodes`, `flags`, `tile_parent`, `levels`,
    /// `status`, `args`), cut to the tiles it used: where the value passes of [`phase_of`] start,
    /// so a frame can splat new values of the same points into the same structure.
    pub structure: BTreeMap<String, HostBuffer>,
    pub gpu_ns: f64,
    /// (phase, ns) summed over passes, when the adapter has timestamps.
    pub phase_ns: Vec<(&'static str, f64)>,
}

/// Memory of an octree against the dense vertex lattices of the same resolution (all levels).
#[derive(Clone, Debug, PartialEq)]
pub struct MemoryReport {
    pub nodes: u64,
    pub bricks: u64,
    /// Nodes, bricks and the anisotropic voxels' directional values.
    pub bytes: u64,
    /// The directional values (`svo_anisotropic`; 0 when isotropic), part of `bytes`.
    pub anisotropic_bytes: u64,
    /// The Gaussian lobes' normal pool (0 without lobes), part of `bytes`.
    pub normal_bytes: u64,
    /// The dense vertex lattices of every level, four u32 channels per point.
    pub dense_bytes: u64,
    /// vct-dense at the same effective resolution: the Morton radiance and normal pyramids (`vec4<f32>`
    /// per voxel, every level) of a grid with one voxel per leaf lattice interval (`2 * 2^depth`).
    pub vct_dense_bytes: u64,
}

impl MemoryReport {
    pub fn of(o: &Octree) -> MemoryReport {
        // Tile 0 holds the root alone.
        let nodes = o.levels[o.depth as usize + 1] as u64 * 8 - 7;
        let dense_points: u64 = (0..=o.depth)
            .map(|l| (2u64 << l) + 1)
            .map(|s| s * s * s)
            .sum();
        MemoryReport {
            nodes,
            bricks: nodes,
            bytes: nodes * (NODE_BYTES + BRICK_BYTES),
            anisotropic_bytes: 0,
            normal_bytes: 0,
            dense_bytes: dense_points * 16,
            vct_dense_bytes: 2 * 16 * (0..=o.depth + 1).map(|l| 1u64 << (3 * l)).sum::<u64>(),
        }
    }
}

/// Build, splat and filter an octree on the GPU. `capacity_tiles`: the node pool (tiles of 8 nodes);
/// `None` takes [`default_capacity`]. Fragments outside the volume, a bad depth, a pool too small and
/// fixed-point overflow are errors.
pub fn build_on_gpu(
    ctx: &GpuContext,
    depth: u32,
    fragments: &[Fragment],
    capacity_tiles: Option<u32>,
) -> Result<GpuOctree, SvoError> {
    build_on_gpu_replayed(ctx, depth, fragments, capacity_tiles, None)
}

/// [`build_on_gpu`] with a static part's structure replayed ([`StaticStructure`]: recorded once for a
/// sequence, VCT 4.2.2): the same octree as a build from all fragments, without flagging from the
/// fragments at points the static part covers. Either way only one fragment per point flags nodes
/// (photons share the voxels' points; the structure depends on the points alone).
pub fn build_on_gpu_replayed(
    ctx: &GpuContext,
    depth: u32,
    fragments: &[Fragment],
    capacity_tiles: Option<u32>,
    statics: Option<&StaticStructure>,
) -> Result<GpuOctree, SvoError> {
    if let Some(st) = statics {
        if st.depth != depth {
            return Err(SvoError::StaticDepth {
                recorded: st.depth,
                depth,
            });
        }
    }
    if depth == 0 || depth > MAX_DEPTH {
        return Err(SvoError::Depth(depth));
    }
    let side = 2u32 << depth;
    if let Some((index, f)) = fragments
        .iter()
        .enumerate()
        .find(|(_, f)| f.pos.iter().any(|&x| x > side))
    {
        return Err(SvoError::Outside {
            index,
            pos: f.pos,
            side,
            depth,
        });
    }
    let capacity = capacity_tiles.unwrap_or_else(|| default_capacity(ctx, depth, fragments.len()));
    let case = case_replayed(
        ctx,
        depth,
        capacity.max(1),
        fragments,
        statics,
        true,
        "build_on_gpu".into(),
        0,
    );
    // The structure's passes do not touch the bricks: the one-binding declaration runs them; the
    // values' passes run with the declaration of the pool the structure used.
    let shader = DECL.shader()?;
    // Two submissions: the structure first, then the values with a brick pool of exactly the tiles the
    // structure used. The pool `capacity` must be sized before the structure exists (capacity_bound:
    // ~4x what the Cornell box's 128^3 photons need), but its bricks are 12x its nodes' bytes, so
    // allocating, uploading and reading back only the used bricks saves most of a build's transfers.
    let (mut structure, mut values): (Vec<Pass>, Vec<Pass>) = case
        .passes
        .iter()
        .cloned()
        .partition(|p| phase_of(&p.entry) == "build");
    let mut resources = case.resources;
    // The case bound the pool of `capacity` tiles in windows where it is past one binding.
    let unbind = |passes: &mut [Pass]| {
        for p in passes {
            p.bindings
                .retain(|(b, _)| !BRICK_VIEWS[1..].contains(&b.as_str()));
            for (b, v) in &mut p.bindings {
                if b == "bricks" {
                    *v = View::Buffer("bricks".into());
                }
            }
        }
    };
    resources.insert(
        "bricks".into(),
        HostBuffer::zeroed(4, ScalarKind::U32).into(),
    );
    unbind(&mut structure);
    const STRUCTURE: [&str; 6] = ["nodes", "flags", "tile_parent", "levels", "status", "args"];
    let built =
        vxgi_harness::run::run(ctx, &shader, DECL.name, &resources, &structure, &STRUCTURE)?;
    let status = built.buffer("status").as_u32().to_vec();
    if status[STATUS_ERRORS] & ERR_POOL != 0 {
        let max = max_capacity(ctx);
        let hint = if capacity >= max {
            format!(
                "; {max} tiles is the most the brick pool holds on this device ({} bindings of {} bytes, in one buffer of at most max_buffer_size {} bytes, / {} bytes per tile of bricks): a shallower octree (lower voxels) or fewer fragments",
                BRICK_VIEWS.len(),
                BRICK_WINDOW * 4,
                ctx.limits().max_buffer_size,
                8 * BRICK_BYTES
            )
        } else {
            String::new()
        };
        return Err(SvoError::Pool {
            capacity,
            needed: status[STATUS_TILES],
            hint,
        });
    }
    let used = status[STATUS_TILES] as usize;
    for name in STRUCTURE {
        resources.insert(
            name.to_string(),
            HostResource::Buffer(built.buffer(name).clone()),
        );
    }
    let kept = STRUCTURE
        .iter()
        .map(|&name| {
            let mut b = built.buffer(name).clone();
            let per_tile = match name {
                "nodes" => 8 * NODE_BYTES as usize,
                "flags" => 8 * 4,
                "tile_parent" => 4,
                _ => 0,
            };
            if per_tile > 0 {
                b.bytes.truncate(used * per_tile);
            }
            (name.to_string(), b)
        })
        .collect();
    let pool = HostBuffer::zeroed(used * 8 * BRICK_WORDS * 4, ScalarKind::U32);
    resources.insert("bricks".into(), pool.into());
    let decl = decl_for(used as u32);
    unbind(&mut values);
    if std::ptr::eq(decl, &WINDOWED_DECL) {
        bind_brick_windows(&mut values, &mut resources, "bricks", BRICK_WINDOW)
            .expect("within max_capacity");
    }
    let shader = decl.shader()?;
    let out = vxgi_harness::run::run(ctx, &shader, decl.name, &resources, &values, &CHECKED)?;
    let b = |n: &str| out.resources[n].buffer().expect("read back").clone();
    let status = b("status").as_u32().to_vec();
    let errors = status[STATUS_ERRORS];
    if errors & ERR_OVERFLOW != 0 {
        return Err(SvoError::Overflow);
    }
    debug_assert_eq!(errors & ERR_OUTSIDE, 0, "checked on the host");
    // The pool as the structure left it, cut to the tiles it used: an octree whose pool is full.
    let nodes: Vec<Node> = bytemuck::cast_slice(&b("nodes").bytes).to_vec();
    let mut flags = b("flags").as_u32().to_vec();
    flags.truncate(used * 8);
    let octree = Octree {
        depth,
        capacity_tiles: used as u32,
        nodes: nodes[..used * 8].to_vec(),
        bricks: b("bricks").as_u32().to_vec(),
        flags,
        levels: b("levels").as_u32().to_vec(),
        status,
        stats: b("stats").as_u32().to_vec(),
    };
    let mut phase_ns: Vec<(&'static str, f64)> = Vec::new();
    let timed = structure
        .iter()
        .zip(&built.pass_ns)
        .chain(values.iter().zip(&out.pass_ns));
    for (p, ns) in timed {
        let ph = phase_of(&p.entry);
        match phase_ns.iter_mut().find(|(n, _)| *n == ph) {
            Some(e) => e.1 += ns,
            None => phase_ns.push((ph, *ns)),
        }
    }
    Ok(GpuOctree {
        octree,
        structure: kept,
        gpu_ns: built.gpu_ns + out.gpu_ns,
        phase_ns,
    })
}

/// The fragments of a lit scene, the paper's setting: `scene` voxelized at `2 * 2^depth` voxels per
/// axis (each voxel one point of the leaf vertex lattice), lit by its lights (`voxel_light`, on the GPU);
/// values: radiance RGB and a "lit" channel, in fixed point with `scale`. Unlit voxels are fragments with
/// zero values: they build the structure but receive nothing, which is what the work lists skip.
pub fn scene_fragments(
    ctx: &GpuContext,
    scene: &crate::scene::Scene,
    depth: u32,
    scale: f32,
) -> anyhow::Result<Vec<Fragment>> {
    if depth == 0 || depth > 8 {
        anyhow::bail!(
            "scene fragments need depth 1..=8 (voxelize takes at most 512 voxels per axis)"
        );
    }
    let side = 2u32 << depth;
    let data = crate::trace::SceneData::new(scene);
    let (grid, list, frame) = super::voxelize::voxelize_on_gpu(ctx, scene, side)?;
    let radiance = super::voxel_light::light_on_gpu(ctx, &data, &grid, &list, &frame)?;
    list.iter()
        .map(|&m| {
            let r = radiance[m as usize];
            let lit = r[0] > 0.0 || r[1] > 0.0 || r[2] > 0.0;
            Ok(Fragment {
                pos: vxgi_cpu_mirror::morton::decode(m),
                _pad: 0,
                value: [
                    to_fixed(r[0], scale)?,
                    to_fixed(r[1], scale)?,
                    to_fixed(r[2], scale)?,
                    if lit { to_fixed(1.0, scale)? } else { 0 },
                ],
            })
        })
        .collect::<Result<_, SvoError>>()
        .map_err(Into::into)
}
