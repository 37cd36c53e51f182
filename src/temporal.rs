//! Temporal stability: how much a pipeline's indirect image changes between consecutive frames beyond
//! what the light itself does (`vxgi temporal`).
//!
//! For frames `t = 0..T` of a motion (a slow camera orbit, the scene's instance animation, or a light
//! moving), with `P[t]` the pipeline's indirect image and `R[t]` the reference's:
//!
//! ```text
//! instability = mean over t < T-1 of mean over pixels and channels of
//!               |(P[t+1] - P[t]) - (R[t+1] - R[t])|, divided by the mean of R over all frames
//! ```
//!
//! A pipeline whose error is the same in every frame scores 0 however large that error is; flicker
//! (cone sets, cache placement or re-voxelization changing the image more than the scene changed)
//! scores what it adds. The reference is the ideal cones ([`crate::reference::ideal_cones`]: the
//! diffuse cone set the pipeline traces, with exact visibility and radiance, deterministic stratified
//! rays): what
//! the cone tracers would give with perfect voxels, so the measure is of the pipelines' own
//! frame-to-frame noise. Its own noise floor is the measure between two references with different
//! ray counts ([`reference_floor`]).
use crate::images::RgbImage;
use crate::kernels::cone_trace::ConeSettings;
use crate::render::Pipeline;
use crate::resident::Resident;
use crate::scene::{Light, Scene};
use anyhow::Result;

/// How the frames of a sequence differ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// The camera orbits its target by `degrees` per frame.
    Orbit { degrees: f32 },
    /// The scene's `[[instances]]` animation: frame `t` is the scene at frame `t`.
    Instances,
    /// Every light moves: point and spot lights by `step` (scene units) along x per frame,
    /// directional lights turn by `step` degrees per frame about the camera's up axis.
    Light { step: f32 },
}

impl Motion {
    /// The name the table prints.
    pub fn name(&self) -> String {
        match self {
            Motion::Orbit { degrees } => format!("orbit {degrees} deg/frame"),
            Motion::Instances => "instances".into(),
            Motion::Light { step } => format!("light {step}/frame"),
        }
    }

    /// Frame `t` of `scene` under this motion.
    pub fn at(&self, scene: &Scene, t: u32) -> Scene {
        match *self {
            Motion::Orbit { degrees } => scene.orbited(degrees * t as f32),
            Motion::Instances => scene.at_frame(t),
            Motion::Light { step } => {
                let mut s = scene.clone();
                let up = glam::Vec3::from(s.camera.up).normalize_or(glam::Vec3::Y);
                let turn = glam::Quat::from_axis_angle(up, (step * t as f32).to_radians());
                for l in &mut s.lights {
                    match l {
                        Light::Point { position, .. } | Light::Spot { position, .. } => {
                            position[0] += step * t as f32;
                        }
                        Light::Directional { direction, .. } => {
                            *direction = (turn * glam::Vec3::from(*direction)).to_array();
                        }
                    }
                }
                s
            }
        }
    }
}

/// The measure over two sequences of indirect images of one size: (instability, per step values).
/// Also returns the mean `|P[t+1] - P[t]|` and `|R[t+1] - R[t]|` relative to the same mean (how much each
/// changes on its own).
pub fn instability(p: &[RgbImage], r: &[RgbImage]) -> Measure {
    instability_on(p, r, None)
}

