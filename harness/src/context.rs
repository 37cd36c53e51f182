//! The GPU context: any wgpu adapter, or the caller's own device and queue.
use crate::error::{HarnessError, Result};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};

/// What a context has done on the GPU since it was created, counted where the harness does it (every
/// device object, upload, readback and submission of the harness goes through one of its counting
/// sites). Take a snapshot before and after a frame; [`Counters::since`] is the frame's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// `queue.submit` calls.
    pub submissions: u64,
    /// Compute pipelines compiled (the context caches them by source and entry point).
    pub pipelines_created: u64,
    /// Buffers created: resources, staging buffers for readback, timestamp resolve buffers.
    pub buffers_created: u64,
    pub textures_created: u64,
    pub bind_groups_created: u64,
    /// Bytes copied from the host into GPU memory (buffer contents at creation, texture writes,
    /// `write_buffer`).
    pub upload_bytes: u64,
    /// Bytes copied back to the host (mapped staging buffers), not counting the timestamp queries.
    pub readback_bytes: u64,
    /// GPU time of the dispatches, summed over submissions (timestamp queries where the adapter has
    /// them, else wall clock around submit and wait; [`GpuContext::timestamps`] says which).
    pub gpu_ns: u64,
}

impl Counters {
    /// What happened between `before` and this snapshot.
    pub fn since(&self, before: &Counters) -> Counters {
        Counters {
            submissions: self.submissions - before.submissions,
            pipelines_created: self.pipelines_created - before.pipelines_created,
            buffers_created: self.buffers_created - before.buffers_created,
            textures_created: self.textures_created - before.textures_created,
            bind_groups_created: self.bind_groups_created - before.bind_groups_created,
            upload_bytes: self.upload_bytes - before.upload_bytes,
            readback_bytes: self.readback_bytes - before.readback_bytes,
            gpu_ns: self.gpu_ns - before.gpu_ns,
        }
    }
}

/// The counters as atomics: the context is shared across threads (`GpuContext::shared`).
#[derive(Debug, Default)]
pub(crate) struct AtomicCounters {
    pub submissions: AtomicU64,
    pub pipelines_created: AtomicU64,
    pub buffers_created: AtomicU64,
    pub textures_created: AtomicU64,
    pub bind_groups_created: AtomicU64,
    pub upload_bytes: AtomicU64,
    pub readback_bytes: AtomicU64,
    pub gpu_ns: AtomicU64,
}

impl AtomicCounters {
    /// Add `n` to the context's counter `c` and to the calling thread's `field` of [`thread_counters`].
    pub fn add(c: &AtomicU64, n: u64, field: fn(&mut Counters) -> &mut u64) {
        c.fetch_add(n, Ordering::Relaxed);
        THREAD.with(|t| {
            let mut v = t.get();
            *field(&mut v) += n;
            t.set(v);
        });
    }
}

thread_local! {
    static THREAD: std::cell::Cell<Counters> = const { std::cell::Cell::new(Counters {
        submissions: 0,
        pipelines_created: 0,
        buffers_created: 0,
        textures_created: 0,
        bind_groups_created: 0,
        upload_bytes: 0,
        readback_bytes: 0,
        gpu_ns: 0,
    }) };
}

/// What the calling thread has done on GPU contexts so far. A frame is drawn by one thread, so the
/// difference of two snapshots around it is that frame's, whatever other threads (tests running in
/// parallel on the shared context) do meanwhile; [`GpuContext::counters`] is the context's total.
pub fn thread_counters() -> Counters {
    THREAD.with(|t| t.get())
}

/// A device and queue plus what the harness needs to know about them.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// Timestamp queries usable at pass boundaries (else timing is wall clock around submit + wait).
    pub timestamps: bool,
    /// Compiled pipelines by (WGSL source, entry point): a driver may compile lazily at first dispatch,
    /// which would otherwise land in every case's GPU time.
    pipelines: Mutex<HashMap<(String, String), wgpu::ComputePipeline>>,
    pub(crate) counts: AtomicCounters,
}

