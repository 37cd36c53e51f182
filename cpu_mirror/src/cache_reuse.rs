//! Mirror of `kernels/cache_reuse.wgsl`: the last frame's radiance caches kept on the surfaces they
//! were made on (Rehfeld et al. 2014, sections 5-6), so that caches follow surfaces rather than
//! jumping between the pixels of their cluster.
//!
//! Last-frame cache `i < prev_count` at `X` with normal `m`, this frame's camera `(eye, f, r, u)`
//! (`r`, `u` scaled by the field of view, as the G-buffer's rays), image `w x h`:
//! - `d = X - eye`, `z = d . f`; `fx = ((d . r) / (z (r . r)) + 1) w / 2`,
//!   `fy = (1 - (d . u) / (z (u . u))) h / 2`; `prev_pixel[i] = floor(fy) w + floor(fx)` where `z > 0`
//!   and `(fx, fy)` lies in `[0, w) x [0, h)`, else `0xffffffff`;
//! - it is a candidate for the cluster `c = pixel_cluster[p]` of that pixel (when `c < kept.len()`)
//!   if `positions[p].w == 1`, the pixel's normal is geometry, `(q / 32767) . m >= min_cos` and
//!   `|positions[p] - X|^2 <= (reach 2 z |u| / h)^2`;
//! - `kept[c] = 0xffffffff - (the lowest candidate i of c)`, `0` without one (`clear` zeroes every
//!   slot first);
//! - for `c < min(cache_count, kept.len())` with a kept cache `i`: `cache_pos[c] = (X, its own w)`,
//!   `cache_normal[c] = (m, 0)`, `cache_pixel[c] = (p % w, p / w)` for `p = prev_pixel[i]`, and the
//!   creation record the cache was traced from last frame: `caches[2c] = prev_caches[2i]`,
//!   `caches[2c + 1] = (prev_caches[2i + 1].xyz, carry)`. With `carry` (1: the volume the caches
//!   were traced through is unchanged since the last frame) its `texels` radiance texels are copied
//!   too, `cache_radiance[c texels + t] = prev_radiance[i texels + t]`, and cache_creation skips
//!   the cache (`caches[2c + 1].w != 0`): tracing the same record through the same volume again
//!   would give the same texels. Other slots keep what they held. `cache_args[2]` (0 from
//!   cache_records) grows by the number of slots that kept a cache. Copies only: exact.
//!
//! The projection's and the tests' results are computed here in f64 with a bound on the GPU's f32
//! error ([`claim`]); an outcome within the bound of a decision's boundary is "either": the GPU may
//! take either side. [`accept`] takes the GPU's outcomes where they are among the possible ones.
use crate::gbuffer::Frame;
use crate::octahedral::unpack;

const U: f64 = f32::EPSILON as f64 / 2.0;
pub const NONE: u32 = u32::MAX;

/// The kernel's uniform block (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ReuseParams {
    /// How far (in pixel footprints at the cache's depth) the pixel's surface point may lie from the
    /// cache for the cache to be kept.
    pub reach: f32,
    /// The least cosine between the pixel's normal and the cache's.
    pub min_cos: f32,
    /// 1 where the volume is unchanged since the last frame: kept caches carry their radiance
    /// texels and are not traced again; 0 to trace them (a renderer's frame that re-lit or moved
    /// anything, or `cache_carry = false`).
    pub carry: u32,
    /// Radiance texels per cache (cache_creation's `res^2`).
    pub texels: u32,
}

impl ReuseParams {
    /// The defaults: three footprints (a surface seen at up to 76 degrees from its normal still
    /// puts its pixel centres within reach), normals within 25.8 degrees.
    pub const DEFAULT: Self = Self {
        reach: 3.0,
        min_cos: 0.9,
        carry: 0,
        texels: 1,
    };
}

