//! The `vxgi` command line: `vxgi verify` runs every declared kernel GPU vs mirror.
use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use vxgi::harness::{kernel::verify, run::copy_bandwidth, GpuContext, VerifyOptions};
use vxgi::images::{read_exr, write_frame, write_heatmap, RgbImage};
use vxgi::kernels::cone_trace::ConeSettings;
use vxgi::render::Pipeline;

#[derive(Parser)]
#[command(
    name = "vxgi",
    version,
    about = "Voxel GI kernels, verified GPU vs scalar mirror"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run every declared kernel (or one) on generated cases, GPU vs mirror, and print a table.
    Verify {
        /// Only this kernel.
        #[arg(long)]
        kernel: Option<String>,
        /// Generated cases per kernel.
        #[arg(long, default_value_t = 48)]
        cases: usize,
        /// Seed of the case generator (a failing case names its seed).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Replay only generated case N (of each kernel, or of --kernel) and print every output's
        /// report, worst elements included, pass or fail: a failure's "reproduce:" line names it.
        #[arg(long, conflicts_with = "cases")]
        case: Option<usize>,
    },
    /// List the declared kernels with their WGSL files and mirrors.
    List,
    /// What each kernel needs of a device (from naga reflection: storage buffers per stage, bind
    /// groups, workgroup size) and which pipelines run within WebGPU's default limits.
    Limits,
    /// Write a kernel as one self-contained WGSL file for another renderer: its kernels/common/
    /// includes composed in, under a header naming its mirror, entry point, workgroup size and every
    /// binding (group, slot, access, type, byte layout) from naga reflection. Validated first.
    Export {
        /// The kernel (`vxgi list` names them), or `all` (needs --out DIR: DIR/<name>.wgsl each).
        kernel: String,
        /// The file to write (default: standard output), or the folder for `all`.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Load a scene file (default: the built-in Cornell box), check it and print what it holds.
    Scene {
        /// A TOML scene file (see docs/scenes.md).
        path: Option<std::path::PathBuf>,
    },
    /// Render a scene on the GPU into --out: direct, indirect, combined, ao (.exr linear + .png sRGB).
    Render {
        /// A TOML scene file (default: the built-in Cornell box).
        scene: Option<PathBuf>,
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Which pipeline renders indirect light and AO.
        #[arg(long, value_enum, default_value_t = Pipeline::VctDense)]
        pipeline: Pipeline,
        /// Print the frame plan (what runs, what is skipped and why) and exit.
        #[arg(long)]
        plan: bool,
        /// Render this many frames (into DIR/frame_000, ...): frame k has the scene's dynamic
        /// instances at their keyframes' transform of frame k and the camera orbited k x --orbit
        /// degrees; a frame whose geometry did not change reuses the last one's voxel volume (the
        /// planner's reuse rule).
        #[arg(long, default_value_t = 1)]
        frames: u32,
        /// Degrees the camera orbits about its target between frames.
        #[arg(long, default_value_t = 10.0)]
        orbit: f32,
        #[command(flatten)]
        render: RenderFlags,
    },
    /// A window drawing the pipeline's GPU-resident frames continuously. Mouse: left drag orbits,
    /// right drag pans, the wheel zooms; keys: W A S D Q E fly, 1-4 or Tab switch the pipeline, V
    /// the view (combined, direct, indirect, AO), [ ] the cone count, - = the voxel grid, the arrow
    /// keys and PageUp/PageDown move the first light, P plays the instances' keyframes, H hides the
    /// overlay, Esc quits. Without a display: `xvfb-run -a vxgi view --frames N --screenshot F.png`.
    #[cfg(feature = "view")]
    View {
        /// A TOML scene file (default: the built-in Cornell box).
        scene: Option<PathBuf>,
        #[arg(long, value_enum, default_value_t = Pipeline::VctDense)]
        pipeline: Pipeline,
        /// Timed actions, a file or inline, one per line or `;`-separated: `FRAME ACTION ARGS`
        /// with the actions orbit YAW [PITCH], pan X Y, zoom F, fly FORWARD RIGHT UP, pipeline
        /// NAME, view combined|direct|indirect|ao, cones N, voxels N, light DX DY DZ, resize W H,
        /// play, pause, overlay on|off (e.g. "1 orbit 20; 2 pipeline lrsm; 3 light 0.1 0 0").
        #[arg(long)]
        script: Option<String>,
        /// Stop after this many frames (a scripted run: other input is ignored).
        #[arg(long)]
        frames: Option<u32>,
        /// Write the last presented frame (with --frames) to this PNG.
        #[arg(long, requires = "frames")]
        screenshot: Option<PathBuf>,
        /// Write frames.csv (vxgi render's counters per frame) and overlay.txt here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Start with the overlay hidden.
        #[arg(long)]
        no_overlay: bool,
        #[command(flatten)]
        render: RenderFlags,
    },
    /// CPU Monte Carlo reference (direct + one bounce, AO) into --out: direct, indirect, combined, ao
    /// as .exr (linear) and .png (sRGB preview).
    Reference {
        /// A TOML scene file (default: the built-in Cornell box).
        scene: Option<PathBuf>,
        /// Samples per pixel.
        #[arg(long, default_value_t = 64)]
        spp: u32,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Every sample through the pixel centre (no anti-aliasing): for comparing conventions.
        #[arg(long)]
        no_jitter: bool,
        /// The indirect image from ideal cones instead of Monte Carlo: the [render] cone set
        /// (--cones, --cone-half-angle; with --cone-interleave N the N^2 classes' whole set) with
        /// exact visibility and radiance, this many stratified rays per cone. Compared with the Monte Carlo reference it measures the cone set's own error;
        /// with a render, the voxels'.
        #[arg(long, value_name = "RAYS")]
        ideal_cones: Option<u32>,
        /// With --ideal-cones: the cone set this pipeline's frame traces, its quality preset
        /// resolved as `vxgi render --pipeline` resolves it (`balanced` narrows the cone tracers'
        /// cones). Without it, the `[render]` keys as the scene file and the flags give them.
        #[arg(long, value_enum, requires = "ideal_cones")]
        pipeline: Option<Pipeline>,
        #[arg(long, default_value = "reference")]
        out: PathBuf,
        #[command(flatten)]
        render: RenderFlags,
    },
    /// Render scenes with every pipeline and the reference; print the table and write report.md.
    Report {
        /// Scene files, or built-in names (cornell_box, thin_wall). Default: both built-ins.
        #[arg(long, num_args = 1..)]
        scenes: Vec<String>,
        /// Reference samples per pixel.
        #[arg(long, default_value_t = 64)]
        spp: u32,
        #[arg(long, default_value = "report")]
        out: PathBuf,
        #[command(flatten)]
        temporal: TemporalArgs,
    },
    /// Run time against error: sweep voxels, cone count and aperture, mip clamp on a scene; each
    /// configuration rendered and compared with one Monte Carlo reference. Writes bench.csv, bench.md
    /// and bench.svg (time vs combined FLIP, Pareto front) into --out.
    Bench {
        /// A TOML scene file (default: the built-in Cornell box).
        scene: Option<PathBuf>,
        /// 4 configurations instead of 54, reference at 8 spp unless --spp says otherwise (for CI).
        #[arg(long)]
        quick: bool,
        /// Reference samples per pixel [default 64, 8 with --quick].
        #[arg(long)]
        spp: Option<u32>,
        /// Compare against this reference directory (its combined.exr and indirect.exr, the scene
        /// camera's size; e.g. references/cornell_box_256_4096spp) instead of rendering one at --spp
        /// (the planner row still renders its own view's at --spp).
        #[arg(long)]
        reference: Option<PathBuf>,
        #[arg(long, default_value = "bench")]
        out: PathBuf,
        /// Which pipeline the sweep renders.
        #[arg(long, value_enum, default_value_t = Pipeline::VctDense)]
        pipeline: Pipeline,
        /// The keys the sweep does not vary (e.g. --ao-range) apply to every configuration.
        #[command(flatten)]
        render: RenderFlags,
        #[command(flatten)]
        temporal: TemporalArgs,
    },
    /// The bisection switch (every pipeline): render the frame with its first stages on the scalar mirrors
    /// and the rest on the GPU, at every split, and print how far each is from the all-mirror frame
    /// (the first split that departs names the kernel to look at). With --mirror-until, render that
    /// one split into --out instead.
    Bisect {
        /// A TOML scene file (default: the built-in Cornell box).
        scene: Option<PathBuf>,
        /// Run the mirrors up to and including this stage (vct-dense: gbuffer, direct_light, voxelize,
        /// voxel_light, surface_coverage_mip, cone_trace; vct-svo: ... svo_photons or voxel_light,
        /// sparse_voxel_octree, svo_anisotropic, svo_cone_trace; lrsm: ... occlusion_voxels,
        /// reflective_shadow_map, lrsm_partition, lrsm_cone_trace; cprc: ... cache_distribution,
        /// cache_creation), the GPU after it; write the frame to --out.
        #[arg(long)]
        mirror_until: Option<String>,
        /// Which pipeline's frame.
        #[arg(long, value_enum, default_value_t = Pipeline::VctDense)]
        pipeline: Pipeline,
        #[arg(long, default_value = "bisect")]
        out: PathBuf,
        #[command(flatten)]
        render: RenderFlags,
    },
    /// Where lrsm's light goes: its mirror frame with each cone sample's occlusion and radiance
    /// swapped, one factor at a time, for vct-dense's voxels' or for variants of Algorithm 1; each
    /// row's indirect energy and FLIP against a reference. Writes factors.md and each row's images.
    LrsmFactors {
        /// A TOML scene file (default: the built-in Cornell box).
        scene: Option<PathBuf>,
        /// The reference directory (its indirect.exr and combined.exr at the scene camera's size,
        /// e.g. references/cornell_box_256_4096spp); without it one is rendered at --spp.
        #[arg(long)]
        reference: Option<PathBuf>,
        /// Reference samples per pixel when no --reference is given.
        #[arg(long, default_value_t = 256)]
        spp: u32,
        #[arg(long, default_value = "lrsm-factors")]
        out: PathBuf,
        /// Only the rows whose name contains this text.
        #[arg(long)]
        rows: Option<String>,
        #[command(flatten)]
        render: RenderFlags,
    },
    /// Temporal stability: each pipeline's frames over a motion (a slow orbit, a moving light, the
    /// scene's instance animation) against the ideal cones' frames; per pipeline and motion the mean
    /// frame-to-frame change the pipeline adds beyond the reference's (docs/temporal.md defines it)
    /// and frame 0's combined FLIP against the path-traced reference. Writes temporal.md,
    /// temporal.csv and temporal.svg (per step) into --out.
    Temporal {
        /// A TOML scene file (default: the built-in Cornell box).
        scene: Option<PathBuf>,
        /// The pipelines measured (default: all four).
        #[arg(long, value_enum, num_args = 1..)]
        pipelines: Vec<Pipeline>,
        /// Frames per motion.
        #[arg(long, default_value_t = 8)]
        frames: u32,
        /// Camera orbit per frame, degrees (0: no orbit row).
        #[arg(long, default_value_t = 0.25)]
        orbit: f32,
        /// Light motion per frame: point and spot lights move this far along x, directional ones
        /// turn this many degrees (0: no light row).
        #[arg(long, default_value_t = 0.01)]
        light_step: f32,
        /// Rays per cone of the ideal-cones reference.
        #[arg(long, default_value_t = 64)]
        rays: u32,
        /// Samples per pixel of the path-traced reference of frame 0 (the FLIP column).
        #[arg(long, default_value_t = 64)]
        spp: u32,
        /// Also measure the reference against one with 4x the rays (its own floor).
        #[arg(long)]
        check_reference: bool,
        #[arg(long, default_value = "temporal")]
        out: PathBuf,
        #[command(flatten)]
        render: RenderFlags,
    },
    /// Compare a test image against a reference: relative MSE and mean LDR-FLIP, optional heat map.
    Compare {
        reference: PathBuf,
        test: PathBuf,
        /// Write the FLIP error map (magma) here as PNG.
        #[arg(long)]
        heatmap: Option<PathBuf>,
    },
}

