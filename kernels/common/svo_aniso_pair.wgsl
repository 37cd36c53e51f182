// The octree's directional values as svo_cone_trace reads them where they fit two storage bindings
// (a pool past one comes as two windows of one buffer: value i is aniso[i], or aniso_1[i - L],
// L = arrayLength(&aniso); the second is one unused value where the pool fits one); past two,
// common/svo_aniso_windows.wgsl (svo_cone_trace_windowed), through the same function.
@group(0) @binding(14) var<storage, read> aniso: array<vec4<f32>>;
@group(0) @binding(26) var<storage, read> aniso_1: array<vec4<f32>>;

fn aniso_load(i: u32) -> vec4<f32> {
    let l = arrayLength(&aniso);
    if (i < l) {
        return aniso[i];
    }
    return aniso_1[i - l];
}
