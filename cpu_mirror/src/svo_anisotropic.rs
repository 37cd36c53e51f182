//! Mirror of `kernels/svo_anisotropic.wgsl`: the sparse voxel octree's anisotropic voxels (Crassin et
//! al. 2011, section 7.1). Above the leaves every brick voxel gets six directional values, one per
//! axis direction (+x, -x, +y, -y, +z, -z: index `2 axis + negative`), each the pre-multiplied
//! `(L * alpha, alpha)` a cone travelling that way sees through the voxel's cell.
//!
//! The isotropic octree averages a parent point's 27 child lattice points with [1 2 1]^3 / 64 weights:
//! a volume average, so a one-voxel wall is half transparent one level up (the leak docs/accuracy/vct-svo.md measures).
//! Here, for direction +a, each of the 9 rows of child points along `a` (weights [1 2 1]^2 / 16 over
//! the other two axes) is composited front to back, in the order the cone meets them. The row's end
//! points are shared with the neighbouring parents (they are half inside this one's cell), so they
//! enter with half their thickness: `half(p) = p / (1 + sqrt(1 - p.alpha))`, which is
//! `1 - (1 - alpha)^(1/2)` for the opacity (written without its cancellation) and scales the emitted
//! light by the same factor (a homogeneous slab's light grows with its opacity). A wall one child
//! voxel thick stays opaque at every level wherever it sits, and a homogeneous medium of opacity
//! `alpha` per child cell gets `1 - (1 - alpha)^2` per parent cell: exact volumetric integration.
//!
//!   row(f, m, b) = over(half(f), over(m, half(b))),   over(f, b) = f + b (1 - f.alpha)
//!
//! with `f` the front point, `m` the middle, `b` the back (for +a: -1, 0, +1; for -a reversed).
//! Leaves (level `depth`) hold the isotropic bricks; the pass of level `l` reads level `l + 1`'s
//! directional values (the leaves' bricks when `l + 1 = depth`) through the child pointers: child
//! point `q` lies in node `min(q / 2, 2^(l+1) - 1)` (any node holding a shared point has the same value
//! there), outside the lattice or in a missing node it is empty. Levels are built from `depth - 1` down
//! to 0, one pass each.
//!
//! **Empty voxels are skipped:** a brick voxel whose isotropic value is zero (all four channels) gets
//! zero directional values without locating its child points. Exact where its child points are all
//! zero; where the filtered sum merely rounds to zero (`(S + 32) >> 6 = 0`: every weight is at least
//! one 64th, so every child point then holds under 32 fixed-point units) the directional values
//! dropped are under 32 units too — no finer than the isotropic pool, which drops the same. On the
//! Cornell box (128^3, photons) 72% of the brick voxels above the leaves are zero.
//!
//! Storage: `aniso[(n * 27 + voxel) * 6 + direction]` (vec4 f32) for the nodes of levels
//! `0..depth` (the first `levels[depth] * 8` nodes: 1/8 of the octree, 2592 bytes each).
//!
//! Accuracy: every quantity is non-negative, alphas in [0, 1]; `half` is sqrt (WGSL: inherited from
//! `1 / inverseSqrt`, a few ULP), an addition and a division (2.5 ULP): 10 ULP relative; `over`
//! multiplies and adds non-negative terms, `1 - alpha` rounds by half an ULP of 1. Each row is within
//! 32 ULP of its magnitude `f + m + b` (an upper bound of every term, half(p) <= p), and the weighted
//! sum of the 9 rows (exact power-of-two weights, 9 additions) within 48 ULP of the weighted sum of the
//! magnitudes: the per-element bound, given exact inputs (the kernel is verified one level at a time).
use crate::sparse_voxel_octree::{brick_value, find, unkey, voxel_index, Node, BRICK_WORDS, NONE};
use bytemuck::{Pod, Zeroable};
use glam::Vec4;

/// Directional values per brick voxel.
pub const DIRECTIONS: usize = 6;
/// Directional values per node.
pub const NODE_VALUES: usize = 27 * DIRECTIONS;

/// The kernel's `struct AnisoParams`: the level this pass builds (its nodes are the octree's
/// `levels` range of it, [`level_nodes`], read by the pass itself: a pass recorded before the
/// structure exists runs over whatever nodes the GPU built).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct AnisoParams {
    pub depth: u32,
    pub level: u32,
    /// The isotropic bricks' fixed point: value = u32 * inv_scale.
    pub inv_scale: f32,
    pub _pad: [u32; 5],
}

