//! The kernel declaration ("DSL", DESIGN.md section 3) and the generic verify driver.
//!
//! A kernel is declared once as a [`KernelDecl`] (WGSL file and entry, bindings by their WGSL names, the
//! dispatch rule, the outputs with their tolerances) plus a [`Kernel`] impl that generates cases and
//! runs the mirror. From that the driver gives: run on GPU, run the mirror, compare, time both.
use crate::compare::{
    bound_name, compare_f32_bounded, compare_halves, compare_u32, flush_subnormal, Comparison,
    Indexing, Tolerance, UlpHistogram,
};
use crate::context::GpuContext;
use crate::error::Result;
use crate::run::{
    grid_for, run, HostBuffer, HostResource, Pass, Resources, TimingSource, View, Workgroups,
};
use crate::shader::{ScalarKind, Shader};
use std::collections::BTreeMap;
use std::time::Instant;

/// One declared output binding and how close the GPU must come to the mirror on it.
#[derive(Clone, Copy, Debug)]
pub struct Output {
    pub binding: &'static str,
    pub tolerance: Tolerance,
}

impl Output {
    /// An output checked to `ulps` units in the last place, or `abs_floor` absolutely near zero.
    pub const fn ulp(binding: &'static str, ulps: u32, abs_floor: f32) -> Self {
        Self {
            binding,
            tolerance: Tolerance::Ulp { ulps, abs_floor },
        }
    }
}

/// How the dispatch grid follows from the data.
#[derive(Clone, Copy, Debug)]
pub enum DispatchRule {
    /// One invocation per element (runtime-array stride) of this binding, x-major, split into x * y
    /// workgroups past the per-dimension limit.
    PerElement { binding: &'static str },
    /// One invocation per item of something that is not an output element (e.g. an RSM quad whose
    /// invocation writes every layer); the case computes the count.
    PerItem { what: &'static str },
}

/// The declaration: everything about a kernel that is not code.
#[derive(Debug)]
pub struct KernelDecl {
    /// snake_case; equals the WGSL file stem and the cpu_mirror module name.
    pub name: &'static str,
    /// Repository-relative path of the WGSL file (for messages).
    pub wgsl_path: &'static str,
    /// The WGSL source (`include_str!` of `wgsl_path`).
    pub wgsl: &'static str,
    /// Shared helpers from `kernels/common/` prepended to `wgsl`, as (path, `include_str!`) pairs.
    pub includes: &'static [(&'static str, &'static str)],
    pub entry: &'static str,
    /// Input bindings, by WGSL name.
    pub inputs: &'static [&'static str],
    pub outputs: &'static [Output],
    pub dispatch: DispatchRule,
    /// The mirror function's path, for listings (`vxgi_cpu_mirror::module::function`).
    pub mirror: &'static str,
    /// One line: what the kernel computes.
    pub summary: &'static str,
}

/// The [`KernelDecl`] of the kernel `name` whose WGSL is `kernels/<name>.wgsl` in the calling crate:
/// `name`, `wgsl_path` and `wgsl` follow from the name, `includes` defaults to none and `entry` to
/// `"main"`; the rest is given as `field: value` pairs (`inputs`, `outputs`, `dispatch`, `mirror`,
/// `summary`: [`KernelDecl::check`] refuses a declaration that leaves one empty).
///
/// ```ignore
/// pub static DECL: KernelDecl = vxgi_harness::kernel_decl!("layer_decay",
///     inputs: Io::INPUTS, outputs: Io::OUTPUTS,
///     dispatch: DispatchRule::PerElement { binding: "decay" },
///     mirror: "vxgi_cpu_mirror::layer_decay::layer_decay", summary: "layer decay f(zc)");
/// ```
#[macro_export]
macro_rules! kernel_decl {
    ($name:literal, $($field:ident: $value:expr),* $(,)?) => {
        $crate::kernel_decl!($name in $name, $($field: $value),*)
    };
    // A second declaration of another kernel's file (another entry or volume): `"svo_bounce" in
    // "svo_cone_trace"`.
    ($name:literal in $file:literal, $($field:ident: $value:expr),* $(,)?) => {
        {
            // A declaration that gives every field leaves the defaults unused.
            #[allow(clippy::needless_update)]
            let decl = $crate::KernelDecl {
                name: $name,
                wgsl_path: concat!("kernels/", $file, ".wgsl"),
                wgsl: include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/kernels/", $file, ".wgsl")),
                $($field: $value,)*
                ..$crate::KernelDecl::DEFAULTS
            };
            decl
        }
    };
}

impl KernelDecl {
    /// What [`kernel_decl!`](crate::kernel_decl!) fills in where a declaration gives nothing: no
    /// includes, entry `main`; the other fields empty, which [`KernelDecl::check`] refuses.
    pub const DEFAULTS: KernelDecl = KernelDecl {
        name: "",
        wgsl_path: "",
        wgsl: "",
        includes: &[],
        entry: "main",
        inputs: &[],
        outputs: &[],
        dispatch: DispatchRule::PerElement { binding: "" },
        mirror: "",
        summary: "",
    };