/// `vxgi report` and `vxgi bench`: the orbit over which each frame's temporal instability is
/// measured (docs/temporal.md).
#[derive(clap::Args, Clone, Debug)]
struct TemporalArgs {
    /// Also measure the temporal instability over this many frames of a camera orbit (0: not
    /// measured; the ideal-cone reference frames cost seconds each on the CPU).
    #[arg(long, default_value_t = 0)]
    temporal_frames: u32,
    /// Degrees the orbit turns per frame.
    #[arg(long, default_value_t = 0.25)]
    temporal_orbit: f32,
    /// Rays per cone of the ideal-cone reference frames (their own floor: about 0.005 at 1024).
    #[arg(long, default_value_t = 1024)]
    temporal_rays: u32,
}

impl TemporalArgs {
    fn orbit(&self) -> Result<Option<vxgi::temporal::Orbit>> {
        match self.temporal_frames {
            0 => Ok(None),
            1 => bail!("--temporal-frames must be 0 (off) or at least 2"),
            frames => {
                if !self.temporal_orbit.is_finite() || self.temporal_rays == 0 {
                    bail!("--temporal-orbit must be finite and --temporal-rays at least 1");
                }
                Ok(Some(vxgi::temporal::Orbit {
                    frames,
                    degrees: self.temporal_orbit,
                    rays: self.temporal_rays,
                }))
            }
        }
    }
}

/// Flags overriding the scene file's `[render]` keys (same names).
#[derive(clap::Args, Clone, Debug, Default)]
struct RenderFlags {
    /// A quality preset: fast, balanced (the default: narrower interleaved cones than the
    /// `[render]` defaults for vct-dense, vct-svo and lrsm) or accurate; the keys it sets apply
    /// where the scene file and the other flags give none (docs/accuracy/presets.md).
    #[arg(long, value_enum)]
    quality: Option<vxgi::quality::Quality>,
    /// Voxel grid side (power of two, 8..=512).
    #[arg(long, alias = "voxels")]
    voxels: Option<u32>,
    /// AO occluder range in scene units.
    #[arg(long = "ao-range", alias = "ao_range")]
    ao_range: Option<f32>,
    /// AO falloff 1 / (1 + ao_lambda r).
    #[arg(long = "ao-lambda", alias = "ao_lambda")]
    ao_lambda: Option<f32>,
    /// Diffuse cones per pixel (1..=64) [default 5].
    #[arg(long)]
    cones: Option<u32>,
    /// Half-angle of the diffuse cones, degrees [default 30].
    #[arg(long = "cone-half-angle", alias = "cone_half_angle")]
    cone_half_angle: Option<f32>,
    /// Cone origins start this many voxels off the surface along its normal [default 2].
    #[arg(long = "cone-offset", alias = "cone_offset")]
    cone_offset: Option<f32>,
    /// Surface-aware mip clamp: sampled cells stay below 1/F of the distance from the origin
    /// surface (0 = off, the paper's rule) [default 2].
    #[arg(long = "mip-clamp", alias = "mip_clamp")]
    mip_clamp: Option<f32>,
    /// Cone step as a fraction of the cone's diameter, (0, 1] [default 0.5, the paper's].
    #[arg(long = "cone-step", alias = "cone_step")]
    cone_step: Option<f32>,
    /// Every cone tracer: sampled mip level relative to the paper's log2(diameter), in [-3, 0]
    /// (narrow cones: about -1) [default 0, the paper's].
    #[arg(
        long = "cone-level-bias",
        alias = "cone_level_bias",
        allow_hyphen_values = true
    )]
    cone_level_bias: Option<f32>,
    /// Every cone tracer: share of a sample's coverage taken as rays already blocked, in [0, 1]
    /// (1: the cone's opacity is its densest sample's) [default 0, the paper's independent layers].
    #[arg(long = "coverage-correlation", alias = "coverage_correlation")]
    coverage_correlation: Option<f32>,
    /// lrsm: RSM side per light view (power of two, 4..=1024) [default 128].
    #[arg(long = "rsm-side", alias = "rsm_side")]
    rsm_side: Option<u32>,
    /// lrsm: depth splits (layers = (a + 1) x (b + 1)) [default 1].
    #[arg(long = "lrsm-depth-splits", alias = "lrsm_depth_splits")]
    lrsm_depth_splits: Option<u32>,
    /// lrsm: <n.l> splits [default 1].
    #[arg(long = "lrsm-normal-splits", alias = "lrsm_normal_splits")]
    lrsm_normal_splits: Option<u32>,
    /// lrsm: overlap of neighbouring depth layers [default 0.05].
    #[arg(long = "lrsm-overlap", alias = "lrsm_overlap")]
    lrsm_overlap: Option<f32>,
    /// lrsm: occlusion mips by surface coverage (a one-voxel wall stays opaque at every level;
    /// false: the paper's volume coverage, the solid fraction) [default true].
    #[arg(long = "lrsm-surface-coverage", alias = "lrsm_surface_coverage")]
    lrsm_surface_coverage: Option<bool>,
    /// lrsm: N = <n, vc> weighs each layer's radiance as the paper's Algorithm 1 writes it (false:
    /// N only culls back faces) [default false].
    #[arg(long = "lrsm-view-weight", alias = "lrsm_view_weight")]
    lrsm_view_weight: Option<bool>,
    /// lrsm: area-weighted LRSMs (each RSM texel weighs 1 / <n.l>) read as eq. 1's premultiplied
    /// product, one level finer, N weighing it: 0.92-1.00 of the reference's indirect energy
    /// (false: Algorithm 1's layers) [default false; every quality preset: true, read where a scene
    /// turns the lit cells off].
    #[arg(long = "lrsm-area-weights", alias = "lrsm_area_weights")]
    lrsm_area_weights: Option<bool>,
    /// lrsm: each sample's light from the light views' texels in the occlusion pyramid's cells
    /// (false: Algorithm 1's layered RSMs, read in light space) [default false; every quality
    /// preset: true].
    #[arg(long = "lrsm-lit-cells", alias = "lrsm_lit_cells")]
    lrsm_lit_cells: Option<bool>,
    /// lrsm: soft shadows from shadow cones of this half-angle through the occlusion voxels, degrees
    /// (0 = exact shadow rays) [default 0].
    #[arg(long = "shadow-cone-angle", alias = "shadow_cone_angle")]
    shadow_cone_angle: Option<f32>,
    /// cprc: radiance-cache side in texels (power of two, 1..=64) [default 16].
    #[arg(long = "cache-resolution", alias = "cache_resolution")]
    cache_resolution: Option<u32>,
    /// cprc: irradiance map side per cache (power of two) [default 8].
    #[arg(long = "irradiance-resolution", alias = "irradiance_resolution")]
    irradiance_resolution: Option<u32>,
    /// cprc: screen tile of the cache distribution, pixels (4..=64) [default 16].
    #[arg(long = "cache-tile", alias = "cache_tile")]
    cache_tile: Option<u32>,
    /// cprc: depth slices of the cluster keys (1..=64) [default 16].
    #[arg(long = "cache-depth-slices", alias = "cache_depth_slices")]
    cache_depth_slices: Option<u32>,
    /// cprc: gathering radius in tiles [default 2].
    #[arg(long = "gather-radius", alias = "gather_radius")]
    gather_radius: Option<f32>,
    /// cprc: weigh each gathered cache by the cosine between the pixel's and the cache's normals
    /// (none facing away); false: CPRC's world and screen weights alone [default true].
    #[arg(long = "gather-angle", alias = "gather_angle")]
    gather_angle: Option<bool>,
    /// cprc: keep the last frame's caches where their surface is still in view (frames after the
    /// first of one renderer) [default false].
    #[arg(long = "cache-reuse", alias = "cache_reuse")]
    cache_reuse: Option<bool>,
    /// cprc with cache reuse: kept caches keep their radiance texels (not traced again) while the
    /// volume is unchanged; the same frames either way [default true].
    #[arg(long = "cache-carry", alias = "cache_carry")]
    cache_carry: Option<bool>,
    /// vct-svo: light-view map side per light view for photon injection (power of two, 16..=2048;
    /// 0 = voxel_light's per-voxel direct light) [default 256].
    #[arg(long = "photon-map", alias = "photon_map")]
    photon_map: Option<u32>,
    /// vct-svo: anisotropic voxels (six directional values per voxel above the leaves) [default true].
    #[arg(long = "anisotropic-voxels", alias = "anisotropic_voxels")]
    anisotropic_voxels: Option<bool>,
    /// vct-svo: voxel shading with Gaussian lobes (normal distributions convolved with the cone's
    /// span decide how much of a voxel faces the cone's origin) and, with photons on glossy
    /// surfaces, glossy voxels (their specular light as a direction lobe) [default false].
    #[arg(long = "voxel-lobes", alias = "voxel_lobes")]
    voxel_lobes: Option<bool>,
    /// vct-dense and cprc: depth-ordered blend (along the cone's main axis an opaque cell facing the cone hides
    /// the one behind it; against leaks through thin walls) instead of the paper's trilinear [default
    /// false].
    #[arg(long = "depth-ordered-blend", alias = "depth_ordered_blend")]
    depth_ordered_blend: Option<bool>,
    /// vct-dense, vct-svo, lrsm: interleaved cone sets of side N, 1 (off), 2, 4 or 8: the N x N pixel
    /// classes trace disjoint subsets of cones x N^2 cones, averaged (tent weights) over each pixel's (2N - 1)^2 neighbours
    /// on its own surface (narrow cones want it: see docs/accuracy/vct-dense.md) [default 1].
    #[arg(long = "cone-interleave", alias = "cone_interleave")]
    cone_interleave: Option<u32>,
    /// vct-svo: light bounces in the voxels, 1 or 2 (the second gathered from every voxel through the
    /// octree, which is then rebuilt) [default 1].
    #[arg(long)]
    bounces: Option<u32>,
    /// Every GPU pipeline: samples per pixel side, 1..=4 (each pixel the mean of supersample^2
    /// samples, as the reference's pixel is the mean over its area; cache_tile stays in pixels)
    /// [default 1: the pixel's centre].
    #[arg(long)]
    supersample: Option<u32>,
}

