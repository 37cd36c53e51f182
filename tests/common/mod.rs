//! Shared by the integration tests: the GPU context, failing loudly when there is none.
#![allow(dead_code)]
use vxgi::harness::GpuContext;

/// Devices the test threads share out: all the integration tests run in one process (one binary),
/// and a device's queue runs its submissions one after another, so each test gets one of these in
/// turn (libtest runs every test on a thread of its own; all of a test's calls get the same one, as
/// long as it makes them from its own thread).
const DEVICES: usize = 2;

/// Why `ctx` cannot run every declared kernel (the first kernels past a device limit; `needs` each
/// kernel's), if it cannot: e.g. an OpenGL adapter found where no Vulkan driver is installed binds 16
/// storage buffers a stage where lrsm's gather binds 20, which would fail a dozen tests with
/// validation errors.
fn unfit(ctx: &GpuContext, needs: &[vxgi::limits::KernelNeeds]) -> Option<String> {
    let limits = ctx.device.limits();
    let short: Vec<String> = needs
        .iter()
        .filter_map(|n| {
            let past = vxgi::limits::exceeded(n, &limits);
            (!past.is_empty()).then(|| format!("{} ({})", n.kernel, past.join(", ")))
        })
        .take(3)
        .collect();
    (!short.is_empty()).then(|| {
        format!(
            "adapter `{}` ({:?}) cannot run {}",
            ctx.info.name,
            ctx.info.backend,
            short.join("; ")
        )
    })
}

/// A GPU context for this test thread. No adapter, or one that cannot run every kernel, is a test
/// *failure* with the install hint, never a skip.
pub fn gpu() -> &'static GpuContext {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::OnceLock;
    static CONTEXTS: OnceLock<Vec<Result<GpuContext, String>>> = OnceLock::new();
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    thread_local! {
        static PICK: usize = NEXT.fetch_add(1, Ordering::Relaxed) % DEVICES;
    }
    let all = CONTEXTS.get_or_init(|| {
        let needs: Vec<_> = vxgi::kernels::all()
            .iter()
            .filter_map(|k| vxgi::limits::kernel_needs(k.decl()).ok())
            .collect();
        (0..DEVICES)
            .map(|_| {
                let ctx = GpuContext::new().map_err(|e| e.to_string())?;
                match unfit(&ctx, &needs) {
                    Some(why) => Err(why),
                    None => Ok(ctx),
                }
            })
            .collect()
    });
    match &all[PICK.with(|p| *p)] {
        Ok(ctx) => ctx,
        Err(e) => panic!(
            "GPU tests need a wgpu adapter that runs every kernel: {e}. Install Mesa's Vulkan \
             driver (lavapipe): `.ci/ensure-gpu`, or `apt-get install mesa-vulkan-drivers`"
        ),
    }
}

/// Run `case`'s passes of the kernel `name` on this thread's GPU and read back `outputs` (no
/// comparison: for properties of the GPU's own result).
pub fn run_case(
    shader: &vxgi::harness::Shader,
    name: &str,
    case: &vxgi::harness::Case,
    outputs: &[&str],
) -> vxgi::harness::RunOutput {
    vxgi::harness::run::run(gpu(), shader, name, &case.resources, &case.passes, outputs)
        .unwrap_or_else(|e| panic!("{name}, case `{}`: {e:#}", case.label))
}

/// The built-in Cornell box at `width x height` with `voxels`^3 voxels.
pub fn cornell(width: u32, height: u32, voxels: u32) -> vxgi::scene::Scene {
    let mut scene = vxgi::scene::Scene::cornell_box();
    scene.camera.width = width;
    scene.camera.height = height;
    scene.render.voxels = voxels;
    scene
}

/// `test` against `reference` (their FLIP and errors), for images that are not files.
pub fn flip(
    reference: &vxgi::images::RgbImage,
    test: &vxgi::images::RgbImage,
) -> vxgi::images::Comparison {
    let p = std::path::Path::new("");
    vxgi::images::compare(reference, p, test, p).expect("images of one size")
}

