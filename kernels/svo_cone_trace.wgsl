// svo_cone_trace — cone_trace's tracer (kernels/common/cone_march.wgsl: AO, diffuse and glossy cones per
// G-buffer pixel, front-to-back, step-corrected alpha) reading the sparse voxel octree instead of the
// dense pyramid: the vct-svo pipeline's cone pass (Crassin et al. 2011, 5-7). Mirror:
// cpu_mirror/src/svo_cone_trace.rs. Node layout and descent: kernels/common/svo_node.wgsl.
//
// Volume: an octree of depth D built from the voxel grid of side 2^(D+1) (cone.side), one fragment per
// voxel at the leaf lattice point of its index, values (L * alpha, alpha) in u32 fixed point (times
// svo.inv_scale). Mip level l (cell s0 * 2^l, as the pyramid's) is octree level D - l, whose lattice
// points sit at origin + s0 / 2 + i s0 2^l (the voxel centres at l = 0); cone.levels = D + 1.
// sample_level: the level's lattice coordinate q = (x - origin) / (s0 2^l) - 1/2^(l+1), the node holding
// the cell floor(q) (clamped into the volume), trilinear over the cell's 8 brick voxels (points outside
// the lattice are empty; a missing node is empty: exact under the octree's halo rule). sample_volume:
// quadrilinear (common/cone_march.wgsl). Anisotropic voxels (svo.anisotropic = 1, VCT 7.1): above the
// leaves each brick voxel is the mix of its three directional values (svo_anisotropic.wgsl) facing the
// cone's direction d, weighted d.x^2, d.y^2, d.z^2 (the leaves are isotropic). Voxel shading with
// Gaussian lobes (svo.lobes = 1, VCT 4.3 and 7): normal_bricks, a second pool in the same node layout,
// holds per voxel ((n + 1) alpha / 2, alpha), n the surface's mean normal; its quadrilinear sample decodes
// to P = N alpha, whose length encodes the normal lobe's variance (1 - |N|) / |N|; the cone's span adds
// tan^2(psi / 2); the sample's colour is scaled by the share of the convolved lobe facing the cone's
// origin, Phi(c / sigma) by the logistic 1 / (1 + exp(-1.702 x)) (lobe_visibility; derivation in the
// mirror's header). Accuracy: the same per-element bound as cone_trace (the mirror's SampleError covers
// the sample point's rounding and the mixing weights'; lobe_visibility's bound the lobe factor's).

struct SvoParams {
    depth: u32,
    inv_scale: f32,
    anisotropic: u32,   // 1: directional values from `aniso` above the leaves
    lobes: u32,         // bit 0: Gaussian lobes from `normal_bricks`; bit 1: glossy voxels from `spec_bricks`
}

@group(0) @binding(8) var<storage, read> nodes: array<Node>;
// bricks and aniso (six directional values per brick voxel of the nodes above the leaves,
// (n * 27 + voxel) * 6 + dir), read through brick_words and aniso_load: common/svo_bricks_one.wgsl
// and common/svo_aniso_pair.wgsl, the bricks in one binding and the values in up to two, or past
// those common/svo_bricks.wgsl and common/svo_aniso_windows.wgsl (declaration
// svo_cone_trace_windowed).
@group(0) @binding(13) var<storage, read> svo: SvoParams;
// Entry voxel_main (declaration svo_bounce): the second bounce's gather from the voxels themselves.
@group(0) @binding(15) var<storage, read> vx_position: array<vec4<f32>>;
@group(0) @binding(16) var<storage, read> vx_normal: array<vec4<f32>>;
@group(0) @binding(17) var<storage, read> vx_albedo: array<vec4<f32>>;
@group(0) @binding(18) var<storage, read_write> vx_indirect: array<vec4<f32>>;
// The lobes' normal pool: bricks in `nodes`' layout, per voxel ((n + 1) alpha / 2, alpha) in fixed point.
@group(0) @binding(19) var<storage, read> normal_bricks: array<u32>;
// The glossy voxels' specular pool: bricks in `nodes`' layout, per voxel the specular photons'
// ((q + w) / 2, w) in fixed point (svo_photons.wgsl).
@group(0) @binding(20) var<storage, read> spec_bricks: array<u32>;

fn brick_voxel(n: u32, v: vec3<u32>) -> vec4<f32> {
    let w = n * BRICK_WORDS + voxel_index(v) * 4u;
    return vec4<f32>(brick_words(w)) * svo.inv_scale;
}

fn normal_voxel(n: u32, v: vec3<u32>) -> vec4<f32> {
    let w = n * BRICK_WORDS + voxel_index(v) * 4u;
    return vec4<f32>(f32(normal_bricks[w]), f32(normal_bricks[w + 1u]), f32(normal_bricks[w + 2u]), f32(normal_bricks[w + 3u])) * svo.inv_scale;
}

fn spec_voxel(n: u32, v: vec3<u32>) -> vec4<f32> {
    let w = n * BRICK_WORDS + voxel_index(v) * 4u;
    return vec4<f32>(f32(spec_bricks[w]), f32(spec_bricks[w + 1u]), f32(spec_bricks[w + 2u]), f32(spec_bricks[w + 3u])) * svo.inv_scale;
}

