//! Run time of the surface-coverage mip chain at 64^3, 128^3 and 256^3: GPU time (timestamp queries
//! where the adapter has them), mirror time, and effective bandwidth as a fraction of a same-size buffer
//! copy measured on the same device in the same run (DESIGN.md section 6).
//!
//! `cargo bench --bench surface_coverage_mip` (add `-- --quick` for a short run).
use criterion::{criterion_group, criterion_main, Criterion};
use std::time::{Duration, Instant};
use vxgi::grids::{generate, Pattern};
use vxgi::harness::{prepare, run::copy_bandwidth, GpuContext};
use vxgi::kernels::surface_coverage_mip::{chain_case, DECL};
use vxgi_cpu_mirror::surface_coverage_mip::{mip_chain, Coverage};

fn bench(c: &mut Criterion) {
    let ctx = GpuContext::new().expect("GPU adapter (see README: install mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.describe());
    let shader = DECL.shader().expect("WGSL validates");
    let mut group = c.benchmark_group("surface_coverage_mip");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let mut summary = Vec::new();
    for n in [64u32, 128, 256] {
        let grid = generate(n, Pattern::RandomSparse { density: 0.3 }, 7);
        let case = chain_case(&shader, &ctx, &grid, Coverage::Surface, format!("{n}^3"), 7);
        let prepared =
            prepare(&ctx, &shader, DECL.name, &case.resources, &case.passes).expect("prepare");
        prepared.dispatch().expect("warm-up dispatch"); // first dispatch compiles the pipeline on lavapipe
        let mut best_ns = f64::INFINITY;
        group.bench_function(format!("gpu/{n}^3"), |b| {
            b.iter_custom(|iters| {
                let mut total = 0.0;
                for _ in 0..iters {
                    let (_, ns, _) = prepared.dispatch().expect("dispatch");
                    best_ns = best_ns.min(ns);
                    total += ns;
                }
                Duration::from_nanos(total as u64)
            })
        });
        let mut mirror_ns = f64::INFINITY;
        group.bench_function(format!("mirror/{n}^3"), |b| {
            b.iter(|| {
                let t = Instant::now();
                let chain = mip_chain(&grid.colour, &grid.normal, Coverage::Surface);
                mirror_ns = mirror_ns.min(t.elapsed().as_nanos() as f64);
                chain
            })
        });
        // Kernel and copy alternate, 8 rounds, best of each: the machine's load drifts between
        // criterion's phases (separate measurements differed 2x run to run on a shared 2-core box).
        let mut copy: f64 = 0.0;
        let mut timing = None;
        for _ in 0..8 {
            let (_, ns, t) = prepared.dispatch().expect("dispatch");
            best_ns = best_ns.min(ns);
            timing = Some(t);
            copy = copy
                .max(copy_bandwidth(&ctx, case.effective_bytes / 2, 3).expect("copy bandwidth"));
        }
        let timing = timing.expect("dispatched");
        let eff = case.effective_bytes as f64 / (best_ns * 1e-9);
        summary.push((n, best_ns, mirror_ns, eff, copy, timing));
    }
    group.finish();
    eprintln!(
        "\n{:>6} {:>10} {:>11} {:>10} {:>10} {:>9}",
        "grid", "GPU ms", "mirror ms", "eff GB/s", "copy GB/s", "fraction"
    );
    for (n, gpu, mirror, eff, copy, timing) in summary {
        eprintln!(
            "{:>6} {:>10.2} {:>11.2} {:>10.2} {:>10.2} {:>9.3}   ({timing})",
            format!("{n}^3"),
            gpu * 1e-6,
            mirror * 1e-6,
            eff * 1e-9,
            copy * 1e-9,
            eff / copy
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
