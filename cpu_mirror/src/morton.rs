//! Morton (Z-order) indexing of cubic voxel grids, as the WGSL kernels use it.
//!
//! Bit 3k of the index is bit k of x, bit 3k+1 of y, bit 3k+2 of z. With this order the eight children
//! of parent `p` in the next finer level are exactly `8p .. 8p+8`, and any aligned block is one
//! contiguous range: a mip level is a 1D reduction, and a level too large for one storage binding
//! splits into contiguous windows.

fn spread(mut v: u32) -> u32 {
    v &= 0x0000_03ff;
    v = (v | (v << 16)) & 0x0300_00ff;
    v = (v | (v << 8)) & 0x0300_f00f;
    v = (v | (v << 4)) & 0x030c_30c3;
    v = (v | (v << 2)) & 0x0924_9249;
    v
}

fn compact(mut v: u32) -> u32 {
    v &= 0x0924_9249;
    v = (v ^ (v >> 2)) & 0x030c_30c3;
    v = (v ^ (v >> 4)) & 0x0300_f00f;
    v = (v ^ (v >> 8)) & 0x0300_00ff;
    v = (v ^ (v >> 16)) & 0x0000_03ff;
    v
}

/// Morton index of (x, y, z), each below 1024.
pub fn encode(x: u32, y: u32, z: u32) -> u32 {
    spread(x) | (spread(y) << 1) | (spread(z) << 2)
}

/// (x, y, z) of a Morton index.
pub fn decode(m: u32) -> [u32; 3] {
    [compact(m), compact(m >> 1), compact(m >> 2)]
}

#[cfg(test)]
mod tests {
    #[test]
    fn roundtrip_and_children_contiguous() {
        for m in [0u32, 1, 7, 8, 511, 4095, 123_456, (1 << 24) - 1] {
            let [x, y, z] = super::decode(m);
            assert_eq!(super::encode(x, y, z), m);
        }
        // Children of parent (px,py,pz) are 8p..8p+8.
        let p = super::encode(3, 5, 6);
        for dz in 0..2 {
            for dy in 0..2 {
                for dx in 0..2 {
                    let c = super::encode(6 + dx, 10 + dy, 12 + dz);
                    assert_eq!(c / 8, p);
                }
            }
        }
    }
}