fn load_scene(path: &Option<PathBuf>, flags: &RenderFlags) -> Result<vxgi::scene::Scene> {
    let mut scene = match path {
        Some(p) => vxgi::scene::Scene::load(p)?,
        None => vxgi::scene::Scene::cornell_box(),
    };
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    // Every flag overrides the `[render]` key of the same name.
    macro_rules! override_keys {
        ($($key:ident),*) => {
            $(if let Some(v) = flags.$key {
                scene.render.$key = v;
                scene.explicit_render.insert(stringify!($key).to_string());
            })*
        };
    }
    override_keys!(
        quality,
        voxels,
        ao_range,
        ao_lambda,
        cones,
        cone_half_angle,
        cone_offset,
        mip_clamp,
        cone_step,
        cone_level_bias,
        coverage_correlation,
        depth_ordered_blend,
        cone_interleave,
        rsm_side,
        lrsm_depth_splits,
        lrsm_normal_splits,
        lrsm_overlap,
        lrsm_surface_coverage,
        lrsm_view_weight,
        lrsm_area_weights,
        lrsm_lit_cells,
        shadow_cone_angle,
        cache_resolution,
        irradiance_resolution,
        cache_tile,
        cache_depth_slices,
        gather_radius,
        gather_angle,
        cache_reuse,
        cache_carry,
        photon_map,
        anisotropic_voxels,
        voxel_lobes,
        bounces,
        supersample
    );
    scene.render.validate().map_err(anyhow::Error::msg)?;
    warn_back_faces(&scene, "");
    Ok(scene)
}

/// Say where most of the camera's view is the back of faces, which reflect nothing: an inside-out
/// mesh, or a camera behind a wall, renders black there in every pipeline and the reference alike,
/// with nothing else to say so. `label` names the scene where a command loads several.
fn warn_back_faces(scene: &vxgi::scene::Scene, label: &str) {
    let data = vxgi::trace::SceneData::new(scene);
    if let Some(share) = vxgi::trace::back_face_share(&data).filter(|&s| s > 0.5) {
        eprintln!(
            "warning: {label}{:.0}% of what the camera sees is the back of faces (their vertex order turns them away from the camera), which reflect nothing: surfaces are one-sided. Either the camera is behind them (outside a closed room, behind a wall: move it) or the mesh is inside out (a room modelled with its faces turned outwards: reverse each face's vertex order)",
            share * 100.0
        );
    }
}

/// A spinner with the elapsed time and a message (hidden when stderr is not a terminal).
fn spinner() -> ProgressBar {
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} {elapsed} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

fn create_out(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!("--out {}: a file, not a folder", dir.display());
    }
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    // A folder that cannot be written is said now, with its path, not after the GPU work.
    let probe = dir.join(".vxgi-write-check");
    std::fs::write(&probe, b"")
        .with_context(|| format!("--out {}: cannot write into it", dir.display()))?;
    std::fs::remove_file(&probe).ok();
    Ok(())
}

/// [`vxgi::limits::check_bounces`] as the CLI's error.
fn check_bounces(pipeline: Pipeline, scene: &vxgi::scene::Scene) -> Result<()> {
    vxgi::limits::check_bounces(scene, pipeline).map_err(anyhow::Error::msg)
}

