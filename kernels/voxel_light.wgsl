// voxel_light — direct light into the non-empty voxels (Rehfeld et al. 2014, 3.1 "Voxel Illumination"),
// with exact hard shadows (one shadow ray per light through the BVH) instead of the paper's shadow
// cones, as the light-transport contract asks. Output is the pre-multiplied (radiance * alpha, alpha)
// grid surface_coverage_mip filters. Mirror: cpu_mirror/src/voxel_light.rs. Uses common/bvh_trace.wgsl and
// common/lights.wgsl (and common/morton.wgsl).
//
// One invocation per entry of `list` (the voxelize kernel's non-empty voxels; entries past
// list_count[0] return). Windows: with grid.size.w > 0 only the voxels v in [size.z, size.z + size.w)
// are lit, vox_colour, vox_normal and vox_radiance bound from voxel size.z (a grid whose buffers pass
// one storage binding is lit a window at a time, each dispatch over the whole list); size.w = 0 is the
// whole grid. Voxel v (Morton index) has centre origin + (xyz + 0.5) * size in the grid's
// frame, placed in the world by grid.model (identity for a world-space grid: then every product is by 1
// or 0, exactly the untransformed arithmetic; a rigid placement lights an instance's own grid where it
// stands, CPRC 3.1), albedo and alpha in vox_colour, mean normal m = normal_model * vox_normal (the
// inverse transpose): n = m / |m| when |m| > 1e-3, else the voxel is lit as if
// facing each light (cos = 1). L = albedo / pi * sum over lights of E * max(n . wi, 0) * visible, where
// E and wi are the direct_light kernel's (point: I / r^2, spot: times its smoothstep, directional: I)
// taken at the centre, and the shadow ray starts one voxel (world.x) from the centre along n and runs to
// two voxels short of the light's distance from the centre (the start's offset may bring it up to a
// voxel nearer the light: a light in a surface's plane is not shadowed by that plane within
// rounding). vox_radiance[v] = (L * alpha, alpha); unlisted voxels are left as they are (0).
// Accuracy: per-element bound as direct_light's (64 ULP per term, 8 ULP absolute on the cosine); a
// term whose shadow ray rounding decides adds its value.

struct VoxelGrid {
    origin: vec4<f32>,   // xyz, w = voxel size (in the grid's own frame)
    size: vec4<u32>,     // side, light count, window's first voxel, its voxels (0: the whole grid)
    model: array<vec4<f32>, 3>,          // rows of world-from-grid (3x4); identity: a world-space grid
    normal_model: array<vec4<f32>, 3>,   // rows of its inverse transpose (xyz)
    world: vec4<f32>,    // x = voxel size in world units (the shadow ray's offsets)
}

@group(0) @binding(0) var<storage, read> grid: VoxelGrid;
@group(0) @binding(1) var<storage, read> nodes: array<BvhNode>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read> vox_colour: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> vox_normal: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> list: array<u32>;
@group(0) @binding(7) var<storage, read> list_count: array<u32>;
@group(0) @binding(8) var<storage, read_write> vox_radiance: array<vec4<f32>>;

const PI: f32 = 3.14159265358979;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = gid.x + gid.y * groups.x * 64u;
    if (k >= list_count[0] || k >= arrayLength(&list)) {
        return;
    }
    let v = list[k];
    // The voxel within the window (below it, the difference wraps past its size).
    let w = v - grid.size.z;
    if (grid.size.w != 0u && w >= grid.size.w) {
        return;
    }
    let col = vox_colour[w];
    let alpha = col.w;
    let ml = vox_normal[w].xyz;
    let m = vec3<f32>(dot(grid.normal_model[0].xyz, ml), dot(grid.normal_model[1].xyz, ml), dot(grid.normal_model[2].xyz, ml));
    let len = sqrt(dot(m, m));
    let cell = vec3<f32>(morton_decode(v));
    let cl = grid.origin.xyz + (cell + vec3<f32>(0.5)) * grid.origin.w;
    let c = vec3<f32>(
        dot(grid.model[0].xyz, cl) + grid.model[0].w,
        dot(grid.model[1].xyz, cl) + grid.model[1].w,
        dot(grid.model[2].xyz, cl) + grid.model[2].w,
    );
    let s = grid.world.x;
    var sum = vec3<f32>(0.0);
    for (var l = 0u; l < grid.size.y; l++) {
        let light = lights[l];
        let inc = incident(light, c);
        let wi = inc.wi;
        let e = inc.e;
        let t_light = inc.t_max;
        var n = wi;
        var cos = 1.0;
        if (len > 1e-3) {
            n = m * (1.0 / len);
            cos = dot(n, wi);
        }
        if (cos <= 0.0 || all(e == vec3<f32>(0.0))) {
            continue;
        }
        let o = c + n * s;
        let t_max = max(t_light - 2.0 * s, 0.0);
        let term = col.xyz * (1.0 / PI) * e * cos;
        if (!trace_occluded(o, wi, 0.0, t_max)) {
            sum += term;
        }
    }
    vox_radiance[w] = vec4<f32>(sum * alpha, alpha);
}
