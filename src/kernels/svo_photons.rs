//! Declaration of `kernels/svo_photons.wgsl` (mirror: `vxgi_cpu_mirror::svo_photons`): vct-svo's light
//! injection, one photon per texel of a light-view map (the G-buffer ray-cast from the light's view,
//! the views lrsm uses: a spot's cone, a point light's six cube faces, a directional light's
//! orthographic view of the scene), landing in the voxel grid the octree's leaves cover.
use super::reflective_shadow_map::view_gbuffer;
use super::sparse_voxel_octree::{to_fixed, SvoError};
use super::voxelize::VoxelFrame;
use crate::lrsm::{light_views, LightView};
use crate::trace::SceneData;
use vxgi_cpu_mirror::bvh_trace::GpuTriangle;
use vxgi_cpu_mirror::direct_light::{GpuLight, GpuMaterial};
use vxgi_cpu_mirror::sparse_voxel_octree::Fragment;
use vxgi_cpu_mirror::svo_photons::{photons, PhotonParams};
use vxgi_harness::bindings::field;
use vxgi_harness::prelude::*;

vxgi_harness::bindings! {
    /// svo_photons' bindings: the light view's G-buffer, the lights and the scene's triangles and
    /// materials in; per texel the photon's voxel, its value and its specular part out.
    pub struct Io {
        inputs: {
            params: Block<PhotonParams>,
            lights: Vec<[f32; 4]>,
            gb_position: Vec<[f32; 4]>,
            gb_normal: Vec<[f32; 4]>,
            gb_albedo: Vec<[f32; 4]>,
            gb_triangle: Vec<u32>,
            // Six vec4<f32> per triangle (`GpuTriangle`).
            triangles: Vec<[f32; 4]>,
            materials: Structs<GpuMaterial>,
        }
        outputs: {
            // The voxel: (p - origin) * inv_h, one correctly rounded subtraction and multiplication
            // per axis (nothing to contract), floor and clamp: exact.
            photon_pos: Vec<[u32; 4]> => Tolerance::Exact,
            // The value: the light contract's arithmetic, a dot product and a cube over a sqrt,
            // within the mirror's per-texel bound (64 ULP + the depth's cancellation + a spot's soft
            // edge + the range of the share: its plane's area in the voxel, over the rounding of the
            // plane's offset, which is ill-conditioned where a tilted plane passes a cell's face).
            photon_value: Vec<[f32; 4]> => Tolerance::MirrorBound,
            // The specular photon: the same arithmetic without 1/pi (the same share and its range),
            // the mirror direction (a dot product and two products of unit vectors) and the lobe
            // length; the mirror's bound adds the light direction's error.
            photon_spec: Vec<[f32; 4]> => Tolerance::MirrorBound,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "svo_photons",
    includes: &[super::LIGHTS, super::SCENE_TYPES],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement {
        binding: "photon_pos",
    },
    mirror: "vxgi_cpu_mirror::svo_photons::photons",
    summary: "light injection of vct-svo: one photon per light-view texel, its reflected flux as radiance of the voxel it lands in (VCT 8.2), and on glossy surfaces its specular part as a mirror-direction lobe (VCT 7)",
);

/// The photon pass's parameters for `view` (its G-buffer frame) over the voxel grid `frame`.
pub fn params_for(view: &LightView, frame: &VoxelFrame) -> PhotonParams {
    let f = &view.frame;
    let side = f.size[0];
    // The G-buffer's right vector spans half the image: tan(half fov) (perspective) or the half width
    // (orthographic); a texel is 2 |right| / side wide.
    let half = glam::Vec3::new(f.right[0], f.right[1], f.right[2]).length();
    let s = 2.0 * half / side as f32;
    PhotonParams {
        eye: [f.eye[0], f.eye[1], f.eye[2], s * s],
        forward: [f.forward[0], f.forward[1], f.forward[2], 0.0],
        grid: [
            frame.origin.x,
            frame.origin.y,
            frame.origin.z,
            1.0 / frame.voxel,
        ],
        info: [side, view.view.info[1], frame.side, view.view.info[3]],
    }
}

/// The photon pass over the light-view G-buffer `gb` of the scene `data` (its triangles and materials
/// give the texels' Ks and Ns).
#[allow(clippy::too_many_arguments)]
pub fn case_for(
    shader: &Shader,
    ctx: &GpuContext,
    data: &SceneData,
    lights: &[GpuLight],
    params: &PhotonParams,
    gb: &Resources,
    label: String,
    seed: u64,
) -> Case {
    let n = (params.info[0] * params.info[0]) as usize;
    let inputs = super::reflective_shadow_map::light_view_inputs(lights, gb);
    let materials = super::or_one(&data.materials);
    let io = Io {
        params: Block(*params),
        lights: field(&inputs, "lights"),
        gb_position: field(&inputs, "gb_position"),
        gb_normal: field(&inputs, "gb_normal"),
        gb_albedo: field(&inputs, "gb_albedo"),
        gb_triangle: field(gb, "gb_triangle"),
        triangles: bytemuck::cast_slice(&data.triangles).to_vec(),
        materials: Structs(materials),
        photon_pos: vec![[0; 4]; n],
        photon_value: vec![[0.0; 4]; n],
        photon_spec: vec![[0.0; 4]; n],
    };
    let pass = DECL.pass(shader, ctx, "photons".into(), DECL.bind_by_name(), n as u64);
    io.case(label, seed, vec![pass])
        .with_effective_bytes(n as u64 * (52 + 48))
}

/// The photons of a scene as octree fragments: the diffuse ones (`light`) and the specular ones
/// (`spec`, encoded `((q + w) / 2, w)` for the unsigned fixed point, see [`spec_fragments`]).
#[derive(Clone, Debug, Default)]
pub struct PhotonFragments {
    pub light: Vec<Fragment>,
    pub spec: Vec<Fragment>,
    /// Texels cast.
    pub texels: u64,
}

impl PhotonFragments {
    /// Add the light to a frame's fragments; with `lobes` also the specular photons' points (structure
    /// only: their values go into the specular pool) and return the specular photons, else none.
    pub fn join_into(self, frags: &mut Vec<Fragment>, lobes: bool) -> Vec<Fragment> {
        frags.extend(self.light);
        if !lobes {
            return Vec::new();
        }
        frags.extend(super::svo_cone_trace::points_of(&self.spec));
        self.spec
    }
}

/// The photons of every light view as the kernel writes them (floats, before the octree's fixed
/// point): `pos` (leaf lattice point, `w` = 1 where the texel hit a front face), `value` (the light
/// it carries), `spec` (its specular part `(q, w)`).
#[derive(Default)]
pub struct Photons {
    pub pos: Vec<[u32; 4]>,
    pub value: Vec<[f32; 4]>,
    pub spec: Vec<[f32; 4]>,
}

impl Photons {
    /// Their fragments in the octree's fixed point (`scale` steps per unit): one per texel that hit a
    /// front face and carries light, and one per texel of a glossy surface for its specular part.
    pub fn fragments(&self, scale: f32) -> Result<PhotonFragments, SvoError> {
        Ok(PhotonFragments {
            light: to_fragments(&self.pos, &self.value, scale)?,
            spec: spec_fragments(&self.pos, &self.spec, scale)?,
            texels: self.pos.len() as u64,
        })
    }

    /// Every value a fragment of these photons stores, with its lattice point (the light's RGB, the
    /// specular part's encoded `(q + w) / 2, w`): what [`super::svo_cone_trace::fixed_scale`] bounds.
    pub fn values(&self) -> impl Iterator<Item = ([u32; 3], [f32; 4])> + '_ {
        self.pos
            .iter()
            .zip(self.value.iter().zip(&self.spec))
            .filter(|(p, _)| p[3] != 0)
            .map(|(p, (v, q))| {
                let e = |a: usize| ((q[a] + q[3]) * 0.5).max(0.0);
                let spec_max = [e(0), e(1), e(2), q[3]].into_iter().fold(0.0f32, f32::max);
                ([p[0], p[1], p[2]], [v[0], v[1], v[2], spec_max])
            })
    }
}

/// Photon fragments of every light of `data` (light-view maps `map_side`^2 per view) on the GPU, in the
/// octree's fixed point (`scale` steps per unit): [`photons_on_gpu`], then [`Photons::fragments`].
pub fn photon_fragments(
    ctx: &GpuContext,
    data: &SceneData,
    frame: &VoxelFrame,
    map_side: u32,
    scale: f32,
) -> anyhow::Result<PhotonFragments> {
    Ok(photons_on_gpu(ctx, data, frame, map_side)?.fragments(scale)?)
}

/// The photons of every light of `data` (light-view maps `map_side`^2 per view) on the GPU.
pub fn photons_on_gpu(
    ctx: &GpuContext,
    data: &SceneData,
    frame: &VoxelFrame,
    map_side: u32,
) -> anyhow::Result<Photons> {
    let views = light_views(&data.lights, data.bounds, map_side, data.frame.eye[3])?;
    let shader = DECL.shader()?;
    let mut out = Photons::default();
    for view in &views {
        let gb = view_gbuffer(ctx, data, view);
        let params = params_for(view, frame);
        let case = case_for(
            &shader,
            ctx,
            data,
            &data.lights,
            &params,
            &gb,
            "photons".into(),
            0,
        );
        let res = case.run(
            ctx,
            &shader,
            DECL.name,
            &["photon_pos", "photon_value", "photon_spec"],
        )?;
        out.pos
            .extend_from_slice(bytemuck::cast_slice(&res.buffer("photon_pos").bytes));
        out.value
            .extend_from_slice(bytemuck::cast_slice(&res.buffer("photon_value").bytes));
        out.spec
            .extend_from_slice(bytemuck::cast_slice(&res.buffer("photon_spec").bytes));
    }
    Ok(out)
}

/// [`photon_fragments`] by the mirrors alone (the light-view G-buffers and the photons).
pub fn mirror_photon_fragments(
    data: &SceneData,
    frame: &VoxelFrame,
    map_side: u32,
    scale: f32,
) -> anyhow::Result<PhotonFragments> {
    Ok(mirror_photons(data, frame, map_side)?.fragments(scale)?)
}

/// [`photons_on_gpu`] by the mirrors alone.
pub fn mirror_photons(
    data: &SceneData,
    frame: &VoxelFrame,
    map_side: u32,
) -> anyhow::Result<Photons> {
    let views = light_views(&data.lights, data.bounds, map_side, data.frame.eye[3])?;
    let mut out = Photons::default();
    for view in &views {
        let (gb, tri) = super::reflective_shadow_map::view_gbuffer_mirror_triangles(data, view);
        let ph = photons(
            &params_for(view, frame),
            &data.lights,
            [&gb[0], &gb[1], &gb[2]],
            &tri,
            &data.triangles,
            &super::or_one(&data.materials),
        );
        out.pos.extend(ph.iter().map(|p| p.pos));
        out.value.extend(ph.iter().map(|p| p.value));
        out.spec.extend(ph.iter().map(|p| p.spec));
    }
    Ok(out)
}

/// Fragments of the specular photons that exist (`w > 0`), encoded for the unsigned fixed point:
/// `((q + w) / 2, w)` per axis (`|q| <= w`; a rounding below zero is clamped), so a sum decodes as
/// `q = 2 xyz - w` at any level.
pub fn spec_fragments(
    pos: &[[u32; 4]],
    spec: &[[f32; 4]],
    scale: f32,
) -> Result<Vec<Fragment>, SvoError> {
    fragments_of(pos, spec, |q| {
        if q[3] <= 0.0 {
            return Ok(None);
        }
        let e = |a: usize| to_fixed(((q[a] + q[3]) * 0.5).max(0.0), scale);
        let value = [e(0)?, e(1)?, e(2)?, to_fixed(q[3], scale)?];
        Ok((value[3] != 0).then_some(value))
    })
}

/// Fragments of the photons that exist and carry light (in fixed point with `scale`).
pub fn to_fragments(
    pos: &[[u32; 4]],
    value: &[[f32; 4]],
    scale: f32,
) -> Result<Vec<Fragment>, SvoError> {
    fragments_of(pos, value, |v| {
        let e = |a: usize| to_fixed(v[a], scale);
        let value = [e(0)?, e(1)?, e(2)?, 0];
        Ok((value != [0; 4]).then_some(value))
    })
}

/// A fragment per photon that exists (`w` of its point non-zero) and whose value `encode` keeps.
fn fragments_of(
    pos: &[[u32; 4]],
    values: &[[f32; 4]],
    encode: impl Fn(&[f32; 4]) -> Result<Option<[u32; 4]>, SvoError>,
) -> Result<Vec<Fragment>, SvoError> {
    let mut out = Vec::new();
    for (p, v) in pos.iter().zip(values).filter(|(p, _)| p[3] != 0) {
        if let Some(value) = encode(v)? {
            let pos = [p[0], p[1], p[2]];
            out.push(Fragment {
                pos,
                _pad: 0,
                value,
            });
        }
    }
    Ok(out)
}

pub struct SvoPhotons;

impl Kernel for SvoPhotons {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    /// A generated scene's lights, one of their views (every cube face comes round), map side 16..64,
    /// grids of 16..64 voxels; a third of the texels made hard (`hard_texels`).
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (scene, label) = super::gbuffer::generated_scene(seed, index);
        let data = SceneData::new(&scene);
        let side = [16u32, 32, 64][index % 3];
        let grid = [16u32, 32, 64][(index / 3) % 3];
        let frame = super::voxelize::frame_of(&scene.mesh, grid);
        let (lights, views) = super::reflective_shadow_map::case_views(&data, side);
        let face = (index / 9) % views.len();
        let view = views[face];
        let mut gb = view_gbuffer(ctx, &data, &view);
        let params = params_for(&view, &frame);
        hard_texels(&mut gb, &params);
        case_for(
            shader,
            ctx,
            &data,
            &lights,
            &params,
            &gb,
            format!(
                "{label}, light {} view {face} of {}, {side}^2 texels, {grid}^3 voxels",
                view.view.info[1],
                views.len()
            ),
            seed,
        )
    }

    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // Scene-scale arithmetic; a normal's subnormal component decides cell_area's branches the
        // same way flushed or not, and elsewhere adds less than the bounds' absolute terms.
        let mut io = Io::read(data);
        let ph = photons(
            &io.params.0,
            bytemuck::cast_slice(&io.lights),
            [&io.gb_position, &io.gb_normal, &io.gb_albedo],
            &io.gb_triangle,
            bytemuck::cast_slice::<_, GpuTriangle>(&io.triangles),
            &io.materials.0,
        );
        io.photon_pos = ph.iter().map(|p| p.pos).collect();
        io.photon_value = ph.iter().map(|p| p.value).collect();
        io.photon_spec = ph.iter().map(|p| p.spec).collect();
        let bounds = |f: fn(&vxgi_cpu_mirror::svo_photons::Photon) -> [f32; 4]| -> Vec<f32> {
            ph.iter().flat_map(f).collect()
        };
        let mut out = io.outputs();
        out.extend([
            bound("photon_value", &bounds(|p| p.bound)),
            bound("photon_spec", &bounds(|p| p.spec_bound)),
        ]);
        out
    }
}

