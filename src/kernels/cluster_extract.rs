//! Declaration of `kernels/cluster_extract.wgsl` (mirror: `vxgi_cpu_mirror::cluster_extract`): clusters
//! from key-sorted pixels (CPRC 3.2), exact. Cases run the keys and sort mirrors on generated G-buffers.
use super::cluster_keys::{depths, sanitise};
use crate::gbuffers::{normals, packed, GPattern};
use bytemuck::Zeroable;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::cluster_extract::{extract, heads, Cluster};
use vxgi_cpu_mirror::cluster_keys::{axis_directions, keys, slice_bounds, KeyInputs, KeyParams};
use vxgi_cpu_mirror::histogram_axes::all_axes;
use vxgi_cpu_mirror::octahedral::reweight_table;
use vxgi_cpu_mirror::radix_sort::sort;
use vxgi_cpu_mirror::tile_normal_histogram::histograms;
use vxgi_harness::run::{grid_for, Pass, Workgroups};
use vxgi_harness::{
    Case, Check, DispatchRule, FloatMode, GpuContext, HostBuffer, HostResource, Indexing, Kernel,
    KernelDecl, Output, Resources, ScalarKind, Shader, Tolerance,
};

pub static DECL: KernelDecl = KernelDecl {
    name: "cluster_extract",
    wgsl_path: "kernels/cluster_extract.wgsl",
    wgsl: include_str!("../../kernels/cluster_extract.wgsl"),
    includes: &[super::tile_normal_histogram::OCTAHEDRAL_BINS, super::BLOCK_SCAN],
    entry: "mark_heads",
    inputs: &["params", "keys", "pixels", "normals", "positions"],
    // Comparisons, integer sums and min/max: exact.
    outputs: &[
        Output { binding: "heads", tolerance: Tolerance::Exact },
        Output { binding: "cluster_count", tolerance: Tolerance::Exact },
        Output { binding: "clusters", tolerance: Tolerance::Exact },
        Output { binding: "pixel_cluster", tolerance: Tolerance::Exact },
    ],
    dispatch: DispatchRule::PerElement { binding: "heads" },
    mirror: "vxgi_cpu_mirror::cluster_extract::extract",
    summary: "clusters of key-sorted pixels: heads, prefix sum, per-cluster normal sum and bounding box (CPRC 3.2)",
};

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
#[allow(clippy::too_many_arguments)]
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
    let p = KeyParams {
        width,
        height,
        tile,
        tiles_x: hp.tiles_x,
        slices,
        _pad: [0; 3],
    };
    let mut bounds = slice_bounds(
        super::cluster_keys::SLICE_NEAR,
        super::cluster_keys::SLICE_FAR,
        slices,
    );
    bounds.push(f32::INFINITY);
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
    let mut resources = Resources::new();
    resources.insert(
        "params".into(),
        HostResource::Buffer(HostBuffer::u32(&[n as u32])),
    );
    resources.insert(
        "keys".into(),
        HostResource::Buffer(HostBuffer::u32(&inp.sorted_keys)),
    );
    resources.insert(
        "pixels".into(),
        HostResource::Buffer(HostBuffer::u32(&inp.sorted_pixels)),
    );
    resources.insert(
        "normals".into(),
        HostResource::Buffer(HostBuffer::u32(bytemuck::cast_slice(&inp.normals))),
    );
    resources.insert(
        "positions".into(),
        HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(&inp.positions))),
    );
    resources.insert(
        "heads".into(),
        HostResource::Buffer(HostBuffer::zeroed(n * 4, ScalarKind::U32)),
    );
    resources.insert(
        "cluster_count".into(),
        HostResource::Buffer(HostBuffer::zeroed(4, ScalarKind::U32)),
    );
    resources.insert(
        "clusters".into(),
        HostResource::Buffer(HostBuffer::zeroed(
            n * std::mem::size_of::<Cluster>(),
            ScalarKind::Mixed,
        )),
    );
    resources.insert(
        "pixel_cluster".into(),
        HostResource::Buffer(HostBuffer::u32(&vec![u32::MAX; n])),
    );
    resources.insert("scan_partials".into(), super::scan_partials(n));
    let mut bindings = DECL.bind_by_name();
    bindings.push((
        "scan_partials".into(),
        vxgi_harness::View::Buffer("scan_partials".into()),
    ));
    let max = ctx.limits().max_compute_workgroups_per_dimension;
    let grid = grid_for(n as u64, 64, max);
    let pass = |entry: &str| Pass {
        label: entry.into(),
        entry: entry.into(),
        bindings: bindings.clone(),
        workgroups: Workgroups::Direct(grid),
    };
    let mut passes = vec![pass("mark_heads")];
    passes.extend(super::scan_passes(&bindings, n, max, "heads"));
    passes.push(pass("build_clusters"));
    Case {
        label,
        seed,
        resources,
        passes,
        checks: ["heads", "cluster_count", "clusters", "pixel_cluster"]
            .iter()
            .map(|r| Check {
                resource: r.to_string(),
                output: r,
                indexing: Indexing::Linear,
            })
            .collect(),
        effective_bytes: n as u64 * 40,
    }
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
    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        let b = |n: &str| data[n].buffer().expect("buffer");
        let k = b("keys").as_u32();
        let (clusters, pixel_cluster) = extract(
            k,
            b("pixels").as_u32(),
            bytemuck::cast_slice(&b("normals").bytes),
            bytemuck::cast_slice(&b("positions").bytes),
        );
        let h = heads(k);
        let mut scanned = Vec::with_capacity(h.len());
        let mut acc = 0u32;
        for x in &h {
            scanned.push(acc);
            acc += x;
        }
        let mut all = vec![Cluster::zeroed(); k.len()];
        all[..clusters.len()].copy_from_slice(&clusters);
        BTreeMap::from([
            ("heads".to_string(), HostBuffer::u32(&scanned)),
            ("cluster_count".to_string(), HostBuffer::u32(&[acc])),
            (
                "clusters".to_string(),
                HostBuffer {
                    bytes: bytemuck::cast_slice(&all).to_vec(),
                    scalar: ScalarKind::Mixed,
                },
            ),
            ("pixel_cluster".to_string(), HostBuffer::u32(&pixel_cluster)),
        ])
    }
}
