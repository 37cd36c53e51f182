// cprc_pixels — what cprc reads from a frame's G-buffer and writes back to its pixels (Rehfeld et al.
// 2014, 3.2-3.3). Mirror: cpu_mirror/src/cprc_pixels.rs (its module comment defines every output).
// Uses kernels/common/scene_types.wgsl (Frame, Triangle).
//
// inputs (one invocation per pixel): from the G-buffer (gb_position, gb_normal, gb_triangle), the
//   camera (frame) and the triangles' materials, the distribution's and the gather's per-pixel inputs:
//   normals (snorm16 packed, background where nothing gathers), depth along the camera's forward
//   axis, positions (w = 1 where the pixel gathers), pixel_dirs (normal; reflection vector and the
//   glossy mip level) and px_specular (Ks). lobes[m] = (Ks rgb, glossy mip level or -1): a host table
//   per material (the level is a log of a power, kept out of the kernel so it is exact).
// compose (one invocation per pixel): indirect = albedo / pi * diffuse + Ks * glossy where the pixel
//   gathers, ao = 1 on any geometry.
// Accuracy: normals, positions, specular, ao exact (the quantisation is one correctly rounded product
// and round); depth, pixel_dirs and indirect within the mirror's per-element bounds.

@group(0) @binding(0) var<storage, read> frame: Frame;
@group(0) @binding(1) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(2) var<storage, read> lobes: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> gb_position: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> gb_normal: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> gb_triangle: array<u32>;
@group(0) @binding(6) var<storage, read_write> normals: array<vec2<u32>>;
@group(0) @binding(7) var<storage, read_write> depth: array<f32>;
@group(0) @binding(8) var<storage, read_write> positions: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> pixel_dirs: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> px_specular: array<vec4<f32>>;

@group(0) @binding(11) var<storage, read> gb_albedo: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read> diffuse: array<vec4<f32>>;
@group(0) @binding(13) var<storage, read> glossy: array<vec4<f32>>;
@group(0) @binding(14) var<storage, read_write> indirect: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read_write> ao: array<vec4<f32>>;

const INV_PI: f32 = 0.3183098861837907;

fn linear(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn finite3(v: vec3<f32>) -> bool {
    return finite(v.x) && finite(v.y) && finite(v.z);
}

fn normalize_or(v: vec3<f32>, or: vec3<f32>) -> vec3<f32> {
    let l2 = dot(v, v);
    if (l2 > 0.0 && finite(l2)) {
        return v / sqrt(l2);
    }
    return or;
}

// snorm16 packing of the G-buffer normal as stored (background: not finite, or quantised to 0).
fn quantised(n: vec3<f32>) -> vec2<u32> {
    if (!finite3(n)) {
        return vec2<u32>(0u);
    }
    let q = vec3<i32>(round(clamp(n, vec3<f32>(-1.0), vec3<f32>(1.0)) * 32767.0));
    if (all(q == vec3<i32>(0))) {
        return vec2<u32>(0u);
    }
    let b = bitcast<vec3<u32>>(q) & vec3<u32>(0xffffu);
    return vec2<u32>(b.x | (b.y << 16u), b.z | (1u << 16u));
}

@compute @workgroup_size(64)
fn inputs(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(gid, groups);
    if (i >= arrayLength(&depth)) {
        return;
    }
    let g = gb_position[i];
    let n = gb_normal[i];
    let t = gb_triangle[i];
    let front = n.w > 0.0 && t < arrayLength(&triangles) && finite3(g.xyz);
    if (!front) {
        normals[i] = vec2<u32>(0u);
        depth[i] = 0.0;
        positions[i] = vec4<f32>(0.0);
        pixel_dirs[2u * i] = vec4<f32>(0.0);
        pixel_dirs[2u * i + 1u] = vec4<f32>(0.0, 0.0, 0.0, -1.0);
        px_specular[i] = vec4<f32>(0.0);
        return;
    }
    let p = g.xyz;
    let eye = frame.eye.xyz;
    let nv = normalize_or(n.xyz, vec3<f32>(0.0, 0.0, 1.0));
    let wo = normalize_or(eye - p, nv);
    let r = nv * (2.0 * dot(nv, wo)) - wo;
    let d = dot(p - eye, frame.forward.xyz);
    let m = min(u32(triangles[t].a.w), arrayLength(&lobes) - 1u);
    let lobe = lobes[m];
    var q = vec2<u32>(0u);
    if (finite(d) && d > 0.0) {
        q = quantised(n.xyz);
    }
    normals[i] = q;
    depth[i] = d;
    positions[i] = vec4<f32>(p, 1.0);
    pixel_dirs[2u * i] = vec4<f32>(nv, 0.0);
    pixel_dirs[2u * i + 1u] = vec4<f32>(r, lobe.w);
    px_specular[i] = vec4<f32>(lobe.xyz, 0.0);
}

@compute @workgroup_size(64)
fn compose(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear(gid, groups);
    if (i >= arrayLength(&indirect)) {
        return;
    }
    if (positions[i].w != 1.0) {
        indirect[i] = vec4<f32>(0.0);
        ao[i] = vec4<f32>(vec3<f32>(select(0.0, 1.0, gb_normal[i].w != 0.0)), 0.0);
        return;
    }
    let c = gb_albedo[i].xyz * INV_PI * diffuse[i].xyz + px_specular[i].xyz * glossy[i].xyz;
    indirect[i] = vec4<f32>(c, 0.0);
    ao[i] = vec4<f32>(1.0, 1.0, 1.0, 0.0);
}
