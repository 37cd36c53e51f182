//! Host resources, passes, the pre-dispatch checks against reflection, dispatch, readback and timing.
use crate::context::GpuContext;
use crate::error::{HarnessError, Result};
use crate::shader::{BindingKind, BufferLayout, ScalarKind, Shader};
use std::collections::BTreeMap;
use std::time::Instant;
use wgpu::util::DeviceExt;

/// Add `n` to counter `field` of [`crate::context::Counters`], for `ctx` and the calling thread.
macro_rules! count {
    ($ctx:expr, $field:ident, $n:expr) => {
        crate::context::AtomicCounters::add(&$ctx.counts.$field, $n, |c| &mut c.$field)
    };
}

/// Bytes of a buffer plus the scalar they hold (checked against the WGSL element type).
#[derive(Clone, Debug, PartialEq)]
pub struct HostBuffer {
    pub bytes: Vec<u8>,
    pub scalar: ScalarKind,
}

impl HostBuffer {
    pub fn f32(data: &[f32]) -> Self {
        Self {
            bytes: bytemuck::cast_slice(data).to_vec(),
            scalar: ScalarKind::F32,
        }
    }
    pub fn u32(data: &[u32]) -> Self {
        Self {
            bytes: bytemuck::cast_slice(data).to_vec(),
            scalar: ScalarKind::U32,
        }
    }
    /// A parameter block (`#[repr(C)]` struct); its layout is checked against WGSL in tests.
    pub fn pod<T: bytemuck::Pod>(value: &T) -> Self {
        Self {
            bytes: bytemuck::bytes_of(value).to_vec(),
            scalar: ScalarKind::Mixed,
        }
    }
    pub fn zeroed(len_bytes: usize, scalar: ScalarKind) -> Self {
        Self {
            bytes: vec![0; len_bytes],
            scalar,
        }
    }
    /// A buffer of `values`, its scalar kind that of their element type.
    pub fn of<E: crate::bindings::Element>(values: &[E]) -> Self {
        Self {
            bytes: bytemuck::cast_slice(values).to_vec(),
            scalar: E::SCALAR,
        }
    }
    /// A buffer of `#[repr(C)]` records (a WGSL array of structs; its stride is checked against
    /// the WGSL's).
    pub fn structs<T: bytemuck::Pod>(values: &[T]) -> Self {
        Self {
            bytes: bytemuck::cast_slice(values).to_vec(),
            scalar: ScalarKind::Mixed,
        }
    }
    /// The bytes as f32 (an empty buffer gives an empty slice: an empty Vec's pointer is not aligned).
    pub fn as_f32(&self) -> &[f32] {
        if self.bytes.is_empty() {
            return &[];
        }
        bytemuck::cast_slice(&self.bytes)
    }
    pub fn as_u32(&self) -> &[u32] {
        if self.bytes.is_empty() {
            return &[];
        }
        bytemuck::cast_slice(&self.bytes)
    }
}

/// A 1D/2D/3D (or 2D-array) texture with all its mip levels, each tightly packed (no row padding).
#[derive(Clone, Debug, PartialEq)]
pub struct HostTexture {
    pub format: wgpu::TextureFormat,
    pub dimension: wgpu::TextureDimension,
    /// Width, height, depth (3D) or layer count (2D arrays).
    pub size: [u32; 3],
    /// `levels[m]` holds mip `m`; the number of levels is the mip count.
    pub levels: Vec<Vec<u8>>,
}

impl HostTexture {
    /// A zero-filled texture with `mips` levels.
    pub fn zeroed(
        format: wgpu::TextureFormat,
        dimension: wgpu::TextureDimension,
        size: [u32; 3],
        mips: u32,
    ) -> Self {
        let mut t = Self {
            format,
            dimension,
            size,
            levels: Vec::new(),
        };
        t.levels = (0..mips).map(|m| vec![0; t.level_bytes(m)]).collect();
        t
    }
    pub fn texel_bytes(&self) -> usize {
        self.format.block_copy_size(None).unwrap_or(4) as usize
    }
    /// Extent of mip `m` (the layer count of a 2D array does not shrink).
    pub fn level_extent(&self, m: u32) -> [u32; 3] {
        let s = |v: u32| (v >> m).max(1);
        match self.dimension {
            wgpu::TextureDimension::D3 => [s(self.size[0]), s(self.size[1]), s(self.size[2])],
            _ => [s(self.size[0]), s(self.size[1]), self.size[2]],
        }
    }
    /// Format, dimension and size without the data.
    pub fn clone_shape(&self) -> Self {
        Self {
            format: self.format,
            dimension: self.dimension,
            size: self.size,
            levels: Vec::new(),
        }
    }
    pub fn level_bytes(&self, m: u32) -> usize {
        let [w, h, d] = self.level_extent(m);
        w as usize * h as usize * d as usize * self.texel_bytes()
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum HostResource {
    Buffer(HostBuffer),
    Texture(HostTexture),
}

impl From<HostBuffer> for HostResource {
    fn from(b: HostBuffer) -> Self {
        HostResource::Buffer(b)
    }
}

impl HostResource {
    pub fn buffer(&self) -> Option<&HostBuffer> {
        match self {
            HostResource::Buffer(b) => Some(b),
            _ => None,
        }
    }
    pub fn texture(&self) -> Option<&HostTexture> {
        match self {
            HostResource::Texture(t) => Some(t),
            _ => None,
        }
    }
}

/// Named host resources: the inputs and zeroed outputs of a run, or what a run read back.
pub type Resources = BTreeMap<String, HostResource>;

/// Resources of these named buffers.
pub fn buffers<const N: usize>(entries: [(&str, HostBuffer); N]) -> Resources {
    entries
        .into_iter()
        .map(|(name, b)| (name.to_string(), HostResource::Buffer(b)))
        .collect()
}

/// The buffer resource `name` of `data` as a slice of `T` (a mirror's view of its inputs), or `None`
/// where there is no such buffer or its bytes are not a whole number of `T`.
pub fn buffer_as<'a, T: bytemuck::Pod>(data: &'a Resources, name: &str) -> Option<&'a [T]> {
    bytemuck::try_cast_slice(&data.get(name)?.buffer()?.bytes).ok()
}

/// What a WGSL binding is bound to in one pass.
#[derive(Clone, Debug)]
pub enum View {
    /// A whole buffer resource.
    Buffer(String),
    /// A window of a buffer resource (split dispatches over buffers larger than one binding may be).
    BufferRange {
        name: String,
        offset: u64,
        size: u64,
    },
    /// All mips of a texture resource.
    Texture(String),
    /// One mip level of a texture resource (storage textures write one level at a time).
    TextureMip { name: String, mip: u32 },
    /// A sampler with this filter mode, clamp-to-edge.
    Sampler(wgpu::FilterMode),
}

impl View {
    /// The resource this view reads or writes (none for a sampler).
    pub fn resource(&self) -> Option<&str> {
        match self {
            View::Buffer(n) | View::Texture(n) => Some(n),
            View::BufferRange { name, .. } | View::TextureMip { name, .. } => Some(name),
            View::Sampler(_) => None,
        }
    }
}

