//! The device limits a frame's settings must fit, checked from the scene before anything large is
//! allocated: the light views' layered RSMs (lrsm), the photon maps (vct-svo), the image (every
//! pipeline, with its supersampling), the dense voxel grids (lrsm: its occlusion voxels). Each
//! refusal names the quantity, the limit and the setting to change. `vxgi scene` runs the same checks.
use crate::render::Pipeline;
use crate::scene::Scene;

/// Bytes per voxel of each dense grid voxelization writes (colour, normal: a `vec4<f32>`). Its
/// accumulators (32 bytes per voxel) take one storage binding's window of the grid at a time.
pub const VOXEL_GRID_BYTES: u64 = crate::kernels::voxelize::GRID_BYTES;

/// `b` in MiB, with the bytes where one decimal would hide them (a limit of 2 GiB - 1 beside 2 GiB).
fn mib(b: u64) -> String {
    let m = format!("{:.1} MiB", b as f64 / (1u64 << 20) as f64);
    if b.is_multiple_of(1u64 << 20) {
        m
    } else {
        format!("{m}, {b} bytes")
    }
}

/// Two bounces are vct-svo's (and the reference's) alone: refused rather than one rendered silently.
pub fn check_bounces(scene: &Scene, pipeline: Pipeline) -> Result<(), String> {
    if scene.render.bounces > 1 && pipeline != Pipeline::VctSvo {
        return Err(format!(
            "bounces = {} is implemented by --pipeline vct-svo only ({} renders one bounce)",
            scene.render.bounces,
            pipeline.name()
        ));
    }
    Ok(())
}

/// The depth-ordered blend samples one pyramid; instanced scenes' placed hierarchies
/// (common/placed_pyramids.wgsl) have the paper's trilinear only: refused rather than ignored.
pub fn check_ordered_instances(scene: &Scene, depth_ordered_blend: bool) -> Result<(), String> {
    if depth_ordered_blend && !scene.instances.list.is_empty() {
        return Err("depth_ordered_blend is not implemented for scenes with [[instances]] (their placed voxel \
             hierarchies are sampled trilinearly): set it to false"
            .into());
    }
    Ok(())
}