/// What this frame's inputs of the kernel hold (the G-buffer's per-pixel inputs of the distribution,
/// and the last frame's caches).
pub struct Inputs<'a> {
    pub frame: &'a Frame,
    pub params: &'a ReuseParams,
    pub prev_pos: &'a [[f32; 4]],
    pub prev_normal: &'a [[f32; 4]],
    pub pixel_cluster: &'a [u32],
    pub normals: &'a [[u32; 2]],
    pub positions: &'a [[f32; 4]],
    /// Cluster slots (the length of `kept`).
    pub slots: usize,
}

/// A test's outcome: certainly passed, certainly failed, or within the GPU's rounding of the boundary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    Yes,
    No,
    Either,
}

fn verdict(value: f64, threshold: f64, bound: f64) -> Verdict {
    // value >= threshold passes.
    if !(value.is_finite() && threshold.is_finite() && bound.is_finite()) {
        return Verdict::Either;
    }
    if value - bound >= threshold {
        Verdict::Yes
    } else if value + bound < threshold {
        Verdict::No
    } else {
        Verdict::Either
    }
}

/// One possible outcome of `claim` for a cache: the pixel it projects to (`NONE`: none) and whether
/// it is a candidate for that pixel's cluster.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outcome {
    pub pixel: u32,
    pub candidate: Verdict,
}

