//! Declaration of `kernels/svo_fragments.wgsl` (mirror: `vxgi_cpu_mirror::svo_fragments`) and its
//! cases: the sparse voxel octree's fragments and their fixed-point scale, built on the GPU, of a lit
//! voxel grid (voxel mode: what [`fixed_scale`](super::svo_cone_trace::fixed_scale) and
//! [`grid_fragments`](super::svo_cone_trace::grid_fragments) do on the host) or of a voxel grid's
//! coverage and a photon map (photon mode: the same with [`Photons::values`] and
//! [`to_fragments`](super::svo_photons::to_fragments)). The passes are verified together, in the
//! case's order: every output is exact.
use super::svo_photons::Photons;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::sparse_voxel_octree::Fragment;
use vxgi_cpu_mirror::svo_fragments::{
    fragments, lattice_peak, lattice_scale, peak, photon_fragments, photon_points, point_bound,
    point_index, scale, threshold, voxel_points, SCALE,
};
pub use vxgi_cpu_mirror::svo_fragments::{FragmentParams, LatticeParams, STATE_WORDS};
use vxgi_harness::bindings::{Block, Structs};
use vxgi_harness::prelude::*;

const _: () = assert!(SCALE == super::svo_cone_trace::SCALE);

vxgi_harness::bindings! {
    /// svo_fragments' bindings: a Morton voxel grid and the list of its non-empty voxels, and in photon
    /// mode the photons, in; the peak and error bits, the scale, the fragments and the per-point counts
    /// and maxima out.
    pub struct Io {
        inputs: {
            params: Block<FragmentParams>,
            lattice_params: Block<LatticeParams>,
            vox_radiance: Vec<[f32; 4]>,
            list: Vec<u32>,
            list_count: Vec<u32>,
            photon_pos: Vec<[u32; 4]>,
            photon_value: Vec<[f32; 4]>,
            photon_spec: Vec<[f32; 4]>,
        }
        outputs: {
            // Integer max on the bits of non-negative floats (peak, and most: counts), error bits by
            // atomicOr, the point bound's integer product and the threshold's integer division cut
            // to an f32 by exact conversions: exact.
            scale_state: Vec<u32> => Tolerance::Exact,
            // Halvings and doublings of powers of two, and comparisons of products with a power of
            // two that stay in f32's normal range (or far below the threshold): exact.
            svo_scale: Vec<f32> => Tolerance::Exact,
            // Morton decode (integer), v * scale (a power of two: exact), floor, an exact difference
            // and comparisons, conversion of an integer-valued float: exact. A subnormal value, which
            // a GPU may flush, gives 0 either way (at most 2^-126 * 2^16 < 0.5).
            fragments: Structs<Fragment> => Tolerance::Exact,
            // Atomic counts per point and channel: exact whatever the order.
            point_count: Vec<u32> => Tolerance::Exact,
            // Integer max on bits; spec_max's one correctly rounded sum of exact halves of normal
            // floats, every special or tiny operand decided on bits (no flush or NaN rule reaches
            // it): exact.
            point_max: Vec<u32> => Tolerance::Exact,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "svo_fragments",
    includes: &[super::MORTON],
    entry: "peak",
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerItem {
        what: "fragment slot (peak, voxel_points, write_fragments: capacity invocations); photon texel (photon_points, write_photon_fragments); lattice point and channel (lattice_peak: 4 (side + 1)^3); one invocation (scale, lattice_scale)",
    },
    mirror: "vxgi_cpu_mirror::svo_fragments::{run, run_photons}",
    summary: "the octree's fragments of a lit voxel grid, or of a grid's coverage and a photon map, on the GPU: per-point, per-channel counts and maxima, a peak bound, the largest fitting power-of-two fixed-point scale, Morton-decoded points and values rounded half away from zero",
);

/// Voxel mode's entry points, in order.
pub const VOXEL_PASSES: [&str; 3] = ["peak", "scale", "write_fragments"];
/// Photon mode's entry points, in order.
pub const PHOTON_PASSES: [&str; 6] = [
    "voxel_points",
    "photon_points",
    "lattice_peak",
    "lattice_scale",
    "write_fragments",
    "write_photon_fragments",
];

/// Invocations of `entry` for `io`: capacity slots, photon texels, lattice points' channels, or one.
pub fn invocations(io: &Io, entry: &str) -> u64 {
    let w = io.lattice_params.0.side as u64 + 1;
    match entry {
        "scale" | "lattice_scale" => 1,
        "photon_points" | "write_photon_fragments" => io.lattice_params.0.photons as u64,
        "lattice_peak" => 4 * w * w * w,
        _ => io.params.0.capacity as u64,
    }
}

/// The passes `entries` in order over `io`'s bindings.
pub fn passes_case(
    shader: &Shader,
    ctx: &GpuContext,
    io: &Io,
    entries: &[&str],
    label: String,
    seed: u64,
) -> Case {
    let passes = entries
        .iter()
        .map(|&entry| {
            let n = invocations(io, entry);
            let mut p = DECL.pass(shader, ctx, entry.into(), DECL.bind_by_name(), n);
            p.entry = entry.into();
            p
        })
        .collect();
    io.case(label, seed, passes)
}

/// Voxel mode's three passes over `capacity` fragment slots.
pub fn case_for(shader: &Shader, ctx: &GpuContext, io: &Io, label: String, seed: u64) -> Case {
    passes_case(shader, ctx, io, &VOXEL_PASSES, label, seed)
}

/// Photon mode's six passes.
pub fn photon_case_for(
    shader: &Shader,
    ctx: &GpuContext,
    io: &Io,
    label: String,
    seed: u64,
) -> Case {
    passes_case(shader, ctx, io, &PHOTON_PASSES, label, seed)
}

/// The bindings of `list[..count]` (distinct Morton indices of `radiance`) in `capacity` slots (at
/// least `count` and 1), for a frame of `bounces` bounces: a zeroed `scale_state` and outputs. The
/// photon bindings hold one unused element each.
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
        lattice_params: Block(LatticeParams::default()),
        vox_radiance: radiance.to_vec(),
        list: slots,
        list_count: vec![count],
        photon_pos: vec![[0; 4]],
        photon_value: vec![[0.0; 4]],
        photon_spec: vec![[0.0; 4]],
        scale_state: vec![0; STATE_WORDS],
        svo_scale: vec![0.0; 2],
        fragments: Structs(vec![bytemuck::Zeroable::zeroed(); capacity as usize]),
        point_count: vec![0],
        point_max: vec![0],
    }
}