fn run_render(
    plan_only: bool,
    pipeline: Pipeline,
    scene: Option<PathBuf>,
    out: PathBuf,
    (frames, orbit): (u32, f32),
    flags: RenderFlags,
) -> Result<()> {
    let scene = load_scene(&scene, &flags)?;
    let (scene, preset) = vxgi::quality::resolved(&scene, pipeline).map_err(anyhow::Error::msg)?;
    // With instances this places every hierarchy's cells: computed once.
    let loops = vxgi::quality::loop_iterations(&scene, pipeline);
    let quality = format!(
        "quality {} for {}: {} (at most {} loop iterations per invocation in the kernels it sizes; lavapipe stops loops past {})",
        scene.render.quality.name(),
        pipeline.name(),
        if preset.is_empty() {
            "the defaults".to_string()
        } else {
            preset.join(", ")
        },
        loops,
        vxgi::quality::LOOP_LIMIT
    );
    check_bounces(pipeline, &scene)?;
    if loops > vxgi::quality::LOOP_LIMIT {
        eprintln!(
            "warning: these settings give up to {loops} loop iterations per invocation (a bound: every cone marched to its end); \
             lavapipe stops loops past {} without an error, cutting the cones short where they run that long \
             (fewer cones, a wider cone angle, a longer cone_step or fewer voxels keep under it)",
            vxgi::quality::LOOP_LIMIT
        );
    }
    let unread: Vec<&str> = unread_keys(pipeline, &scene.render)
        .into_iter()
        .filter(|k| scene.explicit_render.contains(*k))
        .collect();
    if !unread.is_empty() {
        eprintln!(
            "warning: {} does not read {} (set in the scene or on the command line): they change nothing in its frames{}",
            pipeline.name(),
            unread.join(", "),
            if pipeline == Pipeline::Cprc {
                " (cprc's caches trace one cone per texel of their own)"
            } else {
                ""
            }
        );
    }
    let cones = ConeSettings::from(&scene.render);
    if frames == 0 || !orbit.is_finite() {
        bail!("--frames must be at least 1 and --orbit finite");
    }
    if plan_only {
        println!("{quality}");
        // A supersampled frame's passes run on its samples: the plan of the sampled scene.
        let samples = scene.supersampled().map_err(anyhow::Error::msg)?;
        if scene.render.supersample > 1 {
            println!(
                "supersample {0}: {0} x {0} samples per pixel ({1}x{2}), box-filtered to {3}x{4}",
                scene.render.supersample,
                samples.camera.width,
                samples.camera.height,
                scene.camera.width,
                scene.camera.height
            );
        }
        let scene = samples;
        print!("{}", pipeline.plan(&scene, &cones, false));
        if frames > 1 {
            // Frame 2 reuses frame 1's volume unless a dynamic instance moved.
            let moved = scene.at_frame(1).mesh != scene.mesh;
            if moved {
                println!("frame 2 (a dynamic instance moved: everything rebuilt):");
            } else {
                println!("frames 2..{frames} (only the camera moves):");
            }
            print!("{}", pipeline.plan(&scene, &cones, !moved));
        }
        return Ok(());
    }
    create_out(&out)?;
    let ctx = GpuContext::new().context("creating the GPU context")?;
    eprintln!("adapter: {}", ctx.describe());
    eprintln!("{quality}");
    // The frames stay on the GPU: one resident renderer draws them all.
    let mut resident = vxgi::resident::Resident::new(&ctx, pipeline)?;
    // Voxelization's work, for its throughput: the triangles and surface samples of the one grid
    // (scenes with [[instances]] are voxelized per hierarchy by vct-dense and cprc: not reported).
    let vox_work = if scene.instances.list.is_empty() {
        vxgi::kernels::voxelize::prepare(&scene, scene.render.voxels)
            .ok()
            .map(|(input, _)| {
                (
                    input.tris.len(),
                    vxgi_cpu_mirror::voxelize::sample_count(&input.tris),
                )
            })
    } else {
        None
    };
    let mut rows = Vec::new();
    let mut last_memory: Option<Vec<(&str, u64)>> = None;
    // Whether every frame's chain was timed by timestamp queries.
    let mut timed = true;
    for k in 0..frames {
        let dir = if frames == 1 {
            out.clone()
        } else {
            out.join(format!("frame_{k:03}"))
        };
        create_out(&dir)?;
        let bar = spinner();
        let message = |stage: &str| bar.set_message(format!("frame {}/{frames}: {stage}", k + 1));
        // The whole per-frame call is counted: the scene's update (instances, camera) and the frame.
        let ((r, memory), row) = vxgi::frames::counted(&ctx, k, || {
            let view = scene.at_frame(k).orbited(orbit * k as f32);
            message("recording");
            let frame = resident.render(&view, &cones)?;
            Ok((frame, resident.memory()))
        })?;
        rows.push(row);
        match memory {
            Some(vxgi::render::VolumeMemory::Octree(m)) => println!(
                "octree: {} nodes and bricks, {:.1} MB (vct-dense's pyramids at this resolution: {:.1} MB)",
                m.nodes,
                m.bytes as f64 / 1e6,
                m.vct_dense_bytes as f64 / 1e6
            ),
            Some(vxgi::render::VolumeMemory::Lrsm(m)) => println!(
                "lrsm: occlusion voxels {:.1} MB, one RSM {:.1} MB, {}",
                m.occlusion as f64 / 1e6,
                m.rsm as f64 / 1e6,
                m.light_text()
            ),
            Some(vxgi::render::VolumeMemory::Caches(_)) if !r.plan.runs("gather_caches") => {
                println!("cprc: no radiance caches (the plan skipped them, see below)")
            }
            Some(vxgi::render::VolumeMemory::Caches(c)) => {
                match c.coverage {
                    Some((pixels, uncovered)) => println!(
                        "cprc: {} radiance caches; {uncovered} of {pixels} front-facing pixels without a valid cache ({:.2}%)",
                        c.caches,
                        100.0 * uncovered as f64 / pixels.max(1) as f64
                    ),
                    None if scene.render.cache_reuse => println!(
                        "cprc: {} radiance caches, {} kept from the last frame{}",
                        c.caches,
                        c.kept,
                        if c.carried {
                            " (their texels carried, not traced)"
                        } else {
                            ""
                        }
                    ),
                    None => println!("cprc: {} radiance caches", c.caches),
                }
                if c.dropped > 0 {
                    eprintln!(
                        "warning: {} clusters got no radiance cache: past the cache buffers' capacity (lower the image size or cache_depth_slices, or raise cache_tile)",
                        c.dropped
                    );
                }
            }
            None => {}
        }
        // Printed where the chain was built or rebuilt (its table changed).
        if let Some(by_stage) = resident.memory_by_stage() {
            if last_memory.as_deref() != Some(by_stage) {
                println!("{}", vxgi::resident::memory_line(by_stage));
                last_memory = Some(by_stage.to_vec());
            }
        }
        bar.finish_and_clear();
        write_frame(&dir, [&r.direct, &r.indirect, &r.combined, &r.ao])?;
        let stages: Vec<String> = r
            .stages
            .iter()
            .map(|(n, s)| format!("{n} {:.0} ms", s * 1e3))
            .collect();
        println!(
            "wrote direct, indirect, combined, ao (.exr + .png) to {}",
            dir.display()
        );
        timed &= resident.timed();
        if !resident.timed() {
            println!(
                "stages: not timed (the frame's chain has more passes than a timestamp query set holds, or the adapter has no timestamps){}",
                if stages.is_empty() {
                    String::new()
                } else {
                    format!("; built outside the chain, by wall clock: {}", stages.join(", "))
                }
            );
        } else {
            println!(
                "stages (GPU time{}): {}",
                if pipeline == Pipeline::VctSvo && !vxgi::pipeline::builds_in_chain(&scene) {
                    "; the octree build by wall clock"
                } else {
                    ""
                },
                stages.join(", ")
            );
        }
        let vox_seconds = r.stages.iter().find(|(n, _)| *n == "voxelize");
        if let (Some((tris, samples)), Some((_, secs))) = (vox_work, vox_seconds) {
            println!(
                "voxelize: {tris} triangles, {samples} surface samples into {}^3: {:.0} triangles/s, {:.1} M samples/s (its GPU time, triangle setup and every window included)",
                scene.render.voxels,
                tris as f64 / secs,
                samples as f64 / secs / 1e6
            );
        }
        if let Some((listed, all)) = r.cone_tiles {
            println!(
                "cone pass: {listed} of {all} 8x8 screen tiles hold a surface (the other {} not dispatched)",
                all - listed
            );
        }
        let skipped = r.plan.skipped();
        if !skipped.is_empty() {
            println!("skipped by the plan: {}", skipped.join(", "));
        }
    }
    let csv = out.join("frames.csv");
    std::fs::write(&csv, vxgi::frames::csv(&rows))
        .with_context(|| format!("writing {}", csv.display()))?;
    println!(
        "{} ({} timing; per frame in {})",
        vxgi::frames::summary(&rows),
        if ctx.timestamps && timed {
            "GPU: timestamp queries"
        } else {
            "GPU: wall clock around submit and wait"
        },
        csv.display()
    );
    Ok(())
}