/// [`instability`], and with `persistent` (per step `t -> t + 1`, per pixel: whether the pixel sees
/// the same surface in both frames, [`persistent_pixels`]) the same measure over those pixels alone
/// ([`Measure::persistent`]): the change a pipeline adds where a pixel kept its surface (which may
/// have moved, as an instance does). Steps in which no pixel kept its surface do not count in it.
/// Where a pixel's surface changes (an edge crossing it), `|dP - dR|` is the difference of the
/// pipeline's errors on the two surfaces, an error that moves with the edge rather than flicker.
pub fn instability_on(p: &[RgbImage], r: &[RgbImage], persistent: Option<&[Vec<bool>]>) -> Measure {
    assert_eq!(p.len(), r.len(), "one pipeline frame per reference frame");
    let mean_r = r
        .iter()
        .flat_map(|f| f.pixels.iter().flatten())
        .map(|&v| v as f64)
        .sum::<f64>()
        / r.iter().map(|f| f.pixels.len() * 3).sum::<usize>().max(1) as f64;
    let scale = if mean_r > 0.0 { 1.0 / mean_r } else { 0.0 };
    let mut steps = Vec::new();
    let (mut own_p, mut own_r) = (0.0, 0.0);
    let (mut kept_sum, mut kept_share, mut kept_steps) = (0.0, 0.0, 0usize);
    for t in 0..p.len().saturating_sub(1) {
        let n = (p[t].pixels.len() * 3).max(1) as f64;
        let (mut d, mut dp, mut dr) = (0.0, 0.0, 0.0);
        let (mut dk, mut nk) = (0.0, 0usize);
        let kept = persistent.map(|m| &m[t]);
        for i in 0..p[t].pixels.len() {
            let on = kept.is_some_and(|k| k[i]);
            for c in 0..3 {
                let a = p[t + 1].pixels[i][c] as f64 - p[t].pixels[i][c] as f64;
                let b = r[t + 1].pixels[i][c] as f64 - r[t].pixels[i][c] as f64;
                d += (a - b).abs();
                dp += a.abs();
                dr += b.abs();
                if on {
                    dk += (a - b).abs();
                }
            }
            nk += on as usize;
        }
        steps.push(d / n * scale);
        own_p += dp / n * scale;
        own_r += dr / n * scale;
        if nk > 0 {
            kept_sum += dk / (nk * 3) as f64 * scale;
            kept_steps += 1;
        }
        kept_share += nk as f64 / p[t].pixels.len().max(1) as f64;
    }
    let k = steps.len().max(1) as f64;
    let error = p
        .iter()
        .zip(r)
        .map(|(a, b)| {
            let n = (a.pixels.len() * 3).max(1) as f64;
            let sum: f64 = a
                .pixels
                .iter()
                .zip(&b.pixels)
                .flat_map(|(x, y)| (0..3).map(move |c| (x[c] as f64 - y[c] as f64).abs()))
                .sum();
            sum / n * scale
        })
        .sum::<f64>()
        / p.len().max(1) as f64;
    Measure {
        instability: steps.iter().sum::<f64>() / k,
        error,
        steps,
        change: own_p / k,
        reference_change: own_r / k,
        persistent: persistent.map(|_| Persistent {
            instability: kept_sum / kept_steps.max(1) as f64,
            share: kept_share / k,
        }),
    }
}

/// [`instability_on`]'s measure over the pixels that keep their surface from one frame to the next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Persistent {
    /// Mean over steps of the mean `|dP - dR|` over those pixels, relative to R's mean (the same
    /// scale as [`Measure::instability`]).
    pub instability: f64,
    /// The mean fraction of pixels that keep their surface.
    pub share: f64,
}

