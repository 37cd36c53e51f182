// voxelize — surface-sampling voxelization into the dense Morton grid that surface_coverage_mip reads
// (Rehfeld et al. 2014, 3.1 "Voxelization": sample all surfaces uniformly, write each sample to its
// cell, average albedo and normals per cell, keep a list of the non-empty cells).
// Mirror: cpu_mirror/src/voxelize.rs. Declaration and host preparation: src/kernels/voxelize.rs.
// Uses kernels/common/morton.wgsl and kernels/common/vox_triangle.wgsl (the triangles, written by
// triangle_setup.wgsl from the mesh or by the host's mirror of it).
//
// Integer arithmetic throughout the sampling, so the result does not depend on the order of atomic
// additions and the mirror reproduces it exactly:
//   triangles: lattice vertices (1/256 voxel, a.w = sample count n), fixed-point (x 4096) vertex normals
//   and albedo. Sample (i, j), i + j <= n: P = A + ((B - A) i + (C - A) j) / n (i32, truncating
//   division), voxel = P >> 8 (clamped to the grid), normal = (na (n-i-j) + nb i + nc j) / n.
//   Textured triangles (texture.y = W > 0): fixed-point texture coordinates (1/16 texel) interpolate
//   the same way; the sample's albedo is vox_lut of the channels of texel ((Us >> 4) mod W,
//   (Vs >> 4) mod H) at texture.x in vox_texels (packed sRGB8 r | g << 8 | b << 16).
// Windows: splat and resolve see the voxels [params.window_first, window_first + window_voxels)
//   (Morton indices), their `vox_colour` and `vox_normal` bound from that window's first voxel, so a
//   grid whose buffers pass one storage binding is voxelized a window at a time (the same samples
//   and sums: each window keeps its own voxels' samples); one window of side^3 voxels is the whole
//   grid. `acc` holds one window's accumulators (window_voxels x 8 words), the same buffer for every
//   window: resolve leaves it zero for the next window's splat and the next frame's, so the
//   accumulators cost 32 bytes per voxel of a window, not of the grid.
// Pass `splat` (one invocation per triangle row: gid.x = triangle, gid.y = i): adds albedo, normal
//   (two's complement in u32) and 1 into acc[8 w .. 8 w + 7] = (r, g, b, nx, ny, nz, count, -) of the
//   sample's voxel v (Morton index) at w = v - window_first, for the samples in the window. acc must
//   start zeroed.
// Pass `resolve` (one invocation per voxel of the window): takes the window's sums out of acc
//   (atomicExchange with 0), colour = (sum_albedo / count / 4096, 1), normal = (sum_normal / count /
//   4096, 0) — the mean, not renormalised — or zeros when empty; a non-empty voxel appends its index
//   v to `list` (atomic counter list_count[0]; order is the GPU's, the comparison sorts it).
// Pass `occupancy_bits` (dispatched as splat): the same samples, no albedo or normal: sets bit (v mod 32) of
//   occupancy[v / 32] for the sample's voxel v (Morton index) by atomicOr: binary occlusion voxels, one
//   bit per voxel (level 0 of occlusion_voxels.wgsl's pyramid), where splat's accumulators take 32
//   bytes per voxel. occupancy must start zeroed.
// Accuracy: counts, lists, alpha, occupancy exact; colour and normal: one division (2.5 ULP) then an exact
// power-of-two scale, and the integer-to-float conversions are exact below 2^24 (sums of up to 4096
// samples): 3 ULP, 4 past that.

struct VoxParams {
    side: u32,
    triangles: u32,
    window_first: u32,
    window_voxels: u32,
}

@group(0) @binding(0) var<uniform> params: VoxParams;
@group(0) @binding(1) var<storage, read> vox_triangles: array<VoxTriangle>;
@group(0) @binding(2) var<storage, read_write> acc: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> vox_colour: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> vox_normal: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> list: array<u32>;
@group(0) @binding(6) var<storage, read_write> list_count: array<atomic<u32>>;
@group(0) @binding(7) var<storage, read> vox_texels: array<u32>;
@group(0) @binding(8) var<storage, read> vox_lut: array<u32>;
@group(0) @binding(9) var<storage, read_write> occupancy: array<atomic<u32>>;

fn wrap(a: i32, n: u32) -> u32 {
    let m = a % i32(n);
    return u32(select(m, m + i32(n), m < 0));
}