/// The node slots of `level` (8 per tile): `levels[level] * 8 ..levels[level + 1] * 8`.
pub fn level_nodes(levels: &[u32], level: u32) -> std::ops::Range<u32> {
    let l = level as usize;
    levels[l] * 8..levels[l + 1] * 8
}

/// Where (node `n`, brick voxel `v`, direction `dir`) sits in the buffer.
pub fn index(n: u32, v: usize, dir: usize) -> usize {
    (n as usize * 27 + v) * DIRECTIONS + dir
}

/// The direction (0..6) a cone travelling along `d` reads on axis `a`.
pub fn direction(a: usize, d: f32) -> usize {
    2 * a + (d < 0.0) as usize
}

fn half(p: Vec4) -> Vec4 {
    p / (1.0 + (1.0 - p.w).max(0.0).sqrt())
}

fn over(f: Vec4, b: Vec4) -> Vec4 {
    f + b * (1.0 - f.w)
}

/// The value of child lattice point `q` (level `cl`, lattice `0..=2 * 2^cl`) in direction `dir`.
fn child(
    nodes: &[Node],
    bricks: &[u32],
    aniso: &[[f32; 4]],
    p: &AnisoParams,
    cl: u32,
    q: [i64; 3],
    dir: usize,
) -> Vec4 {
    let points = 2i64 << cl;
    if q.iter().any(|&c| c < 0 || c > points) {
        return Vec4::ZERO;
    }
    let last = (1i64 << cl) - 1;
    let c = q.map(|x| (x >> 1).min(last));
    let n = find(nodes, cl, c.map(|x| x as u32));
    if n == NONE {
        return Vec4::ZERO;
    }
    let v = voxel_index([0, 1, 2].map(|a| (q[a] - 2 * c[a]) as u32));
    if cl == p.depth {
        brick_value(bricks, n, v, p.inv_scale)
    } else {
        Vec4::from_array(aniso[index(n, v, dir)])
    }
}

/// The six directional values of brick voxel `v` of node `n` (of level `p.level`) and their bounds;
/// zeros for an unused node slot.
pub fn voxel(
    nodes: &[Node],
    bricks: &[u32],
    aniso: &[[f32; 4]],
    p: &AnisoParams,
    n: u32,
    v: [u32; 3],
) -> ([Vec4; DIRECTIONS], [Vec4; DIRECTIONS]) {
    let mut out = [Vec4::ZERO; DIRECTIONS];
    let mut bound = [Vec4::ZERO; DIRECTIONS];
    let key = nodes[n as usize].key;
    if key == NONE {
        return (out, bound);
    }
    // An empty voxel (isotropic value zero): no directional values (module doc).
    let b = n as usize * BRICK_WORDS + voxel_index(v) * 4;
    if bricks[b..b + 4] == [0; 4] {
        return (out, bound);
    }
    let (_, c) = unkey(key);
    let centre = [0, 1, 2].map(|a| 2 * (2 * c[a] as i64 + v[a] as i64));
    let cl = p.level + 1;
    const W: [f32; 3] = [1.0, 2.0, 1.0];
    for dir in 0..DIRECTIONS {
        let a = dir / 2;
        let (b, cax) = ((a + 1) % 3, (a + 2) % 3);
        let mut acc = Vec4::ZERO;
        let mut mag = Vec4::ZERO;
        for (i, wi) in W.iter().enumerate() {
            for (j, wj) in W.iter().enumerate() {
                let pt = |k: i64| {
                    let mut q = centre;
                    q[a] += k;
                    q[b] += i as i64 - 1;
                    q[cax] += j as i64 - 1;
                    child(nodes, bricks, aniso, p, cl, q, dir)
                };
                let (f, m, bk) = if dir % 2 == 0 {
                    (pt(-1), pt(0), pt(1))
                } else {
                    (pt(1), pt(0), pt(-1))
                };
                let r = over(half(f), over(m, half(bk)));
                let w = wi * wj * (1.0 / 16.0);
                acc += r * w;
                mag += (f + m + bk) * w;
            }
        }
        out[dir] = acc;
        bound[dir] = mag * (48.0 * f32::EPSILON);
    }
    (out, bound)
}

