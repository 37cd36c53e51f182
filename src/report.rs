//! `vxgi report`: every scene with every pipeline and with the Monte Carlo reference, compared; a table
//! (printed and written as report.md with the images side by side).
use crate::images::{compare, write_frame, RgbImage};
use crate::kernels::cone_trace::ConeSettings;
use crate::reference::{leak, pixel_positions, render_reference, ReferenceOptions};
use crate::scene::Scene;
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::Path;
use vxgi_cpu_mirror::cone_trace::pyramid_len;

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

/// GPU buffer bytes of a vct-dense frame: G-buffer (position, normal, triangle) and the four images,
/// scene buffers (BVH nodes, triangles), voxelization accumulators, the level-0 colour/normal/radiance
/// grids, the radiance pyramid and its normals.
pub fn vct_dense_memory(scene: &Scene) -> u64 {
    let px = scene.camera.width as u64 * scene.camera.height as u64;
    let tris = scene.mesh.triangles.len() as u64;
    let side = scene.render.voxels as u64;
    let voxels = side.pow(3);
    let pyramid = pyramid_len(scene.render.voxels) as u64;
    px * (16 + 16 + 4 + 16 * 3)
        + tris * (96 + 2 * 48 + 112)
        + voxels * (32 + 16 * 3 + 4)
        + pyramid * 32
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
        // They trace one plain cone set per pixel: an interleaved scene's set is not theirs.
        if scene.render.cone_interleave > 1 {
            eprintln!(
                "note: {name}: no ideal-cones row (cone_interleave = {}: the ideal cones trace the \
                 plain set of {} cones per pixel, without the interleaved classes and their resolve)",
                scene.render.cone_interleave, scene.render.cones
            );
        }
        if scene.render.bounces == 1 && scene.render.cone_interleave == 1 {
            progress(&format!("{name}: ideal cones"));
            let started = std::time::Instant::now();
            let ideal = rgb(crate::reference::ideal_cones(
                scene,
                scene.render.cones,
                scene.render.cone_half_angle.to_radians().tan(),
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
            let (r, memory) = if pipeline == "vct-dense" {
                let r = crate::render::render(ctx, scene, &cones, |_| {})?;
                (r, vct_dense_memory(scene))
            } else if pipeline == "lrsm" {
                let (r, m) = crate::render::render_lrsm(ctx, scene, &cones, |_| {})?;
                // vct-dense's buffers without the radiance pyramid, with the occlusion voxels and
                // every view's LRSM (and the one RSM alive at a time).
                let pyramid = pyramid_len(scene.render.voxels) as u64 * 32;
                (
                    r,
                    vct_dense_memory(scene) - pyramid + m.occlusion + m.rsm + m.lrsm,
                )
            } else if pipeline == "cprc" {
                let (r, stats) = crate::render::render_cprc(ctx, scene, &cones, |_| {})?;
                // vct-dense's buffers (the pyramid included) and the caches' texels, mips and
                // irradiance maps.
                let s = crate::cprc::CprcSettings::from(&scene.render);
                (r, vct_dense_memory(scene) + s.cache_bytes(stats.caches))
            } else {
                let (r, m) = crate::render::render_svo(ctx, scene, &cones, |_| {})?;
                // vct-dense's buffers with the octree (its actual allocation) for the pyramid.
                let pyramid = pyramid_len(scene.render.voxels) as u64 * 32;
                (r, vct_dense_memory(scene) - pyramid + m.bytes)
            };
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
            // Only where the ideal cones are this frame's reference: one bounce, the plain cone set.
            let instability = match &mut ideal_frames {
                Some(ideal) if crate::temporal::ideal_reference_fits(&scene.render) => {
                    progress(&format!(
                        "{name}: {pipeline}: orbit ({} frames)",
                        ideal.frames
                    ));
                    let motion = ideal.motion;
                    let (reference, _) = ideal.of(scene);
                    let (m, _) = crate::temporal::measure(ctx, kind, scene, motion, reference)?;
                    Some(m.instability)
                }
                _ => None,
            };
            let row = ReportRow {
                pipeline,
                scene: name.clone(),
                seconds: r.stages.iter().map(|s| s.1).sum(),
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
    md.push_str("\ntime: wall clock of the pipeline's stages, transfers between stages included; FLIP: mean LDR-FLIP against the reference (`vxgi compare`); leak: thin_wall only. ideal cones: the scene's diffuse cone set with exact visibility and radiance (CPU, 64 rays per cone; direct and AO the reference's), what the cone tracers would score with perfect voxels. orbit instability (with `--temporal-frames`): the mean frame-to-frame change of the pipeline's indirect image beyond the ideal cones' over a camera orbit, relative to the mean indirect light (docs/temporal.md).\n");
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
