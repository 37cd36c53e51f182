//! Mirror of `kernels/sparse_voxel_octree.wgsl`: the sparse voxel octree of voxel cone tracing
//! (Crassin et al. 2011, sections 4.1-4.2.3 and 8.2) with 3x3x3 vertex-centred bricks.
//!
//! All arithmetic is integer (u32 fixed point, as the paper's 16-bit normalised atomics), so GPU and
//! mirror agree bit for bit; only the order in which the atomic counter hands out node tiles differs,
//! which [`canonical_nodes`] / [`canonical_bricks`] remove (records sorted by node key, pointers replaced
//! by the keys of the nodes they point to).
//!
//! The model, in lattice terms:
//! - Level `l` has `2^l` nodes per axis; a node's brick holds the values at its corners, edge and face
//!   midpoints and centre: the points of level `l`'s vertex lattice (`2 * 2^l + 1` per axis) inside the
//!   node's closed box. Neighbouring bricks share their boundary points.
//! - A fragment is a point of the leaf lattice with four u32 values. It builds the structure and its
//!   values are splatted (atomic add) into one brick holding that point; the border transfer (add along
//!   +axis, copy back, per axis) then makes every copy of a shared point hold the sum.
//! - **Sparsity (the halo rule):** face transfers only complete a shared point when every node holding
//!   a copy of it exists, and a parent's share of a shared child point is only half of it, so every
//!   parent holding that point must have children to count its half. So each fragment, at every level,
//!   flags for subdivision every parent whose closed box holds a point of the fragment's support at that
//!   level (the lattice points its value reaches through the filter: at most 2 per axis, see
//!   [`flag_box`]). Nodes are allocated per 2x2x2 tile, so each flagged parent gets all eight children:
//!   every copy of a non-zero point exists at every level, and the six face passes (x, then y, then z)
//!   reach the bricks that share a point only along an edge or at a corner as well.
//! - **Distribution over levels:** a parent point `P` is the [1 2 1]^3/64 weighted sum of the child lattice
//!   points around it (zero outside the volume). Each parent node computes its share from its own children
//!   (a child point on a face it shares with another parent counts half: weight by inverse multiplicity,
//!   Fig. 4), in four passes of equal cost per thread: centre (27 child points), faces (18), edges (12),
//!   corners (8). (The paper's Fig. 9 is 2D, where edges are the faces: three passes there, four in 3D.)
//!   The transfer then sums the shares, and each value is rounded once, after the transfer:
//!   `(S + 32) >> 6`.
//! - **Skipping empty work:** only nodes that received values (leaves with a non-zero splat; parents with
//!   a non-zero child brick) are `active`; distribution runs over the active list, the transfer and the
//!   rounding over the `ring` list (active nodes and their 26 neighbours: no other node can hold a
//!   non-zero value). Both lists are GPU-built and dispatched indirectly; [`Octree::stats`] counts them.
//! - Overflow of the u32 range (splat sums, transfer sums, distribution shares) sets an error bit and
//!   saturates, never wraps; a node pool too small sets another. The host turns them into errors.
//! - **Static and dynamic parts (the paper's time stamps, 4.2.2):** the structure depends on the
//!   fragments' points alone, so the static part of a scene is subdivided once: [`StaticStructure`]
//!   records which nodes its fragments subdivide (their keys, per level) and which points it covers.
//!   A frame's build then replays those subdivisions (`flag_static`: one thread per recorded node)
//!   and runs `flag_parents` only for fragments at points the static part does not cover (a dynamic
//!   instance's voxels, photons landing on it); the values are splatted and filtered from every
//!   fragment as always. The paper keeps the static nodes in place and appends the dynamic ones at the
//!   end of the pools, cleared each frame; this builder's pools stay level-contiguous (its work lists
//!   and dispatch arguments rely on it), so each frame lays the tiles out again, but the static
//!   part's subdivision is not recomputed from its fragments. The same octree as a build from all
//!   fragments (`build_replayed`).

/// A missing pointer (no child tile, no neighbour, no parent).
pub const NONE: u32 = u32::MAX;
/// Deepest level supported: 512^3 leaves (the key packs 9 bits per coordinate).
pub const MAX_DEPTH: u32 = 9;
/// Values per lattice point.
pub const CHANNELS: usize = 4;
/// Voxels per brick.
pub const BRICK_VOXELS: usize = 27;
/// u32 words per brick.
pub const BRICK_WORDS: usize = BRICK_VOXELS * CHANNELS;

/// Brick voxel `v` (`voxel_index`) of node `n` as floats: its four fixed-point channels times
/// `inv_scale` (the readers' `brick_voxel`: one conversion and one product per channel).
pub fn brick_value(bricks: &[u32], n: u32, v: usize, inv_scale: f32) -> glam::Vec4 {
    let b = n as usize * BRICK_WORDS + v * CHANNELS;
    glam::Vec4::new(
        bricks[b] as f32,
        bricks[b + 1] as f32,
        bricks[b + 2] as f32,
        bricks[b + 3] as f32,
    ) * inv_scale
}
/// Threads per workgroup of every entry point.
pub const WORKGROUP: u32 = 64;

/// `flags` bits, per node.
pub const FLAG_SUBDIVIDE: u32 = 1;
pub const FLAG_ACTIVE: u32 = 2;
pub const FLAG_RING: u32 = 4;

