//! Scene input: a TOML file naming an OBJ mesh (loaded with tobj, triangulated, materials from
//! its .mtl), a camera, lights and optional render settings; or the built-in Cornell box. Everything a
//! user can get wrong is an error with file and line, never a panic.
use glam::{Vec2, Vec3};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use thiserror::Error;

use crate::obj_input;

#[derive(Debug, Error)]
pub enum SceneError {
    #[error("{path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}:{line}:{column}: {message}")]
    Toml {
        path: String,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{path}: mesh OBJ {obj} could not be loaded: {message}")]
    Obj {
        path: String,
        obj: String,
        message: String,
    },
    #[error("{path}:{line}: vertex {index} is not finite: {value:?}")]
    NonFiniteVertex {
        path: String,
        line: usize,
        index: usize,
        value: [f32; 3],
    },
    #[error(
        "{path}:{line}: vertex {index} = {value:?} is past the renderable range: coordinates must be \
         within +-{MAX_COORDINATE:e} scene units (products of such coordinates overflow f32)"
    )]
    VertexOutOfRange {
        path: String,
        line: usize,
        index: usize,
        value: [f32; 3],
    },
    #[error("{path}:{line}: material {name}: {message}")]
    Material {
        path: String,
        line: usize,
        name: String,
        message: String,
    },
    #[error("{path}: the mesh has no triangles{}", if *dropped > 0 { format!(" ({dropped} zero-area ones dropped)") } else { String::new() })]
    EmptyMesh { path: String, dropped: usize },
    #[error("{path}: [camera] {message}")]
    Camera { path: String, message: String },
    #[error("{path}: light {index}: {message}")]
    Light {
        path: String,
        index: usize,
        message: String,
    },
    #[error("{path}: [render] {message}")]
    Render { path: String, message: String },
    #[error("{path}: instance {index}: {message}")]
    Instance {
        path: String,
        index: usize,
        message: String,
    },
    #[error("{path}: the scene has neither a [mesh] nor [[instances]]")]
    NoGeometry { path: String },
    #[error("{path}: texture coordinate of vertex {index} is not finite: {value:?}")]
    NonFiniteUv {
        path: String,
        index: usize,
        value: [f32; 2],
    },
}

/// A `map_Kd` texture as loaded (PNG, JPEG, TGA, BMP, DXT-compressed DDS, HDR, EXR, PNM: the `image` crate's
/// decoders enabled in Cargo.toml): 8-bit sRGB
/// texels, row 0 at the image's top (texture coordinate v = 1).
#[derive(Clone, PartialEq)]
pub struct Texture {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<[u8; 3]>,
}

impl std::fmt::Debug for Texture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Texture({}, {}x{})",
            self.path.display(),
            self.width,
            self.height
        )
    }
}

impl Texture {
    /// Read an image file (alpha dropped).
    pub fn load(path: &Path) -> Result<Self, String> {
        Self::read(path).map(|(t, _)| t)
    }

    /// Read an image file, its format from its contents (a PNG named .jpg is read as PNG), and say
    /// what of it is not used: an alpha channel below 1 somewhere (cut-outs: surfaces are opaque).
    /// Floating-point images (EXR, HDR) hold linear values: they are encoded as sRGB, as 8-bit
    /// textures are stored, clamped to [0, 1] (an albedo).
    pub fn read(path: &Path) -> Result<(Self, Option<String>), String> {
        let img = image::ImageReader::open(path)
            .map_err(|e| e.to_string())?
            .with_guessed_format()
            .map_err(|e| e.to_string())?
            .decode()
            .map_err(|e| image_error(&e))?;
        let (width, height) = (img.width(), img.height());
        if width == 0 || height == 0 {
            return Err("the image is empty".into());
        }
        let cut_out = img.color().has_alpha() && img.to_rgba8().pixels().any(|p| p.0[3] < 255);
        let rgb: Vec<[u8; 3]> = if matches!(
            img.color(),
            image::ColorType::Rgb32F | image::ColorType::Rgba32F
        ) {
            img.to_rgb32f().pixels().map(|p| p.0.map(srgb8)).collect()
        } else {
            img.to_rgb8().pixels().map(|p| p.0).collect()
        };
        let note = cut_out
            .then(|| "its alpha channel (cut-outs) ignored: surfaces are opaque".to_string());
        Ok((
            Self {
                path: path.to_path_buf(),
                width,
                height,
                rgb,
            },
            note,
        ))
    }
}

/// The materials' textures fitted into `budget` texels in all (the texture atlas every pipeline
/// binds whole: [`crate::trace::ATLAS_TEXELS`]): while they hold more, the one with the most texels is
/// read at half its width and height (a triangle filter; a texture several materials share is one).
/// Returns the warning naming each texture read smaller, or `None` where they fit as they are.
pub fn fit_textures(materials: &mut [Material], budget: usize) -> Option<String> {
    let mut unique: Vec<Arc<Texture>> = Vec::new();
    for t in materials.iter().filter_map(|m| m.diffuse_map.as_ref()) {
        if !unique.iter().any(|u| Arc::ptr_eq(u, t)) {
            unique.push(t.clone());
        }
    }
    let texels = |u: &[Arc<Texture>]| -> usize {
        u.iter().map(|t| t.width as usize * t.height as usize).sum()
    };
    let before = texels(&unique);
    if before <= budget {
        return None;
    }
    let lut = crate::trace::srgb_lut();
    let mut smaller = unique.clone();
    while texels(&smaller) > budget {
        let (i, _) = smaller
            .iter()
            .enumerate()
            .max_by_key(|(_, t)| t.width as usize * t.height as usize)
            .expect("textures past a budget exist");
        let t = &smaller[i];
        if t.width == 1 && t.height == 1 {
            break;
        }
        let (w, h) = ((t.width / 2).max(1), (t.height / 2).max(1));
        // Filtered in linear albedo (a black and white checker halves to 0.5, not to code 128,
        // which decodes to 0.22), then encoded as every texture is stored.
        let img = image::Rgb32FImage::from_raw(
            t.width,
            t.height,
            t.rgb
                .iter()
                .flat_map(|c| c.map(|v| lut[v as usize]))
                .collect(),
        )
        .expect("a texture's texels fill its size");
        let half = image::imageops::resize(&img, w, h, image::imageops::FilterType::Triangle);
        smaller[i] = Arc::new(Texture {
            path: t.path.clone(),
            width: w,
            height: h,
            rgb: half.pixels().map(|p| p.0.map(srgb8)).collect(),
        });
    }
    let mut changed = Vec::new();
    for (old, new) in unique.iter().zip(&smaller) {
        if Arc::ptr_eq(old, new) {
            continue;
        }
        changed.push(format!(
            "{} {}x{} -> {}x{}",
            old.path.display(),
            old.width,
            old.height,
            new.width,
            new.height
        ));
        for m in materials.iter_mut() {
            if m.diffuse_map.as_ref().is_some_and(|t| Arc::ptr_eq(t, old)) {
                m.diffuse_map = Some(new.clone());
            }
        }
    }
    Some(format!(
        "the textures hold {before} texels, past the {budget} of the texture atlas (one storage binding every pipeline reads): read at lower resolution: {}",
        changed.join(", ")
    ))
}

