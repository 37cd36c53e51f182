// luminance: Rec. 709 relative luminance of linear RGB pixels, one invocation per pixel.
// Input rgb: vec4<f32> per pixel (w unused). Output luma: f32 per pixel,
//   luma = 0.2126 r + 0.7152 g + 0.0722 b, in that order.
@group(0) @binding(0) var<storage, read> rgb: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> luma: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= arrayLength(&luma)) {
        return;
    }
    let c = rgb[i];
    luma[i] = 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}
