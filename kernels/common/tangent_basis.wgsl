// common/tangent_basis.wgsl — the tangent frame around a unit normal n that every cone set and radiance
// cache uses: t = normalize(cross(up, n)) with up = z, or x where |n.z| >= 0.999; b = cross(n, t).
// Included by the cone tracers (common/cone_march.wgsl's pixel entry), cache_creation and
// gather_caches. Mirror: cpu_mirror/src/cone_trace.rs `basis`.

struct TangentBasis {
    t: vec3<f32>,
    b: vec3<f32>,
}

fn tangent_basis(n: vec3<f32>) -> TangentBasis {
    var up = vec3<f32>(0.0, 0.0, 1.0);
    if (abs(n.z) >= 0.999) {
        up = vec3<f32>(1.0, 0.0, 0.0);
    }
    let tt = cross(up, n);
    let t = tt * (1.0 / sqrt(dot(tt, tt)));
    return TangentBasis(t, cross(n, t));
}