/// `status[0]` error bits.
pub const ERR_POOL: u32 = 1;
pub const ERR_OVERFLOW: u32 = 2;
pub const ERR_OUTSIDE: u32 = 4;

/// `status` words: error bits, the tile counter (tiles the structure asked for, also past the pool),
/// and the two list counters of the level being filtered.
pub const STATUS_ERRORS: usize = 0;
pub const STATUS_TILES: usize = 1;
pub const STATUS_ACTIVE: usize = 2;
pub const STATUS_RING: usize = 3;
pub const STATUS_WORDS: usize = 4;

/// Indirect-dispatch slots (3 u32 each) in `args`: one per level (its nodes), then the ring list, then
/// the four distribution classes.
pub const SLOT_RING: usize = (MAX_DEPTH + 1) as usize;
pub const SLOT_CLASS: usize = SLOT_RING + 1;
pub const ARGS_SLOTS: usize = SLOT_CLASS + 4;

/// Distribution classes: voxels per node and child points read per voxel.
pub const CLASS_VOXELS: [u32; 4] = [1, 6, 12, 8];
pub const CLASS_READS: [u32; 4] = [27, 18, 12, 8];

/// One octree node. Nodes live in tiles of eight siblings (`tile * 8 + child_index`, child index
/// `x + 2y + 4z`); tile 0 holds the root alone. The brick of node `n` is `bricks[n * BRICK_WORDS ..]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Node {
    /// [`key`] of (level, x, y, z); NONE for an unused slot.
    pub key: u32,
    pub parent: u32,
    /// First node of the child tile, as a tile index; NONE when not subdivided.
    pub child: u32,
    /// Face neighbours at the same level: -x, +x, -y, +y, -z, +z.
    pub neighbours: [u32; 6],
}

impl Node {
    pub const UNUSED: Node = Node {
        key: NONE,
        parent: NONE,
        child: NONE,
        neighbours: [NONE; 6],
    };
}

/// A voxel fragment: a point of the leaf vertex lattice (`0..=2 * 2^depth` per axis) and its values.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Fragment {
    pub pos: [u32; 3],
    pub _pad: u32,
    pub value: [u32; 4],
}

impl Fragment {
    /// The structure fragment of voxel `m` (Morton index) of the grid: its point, value 0 (a zero
    /// value splats nothing: the structure is the points').
    pub fn point(m: u32) -> Self {
        Self {
            pos: crate::morton::decode(m),
            _pad: 0,
            value: [0; 4],
        }
    }
}

/// The octree's depth over a grid of `side` voxels a side (a power of two): 2^(depth + 1) = side.
pub fn depth_for(side: u32) -> u32 {
    side.trailing_zeros().saturating_sub(1)
}

/// The kernel's uniform block (`struct OctreeParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct OctreeParams {
    pub depth: u32,
    pub level: u32,
    pub fragments: u32,
    pub capacity_tiles: u32,
    /// Transfer axis (0..3) or distribution class (0..4).
    pub variant: u32,
    /// `max_compute_workgroups_per_dimension`, for the dispatch arguments the GPU writes.
    pub max_groups: u32,
    pub _pad: [u32; 2],
}

/// Node key: level in bits 27..31, x, y, z in 9 bits each.
pub fn key(level: u32, c: [u32; 3]) -> u32 {
    (level << 27) | (c[0] << 18) | (c[1] << 9) | c[2]
}

pub fn unkey(k: u32) -> (u32, [u32; 3]) {
    (k >> 27, [(k >> 18) & 511, (k >> 9) & 511, k & 511])
}

/// The leaf (cell) of a lattice point: `min(p / 2, 2^depth - 1)` per axis; the point is one of its
/// brick's voxels, `p - 2 * leaf`.
pub fn leaf_of(p: [u32; 3], depth: u32) -> [u32; 3] {
    let last = (1u32 << depth) - 1;
    p.map(|x| (x / 2).min(last))
}

/// The points of level `level`'s vertex lattice (inclusive bounds per axis) that a fragment at leaf
/// lattice point `p` can make non-zero: `p` itself at the leaves, then per level up every point within
/// one fine step of the level below's points (the filter's support): at most two per axis.
pub fn support_box(p: [u32; 3], depth: u32, level: u32) -> ([u32; 3], [u32; 3]) {
    let mut lo = p;
    let mut hi = p;
    for _ in level..depth {
        lo = lo.map(|x| x / 2);
        hi = hi.map(|x| x.div_ceil(2));
    }
    (lo, hi)
}

/// The level-`level - 1` nodes a fragment flags for subdivision when level `level` is built (inclusive
/// bounds per axis): every node whose closed box holds a point of the fragment's level-`level` support.
/// Its children then hold every copy of those points, and every parent that shares such a point has
/// children to take its share from (at most 2 per axis: 8 flags per fragment and level).
pub fn flag_box(p: [u32; 3], depth: u32, level: u32) -> ([u32; 3], [u32; 3]) {
    let (slo, shi) = support_box(p, depth, level);
    let last = (1i64 << (level - 1)) - 1;
    // Parent c's closed box spans points 4c..=4c + 4 of level `level`'s lattice.
    let lo = slo.map(|q| ((q as i64 - 4 + 3).div_euclid(4)).clamp(0, last) as u32);
    let hi = shi.map(|q| (q as i64 / 4).clamp(0, last) as u32);
    (lo, hi)
}

