//! The frame plan: the passes a frame runs, built from the scene and the view, each with its kernel,
//! its size, and whether it runs and why. `vxgi render --plan` prints it; [`crate::render::render`]
//! follows it. Skip rules (skip what a scene does not need) are the planner's job: this is the
//! structure they fill, with the decisions that already follow from the scene.
use crate::kernels::cone_trace::ConeSettings;
use crate::scene::Scene;
use std::fmt;

#[derive(Clone, Debug, PartialEq)]
pub struct PlannedPass {
    /// Stage name, as in `Rendered::stages`.
    pub stage: &'static str,
    /// The kernel (`vxgi list` name) that runs it.
    pub kernel: &'static str,
    /// What it is dispatched over.
    pub size: String,
    pub runs: bool,
    /// Why it runs (or is skipped).
    pub why: String,
}

#[derive(Clone, Debug, PartialEq)]
pub struct FramePlan {
    pub pipeline: &'static str,
    pub passes: Vec<PlannedPass>,
}

impl FramePlan {
    /// The vct-dense frame for `scene` with `cones` (a first frame: nothing cached).
    pub fn vct_dense(scene: &Scene, cones: &ConeSettings) -> Self {
        Self::vct_dense_after(scene, cones, false)
    }

    /// The vct-dense frame when `pyramid_cached` says whether the last frame's radiance pyramid was
    /// built from the same geometry, materials, lights and grid, with the levels these cones read
    /// (then only the camera or cone settings that read the same levels changed, and voxelize, voxel_light and the mips are skipped: the pyramid is reused
    /// as it is, so the image is the same as with a rebuild).
    pub fn vct_dense_after(scene: &Scene, cones: &ConeSettings, pyramid_cached: bool) -> Self {
        let (w, h) = (scene.camera.width, scene.camera.height);
        let px = format!("{w}x{h} pixels");
        let side = scene.render.voxels;
        let glossy = scene.materials.iter().filter(|m| m.is_glossy()).count();
        let lights = scene.lights.len();
        let pass = |stage, kernel, size: String, runs, why: String| PlannedPass {
            stage,
            kernel,
            size,
            runs,
            why,
        };
        const CACHED: &str = "skipped: geometry, materials, lights and voxels unchanged since the last frame (its radiance pyramid is reused)";
        let passes = vec![
            pass(
                "gbuffer",
                "gbuffer",
                px.clone(),
                true,
                "every renderer shades G-buffer texels".into(),
            ),
            pass(
                "direct_light",
                "direct_light",
                format!("{px} x {lights} lights"),
                lights > 0,
                if lights > 0 {
                    "exact shadow ray per light and texel".into()
                } else {
                    "skipped: the scene has no lights (direct is 0)".into()
                },
            ),
            pass(
                "voxelize",
                "voxelize",
                format!("{} triangles into {side}^3", scene.mesh.triangles.len()),
                !pyramid_cached,
                if pyramid_cached {
                    CACHED.into()
                } else {
                    "the radiance pyramid's geometry".into()
                },
            ),
            pass(
                "voxel_light",
                "voxel_light",
                format!("non-empty voxels x {lights} lights"),
                lights > 0 && !pyramid_cached,
                if pyramid_cached {
                    CACHED.into()
                } else if lights > 0 {
                    "direct light into the voxels (work list from voxelize)".into()
                } else {
                    "skipped: no lights, the pyramid holds no radiance".into()
                },
            ),
            pass(
                "surface_coverage_mip",
                "surface_coverage_mip",
                mip_levels(side, crate::kernels::cone_trace::pyramid_levels(scene, cones, side)),
                !pyramid_cached,
                if pyramid_cached {
                    CACHED.into()
                } else {
                    "cones read coarser levels as they widen".into()
                },
            ),
            pass(
                "cone_trace",
                "cone_trace",
                format!(
                    "{px} in the 8x8 tiles holding a surface (screen_tiles' list; empty tiles not dispatched) x ({} diffuse{}){}",
                    cones.diffuse_cones,
                    if glossy > 0 { " + 1 glossy" } else { "" },
                    if cones.interleave > 1 {
                        format!(
                            ", then the resolve over {0}x{0} neighbours (tent weights)",
                            2 * cones.interleave - 1
                        )
                    } else {
                        String::new()
                    }
                ),
                true,
                format!(
                    "{}{}",
                    if glossy > 0 {
                        format!("AO + diffuse; glossy cone for the {glossy} glossy material(s)")
                    } else {
                        "AO + diffuse; no glossy cone: no material has Ks".into()
                    },
                    if cones.interleave > 1 {
                        format!(
                            "; interleaved cone sets: {} cones over {1}x{1} classes of a surface",
                            cones.diffuse_cones * cones.interleave * cones.interleave,
                            cones.interleave
                        )
                    } else {
                        String::new()
                    }
                ),
            ),
        ];
        Self {
            pipeline: "vct-dense",
            passes,
        }
    }

