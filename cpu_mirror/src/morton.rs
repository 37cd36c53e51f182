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

fn spread2(mut v: u32) -> u32 {
    v &= 0x0000_ffff;
    v = (v | (v << 8)) & 0x00ff_00ff;
    v = (v | (v << 4)) & 0x0f0f_0f0f;
    v = (v | (v << 2)) & 0x3333_3333;
    v = (v | (v << 1)) & 0x5555_5555;
    v
}

fn compact2(mut v: u32) -> u32 {
    v &= 0x5555_5555;
    v = (v | (v >> 1)) & 0x3333_3333;
    v = (v | (v >> 2)) & 0x0f0f_0f0f;
    v = (v | (v >> 4)) & 0x00ff_00ff;
    v = (v | (v >> 8)) & 0x0000_ffff;
    v
}

/// 2D Morton index of (x, y), each below 65536 (bit 2k = x bit k, 2k+1 = y bit k): the four children of
/// texel `p` in the next finer level are `4p .. 4p+4`.
pub fn encode2(x: u32, y: u32) -> u32 {
    spread2(x) | (spread2(y) << 1)
}

/// (x, y) of a 2D Morton index.
pub fn decode2(m: u32) -> [u32; 2] {
    [compact2(m), compact2(m >> 1)]
}

#[cfg(test)]
mod tests {
    #[test]
    fn roundtrip_2d() {
        for m in [0u32, 1, 2, 3, 4, 1023, 65_535, 1 << 20, u32::MAX] {
            let [x, y] = super::decode2(m);
            assert_eq!(super::encode2(x, y), m);
        }
        // Bit 0 is x bit 0, bit 3 is y bit 1.
        assert_eq!(super::decode2(0b1001), [1, 2]);
    }

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
