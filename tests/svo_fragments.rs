//! `kernels/svo_fragments.wgsl`: its mirror gives the host's fixed-point scale and fragments
//! (`fixed_scale`, `grid_fragments`, and with photons `Photons::values` and `to_fragments`) on lit
//! grids, with and without light, for one and two bounces, at the threshold and one ULP past it; the
//! GPU matches the mirror where the peak halves the scale, on rounding ties, in every photon-mode
//! family and on the threshold of many counts; a value that does not fit, or a point past the
//! lattice, raises its error bit. `fixed_scale`'s bound is the exact sums' scale where every point
//! holds one value, and rounds the product up where nearest would accept an overflow.
use crate::common;
use crate::common::run_case;

use common::{assert_case_passes, gpu};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi::harness::Kernel;
use vxgi::kernels::svo_cone_trace::{coverage_only, fixed_scale, grid_fragments, grid_values};
use vxgi::kernels::svo_fragments::{
    case_for, io_for, largest_fitting, lit_grid, non_empty, passes_case, photon_case_for,
    photon_io_for, random_photons, SvoFragments, DECL,
};
use vxgi::kernels::svo_photons::Photons;
use vxgi_cpu_mirror::sparse_voxel_octree::Fragment;
use vxgi_cpu_mirror::svo_fragments::{
    most_threshold, point_bound, run as mirror, run_photons, scale, threshold, LatticeParams,
    ERR_POINT, ERR_VALUE, SCALE,
};

fn non_zero(f: &[Fragment]) -> Vec<Fragment> {
    f.iter().filter(|f| f.value != [0; 4]).copied().collect()
}

#[test]
fn mirror_gives_the_hosts_scale_and_fragments() {
    for seed in 0..24u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let side = 4 << (seed / 6 % 3);
        let mut radiance = lit_grid(side, &mut rng);
        let list = non_empty(&radiance);
        // A peak that halves the scale, or one at a threshold (fits exactly, or one ULP too large).
        let at = |b| threshold(b, 1) / SCALE;
        let peak = [
            None,
            Some(1.0e20),
            Some(3.0e38),
            Some(at(1)),
            Some(at(1).next_up()),
            Some(at(2).next_up()),
        ][seed as usize % 6];
        if let Some(p) = peak {
            radiance[list[rng.random_range(0..list.len())] as usize][3] = p;
        }
        for cov in [false, true] {
            let values = if cov {
                coverage_only(&radiance)
            } else {
                radiance.clone()
            };
            for bounces in [1, 2] {
                let io = io_for(&radiance, &list, list.len() as u32, 0, cov, bounces);
                let out = mirror(&radiance, &list, list.len() as u32, &io.params.0);
                let s = fixed_scale(grid_values(&values), bounces);
                let at = format!("seed {seed} peak {peak:?} coverage {cov} bounces {bounces}");
                assert_eq!(out.svo_scale, [s, 1.0 / s], "{at}");
                assert_eq!(out.scale_state[1], 0, "{at}");
                assert_eq!(
                    non_zero(&out.fragments),
                    non_zero(&grid_fragments(&values, s).unwrap()),
                    "{at}"
                );
            }
        }
    }
}

#[test]
fn gpu_matches_the_mirror_where_the_scale_halves_and_on_ties() {
    let shader = DECL.shader().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for (peak, cov) in [(1.0e20f32, false), (3.0e38, true), (1.0, false)] {
        let mut radiance = lit_grid(16, &mut rng);
        let list = non_empty(&radiance);
        radiance[list[0] as usize][3] = peak;
        // Every other listed value a tie at the scale the peak leads to, or a neighbour of one.
        let s = scale(peak.to_bits(), threshold(1, 1))[0];
        for &m in &list[1..] {
            for c in &mut radiance[m as usize] {
                let tie = (rng.random_range(0..1u32 << 16) as f32 + 0.5) / s;
                *c = [tie, tie.next_down(), tie.next_up()][rng.random_range(0..3)];
            }
        }
        let io = io_for(&radiance, &list, list.len() as u32, 0, cov, 1);
        let out = mirror(&radiance, &list, list.len() as u32, &io.params.0);
        assert_eq!(out.svo_scale[0], s);
        assert!(peak < 2.0 || s < SCALE / 2.0f32.powi(30), "{peak}: {s}");
        // A tie rounds away from zero.
        let tie = (list[1..].iter().flat_map(|&m| radiance[m as usize]))
            .find(|&v| (v as f64 * s as f64).fract() == 0.5)
            .expect("a tie");
        assert_eq!(
            vxgi_cpu_mirror::svo_fragments::to_fixed(tie, s),
            Some((tie as f64 * s as f64).ceil() as u32)
        );
        let case = case_for(&shader, gpu(), &io, format!("peak {peak}"), 0);
        assert_case_passes(&shader, &SvoFragments, &case);
    }
}

