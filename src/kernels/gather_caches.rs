//! Declaration of `kernels/gather_caches.wgsl` (mirror: `vxgi_cpu_mirror::gather_caches`): CPRC 3.3
//! evaluation by gathering. Cases place caches with the distribution mirrors (histograms, axes, keys,
//! sort, clusters, placement) on generated G-buffers and fill their maps with generated radiance.
use super::cluster_extract::DistributionInputs;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::cache_placement::{best_pixels, score};
use vxgi_cpu_mirror::cache_preconvolve::mip_len;
use vxgi_cpu_mirror::cluster_extract::extract;
use vxgi_cpu_mirror::gather_caches::{
    gather, gather_bound, payload_max, GatherInputs, GatherParams,
};
use vxgi_cpu_mirror::octahedral::unpack;
use vxgi_harness::prelude::*;

vxgi_harness::bindings! {
    /// gather_caches' bindings: the pixels' positions and directions and the caches' records and
    /// maps in; per pixel the gathered diffuse and glossy light, the weights' sum and the in-radius
    /// test out.
    pub struct Io {
        inputs: {
            params: Block<GatherParams>,
            positions: Vec<[f32; 4]>,
            pixel_dirs: Vec<[f32; 4]>,
            cache_pos: Vec<[f32; 4]>,
            cache_pixel: Vec<[u32; 2]>,
            cache_normal: Vec<[f32; 4]>,
            cache_irradiance: Vec<[f32; 4]>,
            cache_mips: Vec<[f32; 4]>,
            tile_ranges: Vec<[u32; 2]>,
        }
        outputs: {
            // Per element from the WGSL rules along the weight sums and the lookups (see
            // `gather_bound`).
            diffuse: Vec<[f32; 4]> => Tolerance::MirrorBound,
            glossy: Vec<[f32; 4]> => Tolerance::MirrorBound,
            weight_sum: Vec<f32> => Tolerance::MirrorBound,
            // Integer pixel-distance test: exact.
            in_radius: Vec<u32> => Tolerance::Exact,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "gather_caches",
    includes: &[super::TANGENT_BASIS],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "weight_sum" },
    mirror: "vxgi_cpu_mirror::gather_caches::gather",
    summary: "per pixel, caches within the screen radius evaluated (irradiance by normal, mips by reflection) and weighted min(w_w, w_s) (CPRC 3.3)",
);

/// Caches placed on a G-buffer by the distribution mirrors: positions, pixels, normals (payload), and the
/// per-tile ranges.
pub struct Caches {
    pub pos: Vec<[f32; 4]>,
    pub pixel: Vec<[u32; 2]>,
    pub normal: Vec<[f32; 4]>,
    pub tile_ranges: Vec<[u32; 2]>,
}

/// The clusters of `inp`'s sorted pixels and each one's picked pixel, by the mirrors of
/// cluster_extract and cache_placement.
pub fn clusters_and_picks(
    inp: &DistributionInputs,
) -> (Vec<vxgi_cpu_mirror::cluster_extract::Cluster>, Vec<u32>) {
    let (clusters, pixel_cluster) = extract(
        &inp.sorted_keys,
        &inp.sorted_pixels,
        &inp.normals,
        &inp.positions,
    );
    let scores: Vec<f32> = (0..inp.normals.len())
        .map(|p| match pixel_cluster[p] {
            u32::MAX => 0.0,
            c => score(inp.normals[p], inp.positions[p], &clusters[c as usize]),
        })
        .collect();
    let best = best_pixels(&clusters, &inp.sorted_pixels, &scores);
    (clusters, best)
}

pub fn place_caches(inp: &DistributionInputs) -> Caches {
    let (clusters, best) = clusters_and_picks(inp);
    caches_at(
        inp.width,
        inp.height,
        inp.tile,
        &inp.normals,
        &inp.positions,
        &clusters,
        &best,
    )
}

/// One cache per cluster at its picked pixel (`picks[c]`, from cache_placement): position, pixel,
/// normal and world radius r_w by `kernels/cache_records.wgsl`'s rule (its mirror); caches are in
/// cluster order, which is tile-major (keys start with the tile), so each tile's caches form one
/// range.
pub fn caches_at(
    width: u32,
    height: u32,
    tile: u32,
    normals: &[[u32; 2]],
    positions: &[[f32; 4]],
    clusters: &[vxgi_cpu_mirror::cluster_extract::Cluster],
    picks: &[u32],
) -> Caches {
    use vxgi_cpu_mirror::cache_records::{records, RecordsParams};
    let tiles_x = width.div_ceil(tile);
    let tiles = (tiles_x * height.div_ceil(tile)) as usize;
    let p = RecordsParams {
        width,
        tile,
        tiles_x,
        capacity: picks.len() as u32,
        ..Default::default()
    };
    let r = records(
        &p,
        clusters,
        picks.len() as u32,
        picks,
        normals,
        positions,
        &vec![[0; 2]; tiles],
    );
    Caches {
        pos: r.cache_pos,
        pixel: r.cache_pixel,
        normal: r.cache_normal,
        tile_ranges: r.tile_ranges,
    }
}

/// Pixel positions with w = 1 on geometry, 0 on background.
pub fn geometry_positions(inp: &DistributionInputs) -> Vec<[f32; 4]> {
    inp.positions
        .iter()
        .zip(&inp.normals)
        .map(|(p, n)| [p[0], p[1], p[2], if n[1] >> 16 == 1 { 1.0 } else { 0.0 }])
        .collect()
}

/// Everything the gather reads (owned), by binding.
pub struct GatherData {
    pub params: GatherParams,
    pub positions: Vec<[f32; 4]>,
    pub pixel_dirs: Vec<[f32; 4]>,
    pub cache_pos: Vec<[f32; 4]>,
    pub cache_pixel: Vec<[u32; 2]>,
    pub cache_normal: Vec<[f32; 4]>,
    pub cache_irradiance: Vec<[f32; 4]>,
    pub cache_mips: Vec<[f32; 4]>,
    pub tile_ranges: Vec<[u32; 2]>,
}

/// A generated gather over caches placed on a generated G-buffer: maps of generated radiance (cache
/// side `res`, irradiance side `irr`), pixel normals from the G-buffer, reflection vectors of the
/// view from the origin, glossy levels varied per pixel (none, whole levels, fractions, past the top).
pub fn generated_data(inp: &DistributionInputs, res: u32, irr: u32, seed: u64) -> GatherData {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let caches = place_caches(inp);
    let count = caches.pos.len();
    let levels = res.trailing_zeros() + 1;
    let params = GatherParams {
        width: inp.width,
        height: inp.height,
        tile: inp.tile,
        tiles_x: inp.width.div_ceil(inp.tile),
        tiles_y: inp.height.div_ceil(inp.tile),
        radius_px: 2 * inp.tile,
        res,
        levels,
        irr,
        angle: 1,
        _pad: [0; 2],
    };
    let mut pixel_dirs = Vec::with_capacity(2 * inp.normals.len());
    for (n, p) in inp.normals.iter().zip(&inp.positions) {
        let q = unpack(*n).unwrap_or([0, 0, 32767]);
        let v = glam::Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32).normalize_or(glam::Vec3::Z);
        let e = -glam::Vec3::new(p[0], p[1], p[2]).normalize_or(glam::Vec3::Z);
        let r = v * (2.0 * v.dot(e)) - e;
        let lf = match rng.random_range(0..5) {
            0 => -1.0,
            1 => rng.random_range(0..=levels) as f32,
            2 => levels as f32 + 0.5,
            _ => rng.random::<f32>() * levels as f32,
        };
        pixel_dirs.push([v.x, v.y, v.z, 0.0]);
        pixel_dirs.push([r.x, r.y, r.z, lf]);
    }
    let mut map = |n: usize| -> Vec<[f32; 4]> {
        (0..n)
            .map(|_| {
                [
                    rng.random::<f32>() * 4.0,
                    rng.random::<f32>(),
                    rng.random::<f32>() * 0.25,
                    0.0,
                ]
            })
            .collect()
    };
    let cache_irradiance = map(count * (irr * irr) as usize);
    let cache_mips = map(count * mip_len(res));
    GatherData {
        params,
        positions: geometry_positions(inp),
        pixel_dirs,
        cache_pos: caches.pos,
        cache_pixel: caches.pixel,
        cache_normal: caches.normal,
        cache_irradiance,
        cache_mips,
        tile_ranges: caches.tile_ranges,
    }
}

