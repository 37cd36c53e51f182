//! GPU vs mirror for `kernels/radix_sort.wgsl`: the stable sort is unique, so exact.
use crate::common::{assert_case_passes, case_passes, gpu, run_case};
use vxgi::kernels::radix_sort::{case_for, RadixSort, SortError, DECL};

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 16, ..proptest::prelude::ProptestConfig::default() })]

    #[test]
    fn any_keys_sort_stably(keys in proptest::collection::vec(proptest::prelude::any::<u32>(), 1..3000), key_bits in 1u32..=32, small in proptest::prelude::any::<bool>()) {
        // Half the time squeeze keys into few values, so equal keys (and stability) are common.
        let keys: Vec<u32> = if small { keys.iter().map(|k| k % 5).collect() } else { keys };
        let values: Vec<u32> = (0..keys.len() as u32).collect();
        let shader = DECL.shader().unwrap();
        let (case, out) = case_for(gpu(), &keys, &values, key_bits, "prop".into(), 0).unwrap();
        case_passes(&shader, &RadixSort, &case)?;
        // And it is a sort: non-decreasing in the masked key, values a permutation.
        let got = run_case(&shader, DECL.name, &case, &[&out[0], &out[1]]);
        let mask = if key_bits == 32 { u32::MAX } else { (1 << key_bits) - 1 };
        let k = got.buffer(&out[0]).as_u32();
        proptest::prop_assert!(k.windows(2).all(|w| (w[0] & mask) <= (w[1] & mask)));
        let mut v = got.buffer(&out[1]).as_u32().to_vec();
        v.sort_unstable();
        proptest::prop_assert_eq!(v, values);
    }
}

#[test]
fn bad_input_is_an_error() {
    let length = SortError::Length { keys: 2, values: 1 };
    for (keys, values, bits, want) in [
        (&[][..], &[][..], 8, SortError::Empty),
        (&[1, 2], &[1], 8, length),
        (&[1], &[1], 0, SortError::KeyBits(0)),
        (&[1], &[1], 33, SortError::KeyBits(33)),
    ] {
        let got = case_for(gpu(), keys, values, bits, "e".into(), 0).unwrap_err();
        assert_eq!(got, want, "{keys:?} {values:?} {bits} bits");
    }
}

#[test]
fn params_struct_matches_the_reflected_wgsl_layout() {
    use vxgi_cpu_mirror::radix_sort::SortParams;
    crate::common::assert_layout!(
        DECL.shader().unwrap(),
        SortParams {
            count,
            shift,
            blocks,
            key_mask
        }
    );
}

/// More digit counts than one invocation may loop over on lavapipe (65535 iterations: llvmpipe's
/// LP_MAX_TGSI_LOOP_ITERATIONS; the counts were once scanned serially and silently truncated there):
/// 1.1M keys have 16 x 4297 = 68752 counts. Sorted exactly like the mirror.
#[test]
fn more_counts_than_one_invocation_may_loop_over() {
    let n = 1_100_000u32;
    let keys: Vec<u32> = (0..n)
        .map(|i| i.wrapping_mul(2_654_435_761) >> 12)
        .collect();
    let values: Vec<u32> = (0..n).collect();
    let shader = DECL.shader().unwrap();
    let (case, _) = case_for(gpu(), &keys, &values, 20, "large".into(), 0).unwrap();
    assert_case_passes(&shader, &RadixSort, &case);
}
