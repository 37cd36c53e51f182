//! Declaration of `kernels/cache_records.wgsl` (mirror: `vxgi_cpu_mirror::cache_records`): the
//! radiance caches' records and the cache stages' indirect arguments from the clusters and picks of
//! the distribution (CPRC 3.2). Cases place caches with the distribution mirrors on generated
//! G-buffers, with capacities above, at and below the cluster count (overflow), and none.
use super::cluster_extract::DistributionInputs;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::cache_records::{bounds, records, RecordsParams, ARGS_LEN};
use vxgi_cpu_mirror::cluster_extract::Cluster;
use vxgi_harness::compare::bound_name;
use vxgi_harness::run::{grid_for, Pass, Workgroups};
use vxgi_harness::{
    Case, Check, DispatchRule, FloatMode, GpuContext, HostBuffer, HostResource, Indexing, Kernel,
    KernelDecl, Output, Resources, ScalarKind, Shader, Tolerance,
};

pub static DECL: KernelDecl = KernelDecl {
    name: "cache_records",
    wgsl_path: "kernels/cache_records.wgsl",
    wgsl: include_str!("../../kernels/cache_records.wgsl"),
    includes: &[super::tile_normal_histogram::OCTAHEDRAL_BINS],
    entry: "main",
    inputs: &[
        "records_params",
        "clusters",
        "cluster_count",
        "picks",
        "normals",
        "positions",
    ],
    outputs: &[
        // The position copied; r_w a square root of a sum (see `cache_records::bounds`).
        Output { binding: "cache_pos", tolerance: Tolerance::MirrorBound },
        // Integer division and remainder: exact.
        Output { binding: "cache_pixel", tolerance: Tolerance::Exact },
        // A normalisation (see `cache_records::bounds`).
        Output { binding: "cache_normal", tolerance: Tolerance::MirrorBound },
        Output { binding: "caches", tolerance: Tolerance::MirrorBound },
        // Integer comparisons of neighbours' tiles, counts and workgroup arithmetic: exact.
        Output { binding: "tile_ranges", tolerance: Tolerance::Exact },
        Output { binding: "cache_count", tolerance: Tolerance::Exact },
        Output { binding: "cache_args", tolerance: Tolerance::Exact },
    ],
    dispatch: DispatchRule::PerItem {
        what: "cache slot up to the capacity (slot 0 also writes the count and the arguments)",
    },
    mirror: "vxgi_cpu_mirror::cache_records::records",
    summary: "radiance caches' records (position, radius, pixel, normal, creation origin, tile ranges) and the cache stages' indirect arguments from the clusters and picks (CPRC 3.2)",
};

/// The resources the kernel writes for `capacity` caches over `tiles` screen tiles, zeroed.
pub fn outputs(capacity: usize, tiles: usize) -> Resources {
    let z = |bytes: usize, s: ScalarKind| HostResource::Buffer(HostBuffer::zeroed(bytes, s));
    let c = capacity.max(1);
    Resources::from([
        ("cache_pos".into(), z(c * 16, ScalarKind::F32)),
        ("cache_pixel".into(), z(c * 8, ScalarKind::U32)),
        ("cache_normal".into(), z(c * 16, ScalarKind::F32)),
        ("caches".into(), z(c * 32, ScalarKind::F32)),
        ("tile_ranges".into(), z(tiles.max(1) * 8, ScalarKind::U32)),
        ("cache_count".into(), z(4, ScalarKind::U32)),
        ("cache_args".into(), z(ARGS_LEN * 4, ScalarKind::U32)),
    ])
}

/// The pass over `p.capacity` slots (one at least: slot 0 writes the arguments).
pub fn pass(ctx: &GpuContext, p: &RecordsParams) -> Pass {
    Pass {
        label: DECL.name.into(),
        entry: DECL.entry.into(),
        bindings: DECL.bind_by_name(),
        workgroups: Workgroups::Direct(grid_for(
            p.capacity.max(1) as u64,
            64,
            ctx.limits().max_compute_workgroups_per_dimension,
        )),
    }
}

/// A case over the clusters and picks the distribution mirrors give `inp`, with `p`.
pub fn case_for(
    ctx: &GpuContext,
    inp: &DistributionInputs,
    p: RecordsParams,
    label: String,
    seed: u64,
) -> Case {
    let (clusters, picks) = super::gather_caches::clusters_and_picks(inp);
    let tiles = (p.tiles_x * inp.height.div_ceil(p.tile)) as usize;
    let mut resources = outputs(p.capacity as usize, tiles);
    let nonempty = |v: Vec<u32>| if v.is_empty() { vec![0] } else { v };
    resources.insert(
        "records_params".into(),
        HostResource::Buffer(HostBuffer::pod(&p)),
    );
    let cl: Vec<Cluster> = if clusters.is_empty() {
        vec![bytemuck::Zeroable::zeroed()]
    } else {
        clusters.clone()
    };
    resources.insert(
        "clusters".into(),
        HostResource::Buffer(HostBuffer {
            bytes: bytemuck::cast_slice(&cl).to_vec(),
            scalar: ScalarKind::Mixed,
        }),
    );
    resources.insert(
        "cluster_count".into(),
        HostResource::Buffer(HostBuffer::u32(&[clusters.len() as u32])),
    );
    resources.insert(
        "picks".into(),
        HostResource::Buffer(HostBuffer::u32(&nonempty(picks))),
    );
    resources.insert(
        "normals".into(),
        HostResource::Buffer(HostBuffer::u32(bytemuck::cast_slice(&inp.normals))),
    );
    resources.insert(
        "positions".into(),
        HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(&inp.positions))),
    );
    let check = |name: &'static str| Check {
        resource: name.into(),
        output: name,
        indexing: Indexing::Linear,
    };
    Case {
        label,
        seed,
        passes: vec![pass(ctx, &p)],
        resources,
        checks: [
            "cache_pos",
            "cache_pixel",
            "cache_normal",
            "caches",
            "tile_ranges",
            "cache_count",
            "cache_args",
        ]
        .map(check)
        .to_vec(),
        effective_bytes: clusters.len() as u64 * (64 + 4 + 16 + 16 + 8 + 16 + 32),
    }
}

