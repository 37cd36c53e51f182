// svo_sample — quadrilinear sampling of the sparse voxel octree (Crassin et al. 2011, 5: lookups "at the
// level corresponding to the cone radius" with quadrilinear interpolation), the octree's read path for
// cone tracing. Mirror: cpu_mirror/src/svo_sample.rs. Node layout and descent: kernels/common/svo_node.wgsl.
//
// One invocation per query (x, y, z in the unit volume, clamped; w = level, clamped to [0, depth]):
//   per level L in {floor(w), floor(w) + 1}: u = x * 2^(L+1) (the level's vertex lattice), node
//   c = min(floor(u / 2), 2^L - 1), brick coordinate u - 2c in [0, 2], cell = min(floor(.), 1), weights
//   f = . - cell; trilinear of the cell's 8 brick voxels, each f32(v) * inv_scale; a missing node is 0
//   (exact: the halo rule allocates every node holding a non-zero point). Levels blended by fract(w);
//   a whole level reads one level only.
// Position arithmetic is exact (power-of-two scaling, Sterbenz subtractions): GPU and mirror pick the
// same nodes, cells and weights. The interpolation is 7 + 1 lerps a(1-t) + bt of non-negative values:
// within a few ULP of the result (see the declaration's tolerance).

struct SampleParams {
    depth: u32,
    count: u32,
    inv_scale: f32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: SampleParams;
@group(0) @binding(1) var<storage, read> nodes: array<Node>;
// bricks: common/svo_bricks.wgsl.
@group(0) @binding(3) var<storage, read> queries: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> samples: array<vec4<f32>>;

fn lerp4(a: vec4<f32>, b: vec4<f32>, t: f32) -> vec4<f32> {
    return a * (1.0 - t) + b * t;
}

fn voxel(base: u32, v: vec3<u32>) -> vec4<f32> {
    let w = base + voxel_index(v) * 4u;
    return vec4<f32>(brick_words(w)) * params.inv_scale;
}

fn sample_level(x: vec3<f32>, level: u32) -> vec4<f32> {
    let side = f32(2u << level);
    let last = (1u << level) - 1u;
    let u = clamp(x, vec3<f32>(0.0), vec3<f32>(1.0)) * side;
    let c = min(vec3<u32>(floor(u * 0.5)), vec3<u32>(last));
    let local = u - 2.0 * vec3<f32>(c);
    let cell = min(vec3<u32>(floor(local)), vec3<u32>(1u));
    let f = local - vec3<f32>(cell);
    let n = find(level, c);
    if (n == NONE) {
        return vec4<f32>(0.0);
    }
    let b = n * BRICK_WORDS;
    let x00 = lerp4(voxel(b, cell), voxel(b, cell + vec3<u32>(1u, 0u, 0u)), f.x);
    let x10 = lerp4(voxel(b, cell + vec3<u32>(0u, 1u, 0u)), voxel(b, cell + vec3<u32>(1u, 1u, 0u)), f.x);
    let x01 = lerp4(voxel(b, cell + vec3<u32>(0u, 0u, 1u)), voxel(b, cell + vec3<u32>(1u, 0u, 1u)), f.x);
    let x11 = lerp4(voxel(b, cell + vec3<u32>(0u, 1u, 1u)), voxel(b, cell + vec3<u32>(1u, 1u, 1u)), f.x);
    return lerp4(lerp4(x00, x10, f.y), lerp4(x01, x11, f.y), f.z);
}

@compute @workgroup_size(64)
fn svo_sample(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= params.count) {
        return;
    }
    let q = queries[i];
    let l = clamp(q.w, 0.0, f32(params.depth));
    let l0 = floor(l);
    let a = l - l0;
    let s0 = sample_level(q.xyz, u32(l0));
    if (a == 0.0) {
        samples[i] = s0;
        return;
    }
    samples[i] = lerp4(s0, sample_level(q.xyz, u32(l0) + 1u), a);
}
