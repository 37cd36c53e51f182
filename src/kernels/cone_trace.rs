//! Declaration of `kernels/cone_trace.wgsl` (mirror: `vxgi_cpu_mirror::cone_trace`): AO, diffuse and
//! glossy cones per G-buffer pixel through the radiance pyramid. A case runs the earlier stages on the
//! GPU (G-buffer, voxelization, voxel lighting, mip chain) on a generated scene and feeds them in.
use super::gbuffer::{generated_scene, scene_resources};
use super::surface_coverage_mip::{self, chain_case, colour_name};
use super::voxelize::{voxelize_on_gpu, VoxelFrame};
use crate::trace::SceneData;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::bvh_trace::GpuTriangle;
use vxgi_cpu_mirror::cone_trace::{
    class_cones, cone_dirs, level_offset, pyramid_len, resolve, shade_pixel, ConeParams,
    OrderedPyramid, PixelOut,
};
use vxgi_cpu_mirror::direct_light::GpuMaterial;
use vxgi_cpu_mirror::gbuffer::Frame;
use vxgi_cpu_mirror::surface_coverage_mip::Coverage;
use vxgi_harness::prelude::*;
use vxgi_harness::run::{Pass, View, Workgroups};

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "cone_trace",
    includes: &[super::TANGENT_BASIS, super::SCENE_TYPES, super::CONE_MARCH, super::MORTON, super::PYRAMID_GRID, super::PYRAMID],
    inputs: super::march_inputs!["pyramid", "pyramid_1", "pyramid_2", "pyramid_normal"],
    // The march's bound (`super::march_outputs!`), the pyramid's trilinear sample in it.
    outputs: super::march_outputs![],
    dispatch: DispatchRule::PerItem {
        what: "8x8 screen tile holding a surface (screen_tiles' list, dispatched indirectly)",
    },
    mirror: "vxgi_cpu_mirror::cone_trace::shade_pixel (+ resolve where interleave > 1)",
    summary: "AO + diffuse cones + one glossy cone per pixel, quadrilinear marching of the radiance pyramid (CPRC 4, VCT 5-7)",
);

/// cone_trace through several voxel hierarchies placed by rigid transforms (an instance's own, CPRC 3.1):
/// the same kernel file and pixel entry with common/placed_pyramids.wgsl as the volume.
pub static INSTANCED_DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "cone_trace_instanced" in "cone_trace",
    includes: &[
        super::TANGENT_BASIS,
        super::SCENE_TYPES,
        super::CONE_MARCH,
        super::MORTON,
        super::PYRAMID_GRID,
        super::PLACED_PYRAMIDS,
    ],
    inputs: super::march_inputs!["pyramid", "pyramid_1", "pyramid_2", "placed", "placed_cells"],
    // As cone_trace's, each sample's error the sum of its hierarchies' (their local points'
    // rounding included).
    outputs: super::march_outputs![],
    dispatch: DispatchRule::PerItem {
        what: "8x8 screen tile holding a surface (screen_tiles' list, dispatched indirectly)",
    },
    mirror: "vxgi_cpu_mirror::cone_trace::shade_pixel (PlacedPyramids)",
    summary: "cone_trace through several voxel hierarchies placed by rigid transforms (instances, CPRC 3.1)",
);

