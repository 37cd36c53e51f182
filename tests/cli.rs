//! The `vxgi` command line as a user runs it.
use crate::common;

use common::vxgi;

#[test]
fn verify_prints_the_table_and_exits_zero() {
    let (code, out, err) = vxgi(&["verify", "--cases", "8", "--seed", "3"]);
    assert_eq!(code, 0, "stdout:\n{out}\nstderr:\n{err}");
    for col in [
        "kernel",
        "cases",
        "elements",
        "max ULP",
        "p99 ULP",
        "GPU ms",
        "mirror ms",
        "eff. GB/s",
        "copy GB/s",
    ] {
        assert!(out.contains(col), "missing column `{col}`:\n{out}");
    }
    assert!(
        out.contains("surface_coverage_mip") && out.contains("adapter:"),
        "{out}"
    );
}

/// `--case N` replays one generated case (what a failure's "reproduce:" line names) and prints each
/// output's report with its worst elements, pass or fail; with `--cases` it is a usage error.
#[test]
fn verify_case_replays_one_generated_case_with_its_worst_elements() {
    let (code, out, err) = vxgi(&[
        "verify",
        "--kernel",
        "sample_lrsm",
        "--seed",
        "3",
        "--case",
        "0",
    ]);
    assert_eq!(code, 0, "stdout:\n{out}\nstderr:\n{err}");
    assert!(out.contains("sample_lrsm case 0 `#0 "), "{out}");
    assert!(out.contains("ok radiance, bound use"), "{out}");
    assert!(
        out.contains("ok index element "),
        "worst elements listed:\n{out}"
    );
    let (code, _, err) = vxgi(&["verify", "--case", "0", "--cases", "3"]);
    assert_ne!(code, 0);
    assert!(err.contains("--cases"), "{err}");
}

#[test]
fn an_unknown_kernel_is_a_clear_error() {
    let (code, out, err) = vxgi(&["verify", "--kernel", "nope"]);
    assert_ne!(code, 0, "{out}");
    assert!(
        err.contains("no kernel named `nope`") && err.contains("surface_coverage_mip"),
        "{err}"
    );
}

#[test]
fn zero_cases_is_refused() {
    let (code, _, err) = vxgi(&["verify", "--cases", "0"]);
    assert_ne!(code, 0);
    assert!(err.contains("--cases"), "{err}");
}

#[test]
fn list_names_wgsl_file_and_mirror() {
    let (code, out, _) = vxgi(&["list"]);
    assert_eq!(code, 0);
    assert!(
        out.contains("kernels/surface_coverage_mip.wgsl")
            && out.contains("vxgi_cpu_mirror::surface_coverage_mip::reduce_level"),
        "{out}"
    );
}