    /// Whether the declaration names everything a listing and a verification need: its WGSL, a
    /// mirror, a summary and at least one output, the element binding of a per-element dispatch.
    pub fn check(&self) -> std::result::Result<(), String> {
        let empty = [
            ("name", self.name),
            ("wgsl", self.wgsl),
            ("mirror", self.mirror),
            ("summary", self.summary),
        ]
        .into_iter()
        .find(|(_, v)| v.trim().is_empty())
        .map(|(f, _)| f);
        let dispatch_empty = matches!(self.dispatch, DispatchRule::PerElement { binding: "" });
        match (empty, self.outputs.is_empty(), dispatch_empty) {
            (Some(f), ..) => Err(format!("kernel `{}`: `{f}` is empty", self.name)),
            (_, true, _) => Err(format!("kernel `{}` declares no output", self.name)),
            (.., true) => Err(format!("kernel `{}`: dispatch names no binding", self.name)),
            _ => Ok(()),
        }
    }

    /// Parse, validate and reflect the WGSL.
    pub fn shader(&self) -> Result<Shader> {
        let mut parts: Vec<(&str, &str)> = self.includes.to_vec();
        parts.push((self.wgsl_path, self.wgsl));
        Shader::from_parts(&parts)
    }

    /// Run `case` (its resources and passes) with this kernel on the GPU; read back `outputs`.
    pub fn run(
        &self,
        ctx: &GpuContext,
        case: &Case,
        outputs: &[&str],
    ) -> Result<crate::run::RunOutput> {
        case.run(ctx, &self.shader()?, self.name, outputs)
    }

    /// The complete WGSL (includes, then the kernel) for `create_shader_module` in another renderer.
    pub fn composed_source(&self) -> String {
        self.includes
            .iter()
            .map(|(_, src)| *src)
            .chain([self.wgsl])
            .collect::<Vec<_>>()
            .join("\n")
    }

