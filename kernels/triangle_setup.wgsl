// triangle_setup — a mesh's triangles put on voxelize's integer lattice on the GPU, so that
// voxelization runs from the mesh itself (VCT 4.1 / CPRC 3.1: the voxelizer's triangle setup).
// Mirror: cpu_mirror/src/triangle_setup.rs. Declaration: src/kernels/triangle_setup.rs.
// Uses kernels/common/vox_triangle.wgsl.
//
// Bindings: setup_params (origin.xyz the grid's low corner, origin.w lattice steps per world unit =
// 256 / voxel size; side in voxels; triangles); mesh_positions and mesh_normals (xyz per vertex),
// mesh_uvs (per vertex; zeros where the mesh has none), mesh_triangles (a, b, c vertex indices,
// material), setup_materials (fixed-point albedo; texture: first atlas texel, W, H, 0; an index past
// the table reads its last entry). Out: vox_triangles (one per triangle), vox_dispatch (voxelize's
// sampling passes' indirect dispatch: ceil(triangles / 64) at least 1, the largest sample count + 1
// at least 1, 1; zero before the pass).
//
// One invocation per triangle (x, then y rows of the grid). Exact in WGSL's arithmetic, so the mirror
// reproduces every word:
//   vertex q = clamp(round((p - origin) * scale), 0, side 256 - 1): one correctly rounded subtraction
//     and multiplication (no product is added, so nothing is contracted), round half to even, a clamp
//     and a conversion of an integer-valued f32 below 2^24. Finite positions (the loader refuses the
//     others); a subnormal flushed changes nothing (it rounds to 0 either way).
//   sample count n = 2 k + 1, k = ceil(|e| / 256) for the longest edge e in lattice steps, in u32:
//     each |component| d = 256 h + l gives |e|^2 = 65536 sum h^2 + sum (512 h l + l^2), so k is the
//     smallest integer with k^2 >= sum h^2 + ceil(sum (512 h l + l^2) / 65536) (below 2^20: the
//     f32 square root is a start, corrected by integer comparisons).
//   normals round(n 4096) and texture coordinates round(u 16 W) (v: -v 16 H) clamped to +-2^30: a
//     power-of-two product is exact, the other one correctly rounded; the coordinates shifted by
//     whole periods 16 W so that the smallest is in [0, 16 W) (floor division; two's complement,
//     wrapping where a triangle spans more than voxelize's 32-bit interpolation holds, which the
//     host refuses at load).

struct SetupParams {
    origin: vec4<f32>,
    side: u32,
    triangles: u32,
    pad0: u32,
    pad1: u32,
}

struct SetupMaterial {
    albedo: vec4<u32>,
    texture: vec4<u32>,
}

@group(0) @binding(0) var<uniform> setup_params: SetupParams;
@group(0) @binding(1) var<storage, read> mesh_positions: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> mesh_normals: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> mesh_uvs: array<vec2<f32>>;
@group(0) @binding(4) var<storage, read> mesh_triangles: array<vec4<u32>>;
@group(0) @binding(5) var<storage, read> setup_materials: array<SetupMaterial>;
@group(0) @binding(6) var<storage, read_write> vox_triangles: array<VoxTriangle>;
@group(0) @binding(7) var<storage, read_write> vox_dispatch: array<atomic<u32>>;

const FIXED_CLAMP: f32 = 1073741824.0;

fn lattice(p: vec4<f32>) -> vec3<i32> {
    let max_q = f32(i32(setup_params.side) * 256 - 1);
    let x = (p.xyz - setup_params.origin.xyz) * setup_params.origin.w;
    return vec3<i32>(clamp(round(x), vec3<f32>(0.0), vec3<f32>(max_q)));
}

// The smallest k with k^2 >= m (m below 2^20).
fn ceil_sqrt(m: u32) -> u32 {
    var k = u32(sqrt(f32(m)));
    loop {
        if (k * k >= m) {
            break;
        }
        k += 1u;
    }
    loop {
        if (k == 0u || (k - 1u) * (k - 1u) < m) {
            break;
        }
        k -= 1u;
    }
    return k;
}

// ceil(|b - a| / 256): an edge's length in voxels, rounded up (see the header).
fn edge_voxels(a: vec3<i32>, b: vec3<i32>) -> u32 {
    let d = vec3<u32>(abs(b - a));
    let h = d >> vec3<u32>(8u);
    let l = d & vec3<u32>(255u);
    let big = h.x * h.x + h.y * h.y + h.z * h.z;
    let small = (512u * h.x * l.x + l.x * l.x) + (512u * h.y * l.y + l.y * l.y) + (512u * h.z * l.z + l.z * l.z);
    return ceil_sqrt(big + (small >> 16u) + select(0u, 1u, (small & 0xffffu) != 0u));
}

fn fixed3(v: vec3<f32>) -> vec3<i32> {
    return vec3<i32>(clamp(round(v * 4096.0), vec3<f32>(-FIXED_CLAMP), vec3<f32>(FIXED_CLAMP)));
}

// One axis of the texture coordinates, 1/16 texel of a texture n texels wide, shifted by whole
// periods so that the smallest is in [0, 16 n).
fn fixed_uv_axis(c: vec3<f32>, n: u32) -> vec3<i32> {
    let period = i32(n * 16u);
    let q = vec3<i32>(clamp(round(c * f32(period)), vec3<f32>(-FIXED_CLAMP), vec3<f32>(FIXED_CLAMP)));
    let lo = min(min(q.x, q.y), q.z);
    let periods = select(lo / period, (lo + 1) / period - 1, lo < 0);
    return q - vec3<i32>(periods * period);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i == 0u) {
        atomicStore(&vox_dispatch[0], max((setup_params.triangles + 63u) / 64u, 1u));
        atomicMax(&vox_dispatch[1], 1u);
        atomicStore(&vox_dispatch[2], 1u);
    }
    if (i >= setup_params.triangles) {
        return;
    }
    let t = mesh_triangles[i];
    let pa = lattice(mesh_positions[t.x]);
    let pb = lattice(mesh_positions[t.y]);
    let pc = lattice(mesh_positions[t.z]);
    let k = max(max(edge_voxels(pa, pb), edge_voxels(pb, pc)), edge_voxels(pc, pa));
    let n = 2u * k + 1u;
    atomicMax(&vox_dispatch[1], n + 1u);
    let m = setup_materials[min(t.w, arrayLength(&setup_materials) - 1u)];
    var uv_ab = vec4<i32>(0);
    var uv_c = vec4<i32>(0);
    if (m.texture.y != 0u && m.texture.z != 0u) {
        let ua = mesh_uvs[t.x];
        let ub = mesh_uvs[t.y];
        let uc = mesh_uvs[t.z];
        let u = fixed_uv_axis(vec3<f32>(ua.x, ub.x, uc.x), m.texture.y);
        let v = fixed_uv_axis(-vec3<f32>(ua.y, ub.y, uc.y), m.texture.z);
        uv_ab = vec4<i32>(u.x, v.x, u.y, v.y);
        uv_c = vec4<i32>(u.z, v.z, 0, 0);
    }
    vox_triangles[i] = VoxTriangle(
        vec4<i32>(pa, i32(n)),
        vec4<i32>(pb, 0),
        vec4<i32>(pc, 0),
        vec4<i32>(fixed3(mesh_normals[t.x].xyz), 0),
        vec4<i32>(fixed3(mesh_normals[t.y].xyz), 0),
        vec4<i32>(fixed3(mesh_normals[t.z].xyz), 0),
        vec4<u32>(m.albedo.xyz, 0u),
        uv_ab,
        uv_c,
        m.texture,
    );
}
