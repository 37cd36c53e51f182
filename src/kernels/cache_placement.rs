//! Declaration of `kernels/cache_placement.wgsl` (mirror: `vxgi_cpu_mirror::cache_placement`): placement
//! scores and one cache pixel per cluster (CPRC 3.2). Scores carry per-element bounds; a GPU pick is
//! accepted when the mirror's score for it is within the bounds of the mirror's best.
use super::cluster_extract::DistributionInputs;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::cache_placement::{best_pixels, score, score_bound};
use vxgi_cpu_mirror::cluster_extract::{extract, Cluster};
use vxgi_harness::prelude::*;
use vxgi_harness::run::Pass;

vxgi_harness::bindings! {
    /// cache_placement's bindings: the clusters and each pixel's cluster, normal and position in;
    /// each pixel's score and each cluster's pick out.
    pub struct Io {
        inputs: {
            /// The clusters, and one more (never empty).
            clusters: Structs<Cluster>,
            cluster_count: Vec<u32>,
            pixel_cluster: Vec<u32>,
            pixels: Vec<u32>,
            normals: Vec<[u32; 2]>,
            positions: Vec<[f32; 4]>,
        }
        outputs: {
            // Per element from the WGSL rules: sqrt and division 2.5 ULP, dots in any order, fused or
            // not, relative to the magnitudes of positions and box (see `score_bound`).
            scores: Vec<f32> => Tolerance::MirrorBound,
            // Exact after acceptance: the mirror takes the GPU's pick when its own score for that
            // pixel is within the score bounds of its best, else its own best (see
            // `accepted_picks`).
            picks: Vec<u32> => Tolerance::Exact,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "cache_placement",
    includes: &[super::tile_normal_histogram::OCTAHEDRAL_BINS],
    entry: "score_pixels",
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "scores" },
    mirror: "vxgi_cpu_mirror::cache_placement::score",
    summary: "placement score per pixel and the argmax pixel per cluster as its radiance cache (CPRC 3.2)",
);

pub fn case_for(ctx: &GpuContext, inp: &DistributionInputs, label: String, seed: u64) -> Case {
    let (clusters, pixel_cluster) = extract(
        &inp.sorted_keys,
        &inp.sorted_pixels,
        &inp.normals,
        &inp.positions,
    );
    let n = inp.normals.len();
    let mut all = clusters.clone();
    all.push(Cluster {
        start_count_key: [0; 4],
        normal_sum: [0; 4],
        bbox_min: [0.0; 4],
        bbox_max: [0.0; 4],
    }); // never empty
    let io = Io {
        cluster_count: vec![clusters.len() as u32],
        picks: vec![0; all.len()],
        clusters: Structs(all),
        pixel_cluster,
        pixels: inp.sorted_pixels.clone(),
        normals: inp.normals.clone(),
        positions: inp.positions.clone(),
        scores: vec![0.0; n],
    };
    let bindings = DECL.bind_by_name();
    let picks = io.picks.len() as u64;
    let passes = vec![
        Pass::linear(ctx, "scores", "score_pixels", bindings.clone(), n as u64),
        Pass::linear(ctx, "picks", "pick_caches", bindings, picks),
    ];
    io.case(label, seed, passes)
}

/// Mirror scores and bounds of every pixel.
pub fn mirror_scores(data: &Resources) -> (Vec<f32>, Vec<f32>) {
    let b = |n: &str| data[n].buffer().expect("buffer");
    let clusters: &[Cluster] = bytemuck::cast_slice(&b("clusters").bytes);
    let normals: &[[u32; 2]] = bytemuck::cast_slice(&b("normals").bytes);
    let positions: &[[f32; 4]] = bytemuck::cast_slice(&b("positions").bytes);
    let pc = b("pixel_cluster").as_u32();
    (0..normals.len())
        .map(|p| match pc[p] {
            u32::MAX => (0.0, 0.0),
            c => {
                let s = score(normals[p], positions[p], &clusters[c as usize]);
                (s, score_bound(positions[p], &clusters[c as usize], s))
            }
        })
        .unzip()
}

/// Per cluster the pick the GPU must have made: its own when the mirror's score for it is within the
/// bounds of the mirror's best (and it is a pixel of that cluster), else the mirror's best. Also
/// returns how many accepted GPU picks differ from the mirror's.
pub fn accepted_picks(data: &Resources, gpu_picks: &[u32]) -> (Vec<u32>, usize) {
    let b = |n: &str| data[n].buffer().expect("buffer");
    let count = b("cluster_count").as_u32()[0] as usize;
    let clusters: &[Cluster] = bytemuck::cast_slice(&b("clusters").bytes);
    let pc = b("pixel_cluster").as_u32();
    let (scores, bounds) = mirror_scores(data);
    let best = best_pixels(&clusters[..count], b("pixels").as_u32(), &scores);
    let mut differ = 0;
    let mut out: Vec<u32> = best
        .iter()
        .enumerate()
        .map(|(c, &m)| {
            let g = gpu_picks.get(c).copied().unwrap_or(u32::MAX);
            let ok = (g as usize) < pc.len()
                && pc[g as usize] == c as u32
                && scores[g as usize]
                    >= scores[m as usize] - (bounds[g as usize] + bounds[m as usize]);
            if ok && g != m {
                differ += 1;
            }
            if ok {
                g
            } else {
                m
            }
        })
        .collect();
    out.resize(gpu_picks.len(), 0);
    (out, differ)
}

pub struct CachePlacement;

impl Kernel for CachePlacement {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (inp, label) = super::cluster_extract::generated_distribution(seed, index);
        case_for(ctx, &inp, label, seed)
    }
    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let (scores, bounds) = mirror_scores(data);
        let (picks, _) = accepted_picks(data, data["picks"].buffer().expect("picks").as_u32());
        let mut out = BTreeMap::from(bounded("scores", &scores, &bounds));
        out.insert("picks".into(), HostBuffer::of(&picks));
        out
    }
}
