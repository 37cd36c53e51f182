//! Declaration of `kernels/svo_fragments.wgsl` (mirror: `vxgi_cpu_mirror::svo_fragments`) and its
//! cases: the sparse voxel octree's fragments of a lit voxel grid and their fixed-point scale, built on
//! the GPU from the voxel list (what [`fixed_scale`](super::svo_cone_trace::fixed_scale) and
//! [`grid_fragments`](super::svo_cone_trace::grid_fragments) do on the host). Three passes, `peak`,
//! `scale`, `fragments`, verified together: every output is exact.
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::sparse_voxel_octree::Fragment;
use vxgi_cpu_mirror::svo_fragments::{run, threshold, SCALE};
pub use vxgi_cpu_mirror::svo_fragments::{FragmentParams, STATE_WORDS};
use vxgi_harness::bindings::{Block, Structs};
use vxgi_harness::{
    Bindings, Case, DispatchRule, FloatMode, GpuContext, HostBuffer, Kernel, KernelDecl, Resources,
    Shader, Tolerance,
};

pub const WGSL: &str = include_str!("../../kernels/svo_fragments.wgsl");

const _: () = assert!(SCALE == super::svo_cone_trace::SCALE);

vxgi_harness::bindings! {
    /// svo_fragments' bindings: a Morton voxel grid and the list of its non-empty voxels in; the
    /// peak and error bits, the scale and the fragments out.
    pub struct Io {
        inputs: {
            params: Block<FragmentParams>,
            vox_radiance: Vec<[f32; 4]>,
            list: Vec<u32>,
            list_count: Vec<u32>,
        }
        outputs: {
            // Integer max on the bits of non-negative floats, and error bits by atomicOr: exact.
            scale_state: Vec<u32> => Tolerance::Exact,
            // Halvings and doublings of powers of two, and comparisons of products with a power of
            // two that stay in f32's normal range (or far below the threshold): exact.
            svo_scale: Vec<f32> => Tolerance::Exact,
            // Morton decode (integer), v * scale (a power of two: exact), floor, an exact difference
            // and comparisons, conversion of an integer-valued float: exact. A subnormal value, which
            // a GPU may flush, gives 0 either way (at most 2^-126 * 2^16 < 0.5).
            fragments: Structs<Fragment> => Tolerance::Exact,
        }
    }
}

pub static DECL: KernelDecl = KernelDecl {
    name: "svo_fragments",
    wgsl_path: "kernels/svo_fragments.wgsl",
    wgsl: WGSL,
    includes: &[],
    entry: "peak",
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerItem {
        what: "fragment slot (peak, fragments: capacity invocations); one invocation (scale)",
    },
    mirror: "vxgi_cpu_mirror::svo_fragments::run",
    summary: "the octree's fragments of a lit voxel grid on the GPU: peak value, largest fitting power-of-two fixed-point scale, Morton-decoded points and values rounded half away from zero",
};

/// The three passes over `capacity` fragment slots.
pub fn case_for(shader: &Shader, ctx: &GpuContext, io: &Io, label: String, seed: u64) -> Case {
    let capacity = io.params.0.capacity as u64;
    let passes = [
        ("peak", capacity),
        ("scale", 1),
        ("write_fragments", capacity),
    ]
    .into_iter()
    .map(|(entry, n)| {
        let mut p = DECL.pass(shader, ctx, entry.into(), DECL.bind_by_name(), n);
        p.entry = entry.into();
        p
    })
    .collect();
    io.case(label, seed, passes)
}

/// The bindings of `list[..count]` (distinct Morton indices of `radiance`) in `capacity` slots (at
/// least `count` and 1), for a frame of `bounces` bounces: a zeroed `scale_state` and outputs.
pub fn io_for(
    radiance: &[[f32; 4]],
    list: &[u32],
    count: u32,
    capacity: u32,
    coverage_only: bool,
    bounces: u32,
) -> Io {
    let capacity = capacity.max(count).max(1);
    let mut slots = list[..count as usize].to_vec();
    slots.resize(capacity as usize, 0);
    Io {
        params: Block(FragmentParams {
            capacity,
            coverage_only: coverage_only as u32,
            // One fragment per lattice point: the voxels are distinct.
            threshold: threshold(bounces, 1),
            _pad: 0,
        }),
        vox_radiance: radiance.to_vec(),
        list: slots,
        list_count: vec![count],
        scale_state: vec![0; STATE_WORDS],
        svo_scale: vec![0.0; 2],
        fragments: Structs(vec![bytemuck::Zeroable::zeroed(); capacity as usize]),
    }
}