/// Cone settings (the `[render]`-level knobs of the vct-dense pipeline).
#[derive(Clone, Copy, Debug)]
pub struct ConeSettings {
    pub diffuse_cones: u32,
    /// Half-angle of the diffuse cones, degrees.
    pub diffuse_half_angle_deg: f32,
    pub ao_range: f32,
    pub ao_lambda: f32,
    /// Cone origins start this many level-0 cells off the surface along its normal.
    pub offset_voxels: f32,
    /// Surface-aware mip clamp (0 = off: the paper's rule), see `vxgi_cpu_mirror::cone_trace`.
    pub mip_clamp: f32,
    /// Step as a fraction of the cone's diameter (the paper's 0.5).
    pub step_factor: f32,
    /// Sampled level relative to the paper's (`ConeParams::level_bias`, <= 0).
    pub level_bias: f32,
    /// Correlated coverage in [0, 1] (`ConeParams::coverage_correlation`; 0 = the paper's).
    pub coverage_correlation: f32,
    /// vct-dense and cprc: the depth-ordered blend (`vxgi_cpu_mirror::cone_trace::OrderedPyramid`)
    /// instead of the paper's trilinear.
    pub depth_ordered_blend: bool,
    /// Side N of the interleaved cone sets (1 = off; `ConeParams::interleave`): the per-pixel
    /// tracers' N x N pixel classes trace disjoint subsets of `diffuse_cones` N^2 cones, resolved
    /// by the tent-weighted window average (`vxgi_cpu_mirror::cone_trace::resolve`).
    pub interleave: u32,
}

impl Default for ConeSettings {
    /// The `[render]` defaults.
    fn default() -> Self {
        Self::from(&crate::scene::RenderSettings::default())
    }
}

impl From<&crate::scene::RenderSettings> for ConeSettings {
    fn from(r: &crate::scene::RenderSettings) -> Self {
        Self {
            diffuse_cones: r.cones,
            diffuse_half_angle_deg: r.cone_half_angle,
            ao_range: r.ao_range,
            ao_lambda: r.ao_lambda,
            offset_voxels: r.cone_offset,
            mip_clamp: r.mip_clamp,
            step_factor: r.cone_step,
            level_bias: r.cone_level_bias,
            coverage_correlation: r.coverage_correlation,
            depth_ordered_blend: r.depth_ordered_blend,
            interleave: r.cone_interleave,
        }
    }
}

/// The pyramid levels `scene`'s cones can read with settings `s` on a grid of side `side` (the
/// planner's rule "mip levels no cone reaches are not built"): `levels_read` of the widest cone — the
/// diffuse cones, or a glossy material's cone where one is wider (tan = clamp(sqrt(2 / (n + 2)), 0.02,
/// 1), the kernel's rule). Every diffuse cone wider than ~8.5 degrees reads the whole pyramid at 128^3.
pub fn pyramid_levels(scene: &crate::scene::Scene, s: &ConeSettings, side: u32) -> u32 {
    let widest = scene
        .materials
        .iter()
        .filter(|m| m.is_glossy())
        .map(|m| (2.0 / (m.shininess + 2.0)).sqrt().clamp(0.02, 1.0))
        .fold(s.diffuse_half_angle_deg.to_radians().tan(), f32::max);
    vxgi_cpu_mirror::cone_trace::levels_read(widest, s.step_factor, side)
}

pub fn cone_params(frame: &VoxelFrame, s: &ConeSettings) -> ConeParams {
    ConeParams {
        origin: [frame.origin.x, frame.origin.y, frame.origin.z, frame.voxel],
        ao_range: s.ao_range,
        ao_lambda: s.ao_lambda,
        diffuse_tan: s.diffuse_half_angle_deg.to_radians().tan(),
        offset_voxels: s.offset_voxels,
        diffuse_cones: s.diffuse_cones.max(1),
        levels: frame.side.trailing_zeros() + 1,
        side: frame.side,
        inv_s0: 1.0 / frame.voxel,
        mip_clamp: s.mip_clamp,
        step_factor: s.step_factor,
        depth_order: u32::from(s.depth_ordered_blend),
        level_bias: s.level_bias,
        coverage_correlation: s.coverage_correlation,
        interleave: s.interleave.max(1),
        _pad: [0; 2],
    }
}

/// Level 0 (voxel radiance and normals) and the surface-coverage mip chain by the mirror,
/// concatenated ([`gpu_pyramid`]'s counterpart).
pub fn mirror_pyramid(radiance: &[[f32; 4]], normal: &[[f32; 4]]) -> Pyramids {
    let mut pyramids = Pyramids {
        colour: radiance.to_vec(),
        normal: normal.to_vec(),
    };
    for (colour, normals) in
        vxgi_cpu_mirror::surface_coverage_mip::mip_chain(radiance, normal, Coverage::Surface)
    {
        pyramids.colour.extend(colour);
        pyramids.normal.extend(normals);
    }
    pyramids
}

