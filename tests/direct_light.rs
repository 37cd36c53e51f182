//! GPU vs mirror for `kernels/direct_light.wgsl` (exact hard shadows, diffuse + normalised Phong, point /
//! spot / directional lights) on generated scenes, fed the GPU's own G-buffer.
mod common;

use common::gpu;
use vxgi::harness::kernel::verify;
use vxgi::harness::{Corruption, VerifyOptions};
use vxgi::kernels::direct_light::DirectLight;

#[test]
fn generated_scenes_match_the_mirror() {
    let rep = verify(
        gpu(),
        &DirectLight,
        &VerifyOptions {
            cases: 12,
            seed: 23,
            corrupt: None,
        },
        &mut |_| {},
    )
    .unwrap();
    assert!(rep.passed(), "{}", rep.failures[0].report());
    println!(
        "max bound use {:.4}, max ULP {}",
        rep.max_bound_use, rep.max_ulp
    );
    assert!(rep.max_bound_use < 1.0);
}

#[test]
fn a_corrupted_radiance_is_caught() {
    let opts = VerifyOptions {
        cases: 1,
        seed: 23,
        corrupt: Some(Corruption {
            resource: "radiance".into(),
            // Cornell box, a floor pixel near the bottom centre (lit).
            index: 4 * (40 * 30 + 20),
        }),
    };
    assert!(!verify(gpu(), &DirectLight, &opts, &mut |_| {})
        .unwrap()
        .passed());
}