/// The 8-bit sRGB code of a linear albedo (clamped to [0, 1]; NaN reads 0), as the previews are
/// written (`images::srgb8`).
fn srgb8(c: f32) -> u8 {
    (crate::images::srgb_encode(c) * 255.0 + 0.5) as u8
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    pub up: [f32; 3],
    pub fov_y_deg: f32,
    pub width: u32,
    pub height: u32,
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum Light {
    /// Radiant intensity (W/sr) per channel.
    Point {
        position: [f32; 3],
        intensity: [f32; 3],
    },
    /// `direction`: where the light travels; `cone_deg`: half-angle; `falloff_deg`: half-angle where
    /// the smooth falloff starts (defaults to `cone_deg`: a hard edge).
    Spot {
        position: [f32; 3],
        direction: [f32; 3],
        intensity: [f32; 3],
        cone_deg: f32,
        falloff_deg: Option<f32>,
    },
    /// `intensity`: irradiance on a surface facing the light (W/m^2).
    Directional {
        direction: [f32; 3],
        intensity: [f32; 3],
    },
}

impl Light {
    /// Its intensity (W/sr, or W/m^2 for a directional light) per channel.
    pub fn intensity(&self) -> [f32; 3] {
        match self {
            Light::Point { intensity, .. }
            | Light::Spot { intensity, .. }
            | Light::Directional { intensity, .. } => *intensity,
        }
    }

    fn intensity_mut(&mut self) -> &mut [f32; 3] {
        match self {
            Light::Point { intensity, .. }
            | Light::Spot { intensity, .. }
            | Light::Directional { intensity, .. } => intensity,
        }
    }
}

/// `[render]`: every key optional. Unknown keys are errors (typos should not pass silently).
#[derive(Clone, Debug, Deserialize, serde::Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct RenderSettings {
    /// The quality preset (`crate::quality`): the keys it sets apply where this file and the command
    /// line give none. `balanced` (the default) sets none.
    pub quality: crate::quality::Quality,
    /// Voxel grid side (a power of two, 8..=512).
    pub voxels: u32,
    /// AO occluder range in scene units.
    pub ao_range: f32,
    /// AO distance falloff 1 / (1 + lambda r).
    pub ao_lambda: f32,
    /// Diffuse cones per pixel (1..=64): up to 9 one along the normal and the rest in a ring, more on a
    /// cosine-weighted spiral over the hemisphere (`cone_trace::diffuse_cones`).
    pub cones: u32,
    /// Half-angle of the diffuse cones, degrees (0, 90).
    pub cone_half_angle: f32,
    /// Cone origins start this many level-0 voxels off the surface along its normal (>= 0).
    pub cone_offset: f32,
    /// Surface-aware mip clamp F (>= 0; 0 = off, the paper's rule): sampled cells stay below 1/F of
    /// the distance from the origin surface.
    pub mip_clamp: f32,
    /// Cone step as a fraction of the cone's diameter, (0, 1] (CPRC 4: 0.5).
    pub cone_step: f32,
    /// Every cone tracer: sampled mip level relative to the paper's log2(diameter / s0), in [-3, 0]
    /// (0 = the paper's rule). Narrow cones match their footprint about one level finer
    /// (`cone_trace::ConeParams::level_bias`; docs/accuracy/vct-dense.md).
    pub cone_level_bias: f32,
    /// Every cone tracer: how far a sample's coverage is taken as rays already blocked, in [0, 1]
    /// (0 = the paper's independent layers; 1: the cone's opacity is its densest sample's)
    /// (`cone_trace::ConeParams::coverage_correlation`; docs/accuracy/vct-dense.md).
    pub coverage_correlation: f32,
    /// vct-dense and cprc (the dense pyramid's cones): the depth-ordered blend — along the cone's main
    /// axis an opaque cell facing the cone hides the opaque cell behind it in the trilinear pair
    /// (`cone_trace::OrderedPyramid`); false = the paper's trilinear. Against light leaking through
    /// one-voxel walls (thin_wall).
    pub depth_ordered_blend: bool,
    /// vct-dense, vct-svo and lrsm (the per-pixel cone tracers; cprc's caches have their own cones):
    /// interleaved cone sets of side N in {1, 2, 4, 8} (1 = off, the paper's one set per pixel). The
    /// N x N pixel classes trace disjoint subsets of one spiral of `cones` N^2 cones and a resolve
    /// pass averages irradiance and occlusion over each pixel's (2N - 1)^2 neighbours on its own surface (tent weights)
    /// (`cone_trace::cone_dirs`, `cone_trace::resolve`; docs/accuracy/vct-dense.md): N^2 times the cones for
    /// the price of `cones` per pixel, blurred over N pixels.
    pub cone_interleave: u32,
    /// lrsm: RSM side per light view (a power of two, 4..=1024; the LRSM is half of it).
    pub rsm_side: u32,
    /// lrsm: depth splits a and <n.l> splits b: (a + 1) x (b + 1) layers (at most 64).
    pub lrsm_depth_splits: u32,
    pub lrsm_normal_splits: u32,
    /// lrsm: overlap of neighbouring depth layers (delta of eq. 15), in [0, 1 / (a + 1)].
    pub lrsm_overlap: f32,
    /// lrsm: occlusion mips by CPRC's surface coverage (a quarter of the children's sum, capped: a
    /// one-voxel wall stays opaque at every level; the default) instead of the paper's volume
    /// coverage (false: the solid fraction, so such a wall is 1/2^k opaque at level k and cones see
    /// through it).
    pub lrsm_surface_coverage: bool,
    /// lrsm: N = <n, vc> weighs each layer's radiance, as the paper's Algorithm 1 writes it, instead
    /// of only culling back faces (false, the default: a Lambertian surface's radiance does not
    /// depend on where it is seen from; eq. 2's view weight cancels for one surface).
    pub lrsm_view_weight: bool,
    /// lrsm: each RSM texel weighs `1 / <n.l>` (the surface it stands for) in the LRSMs' radiance
    /// and moments, which the gather reads as eq. 1's premultiplied product, one level finer, N
    /// weighing it (false, the default: Algorithm 1's opacity-weighted layers). Gathers 0.92-1.00
    /// of the reference's indirect energy where the default gathers about two thirds, at a worse
    /// FLIP on the Cornell box and thin_wall (docs/accuracy/lrsm.md).
    pub lrsm_area_weights: bool,
    /// lrsm: the gather reads each sample's light from the light views' lit texels injected into
    /// the occlusion pyramid's own cells (lit_cells: where a surface's occlusion is, its light is;
    /// every quality preset sets it) instead of Algorithm 1's light-space LRSM lookup (false, the
    /// default: the paper's layered RSMs, which put a wall's light half a cell off its occlusion).
    /// With narrow cones (the presets') it gathers 0.85-1.00 of the reference's indirect energy on
    /// six scenes where the LRSMs gather 0.66-1.41; with the defaults' five 30-degree cones less
    /// than the LRSMs (0.41 of the Cornell box's; part of it the cone's first coarse samples,
    /// opaque and culled: docs/accuracy/lrsm.md).
    pub lrsm_lit_cells: bool,
    /// lrsm: soft shadows — direct light's visibility from one cone of this half-angle (degrees) per
    /// light through the occlusion voxels instead of an exact shadow ray; 0 (the default) = exact rays,
    /// the light-transport contract. In [0, 45].
    pub shadow_cone_angle: f32,
    /// cprc: radiance-cache side in texels (hemi-octahedral; a power of two, 1..=64).
    pub cache_resolution: u32,
    /// cprc: side of each cache's cosine-folded irradiance map (a power of two, 1..=64; capped at
    /// cache_resolution).
    pub irradiance_resolution: u32,
    /// cprc: screen tile of the cache distribution, pixels (4..=64); about 3 caches per tile and
    /// depth slice it covers.
    pub cache_tile: u32,
    /// cprc: depth slices of the cluster keys (1..=64; exponential between 0.1 and 100 units).
    pub cache_depth_slices: u32,
    /// cprc: gathering radius in tiles (the paper's f; > 0, at most 8).
    pub gather_radius: f32,
    /// cprc: the gather's angle term, each cache's weight times max(0, n_p . n_c) (PCRC's angle
    /// limit; CPRC's weights have none): a cache whose hemisphere leans away from the pixel's fades
    /// out, none at 90 degrees, instead of the pixel reading its horizon. true (the default); false
    /// gathers with CPRC's w_w and w_s alone.
    pub gather_angle: bool,
    /// cprc: a frame after the first keeps the last frame's caches on the surfaces they were made
    /// on, where their surface is still in view in the same cluster (`cache_reuse`; the paper's
    /// sections 5-6: caches that follow surfaces instead of jumping between the pixels of their
    /// cluster). Applies to consecutive frames of one GPU-resident renderer (false, the default: every
    /// frame places its caches anew; a single frame is the same either way).
    pub cache_reuse: bool,
    /// cprc with `cache_reuse`: a kept cache also keeps its radiance texels, and is not traced again,
    /// in frames whose volume is the last frame's (nothing re-lit or moved: a camera moving through
    /// a still scene). The same record through the same voxels traces the same texels, so frames are
    /// the same either way; true (the default) skips the work.
    pub cache_carry: bool,
    /// vct-svo: light injection. The side of the light-view map rendered per light view (a power of
    /// two, 16..=2048), one photon per texel splatted into the octree's leaves (VCT 8.2); 0 lights
    /// the voxels with voxel_light's per-voxel direct light instead.
    pub photon_map: u32,
    /// vct-svo: anisotropic voxels (VCT 7.1): six directional values per voxel above the leaves,
    /// composited front to back per direction, read by the three facing the cone; false = the
    /// isotropic Gaussian average alone.
    pub anisotropic_voxels: bool,
    /// vct-svo: voxel shading with Gaussian lobes (VCT 4.3 and 7): a normal pool pre-multiplied by
    /// opacity, filtered with the octree; each sample's colour is scaled by the share of its normal
    /// lobe (variance from the averaged normal's length), convolved with the cone's, that faces the
    /// cone's origin; with photon injection, glossy surfaces' specular photons in a third pool send
    /// their light along a vMF lobe (VCT 7). False: voxels emit alike in every direction.
    pub voxel_lobes: bool,
    /// Bounces of indirect light, 1 or 2, for the reference and vct-svo (the other pipelines do one
    /// and refuse 2). vct-svo's second: every non-empty voxel gathers the first bounce through the
    /// octree with the diffuse cones (`svo_bounce`), its reflected light is added to the fragments and
    /// the octree rebuilt, so the camera's cones see two bounces.
    pub bounces: u32,
    /// Every GPU pipeline: samples per pixel side, 1..=4. The frame is rendered at `supersample` times
    /// the camera's width and height (settings in pixels, `cache_tile`, scale with it) and each pixel
    /// is the mean of its `supersample^2` samples — the reference's pixel is the mean over its area,
    /// the renders' otherwise its centre. 1 (the default): one sample at the centre.
    pub supersample: u32,
}