/// The radiance pyramid and its normal pyramid (surface_coverage_mip's normals above voxelize's),
/// each level 0 and the mip chain concatenated ([`level_offset`]); the depth-ordered blend reads both.
#[derive(Clone, Debug, Default)]
pub struct Pyramids {
    pub colour: Vec<[f32; 4]>,
    pub normal: Vec<[f32; 4]>,
}

/// Level 0 (voxel radiance and normals) and the surface-coverage mip chain built on the GPU,
/// concatenated.
pub fn gpu_pyramid(
    ctx: &GpuContext,
    radiance: &[[f32; 4]],
    normal: &[[f32; 4]],
    side: u32,
) -> anyhow::Result<Pyramids> {
    let grid = crate::grids::Grid {
        n: side,
        colour: radiance.to_vec(),
        normal: normal.to_vec(),
    };
    let shader = surface_coverage_mip::DECL.shader()?;
    let case = chain_case(&shader, ctx, &grid, Coverage::Surface, "pyramid".into(), 0);
    let levels = side.trailing_zeros() + 1;
    let names: Vec<String> = (1..levels).map(colour_name).collect();
    let normal_names: Vec<String> = (1..levels).map(surface_coverage_mip::normal_name).collect();
    let refs: Vec<&str> = names
        .iter()
        .chain(&normal_names)
        .map(|s| s.as_str())
        .collect();
    let out = case.run(ctx, &shader, surface_coverage_mip::DECL.name, &refs)?;
    let concat = |level0: &[[f32; 4]], names: &[String]| {
        let mut pyr = Vec::with_capacity(pyramid_len(side));
        pyr.extend_from_slice(level0);
        for name in names {
            pyr.extend_from_slice(bytemuck::cast_slice::<u8, [f32; 4]>(
                &out.buffer(name).bytes,
            ));
        }
        debug_assert_eq!(pyr.len(), pyramid_len(side));
        pyr
    };
    debug_assert_eq!(level_offset(side, 1), radiance.len());
    Ok(Pyramids {
        colour: concat(radiance, &names),
        normal: concat(normal, &normal_names),
    })
}

/// The cone pass of `scene` with its own inputs built stage by stage on the GPU (G-buffer, voxelize at
/// `scene.render.voxels`, the voxel light's mirror radiance, the mip chain): a case to time or to
/// vary (e.g. its tile list) without the rest of the frame.
pub fn scene_case(
    ctx: &GpuContext,
    scene: &crate::scene::Scene,
    cones: &ConeSettings,
) -> anyhow::Result<Case> {
    let data = SceneData::new(scene);
    let gb = super::direct_light::gpu_gbuffer(ctx, &data);
    let side = scene.render.voxels;
    let (grid, list, frame) = voxelize_on_gpu(ctx, scene, side)?;
    let lcase = super::voxel_light::case_for(ctx, &data, &grid, &list, &frame, "scene".into(), 0);
    let (radiance, _) = super::voxel_light::mirror_radiance(&lcase.resources);
    let pyramids = gpu_pyramid(ctx, &radiance, &grid.normal, side)?;
    let params = cone_params(&frame, cones);
    Ok(case_for(&data, &gb, &pyramids, &params, "scene".into(), 0))
}

/// Run a cone-pass case of `decl` (cone_trace or another kernel on common/cone_march.wgsl) on the
/// GPU: its `indirect` and `ao` bytes.
pub fn run_case(ctx: &GpuContext, decl: &KernelDecl, case: &Case) -> anyhow::Result<[Vec<u8>; 2]> {
    let names = ["indirect", "ao"];
    let out = decl.run(ctx, case, &names)?;
    Ok(names.map(|n| out.buffer(n).bytes.clone()))
}

