//! The `vxgi` command line: `vxgi verify` runs every declared kernel GPU vs mirror.
use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use vxgi::harness::{kernel::verify, run::copy_bandwidth, GpuContext, VerifyOptions};

#[derive(Parser)]
#[command(
    name = "vxgi",
    version,
    about = "Voxel GI kernels, verified GPU vs scalar mirror"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run every declared kernel (or one) on generated cases, GPU vs mirror, and print a table.
    Verify {
        /// Only this kernel.
        #[arg(long)]
        kernel: Option<String>,
        /// Generated cases per kernel.
        #[arg(long, default_value_t = 48)]
        cases: usize,
        /// Seed of the case generator (a failing case names its seed).
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// List the declared kernels with their WGSL files and mirrors.
    List,
    /// Load a scene file (default: the built-in Cornell box), check it and print what it holds.
    Scene {
        /// A TOML scene file (see README, "Scenes").
        path: Option<std::path::PathBuf>,
    },
}

fn main() {
    if let Err(e) = real_main() {
        eprintln!("error: {e}");
        for cause in e.chain().skip(1) {
            eprintln!("  caused by: {cause}");
        }
        std::process::exit(1);
    }
}

fn real_main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::List => {
            for k in vxgi::kernels::all() {
                let d = k.decl();
                println!(
                    "{:<24} {:<40} {}\n{:<24} {}",
                    d.name, d.wgsl_path, d.mirror, "", d.summary
                );
            }
            Ok(())
        }
        Command::Verify {
            kernel,
            cases,
            seed,
        } => run_verify(kernel, cases, seed),
        Command::Scene { path } => run_scene(path),
    }
}

fn run_scene(path: Option<std::path::PathBuf>) -> Result<()> {
    let scene = match &path {
        Some(p) => vxgi::scene::Scene::load(p)?,
        None => vxgi::scene::Scene::cornell_box(),
    };
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let c = &scene.camera;
    println!(
        "{} triangles, {} vertices, {} materials ({} glossy), {} lights, camera {}x{} fov {} deg, voxels {}",
        scene.mesh.triangles.len(),
        scene.mesh.positions.len(),
        scene.materials.len(),
        scene.materials.iter().filter(|m| m.is_glossy()).count(),
        scene.lights.len(),
        c.width,
        c.height,
        c.fov_y_deg,
        scene.render.voxels
    );
    Ok(())
}

fn run_verify(kernel: Option<String>, cases: usize, seed: u64) -> Result<()> {
    let kernels = match &kernel {
        Some(name) => vec![vxgi::kernels::find(name).map_err(anyhow::Error::msg)?],
        None => vxgi::kernels::all(),
    };
    if cases == 0 {
        bail!("--cases must be at least 1");
    }
    let ctx = GpuContext::new().context("creating the GPU context")?;
    println!("adapter: {}", ctx.describe());
    let bar = ProgressBar::new((kernels.len() * cases) as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} cases {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut rows = Vec::new();
    let mut failed = false;
    for k in &kernels {
        bar.set_message(k.decl().name);
        let done = bar.position();
        let rep = verify(
            &ctx,
            *k,
            &VerifyOptions {
                cases,
                seed,
                corrupt: None,
            },
            &mut |i| bar.set_position(done + i as u64),
        )
        .with_context(|| format!("verifying `{}`", k.decl().name))?;
        // Yardstick: a copy of the largest case's size, on this device, in this run.
        let copy = copy_bandwidth(&ctx, rep.largest_case_bytes / 2, 5)
            .context("timing the reference buffer copy")?;
        failed |= !rep.passed();
        rows.push((rep, copy));
    }
    bar.finish_and_clear();
    println!(
        "{:<26} {:>6} {:>12} {:>10} {:>8} {:>9} {:>10} {:>10} {:>10} {:>10} {:>6}",
        "kernel",
        "cases",
        "elements",
        "max ULP",
        "p99 ULP",
        "bound use",
        "GPU ms",
        "mirror ms",
        "eff. GB/s",
        "copy GB/s",
        "result"
    );
    for (rep, copy) in &rows {
        println!(
            "{:<26} {:>6} {:>12} {:>10} {:>8} {:>9} {:>10.2} {:>10.2} {:>10.2} {:>10.2} {:>6}",
            rep.kernel,
            rep.cases,
            rep.elements,
            vxgi::harness::compare::fmt_ulp(rep.max_ulp),
            vxgi::harness::compare::fmt_ulp(rep.p99_ulp()),
            if rep.max_bound_use > 0.0 {
                format!("{:.3}", rep.max_bound_use)
            } else {
                "-".into()
            },
            rep.gpu_ns * 1e-6,
            rep.mirror_ns * 1e-6,
            rep.effective_bandwidth() * 1e-9,
            copy * 1e-9,
            if rep.passed() { "ok" } else { "FAIL" }
        );
    }
    if let Some((rep, _)) = rows.first() {
        println!(
            "GPU time: {}; effective bytes = read each input once + write each output once; \
             bound use = max |gpu - mirror| / per-element bound (kernels with mirror-computed bounds)",
            rep.timing.map(|t| t.to_string()).unwrap_or_default()
        );
    }
    for (rep, _) in &rows {
        if rep.flushed > 0 {
            println!(
                "{}: {} elements matched only the flush-to-zero mirror (allowed by WGSL)",
                rep.kernel, rep.flushed
            );
        }
        for f in rep.failures.iter().take(5) {
            eprintln!("{}", f.report());
        }
    }
    if failed {
        bail!("GPU and mirror disagree (reports above)");
    }
    Ok(())
}
