// direct_light — direct light with exact hard shadows at every G-buffer texel: one shadow ray per
// light through the flattened BVH. Mirror: cpu_mirror/src/direct_light.rs (whose `shade` the reference
// path tracer also uses). Uses kernels/common/bvh_trace.wgsl and
// kernels/common/lights.wgsl.
//
// Contract: back faces and background reflect nothing; BRDF kd/pi + ks (n+2)/(2 pi) max(r . wo, 0)^n
// (r = mirror direction of the light about the shading normal, wo towards the eye, n = diffuse.w);
// point: I cos / r^2; spot: times spot_factor (1 inside falloff, 0 outside cone, smoothstep in cosine
// between); directional: I cos. Lights below the geometric surface or the shading normal add nothing.
// Shadow rays start at p + ng * eps (ng = the triangle's front normal, eps = frame.eye.w) and end short
// of the light, t < max(r - 2 eps, 0) (r its distance from p: the start's offset may bring the ray up
// to eps nearer the light, and it ends eps before that), so that a light in a surface's plane is not
// shadowed by that plane within rounding, as p is not by its own surface; or at 3e38.
// Output: radiance (rgb, 0) per pixel, row-major.
// Accuracy: per-element bound (see shade_with_bound): 64 ULP per light term, 8 ULP absolute on the
// cosines, pow's exp2/log2 rule; a term whose visibility or spot edge rounding decides adds its value.

@group(0) @binding(0) var<storage, read> frame: Frame;
@group(0) @binding(1) var<storage, read> nodes: array<BvhNode>;
@group(0) @binding(2) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read> materials: array<Material>;
@group(0) @binding(5) var<storage, read> gb_position: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> gb_normal: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> gb_triangle: array<u32>;
@group(0) @binding(8) var<storage, read_write> radiance: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> gb_albedo: array<vec4<f32>>;

const PI: f32 = 3.14159265358979;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let pix = gid.x + gid.y * groups.x * 64u;
    if (pix >= arrayLength(&radiance)) {
        return;
    }
    let nrm = gb_normal[pix];
    let ti = gb_triangle[pix];
    if (nrm.w <= 0.0 || ti >= arrayLength(&triangles)) {
        radiance[pix] = vec4<f32>(0.0);
        return;
    }
    let tri = triangles[ti];
    var m = materials[min(u32(tri.a.w), arrayLength(&materials) - 1u)];
    m.diffuse = vec4<f32>(gb_albedo[pix].xyz, m.diffuse.w);   // Kd or the map_Kd texel
    let p = gb_position[pix].xyz;
    let n = nrm.xyz;
    let fc = cross(tri.b.xyz - tri.a.xyz, tri.c.xyz - tri.a.xyz);
    let ng = fc * (1.0 / sqrt(dot(fc, fc)));
    let eps = frame.eye.w;
    let wv = frame.eye.xyz - p;
    let wo = wv * (1.0 / sqrt(dot(wv, wv)));
    let origin = p + ng * eps;
    var sum = vec3<f32>(0.0);
    for (var l = 0u; l < frame.size.z; l++) {
        let light = lights[l];
        let inc = incident(light, p);
        let wi = inc.wi;
        let e = inc.e;
        let t_max = max(inc.t_max - 2.0 * eps, 0.0);
        let cos = dot(n, wi);
        if (cos <= 0.0 || dot(ng, wi) <= 0.0 || all(e == vec3<f32>(0.0))) {
            continue;
        }
        if (trace_occluded(origin, wi, 0.0, t_max)) {
            continue;
        }
        sum += brdf(m, n, wi, wo, cos) * e * cos;
    }
    radiance[pix] = vec4<f32>(sum, 0.0);
}