impl RenderSettings {
    /// The ranges every key must be in (also applied to CLI overrides).
    pub fn validate(&self) -> Result<(), String> {
        if !(8..=512).contains(&self.voxels) || !self.voxels.is_power_of_two() {
            return Err(format!(
                "voxels = {} must be a power of two in 8..=512",
                self.voxels
            ));
        }
        if !(self.ao_range > 0.0
            && self.ao_range.is_finite()
            && self.ao_lambda >= 0.0
            && self.ao_lambda.is_finite())
        {
            return Err(format!(
                "ao_range = {} must be > 0 and ao_lambda = {} >= 0, both finite",
                self.ao_range, self.ao_lambda
            ));
        }
        if !(1..=64).contains(&self.cones) {
            return Err(format!("cones = {} must be in 1..=64", self.cones));
        }
        if !(self.cone_half_angle > 0.0 && self.cone_half_angle < 90.0) {
            return Err(format!(
                "cone_half_angle = {} must be in (0, 90) degrees",
                self.cone_half_angle
            ));
        }
        if !(self.cone_offset >= 0.0 && self.cone_offset <= self.voxels as f32) {
            return Err(format!(
                "cone_offset = {} must be in [0, voxels = {}] (in voxels: a cone that starts past the grid reads nothing)",
                self.cone_offset, self.voxels
            ));
        }
        let min_step = crate::quality::MIN_CONE_STEP;
        if !(self.cone_step >= min_step && self.cone_step <= 1.0) {
            return Err(format!(
                "cone_step = {} must be in [{min_step}, 1] (cone diameters per step; a shorter step's opacity is lost to the GPU's f32 pow: quality::MIN_CONE_STEP)",
                self.cone_step
            ));
        }
        // A bias above 0 would read levels `levels_read` does not build.
        if !(-3.0..=0.0).contains(&self.cone_level_bias) {
            return Err(format!(
                "cone_level_bias = {} must be in [-3, 0] (levels finer than the paper's)",
                self.cone_level_bias
            ));
        }
        if !(0.0..=1.0).contains(&self.coverage_correlation) {
            return Err(format!(
                "coverage_correlation = {} must be in [0, 1]",
                self.coverage_correlation
            ));
        }
        if ![1, 2, 4, 8].contains(&self.cone_interleave) {
            return Err(format!(
                "cone_interleave = {} must be 1 (off), 2, 4 or 8",
                self.cone_interleave
            ));
        }
        if !(4..=1024).contains(&self.rsm_side) || !self.rsm_side.is_power_of_two() {
            return Err(format!(
                "rsm_side = {} must be a power of two in 4..=1024",
                self.rsm_side
            ));
        }
        let layers = (self.lrsm_depth_splits as u64 + 1) * (self.lrsm_normal_splits as u64 + 1);
        if layers > 64 {
            return Err(format!(
                "lrsm_depth_splits = {} and lrsm_normal_splits = {} give {layers} layers; at most 64",
                self.lrsm_depth_splits, self.lrsm_normal_splits
            ));
        }
        let slice = 1.0 / (self.lrsm_depth_splits as f32 + 1.0);
        if self.lrsm_overlap.is_nan() || self.lrsm_overlap < 0.0 {
            // Negative or NaN: nothing to do with the layers' width.
            return Err(format!(
                "lrsm_overlap = {} must be a number in [0, {slice}] (the overlap of neighbouring depth layers, a fraction of the light's depth range)",
                self.lrsm_overlap
            ));
        }
        if self.lrsm_overlap > slice {
            // The two keys bound each other: name both, and say which one holds its default.
            let default = Self::default();
            let mark = |set: bool| if set { "" } else { " (the default)" };
            // The most depth splits this overlap allows, by the check's own f32 comparison.
            let most_splits = (0..=63i64)
                .rev()
                .find(|&a| self.lrsm_overlap <= 1.0 / (a as f32 + 1.0))
                .unwrap_or(-1);
            return Err(format!(
                "lrsm_overlap = {}{} must be in [0, {slice}]: at most one depth layer, which lrsm_depth_splits = {}{} makes 1/{} wide; {} lrsm_overlap{}",
                self.lrsm_overlap,
                mark(self.lrsm_overlap != default.lrsm_overlap),
                self.lrsm_depth_splits,
                mark(self.lrsm_depth_splits != default.lrsm_depth_splits),
                self.lrsm_depth_splits + 1,
                "lower",
                if most_splits >= 0 {
                    format!(" or lrsm_depth_splits to at most {most_splits}")
                } else {
                    String::new()
                }
            ));
        }
        if !(self.shadow_cone_angle >= 0.0 && self.shadow_cone_angle <= 45.0) {
            return Err(format!(
                "shadow_cone_angle = {} must be in [0, 45] degrees (0 = exact shadow rays)",
                self.shadow_cone_angle
            ));
        }
        if !(1..=64).contains(&self.cache_resolution) || !self.cache_resolution.is_power_of_two() {
            return Err(format!(
                "cache_resolution = {} must be a power of two in 1..=64",
                self.cache_resolution
            ));
        }
        if !(1..=64).contains(&self.irradiance_resolution)
            || !self.irradiance_resolution.is_power_of_two()
        {
            return Err(format!(
                "irradiance_resolution = {} must be a power of two in 1..=64",
                self.irradiance_resolution
            ));
        }
        if !(4..=64).contains(&self.cache_tile) {
            return Err(format!(
                "cache_tile = {} must be in 4..=64",
                self.cache_tile
            ));
        }
        if !(1..=64).contains(&self.cache_depth_slices) {
            return Err(format!(
                "cache_depth_slices = {} must be in 1..=64",
                self.cache_depth_slices
            ));
        }
        if !(self.gather_radius > 0.0 && self.gather_radius <= 8.0) {
            return Err(format!(
                "gather_radius = {} must be in (0, 8] tiles",
                self.gather_radius
            ));
        }
        if !(1..=2).contains(&self.bounces) {
            return Err(format!("bounces = {} must be 1 or 2", self.bounces));
        }
        if !(1..=4).contains(&self.supersample) {
            return Err(format!(
                "supersample = {} must be in 1..=4",
                self.supersample
            ));
        }
        if self.cache_tile * self.supersample > 64 {
            return Err(format!(
                "cache_tile = {} x supersample = {} must be at most 64 (the tile is in samples)",
                self.cache_tile, self.supersample
            ));
        }
        if self.photon_map != 0
            && (!(16..=2048).contains(&self.photon_map) || !self.photon_map.is_power_of_two())
        {
            return Err(format!(
                "photon_map = {} must be 0 (voxel_light injection) or a power of two in 16..=2048",
                self.photon_map
            ));
        }
        if !(self.mip_clamp >= 0.0 && self.mip_clamp.is_finite()) {
            return Err(format!(
                "mip_clamp = {} must be finite and >= 0",
                self.mip_clamp
            ));
        }
        Ok(())
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            quality: crate::quality::Quality::Balanced,
            voxels: 128,
            ao_range: 0.5,
            ao_lambda: 1.0,
            cones: 5,
            cone_half_angle: 30.0,
            cone_offset: 2.0,
            // Measured on the Cornell box vs a 256-spp reference (docs/accuracy/vct-dense.md): combined FLIP
            // 0.287 without the clamp, 0.237 with 2; AO FLIP 0.85 -> 0.42.
            mip_clamp: 2.0,
            cone_step: 0.5,
            cone_level_bias: 0.0,
            coverage_correlation: 0.0,
            depth_ordered_blend: false,
            cone_interleave: 1,
            // 2 x 2 layers as the paper's Sibenik and Sponza; 128^2 per view keeps six cube faces
            // cheap on a software GPU.
            rsm_side: 128,
            lrsm_depth_splits: 1,
            lrsm_normal_splits: 1,
            lrsm_overlap: 0.05,
            lrsm_surface_coverage: true,
            lrsm_view_weight: false,
            lrsm_area_weights: false,
            lrsm_lit_cells: false,
            shadow_cone_angle: 0.0,
            // The paper's 16^2 caches and two-tile gathering radius; 16-pixel tiles give ~1000
            // caches at 256x256.
            cache_resolution: 16,
            irradiance_resolution: 8,
            cache_tile: 16,
            cache_depth_slices: 16,
            gather_radius: 2.0,
            gather_angle: true,
            cache_reuse: false,
            cache_carry: true,
            photon_map: 256,
            anisotropic_voxels: true,
            voxel_lobes: false,
            bounces: 1,
            supersample: 1,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshDesc {
    obj: String,
}

/// A rigid transform as written in a scene file: `translate`, `rotate_deg` (Euler angles about x, then
/// y, then z, degrees), `scale` (one factor or three), applied scale first; or a row-major 4x4
/// `matrix` (its last row 0 0 0 1), exclusive with the others.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    pub translate: Option<[f32; 3]>,
    pub rotate_deg: Option<[f32; 3]>,
    pub scale: Option<Scale>,
    pub matrix: Option<[[f32; 4]; 4]>,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum Scale {
    Uniform(f32),
    Axes([f32; 3]),
}

/// A keyframe of a dynamic instance: at `frame`, these transform parts (missing ones: identity);
/// between keyframes each part is interpolated linearly, before the first and after the last held.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    pub frame: u32,
    pub translate: Option<[f32; 3]>,
    pub rotate_deg: Option<[f32; 3]>,
    pub scale: Option<Scale>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct InstanceDesc {
    obj: String,
    #[serde(default)]
    transform: TransformDesc,
    #[serde(default)]
    dynamic: bool,
    #[serde(default)]
    keyframes: Vec<Keyframe>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    mesh: Option<MeshDesc>,
    #[serde(default)]
    instances: Vec<InstanceDesc>,
    camera: CameraDesc,
    #[serde(default)]
    lights: Vec<Light>,
    #[serde(default)]
    render: RenderSettings,
}

/// A texture statement's options and its file: `map_Kd -s 2 2 1 -o 0.5 0.5 0 my tex.png` gives
/// (`-s 2 2 1 -o 0.5 0.5 0`, `my tex.png`). Options (MTL's `-blendu`, `-s`, `-o`, `-bm`, ...) come
/// first, each a dash-led word and its values (numbers, or MTL's words for them: `on`, `off`, a
/// channel, a reflection map's face); the file is the rest, spaces and all. A statement whose rest
/// would be empty keeps its last word as the file.
fn map_options(statement: &str) -> (String, &str) {
    let t = statement.trim();
    const WORDS: [&str; 15] = [
        "on",
        "off",
        "r",
        "g",
        "b",
        "m",
        "l",
        "z",
        "sphere",
        "cube_top",
        "cube_bottom",
        "cube_front",
        "cube_back",
        "cube_left",
        "cube_right",
    ];
    let mut rest = t;
    let mut in_option = false;
    loop {
        let word = rest.split_whitespace().next().unwrap_or("");
        let value = in_option && (word.parse::<f32>().is_ok() || WORDS.contains(&word));
        if word.is_empty() || !(word.starts_with('-') && word.parse::<f32>().is_err() || value) {
            break;
        }
        in_option = true;
        rest = rest.trim_start()[word.len()..].trim_start();
    }
    if rest.is_empty() {
        return match t.rsplit_once(char::is_whitespace) {
            Some((options, file)) => (options.trim().to_string(), file),
            None => (String::new(), t),
        };
    }
    let options = t[..t.len() - rest.len()].trim().to_string();
    (options, rest)
}

/// The keys of a scene file's `[render]` table (none where the text does not parse: the scene's own
/// parse reports that).
fn render_keys(text: &str) -> std::collections::BTreeSet<String> {
    text.parse::<toml::Table>()
        .ok()
        .and_then(|t| t.get("render").and_then(|r| r.as_table()).cloned())
        .map(|r| r.keys().cloned().collect())
        .unwrap_or_default()
}

/// Diffuse albedo (Kd) and normalised Phong lobe (Ks, Ns).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub diffuse: [f32; 3],
    pub specular: [f32; 3],
    pub shininess: f32,
    /// `map_Kd` (resolved against the OBJ's folder, loaded): replaces `diffuse` where present.
    pub diffuse_map: Option<Arc<Texture>>,
}

impl Material {
    pub fn grey() -> Self {
        Self {
            name: "default grey".into(),
            diffuse: [0.8; 3],
            specular: [0.0; 3],
            shininess: 1.0,
            diffuse_map: None,
        }
    }
    pub fn is_glossy(&self) -> bool {
        self.specular.iter().any(|&s| s > 0.0)
    }
}

/// Triangles with per-vertex positions, normals (from `vn`, else flat from the winding: the front
/// is the side from which the vertices appear counter-clockwise) and texture coordinates (from `vt`,
/// else zero), and a material per triangle.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
    pub material: Vec<u32>,
}

#[derive(Clone, Debug)]
pub struct Scene {
    pub mesh: Mesh,
    pub materials: Vec<Material>,
    pub camera: CameraDesc,
    pub lights: Vec<Light>,
    pub render: RenderSettings,
    /// Things worth telling the user that do not stop loading (e.g. no .mtl).
    pub warnings: Vec<String>,
    /// `[[instances]]`: rigid instances of OBJ meshes; `mesh` holds them placed at `frame`.
    pub instances: Instances,
    /// The `[render]` keys the scene file gave (and, from the command line, the flags set): a
    /// quality preset leaves them as they are.
    pub explicit_render: std::collections::BTreeSet<String>,
}

/// A scene's rigid instances and what they are placed on: `mesh` = `base` + every instance's local
/// mesh transformed at the current frame ([`Scene::at_frame`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Instances {
    /// The `[mesh]` part (empty without one).
    pub base: Mesh,
    pub list: Vec<Instance>,
    /// The frame `mesh` shows.
    pub frame: u32,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// The OBJ it came from.
    pub name: String,
    /// In its own frame, material indices into the scene's materials.
    pub local: Mesh,
    pub transform: Transform,
    pub dynamic: bool,
    pub keyframes: Vec<Keyframe>,
}

/// A rigid transform: scale, then rotation (Euler x, y, z in degrees), then translation; or a matrix.
#[derive(Clone, Debug, PartialEq)]
pub enum Transform {
    Parts {
        translate: Vec3,
        rotate_deg: Vec3,
        scale: Vec3,
    },
    Matrix(glam::Mat4),
}

impl Transform {
    pub fn matrix(&self) -> glam::Mat4 {
        match self {
            Transform::Parts {
                translate,
                rotate_deg,
                scale,
            } => {
                let r = rotate_deg.to_array().map(f32::to_radians);
                glam::Mat4::from_scale_rotation_translation(
                    *scale,
                    glam::Quat::from_euler(glam::EulerRot::ZYX, r[2], r[1], r[0]),
                    *translate,
                )
            }
            Transform::Matrix(m) => *m,
        }
    }

    fn parts(
        translate: Option<[f32; 3]>,
        rotate_deg: Option<[f32; 3]>,
        scale: Option<Scale>,
    ) -> Self {
        Transform::Parts {
            translate: Vec3::from(translate.unwrap_or([0.0; 3])),
            rotate_deg: Vec3::from(rotate_deg.unwrap_or([0.0; 3])),
            scale: match scale {
                None => Vec3::ONE,
                Some(Scale::Uniform(s)) => Vec3::splat(s),
                Some(Scale::Axes(a)) => Vec3::from(a),
            },
        }
    }

    fn from_desc(d: &TransformDesc) -> Result<Self, String> {
        let t = match d.matrix {
            Some(m) => {
                if d.translate.is_some() || d.rotate_deg.is_some() || d.scale.is_some() {
                    return Err("transform: matrix excludes translate, rotate_deg and scale".into());
                }
                if m[3] != [0.0, 0.0, 0.0, 1.0] {
                    return Err(format!(
                        "transform: the matrix's last row {:?} must be [0, 0, 0, 1]",
                        m[3]
                    ));
                }
                Transform::Matrix(glam::Mat4::from_cols_array_2d(&m).transpose())
            }
            None => Self::parts(d.translate, d.rotate_deg, d.scale),
        };
        t.check()?;
        Ok(t)
    }

    fn check(&self) -> Result<(), String> {
        let m = self.matrix();
        if !m.is_finite() {
            return Err("transform: not finite".into());
        }
        let det = glam::Mat3::from_mat4(m).determinant();
        if det.is_nan() || det.abs() <= 1e-12 {
            return Err(format!(
                "transform: singular or nearly (the determinant of its 3x3 part is {det:e}, at most 1e-12 in magnitude, as a uniform scale of 1e-4 gives)"
            ));
        }
        Ok(())
    }

