//! The cprc pipeline (Rehfeld et al. 2014, "Clustered Pre-convolved Radiance Caching"): vct-dense's
//! G-buffer, direct light, lit voxels and surface-coverage pyramid; then
//! 1. cache distribution (3.2) on the G-buffer: `tile_normal_histogram`, `histogram_axes`,
//!    `cluster_keys`, `radix_sort`, `cluster_extract`, `cache_placement` — one cache per cluster;
//! 2. cache creation (3.1): `cache_creation`, one cone per cache texel through the pyramid;
//! 3. pre-convolution: `cache_preconvolve`, each cache's mip chain and cosine-folded irradiance map;
//! 4. evaluation by gathering (3.3): `gather_caches`, diffuse by the pixel normal, glossy by the
//!    reflection vector at the mip level of the Phong lobe's solid angle at 1%, weights min(w_w, w_s).
//!
//! Indirect = albedo / pi * E + Ks * G (E the gathered irradiance, G the gathered glossy radiance);
//! the caches hold one bounce of the voxels' direct light, as vct-dense's cones do. cprc has no AO
//! pass: its AO image is 1 (unoccluded) on geometry. Here the distribution (six kernels) and the
//! cache stages (three) each run as one chain on GPU-resident buffers (`vxgi_harness::prepare_chain`),
//! with the per-pixel inputs, the cache records and the composed images computed between them on the
//! host by the mirrors of `cprc_pixels` and `cache_records`; [`crate::resident::Resident`] runs the
//! whole frame, those two kernels included, as one chain (`crate::pipeline::cprc_chain`).
use crate::images::RgbImage;
use crate::kernels::{
    cache_creation, cache_placement, cache_preconvolve, cluster_extract, cluster_keys,
    gather_caches, histogram_axes, radix_sort, tile_normal_histogram,
};
use crate::scene::RenderSettings;
use crate::trace::SceneData;
use anyhow::{Context, Result};
use vxgi_cpu_mirror::cluster_extract::Cluster;
use vxgi_cpu_mirror::gather_caches::GatherParams;
use vxgi_harness::{GpuContext, HostBuffer, HostResource, Resources};

/// cprc's `[render]` knobs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CprcSettings {
    /// Cache side in texels (hemi-octahedral, power of two).
    pub res: u32,
    /// Irradiance map side (power of two, <= res).
    pub irr: u32,
    /// Screen tile of the distribution, pixels.
    pub tile: u32,
    /// Depth slices of the cluster keys.
    pub slices: u32,
    /// Gathering radius in pixels (the paper's f x tile size).
    pub radius_px: u32,
    /// The gather's angle term (`gather_angle`).
    pub angle: bool,
}

impl From<&RenderSettings> for CprcSettings {
    fn from(r: &RenderSettings) -> Self {
        Self {
            res: r.cache_resolution,
            irr: r.irradiance_resolution.min(r.cache_resolution),
            tile: r.cache_tile,
            slices: r.cache_depth_slices,
            radius_px: ((r.gather_radius * r.cache_tile as f32).round() as u32).max(1),
            angle: r.gather_angle,
        }
    }
}

/// What the distribution and the gather read per pixel, from a G-buffer.
pub struct PixelInputs {
    pub width: u32,
    pub height: u32,
    /// snorm16-packed normals (background and back faces: geometry 0).
    pub normals: Vec<[u32; 2]>,
    /// View depth along the camera's forward axis.
    pub depth: Vec<f32>,
    /// World position, w = 1 where the pixel gathers (front-facing geometry), else 0.
    pub positions: Vec<[f32; 4]>,
    /// Two per pixel: (normal, 0), (reflection vector, glossy mip level; -1 without Ks).
    pub pixel_dirs: Vec<[f32; 4]>,
    /// Per pixel: (albedo rgb, 0) and (Ks rgb, 0), for composing the indirect image.
    pub albedo: Vec<[f32; 4]>,
    pub specular: Vec<[f32; 4]>,
    /// Any geometry (front or back face): where the AO image is 1.
    pub geometry: Vec<bool>,
    /// The unit of the clusters' depth slices ([`depth_unit`]).
    pub depth_unit: f32,
}

/// The unit of the clusters' depth slices for a scene of `bounds`: the power of two nearest a
/// quarter of the bounds' diagonal (1 for a room 2 to 5 units across, as every shipped scene but
/// Sponza, 8 for Sponza), so that a scene modelled in other units slices its depths alike (the
/// slices are exponential: a power of two moves their bounds by a fraction of one).
pub fn depth_unit(bounds: (glam::Vec3, glam::Vec3)) -> f32 {
    let quarter = (bounds.1 - bounds.0).length() / 4.0;
    if !(quarter.is_finite() && quarter > 0.0) {
        return 1.0;
    }
    2f32.powi(quarter.log2().round().clamp(-60.0, 60.0) as i32)
}

