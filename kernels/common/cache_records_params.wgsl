// common/cache_records_params.wgsl — cache_records' uniform block (mirror:
// vxgi_cpu_mirror::cache_records::RecordsParams), which cache_reuse reads too (the creation
// origin's offset) from the same buffer in cprc's chain.

struct RecordsParams {
    width: u32,
    tile: u32,
    tiles_x: u32,
    capacity: u32,
    per: vec3<u32>,
    max_groups: u32,
    offset: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}