/// Bind each WGSL name to the whole host buffer of the same name (the common case).
pub fn bind_same_names<'a>(names: impl IntoIterator<Item = &'a str>) -> Vec<(String, View)> {
    names
        .into_iter()
        .map(|n| (n.to_string(), View::Buffer(n.to_string())))
        .collect()
}

#[derive(Clone, Debug)]
pub enum Workgroups {
    Direct([u32; 3]),
    /// Arguments (x, y, z as u32) read from a buffer the GPU wrote: a GPU-built work list.
    Indirect {
        buffer: String,
        offset: u64,
    },
}

/// One dispatch of one entry point.
#[derive(Clone, Debug)]
pub struct Pass {
    pub label: String,
    pub entry: String,
    /// WGSL binding name -> what it is bound to. Bindings the entry does not use are ignored.
    pub bindings: Vec<(String, View)>,
    pub workgroups: Workgroups,
}

impl Pass {
    /// What the WGSL binding `binding` is bound to in this pass.
    pub fn view(&self, binding: &str) -> Option<&View> {
        self.bindings
            .iter()
            .find(|(n, _)| n == binding)
            .map(|(_, v)| v)
    }

    /// A pass of `entry` dispatched over the workgroup grid `groups`.
    pub fn direct(
        label: impl Into<String>,
        entry: &str,
        bindings: Vec<(String, View)>,
        groups: [u32; 3],
    ) -> Self {
        Pass {
            label: label.into(),
            entry: entry.into(),
            bindings,
            workgroups: Workgroups::Direct(groups),
        }
    }

    /// A pass of an entry declared `@workgroup_size(64)` over `invocations` invocations
    /// ([`grid_for`] within the device's workgroup limit).
    pub fn linear(
        ctx: &GpuContext,
        label: impl Into<String>,
        entry: &str,
        bindings: Vec<(String, View)>,
        invocations: u64,
    ) -> Self {
        let max = ctx.limits().max_compute_workgroups_per_dimension;
        Self::direct(label, entry, bindings, grid_for(invocations, 64, max))
    }
}

/// Workgroup grid for `count` invocations of `wg_size` along x: 1D while it fits, else x * y
/// (the kernel linearises with `gid.x + gid.y * num_workgroups.x * wg_size`).
pub fn grid_for(count: u64, wg_size: u32, max_per_dim: u32) -> [u32; 3] {
    let groups = count.div_ceil(wg_size as u64).max(1);
    if groups <= max_per_dim as u64 {
        [groups as u32, 1, 1]
    } else {
        let y = groups.div_ceil(max_per_dim as u64);
        let x = groups.div_ceil(y);
        [x as u32, y as u32, 1]
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimingSource {
    /// GPU timestamp queries around each compute pass.
    Timestamps,
    /// Wall clock around submit + wait (the adapter lacks timestamp queries).
    WallClock,
}

impl std::fmt::Display for TimingSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TimingSource::Timestamps => "GPU timestamps",
            TimingSource::WallClock => "wall clock (submit+wait)",
        })
    }
}

#[derive(Debug)]
pub struct RunOutput {
    /// The resources asked for, as the GPU left them.
    pub resources: Resources,
    /// Per pass GPU time in nanoseconds (timestamps) — empty when timing is wall clock.
    pub pass_ns: Vec<f64>,
    /// GPU time of all passes: sum of `pass_ns`, or wall clock around submit + wait.
    pub gpu_ns: f64,
    pub timing: TimingSource,
}

impl RunOutput {
    pub fn buffer(&self, name: &str) -> &HostBuffer {
        self.resources
            .get(name)
            .and_then(HostResource::buffer)
            .unwrap_or_else(|| panic!("no buffer `{name}` was read back"))
    }
}

struct Checker<'a> {
    ctx: &'a GpuContext,
    shader: &'a Shader,
    kernel: &'a str,
}