// The directional value of brick voxel v of node n for a cone along d: +a or -a by d's sign per axis.
fn directional(n: u32, v: vec3<u32>, d: vec3<f32>) -> vec4<f32> {
    let base = (n * 27u + voxel_index(v)) * 6u;
    let w = d * d;
    let ax = aniso_load(base + select(0u, 1u, d.x < 0.0));
    let ay = aniso_load(base + 2u + select(0u, 1u, d.y < 0.0));
    let az = aniso_load(base + 4u + select(0u, 1u, d.z < 0.0));
    return (ax * w.x + ay * w.y) + az * w.z;
}

fn sample_level(x: vec3<f32>, l: u32) -> vec4<f32> {
    return sample_level_dir(x, l, vec3<f32>(0.0), false);
}

// The lattice cell of x at mip level l: the trilinear stencil's lower corner i0, its weights f, and
// the cell c of the node whose brick holds the stencil (clamped into the volume).
struct Cell {
    i0: vec3<i32>,
    f: vec3<f32>,
    c: vec3<i32>,
}

fn cell_of(x: vec3<f32>, l: u32) -> Cell {
    let s = svo.depth - l;
    let inv = cone.inv_s0 * (1.0 / f32(1u << l));
    let q = (x - cone.origin.xyz) * inv - vec3<f32>(0.5 / f32(1u << l));
    let fl = floor(q);
    let i0 = vec3<i32>(fl);
    let c = clamp(i0 >> vec3<u32>(1u), vec3<i32>(0), vec3<i32>((1i << s) - 1i));
    return Cell(i0, q - fl, c);
}

// Trilinear samples of mip level l in node n (found for `cell`; NONE: empty): the radiance (`s`; with
// `dir_in` the directional values along d where the level has them) and, where svo.lobes turns them on,
// the normal pool (`e`) and the specular pool (`g`), with the same corner weights.
struct Samples {
    s: vec4<f32>,
    e: vec4<f32>,
    g: vec4<f32>,
}