/// The cone pass over a scene whose G-buffer and pyramids are given. The normal pyramid is bound
/// only where `params` asks for the depth-ordered blend (else one empty element: never read).
pub fn case_for(
    data: &SceneData,
    gbuffer: &Resources,
    pyramids: &Pyramids,
    params: &ConeParams,
    label: String,
    seed: u64,
) -> Case {
    let normal: &[[f32; 4]] = if params.depth_order != 0 {
        &pyramids.normal
    } else {
        &[[0.0; 4]]
    };
    let volume = buffers([
        ("pyramid", HostBuffer::of(&pyramids.colour)),
        ("pyramid_normal", HostBuffer::of(normal)),
    ]);
    tracer_case(&DECL, data, gbuffer, params, volume, label, seed)
}

/// The instanced cone pass (`INSTANCED_DECL`): `pyramid` holds every hierarchy, `placed` says where each
/// stands and where its levels start; `params` is the march's grid (covering them all).
pub fn instanced_case_for(
    data: &SceneData,
    gbuffer: &Resources,
    pyramid: &[[f32; 4]],
    placed: &[vxgi_cpu_mirror::cache_creation::Placed],
    params: &ConeParams,
    label: String,
    seed: u64,
) -> Case {
    let mut volume = placed_resources(placed);
    volume.insert("pyramid".into(), HostBuffer::of(pyramid).into());
    tracer_case(&INSTANCED_DECL, data, gbuffer, params, volume, label, seed)
}

/// The `placed` records of hierarchies and their `placed_cells` (common/placed_pyramids.wgsl).
pub fn placed_resources(placed: &[vxgi_cpu_mirror::cache_creation::Placed]) -> Resources {
    buffers([
        ("placed", HostBuffer::structs(placed)),
        (
            "placed_cells",
            HostBuffer::of(&vxgi_cpu_mirror::cache_creation::placed_cells(placed)),
        ),
    ])
}

/// Radiance-pyramid elements per binding: WebGPU's default max_storage_buffer_binding_size (128
/// MiB) of vec4s, which every device binds; a larger pyramid is bound in up to three windows of its
/// buffer (`pyramid`, `pyramid_1`, `pyramid_2`: common/pyramid_grid.wgsl).
pub const PYRAMID_WINDOW: u64 = 1 << 23;

/// Bind the pyramid of `case` (every pass binding `pyramid`) in windows of `window` elements (a
/// multiple of 16: binding offsets are 256-byte aligned) where it has more; the windows it does not
/// need, and every window of a pyramid that fits one, get one unused element (`pyramid_1`,
/// `pyramid_2`). A pyramid past three windows is an error naming its size.
pub fn bind_pyramid_windows(case: &mut Case, window: u64) -> Result<(), String> {
    bind_pyramid_views(&mut case.passes, &mut case.resources, window)
}

/// [`bind_pyramid_windows`] over the passes and resources of a chain (its `pyramid` sized already).
pub fn bind_pyramid_views(
    passes: &mut [Pass],
    resources: &mut Resources,
    window: u64,
) -> Result<(), String> {
    let len = pyramid_elements(resources);
    let views = ["pyramid", "pyramid_1", "pyramid_2"];
    super::bind_windows(passes, resources, "pyramid", &views, 16, window).map_err(|_| {
        format!(
            "the radiance pyramid holds {len} voxels, past three bindings of {window}: fewer voxels"
        )
    })?;
    // Read by the depth-ordered blend alone, which the voxel limits keep within one binding
    // (`limits::check`): past one, its first binding's worth is bound, unread.
    let normal = resources.get("pyramid_normal").and_then(|r| r.buffer());
    if normal.map_or(0, |b| b.bytes.len()) as u64 > PYRAMID_WINDOW * 16 {
        for (binding, view) in passes.iter_mut().flat_map(|p| &mut p.bindings) {
            if binding == "pyramid_normal" {
                *view = View::BufferRange {
                    name: "pyramid_normal".into(),
                    offset: 0,
                    size: PYRAMID_WINDOW * 16,
                };
            }
        }
    }
    Ok(())
}

