// `vxgi view`'s display pass: one frame's images (vec4<f32> per pixel, row by row from the top, as
// `Resident::present` leaves them) onto the window's surface with `vxgi render`'s PNG transform:
// the linear value clamped to [0, 1], then sRGB-encoded (here where the surface format stores what
// it is given, by the hardware where the format is sRGB). Not a verified kernel: a full-screen
// triangle whose fragments read one pixel each.

struct Params {
    // The frame's width and height in pixels.
    size: vec2<u32>,
    // 0 combined (direct + indirect), 1 direct, 2 indirect, 3 ambient occlusion.
    shown: u32,
    // 1: encode to sRGB here (a UNORM surface); 0: the surface format encodes.
    encode: u32,
    // The exposure the frame was rendered at, undone: radiance times this (AO is unitless).
    scale: f32,
    pad0: f32,
    pad1: f32,
    pad2: f32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> direct: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> indirect: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> ao: array<vec4<f32>>;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

// images.rs' srgb_encode.
fn srgb(x: f32) -> f32 {
    let c = clamp(x, 0.0, 1.0);
    if c <= 0.0031308 {
        return 12.92 * c;
    }
    return 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

@fragment
fn fs(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let x = u32(p.x);
    let y = u32(p.y);
    if x >= params.size.x || y >= params.size.y {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let i = y * params.size.x + x;
    var c: vec3<f32>;
    switch params.shown {
        case 0u: {
            c = (direct[i].rgb + indirect[i].rgb) * params.scale;
        }
        case 1u: {
            c = direct[i].rgb * params.scale;
        }
        case 2u: {
            c = indirect[i].rgb * params.scale;
        }
        default: {
            c = ao[i].rgb;
        }
    }
    c = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    if params.encode == 1u {
        c = vec3<f32>(srgb(c.r), srgb(c.g), srgb(c.b));
    }
    return vec4<f32>(c, 1.0);
}
