//! WGSL front end: parse and validate with naga, then reflect bindings and entry points.
use crate::error::{HarnessError, Result};
use naga::valid::{Capabilities, GlobalUse, ValidationFlags, Validator};

/// The scalar a buffer is made of, as far as comparison cares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScalarKind {
    F32,
    U32,
    I32,
    /// A struct with members of different scalar kinds (e.g. a parameter block).
    Mixed,
}

/// Reflected layout of a buffer binding (naga's layouter, so WGSL's alignment rules and vec3 padding hold).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BufferLayout {
    /// Size of the sized part: the whole type, or the prefix before a runtime-sized array.
    pub fixed_size: u32,
    /// Element stride of the trailing runtime-sized array, if any.
    pub runtime_stride: Option<u32>,
    pub scalar: ScalarKind,
}

#[derive(Clone, Debug, PartialEq)]
pub enum BindingKind {
    Uniform(BufferLayout),
    Storage {
        read_only: bool,
        layout: BufferLayout,
    },
    SampledTexture {
        dim: wgpu::TextureViewDimension,
        sample: ScalarKind,
    },
    StorageTexture {
        dim: wgpu::TextureViewDimension,
        format: Option<wgpu::TextureFormat>,
        access: String,
    },
    Sampler,
}

#[derive(Clone, Debug)]
pub struct Binding {
    pub name: String,
    pub group: u32,
    pub binding: u32,
    pub kind: BindingKind,
    /// The WGSL type as written (e.g. `array<vec4<f32>>`).
    pub ty: String,
    /// 1-based line of the declaration in the WGSL file.
    pub line: u32,
}

#[derive(Clone, Debug)]
pub struct EntryPoint {
    pub name: String,
    pub workgroup_size: [u32; 3],
    /// Indices into `Shader::bindings` of the globals this entry reads or writes.
    pub uses: Vec<usize>,
}

/// A parsed, validated and reflected WGSL module.
#[derive(Debug)]
pub struct Shader {
    pub path: String,
    pub source: String,
    pub module: naga::Module,
    pub bindings: Vec<Binding>,
    pub entries: Vec<EntryPoint>,
}