/// The vec4 elements of the `pyramid` resource.
fn pyramid_elements(resources: &Resources) -> u64 {
    let pyramid = resources["pyramid"]
        .buffer()
        .expect("the pyramid is a buffer");
    pyramid.bytes.len() as u64 / 16
}

/// One generated case in eight (`index % 8 == 5`) with its pyramid bound in three windows, as a
/// pyramid past one binding is: the same outputs.
pub fn with_pyramid_split(mut case: Case, index: usize) -> Case {
    if index % 8 != 5 {
        return case;
    }
    let len = pyramid_elements(&case.resources);
    let window = (len.div_ceil(3).div_ceil(16) * 16).max(16);
    bind_pyramid_windows(&mut case, window).expect("three windows hold it");
    if len > window {
        case.label.push_str(", pyramid in three bindings");
    }
    case
}

/// The cone pass of a kernel built on `kernels/common/cone_march.wgsl` (`decl`): the scene, G-buffer
/// and cone bindings, plus the resources of its volume (`volume`, by binding name).
pub fn tracer_case(
    decl: &KernelDecl,
    data: &SceneData,
    gbuffer: &Resources,
    params: &ConeParams,
    volume: Resources,
    label: String,
    seed: u64,
) -> Case {
    let (w, h) = (data.width(), data.height());
    let n = w as usize * h as usize;
    let mut resources = scene_resources(data);
    resources.remove("nodes");
    resources.remove("lights");
    for name in ["gb_position", "gb_normal", "gb_triangle", "gb_albedo"] {
        resources.insert(name.into(), gbuffer[name].clone());
    }
    resources.insert("cone".into(), HostBuffer::pod(params).into());
    resources.insert(
        "cone_dirs".into(),
        HostBuffer::of(&cone_dirs(params)).into(),
    );
    resources.extend(volume);
    for name in ["indirect", "ao", "irradiance"] {
        resources.insert(
            name.into(),
            HostBuffer::zeroed(n * 16, ScalarKind::F32).into(),
        );
    }
    // The pass runs over the 8x8 tiles that hold a surface (screen_tiles' list, here from its mirror:
    // the G-buffer is on the host; a chain builds it on the GPU), dispatched from the list's arguments.
    let normals: &[[f32; 4]] =
        bytemuck::cast_slice(&gbuffer["gb_normal"].buffer().expect("gb_normal").bytes);
    let tiles = vxgi_cpu_mirror::screen_tiles::tile_list(normals, w, h);
    resources.insert("tile_list".into(), HostBuffer::of(&tiles).into());
    let grid = Indexing::Grid {
        dims: [w, h, 1],
        components: 4,
    };
    // Interleaved cone sets: the resolve follows over the same tiles.
    let entries: &[&str] = if params.interleave > 1 {
        &["main", "resolve"]
    } else {
        &["main"]
    };
    let mut case = Case {
        label,
        seed,
        resources,
        passes: entries
            .iter()
            .map(|&entry| Pass {
                label: if entry == "main" {
                    decl.name.into()
                } else {
                    format!("{} {entry}", decl.name)
                },
                entry: entry.into(),
                bindings: decl.bind_by_name(),
                workgroups: Workgroups::Indirect {
                    buffer: "tile_list".into(),
                    offset: 0,
                },
            })
            .collect(),
        checks: ["indirect", "ao", "irradiance"]
            .map(|name| Check::of(name, grid.clone()))
            .to_vec(),
        effective_bytes: n as u64 * 84,
    };
    if decl.inputs.contains(&"pyramid") {
        bind_pyramid_windows(&mut case, PYRAMID_WINDOW)
            .expect("the voxel limits keep the pyramid within its bindings");
    }
    case
}

/// Largest radiance in level 0 (allowances for rounding-decided stops scale with it).
pub fn max_radiance(pyramid: &[[f32; 4]], side: u32) -> f32 {
    pyramid[..level_offset(side, 1)]
        .iter()
        .map(|v| v[0].max(v[1]).max(v[2]))
        .fold(0.0, f32::max)
}

