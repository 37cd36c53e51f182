//! GPU vs mirror for `kernels/surface_coverage_mip.wgsl`, every level of every generated grid, plus the
//! failure paths the harness must catch.
use crate::common::{assert_case_passes, gpu, run_case};
use proptest::prelude::*;
use vxgi::grids::{generate, Pattern};
use vxgi::harness::compare::{compare_f32, Indexing, Tolerance};
use vxgi::harness::kernel::{verify, verify_case};
use vxgi::harness::run::{run, Pass, View, Workgroups};
use vxgi::harness::{
    Case, Corruption, FloatMode, HarnessError, HostBuffer, Kernel, KernelReport, ScalarKind,
    Shader, VerifyOptions,
};
use vxgi::kernels::surface_coverage_mip::{chain_case, chain_mirror, SurfaceCoverageMip, DECL};
use vxgi_cpu_mirror::surface_coverage_mip::{Coverage, MipParams};

/// The chain of `generate(n, pattern, seed)` under `coverage`, labelled with all three.
fn chain(shader: &Shader, n: u32, pattern: Pattern, coverage: Coverage, seed: u64) -> Case {
    let label = format!("{n}^3 {pattern:?} {coverage:?}");
    let grid = generate(n, pattern, seed);
    chain_case(shader, gpu(), &grid, coverage, label, seed)
}

/// `err`'s message (or a report) holds every one of `needles`.
#[track_caller]
fn says(err: &impl std::fmt::Display, needles: &[&str]) {
    let msg = err.to_string();
    for needle in needles {
        assert!(msg.contains(needle), "`{needle}` not in: {msg}");
    }
}

/// Run the chain of `n`^3 `pattern` on the GPU and check every level against the mirror: C and N within
/// the declared 3 ULP, alpha bitwise (sum, * 0.25 and min are exact in f32), volume coverage bitwise
/// (sums and * 0.125 are exact) — or the flush-to-zero result, which WGSL allows, and nothing else.
fn check_chain(n: u32, pattern: Pattern, coverage: Coverage, seed: u64) {
    let shader = DECL.shader().expect("kernel WGSL validates");
    let case = chain(&shader, n, pattern, coverage, seed);
    let (comparisons, ..) =
        verify_case(gpu(), &shader, &SurfaceCoverageMip, &case, None).expect("GPU run");
    assert_eq!(
        comparisons.len(),
        2 * n.trailing_zeros() as usize,
        "one comparison per level and output"
    );
    for c in &comparisons {
        assert!(c.passed(), "{}", c.report());
    }

    // Exactness where the arithmetic is exact: alpha always, everything for volume coverage.
    let readback: Vec<&str> = case.checks.iter().map(|c| c.resource.as_str()).collect();
    let out = run_case(&shader, DECL.name, &case, &readback);
    let mut data = case.resources.clone();
    data.extend(out.resources.clone());
    let ieee = chain_mirror(&case, &data, FloatMode::Ieee);
    let flushed = chain_mirror(&case, &data, FloatMode::FlushToZero);
    for check in &case.checks {
        let gpu = out.buffer(&check.resource).as_f32();
        let m = ieee[&check.resource].as_f32();
        let f = flushed[&check.resource].as_f32();
        let pick = |v: &[f32]| -> Vec<f32> {
            match coverage {
                Coverage::Volume => v.to_vec(),
                Coverage::Surface if check.output == "dst_colour" => {
                    v.iter().skip(3).step_by(4).copied().collect()
                }
                Coverage::Surface => Vec::new(),
            }
        };
        let c = compare_f32(
            (DECL.name, &check.resource, &case.label, seed),
            &pick(gpu),
            &pick(m),
            Some(&pick(f)),
            Tolerance::Exact,
            Indexing::Linear,
        );
        assert!(c.passed(), "exact channels differ:\n{}", c.report());
    }
}