#[test]
fn a_negative_value_raises_the_error_bit() {
    let shader = DECL.shader().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut radiance = lit_grid(8, &mut rng);
    let list = non_empty(&radiance);
    radiance[list[2] as usize] = [-1.0, 0.25, 0.0, 1.0];
    let io = io_for(&radiance, &list, list.len() as u32, 0, false, 1);
    let case = case_for(&shader, gpu(), &io, "negative".into(), 0);
    assert_case_passes(&shader, &SvoFragments, &case);
    let out = run_case(&shader, DECL.name, &case, &["scale_state", "fragments"]);
    assert_eq!(out.buffer("scale_state").as_u32()[1], ERR_VALUE);
    let frags: Vec<Fragment> = bytemuck::pod_collect_to_vec(&out.buffer("fragments").bytes);
    assert_eq!(frags[2].value, [0, 16384, 0, 65536]);
}

/// Photons on the lattice of `side` near `list`'s voxels ([`random_photons`]).
fn photons_near(side: u32, list: &[u32], texels: usize, rng: &mut ChaCha8Rng) -> Photons {
    let near: Vec<[u32; 3]> = list
        .iter()
        .map(|&m| vxgi_cpu_mirror::morton::decode(m))
        .collect();
    random_photons(side, texels, &near, rng)
}

/// Per lattice point and channel, the number of values above 0 among the coverage of `colour` and
/// the photons `ph`.
fn channel_counts(
    colour: &[[f32; 4]],
    ph: &Photons,
) -> std::collections::HashMap<([u32; 3], usize), u32> {
    let mut counts = std::collections::HashMap::new();
    for (p, v) in grid_values(&coverage_only(colour)).chain(ph.values()) {
        for (c, x) in v.into_iter().enumerate() {
            if x > 0.0 {
                *counts.entry((p, c)).or_default() += 1;
            }
        }
    }
    counts
}

#[test]
fn mirror_photon_mode_gives_the_hosts_scale_and_fragments() {
    for seed in 0..24u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(100 + seed);
        let side = 4 << (seed % 3);
        let colour = lit_grid(side, &mut rng);
        let list = non_empty(&colour);
        let texels = rng.random_range(20..300);
        let base = photons_near(side, &list, texels, &mut rng);
        let variant = seed as usize / 3 % 4;
        for bounces in [1, 2] {
            let mut ph = Photons {
                pos: base.pos.clone(),
                value: base.value.clone(),
                spec: base.spec.clone(),
            };
            if variant == 1 {
                // A huge light: the scale halves more than 40 times.
                ph.value[0][1] = 1.0e20;
            }
            let mut expect = None;
            if variant >= 2 {
                // Photon 0's point and red channel made to hold the most values above 0, the
                // largest at the threshold (fits at SCALE) or one ULP above (halves once).
                let counts = channel_counts(&colour, &ph);
                let most = counts.values().copied().max().unwrap_or(0);
                let p = [ph.pos[0][0], ph.pos[0][1], ph.pos[0][2]];
                let k = counts.get(&(p, 0)).copied().unwrap_or(0);
                let want = most.max(k + 1);
                let fit = largest_fitting(want, threshold(bounces, want) / SCALE);
                for j in k..want {
                    let v = if j == k {
                        [fit, fit.next_up()][variant - 2]
                    } else {
                        0.25
                    };
                    ph.pos.push(ph.pos[0]);
                    ph.value.push([v, 0.0, 0.0, 0.0]);
                    ph.spec.push([0.0; 4]);
                }
                expect = Some([SCALE, SCALE / 2.0][variant - 2]);
            }
            let lattice = LatticeParams {
                side,
                photons: ph.pos.len() as u32,
                bounces,
                _pad: 0,
            };
            let n = list.len() as u32;
            let out = run_photons(&colour, &list, n, n, &ph.pos, &ph.value, &ph.spec, &lattice);
            let cov = coverage_only(&colour);
            let s = fixed_scale(grid_values(&cov).chain(ph.values()), bounces);
            let at = format!("seed {seed} variant {variant} bounces {bounces}");
            assert_eq!(out.svo_scale, [s, 1.0 / s], "{at}");
            if let Some(e) = expect {
                assert_eq!(s, e, "{at}");
            }
            if variant == 1 {
                assert!(s < SCALE / 2.0f32.powi(40), "{at}: {s}");
            }
            assert_eq!(out.scale_state[1], 0, "{at}");
            let mut host = grid_fragments(&cov, s).unwrap();
            host.extend(ph.fragments(s).unwrap().light);
            assert_eq!(non_zero(&out.fragments), non_zero(&host), "{at}");
        }
    }
}