fn sample_cell(cell: Cell, l: u32, n: u32, d: vec3<f32>, dir_in: bool) -> Samples {
    var out = Samples(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    if (n == NONE) {
        return out;
    }
    let s = svo.depth - l;
    let points = i32(2u << s);
    let dir = dir_in && s < svo.depth;
    for (var corner = 0u; corner < 8u; corner++) {
        let cc = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
        let w = select(vec3<f32>(1.0) - cell.f, cell.f, cc == vec3<u32>(1u));
        let i = cell.i0 + vec3<i32>(cc);
        let local = i - 2i * cell.c;
        if (any(i < vec3<i32>(0)) || any(i > vec3<i32>(points)) || any(local < vec3<i32>(0)) || any(local > vec3<i32>(2))) {
            continue;
        }
        var value: vec4<f32>;
        if (dir) {
            value = directional(n, vec3<u32>(local), d);
        } else {
            value = brick_voxel(n, vec3<u32>(local));
        }
        let wt = w.x * w.y * w.z;
        out.s += value * wt;
        if ((svo.lobes & 1u) != 0u) {
            out.e += normal_voxel(n, vec3<u32>(local)) * wt;
        }
        if ((svo.lobes & 2u) != 0u) {
            out.g += spec_voxel(n, vec3<u32>(local)) * wt;
        }
    }
    return out;
}

// Trilinear sample of mip level l; `dir_in`: the directional values along d where the level has them.
fn sample_level_dir(x: vec3<f32>, l: u32, d: vec3<f32>, dir_in: bool) -> vec4<f32> {
    let cell = cell_of(x, l);
    return sample_cell(cell, l, find(svo.depth - l, vec3<u32>(cell.c)), d, dir_in).s;
}

// The march's sample: quadrilinear over levels floor(l) and floor(l) + 1 (from the top level up the top
// alone), as common/cone_march.wgsl's sample_volume, with directional values where svo.anisotropic.
// One descent serves both levels: the coarser level's node is the finer one's parent, because its
// lattice coordinate is exactly half the finer one's (scaling by 2 is exact in f32, fused or not), so
// its cell is the finer cell >> 1 (clamping included); where the finer node is missing the coarser is
// looked up. The same values as two descents, so the mirror samples each level on its own.
fn sample_cone(x: vec3<f32>, l: f32, diam: f32, d: vec3<f32>, tan_half: f32) -> vec4<f32> {
    let dir_in = svo.anisotropic != 0u;
    let top = cone.levels - 1u;
    let lf = max(l, 0.0);
    let l0 = floor(lf);
    var s: vec4<f32>;
    var e: vec4<f32>;
    var g: vec4<f32>;
    if (l0 >= f32(top)) {
        let cell = cell_of(x, top);
        let c = sample_cell(cell, top, find(svo.depth - top, vec3<u32>(cell.c)), d, dir_in);
        s = c.s;
        e = c.e;
        g = c.g;
    } else {
        let a = lf - l0;
        let li = u32(l0);
        let fine = cell_of(x, li);
        let coarse = cell_of(x, li + 1u);
        let n = find(svo.depth - li, vec3<u32>(fine.c));
        var np = NONE;
        if (n != NONE) {
            np = nodes[n].parent;
        } else {
            np = find(svo.depth - li - 1u, vec3<u32>(coarse.c));
        }
        let f = sample_cell(fine, li, n, d, dir_in);
        let k = sample_cell(coarse, li + 1u, np, d, dir_in);
        s = f.s * (1.0 - a) + k.s * a;
        e = f.e * (1.0 - a) + k.e * a;
        g = f.g * (1.0 - a) + k.g * a;
    }
    var rgb = s.xyz;
    if ((svo.lobes & 1u) != 0u) {
        rgb = rgb * lobe_visibility(e, d, tan_half);
    }
    if ((svo.lobes & 2u) != 0u) {
        rgb = rgb + vec3<f32>(glossy_voxel(g, d, tan_half));
    }
    return vec4<f32>(rgb, s.w);
}

// The glossy light a specular-pool sample g sends towards the cone's origin: w vMF(-d; q/|q|, kappa),
// kappa the reflected light's concentration rbar / (1 - rbar) convolved with the cone's
// 1 / tan^2(psi/2). Mirror: svo_cone_trace::glossy_voxel (same operation order).
fn glossy_voxel(g: vec4<f32>, d: vec3<f32>, tan_half: f32) -> f32 {
    let w = g.w;
    if (w <= 0.0) {
        return 0.0;
    }
    let q = 2.0 * g.xyz - vec3<f32>(w);
    let ql = length(q);
    let rbar = min(ql / w, 0.999);
    let ks = rbar / (1.0 - rbar);
    let t2 = tan_half * tan_half;
    let r = sqrt(1.0 + t2);
    let s = t2 / ((1.0 + r) * (1.0 + r));
    let kv = 1.0 / max(s, 1e-6);
    let k = ks * kv / (ks + kv);
    var c = 0.0;
    if (ql > 0.0) {
        c = -dot(q, d) / ql;
    }
    var dens = 1.0 / (4.0 * 3.14159265358979);
    if (k > 1e-4) {
        dens = k / (2.0 * 3.14159265358979 * (1.0 - exp(-2.0 * k))) * exp(k * (c - 1.0));
    }
    return w * dens;
}

// The share of a normal-pool sample e's lobe, convolved with the cone's (half-angle tangent tan_half),
// that faces the cone's origin (-d). Mirror: svo_cone_trace::lobe_visibility (same operation order).
fn lobe_visibility(e: vec4<f32>, d: vec3<f32>, tan_half: f32) -> f32 {
    let p = 2.0 * e.xyz - vec3<f32>(e.w);
    let a = e.w;
    let m = min(length(p), a);
    let t2 = tan_half * tan_half;
    let r = sqrt(1.0 + t2);
    let s = t2 / ((1.0 + r) * (1.0 + r));
    let den2 = m * (a - m) + m * m * s;
    let num = -dot(p, d);
    var x = 0.0;
    if (den2 > 0.0) {
        x = clamp(num / sqrt(den2), -40.0, 40.0);
    }
    return 1.0 / (1.0 + exp(-1.702 * x));
}

// Entry voxel_main (declaration svo_bounce; vct-svo's `--bounces 2`): one invocation per non-empty
// voxel i: its centre vx_position, unit mean normal vx_normal (w = 0: none, the voxel's samples face
// opposite ways; writes 0), albedo vx_albedo. The pixel entry's diffuse cones from the centre offset
// along the normal (no glossy cone: no viewer), vx_indirect = (albedo * sum of weighted cone
// radiance, 0): the light the voxel reflects of what the octree holds. Accuracy: the pixel entry's
// indirect bound.
@compute @workgroup_size(64)
fn voxel_main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= arrayLength(&vx_indirect)) {
        return;
    }
    let nrm = vx_normal[i];
    if (nrm.w == 0.0) {
        vx_indirect[i] = vec4<f32>(0.0);
        return;
    }
    let n = nrm.xyz;
    let o = vx_position[i].xyz + n * (cone.offset_voxels * cone.origin.w);
    let basis = tangent_basis(n);
    var diffuse = vec3<f32>(0.0);
    // Interleaved sets (cone.interleave = N > 1): a voxel takes class 0's cones (0, N^2, 2 N^2, ...),
    // which spread over the hemisphere as the whole set does.
    let ni = max(cone.interleave, 1u);
    for (var k = 0u; k < cone.diffuse_cones; k++) {
        let c = cone_dirs[k * ni * ni];
        let dir = basis.t * c.x + basis.b * c.y + n * c.z;
        diffuse += march(o, dir, cone.diffuse_tan, c.z).radiance * c.w;
    }
    vx_indirect[i] = vec4<f32>(vx_albedo[i].xyz * diffuse, 0.0);
}
