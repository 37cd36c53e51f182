//! A pipeline declared once: its frame's stages in order, each with the kernels whose passes it
//! runs, what makes a later frame run it again, whether `vxgi bisect` can split the frame after it,
//! and the plan's rule for running or skipping it. Read by [`crate::render::Pipeline::stages`] (stage
//! times, bench columns), [`crate::plan::FramePlan::of`] (`vxgi render --plan`), [`crate::bisect`]
//! (its split points), [`crate::resident::Resident`] (where the passes a reused frame re-runs start)
//! and [`PipelineDecl::check_chain`] (a recorded chain runs the declared kernels in the declared
//! stages, in order).
use crate::harness::KernelDecl;
use crate::kernels::cone_trace::ConeSettings;
use crate::plan::PlannedPass;
use crate::scene::Scene;
use anyhow::Result;

/// One pipeline's frame (see the module doc).
pub struct PipelineDecl {
    /// The `--pipeline` name.
    pub name: &'static str,
    /// In frame order (the plan's, the stage times' and bisect's).
    pub stages: &'static [StageDecl],
}

/// One stage of a frame: the unit the plan runs or skips, the stage times count and bisect splits at.
pub struct StageDecl {
    pub name: &'static str,
    /// The kernels whose passes it runs (a chain's passes of this stage are of these kernels only).
    pub kernels: &'static [&'static KernelDecl],
    pub reuse: Reuse,
    pub split: Split,
    /// The plan's passes of this stage for a frame: what each runs over, whether it runs and why.
    pub plan: fn(&PlanInputs) -> Vec<PlannedPass>,
    /// Its step in a frame run stage by stage on the mirrors or the GPU (the mirror frames,
    /// `vxgi bisect`; [`super::host`]); `None` where an earlier stage's step runs it.
    pub host: Option<super::host::HostStep>,
}

/// What makes a later frame of the same renderer run a stage again (in recording order: a chain
/// records the `Geometry` stages, then the `Lights` ones, then the `Camera` ones).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Reuse {
    /// Its outputs are kept while the geometry, materials and voxel grid are unchanged
    /// (voxelization).
    Geometry,
    /// Run again when the lights move (or instances, which move what the lights reach) over kept
    /// geometry: light injection and what is built from it.
    Lights,
    /// Run every frame: what the camera sees.
    Camera,
}

/// Whether `vxgi bisect` splits the frame after a stage (mirrors up to it, the GPU after it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// Wherever the plan lists the stage (run or skipped).
    Always,
    /// Only where the plan runs it (an optional refinement of the stage before).
    WhenRun,
    /// Never: bisect runs it on the GPU after the last split (or does not follow it).
    Never,
}

/// What a frame plan is made from: the scene, the cones, whether the last frame's volume serves
/// this one, and the settings of lrsm and cprc the scene's `[render]` table resolves to.
pub struct PlanInputs<'a> {
    pub scene: &'a Scene,
    pub cones: &'a ConeSettings,
    /// The last frame's volume came from the same geometry, materials, lights and settings (the
    /// pipeline's reuse rule holds): the volume's stages are skipped.
    pub cached: bool,
    pub lrsm: crate::kernels::lrsm_cone_trace::LrsmSettings,
    pub cprc: crate::cprc::CprcSettings,
}

impl<'a> PlanInputs<'a> {
    pub fn new(scene: &'a Scene, cones: &'a ConeSettings, cached: bool) -> Self {
        Self {
            scene,
            cones,
            cached,
            lrsm: crate::kernels::lrsm_cone_trace::LrsmSettings::from(&scene.render),
            cprc: crate::cprc::CprcSettings::from(&scene.render),
        }
    }

    /// `{w}x{h} pixels`.
    pub(crate) fn pixels(&self) -> String {
        format!(
            "{}x{} pixels",
            self.scene.camera.width, self.scene.camera.height
        )
    }

    /// The number of materials with a glossy lobe.
    pub(crate) fn glossy(&self) -> usize {
        self.scene
            .materials
            .iter()
            .filter(|m| m.is_glossy())
            .count()
    }
}

impl PipelineDecl {
    /// The stage named `name`.
    pub fn stage(&self, name: &str) -> Option<&StageDecl> {
        self.stages.iter().find(|s| s.name == name)
    }

    /// The stage names, in frame order.
    pub fn stage_names(&self) -> Vec<&'static str> {
        self.stages.iter().map(|s| s.name).collect()
    }

    /// That a chain's `(stage, kernel)` list, in recording order, runs declared stages with their
    /// declared kernels, the volume's before the camera's: every [`Reuse::Geometry`] stage before
    /// every [`Reuse::Lights`] one, and those before the [`Reuse::Camera`] stages. A reused frame
    /// then re-runs one contiguous range of passes: from the first `Lights` stage when the lights
    /// moved, from the first `Camera` stage when only the camera did. (Within the volume a stage may
    /// repeat: lrsm records each light view's RSM and LRSM in turn.)
    pub fn check_chain<'s>(
        &self,
        chain: impl IntoIterator<Item = (&'s str, &'s str)>,
    ) -> Result<()> {
        let mut last: Option<&StageDecl> = None;
        for (stage, kernel) in chain {
            let Some(s) = self.stage(stage) else {
                anyhow::bail!(
                    "{}'s chain records stage `{stage}`, which its declaration does not have (stages: {})",
                    self.name,
                    self.stage_names().join(", ")
                );
            };
            anyhow::ensure!(
                s.kernels.iter().any(|k| k.name == kernel),
                "{}'s chain records kernel `{kernel}` in stage `{stage}`, which declares {}",
                self.name,
                s.kernels
                    .iter()
                    .map(|k| k.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            if let Some(l) = last {
                anyhow::ensure!(
                    s.reuse >= l.reuse,
                    "{}'s chain records stage `{stage}` ({:?}) after `{}` ({:?}): the volume's stages come first",
                    self.name,
                    s.reuse,
                    l.name,
                    l.reuse
                );
            }
            last = Some(s);
        }
        Ok(())
    }
}