/// Per step `t -> t + 1` of `frames` frames of `motion`, per pixel: whether the pixel's centre sees
/// the same surface in both frames (the gbuffer mirror's primary hit): the same triangle, or
/// triangles of one material in one plane (normals within 0.8 degree, plane offsets within 1e-4 of
/// the scene's extent: a wall split in two triangles is one surface). A pixel that sees nothing in
/// either frame does not count.
pub fn persistent_pixels(scene: &Scene, motion: Motion, frames: u32) -> Vec<Vec<bool>> {
    use rayon::prelude::*;
    use vxgi_cpu_mirror::gbuffer::shade_pixel;
    type Seen = Option<(u32, u32, glam::Vec3, f32)>;
    let hits: Vec<(Vec<Seen>, f32)> = (0..frames)
        .into_par_iter()
        .map(|t| {
            let data = crate::trace::SceneData::new(&motion.at(scene, t));
            let (w, h) = (data.width(), data.height());
            let extent = (data.bounds.1 - data.bounds.0).length().max(1e-12);
            let seen = (0..w * h)
                .map(|i| {
                    let px = shade_pixel(&data.frame, &data.nodes, &data.triangles, i % w, i / w);
                    let tri = data.triangles.get(px.triangle as usize)?;
                    let (a, b, c) = (
                        glam::Vec3::from_slice(&tri.a[..3]),
                        glam::Vec3::from_slice(&tri.b[..3]),
                        glam::Vec3::from_slice(&tri.c[..3]),
                    );
                    let n = (b - a).cross(c - a).normalize_or_zero();
                    Some((px.triangle, tri.material(), n, n.dot(a)))
                })
                .collect();
            (seen, extent)
        })
        .collect();
    hits.windows(2)
        .map(|f| {
            let tol = 1e-4 * f[0].1.max(f[1].1);
            f[0].0
                .iter()
                .zip(&f[1].0)
                .map(|(a, b)| match (a, b) {
                    (Some(a), Some(b)) => {
                        a.0 == b.0
                            || (a.1 == b.1 && a.2.dot(b.2) > 0.9999 && (a.3 - b.3).abs() <= tol)
                    }
                    _ => false,
                })
                .collect()
        })
        .collect()
}

/// [`instability`]'s result.
#[derive(Clone, Debug, PartialEq)]
pub struct Measure {
    pub instability: f64,
    /// The mean over frames of the mean `|P[t] - R[t]|`, relative to R's mean: each frame's own
    /// error against the reference, so that a change that steadies frames at the cost of their
    /// accuracy shows.
    pub error: f64,
    /// Per step `t -> t + 1`.
    pub steps: Vec<f64>,
    /// Mean `|P[t+1] - P[t]|` and `|R[t+1] - R[t]|`, relative to R's mean.
    pub change: f64,
    pub reference_change: f64,
    /// The measure over the pixels that keep their surface (where a mask was given).
    pub persistent: Option<Persistent>,
}

/// The reference's indirect images of `frames` frames of `motion` (ideal cones with `rays` rays per
/// cone; frames in parallel).
pub fn reference_frames(scene: &Scene, motion: Motion, frames: u32, rays: u32) -> Vec<RgbImage> {
    use rayon::prelude::*;
    (0..frames)
        .into_par_iter()
        .map(|t| {
            let s = motion.at(scene, t);
            let (cones, tan) = crate::reference::cone_set(&s.render);
            let px = crate::reference::ideal_cones(&s, &cones, tan, rays, |_| {});
            RgbImage::new(s.camera.width, s.camera.height, px)
        })
        .collect()
}

/// The reference's own floor: the measure of the reference at `rays` against the reference at four
/// times as many rays over the same frames. Below the pipelines' values, the reference does not
/// decide their ranking.
pub fn reference_floor(reference: &[RgbImage], scene: &Scene, motion: Motion, rays: u32) -> f64 {
    let finer = reference_frames(scene, motion, reference.len() as u32, rays * 4);
    instability(reference, &finer).instability
}

/// Whether the ideal cones are the own reference of a frame with these settings, as `vxgi report`
/// and `vxgi bench` measure against them: one bounce (they gather one). An interleaved frame's
/// reference is the ideal cones of its classes' whole set ([`crate::reference::cone_set`]).
pub fn ideal_reference_fits(render: &crate::scene::RenderSettings) -> bool {
    render.bounces == 1
}

/// A camera orbit over which `vxgi report` and `vxgi bench` measure each frame's temporal
/// instability (the measure of this module).
#[derive(Clone, Copy, Debug)]
pub struct Orbit {
    pub frames: u32,
    pub degrees: f32,
    /// Rays per cone of the ideal-cone reference frames (its own floor falls about 2x per 4x rays:
    /// about 0.005 at 1024 on the Cornell box, docs/temporal.md).
    pub rays: u32,
}

