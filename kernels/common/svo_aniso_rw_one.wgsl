// The octree's directional values as svo_anisotropic writes them where they fit one storage binding;
// past one, common/svo_aniso_rw.wgsl, through the same two functions.
@group(0) @binding(3) var<storage, read_write> aniso: array<vec4<f32>>;

fn aniso_load(i: u32) -> vec4<f32> {
    return aniso[i];
}

fn aniso_store(i: u32, v: vec4<f32>) {
    aniso[i] = v;
}
