// surface_coverage_mip — one mip level of a dense voxel grid with surface-coverage alpha
// (Rehfeld et al. 2014, "Clustered Pre-convolved Radiance Caching", section 3.1 "Pre-filtered Hierarchy").
// Mirror: cpu_mirror/src/surface_coverage_mip.rs. Declaration: src/kernels/surface_coverage_mip.rs.
//
// Layout. A level of side n is n^3 voxels in Morton (Z-order) index order: bit 3k of the index is bit k
// of x, 3k+1 of y, 3k+2 of z. The eight children of parent p are then src[8p .. 8p+8], so a level is a
// 1D reduction and contiguous in memory; a level too large for one storage binding (256^3 x 16 B =
// 256 MiB, lavapipe binds at most 128 MiB) is dispatched over contiguous windows of src/dst with
// bound buffer ranges. f32 throughout, so the mirror can reproduce the arithmetic bit for bit.
//
// Per voxel, two vec4<f32>:
//   colour = (C.rgb, alpha)   C = colour (albedo or radiance) pre-multiplied by alpha, alpha in [0, 1]
//   normal = (N.xyz, w)       N = average surface normal pre-multiplied by alpha (not renormalised: its
//                             length falls where normals disagree); w a free channel filtered like N
// Inputs must be finite; alpha in [0, 1].
//
// Definition. sc = sum of the 8 children's colour, sn = sum of their normal, each summed left to right
// in child order 0..7 (vec4 adds). Then
//   surface coverage (params.coverage == 0u):
//     alpha_p = min(sc.a * 0.25, 1)            "1/4 of the sum of the source voxels' alpha", clamped
//     C_p     = sc.rgb / max(sc.a, 4)          = (alpha-weighted mean colour) * clamped alpha,
//     N_p     = sn     / max(sc.a, 4)            since min(1, s/4) / s = 1 / max(s, 4)
//   volume coverage (params.coverage == 1u), the naive average the paper argues against:
//     (C_p, alpha_p) = sc * 0.125,  N_p = sn * 0.125
// Accuracy (WGSL 1.0 "Floating Point Accuracy"): + and * are correctly rounded and * 0.25 / * 0.125 are
// exact for normal results, so alpha is exact and volume coverage is exact; x / y is within 2.5 ULP for
// y in [2^-126, 2^126] (here y >= 4), so surface-coverage C and N are within 3 ULP. A GPU may flush
// subnormal inputs, intermediates and results to zero.
//
// Dispatch: one invocation per parent (element of dst_colour), workgroups of 64 along x; past 65535
// workgroups the grid is x * y and the index is gid.x + gid.y * num_workgroups.x * 64.

struct MipParams {
    coverage: u32,
}

@group(0) @binding(0) var<uniform> params: MipParams;
@group(0) @binding(1) var<storage, read> src_colour: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> src_normal: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> dst_colour: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> dst_normal: array<vec4<f32>>;

const SURFACE: u32 = 0u;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = gid.x + gid.y * groups.x * 64u;
    if (p >= arrayLength(&dst_colour)) {
        return;
    }
    let first = 8u * p;
    var sc = src_colour[first];
    var sn = src_normal[first];
    for (var k = 1u; k < 8u; k = k + 1u) {
        sc = sc + src_colour[first + k];
        sn = sn + src_normal[first + k];
    }
    if (params.coverage == SURFACE) {
        let d = max(sc.w, 4.0);
        dst_colour[p] = vec4<f32>(sc.xyz / d, min(sc.w * 0.25, 1.0));
        dst_normal[p] = sn / d;
    } else {
        dst_colour[p] = sc * 0.125;
        dst_normal[p] = sn * 0.125;
    }
}