/// Photon mode's bindings: the coverage of the colour grid `colour`'s listed voxels (`list[..count]`
/// in `capacity` slots, at least `count` and 1) and `photons` on the lattice of side `side` (the
/// grid's), for a frame of `bounces` bounces: zeroed state, `capacity + texels` fragment slots,
/// `4 (side + 1)^3` words per point buffer.
pub fn photon_io_for(
    colour: &[[f32; 4]],
    list: &[u32],
    count: u32,
    capacity: u32,
    photons: &Photons,
    side: u32,
    bounces: u32,
) -> Io {
    let mut io = io_for(colour, list, count, capacity, true, bounces);
    let texels = photons.pos.len();
    let words = 4 * (side as usize + 1).pow(3);
    // Unused: lattice_scale takes the threshold of the most values at one point.
    io.params.0.threshold = 0.0;
    io.lattice_params = Block(LatticeParams {
        side,
        photons: texels as u32,
        bounces,
        _pad: 0,
    });
    // A binding cannot be empty: one unused texel where there is none.
    let or_one = |v: &[[f32; 4]]| {
        if v.is_empty() {
            vec![[0.0; 4]]
        } else {
            v.to_vec()
        }
    };
    io.photon_pos = if texels == 0 {
        vec![[0; 4]]
    } else {
        photons.pos.clone()
    };
    io.photon_value = or_one(&photons.value);
    io.photon_spec = or_one(&photons.spec);
    io.fragments.0.resize(
        io.params.0.capacity as usize + texels,
        bytemuck::Zeroable::zeroed(),
    );
    io.point_count = vec![0; words];
    io.point_max = vec![0; words];
    io
}