fn run_reference(
    scene: Option<PathBuf>,
    opts: vxgi::reference::ReferenceOptions,
    ideal_cones: Option<(u32, Option<Pipeline>)>,
    out: PathBuf,
    flags: RenderFlags,
) -> Result<()> {
    let mut scene = load_scene(&scene, &flags)?;
    match ideal_cones {
        // The ideal cones of a pipeline's cone set: its preset resolved, as its frame's.
        Some((_, Some(pipeline))) => {
            scene = vxgi::quality::resolved(&scene, pipeline)
                .map_err(anyhow::Error::msg)?
                .0;
        }
        _ if scene.render.quality != vxgi::quality::Quality::Balanced => {
            bail!("the reference renders the scene's light transport: a quality preset (--quality or [render] quality) applies to a pipeline's frame, not to it (with --ideal-cones, --pipeline P takes P's cone set under the preset)");
        }
        _ => {}
    }
    let ideal_cones = ideal_cones.map(|(rays, _)| rays);
    if opts.spp == 0 {
        bail!("--spp must be at least 1");
    }
    if ideal_cones == Some(0) {
        bail!("--ideal-cones must be at least 1 ray per cone");
    }
    create_out(&out)?;
    let bar = ProgressBar::new(scene.camera.height as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} rows {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let start = std::time::Instant::now();
    let mut img = vxgi::reference::render_reference(&scene, &opts, |n| bar.inc(n));
    if let Some(rays) = ideal_cones {
        bar.reset();
        bar.set_message("ideal cones");
        let (cones, tan) = vxgi::reference::cone_set(&scene.render);
        img.indirect = vxgi::reference::ideal_cones(&scene, &cones, tan, rays, |n| bar.inc(n));
    }
    bar.finish_and_clear();
    let rgb = |px: Vec<[f32; 3]>| RgbImage::new(img.width, img.height, px);
    write_frame(
        &out,
        [
            &rgb(img.direct.clone()),
            &rgb(img.indirect.clone()),
            &rgb(img.combined()),
            &rgb(img.ao.clone()),
        ],
    )?;
    let indirect = match ideal_cones {
        Some(rays) => format!(
            "; indirect from {} ideal cones of {} deg ({} a pixel, {}x{} interleaved), {} rays each",
            vxgi::reference::cone_set(&scene.render).0.len(),
            scene.render.cone_half_angle,
            scene.render.cones,
            scene.render.cone_interleave,
            scene.render.cone_interleave,
            vxgi::reference::ideal_cone_strata(rays).pow(2)
        ),
        None => String::new(),
    };
    println!(
        "wrote direct, indirect, combined, ao (.exr + .png) to {} ({} spp{indirect}, {:.1} s)",
        out.display(),
        opts.spp,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

fn run_bench(
    scene: Option<PathBuf>,
    pipeline: Pipeline,
    quick: bool,
    (spp, reference, temporal): (Option<u32>, Option<PathBuf>, Option<vxgi::temporal::Orbit>),
    out: PathBuf,
    flags: RenderFlags,
) -> Result<()> {
    let spp = spp.unwrap_or(if quick { 8 } else { 64 });
    if spp == 0 {
        bail!("--spp must be at least 1");
    }
    // The sweep is around the scene's own settings; `bench` adds its preset's point.
    let scene = load_scene(&scene, &flags)?;
    check_bounces(pipeline, &scene)?;
    // A key the file or a flag sets that every configuration of the sweep replaces measures
    // nothing the user asked for: said (the planner's rows keep it).
    let base = toml::Value::try_from(&scene.render)?;
    let configs: Vec<toml::Value> = vxgi::bench::sweep(&scene.render, quick, pipeline)
        .iter()
        .map(toml::Value::try_from)
        .collect::<Result<_, _>>()?;
    let swept: Vec<&str> = scene
        .explicit_render
        .iter()
        .filter(|k| {
            configs
                .iter()
                .all(|c| c.get(k.as_str()) != base.get(k.as_str()))
        })
        .map(String::as_str)
        .collect();
    if !swept.is_empty() {
        eprintln!(
            "warning: the bench's sweep sets {} in every configuration (the values given are kept only by the planner's rows)",
            swept.join(", ")
        );
    }
    create_out(&out)?;
    let ctx = GpuContext::new().context("creating the GPU context")?;
    eprintln!("adapter: {}", ctx.describe());
    let bar = ProgressBar::new(1);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {elapsed} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let (rows, planner) = vxgi::bench::bench(
        &ctx,
        pipeline,
        &scene,
        spp,
        reference.as_deref(),
        (quick, temporal),
        &out,
        |done, total, what| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
            bar.set_message(what.to_string());
        },
    )?;
    bar.finish_and_clear();
    print!(
        "{}",
        vxgi::bench::table(
            &rows,
            pipeline,
            &vxgi::bench::against(spp, reference.as_deref()),
            scene.camera.width,
            scene.camera.height
        )
    );
    print!("{}", vxgi::bench::planner_table(&planner));
    println!("wrote bench.csv, bench.md, bench.svg to {}", out.display());
    Ok(())
}

fn run_report(
    scenes: Vec<String>,
    spp: u32,
    temporal: Option<vxgi::temporal::Orbit>,
    out: PathBuf,
) -> Result<()> {
    if spp == 0 {
        bail!("--spp must be at least 1");
    }
    let names = if scenes.is_empty() {
        vec!["cornell_box".to_string(), "thin_wall".to_string()]
    } else {
        scenes
    };
    let mut loaded = Vec::new();
    for n in &names {
        let scene = match vxgi::scene::Scene::builtin(n) {
            Some(s) => s,
            None => vxgi::scene::Scene::load(n)?,
        };
        for w in &scene.warnings {
            eprintln!("warning: {n}: {w}");
        }
        warn_back_faces(&scene, &format!("{n}: "));
        let stem = Path::new(n)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| n.clone());
        // Each scene's images go to OUT/<label>/: scenes whose files share a stem (a/room.toml,
        // b/room.toml) get `room`, `room_2`, ... rather than overwriting each other.
        let mut label = stem.clone();
        let mut k = 1;
        while loaded.iter().any(|(l, _): &(String, _)| *l == label) {
            k += 1;
            label = format!("{stem}_{k}");
        }
        loaded.push((label, scene));
    }
    create_out(&out)?;
    let ctx = GpuContext::new().context("creating the GPU context")?;
    eprintln!("adapter: {}", ctx.describe());
    let bar = spinner();
    let rows = vxgi::report::report(&ctx, &loaded, spp, temporal, &out, |m| {
        bar.set_message(m.to_string())
    })?;
    bar.finish_and_clear();
    println!(
        "{:<11} {:<14} {:>8} {:>14} {:>14} {:>10} {:>8} {:>18}",
        "pipeline",
        "scene",
        "time",
        "indirect FLIP",
        "combined FLIP",
        "memory",
        "leak",
        "orbit instability"
    );
    for r in &rows {
        println!(
            "{:<11} {:<14} {:>7.2}s {:>14.3} {:>14.3} {:>10} {:>8} {:>18}",
            r.pipeline,
            r.scene,
            r.seconds,
            r.indirect_flip,
            r.combined_flip,
            r.memory_text(),
            r.leak_text(),
            r.instability_text()
        );
    }
    println!("wrote {}", out.join("report.md").display());
    Ok(())
}

fn run_lrsm_factors(
    scene_path: Option<PathBuf>,
    reference: Option<PathBuf>,
    spp: u32,
    out: PathBuf,
    only: Option<String>,
    flags: RenderFlags,
) -> Result<()> {
    use vxgi::images::compare;
    let scene = load_scene(&scene_path, &flags)?;
    let scene = vxgi::quality::resolved(&scene, Pipeline::Lrsm)
        .map_err(anyhow::Error::msg)?
        .0;
    if scene.render.supersample > 1 {
        bail!("lrsm-factors renders one sample per pixel: set supersample = 1");
    }
    create_out(&out)?;
    if reference.is_none() && spp == 0 {
        bail!("--spp must be at least 1");
    }
    let bar = spinner();
    bar.set_message(vxgi::bench::against(spp, reference.as_deref()));
    let (ref_indirect, ref_combined) =
        vxgi::reference::images_for(&scene, spp, reference.as_deref())?;
    bar.finish_and_clear();
    let ref_name = match &reference {
        Some(dir) => dir.display().to_string(),
        None => format!("Monte Carlo reference, {spp} spp, seed 1"),
    };
    let (w, h) = (scene.camera.width, scene.camera.height);
    let cones = ConeSettings::from(&scene.render);
    let name = scene_path
        .as_ref()
        .map_or("cornell_box".into(), |p| p.display().to_string());
    // The thin wall's leak (dark room over lit room, as `vxgi report` measures it).
    let thin_wall = name.contains("thin_wall");
    let positions = if thin_wall {
        vxgi::reference::pixel_positions(&scene)
    } else {
        Vec::new()
    };
    let header = format!(
        "| row | indirect energy | indirect FLIP | combined FLIP |{}\n|---|---|---|---|{}",
        if thin_wall { " leak |" } else { "" },
        if thin_wall { "---|" } else { "" }
    );
    let mut md = format!(
        "# lrsm per-factor diagnostic: {name}\n\n{w}x{h}, {} voxels, occlusion mips by {} coverage; \
         against {ref_name}.\n\n{header}\n",
        scene.render.voxels,
        if scene.render.lrsm_surface_coverage { "surface" } else { "volume" },
    );
    println!("{header}");
    for (k, (label, swap)) in vxgi::lrsm_factors::rows().into_iter().enumerate() {
        if only.as_ref().is_some_and(|o| !label.contains(o.as_str())) {
            continue;
        }
        let t = std::time::Instant::now();
        let f = vxgi::render::render_lrsm_factors(&scene, &cones, swap)?;
        let dir = out.join(format!("row_{k}"));
        create_out(&dir)?;
        write_frame(&dir, [&f.direct, &f.indirect, &f.combined, &f.ao])?;
        let ind = compare(
            &ref_indirect,
            Path::new("reference indirect"),
            &f.indirect,
            &dir,
        )?;
        let comb = compare(
            &ref_combined,
            Path::new("reference combined"),
            &f.combined,
            &dir,
        )?;
        let leak = if thin_wall {
            let l = vxgi::reference::leak(&f.indirect.pixels, &positions, 0.0, 1.0 / 64.0);
            format!(" {l:.4} |")
        } else {
            String::new()
        };
        let line = format!(
            "| {label} | {:.3} | {:.3} | {:.3} |{leak}",
            ind.energy_ratio, ind.flip_mean, comb.flip_mean
        );
        println!("{line}  ({:.1} s)", t.elapsed().as_secs_f64());
        md.push_str(&line);
        md.push('\n');
    }
    std::fs::write(out.join("factors.md"), md)?;
    println!("wrote {}", out.join("factors.md").display());
    Ok(())
}

/// The `[render]` keys `pipeline` does not read with settings `r`: other pipelines' own keys
/// (lrsm's light views, cprc's caches, vct-svo's octree options), the per-pixel cones in cprc
/// (its caches trace their own), the depth-ordered blend outside vct-dense and cprc, and the
/// LRSMs' partition where lrsm reads the lit cells instead.
fn unread_keys(pipeline: Pipeline, r: &vxgi::scene::RenderSettings) -> Vec<&'static str> {
    const LRSM: [&str; 9] = [
        "rsm_side",
        "lrsm_depth_splits",
        "lrsm_normal_splits",
        "lrsm_overlap",
        "lrsm_surface_coverage",
        "lrsm_view_weight",
        "lrsm_area_weights",
        "lrsm_lit_cells",
        "shadow_cone_angle",
    ];
    const CPRC: [&str; 8] = [
        "cache_resolution",
        "irradiance_resolution",
        "cache_tile",
        "cache_depth_slices",
        "gather_radius",
        "gather_angle",
        "cache_reuse",
        "cache_carry",
    ];
    const SVO: [&str; 3] = ["photon_map", "anisotropic_voxels", "voxel_lobes"];
    let mut keys = Vec::new();
    for (own, owner) in [
        (&LRSM[..], Pipeline::Lrsm),
        (&CPRC[..], Pipeline::Cprc),
        (&SVO[..], Pipeline::VctSvo),
    ] {
        if pipeline != owner {
            keys.extend_from_slice(own);
        }
    }
    match pipeline {
        Pipeline::Cprc => keys.extend(["cones", "cone_half_angle", "cone_interleave"]),
        Pipeline::VctSvo => keys.push("depth_ordered_blend"),
        Pipeline::Lrsm => {
            keys.push("depth_ordered_blend");
            if r.lrsm_lit_cells {
                keys.extend([
                    "lrsm_depth_splits",
                    "lrsm_normal_splits",
                    "lrsm_overlap",
                    "lrsm_view_weight",
                    "lrsm_area_weights",
                ]);
            }
        }
        Pipeline::VctDense => {}
    }
    keys
}

