// cache_creation — radiance-cache creation (Rehfeld et al. 2014, 3.1 "Creation"): one cone per cache
// texel, cone-marched through the pre-filtered voxel pyramid with the section 4 rules (the march of
// kernels/common/cone_march.wgsl over the pyramid of kernels/common/pyramid.wgsl).
// Mirror: cpu_mirror/src/cache_creation.rs (its module comment defines the parameterisation).
//
// caches[2c] = (origin xyz, 0): the cache pixel's position moved offset_voxels * s0 along its normal;
// caches[2c + 1] = (normal xyz, 0). texel_dirs[t] = texel t's tangent-space direction (xyz; z = the
// cache normal) and solid angle (w), a host table: hemi-octahedral, res x res, row-major.
// One invocation per (cache, texel): index c * texels + t marches from the origin along
// bt x + bb y + n z (the pixel entry's tangent basis) with half-angle tan_half (the mean texel's solid
// angle) and writes cache_radiance[index] = (radiance rgb, 0). A cache whose caches[2c + 1].w is not
// 0 is skipped: its texels were carried from the last frame (cache_reuse's keep, when the volume is
// unchanged) and stay as they are.
// Accuracy: cone_trace's march bound (MAG of the accumulated magnitudes, allowances where a stop is
// within rounding of its threshold).

struct CacheParams {
    count: u32,
    texels: u32,
    tan_half: f32,
    _pad: u32,
}

@group(0) @binding(12) var<uniform> cache_params: CacheParams;
@group(0) @binding(13) var<storage, read> caches: array<vec4<f32>>;
@group(0) @binding(14) var<storage, read> texel_dirs: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read_write> cache_radiance: array<vec4<f32>>;

@compute @workgroup_size(64)
fn create(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= cache_params.count * cache_params.texels) {
        return;
    }
    let c = i / cache_params.texels;
    let record = caches[2u * c + 1u];
    if (record.w != 0.0) {
        return;
    }
    let td = texel_dirs[i % cache_params.texels];
    let o = caches[2u * c].xyz;
    let n = record.xyz;
    let basis = tangent_basis(n);
    let bt = basis.t;
    let bb = basis.b;
    let d = bt * td.x + bb * td.y + n * td.z;
    let r = march(o, d, cache_params.tan_half, td.z);
    cache_radiance[i] = vec4<f32>(r.radiance, 0.0);
}
