//! Quality presets: `[render] quality = "fast" | "balanced" | "accurate"` (`--quality`), each a point
//! of a pipeline's measured time/error front (docs/accuracy/presets.md has the table and how each
//! point was chosen). A preset sets only the keys the scene file and the command line leave out:
//! an explicit key always wins. `balanced` is the defaults with narrower interleaved cones for the
//! per-pixel cone tracers (cprc: the defaults).
use crate::render::Pipeline;
use crate::scene::{RenderSettings, Scene};
use serde::Deserialize;

/// A quality preset.
#[derive(
    Clone, Copy, Debug, Default, Deserialize, serde::Serialize, PartialEq, Eq, clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Quality {
    /// Half the voxel resolution: the frame's volume an eighth of the default's (lrsm: with its
    /// balanced cones).
    Fast,
    /// The defaults with two interleaved 5-degree cones a pixel (vct-dense, vct-svo, lrsm; lrsm with
    /// the lit cells); cprc: the defaults.
    #[default]
    Balanced,
    /// The settings that reach combined FLIP < 0.1 on the Cornell box against the converged
    /// reference (vct-dense, vct-svo: narrow interleaved cones; cprc: finer caches), 2 x 2 samples
    /// per pixel (lrsm: its balanced cones with those samples).
    Accurate,
}

impl Quality {
    pub fn name(self) -> &'static str {
        match self {
            Quality::Fast => "fast",
            Quality::Balanced => "balanced",
            Quality::Accurate => "accurate",
        }
    }
}

/// A `[render]` value a preset sets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    U32(u32),
    F32(f32),
    Bool(bool),
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::U32(v) => write!(f, "{v}"),
            Value::F32(v) => write!(f, "{v}"),
            Value::Bool(v) => write!(f, "{v}"),
        }
    }
}

/// The per-pixel cone tracers' `balanced` cones: two of 5 degrees a pixel from an 8 x 8
/// interleaved pattern (128 directions a neighbourhood) with the narrow-cone level bias, where the
/// `[render]` defaults trace five of 30 degrees. Chosen for lrsm on the Cornell box, thin_wall and
/// Sponza, then measured unchanged for vct-dense and vct-svo on six scenes: lower combined FLIP on
/// every one (vct-dense on the Cornell box 0.238 -> 0.142, vct-svo 0.236 -> 0.128) for 3-71% more
/// time (docs/accuracy/presets.md). Not cprc's: its caches' cones are its own, and the level bias
/// alone makes thin_wall worse (0.177 -> 0.203).
const NARROW_CONES: [(&str, Value); 4] = [
    ("cones", Value::U32(2)),
    ("cone_half_angle", Value::F32(5.0)),
    ("cone_interleave", Value::U32(8)),
    ("cone_level_bias", Value::F32(-1.25)),
];

/// lrsm's cones in every preset: [`NARROW_CONES`], each sample's light from the lit cells, and the
/// area-weighted LRSM where a scene turns the lit cells off (docs/accuracy/lrsm.md). With the
/// `[render]` defaults' five 30-degree cones a sample spans coarse levels: the LRSMs' filtered
/// depth moments and radiance mix the surfaces of a wide footprint (light straddling thin_wall's
/// wall, leak 0.135), and the lit cells gather 0.41 of the Cornell box's indirect energy (its
/// coarse samples near the cone's start are opaque and culled); narrow cones read fine levels. The other cone
/// tracers' `accurate` set (16 cones of 2.5 degrees a pixel) passes lavapipe's loop limit by 8x
/// with the LRSMs: a march step reads up to three cube faces' layers.
fn lrsm_cones() -> Vec<(&'static str, Value)> {
    [
        NARROW_CONES.as_slice(),
        &[
            ("lrsm_lit_cells", Value::Bool(true)),
            ("lrsm_area_weights", Value::Bool(true)),
        ],
    ]
    .concat()
}

