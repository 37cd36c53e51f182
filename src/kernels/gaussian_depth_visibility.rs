//! Declaration of `kernels/gaussian_depth_visibility.wgsl` (mirror:
//! `vxgi_cpu_mirror::gaussian_depth_visibility`) and its generated cases: realistic pre-filtered moments
//! mixed with the numerically hard ones (one depth, boundaries, tiny opacity, quantised moments, huge or
//! tiny cone radii, depths outside the layer, arbitrary finite bit patterns).
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::gaussian_depth_visibility::{visibility, visibility_bound, VisibilityParams};
use vxgi_harness::prelude::*;

use super::LRSM_MATH;

vxgi_harness::bindings! {
    /// gaussian_depth_visibility's bindings: pre-filtered moments and cone samples in, V out.
    pub struct Io {
        inputs: {
            params: Block<VisibilityParams>,
            moments: Vec<[f32; 4]>,
            /// (depth, radius) of each cone sample.
            cone: Vec<[f32; 2]>,
        }
        outputs: {
            // Per-element bound from the WGSL accuracy rules along the element's path (division
            // 2.5 ULP, sqrt via inverseSqrt, exp 3 + 2|x| ULP, FMA contraction allowed) propagated
            // through dV/dt = phi(t); see `visibility_bound`. A fixed epsilon would be either loose
            // where sigma is large or wrong where sigma^2 is near its floor.
            visibility: Vec<f32> => Tolerance::MirrorBound
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "gaussian_depth_visibility",
    includes: &[LRSM_MATH],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement {
        binding: "visibility",
    },
    mirror: "vxgi_cpu_mirror::gaussian_depth_visibility::visibility",
    summary: "Gaussian depth visibility V (LRSM eq. 10-12) from pre-filtered depth moments",
);

/// Moments and cone samples of one generated case.
#[derive(Clone, Debug)]
pub struct Inputs {
    pub moments: Vec<[f32; 4]>,
    pub cone: Vec<[f32; 2]>,
}

/// Opacity-weighted moments of `depths` with opacities `alphas`, averaged over `n` texels (a box
/// pre-filter of a footprint with empty texels).
pub fn moments_of(depths: &[f32], alphas: &[f32], n: usize) -> [f32; 4] {
    let (mut a, mut az, mut az2) = (0.0f64, 0.0f64, 0.0f64);
    for (&z, &al) in depths.iter().zip(alphas) {
        a += al as f64;
        az += (al * z) as f64;
        az2 += (al * z * z) as f64;
    }
    let n = n as f64;
    [(az / n) as f32, (az2 / n) as f32, (a / n) as f32, 0.0]
}

fn quantise_unorm16(x: f32) -> f32 {
    (x.clamp(0.0, 1.0) * 65535.0).round() / 65535.0
}

/// One element of a hard family, chosen by `rng`.
fn element(rng: &mut ChaCha8Rng) -> ([f32; 4], [f32; 2]) {
    let zc_rc = |rng: &mut ChaCha8Rng| -> [f32; 2] {
        let zc = match rng.random_range(0..6) {
            0 => 0.0,
            1 => 1.0,
            2 => rng.random_range(-5.0..6.0),
            3 => [3.0e38f32, -3.0e38, 1.0e7, -1.0e7][rng.random_range(0..4)],
            _ => rng.random::<f32>(),
        };
        let rc = match rng.random_range(0..6) {
            0 => 0.0,
            1 => [1.0e-7f32, f32::from_bits(3), 1.0e-30][rng.random_range(0..3)],
            2 => [10.0f32, 1.0e6, 3.0e38][rng.random_range(0..3)],
            3 => -rng.random::<f32>(),
            _ => rng.random_range(0.0..0.5),
        };
        [zc, rc]
    };
    let cone = zc_rc(rng);
    let m = match rng.random_range(0..10) {
        // A realistic footprint: 1..64 texels of a noisy tilted surface, some empty.
        0..=2 => {
            let n = rng.random_range(1..=64usize);
            let base: f32 = rng.random();
            let slope: f32 = rng.random_range(-0.02..0.02);
            let noise: f32 = rng.random_range(0.0..0.05);
            let depths: Vec<f32> = (0..n)
                .map(|i| (base + slope * i as f32 + noise * rng.random::<f32>()).clamp(0.0, 1.0))
                .collect();
            let alphas: Vec<f32> = (0..n)
                .map(|_| if rng.random::<f32>() < 0.8 { 1.0 } else { 0.0 })
                .collect();
            moments_of(&depths, &alphas, n)
        }
        // All samples at one depth: z^2 - mu^2 cancels to rounding noise.
        3 => {
            let z = [0.0f32, 1.0, 0.5, 1.0 / 3.0, rng.random()][rng.random_range(0..5)];
            let a = [1.0f32, 0.25, 1.0e-3][rng.random_range(0..3)];
            [a * z, a * z * z, a, 0.0]
        }
        // Two clusters (a depth discontinuity inside one texel's footprint), mean on a layer boundary.
        4 => {
            let z0 = [0.0f32, 1.0][rng.random_range(0..2)];
            moments_of(&[z0, 1.0 - z0, z0], &[1.0, 1.0, 1.0], 3)
        }
        // Tiny opacity: normalising by a near-zero A.
        5 => {
            let a =
                [0.0f32, 1.0e-7, 1.0e-6, 1.1e-6, f32::from_bits(7), -1.0][rng.random_range(0..6)];
            let z: f32 = rng.random();
            [a * z, a * z * z, a, 0.0]
        }
        // Moments as the paper stores them: 16-bit UNORM (z, z^2, A), or f16.
        6 => {
            let z: f32 = rng.random();
            let spread: f32 = rng.random_range(0.0..0.1);
            let a = 1.0;
            let m = [z, z * z + spread * spread, a, 0.0];
            if rng.random() {
                m.map(quantise_unorm16)
            } else {
                m.map(half_round)
            }
        }
        // Arbitrary finite bit patterns (outside the contract's [0,1] depths, but must stay finite).
        7 => {
            let mut finite = || loop {
                let x = f32::from_bits(rng.random());
                if x.is_finite() {
                    return x;
                }
            };
            [finite(), finite(), finite(), 0.0]
        }
        // Empty texel.
        8 => [0.0; 4],
        _ => {
            let z: f32 = rng.random();
            let s: f32 = rng.random_range(0.0..0.3);
            [z, z * z + s * s, 1.0, 0.0]
        }
    };
    (m, cone)
}

/// Round to the nearest f16 and back (quantised storage), without a half-float crate: 11 significant bits.
fn half_round(x: f32) -> f32 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let bits = x.to_bits();
    let rounded = (bits + 0x0000_1000) & !0x0000_1fff;
    f32::from_bits(rounded)
}

/// Generated inputs for case `index` of a run seeded with `seed`.
pub fn inputs(seed: u64, index: usize, count: usize) -> Inputs {
    let mut rng = ChaCha8Rng::seed_from_u64(
        seed.wrapping_mul(0x9e37_79b9_7f4a_7c15)
            .wrapping_add(index as u64),
    );
    let (moments, cone) = (0..count).map(|_| element(&mut rng)).unzip();
    Inputs { moments, cone }
}

/// Host resources and the single pass for `inputs` with `params`.
pub fn case_for(
    shader: &Shader,
    ctx: &GpuContext,
    inputs: &Inputs,
    params: VisibilityParams,
    label: String,
    seed: u64,
) -> Case {
    let n = inputs.moments.len();
    let io = Io {
        params: Block(params),
        moments: inputs.moments.clone(),
        cone: inputs.cone.clone(),
        visibility: vec![0.0; n],
    };
    DECL.case_of(shader, ctx, &io, n as u64, label, seed)
}

pub struct GaussianDepthVisibility;

impl Kernel for GaussianDepthVisibility {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let params = VisibilityParams {
            cdf: (index % 2) as u32,
            ..VisibilityParams::default()
        };
        let count = [4096, 1, 63, 65, 100_000][index % 5];
        let inp = inputs(seed, index, count);
        case_for(
            shader,
            ctx,
            &inp,
            params,
            format!("#{index} n={count} cdf={}", params.cdf),
            seed,
        )
    }

    fn mirror(&self, _case: &Case, data: &Resources, mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(data);
        let (params, flush) = (io.params.0, mode == FloatMode::FlushToZero);
        let samples = || io.moments.iter().zip(&io.cone);
        let b: Vec<f32> = samples()
            .map(|(m, c)| visibility_bound(*m, c[0], c[1], &params))
            .collect();
        io.visibility = samples()
            .map(|(m, c)| visibility(*m, c[0], c[1], &params, flush))
            .collect();
        let mut out = io.outputs();
        out.extend([bound("visibility", &b)]);
        out
    }
}
