//! Frames of a camera orbit, counted: every pipeline on the Cornell box and thin_wall at 256x256,
//! `frames` frames 5 degrees apart with the renderer's reuse on (as `vxgi render --frames 6 --orbit 5`),
//! and scenes/instances.toml's 7-frame animation (`vxgi render scenes/instances.toml --frames 7`);
//! cprc twice more with `cache_reuse`, its kept caches' texels carried (`cache_carry`, the default)
//! and traced again.
//! Per pipeline and scene: the medians over the frames after the first of wall clock, GPU time
//! (timestamp queries), wall / GPU, submissions, buffers and bind groups created, bytes uploaded and
//! read back, from the context's counters (`vxgi::frames`), of the GPU-resident renderer
//! (`vxgi::resident::Resident`). The table goes to stdout as markdown; docs/frames.md holds a run
//! (with the staged frames it replaced, measured in the same run before they were removed).
//!
//! `cargo bench --bench frames [-- FRAMES]` (default 6)
use vxgi::frames::{counted, median, FrameRow};
use vxgi::harness::GpuContext;
use vxgi::kernels::cone_trace::ConeSettings;
use vxgi::render::Pipeline;
use vxgi::resident::Resident;
use vxgi::scene::Scene;

fn main() {
    let frames: u32 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(6)
        .max(2);
    let ctx = GpuContext::new().expect("GPU adapter (see README: install mesa-vulkan-drivers)");
    println!("adapter: {}\n", ctx.describe());
    println!(
        "{frames} frames, 5 degrees apart; medians over frames 1..{}\n",
        frames - 1
    );
    println!("| pipeline | scene | wall ms | GPU ms | wall / GPU | submissions | buffers | bind groups | upload MB | readback MB |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let instances =
        Scene::load(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/instances.toml"))
            .expect("scenes/instances.toml");
    // The instance scene's frames are its animation (a box sliding and turning over frames 0-6),
    // the camera still; the others orbit.
    for (name, scene, animated) in [
        ("cornell_box", Scene::cornell_box(), false),
        ("thin_wall", Scene::thin_wall(), false),
        ("instances", instances, true),
    ] {
        let mut scene = scene;
        scene.camera.width = 256;
        scene.camera.height = 256;
        let frames = if animated { frames.max(7) } else { frames };
        let cones = ConeSettings::from(&scene.render);
        let print = |label: &str, rows: &[FrameRow]| {
            let later = &rows[1..];
            let m = |f: &dyn Fn(&FrameRow) -> f64| median(later.iter().map(f).collect());
            println!(
                "| {label} | {name} | {:.0} | {:.0} | {:.2} | {} | {} | {} | {:.4} | {:.1} |",
                m(&|r| r.wall_ms),
                m(&|r| r.gpu_ms()),
                m(&|r| r.wall_ms / r.gpu_ms()),
                m(&|r| r.counters.submissions as f64),
                m(&|r| r.counters.buffers_created as f64),
                m(&|r| r.counters.bind_groups_created as f64),
                m(&|r| r.counters.upload_bytes as f64) / 1e6,
                m(&|r| r.counters.readback_bytes as f64) / 1e6,
            );
        };
        let view = |k: u32| {
            if animated {
                scene.at_frame(k)
            } else {
                scene.orbited(5.0 * k as f32)
            }
        };
        // (label, pipeline, cprc's cache reuse with its texels carried or traced).
        let runs: Vec<(String, Pipeline, Option<bool>)> = Resident::PIPELINES
            .into_iter()
            .map(|p| (format!("{}, GPU-resident", p.name()), p, None))
            .chain([true, false].map(|carry| {
                let how = if carry { "carried" } else { "traced" };
                (
                    format!("cprc, cache reuse, {how}"),
                    Pipeline::Cprc,
                    Some(carry),
                )
            }))
            .collect();
        let settings = |mut s: Scene, reuse: Option<bool>| {
            if let Some(carry) = reuse {
                s.render.cache_reuse = true;
                s.render.cache_carry = carry;
            }
            s
        };
        for (label, p, reuse) in &runs {
            let mut resident = Resident::new(&ctx, *p).expect("a resident pipeline");
            let rows: Vec<FrameRow> = (0..frames)
                .map(|k| {
                    counted(&ctx, k, || {
                        resident.render(&settings(view(k), *reuse), &cones)
                    })
                    .expect("frame")
                    .1
                })
                .collect();
            print(label, &rows);
        }
    }
}
