//! The comparison engine: GPU output vs mirror output, element by element (DESIGN.md section 4).
use std::fmt::Write as _;

/// How close a GPU value must be to the mirror's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tolerance {
    /// Bitwise equal (integers, copies, float work whose operation order the mirror reproduces).
    /// +0 and -0 are *not* equal here; NaN equals NaN only with the same bits.
    Exact,
    /// At most `ulps` units in the last place apart, or within `abs_floor` absolutely (near zero ULPs are
    /// meaninglessly small).
    Ulp { ulps: u32, abs_floor: f32 },
    /// |gpu - mirror| <= abs + rel * |mirror| (accumulations whose order the GPU may change).
    AbsRel { abs: f64, rel: f64 },
    /// |gpu - mirror| <= a bound the mirror computes per element from the WGSL accuracy rules of the
    /// operations on that element's path (first step towards the conformance suite's acceptance
    /// intervals); the bounds travel as the mirror output `<resource>@bound`.
    MirrorBound,
    /// u32 words each holding two IEEE binary16 values (WGSL's `pack2x16float`, low half first),
    /// compared half by half: at most `ulps` binary16 ULPs apart, or the GPU's ±0 where the mirror's
    /// half is subnormal (a GPU may flush binary16 subnormals). WGSL leaves the rounding of an f32
    /// that binary16 cannot hold to the implementation (either neighbour), so a mirror that rounds to
    /// nearest is at most 1 binary16 ULP from any conforming GPU on the same f32 value.
    Half { ulps: u32 },
}

/// Name of the mirror output that carries the per-element bounds of `resource`.
pub fn bound_name(resource: &str) -> String {
    format!("{resource}@bound")
}

/// The per-element bounds of a mirror's `output`, as an entry of its outputs.
pub fn bound<E: crate::bindings::Element>(
    output: &str,
    bounds: &[E],
) -> (String, crate::run::HostBuffer) {
    (bound_name(output), crate::run::HostBuffer::of(bounds))
}

/// A mirror's value of `output` and its per-element bounds, as two entries of its outputs.
pub fn bounded<E: crate::bindings::Element>(
    output: &str,
    values: &[E],
    bounds: &[E],
) -> [(String, crate::run::HostBuffer); 2] {
    let value = (output.to_string(), crate::run::HostBuffer::of(values));
    [value, bound(output, bounds)]
}

/// Distance in units in the last place between two f32 (0 for +0/-0; u64::MAX if either is NaN
/// and they differ).
pub fn ulp_distance(a: f32, b: f32) -> u64 {
    distance_by(a, b, |x| (x.to_bits() & 0x7fff_ffff) as i64)
}

/// Distance in binary16 units in the last place between two f32 that binary16 holds exactly (0 for
/// +0/-0; u64::MAX if either is NaN and they differ).
pub fn half_ulp_distance(a: f32, b: f32) -> u64 {
    distance_by(a, b, |x| (half::f16::from_f32(x).to_bits() & 0x7fff) as i64)
}

/// The distance of two floats whose sign-magnitude bit patterns (`magnitude`: the pattern without
/// its sign bit) are mapped onto a monotonic integer line.
fn distance_by(a: f32, b: f32, magnitude: impl Fn(f32) -> i64) -> u64 {
    if a.is_nan() || b.is_nan() {
        return if a.to_bits() == b.to_bits() {
            0
        } else {
            u64::MAX
        };
    }
    let key = |x: f32| {
        if x.is_sign_negative() {
            -magnitude(x)
        } else {
            magnitude(x)
        }
    };
    (key(a) - key(b)).unsigned_abs()
}

/// The two binary16 values of each word (`unpack2x16float`: low half first), as f32 (exact).
pub fn unpack_halves(words: &[u32]) -> Vec<f32> {
    words
        .iter()
        .flat_map(|&w| [w as u16, (w >> 16) as u16].map(|h| half::f16::from_bits(h).to_f32()))
        .collect()
}

/// `x` with subnormals replaced by zero of the same sign: what a flush-to-zero GPU does.
pub fn flush_subnormal(x: f32) -> f32 {
    if x.is_subnormal() {
        0.0f32.copysign(x)
    } else {
        x
    }
}

