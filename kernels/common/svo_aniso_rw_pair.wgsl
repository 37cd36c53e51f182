// The octree's directional values as svo_anisotropic writes them where they fit two storage bindings
// (a pool past one comes as two windows of one buffer: value i is aniso[i], or aniso_1[i - L],
// L = arrayLength(&aniso); the second is one unused value where the pool fits one); past two,
// common/svo_aniso_rw.wgsl (svo_anisotropic_windowed), through the same two functions.
@group(0) @binding(3) var<storage, read_write> aniso: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> aniso_1: array<vec4<f32>>;

fn aniso_load(i: u32) -> vec4<f32> {
    let l = arrayLength(&aniso);
    if (i < l) {
        return aniso[i];
    }
    return aniso_1[i - l];
}

fn aniso_store(i: u32, v: vec4<f32>) {
    let l = arrayLength(&aniso);
    if (i < l) {
        aniso[i] = v;
    } else {
        aniso_1[i - l] = v;
    }
}
