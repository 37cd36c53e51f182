// layer_decay — LRSM eq. 15 (Sugihara et al. 2014, section 4.3): the weight of one LRSM layer at cone-sample
// depth zc, smoothly decaying across the layer's overlap regions. Mirror: cpu_mirror/src/layer_decay.rs.
// Declaration: src/kernels/layer_decay.rs.
//
// Per element: sample[i] = (zc, zmin, zmax, delta): the cone sample's depth, the layer's depth range
// [zmin, zmax] (including its overlaps) and the overlap width delta, all in the same depth units.
//   decay[i] = min(k((zc - zmin) / delta), k((zmax - zc) / delta)),   k(x) = t * t * (3 - 2 t),
//   t = clamp(x, 0, 1)
// k is smooth, clamped to [0, 1], and k(x) + k(1 - x) = 1: two layers overlapping by exactly delta get
// weights summing to one across the overlap. For zmax - zmin >= 2 delta this is eq. 15 piece by piece (1 on
// the plateau, k(...) on each ramp); for narrower layers the min keeps it defined. delta <= 0: the step
// zmin <= zc <= zmax. Inputs must be finite (the partition refuses NaN at the API boundary).
// Accuracy: zc - zmin rounds once (0.5 ULP of the difference), / delta 2.5 ULP, so t is within 3 ULP;
// |dk/dt| t / k <= 2 propagates that to 6 ULP; t * t, 3 - 2t (>= 1, no cancellation) and the product
// add 1.5 ULP (fused or not); min and clamp are exact -> 8 ULP.
// The arithmetic lives in kernels/common/lrsm_math.wgsl (shared with sample_lrsm.wgsl).

@group(0) @binding(0) var<storage, read> sample: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> decay: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= arrayLength(&decay)) {
        return;
    }
    let s = sample[i];
    decay[i] = lrsm_layer_decay(s.x, s.y, s.z, s.w);
}