/// Every outcome `claim` may have for cache `i` on a GPU within WGSL's accuracy rules; the first is
/// the exact arithmetic's (its pixel is the mirror's `prev_pixel`).
///
/// Bounds, in units of `u` = 2^-24 (half an ULP: an ULP is up to `2 u` relative), each doubled for
/// any order of a dot product's terms, fused or not: `d = X - eye` rounds each component by
/// `u |d_k|`; a dot product of `d` with `v` is then within `(2 + 3) u sum |d_k v_k|`. `(d . r) / (z
/// (r . r))` adds the relative errors of `z`, of `r . r` (3 u), the product (u) and the division (2.5
/// ULP: 5 u); the `+ 1`, `* 0.5` (exact) and `* w` add `2 u` of the result. The normal test: the
/// constant `1 / 32767` and the product round (u each), the dot `3 u` of `sum |n_k m_k|`. The
/// distance test: `e = P - X` rounds `u |e_k|`, `e . e` within `5 u e . e`; the reach `reach * 2 *
/// z * sqrt(u . u) / h`: `z`'s relative error, the sqrt (the dot's 3 u halved, and sqrt as `1 /
/// inverseSqrt`: 2 ULP and 2.5 ULP, 9 u), two products (u each) and a division (5 u), 17.5 u in
/// all; squared, twice that and one more product. Where the inputs are not finite, or `z` is within
/// its bound of 0 (the projection unbounded), every outcome is possible (WGSL may also assume that
/// no value is NaN or infinite).
pub fn claim(inp: &Inputs, i: usize) -> Vec<Outcome> {
    let f = inp.frame;
    let v3 = |a: [f32; 4]| [a[0] as f64, a[1] as f64, a[2] as f64];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let abs_dot = |a: [f64; 3], b: [f64; 3]| {
        a[0].abs() * b[0].abs() + a[1].abs() * b[1].abs() + a[2].abs() * b[2].abs()
    };
    let x = v3(inp.prev_pos[i]);
    let eye = v3(f.eye);
    let d = [x[0] - eye[0], x[1] - eye[1], x[2] - eye[2]];
    let (fw, r, u) = (v3(f.forward), v3(f.right), v3(f.up));
    let (w, h) = (f.size[0], f.size[1]);
    let none = vec![Outcome {
        pixel: NONE,
        candidate: Verdict::No,
    }];
    if w == 0 || h == 0 {
        return none;
    }
    // Any pixel, each a candidate or not as its cluster's tests allow: the GPU's arithmetic is not
    // bounded here.
    let any = || {
        let mut out = none.clone();
        for p in 0..w * h {
            if let Some(gathers) = gathers(inp, p) {
                let candidate = if gathers {
                    Verdict::Either
                } else {
                    Verdict::No
                };
                out.push(Outcome {
                    pixel: p,
                    candidate,
                });
            }
        }
        out
    };
    let finite = |a: [f32; 4]| a.iter().all(|c| c.is_finite());
    if ![
        inp.prev_pos[i],
        inp.prev_normal[i],
        f.eye,
        f.forward,
        f.right,
        f.up,
    ]
    .into_iter()
    .all(finite)
    {
        return any();
    }
    let z = dot(d, fw);
    let bz = 2.0 * 5.0 * U * abs_dot(d, fw);
    if z + bz <= 0.0 {
        return none;
    }
    if z - bz <= 0.0 {
        return any();
    }
    let rel_z = bz / z;
    // A coordinate in pixels and its bound: `(dot(d, a) / (z dot(a, a)) * sign + 1) * 0.5 * size`.
    let coord = |a: [f64; 3], sign: f64, size: u32| {
        let aa = dot(a, a);
        let n = dot(d, a) / (z * aa);
        let bn = 2.0 * (5.0 * U * abs_dot(d, a) / (z * aa) + n.abs() * (rel_z + 9.0 * U));
        let c = (sign * n + 1.0) * 0.5 * size as f64;
        let bc = 0.5 * size as f64 * bn + 2.0 * 2.0 * U * c.abs();
        (c, bc)
    };
    let (fx, bx) = coord(r, 1.0, w);
    let (fy, by) = coord(u, -1.0, h);
    if !(fx.is_finite() && fy.is_finite() && bx.is_finite() && by.is_finite()) {
        // A degenerate camera (r or u zero).
        return any();
    }
    // The columns (rows) the GPU may land in, and whether it may fall off the image.
    let cells = |c: f64, b: f64, size: u32| -> (Vec<u32>, bool) {
        let lo = (c - b).floor();
        let hi = (c + b).floor();
        let off = lo < 0.0 || hi >= size as f64;
        let cells = (lo.max(0.0) as i64..=hi.min(size as f64 - 1.0) as i64)
            .map(|k| k as u32)
            .collect();
        (cells, off)
    };
    let (xs, off_x) = cells(fx, bx, w);
    let (ys, off_y) = cells(fy, by, h);
    let exact = |c: f64, size: u32| c >= 0.0 && c < size as f64;
    let on_image = exact(fx, w) && exact(fy, h);
    let mut out = Vec::new();
    let m = v3(inp.prev_normal[i]);
    let up_len = dot(u, u).sqrt();
    let reach = inp.params.reach as f64 * 2.0 * z * up_len / h as f64;
    let b_reach = 2.0 * (2.0 * (rel_z + 17.5 * U) + U);
    for &y in &ys {
        for &xx in &xs {
            let p = y * w + xx;
            let candidate = match candidate(inp, p, x, m, reach, b_reach) {
                Some(v) => v,
                None => continue,
            };
            out.push(Outcome {
                pixel: p,
                candidate,
            });
        }
    }
    // The exact arithmetic's outcome first.
    let first = fy.floor().clamp(0.0, h as f64 - 1.0) as u32 * w
        + fx.floor().clamp(0.0, w as f64 - 1.0) as u32;
    if on_image {
        if let Some(k) = out.iter().position(|o| o.pixel == first) {
            out.swap(0, k);
        }
    }
    if off_x || off_y || out.is_empty() {
        let o = Outcome {
            pixel: NONE,
            candidate: Verdict::No,
        };
        if on_image && !out.is_empty() {
            out.push(o);
        } else {
            out.insert(0, o);
        }
    }
    out
}

/// Whether pixel `p` may keep a cache at all (it lies in a cluster slot, gathers and has a geometry
/// normal): the tests on the inputs alone, exact; `None` past the pixel arrays.
fn gathers(inp: &Inputs, p: u32) -> Option<bool> {
    let p = p as usize;
    let c = *inp.pixel_cluster.get(p)?;
    let (pos, n) = (inp.positions.get(p)?, inp.normals.get(p)?);
    Some((c as usize) < inp.slots && pos[3] == 1.0 && unpack(*n).is_some())
}