    /// Linear interpolation of two keyframes' parts at fraction `a`.
    fn lerp(a: &Keyframe, b: &Keyframe, f: f32) -> Self {
        let (ta, tb) = (
            Self::parts(a.translate, a.rotate_deg, a.scale),
            Self::parts(b.translate, b.rotate_deg, b.scale),
        );
        match (ta, tb) {
            (
                Transform::Parts {
                    translate: t0,
                    rotate_deg: r0,
                    scale: s0,
                },
                Transform::Parts {
                    translate: t1,
                    rotate_deg: r1,
                    scale: s1,
                },
            ) => Transform::Parts {
                translate: t0.lerp(t1, f),
                rotate_deg: r0.lerp(r1, f),
                scale: s0.lerp(s1, f),
            },
            _ => unreachable!("keyframes are parts"),
        }
    }
}

impl Instance {
    /// The transform at `frame`: its keyframes' (interpolated, held at the ends) where it has any,
    /// else its own.
    pub fn transform_at(&self, frame: u32) -> Transform {
        let k = &self.keyframes;
        if !self.dynamic || k.is_empty() {
            return self.transform.clone();
        }
        let i = k.partition_point(|kf| kf.frame <= frame);
        if i == 0 {
            return Transform::lerp(&k[0], &k[0], 0.0);
        }
        if i == k.len() {
            return Transform::lerp(&k[i - 1], &k[i - 1], 0.0);
        }
        let (a, b) = (&k[i - 1], &k[i]);
        Transform::lerp(a, b, (frame - a.frame) as f32 / (b.frame - a.frame) as f32)
    }

    /// Its mesh in the scene at `frame`: positions by the matrix, normals by its inverse transpose,
    /// winding reversed where the matrix mirrors (so front faces stay front faces).
    pub fn placed(&self, frame: u32) -> Mesh {
        let m = self.transform_at(frame).matrix();
        let nm = glam::Mat3::from_mat4(m).inverse().transpose();
        let mirror = glam::Mat3::from_mat4(m).determinant() < 0.0;
        let l = &self.local;
        Mesh {
            positions: l.positions.iter().map(|&p| m.transform_point3(p)).collect(),
            normals: l
                .normals
                .iter()
                .map(|&n| (nm * n).normalize_or_zero())
                .collect(),
            uvs: l.uvs.clone(),
            triangles: if mirror {
                l.triangles.iter().map(|t| [t[0], t[2], t[1]]).collect()
            } else {
                l.triangles.clone()
            },
            material: l.material.clone(),
        }
    }
}

impl Mesh {
    /// The smallest box holding every vertex, `(lo, hi)`; `(+inf, -inf)` for a mesh without
    /// vertices.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        )
    }

    /// Empty space that stretches the voxel grid (a cube of the bounds' longest extent, its side):
    /// named where the grid's side without it would be at most `1 / FAR_STRETCH` of what it is. The
    /// bounds are cut into [`FAR_BINS`] slabs along each axis, each triangle's area spread over the
    /// slabs its extent spans; a slab holding less than [`FAR_EMPTY`] of the mean slab's area is
    /// empty, and each axis's extent less its empty slabs is what the grid would need along it.
    /// Finds a small object far from the rest, several of them, and a stray sliver reaching far out
    /// (a bad vertex), none of which leaves the grid's voxels where the surfaces are; surfaces
    /// spread through the grid (a ground plane or a sky dome around a small scene) are content and
    /// are not named.
    pub fn far_geometry(&self) -> Option<FarGeometry> {
        let tri = |i: usize| self.triangles[i].map(|v| self.positions[v as usize]);
        let n = self.triangles.len();
        let (lo, hi) = self.bounds();
        let side = (hi - lo).max_element();
        // An empty or flat mesh, or one whose extent passes f32's range: nothing to measure.
        if n == 0 || side.is_nan() || side <= 0.0 || !side.is_finite() {
            return None;
        }
        let areas: Vec<f64> = (0..n)
            .map(|i| {
                let [a, b, c] = tri(i);
                0.5 * (b - a).as_dvec3().cross((c - a).as_dvec3()).length()
            })
            .collect();
        let total: f64 = areas.iter().sum();
        if !total.is_finite() || total <= 0.0 {
            return None;
        }
        // Per axis, the length of the bounds holding almost no surface.
        let mut empty = [0.0f32; 3];
        for (axis, empty) in empty.iter_mut().enumerate() {
            let extent = hi[axis] - lo[axis];
            if extent <= 0.0 {
                continue;
            }
            let bin = extent / FAR_BINS as f32;
            let mut slabs = [0.0f64; FAR_BINS];
            for (i, &area) in areas.iter().enumerate() {
                let c = tri(i).map(|p| (p[axis] - lo[axis]) / bin);
                let (a, b) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
                let (first, last) = (
                    (a.floor().max(0.0) as usize).min(FAR_BINS - 1),
                    (b.floor().max(0.0) as usize).min(FAR_BINS - 1),
                );
                if first == last {
                    slabs[first] += area;
                    continue;
                }
                for (k, slab) in slabs.iter_mut().enumerate().take(last + 1).skip(first) {
                    let overlap = (b.min(k as f32 + 1.0) - a.max(k as f32)).max(0.0);
                    *slab += area * (overlap / (b - a)) as f64;
                }
            }
            *empty = slabs
                .iter()
                .filter(|&&a| a < FAR_EMPTY * total / FAR_BINS as f64)
                .count() as f32
                * bin;
        }
        // The grid's side were the empty space gone (at least a slab of the longest axis): named
        // when that halves it or more. Empty space along a shorter axis that leaves the side as
        // it is (a backdrop above a wide terrain) is not.
        let shrunk = (0..3)
            .map(|a| hi[a] - lo[a] - empty[a])
            .fold(side / FAR_BINS as f32, f32::max);
        if side / shrunk < FAR_STRETCH {
            return None;
        }
        let axis = (0..3).max_by(|&a, &b| empty[a].total_cmp(&empty[b]))?;
        // The triangle reaching farthest towards the low (sign -1) or high (+1) end.
        let reach = |i: usize, sign: f32| {
            (tri(i).iter()).fold(f32::NEG_INFINITY, |m, p| m.max(p[axis] * sign))
        };
        let reaches = |sign: f32| (0..n).max_by(|&i, &j| reach(i, sign).total_cmp(&reach(j, sign)));
        Some(FarGeometry {
            axis,
            side,
            empty: empty[axis],
            shrunk,
            ends: [(reaches(-1.0)?, lo[axis]), (reaches(1.0)?, hi[axis])],
        })
    }

    /// Append `other` (its vertex indices shifted).
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.uvs.extend_from_slice(&other.uvs);
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|v| v + base)));
        self.material.extend_from_slice(&other.material);
    }
}

/// `x` to four significant digits, for messages.
fn sig(x: f32) -> String {
    if x == 0.0 || !x.is_finite() {
        return x.to_string();
    }
    let scale = 10f64.powi(3 - (x.abs() as f64).log10().floor() as i32);
    ((x as f64 * scale).round() / scale).to_string()
}

/// [`Mesh::far_geometry`]: the grid's stretch from which it is named (its voxels twice as coarse as
/// the surfaces need: a power of two of `voxels` lost).
pub const FAR_STRETCH: f32 = 2.0;
/// [`Mesh::far_geometry`]: the slabs along each axis.
pub const FAR_BINS: usize = 64;
/// [`Mesh::far_geometry`]: a slab holding less than this share of the mean slab's area is empty.
pub const FAR_EMPTY: f64 = 1e-3;

/// Empty space stretching a mesh's voxel grid ([`Mesh::far_geometry`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FarGeometry {
    /// The axis with the most empty space (0 = x, 1 = y, 2 = z), the grid's side, how much of the
    /// bounds along the axis holds almost no surface, and the side the grid would have without the
    /// empty space along every axis.
    pub axis: usize,
    pub side: f32,
    pub empty: f32,
    pub shrunk: f32,
    /// The triangles reaching the bounds' two ends along the axis, and those ends.
    pub ends: [(usize, f32); 2],
}

const CORNELL_OBJ: &str = include_str!("../scenes/cornell_box.obj");
const CORNELL_MTL: &str = include_str!("../scenes/cornell_box.mtl");
const CORNELL_TOML: &str = include_str!("../scenes/cornell_box.toml");

const THIN_WALL_OBJ: &str = include_str!("../scenes/thin_wall.obj");
const THIN_WALL_MTL: &str = include_str!("../scenes/thin_wall.mtl");
const THIN_WALL_TOML: &str = include_str!("../scenes/thin_wall.toml");

impl Scene {
    /// The built-in Cornell box (also shipped as scenes/cornell_box.toml).
    pub fn cornell_box() -> Self {
        Self::embedded("cornell_box", CORNELL_TOML, CORNELL_OBJ, CORNELL_MTL)
    }

    /// The built-in light-leak scene (also shipped as scenes/thin_wall.toml).
    pub fn thin_wall() -> Self {
        Self::embedded("thin_wall", THIN_WALL_TOML, THIN_WALL_OBJ, THIN_WALL_MTL)
    }

    /// `mesh` alone in this scene's settings, materials, camera and lights, without instances:
    /// what one voxel hierarchy is voxelized from. Copies neither this scene's mesh nor its
    /// instance list, so building one per instance stays linear in the instances.
    pub fn with_mesh_alone(&self, mesh: Mesh) -> Self {
        Self {
            mesh,
            materials: self.materials.clone(),
            camera: self.camera.clone(),
            lights: self.lights.clone(),
            render: self.render.clone(),
            warnings: Vec::new(),
            instances: Instances::default(),
            explicit_render: self.explicit_render.clone(),
        }
    }

    /// This scene with every light's intensity times `f`.
    pub fn with_lights_scaled(&self, f: f32) -> Self {
        let mut s = self.clone();
        for l in &mut s.lights {
            *l.intensity_mut() = l.intensity().map(|c| c * f);
        }
        s
    }

    /// This scene with its camera orbited `deg` degrees about the target (around the camera's up
    /// axis): the next view of a camera path.
    pub fn orbited(&self, deg: f32) -> Self {
        use glam::Quat;
        let mut s = self.clone();
        let c = &mut s.camera;
        let (eye, target) = (Vec3::from(c.eye), Vec3::from(c.target));
        let axis = Vec3::from(c.up).normalize();
        c.eye =
            (target + Quat::from_axis_angle(axis, deg.to_radians()) * (eye - target)).to_array();
        s
    }

    /// The scene whose pixels are this one's `supersample` x `supersample` samples: the camera's
    /// width and height and the pixel-measured `cache_tile` times `supersample`, supersample 1. Errors
    /// where the sampled image would pass the camera's 8192-pixel limit.
    pub fn supersampled(&self) -> Result<Self, String> {
        let f = self.render.supersample;
        let mut s = self.clone();
        s.camera.width *= f;
        s.camera.height *= f;
        s.render.cache_tile *= f;
        s.render.supersample = 1;
        validate_camera(&s.camera).map_err(|e| format!("supersample = {f}: {e}"))?;
        s.render.validate()?;
        Ok(s)
    }

    /// A built-in scene by name (`cornell_box`, `thin_wall`).
    pub fn builtin(name: &str) -> Option<Self> {
        match name {
            "cornell_box" => Some(Self::cornell_box()),
            "thin_wall" => Some(Self::thin_wall()),
            _ => None,
        }
    }

    fn embedded(name: &str, toml_text: &str, obj: &str, mtl: &str) -> Self {
        let explicit = render_keys(toml_text);
        let file: SceneFile = toml::from_str(toml_text).expect("built-in scene parses");
        let label = format!("built-in {name}");
        let mut notes = Vec::new();
        let (text, materials) =
            obj_input::mtl_text(&label, mtl, &mut notes).expect("built-in .mtl reads");
        let mtl = vec![MtlSource {
            label: format!("built-in {name}.mtl"),
            text,
            dir: PathBuf::from("."),
            materials,
        }];
        let loaded = load_obj_text(obj, &mtl);
        Self::assemble(
            &label,
            file,
            Some(ObjSource {
                label: label.clone(),
                loaded,
                text: obj.to_string(),
                dir: PathBuf::from("."),
                mtl,
                notes,
            }),
            Vec::new(),
        )
        .map(|s| Scene {
            explicit_render: explicit,
            ..s
        })
        .expect("built-in scene is valid")
    }