    /// The vct-svo frame: vct-dense's G-buffer, direct light, voxelization and voxel light, then the
    /// sparse voxel octree instead of the mip chain and the octree's cone tracer.
    pub fn vct_svo(scene: &Scene, cones: &ConeSettings) -> Self {
        Self::vct_svo_after(scene, cones, false)
    }

    /// The vct-svo frame when `octree_cached` says the last frame's octree came from the same geometry,
    /// materials, lights and grid (vct-dense's reuse rule, see [`FramePlan::vct_dense_after`]).
    pub fn vct_svo_after(scene: &Scene, cones: &ConeSettings, octree_cached: bool) -> Self {
        let dense = Self::vct_dense_after(scene, cones, octree_cached);
        let side = scene.render.voxels;
        let depth = side.trailing_zeros().saturating_sub(1);
        let mut aniso = None;
        let passes: Vec<PlannedPass> = dense
            .passes
            .into_iter()
            .map(|mut p| {
                match p.stage {
                    "surface_coverage_mip" => {
                        p.stage = "sparse_voxel_octree";
                        p.kernel = "sparse_voxel_octree";
                        p.size = format!("depth {depth} over {side}^3 voxels, {} levels", depth + 1);
                        if p.runs {
                            p.why = "build, splat, border transfer, distribution over levels; work lists skip empty nodes".into();
                        } else {
                            p.why = p.why.replace("radiance pyramid", "octree");
                        }
                        let on = scene.render.anisotropic_voxels;
                        aniso = Some(PlannedPass {
                            stage: "svo_anisotropic",
                            kernel: "svo_anisotropic",
                            size: format!("levels 0..{depth}, 6 directions x 27 voxels per node"),
                            runs: p.runs && on,
                            why: if !on {
                                "skipped: anisotropic_voxels = false (isotropic Gaussian average only)".into()
                            } else if p.runs {
                                "six directional values per voxel above the leaves, front to back per direction (VCT 7.1)".into()
                            } else {
                                p.why.clone()
                            },
                        });
                    }
                    "cone_trace" => {
                        p.stage = "svo_cone_trace";
                        p.kernel = "svo_cone_trace";
                        if scene.render.anisotropic_voxels {
                            p.why.push_str("; anisotropic voxels above the leaves");
                        }
                        if scene.render.voxel_lobes {
                            p.why.push_str("; voxel shading with Gaussian lobes");
                        }
                    }
                    "voxel_light" if scene.render.photon_map > 0 => {
                        let map = scene.render.photon_map;
                        p.stage = "svo_photons";
                        p.kernel = "gbuffer + svo_photons";
                        p.size = format!("{} light views x {map}^2 texels", light_views(scene));
                        if p.runs {
                            p.why = "light injection: a map ray-cast from each light view, one photon per texel splatted into the leaves".into();
                        } else {
                            p.why = p.why.replace("radiance pyramid", "octree");
                        }
                    }
                    "voxelize" | "voxel_light" => p.why = p.why.replace("radiance pyramid", "octree"),
                    _ => {}
                }
                p
            })
            .collect();
        let mut passes = passes;
        if let (Some(a), Some(at)) = (
            aniso,
            passes.iter().position(|p| p.stage == "sparse_voxel_octree"),
        ) {
            let octree_runs = passes[at].runs;
            passes.insert(at + 1, a);
            let lights = !scene.lights.is_empty();
            let two = scene.render.bounces == 2;
            let lobes = scene.render.voxel_lobes;
            passes.insert(
                at + 2,
                PlannedPass {
                    stage: "svo_lobes",
                    kernel: "sparse_voxel_octree (normals)",
                    size: format!("depth {depth}: normal pool over the octree's points"),
                    runs: octree_runs && lobes,
                    why: if !lobes {
                        "skipped: voxel_lobes = false (voxels emit alike in every direction)".into()
                    } else if !octree_runs {
                        "skipped: the octree is reused (with its normal pool)".into()
                    } else {
                        "normals pre-multiplied by opacity, filtered as the light (a second build over the same points), for the Gaussian lobes (VCT 4.3, 7); with glossy surfaces and photons, their specular photons in a third pool (the incoming light as a direction distribution, VCT 7)".into()
                    },
                },
            );
            passes.insert(
                at + 3,
                PlannedPass {
                    stage: "svo_bounce",
                    kernel: "svo_bounce + sparse_voxel_octree",
                    size: format!(
                        "non-empty voxels x {} diffuse cones, then the octree again",
                        cones.diffuse_cones
                    ),
                    runs: octree_runs && two && lights,
                    why: if !two {
                        "skipped: bounces = 1".into()
                    } else if !octree_runs {
                        "skipped: the octree is reused (it holds both bounces)".into()
                    } else if !lights {
                        "skipped: no lights, nothing to bounce".into()
                    } else {
                        "second bounce: every voxel gathers the first through the octree, its light added to the fragments, octree rebuilt".into()
                    },
                },
            );
        }
        Self {
            pipeline: "vct-svo",
            passes,
        }
    }