impl Tolerance {
    /// Whether `gpu` is close enough to `mirror`; `bound` is the element's bound for [`Tolerance::MirrorBound`].
    pub fn accepts_bounded(&self, gpu: f32, mirror: f32, bound: Option<f32>) -> bool {
        match (*self, bound) {
            (Tolerance::MirrorBound, Some(b)) => {
                gpu.to_bits() == mirror.to_bits()
                    || ((gpu as f64) - (mirror as f64)).abs() <= b as f64
            }
            _ => self.accepts(gpu, mirror),
        }
    }

    pub fn accepts(&self, gpu: f32, mirror: f32) -> bool {
        match *self {
            // Without its bounds, a mirror-bound output accepts only equality.
            Tolerance::MirrorBound => gpu.to_bits() == mirror.to_bits(),
            Tolerance::Exact => gpu.to_bits() == mirror.to_bits(),
            Tolerance::Ulp { ulps, abs_floor } => {
                ulp_distance(gpu, mirror) <= ulps as u64 || (gpu - mirror).abs() <= abs_floor
            }
            Tolerance::AbsRel { abs, rel } => {
                let (g, m) = (gpu as f64, mirror as f64);
                (g - m).abs() <= abs + rel * m.abs() || gpu.to_bits() == mirror.to_bits()
            }
            Tolerance::Half { ulps } => {
                half_ulp_distance(gpu, mirror) <= ulps as u64
                    || (gpu == 0.0 && mirror.abs() < half::f16::MIN_POSITIVE.to_f32())
            }
        }
    }

    /// How far apart `gpu` and `mirror` are in this tolerance's units (binary16 ULPs for
    /// [`Tolerance::Half`], f32 ULPs otherwise).
    pub fn distance(&self, gpu: f32, mirror: f32) -> u64 {
        match self {
            Tolerance::Half { .. } => half_ulp_distance(gpu, mirror),
            _ => ulp_distance(gpu, mirror),
        }
    }
}

/// How element indices map to coordinates in reports.
#[derive(Clone, Debug)]
pub enum Indexing {
    Linear,
    /// Row-major grid `[x, y, z]` extents (x fastest), `components` scalars per element.
    Grid {
        dims: [u32; 3],
        components: u32,
    },
    /// Morton (Z-order) cube of side `n`, `components` scalars per element.
    Morton {
        n: u32,
        components: u32,
    },
}

impl Indexing {
    /// The same elements with every 32-bit scalar read as two binary16 halves.
    pub fn halves(&self) -> Indexing {
        match *self {
            Indexing::Linear => Indexing::Linear,
            Indexing::Grid { dims, components } => Indexing::Grid {
                dims,
                components: 2 * components,
            },
            Indexing::Morton { n, components } => Indexing::Morton {
                n,
                components: 2 * components,
            },
        }
    }

    pub fn describe(&self, scalar_index: usize) -> String {
        match *self {
            Indexing::Linear => format!("[{scalar_index}]"),
            Indexing::Grid { dims, components } => {
                let e = scalar_index / components as usize;
                let c = scalar_index % components as usize;
                let x = e % dims[0] as usize;
                let y = (e / dims[0] as usize) % dims[1] as usize;
                let z = e / (dims[0] as usize * dims[1] as usize);
                format!("element {e} (x={x}, y={y}, z={z}) component {c}")
            }
            Indexing::Morton { n, components } => {
                let e = scalar_index / components as usize;
                let c = scalar_index % components as usize;
                let [x, y, z] = morton_decode(e as u32);
                format!("element {e} (x={x}, y={y}, z={z} of {n}^3, Morton order) component {c}")
            }
        }
    }
}

pub use vxgi_cpu_mirror::morton::decode as morton_decode;

#[derive(Clone, Debug)]
pub struct Mismatch {
    pub index: usize,
    pub gpu: f32,
    pub mirror: f32,
    pub ulp: u64,
    /// The element's bound under [`Tolerance::MirrorBound`].
    pub bound: Option<f32>,
    /// Outside tolerance (else one of the largest accepted differences).
    pub failed: bool,
}