/// One level's pass: every voxel of `p`'s level's nodes ([`level_nodes`] of the octree's `levels`)
/// written into `aniso` (which holds the deeper levels); returns the bounds of what it wrote, in the
/// buffer's layout (zero elsewhere).
pub fn level_pass(
    nodes: &[Node],
    bricks: &[u32],
    levels: &[u32],
    aniso: &mut [[f32; 4]],
    p: &AnisoParams,
) -> Vec<[f32; 4]> {
    let mut bounds = vec![[0.0f32; 4]; aniso.len()];
    for n in level_nodes(levels, p.level) {
        for vi in 0..27u32 {
            let v = [vi % 3, (vi / 3) % 3, vi / 9];
            let (vals, b) = voxel(nodes, bricks, aniso, p, n, v);
            for dir in 0..DIRECTIONS {
                let k = index(n, vi as usize, dir);
                aniso[k] = vals[dir].to_array();
                bounds[k] = b[dir].to_array();
            }
        }
    }
    bounds
}

/// The per-level parameters of an octree of `depth`, level `depth - 1` first: the order the passes
/// run in.
pub fn passes(depth: u32, inv_scale: f32) -> Vec<AnisoParams> {
    (0..depth)
        .rev()
        .map(|l| AnisoParams {
            depth,
            level: l,
            inv_scale,
            _pad: [0; 5],
        })
        .collect()
}