impl GpuContext {
    /// The adapter wgpu finds first on Vulkan, Metal or DX12, else on any backend (OpenGL), unless
    /// WGPU_BACKEND chooses (WGPU_ADAPTER_NAME is honoured too), with the adapter's own limits (wgpu's
    /// defaults cap buffers at 256 MiB) and timestamp queries when it has them. OpenGL comes last:
    /// Mesa's binds 16 storage buffers a stage, fewer than the cone passes need, and wgpu would pick
    /// it before a CPU Vulkan driver (lavapipe) that runs them all.
    pub fn new() -> Result<Self> {
        let chosen = wgpu::Backends::from_env().is_some();
        let tries: &[Option<wgpu::Backends>] = if chosen {
            &[None]
        } else {
            &[Some(wgpu::Backends::PRIMARY), None]
        };
        let mut last = String::new();
        for backends in tries {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
            if let Some(b) = backends {
                desc.backends = *b;
            }
            let instance = wgpu::Instance::new(desc);
            match pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            })) {
                Ok(adapter) => return Self::for_adapter(&adapter),
                Err(e) => last = e.to_string(),
            }
        }
        Err(HarnessError::NoAdapter(last))
    }

    /// A device on `adapter` (e.g. one chosen to present to a window's surface) as [`GpuContext::new`]
    /// requests it: the adapter's own limits and timestamp queries when it has them.
    pub fn for_adapter(adapter: &wgpu::Adapter) -> Result<Self> {
        let info = adapter.get_info();
        let wanted =
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
        let features = adapter.features() & wanted;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("vxgi-harness"),
            required_features: features,
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| HarnessError::RequestDevice {
            adapter: info.name.clone(),
            message: e.to_string(),
        })?;
        Ok(Self::from_device(device, queue, info))
    }

    /// Wrap a device the caller already owns (reuse in another renderer).
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue, info: wgpu::AdapterInfo) -> Self {
        let timestamps = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        Self {
            device,
            queue,
            info,
            timestamps,
            pipelines: Mutex::default(),
            counts: AtomicCounters::default(),
        }
    }

    /// A snapshot of what this context has done so far (see [`Counters`]).
    pub fn counters(&self) -> Counters {
        let c = &self.counts;
        let l = |a: &AtomicU64| a.load(Ordering::Relaxed);
        Counters {
            submissions: l(&c.submissions),
            pipelines_created: l(&c.pipelines_created),
            buffers_created: l(&c.buffers_created),
            textures_created: l(&c.textures_created),
            bind_groups_created: l(&c.bind_groups_created),
            upload_bytes: l(&c.upload_bytes),
            readback_bytes: l(&c.readback_bytes),
            gpu_ns: l(&c.gpu_ns),
        }
    }

    /// The compute pipeline of `entry` in `source` (auto layout), compiled once per context.
    pub fn pipeline(&self, source: &str, entry: &str, label: &str) -> wgpu::ComputePipeline {
        let key = (source.to_string(), entry.to_string());
        let mut cache = self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        cache
            .entry(key)
            .or_insert_with(|| {
                AtomicCounters::add(&self.counts.pipelines_created, 1, |c| {
                    &mut c.pipelines_created
                });
                let module = self
                    .device
                    .create_shader_module(wgpu::ShaderModuleDescriptor {
                        label: Some(label),
                        source: wgpu::ShaderSource::Wgsl(source.into()),
                    });
                self.device
                    .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(entry),
                        layout: None,
                        module: &module,
                        entry_point: Some(entry),
                        compilation_options: Default::default(),
                        cache: None,
                    })
            })
            .clone()
    }

    /// One context per process, created on first use; tests and the CLI share it.
    pub fn shared() -> Result<&'static GpuContext> {
        static SHARED: OnceLock<std::result::Result<GpuContext, String>> = OnceLock::new();
        match SHARED.get_or_init(|| GpuContext::new().map_err(|e| e.to_string())) {
            Ok(ctx) => Ok(ctx),
            Err(msg) => Err(HarnessError::Context(msg.clone())),
        }
    }

    /// "name (backend, device type, driver)" — artefacts and reports are labelled with it.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?}, driver {} {})",
            self.info.name,
            self.info.backend,
            self.info.device_type,
            self.info.driver,
            self.info.driver_info
        )
    }

    pub fn limits(&self) -> wgpu::Limits {
        self.device.limits()
    }
}