/// Values that are hard for the fixed point and fit it: zeros of both signs, subnormals, the smallest
/// normal, ties after scaling by [`SCALE`] and their neighbours.
pub fn hard_value(rng: &mut ChaCha8Rng) -> f32 {
    let tie = (rng.random_range(0..1u32 << 20) as f32 + 0.5) / SCALE;
    match rng.random_range(0..8) {
        0 => 0.0,
        1 => -0.0,
        2 => f32::from_bits(rng.random_range(1..0x0080_0000)),
        3 => f32::MIN_POSITIVE,
        4 => tie,
        5 => tie.next_down(),
        6 => (0.5 / SCALE).next_down(),
        _ => 0.5 / SCALE,
    }
}

/// A lit Morton grid of side `side` as voxel_light writes it, `(L alpha, alpha)`: a quarter of the
/// voxels non-empty, their channels random with one in eight a [`hard_value`].
pub fn lit_grid(side: u32, rng: &mut ChaCha8Rng) -> Vec<[f32; 4]> {
    (0..side.pow(3))
        .map(|_| {
            if rng.random_range(0..4) != 0 {
                return [0.0; 4];
            }
            let alpha: f32 = [1.0, rng.random_range(0.0..1.0)][rng.random_range(0..2)];
            let mut v = [0.0; 4].map(|_: f32| rng.random_range(0.0..4.0) * alpha);
            v[3] = alpha;
            v.map(|c| {
                if rng.random_range(0..8) == 0 {
                    hard_value(rng)
                } else {
                    c
                }
            })
        })
        .collect()
}

/// Morton indices of the voxels with a non-zero channel, ascending.
pub fn non_empty(radiance: &[[f32; 4]]) -> Vec<u32> {
    (0..radiance.len() as u32)
        .filter(|&m| radiance[m as usize].iter().any(|&c| c != 0.0))
        .collect()
}

pub struct SvoFragments;

impl Kernel for SvoFragments {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    /// Families by `index % 8`: random; fewer entries than slots; a huge peak (the scale halves
    /// many times); every voxel 0; a value that does not fit; ties after scaling; a peak exactly at
    /// the threshold or one ULP above; an empty list. Sides 4..32, coverage only and bounces vary.
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let mut rng = ChaCha8Rng::seed_from_u64(
            seed.wrapping_mul(0x9e37_79b9_7f4a_7c15)
                .wrapping_add(index as u64),
        );
        let side = 4u32 << ((index + index / 8) % 4);
        let coverage_only = (index / 4 + index / 8) % 2 == 1;
        let bounces = 1 + (index / 2 + index / 8) as u32 % 2;
        let (family, round) = (index % 8, index / 8);
        let mut radiance = lit_grid(side, &mut rng);
        let mut list = non_empty(&radiance);
        if family == 3 {
            radiance.fill([0.0; 4]);
        }
        if list.is_empty() {
            list.push(rng.random_range(0..side.pow(3)));
        }
        list.shuffle(&mut rng);
        let count = match family {
            7 => 0,
            1 => rng.random_range(0..=list.len() as u32),
            _ => list.len() as u32,
        };
        let capacity = count + [0, rng.random_range(1..100)][matches!(family, 1 | 7) as usize];
        // Where a special value goes: a listed voxel, a channel coverage_only keeps.
        let (m, c) = (
            list[0] as usize,
            if coverage_only {
                3
            } else {
                rng.random_range(0..4)
            },
        );
        let at_threshold = threshold(bounces, 1) / SCALE;
        match family {
            2 => {
                // Every listed value scaled up with the peak: the fixed point's whole range.
                let huge = [1.0e20, 3.0e38, f32::MAX][round % 3];
                for &m in &list {
                    radiance[m as usize] = radiance[m as usize].map(|v| v * (huge / 16.0));
                }
                radiance[m][c] = huge;
            }
            4 => {
                radiance[m][c] =
                    [-1.0, -0.5 / SCALE, f32::NAN, f32::INFINITY, -f32::INFINITY][round % 5]
            }
            5 => {
                for &m in &list {
                    radiance[m as usize] = [0.0; 4].map(|_: f32| {
                        let tie = (rng.random_range(0..1u32 << 16) as f32 + 0.5) / SCALE;
                        [tie, tie.next_down(), tie.next_up()][rng.random_range(0..3)]
                    });
                }
            }
            6 => radiance[m][c] = [at_threshold, at_threshold.next_up()][round % 2],
            _ => {}
        }
        let io = io_for(&radiance, &list, count, capacity, coverage_only, bounces);
        let label = format!(
            "#{index} {side}^3 family {family} {count}/{} listed, bounces {bounces}{}",
            io.params.0.capacity,
            if coverage_only { ", coverage only" } else { "" }
        );
        case_for(shader, ctx, &io, label, seed)
    }

    /// The three passes from the case's inputs (every operation exact: no float mode).
    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        let mut io = Io::read(data);
        let out = run(&io.vox_radiance, &io.list, io.list_count[0], &io.params.0);
        io.scale_state = out.scale_state.to_vec();
        io.svo_scale = out.svo_scale.to_vec();
        io.fragments = Structs(out.fragments);
        io.outputs()
    }
}