/// Mip level of a Phong lobe of exponent `e` in a cache of `res^2` texels: the lobe's solid angle at 1%
/// (cos^e theta = 0.01: 2 pi (1 - 0.01^(1/e))) over the mean texel's (2 pi / res^2), as a side ratio
/// (each level quadruples a texel's solid angle); 0 at least.
pub fn glossy_level(e: f32, res: u32) -> f32 {
    let c = 0.01f64.powf(1.0 / e.max(1e-3) as f64);
    let ratio = (1.0 - c) * (res as f64 * res as f64);
    (0.5 * ratio.max(1.0).log2()) as f32
}

/// The per-pixel inputs from a G-buffer's positions, normals (w: 1 front, -1 back, 0 none), triangles
/// and albedos: `kernels/cprc_pixels.wgsl`'s `inputs` by its mirror (the resident frame runs the
/// kernel).
pub fn pixel_inputs(
    data: &SceneData,
    pos: &[[f32; 4]],
    nrm: &[[f32; 4]],
    tri: &[u32],
    albedo: &[[f32; 4]],
    res: u32,
) -> PixelInputs {
    use vxgi_cpu_mirror::cprc_pixels as m;
    let f = &data.frame;
    let lobes = crate::kernels::cprc_pixels::lobes(&data.materials, res);
    let material = |t: u32| data.triangles[t as usize].material();
    let scene = m::Scene {
        eye: f.eye,
        forward: f.forward,
        materials: &material,
        triangles: data.triangles.len() as u32,
        lobes: &lobes,
    };
    let n = pos.len();
    let mut px = PixelInputs {
        width: data.width(),
        height: data.height(),
        normals: Vec::with_capacity(n),
        depth: Vec::with_capacity(n),
        positions: Vec::with_capacity(n),
        pixel_dirs: Vec::with_capacity(2 * n),
        albedo: Vec::with_capacity(n),
        specular: Vec::with_capacity(n),
        geometry: nrm.iter().map(|v| v[3] != 0.0).collect(),
        depth_unit: depth_unit(data.bounds),
    };
    for i in 0..n {
        let o = m::pixel(
            &scene,
            &m::GPixel {
                position: pos[i],
                normal: nrm[i],
                triangle: tri[i],
            },
        );
        px.normals.push(o.normal);
        px.depth.push(o.depth);
        px.positions.push(o.position);
        px.pixel_dirs.extend(o.dirs);
        px.albedo.push(if o.position[3] == 1.0 {
            albedo[i]
        } else {
            [0.0; 4]
        });
        px.specular.push(o.specular);
    }
    px
}

/// What the caches are created from: one radiance pyramid (the scene's), or several concatenated, each
/// placed by a rigid transform (CPRC 3.1's per-instance hierarchies).
#[derive(Clone, Copy)]
pub enum CacheVolume<'a> {
    One(&'a crate::kernels::cone_trace::Pyramids),
    Placed(
        &'a [[f32; 4]],
        &'a [vxgi_cpu_mirror::cache_creation::Placed],
    ),
}

/// Whether any pixel reads the caches' mip chains (a glossy material in view).
pub fn any_glossy(px: &PixelInputs) -> bool {
    px.pixel_dirs.iter().skip(1).step_by(2).any(|d| d[3] >= 0.0)
}

/// The caches a distribution placed, ready for creation and the gather.
pub struct CacheSet {
    pub caches: gather_caches::Caches,
    /// Two vec4s per cache for cache_creation: (origin = position + offset along the normal, 0),
    /// (normal, 0).
    pub creation: Vec<[f32; 4]>,
}

impl CacheSet {
    /// No caches (a frame whose plan skips them).
    pub fn empty() -> Self {
        Self::new(
            gather_caches::Caches {
                pos: Vec::new(),
                pixel: Vec::new(),
                normal: Vec::new(),
                tile_ranges: Vec::new(),
            },
            0.0,
        )
    }

    fn new(caches: gather_caches::Caches, offset: f32) -> Self {
        let mut creation = Vec::with_capacity(2 * caches.pos.len());
        for (p, n) in caches.pos.iter().zip(&caches.normal) {
            creation.push([
                p[0] + n[0] * offset,
                p[1] + n[1] * offset,
                p[2] + n[2] * offset,
                0.0,
            ]);
            creation.push(*n);
        }
        Self { caches, creation }
    }
}

