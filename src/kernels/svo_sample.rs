//! Declaration of `kernels/svo_sample.wgsl` (mirror: `vxgi_cpu_mirror::svo_sample`): quadrilinear
//! sampling of the sparse voxel octree, the read path a cone tracer takes through it. Cases: octrees of
//! the `sparse_voxel_octree` generator's families (built by the mirror; the builder is verified on its
//! own), sampled at random points, lattice points, node and volume boundaries, outside the volume, and at
//! whole, fractional and out-of-range levels. [`sample_on_gpu`] is the own-device API.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::sparse_voxel_octree::{build, Octree};
use vxgi_cpu_mirror::svo_sample::{sample_all, SampleParams};
use vxgi_harness::prelude::*;

vxgi_harness::bindings! {
    /// svo_sample's bindings: the octree and the queries (x, y, z, level) in, the samples out.
    pub struct Io {
        inputs: {
            params: Block<SampleParams>,
            nodes: Vec<[u32; 9]>,
            bricks: Vec<u32>,
            queries: Vec<[f32; 4]>,
        }
        outputs: {
            // Node, cell and weights are exact on both sides. Per channel: 8 conversions f32(u32)
            // and 8 scalings (correctly rounded: 0.5 ULP each), 7 + 1 lerps a(1-t) + bt, each 1 - t
            // (exact for t >= 1/2, else 0.5 ULP), two products and a sum (0.5 ULP each; FMA
            // contraction, which WGSL allows, removes one rounding). All terms are non-negative, so
            // relative errors add without cancellation: each side is within ~8 ULP of the exact
            // value, GPU vs mirror within 16. The floor covers flush-to-zero.
            samples: Vec<[f32; 4]> => Tolerance::Ulp { ulps: 16, abs_floor: 1e-30 }
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "svo_sample",
    // `bricks`' windows past its first (`bricks_1`..) are bound by `bind_brick_windows`.
    includes: &[super::SVO_NODE, super::SVO_BRICKS],
    entry: "svo_sample",
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "queries" },
    mirror: "vxgi_cpu_mirror::svo_sample::sample_all",
    summary: "quadrilinear sampling of the sparse voxel octree: descend to the node, trilinear in its 3x3x3 brick, blend two levels (VCT 5)",
);

/// Fixed-point scale of the generated octrees' values (2^16 steps per unit).
pub const CASE_SCALE: f32 = 65536.0;

#[derive(Debug, thiserror::Error)]
pub enum SampleError {
    #[error("query {index} = {query:?} is not finite")]
    NonFinite { index: usize, query: [f32; 4] },
    #[error("no queries")]
    Empty,
    #[error("fixed-point scale {0} must be finite and positive")]
    Scale(f32),
    #[error(transparent)]
    Harness(Box<vxgi_harness::HarnessError>),
}

impl From<vxgi_harness::HarnessError> for SampleError {
    fn from(e: vxgi_harness::HarnessError) -> Self {
        SampleError::Harness(Box::new(e))
    }
}

pub fn case_for(
    ctx: &GpuContext,
    octree: &Octree,
    scale: f32,
    queries: &[[f32; 4]],
    label: String,
    seed: u64,
) -> Case {
    let params = SampleParams {
        depth: octree.depth,
        count: queries.len() as u32,
        inv_scale: 1.0 / scale,
        _pad: 0,
    };
    let io = Io {
        params: Block(params),
        nodes: bytemuck::cast_slice(&octree.nodes).to_vec(),
        bricks: octree.bricks.clone(),
        queries: queries.to_vec(),
        samples: vec![[0.0; 4]; queries.len()],
    };
    let shader = DECL.shader().expect("svo_sample validates");
    let mut case = DECL
        .case_of(&shader, ctx, &io, queries.len() as u64, label, seed)
        .with_indexing("samples", vxgi_harness::Indexing::Linear)
        .with_effective_bytes(queries.len() as u64 * (16 + 16 + 8 * 16));
    let window = super::sparse_voxel_octree::BRICK_WINDOW;
    super::sparse_voxel_octree::bind_brick_windows(
        &mut case.passes,
        &mut case.resources,
        "bricks",
        window,
    )
    .expect("the octree's limits keep its bricks in their bindings");
    case
}

/// Queries of the generator: random points and levels, lattice points of random levels, node and
/// volume boundaries, points outside the volume (clamped), whole / fractional / out-of-range levels.
pub fn queries(rng: &mut ChaCha8Rng, depth: u32, count: usize) -> Vec<[f32; 4]> {
    (0..count)
        .map(|i| {
            let level = match i % 5 {
                0 => rng.random_range(0..=depth) as f32,
                1 => rng.random_range(0.0..depth as f32),
                2 => rng.random_range(-1.0..depth as f32 + 2.0),
                _ => rng.random_range(0.0..=depth as f32),
            };
            let lattice = |rng: &mut ChaCha8Rng, l: u32| {
                let n = 2u32 << l;
                rng.random_range(0..=n) as f32 / n as f32
            };
            let p: [f32; 3] = match (i / 5) % 4 {
                0 => [0, 1, 2].map(|_| rng.random_range(0.0..=1.0)),
                1 => {
                    let l = rng.random_range(0..=depth);
                    [0, 1, 2].map(|_| lattice(rng, l))
                }
                2 => [0, 1, 2].map(|_| [0.0, 1.0, 0.5, 0.25][rng.random_range(0..4)]),
                _ => [0, 1, 2].map(|_| rng.random_range(-0.2..1.2)),
            };
            [p[0], p[1], p[2], level]
        })
        .collect()
}

pub struct SvoSample;

impl Kernel for SvoSample {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (depth, frags, label) = super::sparse_voxel_octree::generated(seed, index);
        let cap = super::sparse_voxel_octree::default_capacity(ctx, depth, frags.len());
        let octree = build(depth, cap, &frags);
        let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(1000 + index as u64));
        let q = queries(&mut rng, depth, 2048);
        let case = case_for(ctx, &octree, CASE_SCALE, &q, label, seed);
        match index % 8 {
            5 => super::sparse_voxel_octree::with_brick_split(case),
            _ => case,
        }
    }
    fn mirror(&self, case: &Case, _data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(&case.resources);
        io.samples = sample_all(
            bytemuck::cast_slice(&io.nodes),
            &io.bricks,
            &io.params.0,
            &io.queries,
        );
        io.outputs()
    }
}

/// Sample `octree` (values in fixed point with `scale`) at `queries` on the GPU.
pub fn sample_on_gpu(
    ctx: &GpuContext,
    octree: &Octree,
    scale: f32,
    queries: &[[f32; 4]],
) -> Result<Vec<[f32; 4]>, SampleError> {
    if queries.is_empty() {
        return Err(SampleError::Empty);
    }
    if !(scale.is_finite() && scale > 0.0) {
        return Err(SampleError::Scale(scale));
    }
    if let Some((index, q)) = queries
        .iter()
        .enumerate()
        .find(|(_, q)| q.iter().any(|x| !x.is_finite()))
    {
        return Err(SampleError::NonFinite { index, query: *q });
    }
    let case = case_for(ctx, octree, scale, queries, "sample_on_gpu".into(), 0);
    let out = DECL.run(ctx, &case, &["samples"])?;
    Ok(bytemuck::cast_slice(&out.buffer("samples").bytes).to_vec())
}
