//! The bisection switch (DESIGN.md section 3, after Vello's CPU/GPU stage switch): a frame whose
//! first stages run on the scalar mirrors and the rest on the GPU, each GPU stage fed what the
//! mirrors produced (the declaration's steps, [`crate::pipeline::host`]). `vxgi bisect` renders the
//! frame at every split and compares each with the all-mirror frame: the first split whose image
//! departs names the kernel to look at, on the real scene rather than on generated cases.
use crate::harness::GpuContext;
use crate::kernels::cone_trace::ConeSettings;
use crate::pipeline::Split;
use crate::render::{Pipeline, Rendered};
use crate::scene::Scene;
use anyhow::{Context, Result};

/// The stages of `pipeline`'s frame for `scene` at which bisect splits, in order: `render_split(..,
/// k)` runs the first `k` on the mirrors. Its declaration's stages that split ([`Split`]) and that
/// the frame's plan lists (vct-svo: photons or voxel_light, directional values and lobes only where
/// they run).
pub fn stages(
    pipeline: Pipeline,
    scene: &Scene,
    cones: &ConeSettings,
) -> Result<Vec<&'static str>> {
    match pipeline {
        Pipeline::VctSvo => anyhow::ensure!(
            scene.render.bounces == 1,
            "bisect follows one bounce (bounces = {})",
            scene.render.bounces
        ),
        Pipeline::Lrsm => anyhow::ensure!(
            scene.render.shadow_cone_angle == 0.0,
            "bisect follows lrsm with exact shadow rays (shadow_cone_angle = {}; set it to 0)",
            scene.render.shadow_cone_angle
        ),
        _ => {}
    }
    let plan = pipeline.plan(scene, cones, false);
    Ok(pipeline
        .decl()
        .stages
        .iter()
        .filter(|s| match s.split {
            Split::Always => plan.passes.iter().any(|p| p.stage == s.name),
            Split::WhenRun => plan.runs(s.name),
            Split::Never => false,
        })
        .map(|s| s.name)
        .collect())
}

/// The split that runs the mirrors up to and including `stage`, or an error naming the stages.
pub fn split_after(stages: &[&str], stage: &str) -> Result<usize> {
    stages
        .iter()
        .position(|s| *s == stage)
        .map(|k| k + 1)
        .with_context(|| {
            format!(
                "no stage `{stage}` in this frame; stages: {}",
                stages.join(", ")
            )
        })
}

/// `pipeline`'s frame with its first `split` [`stages`] on the mirrors and the rest on the GPU (0: all
/// GPU, stage by stage; all: all mirror): its declaration's steps ([`crate::pipeline::host`]).
/// The reasons of `plan`'s passes that run say which side ran each (`mirror:` / `GPU:`). No reuse, no chain, every
/// level built: every split computes the same quantities. A scene with instances is voxelized as
/// its flattened mesh (the per-instance hierarchies of vct-dense and cprc frames are not split).
pub fn render_split(
    ctx: &GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    pipeline: Pipeline,
    split: usize,
    progress: impl Fn(&str),
) -> Result<Rendered> {
    let order = stages(pipeline, scene, cones)?;
    anyhow::ensure!(
        split <= order.len(),
        "split {split} past the {} stages",
        order.len()
    );
    let on_mirror = |stage: &str| order[..split].contains(&stage);
    let (mut r, _) = crate::render::supersampled(scene, pipeline, |s| {
        crate::pipeline::host::frame(pipeline.decl(), Some(ctx), s, cones, &on_mirror, &progress)
    })?;
    // A stage that is no split point runs on the side of the split point before it (its step is
    // that stage's, or follows it).
    let mut mirror = true;
    for p in &mut r.plan.passes {
        if order.contains(&p.stage) {
            mirror = on_mirror(p.stage);
        }
        if p.runs {
            let side = if mirror { "mirror" } else { "GPU" };
            p.why = format!("{side}: {}", p.why);
        }
    }
    Ok(r)
}