pub fn case_for(
    shader: &Shader,
    ctx: &GpuContext,
    d: &GatherData,
    label: String,
    seed: u64,
) -> Case {
    let n = (d.params.width * d.params.height) as usize;
    let io = Io {
        params: Block(d.params),
        positions: super::or_one(&d.positions),
        pixel_dirs: super::or_one(&d.pixel_dirs),
        cache_pos: super::or_one(&d.cache_pos),
        cache_pixel: super::or_one(&d.cache_pixel),
        cache_normal: super::or_one(&d.cache_normal),
        cache_irradiance: super::or_one(&d.cache_irradiance),
        cache_mips: super::or_one(&d.cache_mips),
        tile_ranges: super::or_one(&d.tile_ranges),
        diffuse: vec![[0.0; 4]; n],
        glossy: vec![[0.0; 4]; n],
        weight_sum: vec![0.0; n],
        in_radius: vec![0; n],
    };
    let pass = DECL.pass(shader, ctx, "gather".into(), DECL.bind_by_name(), n as u64);
    io.case(label, seed, vec![pass])
        .with_linear_indexing()
        .with_effective_bytes(n as u64 * 72)
}

pub struct GatherCaches;

/// (cache side, irradiance side) of the generated cases.
const SIZES: [(u32, u32); 3] = [(8, 4), (16, 8), (1, 1)];

