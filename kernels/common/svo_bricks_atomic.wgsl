// The sparse voxel octree's brick pool as its build (sparse_voxel_octree_windowed) writes a pool past
// one storage binding: up to five windows of one buffer. Word i is in window i / L,
// L = arrayLength(&bricks) (every window but the last is full); the windows the pool does not reach
// are one unused word each. sparse_voxel_octree binds one (common/svo_bricks_atomic_one.wgsl): a
// branch per window costs lavapipe about twice the build where the pool fits one binding.
@group(0) @binding(3) var<storage, read_write> bricks: array<atomic<u32>>;
@group(0) @binding(14) var<storage, read_write> bricks_1: array<atomic<u32>>;
@group(0) @binding(15) var<storage, read_write> bricks_2: array<atomic<u32>>;
@group(0) @binding(16) var<storage, read_write> bricks_3: array<atomic<u32>>;
@group(0) @binding(17) var<storage, read_write> bricks_4: array<atomic<u32>>;

fn brick_load(i: u32) -> u32 {
    let l = arrayLength(&bricks);
    if (i < l) {
        return atomicLoad(&bricks[i]);
    }
    let j = i % l;
    switch (i / l) {
        case 1u: { return atomicLoad(&bricks_1[j]); }
        case 2u: { return atomicLoad(&bricks_2[j]); }
        case 3u: { return atomicLoad(&bricks_3[j]); }
        default: { return atomicLoad(&bricks_4[j]); }
    }
}

fn brick_store(i: u32, v: u32) {
    let l = arrayLength(&bricks);
    if (i < l) {
        atomicStore(&bricks[i], v);
        return;
    }
    let j = i % l;
    switch (i / l) {
        case 1u: { atomicStore(&bricks_1[j], v); }
        case 2u: { atomicStore(&bricks_2[j], v); }
        case 3u: { atomicStore(&bricks_3[j], v); }
        default: { atomicStore(&bricks_4[j], v); }
    }
}

// atomicCompareExchangeWeak on word i: (old value, 1 where exchanged).
fn brick_exchange(i: u32, old: u32, next: u32) -> vec2<u32> {
    let l = arrayLength(&bricks);
    let j = i % l;
    var r: vec2<u32>;
    switch (i / l) {
        case 0u: { let x = atomicCompareExchangeWeak(&bricks[j], old, next); r = vec2<u32>(x.old_value, u32(x.exchanged)); }
        case 1u: { let x = atomicCompareExchangeWeak(&bricks_1[j], old, next); r = vec2<u32>(x.old_value, u32(x.exchanged)); }
        case 2u: { let x = atomicCompareExchangeWeak(&bricks_2[j], old, next); r = vec2<u32>(x.old_value, u32(x.exchanged)); }
        case 3u: { let x = atomicCompareExchangeWeak(&bricks_3[j], old, next); r = vec2<u32>(x.old_value, u32(x.exchanged)); }
        default: { let x = atomicCompareExchangeWeak(&bricks_4[j], old, next); r = vec2<u32>(x.old_value, u32(x.exchanged)); }
    }
    return r;
}
