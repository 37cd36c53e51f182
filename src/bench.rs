//! `vxgi bench`: run time against error. A sweep over `[render]` settings of the vct-dense pipeline
//! (voxel resolution, diffuse cone count and aperture, mip clamp), each configuration rendered on the
//! GPU and compared with one Monte Carlo reference of the same scene (relative MSE and mean FLIP of
//! indirect and combined, as `vxgi compare` defines them). Written into the output folder: `bench.csv`,
//! `bench.md` (table, Pareto-optimal rows marked, and the planner's reuse rule off vs on) and
//! `bench.svg` (time vs combined FLIP, Pareto front drawn).
use crate::images::{compare, RgbImage};
use crate::kernels::cone_trace::ConeSettings;
use crate::reference::{render_reference, ReferenceOptions};
use crate::scene::{RenderSettings, Scene};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::Path;

use crate::render::Pipeline;

/// One configuration's result.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchRow {
    pub voxels: u32,
    pub cones: u32,
    pub cone_half_angle: f32,
    pub mip_clamp: f32,
    pub cone_step: f32,
    /// Every cone tracer: sampled level relative to the paper's, and correlated coverage.
    pub cone_level_bias: f32,
    pub coverage_correlation: f32,
    /// lrsm: RSM side per light view and layers (depth x <n.l>, "area-weighted" with
    /// `lrsm_area_weights`; "lit cells" with `lrsm_lit_cells`, which builds no layers); swept for
    /// that pipeline only.
    pub rsm_side: u32,
    pub lrsm_layers: String,
    /// cprc: cache side in texels, distribution tile, and the caches the frame placed (0 elsewhere).
    pub cache_resolution: u32,
    pub cache_tile: u32,
    pub caches: usize,
    /// cprc: irradiance map side, gathering radius in tiles and the gather's angle term.
    pub irradiance_resolution: u32,
    pub gather_radius: f32,
    pub gather_angle: bool,
    /// vct-svo: directional values above the leaves, and the photon map side (0: voxel_light).
    pub anisotropic_voxels: bool,
    pub photon_map: u32,
    /// vct-svo: voxel shading with Gaussian lobes.
    pub voxel_lobes: bool,
    /// vct-dense and cprc: the depth-ordered blend instead of the trilinear one.
    pub depth_ordered_blend: bool,
    /// Every pipeline: samples per pixel side (`supersample`).
    pub supersample: u32,
    /// The per-pixel cone tracers: side of the interleaved cone sets (`cone_interleave`; 1 = off).
    pub cone_interleave: u32,
    /// Seconds of the whole frame: the sum of `stage_seconds`.
    pub seconds: f64,
    /// Seconds per stage of a fresh GPU-resident renderer's frame, in [`Pipeline::stages`] order (0
    /// where the plan skipped the stage): GPU time by timestamp queries (wall clock where the GPU
    /// has none), vct-svo's octree build outside the chain by wall clock.
    #[serde(skip)]
    pub stage_seconds: Vec<f64>,
    pub indirect_rel_mse: f64,
    pub indirect_flip: f32,
    pub combined_rel_mse: f64,
    pub combined_flip: f32,
    /// No other configuration is both faster and more accurate (combined FLIP).
    pub pareto: bool,
    /// Temporal instability over the bench's orbit ([`crate::temporal::Orbit`]; `None`: not
    /// measured).
    pub orbit_instability: Option<f64>,
}