#[test]
fn every_family_at_every_size_up_to_128() {
    for log_n in 0..=7u32 {
        let n = 1 << log_n;
        for family in 0..8 {
            let pattern = Pattern::family(family + 8 * log_n as usize, n);
            // 128^3 is the slow end: one surface and one volume case there, all families below.
            if n == 128 && !(family == 4 || family == 7) {
                continue;
            }
            let coverage = [Coverage::Surface, Coverage::Volume][family % 2];
            check_chain(n, pattern, coverage, 1000 + family as u64);
        }
    }
}

#[test]
fn slabs_at_every_axis_and_offset() {
    let n = 16;
    for axis in 0..3u8 {
        for offset in 0..n {
            let pattern = Pattern::Slab { axis, offset };
            check_chain(n, pattern, Coverage::Surface, offset as u64);
        }
    }
}

#[test]
fn thin_diagonal_surfaces_at_every_offset() {
    let n = 8;
    for offset in 0..3 * n - 2 {
        let pattern = Pattern::Diagonal { offset };
        check_chain(n, pattern, Coverage::Surface, offset as u64);
    }
}

fn pattern_strategy() -> impl Strategy<Value = Pattern> {
    prop_oneof![
        Just(Pattern::Empty),
        Just(Pattern::Full),
        (0u8..3, 0u32..64).prop_map(|(axis, offset)| Pattern::Slab { axis, offset }),
        (0u32..190).prop_map(|offset| Pattern::Diagonal { offset }),
        Just(Pattern::TiltedPlane),
        (0.0f32..1.0).prop_map(|density| Pattern::RandomSparse { density }),
        Just(Pattern::FractionalAlpha),
        Just(Pattern::HardAlphas),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

    #[test]
    fn generated_grids_match_the_mirror(log_n in 0u32..=6, pattern in pattern_strategy(), volume in any::<bool>(), seed in any::<u64>()) {
        let coverage = if volume { Coverage::Volume } else { Coverage::Surface };
        check_chain(1 << log_n, pattern, coverage, seed);
    }
}

/// One generated case of seed `seed`, `corrupt` (a resource and an element) damaged first.
fn verify_one(seed: u64, corrupt: Option<(&str, usize)>) -> Result<KernelReport, String> {
    let corrupt = corrupt.map(|(resource, index)| Corruption {
        resource: resource.into(),
        index,
    });
    let opts = VerifyOptions {
        cases: 1,
        seed,
        corrupt,
    };
    verify(gpu(), &SurfaceCoverageMip, &opts, &mut |_| {}).map_err(|e| e.to_string())
}

#[test]
fn a_corrupted_gpu_element_fails_verification_with_a_full_report() {
    // Case 0 of the generator is an empty 2^3 grid; corrupting it must still be caught.
    let rep = verify_one(42, Some(("colour_1", 2))).expect("GPU run");
    assert!(!rep.passed(), "a corrupted element passed verification");
    let report = rep.failures[0].report();
    says(&report, &["surface_coverage_mip", "colour_1", "seed 42"]);
    says(&report, &["element 0 (x=0, y=0, z=0", "component 2"]);
    says(&report, &["FAIL", "ULP"]);

    // A corruption target that does not exist is an error, not a silent pass.
    assert!(verify_one(42, Some(("colour_1", 99))).is_err());

    // The tightest corruption: one element moved one ULP past the tolerance on a non-trivial case.
    assert!(verify_one(3, None).expect("GPU run").passed());
    let shader = DECL.shader().unwrap();
    let case = chain(&shader, 8, Pattern::Full, Coverage::Surface, 9);
    let corrupt = Corruption {
        resource: "normal_2".into(),
        index: 2,
    };
    let (comps, ..) =
        verify_case(gpu(), &shader, &SurfaceCoverageMip, &case, Some(&corrupt)).unwrap();
    let bad: Vec<_> = comps.iter().filter(|c| !c.passed()).collect();
    assert_eq!(bad.len(), 1, "exactly the corrupted output fails");
    assert_eq!(
        bad[0].failures,
        1,
        "exactly one element fails:\n{}",
        bad[0].report()
    );
    assert_eq!(bad[0].worst[0].index, 2);
}

#[test]
fn a_broken_wgsl_file_reports_line_and_column() {
    let src = "@group(0) @binding(0) var<storage, read_write> dst: array<f32>;\n\n@compute @workgroup_size(64)\nfn main() {\n    dst[0] = 1.0 +;\n}\n";
    let err = Shader::from_wgsl("kernels/broken.wgsl", src).expect_err("must not parse");
    let msg = err.to_string();
    let line_5 = matches!(err, HarnessError::WgslParse { line: 5, .. });
    assert!(line_5 && msg.starts_with("kernels/broken.wgsl:5:"), "{msg}");

    // Parses, but fails validation (f32 stored into a u32 array).
    let src = "@group(0) @binding(0) var<storage, read_write> dst: array<u32>;\n@compute @workgroup_size(1)\nfn main() {\n    dst[0] = 1.5;\n}\n";
    let e = Shader::from_wgsl("kernels/invalid.wgsl", src).expect_err("must not validate");
    use HarnessError::{WgslParse, WgslValidate};
    let line_4 = matches!(e, WgslValidate { line: 4, .. } | WgslParse { line: 4, .. });
    assert!(line_4, "{e}");
    says(&e, &["kernels/invalid.wgsl:4:"]);
}

fn one_level_case() -> (Shader, Case) {
    let shader = DECL.shader().unwrap();
    let case = chain(&shader, 4, Pattern::Full, Coverage::Surface, 1);
    (shader, case)
}

/// The error of running `case`, which must be refused.
fn refused(shader: &Shader, case: &Case) -> HarnessError {
    run(gpu(), shader, DECL.name, &case.resources, &case.passes, &[]).expect_err("must be refused")
}

#[test]
fn mis_sized_bindings_are_refused_before_dispatch_naming_the_binding() {
    let (shader, case) = one_level_case();
    let try_with = |edit: &dyn Fn(&mut Case)| {
        let mut c = case.clone();
        edit(&mut c);
        refused(&shader, &c)
    };
    // `src_colour` bound to a colour_0 of these bytes.
    let src_colour = |b: HostBuffer| {
        move |c: &mut Case| {
            c.resources.insert("colour_0".into(), b.clone().into());
            for p in &mut c.passes {
                p.bindings[1].1 = View::Buffer("colour_0".into());
            }
        }
    };

    // 20 bytes is not a whole number of vec4<f32>.
    let err = try_with(&src_colour(HostBuffer::zeroed(20, ScalarKind::F32)));
    let line = shader.binding("src_colour").unwrap().line;
    let at = format!("surface_coverage_mip.wgsl:{line}");
    says(&err, &["`src_colour`", &at, "20 bytes"]);

    // The uniform block must be exactly MipParams.
    let err = try_with(&|c| {
        c.resources
            .insert("params".into(), HostBuffer::u32(&[0, 0]).into());
    });
    says(&err, &["`params`", "exactly 4 bytes"]);

    // u32 data where WGSL reads f32.
    let err = try_with(&src_colour(HostBuffer::u32(&[0; 256])));
    says(&err, &["`src_colour`", "U32"]);

    // A binding the entry uses, left unbound.
    let err = try_with(&|c| {
        for p in &mut c.passes {
            p.bindings.retain(|(n, _)| n != "dst_normal");
        }
    });
    assert!(matches!(err, HarnessError::MissingBinding { .. }), "{err}");
    says(&err, &["`dst_normal`"]);

    // A name the WGSL does not declare.
    let err = try_with(&|c| {
        let typo = ("dst_colour_typo".into(), View::Buffer("colour_1".into()));
        c.passes[0].bindings.push(typo)
    });
    says(&err, &["dst_colour_typo", "src_colour"]);
}

#[test]
fn sizes_past_device_limits_are_errors_naming_the_limit() {
    let (shader, case) = one_level_case();
    let limits = gpu().limits();
    let mut c = case.clone();
    c.passes[0].workgroups =
        Workgroups::Direct([limits.max_compute_workgroups_per_dimension + 1, 1, 1]);
    let err = refused(&shader, &c);
    says(&err, &["max_compute_workgroups_per_dimension"]);

    // One vec4 more than one storage binding may hold (the buffer itself is within max_buffer_size),
    // in whole vec4s: NVIDIA's limit is 2^31 - 4, not a multiple of the stride.
    let too_big = (limits.max_storage_buffer_binding_size as usize / 16 + 1) * 16;
    if (too_big as u64) < limits.max_buffer_size {
        let mut c = case.clone();
        let big = HostBuffer::zeroed(too_big, ScalarKind::F32);
        c.resources.insert("big".into(), big.into());
        c.passes[0].bindings[1].1 = View::Buffer("big".into());
        let err = refused(&shader, &c);
        says(&err, &["max_storage_buffer_binding_size", "src_colour"]);
    }
}

#[test]
fn params_struct_matches_the_reflected_wgsl_layout() {
    crate::common::assert_layout!(DECL.shader().unwrap(), MipParams { coverage });
}

#[test]
fn the_declaration_names_bindings_the_wgsl_declares() {
    let shader = DECL.shader().unwrap();
    let outputs = DECL.outputs.iter().map(|o| o.binding);
    for name in DECL.inputs.iter().copied().chain(outputs) {
        let found = shader.binding(name).is_some();
        assert!(found, "declared binding `{name}` is not in the WGSL");
    }
    assert_eq!(shader.entry(DECL.entry).unwrap().workgroup_size, [64, 1, 1]);
    let unknown = vxgi::kernels::find("nope").err().unwrap();
    assert!(unknown.contains("surface_coverage_mip"), "{unknown}");
    assert_eq!(SurfaceCoverageMip.decl().name, "surface_coverage_mip");
}

/// A 256^3 chain: level 1's source is 256 MiB, twice what lavapipe binds, so the pass is split into
/// windows. Slow in a debug build: `cargo test --release -- --ignored`.
#[test]
#[ignore]
fn grid_256_splits_into_binding_windows_and_matches() {
    let shader = DECL.shader().unwrap();
    let case = chain(&shader, 256, Pattern::TiltedPlane, Coverage::Surface, 5);
    assert!(
        case.passes.len() > 8,
        "level 1 should be split on a 128 MiB binding limit"
    );
    assert_case_passes(&shader, &SurfaceCoverageMip, &case);
}

#[test]
fn window_split_matches_an_unsplit_run() {
    // Force windows on a small grid by pretending the binding limit is tiny: build the passes by hand.
    let shader = DECL.shader().unwrap();
    let sparse = Pattern::RandomSparse { density: 0.5 };
    let case = chain(&shader, 16, sparse, Coverage::Surface, 77);
    let whole = case.passes[0].clone();
    let mut split = Vec::new();
    for w in 0..2u64 {
        let (p0, count) = (w * 256, 256u64);
        let r = |name: &str, first: u64, len: u64| View::BufferRange {
            name: name.into(),
            offset: first * 16,
            size: len * 16,
        };
        split.push(Pass {
            label: format!("window {w}"),
            bindings: vec![
                ("params".into(), View::Buffer("params".into())),
                ("src_colour".into(), r("colour_0", 8 * p0, 8 * count)),
                ("src_normal".into(), r("normal_0", 8 * p0, 8 * count)),
                ("dst_colour".into(), r("colour_1", p0, count)),
                ("dst_normal".into(), r("normal_1", p0, count)),
            ],
            workgroups: Workgroups::Direct([4, 1, 1]),
            ..whole.clone()
        });
    }
    let levels_1 = |passes: Vec<Pass>| {
        let mut c = case.clone();
        c.passes = passes;
        run_case(&shader, DECL.name, &c, &["colour_1", "normal_1"]).resources
    };
    assert_eq!(levels_1(vec![whole]), levels_1(split));
}
