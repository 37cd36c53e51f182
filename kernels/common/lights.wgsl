// common/lights.wgsl — what reaches a point from one light (the light-transport contract).
// Mirror: cpu_mirror/src/direct_light.rs (`incident`, `spot_factor`). Included by direct_light.wgsl and
// voxel_light.wgsl.
//
// point: wi = towards the light, irradiance scale I / r^2, shadow ray to r; spot: the same times
// spot_factor (1 inside falloff, 0 outside cone, smoothstep in cosine between); directional: wi = -dir,
// I, shadow ray to 3e38. The cosine is the caller's.

struct Light {
    position: vec4<f32>,   // w = kind: 0 point, 1 spot, 2 directional
    direction: vec4<f32>,  // unit travel direction; w = cos(cone)
    intensity: vec4<f32>,  // w = cos(falloff)
}

struct Incident {
    wi: vec3<f32>,
    e: vec3<f32>,
    t_max: f32,
}

fn spot_factor(cos_a: f32, cos_cone: f32, cos_falloff: f32) -> f32 {
    if (cos_a >= cos_falloff) {
        return 1.0;
    }
    if (cos_a < cos_cone) {
        return 0.0;
    }
    let t = clamp((cos_a - cos_cone) / (cos_falloff - cos_cone), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

fn incident(light: Light, p: vec3<f32>) -> Incident {
    if (light.position.w == 2.0) {
        return Incident(-light.direction.xyz, light.intensity.xyz, 3.0e38);
    }
    let lv = light.position.xyz - p;
    let r2 = dot(lv, lv);
    let r = sqrt(r2);
    let wi = lv / r;
    var e = light.intensity.xyz / r2;
    if (light.position.w == 1.0) {
        e = e * spot_factor(-dot(wi, light.direction.xyz), light.direction.w, light.intensity.w);
    }
    return Incident(wi, e, r);
}