/// The node at (level, c) in `nodes`, descending from the root along child pointers (the kernels'
/// `find` in kernels/common/svo_node.wgsl); NONE where a tile is missing.
pub fn find(nodes: &[Node], level: u32, c: [u32; 3]) -> u32 {
    let mut n = 0u32;
    for k in 1..=level {
        let t = nodes[n as usize].child;
        if t == NONE {
            return NONE;
        }
        let s = level - k;
        n = t * 8 + ((c[0] >> s) & 1) + 2 * ((c[1] >> s) & 1) + 4 * ((c[2] >> s) & 1);
    }
    n
}

/// Weight of child lattice point `q` (0..=4 per axis within a parent node at `parent`, level `level`)
/// towards parent brick voxel `v` (0..=2 per axis): per axis 1 at distance one, 2 at distance zero
/// unless the point lies on a face the node shares with another node of its level (then 1: the other
/// node counts the other half), 0 further away. The product over axes is in units of 1/64.
pub fn share_weight(q: [u32; 3], v: [u32; 3], parent: [u32; 3], level: u32) -> u32 {
    let last = (1u32 << level) - 1;
    let mut w = 1;
    for a in 0..3 {
        let d = q[a] as i32 - 2 * v[a] as i32;
        w *= match d {
            0 => {
                let shared = (q[a] == 0 && parent[a] > 0) || (q[a] == 4 && parent[a] < last);
                if shared {
                    1
                } else {
                    2
                }
            }
            -1 | 1 => 1,
            _ => 0,
        };
    }
    w
}

/// The voxels of distribution class `class` (centre, faces, edges, corners): those with that many
/// coordinates on the brick's boundary, in index order.
pub fn class_voxels(class: u32) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    for k in 0..3u32 {
        for j in 0..3u32 {
            for i in 0..3u32 {
                let boundary = [i, j, k].iter().filter(|&&c| c != 1).count() as u32;
                if boundary == class {
                    out.push([i, j, k]);
                }
            }
        }
    }
    out
}

pub fn voxel_index(v: [u32; 3]) -> usize {
    (v[0] + 3 * v[1] + 9 * v[2]) as usize
}

/// Everything the kernel writes: the pools, the per-level tile ranges, status and per-level counts.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Octree {
    pub depth: u32,
    pub capacity_tiles: u32,
    pub nodes: Vec<Node>,
    /// `BRICK_WORDS` per node: voxel `i + 3j + 9k`, channel `c` at `voxel * 4 + c`.
    pub bricks: Vec<u32>,
    pub flags: Vec<u32>,
    /// `levels[l]..levels[l + 1]`: the tiles of level `l`.
    pub levels: Vec<u32>,
    pub status: Vec<u32>,
    /// Per level: active nodes (received values) and ring nodes (active and their neighbours).
    pub stats: Vec<u32>,
}

/// Words of `levels` and `stats`.
pub const LEVELS_WORDS: usize = (MAX_DEPTH + 2) as usize;
pub const STATS_WORDS: usize = 2 * (MAX_DEPTH + 1) as usize;

impl Octree {
    /// The empty pools the kernel starts from: the root in tile 0, nothing else.
    pub fn empty(depth: u32, capacity_tiles: u32) -> Octree {
        let n = capacity_tiles as usize * 8;
        let mut nodes = vec![Node::UNUSED; n];
        nodes[0] = Node {
            key: key(0, [0; 3]),
            ..Node::UNUSED
        };
        let mut levels = vec![0u32; LEVELS_WORDS];
        levels[1] = 1;
        Octree {
            depth,
            capacity_tiles,
            nodes,
            bricks: vec![0; n * BRICK_WORDS],
            flags: vec![0; n],
            levels,
            status: vec![0, 1, 0, 0],
            stats: vec![0; STATS_WORDS],
        }
    }

    /// Node indices of level `l`.
    pub fn level_nodes(&self, l: u32) -> std::ops::Range<u32> {
        self.levels[l as usize] * 8..self.levels[l as usize + 1] * 8
    }

    /// The node at (level, c), found by descending from the root along child pointers.
    pub fn find(&self, level: u32, c: [u32; 3]) -> u32 {
        find(&self.nodes, level, c)
    }

    fn brick(&self, n: u32, v: usize, ch: usize) -> u32 {
        self.bricks[n as usize * BRICK_WORDS + v * CHANNELS + ch]
    }

    fn set_brick(&mut self, n: u32, v: usize, ch: usize, x: u32) {
        self.bricks[n as usize * BRICK_WORDS + v * CHANNELS + ch] = x;
    }

    fn error(&mut self, bit: u32) {
        self.status[STATUS_ERRORS] |= bit;
    }

    /// `x + y`, saturating with the overflow bit set.
    fn add(&mut self, x: u32, y: u32) -> u32 {
        x.checked_add(y).unwrap_or_else(|| {
            self.error(ERR_OVERFLOW);
            u32::MAX
        })
    }

    fn brick_nonzero(&self, n: u32) -> bool {
        let b = n as usize * BRICK_WORDS;
        self.bricks[b..b + BRICK_WORDS].iter().any(|&x| x != 0)
    }