fn run_compare(reference: PathBuf, test: PathBuf, heatmap: Option<PathBuf>) -> Result<()> {
    for p in [&reference, &test] {
        if p.is_dir() {
            bail!(
                "{}: a directory; pass one of its images, e.g. {}",
                p.display(),
                p.join("indirect.exr").display()
            );
        }
    }
    if let Some(h) = &heatmap {
        let png = h.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
        anyhow::ensure!(
            png,
            "--heatmap {}: the heat map is written as PNG; name it .png",
            h.display()
        );
        let same = |a: &Path, b: &Path| {
            a == b || matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
        };
        anyhow::ensure!(
            !same(h, &reference) && !same(h, &test),
            "--heatmap {}: that is an image being compared; name another file",
            h.display()
        );
        // Its folder is made now, as --out's are, rather than found missing after the metrics.
        if let Some(dir) = h.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| {
                format!("--heatmap {}: creating {}", h.display(), dir.display())
            })?;
        }
    }
    let r = read_exr(&reference)?;
    let t = read_exr(&test)?;
    // Radiance is not negative: an image with negative pixels (another tool's output) would give
    // energies and errors without meaning (an energy ratio below 0).
    for (img, path) in [(&r, &reference), (&t, &test)] {
        if let Some((x, y)) = img.first_negative() {
            bail!("{}: negative radiance at ({x}, {y})", path.display());
        }
    }
    // An .exr holds linear radiance, a .png the sRGB-encoded preview: the two do not compare.
    let ext = |p: &Path| p.extension().map(|e| e.to_ascii_lowercase());
    if ext(&reference) != ext(&test) {
        eprintln!(
            "warning: {} and {} are different formats (an .exr is linear radiance, a .png its sRGB preview): compare like with like",
            reference.display(),
            test.display()
        );
    }
    let c = vxgi::images::compare(&r, &reference, &t, &test)?;
    println!("relative MSE {:.6}", c.rel_mse);
    println!("mean FLIP    {:.6}", c.flip_mean);
    if c.energy_ratio.is_finite() {
        println!("energy ratio {:.4} (test / reference)", c.energy_ratio);
    } else {
        println!("energy ratio undefined (the reference image is black)");
    }
    if let Some(path) = heatmap {
        write_heatmap(&path, r.width, r.height, &c.heatmap)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn main() {
    // Output piped into a reader that stops early (`vxgi list | head -1`) ends the process as any
    // Unix tool does, instead of a panic in `println!` (Rust ignores SIGPIPE by default).
    #[cfg(unix)]
    // SAFETY: restores the default disposition of one signal before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    if let Err(e) = real_main() {
        eprintln!("error: {e}");
        // A cause whose text the line above already holds (`{path}: {source}` errors) is not
        // printed twice.
        let mut above = e.to_string();
        for cause in e.chain().skip(1) {
            let cause = cause.to_string();
            if !above.contains(&cause) {
                eprintln!("  caused by: {cause}");
            }
            above = cause;
        }
        std::process::exit(1);
    }
}

fn real_main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::List => {
            for k in vxgi::kernels::all() {
                let d = k.decl();
                println!(
                    "{:<24} {:<40} {}\n{:<24} {}",
                    d.name, d.wgsl_path, d.mirror, "", d.summary
                );
            }
            Ok(())
        }
        Command::Limits => run_limits(),
        Command::Export { kernel, out } => run_export(&kernel, out.as_deref()),
        Command::Verify {
            kernel,
            cases: _,
            seed,
            case: Some(index),
        } => run_verify_case(kernel, seed, index),
        Command::Verify {
            kernel,
            cases,
            seed,
            case: None,
        } => run_verify(kernel, cases, seed),
        Command::Scene { path } => run_scene(path),
        Command::Render {
            scene,
            out,
            pipeline,
            plan,
            frames,
            orbit,
            render,
        } => run_render(plan, pipeline, scene, out, (frames, orbit), render),
        #[cfg(feature = "view")]
        Command::View {
            scene,
            pipeline,
            script,
            frames,
            screenshot,
            out,
            no_overlay,
            render,
        } => {
            if frames == Some(0) {
                bail!("--frames must be at least 1");
            }
            if let Some(shot) = &screenshot {
                let png = shot
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("png"));
                anyhow::ensure!(
                    png,
                    "--screenshot {}: the screenshot is written as PNG; name it .png",
                    shot.display()
                );
            }
            let script = match script {
                Some(s) => vxgi::view::Script::from_arg(&s)?,
                None => vxgi::view::Script::default(),
            };
            if let (Some(n), Some(last)) = (frames, script.steps.iter().map(|(f, _)| *f).max()) {
                if last >= n {
                    eprintln!(
                        "warning: --script has steps at frame {last}, past the last of --frames {n} (frame {}): they do not run",
                        n - 1
                    );
                }
            }
            vxgi::view::run(vxgi::view::ViewOptions {
                scene: load_scene(&scene, &render)?,
                pipeline,
                script,
                frames,
                screenshot,
                out,
                overlay: !no_overlay,
            })
        }
        Command::Reference {
            scene,
            spp,
            seed,
            no_jitter,
            ideal_cones,
            pipeline,
            out,
            render,
        } => run_reference(
            scene,
            vxgi::reference::ReferenceOptions {
                spp,
                seed,
                jitter: !no_jitter,
                // Ideal cones replace the Monte Carlo indirect image: no paths for it.
                indirect: ideal_cones.is_none(),
            },
            ideal_cones.map(|rays| (rays, pipeline)),
            out,
            render,
        ),
        Command::Compare {
            reference,
            test,
            heatmap,
        } => run_compare(reference, test, heatmap),
        Command::Report {
            scenes,
            spp,
            out,
            temporal,
        } => run_report(scenes, spp, temporal.orbit()?, out),
        Command::LrsmFactors {
            scene,
            reference,
            spp,
            out,
            rows,
            render,
        } => run_lrsm_factors(scene, reference, spp, out, rows, render),
        Command::Bisect {
            scene,
            mirror_until,
            pipeline,
            out,
            render,
        } => run_bisect(scene, pipeline, mirror_until, out, render),
        Command::Temporal {
            scene,
            pipelines,
            frames,
            orbit,
            light_step,
            rays,
            spp,
            check_reference,
            out,
            render,
        } => run_temporal(
            scene,
            pipelines,
            (frames, orbit, light_step),
            (rays, spp, check_reference),
            out,
            render,
        ),
        Command::Bench {
            scene,
            quick,
            spp,
            reference,
            out,
            pipeline,
            render,
            temporal,
        } => run_bench(
            scene,
            pipeline,
            quick,
            (spp, reference, temporal.orbit()?),
            out,
            render,
        ),
    }
}