/// The keys `quality` sets for `pipeline`, in `[render]`'s names.
pub fn preset(quality: Quality, pipeline: Pipeline) -> Vec<(&'static str, Value)> {
    use Value::{F32, U32};
    match (quality, pipeline) {
        // lrsm: every preset narrows the cones and reads the lit cells.
        (Quality::Fast, Pipeline::Lrsm) => [lrsm_cones(), vec![("voxels", U32(64))]].concat(),
        (Quality::Balanced, Pipeline::Lrsm) => lrsm_cones(),
        (Quality::Accurate, Pipeline::Lrsm) => {
            [lrsm_cones(), vec![("supersample", U32(2))]].concat()
        }
        (Quality::Balanced, Pipeline::VctDense | Pipeline::VctSvo) => NARROW_CONES.to_vec(),
        (Quality::Balanced, Pipeline::Cprc) => Vec::new(),
        (Quality::Fast, _) => vec![("voxels", U32(64))],
        // scenes/cornell_box_fine_caches.toml: four times the caches, 32^2 texels (one ~2.5 degree
        // cone each), a 4^2 irradiance map, narrow-cone level bias, a tighter mip clamp.
        (Quality::Accurate, Pipeline::Cprc) => vec![
            ("cache_tile", U32(4)),
            ("gather_radius", F32(1.5)),
            ("cache_resolution", U32(32)),
            ("irradiance_resolution", U32(4)),
            ("cone_level_bias", F32(-1.25)),
            ("mip_clamp", F32(1.5)),
            ("supersample", U32(2)),
        ],
        // scenes/cornell_box_interleaved.toml: 16 cones of 2.5 degrees from an 8 x 8 interleaved
        // pattern (1024 per neighbourhood), narrow-cone level bias.
        (Quality::Accurate, _) => vec![
            ("cones", U32(16)),
            ("cone_half_angle", F32(2.5)),
            ("cone_interleave", U32(8)),
            ("cone_level_bias", F32(-1.25)),
            ("supersample", U32(2)),
        ],
    }
}

fn set(r: &mut RenderSettings, key: &str, v: Value) {
    match (key, v) {
        ("voxels", Value::U32(x)) => r.voxels = x,
        ("cones", Value::U32(x)) => r.cones = x,
        ("cone_half_angle", Value::F32(x)) => r.cone_half_angle = x,
        ("cone_interleave", Value::U32(x)) => r.cone_interleave = x,
        ("cone_level_bias", Value::F32(x)) => r.cone_level_bias = x,
        ("supersample", Value::U32(x)) => r.supersample = x,
        ("cache_tile", Value::U32(x)) => r.cache_tile = x,
        ("gather_radius", Value::F32(x)) => r.gather_radius = x,
        ("cache_resolution", Value::U32(x)) => r.cache_resolution = x,
        ("irradiance_resolution", Value::U32(x)) => r.irradiance_resolution = x,
        ("mip_clamp", Value::F32(x)) => r.mip_clamp = x,
        ("lrsm_area_weights", Value::Bool(x)) => r.lrsm_area_weights = x,
        ("lrsm_lit_cells", Value::Bool(x)) => r.lrsm_lit_cells = x,
        _ => unreachable!("a preset sets `{key}` = {v}, which `set` does not know"),
    }
}

/// `scene` with its quality preset applied for `pipeline` (the keys the scene file and the command
/// line gave, `Scene::explicit_render`, are kept), and what the preset set, as `key = value` lines
/// (those an explicit key overrode marked so).
pub fn resolved(scene: &Scene, pipeline: Pipeline) -> Result<(Scene, Vec<String>), String> {
    let mut s = scene.clone();
    let mut said = Vec::new();
    for (key, v) in preset(scene.render.quality, pipeline) {
        if scene.explicit_render.contains(key) {
            said.push(format!(
                "{key}: kept as given (the preset's {v} not applied)"
            ));
        } else {
            set(&mut s.render, key, v);
            said.push(format!("{key} = {v}"));
        }
    }
    s.render.validate()?;
    Ok((s, said))
}

/// lavapipe stops a loop silently past this many iterations in all per invocation.
pub const LOOP_LIMIT: u64 = 65535;