    /// The lrsm frame (Sugihara et al. 2014): G-buffer and direct light as vct-dense; the voxel grid
    /// becomes binary occlusion voxels and their mips; every light view gets an RSM, split into layers
    /// and pre-filtered (the `reflective_shadow_map` stage times all three); the gather cone-traces
    /// occlusion from the voxels and radiance from the LRSMs. `cached`: the last frame's occlusion
    /// voxels and LRSMs came from the same geometry, materials, lights and settings (reused as they are).
    pub fn lrsm_after(
        scene: &Scene,
        cones: &ConeSettings,
        lrsm: &crate::kernels::lrsm_cone_trace::LrsmSettings,
        cached: bool,
    ) -> Self {
        let dense = Self::vct_dense_after(scene, cones, cached);
        let side = scene.render.voxels;
        let lights = scene.lights.len();
        let views = light_views(scene);
        let layers = (lrsm.depth_splits + 1) * (lrsm.normal_splits + 1);
        const CACHED: &str = "skipped: geometry, materials, lights and settings unchanged since the last frame (its occlusion voxels and LRSMs are reused)";
        let mut passes = Vec::new();
        let soft = lrsm.shadow_cone_angle > 0.0;
        for mut p in dense.passes {
            match p.stage {
                "direct_light" if soft && p.runs => {
                    p.runs = false;
                    p.why = format!(
                        "skipped: shadow cones of {} deg through the occlusion voxels replace the exact shadow rays (lrsm_cone_trace's shadow pass)",
                        lrsm.shadow_cone_angle
                    );
                    passes.push(p);
                }
                "voxelize" => {
                    if p.runs {
                        p.why = "the occlusion voxels' level 0: a bit per voxel a surface sample lands in (entry occupancy_bits; no accumulators)".into();
                    } else {
                        p.why = CACHED.into();
                    }
                    passes.push(p);
                }
                "voxel_light" => {
                    passes.push(PlannedPass {
                        stage: "occlusion_voxels",
                        kernel: "occlusion_voxels",
                        size: format!(
                            "{} mip levels over {side}^3 bits (a byte per voxel above level 0)",
                            side.trailing_zeros()
                        ),
                        runs: !cached,
                        why: if cached {
                            CACHED.into()
                        } else if lrsm.surface_coverage {
                            "binary occlusion and its surface-coverage mips (lrsm_surface_coverage: thin walls stay opaque; no radiance in the voxels)"
                                .into()
                        } else {
                            "binary occlusion and its averaged mips (no radiance in the voxels)"
                                .into()
                        },
                    });
                }
                "surface_coverage_mip" => {
                    let size = format!(
                        "{views} light views x {}^2 RSM, {layers} layers",
                        lrsm.rsm_side
                    );
                    let why = if cached {
                        CACHED.to_string()
                    } else if lights == 0 {
                        "skipped: no lights, no RSM (indirect is 0)".to_string()
                    } else {
                        "each view's RSM from the light (point lights: six cube faces; directional: orthographic)".to_string()
                    };
                    for (stage, kernel) in [
                        ("reflective_shadow_map", "reflective_shadow_map"),
                        ("reflective_shadow_map", "lrsm_partition"),
                        ("reflective_shadow_map", "lrsm_prefilter"),
                    ] {
                        passes.push(PlannedPass {
                            stage,
                            kernel,
                            size: size.clone(),
                            runs: !cached && lights > 0,
                            why: why.clone(),
                        });
                    }
                }
                "cone_trace" => {
                    p.stage = "lrsm_cone_trace";
                    p.kernel = "lrsm_cone_trace";
                    p.why = format!(
                        "{}; radiance from {views} LRSM views, read only where a sample has occlusion{}",
                        p.why,
                        if soft && lights > 0 {
                            "; + direct light with one shadow cone per light"
                        } else {
                            ""
                        }
                    );
                    passes.push(p);
                }
                _ => passes.push(p),
            }
        }
        Self {
            pipeline: "lrsm",
            passes,
        }
    }

