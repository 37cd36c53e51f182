//! The GPU context: any wgpu adapter, or the caller's own device and queue.
use crate::error::{HarnessError, Result};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

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
}

impl GpuContext {
    /// First adapter wgpu finds (honours WGPU_BACKEND, WGPU_ADAPTER_NAME), with the adapter's own limits
    /// (wgpu's defaults cap buffers at 256 MiB) and timestamp queries when it has them.
    pub fn new() -> Result<Self> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| HarnessError::NoAdapter(e.to_string()))?;
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
        }
    }

    /// The compute pipeline of `entry` in `source` (auto layout), compiled once per context.
    pub fn pipeline(&self, source: &str, entry: &str, label: &str) -> wgpu::ComputePipeline {
        let key = (source.to_string(), entry.to_string());
        let mut cache = self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        cache
            .entry(key)
            .or_insert_with(|| {
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
