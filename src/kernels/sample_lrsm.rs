//! Declaration of `kernels/sample_lrsm.wgsl` (mirror: `vxgi_cpu_mirror::sample_lrsm`): Algorithm 1 on an
//! LRSM built from a synthetic RSM by the partition and pre-filter mirrors, for batches of cone samples
//! including the hard ones (depths on layer bounds, normals perpendicular to the view direction, mip
//! levels below 0, on integers and past the chain (up to +-1e30), coordinates outside [0, 1] and on
//! texel edges and centres).
use super::{LRSM_MATH, LRSM_SAMPLE};
use crate::lrsm::{synthetic_rsm, PartitionConfig};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::lrsm_partition::{partition, PartitionParams};
use vxgi_cpu_mirror::lrsm_prefilter::{pack_stream, reduce_level, unpack_stream};
use vxgi_cpu_mirror::sample_lrsm::{sample, sample_bound, Lrsm, SampleParams};
use vxgi_harness::prelude::*;

vxgi_harness::bindings! {
    /// sample_lrsm's bindings: an LRSM (every level of every layer) and cone samples in, their
    /// radiance out.
    pub struct Io {
        inputs: {
            params: Block<SampleParams>,
            depth_ranges: Vec<[f32; 4]>,
            lrsm_radiance: Vec<[u32; 2]>,
            lrsm_normal: Vec<[u32; 2]>,
            lrsm_moments: Vec<[u32; 2]>,
            cone_pos: Vec<[f32; 4]>,
            cone_dir: Vec<[f32; 4]>,
        }
        outputs: {
            // Per element from the WGSL rules along the path: normal division and dot product (any
            // order, fused or not), V's own bound, decay 8 ULP, three products and the sum over
            // layers; branch flips at N = 0 or V = 0 change L continuously and are covered (see
            // `sample_bound`).
            radiance: Vec<[f32; 4]> => Tolerance::MirrorBound
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "sample_lrsm",
    includes: &[super::LRSM_TEXEL, LRSM_SAMPLE, LRSM_MATH],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "radiance" },
    mirror: "vxgi_cpu_mirror::sample_lrsm::sample",
    summary: "Sample LRSM (LRSM Algorithm 1): radiance of cone samples from the layered, pre-filtered RSM",
);

/// A complete LRSM (all levels concatenated) plus the parameters to sample it.
#[derive(Clone, Debug)]
pub struct BuiltLrsm {
    pub config: PartitionConfig,
    pub params: SampleParams,
    pub depth_ranges: Vec<[f32; 4]>,
    pub streams: [Vec<[f32; 4]>; 3],
}

/// An RSM partitioned and pre-filtered by the mirrors (every level, concatenated): what
/// lrsm_partition and lrsm_prefilter compute on the GPU.
pub fn lrsm_mirror(rsm: &crate::lrsm::Rsm, config: &PartitionConfig) -> [Vec<[f32; 4]>; 3] {
    let pp = PartitionParams {
        depth_slices: config.depth_slices(),
        normal_slices: config.normal_slices(),
        layer_texels: config.layer_texels() as u32,
        area_weights: config.area_weights as u32,
    };
    let level0 = partition(
        (&rsm.radiance, &rsm.normal, &rsm.depth),
        &config.depth_ranges(),
        &pp,
        false,
    );
    let levels = (config.rsm_side / 2).trailing_zeros() + 1;
    let mut streams = level0.clone();
    let mut level = level0;
    for _ in 1..levels {
        level = reduce_level([&level[0], &level[1], &level[2]], false);
        for (s, l) in streams.iter_mut().zip(&level) {
            s.extend_from_slice(l);
        }
    }
    streams
}

/// Sample LRSM's parameters for LRSMs made with `config` (variance floor 1e-4: sigma >= 1% of a layer;
/// opacity floor 1e-6); `view_weight`: N weighs each layer's radiance (Algorithm 1 as written) instead
/// of only culling back faces. Area-weighted LRSMs (`config.area_weights`) are read as eq. 1's
/// premultiplied product, which N weighs as a projected area: `view_weight` is then set.
pub fn sample_params(config: &PartitionConfig, cdf: u32, view_weight: bool) -> SampleParams {
    let side0 = config.rsm_side / 2;
    SampleParams {
        depth_slices: config.depth_slices(),
        normal_slices: config.normal_slices(),
        levels: side0.trailing_zeros() + 1,
        side0,
        cdf,
        min_variance: 1.0e-4,
        min_alpha: 1.0e-6,
        overlap: config.overlap,
        view_weight: (view_weight || config.area_weights) as u32,
        area: config.area_weights as u32,
        lit_cells: 0,
        lit_base: 0,
    }
}

/// Partition a synthetic RSM and pre-filter it, on the CPU (the GPU kernels for these are verified
/// against exactly these mirrors).
pub fn build_lrsm(config: PartitionConfig, seed: u64, cdf: u32, view_weight: bool) -> BuiltLrsm {
    let rsm = synthetic_rsm(config.rsm_side, &config, seed);
    let ranges = config.depth_ranges();
    let streams = lrsm_mirror(&rsm, &config);
    let params = sample_params(&config, cdf, view_weight);
    BuiltLrsm {
        config,
        params,
        depth_ranges: ranges,
        streams,
    }
}

/// `count` cone samples over `lrsm`.
pub fn cone_samples(lrsm: &BuiltLrsm, seed: u64, count: usize) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let levels = lrsm.params.levels as f32;
    // A coordinate: mostly in [0, 1], some outside, some exactly on a texel edge or centre of some
    // level (the trilinear fetch's bilinear weights 0, 1 or 1/2).
    let coordinate = |rng: &mut ChaCha8Rng| match rng.random_range(0..10) {
        0 => rng.random_range(-0.5..1.5),
        1 => {
            let s = lrsm.params.side0 >> rng.random_range(0..lrsm.params.levels);
            let k = rng.random_range(0..=s) as f32;
            (k + [0.0, 0.5][rng.random_range(0..2)]) / s as f32
        }
        _ => rng.random(),
    };
    (0..count)
        .map(|_| {
            let u = coordinate(&mut rng);
            let v = coordinate(&mut rng);
            let mip = match rng.random_range(0..8) {
                0 => [-1.0, -1e30][rng.random_range(0..2)],
                1 => [levels + 2.0, 1e30][rng.random_range(0..2)],
                2 => rng.random_range(0..lrsm.params.levels) as f32,
                _ => rng.random_range(0.0..levels),
            };
            let zc = match rng.random_range(0..6) {
                0 => {
                    lrsm.depth_ranges[rng.random_range(0..lrsm.depth_ranges.len())]
                        [rng.random_range(0..2)]
                }
                1 => rng.random_range(-0.2..1.2),
                _ => rng.random_range(0.2..0.8),
            };
            let dir = match rng.random_range(0..6) {
                0 => glam::Vec3::new(1.0, 0.0, 0.0), // perpendicular to most normals: N = 0
                _ => glam::Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-0.3..1.0),
                )
                .normalize_or(glam::Vec3::Z),
            };
            let rc = match rng.random_range(0..8) {
                0 => 0.0,
                1 => 2.0, // larger than the whole depth range
                _ => rng.random_range(0.001..0.3),
            };
            ([u, v, mip, zc], [dir.x, dir.y, dir.z, rc])
        })
        .unzip()
}

