//! `vxgi view` in a real window under Xvfb (lavapipe presents to it): each pipeline's screenshot, read
//! from the presented surface texture, against the same frame rendered in this process by the
//! resident renderer `vxgi render` uses (FLIP < 0.02), a scripted run (orbit, switch pipeline, move
//! the light), and the overlay's numbers against frames.csv. Without `xvfb-run` these fail with the
//! install command (`./test` installs it where it can: .ci/ensure-gpu).
use crate::common::gpu;
use std::path::Path;
use std::process::Command;
use vxgi::images::{srgb8, RgbImage};
use vxgi::kernels::cone_trace::ConeSettings;
use vxgi::render::Pipeline;
use vxgi::resident::Resident;
use vxgi::scene::Scene;

/// `vxgi view ARGS` under a fresh virtual X server: its stdout, or a failure with its output.
fn view(args: &[&str]) -> String {
    let found = Command::new("xvfb-run").arg("--help").output().is_ok();
    assert!(
        found,
        "the window tests need xvfb-run: apt-get install xvfb libxkbcommon-x11-0 (or run ./test, which installs them as root)"
    );
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 640x480x24"])
        .arg(env!("CARGO_BIN_EXE_vxgi"))
        .arg("view")
        .args(args)
        .output()
        .expect("running xvfb-run");
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    assert!(
        out.status.success(),
        "vxgi view {args:?} failed:\n{}\n{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    text(&out.stdout)
}

fn linear_of_png(path: &Path) -> RgbImage {
    let img = image::open(path).expect("the screenshot").to_rgb8();
    let (w, h) = img.dimensions();
    let decode = |c: u8| {
        let x = c as f32 / 255.0;
        if x <= 0.04045 {
            x / 12.92
        } else {
            ((x + 0.055) / 1.055).powf(2.4)
        }
    };
    let px = img.pixels().map(|p| p.0.map(decode)).collect();
    RgbImage::new(w, h, px)
}

/// The frame `vxgi render` draws for `scene`, through the PNG transform and back to linear (what a
/// screenshot of it can hold), against the screenshot at `shot`: mean FLIP.
fn flip_against_render(pipeline: Pipeline, scene: &Scene, shot: &Path) -> f32 {
    let ctx = gpu();
    // Its quality preset resolved, as `vxgi render` and the window do.
    let (scene, _) = vxgi::quality::resolved(scene, pipeline).unwrap();
    let mut r = Resident::new(ctx, pipeline).unwrap();
    let frame = r
        .render(&scene, &ConeSettings::from(&scene.render))
        .unwrap();
    let png = shot.with_file_name("render.png");
    let c = &frame.combined;
    image::RgbImage::from_raw(c.width, c.height, srgb8(c))
        .unwrap()
        .save(&png)
        .unwrap();
    let want = linear_of_png(&png);
    let got = linear_of_png(shot);
    vxgi::images::compare(&want, &png, &got, shot)
        .unwrap()
        .flip_mean
}

#[test]
fn every_pipelines_window_shows_what_render_draws() {
    let dir = tempfile_dir("view_pipelines");
    let scene = Scene::cornell_box();
    for p in Resident::PIPELINES {
        let shot = dir.join(format!("{}.png", p.name()));
        let stdout = view(&[
            "--pipeline",
            p.name(),
            "--frames",
            "2",
            "--no-overlay",
            "--screenshot",
            shot.to_str().unwrap(),
        ]);
        assert!(stdout.contains("screenshot: "), "{stdout}");
        let flip = flip_against_render(p, &scene, &shot);
        assert!(flip < 0.02, "{}: window vs render FLIP {flip}", p.name());
    }
}

#[test]
fn a_script_orbits_switches_and_moves_the_light_and_the_overlay_reports_the_counters() {
    let dir = tempfile_dir("view_script");
    let shot = dir.join("scripted.png");
    view(&[
        "--frames",
        "4",
        "--script",
        "1 orbit 20; 2 pipeline lrsm; 2 light 0.05 0 0; 3 overlay off",
        "--screenshot",
        shot.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    let mut scene = Scene::cornell_box().orbited(20.0);
    vxgi::view::move_light(&mut scene.lights[0], glam::Vec3::new(0.05, 0.0, 0.0));
    let flip = flip_against_render(Pipeline::Lrsm, &scene, &shot);
    assert!(flip < 0.02, "scripted window vs render FLIP {flip}");
    // Frame k's overlay shows frame k-1's counters: the same numbers frames.csv holds.
    let csv = std::fs::read_to_string(dir.join("frames.csv")).unwrap();
    let overlay = std::fs::read_to_string(dir.join("overlay.txt")).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 4);
    // Frames 1 and 2 show frames 0 and 1 (frame 3 hides the overlay). The overlay rounds the
    // measured values to 0.1, frames.csv to 0.001: equal within half of 0.1 and the csv's rounding.
    for (k, row) in rows.iter().enumerate().take(2) {
        let prefix = format!("frame {k}: ");
        let line = overlay
            .lines()
            .find(|l| l.starts_with(&prefix))
            .unwrap_or_else(|| panic!("no {prefix:?} in\n{overlay}"));
        let numbers: Vec<f64> = line[prefix.len()..]
            .split(|c: char| !(c.is_ascii_digit() || c == '.'))
            .filter_map(|t| t.parse().ok())
            .collect();
        let [fps, wall, gpu, submissions] = numbers[..4] else {
            panic!("{line:?}")
        };
        let close = |a: f64, b: f64| (a - b).abs() <= 0.0505 + 1e-9 * b.abs();
        assert!(
            close(wall, row[1]) && close(gpu, row[2]),
            "{line:?} vs {row:?}"
        );
        // fps = 1000 / wall, from the exact wall: the csv's rounding moves it by far less.
        assert!(close(fps, 1e3 / row[1].max(1e-3)), "{line:?} vs {row:?}");
        assert_eq!(submissions, row[3], "{line:?}");
    }
    // The orbited frame (1) and lrsm's frame over its kept chain (3): one submission creating no
    // pipeline, buffer or texture.
    for k in [1, 3] {
        assert_eq!(
            &rows[k][3..=6],
            &[1.0, 0.0, 0.0, 0.0],
            "frame {k}: {rows:?}"
        );
    }
}

fn tempfile_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("vxgi_{name}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A script that moves the light or the camera past the scene files' coordinate bound is an error
/// naming it, not a silently black frame.
#[test]
fn a_script_moving_past_the_coordinate_bound_is_an_error() {
    for step in ["0 light 0 0 1e30", "0 fly 1e30 0 0"] {
        let out = Command::new("xvfb-run")
            .args(["-a", "-s", "-screen 0 640x480x24"])
            .arg(env!("CARGO_BIN_EXE_vxgi"))
            .args(["view", "--frames", "1", "--script", step])
            .output()
            .expect("running xvfb-run");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "`{step}` succeeded");
        assert!(
            err.contains("past the scenes' coordinate bound"),
            "{step}: {err}"
        );
    }
}