    /// Entry `flag_parents` (level `l >= 1`): every fragment flags its [`flag_box`] (8 threads each).
    pub fn flag_parents(&mut self, fragments: &[Fragment], l: u32) {
        let side = 2 * (1u32 << self.depth);
        for f in fragments {
            if f.pos.iter().any(|&x| x > side) {
                self.error(ERR_OUTSIDE);
                continue;
            }
            let (lo, hi) = flag_box(f.pos, self.depth, l);
            for o in 0..8u32 {
                let c = [lo[0] + (o & 1), lo[1] + ((o >> 1) & 1), lo[2] + (o >> 2)];
                if (0..3).any(|a| c[a] > hi[a]) {
                    continue;
                }
                let p = self.find(l - 1, c);
                if p != NONE {
                    self.flags[p as usize] |= FLAG_SUBDIVIDE;
                }
            }
        }
    }

    /// Entry `flag_static` (level `l >= 1`): every node of level `l - 1` whose key the static part
    /// recorded is flagged for subdivision (one thread per key: found by descent).
    pub fn flag_static(&mut self, statics: &StaticStructure, l: u32) {
        for &k in statics.keys(l - 1) {
            let (_, c) = unkey(k);
            let n = self.find(l - 1, c);
            if n != NONE {
                self.flags[n as usize] |= FLAG_SUBDIVIDE;
            }
        }
    }

    /// Entry `allocate` (level `l`): each flagged node of level `l - 1` takes a tile from the counter.
    /// The GPU's order is free; the mirror's is node order.
    pub fn allocate(&mut self, l: u32) {
        for n in self.level_nodes(l - 1) {
            if self.flags[n as usize] & FLAG_SUBDIVIDE == 0 {
                continue;
            }
            let t = self.status[STATUS_TILES];
            self.status[STATUS_TILES] += 1;
            if t < self.capacity_tiles {
                self.nodes[n as usize].child = t;
            } else {
                self.error(ERR_POOL);
            }
        }
    }

    /// Entry `finish_level` (level `l`): the end of level `l`'s tiles.
    pub fn finish_level(&mut self, l: u32) {
        self.levels[l as usize + 1] = self.status[STATUS_TILES].min(self.capacity_tiles);
    }

    /// Entry `init_nodes` (level `l`): key, parent and face neighbours of every new node.
    pub fn init_nodes(&mut self, l: u32) {
        // Parents of level l's tiles: the level l - 1 nodes that point at them.
        let mut parent_of_tile = std::collections::HashMap::new();
        for p in self.level_nodes(l - 1) {
            let t = self.nodes[p as usize].child;
            if t != NONE {
                parent_of_tile.insert(t, p);
            }
        }
        let last = (1u32 << l) - 1;
        for n in self.level_nodes(l) {
            let p = parent_of_tile[&(n / 8)];
            let (_, pc) = unkey(self.nodes[p as usize].key);
            let ci = n % 8;
            let c = [
                2 * pc[0] + (ci & 1),
                2 * pc[1] + ((ci >> 1) & 1),
                2 * pc[2] + (ci >> 2),
            ];
            let mut neighbours = [NONE; 6];
            for a in 0..3 {
                if c[a] > 0 {
                    let mut m = c;
                    m[a] -= 1;
                    neighbours[2 * a] = self.find(l, m);
                }
                if c[a] < last {
                    let mut m = c;
                    m[a] += 1;
                    neighbours[2 * a + 1] = self.find(l, m);
                }
            }
            self.nodes[n as usize] = Node {
                key: key(l, c),
                parent: p,
                child: NONE,
                neighbours,
            };
        }
    }

    /// Entry `splat`: each fragment with a non-zero value adds it (atomically) into its leaf's brick and
    /// marks the leaf active.
    pub fn splat(&mut self, fragments: &[Fragment]) {
        let side = 2 * (1u32 << self.depth);
        for f in fragments {
            if f.pos.iter().any(|&x| x > side) || f.value == [0; 4] {
                continue;
            }
            let leaf = leaf_of(f.pos, self.depth);
            let n = self.find(self.depth, leaf);
            if n == NONE {
                continue; // the pool overflowed: already an error
            }
            let v = voxel_index([0, 1, 2].map(|a| f.pos[a] - 2 * leaf[a]));
            for ch in 0..CHANNELS {
                let s = self.add(self.brick(n, v, ch), f.value[ch]);
                self.set_brick(n, v, ch, s);
            }
            self.flags[n as usize] |= FLAG_ACTIVE;
        }
    }

    /// The node one step along `axis` (`dir` -1, 0, +1) from `n`; NONE past the structure.
    fn step(&self, n: u32, axis: usize, dir: i32) -> u32 {
        match (n, dir) {
            (NONE, _) => NONE,
            (_, 0) => n,
            (_, -1) => self.nodes[n as usize].neighbours[2 * axis],
            _ => self.nodes[n as usize].neighbours[2 * axis + 1],
        }
    }