fn sample_albedo(t: VoxTriangle, i: i32, j: i32) -> vec3<u32> {
    let w = t.texture.y;
    let h = t.texture.z;
    if (w == 0u || h == 0u) {
        return t.albedo.xyz;
    }
    let n = t.a.w;
    let us = t.uv_ab.x + ((t.uv_ab.z - t.uv_ab.x) * i + (t.uv_c.x - t.uv_ab.x) * j) / n;
    let vs = t.uv_ab.y + ((t.uv_ab.w - t.uv_ab.y) * i + (t.uv_c.y - t.uv_ab.y) * j) / n;
    let x = wrap(us >> 4u, w);
    let y = wrap(vs >> 4u, h);
    let texel = vox_texels[t.texture.x + y * w + x];
    return vec3<u32>(vox_lut[texel & 255u], vox_lut[(texel >> 8u) & 255u], vox_lut[(texel >> 16u) & 255u]);
}

// The Morton index of the voxel sample (i, j) of t lands in (clamped to the grid).
fn sample_voxel(t: VoxTriangle, i: i32, j: i32, side: i32) -> u32 {
    let n = t.a.w;
    let p = t.a.xyz + ((t.b.xyz - t.a.xyz) * i + (t.c.xyz - t.a.xyz) * j) / vec3<i32>(n);
    return morton3(vec3<u32>(clamp(p / vec3<i32>(256), vec3<i32>(0), vec3<i32>(side - 1))));
}

@compute @workgroup_size(64)
fn splat(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.triangles) {
        return;
    }
    let t = vox_triangles[gid.x];
    let n = t.a.w;
    let i = i32(gid.y);
    if (i > n) {
        return;
    }
    let side = i32(params.side);
    // A window is an aligned power-of-two Morton range, so the box from its first voxel to its last:
    // a triangle whose voxel box (its vertices' voxels, clamped as the samples' are) misses it has
    // no sample in it.
    let lo = vec3<i32>(morton_decode(params.window_first));
    let hi = vec3<i32>(morton_decode(params.window_first + params.window_voxels - 1u));
    let vmin = clamp(min(min(t.a.xyz, t.b.xyz), t.c.xyz) / vec3<i32>(256), vec3<i32>(0), vec3<i32>(side - 1));
    let vmax = clamp(max(max(t.a.xyz, t.b.xyz), t.c.xyz) / vec3<i32>(256), vec3<i32>(0), vec3<i32>(side - 1));
    if (any(vmax < lo) || any(vmin > hi)) {
        return;
    }
    for (var j = 0; j <= n - i; j++) {
        // Outside the window (below it, the difference wraps past window_voxels).
        let w = sample_voxel(t, i, j, side) - params.window_first;
        if (w >= params.window_voxels) {
            continue;
        }
        let nrm = (t.na.xyz * (n - i - j) + t.nb.xyz * i + t.nc.xyz * j) / vec3<i32>(n);
        let base = w * 8u;
        let albedo = sample_albedo(t, i, j);
        atomicAdd(&acc[base], albedo.x);
        atomicAdd(&acc[base + 1u], albedo.y);
        atomicAdd(&acc[base + 2u], albedo.z);
        atomicAdd(&acc[base + 3u], bitcast<u32>(nrm.x));
        atomicAdd(&acc[base + 4u], bitcast<u32>(nrm.y));
        atomicAdd(&acc[base + 5u], bitcast<u32>(nrm.z));
        atomicAdd(&acc[base + 6u], 1u);
    }
}

@compute @workgroup_size(64)
fn occupancy_bits(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.triangles) {
        return;
    }
    let t = vox_triangles[gid.x];
    let n = t.a.w;
    let i = i32(gid.y);
    if (i > n) {
        return;
    }
    let side = i32(params.side);
    for (var j = 0; j <= n - i; j++) {
        let m = sample_voxel(t, i, j, side);
        atomicOr(&occupancy[m >> 5u], 1u << (m & 31u));
    }
}

@compute @workgroup_size(64)
fn resolve(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let v = gid.x + gid.y * groups.x * 64u;
    if (v >= params.window_voxels) {
        return;
    }
    let base = v * 8u;
    var sums: array<u32, 7>;
    for (var k = 0u; k < 7u; k++) {
        sums[k] = atomicExchange(&acc[base + k], 0u);
    }
    let count = sums[6];
    if (count == 0u) {
        vox_colour[v] = vec4<f32>(0.0);
        vox_normal[v] = vec4<f32>(0.0);
        return;
    }
    let c = f32(count);
    let s = 1.0 / 4096.0;
    let alb = vec3<f32>(f32(sums[0]), f32(sums[1]), f32(sums[2]));
    let nrm = vec3<f32>(f32(bitcast<i32>(sums[3])), f32(bitcast<i32>(sums[4])), f32(bitcast<i32>(sums[5])));
    vox_colour[v] = vec4<f32>(alb / c * s, 1.0);
    vox_normal[v] = vec4<f32>(nrm / c * s, 0.0);
    let slot = atomicAdd(&list_count[0], 1u);
    list[slot] = params.window_first + v;
}
