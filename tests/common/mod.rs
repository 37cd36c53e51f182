//! Shared by the integration tests: the GPU context, failing loudly when there is none.
#![allow(dead_code)]
use vxgi::harness::GpuContext;

/// The process-wide GPU context. No adapter is a test *failure* with the install hint, never a skip.
pub fn gpu() -> &'static GpuContext {
    match GpuContext::shared() {
        Ok(ctx) => ctx,
        Err(e) => panic!("GPU tests need a wgpu adapter: {e}"),
    }
}
