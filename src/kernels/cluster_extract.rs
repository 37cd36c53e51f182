//! Declaration of `kernels/cluster_extract.wgsl` (mirror: `vxgi_cpu_mirror::cluster_extract`): clusters
//! from key-sorted pixels (CPRC 3.2), exact. Cases run the keys and sort mirrors on generated G-buffers.
use super::cluster_keys::{depths, sanitise};
use crate::gbuffers::{normals, packed, GPattern};
use bytemuck::Zeroable;
use vxgi_cpu_mirror::cluster_extract::{extract, heads, Cluster};
use vxgi_cpu_mirror::cluster_keys::{axis_directions, keys, KeyInputs};
use vxgi_cpu_mirror::histogram_axes::all_axes;
use vxgi_cpu_mirror::octahedral::reweight_table;
use vxgi_cpu_mirror::radix_sort::sort;
use vxgi_cpu_mirror::tile_normal_histogram::histograms;
use vxgi_harness::prelude::*;
use vxgi_harness::run::{grid_for, Pass};

vxgi_harness::bindings! {
    /// cluster_extract's bindings: key-sorted pixels with their normals and positions in; the
    /// heads' prefix sum, the cluster count, the clusters and each pixel's cluster out.
    pub struct Io {
        inputs: {
            /// The pixel count.
            params: Vec<u32>,
            keys: Vec<u32>,
            pixels: Vec<u32>,
            normals: Vec<[u32; 2]>,
            positions: Vec<[f32; 4]>,
        }
        // Comparisons, integer sums and min/max: exact.
        outputs: {
            heads: Vec<u32> => Tolerance::Exact,
            cluster_count: Vec<u32> => Tolerance::Exact,
            /// One slot per pixel; the first `cluster_count` hold clusters.
            clusters: Structs<Cluster> => Tolerance::Exact,
            /// `u32::MAX` before the kernel: "no cluster".
            pixel_cluster: Vec<u32> => Tolerance::Exact,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "cluster_extract",
    includes: &[super::tile_normal_histogram::OCTAHEDRAL_BINS, super::BLOCK_SCAN],
    entry: "mark_heads",
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "heads" },
    mirror: "vxgi_cpu_mirror::cluster_extract::extract",
    summary: "clusters of key-sorted pixels: heads, prefix sum, per-cluster normal sum and bounding box (CPRC 3.2)",
);

/// World positions for a generated G-buffer: the pixel's view ray at its depth.
pub fn positions(width: u32, height: u32, depth: &[f32]) -> Vec<[f32; 4]> {
    (0..width * height)
        .map(|i| {
            let (u, v) = (
                ((i % width) as f32 + 0.5) / width as f32 - 0.5,
                ((i / width) as f32 + 0.5) / height as f32 - 0.5,
            );
            let d = depth[i as usize];
            [u * d, v * d, d, 1.0]
        })
        .collect()
}

/// Everything the distribution kernels read for one generated G-buffer, computed by the mirrors.
pub struct DistributionInputs {
    pub width: u32,
    pub height: u32,
    pub tile: u32,
    pub normals: Vec<[u32; 2]>,
    pub positions: Vec<[f32; 4]>,
    pub sorted_keys: Vec<u32>,
    pub sorted_pixels: Vec<u32>,
}

pub fn distribution_inputs(
    width: u32,
    height: u32,
    tile: u32,
    slices: u32,
    pattern: GPattern,
    seed: u64,
) -> DistributionInputs {
    distribution_inputs_with_depth(
        width,
        height,
        tile,
        slices,
        pattern,
        seed,
        depths(width, height, slices, seed),
    )
}

/// [`distribution_inputs`] with the caller's depths (e.g. smooth ones, without the stress values).
pub fn distribution_inputs_with_depth(
    width: u32,
    height: u32,
    tile: u32,
    slices: u32,
    pattern: GPattern,
    seed: u64,
    d: Vec<f32>,
) -> DistributionInputs {
    let mut n = packed(&normals(width, height, pattern, seed));
    sanitise(&mut n, &d);
    let hp = super::tile_normal_histogram::params(width, height, tile).expect("valid sizes");
    let (raw, blurred) = histograms(&n, &hp);
    let tile_axes = all_axes(&blurred, &raw, &reweight_table());
    let (p, bounds) = super::cluster_keys::key_params(width, height, tile, slices, 1.0);
    let dirs = axis_directions();
    let k = keys(
        &p,
        &KeyInputs {
            normals: &n,
            depth: &d,
            tile_axes: &tile_axes,
            axis_dirs: &dirs,
            slice_bounds: &bounds,
        },
    );
    let (sorted_keys, sorted_pixels) = sort(&k, &(0..k.len() as u32).collect::<Vec<_>>(), 32);
    let positions = positions(width, height, &d);
    DistributionInputs {
        width,
        height,
        tile,
        normals: n,
        positions,
        sorted_keys,
        sorted_pixels,
    }
}

/// Case `index` of the distribution kernels' generator: the image sizes of `tile_normal_histogram`,
/// 16/1/2/32 depth slices, the G-buffer families of `gbuffers`; and its label.
pub fn generated_distribution(seed: u64, index: usize) -> (DistributionInputs, String) {
    let (w, h, tile) = super::tile_normal_histogram::size_for(index);
    let slices = [16, 1, 2, 32][index % 4];
    let inp = distribution_inputs(
        w,
        h,
        tile,
        slices,
        GPattern::family(index),
        seed.wrapping_add(index as u64),
    );
    (inp, format!("#{index} {w}x{h} tile {tile} {slices} slices"))
}

pub fn case_for(ctx: &GpuContext, inp: &DistributionInputs, label: String, seed: u64) -> Case {
    let n = inp.sorted_keys.len();
    let io = Io {
        params: vec![n as u32],
        keys: inp.sorted_keys.clone(),
        pixels: inp.sorted_pixels.clone(),
        normals: inp.normals.clone(),
        positions: inp.positions.clone(),
        heads: vec![0; n],
        cluster_count: vec![0],
        clusters: Structs(vec![Cluster::zeroed(); n]),
        pixel_cluster: vec![u32::MAX; n],
    };
    let mut bindings = DECL.bind_by_name();
    bindings.push((
        "scan_partials".into(),
        vxgi_harness::View::Buffer("scan_partials".into()),
    ));
    let max = ctx.limits().max_compute_workgroups_per_dimension;
    let grid = grid_for(n as u64, 64, max);
    let pass = |entry: &str| Pass::direct(entry, entry, bindings.clone(), grid);
    let mut passes = vec![pass("mark_heads")];
    passes.extend(super::scan_passes(&bindings, n, max, "heads"));
    passes.push(pass("build_clusters"));
    let mut case = io.case(label, seed, passes);
    case.resources
        .insert("scan_partials".into(), super::scan_partials(n));
    case
}

pub struct ClusterExtract;

impl Kernel for ClusterExtract {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (inp, label) = generated_distribution(seed, index);
        case_for(ctx, &inp, label, seed)
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(data);
        let clusters;
        (clusters, io.pixel_cluster) = extract(&io.keys, &io.pixels, &io.normals, &io.positions);
        let mut acc = 0u32;
        io.heads = heads(&io.keys)
            .iter()
            .map(|x| {
                acc += x;
                acc - x
            })
            .collect();
        io.cluster_count = vec![acc];
        io.clusters.0.fill(Cluster::zeroed());
        io.clusters.0[..clusters.len()].copy_from_slice(&clusters);
        io.outputs()
    }
}
