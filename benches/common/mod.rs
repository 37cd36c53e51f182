//! Shared by the stage benches (distribution, vct, cprc_stages): a kernel case's GPU time and a
//! closure's wall-clock time.
use std::time::Instant;
use vxgi::harness::{prepare, Case, GpuContext, KernelDecl};

/// Best of three dispatches of `case` after a warm-up, in ms (timestamps where the adapter has them).
pub fn gpu_ms(ctx: &GpuContext, decl: &KernelDecl, case: &Case) -> f64 {
    let shader = decl.shader().expect("WGSL validates");
    let prepared =
        prepare(ctx, &shader, decl.name, &case.resources, &case.passes).expect("prepare");
    prepared.dispatch().expect("warm-up");
    (0..3)
        .map(|_| prepared.dispatch().expect("dispatch").1)
        .fold(f64::INFINITY, f64::min)
        * 1e-6
}

/// `f`'s result and its wall-clock time in ms.
pub fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let r = f();
    (r, t.elapsed().as_secs_f64() * 1e3)
}