/// Texels where the plane's area in its cell is hardest, the photon texels at indices divisible by 3:
/// the point moved onto the nearest cell face along its normal's largest axis (a rounding either side
/// of it once the kernel scales by 1 / voxel size), and two in three of those with the normal turned
/// along that axis but for a tilt of a rounding (1e-7) or a subnormal component (1e-40), of either
/// sign.
fn hard_texels(gb: &mut Resources, p: &PhotonParams) {
    let mut pos: Vec<[f32; 4]> = field(gb, "gb_position");
    let mut nrm: Vec<[f32; 4]> = field(gb, "gb_normal");
    let (origin, inv_h) = (glam::Vec3::from_slice(&p.grid[..3]), p.grid[3]);
    for (i, (x, n)) in pos.iter_mut().zip(&mut nrm).enumerate() {
        if n[3] <= 0.0 || i % 3 != 0 {
            continue;
        }
        let axis = (0..3)
            .max_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
            .unwrap();
        let cell = ((x[axis] - origin[axis]) * inv_h).round();
        x[axis] = origin[axis] + cell / inv_h;
        let tilt = match i % 9 {
            3 => 1e-7,
            6 => 1e-40,
            _ => continue,
        } * if i % 18 < 9 { 1.0 } else { -1.0 };
        let sign = n[axis].signum();
        *n = [tilt, tilt, tilt, n[3]];
        n[axis] = sign;
    }
    gb.insert(
        "gb_position".into(),
        HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(&pos))),
    );
    gb.insert(
        "gb_normal".into(),
        HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(&nrm))),
    );
}
