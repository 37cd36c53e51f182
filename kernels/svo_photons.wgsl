// svo_photons — vct-svo's light injection (Crassin et al. 2011, 8.2): one photon per texel of a map
// rendered from the light (the light-view G-buffer gbuffer.wgsl ray-casts with the view's frame),
// landing in the voxel its surface point lies in; sparse_voxel_octree's splat then adds the photons of
// a leaf together. Mirror: cpu_mirror/src/svo_photons.rs (the derivation). Declaration:
// src/kernels/svo_photons.rs. Uses common/lights.wgsl (the light contract's `incident`) and
// common/scene_types.wgsl (Triangle, Material).
//
// One invocation per texel i (row-major):
//   nothing hit or a back face (gb_normal.w <= 0): photon_pos = 0, photon_value = 0;
//   else photon_pos = (clamp(floor((p - origin) / h), 0, side - 1), 1) and
//     photon_value = (albedo * E * d^2 omega * |n|_1 / (pi h^2), 0): the texel's reflected flux spread
//     over the mean surface area a cell of size h holds (h^2 / |n|_1), d^2 omega = s^2 zv^3 / d
//     (perspective; zv the depth along the axis) or s^2 (orthographic).
//   photon_spec (glossy surfaces: the texel's material has Ks; else 0): (m r w, w), the light's mirror
//     direction r = 2 (n.wi) n - wi (wi towards the light) scaled by the Phong lobe's mean length
//     m = Ns / (Ns + 1) (a vMF of concentration Ns has mean length ~ 1 - 1/Ns), weighted by the
//     specular flux w = lum(Ks E) d^2 omega |n|_1 / h^2 (the value's scale without 1/pi: the lobe's
//     density carries the per-steradian part). svo_cone_trace's glossy voxels (the incoming light as a
//     direction distribution, VCT 7, reflected at injection where the surface normal is exact).
// Accuracy: photon_pos exact (one subtraction and one multiplication per axis, both correctly rounded,
// then floor); photon_value within the mirror's per-texel bound (64 ULP, the depth's cancellation, a
// spot's soft edge); photon_spec within the mirror's bound (the same terms, the mirror direction's few
// ULP).

struct PhotonParams {
    eye: vec4<f32>,     // w = texel area s^2
    forward: vec4<f32>, // unit axis
    grid: vec4<f32>,    // origin; w = 1 / h
    info: vec4<u32>,    // view side, light index, grid side, projection (0 perspective, 1 orthographic)
}

@group(0) @binding(0) var<storage, read> params: PhotonParams;
@group(0) @binding(1) var<storage, read> lights: array<Light>;
@group(0) @binding(2) var<storage, read> gb_position: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> gb_normal: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> gb_albedo: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> photon_pos: array<vec4<u32>>;
@group(0) @binding(6) var<storage, read_write> photon_value: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> gb_triangle: array<u32>;
@group(0) @binding(8) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(9) var<storage, read> materials: array<Material>;
@group(0) @binding(10) var<storage, read_write> photon_spec: array<vec4<f32>>;

const PI: f32 = 3.14159265358979;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= arrayLength(&photon_pos)) {
        return;
    }
    let nrm = gb_normal[i];
    if (nrm.w <= 0.0) {
        photon_pos[i] = vec4<u32>(0u);
        photon_value[i] = vec4<f32>(0.0);
        photon_spec[i] = vec4<f32>(0.0);
        return;
    }
    let p = gb_position[i].xyz;
    let inv_h = params.grid.w;
    let cell = (p - params.grid.xyz) * inv_h;
    let top = f32(params.info.z - 1u);
    let v = clamp(floor(cell), vec3<f32>(0.0), vec3<f32>(top));
    photon_pos[i] = vec4<u32>(vec3<u32>(v), 1u);

    let inc = incident(lights[params.info.y], p);
    let rel = p - params.eye.xyz;
    let zv = dot(rel, params.forward.xyz);
    let d = sqrt(dot(rel, rel));
    var area = 0.0;
    if (params.info.w == 1u) {
        area = params.eye.w;
    } else if (zv > 0.0 && d > 0.0) {
        area = params.eye.w * (zv * zv * zv) / d;
    }
    let n = nrm.xyz;
    let l1 = (abs(n.x) + abs(n.y)) + abs(n.z);
    let scale = area * (l1 * (inv_h * inv_h * (1.0 / PI)));
    photon_value[i] = vec4<f32>(gb_albedo[i].xyz * inc.e * scale, 0.0);

    let mat = materials[min(u32(triangles[gb_triangle[i]].a.w), arrayLength(&materials) - 1u)];
    let ks = mat.specular.xyz;
    var spec = vec4<f32>(0.0);
    if (any(ks != vec3<f32>(0.0))) {
        let ns = max(mat.diffuse.w, 0.0);
        let m = ns / (ns + 1.0);
        let ke = ks * inc.e;
        let w = ((0.2126 * ke.x + 0.7152 * ke.y) + 0.0722 * ke.z) * (area * (l1 * (inv_h * inv_h)));
        let r = n * (2.0 * dot(n, inc.wi)) - inc.wi;
        spec = vec4<f32>(r * (m * w), w);
    }
    photon_spec[i] = spec;
}