/// The dense pyramid of a case's resources (`pyramid`, `pyramid_normal`) as the mirror's volume:
/// `OrderedPyramid` is the paper's trilinear where `params.depth_order` is 0 (the normal binding then
/// holds one element, never read) and the depth-ordered blend where it is 1.
pub fn dense_volume<'a>(data: &'a Resources, params: &'a ConeParams) -> OrderedPyramid<'a> {
    let b = |n: &str| &data[n].buffer().expect("buffer").bytes;
    OrderedPyramid {
        p: params,
        voxels: bytemuck::cast_slice(b("pyramid")),
        normals: bytemuck::cast_slice(b("pyramid_normal")),
    }
}

pub fn mirror_cones(data: &Resources) -> Vec<PixelOut> {
    use vxgi_cpu_mirror::cache_creation::{Placed, PlacedPyramids};
    let b = |n: &str| data[n].buffer().expect("buffer");
    let params: ConeParams = *bytemuck::from_bytes(&b("cone").bytes);
    let voxels: &[[f32; 4]] = bytemuck::cast_slice(&b("pyramid").bytes);
    match data.get("placed") {
        None => shade_all(
            data,
            &dense_volume(data, &params),
            max_radiance(voxels, params.side),
        ),
        Some(r) => {
            let placed: &[Placed] = bytemuck::cast_slice(&r.buffer().expect("buffer").bytes);
            let lmax = placed
                .iter()
                .map(|h| {
                    max_radiance(
                        &voxels[h.side_levels_base[2] as usize..],
                        h.side_levels_base[0],
                    )
                })
                .fold(0.0, f32::max);
            let vol = PlacedPyramids {
                p: &params,
                placed,
                voxels,
            };
            shade_all(data, &vol, lmax)
        }
    }
}

/// Every pixel of a cone pass's resources through `volume` (each pixel its interleaving class's
/// cones), then, where `interleave` > 1, the resolve: indirect, AO, irradiance and their bounds.
/// `lmax`: the largest radiance in the volume (allowances for rounding-decided stops scale with it).
pub fn shade_all(
    data: &Resources,
    volume: &(impl vxgi_cpu_mirror::cone_trace::Volume + Sync),
    lmax: f32,
) -> Vec<PixelOut> {
    let b = |n: &str| data[n].buffer().expect("buffer");
    let frame: Frame = *bytemuck::from_bytes(&b("frame").bytes);
    let tris: &[GpuTriangle] = bytemuck::cast_slice(&b("triangles").bytes);
    let materials: &[GpuMaterial] = bytemuck::cast_slice(&b("materials").bytes);
    let dirs: &[[f32; 4]] = bytemuck::cast_slice(&b("cone_dirs").bytes);
    let pos: &[[f32; 4]] = bytemuck::cast_slice(&b("gb_position").bytes);
    let nrm: &[[f32; 4]] = bytemuck::cast_slice(&b("gb_normal").bytes);
    let tri = b("gb_triangle").as_u32();
    let alb: &[[f32; 4]] = bytemuck::cast_slice(&b("gb_albedo").bytes);
    let p = volume.params();
    let w = frame.size[0].max(1);
    let px: Vec<PixelOut> = {
        use rayon::prelude::*;
        (0..tri.len())
            .into_par_iter()
            .map(|i| {
                let cones = class_cones(dirs, p, i as u32 % w, i as u32 / w);
                shade_pixel(
                    volume, &frame, tris, materials, &cones, pos[i], nrm[i], tri[i], alb[i], lmax,
                )
            })
            .collect()
    };
    if p.interleave > 1 {
        resolve(p, w, pos, nrm, alb, &px)
    } else {
        px
    }
}

pub struct ConeTrace;

const SIDES: [u32; 2] = [16, 32];

/// What a cone-pass case (cone_trace, svo_cone_trace) is made from: a generated scene, its G-buffer
/// and lit voxels (side 16 or 32) from the GPU, and marching settings varied per case.
pub struct LitCase {
    pub data: SceneData,
    pub gbuffer: Resources,
    /// Level 0 `(L * alpha, alpha)`, normals and albedo (voxelize's colour), Morton order.
    pub radiance: Vec<[f32; 4]>,
    pub normal: Vec<[f32; 4]>,
    pub albedo: Vec<[f32; 4]>,
    pub frame: VoxelFrame,
    pub settings: ConeSettings,
    pub label: String,
}