    /// [`Self::composed_source`] with an interface header (WGSL `//` comments) for lifting the kernel
    /// into another renderer: what it computes, the files it is composed of, its mirror, the entry
    /// point and workgroup size, and every binding from naga reflection (group, slot, name, access,
    /// WGSL type, byte layout), marked where the entry does not use it. Validates first, so what is
    /// written is what the harness runs.
    pub fn export(&self) -> Result<String> {
        let shader = self.shader()?;
        let entry = shader.require_entry(self.name, self.entry)?;
        let mut h = vec![
            format!("{} (exported by `vxgi export`)", self.name),
            self.summary.to_string(),
            String::new(),
            format!(
                "Composed of, in this order: {}",
                self.includes
                    .iter()
                    .map(|(p, _)| *p)
                    .chain([self.wgsl_path])
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            format!("Scalar mirror (the definition this WGSL is checked against): {}", self.mirror),
            format!(
                "Verify on your device: vxgi verify --kernel {} (GPU vs mirror, per-element bounds)",
                self.name
            ),
            String::new(),
            format!(
                "Interface: entry `{}`, @workgroup_size({}, {}, {})",
                self.entry,
                entry.workgroup_size[0],
                entry.workgroup_size[1],
                entry.workgroup_size[2]
            ),
        ];
        h.push(match self.dispatch {
            DispatchRule::PerElement { binding } => format!(
                "Dispatch: one invocation per element of `{binding}` (the grid: see the kernel's header comment)"
            ),
            DispatchRule::PerItem { what } => format!("Dispatch: one invocation (or workgroup) per {what}"),
        });
        let mut order: Vec<usize> = (0..shader.bindings.len()).collect();
        order.sort_by_key(|&i| (shader.bindings[i].group, shader.bindings[i].binding));
        for i in order {
            let b = &shader.bindings[i];
            let unused = if entry.uses.contains(&i) {
                ""
            } else {
                " (not used by this entry)"
            };
            h.push(format!(
                "  @group({}) @binding({}) {}: {}, {}{unused}",
                b.group,
                b.binding,
                b.name,
                describe(&b.kind),
                b.ty
            ));
            // A struct (or an array of one): its members' byte offsets, for filling the buffer.
            let inner =
                b.ty.strip_prefix("array<")
                    .and_then(|t| t.strip_suffix('>'))
                    .unwrap_or(&b.ty);
            if let Some((size, members)) = shader.struct_layout(inner) {
                let m: Vec<String> = members.iter().map(|(n, o)| format!("{n} @{o}")).collect();
                h.push(format!("      {inner} ({size} B): {}", m.join(", ")));
            }
        }
        let mut out: String = h
            .iter()
            .map(|l| format!("// {l}").trim_end().to_string() + "\n")
            .collect();
        out.push('\n');
        out.push_str(&self.composed_source());
        Ok(out)
    }

    pub fn output(&self, binding: &str) -> Option<&Output> {
        self.outputs.iter().find(|o| o.binding == binding)
    }

    /// Every declared input and output binding bound to the host buffer of the same name.
    pub fn bind_by_name(&self) -> Vec<(String, View)> {
        crate::run::bind_same_names(
            self.inputs
                .iter()
                .copied()
                .chain(self.outputs.iter().map(|o| o.binding)),
        )
    }

    /// The case of a kernel that computes one output element per input element, `n` of them: `inputs`
    /// as given (by WGSL binding name), every declared output zeroed at `n` elements of its WGSL
    /// array's stride (from reflection), one pass of the declared entry over `n` elements, and each
    /// output compared element by element (linear indexing). An output binding that is not a
    /// runtime-sized storage array is refused, naming it and its WGSL line.
    pub fn elementwise_case(
        &self,
        shader: &Shader,
        ctx: &GpuContext,
        n: usize,
        inputs: Resources,
        label: String,
        seed: u64,
    ) -> Result<Case> {
        use crate::shader::BindingKind;
        let mut resources = inputs;
        let mut checks = Vec::new();
        let mut bytes: u64 = resources
            .values()
            .filter_map(HostResource::buffer)
            .map(|b| b.bytes.len() as u64)
            .sum();
        for o in self.outputs {
            let b = shader.require_binding(self.name, o.binding)?;
            let layout = match &b.kind {
                BindingKind::Storage { layout, .. }
                    if layout.runtime_stride.is_some() && layout.fixed_size == 0 =>
                {
                    layout
                }
                _ => {
                    return Err(crate::error::HarnessError::Invalid {
                        kernel: self.name.into(),
                        message: format!(
                            "output `{}` ({}:{}) is `{}`, not a plain runtime-sized storage array: an elementwise case cannot size it",
                            o.binding, self.wgsl_path, b.line, b.ty
                        ),
                    })
                }
            };
            let len = n * layout.runtime_stride.expect("matched") as usize;
            bytes += len as u64;
            resources.insert(
                o.binding.into(),
                HostResource::Buffer(HostBuffer::zeroed(len, layout.scalar)),
            );
            checks.push(Check {
                resource: o.binding.into(),
                output: o.binding,
                indexing: Indexing::Linear,
            });
        }
        let pass = self.pass(shader, ctx, self.name.into(), self.bind_by_name(), n as u64);
        Ok(Case {
            label,
            seed,
            resources,
            passes: vec![pass],
            checks,
            effective_bytes: bytes,
        })
    }

    /// A case of `io`'s buffers ([`crate::bindings!`]) and one pass of the declared entry over
    /// `elements` elements, every binding bound to the resource of its name.
    pub fn case_of(
        &self,
        shader: &Shader,
        ctx: &GpuContext,
        io: &impl crate::bindings::Bindings,
        elements: u64,
        label: String,
        seed: u64,
    ) -> Case {
        let pass = self.pass(shader, ctx, self.name.into(), self.bind_by_name(), elements);
        io.case(label, seed, vec![pass])
    }

    /// A pass of the declared entry with `bindings` (WGSL name -> view), its grid from the dispatch rule
    /// applied to `elements` elements of the rule's binding.
    pub fn pass(
        &self,
        shader: &Shader,
        ctx: &GpuContext,
        label: String,
        bindings: Vec<(String, View)>,
        elements: u64,
    ) -> Pass {
        let wg = shader
            .entry(self.entry)
            .map(|e| e.workgroup_size[0])
            .unwrap_or(1);
        let grid = grid_for(
            elements,
            wg,
            ctx.limits().max_compute_workgroups_per_dimension,
        );
        Pass {
            label,
            entry: self.entry.into(),
            bindings,
            workgroups: Workgroups::Direct(grid),
        }
    }
}

/// How the mirror treats subnormals: IEEE, or flushed to zero on every input, intermediate and output
/// (the other behaviour WGSL allows a GPU).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FloatMode {
    Ieee,
    FlushToZero,
}

impl FloatMode {
    #[inline]
    pub fn f(self, x: f32) -> f32 {
        match self {
            FloatMode::Ieee => x,
            FloatMode::FlushToZero => flush_subnormal(x),
        }
    }
}

/// A resource to compare after a run: which declared output it is an instance of, and how to name
/// its elements in reports.
#[derive(Clone, Debug)]
pub struct Check {
    pub resource: String,
    pub output: &'static str,
    pub indexing: Indexing,
}

impl Check {
    /// The check of the resource named after its output.
    pub fn of(output: &'static str, indexing: Indexing) -> Self {
        Check {
            resource: output.to_string(),
            output,
            indexing,
        }
    }
}

/// One generated test case: the host resources, the passes, what to compare.
#[derive(Clone, Debug)]
pub struct Case {
    pub label: String,
    pub seed: u64,
    pub resources: Resources,
    pub passes: Vec<Pass>,
    pub checks: Vec<Check>,
    /// Bytes the kernel must read once plus write once (for effective bandwidth).
    pub effective_bytes: u64,
}

impl Case {
    /// Run its passes once with `shader` (kernel `kernel`, for messages) on the GPU; read back
    /// `readback`.
    pub fn run(
        &self,
        ctx: &GpuContext,
        shader: &Shader,
        kernel: &str,
        readback: &[&str],
    ) -> Result<crate::run::RunOutput> {
        crate::run::run(ctx, shader, kernel, &self.resources, &self.passes, readback)
    }