/// Key bits the sort needs: every real key is below tiles * 3 * slices, and the background key
/// (all ones) must stay above them in the low bits.
fn key_bits(tiles: u32, slices: u32) -> u32 {
    let m = tiles as u64 * 3 * slices as u64;
    (64 - m.leading_zeros()).clamp(1, 32)
}

/// What cluster_extract and cache_placement read: the pixels and their key-sorted order.
fn sorted_inputs(
    px: &PixelInputs,
    s: &CprcSettings,
    sorted_keys: Vec<u32>,
    sorted_pixels: Vec<u32>,
) -> cluster_extract::DistributionInputs {
    cluster_extract::DistributionInputs {
        width: px.width,
        height: px.height,
        tile: s.tile,
        normals: px.normals.clone(),
        positions: px
            .positions
            .iter()
            .map(|p| [p[0], p[1], p[2], 1.0])
            .collect(),
        sorted_keys,
        sorted_pixels,
    }
}

/// A chain's stages: each kernel's declaration and passes, in order.
pub(crate) type Stages = Vec<(
    &'static vxgi_harness::KernelDecl,
    Vec<vxgi_harness::run::Pass>,
)>;

/// The shaders of `stages`' kernels, in order.
fn shaders_of(stages: &Stages) -> Result<Vec<vxgi_harness::Shader>> {
    stages.iter().map(|(d, _)| Ok(d.shader()?)).collect()
}

/// The distribution's six kernels (histograms, axes, keys, radix sort, clusters, placement) as chain
/// stages over one set of resources, each kernel reading what the previous wrote: the resources
/// (`normals`, `depth` and `positions` hold `px`'s; the distribution reads positions' xyz only) and
/// the stages. The resources shared by name are renamed where two kernels use one name for different
/// things (`params`, `scan_partials`); the sorted pixels are bound as cache_placement's `pixels`.
pub(crate) fn distribution_stages(
    ctx: &GpuContext,
    px: &PixelInputs,
    s: &CprcSettings,
) -> Result<(Resources, Stages)> {
    use vxgi_harness::run::{grid_for, Pass, Workgroups};
    use vxgi_harness::ScalarKind;
    let (w, h) = (px.width, px.height);
    let n = (w * h) as usize;
    let hp = tile_normal_histogram::params(w, h, s.tile)?;
    let tiles = (hp.tiles_x * h.div_ceil(s.tile)) as usize;
    let shaders = [histogram_axes::DECL.shader()?, cluster_keys::DECL.shader()?];
    let mut hist = tile_normal_histogram::case_for(&px.normals, hp, "cprc".into(), 0)?;
    hist.rename_resource("params", "hist_params", false);
    let empty = vec![0u32; tiles * 64];
    let mut axes = histogram_axes::axes_case(&shaders[0], ctx, &empty, &empty, "cprc".into(), 0);
    axes.rename_resource("params", "axes_params", false);
    for r in ["histogram", "blurred"] {
        axes.resources.remove(r);
    }
    // The axes come from the axes kernel: a placeholder the chain drops.
    let mut keys = cluster_keys::case_with_axes(
        &shaders[1],
        ctx,
        &px.normals,
        &px.depth,
        w,
        h,
        s.tile,
        s.slices,
        px.depth_unit,
        &vec![[0; 4]; tiles],
        "cprc".into(),
        0,
    );
    keys.rename_resource("params", "key_params", false);
    keys.rename_resource("tile_axes", "axes", true);
    let values: Vec<u32> = (0..n as u32).collect();
    let (mut sort, [kname, vname]) = radix_sort::case_for(
        ctx,
        &vec![0; n],
        &values,
        key_bits(tiles as u32, s.slices),
        "cprc".into(),
        0,
    )?;
    // The sort starts from the keys kernel's output (and ping-pongs through it).
    sort.rename_resource("keys_a", "keys", true);
    sort.rename_resource("scan_partials", "sort_scan_partials", false);
    let kname = if kname == "keys_a" {
        "keys".to_string()
    } else {
        kname
    };
    let inp = sorted_inputs(px, s, vec![0; n], vec![0; n]);
    let mut extract = cluster_extract::case_for(ctx, &inp, "cprc".into(), 0);
    extract.rename_resource("params", "extract_params", false);
    extract.rename_resource("scan_partials", "extract_scan_partials", false);
    extract.rename_resource("keys", &kname, true);
    extract.rename_resource("pixels", &vname, true);
    // Placement: one invocation per pixel for the scores, and per pixel for the picks (no more
    // clusters than pixels; pick_caches stops at the GPU's cluster count).
    let mut resources = hist.resources;
    resources.extend(axes.resources);
    resources.extend(keys.resources);
    resources.extend(sort.resources);
    resources.extend(extract.resources);
    resources.insert(
        "scores".into(),
        HostResource::Buffer(HostBuffer::zeroed(n * 4, ScalarKind::F32)),
    );
    resources.insert(
        "picks".into(),
        HostResource::Buffer(HostBuffer::zeroed(n * 4, ScalarKind::U32)),
    );
    let mut place_bindings = cache_placement::DECL.bind_by_name();
    for (binding, view) in &mut place_bindings {
        if binding == "pixels" {
            *view = vxgi_harness::View::Buffer(vname.clone());
        }
    }
    let grid = grid_for(
        n as u64,
        64,
        ctx.limits().max_compute_workgroups_per_dimension,
    );
    let place: Vec<Pass> = ["score_pixels", "pick_caches"]
        .iter()
        .map(|e| Pass {
            label: e.to_string(),
            entry: e.to_string(),
            bindings: place_bindings.clone(),
            workgroups: Workgroups::Direct(grid),
        })
        .collect();
    let stages = vec![
        (&tile_normal_histogram::DECL, hist.passes),
        (&histogram_axes::DECL, axes.passes),
        (&cluster_keys::DECL, keys.passes),
        (&radix_sort::DECL, sort.passes),
        (&cluster_extract::DECL, extract.passes),
        (&cache_placement::DECL, place),
    ];
    Ok((resources, stages))
}

