//! Generated dense voxel grids (Morton order) for tests, `vxgi verify` and benchmarks: the families of
//! hard inputs the mip kernels must survive, after the OpenCL conformance suite's mix of random values
//! and tables of hard ones.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::morton;

/// A family of occupancy patterns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pattern {
    Empty,
    Full,
    /// One voxel thick plane perpendicular to `axis` at `offset` (taken modulo the grid side).
    Slab {
        axis: u8,
        offset: u32,
    },
    /// The thin diagonal surface x + y + z = offset (6-connected, one voxel thick along the diagonal).
    Diagonal {
        offset: u32,
    },
    /// Voxels whose centre lies within half a voxel of a random tilted plane.
    TiltedPlane,
    /// Each voxel occupied with probability `density`, alpha exactly 1.
    RandomSparse {
        density: f32,
    },
    /// Random fractional alphas, including exactly 0 and 1.
    FractionalAlpha,
    /// Alphas from a table of hard values: 0, 1, subnormals, the smallest normal, 1 - ulp, 0.25, 0.5.
    HardAlphas,
}

impl Pattern {
    /// The families in the order `vxgi verify` cycles through them (`offset` varies the slab offsets).
    pub fn family(index: usize, n: u32) -> Pattern {
        let o = (index as u32 / 8).wrapping_mul(2_654_435_761) % n.max(1);
        match index % 8 {
            0 => Pattern::Empty,
            1 => Pattern::Full,
            2 => Pattern::Slab {
                axis: (index / 8 % 3) as u8,
                offset: o,
            },
            3 => Pattern::Diagonal { offset: o * 3 / 2 },
            4 => Pattern::TiltedPlane,
            5 => Pattern::RandomSparse { density: 0.1 },
            6 => Pattern::FractionalAlpha,
            _ => Pattern::HardAlphas,
        }
    }
}

/// The hard alpha values of [`Pattern::HardAlphas`].
pub const HARD_ALPHAS: [f32; 9] = [
    0.0,
    1.0,
    f32::from_bits(1),           // smallest subnormal
    f32::from_bits(0x007f_ffff), // largest subnormal
    f32::MIN_POSITIVE,           // smallest normal
    0.999_999_94,                // 1 - ulp
    0.25,
    0.5,
    1.0e-20,
];

/// A level-0 grid: per voxel pre-multiplied (colour.rgb, alpha) and pre-multiplied (normal, w).
#[derive(Clone, Debug)]
pub struct Grid {
    pub n: u32,
    pub colour: Vec<[f32; 4]>,
    pub normal: Vec<[f32; 4]>,
}

impl Grid {
    /// Alpha of voxel (x, y, z).
    pub fn alpha(&self, x: u32, y: u32, z: u32) -> f32 {
        self.colour[morton::encode(x, y, z) as usize][3]
    }
}

fn random_unit(rng: &mut ChaCha8Rng) -> [f32; 3] {
    loop {
        let v: [f32; 3] = [
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ];
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if l > 0.1 && l <= 1.0 {
            return [v[0] / l, v[1] / l, v[2] / l];
        }
    }
}

/// Generate a grid of side `n` (a power of two, at most 1024) with `pattern`, deterministic in `seed`.
pub fn generate(n: u32, pattern: Pattern, seed: u64) -> Grid {
    assert!(
        n.is_power_of_two() && n <= 1024,
        "grid side must be a power of two up to 1024, got {n}"
    );
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let count = (n as usize).pow(3);
    let mut colour = vec![[0.0f32; 4]; count];
    let mut normal = vec![[0.0f32; 4]; count];
    let plane_n = random_unit(&mut rng);
    let plane_d =
        rng.random_range(0.0..n as f32) * (plane_n[0].abs() + plane_n[1].abs() + plane_n[2].abs());
    for m in 0..count {
        let [x, y, z] = morton::decode(m as u32);
        let (alpha, nrm) = match pattern {
            Pattern::Empty => (0.0, [0.0; 3]),
            Pattern::Full => (1.0, random_unit(&mut rng)),
            Pattern::Slab { axis, offset } => {
                let c = [x, y, z][axis as usize % 3];
                let mut nv = [0.0; 3];
                nv[axis as usize % 3] = 1.0;
                (if c == offset % n { 1.0 } else { 0.0 }, nv)
            }
            Pattern::Diagonal { offset } => {
                let s = 1.0 / 3f32.sqrt();
                (
                    if x + y + z == offset % (3 * n - 2).max(1) {
                        1.0
                    } else {
                        0.0
                    },
                    [s, s, s],
                )
            }
            Pattern::TiltedPlane => {
                let p = [x as f32 + 0.5, y as f32 + 0.5, z as f32 + 0.5];
                let d = p[0] * plane_n[0].abs() + p[1] * plane_n[1].abs() + p[2] * plane_n[2].abs()
                    - plane_d;
                (if d.abs() <= 0.5 { 1.0 } else { 0.0 }, plane_n)
            }
            Pattern::RandomSparse { density } => (
                if rng.random::<f32>() < density {
                    1.0
                } else {
                    0.0
                },
                random_unit(&mut rng),
            ),
            Pattern::FractionalAlpha => {
                let a = match rng.random_range(0..4) {
                    0 => 0.0,
                    1 => 1.0,
                    _ => rng.random::<f32>(),
                };
                (a, random_unit(&mut rng))
            }
            Pattern::HardAlphas => (
                HARD_ALPHAS[rng.random_range(0..HARD_ALPHAS.len())],
                random_unit(&mut rng),
            ),
        };
        if alpha > 0.0 {
            let rgb: [f32; 3] = [
                rng.random_range(0.0..8.0),
                rng.random_range(0.0..8.0),
                rng.random_range(0.0..8.0),
            ];
            let w: f32 = rng.random();
            colour[m] = [rgb[0] * alpha, rgb[1] * alpha, rgb[2] * alpha, alpha];
            normal[m] = [nrm[0] * alpha, nrm[1] * alpha, nrm[2] * alpha, w * alpha];
        }
    }
    Grid { n, colour, normal }
}
