// svo_photons — vct-svo's light injection (Crassin et al. 2011, 8.2): one photon per texel of a map
// rendered from the light (the light-view G-buffer gbuffer.wgsl ray-casts with the view's frame),
// landing in the voxel its surface point lies in; sparse_voxel_octree's splat then adds the photons of
// a leaf together. Mirror: cpu_mirror/src/svo_photons.rs (the derivation). Declaration:
// src/kernels/svo_photons.rs. Uses common/lights.wgsl (the light contract's `incident`) and
// common/scene_types.wgsl (Triangle, Material).
//
// One invocation per texel i (row-major):
//   nothing hit or a back face (gb_normal.w <= 0): photon_pos = 0, photon_value = 0;
//   else photon_pos = (v, 1), v = clamp(floor((p - origin) / h), 0, side - 1), and
//     photon_value = (albedo * E * share / pi, 0) with share = d^2 omega / max(A, MIN_AREA h^2): the
//     texel's reflected flux over A, the area of its plane (p and its normal) inside its voxel
//     (cell_area), so that a voxel's photons add to the radiance of the surface in it whatever share
//     of the voxel that surface takes (the octree's alpha is voxelize's, 1 wherever a surface was
//     sampled), on average where the texels are coarser than the voxels; d^2 omega = s^2 zv^3 / d
//     (perspective; zv the depth along the axis) or s^2 (orthographic).
//   photon_spec (glossy surfaces: the texel's material has Ks; else 0): (m r w, w), the light's mirror
//     direction r = 2 (n.wi) n - wi (wi towards the light) scaled by the Phong lobe's mean length
//     m = Ns / (Ns + 1) (a vMF of concentration Ns has mean length ~ 1 - 1/Ns), weighted by the
//     specular flux w = lum(Ks E) share (the value's scale without 1/pi: the lobe's density carries
//     the per-steradian part). svo_cone_trace's glossy voxels (the incoming light as a
//     direction distribution, VCT 7, reflected at injection where the surface normal is exact).
// Accuracy: photon_pos exact (one subtraction and one multiplication per axis, both correctly rounded,
// then floor); photon_value within the mirror's per-texel bound (64 ULP, the depth's cancellation, a
// spot's soft edge, and the share's range: cell_area's offset d is three products and two sums that
// may contract, and strip is monotone, so its range over d's error bounds it); photon_spec within the
// mirror's bound (the same terms, the mirror direction's few ULP).

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
// The least area of a plane in its cell a photon's flux is spread over, in faces (the mirror's
// MIN_AREA: a sliver a plane cuts off a cell's corner does not take a flux over almost no area).
const MIN_AREA: f32 = 0.125;
// cell_area's exact decisions (the mirror's constants, with their reasons): a largest component
// below LEAST_COMPONENT is no plane's; (a + b) 2^16 <= c is along a face; a <= b 2^-24 is dropped.
const LEAST_COMPONENT: f32 = 0x1p-8f;
const ALONG_A_FACE: f32 = 65536.0;
const NEGLIGIBLE: f32 = 0x1p-24f;

// The area of {(x, y) in [0, 1]^2 : a x + b y <= s}, 0 <= a <= b, b > 0; piecewise without
// cancellation.
fn strip(s: f32, a: f32, b: f32) -> f32 {
    if (s >= a + b) {
        return 1.0;
    }
    if (s <= 0.0) {
        return 0.0;
    }
    if (s < a) {
        return s * s / (2.0 * a * b);
    }
    if (s <= b) {
        return (s - 0.5 * a) / b;
    }
    let t = (a + b) - s;
    return 1.0 - t * t / (2.0 * a * b);
}

// The area of the plane through q with normal n inside the unit cell [0, 1]^3: mirrored so that every
// component of n is >= 0 (q_k -> 1 - q_k), sorted a <= b <= c, the piece projects along the largest
// component onto the strip d - c <= a x + b y <= d of the unit square, over the cosine c / |n|; q in
// the cell. A plane along a face has the face's area over the cosine wherever it lies in the cell,
// either face included: a photon on a face lands in the cell floor gives it.
fn cell_area(q: vec3<f32>, n: vec3<f32>) -> f32 {
    let m = abs(n);
    var a = min(min(m.x, m.y), m.z);
    let c = max(max(m.x, m.y), m.z);
    let b = max(min(m.x, m.y), min(max(m.x, m.y), m.z));
    if (c < LEAST_COMPONENT) {
        return 0.0;
    }
    let k = sqrt(dot(n, n)) / c;
    if ((a + b) * ALONG_A_FACE <= c) {
        return k;
    }
    if (a <= b * NEGLIGIBLE) {
        a = 0.0;
    }
    let qm = select(q, vec3<f32>(1.0) - q, n < vec3<f32>(0.0));
    let d = (m.x * qm.x + m.y * qm.y) + m.z * qm.z;
    return k * (strip(d, a, b) - strip(d - c, a, b));
}

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
    // The texel's share: its flux over its plane's area in the cell, that area at least MIN_AREA.
    // A point past the grid (a hit a rounding outside it) is taken onto the cell it is clamped to.
    let q = clamp(cell - v, vec3<f32>(0.0), vec3<f32>(1.0));
    let share = area * (inv_h * inv_h) / max(cell_area(q, n), MIN_AREA);
    let scale = share * (1.0 / PI);
    photon_value[i] = vec4<f32>(gb_albedo[i].xyz * inc.e * scale, 0.0);

    let mat = materials[min(u32(triangles[gb_triangle[i]].a.w), arrayLength(&materials) - 1u)];
    let ks = mat.specular.xyz;
    var spec = vec4<f32>(0.0);
    if (any(ks != vec3<f32>(0.0))) {
        let ns = max(mat.diffuse.w, 0.0);
        let m = ns / (ns + 1.0);
        let ke = ks * inc.e;
        let w = ((0.2126 * ke.x + 0.7152 * ke.y) + 0.0722 * ke.z) * share;
        let r = n * (2.0 * dot(n, inc.wi)) - inc.wi;
        spec = vec4<f32>(r * (m * w), w);
    }
    photon_spec[i] = spec;
}
