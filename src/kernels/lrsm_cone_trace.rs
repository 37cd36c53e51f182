//! Declaration of `kernels/lrsm_cone_trace.wgsl` (mirror: `vxgi_cpu_mirror::lrsm_cone_trace`): the lrsm
//! pipeline's final gathering, and the chain that feeds it ([`LrsmFrame::build`]): voxelize ->
//! occlusion_voxels; per light view gbuffer -> reflective_shadow_map -> lrsm_partition ->
//! lrsm_prefilter, every stage a verified kernel run on the GPU.
use super::cone_trace::{bounded_outputs, cone_params, shade_all, tracer_case, ConeSettings};
use super::occlusion_voxels::occlusion_on_gpu;
use super::reflective_shadow_map::{rsm_on_gpu, LRSM_VIEW};
use super::voxelize::{occupancy_on_gpu, VoxelFrame};
use super::{
    lrsm_partition, lrsm_prefilter, or_one, BRDF, CONE_MARCH, LIGHTS, LRSM_MATH, LRSM_SAMPLE,
};
use crate::lrsm::{light_views, PartitionConfig, Rsm};
use crate::scene::Scene;
use crate::trace::SceneData;
use anyhow::Context;
use vxgi_cpu_mirror::cone_trace::ConeParams;
use vxgi_cpu_mirror::lrsm_cone_trace::{soft_direct, LrsmVolume, ShadowParams};
use vxgi_cpu_mirror::reflective_shadow_map::GpuView;
use vxgi_cpu_mirror::sample_lrsm::{Lrsm, SampleParams};
use vxgi_harness::prelude::*;

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "lrsm_cone_trace",
    includes: &[super::TANGENT_BASIS, super::SCENE_TYPES, CONE_MARCH, super::LRSM_TEXEL, LRSM_SAMPLE, LRSM_MATH, LRSM_VIEW, LIGHTS, BRDF, super::MORTON],
    inputs: super::march_inputs![
        "occ", "occ_offsets", "params", "depth_ranges", "lrsm_radiance", "lrsm_normal",
        "lrsm_moments", "views", "lights", "shadow_params", "lit", "lit_offsets",
    ],
    // The march's bound (`super::march_outputs!`) with each sample's LRSM bound, computed per pixel
    // by the mirror; shadow cones: direct_light's term bound times the cone's visibility bound.
    outputs: super::march_outputs![
        Output { binding: "soft_direct", tolerance: Tolerance::MirrorBound },
    ],
    dispatch: DispatchRule::PerItem {
        what: "8x8 screen tile holding a surface (screen_tiles' list, dispatched indirectly)",
    },
    mirror: "vxgi_cpu_mirror::cone_trace::shade_pixel over vxgi_cpu_mirror::lrsm_cone_trace::LrsmVolume; lrsm_cone_trace::soft_direct",
    summary: "LRSM final gathering: cones through the occlusion voxels' mips, each sample's radiance from every light view's LRSM (LRSM eq. 1, Algorithm 1)",
);

/// The lrsm pipeline's knobs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LrsmSettings {
    /// Shadow cones' half-angle in degrees (0 = exact shadow rays, direct_light).
    pub shadow_cone_angle: f32,
    /// RSM side per light view (LRSM level 0 is half of it).
    pub rsm_side: u32,
    pub depth_splits: u32,
    pub normal_splits: u32,
    pub overlap: f32,
    /// Occlusion mips by CPRC's surface coverage instead of the paper's volume coverage.
    pub surface_coverage: bool,
    /// N weighs each layer's radiance (Algorithm 1 as written) instead of only culling back faces.
    pub view_weight: bool,
    /// Area-weighted LRSMs read as eq. 1's premultiplied product (`lrsm_area_weights`; N then
    /// weighs L whatever `view_weight` says): docs/accuracy/lrsm.md.
    pub area_weights: bool,
    /// Each sample's light from the lit cells (`lrsm_lit_cells`, [`super::lit_cells`]) instead of
    /// the LRSMs, which are then not built.
    pub lit_cells: bool,
    /// The lit table's largest side ([`super::lit_cells::MAX_SIDE`]; lower in some verify cases,
    /// where the gather reads a table coarser than the voxels).
    pub lit_max_side: u32,
}