/// `case` on this thread's GPU, every output within its bound against the mirror, then `outputs`
/// read back (for properties of the GPU's own result).
#[track_caller]
pub fn passing_run(
    shader: &vxgi::harness::Shader,
    kernel: &dyn vxgi::harness::Kernel,
    case: &vxgi::harness::Case,
    outputs: &[&str],
) -> vxgi::harness::RunOutput {
    assert_case_passes(shader, kernel, case);
    run_case(shader, kernel.decl().name, case, outputs)
}

/// Asserts that a `#[repr(C)]` parameter struct has the size and member offsets of the WGSL struct
/// of the same name in `shader`: `assert_layout!(shader, Params { a, b, _pad as "_pad0", _pad as
/// "_pad1" + 4 })` (a Rust field named otherwise in the WGSL, at an offset past its start).
macro_rules! assert_layout {
    ($shader:expr, $ty:ident { $($field:ident $(as $wgsl:literal)? $(+ $plus:literal)?),* $(,)? }) => {{
        let (size, members) = $shader.struct_layout(stringify!($ty)).unwrap();
        assert_eq!(size as usize, std::mem::size_of::<$ty>(), "size of {}", stringify!($ty));
        let want: Vec<(String, u32)> = vec![$((
            [$($wgsl,)? stringify!($field)][0].to_string(),
            (std::mem::offset_of!($ty, $field) $(+ $plus)?) as u32,
        )),*];
        assert_eq!(members, want, "members of {}", stringify!($ty));
    }};
}
pub(crate) use assert_layout;

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

/// `cases` generated cases of `kernel` from `seed`, GPU vs mirror, every output within its bound;
/// fails with the first failing case's report. The report comes back for further checks.
#[track_caller]
pub fn verified(
    kernel: &dyn vxgi::harness::Kernel,
    cases: usize,
    seed: u64,
) -> vxgi::harness::KernelReport {
    let opts = vxgi::harness::VerifyOptions {
        cases,
        seed,
        corrupt: None,
    };
    let rep = vxgi::harness::kernel::verify(gpu(), kernel, &opts, &mut |_| {}).expect("GPU run");
    assert!(rep.passed(), "{}", rep.failures[0].report());
    rep
}

/// The first output of one GPU run of `case` that is outside its bound, as its report.
pub fn first_failure(
    shader: &vxgi::harness::Shader,
    kernel: &dyn vxgi::harness::Kernel,
    case: &vxgi::harness::Case,
) -> Option<String> {
    let (comps, ..) =
        vxgi::harness::kernel::verify_case(gpu(), shader, kernel, case, None).expect("GPU run");
    comps.iter().find(|c| !c.passed()).map(|c| c.report())
}

/// One case of `kernel` on the GPU, every output within its bound against the mirror.
#[track_caller]
pub fn assert_case_passes(
    shader: &vxgi::harness::Shader,
    kernel: &dyn vxgi::harness::Kernel,
    case: &vxgi::harness::Case,
) {
    if let Some(report) = first_failure(shader, kernel, case) {
        panic!("{report}");
    }
}

/// [`assert_case_passes`] for proptest bodies: `case_passes(..)?` fails the property with the report.
pub fn case_passes(
    shader: &vxgi::harness::Shader,
    kernel: &dyn vxgi::harness::Kernel,
    case: &vxgi::harness::Case,
) -> Result<(), proptest::test_runner::TestCaseError> {
    match first_failure(shader, kernel, case) {
        Some(report) => Err(proptest::test_runner::TestCaseError::fail(report)),
        None => Ok(()),
    }
}

/// A scene file of the repository (`scenes/NAME`).
pub fn scene_file(name: &str) -> vxgi::scene::Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    vxgi::scene::Scene::load(&path).unwrap_or_else(|e| panic!("scenes/{name}: {e}"))
}

/// A 256x256 Cornell box frame against the committed converged reference
/// (references/cornell_box_256_4096spp): its combined image's mean FLIP and its indirect energy over
/// the reference's.
pub fn against_converged_cornell(r: &vxgi::render::Rendered) -> (f32, f32) {
    let dir =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("references/cornell_box_256_4096spp");
    let read = |name: &str| vxgi::images::read_exr(&dir.join(format!("{name}.exr"))).unwrap();
    let comb = flip(&read("combined"), &r.combined);
    let sum = |img: &[[f32; 3]]| img.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>();
    let ratio = sum(&r.indirect.pixels) / sum(&read("indirect").pixels);
    (comb.flip_mean, ratio)
}