/// Whether the last-frame cache at `x` (normal `m`) is a candidate for pixel `p`'s cluster: `None`
/// where `p` is outside the pixel arrays (the kernel writes no pixel then: it cannot happen for a
/// pixel on the image with arrays of the image's size).
fn candidate(
    inp: &Inputs,
    p: u32,
    x: [f64; 3],
    m: [f64; 3],
    reach: f64,
    b_reach: f64,
) -> Option<Verdict> {
    if !gathers(inp, p)? {
        return Some(Verdict::No);
    }
    let p = p as usize;
    let pos = inp.positions[p];
    let q = unpack(inp.normals[p]).expect("a geometry normal");
    let np = q.map(|v| v as f64 / 32767.0);
    let cos = np[0] * m[0] + np[1] * m[1] + np[2] * m[2];
    let abs = np[0].abs() * m[0].abs() + np[1].abs() * m[1].abs() + np[2].abs() * m[2].abs();
    let normal = verdict(cos, inp.params.min_cos as f64, 2.0 * 5.0 * U * abs);
    let e = [0, 1, 2].map(|k| pos[k] as f64 - x[k]);
    let ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
    let rr = reach * reach;
    // dot(e, e) <= reach^2 passes: the verdict of reach^2 - e.e >= 0. Past f32's range either side
    // may overflow on the GPU: either outcome.
    let near = if ee.max(rr) > f32::MAX as f64 / 8.0 {
        Verdict::Either
    } else {
        verdict(rr - ee, 0.0, 2.0 * 5.0 * U * ee + b_reach * rr)
    };
    Some(match (normal, near) {
        (Verdict::No, _) | (_, Verdict::No) => Verdict::No,
        (Verdict::Yes, Verdict::Yes) => Verdict::Yes,
        _ => Verdict::Either,
    })
}

/// `kept` and `prev_pixel` as the GPU must have them, given its own (`gpu_kept`, `gpu_pixel`): per
/// cache, the GPU's pixel where it is among [`claim`]'s outcomes, else the mirror's; that pixel's
/// verdict then says whether the cache is certainly, possibly or not a candidate of the pixel's
/// cluster. Per cluster, the GPU's choice where it is possible (a possible candidate, and no lower
/// cache certainly one; or none where no cache certainly is), else the mirror's. `prev_pixel` past
/// `prev_count` keeps `first_pixel`, what it held. Also returns how many accepted values differ from
/// the exact arithmetic's.
pub fn accept(
    inp: &Inputs,
    prev_count: usize,
    gpu_kept: &[u32],
    gpu_pixel: &[u32],
    first_pixel: &[u32],
) -> (Vec<u32>, Vec<u32>, usize) {
    let n = prev_count.min(inp.prev_pos.len()).min(gpu_pixel.len());
    let mut pixel = first_pixel.to_vec();
    let mut sure = vec![u32::MAX; inp.slots];
    let mut possible: Vec<Vec<u32>> = vec![Vec::new(); inp.slots];
    let mut differ = 0;
    for i in 0..n {
        let outcomes = claim(inp, i);
        let o = match outcomes.iter().find(|o| o.pixel == gpu_pixel[i]) {
            Some(o) => {
                differ += (o.pixel != outcomes[0].pixel) as usize;
                *o
            }
            None => outcomes[0],
        };
        pixel[i] = o.pixel;
        let Some(&c) = inp.pixel_cluster.get(o.pixel as usize) else {
            continue;
        };
        let c = c as usize;
        if c < inp.slots && o.candidate != Verdict::No {
            possible[c].push(i as u32);
            if o.candidate == Verdict::Yes {
                sure[c] = sure[c].min(i as u32);
            }
        }
    }
    let kept = (0..inp.slots)
        .map(|c| {
            let g = gpu_kept.get(c).copied().unwrap_or(0);
            let ok = if g == 0 {
                sure[c] == u32::MAX
            } else {
                let i = NONE - g;
                possible[c].contains(&i) && i <= sure[c]
            };
            let own = if sure[c] == u32::MAX {
                0
            } else {
                NONE - sure[c]
            };
            if ok && g != own {
                differ += 1;
            }
            if ok {
                g
            } else {
                own
            }
        })
        .collect();
    (kept, pixel, differ)
}

