// common/morton.wgsl — the Morton order of the voxel grids (mirror: vxgi_cpu_mirror::morton):
// bit i of x, y, z at bits 3i, 3i + 1, 3i + 2, for coordinates below 1024. Integers only: exact.
// And where a point falls in a level of such a grid (`grid_point`), which every trilinear read of
// one shares.

fn spread3(v: u32) -> u32 {
    var x = v & 0x3ffu;
    x = (x | (x << 16u)) & 0x030000ffu;
    x = (x | (x << 8u)) & 0x0300f00fu;
    x = (x | (x << 4u)) & 0x030c30c3u;
    x = (x | (x << 2u)) & 0x09249249u;
    return x;
}

fn compact3(v: u32) -> u32 {
    var x = v & 0x09249249u;
    x = (x | (x >> 2u)) & 0x030c30c3u;
    x = (x | (x >> 4u)) & 0x0300f00fu;
    x = (x | (x >> 8u)) & 0x030000ffu;
    x = (x | (x >> 16u)) & 0x000003ffu;
    return x;
}

fn morton3(p: vec3<u32>) -> u32 {
    return spread3(p.x) | (spread3(p.y) << 1u) | (spread3(p.z) << 2u);
}

fn morton_decode(m: u32) -> vec3<u32> {
    return vec3<u32>(compact3(m), compact3(m >> 1u), compact3(m >> 2u));
}

// Where point x falls in level l of the grid with this origin, 1 / s0 and side: the level's side n,
// the trilinear cell's lower corner i0 and the fractions f. Mirror: cone_trace.rs `GridPoint`.
struct GridPoint {
    n: i32,
    i0: vec3<i32>,
    f: vec3<f32>,
}

fn grid_point(x: vec3<f32>, l: u32, origin: vec3<f32>, inv_s0: f32, side: u32) -> GridPoint {
    let inv = inv_s0 * (1.0 / f32(1u << l));
    let q = (x - origin) * inv - vec3<f32>(0.5);
    let fl = floor(q);
    return GridPoint(i32(side >> l), vec3<i32>(fl), q - fl);
}

// Corner `corner` (0..7) of g's trilinear cell: whether it lies in the grid, its coordinates there
// and its trilinear weight (the product in x, y, z order, as the mirror's).
struct GridCorner {
    inside: bool,
    u: vec3<u32>,
    w: f32,
}

fn grid_corner(g: GridPoint, corner: u32) -> GridCorner {
    let cc = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
    let w = select(vec3<f32>(1.0) - g.f, g.f, cc == vec3<u32>(1u));
    let i = g.i0 + vec3<i32>(cc);
    let inside = !(any(i < vec3<i32>(0)) || any(i >= vec3<i32>(g.n)));
    return GridCorner(inside, vec3<u32>(max(i, vec3<i32>(0))), w.x * w.y * w.z);
}