/// The configurations of a sweep around `base` (its other keys, e.g. AO, kept). Full: voxels
/// {32, 64, 128} x cones {1, 5, 9, 16} x half-angle {20, 30, 45} x mip clamp {0, 2} x cone step
/// {0.5, 1} x blend {trilinear, depth-ordered} = 288 (16 cones: `diffuse_cones`' spiral, the others
/// its ring), level bias and coverage correlation at `base`'s; plus the narrow spiral sets at 128^3
/// (32 cones of 18 deg, 64 of 12 deg; clamp 2, step 0.5, trilinear) with level bias / coverage
/// correlation 0 / 0, -1 / 0 and -1 / 1 = 6 (docs/accuracy/vct-dense.md: where those options pay); plus 5
/// interleaved narrow sets (2.5 deg, bias -1.25: 16 and 8 cones of 8 x 8 classes at 1 and 2 x 2
/// samples, 64 of 4 x 4 at 1); plus `base` at 256^3 = 300. Quick (for
/// CI): voxels {32, 64} x cones {1, 5} at 30 degrees, clamp 2, step 0.5 = 4.
/// lrsm sweeps its own knobs instead ([`lrsm_sweep`]).
pub fn sweep(base: &RenderSettings, quick: bool, pipeline: Pipeline) -> Vec<RenderSettings> {
    if pipeline == Pipeline::Lrsm {
        return lrsm_sweep(base, quick);
    }
    if pipeline == Pipeline::Cprc {
        return cprc_sweep(base, quick);
    }
    if pipeline == Pipeline::VctSvo {
        return svo_sweep(base, quick);
    }
    type Axes<'a> = (
        &'a [u32],
        &'a [u32],
        &'a [f32],
        &'a [f32],
        &'a [f32],
        &'a [bool],
    );
    let (voxels, cones, angles, clamps, steps, blends): Axes = if quick {
        (&[32, 64], &[1, 5], &[30.0], &[2.0], &[0.5], &[false])
    } else {
        (
            &[32, 64, 128],
            &[1, 5, 9, 16],
            &[20.0, 30.0, 45.0],
            &[0.0, 2.0],
            &[0.5, 1.0],
            &[false, true],
        )
    };
    let mut out = Vec::new();
    for &v in voxels {
        for &c in cones {
            for &a in angles {
                for &m in clamps {
                    for &s in steps {
                        for &b in blends {
                            out.push(RenderSettings {
                                voxels: v,
                                cones: c,
                                cone_half_angle: a,
                                mip_clamp: m,
                                cone_step: s,
                                depth_ordered_blend: b,
                                ..base.clone()
                            });
                        }
                    }
                }
            }
        }
    }
    if !quick {
        // Interleaved narrow cones (docs/accuracy/vct-dense.md, "Interleaved cone sets"): 2.5 deg, level bias -1.25, the
        // scene file's 16 cones from 8 x 8 classes and half of them, each at 1 and 2 x 2 samples;
        // and 64 cones from 4 x 4 classes at 1 sample.
        for (c, n, supersample) in [(16, 8, 2), (8, 8, 2), (16, 8, 1), (8, 8, 1), (64, 4, 1)] {
            out.push(RenderSettings {
                voxels: 128,
                cones: c,
                cone_half_angle: 2.5,
                mip_clamp: 2.0,
                cone_step: 0.5,
                cone_level_bias: -1.25,
                coverage_correlation: 0.0,
                depth_ordered_blend: false,
                cone_interleave: n,
                supersample,
                ..base.clone()
            });
        }
        for (c, a) in [(32, 18.0), (64, 12.0)] {
            for (bias, corr) in [(0.0, 0.0), (-1.0, 0.0), (-1.0, 1.0)] {
                out.push(RenderSettings {
                    voxels: 128,
                    cones: c,
                    cone_half_angle: a,
                    mip_clamp: 2.0,
                    cone_step: 0.5,
                    cone_level_bias: bias,
                    coverage_correlation: corr,
                    depth_ordered_blend: false,
                    ..base.clone()
                });
            }
        }
        out.push(at_256(base));
    }
    out
}

/// `base` at 256^3 voxels (past one storage binding on lavapipe: docs/scale.md), its depth-ordered
/// blend off (read from one binding).
fn at_256(base: &RenderSettings) -> RenderSettings {
    RenderSettings {
        voxels: 256,
        depth_ordered_blend: false,
        ..base.clone()
    }
}

/// vct-svo's sweep: voxels {32, 64, 128} x cones {1, 5} x anisotropic voxels {off, on} x light
/// injection {voxel_light, photons 128^2, photons 256^2} = 36, plus Gaussian lobes on the defaults'
/// octree (anisotropic, photons 256^2) at each voxels x cones = 42 (half-angle, clamp, step at
/// `base`'s), plus `base` at 256^3 = 43. Quick: 32^3, 5 cones, {isotropic, anisotropic} x {voxel_light, photons 256^2} = 4.
pub fn svo_sweep(base: &RenderSettings, quick: bool) -> Vec<RenderSettings> {
    let (voxels, cones, maps): (&[u32], &[u32], &[u32]) = if quick {
        (&[32], &[5], &[0, 256])
    } else {
        (&[32, 64, 128], &[1, 5], &[0, 128, 256])
    };
    let mut out = Vec::new();
    for &v in voxels {
        for &c in cones {
            for aniso in [false, true] {
                for &m in maps {
                    out.push(RenderSettings {
                        voxels: v,
                        cones: c,
                        anisotropic_voxels: aniso,
                        photon_map: m,
                        voxel_lobes: false,
                        ..base.clone()
                    });
                }
            }
            if !quick {
                out.push(RenderSettings {
                    voxels: v,
                    cones: c,
                    anisotropic_voxels: true,
                    photon_map: 256,
                    voxel_lobes: true,
                    ..base.clone()
                });
            }
        }
    }
    if !quick {
        out.push(at_256(base));
    }
    out
}

