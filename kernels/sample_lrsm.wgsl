// sample_lrsm — Algorithm 1 "Sample LRSM" of Sugihara et al. 2014 ("Layered Reflective Shadow Maps"):
// the outgoing radiance of cone samples from the layers of a pre-filtered LRSM (eq. 5, 8, 12, 14, 15).
// Mirror: cpu_mirror/src/sample_lrsm.rs. Declaration: src/kernels/sample_lrsm.rs.
// Uses kernels/common/lrsm_sample.wgsl (the per-sample algorithm), common/lrsm_texel.wgsl and
// common/lrsm_math.wgsl.
//
// LRSM (written by lrsm_partition + lrsm_prefilter): levels 0..levels-1 concatenated; level k holds
// layers = depth_slices * normal_slices layers of side s_k = side0 >> k, layer-major, 2D Morton order
// within a layer. Streams radiance = (A R, A), normal = (A n, A), moments = (A z', A z'^2, A, 0), z' the
// depth warped into the layer by depth_ranges[d] = (zmin, zmax, 1 / (zmax - zmin), 0); each texel stored
// as binary16 (common/lrsm_texel.wgsl; unpacked exactly, so the bound is that of f32 inputs).
// Per cone sample i: cone_pos[i] = (u, v, mip, zc): the cone sample projected into the RSM ([0, 1]^2),
// its mip level (log2 of the projected diameter in level-0 texels), and its light-space depth; any
// finite values (coordinates outside [0, 1] clamp to the edge, mips to the chain; NaN's clamping is
// implementation-defined in WGSL, so a NaN coordinate reads a texel the mirror need not pick);
// cone_dir[i] = (vc, rc): unit direction from the sample towards the view sample, and the sample's
// radius in light-space depth units.
// Fetch: trilinear, as the paper's filtered texture reads at mipLevel = log(d_circle) (section 5): the
// two levels around max(mip, 0) (the last level alone past the chain), in each the 2 x 2 texels around
// (u, v) clamped to the edge, weights and sums in WGSL arithmetic (`lrsm_taps`, common/lrsm_sample.wgsl;
// the mirror weighs with the same bits, the sums may round or fuse differently).
// For every layer (d, j) whose depth range contains zc (Algorithm 1's test; layers outside are not
// sampled):  N = dot(n / A_n, vc) (eq. 8, normal normalised by opacity; skipped when A_n <= min_alpha);
// if N > 0: V = eq. 12 on the layer's moments with zc, rc warped into the layer; if V > 0:
// L += f(zc) * r * V * N' with r = A R (already opacity-weighted = A of eq. 14), f of eq. 15, and
// N' = N with params.view_weight = 1 (Algorithm 1 as written), else min(N / LRSM_CULL_RAMP, 1) (N only
// culls back faces, continuously over the last 1.8 degrees before edge-on: eq. 2's
// view weight w' = w V(x,v) <n.v> stands in its numerator and denominator, so for one surface it
// cancels, and the paper itself introduces N to approximate backface culling; weighing by it too
// darkens every sample by the cosine it is seen at, a factor 1.8 of the Cornell box's indirect energy,
// docs/accuracy/lrsm.md).
// Output radiance[i] = (L, number of layers whose depth range contains zc).
// Accuracy: a per-element bound from the WGSL rules on this path (see sample_bound in the mirror).

@group(0) @binding(0) var<uniform> params: SampleParams;
@group(0) @binding(1) var<storage, read> depth_ranges: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> lrsm_radiance: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read> lrsm_normal: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read> lrsm_moments: array<vec2<u32>>;
@group(0) @binding(5) var<storage, read> cone_pos: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> cone_dir: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> radiance: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= arrayLength(&radiance)) {
        return;
    }
    let pos = cone_pos[i];
    let dir = cone_dir[i];
    radiance[i] = lrsm_sample(pos, dir, 0u);
}