/// The most steps one cone of half-angle tangent `tan` takes through a grid of `side` voxels
/// (kernels/common/cone_march.wgsl: the diameter starts at 0.75 s0 and grows by `1 + 2 step tan`
/// each step, the distance by `step` diameters, until sqrt(3) side s0), one more for rounding.
/// Both logarithms by `ln_1p`, so that a cone too narrow for `1 + x` to differ from 1 in f64 still
/// counts (their ratio tends to the linear march's `L / (0.75 step)`); saturating, never overflowing.
pub fn march_steps(side: u32, tan: f32, step: f32) -> u64 {
    let (tan, step) = (tan as f64, step as f64);
    let grow = 2.0 * tan * (side as f64 * 3f64.sqrt()) / 0.75;
    let steps = (grow.ln_1p() / (2.0 * step * tan).ln_1p()).ceil();
    // `as` saturates (NaN to 0: a zero angle or step, which validation refuses).
    (steps as u64).saturating_add(1)
}

/// The smallest `cone_step` (in cone diameters) a scene may set. Each step's opacity is the
/// sample's corrected for the step, `1 - (1 - a)^(step / cell)`, and WGSL's `pow` is only as accurate
/// as `exp2(y * log2(x))`: `log2`'s absolute error near 1 (2^-21) is of the order of a short step's
/// whole opacity, which then rounds away. On lavapipe the GPU's Cornell box keeps 0.998 of its
/// indirect energy at a step of 0.01 diameters, 0.25 at 0.003 and 0.009 at 0.001, where the mirror's
/// frame keeps it all; 2^-6 keeps a margin above the first. (The march distance's own f32 rounding
/// stops mattering two orders of magnitude lower.)
pub const MIN_CONE_STEP: f32 = 1.0 / 64.0;

/// The hierarchies one march step of the instanced kernels (cone_trace_instanced,
/// cache_creation_instanced) reads for `scene` as it stands: those its sample's cell lists
/// (`cache_creation::placed_cells`, what the frame uploads), in the cell that lists the most
/// (`cache_creation::sample_iterations`); `None` where a step reads one volume (no instances, or a
/// pipeline that flattens them). Counted where the instances stand now: keyframes that crowd them
/// later raise it.
pub fn placed_hierarchies(scene: &Scene, pipeline: Pipeline) -> Option<u64> {
    if scene.instances.list.is_empty() || !matches!(pipeline, Pipeline::VctDense | Pipeline::Cprc) {
        return None;
    }
    let (_, parts) = crate::render::hierarchy_parts(scene);
    let frames: Vec<_> = parts
        .iter()
        .map(|(mesh, side, _)| crate::kernels::voxelize::frame_of(mesh, *side))
        .collect();
    let at = crate::pipeline::placement(scene, &frames).expect("one grid frame per hierarchy");
    let cells = vxgi_cpu_mirror::cache_creation::placed_cells(&at.placed);
    Some(vxgi_cpu_mirror::cache_creation::sample_iterations(&cells) as u64)
}

/// lavapipe's count of a loop that runs `n` times: its iterations and the test that exits it.
const fn looped(n: u64) -> u64 {
    n + 1
}