/// Histogram of ULP distances: exact counts up to 256, one overflow bucket.
#[derive(Clone, Debug)]
pub struct UlpHistogram {
    pub counts: Vec<u64>,
}

impl Default for UlpHistogram {
    fn default() -> Self {
        Self {
            counts: vec![0; 258],
        }
    }
}

impl UlpHistogram {
    pub fn add(&mut self, ulp: u64) {
        let i = (ulp as usize).min(257);
        self.counts[i] += 1;
    }
    pub fn merge(&mut self, other: &UlpHistogram) {
        for (a, b) in self.counts.iter_mut().zip(&other.counts) {
            *a += b;
        }
    }
    pub fn total(&self) -> u64 {
        self.counts.iter().sum()
    }
    /// Smallest d with at least `q` of the elements at distance <= d (257 means "over 256").
    pub fn quantile(&self, q: f64) -> u64 {
        let total = self.total();
        if total == 0 {
            return 0;
        }
        let need = (q * total as f64).ceil() as u64;
        let mut acc = 0;
        for (d, c) in self.counts.iter().enumerate() {
            acc += c;
            if acc >= need {
                return d as u64;
            }
        }
        257
    }
}

/// The result of comparing one output of one case.
#[derive(Clone, Debug)]
pub struct Comparison {
    pub kernel: String,
    pub output: String,
    pub case: String,
    pub seed: u64,
    pub tolerance: Tolerance,
    pub indexing: Indexing,
    pub elements: usize,
    /// Elements outside tolerance.
    pub failures: usize,
    /// Worst 10 elements by ULP distance (failing ones first).
    pub worst: Vec<Mismatch>,
    pub max_ulp: u64,
    pub histogram: UlpHistogram,
    /// Elements accepted only as the flush-to-zero result.
    pub flushed: usize,
    /// Largest |gpu - mirror| / bound under [`Tolerance::MirrorBound`] (how much of the bound is used;
    /// 0 for other tolerances).
    pub max_bound_use: f64,
}

impl Comparison {
    pub fn passed(&self) -> bool {
        self.failures == 0
    }
    pub fn p99_ulp(&self) -> u64 {
        self.histogram.quantile(0.99)
    }

    /// The mismatch report: kernel, case and seed, the worst 10 elements with coordinates, both values
    /// and their ULP distance.
    pub fn report(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "kernel `{}` output `{}` case `{}` (seed {}): {} of {} elements outside {:?}; max ULP {}, p99 ULP {}",
            self.kernel,
            self.output,
            self.case,
            self.seed,
            self.failures,
            self.elements,
            self.tolerance,
            fmt_ulp(self.max_ulp),
            fmt_ulp(self.p99_ulp())
        );
        for m in &self.worst {
            let _ = writeln!(
                s,
                "  {} index {}: gpu {:e} ({:#010x}) mirror {:e} ({:#010x}) ULP {}{}",
                if m.failed { "FAIL" } else { "  ok" },
                self.indexing.describe(m.index),
                m.gpu,
                m.gpu.to_bits(),
                m.mirror,
                m.mirror.to_bits(),
                fmt_ulp(m.ulp),
                m.bound
                    .map(|b| format!(
                        " |diff| {:e} bound {b:e}",
                        (m.gpu as f64 - m.mirror as f64).abs()
                    ))
                    .unwrap_or_default(),
            );
        }
        s
    }
}

pub fn fmt_ulp(u: u64) -> String {
    if u == u64::MAX {
        "NaN".into()
    } else {
        u.to_string()
    }
}

/// Compare `gpu` against `mirror` element by element. `mirror_ftz`, when given, is the mirror's result
/// on inputs with subnormals flushed to zero and outputs flushed likewise: an element that matches it
/// (within the same tolerance) is accepted too — exactly what WGSL allows a GPU to do, nothing looser.
pub fn compare_f32(
    meta: (&str, &str, &str, u64),
    gpu: &[f32],
    mirror: &[f32],
    mirror_ftz: Option<&[f32]>,
    tolerance: Tolerance,
    indexing: Indexing,
) -> Comparison {
    compare_f32_bounded(meta, gpu, mirror, mirror_ftz, None, tolerance, indexing)
}

