// common/lrsm_view.wgsl — one light view of the lrsm pipeline (a spot light's cone, one of a point
// light's six 90-degree cube faces, or a directional light's orthographic view of the scene).
// Mirror: GpuView in cpu_mirror/src/reflective_shadow_map.rs. Included by reflective_shadow_map.wgsl, lit_cells.wgsl and lrsm_cone_trace.wgsl.

struct LrsmView {
    eye: vec4<f32>,      // light position (orthographic: the image plane's centre); w = near
    forward: vec4<f32>,  // unit view axis; w = 1 / (far - near)
    right: vec4<f32>,    // unit right / tan(half fov) (orthographic: / half width); w = LRSM level-0
                         // texels per unit diameter at depth 1 (orthographic: at any depth)
    up: vec4<f32>,       // unit up / tan(half fov) (rows run down); w unused
    info: vec4<u32>,     // RSM side, light index, first texel of this view's LRSM, projection (0
                         // perspective, 1 orthographic: a directional light)
}

// Distance of p along the view's axis (unnormalised light-space depth), in a fixed order.
fn view_axis_depth(v: LrsmView, p: vec3<f32>) -> f32 {
    let rel = p - v.eye.xyz;
    let f = v.forward.xyz;
    return (rel.x * f.x + rel.y * f.y) + rel.z * f.z;
}

// Light-space depth of p normalised by the view's near and far (unclamped).
fn view_depth(v: LrsmView, p: vec3<f32>) -> f32 {
    return (view_axis_depth(v, p) - v.eye.w) * v.forward.w;
}

// One coordinate of an RSM texel from its index in the view's 2D Morton order (the even bits of the
// index: x; of the index >> 1: y). Integers only: exact.
fn compact2(v: u32) -> u32 {
    var x = v & 0x55555555u;
    x = (x | (x >> 1u)) & 0x33333333u;
    x = (x | (x >> 2u)) & 0x0f0f0f0fu;
    x = (x | (x >> 4u)) & 0x00ff00ffu;
    x = (x | (x >> 8u)) & 0x0000ffffu;
    return x;
}
