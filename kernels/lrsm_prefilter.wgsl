// lrsm_prefilter — one mip level of every layer of a layered reflective shadow map (Sugihara et al. 2014,
// section 4.2 "Reflective Shadow Map Pre-filtering"; Table 1 layout with the opacity alpha carried in
// every stream). Mirror: cpu_mirror/src/lrsm_prefilter.rs. Declaration: src/kernels/lrsm_prefilter.rs.
//
// Layout. A level holds `layers` square layers of side s: index = layer * s^2 + morton2(x, y) (bit 2k of
// the Morton index is bit k of x, 2k+1 of y). Then the four children of parent P, whatever its layer,
// are src[4P .. 4P+4]: a level is a 1D reduction, and a level larger than one storage binding is
// dispatched over contiguous windows.
// Streams, opacity-weighted (A = fraction of the footprint this layer covers), as lrsm_partition writes
// them:
//   radiance = (A * reflected radiance rho Ld <n.l> / pi, A)
//   normal   = (A * n, A)
//   moments  = (A * z, A * z^2, A, 0)     z warped to [0, 1] within the layer's depth range
// Sampling divides normal and moments by A to cancel empty texels; radiance stays weighted (= A R of
// eq. 14), as Algorithm 1 says.
// Texels are stored as binary16 (common/lrsm_texel.wgsl).
// Definition: parent = (c0 + c1 + c2 + c3) * 0.25 on the unpacked children, adds left to right, stored
// as binary16. Accuracy: unpacking is exact, the adds are correctly rounded and * 0.25 is exact for
// normal results, so the f32 parent is the mirror's (a GPU may flush subnormals, which binary16 cannot
// hold anyway); its rounding to binary16 may take either neighbour: 1 binary16 ULP.

@group(0) @binding(0) var<storage, read> src_radiance: array<vec2<u32>>;
@group(0) @binding(1) var<storage, read> src_normal: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> src_moments: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read_write> dst_radiance: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read_write> dst_normal: array<vec2<u32>>;
@group(0) @binding(5) var<storage, read_write> dst_moments: array<vec2<u32>>;

fn box4(c0: vec2<u32>, c1: vec2<u32>, c2: vec2<u32>, c3: vec2<u32>) -> vec2<u32> {
    return lrsm_pack((((lrsm_unpack(c0) + lrsm_unpack(c1)) + lrsm_unpack(c2)) + lrsm_unpack(c3)) * 0.25);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = gid.x + gid.y * groups.x * 64u;
    if (p >= arrayLength(&dst_radiance)) {
        return;
    }
    let c = 4u * p;
    dst_radiance[p] = box4(src_radiance[c], src_radiance[c + 1u], src_radiance[c + 2u], src_radiance[c + 3u]);
    dst_normal[p] = box4(src_normal[c], src_normal[c + 1u], src_normal[c + 2u], src_normal[c + 3u]);
    dst_moments[p] = box4(src_moments[c], src_moments[c + 1u], src_moments[c + 2u], src_moments[c + 3u]);
}
