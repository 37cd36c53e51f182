//! `vxgi report`: every scene with every pipeline and with the Monte Carlo reference, compared; a table
//! (printed and written as report.md with the images side by side).
use crate::images::{compare, write_frame, RgbImage};
use crate::kernels::cone_trace::ConeSettings;
use crate::reference::{leak, pixel_positions, render_reference, ReferenceOptions};
use crate::scene::Scene;
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::Path;

#[derive(Clone, Debug)]
pub struct ReportRow {
    pub pipeline: &'static str,
    pub scene: String,
    /// Wall-clock seconds of the pipeline's stages (transfers included).
    pub seconds: f64,
    pub indirect_flip: f32,
    pub combined_flip: f32,
    /// Bytes of GPU buffers the frame allocates (none for the ideal cones: CPU).
    pub memory: Option<u64>,
    /// Light leak (thin_wall only): indirect energy seen in the dark room / in the lit room.
    pub leak: Option<f64>,
    /// Temporal instability over the report's orbit ([`crate::temporal::Orbit`]; `None`: not
    /// measured).
    pub instability: Option<f64>,
}

impl ReportRow {
    /// Memory in MB (`-` for none), as the table prints it.
    pub fn memory_text(&self) -> String {
        self.memory
            .map(|m| format!("{:.1} MB", m as f64 / 1e6))
            .unwrap_or_else(|| "-".into())
    }

    /// The instability to four places (`-` for none), as the table prints it.
    pub fn instability_text(&self) -> String {
        self.instability
            .map(|l| format!("{l:.4}"))
            .unwrap_or_else(|| "-".into())
    }

    /// The leak to four places (`-` for none), as the table prints it.
    pub fn leak_text(&self) -> String {
        self.leak
            .map(|l| format!("{l:.4}"))
            .unwrap_or_else(|| "-".into())
    }
}

/// Rays per cone of the report's ideal-cones row (stratified 8 x 8).
pub const IDEAL_CONE_RAYS: u32 = 64;

