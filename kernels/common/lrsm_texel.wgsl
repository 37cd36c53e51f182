// common/lrsm_texel.wgsl — how an LRSM texel is stored (included by lrsm_partition, lrsm_prefilter and,
// with common/lrsm_sample.wgsl, by the kernels that sample an LRSM). Mirror:
// cpu_mirror/src/lrsm_prefilter.rs (`pack`, `unpack`, `quantize`).
//
// A texel of one stream (radiance, normal or moments: four values each) is two u32 words of two
// binary16 values (pack2x16float: x, y in the first word, z, w in the second): 24 bytes a texel over
// the three streams, the 16-bit channels of the paper's Table 1. Values are clamped to binary16's
// finite range first (only radiance can exceed it; pack2x16float's result is indeterminate past it).
// Accuracy: WGSL lets the f32 -> binary16 rounding take either neighbour and flush binary16
// subnormals; unpacking is exact.

const LRSM_HALF_MAX: f32 = 65504.0;

fn lrsm_pack(v: vec4<f32>) -> vec2<u32> {
    let c = clamp(v, vec4<f32>(-LRSM_HALF_MAX), vec4<f32>(LRSM_HALF_MAX));
    return vec2<u32>(pack2x16float(c.xy), pack2x16float(c.zw));
}

fn lrsm_unpack(w: vec2<u32>) -> vec4<f32> {
    return vec4<f32>(unpack2x16float(w.x), unpack2x16float(w.y));
}
