//! cprc's chain: vct-dense's volume and camera passes, the cache distribution, the cache records,
//! creation and pre-convolution dispatched indirectly, the gather; and how many caches it holds.
use super::*;

/// What a cprc chain holds besides its stages: how many caches its buffers have room for, and
/// whether it builds the caches' mip chains (a glossy material in the scene).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CacheRoom {
    pub capacity: u32,
    pub mips: bool,
    /// cache_records' parameters as the chain was built (a frame whose instances moved rewrites its
    /// offset: the world grid's voxel follows the scene's extent).
    pub records: vxgi_cpu_mirror::cache_records::RecordsParams,
}

/// The most bytes a cprc chain spends on its caches' texels, mip chains and irradiance maps: the
/// capacity stops there even where the device's bindings would hold more (the frame's actual count is
/// usually a small part of the worst case: 447 of 12288 on the Cornell box at 256x256).
pub(crate) const CACHE_BUDGET: u64 = 256 << 20;

/// The most caches a frame of `scene` can place (one per cluster: clusters are keyed by tile, normal
/// axis and depth slice, so at most `tiles * 3 * slices` of them, and no more than pixels), within
/// what one storage binding holds of each cache buffer (texels, mip chains where built, irradiance
/// maps) and within [`CACHE_BUDGET`] for all of them. A frame with more clusters than that keeps the
/// first and counts the rest (`CprcStats::dropped`, warned by `vxgi render`).
pub(crate) fn cache_room(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    s: &crate::cprc::CprcSettings,
) -> CacheRoom {
    use vxgi_cpu_mirror::cache_preconvolve::mip_len;
    let (w, h) = (scene.camera.width as u64, scene.camera.height as u64);
    let tiles = w.div_ceil(s.tile as u64) * h.div_ceil(s.tile as u64);
    let mips = scene.materials.iter().any(|m| m.is_glossy());
    let limit = ctx.limits().max_storage_buffer_binding_size;
    let mut per = vec![(s.res * s.res) as u64, (s.irr * s.irr) as u64];
    if mips {
        per.push(mip_len(s.res) as u64);
    }
    let fit = per.iter().map(|t| limit / (t * 16)).min().unwrap_or(0);
    let budget = CACHE_BUDGET / (per.iter().sum::<u64>() * 16);
    let capacity = (tiles * 3 * s.slices as u64)
        .min(w * h)
        .min(fit)
        .min(budget)
        .max(1);
    CacheRoom {
        capacity: capacity as u32,
        mips,
        records: Default::default(),
    }
}

