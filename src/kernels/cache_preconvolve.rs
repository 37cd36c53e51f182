//! Declaration of `kernels/cache_preconvolve.wgsl` (mirror: `vxgi_cpu_mirror::cache_preconvolve`): each
//! radiance cache's mip chain (exact) and cosine-folded irradiance map. Cases are generated caches of
//! radiance: smooth skies, single bright texels, zeros, large and subnormal values.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::cache_preconvolve::{
    irradiance_texel, irradiance_weights, mip_len, mip_texel, PreconvolveParams,
};
use vxgi_harness::prelude::*;
use vxgi_harness::run::Pass;

vxgi_harness::bindings! {
    /// cache_preconvolve's bindings: the caches' radiance in, their mips and irradiance maps out.
    pub struct Io {
        inputs: {
            params: Block<PreconvolveParams>,
            cache_radiance: Vec<[f32; 4]>,
            irr_weights: Vec<f32>,
        }
        outputs: {
            // Adds in the mirror's order and a power-of-two ldexp: exact (WGSL forbids reassociation;
            // flush-to-zero GPUs are the harness's FTZ alternative).
            cache_mips: Vec<[f32; 4]> => Tolerance::Exact,
            // n multiply-adds per texel, one rounding each, fused or not: (n + 1) u sum |L W|,
            // doubled (see `irradiance_texel`).
            cache_irradiance: Vec<[f32; 4]> => Tolerance::MirrorBound,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "cache_preconvolve",
    entry: "mips",
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement {
        binding: "cache_mips",
    },
    mirror: "vxgi_cpu_mirror::cache_preconvolve::mip_texel",
    summary: "radiance caches' mip chains and cosine-folded irradiance maps (CPRC 3.1, PCRC)",
);

/// Both passes over `radiance` (count caches of res^2 texels) with irradiance maps of irr^2 texels.
pub fn case_for(
    ctx: &GpuContext,
    radiance: &[[f32; 4]],
    res: u32,
    irr: u32,
    label: String,
    seed: u64,
) -> Case {
    let count = radiance.len() / (res * res) as usize;
    case_for_count(ctx, count, Some(radiance), res, irr, label, seed)
}

/// [`case_for`] for `count` caches whose texels are `radiance`, or (None) a zeroed `cache_radiance`
/// that an earlier stage of a chain fills on the GPU.
pub fn case_for_count(
    ctx: &GpuContext,
    count: usize,
    radiance: Option<&[[f32; 4]]>,
    res: u32,
    irr: u32,
    label: String,
    seed: u64,
) -> Case {
    let p = PreconvolveParams {
        count: count as u32,
        res,
        levels: res.trailing_zeros() + 1,
        irr_texels: irr * irr,
    };
    let (n_mips, n_irr) = (count * mip_len(res), count * (irr * irr) as usize);
    let texels = (count * (res * res) as usize).max(1);
    let io = Io {
        params: Block(p),
        cache_radiance: match radiance {
            Some(r) if !r.is_empty() => r.to_vec(),
            _ => vec![[0.0; 4]; texels],
        },
        irr_weights: irradiance_weights(res, irr),
        cache_mips: vec![[0.0; 4]; n_mips.max(1)],
        cache_irradiance: vec![[0.0; 4]; n_irr.max(1)],
    };
    let pass =
        |entry: &str, n: usize| Pass::linear(ctx, entry, entry, DECL.bind_by_name(), n as u64);
    let grid = |per: usize| Indexing::Grid {
        dims: [per as u32, count.max(1) as u32, 1],
        components: 4,
    };
    io.case(
        label,
        seed,
        vec![pass("mips", n_mips), pass("irradiance", n_irr)],
    )
    .with_indexing("cache_mips", grid(mip_len(res)))
    .with_indexing("cache_irradiance", grid((irr * irr) as usize))
    .with_effective_bytes(texels as u64 * 16 * 2 + (n_mips + n_irr) as u64 * 16)
}

/// Generated caches: `count` caches of res^2 texels, per cache one of: a smooth sky, one bright texel
/// on black, all zeros, random magnitudes over 2^-20..2^20, subnormals.
pub fn generated_radiance(count: usize, res: u32, seed: u64) -> Vec<[f32; 4]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let t = (res * res) as usize;
    let mut out = Vec::with_capacity(count * t);
    for c in 0..count {
        let bright = rng.random_range(0..t);
        for k in 0..t {
            let v = match c % 5 {
                0 => {
                    let s = 1.0 + (k as f32 / t as f32);
                    [s, 0.5 * s, 0.25, 0.0]
                }
                1 => {
                    if k == bright {
                        [100.0, 50.0, 1.0, 0.0]
                    } else {
                        [0.0; 4]
                    }
                }
                2 => [0.0; 4],
                3 => {
                    let m =
                        |r: &mut ChaCha8Rng| r.random::<f32>() * 2f32.powi(r.random_range(-20..20));
                    [m(&mut rng), m(&mut rng), m(&mut rng), 0.0]
                }
                _ => [
                    f32::from_bits(rng.random_range(1..0x007f_ffff)),
                    rng.random::<f32>(),
                    f32::MIN_POSITIVE,
                    0.0,
                ],
            };
            out.push(v);
        }
    }
    out
}

pub struct CachePreconvolve;

/// (cache side, irradiance side) of the generated cases.
const SIZES: [(u32, u32); 4] = [(16, 8), (4, 4), (32, 8), (1, 1)];

impl Kernel for CachePreconvolve {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (res, irr) = SIZES[index % SIZES.len()];
        let count = [7, 20, 3, 10][index % 4];
        let rad = generated_radiance(count, res, seed.wrapping_add(index as u64));
        let label = format!("#{index} {count} caches {res}^2, irradiance {irr}^2");
        case_for(ctx, &rad, res, irr, label, seed)
    }
    fn mirror(&self, _case: &Case, data: &Resources, mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(data);
        let (p, rad, w) = (io.params.0, &io.cache_radiance, &io.irr_weights);
        let t = (p.res * p.res) as usize;
        let flush = mode == FloatMode::FlushToZero;
        let (mut mips, mut irr, mut irr_b) = (Vec::new(), Vec::new(), Vec::new());
        for c in 0..p.count as usize {
            let tex = &rad[c * t..(c + 1) * t];
            for j in 0..mip_len(p.res) {
                mips.push(mip_texel(tex, p.res, j, flush));
            }
            for k in 0..p.irr_texels as usize {
                let (e, eb) = irradiance_texel(tex, w, k);
                irr.push(e);
                irr_b.push(eb);
            }
        }
        for v in [&mut mips, &mut irr, &mut irr_b] {
            if v.is_empty() {
                v.push([0.0; 4]);
            }
        }
        (io.cache_mips, io.cache_irradiance) = (mips, irr);
        let mut out = io.outputs();
        out.extend([bound("cache_irradiance", &irr_b)]);
        out
    }
}
