//! vxgi-harness: the generic half of the kernel verification harness.
//!
//! * [`shader`]: naga parse + validate (file:line:column errors) and reflection of bindings and entries.
//! * [`context`]: a wgpu device on any adapter (lavapipe where there is no GPU), or the caller's own.
//! * [`run`]: host resources, passes, checks against reflection and device limits *before* any dispatch,
//!   dispatch (direct or indirect), readback (textures with padded rows), timing.
//! * [`compare`]: exact / ULP+floor / abs-rel comparison with mismatch reports and ULP statistics.
//! * [`kernel`]: the kernel declaration and the verify driver.
//! * [`bindings`](mod@bindings): a kernel's buffer bindings as one typed struct ([`bindings!`]), from which its
//!   declared inputs and outputs, a case's resources and checks and the mirror's unpacking follow.
//!
//! It knows no kernel; the declarations live in the `vxgi` crate.
//!
//! Example: `examples/tdd_own_kernel.rs` (its WGSL beside it) declares a kernel that is not part of
//! vxgi, its mirror and tolerance, and verifies it with [`verify`] (`cargo run --example
//! tdd_own_kernel`); `examples/mip_on_own_device.rs` records a vxgi kernel on a device of its own.
pub mod bindings;
pub mod compare;
pub mod context;
pub mod error;
pub mod kernel;
pub mod run;
pub mod shader;

pub use bindings::{Bindings, Block, Structs};
pub use compare::{bound, bound_name, bounded, Comparison, Indexing, Tolerance};
pub use context::{thread_counters, Counters, GpuContext};
pub use error::{HarnessError, Result};
pub use kernel::{
    generated_floats, mirror_outputs, verify, Case, Check, Corruption, DispatchRule, FloatMode,
    Kernel, KernelDecl, KernelReport, MirrorOutputs, Output, VerifyOptions,
};
pub use run::{
    buffer_as, buffers, prepare, prepare_chain, prepare_chain_adopting, run_chain, HostBuffer,
    HostResource, HostTexture, Pass, Prepared, ReadbackSet, Resources, RunOutput, Stage,
    TimingSource, View, Workgroups,
};
pub use shader::{Binding, BindingKind, ScalarKind, Shader};

/// What a kernel declaration names: `use vxgi_harness::prelude::*;` (no `Result`, which would shadow
/// the standard one).
pub mod prelude {
    pub use crate::bindings::{Bindings, Block, Structs};
    pub use crate::compare::{bound, bounded, Indexing, Tolerance};
    pub use crate::context::GpuContext;
    pub use crate::kernel::{
        mirror_outputs, Case, Check, DispatchRule, FloatMode, Kernel, KernelDecl, MirrorOutputs,
        Output,
    };
    pub use crate::run::{buffers, HostBuffer, HostResource, Resources, View};
    pub use crate::shader::{ScalarKind, Shader};
}
