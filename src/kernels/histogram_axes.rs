//! Declaration of `kernels/histogram_axes.wgsl` (mirror: `vxgi_cpu_mirror::histogram_axes`): three
//! axes per tile from the blurred normal histograms of `tile_normal_histogram` (CPRC 3.2), integer and
//! exact.
use super::tile_normal_histogram::{params, size_for};
use crate::gbuffers::{normals, packed, GPattern};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::histogram_axes::all_axes;
use vxgi_cpu_mirror::octahedral::{reweight_table, BIN_COUNT};
use vxgi_cpu_mirror::tile_normal_histogram::histograms;
use vxgi_harness::prelude::*;

vxgi_harness::bindings! {
    /// histogram_axes' bindings: each tile's raw and blurred histograms in, its three axes out.
    pub struct Io {
        inputs: {
            /// The tile count.
            params: Vec<u32>,
            blurred: Vec<u32>,
            histogram: Vec<u32>,
            reweight: Vec<u32>,
        }
        outputs: {
            // Integer argmax (lowest index on ties) and integer re-weighting: exact.
            axes: Vec<[u32; 4]> => Tolerance::Exact
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "histogram_axes",
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "axes" },
    mirror: "vxgi_cpu_mirror::histogram_axes::all_axes",
    summary: "three axes per tile by re-weighted histogram argmax (CPRC 3.2)",
);

/// Axes case from histograms (raw, blurred) of `tiles` tiles.
pub fn axes_case(
    shader: &Shader,
    ctx: &GpuContext,
    raw: &[u32],
    blurred: &[u32],
    label: String,
    seed: u64,
) -> Case {
    let tiles = raw.len() / BIN_COUNT;
    let io = Io {
        params: vec![tiles as u32],
        blurred: blurred.to_vec(),
        histogram: raw.to_vec(),
        reweight: reweight_table(),
        axes: vec![[0; 4]; tiles],
    };
    DECL.case_of(shader, ctx, &io, tiles as u64, label, seed)
}

pub struct HistogramAxes;

impl Kernel for HistogramAxes {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (raw, blurred) = if index % 3 == 2 {
            // Synthetic histograms: all zero, all equal, one hot bin, maximal counts, random.
            let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(index as u64));
            let tiles = 200;
            let mut raw = vec![0u32; tiles * BIN_COUNT];
            for t in 0..tiles {
                let h = &mut raw[t * BIN_COUNT..(t + 1) * BIN_COUNT];
                match t % 5 {
                    0 => {}
                    1 => h.fill(7),
                    2 => h[rng.random_range(0..BIN_COUNT)] = 4096,
                    3 => h.iter_mut().for_each(|x| *x = 64),
                    _ => h.iter_mut().for_each(|x| *x = rng.random_range(0..100)),
                }
            }
            let blurred: Vec<u32> = raw
                .chunks(BIN_COUNT)
                .flat_map(|h| {
                    vxgi_cpu_mirror::tile_normal_histogram::blur(h.try_into().expect("64 bins"))
                })
                .collect();
            (raw, blurred)
        } else {
            let (w, h, tile) = size_for(index);
            let n = packed(&normals(
                w,
                h,
                GPattern::family(index),
                seed.wrapping_add(index as u64),
            ));
            histograms(&n, &params(w, h, tile).expect("valid sizes"))
        };
        axes_case(
            shader,
            ctx,
            &raw,
            &blurred,
            format!("#{index} {} tiles", raw.len() / BIN_COUNT),
            seed,
        )
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(data);
        io.axes = all_axes(&io.blurred, &io.histogram, &io.reweight);
        io.outputs()
    }
}