    /// The cprc frame (Rehfeld et al. 2014): vct-dense's stages up to the radiance pyramid (with its
    /// reuse rule: `cached`), then the cache distribution, creation, pre-convolution and the gather
    /// instead of per-pixel cones. The caches follow the view, so they are rebuilt every frame.
    pub fn cprc_after(
        scene: &Scene,
        cones: &ConeSettings,
        s: &crate::cprc::CprcSettings,
        cached: bool,
    ) -> Self {
        let dense = Self::vct_dense_after(scene, cones, cached);
        let (w, h) = (scene.camera.width, scene.camera.height);
        let tiles = w.div_ceil(s.tile) * h.div_ceil(s.tile);
        let glossy = scene.materials.iter().filter(|m| m.is_glossy()).count();
        let levels = s.res.trailing_zeros() + 1;
        let mut passes = Vec::new();
        for mut p in dense.passes {
            if p.stage == "surface_coverage_mip" {
                // The caches' cones read the pyramid: every level is built.
                let side = scene.render.voxels;
                p.size = mip_levels(side, side.trailing_zeros() + 1);
            }
            if p.stage != "cone_trace" {
                passes.push(p);
                continue;
            }
            if scene.lights.is_empty() {
                // Without lights the pyramid holds no radiance and cprc has no AO pass: indirect is 0
                // whatever the caches would hold, so nothing after direct light runs.
                for p in &mut passes {
                    if matches!(p.stage, "voxelize" | "surface_coverage_mip") {
                        p.runs = false;
                        p.why = "skipped: no lights, the caches would hold no radiance (cprc has no AO)".into();
                    }
                }
            }
            let no_light = |mut p: PlannedPass| {
                if scene.lights.is_empty() {
                    p.runs = false;
                    p.why = "skipped: no lights, indirect is 0".into();
                }
                p
            };
            passes.push(no_light(PlannedPass {
                stage: "cache_distribution",
                kernel: "cprc_pixels",
                size: format!("{w}x{h} pixels"),
                runs: true,
                why: "the distribution's and the gather's per-pixel inputs from the G-buffer (entry inputs)".into(),
            }));
            for kernel in [
                "tile_normal_histogram",
                "histogram_axes",
                "cluster_keys",
                "radix_sort",
                "cluster_extract",
                "cache_placement",
            ] {
                passes.push(no_light(PlannedPass {
                    stage: "cache_distribution",
                    kernel,
                    size: format!("{w}x{h} pixels, {tiles} tiles of {}^2, {} depth slices", s.tile, s.slices),
                    runs: true,
                    why: "one cache per cluster of the view's pixels (tile x normal axis x depth slice)".into(),
                }));
            }
            passes.push(no_light(PlannedPass {
                stage: "cache_distribution",
                kernel: "cache_records",
                size: "one per cluster".into(),
                runs: true,
                why: "each cluster's cache record, and the cache stages' workgroups from the count"
                    .into(),
            }));
            passes.push(no_light(PlannedPass {
                stage: "cache_creation",
                kernel: "cache_creation",
                size: format!("caches x {}^2 texels", s.res),
                runs: true,
                why: "one cone per cache texel through the radiance pyramid".into(),
            }));
            passes.push(no_light(PlannedPass {
                stage: "cache_preconvolve",
                kernel: "cache_preconvolve",
                size: format!("caches x {}^2 irradiance texels", s.irr),
                runs: true,
                why: "cosine-folded irradiance for diffuse (entry irradiance)".into(),
            }));
            passes.push(no_light(PlannedPass {
                // Its own stage name so that skipping it does not read as skipping pre-convolution
                // (timed within cache_preconvolve).
                stage: "cache_mips",
                kernel: "cache_preconvolve",
                size: format!("caches x {levels} mip levels"),
                runs: glossy > 0,
                why: if glossy > 0 {
                    format!("mip chain for the {glossy} glossy material(s) (entry mips; skipped at run time if none is in view)")
                } else {
                    "skipped: no material has Ks, no pixel reads a mip chain (entry mips)".into()
                },
            }));
            passes.push(no_light(PlannedPass {
                stage: "gather_caches",
                kernel: "gather_caches",
                size: format!("{w}x{h} pixels, radius {} px", s.radius_px),
                runs: true,
                why: if glossy > 0 {
                    "irradiance by normal; glossy lookups only for pixels with Ks".into()
                } else {
                    "irradiance by normal; no glossy lookups: no material has Ks".into()
                },
            }));
            passes.push(no_light(PlannedPass {
                stage: "gather_caches",
                kernel: "cprc_pixels",
                size: format!("{w}x{h} pixels"),
                runs: true,
                why: "indirect = albedo / pi x irradiance + Ks x glossy; AO 1 on geometry (entry compose)".into(),
            }));
        }
        Self {
            pipeline: "cprc",
            passes,
        }
    }

