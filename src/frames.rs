//! Per-frame counters of a sequence of frames, read from the GPU context (never estimated):
//! `vxgi render --frames N --out DIR` writes them to `DIR/frames.csv`.
use vxgi_harness::Counters;

/// The CSV header of `frames.csv`, one row per frame (frames counted from 0).
pub const HEADER: &str = "frame,wall_ms,gpu_ms,submissions,pipelines_created,buffers_created,textures_created,bind_groups_created,upload_bytes,readback_bytes";

/// One frame: the wall clock of the whole per-frame call (scene update, planning, encoding,
/// submissions, the waits and readbacks; writing images excluded) and what the context counted.
#[derive(Clone, Debug)]
pub struct FrameRow {
    pub frame: u32,
    pub wall_ms: f64,
    pub counters: Counters,
}

impl FrameRow {
    pub fn gpu_ms(&self) -> f64 {
        self.counters.gpu_ns as f64 / 1e6
    }

    /// The row in [`HEADER`]'s columns.
    pub fn csv(&self) -> String {
        let c = &self.counters;
        format!(
            "{},{:.3},{:.3},{},{},{},{},{},{},{}",
            self.frame,
            self.wall_ms,
            self.gpu_ms(),
            c.submissions,
            c.pipelines_created,
            c.buffers_created,
            c.textures_created,
            c.bind_groups_created,
            c.upload_bytes,
            c.readback_bytes
        )
    }
}

/// Run `frame` on this thread and count what it did on the GPU (`vxgi_harness::thread_counters`:
/// other threads' work on a shared context is not the frame's). `ctx` is the frame's context.
pub fn counted<T>(
    ctx: &vxgi_harness::GpuContext,
    index: u32,
    frame: impl FnOnce() -> anyhow::Result<T>,
) -> anyhow::Result<(T, FrameRow)> {
    let _ = ctx;
    let before = vxgi_harness::thread_counters();
    let t = std::time::Instant::now();
    let out = frame()?;
    let wall_ms = t.elapsed().as_secs_f64() * 1e3;
    Ok((
        out,
        FrameRow {
            frame: index,
            wall_ms,
            counters: vxgi_harness::thread_counters().since(&before),
        },
    ))
}

/// `frames.csv`: [`HEADER`] and one line per row.
pub fn csv(rows: &[FrameRow]) -> String {
    let mut s = format!("{HEADER}\n");
    for r in rows {
        s.push_str(&r.csv());
        s.push('\n');
    }
    s
}

/// The median of `v` (0 when empty).
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// One line for the terminal: frames per second over the frames after the first (which builds what
/// the others reuse), their median wall and GPU ms and the median of wall / GPU.
pub fn summary(rows: &[FrameRow]) -> String {
    let later: Vec<&FrameRow> = rows.iter().skip(usize::from(rows.len() > 1)).collect();
    let wall: f64 = later.iter().map(|r| r.wall_ms).sum();
    let fps = if wall > 0.0 {
        later.len() as f64 / (wall / 1e3)
    } else {
        0.0
    };
    let ratio = median(
        later
            .iter()
            .filter(|r| r.counters.gpu_ns > 0)
            .map(|r| r.wall_ms / r.gpu_ms())
            .collect(),
    );
    format!(
        "{:.2} fps over {} frame{}{}: median wall {:.1} ms, GPU {:.1} ms, wall / GPU {:.2}; median {} submissions, {} buffers created, {} bytes read back per frame",
        fps,
        later.len(),
        if later.len() == 1 { "" } else { "s" },
        if rows.len() > 1 { " after the first" } else { "" },
        median(later.iter().map(|r| r.wall_ms).collect()),
        median(later.iter().map(|r| r.gpu_ms()).collect()),
        ratio,
        median(later.iter().map(|r| r.counters.submissions as f64).collect()),
        median(later.iter().map(|r| r.counters.buffers_created as f64).collect()),
        median(later.iter().map(|r| r.counters.readback_bytes as f64).collect()),
    )
}