impl Orbit {
    /// Its reference frames (none computed yet).
    pub fn ideal_frames(&self) -> IdealFrames {
        IdealFrames::new(
            Motion::Orbit {
                degrees: self.degrees,
            },
            self.frames,
            self.rays,
        )
    }
}

/// The ideal-cone reference frames of one motion, computed once per cone set (cone count, aperture
/// and interleave: a quality preset may narrow a pipeline's set) and reused by every pipeline
/// tracing it.
pub struct IdealFrames {
    pub motion: Motion,
    pub frames: u32,
    pub rays: u32,
    sets: Vec<((u32, u32, u32), Vec<RgbImage>)>,
}

impl IdealFrames {
    pub fn new(motion: Motion, frames: u32, rays: u32) -> Self {
        Self {
            motion,
            frames,
            rays,
            sets: Vec::new(),
        }
    }

    /// The reference frames for `scene`'s cone set (as a pipeline resolved it), and whether they
    /// were computed by this call.
    pub fn of(&mut self, scene: &Scene) -> (&[RgbImage], bool) {
        let r = &scene.render;
        let set = (r.cones, r.cone_half_angle.to_bits(), r.cone_interleave);
        let new = !self.sets.iter().any(|(k, _)| *k == set);
        if new {
            let frames = reference_frames(scene, self.motion, self.frames, self.rays);
            self.sets.push((set, frames));
        }
        let frames = &self
            .sets
            .iter()
            .find(|(k, _)| *k == set)
            .expect("computed above")
            .1;
        (frames, new)
    }
}

/// `pipeline`'s instability over the frames of `motion` against `reference` (the ideal cones of
/// those frames, one per frame), with its frames as [`pipeline_frames`] draws them; over the kept
/// surfaces too where `kept` ([`persistent_pixels`] of the same frames) is given.
pub fn measure(
    ctx: &crate::harness::GpuContext,
    pipeline: Pipeline,
    scene: &Scene,
    motion: Motion,
    reference: &[RgbImage],
    kept: Option<&[Vec<bool>]>,
) -> Result<(Measure, Vec<crate::render::Rendered>)> {
    let got = pipeline_frames(ctx, pipeline, scene, motion, reference.len() as u32)?;
    let indirect: Vec<_> = got.iter().map(|f| f.indirect.clone()).collect();
    Ok((instability_on(&indirect, reference, kept), got))
}

/// `pipeline`'s frames of the sequence, one GPU-resident renderer drawing them all in order: the
/// frames a viewer would show.
pub fn pipeline_frames(
    ctx: &crate::harness::GpuContext,
    pipeline: Pipeline,
    scene: &Scene,
    motion: Motion,
    frames: u32,
) -> Result<Vec<crate::render::Rendered>> {
    let cones = ConeSettings::from(&scene.render);
    let mut out = Vec::new();
    let mut r = Resident::new(ctx, pipeline)?;
    for t in 0..frames {
        out.push(r.render(&motion.at(scene, t), &cones)?);
    }
    Ok(out)
}

/// One row of the table.
#[derive(Clone, Debug)]
pub struct Row {
    pub pipeline: &'static str,
    pub motion: String,
    pub measure: Measure,
    /// Combined FLIP of frame 0 against the path-traced reference.
    pub combined_flip: f32,
    /// The median of the frames after the first of their stages' times, ms ([`later_frames_ms`]).
    pub frame_ms: f64,
}

/// The median over the frames after the first (the first builds what the others keep) of each
/// frame's stage times summed, in ms: GPU time where the renderer had timestamp queries. 0 for a
/// sequence of one frame.
pub fn later_frames_ms(frames: &[crate::render::Rendered]) -> f64 {
    let mut ms: Vec<f64> = frames
        .iter()
        .skip(1)
        .map(|f| f.stages.iter().map(|(_, s)| s).sum::<f64>() * 1e3)
        .collect();
    if ms.is_empty() {
        return 0.0;
    }
    ms.sort_by(f64::total_cmp);
    ms[ms.len() / 2]
}