    /// This cprc plan for a scene of `hierarchies` voxel hierarchies (CPRC 3.1), `voxelized` of them
    /// voxelized this frame (the rest kept from earlier frames: instances are never re-voxelized).
    pub fn with_hierarchies(mut self, hierarchies: usize, voxelized: usize) -> Self {
        for p in &mut self.passes {
            match p.stage {
                "voxelize" => {
                    p.runs = voxelized > 0;
                    p.size = format!("{hierarchies} hierarchies, each in its own frame");
                    p.why = if voxelized > 0 {
                        format!("{voxelized} meshes not voxelized before (one voxelization per distinct mesh and grid side, shared by its instances; moving an instance does not re-voxelize it)")
                    } else {
                        "skipped: every hierarchy was voxelized in an earlier frame (instances are lit where they stand)".into()
                    };
                }
                "voxel_light" => {
                    p.runs = true;
                    p.size = format!("{hierarchies} hierarchies' non-empty voxels");
                    p.why = "each hierarchy lit where its instance stands now (shadows from the whole scene)".into();
                }
                "surface_coverage_mip" => {
                    p.runs = true;
                    p.size = format!("{hierarchies} pyramids, every level");
                    p.why = format!("{hierarchies} pyramids, one per hierarchy");
                }
                _ => {}
            }
        }
        self
    }

