//! Declaration of `kernels/gather_caches.wgsl` (mirror: `vxgi_cpu_mirror::gather_caches`): CPRC 3.3
//! gathering weights. Cases place caches with the distribution mirrors (histograms, axes, keys, sort,
//! clusters, placement) on generated G-buffers.
use super::cluster_extract::DistributionInputs;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::cache_placement::{best_pixels, score};
use vxgi_cpu_mirror::cluster_extract::extract;
use vxgi_cpu_mirror::gather_caches::{
    gather, gather_bound, payload_max, GatherInputs, GatherParams,
};
use vxgi_cpu_mirror::octahedral::unpack;
use vxgi_harness::compare::bound_name;
use vxgi_harness::{
    Case, Check, DispatchRule, FloatMode, GpuContext, HostBuffer, HostResource, Indexing, Kernel,
    KernelDecl, Output, Resources, ScalarKind, Shader, Tolerance,
};

pub static DECL: KernelDecl = KernelDecl {
    name: "gather_caches",
    wgsl_path: "kernels/gather_caches.wgsl",
    wgsl: include_str!("../../kernels/gather_caches.wgsl"),
    includes: &[],
    entry: "main",
    inputs: &["params", "positions", "cache_pos", "cache_pixel", "cache_payload", "tile_ranges"],
    outputs: &[
        // Per element from the WGSL rules along the weight sums (see `gather_bound`).
        Output { binding: "gathered", tolerance: Tolerance::MirrorBound },
        Output { binding: "weight_sum", tolerance: Tolerance::MirrorBound },
        // Integer pixel-distance test: exact.
        Output { binding: "in_radius", tolerance: Tolerance::Exact },
    ],
    dispatch: DispatchRule::PerElement { binding: "weight_sum" },
    mirror: "vxgi_cpu_mirror::gather_caches::gather",
    summary: "per pixel, caches within the screen radius weighted min(w_w, w_s), normalised gather (CPRC 3.3)",
};

/// Caches placed on a G-buffer by the distribution mirrors: positions, pixels, normals (payload), and the
/// per-tile ranges.
pub struct Caches {
    pub pos: Vec<[f32; 4]>,
    pub pixel: Vec<[u32; 2]>,
    pub normal: Vec<[f32; 4]>,
    pub tile_ranges: Vec<[u32; 2]>,
}

pub fn place_caches(inp: &DistributionInputs) -> Caches {
    let (clusters, pixel_cluster) = extract(
        &inp.sorted_keys,
        &inp.sorted_pixels,
        &inp.normals,
        &inp.positions,
    );
    let scores: Vec<f32> = (0..inp.normals.len())
        .map(|p| match pixel_cluster[p] {
            u32::MAX => 0.0,
            c => score(inp.normals[p], inp.positions[p], &clusters[c as usize]),
        })
        .collect();
    let best = best_pixels(&clusters, &inp.sorted_pixels, &scores);
    let tiles_x = inp.width.div_ceil(inp.tile);
    let tiles = (tiles_x * inp.height.div_ceil(inp.tile)) as usize;
    let mut c = Caches {
        pos: Vec::new(),
        pixel: Vec::new(),
        normal: Vec::new(),
        tile_ranges: vec![[0, 0]; tiles],
    };
    for (i, &p) in best.iter().enumerate() {
        let (x, y) = (p % inp.width, p / inp.width);
        let q = unpack(inp.normals[p as usize]).unwrap_or([0, 0, 32767]);
        // r_w: 1.5 x the cluster's bounding-box diagonal (every pixel of the cluster lies within the
        // diagonal of the cache, which is one of them), at least 1e-3 scene units.
        let cl = &clusters[i];
        let diag = (0..3)
            .map(|a| (cl.bbox_max[a] - cl.bbox_min[a]).powi(2))
            .sum::<f32>()
            .sqrt();
        let wp = inp.positions[p as usize];
        c.pos.push([wp[0], wp[1], wp[2], (1.5 * diag).max(1.0e-3)]);
        c.pixel.push([x, y]);
        c.normal.push([
            q[0] as f32 / 32767.0,
            q[1] as f32 / 32767.0,
            q[2] as f32 / 32767.0,
            1.0,
        ]);
        let t = ((y / inp.tile) * tiles_x + x / inp.tile) as usize;
        if c.tile_ranges[t][1] == 0 {
            c.tile_ranges[t][0] = i as u32;
        }
        c.tile_ranges[t][1] = i as u32 + 1;
    }
    c
}

