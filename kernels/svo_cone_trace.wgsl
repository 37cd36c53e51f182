// svo_cone_trace — cone_trace's tracer (kernels/common/cone_march.wgsl: AO, diffuse and glossy cones per
// G-buffer pixel, front-to-back, step-corrected alpha) reading the sparse voxel octree instead of the
// dense pyramid: the vct-svo pipeline's cone pass (Crassin et al. 2011, 5-7). Mirror:
// cpu_mirror/src/svo_cone_trace.rs. Node layout and descent: kernels/common/svo_node.wgsl.
//
// Volume: an octree of depth D built from the voxel grid of side 2^(D+1) (cone.side), one fragment per
// voxel at the leaf lattice point of its index, values (L * alpha, alpha) in u32 fixed point (times
// svo.inv_scale). Mip level l (cell s0 * 2^l, as the pyramid's) is octree level D - l, whose lattice
// points sit at origin + s0 / 2 + i s0 2^l (the voxel centres at l = 0); cone.levels = D + 1.
// sample_level: the level's lattice coordinate q = (x - origin) / (s0 2^l) - 1/2^(l+1), the node holding
// the cell floor(q) (clamped into the volume), trilinear over the cell's 8 brick voxels (points outside
// the lattice are empty; a missing node is empty: exact under the octree's halo rule). sample_volume:
// quadrilinear (common/cone_march.wgsl). Accuracy: the same per-element bound as
// cone_trace (the mirror's SampleError covers the sample point's rounding).

struct SvoParams {
    depth: u32,
    inv_scale: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(8) var<storage, read> nodes: array<Node>;
@group(0) @binding(12) var<storage, read> bricks: array<u32>;
@group(0) @binding(13) var<storage, read> svo: SvoParams;

fn brick_voxel(n: u32, v: vec3<u32>) -> vec4<f32> {
    let w = n * BRICK_WORDS + voxel_index(v) * 4u;
    return vec4<f32>(f32(bricks[w]), f32(bricks[w + 1u]), f32(bricks[w + 2u]), f32(bricks[w + 3u])) * svo.inv_scale;
}

fn sample_level(x: vec3<f32>, l: u32) -> vec4<f32> {
    let s = svo.depth - l;
    let inv = cone.inv_s0 * (1.0 / f32(1u << l));
    let q = (x - cone.origin.xyz) * inv - vec3<f32>(0.5 / f32(1u << l));
    let fl = floor(q);
    let f = q - fl;
    let i0 = vec3<i32>(fl);
    let points = i32(2u << s);
    let c = clamp(i0 >> vec3<u32>(1u), vec3<i32>(0), vec3<i32>((1i << s) - 1i));
    let n = find(s, vec3<u32>(c));
    if (n == NONE) {
        return vec4<f32>(0.0);
    }
    var acc = vec4<f32>(0.0);
    for (var corner = 0u; corner < 8u; corner++) {
        let cc = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
        let w = select(vec3<f32>(1.0) - f, f, cc == vec3<u32>(1u));
        let i = i0 + vec3<i32>(cc);
        let local = i - 2i * c;
        if (any(i < vec3<i32>(0)) || any(i > vec3<i32>(points)) || any(local < vec3<i32>(0)) || any(local > vec3<i32>(2))) {
            continue;
        }
        acc += brick_voxel(n, vec3<u32>(local)) * (w.x * w.y * w.z);
    }
    return acc;
}

// The march's sample: the volume's own radiance (see common/cone_march.wgsl).
fn sample_cone(x: vec3<f32>, l: f32, diam: f32, d: vec3<f32>) -> vec4<f32> {
    return sample_volume(x, l);
}