    /// This plan (a first frame's, vct-dense or lrsm) for a frame whose lights moved over an unchanged
    /// voxel grid: voxelize (and lrsm's occlusion voxels) skipped, the grid is kept; what the lights
    /// feed runs again (vct-dense: voxel_light and the mips; lrsm: the light views' RSMs and LRSMs).
    pub fn with_voxels_kept(mut self) -> Self {
        for p in &mut self.passes {
            match p.stage {
                "voxelize" | "occlusion_voxels" => {
                    p.runs = false;
                    p.why = "skipped: the geometry and the grid are unchanged: the voxels of an earlier frame are kept".into();
                }
                "voxel_light" | "surface_coverage_mip" | "reflective_shadow_map" => {
                    p.why = format!("{}; again: the lights moved", p.why);
                }
                _ => {}
            }
        }
        self
    }

    /// This plan with `note` added to why `stage` runs or is skipped.
    pub fn with_note(mut self, stage: &str, note: &str) -> Self {
        for p in self.passes.iter_mut().filter(|p| p.stage == stage) {
            p.why = format!("{}; {note}", p.why);
        }
        self
    }

    /// The stages the plan skips, in order.
    pub fn skipped(&self) -> Vec<&'static str> {
        let mut s: Vec<&'static str> = self
            .passes
            .iter()
            .filter(|p| !p.runs)
            .map(|p| p.stage)
            .collect();
        s.dedup(); // a stage of several kernels (lrsm's reflective_shadow_map) once
        s
    }

    pub fn runs(&self, stage: &str) -> bool {
        self.passes.iter().any(|p| p.stage == stage && p.runs)
    }
}

impl fmt::Display for FramePlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "frame plan ({}):", self.pipeline)?;
        for p in &self.passes {
            writeln!(
                f,
                "  {} {:<22} {:<34} {}",
                if p.runs { "run " } else { "skip" },
                p.kernel,
                p.size,
                p.why
            )?;
        }
        Ok(())
    }
}

/// Light views `lrsm::light_views` gives `scene`'s lights: one per spot of at most 60 degrees and per
/// directional light, six cube faces per point light or wider spot.
pub fn light_views(scene: &Scene) -> usize {
    use crate::scene::Light;
    scene
        .lights
        .iter()
        .map(|l| match l {
            // The light views' own rule (lrsm::light_views): one view where the cone's cosine, in
            // f32 as the GPU light holds it, is at least 0.5.
            Light::Spot { cone_deg, .. } if cone_deg.to_radians().cos() >= 0.5 => 1,
            Light::Directional { .. } => 1,
            _ => 6,
        })
        .sum()
}

/// The pass size of a mip chain of a `side`^3 grid that builds its first `built` levels (level 0
/// included): the rest are levels no cone reaches (`cone_trace::pyramid_levels`).
fn mip_levels(side: u32, built: u32) -> String {
    let full = side.trailing_zeros() + 1;
    if built >= full {
        format!("{} levels below {side}^3", full - 1)
    } else {
        format!(
            "{} of {} levels below {side}^3 (levels {built}..={}: no cone reaches them, not built)",
            built - 1,
            full - 1,
            full - 1
        )
    }
}