/// Cache distribution on the GPU (`distribution_stages` as one chain on one set of GPU resources):
/// nothing goes through the host until the clusters and picks are read back.
pub fn distribute_gpu(
    ctx: &GpuContext,
    px: &PixelInputs,
    s: &CprcSettings,
    offset: f32,
) -> Result<CacheSet> {
    let (w, h) = (px.width, px.height);
    let (resources, stages) = distribution_stages(ctx, px, s)?;
    let shaders = shaders_of(&stages)?;
    let chain: Vec<vxgi_harness::Stage> = stages
        .iter()
        .zip(&shaders)
        .map(|((d, passes), shader)| vxgi_harness::Stage {
            shader,
            kernel: d.name,
            passes,
        })
        .collect();
    let prepared =
        vxgi_harness::prepare_chain(ctx, &chain, &resources).context("cache distribution")?;
    prepared.dispatch().context("cache distribution")?;
    let out = prepared
        .read(&["cluster_count", "clusters", "picks"])
        .context("cache distribution")?;
    let b = |name: &str| &out[name].buffer().expect("buffer").bytes;
    let count = bytemuck::cast_slice::<u8, u32>(b("cluster_count"))[0] as usize;
    let clusters = &bytemuck::cast_slice::<u8, Cluster>(b("clusters"))[..count];
    let picks = &bytemuck::cast_slice::<u8, u32>(b("picks"))[..count];
    let caches =
        gather_caches::caches_at(w, h, s.tile, &px.normals, &px.positions, clusters, picks);
    Ok(CacheSet::new(caches, offset))
}

/// The same distribution by the mirrors (the mirror pipeline's).
pub fn distribute_mirror(px: &PixelInputs, s: &CprcSettings, offset: f32) -> Result<CacheSet> {
    use vxgi_cpu_mirror::{
        cluster_keys as ck, histogram_axes, octahedral, radix_sort as rs,
        tile_normal_histogram as th,
    };
    let (w, h) = (px.width, px.height);
    let hp = tile_normal_histogram::params(w, h, s.tile)?;
    let (raw, blurred) = th::histograms(&px.normals, &hp);
    let axes = histogram_axes::all_axes(&blurred, &raw, &octahedral::reweight_table());
    let u = px.depth_unit;
    let mut bounds = ck::slice_bounds(
        cluster_keys::SLICE_NEAR * u,
        cluster_keys::SLICE_FAR * u,
        s.slices,
    );
    bounds.push(f32::INFINITY);
    let p = ck::KeyParams {
        width: w,
        height: h,
        tile: s.tile,
        tiles_x: hp.tiles_x,
        slices: s.slices,
        _pad: [0; 3],
    };
    let dirs = ck::axis_directions();
    let keys = ck::keys(
        &p,
        &ck::KeyInputs {
            normals: &px.normals,
            depth: &px.depth,
            tile_axes: &axes,
            axis_dirs: &dirs,
            slice_bounds: &bounds,
        },
    );
    let tiles = hp.tiles_x * h.div_ceil(s.tile);
    let values: Vec<u32> = (0..keys.len() as u32).collect();
    let (sorted_keys, sorted_pixels) = rs::sort(&keys, &values, key_bits(tiles, s.slices));
    let inp = sorted_inputs(px, s, sorted_keys, sorted_pixels);
    Ok(CacheSet::new(gather_caches::place_caches(&inp), offset))
}

