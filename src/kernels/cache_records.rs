//! Declaration of `kernels/cache_records.wgsl` (mirror: `vxgi_cpu_mirror::cache_records`): the
//! radiance caches' records and the cache stages' indirect arguments from the clusters and picks of
//! the distribution (CPRC 3.2). Cases place caches with the distribution mirrors on generated
//! G-buffers, with capacities above, at and below the cluster count (overflow), and none.
use super::cluster_extract::DistributionInputs;
use vxgi_cpu_mirror::cache_records::{bounds, records, RecordsParams, ARGS_LEN};
use vxgi_cpu_mirror::cluster_extract::Cluster;
use vxgi_harness::prelude::*;
use vxgi_harness::run::Pass;

vxgi_harness::bindings! {
    /// cache_records' bindings: the distribution's clusters and picks and the G-buffer's normals and
    /// positions in; the caches' records and the cache stages' indirect arguments out.
    pub struct Io {
        inputs: {
            records_params: Block<RecordsParams>,
            clusters: Structs<Cluster>,
            cluster_count: Vec<u32>,
            picks: Vec<u32>,
            normals: Vec<[u32; 2]>,
            positions: Vec<[f32; 4]>,
        }
        outputs: {
            // The position copied; r_w a square root of a sum (see `cache_records::bounds`).
            cache_pos: Vec<[f32; 4]> => Tolerance::MirrorBound,
            // Integer division and remainder: exact.
            cache_pixel: Vec<[u32; 2]> => Tolerance::Exact,
            // A normalisation (see `cache_records::bounds`).
            cache_normal: Vec<[f32; 4]> => Tolerance::MirrorBound,
            caches: Vec<[f32; 4]> => Tolerance::MirrorBound,
            // Integer comparisons of neighbours' tiles, counts and workgroup arithmetic: exact.
            tile_ranges: Vec<[u32; 2]> => Tolerance::Exact,
            cache_count: Vec<u32> => Tolerance::Exact,
            cache_args: Vec<u32> => Tolerance::Exact,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "cache_records",
    includes: &[super::tile_normal_histogram::OCTAHEDRAL_BINS],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerItem {
        what: "cache slot up to the capacity (slot 0 also writes the count and the arguments)",
    },
    mirror: "vxgi_cpu_mirror::cache_records::records",
    summary: "radiance caches' records (position, radius, pixel, normal, creation origin, tile ranges) and the cache stages' indirect arguments from the clusters and picks (CPRC 3.2)",
);

/// The bindings for `capacity` caches over `tiles` screen tiles (outputs zeroed, one slot and one
/// tile at least), with these inputs; empty lists get one zero element (bindings cannot be empty).
fn io(
    p: RecordsParams,
    clusters: &[Cluster],
    picks: Vec<u32>,
    normals: Vec<[u32; 2]>,
    positions: Vec<[f32; 4]>,
    tiles: usize,
) -> Io {
    let c = p.capacity.max(1) as usize;
    Io {
        records_params: Block(p),
        clusters: Structs(if clusters.is_empty() {
            vec![bytemuck::Zeroable::zeroed()]
        } else {
            clusters.to_vec()
        }),
        cluster_count: vec![clusters.len() as u32],
        picks: if picks.is_empty() { vec![0] } else { picks },
        normals,
        positions,
        cache_pos: vec![[0.0; 4]; c],
        cache_pixel: vec![[0; 2]; c],
        cache_normal: vec![[0.0; 4]; c],
        caches: vec![[0.0; 4]; 2 * c],
        tile_ranges: vec![[0; 2]; tiles.max(1)],
        cache_count: vec![0],
        cache_args: vec![0; ARGS_LEN],
    }
}

/// The resources the kernel writes for `capacity` caches over `tiles` screen tiles, zeroed.
pub fn outputs(capacity: usize, tiles: usize) -> Resources {
    let p = RecordsParams {
        capacity: capacity as u32,
        ..bytemuck::Zeroable::zeroed()
    };
    let mut r = io(p, &[], vec![], vec![], vec![], tiles).resources();
    r.retain(|name, _| Io::OUTPUTS.iter().any(|o| o.binding == name));
    r
}

/// The pass over `p.capacity` slots (one at least: slot 0 writes the arguments).
pub fn pass(ctx: &GpuContext, p: &RecordsParams) -> Pass {
    let slots = p.capacity.max(1) as u64;
    Pass::linear(ctx, DECL.name, DECL.entry, DECL.bind_by_name(), slots)
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
    let io = io(
        p,
        &clusters,
        picks,
        inp.normals.clone(),
        inp.positions.clone(),
        tiles,
    );
    io.case(label, seed, vec![pass(ctx, &p)])
        .with_linear_indexing()
        .with_effective_bytes(clusters.len() as u64 * (64 + 4 + 16 + 16 + 8 + 16 + 32))
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

    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let io = Io::read(data);
        let p = io.records_params.0;
        let (clusters, positions) = (&io.clusters.0, &io.positions);
        let r = records(
            &p,
            clusters,
            io.cluster_count[0],
            &io.picks,
            &io.normals,
            positions,
            &vec![[0; 2]; io.tile_ranges.len()],
        );
        // Every slot up to the capacity: those without a cache keep their zeros.
        let slots = (p.capacity.max(1)) as usize;
        let pad = |mut v: Vec<[f32; 4]>, len: usize| {
            v.resize(len, [0.0; 4]);
            v
        };
        let (mut pos_b, mut nrm_b, mut cr_b) = (Vec::new(), Vec::new(), Vec::new());
        for c in 0..r.count as usize {
            let (bn, brw, bo) = bounds(&p, &clusters[c], positions[io.picks[c] as usize]);
            pos_b.push([0.0, 0.0, 0.0, brw]);
            nrm_b.push([bn, bn, bn, 0.0]);
            cr_b.extend([[bo[0], bo[1], bo[2], 0.0], [bn, bn, bn, 0.0]]);
        }
        let mut io = io;
        io.cache_pixel = r.cache_pixel;
        io.cache_pixel.resize(slots, [0; 2]);
        (io.cache_pos, io.cache_normal) = (pad(r.cache_pos, slots), pad(r.cache_normal, slots));
        io.caches = pad(r.caches, 2 * slots);
        (io.tile_ranges, io.cache_count, io.cache_args) =
            (r.tile_ranges, vec![r.count], r.args.to_vec());
        let mut out = io.outputs();
        out.extend([
            bound("cache_pos", &pad(pos_b, slots)),
            bound("cache_normal", &pad(nrm_b, slots)),
            bound("caches", &pad(cr_b, 2 * slots)),
        ]);
        out
    }
}