fn run_temporal(
    scene: Option<PathBuf>,
    pipelines: Vec<Pipeline>,
    (frames, orbit, light_step): (u32, f32, f32),
    (rays, spp, check_reference): (u32, u32, bool),
    out: PathBuf,
    flags: RenderFlags,
) -> Result<()> {
    use vxgi::temporal::{self, Motion};
    // A pipeline named twice is measured once.
    let mut pipelines = pipelines;
    let mut seen = Vec::new();
    pipelines.retain(|p| {
        let first = !seen.contains(p);
        seen.push(*p);
        first
    });
    if frames < 2 || rays == 0 || spp == 0 || rays.checked_mul(4).is_none() {
        bail!("--frames must be at least 2, --rays and --spp at least 1 (and --rays at most 2^30)");
    }
    if !(orbit.is_finite() && light_step.is_finite()) {
        bail!("--orbit and --light-step must be finite");
    }
    let scene = load_scene(&scene, &flags)?;
    let pipelines = if pipelines.is_empty() {
        Pipeline::ALL.to_vec()
    } else {
        pipelines
    };
    for p in &pipelines {
        check_bounces(*p, &scene)?;
    }
    let mut motions = Vec::new();
    if orbit != 0.0 {
        motions.push(Motion::Orbit { degrees: orbit });
    }
    if light_step != 0.0 && !scene.lights.is_empty() {
        motions.push(Motion::Light { step: light_step });
    }
    if !scene.instances.list.is_empty() {
        motions.push(Motion::Instances);
    }
    if motions.is_empty() {
        bail!("nothing moves: give --orbit or --light-step (and lights), or a scene with [[instances]]");
    }
    create_out(&out)?;
    let ctx = GpuContext::new().context("creating the GPU context")?;
    eprintln!("adapter: {}", ctx.describe());
    let bar = spinner();
    bar.set_message(format!("path-traced reference of frame 0 ({spp} spp)"));
    let first = vxgi::reference::render_reference(
        &scene,
        &vxgi::reference::ReferenceOptions::spp(spp),
        |_| {},
    );
    let ref_combined =
        vxgi::images::RgbImage::new(scene.camera.width, scene.camera.height, first.combined());
    let mut rows = Vec::new();
    let mut floors = Vec::new();
    for motion in motions {
        // The ideal cones of each cone set a pipeline traces (a preset may narrow it), once each.
        let mut references = temporal::IdealFrames::new(motion, frames, rays);
        // Which pixels keep their surface depends on the camera and geometry alone: once a motion.
        let kept = temporal::persistent_pixels(&scene, motion, frames);
        for &p in &pipelines {
            let own = vxgi::quality::resolved(&scene, p)
                .map_err(anyhow::Error::msg)?
                .0;
            bar.set_message(format!(
                "{}: ideal cones ({rays} rays per cone)",
                motion.name()
            ));
            let (reference, new) = references.of(&own);
            if new
                && reference
                    .iter()
                    .all(|f| f.pixels.iter().flatten().all(|&c| c == 0.0))
            {
                // Every measure is relative to the reference's mean: against black it is 0 for
                // any pipeline, which would read as perfectly stable.
                bar.suspend(|| {
                    eprintln!(
                        "warning: {}: the ideal cones' indirect light is 0 in every frame: instability and error are undefined (written as 0)",
                        motion.name()
                    )
                });
            }
            if new && check_reference {
                bar.set_message(format!("{}: the reference's floor", motion.name()));
                floors.push((
                    motion.name(),
                    temporal::reference_floor(reference, &own, motion, rays),
                ));
            }
            bar.set_message(format!("{}: {}", motion.name(), p.name()));
            let (measure, got) = temporal::measure(&ctx, p, &own, motion, reference, Some(&kept))?;
            let name = Path::new(p.name());
            let flip =
                vxgi::images::compare(&ref_combined, name, &got[0].combined, name)?.flip_mean;
            rows.push(temporal::Row {
                pipeline: p.name(),
                motion: motion.name(),
                measure,
                combined_flip: flip,
                frame_ms: temporal::later_frames_ms(&got),
            });
        }
    }
    bar.finish_and_clear();
    let mut md = String::from(
        "| pipeline | motion | instability | on kept surfaces (share of pixels) | own change | reference's change | error (mean over frames) | combined FLIP (frame 0) | frame ms (median after the first) |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut csv = String::from(
        "pipeline,motion,instability,persistent_instability,persistent_share,change,reference_change,error,combined_flip,frame_ms\n",
    );
    for r in &rows {
        let m = &r.measure;
        let kept = m.persistent.expect("measure() masks the kept surfaces");
        md.push_str(&format!(
            "| {} | {} | {:.4} | {:.4} ({:.0}%) | {:.4} | {:.4} | {:.4} | {:.3} | {:.0} |\n",
            r.pipeline,
            r.motion,
            m.instability,
            kept.instability,
            kept.share * 100.0,
            m.change,
            m.reference_change,
            m.error,
            r.combined_flip,
            r.frame_ms
        ));
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{}\n",
            r.pipeline,
            r.motion,
            m.instability,
            kept.instability,
            kept.share,
            m.change,
            m.reference_change,
            m.error,
            r.combined_flip,
            r.frame_ms
        ));
    }
    for (motion, floor) in &floors {
        md.push_str(&format!(
            "\nThe reference's own floor ({motion}: {rays} against {} rays per cone): {floor:.4}\n",
            rays * 4
        ));
    }
    print!("{md}");
    std::fs::write(out.join("temporal.md"), &md)?;
    std::fs::write(out.join("temporal.csv"), &csv)?;
    temporal::plot(&out.join("temporal.svg"), &rows)?;
    println!(
        "wrote temporal.md, temporal.csv and temporal.svg to {}",
        out.display()
    );
    Ok(())
}

fn run_bisect(
    scene: Option<PathBuf>,
    pipeline: Pipeline,
    mirror_until: Option<String>,
    out: PathBuf,
    flags: RenderFlags,
) -> Result<()> {
    let scene = load_scene(&scene, &flags)?;
    let scene = vxgi::quality::resolved(&scene, pipeline)
        .map_err(anyhow::Error::msg)?
        .0;
    check_bounces(pipeline, &scene)?;
    // The splits are compared sample for sample: a supersampled frame's samples are its pixels here.
    let scene = if scene.render.supersample > 1 {
        eprintln!(
            "note: supersample = {0}: bisect compares the frame's samples ({0} x the resolution)",
            scene.render.supersample
        );
        scene.supersampled().map_err(anyhow::Error::msg)?
    } else {
        scene
    };
    let cones = ConeSettings::from(&scene.render);
    // Resolve the stages before starting the GPU, so a typo fails at once.
    let stages = vxgi::bisect::stages(pipeline, &scene, &cones)?;
    if !scene.instances.list.is_empty() {
        eprintln!(
            "note: bisect voxelizes the scene's {} instances as one flattened mesh (their own \
             hierarchies, which `vxgi render` uses, are not split)",
            scene.instances.list.len()
        );
    }
    let split = mirror_until
        .as_deref()
        .map(|s| vxgi::bisect::split_after(&stages, s))
        .transpose()?;
    if split.is_some() {
        create_out(&out)?;
    }
    let ctx = GpuContext::new().context("creating the GPU context")?;
    eprintln!("adapter: {}", ctx.describe());
    let bar = spinner();
    let message = |stage: &str| bar.set_message(stage.to_string());
    match split {
        Some(split) => {
            let r = vxgi::bisect::render_split(&ctx, &scene, &cones, pipeline, split, message)?;
            bar.finish_and_clear();
            write_frame(&out, [&r.direct, &r.indirect, &r.combined, &r.ao])?;
            print!("{}", r.plan);
            println!(
                "wrote direct, indirect, combined, ao (.exr + .png) to {}",
                out.display()
            );
        }
        None => {
            let rows = vxgi::bisect::bisect(&ctx, &scene, &cones, pipeline, message)?;
            bar.finish_and_clear();
            println!(
                "{}, each split against the all-mirror frame:",
                pipeline.name()
            );
            print!("{}", vxgi::bisect::table(&stages, &rows));
        }
    }
    Ok(())
}

fn run_scene(path: Option<std::path::PathBuf>) -> Result<()> {
    let scene = match &path {
        Some(p) => vxgi::scene::Scene::load(p)?,
        None => vxgi::scene::Scene::cornell_box(),
    };
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    warn_back_faces(&scene, "");
    let c = &scene.camera;
    for (k, i) in scene.instances.list.iter().enumerate() {
        println!(
            "instance {k}: {} ({} triangles){}",
            i.name,
            i.local.triangles.len(),
            if i.dynamic {
                format!(", dynamic, {} keyframes", i.keyframes.len())
            } else {
                String::new()
            }
        );
    }
    println!(
        "{} triangles, {} vertices, {} materials ({} glossy), {} lights, camera {}x{} fov {} deg, voxels {}",
        scene.mesh.triangles.len(),
        scene.mesh.positions.len(),
        scene.materials.len(),
        scene.materials.iter().filter(|m| m.is_glossy()).count(),
        scene.lights.len(),
        c.width,
        c.height,
        c.fov_y_deg,
        scene.render.voxels
    );
    // What voxelize's arithmetic needs of the mesh at the scene's voxels (every pipeline voxelizes
    // it; `vxgi render` refuses it when the triangles are set up), and the grid it puts around it.
    match vxgi::kernels::voxelize::mesh_input(&scene, scene.render.voxels) {
        Err(e) => bail!("the mesh cannot be voxelized: {e}"),
        Ok((_, f)) => {
            let hi = f.origin + glam::Vec3::splat(f.voxel * f.side as f32);
            let when = if scene.instances.list.iter().any(|i| i.dynamic) {
                ", at frame 0"
            } else {
                ""
            };
            println!(
                "voxel grid: {}^3 voxels of {} from ({}, {}, {}) to ({}, {}, {}) (a cube around the mesh's bounds{when})",
                f.side, f.voxel, f.origin.x, f.origin.y, f.origin.z, hi.x, hi.y, hi.z
            );
        }
    }
    // The device limits each pipeline's frame must fit (what `vxgi render` refuses before it starts).
    match GpuContext::new() {
        Ok(ctx) => {
            let limits = ctx.limits();
            let mut refused = 0;
            for p in Pipeline::ALL {
                match vxgi::limits::check(&scene, p, &limits) {
                    Ok(()) => println!("{}: fits this device's limits", p.name()),
                    Err(e) => {
                        refused += 1;
                        println!("{}: refused: {e}", p.name())
                    }
                }
            }
            if refused == 4 {
                bail!("no pipeline can render this scene on {}", ctx.describe());
            }
        }
        Err(e) => eprintln!("device limits not checked (no GPU adapter: {e})"),
    }
    Ok(())
}

