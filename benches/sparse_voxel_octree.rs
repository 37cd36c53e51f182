//! The sparse voxel octree on a lit Cornell box (the paper's setting: structure from all surface voxels,
//! values from direct light only): GPU time per phase (build, splat, transfer, distribution, work lists)
//! against the mirror's, the share of transfer and distribution work the active lists skip, and memory
//! against dense lattices. The GPU result is checked against the mirror (canonical form) first.
//!
//! `cargo bench --bench sparse_voxel_octree`
use std::time::Instant;
use vxgi::harness::GpuContext;
use vxgi::kernels::sparse_voxel_octree::{build_on_gpu, scene_fragments, MemoryReport};
use vxgi::scene::Scene;
use vxgi_cpu_mirror::sparse_voxel_octree::{canonical_bricks, canonical_nodes, Octree};

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn main() {
    let ctx = GpuContext::new().expect("GPU adapter (see README: install mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.describe());
    println!("| depth (leaf lattice) | fragments (lit) | nodes | memory: octree / dense lattices / vct-dense pyramids | phase | GPU ms | mirror ms | work skipped |");
    println!("|---|---|---|---|---|---|---|---|");
    for depth in [5u32, 6] {
        let scene = Scene::cornell_box();
        // Radiance up to ~10 per channel; 2^16 steps per unit keeps 64 x the largest sums below u32.
        let frags = scene_fragments(&ctx, &scene, depth, 4096.0).expect("fragments");
        let lit = frags.iter().filter(|f| f.value != [0; 4]).count();
        let gpu = build_on_gpu(&ctx, depth, &frags, None).expect("GPU build");
        // Warm runs: the best of three.
        let mut best = gpu;
        for _ in 0..2 {
            let g = build_on_gpu(&ctx, depth, &frags, None).expect("GPU build");
            if g.gpu_ns < best.gpu_ns {
                best = g;
            }
        }
        // The mirror, phase by phase.
        let mut o = Octree::empty(depth, best.octree.capacity_tiles);
        let t = Instant::now();
        o.build_structure(&frags);
        let m_build = ms(t);
        let t = Instant::now();
        o.splat(&frags);
        let m_splat = ms(t);
        let (mut m_lists, mut m_transfer, mut m_dist) = (0.0, 0.0, 0.0);
        // Threads the transfer and distribution launch against all nodes of each level.
        let (mut transfer_threads, mut transfer_all, mut dist_threads, mut dist_all) =
            (0u64, 0u64, 0u64, 0u64);
        for l in (0..=depth).rev() {
            let t = Instant::now();
            let (active, ring) = o.lists(l);
            m_lists += ms(t);
            let level_nodes = o.level_nodes(l).len() as u64;
            if l < depth {
                let t = Instant::now();
                for class in 0..4 {
                    o.distribute(&active, l, class);
                }
                m_dist += ms(t);
                dist_threads += active.len() as u64 * 27;
                dist_all += level_nodes * 27;
            }
            let t = Instant::now();
            for axis in 0..3 {
                o.transfer_add(&ring, axis);
                o.transfer_copy(&ring, axis);
            }
            m_transfer += ms(t);
            transfer_threads += ring.len() as u64 * 6;
            transfer_all += level_nodes * 6;
            if l < depth {
                // The level's one rounding, after its transfer: part of the distribution.
                let t = Instant::now();
                o.round_level(&ring);
                m_dist += ms(t);
            }
            if l > 0 {
                let t = Instant::now();
                o.mark_parents(&ring);
                m_lists += ms(t);
            }
        }
        assert!(
            canonical_nodes(&best.octree.nodes).0 == canonical_nodes(&o.nodes).0,
            "GPU structure differs from the mirror"
        );
        let (g, m) = (
            canonical_bricks(&best.octree.nodes, &best.octree.bricks),
            canonical_bricks(&o.nodes, &o.bricks),
        );
        let differ = g.iter().zip(&m).filter(|(a, b)| a != b).count();
        assert_eq!(
            differ, 0,
            "{differ} brick words differ between GPU and mirror"
        );
        let mem = MemoryReport::of(&best.octree);
        let phase = |name: &str| {
            best.phase_ns
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, ns)| format!("{:.2}", ns * 1e-6))
                .unwrap_or_else(|| "-".into())
        };
        let side = 2u32 << depth;
        let head = format!(
            "| {depth} ({}^3) | {} ({lit}) | {} | {:.1} / {:.1} / {:.1} MB |",
            side + 1,
            frags.len(),
            mem.nodes,
            mem.bytes as f64 / 1e6,
            mem.dense_bytes as f64 / 1e6,
            mem.vct_dense_bytes as f64 / 1e6
        );
        let skip = |done: u64, all: u64| {
            format!(
                "{:.0}% ({done} of {all} threads)",
                100.0 * (1.0 - done as f64 / all as f64)
            )
        };
        let rows = [
            ("build", m_build, String::new()),
            ("splat", m_splat, String::new()),
            ("work lists", m_lists, String::new()),
            ("transfer", m_transfer, skip(transfer_threads, transfer_all)),
            ("distribution", m_dist, skip(dist_threads, dist_all)),
        ];
        for (i, (name, m, s)) in rows.iter().enumerate() {
            let h = if i == 0 {
                head.clone()
            } else {
                "| | | | |".into()
            };
            println!("{h} {name} | {} | {m:.2} | {s} |", phase(name));
        }
        println!(
            "| | | | | total | {:.2} ({}) | {:.2} | |",
            best.gpu_ns * 1e-6,
            if best.phase_ns.is_empty() {
                "wall clock"
            } else {
                "timestamps"
            },
            m_build + m_splat + m_lists + m_transfer + m_dist
        );
    }
}
