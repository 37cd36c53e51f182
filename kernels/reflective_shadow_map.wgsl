// reflective_shadow_map — one light view's reflective shadow map (Dachsbacher & Stamminger 2005, as LRSM
// section 5 renders it: reflected radiance, normal, depth and <n.l>) from a G-buffer ray-cast from that
// view by gbuffer.wgsl, written in the 2D Morton order lrsm_partition reads. Mirror:
// cpu_mirror/src/reflective_shadow_map.rs. Declaration: src/kernels/reflective_shadow_map.rs. Uses
// common/lights.wgsl (the light contract's `incident`) and common/lrsm_view.wgsl.
//
// One invocation per RSM texel m: (x, y) = 2D Morton decode of m, G-buffer pixel y * side + x.
//   nothing hit or a back face (gb_normal.w <= 0: back faces reflect nothing): radiance 0, normal 0,
//     depth 1 (coverage 0: lrsm_partition leaves the texel out);
//   else radiance = (albedo / pi * E * <n.l>, 1) with E from `incident` (no shadow ray: the view sees the
//     point), normal = (n, <n.l>), depth = clamp(view_depth(p), 0, 1).
// Accuracy: radiance and <n.l> within direct_light's per-term bound, depth 8 ULP of its magnitudes
// (per-element bounds in the mirror); coverage and the normal's xyz are copies.

@group(0) @binding(0) var<storage, read> view: LrsmView;
@group(0) @binding(1) var<storage, read> lights: array<Light>;
@group(0) @binding(2) var<storage, read> gb_position: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> gb_normal: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> gb_albedo: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> rsm_radiance: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> rsm_normal: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> rsm_depth: array<f32>;

const PI: f32 = 3.14159265358979;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let m = gid.x + gid.y * groups.x * 64u;
    let side = view.info.x;
    if (m >= side * side || m >= arrayLength(&rsm_depth)) {
        return;
    }
    let pix = compact2(m >> 1u) * side + compact2(m);
    let nrm = gb_normal[pix];
    if (nrm.w <= 0.0) {
        rsm_radiance[m] = vec4<f32>(0.0);
        rsm_normal[m] = vec4<f32>(0.0);
        rsm_depth[m] = 1.0;
        return;
    }
    let p = gb_position[pix].xyz;
    let n = nrm.xyz;
    let inc = incident(lights[view.info.y], p);
    let ndotl = max(dot(n, inc.wi), 0.0);
    let rad = gb_albedo[pix].xyz * (1.0 / PI) * inc.e * ndotl;
    rsm_radiance[m] = vec4<f32>(rad, 1.0);
    rsm_normal[m] = vec4<f32>(n, ndotl);
    rsm_depth[m] = clamp(view_depth(view, p), 0.0, 1.0);
}