impl Checker<'_> {
    fn mismatch(&self, b: &crate::shader::Binding, expected: String, got: String) -> HarnessError {
        HarnessError::BindingMismatch {
            kernel: self.kernel.into(),
            path: self.shader.path.clone(),
            line: b.line,
            binding: b.name.clone(),
            expected,
            got,
        }
    }
    fn limit(&self, what: String, value: u64, limit_name: &'static str, limit: u64) -> Result<()> {
        if value > limit {
            return Err(HarnessError::Limit {
                kernel: self.kernel.into(),
                what,
                value,
                limit_name,
                limit,
            });
        }
        Ok(())
    }

    fn check_buffer(
        &self,
        b: &crate::shader::Binding,
        layout: &BufferLayout,
        uniform: bool,
        host: &HostBuffer,
        size: u64,
    ) -> Result<()> {
        let limits = self.ctx.limits();
        let expect = match layout.runtime_stride {
            Some(st) => format!(
                "{} + n * {st} bytes (n >= 1) of {}",
                layout.fixed_size, b.ty
            ),
            None => format!("exactly {} bytes ({})", layout.fixed_size, b.ty),
        };
        let fits = match layout.runtime_stride {
            Some(st) => {
                size >= layout.fixed_size as u64 + st as u64
                    && (size - layout.fixed_size as u64).is_multiple_of(st as u64)
            }
            None => size == layout.fixed_size as u64,
        };
        if !fits {
            return Err(self.mismatch(b, expect, format!("bound {size} bytes")));
        }
        // An `array<atomic<u32>>` may hold f32 bits that a kernel adds by compare-exchange (WGSL
        // has no float atomics): f32 data binds to it.
        let float_bits = host.scalar == ScalarKind::F32 && b.ty.contains("atomic<u32>");
        if layout.scalar != ScalarKind::Mixed
            && host.scalar != ScalarKind::Mixed
            && layout.scalar != host.scalar
            && !float_bits
        {
            return Err(self.mismatch(
                b,
                format!("{:?} elements ({})", layout.scalar, b.ty),
                format!("gave {:?} data", host.scalar),
            ));
        }
        if uniform {
            self.limit(
                format!("uniform binding `{}` size", b.name),
                size,
                "max_uniform_buffer_binding_size",
                limits.max_uniform_buffer_binding_size,
            )
        } else {
            self.limit(
                format!("storage binding `{}` size", b.name),
                size,
                "max_storage_buffer_binding_size",
                limits.max_storage_buffer_binding_size,
            )
        }
    }

    /// Every resource against the device's size limits (once per chain: its stages share them).
    fn check_resources(&self, resources: &Resources) -> Result<()> {
        let limits = self.ctx.limits();
        for (name, res) in resources {
            let size = match res {
                HostResource::Buffer(b) => b.bytes.len() as u64,
                HostResource::Texture(t) => t.levels.iter().map(|l| l.len() as u64).sum(),
            };
            self.limit(
                format!("resource `{name}` size"),
                size,
                "max_buffer_size",
                limits.max_buffer_size,
            )?;
            if let HostResource::Texture(t) = res {
                let dim_limit = match t.dimension {
                    wgpu::TextureDimension::D1 => limits.max_texture_dimension_1d,
                    wgpu::TextureDimension::D2 => limits.max_texture_dimension_2d,
                    wgpu::TextureDimension::D3 => limits.max_texture_dimension_3d,
                };
                let limit_name = match t.dimension {
                    wgpu::TextureDimension::D1 => "max_texture_dimension_1d",
                    wgpu::TextureDimension::D2 => "max_texture_dimension_2d",
                    wgpu::TextureDimension::D3 => "max_texture_dimension_3d",
                };
                self.limit(
                    format!("texture `{name}` extent"),
                    t.size[0].max(t.size[1]) as u64,
                    limit_name,
                    dim_limit as u64,
                )?;
                for (m, l) in t.levels.iter().enumerate() {
                    if l.len() != t.level_bytes(m as u32) {
                        return Err(HarnessError::Invalid {
                            kernel: self.kernel.into(),
                            message: format!(
                                "texture `{name}` mip {m} holds {} bytes, its extent needs {}",
                                l.len(),
                                t.level_bytes(m as u32)
                            ),
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// Every pass's entry point and bindings against the shader's reflection and `resources`.
    fn check_passes(&self, resources: &Resources, passes: &[Pass]) -> Result<()> {
        let limits = self.ctx.limits();
        for pass in passes {
            let entry = self.shader.require_entry(self.kernel, &pass.entry)?;
            for (name, _) in &pass.bindings {
                self.shader.require_binding(self.kernel, name)?;
            }
            for &bi in &entry.uses {
                let b = &self.shader.bindings[bi];
                let Some(view) = pass.view(&b.name) else {
                    return Err(HarnessError::MissingBinding {
                        kernel: self.kernel.into(),
                        path: self.shader.path.clone(),
                        line: b.line,
                        binding: b.name.clone(),
                        entry: entry.name.clone(),
                    });
                };
                let res = match view.resource() {
                    Some(r) => {
                        Some(
                            resources
                                .get(r)
                                .ok_or_else(|| HarnessError::UnknownResource {
                                    kernel: self.kernel.into(),
                                    pass: pass.label.clone(),
                                    resource: r.to_string(),
                                })?,
                        )
                    }
                    None => None,
                };
                match (&b.kind, view, res) {
                    (BindingKind::Uniform(l), View::Buffer(_), Some(HostResource::Buffer(h))) => {
                        self.check_buffer(b, l, true, h, h.bytes.len() as u64)?
                    }
                    (
                        BindingKind::Storage { layout, .. },
                        View::Buffer(_),
                        Some(HostResource::Buffer(h)),
                    ) => self.check_buffer(b, layout, false, h, h.bytes.len() as u64)?,
                    (
                        BindingKind::Uniform(_) | BindingKind::Storage { .. },
                        View::BufferRange { offset, size, .. },
                        Some(HostResource::Buffer(h)),
                    ) => {
                        let align = limits
                            .min_storage_buffer_offset_alignment
                            .max(limits.min_uniform_buffer_offset_alignment)
                            as u64;
                        if offset % align != 0 || offset + size > h.bytes.len() as u64 {
                            return Err(self.mismatch(
                                b,
                                format!("a window aligned to {align} bytes inside the buffer"),
                                format!(
                                    "bound [{offset}, {}) of {} bytes",
                                    offset + size,
                                    h.bytes.len()
                                ),
                            ));
                        }
                        let (layout, uniform) = match &b.kind {
                            BindingKind::Uniform(l) => (l, true),
                            BindingKind::Storage { layout, .. } => (layout, false),
                            _ => unreachable!(),
                        };
                        self.check_buffer(b, layout, uniform, h, *size)?;
                    }
                    (
                        BindingKind::SampledTexture { dim, .. }
                        | BindingKind::StorageTexture { dim, .. },
                        View::Texture(_) | View::TextureMip { .. },
                        Some(HostResource::Texture(t)),
                    ) => {
                        let ok = matches!(
                            (dim, t.dimension),
                            (wgpu::TextureViewDimension::D1, wgpu::TextureDimension::D1)
                                | (
                                    wgpu::TextureViewDimension::D2
                                        | wgpu::TextureViewDimension::D2Array,
                                    wgpu::TextureDimension::D2
                                )
                                | (wgpu::TextureViewDimension::D3, wgpu::TextureDimension::D3)
                        );
                        if !ok {
                            return Err(self.mismatch(
                                b,
                                format!("a {dim:?} texture ({})", b.ty),
                                format!("gave a {:?} texture", t.dimension),
                            ));
                        }
                        if let BindingKind::StorageTexture { format, .. } = &b.kind {
                            if *format != Some(t.format) {
                                return Err(self.mismatch(
                                    b,
                                    format!("format {format:?}"),
                                    format!("gave {:?}", t.format),
                                ));
                            }
                            if !matches!(view, View::TextureMip { .. }) {
                                return Err(self.mismatch(
                                    b,
                                    "one mip level (View::TextureMip)".into(),
                                    "bound all mips".into(),
                                ));
                            }
                        }
                        if let View::TextureMip { mip, .. } = view {
                            if *mip as usize >= t.levels.len() {
                                return Err(self.mismatch(
                                    b,
                                    format!("a mip below {}", t.levels.len()),
                                    format!("asked for mip {mip}"),
                                ));
                            }
                        }
                    }
                    (BindingKind::Sampler, View::Sampler(_), None) => {}
                    (kind, view, _) => {
                        return Err(self.mismatch(
                            b,
                            format!("{kind:?}"),
                            format!("bound {view:?}"),
                        ));
                    }
                }
            }
            match &pass.workgroups {
                Workgroups::Direct(g) => {
                    for (axis, v) in ["x", "y", "z"].iter().zip(g) {
                        self.limit(format!("pass `{}` workgroup count along {axis}", pass.label), *v as u64, "max_compute_workgroups_per_dimension", limits.max_compute_workgroups_per_dimension as u64)?;
                    }
                }
                Workgroups::Indirect { buffer, offset } => match resources.get(buffer) {
                    _ if entry.uses.iter().any(|&bi| {
                        let b = &self.shader.bindings[bi];
                        matches!(b.kind, BindingKind::Storage { read_only: false, .. })
                            && pass.bindings.iter().any(|(n, v)| *n == b.name && v.resource() == Some(buffer.as_str()))
                    }) =>
                    {
                        return Err(HarnessError::Invalid {
                            kernel: self.kernel.into(),
                            message: format!(
                                "pass `{}` dispatches from buffer `{buffer}` while binding it as writable storage; \
                                 bind it read-only in that pass (WebGPU usage rules)",
                                pass.label
                            ),
                        })
                    }
                    Some(HostResource::Buffer(h)) if offset % 4 == 0 && offset + 12 <= h.bytes.len() as u64 => {}
                    _ => {
                        return Err(HarnessError::Invalid {
                            kernel: self.kernel.into(),
                            message: format!("pass `{}`: indirect arguments need 12 bytes at a 4-aligned offset {offset} of buffer `{buffer}`", pass.label),
                        })
                    }
                },
            }
        }
        Ok(())
    }
}

enum GpuRes {
    Buffer(wgpu::Buffer),
    Texture(wgpu::Texture),
}

struct Step {
    label: String,
    pipeline: wgpu::ComputePipeline,
    bind_groups: Vec<(u32, wgpu::BindGroup)>,
    workgroups: Workgroups,
}

/// A buffer's size, or a texture's texels over its mip levels.
fn res_bytes(r: &GpuRes) -> u64 {
    match r {
        GpuRes::Buffer(b) => b.size(),
        GpuRes::Texture(t) => {
            let e = t.size();
            let shape = HostTexture {
                format: t.format(),
                dimension: t.dimension(),
                size: [e.width, e.height, e.depth_or_array_layers],
                levels: Vec::new(),
            };
            (0..t.mip_level_count())
                .map(|m| shape.level_bytes(m) as u64)
                .sum()
        }
    }
}

/// Resources uploaded and passes recorded once; dispatch as often as wanted (benchmarks), read back any
/// resource. [`run`] is `prepare` + `dispatch` + `read`.
pub struct Prepared<'a> {
    ctx: &'a GpuContext,
    kernel: String,
    gpu: BTreeMap<String, GpuRes>,
    /// Shape of each resource (buffers: scalar kind; textures: everything but the data).
    shapes: BTreeMap<String, HostResource>,
    steps: Vec<Step>,
    queries: Option<(wgpu::QuerySet, wgpu::Buffer, u32)>,
}

fn scoped<T>(ctx: &GpuContext, kernel: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
    let scope_v = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let scope_m = ctx.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let r = f();
    let errors = [
        pollster::block_on(scope_m.pop()),
        pollster::block_on(scope_v.pop()),
    ];
    if let Some(e) = errors.into_iter().flatten().next() {
        return Err(HarnessError::Gpu {
            kernel: kernel.into(),
            message: e.to_string(),
        });
    }
    r
}

/// Check everything against reflection and the device limits, then upload `resources` and record
/// `passes`. Nothing reaches the GPU before the checks pass.
pub fn prepare<'a>(
    ctx: &'a GpuContext,
    shader: &Shader,
    kernel: &str,
    resources: &Resources,
    passes: &[Pass],
) -> Result<Prepared<'a>> {
    prepare_chain(
        ctx,
        &[Stage {
            shader,
            kernel,
            passes,
        }],
        resources,
    )
}

/// One kernel's passes in a [`prepare_chain`]: its shader, its name (for messages) and its passes.
pub struct Stage<'s> {
    pub shader: &'s Shader,
    pub kernel: &'s str,
    pub passes: &'s [Pass],
}

/// [`prepare`] for several kernels run one after another in one submission over one set of GPU
/// resources: a resource one stage writes is what a later stage reads (by name, through each pass's
/// bindings), never copied through the host. Each stage is checked against its own shader.
pub fn prepare_chain<'a>(
    ctx: &'a GpuContext,
    stages: &[Stage],
    resources: &Resources,
) -> Result<Prepared<'a>> {
    prepare_chain_adopting(ctx, stages, resources, &BTreeMap::new())
}