/// The parameters for `inp` with `capacity` slots, caches of `texels` (mips: `mips` per cache, 0
/// without) and irradiance maps of `irr_texels`, cones starting `offset` off the surface.
pub fn params(
    ctx: &GpuContext,
    inp: &DistributionInputs,
    capacity: u32,
    per: [u32; 3],
    offset: f32,
) -> RecordsParams {
    RecordsParams {
        width: inp.width,
        tile: inp.tile,
        tiles_x: inp.width.div_ceil(inp.tile),
        capacity,
        per,
        max_groups: ctx.limits().max_compute_workgroups_per_dimension,
        offset,
        _pad: [0; 3],
    }
}

pub struct CacheRecords;

impl Kernel for CacheRecords {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (inp, label) = super::cluster_extract::generated_distribution(seed, index);
        // Capacities: ample, exactly the pixels, a handful (overflow) and one.
        let n = inp.normals.len() as u32;
        let capacity = [n, n.div_ceil(2).max(1), 7, 1][index % 4];
        let per = [[256, 341, 64], [64, 0, 16], [1, 1, 1], [4096, 5461, 4096]][index % 4];
        let offset = [0.01, 0.0, -0.5, 3.0][index % 4];
        let p = params(ctx, &inp, capacity, per, offset);
        case_for(ctx, &inp, p, format!("{label} capacity {capacity}"), seed)
    }

    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        let b = |k: &str| &data[k].buffer().expect("a buffer").bytes;
        let p: RecordsParams = *bytemuck::from_bytes(b("records_params"));
        let clusters: &[Cluster] = bytemuck::cast_slice(b("clusters"));
        let count = bytemuck::cast_slice::<u8, u32>(b("cluster_count"))[0];
        let picks: &[u32] = bytemuck::cast_slice(b("picks"));
        let normals: &[[u32; 2]] = bytemuck::cast_slice(b("normals"));
        let positions: &[[f32; 4]] = bytemuck::cast_slice(b("positions"));
        let tiles = b("tile_ranges").len() / 8;
        let r = records(
            &p,
            clusters,
            count,
            picks,
            normals,
            positions,
            &vec![[0; 2]; tiles],
        );
        // Every slot up to the capacity: those without a cache keep their zeros.
        let slots = (p.capacity.max(1)) as usize;
        let pad = |mut v: Vec<[f32; 4]>, len: usize| {
            v.resize(len, [0.0; 4]);
            v
        };
        let (mut pos_b, mut nrm_b, mut cr_b) = (Vec::new(), Vec::new(), Vec::new());
        for c in 0..r.count as usize {
            let (bn, brw, bo) = bounds(&p, &clusters[c], positions[picks[c] as usize]);
            pos_b.push([0.0, 0.0, 0.0, brw]);
            nrm_b.push([bn, bn, bn, 0.0]);
            cr_b.extend([[bo[0], bo[1], bo[2], 0.0], [bn, bn, bn, 0.0]]);
        }
        let mut pixel = r.cache_pixel.clone();
        pixel.resize(slots, [0; 2]);
        let f = |v: Vec<[f32; 4]>| HostBuffer::f32(bytemuck::cast_slice(&v));
        BTreeMap::from([
            ("cache_pos".to_string(), f(pad(r.cache_pos, slots))),
            (bound_name("cache_pos"), f(pad(pos_b, slots))),
            (
                "cache_pixel".to_string(),
                HostBuffer::u32(bytemuck::cast_slice(&pixel)),
            ),
            ("cache_normal".to_string(), f(pad(r.cache_normal, slots))),
            (bound_name("cache_normal"), f(pad(nrm_b, slots))),
            ("caches".to_string(), f(pad(r.caches, 2 * slots))),
            (bound_name("caches"), f(pad(cr_b, 2 * slots))),
            (
                "tile_ranges".to_string(),
                HostBuffer::u32(bytemuck::cast_slice(&r.tile_ranges)),
            ),
            ("cache_count".to_string(), HostBuffer::u32(&[r.count])),
            ("cache_args".to_string(), HostBuffer::u32(&r.args)),
        ])
    }
}