/// The gather's inputs from a frame's pixels, its caches and their pre-convolved maps.
pub fn gather_data(
    px: &PixelInputs,
    set: &CacheSet,
    s: &CprcSettings,
    irradiance: Vec<[f32; 4]>,
    mips: Vec<[f32; 4]>,
) -> gather_caches::GatherData {
    let c = &set.caches;
    gather_caches::GatherData {
        params: GatherParams {
            width: px.width,
            height: px.height,
            tile: s.tile,
            tiles_x: px.width.div_ceil(s.tile),
            tiles_y: px.height.div_ceil(s.tile),
            radius_px: s.radius_px,
            res: s.res,
            levels: s.res.trailing_zeros() + 1,
            irr: s.irr,
            angle: u32::from(s.angle),
            _pad: [0; 2],
        },
        positions: px.positions.clone(),
        pixel_dirs: px.pixel_dirs.clone(),
        cache_pos: c.pos.clone(),
        cache_pixel: c.pixel.clone(),
        cache_normal: c.normal.clone(),
        cache_irradiance: irradiance,
        cache_mips: mips,
        tile_ranges: c.tile_ranges.clone(),
    }
}

/// What a cprc frame reports beyond its images.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CprcStats {
    pub caches: usize,
    /// Clusters past the frame's cache capacity, left without a cache (the resident renderer's
    /// buffers hold [`crate::pipeline`]' capacity).
    pub dropped: usize,
    /// Caches kept from the last frame (`cache_reuse`), in place of ones placed anew.
    pub kept: usize,
    /// Whether the kept caches carried their texels rather than being traced again
    /// (`cache_carry`, in a frame whose volume is the last frame's).
    pub carried: bool,
    /// Front-facing geometry pixels, and those left without a valid cache ([`coverage`]: the paper's
    /// Fig. 6 measure); `None` where not measured (resident frames: the caches stay on the GPU).
    pub coverage: Option<(usize, usize)>,
}

/// Indirect (albedo / pi * E + Ks * G) and AO (1 on geometry) images from the gather's outputs;
/// the stats count the pixels without a valid cache by [`coverage`].
pub fn compose(
    px: &PixelInputs,
    gathered: &(Vec<[f32; 4]>, Vec<[f32; 4]>, gather_caches::GatherData),
) -> (RgbImage, RgbImage, CprcStats) {
    let (diffuse, glossy, data) = gathered;
    let (pixels, uncovered) = coverage(data);
    let stats = CprcStats {
        caches: data.cache_pos.len(),
        dropped: 0,
        kept: 0,
        carried: false,
        coverage: Some((pixels, uncovered)),
    };
    let mut ind = Vec::with_capacity(diffuse.len());
    let mut ao = Vec::with_capacity(diffuse.len());
    for i in 0..diffuse.len() {
        let geometry = [0.0, 0.0, 0.0, px.geometry[i] as u8 as f32];
        let (c, a) = vxgi_cpu_mirror::cprc_pixels::compose(
            px.positions[i],
            geometry,
            px.albedo[i],
            px.specular[i],
            diffuse[i],
            glossy[i],
        );
        ind.push([c[0], c[1], c[2]]);
        ao.push([a[0], a[1], a[2]]);
    }
    let (w, h) = (px.width, px.height);
    (RgbImage::new(w, h, ind), RgbImage::new(w, h, ao), stats)
}