    /// Load a scene file; paths inside it are relative to it.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, SceneError> {
        let path = path.as_ref();
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
            path: p.clone(),
            source,
        })?;
        let file: SceneFile = toml::from_str(&text).map_err(|e| {
            let (line, column) = e.span().map(|s| line_col(&text, s.start)).unwrap_or((0, 0));
            SceneError::Toml {
                path: p.clone(),
                line,
                column,
                message: e.message().to_string(),
            }
        })?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let read_obj = |obj: &str| -> Result<ObjSource, SceneError> {
            let obj_path = resolve_crate_path(obj)
                .map_err(|message| SceneError::Obj {
                    path: p.clone(),
                    obj: obj.to_string(),
                    message,
                })?
                .unwrap_or_else(|| dir.join(obj));
            let bytes = std::fs::read(&obj_path).map_err(|e| SceneError::Obj {
                path: p.clone(),
                obj: obj_path.display().to_string(),
                message: e.to_string(),
            })?;
            let mut notes = Vec::new();
            let label = obj_path.display().to_string();
            let text = obj_input::obj_text(
                &label,
                &obj_input::decode(&label, bytes, &mut notes),
                &mut notes,
            );
            let obj_dir = obj_input::folder_of(&obj_path);
            let mtl = read_mtls(&text, &obj_dir, &mut notes).map_err(|e| match e {
                SceneError::Obj { obj, message, .. } => SceneError::Obj {
                    path: p.clone(),
                    obj,
                    message,
                },
                e => e,
            })?;
            // tobj is not known to panic on what passed the checks above; should it, the panic is
            // an error naming the file, not an abort.
            let loaded = std::panic::catch_unwind(|| load_obj_text(&text, &mtl)).map_err(|_| {
                SceneError::Obj {
                    path: p.clone(),
                    obj: label.clone(),
                    message: "the OBJ reader (tobj) failed on this file or its .mtl".into(),
                }
            })?;
            Ok(ObjSource {
                label,
                loaded,
                text,
                dir: obj_dir,
                mtl,
                notes,
            })
        };
        let base = file.mesh.as_ref().map(|m| read_obj(&m.obj)).transpose()?;
        let instances = file
            .instances
            .iter()
            .map(|i| read_obj(&i.obj))
            .collect::<Result<Vec<_>, _>>()?;
        let label = base
            .as_ref()
            .map(|b| b.label.clone())
            .unwrap_or_else(|| p.clone());
        // Values that parsed but are out of range: the file, and the line of the key they name.
        let at = |table: &str, index: usize, message: &str| match message_line(
            &text, table, index, message,
        ) {
            Some(line) => format!("{p}:{line}"),
            None => p.clone(),
        };
        Self::assemble(&label, file, base, instances)
            .map_err(|e| match e {
                SceneError::Camera { message, .. } => SceneError::Camera {
                    path: at("camera", 0, &message),
                    message,
                },
                SceneError::Light { index, message, .. } => SceneError::Light {
                    path: at("lights", index, &message),
                    index,
                    message,
                },
                SceneError::Render { message, .. } => SceneError::Render {
                    path: at("render", 0, &message),
                    message,
                },
                SceneError::Instance { index, message, .. } => SceneError::Instance {
                    path: at("instances", index, &message),
                    index,
                    message,
                },
                SceneError::NoGeometry { .. } => SceneError::NoGeometry { path: p.clone() },
                other => other,
            })
            .map(|s| Scene {
                explicit_render: render_keys(&text),
                ..s
            })
    }

    /// The scene from its file and OBJs: the `[mesh]` (if any) and every instance's mesh, placed at
    /// frame 0; materials of each OBJ after the earlier ones, an equal material loaded once.
    fn assemble(
        obj_label: &str,
        mut file: SceneFile,
        base: Option<ObjSource>,
        instance_objs: Vec<ObjSource>,
    ) -> Result<Self, SceneError> {
        let mut warnings = Vec::new();
        let (base, mut materials) = match base {
            Some(src) => obj_mesh(src, &mut warnings)?,
            None => (Mesh::default(), Vec::new()),
        };
        let mut list = Vec::new();
        for (index, (desc, src)) in file.instances.iter().zip(instance_objs).enumerate() {
            let err = |message: String| SceneError::Instance {
                path: obj_label.into(),
                index,
                message,
            };
            let name = src.label.clone();
            let (mut local, mats) = obj_mesh(src, &mut warnings)?;
            // A material equal to one already loaded (the same OBJ instanced again) is that one:
            // instances of one OBJ then have equal meshes, which share one voxelization.
            let shared: Vec<u32> = mats
                .into_iter()
                .map(|mat| match materials.iter().position(|m| *m == mat) {
                    Some(k) => k as u32,
                    None => {
                        materials.push(mat);
                        materials.len() as u32 - 1
                    }
                })
                .collect();
            for m in &mut local.material {
                *m = shared[*m as usize];
            }
            let transform = Transform::from_desc(&desc.transform).map_err(err)?;
            if !desc.keyframes.is_empty() && !desc.dynamic {
                return Err(err("keyframes need dynamic = true".into()));
            }
            for w in desc.keyframes.windows(2) {
                if w[1].frame <= w[0].frame {
                    return Err(err(format!(
                        "keyframe frames must increase ({} then {})",
                        w[0].frame, w[1].frame
                    )));
                }
            }
            for k in &desc.keyframes {
                Transform::parts(k.translate, k.rotate_deg, k.scale)
                    .check()
                    .map_err(|m| err(format!("keyframe {}: {m}", k.frame)))?;
            }
            list.push(Instance {
                name,
                local,
                transform,
                dynamic: desc.dynamic,
                keyframes: desc.keyframes.clone(),
            });
        }
        let instances = Instances {
            base,
            list,
            frame: 0,
        };
        // Between two keyframes the scale, rotation and translation are interpolated apart, so a
        // vertex is bounded by its distance from the origin times the larger scale plus the larger
        // translation of the two (rotation keeps lengths); a scale changing sign is singular in between.
        for (index, inst) in instances.list.iter().enumerate() {
            let err = |message: String| SceneError::Instance {
                path: obj_label.into(),
                index,
                message,
            };
            let radius = inst
                .local
                .positions
                .iter()
                .fold(0.0f64, |m, p| m.max(p.as_dvec3().length()));
            for w in inst.keyframes.windows(2) {
                let parts =
                    |k: &Keyframe| match Transform::parts(k.translate, k.rotate_deg, k.scale) {
                        Transform::Parts {
                            translate, scale, ..
                        } => (translate.as_dvec3(), scale.as_dvec3()),
                        Transform::Matrix(_) => unreachable!("keyframes are parts"),
                    };
                let ((t0, s0), (t1, s1)) = (parts(&w[0]), parts(&w[1]));
                if (0..3).any(|a| s0[a] * s1[a] < 0.0) {
                    return Err(err(format!(
                        "keyframes {} and {}: a scale changes sign between them (the transform is singular in between)",
                        w[0].frame, w[1].frame
                    )));
                }
                let bound =
                    radius * s0.abs().max(s1.abs()).max_element() + t0.abs().max(t1.abs()).length();
                if bound > MAX_COORDINATE as f64 {
                    return Err(err(format!(
                        "transform: between keyframes {} and {} its vertices may reach {bound:e}, past the renderable range (coordinates within +-{MAX_COORDINATE:e} scene units: products of larger ones overflow f32)",
                        w[0].frame, w[1].frame
                    )));
                }
            }
        }
        // Placed geometry must stay in range at frame 0 and at each keyframe.
        for (index, inst) in instances.list.iter().enumerate() {
            let frames = std::iter::once(0).chain(inst.keyframes.iter().map(|k| k.frame));
            for frame in frames {
                let placed = inst.placed(frame);
                if let Some((i, p)) = placed
                    .positions
                    .iter()
                    .enumerate()
                    .find(|(_, p)| !(p.is_finite() && in_range(**p)))
                {
                    return Err(SceneError::Instance {
                        path: obj_label.into(),
                        index,
                        message: format!(
                            "transform: at frame {frame} its vertex {i} is at {:?}, past the renderable range (coordinates within +-{MAX_COORDINATE:e} scene units: products of larger ones overflow f32)",
                            p.to_array()
                        ),
                    });
                }
            }
        }
        let mesh = instances.mesh_at(0);
        if mesh.triangles.is_empty() {
            return Err(SceneError::NoGeometry {
                path: obj_label.into(),
            });
        }
        if finite3(file.camera.up) {
            file.camera.up = rescaled_direction(file.camera.up);
        }
        for l in &mut file.lights {
            match l {
                Light::Spot { direction, .. } | Light::Directional { direction, .. }
                    if finite3(*direction) =>
                {
                    *direction = rescaled_direction(*direction);
                }
                _ => {}
            }
        }
        validate_camera(&file.camera).map_err(|message| SceneError::Camera {
            path: obj_label.into(),
            message,
        })?;
        for (index, l) in file.lights.iter().enumerate() {
            validate_light(l).map_err(|message| SceneError::Light {
                path: obj_label.into(),
                index,
                message,
            })?;
        }
        file.render
            .validate()
            .map_err(|message| SceneError::Render {
                path: obj_label.into(),
                message,
            })?;
        if file.lights.is_empty() {
            warnings.push("the scene has no lights: every image will be black".into());
        }
        // Frame 0, then each dynamic instance's keyframes (at most 32 frames): the first that
        // stretches the grid is named.
        let mut frames: Vec<u32> = (instances.list.iter())
            .flat_map(|i| i.keyframes.iter().map(|k| k.frame))
            .filter(|&f| f != instances.frame)
            .collect();
        frames.sort_unstable();
        frames.dedup();
        let far = std::iter::once(None)
            .chain(frames.into_iter().take(32).map(Some))
            .find_map(|f| {
                let g = match f {
                    None => mesh.far_geometry(),
                    Some(f) => instances.mesh_at(f).far_geometry(),
                };
                g.map(|g| (f, g))
            });
        if let Some((frame, f)) = far {
            let axis = ["x", "y", "z"][f.axis];
            let end = |(t, at): (usize, f32)| {
                let material =
                    (materials.get(mesh.material[t] as usize)).map_or("?", |m| m.name.as_str());
                format!(
                    "triangle {t} of material {material} at {axis} = {}",
                    sig(at)
                )
            };
            warnings.push(format!(
                "{:.0}% of the voxel grid's side along {axis} holds almost no surface ({} of {}{}): the grid covers the scene's bounds, so its voxels are up to {:.1} times coarser than the surfaces need; the bounds' ends along {axis}: {}, {} (remove stray or far geometry, or raise voxels)",
                100.0 * f.empty / f.side,
                sig(f.empty),
                sig(f.side),
                frame.map_or(String::new(), |f| format!(", at frame {f}")),
                f.side / f.shrunk,
                end(f.ends[0]),
                end(f.ends[1]),
            ));
        }
        if let Some(w) = fit_textures(&mut materials, crate::trace::ATLAS_TEXELS) {
            warnings.push(w);
        }
        Ok(Scene {
            mesh,
            materials,
            camera: file.camera,
            lights: file.lights,
            render: file.render,
            warnings,
            instances,
            explicit_render: Default::default(),
        })
    }

    /// This scene at animation frame `frame`: dynamic instances moved to their keyframes' transform
    /// there (everything else unchanged; a scene without instances is returned as it is).
    pub fn at_frame(&self, frame: u32) -> Self {
        let mut s = self.clone();
        if !self.instances.list.is_empty() {
            s.mesh = self.instances.mesh_at(frame);
            s.instances.frame = frame;
        }
        s
    }
}