    /// This case with the check of `resource` indexed by `indexing` (a grid rather than the element
    /// list [`crate::bindings::Bindings::case`] assumes), for the mismatch report.
    pub fn with_indexing(mut self, resource: &str, indexing: Indexing) -> Self {
        for c in self.checks.iter_mut().filter(|c| c.resource == resource) {
            c.indexing = indexing.clone();
        }
        self
    }

    /// This case with every check indexed as a grid of `dims` elements, each with the components its
    /// check had (a linear check's element is one component).
    pub fn with_grid(mut self, dims: [u32; 3]) -> Self {
        for c in &mut self.checks {
            let components = match c.indexing {
                Indexing::Grid { components, .. } => components,
                _ => 1,
            };
            c.indexing = Indexing::Grid { dims, components };
        }
        self
    }

    /// This case with every check indexed as a flat element list (the report names element i, not
    /// grid coordinates).
    pub fn with_linear_indexing(mut self) -> Self {
        for c in &mut self.checks {
            c.indexing = Indexing::Linear;
        }
        self
    }

    /// This case with `bytes` as its effective bytes: the kernel's own traffic model where it reads
    /// less than every bound byte once (a tree, a table) or some bytes more than once.
    pub fn with_effective_bytes(mut self, bytes: u64) -> Self {
        self.effective_bytes = bytes;
        self
    }

