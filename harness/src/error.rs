//! Every way the harness refuses work, with enough context to act on it.
use thiserror::Error;

/// Install hint printed whenever no GPU adapter is found.
pub const NO_ADAPTER_HINT: &str = "no GPU adapter found. On a machine without a GPU install Mesa's software \
Vulkan driver (lavapipe): `apt-get update && apt-get install -y mesa-vulkan-drivers` (Debian/Ubuntu, as root), \
then run again. WGPU_BACKEND=vulkan forces the Vulkan backend.";

#[derive(Debug, Error)]
pub enum HarnessError {
    #[error("{NO_ADAPTER_HINT} (wgpu said: {0})")]
    NoAdapter(String),
    /// A context error recorded once and handed to every later caller (see `GpuContext::shared`).
    #[error("{0}")]
    Context(String),
    #[error("could not create a device on adapter {adapter}: {message}")]
    RequestDevice { adapter: String, message: String },
    #[error("{path}:{line}:{column}: WGSL parse error: {message}\n{rendered}")]
    WgslParse {
        path: String,
        line: u32,
        column: u32,
        message: String,
        rendered: String,
    },
    #[error("{path}:{line}:{column}: WGSL validation error: {message}\n{rendered}")]
    WgslValidate {
        path: String,
        line: u32,
        column: u32,
        message: String,
        rendered: String,
    },
    #[error("{path}: naga could not lay out the module's types: {message}")]
    Layout { path: String, message: String },
    #[error("kernel `{kernel}`: no entry point `{entry}` in {path} (entry points: {available})")]
    UnknownEntry {
        kernel: String,
        path: String,
        entry: String,
        available: String,
    },
    #[error(
        "kernel `{kernel}`: {path} declares no binding named `{binding}` (bindings: {available})"
    )]
    UnknownBinding {
        kernel: String,
        path: String,
        binding: String,
        available: String,
    },
    #[error("kernel `{kernel}`: binding `{binding}` ({path}:{line}) is used by entry `{entry}` but nothing is bound to it")]
    MissingBinding {
        kernel: String,
        path: String,
        line: u32,
        binding: String,
        entry: String,
    },
    #[error("kernel `{kernel}`: binding `{binding}` ({path}:{line}) expects {expected}, but the host {got}")]
    BindingMismatch {
        kernel: String,
        path: String,
        line: u32,
        binding: String,
        expected: String,
        got: String,
    },
    #[error("kernel `{kernel}`: no host resource named `{resource}` (pass `{pass}`)")]
    UnknownResource {
        kernel: String,
        pass: String,
        resource: String,
    },
    #[error("kernel `{kernel}`: {what} is {value}, past the device limit {limit_name} = {limit}")]
    Limit {
        kernel: String,
        what: String,
        value: u64,
        limit_name: &'static str,
        limit: u64,
    },
    #[error("kernel `{kernel}`: the GPU reported an error: {message}")]
    Gpu { kernel: String, message: String },
    #[error("kernel `{kernel}`: {message}")]
    Invalid { kernel: String, message: String },
    #[error("could not read {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
}

pub type Result<T, E = HarnessError> = std::result::Result<T, E>;