/// Every limit `pipeline` would hit rendering `scene` on a device with `limits`, and what it does not
/// implement for these settings, or Ok.
pub fn check(scene: &Scene, pipeline: Pipeline, limits: &wgpu::Limits) -> Result<(), String> {
    check_bounces(scene, pipeline)?;
    check_kernels(pipeline, limits)?;
    if matches!(pipeline, Pipeline::VctDense | Pipeline::Cprc) {
        check_ordered_instances(scene, scene.render.depth_ordered_blend)?;
    }
    let binding = limits.max_storage_buffer_binding_size;
    let r = &scene.render;
    let past = |what: String, bytes: u64, change: &str| {
        Err(format!(
            "{what} need {} in one storage binding, past the device's max_storage_buffer_binding_size ({}): {change}",
            mib(bytes),
            mib(binding)
        ))
    };
    // The image: the G-buffer's vec4<f32> per sample is the largest per-pixel binding.
    let (w, h, s) = (
        scene.camera.width as u64,
        scene.camera.height as u64,
        r.supersample as u64,
    );
    let pixel_bytes = w * s * h * s * 16;
    if pixel_bytes > binding {
        return past(
            format!(
                "{w} x {h} pixels at supersample = {s} ({} x {} samples, 16 bytes each in the G-buffer)",
                w * s,
                h * s
            ),
            pixel_bytes,
            "lower the camera's width and height or supersample",
        );
    }
    // lrsm voxelizes into occupancy bits (level 0 of its occlusion voxels; the mips above it are
    // bytes), gathered from one binding; every other pipeline into dense grids.
    if pipeline == Pipeline::Lrsm {
        let occ = vxgi_cpu_mirror::occlusion_voxels::pyramid_bytes(r.voxels);
        if occ > binding {
            return past(
                format!(
                    "voxels = {}: lrsm's occlusion voxels (a bit per voxel, their mips a byte)",
                    r.voxels
                ),
                occ,
                "lower voxels",
            );
        }
    }
    // vct-svo's photons-lit octree takes its geometry from occupancy bits too (above 128^3, where
    // its staged build runs: `coverage_alone`).
    let voxel_bytes = (r.voxels as u64).pow(3) * VOXEL_GRID_BYTES;
    let dense = match pipeline {
        Pipeline::Lrsm => false,
        Pipeline::VctSvo => !crate::pipeline::coverage_alone(scene),
        _ => true,
    };
    if dense && voxel_bytes > limits.max_buffer_size {
        return Err(format!(
            "voxels = {}: the voxelized grid ({VOXEL_GRID_BYTES} bytes per voxel for its colour, as many for its normals) needs {} in one buffer, past the device's max_buffer_size ({}): lower voxels",
            r.voxels,
            mib(voxel_bytes),
            mib(limits.max_buffer_size)
        ));
    }
    // With [[instances]], vct-dense's and cprc's hierarchies bind their grids whole (the windows
    // above serve the one-grid chains).
    if matches!(pipeline, Pipeline::VctDense | Pipeline::Cprc)
        && !scene.instances.list.is_empty()
        && voxel_bytes > binding
    {
        return past(
            format!(
                "voxels = {} with [[instances]]: a hierarchy's voxel grid ({VOXEL_GRID_BYTES} bytes per voxel)",
                r.voxels
            ),
            voxel_bytes,
            "lower voxels (vct-svo and lrsm voxelize instanced scenes whole)",
        );
    }
    // vct-dense and cprc bind their radiance pyramid in up to three windows; the depth-ordered
    // blend's normal pyramid in one.
    let pyramid = vxgi_cpu_mirror::cone_trace::pyramid_len(r.voxels) as u64 * 16;
    if matches!(pipeline, Pipeline::VctDense | Pipeline::Cprc)
        && r.depth_ordered_blend
        && pyramid > binding.min(crate::kernels::cone_trace::PYRAMID_WINDOW * 16)
    {
        return past(
            format!(
                "voxels = {} with depth_ordered_blend: the normal pyramid (16 bytes per voxel and its mips)",
                r.voxels
            ),
            pyramid,
            "lower voxels or set depth_ordered_blend = false",
        );
    }
    if matches!(pipeline, Pipeline::VctDense | Pipeline::Cprc)
        && pyramid > 3 * binding.min(crate::kernels::cone_trace::PYRAMID_WINDOW * 16)
    {
        return past(
            format!(
                "voxels = {}: the radiance pyramid in three bindings",
                r.voxels
            ),
            pyramid / 3,
            "lower voxels",
        );
    }
    let views = crate::plan::light_views(scene) as u64;
    match pipeline {
        Pipeline::Lrsm if r.lrsm_lit_cells => {
            // The lit cells, every level, in one binding (the table's side capped: lit_cells::MAX_SIDE).
            use crate::kernels::lit_cells::{table_side, MAX_SIDE};
            let side = table_side(r.voxels, MAX_SIDE);
            let bytes = crate::kernels::lit_cells::pyramid_bytes(side);
            if bytes > binding.min(limits.max_buffer_size) {
                return past(
                    format!(
                        "lrsm: the lit cells of {side}^3 cells and their levels (32 bytes a cell)"
                    ),
                    bytes,
                    "lower voxels or set lrsm_lit_cells = false (the LRSMs)",
                );
            }
        }
        Pipeline::Lrsm => {
            // Every view's LRSM (all layers, whole mip chain) is gathered from one binding per
            // stream (radiance, normal, depth moments: four binary16 values each).
            let config = crate::lrsm::PartitionConfig {
                rsm_side: r.rsm_side,
                depth_splits: r.lrsm_depth_splits,
                normal_splits: r.lrsm_normal_splits,
                overlap: r.lrsm_overlap,
                area_weights: r.lrsm_area_weights,
            };
            // One stream of the three `lrsm_bytes` counts.
            let per_view = crate::lrsm::lrsm_bytes(&config) / 3;
            let layers = config.layers() as u64;
            let texel = crate::kernels::lrsm_prefilter::TEXEL_BYTES;
            let texels = per_view / (layers * texel);
            let bytes = views * per_view;
            if bytes > binding.min(limits.max_buffer_size) {
                let fit = binding.min(limits.max_buffer_size) / per_view;
                return past(
                    format!(
                        "lrsm: {} lights in {views} light views (a point light has six) x {layers} layers x {texels} texels of rsm_side = {} (its LRSM and mips), {texel} bytes each,",
                        scene.lights.len(),
                        r.rsm_side
                    ),
                    bytes,
                    &format!(
                        "at most {fit} light views at these settings; lower rsm_side, lrsm_depth_splits or lrsm_normal_splits, or use fewer lights"
                    ),
                );
            }
        }
        Pipeline::VctSvo if r.photon_map > 0 => {
            // Each texel of every view's photon map can become a fragment (32 bytes), twice with the
            // lobes (its specular part); the octree build binds them all at once.
            let p = r.photon_map as u64;
            let per_texel = 32 * (1 + r.voxel_lobes as u64);
            let bytes = views * p * p * per_texel;
            if bytes >= binding {
                let most = (4..=11)
                    .map(|k| 1u64 << k)
                    .filter(|q| views * q * q * per_texel < binding)
                    .max();
                return past(
                    format!(
                        "vct-svo: photon_map = {p} in {views} light views gives up to {} photon fragments ({per_texel} bytes each), which",
                        views * p * p
                    ),
                    bytes,
                    &match most {
                        Some(m) => format!("at most photon_map = {m} with these lights"),
                        None => "use photon_map = 0 (voxel_light injection) or fewer lights".into(),
                    },
                );
            }
        }
        _ => {}
    }
    Ok(())
}

