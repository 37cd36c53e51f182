//! GPU vs mirror for `kernels/svo_cone_trace.wgsl` (per-element bounds, as cone_trace), and the octree
//! read at the voxels' own level gives the dense pyramid's level 0 back.
mod common;

use common::gpu;
use vxgi::harness::kernel::verify;
use vxgi::harness::{Corruption, VerifyOptions};
use vxgi::kernels::svo_cone_trace::SvoConeTrace;

#[test]
fn generated_scenes_match_the_mirror() {
    let rep = verify(
        gpu(),
        &SvoConeTrace,
        &VerifyOptions {
            cases: 8,
            seed: 1,
            corrupt: None,
        },
        &mut |_| {},
    )
    .unwrap();
    assert!(rep.passed(), "{}", rep.failures[0].report());
    assert!(rep.max_bound_use <= 1.0);
}

#[test]
fn a_corrupted_pixel_is_caught() {
    let rep = verify(
        gpu(),
        &SvoConeTrace,
        &VerifyOptions {
            cases: 1,
            seed: 1,
            corrupt: Some(Corruption {
                resource: "indirect".into(),
                index: 4100,
            }),
        },
        &mut |_| {},
    )
    .unwrap();
    assert!(!rep.passed());
}

#[test]
fn level_zero_of_the_octree_is_the_voxel_grid() {
    use glam::Vec3;
    use vxgi::kernels::cone_trace::{cone_params, ConeSettings};
    use vxgi::kernels::svo_cone_trace::{grid_fragments, svo_cone_params, SCALE};
    use vxgi::kernels::{voxel_light, voxelize};
    use vxgi::scene::Scene;
    use vxgi_cpu_mirror::cone_trace::{Pyramid, Volume};
    use vxgi_cpu_mirror::sparse_voxel_octree::{build, capacity_bound};
    use vxgi_cpu_mirror::svo_cone_trace::{SvoParams, SvoVolume};

    let scene = Scene::cornell_box();
    let side = 32;
    let data = vxgi::trace::SceneData::new(&scene);
    let (grid, list, frame) = voxelize::voxelize_on_gpu(gpu(), &scene, side).unwrap();
    let rad = voxel_light::light_on_gpu(gpu(), &data, &grid, &list, &frame).unwrap();
    let frags = grid_fragments(&rad, SCALE).unwrap();
    let depth = 4;
    let octree = build(depth, capacity_bound(depth, frags.len()) as u32, &frags);
    let settings = ConeSettings::default();
    let (pp, sp) = (cone_params(&frame, &settings), svo_cone_params(&frame, &settings));
    // The whole pyramid (sampling at level 0 blends level 1 with weight 0).
    let voxels = vxgi::kernels::cone_trace::gpu_pyramid(gpu(), &rad, &grid.normal, side).unwrap();
    let pyr = Pyramid { p: &pp, voxels: &voxels };
    let svo = SvoParams {
        depth,
        inv_scale: 1.0 / SCALE,
        _pad: [0; 2],
    };
    let vol = SvoVolume {
        p: &sp,
        svo: &svo,
        nodes: &octree.nodes,
        bricks: &octree.bricks,
    };
    let lo = frame.origin;
    let extent = frame.voxel * side as f32;
    let mut nonzero = 0;
    for i in 0..4000u32 {
        // A deterministic spread of points over the grid (and a little outside it).
        let h = |k: u32| ((i.wrapping_mul(2654435761).wrapping_add(k * 40503)) % 10007) as f32 / 10007.0;
        let x = lo + Vec3::new(h(1), h(2), h(3)) * extent * 1.1 - Vec3::splat(0.05 * extent);
        let (a, _) = Volume::sample(&pyr, x, 0.0);
        let (b, _) = vol.sample(x, 0.0);
        // Fixed point rounds each voxel value to 1/SCALE; trilinear weights sum to <= 1.
        assert!((a - b).abs().max_element() <= 1.0 / SCALE, "at {x}: pyramid {a} vs octree {b}");
        nonzero += (a.w > 0.0) as u32;
    }
    assert!(nonzero > 100, "the points must meet the surfaces ({nonzero} did)");
}