    /// Point every binding (and indirect dispatch) of the passes that uses resource `from` at `to`
    /// instead, and move the resource (if the case has it) to that name — how a case joins a chain
    /// (`prepare_chain`) whose other stages use the name for something else. With `shared`, the case's own copy is dropped:
    /// an earlier stage of the chain provides `to`.
    pub fn rename_resource(&mut self, from: &str, to: &str, shared: bool) {
        use crate::run::View;
        if let Some(r) = self.resources.remove(from) {
            if !shared {
                self.resources.insert(to.into(), r);
            }
        }
        for p in &mut self.passes {
            for (_, v) in &mut p.bindings {
                if let View::Buffer(n) | View::BufferRange { name: n, .. } = v {
                    if n == from {
                        *n = to.into();
                    }
                }
            }
            if let crate::run::Workgroups::Indirect { buffer, .. } = &mut p.workgroups {
                if buffer == from {
                    *buffer = to.into();
                }
            }
        }
    }
}

/// What a mirror returns: the value of every checked resource, by name.
pub type MirrorOutputs = BTreeMap<String, HostBuffer>;

/// Mirror outputs of these named buffers.
pub fn mirror_outputs<const N: usize>(entries: [(&str, HostBuffer); N]) -> MirrorOutputs {
    entries
        .into_iter()
        .map(|(name, b)| (name.to_string(), b))
        .collect()
}

/// A declared kernel with its case generator and mirror.
pub trait Kernel: Sync {
    fn decl(&self) -> &'static KernelDecl;

    /// Case `index` of a run seeded with `seed`; cycles through the kernel's families of hard inputs.
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case;

    /// The mirror's value of every checked resource. `data` holds the case's inputs overlaid with what
    /// the GPU read back, so a multi-pass kernel verifies each pass on exactly the input the GPU pass saw.
    fn mirror(&self, case: &Case, data: &Resources, mode: FloatMode) -> MirrorOutputs;

    /// Put an output whose order the GPU leaves free (atomic allocation) into a canonical order before
    /// comparing; applied to GPU and mirror alike. `all` holds every checked buffer of the same side as
    /// it was produced (before any canonicalising), for outputs whose order follows another's (e.g.
    /// bricks in the order of their nodes).
    fn canonicalise(
        &self,
        _resource: &str,
        _data: &mut HostBuffer,
        _all: &BTreeMap<String, HostBuffer>,
    ) {
    }
}

/// Deliberately damage the GPU result before comparing: the harness must catch it.
#[derive(Clone, Debug)]
pub struct Corruption {
    pub resource: String,
    pub index: usize,
}

#[derive(Clone, Debug, Default)]
pub struct VerifyOptions {
    pub cases: usize,
    pub seed: u64,
    pub corrupt: Option<Corruption>,
}

impl VerifyOptions {
    /// `cases` generated cases from seed 1, nothing corrupted.
    pub fn cases(cases: usize) -> Self {
        Self {
            cases,
            seed: 1,
            corrupt: None,
        }
    }
}

/// Test values for generated cases: each call draws, from `seed` (ChaCha8), one of `hard` (one draw
/// in eight) or a uniform value in [0, 10) on a 1e-4 grid; the same seed gives the same sequence.
pub fn generated_floats(seed: u64, hard: &[f32]) -> impl FnMut() -> f32 + '_ {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    move || {
        if !hard.is_empty() && rng.random_ratio(1, 8) {
            hard[rng.random_range(0..hard.len())]
        } else {
            rng.random_range(0..100_000u32) as f32 * 1e-4
        }
    }
}

