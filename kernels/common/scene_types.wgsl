// common/scene_types.wgsl — the scene's camera, triangle and material records as the host uploads
// them (vxgi::trace::SceneData; mirrors: vxgi_cpu_mirror::gbuffer::Frame,
// vxgi_cpu_mirror::bvh_trace::GpuTriangle, vxgi_cpu_mirror::direct_light::GpuMaterial). Included by
// every kernel that reads the camera `frame`, `triangles` or `materials` (with common/bvh_trace.wgsl,
// common/cone_march.wgsl, and svo_photons.wgsl).

// The camera: forward unit, right and up scaled by tan(fov / 2) (and the aspect), a pixel's ray
// forward + right * ndc.x + up * ndc.y (vxgi::trace::camera_frame).
struct Frame {
    eye: vec4<f32>,      // w = ray offset epsilon
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    size: vec4<u32>,     // width, height, light count, projection (0 perspective, 1 orthographic)
}

struct Triangle {
    a: vec4<f32>,   // w = material index
    b: vec4<f32>,
    c: vec4<f32>,
    na: vec4<f32>,
    nb: vec4<f32>,
    nc: vec4<f32>,
}

// diffuse.w = Phong exponent; texture = (first atlas texel, width, height, 0) of the map_Kd texture
// that replaces diffuse.rgb (width 0: none; gbuffer.wgsl reads it into gb_albedo).
struct Material {
    diffuse: vec4<f32>,
    specular: vec4<f32>,
    texture: vec4<u32>,
}
