//! Declaration of `kernels/tile_normal_histogram.wgsl` (mirror: `vxgi_cpu_mirror::tile_normal_histogram`):
//! the first stage of the clustered cache distribution (CPRC 3.2), integer and exact. Its output feeds
//! `histogram_axes`.
use crate::gbuffers::{normals, packed, GPattern};
use thiserror::Error;
use vxgi_cpu_mirror::octahedral::BIN_COUNT;
use vxgi_cpu_mirror::tile_normal_histogram::{histograms, HistogramParams};
use vxgi_harness::prelude::*;
use vxgi_harness::run::Pass;

/// Shared octahedral binning, included by both kernels.
pub const OCTAHEDRAL_BINS: (&str, &str) = (
    "kernels/common/octahedral_bins.wgsl",
    include_str!("../../kernels/common/octahedral_bins.wgsl"),
);

vxgi_harness::bindings! {
    /// tile_normal_histogram's bindings: packed normals in, each tile's histogram (raw and
    /// blurred, `BIN_COUNT` bins per tile) out.
    pub struct Io {
        inputs: {
            params: Block<HistogramParams>,
            normals: Vec<[u32; 2]>,
        }
        outputs: {
            // Integer counts and integer weighted sums: exact.
            histogram: Vec<u32> => Tolerance::Exact,
            blurred: Vec<u32> => Tolerance::Exact,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "tile_normal_histogram",
    includes: &[OCTAHEDRAL_BINS],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerItem {
        what: "screen tile: one workgroup of 64 (one per bin) per tile",
    },
    mirror: "vxgi_cpu_mirror::tile_normal_histogram::histograms",
    summary: "per-tile octahedral normal histogram and its wrapped binomial blur (CPRC 3.2)",
);

#[derive(Debug, Error, PartialEq)]
pub enum TileError {
    #[error(
        "tile size {0} must be 1..=64 (larger tiles could overflow the u32 re-weighted histogram)"
    )]
    TileSize(u32),
    #[error("G-buffer of {width}x{height} has no pixels")]
    Empty { width: u32, height: u32 },
    #[error("G-buffer holds {got} normals, {width}x{height} needs {want}")]
    Length {
        width: u32,
        height: u32,
        got: usize,
        want: usize,
    },
}

/// Parameters for a `width` x `height` G-buffer in tiles of `tile` pixels, checked.
pub fn params(width: u32, height: u32, tile: u32) -> Result<HistogramParams, TileError> {
    if !(1..=64).contains(&tile) {
        return Err(TileError::TileSize(tile));
    }
    if width == 0 || height == 0 {
        return Err(TileError::Empty { width, height });
    }
    Ok(HistogramParams {
        width,
        height,
        tile,
        tiles_x: width.div_ceil(tile),
    })
}

pub fn case_for(
    normals: &[[u32; 2]],
    p: HistogramParams,
    label: String,
    seed: u64,
) -> Result<Case, TileError> {
    let want = (p.width * p.height) as usize;
    if normals.len() != want {
        return Err(TileError::Length {
            width: p.width,
            height: p.height,
            got: normals.len(),
            want,
        });
    }
    let tiles_y = p.height.div_ceil(p.tile);
    let tiles = (p.tiles_x * tiles_y) as usize;
    let io = Io {
        params: Block(p),
        normals: normals.to_vec(),
        histogram: vec![0; tiles * BIN_COUNT],
        blurred: vec![0; tiles * BIN_COUNT],
    };
    let groups = [p.tiles_x, tiles_y, 1];
    let pass = Pass::direct("histograms", "main", DECL.bind_by_name(), groups);
    Ok(io
        .case(label, seed, vec![pass])
        .with_grid([BIN_COUNT as u32, p.tiles_x, tiles_y]))
}

/// The image sizes and tiles `vxgi verify` cycles through (including sizes not a multiple of the tile).
pub fn size_for(index: usize) -> (u32, u32, u32) {
    [
        (64, 64, 32),
        (100, 37, 32),
        (1, 1, 32),
        (33, 65, 16),
        (256, 144, 32),
        (96, 64, 64),
        (17, 9, 1),
    ][index % 7]
}

pub struct TileNormalHistogram;

impl Kernel for TileNormalHistogram {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, _ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (w, h, tile) = size_for(index);
        let pattern = GPattern::family(index);
        let n = packed(&normals(w, h, pattern, seed.wrapping_add(index as u64)));
        case_for(
            &n,
            params(w, h, tile).expect("valid sizes"),
            format!("#{index} {w}x{h} tile {tile} {pattern:?}"),
            seed,
        )
        .expect("valid case")
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(data);
        (io.histogram, io.blurred) = histograms(&io.normals, &io.params.0);
        io.outputs()
    }
}