    /// Entries `begin_level`, `mark_ring`, `compact` and `list_args` (level `l`): the active list and the
    /// ring list (active nodes and their 26 neighbours, reached x, then y, then z through face pointers).
    /// Returns (active, ring) in the GPU's list order up to permutation (the mirror's is node order).
    pub fn lists(&mut self, l: u32) -> (Vec<u32>, Vec<u32>) {
        for n in self.level_nodes(l) {
            if self.flags[n as usize] & FLAG_ACTIVE == 0 {
                continue;
            }
            for dx in -1..=1 {
                let a = self.step(n, 0, dx);
                for dy in -1..=1 {
                    let b = self.step(a, 1, dy);
                    for dz in -1..=1 {
                        let c = self.step(b, 2, dz);
                        if c != NONE {
                            self.flags[c as usize] |= FLAG_RING;
                        }
                    }
                }
            }
        }
        let mut active = Vec::new();
        let mut ring = Vec::new();
        for n in self.level_nodes(l) {
            if self.flags[n as usize] & FLAG_ACTIVE != 0 {
                active.push(n);
            }
            if self.flags[n as usize] & FLAG_RING != 0 {
                ring.push(n);
            }
        }
        self.status[STATUS_ACTIVE] = active.len() as u32;
        self.status[STATUS_RING] = ring.len() as u32;
        self.stats[2 * l as usize] = active.len() as u32;
        self.stats[2 * l as usize + 1] = ring.len() as u32;
        (active, ring)
    }

    /// Entry `transfer_add` (axis): each ring node adds its +axis face into its +axis neighbour's -axis
    /// face (Fig. 9 left, step 1). Each face has one writer: no atomics.
    pub fn transfer_add(&mut self, ring: &[u32], axis: usize) {
        for &n in ring {
            let r = self.nodes[n as usize].neighbours[2 * axis + 1];
            if r == NONE {
                continue;
            }
            for (from, to) in face_pairs(axis) {
                for ch in 0..CHANNELS {
                    let s = self.add(self.brick(r, to, ch), self.brick(n, from, ch));
                    self.set_brick(r, to, ch, s);
                }
            }
        }
    }

    /// Entry `transfer_copy` (axis): each ring node copies its +axis neighbour's -axis face (now the sum)
    /// back into its +axis face (Fig. 9 left, step 2).
    pub fn transfer_copy(&mut self, ring: &[u32], axis: usize) {
        for &n in ring {
            let r = self.nodes[n as usize].neighbours[2 * axis + 1];
            if r == NONE {
                continue;
            }
            for (to, from) in face_pairs(axis) {
                for ch in 0..CHANNELS {
                    let x = self.brick(r, from, ch);
                    self.set_brick(n, to, ch, x);
                }
            }
        }
    }

    /// Entry `distribute` (class): each active node of level `l` computes its share of its class's brick
    /// voxels from its children's bricks (weights [`share_weight`], units of 1/64, not yet divided).
    pub fn distribute(&mut self, active: &[u32], l: u32, class: u32) {
        let voxels = class_voxels(class);
        for &n in active {
            let t = self.nodes[n as usize].child;
            let (_, pc) = unkey(self.nodes[n as usize].key);
            for &v in &voxels {
                for ch in 0..CHANNELS {
                    let mut s = 0u32;
                    for q in child_points(v) {
                        let w = share_weight(q, v, pc, l);
                        let c = q.map(|x| (x / 2).min(1));
                        let child = t * 8 + c[0] + 2 * c[1] + 4 * c[2];
                        let local = [0, 1, 2].map(|a| q[a] - 2 * c[a]);
                        let x = self.brick(child, voxel_index(local), ch);
                        let prod = x.checked_mul(w).unwrap_or_else(|| {
                            self.error(ERR_OVERFLOW);
                            u32::MAX
                        });
                        s = self.add(s, prod);
                    }
                    self.set_brick(n, voxel_index(v), ch, s);
                }
            }
        }
    }

    /// Entry `round_level`: the one rounding of a level, after its transfer: `(S + 32) >> 6`.
    pub fn round_level(&mut self, ring: &[u32]) {
        for &n in ring {
            for w in 0..BRICK_WORDS {
                let i = n as usize * BRICK_WORDS + w;
                let s = self.bricks[i];
                self.bricks[i] = self.add(s, 32) >> 6;
            }
        }
    }

    /// Entry `mark_parents`: the parent of every ring node with a non-zero brick becomes active.
    pub fn mark_parents(&mut self, ring: &[u32]) {
        for &n in ring {
            if self.brick_nonzero(n) {
                let p = self.nodes[n as usize].parent;
                self.flags[p as usize] |= FLAG_ACTIVE;
            }
        }
    }

    /// Structure only: the entries of the build, level by level.
    pub fn build_structure(&mut self, fragments: &[Fragment]) {
        for l in 1..=self.depth {
            self.flag_parents(fragments, l);
            self.allocate(l);
            self.finish_level(l);
            self.init_nodes(l);
        }
    }

    /// Structure with the static part replayed: per level `flag_static`, then `flag_parents` for the
    /// fragments at points the static part does not cover, then as [`Self::build_structure`].
    pub fn build_structure_replayed(&mut self, statics: &StaticStructure, fragments: &[Fragment]) {
        let flagging = statics.flagging(fragments);
        for l in 1..=self.depth {
            self.flag_static(statics, l);
            self.flag_parents(&flagging, l);
            self.allocate(l);
            self.finish_level(l);
            self.init_nodes(l);
        }
    }