impl Kernel for GatherCaches {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (inp, label) = super::cluster_extract::generated_distribution(seed, index);
        let (res, irr) = SIZES[index % SIZES.len()];
        let mut d = generated_data(&inp, res, irr, seed ^ index as u64);
        // One case in four gathers without the angle term (`gather_angle = false`).
        d.params.angle = u32::from(index % 4 != 1);
        let angle = if d.params.angle == 0 {
            ", no angle term"
        } else {
            ""
        };
        case_for(
            shader,
            ctx,
            &d,
            format!("{label}, caches {res}^2 / {irr}^2{angle}"),
            seed,
        )
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        mirror_outputs(data)
    }
}

/// The mirror's outputs and bounds for a gather's resources.
pub fn mirror_outputs(data: &Resources) -> BTreeMap<String, HostBuffer> {
    use rayon::prelude::*;
    let mut io = Io::read(data);
    let p = io.params.0;
    let inp = GatherInputs {
        positions: &io.positions,
        pixel_dirs: &io.pixel_dirs,
        cache_pos: &io.cache_pos,
        cache_pixel: &io.cache_pixel,
        cache_normal: &io.cache_normal,
        cache_irradiance: &io.cache_irradiance,
        cache_mips: &io.cache_mips,
        tile_ranges: &io.tile_ranges,
    };
    let n = (p.width * p.height) as usize;
    let vmax = [
        payload_max(inp.cache_irradiance),
        payload_max(inp.cache_mips),
    ];
    let px: Vec<_> = (0..n)
        .into_par_iter()
        .map(|i| {
            let r = gather(&p, &inp, i, vmax);
            (r, gather_bound(&r, vmax))
        })
        .collect();
    io.diffuse = px.iter().map(|p| p.0.diffuse).collect();
    io.glossy = px.iter().map(|p| p.0.glossy).collect();
    io.weight_sum = px.iter().map(|p| p.0.weight_sum).collect();
    io.in_radius = px.iter().map(|p| p.0.in_radius).collect();
    let f4 = |g: fn(&_) -> [f32; 4]| px.iter().map(g).collect::<Vec<_>>();
    let mut out = io.outputs();
    out.extend([
        bound("diffuse", &f4(|p| p.1 .0)),
        bound("glossy", &f4(|p| p.1 .1)),
    ]);
    let weights: Vec<f32> = px.iter().map(|p| p.1 .2).collect();
    out.extend([bound("weight_sum", &weights)]);
    out
}
