// gbuffer — one primary ray per pixel centre through the scene's flattened BVH: the G-buffer every
// renderer shares. Mirror: cpu_mirror/src/gbuffer.rs. Uses kernels/common/bvh_trace.wgsl.
//
// Inputs: frame (eye, forward, right, up pre-scaled by fov and aspect; size = width, height), the
// flattened BVH nodes and triangles (vertex positions, a.w = material, vertex normals).
// Pixel (x, y), y down: ndc = ((x + 0.5) / w * 2 - 1, 1 - (y + 0.5) / h * 2),
//   d = normalize(forward + right * ndc.x + up * ndc.y), origin = eye; or, orthographic (size.w = 1, a
//   directional light's RSM): d = forward (unit), origin = eye + right * ndc.x + up * ndc.y.
// Outputs per pixel (row-major): gb_position = (p, t) or (0, 0, 0, -1) for no hit;
//   gb_normal = (normalize(na (1-u-v) + nb u + nc v), side) with side 1 front, -1 back, 0 none (the
//   face normal where the interpolated one has squared length <= 1e-12);
//   gb_triangle = triangle index or NONE;
//   gb_albedo = (albedo, 0): the material's Kd, or where it has a map_Kd texture the nearest texel at
//   uv = uv_a (1-u-v) + uv_b u + uv_c v (uvs[3 t + k]), repeating: f = uv - floor(uv), column
//   min(u32(f.x W), W-1), row min(u32((1 - f.y) H), H-1) (row 0 = the image's top); texels packed
//   sRGB8 r | g << 8 | b << 16, decoded through srgb_lut. Zeros for no hit.
// Albedo accuracy: exact where Kd; from a texture, any texel the uv's rounding could select
// (albedo_bound; the texel choice itself is exact for a given uv: x - floor(x) is exact).
// Accuracy: t, p and n within per-element bounds (quotients of dots/crosses, conditioned by the
// grazing angle; see texel_bounds). Which triangle is hit is exact except where rounding decides (ray
// within 1e-4 barycentric of an edge, or meeting triangles at equal depth): there the mirror accepts
// the GPU's pick after checking it is one rounding could have made.

@group(0) @binding(0) var<storage, read> frame: Frame;
@group(0) @binding(1) var<storage, read> nodes: array<BvhNode>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(3) var<storage, read_write> gb_position: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> gb_normal: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> gb_triangle: array<u32>;
@group(0) @binding(6) var<storage, read> materials: array<Material>;
@group(0) @binding(7) var<storage, read> uvs: array<vec2<f32>>;
@group(0) @binding(8) var<storage, read> texels: array<u32>;
@group(0) @binding(9) var<storage, read> srgb_lut: array<f32>;
@group(0) @binding(10) var<storage, read_write> gb_albedo: array<vec4<f32>>;

fn albedo(ti: u32, u: f32, v: f32) -> vec4<f32> {
    let m = materials[min(u32(triangles[ti].a.w), arrayLength(&materials) - 1u)];
    let w = m.texture.y;
    let h = m.texture.z;
    if (w == 0u || h == 0u) {
        return vec4<f32>(m.diffuse.xyz, 0.0);
    }
    let uv = uvs[3u * ti] * (1.0 - u - v) + uvs[3u * ti + 1u] * u + uvs[3u * ti + 2u] * v;
    let f = uv - floor(uv);
    let x = min(u32(f.x * f32(w)), w - 1u);
    let y = min(u32((1.0 - f.y) * f32(h)), h - 1u);
    let t = texels[m.texture.x + y * w + x];
    return vec4<f32>(srgb_lut[t & 255u], srgb_lut[(t >> 8u) & 255u], srgb_lut[(t >> 16u) & 255u], 0.0);
}

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
    var o = frame.eye.xyz;
    var d = frame.forward.xyz;
    if (frame.size.w == 1u) {
        // Orthographic (a directional light's RSM): parallel rays from the image plane.
        o = frame.eye.xyz + frame.right.xyz * nx + frame.up.xyz * ny;
    } else {
        let dd = frame.forward.xyz + frame.right.xyz * nx + frame.up.xyz * ny;
        d = dd * (1.0 / sqrt(dot(dd, dd)));
    }
    let hit = trace_closest(o, d, 0.0, 3.0e38);
    if (hit.tri == NONE) {
        gb_position[pix] = vec4<f32>(0.0, 0.0, 0.0, -1.0);
        gb_normal[pix] = vec4<f32>(0.0);
        gb_triangle[pix] = NONE;
        gb_albedo[pix] = vec4<f32>(0.0);
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
    gb_albedo[pix] = albedo(hit.tri, hit.u, hit.v);
}