/// Render every scene with the reference (`spp`), vct-dense, vct-svo, lrsm and cprc, write the images under
/// `out` (`<scene>/reference/`, `<scene>/<pipeline>/`) and report.md; return the rows. Each scene also
/// gets an "ideal cones" row: the scene's diffuse cone set with exact visibility and radiance
/// ([`crate::reference::ideal_cones`], CPU), the error the cone tracers would keep with perfect
/// voxels. With `temporal`, each pipeline row also measures its instability over that orbit.
pub fn report(
    ctx: &crate::harness::GpuContext,
    scenes: &[(String, Scene)],
    spp: u32,
    temporal: Option<crate::temporal::Orbit>,
    out: &Path,
    progress: impl Fn(&str),
) -> Result<Vec<ReportRow>> {
    let mut rows = Vec::new();
    let mut md = String::from("# vxgi report\n\n| pipeline | scene | time | indirect FLIP | combined FLIP | memory | leak | orbit instability |\n|---|---|---|---|---|---|---|---|\n");
    let mut images = String::new();
    for (name, scene) in scenes {
        let dir = out.join(name);
        let mut ideal_frames = temporal.map(|t| t.ideal_frames());
        progress(&format!("{name}: reference ({spp} spp)"));
        let reference = render_reference(scene, &ReferenceOptions::spp(spp), |_| {});
        let (w, h) = (reference.width, reference.height);
        let rgb = |px: Vec<[f32; 3]>| RgbImage::new(w, h, px);
        let ref_direct = rgb(reference.direct.clone());
        let ref_indirect = rgb(reference.indirect.clone());
        let ref_combined = rgb(reference.combined());
        let ref_ao = rgb(reference.ao.clone());
        write_into(
            &dir.join("reference"),
            [&ref_direct, &ref_indirect, &ref_combined, &ref_ao],
        )?;

        // Ideal cones gather one bounce: against a two-bounce reference they would be a wrong row.
        // An interleaved frame's are of its classes' whole set (`reference::cone_set`).
        if scene.render.bounces == 1 {
            progress(&format!("{name}: ideal cones"));
            let started = std::time::Instant::now();
            let (cones, tan) = crate::reference::cone_set(&scene.render);
            let ideal = rgb(crate::reference::ideal_cones(
                scene,
                &cones,
                tan,
                IDEAL_CONE_RAYS,
                |_| {},
            ));
            let seconds = started.elapsed().as_secs_f64();
            // The reference's own direct and AO: the row measures the indirect light alone.
            let ideal_combined = rgb(crate::images::add(&reference.direct, &ideal.pixels));
            write_into(
                &dir.join("ideal-cones"),
                [&ref_direct, &ideal, &ideal_combined, &ref_ao],
            )?;
            let p = Path::new(name);
            let row = ReportRow {
                pipeline: "ideal cones",
                scene: name.clone(),
                seconds,
                indirect_flip: compare(&ref_indirect, p, &ideal, p)?.flip_mean,
                combined_flip: compare(&ref_combined, p, &ideal_combined, p)?.flip_mean,
                memory: None,
                leak: name
                    .contains("thin_wall")
                    .then(|| leak(&ideal.pixels, &pixel_positions(scene), 0.0, 1.0 / 64.0)),
                instability: None,
            };
            push_row(&mut md, &mut rows, row);
        }
        for pipeline in ["vct-dense", "vct-svo", "lrsm", "cprc"] {
            if scene.render.bounces > 1 && pipeline != "vct-svo" {
                // One bounce against a two-bounce reference would be a wrong row: vct-svo alone.
                continue;
            }
            progress(&format!("{name}: {pipeline}"));
            // The scene's quality preset for this pipeline (the file's explicit keys kept).
            let kind = crate::render::Pipeline::from_name(pipeline).expect("a pipeline's name");
            let (scene, _) = crate::quality::resolved(scene, kind).map_err(anyhow::Error::msg)?;
            let scene = &scene;
            let cones = ConeSettings::from(&scene.render);
            // The GPU-resident renderer's first frame (its pipelines and buffers created), and what
            // its chain holds on the GPU (vct-svo's octree uploaded into it).
            let mut resident = crate::resident::Resident::new(ctx, kind)?;
            let t = std::time::Instant::now();
            let r = resident.render(scene, &cones)?;
            let seconds = t.elapsed().as_secs_f64();
            let memory = resident.gpu_bytes().unwrap_or(0);
            write_into(
                &dir.join(pipeline),
                [&r.direct, &r.indirect, &r.combined, &r.ao],
            )?;
            let p = Path::new(name);
            let ind = compare(&ref_indirect, p, &r.indirect, p)?;
            let comb = compare(&ref_combined, p, &r.combined, p)?;
            let leak = name
                .contains("thin_wall")
                .then(|| leak(&r.indirect.pixels, &pixel_positions(scene), 0.0, 1.0 / 64.0));
            // Only where the ideal cones are this frame's reference: one bounce (an interleaved
            // frame's: its classes' whole set).
            let instability = match &mut ideal_frames {
                Some(ideal) if crate::temporal::ideal_reference_fits(&scene.render) => {
                    progress(&format!(
                        "{name}: {pipeline}: orbit ({} frames)",
                        ideal.frames
                    ));
                    let motion = ideal.motion;
                    let (reference, _) = ideal.of(scene);
                    let (m, _) =
                        crate::temporal::measure(ctx, kind, scene, motion, reference, None)?;
                    Some(m.instability)
                }
                _ => None,
            };
            let row = ReportRow {
                pipeline,
                scene: name.clone(),
                seconds,
                indirect_flip: ind.flip_mean,
                combined_flip: comb.flip_mean,
                memory: Some(memory),
                leak,
                instability,
            };
            push_row(&mut md, &mut rows, row);
        }
        let _ = writeln!(
            images,
            "\n### {name}\n\nreference ({spp} spp) | ideal cones | vct-dense | vct-svo | lrsm | cprc\n---|---|---|---|---|---\n![]({name}/reference/combined.png) | ![]({name}/ideal-cones/combined.png) | ![]({name}/vct-dense/combined.png) | ![]({name}/vct-svo/combined.png) | ![]({name}/lrsm/combined.png) | ![]({name}/cprc/combined.png)\n![]({name}/reference/indirect.png) | ![]({name}/ideal-cones/indirect.png) | ![]({name}/vct-dense/indirect.png) | ![]({name}/vct-svo/indirect.png) | ![]({name}/lrsm/indirect.png) | ![]({name}/cprc/indirect.png)\n![]({name}/reference/ao.png) | ![]({name}/ideal-cones/ao.png) | ![]({name}/vct-dense/ao.png) | ![]({name}/vct-svo/ao.png) | ![]({name}/lrsm/ao.png) | ![]({name}/cprc/ao.png)"
        );
    }
    md.push_str("\ntime: wall clock of the GPU-resident renderer's first frame (its pipelines and buffers created); memory: the bytes its frame holds on the GPU; FLIP: mean LDR-FLIP against the reference (`vxgi compare`); leak: thin_wall only. ideal cones: the scene's diffuse cone set with exact visibility and radiance (CPU, 64 rays per cone; direct and AO the reference's), what the cone tracers would score with perfect voxels. orbit instability (with `--temporal-frames`): the mean frame-to-frame change of the pipeline's indirect image beyond the ideal cones' over a camera orbit, relative to the mean indirect light (docs/temporal.md).\n");
    md.push_str(&images);
    std::fs::write(out.join("report.md"), md)
        .with_context(|| format!("writing {}", out.join("report.md").display()))?;
    Ok(rows)
}

/// Append one row to the table and the rows.
fn push_row(md: &mut String, rows: &mut Vec<ReportRow>, row: ReportRow) {
    let _ = writeln!(
        md,
        "| {} | {} | {:.2} s | {:.3} | {:.3} | {} | {} | {} |",
        row.pipeline,
        row.scene,
        row.seconds,
        row.indirect_flip,
        row.combined_flip,
        row.memory_text(),
        row.leak_text(),
        row.instability_text()
    );
    rows.push(row);
}

/// Create `dir` and write the four images into it.
fn write_into(dir: &Path, images: [&RgbImage; 4]) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    write_frame(dir, images)?;
    Ok(())
}