impl Shader {
    /// Read and validate a WGSL file.
    pub fn load(path: impl AsRef<std::path::Path>) -> Result<Self> {
        let path = path.as_ref();
        let source = std::fs::read_to_string(path).map_err(|source| HarnessError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_wgsl(&path.display().to_string(), &source)
    }

    /// Parse, validate and reflect `source`; `path` labels every message.
    pub fn from_wgsl(path: &str, source: &str) -> Result<Self> {
        Self::from_parts(&[(path, source)])
    }

    /// The small include step of DESIGN.md section 2: `parts` are (path, source) pairs, shared helpers
    /// from `kernels/common/` first and the kernel last, concatenated in order. Messages name the part
    /// and line the error is in. Includes hold functions and constants only (bindings belong to the
    /// kernel file, whose lines reflection reports).
    pub fn from_parts(parts: &[(&str, &str)]) -> Result<Self> {
        let (path, _) = *parts.last().expect("at least the kernel itself");
        let mut source = String::new();
        let mut starts = Vec::new(); // (first line, path)
        for (p, src) in parts {
            starts.push((source.matches('\n').count() as u32 + 1, *p));
            source.push_str(src);
            if !src.ends_with('\n') {
                source.push('\n');
            }
        }
        // Global line -> (part path, line within the part).
        let locate = |line: u32| -> (String, u32) {
            let (first, p) = starts
                .iter()
                .rev()
                .find(|(first, _)| *first <= line)
                .copied()
                .unwrap_or((1, path));
            (p.to_string(), line + 1 - first)
        };
        let kernel_first_line = starts.last().map(|s| s.0).unwrap_or(1);
        let source = source.as_str();
        let module = naga::front::wgsl::parse_str(source).map_err(|e| {
            let (line, column) = e
                .location(source)
                .map(|l| (l.line_number, l.line_position))
                .unwrap_or((0, 0));
            let (file, line) = locate(line);
            HarnessError::WgslParse {
                path: file,
                line,
                column,
                message: e.message().to_string(),
                rendered: e.emit_to_string_with_path(source, path),
            }
        })?;
        let info = Validator::new(ValidationFlags::all(), Capabilities::all())
            .validate(&module)
            .map_err(|e| {
                let (line, column) = e
                    .location(source)
                    .map(|l| (l.line_number, l.line_position))
                    .unwrap_or((0, 0));
                let (file, line) = locate(line);
                HarnessError::WgslValidate {
                    path: file,
                    line,
                    column,
                    message: e.as_inner().to_string(),
                    rendered: e.emit_to_string_with_path(source, path),
                }
            })?;
        let mut layouter = naga::proc::Layouter::default();
        layouter
            .update(module.to_ctx())
            .map_err(|e| HarnessError::Layout {
                path: path.to_string(),
                message: e.to_string(),
            })?;

        let mut bindings = Vec::new();
        let mut handle_of = Vec::new();
        for (handle, var) in module.global_variables.iter() {
            let Some(rb) = &var.binding else { continue };
            let kind = reflect_kind(&module, &layouter, var);
            let line = (module
                .global_variables
                .get_span(handle)
                .location(source)
                .line_number
                + 1)
            .saturating_sub(kernel_first_line);
            bindings.push(Binding {
                name: var
                    .name
                    .clone()
                    .unwrap_or_else(|| format!("@group({})@binding({})", rb.group, rb.binding)),
                group: rb.group,
                binding: rb.binding,
                kind,
                ty: type_name(&module, var.ty),
                line,
            });
            handle_of.push(handle);
        }
        let entries = module
            .entry_points
            .iter()
            .enumerate()
            .filter(|(_, ep)| ep.stage == naga::ShaderStage::Compute)
            .map(|(i, ep)| {
                let fi = info.get_entry_point(i);
                let uses = handle_of
                    .iter()
                    .enumerate()
                    .filter(|(_, h)| !fi[**h].is_empty() && fi[**h] != GlobalUse::empty())
                    .map(|(k, _)| k)
                    .collect();
                EntryPoint {
                    name: ep.name.clone(),
                    workgroup_size: ep.workgroup_size,
                    uses,
                }
            })
            .collect();
        Ok(Shader {
            path: path.to_string(),
            source: source.to_string(),
            module,
            bindings,
            entries,
        })
    }

    pub fn binding(&self, name: &str) -> Option<&Binding> {
        self.bindings.iter().find(|b| b.name == name)
    }

    pub fn entry(&self, name: &str) -> Option<&EntryPoint> {
        self.entries.iter().find(|e| e.name == name)
    }

    /// [`Self::entry`], or the error naming `kernel`, this file and the entry points it has.
    pub fn require_entry(&self, kernel: &str, name: &str) -> Result<&EntryPoint> {
        self.entry(name).ok_or_else(|| HarnessError::UnknownEntry {
            kernel: kernel.into(),
            path: self.path.clone(),
            entry: name.into(),
            available: self
                .entries
                .iter()
                .map(|e| e.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        })
    }

    /// [`Self::binding`], or the error naming `kernel`, this file and the bindings it has.
    pub fn require_binding(&self, kernel: &str, name: &str) -> Result<&Binding> {
        self.binding(name)
            .ok_or_else(|| HarnessError::UnknownBinding {
                kernel: kernel.into(),
                path: self.path.clone(),
                binding: name.into(),
                available: self
                    .bindings
                    .iter()
                    .map(|b| b.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// Reflected layout of a named struct type (for checking `#[repr(C)]` parameter structs):
    /// total size and (member name, offset) pairs.
    pub fn struct_layout(&self, type_name: &str) -> Option<(u32, Vec<(String, u32)>)> {
        let (_, ty) = self
            .module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(type_name))?;
        match &ty.inner {
            naga::TypeInner::Struct { members, span } => Some((
                *span,
                members
                    .iter()
                    .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                    .collect(),
            )),
            _ => None,
        }
    }
}

fn scalar_of(module: &naga::Module, ty: naga::Handle<naga::Type>) -> ScalarKind {
    use naga::TypeInner as T;
    let from = |s: naga::Scalar| match (s.kind, s.width) {
        (naga::ScalarKind::Float, 4) => ScalarKind::F32,
        (naga::ScalarKind::Uint, 4) => ScalarKind::U32,
        (naga::ScalarKind::Sint, 4) => ScalarKind::I32,
        _ => ScalarKind::Mixed,
    };
    match &module.types[ty].inner {
        T::Scalar(s) | T::Vector { scalar: s, .. } | T::Matrix { scalar: s, .. } => from(*s),
        T::Atomic(s) => from(*s),
        T::Array { base, .. } => scalar_of(module, *base),
        T::Struct { members, .. } => {
            let kinds: Vec<_> = members.iter().map(|m| scalar_of(module, m.ty)).collect();
            match kinds.first() {
                Some(k) if kinds.iter().all(|x| x == k) => *k,
                _ => ScalarKind::Mixed,
            }
        }
        _ => ScalarKind::Mixed,
    }
}

fn buffer_layout(
    module: &naga::Module,
    layouter: &naga::proc::Layouter,
    ty: naga::Handle<naga::Type>,
) -> BufferLayout {
    use naga::TypeInner as T;
    let scalar = scalar_of(module, ty);
    match &module.types[ty].inner {
        T::Array {
            size: naga::ArraySize::Dynamic,
            stride,
            ..
        } => BufferLayout {
            fixed_size: 0,
            runtime_stride: Some(*stride),
            scalar,
        },
        T::Struct { members, span } => match members.last().map(|m| &module.types[m.ty].inner) {
            Some(T::Array {
                size: naga::ArraySize::Dynamic,
                stride,
                ..
            }) => BufferLayout {
                fixed_size: members.last().unwrap().offset,
                runtime_stride: Some(*stride),
                scalar,
            },
            _ => BufferLayout {
                fixed_size: *span,
                runtime_stride: None,
                scalar,
            },
        },
        _ => BufferLayout {
            fixed_size: layouter[ty].size,
            runtime_stride: None,
            scalar,
        },
    }
}

fn view_dim(dim: naga::ImageDimension, arrayed: bool) -> wgpu::TextureViewDimension {
    use naga::ImageDimension as D;
    use wgpu::TextureViewDimension as V;
    match (dim, arrayed) {
        (D::D1, _) => V::D1,
        (D::D2, false) => V::D2,
        (D::D2, true) => V::D2Array,
        (D::D3, _) => V::D3,
        (D::Cube, false) => V::Cube,
        (D::Cube, true) => V::CubeArray,
    }
}

/// Storage formats WebGPU core allows for storage textures.
pub fn storage_format(f: naga::StorageFormat) -> Option<wgpu::TextureFormat> {
    use naga::StorageFormat as S;
    use wgpu::TextureFormat as F;
    Some(match f {
        S::R32Float => F::R32Float,
        S::R32Uint => F::R32Uint,
        S::R32Sint => F::R32Sint,
        S::Rg32Float => F::Rg32Float,
        S::Rg32Uint => F::Rg32Uint,
        S::Rg32Sint => F::Rg32Sint,
        S::Rgba8Unorm => F::Rgba8Unorm,
        S::Rgba8Snorm => F::Rgba8Snorm,
        S::Rgba8Uint => F::Rgba8Uint,
        S::Rgba8Sint => F::Rgba8Sint,
        S::Rgba16Float => F::Rgba16Float,
        S::Rgba16Uint => F::Rgba16Uint,
        S::Rgba16Sint => F::Rgba16Sint,
        S::Rgba32Float => F::Rgba32Float,
        S::Rgba32Uint => F::Rgba32Uint,
        S::Rgba32Sint => F::Rgba32Sint,
        _ => return None,
    })
}

fn reflect_kind(
    module: &naga::Module,
    layouter: &naga::proc::Layouter,
    var: &naga::GlobalVariable,
) -> BindingKind {
    use naga::TypeInner as T;
    match var.space {
        naga::AddressSpace::Uniform => {
            BindingKind::Uniform(buffer_layout(module, layouter, var.ty))
        }
        naga::AddressSpace::Storage { access } => BindingKind::Storage {
            read_only: !access.contains(naga::StorageAccess::STORE),
            layout: buffer_layout(module, layouter, var.ty),
        },
        _ => match &module.types[var.ty].inner {
            T::Image {
                dim,
                arrayed,
                class,
            } => match class {
                naga::ImageClass::Storage { format, access } => BindingKind::StorageTexture {
                    dim: view_dim(*dim, *arrayed),
                    format: storage_format(*format),
                    access: format!("{access:?}"),
                },
                naga::ImageClass::Sampled { kind, .. } => BindingKind::SampledTexture {
                    dim: view_dim(*dim, *arrayed),
                    sample: match kind {
                        naga::ScalarKind::Float => ScalarKind::F32,
                        naga::ScalarKind::Uint => ScalarKind::U32,
                        naga::ScalarKind::Sint => ScalarKind::I32,
                        _ => ScalarKind::Mixed,
                    },
                },
                _ => BindingKind::SampledTexture {
                    dim: view_dim(*dim, *arrayed),
                    sample: ScalarKind::F32,
                },
            },
            _ => BindingKind::Sampler,
        },
    }
}

/// WGSL spelling of a type, for messages.
pub fn type_name(module: &naga::Module, ty: naga::Handle<naga::Type>) -> String {
    use naga::common::wgsl::TypeContext;
    module.to_ctx().type_to_string(ty)
}