impl From<&crate::scene::RenderSettings> for LrsmSettings {
    fn from(r: &crate::scene::RenderSettings) -> Self {
        Self {
            shadow_cone_angle: r.shadow_cone_angle,
            rsm_side: r.rsm_side,
            depth_splits: r.lrsm_depth_splits,
            normal_splits: r.lrsm_normal_splits,
            overlap: r.lrsm_overlap,
            surface_coverage: r.lrsm_surface_coverage,
            view_weight: r.lrsm_view_weight,
            area_weights: r.lrsm_area_weights,
            lit_cells: r.lrsm_lit_cells,
            lit_max_side: super::lit_cells::MAX_SIDE,
        }
    }
}

impl LrsmSettings {
    /// The gather's Sample LRSM parameters (lit cells or LRSMs as these settings ask) over a voxel
    /// grid `frame`.
    pub fn sample_params(&self, frame: &VoxelFrame) -> SampleParams {
        let mut p = super::sample_lrsm::sample_params(&self.partition(), 0, self.view_weight);
        p.lit_cells = self.lit_cells as u32;
        p.lit_base = super::lit_cells::grid_of(frame, self.lit_max_side).1;
        p
    }

    /// The lit table over `frame` for `lights` over scene `bounds` (its radiance unit from them, its
    /// area weight from how many cast light) and the occlusion level its finest level stands at.
    pub fn lit_grid(
        &self,
        frame: &VoxelFrame,
        lights: &[vxgi_cpu_mirror::direct_light::GpuLight],
        bounds: (glam::Vec3, glam::Vec3),
    ) -> (vxgi_cpu_mirror::lit_cells::LitGrid, u32) {
        let (mut grid, base) = super::lit_cells::grid_of(frame, self.lit_max_side);
        grid.scale = super::lit_cells::radiance_unit(lights, bounds);
        let casting = lights.iter().filter(|l| crate::lrsm::casts(l)).count();
        vxgi_cpu_mirror::lit_cells::weigh_lights(&mut grid, casting, lights.len());
        (grid, base)
    }

    /// The RSM's partition into layers these settings ask for.
    pub fn partition(&self) -> PartitionConfig {
        PartitionConfig {
            rsm_side: self.rsm_side,
            depth_splits: self.depth_splits,
            normal_splits: self.normal_splits,
            overlap: self.overlap,
            area_weights: self.area_weights,
        }
    }
}

impl Default for LrsmSettings {
    /// The `[render]` defaults: 4 layers (2 x 2, the paper's Sibenik/Sponza setting), 128^2 RSM per view.
    fn default() -> Self {
        Self::from(&crate::scene::RenderSettings::default())
    }
}

/// Everything the gather reads, built on the GPU.
#[derive(Clone, Debug)]
pub struct LrsmFrame {
    pub voxels: VoxelFrame,
    /// Occlusion pyramid words, levels concatenated, and each level's first word.
    pub occ: Vec<u32>,
    pub occ_offsets: Vec<u32>,
    pub views: Vec<GpuView>,
    pub params: SampleParams,
    pub depth_ranges: Vec<[f32; 4]>,
    /// Every view's LRSM (all levels), concatenated: radiance, normal, moments, as the values the
    /// GPU's binary16 texels hold (`vxgi_cpu_mirror::lrsm_prefilter`'s storage).
    pub streams: [Vec<[f32; 4]>; 3],
    /// With `lrsm_lit_cells` the lit cells instead of the LRSMs (whose streams are then empty):
    /// every level, two vec4 a cell ([`super::lit_cells`]), and each level's first cell.
    pub lit: Vec<[f32; 4]>,
    pub lit_offsets: Vec<u32>,
    /// Bytes of each structure: occlusion voxels, RSMs (one view at a time), LRSMs.
    pub memory: LrsmMemory,
}

/// Bytes held per data structure (the paper's Table 2).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LrsmMemory {
    pub occlusion: u64,
    /// One RSM (radiance + normal: 2 x 16 bytes, depth 4 bytes per texel).
    pub rsm: u64,
    /// All views' LRSMs (3 streams of 8 bytes per texel, every level).
    pub lrsm: u64,
    /// The lit cells (every level, 32 bytes a cell, and the high words of level 0's fixed-point
    /// sums, 32 bytes a level-0 cell).
    pub lit: u64,
    pub views: u32,
}

