//! Declaration of `kernels/reflective_shadow_map.wgsl` (mirror:
//! `vxgi_cpu_mirror::reflective_shadow_map`): one light view's RSM from a G-buffer the GPU ray-cast from
//! that view, in the Morton order lrsm_partition reads.
use super::direct_light::gpu_gbuffer;
use super::gbuffer::generated_scene;
use crate::lrsm::{light_views, LightView, Rsm};
use crate::trace::SceneData;
use vxgi_cpu_mirror::direct_light::GpuLight;
use vxgi_cpu_mirror::reflective_shadow_map::{rsm, GpuView};
use vxgi_harness::bindings::field;
use vxgi_harness::prelude::*;

/// The light view's struct and projection, included by reflective_shadow_map and lrsm_cone_trace.
pub const LRSM_VIEW: (&str, &str) = (
    "kernels/common/lrsm_view.wgsl",
    include_str!("../../kernels/common/lrsm_view.wgsl"),
);

vxgi_harness::bindings! {
    /// reflective_shadow_map's bindings: the light view, the lights and the view's G-buffer in, the
    /// RSM out.
    pub struct Io {
        inputs: {
            view: Block<GpuView>,
            lights: Vec<[f32; 4]>,
            gb_position: Vec<[f32; 4]>,
            gb_normal: Vec<[f32; 4]>,
            gb_albedo: Vec<[f32; 4]>,
        }
        // Radiance and <n.l>: the light contract's arithmetic (sqrt, divisions, a spot's
        // smoothstep) within the mirror's per-texel bound; depth a dot product within 8 ULP of its
        // magnitudes; coverage and the normal's xyz are copies (bound 0).
        outputs: {
            rsm_radiance: Vec<[f32; 4]> => Tolerance::MirrorBound,
            rsm_normal: Vec<[f32; 4]> => Tolerance::MirrorBound,
            rsm_depth: Vec<f32> => Tolerance::MirrorBound,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "reflective_shadow_map",
    includes: &[super::LIGHTS, LRSM_VIEW],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement {
        binding: "rsm_depth",
    },
    mirror: "vxgi_cpu_mirror::reflective_shadow_map::rsm",
    summary: "reflective shadow map of one light view (spot cone or point-light cube face): albedo/pi E <n.l>, normal, <n.l>, normalised light-space depth, 2D Morton order (LRSM 5)",
);

/// The inputs every light-view kernel (this one, svo_photons) reads besides its own parameters:
/// `lights` (one default light of zero intensity when there is none: a binding cannot be empty) and
/// the light view's G-buffer `gb_position`, `gb_normal`, `gb_albedo`.
pub fn light_view_inputs(lights: &[GpuLight], gb: &Resources) -> Resources {
    let lights = HostBuffer::f32(bytemuck::cast_slice(&super::or_one(lights)));
    let mut resources = Resources::from([("lights".to_string(), lights.into())]);
    for name in ["gb_position", "gb_normal", "gb_albedo"] {
        resources.insert(name.into(), gb[name].clone());
    }
    resources
}

/// The RSM pass of `view` over the G-buffer `gb` the GPU ray-cast with `view.frame`.
pub fn case_for(
    shader: &Shader,
    ctx: &GpuContext,
    lights: &[GpuLight],
    view: &LightView,
    gb: &Resources,
    label: String,
    seed: u64,
) -> Case {
    let side = view.view.info[0];
    let n = (side * side) as usize;
    let inputs = light_view_inputs(lights, gb);
    let io = Io {
        view: Block(view.view),
        lights: field(&inputs, "lights"),
        gb_position: field(&inputs, "gb_position"),
        gb_normal: field(&inputs, "gb_normal"),
        gb_albedo: field(&inputs, "gb_albedo"),
        rsm_radiance: vec![[0.0; 4]; n],
        rsm_normal: vec![[0.0; 4]; n],
        rsm_depth: vec![0.0; n],
    };
    let pass = DECL.pass(shader, ctx, "rsm".into(), DECL.bind_by_name(), n as u64);
    io.case(label, seed, vec![pass])
        .with_effective_bytes(n as u64 * (48 + 36))
}

/// The G-buffer of `view` on the GPU (the scene's data with the view's frame).
pub fn view_gbuffer(ctx: &GpuContext, data: &SceneData, view: &LightView) -> Resources {
    let mut d = data.clone();
    d.frame = view.frame;
    gpu_gbuffer(ctx, &d)
}

/// The G-buffer of `view` by the mirror: (position, normal, albedo) per pixel, row-major.
pub fn view_gbuffer_mirror(data: &SceneData, view: &LightView) -> [Vec<[f32; 4]>; 3] {
    view_gbuffer_mirror_triangles(data, view).0
}

/// [`view_gbuffer_mirror`] and each pixel's triangle (gb_triangle).
pub fn view_gbuffer_mirror_triangles(
    data: &SceneData,
    view: &LightView,
) -> ([Vec<[f32; 4]>; 3], Vec<u32>) {
    use rayon::prelude::*;
    use vxgi_cpu_mirror::gbuffer as gbm;
    let tex = data.textures();
    let side = view.frame.size[0];
    let texels: Vec<gbm::Texel> = (0..side * side)
        .into_par_iter()
        .map(|i| {
            gbm::shade_pixel(
                &view.frame,
                &data.nodes,
                &data.triangles,
                i % side,
                i / side,
            )
        })
        .collect();
    (
        [
            texels.iter().map(|t| t.position).collect(),
            texels.iter().map(|t| t.normal).collect(),
            texels
                .iter()
                .map(|t| gbm::albedo(&data.materials, &data.triangles, &tex, t))
                .collect(),
        ],
        texels.iter().map(|t| t.triangle).collect(),
    )
}

/// The RSM of `view` by the mirrors: G-buffer ray-cast from the light, then this kernel's mirror.
pub fn rsm_mirror(data: &SceneData, view: &LightView) -> Rsm {
    let [pos, nrm, alb] = view_gbuffer_mirror(data, view);
    let r = vxgi_cpu_mirror::reflective_shadow_map::rsm(&view.view, &data.lights, &pos, &nrm, &alb);
    Rsm {
        side: view.view.info[0],
        radiance: r.radiance,
        normal: r.normal,
        depth: r.depth,
    }
}

/// The RSM of `view` on the GPU: G-buffer from the view, then this kernel.
pub fn rsm_on_gpu(ctx: &GpuContext, data: &SceneData, view: &LightView) -> anyhow::Result<Rsm> {
    let gb = view_gbuffer(ctx, data, view);
    let shader = DECL.shader()?;
    let case = case_for(&shader, ctx, &data.lights, view, &gb, "rsm".into(), 0);
    let out = case.run(
        ctx,
        &shader,
        DECL.name,
        &["rsm_radiance", "rsm_normal", "rsm_depth"],
    )?;
    let f4 = |n: &str| bytemuck::cast_slice::<u8, [f32; 4]>(&out.buffer(n).bytes).to_vec();
    Ok(Rsm {
        side: view.view.info[0],
        radiance: f4("rsm_radiance"),
        normal: f4("rsm_normal"),
        depth: out.buffer("rsm_depth").as_f32().to_vec(),
    })
}

/// The lights and light views (maps of `side`^2 texels) a light-view kernel's generated case draws
/// from: the scene's, or where a scene has no light left, a point light of zero intensity that is not
/// in the scene (its views still exercise the kernel).
pub fn case_views(data: &SceneData, side: u32) -> (Vec<GpuLight>, Vec<LightView>) {
    let views = light_views(&data.lights, data.bounds, side, data.frame.eye[3])
        .expect("every light kind has views");
    if views.is_empty() {
        let l = vec![GpuLight::default()];
        let v = light_views(&l, data.bounds, side, data.frame.eye[3]).expect("point light");
        (l, v)
    } else {
        (data.lights.clone(), views)
    }
}

pub struct ReflectiveShadowMap;

impl Kernel for ReflectiveShadowMap {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    /// A generated scene's lights; one of their views (every cube face comes round), RSM side 16..64.
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (scene, label) = generated_scene(seed, index);
        let data = SceneData::new(&scene);
        let side = [16u32, 32, 64][index % 3];
        let (lights, views) = case_views(&data, side);
        // Without a light of its own the scene's case is the zero light's first view.
        let face = if data.lights.is_empty() {
            0
        } else {
            (index / 3) % views.len()
        };
        let view = views[face];
        let gb = view_gbuffer(ctx, &data, &view);
        let label = if data.lights.is_empty() {
            format!("{label}, no light")
        } else {
            format!(
                "{label}, light {} view {face} of {}, {side}^2",
                view.view.info[1],
                views.len()
            )
        };
        case_for(shader, ctx, &lights, &view, &gb, label, seed)
    }

    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // Scene-scale arithmetic: no subnormals arise; one mode serves both (subnormal results are
        // accepted flushed by the harness anyway).
        let mut io = Io::read(data);
        let lights: &[GpuLight] = bytemuck::cast_slice(&io.lights);
        let r = rsm(
            &io.view.0,
            lights,
            &io.gb_position,
            &io.gb_normal,
            &io.gb_albedo,
        );
        (io.rsm_radiance, io.rsm_normal, io.rsm_depth) = (r.radiance, r.normal, r.depth);
        let mut out = io.outputs();
        out.extend([
            bound("rsm_radiance", &r.radiance_bound),
            bound("rsm_normal", &r.normal_bound),
        ]);
        out.extend([bound("rsm_depth", &r.depth_bound)]);
        out
    }
}
