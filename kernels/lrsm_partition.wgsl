// lrsm_partition — split a reflective shadow map into depth x <n.l> layers at quarter resolution
// (Sugihara et al. 2014, "Layered Reflective Shadow Maps", sections 4.3 and 5, Table 1).
// Mirror: cpu_mirror/src/lrsm_partition.rs. Declaration: src/kernels/lrsm_partition.rs.
//
// Input RSM, side 2s, in 2D Morton order (index bit 2k = x bit k, 2k+1 = y bit k), so texels 4q .. 4q+4
// form the 2x2 quad q. Per texel:
//   rsm_radiance = (rho Ld <n.l> / pi, coverage)   coverage 1 where the light sees geometry, else 0
//   rsm_normal   = (n, <n.l>)
//   rsm_depth    = z                               light-space depth normalised to [0, 1]
// depth_ranges[d] = (zmin, zmax, 1 / (zmax - zmin), 0) of depth slice d (overlapping its neighbours; the
// host builds and validates them). Layers: L = d * normal_slices + j, with the <n.l> slice
//   j = min(u32(max(<n.l>, 0) * normal_slices), normal_slices - 1).
// Output (LRSM level 0, layer-major, layer L quad q at L * layer_texels + q; same streams as
// lrsm_prefilter): for each quad and layer, the member texels (coverage > 0.5, slice j, zmin <= z <= zmax)
// summed in texel order 0..3 and scaled by 1/4 — the opacity-weighted average over the quad, so texels of
// one layer are merged and empty texels cancel after normalising by opacity:
//   out_radiance = (sum R, count) / 4, out_normal = (sum n, count) / 4,
//   out_moments  = (sum z', sum z'^2, count, 0) / 4,   z' = (z - zmin) * inv_range  (warped to [0, 1])
// each stored as binary16 (common/lrsm_texel.wgsl). With params.area_weights = 1 each member texel's
// radiance and moment terms (the counts in w included) weigh a = 1 / max(<n.l>, 1e-3), the area of
// surface it stands for per unit of the light's image (eq. 3's Jacobian before filtering): the
// filtered radiance, opacity and moments are then area-weighted; a texel whose <n.l> is not above 0
// (the RSM stores max(<n.l>, 0): it faces away from the light) holds no lit surface and weighs 0.
// The normal stream stays as above.
// One invocation per quad; it writes that quad's texel in every layer.
// Accuracy: subtraction, products and adds are correctly rounded and * 0.25 exact: radiance and normal
// are exact in f32; the z'^2 accumulation may be fused into an FMA (allowed by WGSL), which moves each
// of three nonnegative partial sums by at most 1 ULP: moments within 4 f32 ULP. With area weights the
// division 1 / c is within 2.5 ULP and each weighted term may fuse with its sum: every term and sum is
// nonnegative (R >= 0, z' >= 0 for members, a > 0), so each value is within 9 f32 ULP relative. Either
// is then rounded to binary16 either way: within 1 binary16 ULP of the mirror's round-to-nearest (an
// f32 difference far below a binary16 ULP cannot cross more than one binary16 rounding boundary).

struct PartitionParams {
    depth_slices: u32,
    normal_slices: u32,
    layer_texels: u32,
    area_weights: u32,
}

@group(0) @binding(0) var<uniform> params: PartitionParams;
@group(0) @binding(1) var<storage, read> depth_ranges: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rsm_radiance: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> rsm_normal: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> rsm_depth: array<f32>;
@group(0) @binding(5) var<storage, read_write> out_radiance: array<vec2<u32>>;
@group(0) @binding(6) var<storage, read_write> out_normal: array<vec2<u32>>;
@group(0) @binding(7) var<storage, read_write> out_moments: array<vec2<u32>>;

// The smallest <n.l> an area weight divides by (mirror: lrsm_partition::MIN_COSINE).
const MIN_COSINE: f32 = 1.0e-3;

fn normal_slice(ndotl: f32) -> u32 {
    return min(u32(max(ndotl, 0.0) * f32(params.normal_slices)), params.normal_slices - 1u);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let q = gid.x + gid.y * groups.x * 64u;
    if (q >= params.layer_texels) {
        return;
    }
    for (var d = 0u; d < params.depth_slices; d = d + 1u) {
        let range = depth_ranges[d];
        for (var j = 0u; j < params.normal_slices; j = j + 1u) {
            var r = vec4<f32>(0.0);
            var n = vec4<f32>(0.0);
            var m = vec4<f32>(0.0);
            for (var k = 0u; k < 4u; k = k + 1u) {
                let t = 4u * q + k;
                let rad = rsm_radiance[t];
                let nrm = rsm_normal[t];
                let z = rsm_depth[t];
                if (rad.w > 0.5 && normal_slice(nrm.w) == j && z >= range.x && z <= range.y) {
                    let zw = (z - range.x) * range.z;
                    // A texel facing away from the light (<n.l> stored as 0) holds no lit surface.
                    let lit = select(0.0, 1.0 / max(nrm.w, MIN_COSINE), nrm.w > 0.0);
                    let a = select(1.0, lit, params.area_weights != 0u);
                    r = r + vec4<f32>(rad.xyz, 1.0) * a;
                    n = n + vec4<f32>(nrm.xyz, 1.0);
                    m = m + vec4<f32>(zw, zw * zw, 1.0, 0.0) * a;
                }
            }
            let out = (d * params.normal_slices + j) * params.layer_texels + q;
            out_radiance[out] = lrsm_pack(r * 0.25);
            out_normal[out] = lrsm_pack(n * 0.25);
            out_moments[out] = lrsm_pack(m * 0.25);
        }
    }
}
