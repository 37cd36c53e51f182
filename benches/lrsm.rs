//! LRSM kernels: Sample LRSM GPU vs mirror time; the two normal-CDF evaluations of Gaussian depth
//! visibility by run time against error (and which is on the Pareto front); LRSM memory of the paper's
//! Table 2 configurations from our layout.
//!
//! `cargo bench --bench lrsm`
use criterion::{criterion_group, criterion_main, Criterion};
use rayon::prelude::*;
use std::time::{Duration, Instant};
use vxgi::harness::{prepare, GpuContext};
use vxgi::kernels::{gaussian_depth_visibility as gdv, sample_lrsm};
use vxgi::lrsm::PartitionConfig;
use vxgi_cpu_mirror::gaussian_depth_visibility::{erfc_approx, visibility, Cdf, VisibilityParams};
use vxgi_cpu_mirror::sample_lrsm::{sample, Lrsm};

fn gpu_ns(
    ctx: &GpuContext,
    case: &vxgi::harness::Case,
    shader: &vxgi::harness::Shader,
    name: &str,
    c: &mut Criterion,
    label: &str,
) -> f64 {
    let prepared = prepare(ctx, shader, name, &case.resources, &case.passes).expect("prepare");
    prepared.dispatch().expect("warm-up");
    let mut best = f64::INFINITY;
    c.bench_function(label, |b| {
        b.iter_custom(|iters| {
            let mut total = 0.0;
            for _ in 0..iters {
                let (_, ns, _) = prepared.dispatch().expect("dispatch");
                best = best.min(ns);
                total += ns;
            }
            Duration::from_nanos(total as u64)
        })
    });
    best
}