/// Pixel positions with w = 1 on geometry, 0 on background.
pub fn geometry_positions(inp: &DistributionInputs) -> Vec<[f32; 4]> {
    inp.positions
        .iter()
        .zip(&inp.normals)
        .map(|(p, n)| [p[0], p[1], p[2], if n[1] >> 16 == 1 { 1.0 } else { 0.0 }])
        .collect()
}

pub fn case_for(
    shader: &Shader,
    ctx: &GpuContext,
    inp: &DistributionInputs,
    label: String,
    seed: u64,
) -> Case {
    let caches = place_caches(inp);
    let n = inp.normals.len();
    let p = GatherParams {
        width: inp.width,
        height: inp.height,
        tile: inp.tile,
        tiles_x: inp.width.div_ceil(inp.tile),
        tiles_y: inp.height.div_ceil(inp.tile),
        radius_px: 2 * inp.tile,
        _pad: [0; 2],
    };
    let nonempty = |v: &[[f32; 4]]| {
        if v.is_empty() {
            vec![[0.0; 4]]
        } else {
            v.to_vec()
        }
    };
    let f4 =
        |v: &[[f32; 4]]| HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(&nonempty(v))));
    let mut resources = Resources::new();
    resources.insert("params".into(), HostResource::Buffer(HostBuffer::pod(&p)));
    resources.insert("positions".into(), f4(&geometry_positions(inp)));
    resources.insert("cache_pos".into(), f4(&caches.pos));
    let pixels = if caches.pixel.is_empty() {
        vec![[0u32; 2]]
    } else {
        caches.pixel.clone()
    };
    resources.insert(
        "cache_pixel".into(),
        HostResource::Buffer(HostBuffer::u32(bytemuck::cast_slice(&pixels))),
    );
    resources.insert("cache_payload".into(), f4(&caches.normal));
    resources.insert(
        "tile_ranges".into(),
        HostResource::Buffer(HostBuffer::u32(bytemuck::cast_slice(&caches.tile_ranges))),
    );
    resources.insert(
        "gathered".into(),
        HostResource::Buffer(HostBuffer::zeroed(n * 16, ScalarKind::F32)),
    );
    resources.insert(
        "weight_sum".into(),
        HostResource::Buffer(HostBuffer::zeroed(n * 4, ScalarKind::F32)),
    );
    resources.insert(
        "in_radius".into(),
        HostResource::Buffer(HostBuffer::zeroed(n * 4, ScalarKind::U32)),
    );
    let bindings = DECL.bind_by_name();
    Case {
        label,
        seed,
        passes: vec![DECL.pass(shader, ctx, "gather".into(), bindings, n as u64)],
        resources,
        checks: ["gathered", "weight_sum", "in_radius"]
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

pub struct GatherCaches;

impl Kernel for GatherCaches {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (inp, label) = super::cluster_extract::generated_distribution(seed, index);
        case_for(shader, ctx, &inp, label, seed)
    }
    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        let b = |n: &str| data[n].buffer().expect("buffer");
        let p: GatherParams = *bytemuck::from_bytes(&b("params").bytes);
        let inp = GatherInputs {
            positions: bytemuck::cast_slice(&b("positions").bytes),
            cache_pos: bytemuck::cast_slice(&b("cache_pos").bytes),
            cache_pixel: bytemuck::cast_slice(&b("cache_pixel").bytes),
            cache_payload: bytemuck::cast_slice(&b("cache_payload").bytes),
            tile_ranges: bytemuck::cast_slice(&b("tile_ranges").bytes),
        };
        let n = (p.width * p.height) as usize;
        let (mut g, mut ws, mut cnt, mut gb, mut wb) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let vmax = payload_max(inp.cache_payload);
        for i in 0..n {
            let r = gather(&p, &inp, i);
            let (gi, wi, ci) = r;
            let (gbi, wbi) = gather_bound(r, vmax);
            g.push(gi);
            ws.push(wi);
            cnt.push(ci);
            gb.push(gbi);
            wb.push(wbi);
        }
        BTreeMap::from([
            (
                "gathered".to_string(),
                HostBuffer::f32(bytemuck::cast_slice(&g)),
            ),
            (
                bound_name("gathered"),
                HostBuffer::f32(bytemuck::cast_slice(&gb)),
            ),
            ("weight_sum".to_string(), HostBuffer::f32(&ws)),
            (bound_name("weight_sum"), HostBuffer::f32(&wb)),
            ("in_radius".to_string(), HostBuffer::u32(&cnt)),
        ])
    }
}