/// The scale of the exact per-point channel sums (fixed_scale before the bound replaced them).
fn scale_of_sums(values: impl Iterator<Item = ([u32; 3], [f32; 4])>, bounces: u32) -> f32 {
    let mut sums = std::collections::HashMap::<[u32; 3], ([f64; 4], f64)>::new();
    for (p, v) in values {
        let (s, n) = sums.entry(p).or_default();
        for c in 0..4 {
            s[c] += v[c].max(0.0) as f64;
        }
        *n += 1.0;
    }
    let peak = sums
        .values()
        .flat_map(|(s, _)| s.iter().copied())
        .fold(0.0, f64::max);
    let most = sums.values().map(|(_, n)| *n).fold(0.0, f64::max);
    let b = bounces as f64;
    let fits = |s: f64| 64.0 * (b * (peak * s + most / 2.0) + 1.0) <= u32::MAX as f64;
    let mut s = SCALE as f64;
    while !fits(s) && s > f32::MIN_POSITIVE as f64 {
        s *= 0.5;
    }
    s as f32
}

#[test]
fn fixed_scale_with_one_value_per_point_is_the_exact_sums_scale() {
    for seed in 0..16u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut radiance = lit_grid(8, &mut rng);
        let list = non_empty(&radiance);
        let m = list[rng.random_range(0..list.len())] as usize;
        radiance[m][rng.random_range(0..4)] = [
            1.0,
            1.0e20,
            3.0e38,
            f32::MAX,
            f32::INFINITY,
            f32::NAN,
            threshold(1, 1) / SCALE,
            (threshold(1, 1) / SCALE).next_up(),
        ][seed as usize % 8];
        for b in [1, 2] {
            assert_eq!(
                fixed_scale(grid_values(&radiance), b),
                scale_of_sums(grid_values(&radiance), b),
                "seed {seed} bounces {b}"
            );
        }
    }
    assert_eq!(fixed_scale(std::iter::empty(), 1), SCALE);
}

