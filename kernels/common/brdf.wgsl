// common/brdf.wgsl — the light-transport contract's BRDF: kd / pi + ks (n + 2) / (2 pi) max(r . wo, 0)^n
// (r: the light's mirror direction about n). Mirror: cpu_mirror/src/direct_light.rs (`brdf`). Included
// by direct_light.wgsl and lrsm_cone_trace.wgsl (its shadow-cone entry); the including kernel defines
// `Material` and `PI`.

fn brdf(m: Material, n: vec3<f32>, wi: vec3<f32>, wo: vec3<f32>, cos: f32) -> vec3<f32> {
    let kd = m.diffuse.xyz * (1.0 / PI);
    let ks = m.specular.xyz;
    if (all(ks == vec3<f32>(0.0))) {
        return kd;
    }
    let shin = m.diffuse.w;
    let r = n * (2.0 * cos) - wi;
    let x = dot(r, wo);
    var lobe = 0.0;
    if (x > 0.0) {
        lobe = pow(x, shin);
    }
    return kd + ks * ((shin + 2.0) * (0.5 / PI) * lobe);
}
