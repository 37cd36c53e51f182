//! Typed bindings: a kernel's buffer bindings as one struct whose fields are named after the WGSL
//! bindings, declared with [`bindings!`](crate::bindings!). From that one declaration follow the
//! declaration's input and output lists (with each output's tolerance), a case's resources (outputs
//! as the caller sized them, usually zeroed), its checks, its effective bytes, and the mirror's
//! unpacking ([`Bindings::read`]) and result ([`Bindings::outputs`]).
//!
//! A macro rather than a derive: it needs no proc-macro crate, and the tolerances sit beside the
//! output fields they bound. The field types are not trusted: before any dispatch the harness checks
//! every buffer against the WGSL's reflection (element scalar kind, size against the binding's
//! layout), so a field whose type disagrees with its binding is refused by name.
use crate::compare::Indexing;
use crate::kernel::{Case, Check};
use crate::run::{HostBuffer, HostResource, Pass, Resources};
use crate::shader::ScalarKind;
use std::collections::BTreeMap;

/// One element of a storage buffer: a scalar or a vector (array) of them.
pub trait Element: bytemuck::Pod {
    const SCALAR: ScalarKind;
    /// Scalars per element (the mismatch report's `components`).
    const COMPONENTS: u32;
}

macro_rules! elements {
    ($($t:ty => $kind:ident),*) => {$(
        impl Element for $t {
            const SCALAR: ScalarKind = ScalarKind::$kind;
            const COMPONENTS: u32 = 1;
        }
        impl<const N: usize> Element for [$t; N] where [$t; N]: bytemuck::Pod {
            const SCALAR: ScalarKind = ScalarKind::$kind;
            const COMPONENTS: u32 = N as u32;
        }
    )*};
}
elements!(f32 => F32, u32 => U32, i32 => I32);

/// A field of a [`Bindings`] struct: how it becomes a buffer, and back.
pub trait Field: Sized {
    fn to_buffer(&self) -> HostBuffer;
    fn from_buffer(buffer: &HostBuffer) -> Self;
    /// How a mismatch report names its elements.
    fn indexing(&self) -> Indexing;
    fn byte_len(&self) -> u64;
}

/// A runtime-sized array of elements.
impl<E: Element> Field for Vec<E> {
    fn to_buffer(&self) -> HostBuffer {
        HostBuffer {
            bytes: bytemuck::cast_slice(self).to_vec(),
            scalar: E::SCALAR,
        }
    }
    fn from_buffer(buffer: &HostBuffer) -> Self {
        // Copies: the bytes need not be aligned for `E`.
        bytemuck::pod_collect_to_vec(&buffer.bytes)
    }
    fn indexing(&self) -> Indexing {
        match E::COMPONENTS {
            1 => Indexing::Linear,
            c => Indexing::Grid {
                dims: [self.len() as u32, 1, 1],
                components: c,
            },
        }
    }
    fn byte_len(&self) -> u64 {
        std::mem::size_of_val(self.as_slice()) as u64
    }
}

/// A parameter block: one `#[repr(C)]` struct (its layout is checked against the WGSL struct's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Block<T>(pub T);

impl<T: bytemuck::Pod> Field for Block<T> {
    fn to_buffer(&self) -> HostBuffer {
        HostBuffer::pod(&self.0)
    }
    fn from_buffer(buffer: &HostBuffer) -> Self {
        Block(bytemuck::pod_read_unaligned(
            &buffer.bytes[..std::mem::size_of::<T>()],
        ))
    }
    fn indexing(&self) -> Indexing {
        Indexing::Linear
    }
    fn byte_len(&self) -> u64 {
        std::mem::size_of::<T>() as u64
    }
}

/// A runtime-sized array of structs (a WGSL struct with members of several scalar kinds; its
/// stride is checked against the WGSL struct's).
#[derive(Clone, Debug, PartialEq)]
pub struct Structs<T>(pub Vec<T>);

