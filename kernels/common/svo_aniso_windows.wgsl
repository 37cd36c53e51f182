// The octree's directional values (svo_anisotropic) as svo_cone_trace_windowed reads them: up to six
// windows of one buffer, for values past two storage bindings (or bricks past one). Value i is in
// window i / L, L = arrayLength(&aniso): every window but the last is full; the windows the pool
// does not reach are one unused value each. svo_cone_trace reads up to two bindings
// (common/svo_aniso_pair.wgsl): a branch per window in its march costs lavapipe about twice the
// pass where no pool needs more.
@group(0) @binding(14) var<storage, read> aniso: array<vec4<f32>>;
@group(0) @binding(26) var<storage, read> aniso_1: array<vec4<f32>>;
@group(0) @binding(27) var<storage, read> aniso_2: array<vec4<f32>>;
@group(0) @binding(28) var<storage, read> aniso_3: array<vec4<f32>>;
@group(0) @binding(29) var<storage, read> aniso_4: array<vec4<f32>>;
@group(0) @binding(31) var<storage, read> aniso_5: array<vec4<f32>>;

fn aniso_load(i: u32) -> vec4<f32> {
    let l = arrayLength(&aniso);
    if (i < l) {
        return aniso[i];
    }
    var j = i - l;
    if (j < l) {
        return aniso_1[j];
    }
    j -= l;
    if (j < l) {
        return aniso_2[j];
    }
    j -= l;
    if (j < l) {
        return aniso_3[j];
    }
    j -= l;
    if (j < l) {
        return aniso_4[j];
    }
    return aniso_5[j - l];
}
