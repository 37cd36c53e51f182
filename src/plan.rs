//! The frame plan: the passes a frame runs, built from the scene and the view, each with its kernel,
//! its size, and whether it runs and why. `vxgi render --plan` prints it; the renderers follow it.
//! Each pipeline's declaration ([`crate::pipeline::PipelineDecl`]) holds its stages' rules (skip
//! what a scene does not need); [`FramePlan::of`] applies them, and the `with_*` methods below add
//! what only the frame's renderer knows (instances voxelized before, voxels kept, cache counts).
use crate::pipeline::{PipelineDecl, PlanInputs};
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

impl PlannedPass {
    pub fn new(
        stage: &'static str,
        kernel: &'static str,
        size: impl Into<String>,
        runs: bool,
        why: impl Into<String>,
    ) -> Self {
        Self {
            stage,
            kernel,
            size: size.into(),
            runs,
            why: why.into(),
        }
    }
}

impl FramePlan {
    /// `decl`'s frame plan: each declared stage's passes by its plan rule, in frame order.
    pub fn of(decl: &PipelineDecl, inputs: &PlanInputs) -> Self {
        let passes = decl
            .stages
            .iter()
            .flat_map(|s| {
                let passes = (s.plan)(inputs);
                debug_assert!(
                    passes.iter().all(|p| p.stage == s.name),
                    "{}'s stage {} plans a pass of another stage",
                    decl.name,
                    s.name
                );
                passes
            })
            .collect();
        Self {
            pipeline: decl.name,
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
                "voxel_light"
                | "surface_coverage_mip"
                | "reflective_shadow_map"
                | "lrsm_partition" => {
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

    /// The stages the plan skips (none of their passes runs), in order.
    pub fn skipped(&self) -> Vec<&'static str> {
        let mut s: Vec<&'static str> = self
            .passes
            .iter()
            .filter(|p| !self.runs(p.stage))
            .map(|p| p.stage)
            .collect();
        s.dedup(); // a stage of several passes (cprc's cache_distribution) once
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
    scene.lights.iter().map(views_of).sum()
}

/// The light views of one light ([`light_views`]): 1, or 6 cube faces; none for a light of zero
/// intensity (it casts nothing).
pub fn views_of(light: &crate::scene::Light) -> usize {
    use crate::scene::Light;
    if light.intensity() == [0.0; 3] {
        return 0;
    }
    match light {
        // The light views' own rule (lrsm::light_views): one view where the cone's cosine, in
        // f32 as the GPU light holds it, is at least 0.5.
        Light::Spot { cone_deg, .. } if cone_deg.to_radians().cos() >= 0.5 => 1,
        Light::Directional { .. } => 1,
        _ => 6,
    }
}

/// The pass size of a mip chain of a `side`^3 grid that builds its first `built` levels (level 0
/// included): the rest are levels no cone reaches (`cone_trace::pyramid_levels`).
pub(crate) fn mip_levels(side: u32, built: u32) -> String {
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
