//! GPU vs mirror for `kernels/svo_sample.wgsl`, and sampling the octree at a whole level equals
//! trilinear interpolation of the dense lattice of that level (sparsity loses nothing).
use crate::common;

use common::{case_passes, gpu};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use vxgi::kernels::sparse_voxel_octree::{default_capacity, generated};
use vxgi::kernels::svo_sample::{case_for, queries, sample_on_gpu, SampleError, SvoSample, DECL};
use vxgi_cpu_mirror::sparse_voxel_octree::{build, dense_reference, Fragment};

/// Trilinear interpolation of the dense lattice of level `l` at unit-volume point `x`, in f64.
fn dense_trilinear(lattice: &[[u32; 4]], l: u32, x: [f32; 3], inv_scale: f64) -> [f64; 4] {
    let n = 2usize << l; // intervals
    let s = n + 1;
    let mut i0 = [0usize; 3];
    let mut f = [0f64; 3];
    for a in 0..3 {
        let u = x[a].clamp(0.0, 1.0) as f64 * n as f64;
        i0[a] = (u.floor() as usize).min(n - 1);
        f[a] = u - i0[a] as f64;
    }
    let mut out = [0f64; 4];
    for dz in 0..2 {
        for dy in 0..2 {
            for dx in 0..2 {
                let w = [dx, dy, dz]
                    .iter()
                    .enumerate()
                    .map(|(a, &d)| if d == 1 { f[a] } else { 1.0 - f[a] })
                    .product::<f64>();
                let p = [i0[0] + dx, i0[1] + dy, i0[2] + dz];
                let v = lattice[p[0] + s * (p[1] + s * p[2])];
                for ch in 0..4 {
                    out[ch] += w * v[ch] as f64 * inv_scale;
                }
            }
        }
    }
    out
}

#[test]
fn whole_levels_equal_trilinear_interpolation_of_the_dense_lattice() {
    let scale = 65536.0f32;
    for index in 0..16 {
        let (depth, frags, label) = generated(21, index);
        if index % 8 == 7 || depth > 6 {
            continue; // overflowing values; dense lattices past depth 6 are too large to hold
        }
        let octree = build(depth, default_capacity(gpu(), depth, frags.len()), &frags);
        let dense = dense_reference(depth, &frags).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(index as u64);
        let q: Vec<[f32; 4]> = queries(&mut rng, depth, 1024)
            .into_iter()
            .map(|mut q| {
                q[3] = (q[3].clamp(0.0, depth as f32)).floor();
                q
            })
            .collect();
        let got = sample_on_gpu(gpu(), &octree, scale, &q).unwrap();
        for (qi, g) in q.iter().zip(&got) {
            let want = dense_trilinear(
                &dense[qi[3] as usize],
                qi[3] as u32,
                [qi[0], qi[1], qi[2]],
                1.0 / scale as f64,
            );
            for ch in 0..4 {
                // f32 interpolation of values up to 2^20 / 2^16: relative 1e-5 of the largest corner.
                let tol = 1e-5 * want[ch].abs().max(1.0);
                assert!(
                    (g[ch] as f64 - want[ch]).abs() <= tol,
                    "{label}: query {qi:?} channel {ch}: octree {} vs dense {}",
                    g[ch],
                    want[ch]
                );
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 8, ..ProptestConfig::default() })]

    /// Any fragment set, any queries (finite): GPU within the declared ULP tolerance of the mirror.
    #[test]
    fn random_octrees_and_queries_match_the_mirror(depth in 1u32..=5, pts in proptest::collection::vec((proptest::array::uniform3(0u32..=64), proptest::array::uniform4(0u32..1 << 24)), 1..40), seed in any::<u64>()) {
        let side = 2u32 << depth;
        let frags: Vec<Fragment> = pts.iter().map(|(p, v)| Fragment { pos: p.map(|x| x % (side + 1)), _pad: 0, value: *v }).collect();
        let octree = build(depth, default_capacity(gpu(), depth, frags.len()), &frags);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let q = queries(&mut rng, depth, 512);
        let case = case_for(gpu(), &octree, 4096.0, &q, "prop".into(), seed);
        case_passes(&DECL.shader().unwrap(), &SvoSample, &case)?;
    }
}

#[test]
fn bad_queries_are_errors() {
    let octree = build(2, 16, &[]);
    assert!(matches!(
        sample_on_gpu(gpu(), &octree, 1.0, &[]),
        Err(SampleError::Empty)
    ));
    assert!(matches!(
        sample_on_gpu(gpu(), &octree, 0.0, &[[0.5; 4]]),
        Err(SampleError::Scale(_))
    ));
    let e = sample_on_gpu(gpu(), &octree, 1.0, &[[0.5; 4], [f32::NAN, 0.0, 0.0, 1.0]]).unwrap_err();
    assert!(matches!(e, SampleError::NonFinite { index: 1, .. }), "{e}");
    // An empty octree samples to zero everywhere, at every level.
    let q = [[0.3, 0.9, 0.1, 1.5], [1.0, 1.0, 1.0, 2.0]];
    let z = sample_on_gpu(gpu(), &octree, 1.0, &q).unwrap();
    assert_eq!(z, vec![[0.0; 4]; 2]);
}
