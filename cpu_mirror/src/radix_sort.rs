//! Mirror of `kernels/radix_sort.wgsl`: a stable sort of (key, value) pairs by key, least significant
//! digit first, 4-bit digits, over the low `key_bits` bits of the key. Stability makes the result
//! unique, so the GPU must match exactly. The passes are mirrored too, so each can be verified alone.

/// Bits per digit (16 buckets).
pub const DIGIT_BITS: u32 = 4;
/// Elements per block: one invocation counts and scatters one block, in order (that keeps it stable).
pub const BLOCK: usize = 256;

/// The kernel's uniform block (`struct SortParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SortParams {
    pub count: u32,
    /// Bit offset of this pass's digit.
    pub shift: u32,
    /// ceil(count / BLOCK).
    pub blocks: u32,
    /// Digits are taken of `key & key_mask` (the low key_bits bits).
    pub key_mask: u32,
}

/// The mask of the low `key_bits` bits.
pub fn key_mask(key_bits: u32) -> u32 {
    if key_bits >= 32 {
        u32::MAX
    } else {
        (1u32 << key_bits) - 1
    }
}

/// Passes needed for keys below 2^key_bits.
pub fn passes(key_bits: u32) -> u32 {
    key_bits.div_ceil(DIGIT_BITS).max(1)
}

/// `count_digits`: per digit d and block b, how many of the block's keys have digit d
/// (`counts[d * blocks + b]`, digit-major so that one exclusive scan gives scatter offsets).
pub fn count_digits(keys: &[u32], p: &SortParams) -> Vec<u32> {
    let mut counts = vec![0u32; 16 * p.blocks as usize];
    for (i, k) in keys.iter().enumerate().take(p.count as usize) {
        let d = (((k & p.key_mask) >> p.shift) & 15) as usize;
        counts[d * p.blocks as usize + i / BLOCK] += 1;
    }
    counts
}

/// `scan_counts`: exclusive prefix sum.
pub fn scan(counts: &[u32]) -> Vec<u32> {
    let mut acc = 0u32;
    counts
        .iter()
        .map(|c| {
            let before = acc;
            acc += c;
            before
        })
        .collect()
}

/// `scatter`: every element to its digit's next slot, blocks and elements in order (stable).
pub fn scatter(
    keys: &[u32],
    values: &[u32],
    offsets: &[u32],
    p: &SortParams,
) -> (Vec<u32>, Vec<u32>) {
    let mut next = offsets.to_vec();
    let (mut k2, mut v2) = (vec![0u32; keys.len()], vec![0u32; values.len()]);
    for i in 0..p.count as usize {
        let d = (((keys[i] & p.key_mask) >> p.shift) & 15) as usize;
        let slot = &mut next[d * p.blocks as usize + i / BLOCK];
        k2[*slot as usize] = keys[i];
        v2[*slot as usize] = values[i];
        *slot += 1;
    }
    (k2, v2)
}

/// The whole sort: what every pass sequence must end with.
pub fn sort(keys: &[u32], values: &[u32], key_bits: u32) -> (Vec<u32>, Vec<u32>) {
    let mask = key_mask(key_bits);
    let mut pairs: Vec<(u32, u32)> = keys.iter().copied().zip(values.iter().copied()).collect();
    pairs.sort_by_key(|&(k, _)| k & mask);
    pairs.into_iter().unzip()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_compose_to_a_stable_sort() {
        let keys: Vec<u32> = (0..1000u32)
            .map(|i| i.wrapping_mul(2_654_435_761) >> 20)
            .collect();
        let values: Vec<u32> = (0..1000).collect();
        let (mut k, mut v) = (keys.clone(), values.clone());
        for pass in 0..passes(12) {
            let p = SortParams {
                count: 1000,
                shift: pass * DIGIT_BITS,
                blocks: 1000usize.div_ceil(BLOCK) as u32,
                key_mask: key_mask(12),
            };
            let offsets = scan(&count_digits(&k, &p));
            (k, v) = scatter(&k, &v, &offsets, &p);
        }
        assert_eq!((k, v), sort(&keys, &values, 12));
    }
}