/// [`prepare_chain`] binding GPU buffers that exist already in place of some resources: each
/// `adopted` buffer (e.g. one an earlier chain's passes computed, with the same usage: see
/// [`Prepared::buffer`]) stands for the buffer resource of its name, whose host contents are not
/// uploaded. Its size must be that resource's.
pub fn prepare_chain_adopting<'a>(
    ctx: &'a GpuContext,
    stages: &[Stage],
    resources: &Resources,
    adopted: &BTreeMap<String, wgpu::Buffer>,
) -> Result<Prepared<'a>> {
    for (name, buffer) in adopted {
        let size = match resources.get(name) {
            Some(HostResource::Buffer(b)) => b.bytes.len() as u64,
            _ => u64::MAX,
        };
        if buffer.size() != size {
            let kernel = stages
                .iter()
                .map(|s| s.kernel)
                .collect::<Vec<_>>()
                .join(" + ");
            let needs = if size == u64::MAX {
                "a buffer resource of that name, and the chain has none".to_string()
            } else {
                format!("{size} bytes for the chain's buffer of that name")
            };
            return Err(HarnessError::Invalid {
                kernel,
                message: format!(
                    "the adopted buffer `{name}` holds {} bytes; it needs {needs}",
                    buffer.size()
                ),
            });
        }
    }
    for (k, st) in stages.iter().enumerate() {
        let checker = Checker {
            ctx,
            shader: st.shader,
            kernel: st.kernel,
        };
        if k == 0 {
            checker.check_resources(resources)?;
        }
        checker.check_passes(resources, st.passes)?;
    }
    let kernel = stages
        .iter()
        .map(|s| s.kernel)
        .collect::<Vec<_>>()
        .join(" + ");
    let kernel = kernel.as_str();
    let passes: Vec<(&Shader, &Pass)> = stages
        .iter()
        .flat_map(|st| st.passes.iter().map(move |p| (st.shader, p)))
        .collect();
    scoped(ctx, kernel, || {
        let device = &ctx.device;
        let mut gpu = BTreeMap::new();
        let mut shapes = BTreeMap::new();
        for (name, res) in resources {
            let g = match res {
                HostResource::Buffer(b) => {
                    shapes.insert(
                        name.clone(),
                        HostResource::Buffer(HostBuffer {
                            bytes: Vec::new(),
                            scalar: b.scalar,
                        }),
                    );
                    if let Some(buffer) = adopted.get(name) {
                        gpu.insert(name.clone(), GpuRes::Buffer(buffer.clone()));
                        continue;
                    }
                    let usage = wgpu::BufferUsages::STORAGE
                        | wgpu::BufferUsages::UNIFORM
                        | wgpu::BufferUsages::COPY_SRC
                        | wgpu::BufferUsages::COPY_DST
                        | wgpu::BufferUsages::INDIRECT;
                    // wgpu zero-initialises new buffers: an all-zero host buffer (outputs,
                    // accumulators) need not be copied up.
                    let zero = !b.bytes.is_empty()
                        && b.bytes.len() % 4 == 0
                        && b.bytes.iter().all(|&x| x == 0);
                    count!(ctx, buffers_created, 1);
                    if !zero {
                        count!(ctx, upload_bytes, b.bytes.len() as u64);
                    }
                    GpuRes::Buffer(if zero {
                        device.create_buffer(&wgpu::BufferDescriptor {
                            label: Some(name),
                            size: b.bytes.len() as u64,
                            usage,
                            mapped_at_creation: false,
                        })
                    } else {
                        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some(name),
                            contents: &b.bytes,
                            usage,
                        })
                    })
                }
                HostResource::Texture(t) => {
                    shapes.insert(
                        name.clone(),
                        HostResource::Texture(HostTexture {
                            levels: vec![Vec::new(); t.levels.len()],
                            ..t.clone_shape()
                        }),
                    );
                    let mut usage = wgpu::TextureUsages::TEXTURE_BINDING
                        | wgpu::TextureUsages::COPY_SRC
                        | wgpu::TextureUsages::COPY_DST;
                    if t.format
                        .guaranteed_format_features(device.features())
                        .allowed_usages
                        .contains(wgpu::TextureUsages::STORAGE_BINDING)
                    {
                        usage |= wgpu::TextureUsages::STORAGE_BINDING;
                    }
                    count!(ctx, textures_created, 1);
                    let tex = device.create_texture(&wgpu::TextureDescriptor {
                        label: Some(name),
                        size: wgpu::Extent3d {
                            width: t.size[0],
                            height: t.size[1],
                            depth_or_array_layers: t.size[2],
                        },
                        mip_level_count: t.levels.len() as u32,
                        sample_count: 1,
                        dimension: t.dimension,
                        format: t.format,
                        usage,
                        view_formats: &[],
                    });
                    for (m, data) in t.levels.iter().enumerate() {
                        let [w, h, d] = t.level_extent(m as u32);
                        count!(ctx, upload_bytes, data.len() as u64);
                        ctx.queue.write_texture(
                            wgpu::TexelCopyTextureInfo {
                                texture: &tex,
                                mip_level: m as u32,
                                origin: wgpu::Origin3d::ZERO,
                                aspect: wgpu::TextureAspect::All,
                            },
                            data,
                            wgpu::TexelCopyBufferLayout {
                                offset: 0,
                                bytes_per_row: Some(w * t.texel_bytes() as u32),
                                rows_per_image: Some(h),
                            },
                            wgpu::Extent3d {
                                width: w,
                                height: h,
                                depth_or_array_layers: d,
                            },
                        );
                    }
                    GpuRes::Texture(tex)
                }
            };
            gpu.insert(name.clone(), g);
        }

        let use_ts = ctx.timestamps
            && !passes.is_empty()
            && passes.len() * 2 <= wgpu::QUERY_SET_MAX_QUERIES as usize;
        let queries = use_ts.then(|| {
            let n = passes.len() as u32 * 2;
            let set = device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass times"),
                ty: wgpu::QueryType::Timestamp,
                count: n,
            });
            count!(ctx, buffers_created, 1);
            let resolve = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps"),
                size: n as u64 * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            (set, resolve, n)
        });

        let mut steps = Vec::new();
        for &(shader, pass) in &passes {
            let pipeline = ctx.pipeline(&shader.source, &pass.entry, kernel);
            let entry = shader.entry(&pass.entry).expect("checked");
            let mut groups: BTreeMap<u32, Vec<(u32, wgpu::BindingResource)>> = BTreeMap::new();
            let mut views = Vec::new();
            let mut samplers = Vec::new();
            // Views and samplers must outlive the bind-group entries that borrow them: build them first.
            for &bi in &entry.uses {
                let b = &shader.bindings[bi];
                let view = pass.view(&b.name).expect("checked");
                match view {
                    View::Texture(n) | View::TextureMip { name: n, .. } => {
                        let GpuRes::Texture(t) = &gpu[n] else {
                            unreachable!("checked")
                        };
                        let (base, count) = match view {
                            View::TextureMip { mip, .. } => (*mip, Some(1)),
                            _ => (0, None),
                        };
                        let dim = match &b.kind {
                            BindingKind::SampledTexture { dim, .. }
                            | BindingKind::StorageTexture { dim, .. } => *dim,
                            _ => unreachable!("checked"),
                        };
                        views.push((
                            bi,
                            t.create_view(&wgpu::TextureViewDescriptor {
                                dimension: Some(dim),
                                base_mip_level: base,
                                mip_level_count: count,
                                ..Default::default()
                            }),
                        ));
                    }
                    View::Sampler(filter) => samplers.push((
                        bi,
                        device.create_sampler(&wgpu::SamplerDescriptor {
                            mag_filter: *filter,
                            min_filter: *filter,
                            mipmap_filter: match filter {
                                wgpu::FilterMode::Linear => wgpu::MipmapFilterMode::Linear,
                                wgpu::FilterMode::Nearest => wgpu::MipmapFilterMode::Nearest,
                            },
                            ..Default::default()
                        }),
                    )),
                    _ => {}
                }
            }
            for &bi in &entry.uses {
                let b = &shader.bindings[bi];
                let view = pass.view(&b.name).expect("checked");
                let resource = match view {
                    View::Buffer(n) => {
                        let GpuRes::Buffer(buf) = &gpu[n] else {
                            unreachable!("checked")
                        };
                        buf.as_entire_binding()
                    }
                    View::BufferRange { name, offset, size } => {
                        let GpuRes::Buffer(buf) = &gpu[name] else {
                            unreachable!("checked")
                        };
                        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: buf,
                            offset: *offset,
                            size: wgpu::BufferSize::new(*size),
                        })
                    }
                    View::Texture(_) | View::TextureMip { .. } => {
                        wgpu::BindingResource::TextureView(
                            &views.iter().find(|(i, _)| *i == bi).expect("built above").1,
                        )
                    }
                    View::Sampler(_) => wgpu::BindingResource::Sampler(
                        &samplers
                            .iter()
                            .find(|(i, _)| *i == bi)
                            .expect("built above")
                            .1,
                    ),
                };
                groups
                    .entry(b.group)
                    .or_default()
                    .push((b.binding, resource));
            }
            let bind_groups = groups
                .into_iter()
                .map(|(g, entries)| {
                    count!(ctx, bind_groups_created, 1);
                    let entries: Vec<_> = entries
                        .into_iter()
                        .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource })
                        .collect();
                    (
                        g,
                        device.create_bind_group(&wgpu::BindGroupDescriptor {
                            label: Some(&pass.label),
                            layout: &pipeline.get_bind_group_layout(g),
                            entries: &entries,
                        }),
                    )
                })
                .collect();
            steps.push(Step {
                label: pass.label.clone(),
                pipeline,
                bind_groups,
                workgroups: pass.workgroups.clone(),
            });
        }
        Ok(Prepared {
            ctx,
            kernel: kernel.into(),
            gpu,
            shapes,
            steps,
            queries,
        })
    })
}