impl Instances {
    /// `base` and every instance placed at `frame`.
    pub fn mesh_at(&self, frame: u32) -> Mesh {
        let mut mesh = self.base.clone();
        for i in &self.list {
            mesh.append(&i.placed(frame));
        }
        mesh
    }
}

/// One OBJ to load: its label (path), tobj's result, its text (for line numbers) and folder.
struct ObjSource {
    label: String,
    loaded: tobj::LoadResult,
    text: String,
    dir: PathBuf,
    /// The .mtl files its `mtllib` lines name, for material errors' lines and textures' folders.
    mtl: Vec<MtlSource>,
    /// What reading the files changed or left out (`obj_input`): loader warnings.
    notes: Vec<String>,
}

/// A .mtl file as tobj reads it (`obj_input::mtl_text`): its label (path), text, folder and the
/// materials it defines.
struct MtlSource {
    label: String,
    text: String,
    dir: PathBuf,
    materials: Vec<String>,
}

/// The .mtl files an OBJ's `mtllib` lines name, found beside it (`obj_input::find_file`; an argument
/// that names no file is read as several file names, as the format allows), each read as tobj reads
/// it. A file that is not there is a note naming where it was looked for (the only word of it: tobj
/// is given no file to fail on). A file that cannot be read is [`SceneError::Obj`] (its `path` the
/// caller's to fill), a statement that cannot be [`SceneError::Material`].
fn read_mtls(
    obj_text: &str,
    obj_dir: &Path,
    notes: &mut Vec<String>,
) -> Result<Vec<MtlSource>, SceneError> {
    let mut out = Vec::new();
    for named_as in obj_text
        .lines()
        .filter_map(|l| l.trim().strip_prefix("mtllib "))
        .map(str::trim)
    {
        let files: Vec<(String, Option<PathBuf>)> = match obj_input::find_file(&[obj_dir], named_as)
        {
            Some(f) => vec![(named_as.to_string(), Some(f))],
            None => named_as
                .split_whitespace()
                .map(|w| (w.to_string(), obj_input::find_file(&[obj_dir], w)))
                .collect(),
        };
        if files.iter().all(|(_, f)| f.is_none()) {
            notes.push(format!(
                "no usable .mtl (mtllib {named_as}: no such file in {}): its materials are grey diffuse 0.8",
                obj_dir.display()
            ));
            continue;
        }
        for (name, file) in files {
            let Some(file) = file else {
                notes.push(format!(
                    "mtllib {name}: no such file in {}",
                    obj_dir.display()
                ));
                continue;
            };
            let label = file.display().to_string();
            let bytes = std::fs::read(&file).map_err(|e| SceneError::Obj {
                path: String::new(),
                obj: label.clone(),
                message: e.to_string(),
            })?;
            let decoded = obj_input::decode(&label, bytes, notes);
            let (text, materials) =
                obj_input::mtl_text(&label, &decoded, notes).map_err(|e| SceneError::Material {
                    path: label.clone(),
                    line: e.line,
                    name: e.material,
                    message: e.message,
                })?;
            out.push(MtlSource {
                label,
                text,
                dir: obj_input::folder_of(&file),
                materials,
            });
        }
    }
    Ok(out)
}

/// tobj's reading of an OBJ's text (`obj_input::obj_text`) with its .mtl files as read by
/// [`read_mtls`], all of them before the OBJ's first statement: tobj resolves a `usemtl` against
/// the materials read so far, so one before its `mtllib` line found nothing. (tobj's errors carry
/// no line; [`obj_error_line`] finds it in the OBJ's own text.)
fn load_obj_text(text: &str, mtl: &[MtlSource]) -> tobj::LoadResult {
    const EVERY: &str = "\u{1}every mtllib";
    let text = if mtl.is_empty() {
        text.to_string()
    } else {
        format!("mtllib {EVERY}\n{text}")
    };
    tobj::load_obj_buf(&mut text.as_bytes(), &load_options(), |named| {
        // Every `mtllib` line of the OBJ itself loads nothing: its files are in EVERY, and one
        // that was not found is already named by read_mtls.
        if named.to_string_lossy().trim() == EVERY {
            let texts: Vec<&str> = mtl.iter().map(|m| m.text.as_str()).collect();
            tobj::load_mtl_buf(&mut texts.join("\n").as_bytes())
        } else {
            Ok((Vec::new(), Default::default()))
        }
    })
}

/// An OBJ's mesh (triangulated, checked, flat normals where it has none) and its materials (the .mtl's,
/// then grey for triangles without one).
fn obj_mesh(
    src: ObjSource,
    warnings: &mut Vec<String>,
) -> Result<(Mesh, Vec<Material>), SceneError> {
    let obj_label = src.label.as_str();
    let obj_text = src.text.as_str();
    let obj_dir = src.dir.as_path();
    warnings.extend(src.notes.iter().cloned());
    {
        let (models, mtl) = src.loaded.map_err(|e| {
            let line = obj_error_line(obj_text, &e);
            let (obj, message) = match line {
                Some(l) => {
                    let text: String = obj_text
                        .lines()
                        .nth(l - 1)
                        .unwrap_or("")
                        .trim()
                        .chars()
                        .take(80)
                        .collect();
                    (format!("{obj_label}:{l}"), format!("{e}: `{text}`"))
                }
                None => (obj_label.to_string(), e.to_string()),
            };
            SceneError::Obj {
                path: obj_label.into(),
                obj,
                message,
            }
        })?;
        // One texture per file, however many materials name it (the atlas holds it once).
        let mut read: Vec<(PathBuf, Arc<Texture>)> = Vec::new();
        let mut superseded = Vec::new();
        let mut materials: Vec<Material> = match mtl {
            Ok(all) => {
                // A material defined again later is the later one wherever it is used: the
                // earlier is neither read nor checked.
                superseded = (0..all.len())
                    .map(|i| all[i + 1..].iter().any(|m| m.name == all[i].name))
                    .collect();
                all
                .into_iter()
                .zip(superseded.clone())
                .map(|(m, superseded)| {
                    if superseded {
                        return Material {
                            name: m.name,
                            ..Material::grey()
                        };
                    }
                    // A texture that cannot be read is a warning: the material keeps its Kd.
                    let diffuse_map = m.diffuse_texture.as_ref().and_then(|t| {
                        let (options, file) = map_options(t);
                        if !options.is_empty() {
                            warnings.push(format!(
                                "material {}: map_Kd options `{options}` ignored (the texture is read as it is, repeating)",
                                m.name
                            ));
                        }
                        // Beside the .mtl that defines the material, then beside the OBJ.
                        let mtl_dir = src
                            .mtl
                            .iter()
                            .rev()
                            .find(|f| f.materials.contains(&m.name))
                            .map(|f| f.dir.as_path());
                        let dirs: Vec<&Path> = mtl_dir.into_iter().chain([obj_dir]).collect();
                        let Some(path) = obj_input::find_file(&dirs, file) else {
                            let looked: Vec<String> =
                                dirs.iter().map(|d| d.display().to_string()).collect();
                            warnings.push(format!(
                                "material {}: map_Kd {file} not used (no such file in {}): Kd instead",
                                m.name,
                                looked.join(" or ")
                            ));
                            return None;
                        };
                        if let Some((_, t)) = read.iter().find(|(p, _)| *p == path) {
                            return Some(t.clone());
                        }
                        Texture::read(&path)
                            .map_err(|e| {
                                warnings.push(format!(
                                    "material {}: map_Kd {} not used ({e}): Kd instead",
                                    m.name,
                                    path.display()
                                ))
                            })
                            .ok()
                            .map(|(t, note)| {
                                if let Some(note) = note {
                                    warnings.push(format!(
                                        "material {}: map_Kd {}: {note}",
                                        m.name,
                                        path.display()
                                    ));
                                }
                                let t = Arc::new(t);
                                read.push((path.clone(), t.clone()));
                                t
                            })
                    });
                    // What the light-transport contract has no term for is said, not dropped
                    // silently: light comes from [[lights]], surfaces are opaque.
                    let ignored: Vec<&str> = [
                        ("Ke (emission)", m.emissive.is_some_and(|e| e != [0.0; 3])),
                        (
                            "d / Tr (transparency)",
                            m.dissolve.is_some_and(|d| d < 1.0),
                        ),
                        ("map_d (cut-out)", m.dissolve_texture.is_some()),
                        (
                            "map_Ka (ambient texture; map_Kd is the albedo's)",
                            m.ambient_texture.is_some() && m.diffuse_texture.is_none(),
                        ),
                    ]
                    .into_iter()
                    .filter_map(|(what, set)| set.then_some(what))
                    .collect();
                    if !ignored.is_empty() {
                        warnings.push(format!(
                            "material {}: {} ignored (light comes from [[lights]] entries; surfaces are opaque)",
                            m.name,
                            ignored.join(", ")
                        ));
                    }
                    Material {
                        name: m.name,
                        diffuse: m.diffuse.unwrap_or([0.8; 3]),
                        specular: m.specular.unwrap_or([0.0; 3]),
                        shininess: m.shininess.unwrap_or(1.0),
                        diffuse_map,
                    }
                })
                .collect()
            }
            Err(e) => {
                // Name the files tobj could not use (read_mtls found and read them).
                let named: Vec<&str> = src.mtl.iter().map(|m| m.label.as_str()).collect();
                let which = if named.is_empty() {
                    "the OBJ has no mtllib line".to_string()
                } else {
                    format!("{}: {e}", named.join(", "))
                };
                warnings.push(format!(
                    "{obj_label}: no usable .mtl ({which}): every surface is grey diffuse 0.8"
                ));
                Vec::new()
            }
        };
        for (i, m) in materials.iter().enumerate() {
            if !superseded.get(i).copied().unwrap_or(false) {
                check_material(m, &src.mtl, obj_label)?;
            }
        }
        let grey = materials.len() as u32;
        materials.push(Material::grey());
        let mut mesh = Mesh::default();
        for m in &models {
            let base = mesh.positions.len() as u32;
            let positions: Vec<Vec3> = m
                .mesh
                .positions
                .chunks(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]))
                .collect();
            let has_normals = m.mesh.normals.len() == m.mesh.positions.len();
            let normals: Vec<Vec3> = if has_normals {
                m.mesh
                    .normals
                    .chunks(3)
                    .map(|c| Vec3::new(c[0], c[1], c[2]).normalize_or_zero())
                    .collect()
            } else {
                vec![Vec3::ZERO; positions.len()]
            };
            let has_uvs = m.mesh.texcoords.len() * 3 == m.mesh.positions.len() * 2;
            let uvs: Vec<Vec2> = if has_uvs {
                m.mesh
                    .texcoords
                    .chunks(2)
                    .map(|c| Vec2::new(c[0], c[1]))
                    .collect()
            } else {
                vec![Vec2::ZERO; positions.len()]
            };
            mesh.positions.extend(positions);
            mesh.normals.extend(normals);
            mesh.uvs.extend(uvs);
            let mat = m
                .mesh
                .material_id
                .map(|i| i as u32)
                .filter(|&i| i < grey)
                .unwrap_or(grey);
            if !has_uvs && materials[mat as usize].diffuse_map.is_some() {
                let w = format!(
                    "{obj_label}: object {} uses textured material {} but has no vt: its texture is read at (0, 0)",
                    m.name, materials[mat as usize].name
                );
                // tobj splits an object into a mesh per material run: say it once.
                if !warnings.contains(&w) {
                    warnings.push(w);
                }
            }
            // One arity per face; none where every face is a triangle.
            let arities: Vec<usize> = if m.mesh.face_arities.is_empty() {
                vec![3; m.mesh.indices.len() / 3]
            } else {
                m.mesh.face_arities.iter().map(|&a| a as usize).collect()
            };
            let mut first = 0;
            for a in arities {
                let face: Vec<u32> = m.mesh.indices[first..first + a]
                    .iter()
                    .map(|&i| base + i)
                    .collect();
                first += a;
                for t in triangulate(&face, &mesh.positions) {
                    mesh.triangles.push(t);
                    mesh.material.push(mat);
                }
            }
        }
        // Source lines: single_index may duplicate vertices, so locate each position by value.
        let line_of = |p: Vec3| -> usize {
            obj_text
                .lines()
                .enumerate()
                .filter(|(_, l)| l.trim_start().starts_with("v "))
                .find(|(_, l)| {
                    let v: Vec<f32> = l
                        .split_whitespace()
                        .skip(1)
                        .take(3)
                        .filter_map(|x| x.parse().ok())
                        .collect();
                    v.len() == 3
                        && (v[0] == p.x || (v[0].is_nan() && p.x.is_nan()))
                        && (v[1] == p.y || (v[1].is_nan() && p.y.is_nan()))
                        && (v[2] == p.z || (v[2].is_nan() && p.z.is_nan()))
                })
                .map(|(i, _)| i + 1)
                .unwrap_or(0)
        };
        for (i, p) in mesh.positions.iter().enumerate() {
            if !p.is_finite() {
                return Err(SceneError::NonFiniteVertex {
                    path: obj_label.into(),
                    line: line_of(*p),
                    index: i,
                    value: p.to_array(),
                });
            }
            if !in_range(*p) {
                return Err(SceneError::VertexOutOfRange {
                    path: obj_label.into(),
                    line: line_of(*p),
                    index: i,
                    value: p.to_array(),
                });
            }
        }
        for (index, uv) in mesh.uvs.iter().enumerate() {
            if !uv.is_finite() {
                return Err(SceneError::NonFiniteUv {
                    path: obj_label.into(),
                    index,
                    value: uv.to_array(),
                });
            }
        }
        // Zero-area triangles (a repeated vertex, or three on a line) cover nothing: every renderer
        // drops them, so does the loader, with one warning. The area is computed in f64, where the
        // products of in-range coordinates are exact enough and cannot overflow.
        let before = mesh.triangles.len();
        let mut dropped_lines = Vec::new();
        let mut repeated = 0usize;
        let mut keep = vec![true; before];
        for (i, t) in mesh.triangles.iter().enumerate() {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            let flat = (b - a).cross(c - a).normalize_or_zero();
            let [a, b, c] = [a, b, c].map(|p| p.as_dvec3());
            let (e1, e2) = (b - a, c - a);
            // Zero area in f64 (relative to the longest edge), or a normal f32 cannot form.
            if flat == Vec3::ZERO
                || e1.cross(e2).length() <= 1e-12 * e1.length().max(e2.length()).powi(2)
            {
                keep[i] = false;
                repeated += (a == b || b == c || a == c) as usize;
                if dropped_lines.len() < 3 {
                    dropped_lines.push([a, b, c].map(|p| line_of(p.as_vec3())));
                }
            }
        }
        let dropped = keep.iter().filter(|k| !**k).count();
        if dropped > 0 {
            let mut k = keep.iter();
            mesh.triangles.retain(|_| *k.next().unwrap());
            let mut k = keep.iter();
            mesh.material.retain(|_| *k.next().unwrap());
            // Vertices only the dropped triangles used go too: they would still count in the
            // scene's bounds (the voxel grid's extent, the ray epsilon).
            let mut used = vec![false; mesh.positions.len()];
            for &v in mesh.triangles.iter().flatten() {
                used[v as usize] = true;
            }
            let mut remap = vec![u32::MAX; mesh.positions.len()];
            let mut next = 0u32;
            for (i, u) in used.iter().enumerate() {
                if *u {
                    remap[i] = next;
                    next += 1;
                }
            }
            fn keep_used<T>(v: &mut Vec<T>, used: &[bool]) {
                let mut u = used.iter();
                v.retain(|_| *u.next().unwrap());
            }
            keep_used(&mut mesh.positions, &used);
            keep_used(&mut mesh.normals, &used);
            keep_used(&mut mesh.uvs, &used);
            for t in &mut mesh.triangles {
                *t = t.map(|v| remap[v as usize]);
            }
            warnings.push(format!(
                "{obj_label}: {dropped} of {before} triangles have zero area ({repeated} with a repeated vertex) and are dropped (the first at vertex lines {dropped_lines:?})"
            ));
        }
        let fallback = mesh.material.iter().filter(|&&m| m == grey).count();
        if fallback > 0 {
            warnings.push(format!("{obj_label}: {fallback} triangles have no material (no .mtl file, no usemtl, or a usemtl name the .mtl does not define): grey diffuse 0.8"));
        }
        if mesh.triangles.is_empty() {
            return Err(SceneError::EmptyMesh {
                path: obj_label.into(),
                dropped,
            });
        }
        // A face whose vertex normals all point to its back: one-sided, it is seen from its
        // winding's front (docs/contract.md), where its shading normal faces away; such a surface
        // renders black from the side the normals claim. Said, not changed.
        let against = mesh
            .triangles
            .iter()
            .filter(|t| {
                let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
                let face = (b - a).cross(c - a);
                t.iter().all(|&v| {
                    let n = mesh.normals[v as usize];
                    n != Vec3::ZERO && n.dot(face) < 0.0
                })
            })
            .count();
        if against > 0 {
            warnings.push(format!(
                "{obj_label}: {against} of {} triangles have every vertex normal (vn) against their winding: a face's front is its counter-clockwise side, so these render black where their normals face; reverse their vertex order (or their normals)",
                mesh.triangles.len()
            ));
        }
        // Flat normals from the winding where the OBJ has none: such a triangle gets vertices of its
        // own, so a vertex shared by faces of different orientation keeps each face flat.
        for t in 0..mesh.triangles.len() {
            let tri = mesh.triangles[t];
            if tri.iter().all(|&v| mesh.normals[v as usize] != Vec3::ZERO) {
                continue;
            }
            let [a, b, c] = tri.map(|v| mesh.positions[v as usize]);
            let flat = (b - a).cross(c - a).normalize();
            let base = mesh.positions.len() as u32;
            mesh.positions.extend([a, b, c]);
            mesh.normals.extend([flat; 3]);
            mesh.uvs.extend(tri.map(|v| mesh.uvs[v as usize]));
            mesh.triangles[t] = [base, base + 1, base + 2];
        }
        Ok((mesh, materials))
    }
}