/// The last frame's creation records and radiance texels, which a kept cache takes (`prev_caches`
/// two vec4s per cache, `prev_radiance` `params.texels` per cache).
pub struct Last<'a> {
    pub caches: &'a [[f32; 4]],
    pub radiance: &'a [[f32; 4]],
}

/// This frame's records as cache_records left them: (cache_pos, cache_pixel, cache_normal, caches,
/// cache_radiance).
pub type Records<'a> = (
    &'a mut [[f32; 4]],
    &'a mut [[u32; 2]],
    &'a mut [[f32; 4]],
    &'a mut [[f32; 4]],
    &'a mut [[f32; 4]],
);

/// The records after `keep`, overwritten for every slot below `min(cache_count, kept.len())` that
/// kept a cache (with `carry`, its radiance texels too, where both buffers hold them). Returns how
/// many slots kept one.
pub fn keep(
    inp: &Inputs,
    kept: &[u32],
    prev_pixel: &[u32],
    cache_count: u32,
    last: &Last,
    records: Records,
) -> u32 {
    let (pos, pix, nrm, crt, radiance) = records;
    let mut count = 0;
    let w = inp.frame.size[0].max(1);
    let t = inp.params.texels as usize;
    for c in 0..(cache_count as usize).min(kept.len()) {
        if kept[c] == 0 {
            continue;
        }
        let i = (NONE - kept[c]) as usize;
        count += 1;
        let (x, m) = (inp.prev_pos[i], inp.prev_normal[i]);
        let p = prev_pixel[i];
        pos[c] = [x[0], x[1], x[2], pos[c][3]];
        pix[c] = [p % w, p / w];
        nrm[c] = [m[0], m[1], m[2], 0.0];
        let (o, d) = (last.caches[2 * i], last.caches[2 * i + 1]);
        crt[2 * c] = o;
        crt[2 * c + 1] = [d[0], d[1], d[2], f32::from(u8::from(inp.params.carry != 0))];
        if inp.params.carry != 0 {
            for k in 0..t {
                if let (Some(&v), Some(dst)) =
                    (last.radiance.get(i * t + k), radiance.get_mut(c * t + k))
                {
                    *dst = v;
                }
            }
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4 x 4 view down -z (90 degrees), every pixel on the plane z = -2 facing the camera, one
    /// cluster per pixel.
    struct View {
        frame: Frame,
        positions: Vec<[f32; 4]>,
        normals: Vec<[u32; 2]>,
        clusters: Vec<u32>,
    }

    impl View {
        /// The kernel's inputs over this view.
        fn inputs<'a>(
            &'a self,
            params: &'a ReuseParams,
            prev_pos: &'a [[f32; 4]],
            prev_normal: &'a [[f32; 4]],
            slots: usize,
        ) -> Inputs<'a> {
            Inputs {
                frame: &self.frame,
                params,
                prev_pos,
                prev_normal,
                pixel_cluster: &self.clusters,
                normals: &self.normals,
                positions: &self.positions,
                slots,
            }
        }
    }

    fn view() -> View {
        let frame = Frame {
            eye: [0.0; 4],
            forward: [0.0, 0.0, -1.0, 0.0],
            right: [1.0, 0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0, 0.0],
            size: [4, 4, 0, 0],
        };
        let positions = (0..16)
            .map(|p| {
                let (x, y) = ((p % 4) as f32 + 0.5, (p / 4) as f32 + 0.5);
                [
                    (x / 4.0 * 2.0 - 1.0) * 2.0,
                    (1.0 - y / 4.0 * 2.0) * 2.0,
                    -2.0,
                    1.0,
                ]
            })
            .collect();
        let normals = vec![crate::octahedral::pack(Some([0, 0, 32767])); 16];
        View {
            frame,
            positions,
            normals,
            clusters: (0..16).collect(),
        }
    }

    #[test]
    fn a_pixel_centre_is_its_pixels_sure_candidate_and_a_corner_is_either_pixel() {
        let v = view();
        let params = ReuseParams::DEFAULT;
        let prev_pos = vec![v.positions[9], [0.0, 0.0, -2.0, 0.0], [0.0, 0.0, 2.0, 0.0]];
        let prev_normal = vec![[0.0, 0.0, 1.0, 0.0]; 3];
        let inp = v.inputs(&params, &prev_pos, &prev_normal, 16);
        assert_eq!(
            claim(&inp, 0),
            vec![Outcome {
                pixel: 9,
                candidate: Verdict::Yes
            }]
        );
        // The image's centre is the corner of pixels 5, 6, 9 and 10: any of them.
        let mut corner: Vec<u32> = claim(&inp, 1).iter().map(|o| o.pixel).collect();
        corner.sort_unstable();
        assert_eq!(corner, vec![5, 6, 9, 10]);
        // Behind the camera: no pixel.
        assert_eq!(claim(&inp, 2)[0].pixel, NONE);
        // The GPU's choice of cache 1 for cluster 10 is possible; cluster 9 must keep cache 0,
        // which is sure and lower.
        let mut gpu = vec![0; 16];
        gpu[9] = NONE - 1;
        gpu[10] = NONE - 1;
        let (kept, _, _) = accept(&inp, 3, &gpu, &[9, 10, NONE], &[0; 3]);
        assert_eq!((kept[9], kept[10]), (NONE, NONE - 1));
    }

    /// keep: the slot takes the last cache's creation record as it was (w = carry) and, carrying,
    /// its texels; without carry the texels stay as cache_records left them; a slot past
    /// cache_count keeps nothing.
    #[test]
    fn keep_copies_the_record_and_carries_texels_only_when_asked() {
        let v = view();
        let prev_pos = vec![v.positions[9], v.positions[2]];
        let prev_normal = vec![[0.0, 0.0, 1.0, 0.0]; 2];
        let last_caches = [
            [1.0, 2.0, 3.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [4.0; 4],
            [5.0; 4],
        ];
        let last_radiance: Vec<[f32; 4]> = (0..4).map(|t| [t as f32 + 10.0; 4]).collect();
        let last = Last {
            caches: &last_caches,
            radiance: &last_radiance,
        };
        for carry in [0, 1] {
            let params = ReuseParams {
                carry,
                texels: 2,
                ..ReuseParams::DEFAULT
            };
            let inp = v.inputs(&params, &prev_pos, &prev_normal, 3);
            // Slot 0 keeps last cache 1, slot 2 keeps cache 0 but lies past cache_count = 2.
            let kept = [NONE - 1, 0, NONE];
            let (mut pos, mut pix, mut nrm) = ([[9.0; 4]; 3], [[7, 7]; 3], [[9.0; 4]; 3]);
            let (mut crt, mut rad) = ([[9.0; 4]; 6], [[-1.0; 4]; 6]);
            let n = keep(
                &inp,
                &kept,
                &[9, 2],
                2,
                &last,
                (&mut pos, &mut pix, &mut nrm, &mut crt, &mut rad),
            );
            assert_eq!(n, 1);
            assert_eq!((crt[0], crt[1]), ([4.0; 4], [5.0, 5.0, 5.0, carry as f32]));
            assert_eq!((pix[0], pos[0][3]), ([2, 0], 9.0));
            let carried = if carry == 1 {
                [[12.0; 4], [13.0; 4]]
            } else {
                [[-1.0; 4]; 2]
            };
            assert_eq!(rad[..2], carried);
            assert_eq!((crt[4], rad[4], pix[2]), ([9.0; 4], [-1.0; 4], [7, 7]));
        }
    }
}
