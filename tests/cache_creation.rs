//! GPU vs mirror for `kernels/cache_creation.wgsl` (one cone per radiance-cache texel, CPRC 3.1) on
//! generated scenes whose earlier stages ran on the GPU, and what a cache sees in a known volume.
use crate::common;

use common::verified;
use vxgi::kernels::cache_creation::CacheCreationInstanced;
use vxgi_cpu_mirror::cache_creation::{
    cone_tan, create_texel, texel_directions, Placed, PlacedPyramids,
};
use vxgi_cpu_mirror::cone_trace::{level_offset, pyramid_len, ConeParams, Pyramid};

/// An 8^3 grid whose top layer is an emitting ceiling (radiance 1, opaque), its surface-coverage mips,
/// and the march parameters of that grid (voxel size 1 at the origin).
fn ceiling() -> (Vec<[f32; 4]>, ConeParams) {
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
        ..Default::default()
    };
    (vox, p)
}

/// A cache in an 8^3 grid whose top layer is an emitting ceiling (radiance 1, opaque) and nothing else:
/// the texels that look up see it, those along the horizon do not, and the cosine-weighted sum over
/// the hemisphere (the irradiance / pi the gather will use) is the ceiling's view factor-ish share.
#[test]
fn a_cache_under_a_lit_ceiling_sees_it_above_and_not_below() {
    let (vox, p) = ceiling();
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

#[test]
fn instanced_hierarchies_match_the_mirror() {
    verified(&CacheCreationInstanced, 6, 5);
}

/// The placed hierarchies mean what they say: one hierarchy in place reads like the plain pyramid;
/// the pyramid shifted by three voxels reads at a cache shifted by the same as the plain one at the
/// original cache; and a second copy turned upside down under the first is seen looking down, where
/// the ceiling alone leaves those texels dark.
#[test]
fn placed_hierarchies_move_what_the_caches_see() {
    use vxgi_cpu_mirror::cone_trace::Volume;
    let (vox, p) = ceiling();
    let plain = Pyramid {
        p: &p,
        voxels: &vox,
    };
    let place = |m: glam::Mat4| Placed::new([0.0; 3], 1.0, 8, 0, m, 1.0);
    let res = 8;
    let dirs = texel_directions(res);
    let tan = cone_tan(res);
    let texels = |vol: &dyn Volume, cache: [[f32; 4]; 2]| -> Vec<[f32; 4]> {
        dirs.iter()
            .map(|d| create_texel(vol, cache, *d, tan, 1.0).0)
            .collect()
    };
    let at = |o: [f32; 3]| [[o[0], o[1], o[2], 0.0], [0.0, 0.0, 1.0, 0.0]];
    let close = |a: &[[f32; 4]], b: &[[f32; 4]]| {
        a.iter()
            .zip(b)
            .all(|(x, y)| (0..3).all(|k| (x[k] - y[k]).abs() <= 1e-5 * (1.0 + y[k].abs())))
    };
    let cache = at([4.0, 4.0, 2.0]);
    let reference = texels(&plain, cache);
    assert!(reference.iter().any(|t| t[0] > 0.5), "the ceiling is seen");
    let one = [place(glam::Mat4::IDENTITY)];
    let in_place = PlacedPyramids {
        p: &p,
        placed: &one,
        voxels: &vox,
    };
    assert!(
        close(&texels(&in_place, cache), &reference),
        "identity placement"
    );
    // Shifted by 3 voxels along x and read 3 voxels further along x, the march's grid shifted too
    // (so its steps and far end fall where they fell).
    let moved = [place(glam::Mat4::from_translation(glam::Vec3::X * 3.0))];
    let mut p3 = p;
    p3.origin[0] += 3.0;
    let shifted = PlacedPyramids {
        p: &p3,
        placed: &moved,
        voxels: &vox,
    };
    assert!(
        close(&texels(&shifted, at([7.0, 4.0, 2.0])), &reference),
        "translation"
    );
    // The copy turned upside down about the grid's mid-height plane z = 4 (the ceiling at z 7-8 becomes
    // a floor at z 0-1): looking down from z = 4 now finds light.
    let flip = glam::Mat4::from_translation(glam::Vec3::new(0.0, 8.0, 8.0))
        * glam::Mat4::from_rotation_x(std::f32::consts::PI);
    let two = [place(glam::Mat4::IDENTITY), place(flip)];
    let both = PlacedPyramids {
        p: &p,
        placed: &two,
        voxels: &vox,
    };
    let down = [[4.0, 4.0, 4.0, 0.0], [0.0, 0.0, -1.0, 0.0]];
    let seen = |vol: &dyn Volume| {
        dirs.iter()
            .filter(|d| d[2] > 0.9)
            .map(|d| create_texel(vol, down, *d, tan, 1.0).0[0])
            .fold(0.0f32, f32::max)
    };
    let (alone, with_floor) = (seen(&plain), seen(&both));
    assert!(
        alone < 0.05 && with_floor > 0.5,
        "ceiling alone {alone}, with the floor {with_floor}"
    );
}