pub fn lit_case(ctx: &GpuContext, seed: u64, index: usize) -> LitCase {
    let (scene, label) = generated_scene(seed, index);
    let side = SIDES[(index / 4) % SIDES.len()];
    let data = SceneData::new(&scene);
    let gbuffer = super::direct_light::gpu_gbuffer(ctx, &data);
    let (grid, list, frame) = voxelize_on_gpu(ctx, &scene, side).expect("generated grids voxelize");
    let radiance = super::voxel_light::light_on_gpu(ctx, &data, &grid, &list, &frame)
        .expect("voxel_light runs");
    // The depth-ordered blend on every other case (cone_trace reads it; the other cone kernels
    // ignore it).
    let settings = ConeSettings {
        depth_ordered_blend: index % 2 == 1,
        ..varied_marching(ConeSettings::from(&scene.render), index)
    };
    LitCase {
        data,
        gbuffer,
        radiance,
        normal: grid.normal,
        albedo: grid.colour,
        frame,
        settings,
        label: format!("{label}, {side}^3{}", marching_label(&settings)),
    }
}

/// The marching every cone kernel's generated cases vary (the same march, common/cone_march.wgsl):
/// step factor 0.5 (the paper's), 0.75, 1; mip clamp on and off; level bias 0, -1, -1.5; coverage
/// correlation 0 (in three cases of seven), 0.25, 0.5, 1; interleaved cone sets off (two cases of
/// five), 2, 4, 8 (with the resolve pass).
pub fn varied_marching(base: ConeSettings, index: usize) -> ConeSettings {
    ConeSettings {
        interleave: [1, 4, 2, 1, 8][(index / 2) % 5],
        step_factor: [0.5, 0.75, 1.0][index % 3],
        mip_clamp: if index % 5 == 4 { 0.0 } else { 2.0 },
        level_bias: [0.0, 0.0, -1.0, -1.5][(index / 3) % 4],
        coverage_correlation: [0.0, 0.0, 1.0, 0.5, 0.0, 1.0, 0.25][index % 7],
        ..base
    }
}

/// The case label's note of the non-default marching options.
pub fn marching_label(s: &ConeSettings) -> String {
    let mut l = String::new();
    if s.level_bias != 0.0 {
        l += &format!(", level bias {}", s.level_bias);
    }
    if s.coverage_correlation != 0.0 {
        l += &format!(", coverage correlation {}", s.coverage_correlation);
    }
    if s.interleave > 1 {
        l += &format!(", interleave {0}x{0}", s.interleave);
    }
    l
}

/// A cone pass's mirror outputs (indirect, ao, irradiance, their bounds) by resource name.
pub fn bounded_outputs(px: &[PixelOut]) -> BTreeMap<String, HostBuffer> {
    let f = |g: fn(&PixelOut) -> [f32; 4]| px.iter().map(g).collect::<Vec<_>>();
    let out = bounded("indirect", &f(|p| p.indirect), &f(|p| p.indirect_bound));
    let ao = bounded("ao", &f(|p| p.ao), &f(|p| p.ao_bound));
    let e = bounded(
        "irradiance",
        &f(|p| p.irradiance),
        &f(|p| p.irradiance_bound),
    );
    out.into_iter().chain(ao).chain(e).collect()
}

/// The (indirect, ao) images' pixels of a cone pass's mirror outputs.
pub fn indirect_and_ao(px: &[PixelOut]) -> [Vec<[f32; 4]>; 2] {
    [
        px.iter().map(|p| p.indirect).collect(),
        px.iter().map(|p| p.ao).collect(),
    ]
}