/// lrsm's sweep: voxels {32, 64, 128} x cones {1, `base`'s (at least 2)} x RSM side {64, 128, 256} x
/// layers {1 x 1, 2 x 2, 3 x 2} = 54 (the cone angle, interleave, clamp and step at `base`'s); plus
/// `base` at voxels 256 and 512 (its occlusion voxels are bits: the papers' 512^3 fits) and `base`
/// with `lrsm_lit_cells` the other way (the lit cells against the LRSMs) = 57. With the lit cells
/// (every preset's) the layers are not built, so they are not swept: 18 + 3 = 21. Quick: 32^3,
/// `base`'s cones, RSM {32, 64} x layers {1 x 1, 2 x 2} = 4 (with the lit cells: RSM {32, 64} x
/// {the lit cells, 2 x 2 LRSMs} = 4).
pub fn lrsm_sweep(base: &RenderSettings, quick: bool) -> Vec<RenderSettings> {
    type Axes<'a> = (&'a [u32], &'a [u32], &'a [u32], &'a [(u32, u32)]);
    let own = [base.cones];
    let both = [1, base.cones.max(2)];
    let base_layers = [(base.lrsm_depth_splits, base.lrsm_normal_splits)];
    let (voxels, cones, sides, layers): Axes = if quick {
        (&[32], &own, &[32, 64], &[(0, 0), (1, 1)])
    } else {
        (
            &[32, 64, 128],
            &both,
            &[64, 128, 256],
            &[(0, 0), (1, 1), (2, 1)],
        )
    };
    if quick && base.lrsm_lit_cells {
        let mut out = Vec::new();
        for &r in sides {
            out.push(RenderSettings {
                voxels: 32,
                rsm_side: r,
                ..base.clone()
            });
            out.push(RenderSettings {
                voxels: 32,
                rsm_side: r,
                lrsm_lit_cells: false,
                lrsm_depth_splits: 1,
                lrsm_normal_splits: 1,
                ..base.clone()
            });
        }
        return out;
    }
    let layers = if base.lrsm_lit_cells {
        &base_layers[..]
    } else {
        layers
    };
    let mut out = Vec::new();
    for &v in voxels {
        for &c in cones {
            for &r in sides {
                for &(d, n) in layers {
                    out.push(RenderSettings {
                        voxels: v,
                        cones: c,
                        rsm_side: r,
                        lrsm_depth_splits: d,
                        lrsm_normal_splits: n,
                        ..base.clone()
                    });
                }
            }
        }
    }
    if !quick {
        for v in [256, 512] {
            out.push(RenderSettings {
                voxels: v,
                ..base.clone()
            });
        }
        out.push(RenderSettings {
            lrsm_lit_cells: !base.lrsm_lit_cells,
            ..base.clone()
        });
    }
    out
}

/// cprc's sweep, the paper's Fig. 5 trade-off: cache tile {4, 8, 16} pixels (the cache count follows:
/// about 1.7 caches per tile at 256x256 in the Cornell box) x cache resolution {16, 32} = 6, the
/// voxels and cones at `base`'s; plus the fine caches of scenes/cornell_box_fine_caches.toml (32^2
/// texels, 4^2 irradiance, radius 1.5 tiles, level bias -1.25, mip clamp 1.5) at tile {8, 4} x
/// samples per pixel {1, 2} = 4 (docs/accuracy/cprc.md), `base` at 256^3 and `base` without the
/// gather's angle term (CPRC's own weights) = 12. Quick: tile {8, 16} x resolution {8, 16} = 4.
pub fn cprc_sweep(base: &RenderSettings, quick: bool) -> Vec<RenderSettings> {
    let (tiles, res): (&[u32], &[u32]) = if quick {
        (&[8, 16], &[8, 16])
    } else {
        (&[4, 8, 16], &[16, 32])
    };
    let mut out = Vec::new();
    for &t in tiles {
        for &r in res {
            out.push(RenderSettings {
                cache_tile: t,
                cache_resolution: r,
                ..base.clone()
            });
        }
    }
    if !quick {
        for t in [8, 4] {
            for supersample in [1, 2] {
                out.push(RenderSettings {
                    cache_tile: t,
                    cache_resolution: 32,
                    irradiance_resolution: 4,
                    gather_radius: 1.5,
                    cone_level_bias: -1.25,
                    mip_clamp: 1.5,
                    supersample,
                    ..base.clone()
                });
            }
        }
        out.push(at_256(base));
        out.push(RenderSettings {
            gather_angle: false,
            ..base.clone()
        });
    }
    out
}