/// The per-step instability of every row, one line each (`temporal.svg`).
pub fn plot(path: &std::path::Path, rows: &[Row]) -> Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (800, 500)).into_drawing_area();
    let err = |e: DrawingAreaErrorKind<_>| anyhow::anyhow!("plotting {}: {e:?}", path.display());
    root.fill(&WHITE).map_err(err)?;
    let steps = rows
        .iter()
        .map(|r| r.measure.steps.len())
        .max()
        .unwrap_or(1)
        .max(1);
    let top = rows
        .iter()
        .flat_map(|r| r.measure.steps.iter().copied())
        .fold(1e-6, f64::max)
        * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption("frame-to-frame instability", ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..steps as f64, 0.0..top)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("step (frame t to t + 1)")
        .y_desc("|dP - dR| / mean R")
        .draw()
        .map_err(err)?;
    for (k, r) in rows.iter().enumerate() {
        let colour = Palette99::pick(k).to_rgba();
        let points: Vec<(f64, f64)> = r
            .measure
            .steps
            .iter()
            .enumerate()
            .map(|(t, &v)| (t as f64 + 0.5, v))
            .collect();
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(2)))
            .map_err(err)?
            .label(format!("{} ({})", r.pipeline, r.motion))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(v: &[f32]) -> RgbImage {
        RgbImage::new(v.len() as u32, 1, v.iter().map(|&x| [x; 3]).collect())
    }

    #[test]
    fn a_constant_error_is_stable_and_added_change_is_measured() {
        let r = [img(&[1.0, 2.0]), img(&[1.5, 2.5]), img(&[2.0, 3.0])];
        // The same change as the reference, offset by a constant error: 0.
        let p: Vec<_> = r
            .iter()
            .map(|f| img(&f.pixels.iter().map(|p| p[0] + 0.3).collect::<Vec<_>>()))
            .collect();
        let m = instability(&p, &r);
        assert!(m.instability.abs() < 1e-12, "{m:?}");
        // One pixel 0.2 too bright in frame 1 only: off by 0.2 in both steps on one pixel of two,
        // 0.1 on average, over mean R = 2: 0.05.
        let q = [img(&[1.0, 2.0]), img(&[1.7, 2.5]), img(&[2.0, 3.0])];
        let m = instability(&q, &r);
        assert!((m.instability - 0.05).abs() < 1e-6, "{m:?}");
        assert_eq!(m.steps.len(), 2);
        assert!((m.reference_change - 0.25).abs() < 1e-6, "{m:?}");
        assert_eq!(m.persistent, None);
        // The same, with pixel 0 changing surface in step 0 and both kept in step 1: step 0 counts
        // pixel 1 alone (off by 0), step 1 both (0.1 on average over mean R = 2: 0.05); 0.025.
        let kept = [vec![false, true], vec![true, true]];
        let m = instability_on(&q, &r, Some(&kept));
        let k = m.persistent.unwrap();
        assert!((k.instability - 0.025).abs() < 1e-6, "{m:?}");
        assert!((k.share - 0.75).abs() < 1e-12, "{m:?}");
        assert!(
            (m.instability - 0.05).abs() < 1e-6,
            "the mask changes only its own measure"
        );
    }

    #[test]
    fn a_still_scene_keeps_every_seen_pixel_and_an_orbit_uncovers_some() {
        let mut scene = Scene::cornell_box();
        scene.camera.width = 24;
        scene.camera.height = 24;
        let still = persistent_pixels(&scene, Motion::Orbit { degrees: 0.0 }, 2);
        let seen = crate::reference::pixel_positions(&scene)
            .iter()
            .filter(|p| p[3] >= 0.0)
            .count();
        assert_eq!(still[0].iter().filter(|&&k| k).count(), seen);
        let moved = persistent_pixels(&scene, Motion::Orbit { degrees: 10.0 }, 3);
        assert_eq!(moved.len(), 2);
        for step in &moved {
            let kept = step.iter().filter(|&&k| k).count();
            assert!(kept > seen / 2 && kept < seen, "{kept} of {seen}");
        }
    }
}
