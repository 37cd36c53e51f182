//! The checks every kernel of `vxgi::kernels::all()` gets alike, from its declaration and its own
//! case generator: its generated cases match the mirror, a corrupted element of any checked output is
//! caught, and a host buffer that does not fit its WGSL binding is refused before any dispatch, naming
//! the kernel and the binding. Kernel-specific properties stay in the kernel's own test file.
use crate::common::gpu;
use vxgi::harness::kernel::{verify, verify_case};
use vxgi::harness::{Corruption, HostResource, VerifyOptions, View};

/// Generated cases per kernel. Each generator picks its stress patterns (sizes, edge and bad inputs,
/// options) by `index % k` with k <= 8, so 8 cases reach every value of every pattern, though not
/// every combination: `vxgi verify` (24 cases a kernel in CI's main job) runs more on another seed.
const CASES: usize = 8;

#[test]
fn every_kernel_verifies_its_generated_cases_within_their_bounds() {
    for k in vxgi::kernels::all() {
        let name = k.decl().name;
        let opts = VerifyOptions {
            cases: CASES,
            seed: 17,
            corrupt: None,
        };
        let rep = verify(gpu(), k, &opts, &mut |_| {}).unwrap_or_else(|e| panic!("{name}: {e:#}"));
        assert!(rep.passed(), "{name}: {}", rep.failures[0].report());
        assert!(rep.elements > 0, "{name}: no element checked");
        assert!(
            rep.max_bound_use <= 1.0,
            "{name}: bound use {}",
            rep.max_bound_use
        );
    }
}

#[test]
fn every_kernel_matches_its_mirror_catches_a_corruption_and_refuses_a_misfit() {
    for k in vxgi::kernels::all() {
        let decl = k.decl();
        let shader = decl.shader().unwrap();
        let case = k.case(&shader, gpu(), 5, 0);
        let at = format!("{} case 0 ({})", decl.name, case.label);
        let (comps, ..) = verify_case(gpu(), &shader, k, &case, None).unwrap();
        if let Some(c) = comps.iter().find(|c| !c.passed()) {
            panic!("{at}: {}", c.report());
        }
        // A corrupted element of each checked output, one at a time.
        let mut resources: Vec<&str> = case.checks.iter().map(|c| c.resource.as_str()).collect();
        resources.dedup();
        for r in resources {
            let corrupt = Corruption {
                resource: r.to_string(),
                index: 0,
            };
            let (comps, ..) = verify_case(gpu(), &shader, k, &case, Some(&corrupt)).unwrap();
            assert!(
                comps.iter().any(|c| !c.passed()),
                "{at}: `{r}`[0] corrupted and still passed"
            );
        }
        // One byte more in a buffer the first pass binds whole (or one byte less in the window it
        // binds): no WGSL layout takes that size.
        let pass = &case.passes[0];
        let entry = shader.entry(&pass.entry).unwrap();
        let used = |b: &str| entry.uses.iter().any(|&i| shader.bindings[i].name == b);
        let mut misfit = case.clone();
        let bound = pass.bindings.iter().enumerate().find(|(_, (b, v))| {
            used(b)
                && match v {
                    View::Buffer(n) => case.resources[n].buffer().is_some(),
                    View::BufferRange { .. } => true,
                    _ => false,
                }
        });
        let (slot, (binding, view)) = bound.unwrap_or_else(|| panic!("{at}: no buffer bound"));
        match view {
            View::Buffer(n) => {
                if let Some(HostResource::Buffer(b)) = misfit.resources.get_mut(n) {
                    b.bytes.push(0);
                }
            }
            _ => {
                if let View::BufferRange { size, .. } = &mut misfit.passes[0].bindings[slot].1 {
                    *size -= 1;
                }
            }
        }
        let name = binding;
        let e = verify_case(gpu(), &shader, k, &misfit, None)
            .err()
            .unwrap_or_else(|| panic!("{at}: a misfit `{name}` passed"))
            .to_string();
        assert!(
            e.contains(decl.name) && e.contains(name.as_str()),
            "{at}: {e}"
        );
    }
}