/// What verifying one kernel over many cases found.
#[derive(Clone, Debug)]
pub struct KernelReport {
    pub kernel: String,
    pub cases: usize,
    pub elements: u64,
    pub max_ulp: u64,
    pub histogram: UlpHistogram,
    pub gpu_ns: f64,
    pub mirror_ns: f64,
    pub effective_bytes: u64,
    pub largest_case_bytes: u64,
    pub timing: Option<TimingSource>,
    /// Comparisons that failed (each with its report).
    pub failures: Vec<Comparison>,
    /// The generated case each failure came from, `failures[k]` from `Kernel::case(.., seed,
    /// failed_cases[k])`: what `vxgi verify --case` replays.
    pub failed_cases: Vec<usize>,
    pub flushed: usize,
    /// Largest fraction of a per-element bound used (outputs with `Tolerance::MirrorBound`).
    pub max_bound_use: f64,
}

impl KernelReport {
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }
    /// This report, or the first failure's mismatch report (which names its case) as the error.
    pub fn check(self) -> Result<Self, String> {
        match self.failures.first() {
            Some(f) => Err(f.report()),
            None => Ok(self),
        }
    }
    pub fn p99_ulp(&self) -> u64 {
        self.histogram.quantile(0.99)
    }
    /// Effective bytes per second of GPU time.
    pub fn effective_bandwidth(&self) -> f64 {
        if self.gpu_ns > 0.0 {
            self.effective_bytes as f64 / (self.gpu_ns * 1e-9)
        } else {
            0.0
        }
    }
}

/// An f32 buffer with its subnormals flushed, read byte-wise (a buffer's bytes need not be 4-aligned:
/// a struct uploaded through `HostBuffer::f32` of a byte copy, an empty Vec).
fn flush_buffer(b: &HostBuffer) -> HostBuffer {
    let flushed: Vec<f32> = b
        .bytes
        .chunks_exact(4)
        .map(|c| flush_subnormal(f32::from_le_bytes([c[0], c[1], c[2], c[3]])))
        .collect();
    HostBuffer::f32(&flushed)
}

/// A binding's kind and byte layout in words, for [`KernelDecl::export`].
fn describe(kind: &crate::shader::BindingKind) -> String {
    use crate::shader::{BindingKind as K, BufferLayout};
    let layout = |l: &BufferLayout| match l.runtime_stride {
        Some(s) if l.fixed_size > 0 => format!("{} B + n x {s} B", l.fixed_size),
        Some(s) => format!("n x {s} B"),
        None => format!("{} B", l.fixed_size),
    };
    match kind {
        K::Uniform(l) => format!("uniform, {}", layout(l)),
        K::Storage {
            read_only,
            layout: l,
        } => format!(
            "storage {}, {}",
            if *read_only { "read" } else { "read_write" },
            layout(l)
        ),
        K::SampledTexture { dim, sample } => format!("sampled texture {dim:?} of {sample:?}"),
        K::StorageTexture {
            dim,
            format,
            access,
        } => format!("storage texture {dim:?}, {format:?}, {access}"),
        K::Sampler => "sampler".into(),
    }
}

fn flush_resources(r: &Resources) -> Resources {
    r.iter()
        .map(|(k, v)| {
            let v = match v {
                HostResource::Buffer(b) if b.scalar == ScalarKind::F32 => {
                    HostResource::Buffer(flush_buffer(b))
                }
                other => other.clone(),
            };
            (k.clone(), v)
        })
        .collect()
}