impl Prepared<'_> {
    /// Run every pass once, in order, in one submission; returns (per-pass ns, total GPU ns, timing source).
    pub fn dispatch(&self) -> Result<(Vec<f64>, f64, TimingSource)> {
        self.dispatch_steps(0..self.steps.len())
    }

    /// Copy whole buffer resources into others at byte offsets (`(src, dst, dst_offset)`), in one
    /// submission: a chain's stages hand over on the GPU where one kernel's outputs are separate
    /// buffers and the next reads them as one (a mip chain's levels into a pyramid). Sizes and offsets
    /// are checked (multiples of 4, inside `dst`).
    pub fn copy_into(&self, copies: &[(&str, &str, u64)]) -> Result<()> {
        let ctx = self.ctx;
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("copies"),
            });
        self.encode_copies(&mut enc, copies)?;
        self.submit(enc)
    }

    /// How many passes (of every stage of a chain, in order) this runs.
    pub fn step_count(&self) -> usize {
        self.steps.len()
    }

    /// Run the passes `range` once, in order, in one submission (a chain's stages one by one, each
    /// timed alone, on the same GPU resources); returns as [`Prepared::dispatch`] for those passes.
    pub fn dispatch_steps(
        &self,
        range: std::ops::Range<usize>,
    ) -> Result<(Vec<f64>, f64, TimingSource)> {
        let ctx = self.ctx;
        if range.is_empty() {
            let source = if self.queries.is_some() {
                TimingSource::Timestamps
            } else {
                TimingSource::WallClock
            };
            return Ok((Vec::new(), 0.0, source));
        }
        scoped(ctx, &self.kernel, || {
            let mut encoder = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some(&self.kernel),
                });
            self.encode_steps(&mut encoder, range.clone());
            let ts_staging = self.queries.as_ref().map(|(set, resolve, _)| {
                let (first, n) = (range.start as u32 * 2, range.len() as u32 * 2);
                encoder.resolve_query_set(set, first..first + n, resolve, 0);
                // The timestamps' own staging buffer: counted as a buffer, not as readback.
                let st = staging(ctx, n as u64 * 8);
                encoder.copy_buffer_to_buffer(resolve, 0, &st, 0, n as u64 * 8);
                st
            });
            let start = Instant::now();
            count!(ctx, submissions, 1);
            ctx.queue.submit([encoder.finish()]);
            wait(ctx, &self.kernel)?;
            let wall_ns = start.elapsed().as_nanos() as f64;
            match ts_staging {
                Some(st) => {
                    st.slice(..).map_async(wgpu::MapMode::Read, |_| {});
                    wait(ctx, &self.kernel)?;
                    let view = st
                        .slice(..)
                        .get_mapped_range()
                        .map_err(|e| HarnessError::Gpu {
                            kernel: self.kernel.clone(),
                            message: e.to_string(),
                        })?;
                    let ticks: &[u64] = bytemuck::cast_slice(&view);
                    let period = ctx.queue.get_timestamp_period() as f64;
                    let per: Vec<f64> = ticks
                        .chunks(2)
                        .map(|c| c[1].saturating_sub(c[0]) as f64 * period)
                        .collect();
                    let sum: f64 = per.iter().sum();
                    count!(ctx, gpu_ns, sum as u64);
                    Ok((per, sum, TimingSource::Timestamps))
                }
                None => {
                    count!(ctx, gpu_ns, wall_ns as u64);
                    Ok((Vec::new(), wall_ns, TimingSource::WallClock))
                }
            }
        })
    }

    /// Read back the named resources as they are now.
    pub fn read(&self, names: &[&str]) -> Result<Resources> {
        let ctx = self.ctx;
        let kernel = &self.kernel;
        for r in names {
            if !self.gpu.contains_key(*r) {
                return Err(HarnessError::UnknownResource {
                    kernel: kernel.clone(),
                    pass: "readback".into(),
                    resource: r.to_string(),
                });
            }
        }
        scoped(ctx, kernel, || {
            let device = &ctx.device;
            let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("readback"),
            });
            let mut staged = Vec::new();
            for name in names {
                match (&self.gpu[*name], &self.shapes[*name]) {
                    (GpuRes::Buffer(b), HostResource::Buffer(h)) => {
                        let st = staging(ctx, b.size());
                        count!(ctx, readback_bytes, b.size());
                        enc.copy_buffer_to_buffer(b, 0, &st, 0, b.size());
                        staged.push((name.to_string(), st, None, h.scalar));
                    }
                    (GpuRes::Texture(t), HostResource::Texture(h)) => {
                        let mut layout = Vec::new();
                        let mut total = 0u64;
                        for m in 0..h.levels.len() as u32 {
                            let [w, hh, d] = h.level_extent(m);
                            let row = w * h.texel_bytes() as u32;
                            let padded = row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
                                * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
                            layout.push((total, row, padded, [w, hh, d]));
                            total += padded as u64 * hh as u64 * d as u64;
                        }
                        let st = staging(ctx, total.max(4));
                        count!(ctx, readback_bytes, total);
                        for (m, (off, _, padded, [w, hh, d])) in layout.iter().enumerate() {
                            enc.copy_texture_to_buffer(
                                wgpu::TexelCopyTextureInfo {
                                    texture: t,
                                    mip_level: m as u32,
                                    origin: wgpu::Origin3d::ZERO,
                                    aspect: wgpu::TextureAspect::All,
                                },
                                wgpu::TexelCopyBufferInfo {
                                    buffer: &st,
                                    layout: wgpu::TexelCopyBufferLayout {
                                        offset: *off,
                                        bytes_per_row: Some(*padded),
                                        rows_per_image: Some(*hh),
                                    },
                                },
                                wgpu::Extent3d {
                                    width: *w,
                                    height: *hh,
                                    depth_or_array_layers: *d,
                                },
                            );
                        }
                        staged.push((
                            name.to_string(),
                            st,
                            Some((layout, h.clone())),
                            ScalarKind::Mixed,
                        ));
                    }
                    _ => unreachable!("shapes mirror gpu"),
                }
            }
            count!(ctx, submissions, 1);
            ctx.queue.submit([enc.finish()]);
            for (_, st, _, _) in &staged {
                st.slice(..).map_async(wgpu::MapMode::Read, |_| {});
            }
            wait(ctx, kernel)?;
            let mut out = Resources::new();
            for (name, st, tex, scalar) in staged {
                let bytes = st
                    .slice(..)
                    .get_mapped_range()
                    .map_err(|e| HarnessError::Gpu {
                        kernel: kernel.clone(),
                        message: format!("mapping `{name}` for readback: {e}"),
                    })?
                    .to_vec();
                let res = match tex {
                    None => HostResource::Buffer(HostBuffer { bytes, scalar }),
                    Some((layout, mut h)) => {
                        // Drop the row padding copy_texture_to_buffer needs (rows aligned to 256 bytes).
                        for (m, (off, row, padded, [_, hh, d])) in layout.into_iter().enumerate() {
                            let level = &mut h.levels[m];
                            level.clear();
                            for r in 0..(hh * d) as u64 {
                                let s = (off + r * padded as u64) as usize;
                                level.extend_from_slice(&bytes[s..s + row as usize]);
                            }
                        }
                        HostResource::Texture(h)
                    }
                };
                out.insert(name, res);
            }
            Ok(out)
        })
    }
}

