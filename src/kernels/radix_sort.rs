//! Declaration of `kernels/radix_sort.wgsl` (mirror: `vxgi_cpu_mirror::radix_sort`): a stable GPU sort of
//! (key, value) pairs, as a sequence of passes (count, scan, scatter per 4-bit digit) with intermediate
//! buffers; the final buffers must equal the mirror's stable sort exactly.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;
use thiserror::Error;
use vxgi_cpu_mirror::radix_sort::{key_mask, passes, sort, SortParams, BLOCK, DIGIT_BITS};
use vxgi_harness::prelude::*;
use vxgi_harness::run::{grid_for, Pass, View};

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "radix_sort",
    includes: &[super::BLOCK_SCAN],
    entry: "count_digits",
    inputs: &["src_keys", "src_values"],
    // A stable sort has one answer; integers: exact.
    outputs: &[
        Output { binding: "dst_keys", tolerance: Tolerance::Exact },
        Output { binding: "dst_values", tolerance: Tolerance::Exact },
    ],
    dispatch: DispatchRule::PerItem { what: "block of 256 elements (count_digits, scatter); the counts' block scan between them" },
    mirror: "vxgi_cpu_mirror::radix_sort::sort",
    summary: "stable LSD radix sort of (key, value) pairs, 4-bit digits, passes only for the key bits used",
);

#[derive(Debug, Error, PartialEq)]
pub enum SortError {
    #[error("nothing to sort")]
    Empty,
    #[error("{keys} keys but {values} values")]
    Length { keys: usize, values: usize },
    #[error("key_bits {0} must be 1..=32")]
    KeyBits(u32),
}

/// Resources and passes sorting `keys`/`values` by the low `key_bits` bits. The result lands in
/// `keys_a`/`values_a` or `keys_b`/`values_b`; the returned names say which.
pub fn case_for(
    ctx: &GpuContext,
    keys: &[u32],
    values: &[u32],
    key_bits: u32,
    label: String,
    seed: u64,
) -> Result<(Case, [String; 2]), SortError> {
    if keys.is_empty() {
        return Err(SortError::Empty);
    }
    if keys.len() != values.len() {
        return Err(SortError::Length {
            keys: keys.len(),
            values: values.len(),
        });
    }
    if !(1..=32).contains(&key_bits) {
        return Err(SortError::KeyBits(key_bits));
    }
    let n = keys.len();
    let blocks = n.div_ceil(BLOCK) as u32;
    let words = |n: usize| HostBuffer::zeroed(n * 4, ScalarKind::U32);
    let mut resources = buffers([
        ("keys_a", HostBuffer::of(keys)),
        ("values_a", HostBuffer::of(values)),
        ("keys_b", words(n)),
        ("values_b", words(n)),
        ("counts", words(16 * blocks as usize)),
    ]);
    let grid = grid_for(
        blocks as u64,
        64,
        ctx.limits().max_compute_workgroups_per_dimension,
    );
    resources.insert(
        "scan_partials".into(),
        super::scan_partials(16 * blocks as usize),
    );
    let mut pass_list = Vec::new();
    let total = passes(key_bits);
    for p in 0..total {
        let params = SortParams {
            count: n as u32,
            shift: p * DIGIT_BITS,
            blocks,
            key_mask: key_mask(key_bits),
        };
        let pname = format!("params_{p}");
        resources.insert(pname.clone(), HostBuffer::pod(&params).into());
        let (src, dst) = if p % 2 == 0 { ("a", "b") } else { ("b", "a") };
        let bindings = vec![
            ("params".to_string(), View::Buffer(pname)),
            ("src_keys".to_string(), View::Buffer(format!("keys_{src}"))),
            (
                "src_values".to_string(),
                View::Buffer(format!("values_{src}")),
            ),
            ("dst_keys".to_string(), View::Buffer(format!("keys_{dst}"))),
            (
                "dst_values".to_string(),
                View::Buffer(format!("values_{dst}")),
            ),
            ("counts".to_string(), View::Buffer("counts".into())),
            (
                "scan_partials".to_string(),
                View::Buffer("scan_partials".into()),
            ),
        ];
        let pass =
            |entry: &str| Pass::direct(format!("digit {p} {entry}"), entry, bindings.clone(), grid);
        pass_list.push(pass("count_digits"));
        pass_list.extend(super::scan_passes(
            &bindings,
            16 * blocks as usize,
            ctx.limits().max_compute_workgroups_per_dimension,
            &format!("digit {p}"),
        ));
        pass_list.push(pass("scatter"));
    }
    let fin = if total % 2 == 1 { "b" } else { "a" };
    let out = [format!("keys_{fin}"), format!("values_{fin}")];
    let case = Case {
        label,
        seed,
        resources,
        passes: pass_list,
        checks: std::iter::zip(["dst_keys", "dst_values"], &out)
            .map(|(output, r)| Check {
                resource: r.clone(),
                ..Check::of(output, Indexing::Linear)
            })
            .collect(),
        effective_bytes: total as u64 * n as u64 * 8 * 3,
    };
    Ok((case, out))
}

pub struct RadixSort;

impl Kernel for RadixSort {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }
    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(index as u64));
        let n = [1, 255, 256, 257, 5000, 100_000][index % 6];
        let key_bits = [32, 16, 12, 4, 1, 23][(index / 6 + index) % 6];
        let keys: Vec<u32> = (0..n)
            .map(|i| match index % 4 {
                0 => rng.random(),
                1 => rng.random_range(0..8), // many equal keys: stability matters
                2 => (n - i) as u32,         // reversed
                _ => 7,                      // all equal
            })
            .collect();
        let values: Vec<u32> = (0..n as u32).collect();
        let label = format!("#{index} n={n} key_bits={key_bits}");
        case_for(ctx, &keys, &values, key_bits, label, seed)
            .expect("valid case")
            .0
    }
    /// From the case's own input (`data` may hold the GPU's sorted result under the same name).
    fn mirror(&self, case: &Case, _data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let keys = case.resources["keys_a"].buffer().expect("keys").as_u32();
        let values = case.resources["values_a"]
            .buffer()
            .expect("values")
            .as_u32();
        let params: SortParams =
            *bytemuck::from_bytes(&case.resources["params_0"].buffer().expect("params").bytes);
        let (k, v) = sort(keys, values, params.key_mask.count_ones());
        BTreeMap::from([
            (case.checks[0].resource.clone(), HostBuffer::u32(&k)),
            (case.checks[1].resource.clone(), HostBuffer::u32(&v)),
        ])
    }
}