/// The triangles of one OBJ face (indices into `positions`), wound as the face is: itself, a fan from
/// the first vertex where the polygon is convex (what tobj's triangulation gives), ear clipping
/// (earcutr) in the polygon's plane where a vertex is reflex, where a fan would cover outside the
/// polygon and fold over itself. Fewer than three vertices (`f` with none): none.
fn triangulate(face: &[u32], positions: &[Vec3]) -> Vec<[u32; 3]> {
    let fan = || (1..face.len() - 1).map(|i| [face[0], face[i], face[i + 1]]);
    if face.len() < 3 {
        return Vec::new();
    }
    if face.len() == 3 {
        return fan().collect();
    }
    let p: Vec<Vec3> = face.iter().map(|&i| positions[i as usize]).collect();
    let k = p.len();
    // Newell's normal: the polygon's area vector, whatever its shape.
    let n = (0..k).fold(Vec3::ZERO, |acc, i| {
        let (a, b) = (p[i], p[(i + 1) % k]);
        acc + Vec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        )
    });
    // A vertex turning against the polygon's normal by an angle whose sine passes 1e-4 is reflex;
    // a straight one (three points on a line within rounding) is not, whichever way its rounding
    // turns it.
    let convex = (0..k).all(|i| {
        let (e1, e2) = (p[(i + 1) % k] - p[i], p[(i + 2) % k] - p[(i + 1) % k]);
        e1.cross(e2).dot(n) >= -1e-4 * e1.length() * e2.length() * n.length()
    });
    if convex || !n.is_finite() || n == Vec3::ZERO {
        return fan().collect();
    }
    let (u, v) = match n.abs().max_position() {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    let flat: Vec<f64> = p.iter().flat_map(|q| [q[u] as f64, q[v] as f64]).collect();
    match earcutr::earcut(&flat, &[], 2) {
        Ok(t) if !t.is_empty() => t
            .chunks(3)
            .map(|c| {
                let [a, b, cc] = [c[0], c[1], c[2]];
                if (p[b] - p[a]).cross(p[cc] - p[a]).dot(n) < 0.0 {
                    [face[a], face[cc], face[b]]
                } else {
                    [face[a], face[b], face[cc]]
                }
            })
            .collect(),
        _ => fan().collect(),
    }
}