/// [`compare_f32`] with per-element bounds for [`Tolerance::MirrorBound`].
pub fn compare_f32_bounded(
    meta: (&str, &str, &str, u64),
    gpu: &[f32],
    mirror: &[f32],
    mirror_ftz: Option<&[f32]>,
    bounds: Option<&[f32]>,
    tolerance: Tolerance,
    indexing: Indexing,
) -> Comparison {
    let (kernel, output, case, seed) = meta;
    let mut c = Comparison {
        kernel: kernel.into(),
        output: output.into(),
        case: case.into(),
        seed,
        tolerance,
        indexing,
        elements: gpu.len().max(mirror.len()),
        failures: 0,
        worst: Vec::new(),
        max_ulp: 0,
        histogram: UlpHistogram::default(),
        flushed: 0,
        max_bound_use: 0.0,
    };
    if gpu.len() != mirror.len() {
        c.failures = c.elements;
        c.max_ulp = u64::MAX;
        c.worst.push(Mismatch {
            index: gpu.len().min(mirror.len()),
            gpu: f32::NAN,
            mirror: f32::NAN,
            ulp: u64::MAX,
            bound: None,
            failed: true,
        });
        return c;
    }
    let mut candidates: Vec<(bool, Mismatch)> = Vec::new();
    for (i, (&g, &m)) in gpu.iter().zip(mirror).enumerate() {
        let mut ulp = tolerance.distance(g, m);
        let bound = bounds.and_then(|b| b.get(i).copied());
        if let Some(b) = bound {
            let diff = (g as f64 - m as f64).abs();
            if diff > 0.0 {
                c.max_bound_use = c.max_bound_use.max(if b > 0.0 {
                    diff / b as f64
                } else {
                    f64::INFINITY
                });
            }
        }
        let mut ok = tolerance.accepts_bounded(g, m, bound);
        if !ok {
            if let Some(ftz) = mirror_ftz {
                if tolerance.accepts_bounded(g, ftz[i], bound) {
                    ok = true;
                    ulp = tolerance.distance(g, ftz[i]);
                    c.flushed += 1;
                }
            }
        }
        c.histogram.add(ulp);
        c.max_ulp = c.max_ulp.max(ulp);
        if !ok {
            c.failures += 1;
        }
        if !ok || ulp > 0 {
            candidates.push((
                !ok,
                Mismatch {
                    index: i,
                    gpu: g,
                    mirror: m,
                    ulp,
                    bound,
                    failed: !ok,
                },
            ));
            if candidates.len() > 1024 {
                keep_worst(&mut candidates);
            }
        }
    }
    keep_worst(&mut candidates);
    c.worst = candidates.into_iter().map(|(_, m)| m).collect();
    c
}

fn keep_worst(v: &mut Vec<(bool, Mismatch)>) {
    v.sort_by(|a, b| {
        b.0.cmp(&a.0)
            .then(b.1.ulp.cmp(&a.1.ulp))
            .then(a.1.index.cmp(&b.1.index))
    });
    v.truncate(10);
}

/// Compare integer outputs: always exact.
/// Exact comparison of integer outputs; `alt`, when given, is the flush-to-zero mirror's result (an
/// integer computed from float inputs a GPU may flush), accepted element by element as for floats.
pub fn compare_u32(
    meta: (&str, &str, &str, u64),
    gpu: &[u32],
    mirror: &[u32],
    alt: Option<&[u32]>,
    indexing: Indexing,
) -> Comparison {
    let bits = |v: &[u32]| -> Vec<f32> { v.iter().map(|&x| f32::from_bits(x)).collect() };
    compare_words(meta, [gpu, mirror], alt, bits, Tolerance::Exact, indexing)
}

/// Compare words as the f32 values `decode` reads from them.
fn compare_words(
    meta: (&str, &str, &str, u64),
    [gpu, mirror]: [&[u32]; 2],
    alt: Option<&[u32]>,
    decode: impl Fn(&[u32]) -> Vec<f32>,
    tolerance: Tolerance,
    indexing: Indexing,
) -> Comparison {
    let a = alt.map(&decode);
    compare_f32(
        meta,
        &decode(gpu),
        &decode(mirror),
        a.as_deref(),
        tolerance,
        indexing,
    )
}