/// cprc's chain: vct-dense's volume (every pyramid level: the caches' cones read them all), gbuffer
/// and direct_light; then cprc_pixels' `inputs`, the distribution's six kernels, cache_records (its
/// count copied into creation's and pre-convolution's uniform blocks), cache creation and
/// pre-convolution dispatched from the GPU-built arguments, the gather, and cprc_pixels' `compose`
/// (`indirect`, `ao`). Nothing between the G-buffer and the images goes through the host. With
/// `[[instances]]` the volume is [`instanced_volume`]'s hierarchies (their grid frames returned) and
/// creation marches through all of them.
pub(crate) fn cprc_chain(
    ctx: &crate::harness::GpuContext,
    scene: &Scene,
    data: &SceneData,
    cones: &ConeSettings,
) -> Result<(Chain, CacheRoom, Option<Vec<voxelize::VoxelFrame>>)> {
    use crate::cprc::{self, CacheSet, CacheVolume, CprcSettings, PixelInputs};
    use crate::harness::run::Workgroups;
    use crate::kernels::{cache_records, cprc_pixels};
    use vxgi_cpu_mirror::cache_records::args_offset;
    let (mut chain, hierarchies) = if scene.instances.list.is_empty() {
        (dense_chain(ctx, scene, data, None, true)?, None)
    } else {
        let (mut chain, frames, at) = instanced_volume(ctx, scene, data)?;
        push_camera_gbuffer(ctx, data, &mut chain)?;
        (chain, Some((frames, at.placed)))
    };
    let s = CprcSettings::from(&scene.render);
    let mut room = cache_room(ctx, scene, &s);
    let (w, h) = (data.width(), data.height());
    let n = (w * h) as usize;
    // The per-pixel inputs, computed by `inputs` from the G-buffer (zeroed here).
    let px = PixelInputs {
        width: w,
        height: h,
        normals: vec![[0; 2]; n],
        depth: vec![0.0; n],
        positions: vec![[0.0; 4]; n],
        pixel_dirs: vec![[0.0; 4]; 2 * n],
        albedo: vec![[0.0; 4]; n],
        specular: vec![[0.0; 4]; n],
        geometry: vec![false; n],
    };
    let mut pixels = cprc_pixels::outputs(n);
    pixels.insert(
        "lobes".into(),
        HostResource::Buffer(crate::harness::HostBuffer::f32(bytemuck::cast_slice(
            &cprc_pixels::lobes(&data.materials, s.res),
        ))),
    );
    for name in ["indirect", "ao"] {
        pixels.insert(
            name.into(),
            HostResource::Buffer(crate::harness::HostBuffer::zeroed(
                n * 16,
                crate::harness::ScalarKind::F32,
            )),
        );
    }
    chain.merge(cprc_pixels::DECL.name, pixels)?;
    let pixel_shader = cprc_pixels::DECL.shader()?;
    chain.push_as(
        cprc_pixels::DECL.shader()?,
        cprc_pixels::DECL.name,
        "cache_distribution",
        vec![cprc_pixels::pass(ctx, "inputs", n)],
    );
    let (mut dist, stages) = cprc::distribution_stages(ctx, &px, &s)?;
    // The distribution reads the pixel inputs `inputs` writes.
    for name in ["normals", "depth", "positions"] {
        dist.remove(name);
    }
    chain.merge("the cache distribution", dist)?;
    for (decl, passes) in stages {
        chain.push_as(decl.shader()?, decl.name, "cache_distribution", passes);
    }
    // The records of every cache slot and the cache stages' arguments.
    let cone = cone_trace::cone_params(&chain.frame, cones);
    let params = vxgi_cpu_mirror::cache_records::RecordsParams {
        width: w,
        tile: s.tile,
        tiles_x: w.div_ceil(s.tile),
        capacity: room.capacity,
        per: [
            s.res * s.res,
            if room.mips {
                vxgi_cpu_mirror::cache_preconvolve::mip_len(s.res) as u32
            } else {
                0
            },
            s.irr * s.irr,
        ],
        max_groups: ctx.limits().max_compute_workgroups_per_dimension,
        offset: cone.offset_voxels * cone.origin[3],
        _pad: [0; 3],
    };
    room.records = params;
    let tiles = (params.tiles_x * h.div_ceil(s.tile)) as usize;
    let mut records = cache_records::outputs(room.capacity as usize, tiles);
    records.insert(
        "records_params".into(),
        HostResource::Buffer(crate::harness::HostBuffer::pod(&params)),
    );
    chain.merge(cache_records::DECL.name, records)?;
    chain.push_as(
        cache_records::DECL.shader()?,
        cache_records::DECL.name,
        "cache_distribution",
        vec![cache_records::pass(ctx, &params)],
    );
    let after_records = chain.pass_count();
    // Creation, pre-convolution and the gather over every slot, dispatched from the arguments.
    let len = pyramid_texels(&chain);
    let zeros = cone_trace::Pyramids {
        colour: vec![[0.0; 4]; len],
        normal: Vec::new(),
    };
    let volume = match &hierarchies {
        None => CacheVolume::One(&zeros),
        Some((_, placed)) => CacheVolume::Placed(&zeros.colour, placed),
    };
    let (mut caches, parts) = cprc::cache_stages(
        ctx,
        &px,
        &CacheSet::empty(),
        room.capacity as usize,
        &s,
        volume,
        &cone,
        room.mips,
    )?;
    // The pyramid and its normals are the volume's (the case's normal pyramid is a placeholder where
    // the cones do not read it); the pixel inputs are `inputs`'.
    for name in ["pyramid_normal", "positions", "pixel_dirs"] {
        caches.remove(name);
    }
    chain.merge("the cache stages", caches)?;
    for (decl, mut passes) in parts {
        let stage = match decl.name {
            "gather_caches" => "gather_caches",
            "cache_preconvolve" => "cache_preconvolve",
            _ => "cache_creation",
        };
        for p in &mut passes {
            let k = match p.entry.as_str() {
                "create" => Some(0),
                "mips" => Some(1),
                "irradiance" => Some(2),
                _ => None,
            };
            if let Some(k) = k {
                p.workgroups = Workgroups::Indirect {
                    buffer: "cache_args".into(),
                    offset: args_offset(k),
                };
            }
        }
        chain.push_as(decl.shader()?, decl.name, stage, passes);
    }
    chain.push_as(
        pixel_shader,
        cprc_pixels::DECL.name,
        "gather_caches",
        vec![cprc_pixels::pass(ctx, "compose", n)],
    );
    // The GPU's cache count into the uniform blocks of creation and pre-convolution (`count` is the
    // first field of both).
    for dst in ["cache_params", "pre_params"] {
        chain.copies.push(ChainCopy {
            after: after_records,
            src: "cache_count".into(),
            dst: dst.into(),
            offset: 0,
        });
    }
    Ok((chain, room, hierarchies.map(|(frames, _)| frames)))
}