impl<T: bytemuck::Pod> Field for Structs<T> {
    fn to_buffer(&self) -> HostBuffer {
        HostBuffer {
            bytes: bytemuck::cast_slice(&self.0).to_vec(),
            scalar: ScalarKind::Mixed,
        }
    }
    fn from_buffer(buffer: &HostBuffer) -> Self {
        Structs(bytemuck::pod_collect_to_vec(&buffer.bytes))
    }
    fn indexing(&self) -> Indexing {
        Indexing::Linear
    }
    fn byte_len(&self) -> u64 {
        std::mem::size_of_val(self.0.as_slice()) as u64
    }
}

/// A kernel's buffer bindings as one struct ([`bindings!`](crate::bindings!) implements it).
pub trait Bindings: Sized {
    /// Every field as the resource of its binding's name.
    fn resources(&self) -> Resources;
    /// The fields from `resources` (a case's, or the mirror's data); panics naming a missing one.
    fn read(resources: &Resources) -> Self;
    /// One check per output, indexed by its element type.
    fn checks(&self) -> Vec<Check>;
    /// The bytes of every field: each read once or written once.
    fn bytes(&self) -> u64;
    /// The outputs as the mirror returns them.
    fn outputs(&self) -> BTreeMap<String, HostBuffer>;

    /// A case of these bindings dispatched by `passes`.
    fn case(&self, label: String, seed: u64, passes: Vec<Pass>) -> Case {
        Case {
            label,
            seed,
            resources: self.resources(),
            passes,
            checks: self.checks(),
            effective_bytes: self.bytes(),
        }
    }
}

/// The field `name` of `resources`, for [`Bindings::read`].
pub fn field<F: Field>(resources: &Resources, name: &str) -> F {
    match resources.get(name) {
        Some(HostResource::Buffer(b)) => F::from_buffer(b),
        Some(_) => panic!("binding `{name}` holds a texture, not a buffer"),
        None => panic!("no resource `{name}` for its typed binding"),
    }
}