/// Buffers of a [`Prepared`] read back every frame into staging buffers created once
/// ([`Prepared::readback_set`]): recorded into the frame's encoder ([`Prepared::encode_read`]), mapped
/// after its one submission ([`Prepared::finish_read`]).
pub struct ReadbackSet {
    staged: Vec<(String, wgpu::Buffer, ScalarKind)>,
    /// Timestamp ticks of the recorded passes (two per pass), where the adapter has timestamps.
    timestamps: Option<wgpu::Buffer>,
}

impl Prepared<'_> {
    /// The GPU buffer of resource `name` (to bind it elsewhere, or to read it in the caller's own
    /// submission).
    pub fn buffer(&self, name: &str) -> Option<&wgpu::Buffer> {
        match self.gpu.get(name) {
            Some(GpuRes::Buffer(b)) => Some(b),
            _ => None,
        }
    }

    /// Write `bytes` into the buffer resource `name` at offset 0 (a frame's small inputs: the camera,
    /// the lights); counted as uploaded bytes. Sizes must match the resource's.
    pub fn write_buffer(&self, name: &str, bytes: &[u8]) -> Result<()> {
        match self.gpu.get(name) {
            Some(GpuRes::Buffer(b)) if b.size() == bytes.len() as u64 => {
                count!(self.ctx, upload_bytes, bytes.len() as u64);
                self.ctx.queue.write_buffer(b, 0, bytes);
                Ok(())
            }
            Some(GpuRes::Buffer(b)) => Err(HarnessError::Gpu {
                kernel: self.kernel.clone(),
                message: format!(
                    "write of {} bytes into `{name}` ({} bytes): sizes differ",
                    bytes.len(),
                    b.size()
                ),
            }),
            _ => Err(HarnessError::UnknownResource {
                kernel: self.kernel.clone(),
                pass: "write".into(),
                resource: name.to_string(),
            }),
        }
    }

    /// Record the passes `range` into `encoder`, with the timestamp writes of those passes where the
    /// adapter has timestamps ([`Prepared::encode_read`] resolves them). Timed passes are one compute
    /// pass each (a timestamp pair brackets a compute pass); untimed ones share one compute pass.
    /// wgpu still tracks each dispatch's usage and puts a barrier between dispatches that need one,
    /// and opening a compute pass costs time in the number of the device's buffers, so a chain of
    /// thousands of passes (a scene of thousands of instances, too many to time) recorded one pass
    /// each would cost time quadratic in its size.
    pub fn encode_steps(&self, encoder: &mut wgpu::CommandEncoder, range: std::ops::Range<usize>) {
        let record = |cpass: &mut wgpu::ComputePass<'_>, step: &Step| {
            cpass.set_pipeline(&step.pipeline);
            for (g, bg) in &step.bind_groups {
                cpass.set_bind_group(*g, bg, &[]);
            }
            match &step.workgroups {
                Workgroups::Direct([x, y, z]) => cpass.dispatch_workgroups(*x, *y, *z),
                Workgroups::Indirect { buffer, offset } => {
                    let GpuRes::Buffer(buf) = &self.gpu[buffer] else {
                        unreachable!("checked")
                    };
                    cpass.dispatch_workgroups_indirect(buf, *offset);
                }
            }
        };
        let Some((set, _, _)) = &self.queries else {
            if !range.is_empty() {
                let mut cpass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(&self.steps[range.start].label),
                    timestamp_writes: None,
                });
                for step in &self.steps[range] {
                    // The step's name where a debugger or a validation error shows the pass.
                    cpass.insert_debug_marker(&step.label);
                    record(&mut cpass, step);
                }
            }
            return;
        };
        for pi in range {
            let step = &self.steps[pi];
            let mut cpass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(&step.label),
                timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                    query_set: set,
                    beginning_of_pass_write_index: Some(pi as u32 * 2),
                    end_of_pass_write_index: Some(pi as u32 * 2 + 1),
                }),
            });
            record(&mut cpass, step);
        }
    }

    /// Record zeroing the buffer resources `names` (on the GPU: nothing uploaded): outputs a frame
    /// writes only in part, and append lists, start each frame as a fresh resource would.
    pub fn encode_clear(&self, encoder: &mut wgpu::CommandEncoder, names: &[&str]) -> Result<()> {
        for name in names {
            match self.gpu.get(*name) {
                Some(GpuRes::Buffer(b)) => encoder.clear_buffer(b, 0, None),
                _ => {
                    return Err(HarnessError::UnknownResource {
                        kernel: self.kernel.clone(),
                        pass: "clear".into(),
                        resource: name.to_string(),
                    })
                }
            }
        }
        Ok(())
    }

    /// Record [`Prepared::copy_into`]'s copies into `encoder` (checked the same way).
    pub fn encode_copies(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        copies: &[(&str, &str, u64)],
    ) -> Result<()> {
        for &(src, dst, offset) in copies {
            self.encode_copy_range(encoder, src, None, dst, offset)?;
        }
        Ok(())
    }

    /// Record a copy of `src` (of the byte range `range` of it, else all of it) into `dst` at
    /// `offset`; a misaligned or out-of-range copy is an error naming both.
    pub fn encode_copy_range(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        src: &str,
        range: Option<std::ops::Range<u64>>,
        dst: &str,
        offset: u64,
    ) -> Result<()> {
        let buffer = |name: &str| -> Result<&wgpu::Buffer> {
            match self.gpu.get(name) {
                Some(GpuRes::Buffer(b)) => Ok(b),
                _ => Err(HarnessError::UnknownResource {
                    kernel: self.kernel.clone(),
                    pass: "copy".into(),
                    resource: name.to_string(),
                }),
            }
        };
        let (s, d) = (buffer(src)?, buffer(dst)?);
        let range = range.unwrap_or(0..s.size());
        let size = range.end.saturating_sub(range.start);
        if !offset.is_multiple_of(4)
            || !range.start.is_multiple_of(4)
            || !size.is_multiple_of(4)
            || range.end > s.size()
            || offset + size > d.size()
        {
            return Err(HarnessError::Gpu {
                    kernel: self.kernel.clone(),
                    message: format!(
                        "copy of `{src}` bytes {range:?} ({} bytes) into `{dst}` ({} bytes) at {offset}: misaligned or out of range",
                        s.size(),
                        d.size()
                    ),
                });
        }
        encoder.copy_buffer_to_buffer(s, range.start, d, offset, size);
        Ok(())
    }

    /// The bytes of the GPU resources this holds: each buffer's size and each texture's texels over
    /// its mip levels (what the chain keeps on the device; staging and query buffers not included).
    pub fn gpu_bytes(&self) -> u64 {
        self.gpu.values().map(res_bytes).sum()
    }

    /// The bytes of resource `name` on the GPU, as [`Prepared::gpu_bytes`] counts them.
    pub fn resource_bytes(&self, name: &str) -> Option<u64> {
        self.gpu.get(name).map(res_bytes)
    }

    /// Staging buffers, created now and reused every frame, for the buffer resources `names` (and for
    /// the passes' timestamps).
    pub fn readback_set(&self, names: &[&str]) -> Result<ReadbackSet> {
        let mut staged = Vec::new();
        for name in names {
            match (self.gpu.get(*name), self.shapes.get(*name)) {
                (Some(GpuRes::Buffer(b)), Some(HostResource::Buffer(h))) => {
                    staged.push((name.to_string(), staging(self.ctx, b.size()), h.scalar));
                }
                _ => {
                    return Err(HarnessError::UnknownResource {
                        kernel: self.kernel.clone(),
                        pass: "readback".into(),
                        resource: name.to_string(),
                    })
                }
            }
        }
        let timestamps = self
            .queries
            .as_ref()
            .map(|(_, _, n)| staging(self.ctx, *n as u64 * 8));
        Ok(ReadbackSet { staged, timestamps })
    }

    /// Record the copies of `set`'s buffers into `encoder`, and of the timestamps of the passes
    /// `timed` (the ones this submission records: only written queries are resolved).
    pub fn encode_read(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        set: &ReadbackSet,
        timed: std::ops::Range<usize>,
    ) {
        for (name, st, _) in &set.staged {
            let GpuRes::Buffer(b) = &self.gpu[name] else {
                unreachable!("checked by readback_set")
            };
            encoder.copy_buffer_to_buffer(b, 0, st, 0, b.size());
        }
        if let (Some((qs, resolve, _)), Some(st)) = (&self.queries, &set.timestamps) {
            if !timed.is_empty() {
                let (first, n) = (timed.start as u32 * 2, timed.len() as u32 * 2);
                encoder.resolve_query_set(qs, first..first + n, resolve, 0);
                encoder.copy_buffer_to_buffer(resolve, 0, st, 0, n as u64 * 8);
            }
        }
    }

    /// Submit `encoder` (one counted submission) and wait for it. Without timestamp queries the
    /// wall clock around submit and wait is the counters' GPU time.
    pub fn submit(&self, encoder: wgpu::CommandEncoder) -> Result<()> {
        let ctx = self.ctx;
        scoped(ctx, &self.kernel, || {
            count!(ctx, submissions, 1);
            let start = Instant::now();
            ctx.queue.submit([encoder.finish()]);
            let r = wait(ctx, &self.kernel);
            if self.queries.is_none() {
                count!(ctx, gpu_ns, start.elapsed().as_nanos() as u64);
            }
            r
        })
    }

    /// After the submission that recorded [`Prepared::encode_read`] of `set` with `timed` passes:
    /// the buffers as host resources, and each timed pass's GPU ns (timestamps; empty without them),
    /// whose sum is added to the context's counters. The bytes read are the frame's outputs: not
    /// counted as readback (the counters' readback is what a frame moves besides its outputs).
    pub fn finish_read(&self, set: &ReadbackSet, timed: usize) -> Result<(Resources, Vec<f64>)> {
        let ctx = self.ctx;
        let kernel = &self.kernel;
        for (_, st, _) in &set.staged {
            st.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        }
        if let Some(st) = &set.timestamps {
            st.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        }
        let waited = wait(ctx, kernel);
        let map_err = |name: &str, e: wgpu::MapRangeError| HarnessError::Gpu {
            kernel: kernel.clone(),
            message: format!("mapping `{name}` for readback: {e}"),
        };
        let read = || -> Result<(Resources, Vec<f64>)> {
            waited?;
            let mut out = Resources::new();
            for (name, st, scalar) in &set.staged {
                let bytes = st
                    .slice(..)
                    .get_mapped_range()
                    .map_err(|e| map_err(name, e))?
                    .to_vec();
                out.insert(
                    name.clone(),
                    HostResource::Buffer(HostBuffer {
                        bytes,
                        scalar: *scalar,
                    }),
                );
            }
            let mut per = Vec::new();
            if let Some(st) = &set.timestamps {
                let view = st
                    .slice(..)
                    .get_mapped_range()
                    .map_err(|e| map_err("timestamps", e))?;
                let ticks: &[u64] = bytemuck::cast_slice(&view);
                let period = ctx.queue.get_timestamp_period() as f64;
                per = (0..timed)
                    .map(|p| ticks[2 * p + 1].saturating_sub(ticks[2 * p]) as f64 * period)
                    .collect();
            }
            Ok((out, per))
        };
        let result = read();
        // Unmapped on every path (every buffer is mapped or pending here: unmap ends either), since
        // the next frame copies into them again.
        for st in set
            .staged
            .iter()
            .map(|(_, st, _)| st)
            .chain(set.timestamps.as_ref())
        {
            st.unmap();
        }
        let (out, per) = result?;
        count!(ctx, gpu_ns, per.iter().sum::<f64>() as u64);
        Ok((out, per))
    }
}

