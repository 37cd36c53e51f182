// The octree's directional values as svo_anisotropic_windowed writes values past two storage
// bindings (or with bricks past one): up to six windows of one buffer. Value i is in window i / L, L = arrayLength(&aniso) (every
// window but the last is full); the windows the pool does not reach are one unused value each.
@group(0) @binding(3) var<storage, read_write> aniso: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> aniso_1: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> aniso_2: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> aniso_3: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> aniso_4: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> aniso_5: array<vec4<f32>>;

fn aniso_load(i: u32) -> vec4<f32> {
    let l = arrayLength(&aniso);
    if (i < l) {
        return aniso[i];
    }
    let j = i % l;
    switch (i / l) {
        case 1u: { return aniso_1[j]; }
        case 2u: { return aniso_2[j]; }
        case 3u: { return aniso_3[j]; }
        case 4u: { return aniso_4[j]; }
        default: { return aniso_5[j]; }
    }
}

fn aniso_store(i: u32, v: vec4<f32>) {
    let l = arrayLength(&aniso);
    if (i < l) {
        aniso[i] = v;
        return;
    }
    let j = i % l;
    switch (i / l) {
        case 1u: { aniso_1[j] = v; }
        case 2u: { aniso_2[j] = v; }
        case 3u: { aniso_3[j] = v; }
        case 4u: { aniso_4[j] = v; }
        default: { aniso_5[j] = v; }
    }
}
