//! `kernels/svo_fragments.wgsl`: its mirror gives the host's fixed-point scale and fragments
//! (`fixed_scale`, `grid_fragments`) on lit grids, with and without light, for one and two bounces;
//! the GPU matches the mirror where the peak halves the scale and on rounding ties; a value that does
//! not fit raises the error bit.
use crate::common;

use common::{assert_case_passes, gpu};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi::harness::run::run;
use vxgi::kernels::svo_cone_trace::{coverage_only, fixed_scale, grid_fragments, grid_values};
use vxgi::kernels::svo_fragments::{case_for, io_for, lit_grid, non_empty, SvoFragments, DECL};
use vxgi_cpu_mirror::sparse_voxel_octree::Fragment;
use vxgi_cpu_mirror::svo_fragments::{run as mirror, scale, threshold, ERR_VALUE, SCALE};

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
    let out = run(
        gpu(),
        &shader,
        DECL.name,
        &case.resources,
        &case.passes,
        &["scale_state", "fragments"],
    )
    .unwrap();
    assert_eq!(out.buffer("scale_state").as_u32()[1], ERR_VALUE);
    let frags: Vec<Fragment> = bytemuck::pod_collect_to_vec(&out.buffer("fragments").bytes);
    assert_eq!(frags[2].value, [0, 16384, 0, 65536]);
}