impl LrsmMemory {
    /// The light structure the gather reads, and its size: the lit cells or the LRSMs.
    pub fn light_text(&self) -> String {
        if self.lit > 0 {
            format!(
                "lit cells of {} light views {:.1} MB",
                self.views,
                self.lit as f64 / 1e6
            )
        } else {
            format!("{} LRSMs {:.1} MB", self.views, self.lrsm as f64 / 1e6)
        }
    }

    /// What `frame` holds (its lit table by its levels, `lit_offsets`, whether its `lit` is filled
    /// or a chain binds its own), with one RSM of side `rsm_side`.
    pub fn of(frame: &LrsmFrame, rsm_side: u32) -> Self {
        Self {
            occlusion: frame.occ.len() as u64 * 4,
            rsm: (rsm_side as u64).pow(2) * 36,
            lrsm: frame.streams[0].len() as u64 * 3 * lrsm_prefilter::TEXEL_BYTES,
            // A table of side s has log2(s) + 1 levels.
            lit: match frame.lit_offsets.len() {
                0 => 0,
                levels => super::lit_cells::table_bytes(1 << (levels - 1)),
            },
            views: frame.views.len() as u32,
        }
    }
}

/// The occlusion levels concatenated, and each level's first word.
fn concat_levels(levels: &[Vec<u32>]) -> (Vec<u32>, Vec<u32>) {
    let mut occ = Vec::new();
    let mut offsets = Vec::new();
    for l in levels {
        offsets.push(occ.len() as u32);
        occ.extend_from_slice(l);
    }
    (occ, offsets)
}

/// A view's RSM partitioned and pre-filtered on the GPU: the three streams, levels concatenated.
pub fn lrsm_on_gpu(
    ctx: &GpuContext,
    rsm: &Rsm,
    config: &PartitionConfig,
) -> anyhow::Result<[Vec<[f32; 4]>; 3]> {
    let pshader = lrsm_partition::DECL.shader()?;
    let pcase = lrsm_partition::case_for(&pshader, ctx, rsm, config, "partition".into(), 0)?;
    let out = pcase.run(
        ctx,
        &pshader,
        lrsm_partition::DECL.name,
        &["out_radiance", "out_normal", "out_moments"],
    )?;
    let f4 = lrsm_prefilter::values;
    let level0 = [
        f4(out.buffer("out_radiance")),
        f4(out.buffer("out_normal")),
        f4(out.buffer("out_moments")),
    ];
    let side0 = config.rsm_side / 2;
    let levels = side0.trailing_zeros() + 1;
    let mut streams = level0.clone();
    if levels > 1 {
        let fshader = lrsm_prefilter::DECL.shader()?;
        let fcase = lrsm_prefilter::chain_case(
            &fshader,
            ctx,
            &level0,
            config.layers(),
            side0,
            "prefilter".into(),
            0,
        );
        let names: Vec<String> = (1..levels)
            .flat_map(|k| (0..3).map(move |s| lrsm_prefilter::stream_name(s, k)))
            .collect();
        let refs: Vec<&str> = names.iter().map(String::as_str).collect();
        let out = fcase.run(ctx, &fshader, lrsm_prefilter::DECL.name, &refs)?;
        for k in 1..levels {
            for (s, stream) in streams.iter_mut().enumerate() {
                stream.extend(f4(out.buffer(&lrsm_prefilter::stream_name(s, k))));
            }
        }
    }
    Ok(streams)
}