/// Creation, pre-convolution and the gather as chain stages over one set of resources for the
/// caches of `set` (`capacity` slots at least: a chain whose caches the GPU writes sizes them for
/// the most it may hold): creation's (its `caches` are the creation records), pre-convolution's
/// (its `cache_radiance` is creation's, its uniform block `pre_params`), the gather's (its maps are
/// pre-convolution's, its uniform block `gather_params`). Without `glossy` pixels the `mips` pass is
/// left out (and its buffer is a placeholder); without caches (and no capacity) only the gather runs.
#[allow(clippy::too_many_arguments)]
pub(crate) fn cache_stages(
    ctx: &GpuContext,
    px: &PixelInputs,
    set: &CacheSet,
    capacity: usize,
    s: &CprcSettings,
    volume: CacheVolume,
    cone: &vxgi_cpu_mirror::cone_trace::ConeParams,
    glossy: bool,
) -> Result<(Resources, Stages)> {
    use vxgi_harness::View;
    let count = set.caches.pos.len().max(capacity);
    let mut slots = CacheSet::empty();
    let sized = if count > set.caches.pos.len() {
        // Zeroed records for every slot: the chain's records kernel fills them.
        let tiles = (px.width.div_ceil(s.tile) * px.height.div_ceil(s.tile)) as usize;
        slots.caches.pos = vec![[0.0; 4]; count];
        slots.caches.pixel = vec![[0; 2]; count];
        slots.caches.normal = vec![[0.0; 4]; count];
        slots.caches.tile_ranges = vec![[0; 2]; tiles];
        slots.creation = vec![[0.0; 4]; 2 * count];
        &slots
    } else {
        set
    };
    let data = gather_data(px, sized, s, Vec::new(), Vec::new());
    let cdecl = match volume {
        CacheVolume::One(_) => &cache_creation::DECL,
        CacheVolume::Placed(..) => &cache_creation::INSTANCED_DECL,
    };
    let gshader = gather_caches::DECL.shader()?;
    let mut gcase = gather_caches::case_for(&gshader, ctx, &data, "cprc".into(), 0);
    let ccase = match volume {
        CacheVolume::One(pyramids) => cache_creation::case_for(
            ctx,
            pyramids,
            cone,
            &sized.creation,
            s.res,
            "cprc".into(),
            0,
        ),
        CacheVolume::Placed(pyramids, placed) => cache_creation::instanced_case_for(
            ctx,
            pyramids,
            placed,
            cone,
            &sized.creation,
            s.res,
            "cprc".into(),
            0,
        ),
    };
    let mut pcase =
        cache_preconvolve::case_for_count(ctx, count, None, s.res, s.irr, "cprc".into(), 0);
    pcase.rename_resource("params", "pre_params", false);
    if !glossy {
        // No pixel reads a mip chain: the plan skips the `mips` pass (and its buffer).
        pcase.passes.retain(|p| p.entry != "mips");
        pcase.resources.insert(
            "cache_mips".into(),
            HostResource::Buffer(HostBuffer::zeroed(16, vxgi_harness::ScalarKind::F32)),
        );
    }
    if count == 0 {
        // Nothing to create: the gather alone (it reads no map without caches).
        pcase.passes.clear();
    }
    let mut resources = ccase.resources;
    for (k, v) in pcase.resources {
        if k != "cache_radiance" || count == 0 {
            resources.insert(k, v);
        }
    }
    for k in ["cache_irradiance", "cache_mips"] {
        gcase.resources.remove(k);
    }
    let gparams = gcase
        .resources
        .remove("params")
        .expect("the gather's params");
    resources.insert("gather_params".into(), gparams);
    resources.extend(gcase.resources);
    for pass in &mut gcase.passes {
        for (name, view) in &mut pass.bindings {
            if name == "params" {
                *view = View::Buffer("gather_params".into());
            }
        }
    }
    let creation_passes = if count == 0 { Vec::new() } else { ccase.passes };
    Ok((
        resources,
        vec![
            (cdecl, creation_passes),
            (&cache_preconvolve::DECL, pcase.passes),
            (&gather_caches::DECL, gcase.passes),
        ],
    ))
}