fn load_options() -> tobj::LoadOptions {
    tobj::LoadOptions {
        // [`triangulate`] does it, for concave polygons too.
        triangulate: false,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map(|i| i + 1).unwrap_or(0) + 1;
    (line, column)
}

fn finite3(v: [f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// The largest coordinate magnitude a scene may have (vertices after their instance's transform,
/// camera, light positions), in scene units. The renderers normalise cross products of two edges in
/// f32 (each edge component up to 2B, each cross component up to 2 (2B)^2 = 8B^2) through their
/// squared length: 3 (8B^2)^2 = 1.9e38 stays below f32::MAX = 3.4e38 at B = 1e9. (The `bvh` crate's
/// surface-area heuristic overflows, and panics, near 3e19.)
pub const MAX_COORDINATE: f32 = 1e9;

fn in_range(v: Vec3) -> bool {
    v.abs().max_element() <= MAX_COORDINATE
}

/// `v` times the power of two that brings its largest component into [1, 2): the same direction,
/// normalisable without overflow or underflow. Exact, so a direction already in that range (every
/// shipped scene's) is unchanged bit for bit, and `normalize` of the result equals `normalize` of
/// `v` wherever the latter does not overflow. `v` must be finite and non-zero.
pub fn rescaled_direction(v: [f32; 3]) -> [f32; 3] {
    let m = v.iter().fold(0.0f64, |m, &x| m.max((x as f64).abs()));
    if m == 0.0 || !m.is_finite() {
        return v;
    }
    let s = 2f64.powi(-(m.log2().floor() as i32));
    // Scaling an f32 by a power of two into the normal range is exact.
    v.map(|x| (x as f64 * s) as f32)
}

/// Where a key of a scene file's table is set: the 1-based line of `key = ...` inside `[table]` (or
/// the `index`-th `[[table]]`), for errors about a value that parsed but is out of range.
fn key_line(text: &str, table: &str, index: usize, key: &str) -> Option<usize> {
    let mut current = String::new();
    // Which occurrence of `[[table]]` this is (1-based; 1 for a plain `[table]`).
    let mut seen = 0usize;
    let mut count = 0usize;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if let Some(h) = t.strip_prefix("[[").and_then(|h| h.split("]]").next()) {
            current = h.trim().to_string();
            if current == table {
                count += 1;
            }
            seen = count;
            continue;
        }
        if let Some(h) = t.strip_prefix('[').and_then(|h| h.split(']').next()) {
            current = h.trim().to_string();
            seen = 1;
            continue;
        }
        let in_table = current == table && seen == index + 1;
        if !in_table || t.starts_with('#') {
            continue;
        }
        let k = t.split('=').next().unwrap_or("").trim();
        if t.contains('=') && (k == key || k.starts_with(&format!("{key}."))) {
            return Some(i + 1);
        }
        // An inline table (`transform = { scale = 1e30 }`) names its keys on one line: a key after
        // `{` or `,`.
        let code = t.split('#').next().unwrap_or("");
        if code
            .split(['{', ','])
            .skip(1)
            .any(|piece| piece.split('=').next().map(str::trim) == Some(key) && piece.contains('='))
        {
            return Some(i + 1);
        }
    }
    None
}

/// The first key of `table` that `message` names (`"voxels = 100 must be ..."`, `"eye ... past"`):
/// its first word that is a key set in the table.
fn message_line(text: &str, table: &str, index: usize, message: &str) -> Option<usize> {
    message
        .split(|c: char| !(c.is_alphanumeric() || c == '_'))
        .filter(|w| !w.is_empty())
        .find_map(|w| key_line(text, table, index, w))
}

/// The first line of an OBJ that tobj's `e` is about: tobj reports no line, so the checks it makes
/// are repeated here (statements it parses, face indices against the file's counts). `None` where
/// no line is to blame.
fn obj_error_line(text: &str, e: &tobj::LoadError) -> Option<usize> {
    use tobj::LoadError as E;
    let floats = |words: &[&str], n: usize| {
        words.len() > n && words[1..=n].iter().all(|w| w.parse::<f32>().is_ok())
    };
    let (mut nv, mut nt, mut nn) = (0usize, 0usize, 0usize);
    let total = |key: &str| {
        text.lines()
            .filter(|l| l.split_whitespace().next() == Some(key))
            .count()
    };
    let (tv, tt, tn) = (total("v"), total("vt"), total("vn"));
    // A face index: 1-based, or negative relative to the count so far; `Some(in bounds)`, `None` if
    // it does not parse.
    let index_ok = |w: &str, so_far: usize, all: usize| -> Option<bool> {
        let i: isize = w.parse().ok()?;
        Some(match i {
            0 => false,
            i if i > 0 => (i as usize) <= all,
            i => i.unsigned_abs() <= so_far,
        })
    };
    for (i, line) in text.lines().enumerate() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let bad = match words.first().copied() {
            Some("v") => {
                nv += 1;
                matches!(
                    e,
                    E::PositionParseError | E::ScalingByZeroError | E::ColorParseError
                ) && !(floats(&words, 3)
                    && match words.len() {
                        4 => true,
                        5 => words[4].parse::<f32>().is_ok_and(|w| w != 0.0),
                        7 => true,
                        _ => false,
                    })
            }
            Some("vt") => {
                nt += 1;
                matches!(e, E::TexcoordParseError) && !floats(&words, 2)
            }
            Some("vn") => {
                nn += 1;
                matches!(e, E::NormalParseError) && !floats(&words, 3)
            }
            Some("f") | Some("l") => words[1..].iter().any(|w| {
                let parts: Vec<&str> = w.split('/').collect();
                let check = |k: usize, so_far: usize, all: usize| -> Option<bool> {
                    match parts.get(k) {
                        None | Some(&"") => Some(true),
                        Some(p) => index_ok(p, so_far, all),
                    }
                };
                let (pv, pt, pn) = (
                    index_ok(parts[0], nv, tv),
                    check(1, nt, tt),
                    check(2, nn, tn),
                );
                match e {
                    E::FaceParseError => {
                        pv.is_none() || pt.is_none() || pn.is_none() || parts.len() > 3
                    }
                    E::FaceVertexOutOfBounds => pv == Some(false),
                    E::FaceTexCoordOutOfBounds => pt == Some(false),
                    E::FaceNormalOutOfBounds => pn == Some(false),
                    _ => false,
                }
            }),
            Some("usemtl") => matches!(e, E::MaterialParseError) && words.len() < 2,
            _ => false,
        };
        if bad {
            return Some(i + 1);
        }
    }
    None
}

/// Kd and Ks finite and in [0, 1] per channel (reflectances: more would create energy, less is not
/// light), Ns finite and >= 0 (the Phong exponent). The error names the .mtl line of the value.
fn check_material(m: &Material, mtls: &[MtlSource], obj_label: &str) -> Result<(), SceneError> {
    let bad3 = |v: [f32; 3]| !v.iter().all(|x| (0.0..=1.0).contains(x));
    let problem = if bad3(m.diffuse) {
        Some((
            "Kd",
            format!("Kd {:?} must be finite and in [0, 1]", m.diffuse),
        ))
    } else if bad3(m.specular) {
        Some((
            "Ks",
            format!("Ks {:?} must be finite and in [0, 1]", m.specular),
        ))
    } else if !(m.shininess.is_finite() && m.shininess >= 0.0) {
        Some(("Ns", format!("Ns {} must be finite and >= 0", m.shininess)))
    } else {
        None
    };
    let Some((key, message)) = problem else {
        return Ok(());
    };
    // The .mtl that defines the material (an OBJ may name several; a later definition is used).
    let (path, line) = match mtls
        .iter()
        .rev()
        .find(|f| f.materials.contains(&m.name))
        .or(mtls.first())
    {
        Some(MtlSource { label, text, .. }) => {
            let mut line = 0;
            let mut inside = false;
            for (i, l) in text.lines().enumerate() {
                let w: Vec<&str> = l.split_whitespace().collect();
                match w.first().copied() {
                    Some("newmtl") => {
                        inside = l.trim().strip_prefix("newmtl").map(str::trim) == Some(&m.name);
                        if inside && line == 0 {
                            line = i + 1;
                        }
                    }
                    Some(k) if inside && k == key => line = i + 1,
                    _ => {}
                }
            }
            (label.clone(), line)
        }
        None => (obj_label.to_string(), 0),
    };
    Err(SceneError::Material {
        path,
        line,
        name: m.name.clone(),
        message,
    })
}

/// A mesh path of the form `crate:NAME/REST`: REST inside the sources of the dependency NAME, as
/// cargo fetched them (build.rs records where; `VXGI_CRATE_<NAME>` at run time overrides it).
/// `Ok(None)` for an ordinary path. Only `bvh` is known: it ships the Dabrovic Sponza.
fn resolve_crate_path(obj: &str) -> Result<Option<PathBuf>, String> {
    let Some(rest) = obj.strip_prefix("crate:") else {
        return Ok(None);
    };
    let (name, file) = rest.split_once('/').unwrap_or((rest, ""));
    if name != "bvh" {
        return Err(format!(
            "crate:{name}/...: only the bvh package's files can be named this way"
        ));
    }
    let dir = std::env::var("VXGI_CRATE_BVH")
        .ok()
        .filter(|d| !d.is_empty())
        .unwrap_or_else(|| env!("VXGI_CRATE_BVH").to_string());
    if dir.is_empty() {
        return Err("the bvh package's folder is unknown (cargo metadata failed when vxgi was built): set VXGI_CRATE_BVH to it".into());
    }
    Ok(Some(Path::new(&dir).join(file)))
}

/// A short reason why an image could not be used (the `image` crate's decoding errors can carry a
/// dump of the bytes that failed).
fn image_error(e: &image::ImageError) -> String {
    use image::ImageError as I;
    match e {
        I::Decoding(d) => {
            let format = match d.format_hint() {
                image::error::ImageFormatHint::Exact(f) => format!("{f:?}").to_uppercase(),
                image::error::ImageFormatHint::Name(n) => n,
                image::error::ImageFormatHint::PathExtension(p) => p.display().to_string(),
                _ => "image".into(),
            };
            // The decoder's own reason where it is short text (not a dump of chunk bytes).
            let reason = std::error::Error::source(d)
                .map(|r| r.to_string())
                .filter(|r| r.len() <= 80 && !r.contains('[') && !r.contains('\n'))
                .map(|r| format!(": {r}"))
                .unwrap_or_default();
            format!("not a valid {format} file (decoding failed{reason})")
        }
        I::Unsupported(u) => {
            let what: String = u
                .to_string()
                .lines()
                .next()
                .unwrap_or("")
                .chars()
                .take(100)
                .collect();
            format!("{what}: the formats read here are PNG, JPEG, TGA, BMP, DDS (DXT1, DXT3, DXT5), HDR, EXR and PNM; convert it to PNG")
        }
        I::IoError(io) => io.to_string(),
        I::Limits(l) => format!("past the decoder's limits ({l})"),
        other => {
            let s = other.to_string();
            let first = s.lines().next().unwrap_or("").to_string();
            first.chars().take(120).collect()
        }
    }
}

fn validate_camera(c: &CameraDesc) -> Result<(), String> {
    if !(finite3(c.eye) && finite3(c.target) && finite3(c.up)) {
        return Err("eye, target and up must be finite".into());
    }
    let (eye, target, up) = (Vec3::from(c.eye), Vec3::from(c.target), Vec3::from(c.up));
    for (name, p) in [("eye", eye), ("target", target)] {
        if !in_range(p) {
            return Err(format!(
                "{name} {:?} is past the renderable range (coordinates within +-{MAX_COORDINATE:e} scene units: products of larger ones overflow f32)",
                p.to_array()
            ));
        }
    }
    // Scaled by a power of two first, so that a long `up` normalises without overflow.
    let up = Vec3::from(rescaled_direction(up.to_array()));
    let forward = target - eye;
    if forward.length() <= 0.0 {
        return Err("eye and target coincide".into());
    }
    if forward.normalize().cross(up.normalize_or_zero()).length() < 1e-6 {
        return Err("up is zero or parallel to the view direction".into());
    }
    if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
        return Err(format!("fov_y_deg = {} must be in (0, 180)", c.fov_y_deg));
    }
    if c.width == 0 || c.height == 0 || c.width > 8192 || c.height > 8192 {
        return Err(format!(
            "width x height = {} x {} must be 1..=8192 each",
            c.width, c.height
        ));
    }
    Ok(())
}

fn validate_light(l: &Light) -> Result<(), String> {
    let intensity = match l {
        Light::Point { intensity, .. }
        | Light::Spot { intensity, .. }
        | Light::Directional { intensity, .. } => *intensity,
    };
    if !finite3(intensity) || intensity.iter().any(|&x| x < 0.0) {
        return Err(format!("intensity {intensity:?} must be finite and >= 0"));
    }
    let position = match l {
        Light::Point { position, .. } | Light::Spot { position, .. } => Some(*position),
        Light::Directional { .. } => None,
    };
    if let Some(p) = position.filter(|p| finite3(*p) && !in_range(Vec3::from(*p))) {
        return Err(format!(
            "position {p:?} is past the renderable range (coordinates within +-{MAX_COORDINATE:e} scene units: products of larger ones overflow f32)"
        ));
    }
    match l {
        Light::Point { position, .. } if !finite3(*position) => {
            Err("position must be finite".into())
        }
        Light::Spot {
            position,
            direction,
            cone_deg,
            falloff_deg,
            ..
        } => {
            if !finite3(*position) {
                return Err(format!("position {position:?} must be finite"));
            }
            if !finite3(*direction) || Vec3::from(*direction).length() <= 0.0 {
                return Err(format!(
                    "direction {direction:?} must be finite and non-zero (where the spot points)"
                ));
            }
            if !(*cone_deg > 0.0 && *cone_deg <= 90.0) {
                return Err(format!("cone_deg = {cone_deg} must be in (0, 90]"));
            }
            match falloff_deg {
                Some(f) if !(*f >= 0.0 && f <= cone_deg) => {
                    Err(format!("falloff_deg = {f} must be in [0, cone_deg]"))
                }
                _ => Ok(()),
            }
        }
        Light::Directional { direction, .. }
            if !finite3(*direction) || Vec3::from(*direction).length() <= 0.0 =>
        {
            Err("direction must be finite and non-zero".into())
        }
        _ => Ok(()),
    }
}