/// The planner's reuse rule measured: two frames, the second with the camera orbited 10 degrees about
/// its target (geometry, materials and lights unchanged), rendered with the rule off (every pass every
/// frame) and on (the second frame reuses the first's radiance pyramid).
#[derive(Clone, Debug)]
pub struct PlannerRow {
    /// Seconds of the second frame's stages (as [`BenchRow::stage_seconds`]), rule off and on.
    pub off_seconds: f64,
    pub on_seconds: f64,
    /// Combined mean FLIP of the second frame against a reference of that view, rule off and on.
    pub off_flip: f32,
    pub on_flip: f32,
    /// Largest difference between the two second frames (any pixel, any channel, all four images).
    pub max_difference: f32,
    /// The stages the rule skipped in the second frame.
    pub skipped: Vec<&'static str>,
}

/// Measure the reuse rule on `scene` (see [`PlannerRow`]); times are the minimum over `repeats`.
pub fn planner_comparison(
    ctx: &crate::harness::GpuContext,
    pipeline: Pipeline,
    scene: &Scene,
    spp: u32,
    repeats: usize,
) -> Result<PlannerRow> {
    let cones = ConeSettings::from(&scene.render);
    let second = scene.orbited(10.0);
    let mut best = [f64::INFINITY; 2];
    let mut frames = Vec::new();
    let mut skipped = Vec::new();
    for (k, reuse) in [false, true].into_iter().enumerate() {
        for _ in 0..repeats.max(1) {
            // The rule off: a fresh GPU-resident renderer for the second frame (nothing kept).
            let mut r = crate::resident::Resident::new(ctx, pipeline)?;
            r.render(scene, &cones)?;
            if !reuse {
                r = crate::resident::Resident::new(ctx, pipeline)?;
            }
            let f = r.render(&second, &cones)?;
            best[k] = best[k].min(f.stages.iter().map(|s| s.1).sum());
            if reuse {
                skipped = f.plan.skipped();
            }
            frames.push((k, f));
        }
    }
    let last = |k: usize| &frames.iter().rev().find(|f| f.0 == k).expect("rendered").1;
    let (off, on) = (last(0), last(1));
    let max_difference = [
        (&off.direct, &on.direct),
        (&off.indirect, &on.indirect),
        (&off.combined, &on.combined),
        (&off.ao, &on.ao),
    ]
    .iter()
    .flat_map(|(a, b)| {
        a.pixels
            .iter()
            .flatten()
            .zip(b.pixels.iter().flatten())
            .map(|(x, y)| (x - y).abs())
    })
    .fold(0.0, f32::max);
    let reference = render_reference(&second, &ReferenceOptions::spp(spp), |_| {});
    let ref_combined = RgbImage::new(reference.width, reference.height, reference.combined());
    let p = Path::new("bench");
    Ok(PlannerRow {
        off_seconds: best[0],
        on_seconds: best[1],
        off_flip: compare(&ref_combined, p, &off.combined, p)?.flip_mean,
        on_flip: compare(&ref_combined, p, &on.combined, p)?.flip_mean,
        max_difference,
        skipped,
    })
}

/// The planner section of the table.
pub fn planner_table(p: &PlannerRow) -> String {
    format!(
        "\n## Planner: reuse the voxel volume (pyramid or octree) when only the view changed\n\n\
         Second of two frames (camera orbited 10 degrees, `[render]` settings of the scene), rule off \
         (every pass) vs on (skips {}).\n\n\
         | rule | frame time | combined FLIP (reference of that view) |\n\
         |---|---|---|\n\
         | off | {:.0} ms | {:.3} |\n\
         | on | {:.0} ms | {:.3} |\n\n\
         Saved {:.0}% of the frame; largest difference between the two frames: {:e} (the reused \
         volume is the one a rebuild makes).\n",
        p.skipped.join(", "),
        p.off_seconds * 1e3,
        p.off_flip,
        p.on_seconds * 1e3,
        p.on_flip,
        100.0 * (1.0 - p.on_seconds / p.off_seconds),
        p.max_difference
    )
}

/// Which points (time, error) are Pareto-optimal: no other point is at most as slow and at most as
/// wrong while strictly better in one of the two.
pub fn pareto(points: &[(f64, f64)]) -> Vec<bool> {
    points
        .iter()
        .map(|&(t, e)| {
            !points
                .iter()
                .any(|&(t2, e2)| t2 <= t && e2 <= e && (t2 < t || e2 < e))
        })
        .collect()
}

