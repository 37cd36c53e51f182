// gbuffer — one primary ray per pixel centre through the scene's flattened BVH: the G-buffer every
// renderer shares. Mirror: cpu_mirror/src/gbuffer.rs. Uses kernels/common/bvh_trace.wgsl.
//
// Inputs: frame (eye, forward, right, up pre-scaled by fov and aspect; size = width, height), the
// flattened BVH nodes and triangles (vertex positions, a.w = material, vertex normals).
// Pixel (x, y), y down: ndc = ((x + 0.5) / w * 2 - 1, 1 - (y + 0.5) / h * 2),
//   d = normalize(forward + right * ndc.x + up * ndc.y), origin = eye.
// Outputs per pixel (row-major): gb_position = (p, t) or (0, 0, 0, -1) for no hit;
//   gb_normal = (normalize(na (1-u-v) + nb u + nc v), side) with side 1 front, -1 back, 0 none (the
//   face normal where the interpolated one has squared length <= 1e-12);
//   gb_triangle = triangle index or NONE.
// Accuracy: t, p and n within per-element bounds (quotients of dots/crosses, conditioned by the
// grazing angle; see texel_bounds). Which triangle is hit is exact except where rounding decides (ray
// within 1e-4 barycentric of an edge, or meeting triangles at equal depth): there the mirror accepts
// the GPU's pick after checking it is one rounding could have made.

struct Frame {
    eye: vec4<f32>,      // w = ray offset epsilon
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    size: vec4<u32>,     // width, height, light count, 0
}

@group(0) @binding(0) var<storage, read> frame: Frame;
@group(0) @binding(1) var<storage, read> nodes: array<BvhNode>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(3) var<storage, read_write> gb_position: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> gb_normal: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> gb_triangle: array<u32>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = frame.size.x;
    let h = frame.size.y;
    if (gid.x >= w || gid.y >= h) {
        return;
    }
    let pix = gid.y * w + gid.x;
    let nx = (f32(gid.x) + 0.5) / f32(w) * 2.0 - 1.0;
    let ny = 1.0 - (f32(gid.y) + 0.5) / f32(h) * 2.0;
    let dd = frame.forward.xyz + frame.right.xyz * nx + frame.up.xyz * ny;
    let d = dd * (1.0 / sqrt(dot(dd, dd)));
    let o = frame.eye.xyz;
    let hit = trace_closest(o, d, 0.0, 3.0e38);
    if (hit.tri == NONE) {
        gb_position[pix] = vec4<f32>(0.0, 0.0, 0.0, -1.0);
        gb_normal[pix] = vec4<f32>(0.0);
        gb_triangle[pix] = NONE;
        return;
    }
    let tri = triangles[hit.tri];
    let p = o + d * hit.t;
    let bw = 1.0 - hit.u - hit.v;
    var ns = tri.na.xyz * bw + tri.nb.xyz * hit.u + tri.nc.xyz * hit.v;
    if (!(dot(ns, ns) > 1e-12)) {
        // Vertex normals that cancel (or are zero): the face normal instead of a NaN.
        ns = cross(tri.b.xyz - tri.a.xyz, tri.c.xyz - tri.a.xyz);
    }
    let n = ns * (1.0 / sqrt(dot(ns, ns)));
    gb_position[pix] = vec4<f32>(p, hit.t);
    gb_normal[pix] = vec4<f32>(n, select(-1.0, 1.0, hit.det > 0.0));
    gb_triangle[pix] = hit.tri;
}
