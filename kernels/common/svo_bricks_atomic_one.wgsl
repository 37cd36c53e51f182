// The sparse voxel octree's brick pool as its build (sparse_voxel_octree) writes it where it fits one
// storage binding; past one, common/svo_bricks_atomic.wgsl, through the same three functions.
@group(0) @binding(3) var<storage, read_write> bricks: array<atomic<u32>>;

fn brick_load(i: u32) -> u32 {
    return atomicLoad(&bricks[i]);
}

fn brick_store(i: u32, v: u32) {
    atomicStore(&bricks[i], v);
}

// atomicCompareExchangeWeak on word i: (old value, 1 where exchanged).
fn brick_exchange(i: u32, old: u32, next: u32) -> vec2<u32> {
    let x = atomicCompareExchangeWeak(&bricks[i], old, next);
    return vec2<u32>(x.old_value, u32(x.exchanged));
}