/// Run the sweep on `scene` against a reference of `spp` samples per pixel and write the results into
/// `out`. One untimed warm-up frame first (the driver compiles pipelines on first use); each
/// configuration's stage times are the minimum over `repeats` frames (2 in the full sweep, 1 quick).
/// `progress(done, total, what)` is called before each step (the reference is step 0).
/// What a bench's errors are measured against, as its table's title says: "reference DIR" or
/// "reference N spp".
pub fn against(spp: u32, reference: Option<&Path>) -> String {
    match reference {
        Some(dir) => format!("reference {}", dir.display()),
        None => format!("reference {spp} spp"),
    }
}

/// The sweep ([`sweep`]) is around `scene`'s `[render]` settings as given (no preset applied), plus
/// the point its quality preset resolves to. `reference`: a directory holding the scene camera's
/// `combined.exr` and `indirect.exr` (e.g. a
/// converged one, references/cornell_box_256_4096spp) to compare against instead of a reference
/// rendered at `spp` (the planner row renders its own view's at `spp` either way). With `temporal`,
/// each configuration's temporal instability over that orbit too.
#[allow(clippy::too_many_arguments)]
pub fn bench(
    ctx: &crate::harness::GpuContext,
    pipeline: Pipeline,
    scene: &Scene,
    spp: u32,
    reference: Option<&Path>,
    (quick, temporal): (bool, Option<crate::temporal::Orbit>),
    out: &Path,
    mut progress: impl FnMut(usize, usize, &str),
) -> Result<(Vec<BenchRow>, PlannerRow)> {
    let mut configs = sweep(&scene.render, quick, pipeline);
    // The quality preset's point (`--quality`; `balanced` where none is given), where the sweep
    // around the scene's own settings lacks it.
    if !quick {
        let preset = crate::quality::resolved(scene, pipeline)
            .map_err(anyhow::Error::msg)?
            .0
            .render;
        if !configs.contains(&preset) {
            configs.push(preset);
        }
    }
    let repeats = if quick { 1 } else { 2 };
    let total = configs.len() + 2;
    let (w, h) = (scene.camera.width, scene.camera.height);
    if reference.is_none() {
        progress(0, total, &format!("reference ({spp} spp)"));
    }
    let (ref_indirect, ref_combined) = crate::reference::images_for(scene, spp, reference)?;
    let mut ideal_frames = temporal.map(|t| t.ideal_frames());
    let mut rows = Vec::new();
    let frame = |settings: &RenderSettings| {
        let s = Scene {
            render: settings.clone(),
            ..scene.clone()
        };
        // A fresh GPU-resident renderer: every stage runs.
        let mut r = crate::resident::Resident::new(ctx, pipeline)?;
        let f = r
            .render(&s, &ConeSettings::from(settings))
            .with_context(|| format!("rendering with {settings:?}"))?;
        Ok::<_, anyhow::Error>((f, r.memory()))
    };
    frame(&configs[0])?;
    for (i, settings) in configs.iter().enumerate() {
        progress(
            i + 1,
            total,
            &format!(
                "{}^3 voxels, {} cones of {} deg, clamp {}, RSM {}^2",
                settings.voxels,
                settings.cones,
                settings.cone_half_angle,
                settings.mip_clamp,
                settings.rsm_side
            ),
        );
        let names = pipeline.stages();
        let mut stage_seconds = vec![f64::INFINITY; names.len()];
        let mut r = None;
        let mut caches = 0;
        for _ in 0..repeats {
            let (f, memory) = frame(settings)?;
            if let Some(crate::render::VolumeMemory::Caches(c)) = memory {
                caches = c.caches;
            }
            let mut t = vec![0.0; names.len()];
            for (name, secs) in &f.stages {
                if let Some(k) = names.iter().position(|s| s == name) {
                    t[k] += secs;
                }
            }
            for (best, t) in stage_seconds.iter_mut().zip(t) {
                *best = best.min(t);
            }
            r = Some(f);
        }
        let r = r.expect("at least one frame");
        // Only where the ideal cones are this frame's reference: one bounce (an interleaved
        // frame's: its classes' whole set).
        let orbit_instability = match &mut ideal_frames {
            Some(ideal) if crate::temporal::ideal_reference_fits(settings) => {
                let s = Scene {
                    render: settings.clone(),
                    ..scene.clone()
                };
                let motion = ideal.motion;
                let (reference, _) = ideal.of(&s);
                Some(
                    crate::temporal::measure(ctx, pipeline, &s, motion, reference, None)?
                        .0
                        .instability,
                )
            }
            _ => None,
        };
        let p = Path::new("bench");
        let ind = compare(&ref_indirect, p, &r.indirect, p)?;
        let comb = compare(&ref_combined, p, &r.combined, p)?;
        rows.push(BenchRow {
            voxels: settings.voxels,
            cones: settings.cones,
            cone_half_angle: settings.cone_half_angle,
            mip_clamp: settings.mip_clamp,
            cone_step: settings.cone_step,
            cone_level_bias: settings.cone_level_bias,
            coverage_correlation: settings.coverage_correlation,
            rsm_side: settings.rsm_side,
            lrsm_layers: if settings.lrsm_lit_cells {
                "lit cells".into()
            } else {
                format!(
                    "{}x{}{}",
                    settings.lrsm_depth_splits + 1,
                    settings.lrsm_normal_splits + 1,
                    if settings.lrsm_area_weights {
                        " area-weighted"
                    } else {
                        ""
                    }
                )
            },
            cache_resolution: settings.cache_resolution,
            cache_tile: settings.cache_tile,
            caches,
            irradiance_resolution: settings.irradiance_resolution,
            gather_radius: settings.gather_radius,
            gather_angle: settings.gather_angle,
            anisotropic_voxels: settings.anisotropic_voxels,
            photon_map: settings.photon_map,
            voxel_lobes: settings.voxel_lobes,
            depth_ordered_blend: settings.depth_ordered_blend,
            supersample: settings.supersample,
            cone_interleave: settings.cone_interleave,
            seconds: stage_seconds.iter().sum(),
            stage_seconds,
            indirect_rel_mse: ind.rel_mse,
            indirect_flip: ind.flip_mean,
            combined_rel_mse: comb.rel_mse,
            combined_flip: comb.flip_mean,
            pareto: false,
            orbit_instability,
        });
    }
    let points: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r.seconds, r.combined_flip as f64))
        .collect();
    for (r, p) in rows.iter_mut().zip(pareto(&points)) {
        r.pareto = p;
    }
    progress(total - 1, total, "planner: reuse rule off vs on");
    let planner = planner_comparison(ctx, pipeline, scene, spp, repeats)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    write_csv(&out.join("bench.csv"), pipeline, &rows)?;
    let md = table(&rows, pipeline, &against(spp, reference), w, h) + &planner_table(&planner);
    std::fs::write(out.join("bench.md"), md)
        .with_context(|| format!("writing {}", out.join("bench.md").display()))?;
    plot(&out.join("bench.svg"), &rows, pipeline)?;
    Ok((rows, planner))
}