    /// Values: splat, then per level from the leaves up: lists, (distribution,) transfer, (rounding,)
    /// mark the parents.
    pub fn filter(&mut self, fragments: &[Fragment]) {
        self.splat(fragments);
        for l in (0..=self.depth).rev() {
            let (active, ring) = self.lists(l);
            if l < self.depth {
                for class in 0..4 {
                    self.distribute(&active, l, class);
                }
            }
            for axis in 0..3 {
                self.transfer_add(&ring, axis);
                self.transfer_copy(&ring, axis);
            }
            if l < self.depth {
                self.round_level(&ring);
            }
            if l > 0 {
                self.mark_parents(&ring);
            }
        }
    }
}

/// The whole kernel: build the structure from `fragments`, splat their values and filter all levels.
pub fn build(depth: u32, capacity_tiles: u32, fragments: &[Fragment]) -> Octree {
    let mut o = Octree::empty(depth, capacity_tiles);
    o.build_structure(fragments);
    o.filter(fragments);
    o
}

/// (voxel on the +axis face, voxel on the -axis face) pairs that coincide across a face, the other two
/// coordinates in index order.
pub fn face_pairs(axis: usize) -> Vec<(usize, usize)> {
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut out = Vec::with_capacity(9);
    for v in 0..3u32 {
        for u in 0..3u32 {
            let mut c = [0u32; 3];
            c[a.min(b)] = u;
            c[a.max(b)] = v;
            let mut hi = c;
            hi[axis] = 2;
            out.push((voxel_index(hi), voxel_index(c)));
        }
    }
    out
}

/// The child lattice points (0..=4 per axis) within one step of parent voxel `v`.
pub fn child_points(v: [u32; 3]) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    for dz in -1i32..=1 {
        for dy in -1i32..=1 {
            for dx in -1i32..=1 {
                let q = [
                    2 * v[0] as i32 + dx,
                    2 * v[1] as i32 + dy,
                    2 * v[2] as i32 + dz,
                ];
                if q.iter().all(|&x| (0..=4).contains(&x)) {
                    out.push(q.map(|x| x as u32));
                }
            }
        }
    }
    out
}

/// Nodes with pointers replaced by the keys of the nodes they point to (a child tile by its first
/// node's key), sorted by key; unused slots (key NONE) last. Two pools that differ only in allocation
/// order give the same canonical form. Returns the sorted records and the permutation (old indices).
pub fn canonical_nodes(nodes: &[Node]) -> (Vec<Node>, Vec<usize>) {
    let key_of = |i: u32| {
        if i == NONE || (i as usize) >= nodes.len() {
            NONE
        } else {
            nodes[i as usize].key
        }
    };
    let mut order: Vec<usize> = (0..nodes.len()).collect();
    order.sort_by_key(|&i| (nodes[i].key, i));
    let out = order
        .iter()
        .map(|&i| {
            let n = nodes[i];
            Node {
                key: n.key,
                parent: key_of(n.parent),
                child: if n.child == NONE {
                    NONE
                } else {
                    key_of(n.child.saturating_mul(8))
                },
                neighbours: n.neighbours.map(key_of),
            }
        })
        .collect();
    (out, order)
}

/// Bricks in the canonical node order of [`canonical_nodes`].
pub fn canonical_bricks(nodes: &[Node], bricks: &[u32]) -> Vec<u32> {
    let (_, order) = canonical_nodes(nodes);
    let mut out = Vec::with_capacity(bricks.len());
    for i in order {
        let b = i * BRICK_WORDS;
        if b + BRICK_WORDS <= bricks.len() {
            out.extend_from_slice(&bricks[b..b + BRICK_WORDS]);
        }
    }
    out
}

