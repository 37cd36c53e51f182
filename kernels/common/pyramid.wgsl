// common/pyramid.wgsl — the dense radiance pyramid as the volume common/cone_march.wgsl samples: the
// cone's grid (cone.origin, cone.inv_s0, cone.side), trilinear within a level via
// common/pyramid_grid.wgsl. Included by cone_trace (per pixel) and cache_creation (per radiance-cache
// texel). Mirror: cpu_mirror/src/cone_trace.rs (`Pyramid`).

fn sample_level(x: vec3<f32>, l: u32) -> vec4<f32> {
    return sample_grid(x, l, cone.origin.xyz, cone.inv_s0, cone.side, 0u);
}

// The march's sample: the volume's own radiance (see common/cone_march.wgsl).
fn sample_cone(x: vec3<f32>, l: f32, diam: f32, d: vec3<f32>, tan_half: f32) -> vec4<f32> {
    return sample_volume(x, l);
}