#[test]
fn fixed_scale_bounds_every_sum_and_rounds_the_product_up() {
    // Several values per point, some channels 0 or negative: the rounded sums at the scale it gives
    // pass the build's test.
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for _ in 0..200 {
        let values: Vec<([u32; 3], [f32; 4])> = (0..rng.random_range(1..200))
            .map(|_| {
                let p = [0; 3].map(|_: u32| rng.random_range(0..3));
                let big = [1.0f32, 1.0e3, 1.0e6][rng.random_range(0..3)];
                (p, [0.0; 4].map(|_: f32| rng.random_range(-0.5..1.0) * big))
            })
            .collect();
        for b in [1, 2] {
            let s = fixed_scale(values.iter().copied(), b);
            let mut sums = std::collections::HashMap::<[u32; 3], [f64; 4]>::new();
            for (p, v) in &values {
                let e = sums.entry(*p).or_default();
                for c in 0..4 {
                    e[c] += vxgi::kernels::sparse_voxel_octree::to_fixed(v[c].max(0.0), s).unwrap()
                        as f64;
                }
            }
            for v in sums.values().flatten() {
                assert!(64.0 * (b as f64 * v + 1.0) <= u32::MAX as f64, "{v} at {s}");
            }
        }
    }
    // n equal values m at one point whose exact sum does not fit at SCALE while the nearest f32 of
    // n m does: the bound (rounded up) halves the scale, nearest would not.
    let mut found = 0;
    for n in 3..3000u32 {
        let p = threshold(1, n) / SCALE;
        let m = largest_fitting(n, p).next_up();
        let values = (0..n).map(|_| ([1, 2, 3], [m, 0.0, 0.0, 0.0]));
        if n as f32 * m > p || scale_of_sums(values.clone(), 1) == SCALE {
            continue;
        }
        assert_eq!(fixed_scale(values, 1), SCALE / 2.0, "n {n}");
        found += 1;
    }
    assert!(found > 0, "{found}");
}

#[test]
fn gpu_matches_the_mirror_in_every_photon_family() {
    let shader = DECL.shader().unwrap();
    let mut seen = [0usize; 8];
    for index in (0..32).filter(|i| (i + i / 8) % 2 == 1) {
        let case = SvoFragments.case(&shader, gpu(), 3, index);
        assert!(case.label.contains("photons"), "{}", case.label);
        assert_case_passes(&shader, &SvoFragments, &case);
        // What the family claims to reach, by the mirror.
        let out = SvoFragments.mirror(&case, &case.resources, vxgi::harness::FloatMode::Ieee);
        let state = out["scale_state"].as_u32();
        let s = out["svo_scale"].as_f32()[0];
        let (family, round) = (index % 8, index / 8);
        match family {
            2 => assert!(s < SCALE / 2.0f32.powi(30), "{}: {s}", case.label),
            4 => assert_ne!(state[1], 0, "{}", case.label),
            6 => assert_eq!(s, [SCALE, SCALE / 2.0][round % 2], "{}", case.label),
            7 => assert!(state[2] >= 200, "{}", case.label),
            _ => assert_eq!(state[1], 0, "{}", case.label),
        }
        seen[family] += 1;
    }
    assert!(seen.iter().all(|&n| n == 2), "{seen:?}");
}

#[test]
fn gpu_threshold_from_the_most_values_is_the_mirrors() {
    let shader = DECL.shader().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let colour = lit_grid(4, &mut rng);
    let list = non_empty(&colour);
    let n = list.len() as u32;
    let limit = u32::MAX - 64;
    for b in [1u32, 2] {
        let mut ns = vec![0u32, 1, 2, 3, 7, 100, 1000, 65_537, 1 << 20];
        // T = 2^24, T = 1 and T < 0.
        for c in [
            (limit - (b << 30)) / (32 * b),
            (limit - 64 * b) / (32 * b),
            limit / 32 / b,
        ] {
            ns.extend([c - 1, c, c + 1]);
        }
        for most in ns {
            let mut io = photon_io_for(&colour, &list, n, n, &Photons::default(), 4, b);
            io.scale_state = vec![1.0f32.to_bits(), 0, most, 0];
            let case = passes_case(
                &shader,
                gpu(),
                &io,
                &["lattice_scale"],
                format!("b {b} most {most}"),
                0,
            );
            assert_case_passes(&shader, &SvoFragments, &case);
            let t = most_threshold(b, most);
            let host = threshold(b, most);
            assert_eq!(
                t.to_bits(),
                if host < 0.0 {
                    (-1.0f32).to_bits()
                } else {
                    host.to_bits()
                }
            );
            let out = SvoFragments.mirror(&case, &case.resources, vxgi::harness::FloatMode::Ieee);
            assert_eq!(
                out["scale_state"].as_u32()[3],
                t.to_bits(),
                "b {b} most {most}"
            );
        }
    }
}