/// The invariant of the transfer: every voxel two face neighbours share holds the same values in both
/// bricks (edge and corner copies follow, since their nodes are linked face by face).
pub fn shared_voxels_consistent(o: &Octree) -> Result<(), String> {
    for (n, node) in o.nodes.iter().enumerate() {
        if node.key == NONE {
            continue;
        }
        for axis in 0..3 {
            let r = node.neighbours[2 * axis + 1];
            if r == NONE {
                continue;
            }
            for (hi, lo) in face_pairs(axis) {
                for ch in 0..CHANNELS {
                    let a = o.brick(n as u32, hi, ch);
                    let b = o.brick(r, lo, ch);
                    if a != b {
                        let (l, c) = unkey(node.key);
                        return Err(format!(
                            "level {l} node {c:?} and its +{} neighbour disagree at voxel {hi}/{lo} channel {ch}: {a} vs {b}",
                            ["x", "y", "z"][axis]
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

/// Dense reference: level `l`'s vertex lattice (`2 * 2^l + 1` per axis, x fastest), four channels per
/// point. The leaves hold the sum of the splats at each point; each coarser level the [1 2 1]^3 / 64
/// filter of the level below around each point (zero outside the volume), rounded `(S + 32) >> 6`.
/// `None` on u32 overflow. `out[l]` for l in 0..=depth.
pub fn dense_reference(depth: u32, fragments: &[Fragment]) -> Option<Vec<Vec<[u32; 4]>>> {
    let side = |l: u32| 2 * (1usize << l) + 1;
    let mut levels = vec![Vec::new(); depth as usize + 1];
    let s = side(depth);
    let mut leaf = vec![[0u32; 4]; s * s * s];
    for f in fragments {
        let i = f.pos[0] as usize + s * (f.pos[1] as usize + s * f.pos[2] as usize);
        for (a, v) in leaf[i].iter_mut().zip(f.value) {
            *a = a.checked_add(v)?;
        }
    }
    levels[depth as usize] = leaf;
    for l in (0..depth).rev() {
        let fine = &levels[l as usize + 1];
        let sf = side(l + 1) as i64;
        let sc = side(l);
        let mut coarse = vec![[0u32; 4]; sc * sc * sc];
        for z in 0..sc {
            for y in 0..sc {
                for x in 0..sc {
                    let mut acc = [0u32; 4];
                    for dz in -1i64..=1 {
                        for dy in -1i64..=1 {
                            for dx in -1i64..=1 {
                                let q = [2 * x as i64 + dx, 2 * y as i64 + dy, 2 * z as i64 + dz];
                                if q.iter().any(|&c| c < 0 || c >= sf) {
                                    continue;
                                }
                                let w = [dx, dy, dz]
                                    .iter()
                                    .map(|&d| if d == 0 { 2u32 } else { 1 })
                                    .product::<u32>();
                                let v = fine[(q[0] + sf * (q[1] + sf * q[2])) as usize];
                                for ch in 0..4 {
                                    acc[ch] = acc[ch].checked_add(v[ch].checked_mul(w)?)?;
                                }
                            }
                        }
                    }
                    for a in acc.iter_mut() {
                        *a = a.checked_add(32)? >> 6;
                    }
                    coarse[x + sc * (y + sc * z)] = acc;
                }
            }
        }
        levels[l as usize] = coarse;
    }
    Some(levels)
}

/// [`build`] with a node pool of [`capacity_bound`] tiles: one that always fits `fragments`.
pub fn build_fitted(depth: u32, fragments: &[Fragment]) -> Octree {
    build(
        depth,
        capacity_bound(depth, fragments.len()) as u32,
        fragments,
    )
}

/// What a scene's static part subdivides, recorded once (VCT 4.2.2's static/dynamic split; see the
/// module doc): per level `k < depth` the keys of the level-`k` nodes with children (sorted), and the
/// leaf lattice points the static fragments stand on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StaticStructure {
    pub depth: u32,
    /// Keys of `keys[offsets[k]..offsets[k + 1]]`: level `k`'s subdivided nodes.
    pub keys: Vec<u32>,
    pub offsets: Vec<u32>,
    /// The static fragments' points.
    pub points: std::collections::HashSet<[u32; 3]>,
}

impl StaticStructure {
    /// Record the structure `fragments` (the static part) build at `depth` (the mirror's structure
    /// pass: integer, the GPU's up to allocation order, which the keys do not see).
    pub fn record(depth: u32, fragments: &[Fragment]) -> StaticStructure {
        let mut o = Octree::empty(depth, capacity_bound(depth, fragments.len()) as u32);
        o.build_structure(fragments);
        let mut keys = Vec::new();
        let mut offsets = vec![0u32];
        for k in 0..depth {
            let mut level: Vec<u32> = o
                .level_nodes(k)
                .filter(|&n| o.nodes[n as usize].child != NONE)
                .map(|n| o.nodes[n as usize].key)
                .collect();
            level.sort_unstable();
            keys.extend(level);
            offsets.push(keys.len() as u32);
        }
        StaticStructure {
            depth,
            keys,
            offsets,
            points: fragments.iter().map(|f| f.pos).collect(),
        }
    }

    /// The recorded keys of level `k`'s subdivided nodes.
    pub fn keys(&self, k: u32) -> &[u32] {
        &self.keys[self.offsets[k as usize] as usize..self.offsets[k as usize + 1] as usize]
    }

    /// Whether a static fragment stands on point `p` (then a fragment there flags nothing new).
    pub fn covers(&self, p: [u32; 3]) -> bool {
        self.points.contains(&p)
    }

    /// The fragments whose points the static part does not cover: the ones that still flag.
    pub fn flagging(&self, fragments: &[Fragment]) -> Vec<Fragment> {
        fragments
            .iter()
            .filter(|f| !self.covers(f.pos))
            .copied()
            .collect()
    }
}

/// [`build`] with the static part's structure replayed ([`Octree::build_structure_replayed`]):
/// `fragments` are all of the frame's (static ones included: they carry values).
pub fn build_replayed(
    capacity_tiles: u32,
    statics: &StaticStructure,
    fragments: &[Fragment],
) -> Octree {
    let mut o = Octree::empty(statics.depth, capacity_tiles);
    o.build_structure_replayed(statics, fragments);
    o.filter(fragments);
    o
}

/// `source`'s bricks in the node layout `target` (a brick per node of `target` up to its last used
/// one, zero where `source` has no node with its key). The structure depends on the fragments' points alone (`flag_parents`
/// reads no values), so two builds from fragments at the same points have the same nodes, in the
/// order their tile counters handed them out: this carries a second brick pool (other values at the
/// same points, e.g. svo_cone_trace's normals) into the first build's layout, so one node lookup
/// serves both.
pub fn bricks_in_layout(target: &[Node], source: &Octree) -> Vec<u32> {
    let at: std::collections::HashMap<u32, usize> = source
        .nodes
        .iter()
        .enumerate()
        .filter(|(_, n)| n.key != NONE)
        .map(|(i, n)| (n.key, i))
        .collect();
    let used = target
        .iter()
        .rposition(|n| n.key != NONE)
        .map_or(0, |i| i + 1);
    let mut out = vec![0u32; used * BRICK_WORDS];
    for (i, n) in target[..used].iter().enumerate() {
        if let Some(&j) = at.get(&n.key) {
            let b = j * BRICK_WORDS;
            if b + BRICK_WORDS <= source.bricks.len() {
                out[i * BRICK_WORDS..(i + 1) * BRICK_WORDS]
                    .copy_from_slice(&source.bricks[b..b + BRICK_WORDS]);
            }
        }
    }
    out
}

/// Tiles a build needs at most: per level, every fragment flags at most 8 parents (and there are at
/// most `8^(l-1)` parents), one tile each; plus the root's tile.
pub fn capacity_bound(depth: u32, fragments: usize) -> u64 {
    1 + (1..=depth)
        .map(|l| (8 * fragments as u64).min(1u64 << (3 * (l - 1))))
        .sum::<u64>()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frag(p: [u32; 3], v: u32) -> Fragment {
        Fragment {
            pos: p,
            _pad: 0,
            value: [v, 2 * v, 0, v + 1],
        }
    }

    /// Every brick voxel of every node equals the dense reference at its lattice point, and every
    /// non-zero dense point lies in some node.
    fn check_dense(depth: u32, frags: &[Fragment]) {
        let cap = capacity_bound(depth, frags.len()) as u32;
        let o = build(depth, cap, frags);
        assert_eq!(o.status[STATUS_ERRORS], 0);
        let dense = dense_reference(depth, frags).unwrap();
        let mut covered: Vec<Vec<bool>> = dense.iter().map(|d| vec![false; d.len()]).collect();
        // Deepest level first: the first mismatch reported is where the levels diverge.
        let mut order: Vec<usize> = (0..o.nodes.len())
            .filter(|&n| o.nodes[n].key != NONE)
            .collect();
        order.sort_by_key(|&n| std::cmp::Reverse(o.nodes[n].key >> 27));
        for n in order {
            let (l, c) = unkey(o.nodes[n].key);
            let s = 2 * (1usize << l) + 1;
            for k in 0..3u32 {
                for j in 0..3u32 {
                    for i in 0..3u32 {
                        let p = [2 * c[0] + i, 2 * c[1] + j, 2 * c[2] + k].map(|x| x as usize);
                        let di = p[0] + s * (p[1] + s * p[2]);
                        let v = voxel_index([i, j, k]);
                        let got: Vec<u32> = (0..4)
                            .map(|ch| o.bricks[n * BRICK_WORDS + v * 4 + ch])
                            .collect();
                        assert_eq!(
                            got,
                            dense[l as usize][di].to_vec(),
                            "depth {depth} level {l} node {c:?} voxel {:?}",
                            [i, j, k]
                        );
                        covered[l as usize][di] = true;
                    }
                }
            }
        }
        for l in 0..=depth as usize {
            for (i, v) in dense[l].iter().enumerate() {
                assert!(covered[l][i] || *v == [0; 4], "level {l} point {i} lost");
            }
        }
    }

    #[test]
    fn single_points_match_dense() {
        for depth in 1..=4u32 {
            let side = 2 << depth;
            for p in [
                [0, 0, 0],
                [side, side, side],
                [1, 2, 3],
                [side / 2, side / 2, side / 2],
                [2, side - 1, 4],
            ] {
                check_dense(depth, &[frag(p, 1000)]);
            }
        }
    }

    #[test]
    fn scattered_points_match_dense() {
        let mut x = 12345u64;
        let mut next = |m: u32| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((x >> 33) % m as u64) as u32
        };
        for depth in [2u32, 3, 5] {
            let side = 2 << depth;
            let frags: Vec<_> = (0..20)
                .map(|_| frag([next(side + 1), next(side + 1), next(side + 1)], next(5000)))
                .collect();
            check_dense(depth, &frags);
        }
    }

    #[test]
    fn canonical_form_ignores_allocation_order() {
        let frags = [frag([3, 5, 7], 10), frag([9, 1, 2], 20)];
        let o = build(3, 200, &frags);
        // Swap two level-3 tiles by hand: pointers follow, the canonical form must not change.
        let (a, b) = (o.levels[3], o.levels[3] + 1);
        let mut nodes = o.nodes.clone();
        let mut bricks = o.bricks.clone();
        let remap = |t: u32| {
            if t == a {
                b
            } else if t == b {
                a
            } else {
                t
            }
        };
        let remap_node = |n: u32| {
            if n == NONE {
                NONE
            } else {
                remap(n / 8) * 8 + n % 8
            }
        };
        for i in 0..8 {
            nodes.swap((a * 8 + i) as usize, (b * 8 + i) as usize);
            for w in 0..BRICK_WORDS {
                bricks.swap(
                    (a * 8 + i) as usize * BRICK_WORDS + w,
                    (b * 8 + i) as usize * BRICK_WORDS + w,
                );
            }
        }
        for n in nodes.iter_mut() {
            if n.child != NONE {
                n.child = remap(n.child);
            }
            n.neighbours = n.neighbours.map(remap_node);
        }
        assert_eq!(canonical_nodes(&nodes).0, canonical_nodes(&o.nodes).0);
        assert_eq!(
            canonical_bricks(&nodes, &bricks),
            canonical_bricks(&o.nodes, &o.bricks)
        );
    }
}