fn write_csv(path: &Path, pipeline: Pipeline, rows: &[BenchRow]) -> Result<()> {
    let mut w =
        csv::Writer::from_path(path).with_context(|| format!("writing {}", path.display()))?;
    // Header by hand: the flattened per-stage columns follow the serialised fields.
    let mut header: Vec<String> = [
        "voxels",
        "cones",
        "cone_half_angle",
        "mip_clamp",
        "cone_step",
        "cone_level_bias",
        "coverage_correlation",
        "rsm_side",
        "lrsm_layers",
        "cache_resolution",
        "cache_tile",
        "caches",
        "irradiance_resolution",
        "gather_radius",
        "gather_angle",
        "anisotropic_voxels",
        "photon_map",
        "voxel_lobes",
        "depth_ordered_blend",
        "supersample",
        "cone_interleave",
        "seconds",
        "indirect_rel_mse",
        "indirect_flip",
        "combined_rel_mse",
        "combined_flip",
        "pareto",
        "orbit_instability",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    header.extend(pipeline.stages().iter().map(|s| format!("{s}_seconds")));
    w.write_record(&header)?;
    for r in rows {
        let mut rec = vec![
            r.voxels.to_string(),
            r.cones.to_string(),
            r.cone_half_angle.to_string(),
            r.mip_clamp.to_string(),
            r.cone_step.to_string(),
            r.cone_level_bias.to_string(),
            r.coverage_correlation.to_string(),
            r.rsm_side.to_string(),
            r.lrsm_layers.clone(),
            r.cache_resolution.to_string(),
            r.cache_tile.to_string(),
            r.caches.to_string(),
            r.irradiance_resolution.to_string(),
            r.gather_radius.to_string(),
            r.gather_angle.to_string(),
            r.anisotropic_voxels.to_string(),
            r.photon_map.to_string(),
            r.voxel_lobes.to_string(),
            r.depth_ordered_blend.to_string(),
            r.supersample.to_string(),
            r.cone_interleave.to_string(),
            format!("{:.4}", r.seconds),
            format!("{:.5}", r.indirect_rel_mse),
            format!("{:.4}", r.indirect_flip),
            format!("{:.5}", r.combined_rel_mse),
            format!("{:.4}", r.combined_flip),
            r.pareto.to_string(),
            r.orbit_instability
                .map(|v| format!("{v:.5}"))
                .unwrap_or_default(),
        ];
        rec.extend(r.stage_seconds.iter().map(|s| format!("{s:.4}")));
        w.write_record(&rec)?;
    }
    w.flush()?;
    Ok(())
}

/// The Markdown table (rows by time, Pareto-optimal ones marked).
/// `against`: what the errors are measured against ("reference 64 spp", "reference DIR").
pub fn table(rows: &[BenchRow], pipeline: Pipeline, against: &str, w: u32, h: u32) -> String {
    let mut sorted: Vec<&BenchRow> = rows.iter().collect();
    sorted.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
    let stages = pipeline.stages();
    let (name, last) = (pipeline.name(), stages.len() - 1);
    // The pixel-shading stage (cprc: its cache stages together, from distribution on).
    let first_shading = stages
        .iter()
        .position(|s| *s == "cache_distribution")
        .unwrap_or(last);
    let shading = if first_shading < last {
        "cache stages"
    } else {
        stages[last]
    };
    let mut md = format!(
        "# vxgi bench ({name}, {w}x{h}, {against})\n\n\
         | voxels | cones | half-angle | mip clamp | step | level bias / coverage corr. | blend | samples | RSM | layers | caches | cache res (irradiance, radius) | octree | time | {shading} | voxelize | indirect FLIP | combined FLIP | combined rel. MSE | orbit instability | Pareto |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    );
    let lrsm = pipeline == Pipeline::Lrsm;
    let cprc = pipeline == Pipeline::Cprc;
    let svo = pipeline == Pipeline::VctSvo;
    for r in sorted {
        let _ = writeln!(
            md,
            "| {}^3 | {} | {} | {} | {} | {} / {} | {} | {}x{} | {} | {} | {} | {} | {} | {:.0} ms | {:.0} ms | {:.0} ms | {:.3} | {:.3} | {:.4} | {} | {} |",
            r.voxels,
            if r.cone_interleave > 1 {
                format!("{0} ({1}x{1} interleaved)", r.cones, r.cone_interleave)
            } else {
                r.cones.to_string()
            },
            r.cone_half_angle,
            r.mip_clamp,
            r.cone_step,
            r.cone_level_bias,
            r.coverage_correlation,
            match (svo || lrsm, r.depth_ordered_blend) {
                (true, _) => "-",
                (false, true) => "depth-ordered",
                (false, false) => "trilinear",
            },
            r.supersample,
            r.supersample,
            if lrsm { format!("{}^2", r.rsm_side) } else { "-".into() },
            if lrsm { r.lrsm_layers.as_str() } else { "-" },
            if cprc {
                format!("{} (tile {})", r.caches, r.cache_tile)
            } else {
                "-".into()
            },
            if cprc {
                format!(
                    "{}^2 ({}^2, {}{})",
                    r.cache_resolution,
                    r.irradiance_resolution,
                    r.gather_radius,
                    if r.gather_angle { "" } else { ", no angle term" }
                )
            } else {
                "-".into()
            },
            if svo {
                format!(
                    "{}, {}{}",
                    if r.anisotropic_voxels {
                        "anisotropic"
                    } else {
                        "isotropic"
                    },
                    match r.photon_map {
                        0 => "voxel_light".to_string(),
                        m => format!("photons {m}^2"),
                    },
                    if r.voxel_lobes { ", lobes" } else { "" }
                )
            } else {
                "-".into()
            },
            r.seconds * 1e3,
            r.stage_seconds[first_shading..].iter().sum::<f64>() * 1e3,
            r.stage_seconds[2] * 1e3,
            r.indirect_flip,
            r.combined_flip,
            r.combined_rel_mse,
            r.orbit_instability
                .map_or("-".to_string(), |v| format!("{v:.4}")),
            if r.pareto { "**yes**" } else { "" }
        );
    }
    md.push_str(
        "\ntime: the GPU time of a fresh GPU-resident renderer's frame, stage by stage (timestamp \
         queries; vct-svo's octree build by wall clock; per stage in bench.csv); FLIP and rel. MSE as `vxgi compare` defines them, against the Monte Carlo \
         reference; orbit instability (with `--temporal-frames`): the frame-to-frame change of the \
         indirect image beyond the ideal cones' over a camera orbit, relative to the mean indirect \
         light (docs/temporal.md); Pareto: no other configuration is both faster and more accurate.\n\n![time vs error](bench.svg)\n",
    );
    md
}

fn plot(path: &Path, rows: &[BenchRow], pipeline: Pipeline) -> Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (800, 500)).into_drawing_area();
    let err = |e: DrawingAreaErrorKind<_>| anyhow::anyhow!("plotting {}: {e:?}", path.display());
    root.fill(&WHITE).map_err(err)?;
    let t_max = rows.iter().map(|r| r.seconds * 1e3).fold(1.0, f64::max) * 1.1;
    // Errors span a narrow band: the y axis covers it with a margin rather than starting at 0.
    let flips = || rows.iter().map(|r| r.combined_flip as f64);
    let (e_lo, e_hi) = (flips().fold(1.0, f64::min), flips().fold(0.0, f64::max));
    let pad = ((e_hi - e_lo) * 0.1).max(0.005);
    let (e_min, e_max) = ((e_lo - pad).max(0.0), e_hi + pad);
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("{}: time vs error", pipeline.name()),
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_max, e_min..e_max)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("frame time (ms, GPU)")
        .y_desc("combined mean FLIP")
        .draw()
        .map_err(err)?;
    chart
        .draw_series(rows.iter().map(|r| {
            Circle::new(
                (r.seconds * 1e3, r.combined_flip as f64),
                4,
                BLUE.mix(0.5).filled(),
            )
        }))
        .map_err(err)?
        .label("configuration")
        .legend(|(x, y)| Circle::new((x, y), 4, BLUE.mix(0.5).filled()));
    let mut front: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.pareto)
        .map(|r| (r.seconds * 1e3, r.combined_flip as f64))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    chart
        .draw_series(LineSeries::new(front.clone(), RED.stroke_width(2)))
        .map_err(err)?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
    chart
        .draw_series(front.iter().map(|&p| Circle::new(p, 5, RED.filled())))
        .map_err(err)?;
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

    #[test]
    fn pareto_keeps_only_undominated_points() {
        let p = [(1.0, 0.5), (2.0, 0.3), (2.0, 0.4), (3.0, 0.3), (0.5, 0.9)];
        assert_eq!(pareto(&p), vec![true, true, false, false, true]);
    }

    #[test]
    fn sweeps_cover_the_grid_and_keep_other_keys() {
        let base = RenderSettings {
            ao_range: 0.25,
            ..Default::default()
        };
        let full = sweep(&base, false, Pipeline::VctDense);
        assert_eq!(full.len(), 300);
        assert_eq!(full.iter().filter(|s| s.voxels == 256).count(), 1);
        assert_eq!(
            full.iter()
                .filter(|s| s.cone_level_bias != 0.0 || s.coverage_correlation != 0.0)
                .count(),
            9
        );
        assert_eq!(full.iter().filter(|s| s.cone_interleave > 1).count(), 5);
        assert!(full
            .iter()
            .all(|s| s.ao_range == 0.25 && s.validate().is_ok()));
        assert_eq!(sweep(&base, true, Pipeline::VctSvo).len(), 4);
        let svo = sweep(&base, false, Pipeline::VctSvo);
        assert_eq!(svo.len(), 43);
        assert_eq!(svo.iter().filter(|s| s.voxel_lobes).count(), 6);
        assert!(svo
            .iter()
            .all(|s| s.ao_range == 0.25 && s.validate().is_ok()));
        assert_eq!(svo.iter().filter(|s| s.anisotropic_voxels).count(), 25);
        let lrsm = sweep(&base, false, Pipeline::Lrsm);
        assert_eq!(lrsm.len(), 57);
        let other = |s: &&RenderSettings| s.lrsm_lit_cells != base.lrsm_lit_cells;
        assert_eq!(lrsm.iter().filter(other).count(), 1);
        let lit = RenderSettings {
            lrsm_lit_cells: true,
            ..base.clone()
        };
        assert_eq!(sweep(&lit, false, Pipeline::Lrsm).len(), 21);
        let quick = sweep(&lit, true, Pipeline::Lrsm);
        assert_eq!(quick.iter().filter(|s| s.lrsm_lit_cells).count(), 2);
        assert_eq!(quick.len(), 4);
        assert_eq!(lrsm.iter().filter(|s| s.voxels > 128).count(), 2);
        assert!(lrsm
            .iter()
            .all(|s| s.ao_range == 0.25 && s.validate().is_ok()));
        assert_eq!(sweep(&base, true, Pipeline::Lrsm).len(), 4);
        let cprc = sweep(&base, false, Pipeline::Cprc);
        assert_eq!(cprc.len(), 12);
        assert_eq!(cprc.iter().filter(|s| !s.gather_angle).count(), 1);
        assert!(cprc.iter().all(|s| s.validate().is_ok()));
        assert_eq!(sweep(&base, true, Pipeline::Cprc).len(), 4);
    }
}
