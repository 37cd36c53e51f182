//! GPU vs mirror for `kernels/cache_creation.wgsl` (one cone per radiance-cache texel, CPRC 3.1) on
//! generated scenes whose earlier stages ran on the GPU, and what a cache sees in a known volume.
mod common;

use common::gpu;
use vxgi::harness::kernel::verify;
use vxgi::harness::{Corruption, VerifyOptions};
use vxgi::kernels::cache_creation::{mirror_texels, CacheCreation};
use vxgi_cpu_mirror::cache_creation::{cone_tan, create_texel, texel_directions};
use vxgi_cpu_mirror::cone_trace::{level_offset, pyramid_len, ConeParams, Pyramid};

#[test]
fn generated_scenes_match_the_mirror() {
    let rep = verify(
        gpu(),
        &CacheCreation,
        &VerifyOptions {
            cases: 6,
            seed: 5,
            corrupt: None,
        },
        &mut |_| {},
    )
    .unwrap();
    assert!(rep.passed(), "{}", rep.failures[0].report());
    assert!(rep.max_bound_use < 1.0);
}

#[test]
fn a_corrupted_texel_is_caught() {
    // Case 0 (the Cornell box): find a texel the mirror says is bright and corrupt it.
    let case = vxgi::harness::Kernel::case(
        &CacheCreation,
        &vxgi::kernels::cache_creation::DECL.shader().unwrap(),
        gpu(),
        5,
        0,
    );
    let (rad, _) = mirror_texels(&case.resources);
    let bright = rad.iter().position(|v| v[0] > 1e-3).expect("a lit texel");
    let opts = VerifyOptions {
        cases: 1,
        seed: 5,
        corrupt: Some(Corruption {
            resource: "cache_radiance".into(),
            index: 4 * bright,
        }),
    };
    assert!(!verify(gpu(), &CacheCreation, &opts, &mut |_| {})
        .unwrap()
        .passed());
}

/// A cache in an 8^3 grid whose top layer is an emitting ceiling (radiance 1, opaque) and nothing else:
/// the texels that look up see it, those along the horizon do not, and the cosine-weighted sum over
/// the hemisphere (the irradiance / pi the gather will use) is the ceiling's view factor-ish share.
#[test]
fn a_cache_under_a_lit_ceiling_sees_it_above_and_not_below() {
    let side = 8u32;
    let mut vox = vec![[0.0f32; 4]; pyramid_len(side)];
    for x in 0..side {
        for y in 0..side {
            let m = vxgi_cpu_mirror::morton::encode(x, y, side - 1) as usize;
            vox[m] = [1.0, 1.0, 1.0, 1.0];
        }
    }
    // Coarser levels with surface coverage (the pipeline's mips): the ceiling stays opaque.
    let mut level = vox[..level_offset(side, 1)].to_vec();
    let mut nrm = vec![[0.0f32, 0.0, -1.0, 1.0]; level.len()];
    let mut off = level.len();
    while level.len() > 1 {
        let (c, n) = vxgi_cpu_mirror::surface_coverage_mip::reduce_level(
            &level,
            &nrm,
            vxgi_cpu_mirror::surface_coverage_mip::Coverage::Surface,
            false,
        );
        vox[off..off + c.len()].copy_from_slice(&c);
        off += c.len();
        level = c;
        nrm = n;
    }
    let p = ConeParams {
        origin: [0.0, 0.0, 0.0, 1.0],
        ao_range: 0.0,
        ao_lambda: 0.0,
        diffuse_tan: 0.5,
        offset_voxels: 0.0,
        diffuse_cones: 1,
        levels: side.trailing_zeros() + 1,
        side,
        inv_s0: 1.0,
        mip_clamp: 0.0,
        step_factor: 0.5,
        _pad: [0; 2],
    };
    let pyr = Pyramid {
        p: &p,
        voxels: &vox,
    };
    let res = 8;
    let dirs = texel_directions(res);
    let cache = [[4.0, 4.0, 2.0, 0.0], [0.0, 0.0, 1.0, 0.0]];
    let (mut up, mut horizon, mut cosine_sum) = (0.0f32, 0.0f32, 0.0f32);
    for d in &dirs {
        let (l, _) = create_texel(&pyr, cache, *d, cone_tan(res), 1.0);
        assert!(l[0].is_finite() && (0.0..=1.0 + 1e-5).contains(&l[0]));
        cosine_sum += l[0] * d[2] * d[3];
        if d[2] > 0.9 {
            up = up.max(l[0]);
        }
        if d[2] < 0.1 {
            horizon = horizon.max(l[0]);
        }
    }
    assert!(up > 0.6, "straight up sees the ceiling: {up}");
    assert!(horizon < 0.5, "the horizon misses it: {horizon}");
    // The ceiling at height 5.5 above a cache in the middle of an 8 x 8 room subtends most of the
    // upper hemisphere's cosine weight (pi): E / pi between 0.3 and 1.
    let e = cosine_sum / std::f32::consts::PI;
    assert!(e > 0.3 && e < 1.0, "{e}");
}
