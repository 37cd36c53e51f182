//! Generated G-buffer normals (packed snorm16, see `kernels/common/octahedral_bins.wgsl`) for the cache
//! distribution kernels: the families the issue lists, deterministic in their seed.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::octahedral::{bin_direction, pack, quantise, BIN_COUNT};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GPattern {
    /// Three walls of a room corner seen from inside.
    FlatWalls,
    /// Spheres in front of a back wall: every direction of a hemisphere.
    Spheres,
    /// Many one-pixel-thin features with random normals over background.
    ThinFeatures,
    AllBackground,
    /// One geometry pixel per tile (at a random place in it).
    OnePixelPerTile {
        tile: u32,
    },
    /// The same normal everywhere.
    IdenticalNormals,
    /// Normals exactly on octahedral bin borders (and the poles and equator).
    BinBorders,
    /// Non-finite and zero-length normals mixed in: treated as background by the quantiser.
    BadNormals,
}

impl GPattern {
    pub fn family(index: usize) -> GPattern {
        match index % 8 {
            0 => GPattern::FlatWalls,
            1 => GPattern::Spheres,
            2 => GPattern::ThinFeatures,
            3 => GPattern::AllBackground,
            4 => GPattern::OnePixelPerTile { tile: 32 },
            5 => GPattern::IdenticalNormals,
            6 => GPattern::BinBorders,
            _ => GPattern::BadNormals,
        }
    }
}

/// Float normals (None = background) of a `width` x `height` G-buffer, row-major.
pub fn normals(width: u32, height: u32, pattern: GPattern, seed: u64) -> Vec<Option<[f32; 3]>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let fixed: [f32; 3] = {
        let d = bin_direction(rng.random_range(0..BIN_COUNT));
        [d[0] as f32, d[1] as f32, d[2] as f32]
    };
    let offset: (u32, u32) = (rng.random_range(0..32), rng.random_range(0..32));
    let mut out = Vec::with_capacity((width * height) as usize);
    for y in 0..height {
        for x in 0..width {
            let (u, v) = (
                (x as f32 + 0.5) / width as f32,
                (y as f32 + 0.5) / height as f32,
            );
            let n = match pattern {
                GPattern::FlatWalls => Some(if u < 0.3 {
                    [1.0, 0.0, 0.0]
                } else if v > 0.7 {
                    [0.0, 1.0, 0.0]
                } else {
                    [0.0, 0.0, 1.0]
                }),
                GPattern::Spheres => {
                    let (cx, cy) = ((u * 4.0).fract() - 0.5, (v * 3.0).fract() - 0.5);
                    let r2 = cx * cx + cy * cy;
                    Some(if r2 < 0.16 {
                        [cx / 0.4, cy / 0.4, (1.0 - r2 / 0.16).max(0.0).sqrt()]
                    } else {
                        [0.0, 0.0, 1.0]
                    })
                }
                GPattern::ThinFeatures => (x % 7 == 0 || y % 11 == 0).then(|| {
                    [
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                    ]
                }),
                GPattern::AllBackground => None,
                GPattern::OnePixelPerTile { tile } => {
                    (x % tile == offset.0 % tile && y % tile == offset.1 % tile).then_some(fixed)
                }
                GPattern::IdenticalNormals => Some(fixed),
                GPattern::BinBorders => {
                    // Octahedral coordinates on a multiple of 1/4 (bin borders for 8 bins), decoded.
                    let (a, b) = (
                        rng.random_range(-4..=4) as f32 / 4.0,
                        rng.random_range(-4..=4) as f32 / 4.0,
                    );
                    let z = 1.0 - a.abs() - b.abs();
                    let (px, py) = if z >= 0.0 {
                        (a, b)
                    } else {
                        ((1.0 - b.abs()) * a.signum(), (1.0 - a.abs()) * b.signum())
                    };
                    Some([px, py, z])
                }
                GPattern::BadNormals => Some(match rng.random_range(0..4) {
                    0 => [f32::NAN, 0.0, 1.0],
                    1 => [0.0, 0.0, 0.0],
                    2 => [f32::INFINITY, 1.0, 0.0],
                    _ => [
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                    ],
                }),
            };
            out.push(n);
        }
    }
    out
}

/// Quantise and pack float normals as the kernels read them (None and bad normals become background).
pub fn packed(normals: &[Option<[f32; 3]>]) -> Vec<[u32; 2]> {
    normals.iter().map(|n| pack(n.and_then(quantise))).collect()
}