/// The kernel's passes `entries` in order, by the mirror, over `io`'s buffers as they stand.
pub fn mirror_passes(io: &mut Io, entries: &[&str]) {
    let p = io.params.0;
    let l = io.lattice_params.0;
    let cov = p.coverage_only != 0;
    let count = io.list_count[0].min(p.capacity);
    for &entry in entries {
        match entry {
            "peak" => {
                let k = peak(&io.vox_radiance, &io.list, count, cov);
                io.scale_state[0] = io.scale_state[0].max(k);
            }
            "scale" => io.svo_scale = scale(io.scale_state[0], p.threshold).to_vec(),
            "write_fragments" => {
                let (f, e) = fragments(
                    &io.vox_radiance,
                    &io.list,
                    count,
                    p.capacity,
                    cov,
                    io.svo_scale[0],
                );
                io.fragments.0[..f.len()].copy_from_slice(&f);
                io.scale_state[1] |= e;
            }
            "voxel_points" => {
                io.scale_state[1] |= voxel_points(
                    &io.vox_radiance,
                    &io.list,
                    count,
                    cov,
                    l.side,
                    &mut io.point_count,
                    &mut io.point_max,
                )
            }
            "photon_points" => {
                io.scale_state[1] |= photon_points(
                    &io.photon_pos,
                    &io.photon_value,
                    &io.photon_spec,
                    l.photons,
                    l.side,
                    &mut io.point_count,
                    &mut io.point_max,
                )
            }
            "lattice_peak" => {
                let (k, most) = lattice_peak(&io.point_count, &io.point_max);
                io.scale_state[0] = io.scale_state[0].max(k);
                io.scale_state[2] = io.scale_state[2].max(most);
            }
            "lattice_scale" => {
                let (s, t) = lattice_scale(io.scale_state[0], io.scale_state[2], l.bounces);
                io.scale_state[3] = t.to_bits();
                io.svo_scale = s.to_vec();
            }
            "write_photon_fragments" => {
                let (f, e) =
                    photon_fragments(&io.photon_pos, &io.photon_value, l.photons, io.svo_scale[0]);
                let c = p.capacity as usize;
                io.fragments.0[c..c + f.len()].copy_from_slice(&f);
                io.scale_state[1] |= e;
            }
            e => panic!("svo_fragments has no entry point `{e}`"),
        }
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

/// `texels` photon texels on the lattice of side `side` as svo_photons writes them, several per
/// point: their points drawn from `texels / 4 + 1`, about half of them from `near` (the listed
/// voxels' points) and one in eight of the others on an upper face of the lattice (a coordinate =
/// `side`). One texel in eight but the first holds no photon (`pos.w = 0`, its values garbage: NaN,
/// infinities, negatives). The light is random in 0..4, the specular part `(q, w)` with `|q| <= w`
/// (w 0 on half the texels), one channel in eight of each a [`hard_value`].
pub fn random_photons(
    side: u32,
    texels: usize,
    near: &[[u32; 3]],
    rng: &mut ChaCha8Rng,
) -> Photons {
    let points: Vec<[u32; 3]> = (0..texels / 4 + 1)
        .map(|_| {
            if !near.is_empty() && rng.random_range(0..2) == 0 {
                return near[rng.random_range(0..near.len())];
            }
            let mut p = [0; 3].map(|_: u32| rng.random_range(0..=side));
            if rng.random_range(0..8) == 0 {
                p[rng.random_range(0..3)] = side;
            }
            p
        })
        .collect();
    let hard = |rng: &mut ChaCha8Rng, v: f32| {
        if rng.random_range(0..8) == 0 {
            hard_value(rng)
        } else {
            v
        }
    };
    let mut out = Photons::default();
    for t in 0..texels {
        let [x, y, z] = points[rng.random_range(0..points.len())];
        if t > 0 && rng.random_range(0..8) == 0 {
            out.pos.push([x, y, z, 0]);
            out.value
                .push([f32::NAN, -1.0, f32::INFINITY, rng.random_range(0.0..1.0)]);
            out.spec.push([f32::NEG_INFINITY, f32::NAN, 1.0e30, -1.0]);
            continue;
        }
        out.pos.push([x, y, z, 1]);
        let mut v = [0.0; 4].map(|_: f32| rng.random_range(0.0..4.0));
        for c in &mut v[..3] {
            *c = hard(rng, *c);
        }
        out.value.push(v);
        let w: f32 = [0.0, rng.random_range(0.0..2.0)][rng.random_range(0..2)];
        let mut q = [0.0; 4].map(|_: f32| rng.random_range(-1.0..=1.0) * w);
        q[3] = w;
        out.spec.push(q.map(|c| hard(rng, c)));
    }
    out
}

/// The largest f32 `m` with `point_bound(n, m) <= target` (n >= 1, target finite and >= 0).
pub fn largest_fitting(n: u32, target: f32) -> f32 {
    let fits = |m: f32| f32::from_bits(point_bound(n, m.to_bits())) <= target;
    let mut m = target / n as f32;
    while !fits(m) {
        m = m.next_down();
    }
    while fits(m.next_up()) {
        m = m.next_up();
    }
    m
}

pub struct SvoFragments;

impl Kernel for SvoFragments {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    /// Voxel mode where `(index + index / 8)` is even, photon mode where it is odd. Families by
    /// `index % 8`: random; fewer entries than slots (photon mode: half the texels empty); a huge
    /// peak (the scale halves many times; photon mode: huge light, and a specular sum overflowing
    /// to +inf); every value 0; a value that does not fit (photon mode: also NaN and infinities in
    /// the specular part, a point past the lattice); ties after scaling; a peak exactly at the
    /// threshold or one ULP above (photon mode: in a light channel of a point made to hold the most
    /// values, a count that is mostly no power of two, so n m rounds); an empty list (photon mode:
    /// and a pile of hundreds of photons at one point). Sides 4..32, coverage only and bounces vary.
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let mut rng = ChaCha8Rng::seed_from_u64(
            seed.wrapping_mul(0x9e37_79b9_7f4a_7c15)
                .wrapping_add(index as u64),
        );
        if (index + index / 8) % 2 == 1 {
            return photon_case(shader, ctx, seed, index, &mut rng);
        }
        let side = 4u32 << ((index / 2 + index / 8) % 4);
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

    /// The case's passes in order, from its own inputs (the state before the first pass: every
    /// operation is exact, nothing to take from the GPU's read-back).
    fn mirror(&self, case: &Case, _data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(&case.resources);
        let entries: Vec<&str> = case.passes.iter().map(|p| p.entry.as_str()).collect();
        mirror_passes(&mut io, &entries);
        io.outputs()
    }
}

/// A photon-mode case: a lit colour grid's listed voxels and random photons ([`random_photons`]) on
/// its lattice, in the family of `index % 8` (see [`SvoFragments::case`]).
fn photon_case(
    shader: &Shader,
    ctx: &GpuContext,
    seed: u64,
    index: usize,
    rng: &mut ChaCha8Rng,
) -> Case {
    let side = 4u32 << ((index / 2 + index / 8) % 4);
    let bounces = 1 + (index / 4 + index / 8) as u32 % 2;
    let (family, round) = (index % 8, index / 8);
    let mut colour = lit_grid(side, rng);
    let mut list = non_empty(&colour);
    if family == 3 {
        colour.fill([0.0; 4]);
    }
    list.shuffle(rng);
    let count = match family {
        7 => 0,
        1 => rng.random_range(0..=list.len() as u32),
        _ => list.len() as u32,
    };
    let capacity = count + [0, rng.random_range(1..100)][matches!(family, 1 | 7) as usize];
    let near: Vec<[u32; 3]> = list[..count as usize]
        .iter()
        .map(|&m| vxgi_cpu_mirror::morton::decode(m))
        .collect();
    let texels = rng.random_range(16..400);
    let mut ph = random_photons(side, texels, &near, rng);
    // Special values go to texel 0 (it holds a photon), in channel c of its light.
    let c = rng.random_range(0..3);
    match family {
        1 => {
            for t in 1..texels {
                if rng.random_range(0..2) == 0 {
                    ph.pos[t][3] = 0;
                }
            }
        }
        2 => {
            let huge = [1.0e20, 3.0e38, f32::MAX][round % 3];
            for v in &mut ph.value {
                *v = v.map(|x| x * (huge / 16.0));
            }
            ph.value[0][c] = huge;
            // 3e38 + 3e38 overflows: spec_max +inf, the smallest scale.
            ph.spec[0] = [huge, 0.0, -huge, huge];
        }
        3 => {
            for (v, q) in ph.value.iter_mut().zip(&mut ph.spec) {
                *v = [0.0; 4];
                *q = [0.0; 4];
            }
        }
        4 => match round % 6 {
            5 => ph.pos[0] = [side + 1, 0, side, 1],
            r => {
                ph.value[0][c] = [-1.0, -0.5 / SCALE, f32::NAN, f32::INFINITY, -f32::INFINITY][r];
                // +inf (the smallest scale) only beside a non-finite light, an error at any scale.
                let w = [1.0, f32::INFINITY][(r == 3) as usize];
                ph.spec[0] = [f32::NAN, f32::NEG_INFINITY, 0.5, w];
            }
        },
        5 => {
            for v in &mut ph.value {
                for x in &mut v[..3] {
                    let tie = (rng.random_range(0..1u32 << 16) as f32 + 0.5) / SCALE;
                    *x = [tie, tie.next_down(), tie.next_up()][rng.random_range(0..3)];
                }
            }
        }
        6 => {
            // The point and light channel with the most values above 0 made to hold the most of
            // all (one more every other round: a count that is mostly no power of two, so n m
            // rounds), its largest at the threshold or one ULP above.
            let words = 4 * (side as usize + 1).pow(3);
            let (mut n, mut m) = (vec![0; words], vec![0; words]);
            let l = &list[..count as usize];
            voxel_points(&colour, l, count, true, side, &mut n, &mut m);
            photon_points(
                &ph.pos,
                &ph.value,
                &ph.spec,
                texels as u32,
                side,
                &mut n,
                &mut m,
            );
            let most = *n.iter().max().unwrap();
            let i = point_index(side, [ph.pos[0][0], ph.pos[0][1], ph.pos[0][2]]).unwrap();
            let k = n[4 * i + c];
            let want = most.max(k + 1) + (round % 4 >= 2) as u32;
            let fit = largest_fitting(want, most_threshold_of(bounces, want) / SCALE);
            for j in k..want {
                let mut v = [0.0; 4];
                v[c] = if j == k {
                    [fit, fit.next_up()][round % 2]
                } else {
                    0.5
                };
                ph.pos.push(ph.pos[0]);
                ph.value.push(v);
                ph.spec.push([0.0; 4]);
            }
        }
        7 => {
            // Hundreds of photons at one point: n m rounds.
            let p = ph.pos[0];
            for _ in 0..rng.random_range(200..600) {
                ph.pos.push(p);
                ph.value
                    .push([0.0; 4].map(|_: f32| rng.random_range(0.0..1.0)));
                ph.spec.push([0.0; 4]);
            }
        }
        _ => {}
    }
    let io = photon_io_for(&colour, &list, count, capacity, &ph, side, bounces);
    let label = format!(
        "#{index} photons {side}^3 family {family} {count}/{} listed, {} texels, bounces {bounces}",
        io.params.0.capacity,
        ph.pos.len()
    );
    photon_case_for(shader, ctx, &io, label, seed)
}

fn most_threshold_of(bounces: u32, most: u32) -> f32 {
    vxgi_cpu_mirror::svo_fragments::most_threshold(bounces, most)
}