/// Whether every kernel of `pipeline`'s frame fits a device with `limits` (bindings per stage, bind
/// groups, workgroup sizes), or the kernels that do not and by how much: a device that cannot
/// create a frame's compute pipelines is refused by name before anything is allocated.
pub fn check_kernels(pipeline: Pipeline, limits: &wgpu::Limits) -> Result<(), String> {
    use std::sync::OnceLock;
    // Reflection of a pipeline's kernels, once per process (every frame checks).
    type Needs = Result<Vec<KernelNeeds>, String>;
    static NEEDS: OnceLock<Vec<(Pipeline, Needs)>> = OnceLock::new();
    let all = NEEDS.get_or_init(|| {
        [
            Pipeline::VctDense,
            Pipeline::VctSvo,
            Pipeline::Lrsm,
            Pipeline::Cprc,
        ]
        .into_iter()
        .map(|p| {
            // A kernel that cannot be found or reflected is an error, never a pass.
            let needs = pipeline_kernels(p)
                .into_iter()
                .map(kernel_needs)
                .collect::<Result<Vec<_>, String>>();
            (p, needs)
        })
        .collect()
    });
    let needs = match all.iter().find(|(p, _)| *p == pipeline) {
        Some((_, Ok(n))) => n.as_slice(),
        Some((_, Err(e))) => return Err(format!("{}'s kernels: {e}", pipeline.name())),
        None => &[],
    };
    let short: Vec<String> = needs
        .iter()
        .filter_map(|n| {
            let e = exceeded(n, limits);
            (!e.is_empty()).then(|| format!("{} ({})", n.kernel, e.join(", ")))
        })
        .collect();
    if short.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "this device cannot run {}: {} (request the adapter's own limits when creating the device; `vxgi limits` lists every kernel's needs)",
            pipeline.name(),
            short.join("; ")
        ))
    }
}

/// What one kernel needs of a device, from its WGSL's naga reflection (the most any of its entry
/// points needs).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct KernelNeeds {
    pub kernel: &'static str,
    pub storage_buffers: u32,
    pub uniform_buffers: u32,
    pub sampled_textures: u32,
    pub storage_textures: u32,
    pub bind_groups: u32,
    /// Invocations per workgroup, and the largest workgroup side per axis.
    pub invocations: u32,
    pub workgroup_size: [u32; 3],
}