pub fn case_for(
    shader: &Shader,
    ctx: &GpuContext,
    lrsm: &BuiltLrsm,
    pos: &[[f32; 4]],
    dir: &[[f32; 4]],
    label: String,
    seed: u64,
) -> Case {
    let io = Io {
        params: Block(lrsm.params),
        depth_ranges: lrsm.depth_ranges.clone(),
        lrsm_radiance: pack_stream(&lrsm.streams[0]),
        lrsm_normal: pack_stream(&lrsm.streams[1]),
        lrsm_moments: pack_stream(&lrsm.streams[2]),
        cone_pos: pos.to_vec(),
        cone_dir: dir.to_vec(),
        radiance: vec![[0.0; 4]; pos.len()],
    };
    let bindings = DECL.bind_by_name();
    let pass = DECL.pass(shader, ctx, "sample".into(), bindings, pos.len() as u64);
    let layers = (lrsm.params.depth_slices * lrsm.params.normal_slices) as u64;
    // Per sample: its two vec4s, up to 8 taps (trilinear) of 3 texels of 8 bytes per layer, and
    // the output.
    io.case(label, seed, vec![pass])
        .with_effective_bytes(pos.len() as u64 * (32 + 16 + layers * 8 * 24))
}

pub struct SampleLrsm;

impl Kernel for SampleLrsm {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let config = super::lrsm_partition::config_for(index);
        // The two CDFs alternate, and N as a weight or a cull every other pair of cases.
        let view_weight = index % 4 < 2;
        let lrsm = build_lrsm(
            config,
            seed.wrapping_add(index as u64),
            (index % 2) as u32,
            view_weight,
        );
        let count = [4096, 1, 100, 20_000][index % 4];
        let (pos, dir) = cone_samples(&lrsm, seed ^ index as u64, count);
        let label = format!(
            "#{index} {}^2 RSM, {} layers, {count} samples, cdf {}, N {}",
            config.rsm_side,
            config.layers(),
            index % 2,
            if view_weight { "weighs" } else { "culls" }
        );
        case_for(shader, ctx, &lrsm, &pos, &dir, label, seed)
    }

    fn mirror(&self, _case: &Case, data: &Resources, mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(data);
        let [radiance, normal, moments] =
            [&io.lrsm_radiance, &io.lrsm_normal, &io.lrsm_moments].map(|s| unpack_stream(s));
        let lrsm = Lrsm {
            depth_ranges: &io.depth_ranges,
            radiance: &radiance,
            normal: &normal,
            moments: &moments,
        };
        let (params, flush) = (io.params.0, mode == FloatMode::FlushToZero);
        let pairs = || io.cone_pos.iter().zip(&io.cone_dir);
        let l: Vec<[f32; 4]> = pairs()
            .map(|(p, d)| sample(&lrsm, &params, *p, *d, flush))
            .collect();
        let b: Vec<[f32; 4]> = pairs()
            .map(|(p, d)| sample_bound(&lrsm, &params, *p, *d))
            .collect();
        io.radiance = l;
        let mut out = io.outputs();
        out.extend([bound("radiance", &b)]);
        out
    }
}
