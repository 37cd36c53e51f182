//! Declaration of `kernels/layer_decay.wgsl` (mirror: `vxgi_cpu_mirror::layer_decay`) and its cases:
//! samples on plateaus, ramps, exactly on range ends, outside, zero and negative overlap, layers narrower
//! than two overlaps, and huge and tiny magnitudes.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::layer_decay::layer_decay;
use vxgi_harness::prelude::*;

use super::LRSM_MATH;

vxgi_harness::bindings! {
    /// layer_decay's bindings: (zc, zmin, zmax, delta) samples in, their decay out.
    pub struct Io {
        inputs: { sample: Vec<[f32; 4]> }
        outputs: {
            // t = (zc - zmin) / delta: one rounded subtraction + division (2.5 ULP) -> 3 ULP;
            // smoothstep's relative condition |dk/dt| t / k <= 2 makes that 6 ULP; its own products
            // and 3 - 2t (>= 1, no cancellation) add 1.5 ULP, fused or not; clamp/min exact -> 8 ULP.
            // Near 0, ULPs stay relative (t^2 underflows only below 1e-19, where the flush-to-zero
            // alternative applies).
            decay: Vec<f32> => Tolerance::Ulp { ulps: 8, abs_floor: 0.0 }
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "layer_decay",
    includes: &[LRSM_MATH],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "decay" },
    mirror: "vxgi_cpu_mirror::layer_decay::layer_decay",
    summary: "layer decay f(zc) (LRSM eq. 15), smoothstep falloff over the layer overlaps",
);

/// `count` generated (zc, zmin, zmax, delta) samples.
pub fn samples(seed: u64, index: usize, count: usize) -> Vec<[f32; 4]> {
    let mut rng = ChaCha8Rng::seed_from_u64(
        seed.wrapping_mul(0x9e37_79b9_7f4a_7c15)
            .wrapping_add(index as u64),
    );
    (0..count)
        .map(|_| {
            let zmin: f32 = rng.random_range(-0.2..0.8);
            let width: f32 = [rng.random_range(0.05..1.0), 0.0, 1.0e-6]
                [rng.random_range(0..3usize) * (rng.random_range(0..8) == 0) as usize];
            let zmax = zmin + width;
            let delta: f32 = match rng.random_range(0..8) {
                0 => 0.0,
                1 => -0.1,
                2 => width, // narrower than two overlaps
                3 => f32::from_bits(rng.random_range(1..0x0080_0000)),
                _ => rng.random_range(0.001..0.2),
            };
            let zc = match rng.random_range(0..8) {
                0 => zmin,
                1 => zmax,
                2 => zmin + delta,
                3 => zmax - delta,
                4 => [1.0e30f32, -1.0e30, 0.0][rng.random_range(0..3)],
                _ => rng.random_range(zmin - 0.3..zmax + 0.3),
            };
            [zc, zmin, zmax, delta]
        })
        .collect()
}

pub fn case_for(
    shader: &Shader,
    ctx: &GpuContext,
    samples: &[[f32; 4]],
    label: String,
    seed: u64,
) -> Case {
    let io = Io {
        sample: samples.to_vec(),
        decay: vec![0.0; samples.len()],
    };
    DECL.case_of(shader, ctx, &io, samples.len() as u64, label, seed)
}

pub struct LayerDecay;

impl Kernel for LayerDecay {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let count = [4096, 1, 65, 100_000][index % 4];
        case_for(
            shader,
            ctx,
            &samples(seed, index, count),
            format!("#{index} n={count}"),
            seed,
        )
    }

    fn mirror(&self, _case: &Case, data: &Resources, mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(data);
        let flush = mode == FloatMode::FlushToZero;
        io.decay = io
            .sample
            .iter()
            .map(|v| layer_decay(v[0], v[1], v[2], v[3], flush))
            .collect();
        io.outputs()
    }
}