/// The most loop iterations one step of `pipeline`'s cone march runs on `scene` (its settings as
/// resolved), every loop of the step counted as lavapipe counts them (one shared counter, a loop
/// of n iterations counting n + 1 with its exit test), read from the kernels' WGSL:
/// - the march's own `while` (common/cone_march.wgsl, lrsm_cone_trace.wgsl): 1;
/// - a quadrilinear sample of a dense pyramid (vct-dense, cprc, and lrsm's occlusion voxels): two
///   levels of 8 trilinear corners (common/pyramid_grid.wgsl `sample_grid`, lrsm_cone_trace.wgsl's
///   occlusion level; the depth-ordered blend's 4 corner pairs take fewer);
/// - with `[[instances]]` (vct-dense, cprc: common/placed_pyramids.wgsl) the cell's list of `h`
///   hierarchies ([`placed_hierarchies`]), each sampled so;
/// - vct-svo (svo_cone_trace.wgsl `sample_cone`): the descent to the finer level's node (`find`,
///   up to `depth` levels) and, where it is missing, to the coarser one's (`depth - 1`), then two
///   levels of 8 corners;
/// - lrsm with the lit cells (lrsm_cone_trace.wgsl `lit_volume`): the occlusion sample and the lit
///   cells', two levels of 8 cells;
/// - lrsm with the LRSMs (lrsm_cone_trace.wgsl `sample_cone`): the occlusion sample, the loop over the light
///   views, and in every view the sample lies in front of (a bound: a wide sample's disc may
///   overlap several; of a point light's six cube faces at most three) the taps
///   (common/lrsm_sample.wgsl `lrsm_taps`: the levels below the fetched one, 2 levels of 4 taps)
///   and Algorithm 1 (its depth slices, their normal slices, and per layer three 8-tap fetches).
///
/// Checked on lavapipe: vct-svo at 64^3 (depth 5, 63 steps a cone of 2.5 degrees) departs from its
/// mirror from 38 cones on and agrees up to 36; this bound (30 a step) allows 34.
pub fn step_iterations(scene: &Scene, pipeline: Pipeline) -> u64 {
    let r = &scene.render;
    let quadrilinear = 2 * looped(8);
    match pipeline {
        Pipeline::VctDense | Pipeline::Cprc => match placed_hierarchies(scene, pipeline) {
            None => 1 + quadrilinear,
            Some(h) => 1 + looped(h) + h * quadrilinear,
        },
        Pipeline::VctSvo => {
            let depth = vxgi_cpu_mirror::sparse_voxel_octree::depth_for(r.voxels) as u64;
            1 + looped(depth) + looped(depth.saturating_sub(1)) + quadrilinear
        }
        // The lit cells: the occlusion sample and the lit cells' own (two levels of 8 cells).
        Pipeline::Lrsm if r.lrsm_lit_cells => 1 + 2 * quadrilinear,
        Pipeline::Lrsm => {
            // A cube's faces come in opposite pairs and a sample lies in front of (zv > 0) at most
            // one of each pair: 3 of a point light's 6 views are sampled, the loop runs over all.
            let views = crate::plan::light_views(scene) as u64;
            let sampled: u64 = scene
                .lights
                .iter()
                .map(|l| match crate::plan::views_of(l) {
                    6 => 3,
                    v => v as u64,
                })
                .sum();
            let levels = (r.rsm_side / 2).max(1).trailing_zeros() as u64 + 1;
            let taps = looped(levels) + looped(2) + 2 * looped(4);
            let (ds, ns) = (
                r.lrsm_depth_splits as u64 + 1,
                r.lrsm_normal_splits as u64 + 1,
            );
            let algorithm_1 = looped(ds) + ds * looped(ns) + ds * ns * 3 * looped(8);
            1 + quadrilinear + looped(views) + sampled * (taps + algorithm_1)
        }
    }
}