/// Compare words of two binary16 values each under [`Tolerance::Half`] (`indexing` counts the
/// halves); `alt` as for [`compare_u32`].
pub fn compare_halves(
    meta: (&str, &str, &str, u64),
    gpu: &[u32],
    mirror: &[u32],
    alt: Option<&[u32]>,
    tolerance: Tolerance,
    indexing: Indexing,
) -> Comparison {
    compare_words(meta, [gpu, mirror], alt, unpack_halves, tolerance, indexing)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_accept_either_rounding_and_a_flushed_subnormal_only() {
        let meta = ("k", "o", "c", 0);
        let h = |x: f32| half::f16::from_f32(x).to_bits() as u32;
        let word = |lo: f32, hi: f32| h(lo) | (h(hi) << 16);
        let tol = Tolerance::Half { ulps: 1 };
        let next = f32::from(half::f16::from_bits(half::f16::from_f32(1.5).to_bits() + 1));
        let next2 = f32::from(half::f16::from_bits(half::f16::from_f32(1.5).to_bits() + 2));
        let sub = f32::from(half::f16::from_bits(3));
        let ok = |g: u32, m: u32| compare_halves(meta, &[g], &[m], None, tol, Indexing::Linear);
        assert!(ok(word(next, 0.0), word(1.5, 0.0)).passed());
        assert!(ok(word(0.0, 0.0), word(sub, 0.0)).passed());
        assert!(!ok(word(next2, 0.0), word(1.5, 0.0)).passed());
        // The high half is compared too, and a distance is counted in binary16 ULPs.
        let c = ok(word(1.5, next2), word(1.5, 1.5));
        assert!(!c.passed());
        assert_eq!(c.max_ulp, 2);
        assert_eq!(half_ulp_distance(-sub, sub), 6);
    }

    #[test]
    fn ulp_distance_across_zero_and_neighbours() {
        assert_eq!(ulp_distance(1.0, 1.0), 0);
        assert_eq!(ulp_distance(0.0, -0.0), 0);
        assert_eq!(ulp_distance(1.0, f32::from_bits(1.0f32.to_bits() + 3)), 3);
        assert_eq!(ulp_distance(f32::from_bits(1), -f32::from_bits(1)), 2);
        assert_eq!(ulp_distance(f32::NAN, 1.0), u64::MAX);
    }

    #[test]
    fn flush_zero_alternative_is_the_only_extra_acceptance() {
        let sub = f32::from_bits(5);
        let c = compare_f32(
            ("k", "o", "c", 0),
            &[0.0],
            &[sub],
            Some(&[0.0]),
            Tolerance::Exact,
            Indexing::Linear,
        );
        assert!(c.passed());
        assert_eq!(c.flushed, 1);
        let c = compare_f32(
            ("k", "o", "c", 0),
            &[f32::from_bits(4)],
            &[sub],
            Some(&[0.0]),
            Tolerance::Exact,
            Indexing::Linear,
        );
        assert!(!c.passed());
    }

    #[test]
    fn integer_outputs_accept_the_flush_to_zero_mirrors_words_only() {
        let meta = ("k", "o", "c", 0);
        // A subnormal alpha: solid (255) under IEEE, empty (0) where the GPU flushed it.
        let c = compare_u32(meta, &[0, 7], &[255, 7], Some(&[0, 7]), Indexing::Linear);
        assert!(c.passed());
        assert_eq!(c.flushed, 1);
        let c = compare_u32(meta, &[1, 7], &[255, 7], Some(&[0, 7]), Indexing::Linear);
        assert!(!c.passed());
        assert!(!compare_u32(meta, &[0], &[255], None, Indexing::Linear).passed());
    }

    #[test]
    fn histogram_quantiles() {
        let mut h = UlpHistogram::default();
        for _ in 0..99 {
            h.add(0);
        }
        h.add(7);
        assert_eq!(h.quantile(0.99), 0);
        assert_eq!(h.quantile(1.0), 7);
    }
}