#[test]
fn scene_summarises_the_built_in_cornell_box_and_reports_bad_files() {
    let (code, out, err) = vxgi(&["scene"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("30 triangles") && out.contains("1 lights"),
        "{out}"
    );
    // The Cornell box spans 2 units along its longest axes.
    assert!(
        out.contains("voxel grid: 128^3 voxels of 0.015625"),
        "{out}"
    );
    let (code, _, err) = vxgi(&["scene", "/nonexistent/scene.toml"]);
    assert_ne!(code, 0);
    assert!(err.contains("/nonexistent/scene.toml"), "{err}");
    // The OS's reason stands once: in the path's line, not again as a cause.
    assert_eq!(err.matches("No such file").count(), 1, "{err}");
}

/// An inside-out mesh (the Cornell box with every face's vertex order reversed) renders black in
/// every pipeline and the reference alike (back faces reflect nothing): `vxgi scene`, `vxgi render`
/// (here its plan, which needs no GPU) and `vxgi report` say so; the shipped box, seen from inside
/// its front faces, says nothing.
#[test]
fn an_inside_out_mesh_is_named() {
    let d = std::env::temp_dir().join(format!("vxgi-cli-{}-inside-out", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let obj = std::fs::read_to_string(root.join("cornell_box.obj")).unwrap();
    let flipped: Vec<String> = obj
        .lines()
        .map(|l| match l.strip_prefix("f ") {
            Some(f) => format!(
                "f {}",
                f.split_whitespace().rev().collect::<Vec<_>>().join(" ")
            ),
            None => l.to_string(),
        })
        .collect();
    std::fs::write(d.join("cornell_box.obj"), flipped.join("\n")).unwrap();
    std::fs::copy(root.join("cornell_box.mtl"), d.join("cornell_box.mtl")).unwrap();
    std::fs::copy(root.join("cornell_box.toml"), d.join("scene.toml")).unwrap();
    let scene = d.join("scene.toml");
    let said = "100% of what the camera sees is the back of faces";
    let (code, _, err) = vxgi(&["scene", scene.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains(said), "{err}");
    let (code, _, err) = vxgi(&["render", scene.to_str().unwrap(), "--plan"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains(said), "{err}");
    let (code, _, err) = vxgi(&["scene", root.join("cornell_box.toml").to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("back of faces"), "{err}");
    std::fs::remove_dir_all(&d).ok();
}

/// Texture coordinates past what voxelize's fixed point holds: `vxgi scene` refuses the scene, naming
/// the triangle's material, its texture and the coordinates' range, as `vxgi render` does.
#[test]
fn scene_names_texture_coordinates_voxelize_cannot_hold() {
    let d = std::env::temp_dir().join(format!("vxgi-cli-{}-uv", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    std::fs::copy(root.join("checker.png"), d.join("checker.png")).unwrap();
    std::fs::write(
        d.join("m.mtl"),
        "newmtl tiles\nKd 1 1 1\nmap_Kd checker.png\n",
    )
    .unwrap();
    std::fs::write(
        d.join("quad.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1e7 0\nvt 0 1\nvn 0 0 1\nusemtl tiles\nf 1/1/1 2/2/1 3/3/1\n",
    )
    .unwrap();
    let p = d.join("uv.toml");
    std::fs::write(
        &p,
        "[mesh]\nobj = \"quad.obj\"\n[camera]\neye = [0.5, 0.5, 2.0]\ntarget = [0.5, 0.5, 0.0]\nup = [0.0, 1.0, 0.0]\nfov_y_deg = 40.0\nwidth = 16\nheight = 16\n[[lights]]\ntype = \"point\"\nposition = [0.5, 0.5, 1.0]\nintensity = [1.0, 1.0, 1.0]\n",
    )
    .unwrap();
    let p = p.to_str().unwrap();
    for args in [
        vec!["scene", p],
        vec!["render", p, "--pipeline", "vct-dense"],
    ] {
        let (code, _, err) = vxgi(&args);
        assert_ne!(code, 0, "{args:?}");
        assert!(
            err.contains("triangle 0 (material tiles, map_Kd")
                && err.contains("checker.png")
                && err.contains("u 0..10000000"),
            "{args:?}: {err}"
        );
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn two_bounces_are_refused_where_a_pipeline_renders_one_and_planned_by_vct_svo() {
    let (code, _, err) = vxgi(&["render", "--bounces", "2", "--plan"]);
    assert_ne!(code, 0);
    assert!(
        err.contains("bounces = 2") && err.contains("vct-svo"),
        "{err}"
    );
    let (code, out, err) = vxgi(&[
        "render",
        "--pipeline",
        "vct-svo",
        "--bounces",
        "2",
        "--plan",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("run  svo_bounce"), "{out}");
    let (code, _, err) = vxgi(&["render", "--bounces", "3", "--plan"]);
    assert_ne!(code, 0);
    assert!(err.contains("bounces = 3 must be 1 or 2"), "{err}");
}

#[test]
fn bisect_names_its_stages_and_refuses_an_unknown_one() {
    let (code, out, err) = vxgi(&["bisect", "--mirror-until", "voxelise"]);
    assert_ne!(code, 0, "{out}");
    assert!(
        err.contains("no stage `voxelise`") && err.contains("surface_coverage_mip"),
        "{err}"
    );
    let dir = std::env::temp_dir().join(format!("vxgi_bisect_{}", std::process::id()));
    let dir_s = dir.to_str().unwrap();
    let (code, out, err) = vxgi(&[
        "bisect",
        "--mirror-until",
        "voxel_light",
        "--voxels",
        "16",
        "--out",
        dir_s,
    ]);
    assert_eq!(code, 0, "stdout:\n{out}\nstderr:\n{err}");
    assert!(
        out.contains("mirror: direct light into the voxels"),
        "{out}"
    );
    assert!(out.contains("GPU: cones read coarser levels"), "{out}");
    assert!(dir.join("combined.exr").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_supersampled_plan_runs_on_the_samples_and_bad_factors_are_refused() {
    let (code, out, err) = vxgi(&["render", "--plan", "--supersample", "2"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("supersample 2: 2 x 2 samples per pixel (512x512), box-filtered to 256x256")
            && out.contains("512x512 pixels"),
        "{out}"
    );
    let (code, _, err) = vxgi(&["render", "--plan", "--supersample", "5"]);
    assert_ne!(code, 0);
    assert!(err.contains("supersample = 5 must be in 1..=4"), "{err}");
}

/// Settings past the device's limits are refused at once, before anything large is allocated, with
/// an ordinary error exit naming the limit and the setting; `vxgi scene` reports the same.
#[test]
fn settings_past_the_device_limits_are_refused_at_once() {
    let d = std::env::temp_dir().join(format!("vxgi-cli-{}-limits", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for f in ["cornell_box.obj", "cornell_box.mtl"] {
        std::fs::copy(root.join(f), d.join(f)).unwrap();
    }
    let toml = std::fs::read_to_string(root.join("cornell_box.toml")).unwrap();
    let light = "[[lights]]\ntype = \"point\"\nposition = [0.0, 1.9, 0.0]\nintensity = [0.05, 0.05, 0.05]\n\n";
    // The scene file up to its light, then 200 lights, read through the paper's LRSMs (whose size
    // grows with the light views; the lit cells' does not).
    let head = &toml[..toml.find("[[lights]]").unwrap()];
    let p = d.join("many_lights.toml");
    let lrsms = "[render]\nlrsm_lit_cells = false\n";
    std::fs::write(&p, format!("{head}{}{lrsms}", light.repeat(200))).unwrap();
    let p = p.to_str().unwrap();
    let out = d.join("out");
    let t = std::time::Instant::now();
    let (code, _, err) = vxgi(&[
        "render",
        p,
        "--pipeline",
        "lrsm",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("1200 light views") && err.contains("max_storage_buffer_binding_size"),
        "{err}"
    );
    // Not a timing assertion: a refusal after rendering would take tens of seconds here.
    println!("refused after {:.2} s", t.elapsed().as_secs_f64());
    let (code, out_s, err) = vxgi(&["scene", p]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out_s.contains("lrsm: refused") && out_s.contains("vct-dense: fits"),
        "{out_s}"
    );
    let (code, _, err) = vxgi(&[
        "render",
        "--pipeline",
        "vct-svo",
        "--photon-map",
        "2048",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("photon_map = 2048") && err.contains("at most photon_map"),
        "{err}"
    );
}

/// `vxgi render --frames N --out DIR` writes DIR/frames.csv: exactly the header, one row per frame
/// counted from 0, the counts read from the GPU context; compute pipelines are compiled once per
/// renderer (no frame after the first creates one) and every frame did GPU work. The GPU-resident
/// pipelines (vct-dense, lrsm): every frame after the first is one submission that creates nothing,
/// reads nothing back but its images and uploads at most 64 KiB.
#[test]
fn render_frames_writes_the_counters_per_frame() {
    let d = std::env::temp_dir().join(format!("vxgi-cli-{}-frames", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for f in ["cornell_box.obj", "cornell_box.mtl"] {
        std::fs::copy(root.join(f), d.join(f)).unwrap();
    }
    let toml = std::fs::read_to_string(root.join("cornell_box.toml"))
        .unwrap()
        .replace("width = 256", "width = 32")
        .replace("height = 256", "height = 32");
    let p = d.join("small.toml");
    std::fs::write(&p, toml).unwrap();
    for pipeline in ["vct-dense", "lrsm"] {
        let out = d.join(pipeline);
        let (code, stdout, err) = vxgi(&[
            "render",
            p.to_str().unwrap(),
            "--pipeline",
            pipeline,
            "--voxels",
            "32",
            "--rsm-side",
            "32",
            "--frames",
            "3",
            "--orbit",
            "5",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        assert!(
            stdout.contains("fps over 2 frames after the first"),
            "{stdout}"
        );
        let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
        let mut lines = csv.lines();
        assert_eq!(
            lines.next(),
            Some("frame,wall_ms,gpu_ms,submissions,pipelines_created,buffers_created,textures_created,bind_groups_created,upload_bytes,readback_bytes")
        );
        let rows: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), 3, "{csv}");
        for (k, r) in rows.iter().enumerate() {
            assert_eq!(r.len(), 10, "{csv}");
            assert_eq!(r[0], k as f64);
            assert!(r[1] > 0.0 && r[2] > 0.0 && r[3] >= 1.0, "frame {k}: {csv}");
            if k > 0 {
                assert_eq!(
                    r[3..8],
                    [1.0, 0.0, 0.0, 0.0, 0.0],
                    "{pipeline} frame {k}: {csv}"
                );
                assert!(
                    r[8] <= 65536.0 && r[9] == 0.0,
                    "{pipeline} frame {k}: {csv}"
                );
            }
        }
        assert!(rows[0][4] > 0.0, "frame 0 compiles the pipelines: {csv}");
    }
}

/// `vxgi limits`: every kernel's needs from reflection, and a line per pipeline against WebGPU's
/// default limits (eight storage buffers per stage: the ray-traced kernels bind more).
#[test]
fn limits_lists_every_kernel_and_pipeline() {
    let (code, out, err) = vxgi(&["limits"]);
    assert_eq!(code, 0, "{err}");
    for k in vxgi::kernels::all() {
        assert!(out.contains(&format!("| {} |", k.decl().name)), "{out}");
    }
    for p in ["vct-dense:", "vct-svo:", "lrsm:", "cprc:"] {
        assert!(out.contains(p), "{out}");
    }
    assert!(out.contains("| gbuffer | 11 |"), "{out}");
}

/// `compare` against a black reference says the energy ratio is undefined instead of printing NaN
/// or inf, and warns when an .exr (linear) is compared with a .png (its sRGB preview).
#[test]
fn compare_names_an_undefined_energy_ratio_and_mixed_encodings() {
    use vxgi::images::{write_exr, RgbImage};
    let dir = std::env::temp_dir().join(format!("vxgi-cli-compare-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let black = dir.join("black.exr");
    let lit = dir.join("lit.exr");
    write_exr(&black, &RgbImage::new(4, 4, vec![[0.0; 3]; 16])).unwrap();
    write_exr(&lit, &RgbImage::new(4, 4, vec![[0.5; 3]; 16])).unwrap();
    let s = |p: &std::path::Path| p.display().to_string();
    for test in [&black, &lit] {
        let (code, out, err) = vxgi(&["compare", &s(&black), &s(test)]);
        assert_eq!(code, 0, "{out}\n{err}");
        assert!(
            out.contains("energy ratio undefined (the reference image is black)"),
            "{out}"
        );
        assert!(!out.contains("NaN") && !out.contains("inf"), "{out}");
        assert!(!err.contains("different formats"), "{err}");
    }
    let png = dir.join("lit.png");
    image::RgbImage::from_raw(4, 4, vec![128; 48])
        .unwrap()
        .save(&png)
        .unwrap();
    let (code, out, err) = vxgi(&["compare", &s(&lit), &s(&png)]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(err.contains("different formats"), "{err}");
    // A directory, and a heat map named as another format, are named as such.
    let (code, _, err) = vxgi(&["compare", &s(&dir), &s(&lit)]);
    assert_ne!(code, 0);
    assert!(
        err.contains("a directory") && err.contains("indirect.exr"),
        "{err}"
    );
    let heat = dir.join("heat.jpg");
    let (code, _, err) = vxgi(&["compare", &s(&lit), &s(&lit), "--heatmap", &s(&heat)]);
    assert_ne!(code, 0);
    assert!(err.contains("name it .png") && !heat.exists(), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A setting the chosen pipeline does not read (set in the file or on the command line) is said to
/// change nothing, naming it; one it reads is not. A cone offset past the grid is refused.
#[test]
fn settings_a_pipeline_does_not_read_are_named_and_a_far_cone_offset_refused() {
    for (pipeline, flags, unread) in [
        (
            "vct-dense",
            &["--photon-map", "64", "--cache-tile", "4"][..],
            "cache_tile, photon_map",
        ),
        ("cprc", &["--cones", "4"][..], "cones"),
        (
            "vct-svo",
            &["--depth-ordered-blend", "true"][..],
            "depth_ordered_blend",
        ),
        (
            "lrsm",
            &["--lrsm-depth-splits", "4"][..],
            "lrsm_depth_splits",
        ),
    ] {
        let mut args = vec!["render", "--plan", "--pipeline", pipeline];
        args.extend_from_slice(flags);
        let (code, _, err) = vxgi(&args);
        assert_eq!(code, 0, "{err}");
        assert!(
            err.contains(&format!("{pipeline} does not read {unread} (")),
            "{pipeline}: {err}"
        );
    }
    for (pipeline, flags) in [
        ("vct-svo", &["--photon-map", "64"][..]),
        (
            "lrsm",
            &["--lrsm-lit-cells", "false", "--lrsm-depth-splits", "4"][..],
        ),
        ("cprc", &["--cache-tile", "4"][..]),
    ] {
        let mut args = vec!["render", "--plan", "--pipeline", pipeline];
        args.extend_from_slice(flags);
        let (code, _, err) = vxgi(&args);
        assert_eq!(code, 0, "{err}");
        assert!(!err.contains("does not read"), "{pipeline}: {err}");
    }
    let (code, _, err) = vxgi(&["render", "--plan", "--cone-offset", "1000"]);
    assert_ne!(code, 0);
    assert!(
        err.contains("cone_offset = 1000 must be in [0, voxels"),
        "{err}"
    );
}

/// Output into a pipe its reader closed ends the process as a Unix tool's does, without a panic; a
/// view script's window past the camera's limit and a cone step whose opacity the GPU's `pow`
/// rounds away are refused before anything runs.
#[test]
fn a_closed_pipe_a_huge_window_and_a_short_cone_step_end_cleanly() {
    use std::io::Read;
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_vxgi"))
        .arg("list")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run vxgi");
    drop(child.stdout.take());
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    let status = child.wait().unwrap();
    assert!(
        status.code() != Some(101) && !err.contains("panicked"),
        "{status:?}: {err}"
    );
    let (code, _, err) = vxgi(&["view", "--frames", "2", "--script", "1 resize 16385 1"]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("8192x8192") && !err.contains("panicked"),
        "{err}"
    );
    let (code, _, err) = vxgi(&["render", "--plan", "--cone-step", "0.001"]);
    let refused = code == 1 && err.contains("cone_step = 0.001 must be in [0.015625, 1]");
    assert!(refused, "{err}");
}

/// Inputs that are not what they claim are named before any work: an image with negative
/// radiance, a heat map that would overwrite an input, a reference folder of black images, an
/// `--out` that is a file, a `--script` naming a file that is not there.
#[test]
fn bad_images_references_and_paths_are_named_first() {
    use vxgi::images::{write_exr, RgbImage};
    let dir = std::env::temp_dir().join(format!("vxgi-cli-named-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("black")).unwrap();
    let s = |p: &std::path::Path| p.display().to_string();
    let lit = dir.join("lit.exr");
    let neg = dir.join("neg.exr");
    write_exr(&lit, &RgbImage::new(4, 4, vec![[0.5; 3]; 16])).unwrap();
    let mut px = vec![[0.5; 3]; 16];
    px[6] = [0.5, -1.0, 0.5];
    write_exr(&neg, &RgbImage::new(4, 4, px)).unwrap();
    let (code, _, err) = vxgi(&["compare", &s(&lit), &s(&neg)]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("neg.exr: negative radiance at (2, 1)"),
        "{err}"
    );
    let png = dir.join("lit.png");
    image::RgbImage::from_raw(4, 4, vec![128; 48])
        .unwrap()
        .save(&png)
        .unwrap();
    let (code, _, err) = vxgi(&["compare", &s(&png), &s(&png), "--heatmap", &s(&png)]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("an image being compared"), "{err}");
    let black = RgbImage::new(256, 256, vec![[0.0; 3]; 256 * 256]);
    for name in ["indirect.exr", "combined.exr"] {
        write_exr(&dir.join("black").join(name), &black).unwrap();
    }
    let out = dir.join("factors");
    let (code, _, err) = vxgi(&[
        "lrsm-factors",
        "--reference",
        &s(&dir.join("black")),
        "--out",
        &s(&out),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("black everywhere"), "{err}");
    let (code, _, err) = vxgi(&["render", "--out", &s(&lit)]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("a file, not a folder"), "{err}");
    let (code, _, err) = vxgi(&["view", "--frames", "2", "--script", "nope.txt"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--script nope.txt: no such file"), "{err}");
    let (code, _, err) = vxgi(&["view", "--frames", "2", "--screenshot", "s.jpg"]);
    assert!(
        code == 1 && err.contains("written as PNG; name it .png"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