/// [`run`] for a chain of kernels ([`prepare_chain`]): one upload, one submission, one readback.
pub fn run_chain(
    ctx: &GpuContext,
    stages: &[Stage],
    resources: &Resources,
    readback: &[&str],
) -> Result<RunOutput> {
    let prepared = prepare_chain(ctx, stages, resources)?;
    let (pass_ns, gpu_ns, timing) = prepared.dispatch()?;
    let resources = prepared.read(readback)?;
    Ok(RunOutput {
        resources,
        pass_ns,
        gpu_ns,
        timing,
    })
}

/// Check, upload, run `passes` once and read back the resources named in `readback`.
pub fn run(
    ctx: &GpuContext,
    shader: &Shader,
    kernel: &str,
    resources: &Resources,
    passes: &[Pass],
    readback: &[&str],
) -> Result<RunOutput> {
    let stage = Stage {
        shader,
        kernel,
        passes,
    };
    run_chain(ctx, &[stage], resources, readback)
}

fn staging(ctx: &GpuContext, size: u64) -> wgpu::Buffer {
    count!(ctx, buffers_created, 1);
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("staging"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

fn wait(ctx: &GpuContext, kernel: &str) -> Result<()> {
    ctx.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map(|_| ())
        .map_err(|e| HarnessError::Gpu {
            kernel: kernel.into(),
            message: format!("waiting for the queue: {e}"),
        })
}

/// Time a `copy_buffer_to_buffer` of `bytes` on this device: the yardstick effective bandwidth is divided by.
/// Returns bytes moved (read + write) per second, best of `repeats`.
pub fn copy_bandwidth(ctx: &GpuContext, bytes: u64, repeats: usize) -> Result<f64> {
    let bytes = bytes.max(4).div_ceil(4) * 4;
    let device = &ctx.device;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let mk = |usage| {
        count!(ctx, buffers_created, 1);
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("copy bench"),
            size: bytes,
            usage,
            mapped_at_creation: false,
        })
    };
    let a = mk(wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST);
    let b = mk(wgpu::BufferUsages::COPY_DST);
    // Touch the source once so the copy reads real pages.
    count!(ctx, upload_bytes, bytes);
    ctx.queue.write_buffer(&a, 0, &vec![1u8; bytes as usize]);
    let qs = device
        .features()
        .contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS)
        .then(|| {
            (
                device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: None,
                    ty: wgpu::QueryType::Timestamp,
                    count: 2,
                }),
                {
                    count!(ctx, buffers_created, 1);
                    device.create_buffer(&wgpu::BufferDescriptor {
                        label: None,
                        size: 16,
                        usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                        mapped_at_creation: false,
                    })
                },
                staging(ctx, 16),
            )
        });
    let mut best = f64::INFINITY;
    for _ in 0..repeats.max(1) {
        let mut enc = device.create_command_encoder(&Default::default());
        if let Some((set, _, _)) = &qs {
            enc.write_timestamp(set, 0);
        }
        enc.copy_buffer_to_buffer(&a, 0, &b, 0, bytes);
        if let Some((set, resolve, st)) = &qs {
            enc.write_timestamp(set, 1);
            enc.resolve_query_set(set, 0..2, resolve, 0);
            enc.copy_buffer_to_buffer(resolve, 0, st, 0, 16);
        }
        let start = Instant::now();
        count!(ctx, submissions, 1);
        ctx.queue.submit([enc.finish()]);
        wait(ctx, "copy")?;
        let mut ns = start.elapsed().as_nanos() as f64;
        if let Some((_, _, st)) = &qs {
            st.slice(..).map_async(wgpu::MapMode::Read, |_| {});
            wait(ctx, "copy")?;
            {
                let v = st
                    .slice(..)
                    .get_mapped_range()
                    .map_err(|e| HarnessError::Gpu {
                        kernel: "copy".into(),
                        message: e.to_string(),
                    })?;
                let t: &[u64] = bytemuck::cast_slice(&v);
                let gpu =
                    t[1].saturating_sub(t[0]) as f64 * ctx.queue.get_timestamp_period() as f64;
                if gpu > 0.0 {
                    ns = gpu;
                }
            }
            st.unmap();
        }
        best = best.min(ns);
    }
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(HarnessError::Gpu {
            kernel: "copy".into(),
            message: e.to_string(),
        });
    }
    Ok(2.0 * bytes as f64 / (best * 1e-9))
}