/// Run creation, pre-convolution and the gather on the GPU for a frame's caches as one chain on one set
/// of GPU buffers (`cache_stages`): the caches' texels, mips and irradiance maps never leave the
/// GPU; each stage is its own submission, timed alone (wall clock) and pushed to `stages`. Returns
/// the gather's (diffuse, glossy) and what it read (its maps left empty: they stayed on the GPU).
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub fn evaluate_gpu(
    ctx: &GpuContext,
    px: &PixelInputs,
    set: &CacheSet,
    s: &CprcSettings,
    volume: CacheVolume,
    cone: &vxgi_cpu_mirror::cone_trace::ConeParams,
    stages: &mut Vec<(&'static str, f64)>,
    progress: &impl Fn(&str),
) -> Result<(Vec<[f32; 4]>, Vec<[f32; 4]>, gather_caches::GatherData)> {
    use vxgi_harness::{prepare_chain, Stage};
    let data = gather_data(px, set, s, Vec::new(), Vec::new());
    let (resources, parts) = cache_stages(ctx, px, set, 0, s, volume, cone, any_glossy(px))?;
    let shaders = shaders_of(&parts)?;
    let chain: Vec<Stage> = parts
        .iter()
        .zip(&shaders)
        .map(|((d, passes), shader)| Stage {
            shader,
            kernel: d.name,
            passes,
        })
        .collect();
    // Wall clock per stage, transfers included: the upload counts to the first stage that runs, the
    // readback to the gather.
    progress("cache creation");
    let mut t = std::time::Instant::now();
    let prepared = prepare_chain(ctx, &chain, &resources).context("cache stages")?;
    let mut first = 0;
    for (stage, what, st) in [
        ("cache_creation", "cache creation", &chain[0]),
        ("cache_preconvolve", "pre-convolution", &chain[1]),
        ("gather_caches", "gathering", &chain[2]),
    ] {
        let n = st.passes.len();
        if n == 0 {
            continue;
        }
        progress(what);
        prepared
            .dispatch_steps(first..first + n)
            .with_context(|| what.to_string())?;
        first += n;
        if stage == "gather_caches" {
            let out = prepared.read(&["diffuse", "glossy"]).context("gathering")?;
            stages.push((stage, t.elapsed().as_secs_f64()));
            let f4 = |name: &str| -> Vec<[f32; 4]> {
                bytemuck::cast_slice(&out[name].buffer().expect("buffer").bytes).to_vec()
            };
            return Ok((f4("diffuse"), f4("glossy"), data));
        }
        stages.push((stage, t.elapsed().as_secs_f64()));
        t = std::time::Instant::now();
    }
    unreachable!("the gather always runs")
}

/// Creation, pre-convolution and the gather by the mirrors.
#[allow(clippy::type_complexity)]
pub fn evaluate_mirror(
    px: &PixelInputs,
    set: &CacheSet,
    s: &CprcSettings,
    pyramids: &crate::kernels::cone_trace::Pyramids,
    cone: &vxgi_cpu_mirror::cone_trace::ConeParams,
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>, gather_caches::GatherData) {
    use rayon::prelude::*;
    use vxgi_cpu_mirror::{cache_creation as cc, cache_preconvolve as cp, gather_caches as gm};
    // Both rules: OrderedPyramid is the plain trilinear where cone.depth_order is 0.
    let pyr = vxgi_cpu_mirror::cone_trace::OrderedPyramid {
        p: cone,
        voxels: &pyramids.colour,
        normals: &pyramids.normal,
    };
    let lmax = crate::kernels::cone_trace::max_radiance(&pyramids.colour, cone.side);
    let dirs = cc::texel_directions(s.res);
    let tan = cc::cone_tan(s.res);
    let t = (s.res * s.res) as usize;
    let count = set.caches.pos.len();
    let radiance: Vec<[f32; 4]> = (0..count * t)
        .into_par_iter()
        .map(|i| {
            let c = i / t;
            cc::create_texel(
                &pyr,
                [set.creation[2 * c], set.creation[2 * c + 1]],
                dirs[i % t],
                tan,
                lmax,
            )
            .0
        })
        .collect();
    let weights = cp::irradiance_weights(s.res, s.irr);
    let (mut mips, mut irr) = (Vec::new(), Vec::new());
    let glossy = any_glossy(px);
    for c in 0..count {
        let tex = &radiance[c * t..(c + 1) * t];
        if glossy {
            mips.extend((0..cp::mip_len(s.res)).map(|j| cp::mip_texel(tex, s.res, j, false)));
        }
        irr.extend((0..(s.irr * s.irr) as usize).map(|k| cp::irradiance_texel(tex, &weights, k).0));
    }
    let data = gather_data(px, set, s, irr, mips);
    let inp = gm::GatherInputs {
        positions: &data.positions,
        pixel_dirs: &data.pixel_dirs,
        cache_pos: &data.cache_pos,
        cache_pixel: &data.cache_pixel,
        cache_normal: &data.cache_normal,
        cache_irradiance: &data.cache_irradiance,
        cache_mips: &data.cache_mips,
        tile_ranges: &data.tile_ranges,
    };
    let vmax = [
        gm::payload_max(inp.cache_irradiance),
        gm::payload_max(inp.cache_mips),
    ];
    let r: Vec<gm::Gathered> = (0..data.positions.len())
        .into_par_iter()
        .map(|i| gm::gather(&data.params, &inp, i, vmax))
        .collect();
    (
        r.iter().map(|g| g.diffuse).collect(),
        r.iter().map(|g| g.glossy).collect(),
        data,
    )
}

/// The G-buffer of a GPU frame as host arrays: positions, normals, triangles, albedos.
#[allow(clippy::type_complexity)]
pub fn gbuffer_arrays(gb: &Resources) -> (Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<u32>, Vec<[f32; 4]>) {
    let b = |n: &str| gb[n].buffer().expect("G-buffer buffer");
    (
        bytemuck::cast_slice(&b("gb_position").bytes).to_vec(),
        bytemuck::cast_slice(&b("gb_normal").bytes).to_vec(),
        b("gb_triangle").as_u32().to_vec(),
        bytemuck::cast_slice(&b("gb_albedo").bytes).to_vec(),
    )
}

/// Pixels that gather (front-facing geometry) and those among them without a valid cache: none of the
/// caches the gather visits has weight min(w_w, w_s) > 0 *and* faces the pixel's hemisphere
/// (n_p . n_c > 0: a cache holds only its upper hemisphere), so the gather's weights (with their
/// angle term) sum to 0 there — the paper's Fig. 6 measure.
pub fn coverage(d: &gather_caches::GatherData) -> (usize, usize) {
    use rayon::prelude::*;
    let p = &d.params;
    let reach = p.radius_px.div_ceil(p.tile) as i32;
    let r2 = (p.radius_px * p.radius_px) as i32;
    let valid: Vec<Option<bool>> = (0..d.positions.len())
        .into_par_iter()
        .map(|i| {
            let pos = d.positions[i];
            if pos[3] != 1.0 {
                return None;
            }
            let n = d.pixel_dirs[2 * i];
            let (x, y) = ((i as u32 % p.width) as i32, (i as u32 / p.width) as i32);
            let (tx, ty) = (x / p.tile as i32, y / p.tile as i32);
            for ny in (ty - reach).max(0)..=(ty + reach).min(p.tiles_y as i32 - 1) {
                for nx in (tx - reach).max(0)..=(tx + reach).min(p.tiles_x as i32 - 1) {
                    let t = (ny as u32 * p.tiles_x + nx as u32) as usize;
                    // A tile without a range (no caches at all) holds none.
                    let [a, b] = d.tile_ranges.get(t).copied().unwrap_or([0, 0]);
                    for c in a as usize..b as usize {
                        let [cx, cy] = d.cache_pixel[c];
                        let ds2 = (cx as i32 - x).pow(2) + (cy as i32 - y).pow(2);
                        if ds2 >= r2 {
                            continue;
                        }
                        let cp = d.cache_pos[c];
                        let dw2: f32 = (0..3).map(|k| (pos[k] - cp[k]).powi(2)).sum();
                        let w = (1.0 - dw2 / (cp[3] * cp[3])).min(1.0 - ds2 as f32 / r2 as f32);
                        let cn = d.cache_normal[c];
                        if w > 0.0 && n[0] * cn[0] + n[1] * cn[1] + n[2] * cn[2] > 0.0 {
                            return Some(true);
                        }
                    }
                }
            }
            Some(false)
        })
        .collect();
    let pixels = valid.iter().filter(|v| v.is_some()).count();
    let uncovered = valid.iter().filter(|v| **v == Some(false)).count();
    (pixels, uncovered)
}

/// The equidistant distribution Fig. 6 compares against: about as many caches as `like` holds, on a
/// square grid of pixels (one per cell centre that sees front-facing geometry), with the pixel's normal
/// and the mean world radius of `like`'s caches (so both spend the same reach); stored tile by tile.
pub fn distribute_equidistant(
    px: &PixelInputs,
    like: &CacheSet,
    s: &CprcSettings,
    offset: f32,
) -> CacheSet {
    let (w, h) = (px.width, px.height);
    let n = like.caches.pos.len().max(1);
    let r_w = like.caches.pos.iter().map(|p| p[3] as f64).sum::<f64>() as f32 / n as f32;
    let step = ((w * h) as f64 / n as f64).sqrt().max(1.0);
    let mut picks = Vec::new();
    let mut gy = step / 2.0;
    while gy < h as f64 {
        let mut gx = step / 2.0;
        while gx < w as f64 {
            let i = gy as u32 * w + gx as u32;
            if px.positions[i as usize][3] == 1.0 {
                picks.push(i);
            }
            gx += step;
        }
        gy += step;
    }
    let tiles_x = w.div_ceil(s.tile);
    picks.sort_by_key(|&i| ((i / w) / s.tile * tiles_x + (i % w) / s.tile, i));
    let mut c = gather_caches::Caches {
        pos: Vec::new(),
        pixel: Vec::new(),
        normal: Vec::new(),
        tile_ranges: vec![[0, 0]; (tiles_x * h.div_ceil(s.tile)) as usize],
    };
    for (k, &i) in picks.iter().enumerate() {
        let p = px.positions[i as usize];
        let nv = px.pixel_dirs[2 * i as usize];
        c.pos.push([p[0], p[1], p[2], r_w]);
        c.pixel.push([i % w, i / w]);
        c.normal.push([nv[0], nv[1], nv[2], 0.0]);
        let t = ((i / w) / s.tile * tiles_x + (i % w) / s.tile) as usize;
        if c.tile_ranges[t][1] == 0 {
            c.tile_ranges[t][0] = k as u32;
        }
        c.tile_ranges[t][1] = k as u32 + 1;
    }
    CacheSet::new(c, offset)
}