/// One row of `vxgi bisect`: the split and how far its images are from the all-mirror frame.
#[derive(Clone, Debug)]
pub struct SplitRow {
    /// Stages on the mirrors: the first `split` of the frame's [`stages`].
    pub split: usize,
    /// (image, mean FLIP vs the all-mirror image, largest absolute channel difference, pixels whose
    /// largest channel difference is above 1e-3 of the image's largest value).
    pub images: Vec<(&'static str, f32, f32, usize)>,
    /// The split that runs the camera's G-buffer on the GPU: where its triangle picks differ from
    /// the mirror's ([`gbuffer_ties`]).
    pub gbuffer_ties: Option<GbufferTies>,
}

/// The camera G-buffer's triangle picks on the GPU against the mirror's, over a frame's samples.
#[derive(Clone, Debug, PartialEq)]
pub struct GbufferTies {
    /// Samples where the GPU picked another triangle than the mirror and rounding may pick either
    /// (a ray on a shared edge, equal depths): gbuffer's verification accepts these.
    pub accepted: usize,
    /// Samples where the picks differ and rounding cannot explain it.
    pub unexplained: usize,
    pub samples: usize,
    /// The first of gbuffer's outputs outside its verification's bound on this frame (its report's
    /// first line); `None` where every output is within it.
    pub failure: Option<String>,
}

/// The camera's G-buffer of `scene`'s frame (its samples where it supersamples) on the GPU, checked
/// as `vxgi verify` checks gbuffer (every output within its bound, a differing triangle pick only
/// where rounding may make it), and its triangle picks counted against the mirror's.
pub fn gbuffer_ties(ctx: &GpuContext, scene: &Scene) -> Result<GbufferTies> {
    use crate::kernels::gbuffer;
    let samples = if scene.render.supersample > 1 {
        scene.supersampled().map_err(anyhow::Error::msg)?
    } else {
        scene.clone()
    };
    let case = gbuffer::case_for(&crate::trace::SceneData::new(&samples), "bisect".into(), 0);
    let shader = gbuffer::DECL.shader()?;
    let out = crate::harness::run::run(
        ctx,
        &shader,
        gbuffer::DECL.name,
        &case.resources,
        &case.passes,
        &["gb_triangle"],
    )?;
    let gpu = out.buffer("gb_triangle").as_u32();
    let mirror = gbuffer::mirror_gbuffer(&case.resources, gpu);
    let (checks, ..) =
        crate::harness::kernel::verify_case(ctx, &shader, &gbuffer::Gbuffer, &case, None)?;
    let failure = (checks.iter().find(|c| !c.passed()))
        .map(|c| c.report().lines().next().unwrap_or_default().to_string());
    Ok(GbufferTies {
        accepted: mirror.accepted_differences,
        unexplained: mirror
            .triangle
            .iter()
            .zip(gpu)
            .filter(|(m, g)| m != g)
            .count(),
        samples: gpu.len(),
        failure,
    })
}

/// Render every split (all GPU .. all mirror) and compare each with the all-mirror frame.
pub fn bisect(
    ctx: &GpuContext,
    scene: &Scene,
    cones: &ConeSettings,
    pipeline: Pipeline,
    progress: impl Fn(&str),
) -> Result<Vec<SplitRow>> {
    let order = stages(pipeline, scene, cones)?;
    let mirror = render_split(ctx, scene, cones, pipeline, order.len(), &progress)?;
    let mut rows = Vec::new();
    for split in 0..order.len() {
        let r = render_split(ctx, scene, cones, pipeline, split, &progress)?;
        let mut images = Vec::new();
        for (name, a, b) in [
            ("direct", &mirror.direct, &r.direct),
            ("indirect", &mirror.indirect, &r.indirect),
            ("ao", &mirror.ao, &r.ao),
        ] {
            // The images are in memory: name them by frame and image in errors.
            let reference = std::path::PathBuf::from(format!("all-mirror frame, {name} image"));
            let split_name = std::path::PathBuf::from(format!(
                "frame with the mirrors up to stage {split} ({}), {name} image",
                order.get(split).copied().unwrap_or("none")
            ));
            let c = crate::images::compare(a, &reference, b, &split_name)?;
            let diff: Vec<f32> = a
                .pixels
                .iter()
                .zip(&b.pixels)
                .map(|(x, y)| (0..3).map(|k| (x[k] - y[k]).abs()).fold(0.0f32, f32::max))
                .collect();
            let top = a
                .pixels
                .iter()
                .flatten()
                .fold(0.0f32, |m, v| m.max(v.abs()));
            let off = diff.iter().filter(|&&d| d > 1e-3 * top).count();
            images.push((
                name,
                c.flip_mean,
                diff.iter().fold(0.0f32, |m, &d| m.max(d)),
                off,
            ));
        }
        let gbuffer_ties = match order.get(split) {
            Some(&"gbuffer") => Some(gbuffer_ties(ctx, scene)?),
            _ => None,
        };
        rows.push(SplitRow {
            split,
            images,
            gbuffer_ties,
        });
    }
    Ok(rows)
}

/// `vxgi bisect`'s table for a frame of `stages`.
pub fn table(stages: &[&str], rows: &[SplitRow]) -> String {
    let mut s = String::from(
        "| mirror up to | GPU from | direct: FLIP, max diff, pixels off | indirect | ao |\n|---|---|---|---|---|\n",
    );
    for r in rows {
        let (m, g) = (
            r.split.checked_sub(1).map_or("-", |k| stages[k]),
            stages.get(r.split).copied().unwrap_or("-"),
        );
        let cells: Vec<String> = r
            .images
            .iter()
            .map(|(_, f, d, n)| format!("{f:.5}, {d:.2e}, {n}"))
            .collect();
        s += &format!("| {m} | {g} | {} |\n", cells.join(" | "));
    }
    // The bisection's answer: the latest GPU stage whose split still departs from the mirrors. A
    // split runs the GPU from its stage on, so the departure starts at the first GPU stage of the
    // last departing row whose successor agrees.
    let departs = |r: &SplitRow| r.images.iter().any(|i| i.3 > 0);
    match rows.iter().rposition(departs) {
        Some(k) => {
            s += &format!(
                "first stage whose GPU result departs from its mirror (pixels off by > 1e-3 of the image's largest value): {}",
                stages[rows[k].split]
            );
            // A departure at the G-buffer that its verification allows: rays on a shared edge or at
            // equal depths, where rounding may pick either triangle (samples at thirds of a pixel
            // meet the Cornell box's edges).
            match &rows[k].gbuffer_ties {
                Some(t) if t.failure.is_none() => {
                    s += &format!(
                        ", within its verification's bounds on this frame: on {} of {} samples the GPU picked another triangle than the mirror where rounding may pick either (a shared edge, equal depths); every later stage agrees with its mirror from its inputs\n",
                        t.accepted, t.samples
                    )
                }
                Some(t) => {
                    s += &format!(
                        " (its verification fails on this frame: {}; {} of {} samples' triangle picks differ where rounding cannot explain it)\n",
                        t.failure.as_deref().unwrap_or_default(),
                        t.unexplained,
                        t.samples
                    )
                }
                _ => s += "\n",
            }
        }
        None => s +=
            "every split agrees with the all-mirror frame to 1e-3 of each image's largest value\n",
    }
    s
}