impl LrsmFrame {
    /// Voxelize `scene` at `side`^3 into occlusion voxels, and build every light view's LRSM.
    pub fn build(
        ctx: &GpuContext,
        scene: &Scene,
        data: &SceneData,
        side: u32,
        settings: &LrsmSettings,
        progress: &dyn Fn(&str),
        stages: &mut Vec<(&'static str, f64)>,
    ) -> anyhow::Result<Self> {
        progress("voxelize");
        let t = std::time::Instant::now();
        let (bits, voxels) = occupancy_on_gpu(ctx, scene, side)?;
        stages.push(("voxelize", t.elapsed().as_secs_f64()));
        Self::build_with(
            Some(ctx),
            &|_| false,
            data,
            &bits,
            voxels,
            settings,
            progress,
            stages,
        )
    }

    /// The frame from a voxelized grid's occupancy (`bits`: level 0 of the occlusion voxels, voxelize's
    /// `occupancy_bits`), each stage —
    /// `occlusion_voxels`, `reflective_shadow_map` (a view's RSM from its ray-cast G-buffer),
    /// `lrsm_partition` (partition + pre-filter) — by the mirror where `mirror(stage)` says so or no
    /// GPU is given, else on the GPU. Stage times go to `stages` (the RSMs and LRSMs together, as
    /// `reflective_shadow_map`).
    #[allow(clippy::too_many_arguments)]
    pub fn build_with(
        gpu: Option<&GpuContext>,
        mirror: &dyn Fn(&str) -> bool,
        data: &SceneData,
        bits: &[u32],
        voxels: VoxelFrame,
        settings: &LrsmSettings,
        progress: &dyn Fn(&str),
        stages: &mut Vec<(&'static str, f64)>,
    ) -> anyhow::Result<Self> {
        let on_gpu = |stage: &str| gpu.filter(|_| !mirror(stage));
        progress("occlusion voxels");
        let t = std::time::Instant::now();
        let coverage = if settings.surface_coverage {
            vxgi_cpu_mirror::occlusion_voxels::Coverage::Surface
        } else {
            vxgi_cpu_mirror::occlusion_voxels::Coverage::Volume
        };
        let levels = match on_gpu("occlusion_voxels") {
            Some(ctx) => {
                occlusion_on_gpu(ctx, bits, voxels.side, coverage).context("occlusion voxels")?
            }
            None => vxgi_cpu_mirror::occlusion_voxels::pyramid_of_bits(
                bits.to_vec(),
                voxels.side,
                coverage,
            ),
        };
        stages.push(("occlusion_voxels", t.elapsed().as_secs_f64()));
        let t = std::time::Instant::now();
        let (occ, occ_offsets) = concat_levels(&levels);
        let config = settings.partition();
        if let Some(ctx) = gpu {
            config.validate(ctx.limits().max_storage_buffer_binding_size)?;
        }
        let mut views = light_views(
            &data.lights,
            data.bounds,
            settings.rsm_side,
            data.frame.eye[3],
        )?;
        let mut streams: [Vec<[f32; 4]>; 3] = Default::default();
        let count = views.len();
        // Seconds in each view's RSM and in its layers (the two stages), summed over the views.
        let mut partition_secs = 0.0;
        // With lit cells: every view's RSM, injected together after the last.
        let mut rsms = Vec::new();
        for (k, v) in views.iter_mut().enumerate() {
            progress(&format!("RSM and LRSM of light view {} of {count}", k + 1));
            v.view.info[2] = streams[0].len() as u32;
            let rsm = match on_gpu("reflective_shadow_map") {
                Some(ctx) => rsm_on_gpu(ctx, data, v).context("reflective shadow map")?,
                None => super::reflective_shadow_map::rsm_mirror(data, v),
            };
            if settings.lit_cells {
                rsms.push(rsm);
                continue;
            }
            let p = std::time::Instant::now();
            let s = match on_gpu("lrsm_partition") {
                Some(ctx) => lrsm_on_gpu(ctx, &rsm, &config).context("LRSM")?,
                None => super::sample_lrsm::lrsm_mirror(&rsm, &config),
            };
            for (acc, part) in streams.iter_mut().zip(s) {
                acc.extend(part);
            }
            partition_secs += p.elapsed().as_secs_f64();
        }
        if !views.is_empty() {
            let all = t.elapsed().as_secs_f64();
            stages.push(("reflective_shadow_map", all - partition_secs));
            if !settings.lit_cells {
                stages.push(("lrsm_partition", partition_secs));
            }
        }
        let (mut lit, mut lit_offsets) = (Vec::new(), Vec::new());
        if settings.lit_cells {
            progress("lit cells");
            let t = std::time::Instant::now();
            let (grid, _) = settings.lit_grid(&voxels, &data.lights, data.bounds);
            let gpu_views: Vec<GpuView> = views.iter().map(|v| v.view).collect();
            let levels = match on_gpu("lit_cells") {
                Some(ctx) => super::lit_cells::lit_on_gpu(ctx, &grid, &gpu_views, &rsms)
                    .context("lit cells")?,
                None => super::lit_cells::lit_mirror(&grid, &gpu_views, &rsms),
            };
            for level in &levels {
                lit_offsets.push((lit.len() / 2) as u32);
                lit.extend(bytemuck::cast_slice::<f32, [f32; 4]>(level));
            }
            stages.push(("lit_cells", t.elapsed().as_secs_f64()));
        }
        let params = settings.sample_params(&voxels);
        let mut frame = Self {
            voxels,
            occ,
            occ_offsets,
            views: views.iter().map(|v| v.view).collect(),
            params,
            depth_ranges: config.depth_ranges(),
            streams,
            lit,
            lit_offsets,
            memory: LrsmMemory::default(),
        };
        frame.memory = LrsmMemory::of(&frame, settings.rsm_side);
        Ok(frame)
    }

    /// Bound on any cone sample's radiance: per view, the sum over layers of the largest opacity-
    /// weighted radiance (V, N and the decay are at most 1), summed over views.
    pub fn lmax(&self) -> f32 {
        if self.params.lit_cells != 0 {
            // A lit cell's light is at most its mean radiance (coverage and N's ramp <= 1), and a
            // level's mean at most its children's largest (1e-3 for the sums' roundings).
            let mean = self
                .lit
                .chunks(2)
                .filter(|c| c[0][3] > 0.0)
                .map(|c| c[0][0].max(c[0][1]).max(c[0][2]) / c[0][3])
                .fold(0.0f32, f32::max);
            return mean * 1.001;
        }
        let layers = (self.params.depth_slices * self.params.normal_slices) as usize;
        let texels = (self.params.side0 as usize).pow(2);
        let per_view: usize = self.streams[0].len() / self.views.len().max(1);
        let mut total = 0.0f32;
        for v in 0..self.views.len() {
            for layer in 0..layers {
                let start = v * per_view + layer * texels;
                let m = self.streams[0][start..start + texels]
                    .iter()
                    .map(|r| r[0].max(r[1]).max(r[2]))
                    .fold(0.0f32, f32::max);
                total += m;
            }
        }
        total
    }

    /// The mirror's view of it.
    pub fn volume<'a>(&'a self, p: &'a ConeParams) -> LrsmVolume<'a> {
        LrsmVolume {
            p,
            occ: &self.occ,
            occ_offsets: &self.occ_offsets,
            sp: &self.params,
            lrsm: Lrsm {
                depth_ranges: &self.depth_ranges,
                radiance: &self.streams[0],
                normal: &self.streams[1],
                moments: &self.streams[2],
            },
            views: &self.views,
            lit: &self.lit,
            lit_offsets: &self.lit_offsets,
            lmax: self.lmax(),
        }
    }
}

/// The same frame data computed by the mirrors alone (no GPU): occlusion pyramid of the voxelized grid
/// `colour` (alpha > 0 = solid: the bits voxelize's `occupancy_bits` writes), every view's RSM from a
/// mirror G-buffer ray-cast from the light, then partition and pre-filter. For the snapshot tests'
/// lrsm images.
pub fn mirror_frame(
    data: &SceneData,
    colour: &[[f32; 4]],
    voxels: VoxelFrame,
    settings: &LrsmSettings,
) -> anyhow::Result<LrsmFrame> {
    LrsmFrame::build_with(
        None,
        &|_| true,
        data,
        &vxgi_cpu_mirror::occlusion_voxels::binarize(colour, false),
        voxels,
        settings,
        &|_| {},
        &mut Vec::new(),
    )
}

/// The gather over a scene whose G-buffer and LRSM frame are given; with `shadow_tan` > 0 also the
/// shadow-cone pass (`shadow_main`, cones of that tan of the half-angle) into `soft_direct`.
pub fn case_for(
    data: &SceneData,
    gbuffer: &Resources,
    frame: &LrsmFrame,
    params: &ConeParams,
    shadow_tan: f32,
    label: String,
    seed: u64,
) -> Case {
    // Bindings cannot be empty: a scene without lights binds one view that sees nothing (behind it).
    let packed = |k: usize| lrsm_prefilter::stored(&or_one(&frame.streams[k]));
    let shadow = ShadowParams {
        tan_half: shadow_tan,
        light_count: data.lights.len() as u32,
        _pad: [0; 2],
    };
    let n = (data.width() * data.height()) as usize;
    let volume = buffers([
        ("occ", HostBuffer::of(&frame.occ)),
        ("occ_offsets", HostBuffer::of(&frame.occ_offsets)),
        ("params", HostBuffer::pod(&frame.params)),
        ("depth_ranges", HostBuffer::of(&frame.depth_ranges)),
        ("lrsm_radiance", packed(0)),
        ("lrsm_normal", packed(1)),
        ("lrsm_moments", packed(2)),
        ("views", HostBuffer::structs(&or_one(&frame.views))),
        (
            "lights",
            HostBuffer::f32(bytemuck::cast_slice(&or_one(&data.lights))),
        ),
        ("shadow_params", HostBuffer::pod(&shadow)),
        ("soft_direct", HostBuffer::zeroed(n * 16, ScalarKind::F32)),
        ("lit", HostBuffer::of(&or_one(&frame.lit))),
        ("lit_offsets", HostBuffer::of(&or_one(&frame.lit_offsets))),
    ]);
    let mut case = tracer_case(&DECL, data, gbuffer, params, volume, label, seed);
    if shadow_tan > 0.0 {
        let mut pass = case.passes[0].clone();
        pass.label = "shadow cones".into();
        pass.entry = "shadow_main".into();
        case.passes.push(pass);
        let indexing = case.checks[0].indexing.clone();
        case.checks.push(Check::of("soft_direct", indexing));
    }
    case
}

/// The LRSM frame a gather case binds (for the mirrors).
fn frame_of(data: &Resources, params: &ConeParams) -> LrsmFrame {
    let b = |n: &str| data[n].buffer().expect("buffer");
    let sp: SampleParams = *bytemuck::from_bytes(&b("params").bytes);
    let f4 = |n: &str| -> Vec<[f32; 4]> { bytemuck::cast_slice(&b(n).bytes).to_vec() };
    LrsmFrame {
        voxels: VoxelFrame {
            origin: glam::Vec3::ZERO,
            voxel: params.origin[3],
            side: params.side,
        },
        occ: b("occ").as_u32().to_vec(),
        occ_offsets: b("occ_offsets").as_u32().to_vec(),
        views: bytemuck::cast_slice(&b("views").bytes).to_vec(),
        params: sp,
        depth_ranges: f4("depth_ranges"),
        streams: ["lrsm_radiance", "lrsm_normal", "lrsm_moments"]
            .map(|n| lrsm_prefilter::values(b(n))),
        lit: f4("lit"),
        lit_offsets: b("lit_offsets").as_u32().to_vec(),
        memory: LrsmMemory::default(),
    }
}

/// Mirror outputs of a gather case (indirect, ao and their bounds).
pub fn mirror_gather(data: &Resources) -> Vec<vxgi_cpu_mirror::cone_trace::PixelOut> {
    let params: ConeParams = *bytemuck::from_bytes(&data["cone"].buffer().expect("cone").bytes);
    let frame = frame_of(data, &params);
    let vol = frame.volume(&params);
    shade_all(data, &vol, vol.lmax)
}

/// Mirror of the shadow-cone pass: soft direct light and its bound per pixel.
pub fn mirror_soft_direct(data: &Resources) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    use rayon::prelude::*;
    let b = |n: &str| data[n].buffer().expect("buffer");
    let params: ConeParams = *bytemuck::from_bytes(&b("cone").bytes);
    let shadow: ShadowParams = *bytemuck::from_bytes(&b("shadow_params").bytes);
    let f4 = |n: &str| -> Vec<[f32; 4]> { bytemuck::cast_slice(&b(n).bytes).to_vec() };
    let frame = frame_of(data, &params);
    let vol = frame.volume(&params);
    let sframe: vxgi_cpu_mirror::gbuffer::Frame = *bytemuck::from_bytes(&b("frame").bytes);
    let tris: Vec<vxgi_cpu_mirror::bvh_trace::GpuTriangle> =
        bytemuck::cast_slice(&b("triangles").bytes).to_vec();
    let lights: Vec<vxgi_cpu_mirror::direct_light::GpuLight> =
        bytemuck::cast_slice(&b("lights").bytes).to_vec();
    let lights = &lights[..shadow.light_count as usize];
    let materials: Vec<vxgi_cpu_mirror::direct_light::GpuMaterial> =
        bytemuck::cast_slice(&b("materials").bytes).to_vec();
    let (pos, nrm, alb) = (f4("gb_position"), f4("gb_normal"), f4("gb_albedo"));
    let tri = b("gb_triangle").as_u32().to_vec();
    (0..tri.len())
        .into_par_iter()
        .map(|i| {
            let (l, e) = soft_direct(
                &vol,
                &sframe,
                &tris,
                lights,
                &materials,
                (pos[i], nrm[i], tri[i], alb[i]),
                shadow.tan_half,
            );
            ([l.x, l.y, l.z, 0.0], [e.x, e.y, e.z, 0.0])
        })
        .unzip()
}

pub struct LrsmConeTrace;

impl Kernel for LrsmConeTrace {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    /// A generated scene (point, spot and directional lights), 16^3 or 32^3 voxels,
    /// RSMs of 16^2 or 32^2 per view, 1 or 4 layers.
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (scene, label) = super::gbuffer::generated_scene(seed, index);
        let side = [16u32, 32][(index / 4) % 2];
        let data = SceneData::new(&scene);
        // Marching varied as cone_trace's cases.
        let cones = super::cone_trace::varied_marching(ConeSettings::from(&scene.render), index);
        let settings = LrsmSettings {
            shadow_cone_angle: 0.0,
            rsm_side: [16, 32][index % 2],
            depth_splits: (index / 2 % 2) as u32,
            normal_splits: (index / 2 % 2) as u32,
            overlap: 0.05,
            // The occlusion mips by surface coverage in one case of eight; N as the paper's
            // weight in every third case.
            surface_coverage: index % 8 == 6,
            view_weight: index % 3 == 1,
            // Every fourth case with area-weighted LRSMs (premultiplied samples one level finer),
            // among them the surface-coverage cases (index % 8 == 6).
            area_weights: index % 4 == 2,
            // Every fourth case reads the lit cells (no LRSM).
            lit_cells: index.is_multiple_of(4),
            // Half of those (32^3) read a lit table of 8^3: samples below its level read it.
            lit_max_side: if index % 8 == 4 {
                8
            } else {
                super::lit_cells::MAX_SIDE
            },
        };
        let frame = LrsmFrame::build(
            ctx,
            &scene,
            &data,
            side,
            &settings,
            &|_| {},
            &mut Vec::new(),
        )
        .expect("generated scenes build");
        let params = cone_params(&frame.voxels, &cones);
        let gb = super::direct_light::gpu_gbuffer(ctx, &data);
        // Shadow cones of 2, 5 and 10 degrees (half-angle).
        let shadow_tan = [2.0f32, 5.0, 10.0][index % 3].to_radians().tan();
        case_for(
            &data,
            &gb,
            &frame,
            &params,
            shadow_tan,
            format!(
                "{label}, {side}^3{}, RSM {}^2, {} layers, {} views{}",
                super::cone_trace::marching_label(&cones),
                settings.rsm_side,
                frame.params.depth_slices * frame.params.normal_slices,
                frame.views.len(),
                if settings.surface_coverage {
                    ", surface-coverage occlusion".to_string()
                } else if settings.lit_cells {
                    format!(", lit cells from level {}", frame.params.lit_base)
                } else {
                    String::new()
                }
            ),
            seed,
        )
    }

    fn mirror(&self, case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // Radiance-scale arithmetic, as cone_trace: one mode serves both.
        let mut out = bounded_outputs(&mirror_gather(data));
        if case.checks.iter().any(|c| c.resource == "soft_direct") {
            let (l, e) = mirror_soft_direct(data);
            out.extend(bounded("soft_direct", &l, &e));
        }
        out
    }
}
