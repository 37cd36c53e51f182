// One triangle on voxelize's integer lattice (cpu_mirror/src/voxelize.rs `VoxTriangle`): written by
// triangle_setup.wgsl, sampled by voxelize.wgsl.
struct VoxTriangle {
    a: vec4<i32>,       // lattice vertex (1/256 voxel); w = sample count n
    b: vec4<i32>,
    c: vec4<i32>,
    na: vec4<i32>,      // fixed-point (x 4096) vertex normals
    nb: vec4<i32>,
    nc: vec4<i32>,
    albedo: vec4<u32>,  // fixed-point albedo (rgb)
    uv_ab: vec4<i32>,   // Ua, Va, Ub, Vb (1/16 texel)
    uv_c: vec4<i32>,    // Uc, Vc
    texture: vec4<u32>, // first atlas texel, W, H, 0
}