/// A seeded rigid placement of a voxel grid about its centre (an instance of it elsewhere): a rotation
/// of 10-40 degrees about a random axis, a shift of up to a third of the grid, scale 1 or 0.8.
pub fn random_placement(rng: &mut impl rand::Rng, frame: &VoxelFrame) -> glam::Mat4 {
    let extent = frame.voxel * frame.side as f32;
    let centre = frame.origin + glam::Vec3::splat(0.5 * extent);
    let axis = glam::Vec3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(0.1..1.0),
    )
    .normalize();
    let scale = if rng.random_bool(0.5) { 1.0 } else { 0.8 };
    let shift = glam::Vec3::new(
        rng.random_range(-0.33..0.33),
        rng.random_range(-0.33..0.33),
        rng.random_range(-0.33..0.33),
    ) * extent;
    glam::Mat4::from_translation(centre + shift)
        * glam::Mat4::from_axis_angle(axis, rng.random_range(0.17..0.7))
        * glam::Mat4::from_scale(glam::Vec3::splat(scale))
        * glam::Mat4::from_translation(-centre)
}

/// What an instanced cone-pass case (cone_trace, cache_creation) is made from: [`lit_case`]'s scene
/// and its pyramid as hierarchy 0 (in place), then `copies` more of it placed by
/// [`random_placement`] (instances of one mesh, drawn from `seed ^ salt ^ index`); the march's parameters
/// without the depth-ordered blend (common/placed_pyramids.wgsl's trilinear).
pub struct PlacedCase {
    pub lit: LitCase,
    pub pyramid: Vec<[f32; 4]>,
    pub placed: Vec<vxgi_cpu_mirror::cache_creation::Placed>,
    pub params: ConeParams,
}

pub fn placed_case(
    ctx: &GpuContext,
    seed: u64,
    salt: u64,
    index: usize,
    copies: usize,
) -> PlacedCase {
    use rand::SeedableRng;
    use vxgi_cpu_mirror::cache_creation::Placed;
    let lit = lit_case(ctx, seed, index);
    let pyramid = gpu_pyramid(ctx, &lit.radiance, &lit.normal, lit.frame.side)
        .expect("mip chain runs")
        .colour;
    let params = ConeParams {
        depth_order: 0,
        ..cone_params(&lit.frame, &lit.settings)
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ salt ^ index as u64);
    let (s0, side, origin) = (lit.frame.voxel, lit.frame.side, lit.frame.origin.to_array());
    let mut placed = vec![Placed::new(origin, s0, side, 0, glam::Mat4::IDENTITY, s0)];
    for _ in 0..copies {
        let m = random_placement(&mut rng, &lit.frame);
        placed.push(Placed::new(origin, s0, side, 0, m, s0));
    }
    PlacedCase {
        lit,
        pyramid,
        placed,
        params,
    }
}

pub struct ConeTraceInstanced;

impl Kernel for ConeTraceInstanced {
    fn decl(&self) -> &'static KernelDecl {
        &INSTANCED_DECL
    }
    /// cone_trace's cases through [`placed_case`] with one copy.
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let p = placed_case(ctx, seed, 0xc0e, index, 1);
        let case = instanced_case_for(
            &p.lit.data,
            &p.lit.gbuffer,
            &p.pyramid,
            &p.placed,
            &p.params,
            format!("{}, 2 hierarchies", p.lit.label),
            seed,
        );
        with_pyramid_split(case, index)
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        bounded_outputs(&mirror_cones(data))
    }
}

impl Kernel for ConeTrace {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let c = lit_case(ctx, seed, index);
        let pyr = gpu_pyramid(ctx, &c.radiance, &c.normal, c.frame.side).expect("mip chain runs");
        let params = cone_params(&c.frame, &c.settings);
        let label = if params.depth_order != 0 {
            format!("{}, depth-ordered", c.label)
        } else {
            c.label
        };
        with_pyramid_split(
            case_for(&c.data, &c.gbuffer, &pyr, &params, label, seed),
            index,
        )
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // Radiance-scale arithmetic; subnormal alphas at coarse levels only scale terms that are
        // already below the bound: one mode serves both.
        bounded_outputs(&mirror_cones(data))
    }
}