/// Run one case on the GPU and the mirror and compare every checked resource.
pub fn verify_case(
    ctx: &GpuContext,
    shader: &Shader,
    kernel: &dyn Kernel,
    case: &Case,
    corrupt: Option<&Corruption>,
) -> Result<(Vec<Comparison>, f64, f64, TimingSource)> {
    let decl = kernel.decl();
    let readback: Vec<&str> = case.checks.iter().map(|c| c.resource.as_str()).collect();
    let mut out = run(
        ctx,
        shader,
        decl.name,
        &case.resources,
        &case.passes,
        &readback,
    )?;
    if let Some(c) = corrupt {
        let tol = case
            .checks
            .iter()
            .find(|k| k.resource == c.resource)
            .and_then(|k| decl.output(k.output))
            .map(|o| o.tolerance);
        let word = match out.resources.get_mut(&c.resource) {
            Some(HostResource::Buffer(b)) => {
                bytemuck::cast_slice_mut::<u8, u32>(&mut b.bytes).get_mut(c.index)
            }
            _ => None,
        };
        let Some(w) = word else {
            return Err(crate::HarnessError::Invalid {
                kernel: decl.name.into(),
                message: format!(
                    "cannot corrupt `{}`[{}]: no such checked element",
                    c.resource, c.index
                ),
            });
        };
        // Move the element one ULP past a ULP tolerance, flip bits under an exact one, and add 1 under
        // absolute ones (bounds of a few ULP cannot absorb that).
        let x = f32::from_bits(*w);
        *w = match tol {
            Some(Tolerance::Ulp { ulps, .. }) if x.abs() > 1e-30 => w.wrapping_add(ulps + 1),
            Some(Tolerance::MirrorBound | Tolerance::AbsRel { .. })
                if x.is_finite() && x + 1.0 != x =>
            {
                (x + 1.0).to_bits()
            }
            _ => *w ^ 0x0040_0001,
        };
    }
    let mut data = case.resources.clone();
    for (k, v) in &out.resources {
        data.insert(k.clone(), v.clone());
    }
    let t0 = Instant::now();
    let mut expected = kernel.mirror(case, &data, FloatMode::Ieee);
    let mirror_ns = t0.elapsed().as_nanos() as f64;
    let has_subnormal = |b: &HostBuffer| {
        b.scalar == ScalarKind::F32
            && b.bytes
                .chunks_exact(4)
                .any(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]).is_subnormal())
    };
    let ftz_needed = data
        .values()
        .filter_map(HostResource::buffer)
        .any(has_subnormal)
        || expected.values().any(has_subnormal);
    // Outputs flushed too: WGSL lets a GPU flush a subnormal result whether or not the mirror's
    // FlushToZero mode models it (seen on an H100: a light term of 1.7e-42 written as 0).
    let mut expected_ftz = ftz_needed.then(|| {
        kernel
            .mirror(case, &flush_resources(&data), FloatMode::FlushToZero)
            .into_iter()
            .map(|(k, b)| {
                let b = if b.scalar == ScalarKind::F32 {
                    flush_buffer(&b)
                } else {
                    b
                };
                (k, b)
            })
            .collect::<BTreeMap<_, _>>()
    });
    // Both sides as produced, for canonicalising outputs whose order follows another output's.
    let buffers_of = |r: &Resources| -> BTreeMap<String, HostBuffer> {
        r.iter()
            .filter_map(|(k, v)| v.buffer().map(|b| (k.clone(), b.clone())))
            .collect()
    };
    let gpu_all = buffers_of(&out.resources);
    let mirror_all = expected.clone();
    let ftz_all = expected_ftz.clone();
    let mut comps = Vec::new();
    for check in &case.checks {
        let tol = decl
            .output(check.output)
            .map(|o| o.tolerance)
            .unwrap_or(Tolerance::Exact);
        let mut gpu = out
            .resources
            .remove(&check.resource)
            .and_then(|r| match r {
                HostResource::Buffer(b) => Some(b),
                _ => None,
            })
            .expect("read back");
        let mut mirror = expected
            .remove(&check.resource)
            .unwrap_or_else(|| panic!("mirror of `{}` gave no `{}`", decl.name, check.resource));
        kernel.canonicalise(&check.resource, &mut gpu, &gpu_all);
        kernel.canonicalise(&check.resource, &mut mirror, &mirror_all);
        let meta = (
            decl.name,
            check.resource.as_str(),
            case.label.as_str(),
            case.seed,
        );
        let ftz = expected_ftz
            .as_mut()
            .and_then(|e| e.remove(&check.resource))
            .map(|mut b| {
                kernel.canonicalise(
                    &check.resource,
                    &mut b,
                    ftz_all.as_ref().unwrap_or(&mirror_all),
                );
                b
            });
        let c = match gpu.scalar {
            ScalarKind::F32 => {
                // Per-element bounds (Tolerance::MirrorBound) come from the IEEE mirror run and are
                // not canonicalised: outputs with a free order use a fixed tolerance.
                let bounds = expected.remove(&bound_name(&check.resource));
                compare_f32_bounded(
                    meta,
                    gpu.as_f32(),
                    mirror.as_f32(),
                    ftz.as_ref().map(|b| b.as_f32()),
                    bounds.as_ref().map(|b| b.as_f32()),
                    tol,
                    check.indexing.clone(),
                )
            }
            // Words of two binary16 values, compared half by half.
            _ if matches!(tol, Tolerance::Half { .. }) => compare_halves(
                meta,
                gpu.as_u32(),
                mirror.as_u32(),
                ftz.as_ref().map(|b| b.as_u32()),
                tol,
                check.indexing.halves(),
            ),
            // Integer outputs may depend on float inputs (occlusion_voxels: alpha > 0): where the
            // inputs hold subnormals, the flush-to-zero mirror's integers are accepted too.
            _ => compare_u32(
                meta,
                gpu.as_u32(),
                mirror.as_u32(),
                ftz.as_ref().map(|b| b.as_u32()),
                check.indexing.clone(),
            ),
        };
        comps.push(c);
    }
    Ok((comps, out.gpu_ns, mirror_ns, out.timing))
}