#[test]
fn gpu_point_bound_is_the_mirrors() {
    // One lattice point (side 0) holding n values of largest m: lattice_peak leaves its bound.
    let shader = DECL.shader().unwrap();
    let colour = vec![[0.0; 4]];
    let ms = [
        f32::from_bits(1),
        f32::from_bits(0x7f_ffff),
        f32::MIN_POSITIVE,
        0.1,
        1.0,
        1.0f32.next_down(),
        16_777_215.0,
        3.0e38,
        f32::MAX,
        f32::INFINITY,
    ];
    let ns = [
        1u32,
        3,
        7,
        255,
        65_537,
        (1 << 24) + 1,
        0x7fff_ffff,
        u32::MAX,
    ];
    for &m in &ms {
        for &n in &ns {
            let mut io = photon_io_for(&colour, &[0], 0, 1, &Photons::default(), 0, 1);
            io.point_count = vec![n];
            io.point_max = vec![m.to_bits()];
            let label = format!("n {n} m {m:e}");
            let case = passes_case(&shader, gpu(), &io, &["lattice_peak"], label.clone(), 0);
            assert_case_passes(&shader, &SvoFragments, &case);
            let out = SvoFragments.mirror(&case, &case.resources, vxgi::harness::FloatMode::Ieee);
            let state = out["scale_state"].as_u32();
            assert_eq!(
                (state[0], state[2]),
                (point_bound(n, m.to_bits()), n),
                "{label}"
            );
        }
    }
}

#[test]
fn a_photon_past_the_lattice_raises_the_point_error_bit() {
    let shader = DECL.shader().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let colour = lit_grid(8, &mut rng);
    let list = non_empty(&colour);
    let n = list.len() as u32;
    let mut ph = photons_near(8, &list, 40, &mut rng);
    ph.pos[3] = [8, 9, 0, 1];
    // On the upper faces: inside.
    ph.pos[4] = [8, 8, 8, 1];
    ph.value[3] = [1.0; 4];
    ph.value[4] = [1.0; 4];
    let io = photon_io_for(&colour, &list, n, n, &ph, 8, 1);
    let case = photon_case_for(&shader, gpu(), &io, "past the lattice".into(), 0);
    assert_case_passes(&shader, &SvoFragments, &case);
    let out = run_case(&shader, DECL.name, &case, &["scale_state", "point_count"]);
    assert_eq!(out.buffer("scale_state").as_u32()[1], ERR_POINT);
    // The last point's red channel.
    assert!(out.buffer("point_count").as_u32()[4 * (9 * 9 * 9 - 1)] >= 1);
}

#[test]
fn params_structs_match_the_reflected_wgsl_layout() {
    use vxgi_cpu_mirror::svo_fragments::FragmentParams;
    let shader = DECL.shader().unwrap();
    let check = |name: &str, size: usize, want: &[(&str, usize)]| {
        let (s, members) = shader.struct_layout(name).unwrap();
        assert_eq!(s as usize, size, "{name}");
        let want: Vec<(String, u32)> = want
            .iter()
            .map(|(n, o)| (n.to_string(), *o as u32))
            .collect();
        assert_eq!(members, want, "{name}");
    };
    check(
        "FragmentParams",
        std::mem::size_of::<FragmentParams>(),
        &[
            ("capacity", std::mem::offset_of!(FragmentParams, capacity)),
            (
                "coverage_only",
                std::mem::offset_of!(FragmentParams, coverage_only),
            ),
            ("threshold", std::mem::offset_of!(FragmentParams, threshold)),
            ("_pad", std::mem::offset_of!(FragmentParams, _pad)),
        ],
    );
    check(
        "LatticeParams",
        std::mem::size_of::<LatticeParams>(),
        &[
            ("side", std::mem::offset_of!(LatticeParams, side)),
            ("photons", std::mem::offset_of!(LatticeParams, photons)),
            ("bounces", std::mem::offset_of!(LatticeParams, bounces)),
            ("_pad", std::mem::offset_of!(LatticeParams, _pad)),
        ],
    );
}