fn run_limits() -> Result<()> {
    use vxgi::limits::{exceeded, kernel_needs, pipeline_kernels};
    let webgpu = wgpu::Limits::default();
    println!("| kernel | storage buffers | uniforms | textures (sampled, storage) | bind groups | workgroup | within WebGPU's defaults |");
    println!("|---|---|---|---|---|---|---|");
    for k in vxgi::kernels::all() {
        let n = kernel_needs(k.decl()).map_err(anyhow::Error::msg)?;
        let over = exceeded(&n, &webgpu);
        println!(
            "| {} | {} | {} | {}, {} | {} | {}x{}x{} | {} |",
            n.kernel,
            n.storage_buffers,
            n.uniform_buffers,
            n.sampled_textures,
            n.storage_textures,
            n.bind_groups,
            n.workgroup_size[0],
            n.workgroup_size[1],
            n.workgroup_size[2],
            if over.is_empty() {
                "yes".to_string()
            } else {
                over.join("; ")
            }
        );
    }
    println!();
    for p in Pipeline::ALL {
        let decls = pipeline_kernels(p);
        let kernels: Vec<&str> = decls.iter().map(|k| k.name).collect();
        let mut over = Vec::new();
        for k in decls {
            let n = kernel_needs(k).map_err(anyhow::Error::msg)?;
            if !exceeded(&n, &webgpu).is_empty() {
                over.push(k.name);
            }
        }
        println!(
            "{}: {} ({})",
            p.name(),
            if over.is_empty() {
                "runs within WebGPU's default limits".to_string()
            } else {
                format!(
                    "needs more than WebGPU's default limits in {}",
                    over.join(", ")
                )
            },
            kernels.join(", ")
        );
    }
    Ok(())
}

fn run_export(kernel: &str, out: Option<&Path>) -> Result<()> {
    let write = |path: &Path, text: &str| -> Result<()> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
        std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
    };
    if kernel == "all" {
        let Some(dir) = out else {
            bail!("`vxgi export all` writes one file per kernel: give the folder with --out DIR");
        };
        let kernels = vxgi::kernels::all();
        for k in &kernels {
            let d = k.decl();
            let text = d
                .export()
                .with_context(|| format!("exporting `{}`", d.name))?;
            write(&dir.join(format!("{}.wgsl", d.name)), &text)?;
        }
        eprintln!("wrote {} kernels to {}", kernels.len(), dir.display());
        return Ok(());
    }
    let d = vxgi::kernels::find(kernel)
        .map_err(anyhow::Error::msg)?
        .decl();
    let text = d
        .export()
        .with_context(|| format!("exporting `{}`", d.name))?;
    match out {
        Some(path) => {
            write(path, &text)?;
            eprintln!("wrote {} to {}", d.name, path.display());
        }
        None => print!("{text}"),
    }
    Ok(())
}

/// `--kernel NAME`'s kernel, or every declared kernel.
fn selected_kernels(kernel: Option<&str>) -> Result<Vec<&'static dyn vxgi::harness::Kernel>> {
    Ok(match kernel {
        Some(name) => vec![vxgi::kernels::find(name).map_err(anyhow::Error::msg)?],
        None => vxgi::kernels::all(),
    })
}

/// `vxgi verify --case N`: generated case `index` of each selected kernel, GPU vs mirror, with every
/// output's full report (the worst elements, both values, ULP and bound), pass or fail.
fn run_verify_case(kernel: Option<String>, seed: u64, index: usize) -> Result<()> {
    let kernels = selected_kernels(kernel.as_deref())?;
    let ctx = GpuContext::new().context("creating the GPU context")?;
    println!("adapter: {}", ctx.describe());
    let mut failed = false;
    for k in kernels {
        let name = k.decl().name;
        let shader = k.decl().shader()?;
        let case = k.case(&shader, &ctx, seed, index);
        let (comps, gpu_ns, mirror_ns, timing) =
            vxgi::harness::kernel::verify_case(&ctx, &shader, k, &case, None)
                .with_context(|| format!("verifying `{name}` case {index} (seed {seed})"))?;
        println!(
            "{name} case {index} `{}` (seed {seed}): GPU {:.2} ms ({timing}), mirror {:.2} ms",
            case.label,
            gpu_ns * 1e-6,
            mirror_ns * 1e-6
        );
        for c in &comps {
            failed |= !c.passed();
            let bound = if c.max_bound_use > 0.0 {
                format!(", bound use {:.3}", c.max_bound_use)
            } else {
                String::new()
            };
            println!(
                "{} {}{bound}\n{}",
                if c.passed() { "ok" } else { "FAIL" },
                c.output,
                c.report()
            );
        }
    }
    if failed {
        bail!("GPU and mirror disagree (reports above)");
    }
    Ok(())
}

fn run_verify(kernel: Option<String>, cases: usize, seed: u64) -> Result<()> {
    let kernels = selected_kernels(kernel.as_deref())?;
    if cases == 0 {
        bail!("--cases must be at least 1");
    }
    let ctx = GpuContext::new().context("creating the GPU context")?;
    println!("adapter: {}", ctx.describe());
    let bar = ProgressBar::new((kernels.len() * cases) as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} cases {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut rows = Vec::new();
    let mut failed = false;
    for k in &kernels {
        bar.set_message(k.decl().name);
        let done = bar.position();
        let rep = verify(
            &ctx,
            *k,
            &VerifyOptions {
                cases,
                seed,
                corrupt: None,
            },
            &mut |i| bar.set_position(done + i as u64),
        )
        .with_context(|| format!("verifying `{}`", k.decl().name))?;
        // Yardstick: a copy of the largest case's size, on this device, in this run.
        let copy = copy_bandwidth(&ctx, rep.largest_case_bytes / 2, 5)
            .context("timing the reference buffer copy")?;
        failed |= !rep.passed();
        rows.push((rep, copy));
    }
    bar.finish_and_clear();
    println!(
        "{:<26} {:>6} {:>12} {:>10} {:>8} {:>9} {:>10} {:>10} {:>10} {:>10} {:>6}",
        "kernel",
        "cases",
        "elements",
        "max ULP",
        "p99 ULP",
        "bound use",
        "GPU ms",
        "mirror ms",
        "eff. GB/s",
        "copy GB/s",
        "result"
    );
    for (rep, copy) in &rows {
        println!(
            "{:<26} {:>6} {:>12} {:>10} {:>8} {:>9} {:>10.2} {:>10.2} {:>10.2} {:>10.2} {:>6}",
            rep.kernel,
            rep.cases,
            rep.elements,
            vxgi::harness::compare::fmt_ulp(rep.max_ulp),
            vxgi::harness::compare::fmt_ulp(rep.p99_ulp()),
            if rep.max_bound_use > 0.0 {
                format!("{:.3}", rep.max_bound_use)
            } else {
                "-".into()
            },
            rep.gpu_ns * 1e-6,
            rep.mirror_ns * 1e-6,
            rep.effective_bandwidth() * 1e-9,
            copy * 1e-9,
            if rep.passed() { "ok" } else { "FAIL" }
        );
    }
    if let Some((rep, _)) = rows.first() {
        println!(
            "GPU time: {}; effective bytes = read each input once + write each output once; \
             bound use = max |gpu - mirror| / per-element bound (kernels with mirror-computed bounds)",
            rep.timing.map(|t| t.to_string()).unwrap_or_default()
        );
    }
    for (rep, _) in &rows {
        if rep.flushed > 0 {
            println!(
                "{}: {} elements matched only the flush-to-zero mirror (allowed by WGSL)",
                rep.kernel, rep.flushed
            );
        }
        for (f, i) in rep.failures.iter().zip(&rep.failed_cases).take(5) {
            eprintln!("{}", f.report());
            eprintln!(
                "reproduce: vxgi verify --kernel {} --seed {seed} --case {i}\n",
                rep.kernel
            );
        }
    }
    if failed {
        bail!("GPU and mirror disagree (reports above)");
    }
    Ok(())
}