fn bench(c: &mut Criterion) {
    let ctx = GpuContext::new().expect("GPU adapter (see README: install mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.describe());

    // Sample LRSM: the paper's 1024^2 RSM -> 512^2 LRSM, 2 x 2 layers; 262144 cone samples.
    let config = PartitionConfig::two_by_two(1024);
    let built = sample_lrsm::build_lrsm(config, 1, 0, false);
    let (pos, dir) = sample_lrsm::cone_samples(&built, 2, 1 << 18);
    let shader = sample_lrsm::DECL.shader().expect("WGSL validates");
    let case = sample_lrsm::case_for(&shader, &ctx, &built, &pos, &dir, "bench".into(), 0);
    let sample_gpu = gpu_ns(
        &ctx,
        &case,
        &shader,
        sample_lrsm::DECL.name,
        c,
        "sample_lrsm/gpu/262144",
    );
    let lrsm = Lrsm {
        depth_ranges: &built.depth_ranges,
        radiance: &built.streams[0],
        normal: &built.streams[1],
        moments: &built.streams[2],
    };
    let mut sample_mirror = f64::INFINITY;
    c.bench_function("sample_lrsm/mirror/262144", |b| {
        b.iter(|| {
            let t = Instant::now();
            let out: Vec<[f32; 4]> = pos
                .par_iter()
                .zip(&dir)
                .map(|(p, d)| sample(&lrsm, &built.params, *p, *d, false))
                .collect();
            sample_mirror = sample_mirror.min(t.elapsed().as_nanos() as f64);
            out
        })
    });

    // Gaussian depth visibility, both CDFs, 1M elements.
    let inputs = gdv::inputs(3, 0, 1 << 20);
    let vshader = gdv::DECL.shader().expect("WGSL validates");
    let mut rows = Vec::new();
    for cdf in [Cdf::AS7126, Cdf::AS7127] {
        let params = VisibilityParams {
            cdf: cdf as u32,
            ..VisibilityParams::default()
        };
        let case = gdv::case_for(&vshader, &ctx, &inputs, params, "bench".into(), 0);
        let ns = gpu_ns(
            &ctx,
            &case,
            &vshader,
            gdv::DECL.name,
            c,
            &format!("gaussian_depth_visibility/gpu/{cdf:?}"),
        );
        // Error of the CDF itself against the exact erfc, over [0, 6].
        let max_err = (0..=60_000)
            .map(|i| i as f32 * 1e-4)
            .map(|x| (erfc_approx(x, cdf, false) as f64 - libm::erfc(x as f64)).abs())
            .fold(0.0, f64::max);
        // Error of V against V with the exact normal CDF, over the generated inputs that are inside the
        // kernel's contract (opacity in (min_alpha, 1], normalised moments and cone in the layer's
        // [0, 1] depth range); outside it f32 and f64 cancel differently and the comparison says
        // nothing about the CDF.
        let mut v_err = 0.0f64;
        let in_contract = |m: &[f32; 4], cz: &[f32; 2]| {
            m[2] > params.min_alpha
                && m[2] <= 1.0
                && (0.0..=1.0).contains(&(m[0] / m[2]))
                && (0.0..=1.0).contains(&(m[1] / m[2]))
                && (0.0..=1.0).contains(&cz[0])
                && (0.0..=1.0).contains(&cz[1])
        };
        for (m, cz) in inputs
            .moments
            .iter()
            .zip(&inputs.cone)
            .filter(|(m, cz)| in_contract(m, cz))
            .take(100_000)
        {
            let v = visibility(*m, cz[0], cz[1], &params, false) as f64;
            let exact = exact_visibility(*m, cz[0], cz[1], &params);
            v_err = v_err.max((v - exact).abs());
        }
        rows.push((cdf, ns, max_err, v_err));
    }

    eprintln!("\nSample LRSM, 262144 cone samples on a 512^2 x 4-layer LRSM (1024^2 RSM):");
    eprintln!(
        "  GPU {:.2} ms, mirror (rayon, {} threads) {:.2} ms",
        sample_gpu * 1e-6,
        rayon::current_num_threads(),
        sample_mirror * 1e-6
    );
    eprintln!("\nNormal CDF for eq. 12, 1M elements:");
    eprintln!(
        "  {:<8} {:>9} {:>16} {:>20}",
        "cdf", "GPU ms", "max |erfc err|", "max |V - V_exact|"
    );
    for (cdf, ns, e, v) in &rows {
        eprintln!(
            "  {:<8} {:>9.3} {:>16.2e} {:>20.2e}",
            format!("{cdf:?}"),
            ns * 1e-6,
            e,
            v
        );
    }
    let pareto: Vec<String> = rows
        .iter()
        .filter(|a| {
            !rows
                .iter()
                .any(|b| b.1 <= a.1 && b.3 <= a.3 && (b.1 < a.1 || b.3 < a.3))
        })
        .map(|r| format!("{:?}", r.0))
        .collect();
    eprintln!("  Pareto front (time vs V error): {}", pareto.join(", "));

    eprintln!("\nLRSM memory from our layout (3 x vec4<f32> per layer texel, full mip chain):");
    eprintln!(
        "  {:<12} {:>8} {:>10} {:>12} {:>16}",
        "RSM", "layers", "LRSM", "ours MB", "paper (16-bit) MB"
    );
    for (rsm, a, b, paper) in [
        (1024u32, 1u32, 1u32, 33.6),
        (1024, 2, 1, 50.4),
        (512, 1, 1, f64::NAN),
    ] {
        let cfg = PartitionConfig {
            depth_splits: a,
            normal_splits: b,
            ..PartitionConfig::two_by_two(rsm)
        };
        eprintln!(
            "  {:<12} {:>8} {:>10} {:>12.1} {:>16}",
            format!("{rsm}^2"),
            format!("{}x{}", a + 1, b + 1),
            format!("{}^2", rsm / 2),
            vxgi::lrsm::lrsm_bytes(&cfg) as f64 / 1e6,
            if paper.is_nan() {
                "-".to_string()
            } else {
                format!("{paper}")
            }
        );
    }
}

/// V with the exact normal CDF (f64) on the same floored moments.
fn exact_visibility(m: [f32; 4], zc: f32, rc: f32, p: &VisibilityParams) -> f64 {
    let a = m[2] as f64;
    if a.partial_cmp(&(p.min_alpha as f64)) != Some(std::cmp::Ordering::Greater) {
        return 0.0;
    }
    let lim = 1.0e6;
    let mu = (m[0] as f64 / a).clamp(-lim, lim);
    let var = (m[1] as f64 / a - mu * mu).clamp(p.min_variance as f64, lim * lim);
    let (zc, rc) = ((zc as f64).clamp(-lim, lim), (rc as f64).clamp(0.0, lim));
    let phi = |t: f64| 0.5 * libm::erfc(-t / std::f64::consts::SQRT_2);
    let s = var.sqrt();
    phi((zc + rc - mu) / s) - phi((zc - rc - mu) / s)
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).warm_up_time(Duration::from_millis(300)).measurement_time(Duration::from_secs(2));
    targets = bench
}
criterion_main!(benches);
