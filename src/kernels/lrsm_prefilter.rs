//! Declaration of `kernels/lrsm_prefilter.wgsl` (mirror: `vxgi_cpu_mirror::lrsm_prefilter`): the mip chain
//! of every LRSM layer, verified level by level on the level the GPU produced before it.
use super::{chain_levels, reduction_chain_case, ChainStream};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::lrsm_prefilter::{
    pack_stream, quantize, reduce_level, unpack_stream, Streams,
};
use vxgi_harness::prelude::*;

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "lrsm_prefilter",
    includes: &[super::LRSM_TEXEL],
    inputs: &["src_radiance", "src_normal", "src_moments"],
    // Exact unpacking, four correctly rounded adds and an exact * 0.25: the mirror's f32 bit for bit
    // (or the flush-to-zero result, which binary16 rounds alike); stored as binary16 rounded either
    // way (WGSL leaves the direction open): 1 binary16 ULP.
    outputs: &[
        Output {
            binding: "dst_radiance",
            tolerance: Tolerance::Half { ulps: 1 },
        },
        Output {
            binding: "dst_normal",
            tolerance: Tolerance::Half { ulps: 1 },
        },
        Output {
            binding: "dst_moments",
            tolerance: Tolerance::Half { ulps: 1 },
        },
    ],
    dispatch: DispatchRule::PerElement {
        binding: "dst_radiance",
    },
    mirror: "vxgi_cpu_mirror::lrsm_prefilter::reduce_level",
    summary: "box-filtered mip level of every LRSM layer, opacity-weighted (LRSM 4.2, Table 1)",
);

/// Bytes of one texel of one stream as stored (four binary16 values).
pub const TEXEL_BYTES: u64 = 8;
const STREAMS: [&str; 3] = ["radiance", "normal", "moments"];

/// A stream's values as the GPU buffer that stores them (binary16 pairs, lossless for stored values).
pub fn stored(stream: &[[f32; 4]]) -> HostBuffer {
    HostBuffer::u32(bytemuck::cast_slice(&pack_stream(stream)))
}

/// The values a stored stream's buffer holds.
pub fn values(buffer: &HostBuffer) -> Vec<[f32; 4]> {
    unpack_stream(bytemuck::cast_slice(&buffer.bytes))
}

pub fn stream_name(stream: usize, level: u32) -> String {
    format!("{}_{level}", STREAMS[stream])
}

/// Generated level-0 layers: opacities 0, 1/4 .. 1 and subnormal, warped depths in [0, 1], unit normals,
/// radiance up to 4 and past binary16's range (clamped), as stored.
pub fn generate(layers: u32, side: u32, seed: u64) -> Streams {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = (layers * side * side) as usize;
    let mut out: Streams = [
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    ];
    for _ in 0..n {
        let a = match rng.random_range(0..8) {
            0..=2 => 0.0,
            3 => f32::from_bits(rng.random_range(1..0x0080_0000)),
            4 => [0.25, 0.5, 0.75][rng.random_range(0..3)],
            _ => 1.0,
        };
        let z: f32 = rng.random();
        let n3 = glam::Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(0.1..1.0),
        )
        .normalize();
        let scale = if rng.random_ratio(1, 16) { 1.0e5 } else { 1.0 };
        let r: [f32; 3] = [
            scale * rng.random_range(0.0..4.0),
            rng.random_range(0.0..4.0),
            rng.random_range(0.0..4.0),
        ];
        out[0].push(quantize([a * r[0], a * r[1], a * r[2], a]));
        out[1].push(quantize([a * n3.x, a * n3.y, a * n3.z, a]));
        out[2].push(quantize([a * z, a * z * z, a, 0.0]));
    }
    out
}

/// The whole chain of `level0` (`layers` layers of side `side`) as one case.
pub fn chain_case(
    shader: &Shader,
    ctx: &GpuContext,
    level0: &Streams,
    layers: u32,
    side: u32,
    label: String,
    seed: u64,
) -> Case {
    let levels = side.trailing_zeros();
    let parents: Vec<u64> = (1..=levels)
        .map(|k| layers as u64 * ((side >> k) as u64).pow(2))
        .collect();
    let names: [&dyn Fn(u32) -> String; 3] =
        [&|k| stream_name(0, k), &|k| stream_name(1, k), &|k| {
            stream_name(2, k)
        }];
    let streams: Vec<ChainStream> = (0..3)
        .map(|s| ChainStream {
            src_binding: DECL.inputs[s],
            dst_binding: DECL.outputs[s].binding,
            resource: names[s],
        })
        .collect();
    let level0 = level0.iter().map(|d| stored(d)).collect();
    let indexing = |k: u32| Indexing::Grid {
        dims: [(side >> k).pow(2), layers, 1],
        components: 2,
    };
    reduction_chain_case(
        &DECL,
        shader,
        ctx,
        &streams,
        level0,
        &parents,
        (4, TEXEL_BYTES),
        &indexing,
        Vec::new(),
        label,
        seed,
    )
}

pub struct LrsmPrefilter;

impl Kernel for LrsmPrefilter {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let layers = [1, 4, 6, 9][index % 4];
        let side = 2u32 << (index % 7);
        let s = seed
            .wrapping_mul(0x9e37_79b9_7f4a_7c15)
            .wrapping_add(index as u64);
        chain_case(
            shader,
            ctx,
            &generate(layers, side, s),
            layers,
            side,
            format!("#{index} {layers} layers {side}^2"),
            seed,
        )
    }

    fn mirror(&self, case: &Case, data: &Resources, mode: FloatMode) -> MirrorOutputs {
        let mut out = MirrorOutputs::new();
        for k in chain_levels(case, 3) {
            let src = |s: usize| values(data[&stream_name(s, k - 1)].buffer().expect("buffer"));
            let (r, n, m) = (src(0), src(1), src(2));
            let level = reduce_level([&r, &n, &m], mode == FloatMode::FlushToZero);
            for (s, v) in level.iter().enumerate() {
                out.insert(stream_name(s, k), stored(v));
            }
        }
        out
    }
}