/// [`KernelNeeds`] of `decl`.
pub fn kernel_needs(decl: &crate::harness::KernelDecl) -> Result<KernelNeeds, String> {
    use crate::harness::BindingKind as K;
    let shader = decl.shader().map_err(|e| e.to_string())?;
    let mut n = KernelNeeds {
        kernel: decl.name,
        ..Default::default()
    };
    for e in &shader.entries {
        let count = |f: &dyn Fn(&K) -> bool| {
            e.uses
                .iter()
                .filter(|&&i| f(&shader.bindings[i].kind))
                .count() as u32
        };
        n.storage_buffers = n
            .storage_buffers
            .max(count(&|k| matches!(k, K::Storage { .. })));
        n.uniform_buffers = n
            .uniform_buffers
            .max(count(&|k| matches!(k, K::Uniform(_))));
        n.sampled_textures = n
            .sampled_textures
            .max(count(&|k| matches!(k, K::SampledTexture { .. })));
        n.storage_textures = n
            .storage_textures
            .max(count(&|k| matches!(k, K::StorageTexture { .. })));
        let groups = e
            .uses
            .iter()
            .map(|&i| shader.bindings[i].group + 1)
            .max()
            .unwrap_or(0);
        n.bind_groups = n.bind_groups.max(groups);
        let [x, y, z] = e.workgroup_size;
        n.invocations = n.invocations.max(x * y * z);
        for (a, s) in n.workgroup_size.iter_mut().zip([x, y, z]) {
            *a = (*a).max(s);
        }
    }
    Ok(n)
}

/// The limits among these that `needs` passes on a device with `limits`: "name: needs N, has M".
pub fn exceeded(needs: &KernelNeeds, limits: &wgpu::Limits) -> Vec<String> {
    let mut out = Vec::new();
    let mut check = |name: &str, need: u32, has: u32| {
        if need > has {
            out.push(format!("{name}: needs {need}, has {has}"));
        }
    };
    check(
        "max_storage_buffers_per_shader_stage",
        needs.storage_buffers,
        limits.max_storage_buffers_per_shader_stage,
    );
    check(
        "max_uniform_buffers_per_shader_stage",
        needs.uniform_buffers,
        limits.max_uniform_buffers_per_shader_stage,
    );
    check(
        "max_sampled_textures_per_shader_stage",
        needs.sampled_textures,
        limits.max_sampled_textures_per_shader_stage,
    );
    check(
        "max_storage_textures_per_shader_stage",
        needs.storage_textures,
        limits.max_storage_textures_per_shader_stage,
    );
    check("max_bind_groups", needs.bind_groups, limits.max_bind_groups);
    check(
        "max_compute_invocations_per_workgroup",
        needs.invocations,
        limits.max_compute_invocations_per_workgroup,
    );
    check(
        "max_compute_workgroup_size_x",
        needs.workgroup_size[0],
        limits.max_compute_workgroup_size_x,
    );
    check(
        "max_compute_workgroup_size_y",
        needs.workgroup_size[1],
        limits.max_compute_workgroup_size_y,
    );
    check(
        "max_compute_workgroup_size_z",
        needs.workgroup_size[2],
        limits.max_compute_workgroup_size_z,
    );
    out
}

/// The kernels a pipeline's frame can run: every kernel its declaration's stages name, once, in
/// frame order.
pub fn pipeline_kernels(pipeline: Pipeline) -> Vec<&'static crate::harness::KernelDecl> {
    let mut seen = std::collections::BTreeSet::new();
    pipeline
        .decl()
        .stages
        .iter()
        .flat_map(|s| s.kernels.iter().copied())
        .filter(|k| seen.insert(k.name))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A device with fewer storage buffers per stage than a pipeline's kernels bind (a GL adapter
    /// has 16; WebGPU's default is 8) is refused by name, kernel and limit; the adapter's own
    /// limits as lavapipe reports them pass.
    #[test]
    fn kernels_past_the_device_limits_are_refused_by_name() {
        let scene = Scene::cornell_box();
        let limits = wgpu::Limits {
            max_storage_buffers_per_shader_stage: 16,
            ..wgpu::Limits::default()
        };
        let e = check(&scene, Pipeline::Lrsm, &limits).unwrap_err();
        assert!(
            e.contains("cannot run lrsm")
                && e.contains(
                    "lrsm_cone_trace (max_storage_buffers_per_shader_stage: needs 22, has 16"
                ),
            "{e}"
        );
        let roomy = wgpu::Limits {
            max_storage_buffers_per_shader_stage: 32,
            ..limits
        };
        assert_eq!(check_kernels(Pipeline::Lrsm, &roomy), Ok(()));
    }
}