/// A kernel's typed buffer bindings (see the [module doc](mod@crate::bindings)):
///
/// ```
/// use vxgi_harness::{bindings, Tolerance};
/// bindings! {
///     /// `kernels/scale.wgsl`'s bindings.
///     pub struct ScaleBindings {
///         inputs: { factor: Vec<f32>, x: Vec<[f32; 4]> }
///         // one rounded product: 0.5 ULP
///         outputs: { y: Vec<[f32; 4]> => Tolerance::Ulp { ulps: 1, abs_floor: 0.0 } }
///     }
/// }
/// assert_eq!(ScaleBindings::INPUTS, ["factor", "x"]);
/// assert_eq!(ScaleBindings::OUTPUTS[0].binding, "y");
/// ```
///
/// The struct gets `INPUTS` and `OUTPUTS` for its kernel's [`KernelDecl`](crate::KernelDecl) and
/// implements [`Bindings`].
#[macro_export]
macro_rules! bindings {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            inputs: { $( $(#[$im:meta])* $input:ident : $ity:ty ),* $(,)? }
            outputs: { $( $(#[$om:meta])* $output:ident : $oty:ty => $tol:expr ),* $(,)? }
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug)]
        $vis struct $name {
            $( $(#[$im])* pub $input: $ity, )*
            $( $(#[$om])* pub $output: $oty, )*
        }

        impl $name {
            /// The input bindings, by WGSL name.
            pub const INPUTS: &'static [&'static str] = &[$(stringify!($input)),*];
            /// The output bindings and their tolerances.
            pub const OUTPUTS: &'static [$crate::Output] = &[$($crate::Output {
                binding: stringify!($output),
                tolerance: $tol,
            }),*];
        }

        impl $crate::bindings::Bindings for $name {
            fn resources(&self) -> $crate::Resources {
                use $crate::bindings::Field;
                let mut r = $crate::Resources::new();
                $( r.insert(
                    stringify!($input).to_string(),
                    $crate::HostResource::Buffer(self.$input.to_buffer()),
                ); )*
                $( r.insert(
                    stringify!($output).to_string(),
                    $crate::HostResource::Buffer(self.$output.to_buffer()),
                ); )*
                r
            }
            fn read(resources: &$crate::Resources) -> Self {
                Self {
                    $( $input: $crate::bindings::field(resources, stringify!($input)), )*
                    $( $output: $crate::bindings::field(resources, stringify!($output)), )*
                }
            }
            fn checks(&self) -> Vec<$crate::Check> {
                use $crate::bindings::Field;
                vec![$($crate::Check {
                    resource: stringify!($output).to_string(),
                    output: stringify!($output),
                    indexing: self.$output.indexing(),
                }),*]
            }
            fn bytes(&self) -> u64 {
                use $crate::bindings::Field;
                0 $( + self.$input.byte_len() )* $( + self.$output.byte_len() )*
            }
            fn outputs(&self) -> std::collections::BTreeMap<String, $crate::HostBuffer> {
                use $crate::bindings::Field;
                std::collections::BTreeMap::from([$(
                    (stringify!($output).to_string(), self.$output.to_buffer()),
                )*])
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Tolerance;

    #[repr(C)]
    #[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
    struct Params {
        count: u32,
        scale: f32,
    }

    crate::bindings! {
        struct Io {
            inputs: { params: Block<Params>, records: Structs<Params>, x: Vec<[f32; 3]> }
            outputs: {
                y: Vec<u32> => Tolerance::Exact,
                z: Vec<[i32; 2]> => Tolerance::Ulp { ulps: 2, abs_floor: 0.0 },
            }
        }
    }

    fn io() -> Io {
        Io {
            params: Block(Params {
                count: 2,
                scale: 0.5,
            }),
            records: Structs(vec![Params {
                count: 7,
                scale: -1.0,
            }]),
            x: vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]],
            y: vec![0; 2],
            z: vec![[0; 2]; 3],
        }
    }

    /// Every field becomes the resource of its name with its scalar kind, reads back equal, and
    /// the outputs get checks indexed by their element type.
    #[test]
    fn fields_round_trip_through_resources_with_their_scalar_kinds() {
        let io = io();
        let r = io.resources();
        let kind = |n: &str| r[n].buffer().unwrap().scalar;
        assert_eq!(
            [
                kind("params"),
                kind("records"),
                kind("x"),
                kind("y"),
                kind("z")
            ],
            [
                ScalarKind::Mixed,
                ScalarKind::Mixed,
                ScalarKind::F32,
                ScalarKind::U32,
                ScalarKind::I32
            ]
        );
        let back = Io::read(&r);
        assert_eq!(back.params, io.params);
        assert_eq!(back.records, io.records);
        assert_eq!(
            (back.x, back.y, back.z),
            (io.x.clone(), io.y.clone(), io.z.clone())
        );
        assert_eq!(io.bytes(), 8 + 8 + 24 + 8 + 24);
        let checks = io.checks();
        assert_eq!(checks.len(), 2);
        assert!(matches!(checks[0].indexing, Indexing::Linear));
        assert!(matches!(
            checks[1].indexing,
            Indexing::Grid {
                dims: [3, 1, 1],
                components: 2
            }
        ));
        assert_eq!(Io::INPUTS, ["params", "records", "x"]);
        let outputs: Vec<_> = Io::OUTPUTS
            .iter()
            .map(|o| (o.binding, matches!(o.tolerance, Tolerance::Exact)))
            .collect();
        assert_eq!(outputs, [("y", true), ("z", false)]);
        assert_eq!(
            io.outputs().keys().collect::<Vec<_>>(),
            ["y", "z"].map(String::from).iter().collect::<Vec<_>>()
        );
    }

    #[test]
    #[should_panic(expected = "no resource `x` for its typed binding")]
    fn a_missing_binding_is_named() {
        let mut r = io().resources();
        r.remove("x");
        Io::read(&r);
    }
}