/// Every level's directional values (buffer of `levels[depth] * 8` nodes).
pub fn build(
    nodes: &[Node],
    bricks: &[u32],
    depth: u32,
    levels: &[u32],
    inv_scale: f32,
) -> Vec<[f32; 4]> {
    let mut aniso = vec![[0.0f32; 4]; levels[depth as usize] as usize * 8 * NODE_VALUES];
    for p in passes(depth, inv_scale) {
        level_pass(nodes, bricks, levels, &mut aniso, &p);
    }
    aniso
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse_voxel_octree::{build as build_octree, capacity_bound, Fragment};

    const SCALE: f32 = 65536.0;

    fn octree(depth: u32, points: &[([u32; 3], [f32; 4])]) -> crate::sparse_voxel_octree::Octree {
        let frags: Vec<Fragment> = points
            .iter()
            .map(|&(pos, v)| Fragment {
                pos,
                _pad: 0,
                value: v.map(|x| (x * SCALE).round() as u32),
            })
            .collect();
        build_octree(depth, capacity_bound(depth, frags.len()) as u32, &frags)
    }

    /// The directional value at level `l`, lattice point `p` (level-l lattice), direction `dir`.
    fn at(
        o: &crate::sparse_voxel_octree::Octree,
        an: &[[f32; 4]],
        l: u32,
        p: [u32; 3],
        dir: usize,
    ) -> Vec4 {
        let last = (1u32 << l) - 1;
        let c = p.map(|x| (x / 2).min(last));
        let n = o.find(l, c);
        assert_ne!(n, NONE, "node of {p:?} at level {l}");
        Vec4::from_array(an[index(n, voxel_index([0, 1, 2].map(|a| p[a] - 2 * c[a])), dir)])
    }

    /// Empty voxels are skipped: where a parent voxel's filtered value rounds to zero (a faint point,
    /// 10 fixed-point units, seen through a corner weight of 1/64), its directional values are zero,
    /// and what was dropped is under 32 units; a bright point's parent voxel keeps its values.
    #[test]
    fn voxels_whose_isotropic_value_rounds_to_zero_have_no_directional_values() {
        let depth = 2; // leaves' lattice 0..=8
        let faint = 10.0 / SCALE;
        for (value, expect_zero) in [(faint, true), (0.5, false)] {
            // An odd point: parent point (2, 2, 2) of level 1 reaches it with weight 1 per axis.
            let o = octree(depth, &[([5, 5, 5], [value, value, value, value])]);
            let an = build(&o.nodes, &o.bricks, o.depth, &o.levels, 1.0 / SCALE);
            let c = o.find(1, [1, 1, 1]);
            let b =
                c as usize * crate::sparse_voxel_octree::BRICK_WORDS + voxel_index([0, 0, 0]) * 4;
            assert_eq!(o.bricks[b..b + 4] == [0; 4], expect_zero, "value {value}");
            // The point itself is in the leaves either way (what the skip dropped: under 32 units).
            let leaf = o.find(2, [2, 2, 2]);
            let lb = leaf as usize * crate::sparse_voxel_octree::BRICK_WORDS
                + voxel_index([1, 1, 1]) * 4;
            assert_eq!(o.bricks[lb], (value * SCALE).round() as u32);
            for dir in 0..DIRECTIONS {
                let v = at(&o, &an, 1, [2, 2, 2], dir);
                if expect_zero {
                    assert_eq!(v, Vec4::ZERO);
                } else {
                    assert!(v.w > 0.0, "dir {dir}: {v}");
                }
            }
        }
    }

    /// A wall of opaque voxels one leaf thick (plane x = k) stays opaque across x at every level, for
    /// even and odd k, where the isotropic average halves it.
    #[test]
    fn a_thin_wall_stays_opaque_across_it() {
        let depth = 3; // 16^3 leaves' lattice 0..=16
        for k in [6u32, 7] {
            let mut pts = Vec::new();
            for y in 0..=16 {
                for z in 0..=16 {
                    pts.push(([k, y, z], [0.5, 0.25, 0.0, 1.0]));
                }
            }
            let o = octree(depth, &pts);
            let an = build(&o.nodes, &o.bricks, depth, &o.levels, 1.0 / SCALE);
            // Level 2 (lattice 0..=8): the parent points around the wall, mid-plane in y and z.
            let near = [k / 2, 4, 4];
            for dir in [0, 1] {
                let v = at(&o, &an, 2, near, dir);
                assert!((v.w - 1.0).abs() < 1e-6, "k {k} dir {dir}: {v}");
            }
            // And one level further up, on both sides of the wall.
            for x in [1, 2] {
                for dir in [0, 1] {
                    let v = at(&o, &an, 1, [x, 2, 2], dir);
                    assert!(
                        (v.w - 1.0).abs() < 1e-6,
                        "k {k} level 1 x {x} dir {dir}: {v}"
                    );
                }
            }
        }
    }

    /// A homogeneous medium of opacity a per leaf cell: a parent cell twice as thick has
    /// 1 - (1 - a)^2 across it in every direction (inside, away from the volume's border).
    #[test]
    fn a_homogeneous_medium_integrates_exactly() {
        let depth = 3;
        let a = 0.3f32;
        let mut pts = Vec::new();
        for x in 0..=16 {
            for y in 0..=16 {
                for z in 0..=16 {
                    pts.push(([x, y, z], [0.2, 0.2, 0.2, a]));
                }
            }
        }
        let o = octree(depth, &pts);
        let an = build(&o.nodes, &o.bricks, depth, &o.levels, 1.0 / SCALE);
        let fixed_a = (a * SCALE).round() / SCALE;
        for dir in 0..6 {
            let v = at(&o, &an, 2, [4, 4, 4], dir);
            let want = 1.0 - (1.0 - fixed_a).powi(2);
            assert!((v.w - want).abs() < 1e-5, "dir {dir}: {} vs {want}", v.w);
            // Level 1: four leaf cells thick.
            let v = at(&o, &an, 1, [2, 2, 2], dir);
            let want = 1.0 - (1.0 - fixed_a).powi(4);
            assert!((v.w - want).abs() < 1e-5, "dir {dir}: {} vs {want}", v.w);
        }
    }

    /// Front-to-back order: a red opaque layer in front of a green one shows red travelling +x and
    /// green travelling -x.
    #[test]
    fn the_front_layer_is_what_a_cone_sees() {
        let depth = 2;
        let mut pts = Vec::new();
        for y in 0..=8 {
            for z in 0..=8 {
                pts.push(([3, y, z], [1.0, 0.0, 0.0, 1.0]));
                pts.push(([4, y, z], [0.0, 1.0, 0.0, 1.0]));
            }
        }
        let o = octree(depth, &pts);
        let an = build(&o.nodes, &o.bricks, depth, &o.levels, 1.0 / SCALE);
        let plus = at(&o, &an, 1, [2, 2, 2], 0);
        let minus = at(&o, &an, 1, [2, 2, 2], 1);
        assert!(plus.x > 0.4 && plus.y < 1e-6, "+x {plus}");
        assert!(minus.y > 0.4 && minus.x < 1e-6, "-x {minus}");
        assert!((plus.w - 1.0).abs() < 1e-6 && (minus.w - 1.0).abs() < 1e-6);
    }
}
