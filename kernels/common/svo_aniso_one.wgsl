// The octree's directional values as svo_cone_trace reads them where they fit one storage binding;
// past one, common/svo_aniso_windows.wgsl (svo_cone_trace_windowed), through the same function.
@group(0) @binding(14) var<storage, read> aniso: array<vec4<f32>>;

fn aniso_load(i: u32) -> vec4<f32> {
    return aniso[i];
}
