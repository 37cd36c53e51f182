//! Reuse in another renderer: create your own wgpu device, your own buffers, and record the
//! surface-coverage mip kernel into your own command encoder. Nothing of the harness is involved.
//!
//! `cargo run --example mip_on_own_device`
use vxgi::kernels::surface_coverage_mip::MipPipeline;
use vxgi_cpu_mirror::morton;
use vxgi_cpu_mirror::surface_coverage_mip::Coverage;
use wgpu::util::DeviceExt;

fn main() {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .expect("no GPU adapter; on Debian: apt-get install -y mesa-vulkan-drivers");
    let (device, queue) =
        pollster::block_on(adapter.request_device(&Default::default())).expect("device");

    // A 4^3 grid: the bottom layer (y = 0) opaque white, normals +y, stored in Morton order.
    let n = 4u32;
    let mut colour = vec![[0.0f32; 4]; (n * n * n) as usize];
    let mut normal = vec![[0.0f32; 4]; colour.len()];
    for z in 0..n {
        for x in 0..n {
            let m = morton::encode(x, 0, z) as usize;
            colour[m] = [1.0, 1.0, 1.0, 1.0];
            normal[m] = [0.0, 1.0, 0.0, 0.0];
        }
    }
    let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let src_c = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(&colour),
        usage: storage,
    });
    let src_n = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(&normal),
        usage: storage,
    });
    let parents = (n / 2).pow(3) as u64;
    let mk = || {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: parents * 16,
            usage: storage,
            mapped_at_creation: false,
        })
    };
    let (dst_c, dst_n) = (mk(), mk());
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: parents * 16,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });

    let mip = MipPipeline::new(&device, Coverage::Surface);
    let mut encoder = device.create_command_encoder(&Default::default());
    mip.encode_level(
        &device,
        &mut encoder,
        [
            src_c.as_entire_buffer_binding(),
            src_n.as_entire_buffer_binding(),
        ],
        [
            dst_c.as_entire_buffer_binding(),
            dst_n.as_entire_buffer_binding(),
        ],
        parents as u32,
    );
    encoder.copy_buffer_to_buffer(&dst_c, 0, &readback, 0, parents * 16);
    queue.submit([encoder.finish()]);
    readback
        .slice(..)
        .map_async(wgpu::MapMode::Read, |r| r.expect("map"));
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("poll");
    let data = readback.slice(..).get_mapped_range().expect("mapped");
    let level1: &[[f32; 4]] = bytemuck::cast_slice(&data);
    for (m, c) in level1.iter().enumerate() {
        let [x, y, z] = morton::decode(m as u32);
        println!("level 1 ({x},{y},{z}): colour {:?} alpha {}", &c[..3], c[3]);
    }
    // Half of each bottom 2x2x2 block is full: surface coverage keeps it opaque (alpha 1), where
    // the plain average would give 0.5.
    assert!(level1
        .iter()
        .enumerate()
        .all(|(m, c)| (morton::decode(m as u32)[1] == 0) == (c[3] == 1.0)));
    println!("ok: the half-full blocks stay opaque under surface coverage");
}
