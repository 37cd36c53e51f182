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

/// scenes/thin_wall.toml (one-voxel wall between a lit and a dark room) at `width x height`.
pub fn thin_wall(width: u32, height: u32) -> vxgi::scene::Scene {
    let mut scene = vxgi::scene::Scene::load(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/thin_wall.toml"),
    )
    .expect("scenes/thin_wall.toml loads");
    scene.camera.width = width;
    scene.camera.height = height;
    scene
}

/// Run the `vxgi` binary as a user would: (exit code, stdout, stderr).
pub fn vxgi(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vxgi"))
        .args(args)
        .output()
        .expect("run vxgi");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}
