//! Declaration of `kernels/cache_reuse.wgsl` (mirror: `vxgi_cpu_mirror::cache_reuse`): the last
//! frame's radiance caches kept where their surface is still in view (CPRC sections 5-6). Cases are
//! pinhole views of three planes with last-frame caches on them (jittered by up to a pixel and a
//! half), off them, behind the camera, off the image, with turned normals, on pixel corners and in
//! pairs on one spot (the lowest index wins); every other case carries the kept caches' radiance
//! texels (1 to 64 a cache); outputs start with garbage, so a slot written wrongly or not cleared
//! shows.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::cache_reuse::{accept, keep, Inputs, Last, ReuseParams, NONE};
use vxgi_cpu_mirror::gbuffer::Frame;
use vxgi_harness::prelude::*;
use vxgi_harness::run::Pass;

vxgi_harness::bindings! {
    /// cache_reuse's bindings: this frame's camera, the distribution's per-pixel clusters, normals
    /// and positions, the last frame's caches (records and radiance texels) in; each last cache's
    /// pixel, each cluster's kept cache, and the records (and carried texels) of the slots that
    /// keep one out.
    pub struct Io {
        inputs: {
            frame: Block<Frame>,
            reuse_params: Block<ReuseParams>,
            prev_count: Vec<u32>,
            prev_pos: Vec<[f32; 4]>,
            prev_normal: Vec<[f32; 4]>,
            prev_caches: Vec<[f32; 4]>,
            prev_radiance: Vec<[f32; 4]>,
            pixel_cluster: Vec<u32>,
            normals: Vec<[u32; 2]>,
            positions: Vec<[f32; 4]>,
            cache_count: Vec<u32>,
        }
        outputs: {
            // Exact after acceptance: the GPU's pixel where the mirror's bounds on the projection
            // allow it (`cache_reuse::claim`), else the mirror's.
            prev_pixel: Vec<u32> => Tolerance::Exact,
            // Exact after acceptance: the GPU's choice where it is possible within the tests'
            // bounds (`cache_reuse::accept`).
            kept: Vec<u32> => Tolerance::Exact,
            // Copies and integer division: exact.
            cache_pos: Vec<[f32; 4]> => Tolerance::Exact,
            cache_pixel: Vec<[u32; 2]> => Tolerance::Exact,
            cache_normal: Vec<[f32; 4]> => Tolerance::Exact,
            caches: Vec<[f32; 4]> => Tolerance::Exact,
            cache_radiance: Vec<[f32; 4]> => Tolerance::Exact,
            // cache_records' arguments, the kept caches counted in [2]: integers, exact.
            cache_args: Vec<u32> => Tolerance::Exact,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "cache_reuse",
    includes: &[super::tile_normal_histogram::OCTAHEDRAL_BINS, super::SCENE_TYPES],
    entry: "claim",
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerItem {
        what: "cluster slot (clear, keep) or last-frame cache (claim)",
    },
    mirror: "vxgi_cpu_mirror::cache_reuse::{accept, keep}",
    summary: "the last frame's radiance caches kept on their surfaces where still in view, instead of placed anew (CPRC 5-6)",
);

/// The passes before cache_records (`clear` over `slots` cluster slots, `claim` over `prev` last-frame
/// caches) and the one after it (`keep` over the first `caches` slots: the cache buffers' capacity,
/// past which no slot holds a cache).
pub fn passes(ctx: &GpuContext, slots: usize, prev: usize, caches: usize) -> (Vec<Pass>, Pass) {
    let pass = |entry: &str, n: usize| {
        let label = format!("{} {entry}", DECL.name);
        Pass::linear(ctx, label, entry, DECL.bind_by_name(), n.max(1) as u64)
    };
    (
        vec![pass("clear", slots), pass("claim", prev)],
        pass("keep", caches.min(slots)),
    )
}

/// Its own resources for `slots` cluster slots and room for `prev` last-frame caches of
/// `params.texels` radiance texels, all zero (no last caches; a chain's per-frame resets then clear
/// rather than restore them): the kept choices, each last cache's pixel, the copies of the last
/// records and radiance, and `params`.
pub fn resources(slots: usize, prev: usize, params: ReuseParams) -> Resources {
    let mut r = Resources::new();
    let mut put = |name: &str, b: HostBuffer| r.insert(name.into(), b.into());
    put("reuse_params", HostBuffer::pod(&params));
    put("kept", HostBuffer::u32(&vec![0; slots.max(1)]));
    put("prev_pixel", HostBuffer::u32(&vec![0; prev.max(1)]));
    put("prev_count", HostBuffer::u32(&[0]));
    put("prev_pos", HostBuffer::f32(&vec![0.0; 4 * prev.max(1)]));
    put("prev_normal", HostBuffer::f32(&vec![0.0; 4 * prev.max(1)]));
    put("prev_caches", HostBuffer::f32(&vec![0.0; 8 * prev.max(1)]));
    let texels = prev.max(1) * params.texels.max(1) as usize;
    put("prev_radiance", HostBuffer::f32(&vec![0.0; 4 * texels]));
    r
}

fn unit(rng: &mut ChaCha8Rng) -> glam::DVec3 {
    loop {
        let v = glam::DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
            return v.normalize();
        }
    }
}

/// Case `index`'s bindings: a view of three planes and last-frame caches about them.
pub fn generated(seed: u64, index: usize) -> (Io, String) {
    use glam::DVec3;
    let mut rng = ChaCha8Rng::seed_from_u64(
        seed.wrapping_mul(0x9e37_79b9_7f4a_7c15)
            .wrapping_add(index as u64),
    );
    let (w, h) = [(32u32, 24u32), (1, 1), (17, 9), (64, 48)][index % 4];
    let eye = DVec3::new(
        rng.random_range(-2.0..2.0),
        rng.random_range(-2.0..2.0),
        rng.random_range(-2.0..2.0),
    );
    let fwd = unit(&mut rng);
    let tan = (rng.random_range(20.0f64..90.0).to_radians() * 0.5).tan();
    let side = fwd.cross(DVec3::Y).try_normalize().unwrap_or(DVec3::X);
    let (right, up) = (side * tan * w as f64 / h as f64, side.cross(fwd) * tan);
    let v4 = |v: DVec3, w: f32| [v.x as f32, v.y as f32, v.z as f32, w];
    let frame = Frame {
        eye: v4(eye, 0.0),
        forward: v4(fwd, 0.0),
        right: v4(right, 0.0),
        up: v4(up, 0.0),
        size: [w, h, 0, 0],
    };
    // As the kernels see the camera: the f32 vectors.
    let f = |a: [f32; 4]| DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
    let (eye, fwd, right, up) = (f(frame.eye), f(frame.forward), f(frame.right), f(frame.up));
    let ray = |fx: f64, fy: f64| {
        fwd + right * (fx / w as f64 * 2.0 - 1.0) + up * (1.0 - fy / h as f64 * 2.0)
    };
    let planes: Vec<(DVec3, f64)> = (0..3)
        .map(|_| {
            let mut n = unit(&mut rng);
            if n.dot(fwd) > -0.2 {
                n = (n - fwd * (n.dot(fwd) + 0.6)).normalize();
            }
            let at = eye + fwd * rng.random_range(1.0..5.0) + unit(&mut rng) * 0.5;
            (n, n.dot(at))
        })
        .collect();
    // The nearest plane along a ray, (t, plane).
    let hit = |d: DVec3| -> Option<(f64, usize)> {
        planes
            .iter()
            .enumerate()
            .filter_map(|(k, (n, o))| {
                let t = (o - n.dot(eye)) / n.dot(d);
                (t > 1e-3).then_some((t, k))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
    };
    let n_px = (w * h) as usize;
    let (mut positions, mut normals) = (vec![[0.0f32; 4]; n_px], vec![[0u32; 2]; n_px]);
    let mut plane_of = vec![None; n_px];
    let mut cluster_key = vec![None; n_px];
    for p in 0..n_px {
        let (x, y) = (p as u32 % w, p as u32 / w);
        let d = ray(x as f64 + 0.5, y as f64 + 0.5);
        let Some((t, k)) = hit(d) else { continue };
        let (n, _) = planes[k];
        let front = n.dot(d) < 0.0;
        positions[p] = v4(eye + d * t, if front { 1.0 } else { 0.0 });
        if front {
            let q = [n.x, n.y, n.z].map(|c| (c * 32767.0).round() as i32);
            normals[p] = vxgi_cpu_mirror::octahedral::pack(Some(q));
            plane_of[p] = Some(k);
            cluster_key[p] = Some(((y / 8) * w.div_ceil(8) + x / 8) * 3 + k as u32);
        }
    }
    let mut keys: Vec<u32> = cluster_key.iter().flatten().copied().collect();
    keys.sort_unstable();
    keys.dedup();
    let pixel_cluster: Vec<u32> = cluster_key
        .iter()
        .map(|k| k.map_or(NONE, |k| keys.binary_search(&k).unwrap() as u32))
        .collect();
    // Slots: every cluster and one more, or (every fourth case) half of them: claims of clusters
    // past the slots are dropped.
    let slots = if index % 4 == 3 {
        keys.len().div_ceil(2).max(1)
    } else {
        keys.len() + 1
    };
    let front: Vec<usize> = (0..n_px).filter(|&p| plane_of[p].is_some()).collect();
    let params = [
        ReuseParams::DEFAULT,
        ReuseParams {
            reach: 0.5,
            min_cos: -1.0,
            ..ReuseParams::DEFAULT
        },
        ReuseParams {
            reach: 3.0,
            min_cos: 0.999,
            ..ReuseParams::DEFAULT
        },
        ReuseParams {
            reach: 20.0,
            ..ReuseParams::DEFAULT
        },
    ][index % 4];
    // Every other case carries the kept caches' texels (1 to 64 a cache).
    let params = ReuseParams {
        carry: (index % 2) as u32,
        texels: [4, 1, 16, 64][(index / 2) % 4],
        ..params
    };

    let m = [40usize, 3, 9, 120][index % 4];
    let (mut prev_pos, mut prev_normal) = (Vec::with_capacity(m), Vec::with_capacity(m));
    for _ in 0..m {
        let kind = rng.random_range(0..20);
        if front.is_empty() || kind == 0 {
            // Behind the camera, or off the image.
            let x = if rng.random_bool(0.5) {
                eye - fwd * 2.0
            } else {
                eye + fwd + right * 3.0
            };
            prev_pos.push(v4(x, 0.0));
            prev_normal.push(v4(unit(&mut rng), 0.0));
            continue;
        }
        let p = front[rng.random_range(0..front.len())];
        let k = plane_of[p].expect("a front pixel");
        let (n, o) = planes[k];
        let (x, y) = ((p as u32 % w) as f64, (p as u32 / w) as f64);
        // A point of the plane seen near the pixel: jittered by up to 1.5 pixels, or on a corner.
        let (fx, fy) = if kind == 1 {
            (x, y)
        } else {
            (
                x + 0.5 + rng.random_range(-1.5..1.5),
                y + 0.5 + rng.random_range(-1.5..1.5),
            )
        };
        let d = ray(fx, fy);
        let mut at = eye + d * ((o - n.dot(eye)) / n.dot(d));
        let mut normal = n;
        match kind {
            // Off the surface, about as far as the reach (in footprints at the cache's depth).
            2 | 3 => {
                let footprint = 2.0 * (at - eye).dot(fwd) * up.length() / h as f64;
                at += n * footprint * params.reach as f64 * rng.random_range(0.7..1.3);
            }
            // A turned normal.
            4 => normal = (n + unit(&mut rng) * rng.random_range(0.0..1.5)).normalize(),
            5 => normal = -n,
            _ => {}
        }
        prev_pos.push(v4(at, rng.random_range(0.0..1.0)));
        prev_normal.push(v4(normal, 0.0));
        // The same cache again: the lower index wins.
        if kind == 6 {
            prev_pos.push(*prev_pos.last().unwrap());
            prev_normal.push(*prev_normal.last().unwrap());
        }
    }
    let len = prev_pos.len().max(1);
    prev_pos.resize(len, [0.0; 4]);
    prev_normal.resize(len, [0.0; 4]);
    // All of them, or all but the last three (whose pixels must stay as they were).
    let prev_count = if index % 3 == 2 {
        len.saturating_sub(3)
    } else {
        len
    };
    let garbage = |rng: &mut ChaCha8Rng| rng.random_range(-9.0f32..9.0);
    let mut four =
        |n: usize| -> Vec<[f32; 4]> { (0..n).map(|_| [0; 4].map(|_| garbage(&mut rng))).collect() };
    let (cache_pos, cache_normal, caches) = (four(slots), four(slots), four(2 * slots));
    let t = params.texels as usize;
    let (prev_caches, prev_radiance, cache_radiance) =
        (four(2 * len), four(len * t), four(slots * t));
    let io = Io {
        frame: Block(frame),
        reuse_params: Block(params),
        prev_count: vec![prev_count as u32],
        prev_pos,
        prev_normal,
        prev_caches,
        prev_radiance,
        pixel_cluster,
        normals,
        positions,
        cache_count: vec![rng.random_range(0..=slots as u32)],
        prev_pixel: (0..len).map(|_| rng.random()).collect(),
        kept: (0..slots).map(|_| rng.random()).collect(),
        cache_pos,
        cache_pixel: (0..slots).map(|_| [rng.random(), rng.random()]).collect(),
        cache_normal,
        caches,
        cache_radiance,
        // As cache_records leaves them: [2] is 0, the rest the count and workgroups.
        cache_args: (0..vxgi_cpu_mirror::cache_records::ARGS_LEN)
            .map(|k| if k == 2 { 0 } else { rng.random() })
            .collect(),
    };
    let label = format!(
        "#{index} {w}x{h}, {} clusters in {slots} slots, {prev_count} of {len} last caches{}",
        keys.len(),
        if params.carry != 0 {
            format!(", carrying {t} texels each")
        } else {
            String::new()
        }
    );
    (io, label)
}

pub struct CacheReuse;

impl Kernel for CacheReuse {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (io, label) = generated(seed, index);
        let (mut all, keep) = passes(ctx, io.kept.len(), io.prev_pos.len(), io.cache_pos.len());
        all.push(keep);
        io.case(label, seed, all)
    }

    fn mirror(&self, case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let (io, first) = (Io::read(data), Io::read(&case.resources));
        let inp = Inputs {
            frame: &io.frame.0,
            params: &io.reuse_params.0,
            prev_pos: &io.prev_pos,
            prev_normal: &io.prev_normal,
            pixel_cluster: &io.pixel_cluster,
            normals: &io.normals,
            positions: &io.positions,
            slots: io.kept.len(),
        };
        let (kept, pixel, _) = accept(
            &inp,
            io.prev_count[0] as usize,
            &io.kept,
            &io.prev_pixel,
            &first.prev_pixel,
        );
        let mut out = first.clone();
        let last = Last {
            caches: &io.prev_caches,
            radiance: &io.prev_radiance,
        };
        let count = keep(
            &inp,
            &kept,
            &pixel,
            io.cache_count[0],
            &last,
            (
                &mut out.cache_pos,
                &mut out.cache_pixel,
                &mut out.cache_normal,
                &mut out.caches,
                &mut out.cache_radiance,
            ),
        );
        (out.kept, out.prev_pixel) = (kept, pixel);
        out.cache_args[2] = out.cache_args[2].wrapping_add(count);
        out.outputs()
    }
}