/// Verify `kernel` on `opts.cases` generated cases. `progress` is called after each case.
pub fn verify(
    ctx: &GpuContext,
    kernel: &dyn Kernel,
    opts: &VerifyOptions,
    progress: &mut dyn FnMut(usize),
) -> Result<KernelReport> {
    let decl = kernel.decl();
    decl.check()
        .map_err(|message| crate::HarnessError::Invalid {
            kernel: decl.name.into(),
            message,
        })?;
    let shader = decl.shader()?;
    let mut rep = KernelReport {
        kernel: decl.name.into(),
        cases: 0,
        elements: 0,
        max_ulp: 0,
        histogram: UlpHistogram::default(),
        gpu_ns: 0.0,
        mirror_ns: 0.0,
        effective_bytes: 0,
        largest_case_bytes: 0,
        timing: None,
        failures: Vec::new(),
        failed_cases: Vec::new(),
        flushed: 0,
        max_bound_use: 0.0,
    };
    for i in 0..opts.cases {
        let case = kernel.case(&shader, ctx, opts.seed, i);
        let corrupt = if i == 0 { opts.corrupt.as_ref() } else { None };
        let (comps, gpu_ns, mirror_ns, timing) = verify_case(ctx, &shader, kernel, &case, corrupt)?;
        rep.cases += 1;
        rep.gpu_ns += gpu_ns;
        rep.mirror_ns += mirror_ns;
        rep.effective_bytes += case.effective_bytes;
        rep.largest_case_bytes = rep.largest_case_bytes.max(case.effective_bytes);
        rep.timing = Some(timing);
        for c in comps {
            rep.elements += c.elements as u64;
            rep.max_ulp = rep.max_ulp.max(c.max_ulp);
            rep.histogram.merge(&c.histogram);
            rep.flushed += c.flushed;
            rep.max_bound_use = rep.max_bound_use.max(c.max_bound_use);
            if !c.passed() {
                rep.failures.push(c);
                rep.failed_cases.push(i);
            }
        }
        progress(i + 1);
    }
    Ok(rep)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_declaration_that_leaves_a_field_empty_is_refused_by_name() {
        let base = KernelDecl {
            name: "k",
            wgsl: "@compute @workgroup_size(1) fn main() {}",
            outputs: &[Output {
                binding: "y",
                tolerance: Tolerance::Exact,
            }],
            dispatch: DispatchRule::PerElement { binding: "y" },
            mirror: "m::f",
            summary: "s",
            ..KernelDecl::DEFAULTS
        };
        assert_eq!(base.check(), Ok(()));
        let e = KernelDecl {
            summary: " ",
            ..base
        };
        assert!(e.check().unwrap_err().contains("`summary`"));
        let e = KernelDecl {
            outputs: &[],
            ..base
        };
        assert!(e.check().unwrap_err().contains("no output"));
        let e = KernelDecl {
            dispatch: DispatchRule::PerElement { binding: "" },
            ..base
        };
        assert!(e.check().unwrap_err().contains("dispatch"));
    }
}