/// The worst case of loop iterations in one invocation of the kernels whose loops the settings
/// size, for `pipeline` on `scene` (its settings as resolved): per pixel, every diffuse cone's march
/// (each step [`step_iterations`]), the glossy cone's where a material has Ks (its narrowest
/// aperture, tan 0.02), and the interleaved resolve's (2N - 1)^2 neighbours (vct-dense, vct-svo,
/// lrsm); lrsm's shadow cones (their own entry) where `shadow_cone_angle` traces them; cprc the
/// largest of a cache texel's march, a pre-convolved texel's sum over the cache (res^2 texels) and
/// the gather's caches (the tiles within its radius, at most 3 x slices caches and no more than
/// pixels each). Not counted: data-dependent loops (the BVH's traversal).
pub fn loop_iterations(scene: &Scene, pipeline: Pipeline) -> u64 {
    let r = &scene.render;
    let side = r.voxels;
    let per_step = step_iterations(scene, pipeline);
    match pipeline {
        Pipeline::Cprc => {
            let s = crate::cprc::CprcSettings::from(r);
            let tan = vxgi_cpu_mirror::cache_creation::cone_tan(s.res);
            let creation = march_steps(side, tan, r.cone_step).saturating_mul(per_step);
            let preconvolve = (s.res * s.res) as u64;
            let reach = s.radius_px.div_ceil(s.tile) as u64;
            let per_tile = (3 * s.slices as u64).min((s.tile * s.tile) as u64);
            let gather = (2 * reach + 1).pow(2) * per_tile;
            creation.max(preconvolve).max(gather)
        }
        _ => {
            let tan = r.cone_half_angle.to_radians().tan();
            let glossy = if scene.materials.iter().any(|m| m.is_glossy()) {
                march_steps(side, 0.02, r.cone_step)
            } else {
                0
            };
            let steps = (r.cones as u64)
                .saturating_mul(march_steps(side, tan, r.cone_step))
                .saturating_add(glossy);
            let marches = steps
                .saturating_mul(per_step)
                .saturating_add(looped(r.cones as u64));
            let n = r.cone_interleave as u64;
            let gather = marches + (2 * n - 1).pow(2);
            if pipeline == Pipeline::Lrsm && r.shadow_cone_angle > 0.0 {
                // One shadow cone per light, each step an occlusion sample.
                let shadow_tan = r.shadow_cone_angle.to_radians().tan();
                let shadow = (scene.lights.len() as u64)
                    .saturating_mul(march_steps(side, shadow_tan, r.cone_step))
                    .saturating_mul(1 + 2 * looped(8));
                gather.max(shadow)
            } else {
                gather
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn march_steps_follow_the_marchs_growth() {
        // 30 degree cones through 128^3: the diameter grows 1.577x a step, 13 steps reach the far
        // corner; 2.5 degrees: 77.
        assert_eq!(march_steps(128, 30f32.to_radians().tan(), 0.5), 14);
        assert_eq!(march_steps(128, 2.5f32.to_radians().tan(), 0.5), 78);
        // The march itself, stepped as the kernel steps it, never takes more.
        for (side, deg, step) in [
            (128, 30.0f32, 0.5f32),
            (64, 2.5, 0.5),
            (256, 10.0, 0.25),
            (32, 1.0, 1.0),
        ] {
            let tan = deg.to_radians().tan();
            let (s0, grow) = (1.0f32, 1.0 + 2.0 * step * tan);
            let max_dist = side as f32 * s0 * 1.7320508;
            let (mut diam, mut t, mut n) = (0.75 * s0, 0.75 * s0 * 0.5 * step, 0u64);
            while t <= max_dist {
                n += 1;
                t += diam * step;
                diam *= grow;
            }
            assert!(
                n <= march_steps(side, tan, step),
                "{side} {deg} {step}: {n}"
            );
        }
    }

    #[test]
    fn instanced_marches_count_the_hierarchies_each_step_reads() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let scene = Scene::load(root.join("instances.toml")).unwrap();
        let flat = Scene {
            instances: Default::default(),
            ..scene.clone()
        };
        for p in [Pipeline::VctDense, Pipeline::Cprc] {
            // The room and two boxes: at most the three hierarchies in a cell, each sampled as the
            // one volume of the flat scene is.
            let h = placed_hierarchies(&scene, p).unwrap();
            assert!((1..=3).contains(&h), "{p:?}: {h}");
            let (one, placed) = (step_iterations(&flat, p), step_iterations(&scene, p));
            assert_eq!(placed, 1 + (h + 1) + h * (one - 1), "{p:?}");
            assert!(
                loop_iterations(&scene, p) >= loop_iterations(&flat, p),
                "{p:?}"
            );
        }
        // vct-svo and lrsm march one volume whatever the instances.
        assert_eq!(placed_hierarchies(&scene, Pipeline::Lrsm), None);
        assert_eq!(placed_hierarchies(&flat, Pipeline::VctDense), None);
    }

    /// The count is an upper bound where lavapipe shows the limit: vct-svo on the Cornell box at
    /// 64^3 with cones of 2.5 degrees departs from its mirror from 38 cones on (its marches cut
    /// short) and agrees at 36 (`vxgi bisect SCENE --pipeline vct-svo --voxels 64 --cones N
    /// --cone-half-angle 2.5` at 64x64). Every count that lavapipe cuts must be past the limit, and
    /// the defaults well below it.
    #[test]
    fn the_count_bounds_what_lavapipe_cuts() {
        let mut scene = Scene::cornell_box();
        scene.render.voxels = 64;
        scene.render.cone_half_angle = 2.5;
        scene.render.cones = 38;
        let cut = loop_iterations(&scene, Pipeline::VctSvo);
        assert!(cut > LOOP_LIMIT, "{cut}");
        scene.render.cones = 16;
        let fine = loop_iterations(&scene, Pipeline::VctSvo);
        assert!(fine < LOOP_LIMIT / 2, "{fine}");
        for p in Pipeline::ALL {
            let loops = loop_iterations(&Scene::cornell_box(), p);
            assert!(loops < LOOP_LIMIT / 2, "{p:?}: {loops}");
        }
    }

    #[test]
    fn explicit_keys_override_the_preset_and_the_file_can_name_one() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        // The interleaved scene gives voxels, cones, the cone angle, interleave, level bias and
        // supersample: fast's voxels = 64 does not apply.
        let mut scene = Scene::load(root.join("cornell_box_interleaved.toml")).unwrap();
        scene.render.quality = Quality::Fast;
        let (s, said) = resolved(&scene, Pipeline::VctDense).unwrap();
        assert_eq!(s.render.voxels, 128);
        assert!(said[0].contains("kept as given"), "{said:?}");
        // The fine-caches scene under accurate for cprc: every key it sets was given already, so
        // the settings stay as the file has them.
        let mut fine = Scene::load(root.join("cornell_box_fine_caches.toml")).unwrap();
        fine.render.quality = Quality::Accurate;
        let (s, _) = resolved(&fine, Pipeline::Cprc).unwrap();
        assert_eq!(s.render, fine.render);
        // A file naming a preset.
        let dir = std::env::temp_dir().join(format!("vxgi-quality-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let toml = std::fs::read_to_string(root.join("cornell_box.toml"))
            .unwrap()
            .replace(
                "\"cornell_box.obj\"",
                &format!("{:?}", root.join("cornell_box.obj").display().to_string()),
            )
            + "\n[render]\nquality = \"accurate\"\n";
        std::fs::write(dir.join("q.toml"), toml).unwrap();
        let q = Scene::load(dir.join("q.toml")).unwrap();
        assert_eq!(q.render.quality, Quality::Accurate);
        let (s, _) = resolved(&q, Pipeline::VctDense).unwrap();
        assert_eq!((s.render.cones, s.render.cone_interleave), (16, 8));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn every_preset_sets_only_keys_it_knows_and_validates() {
        for q in [Quality::Fast, Quality::Balanced, Quality::Accurate] {
            for p in Pipeline::ALL {
                let mut scene = Scene::cornell_box();
                scene.render.quality = q;
                let (s, said) = resolved(&scene, p).unwrap();
                assert_eq!(said.len(), preset(q, p).len());
                let loops = loop_iterations(&s, p);
                assert!(loops < LOOP_LIMIT, "{q:?} {p:?}: {loops} iterations");
                if q == Quality::Balanced && p == Pipeline::Cprc {
                    assert_eq!(s.render, scene.render);
                }
            }
        }
    }

    /// The step count never overflows or shrinks as a cone narrows: narrower cones grow more slowly and take more steps, down to the
    /// linear march's L / (0.75 step) as the angle goes to 0.
    #[test]
    fn march_steps_grow_as_cones_narrow_and_never_overflow() {
        let mut last = 0;
        for tan in [
            1.0f32,
            0.1,
            1e-3,
            1e-6,
            1e-12,
            1e-30,
            1e-40,
            f32::MIN_POSITIVE / 4.0,
        ] {
            let n = march_steps(128, tan, 0.5);
            assert!(n >= last, "tan {tan}: {n} steps < {last} for a wider cone");
            last = n;
        }
        // The linear march's limit: sqrt(3) 128 / (0.75 * 0.5) = 591.2 -> 592, + 1.
        assert_eq!(march_steps(128, 1e-40, 0.5), 593);
        // The smallest valid step and an f32 subnormal angle: large, finite, no overflow.
        let n = march_steps(512, 1e-45, MIN_CONE_STEP);
        assert!(n > LOOP_LIMIT && n < u64::MAX, "{n}");
    }
}
