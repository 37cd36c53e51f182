//! Declaration of `kernels/triangle_setup.wgsl` (mirror: `vxgi_cpu_mirror::triangle_setup`): a mesh's
//! triangles on voxelize's integer lattice, on the GPU, and voxelize's indirect dispatch. [`MeshInput`]
//! is a scene's mesh as the kernel reads it; the host's [`super::voxelize::prepare`] runs the mirror
//! over the same input (one definition of the setup). Cases are the generated scenes of
//! [`super::gbuffer::generated_scene`] in grids of 8^3..512^3, with lattice and fixed-point ties,
//! vertices outside the grid, degenerate triangles, huge and subnormal normals, texture coordinates
//! far from the origin and at rounding ties, and material indices past the table.
use super::gbuffer::generated_scene;
use super::voxelize::{fixed_lut, frame_of, VoxelFrame};
use crate::scene::Scene;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::triangle_setup::{
    setup, setup_triangle, uv_range_fits, SetupMaterial, SetupParams,
};
use vxgi_cpu_mirror::voxelize::{VoxInput, VoxTriangle, FIXED, SUB};
use vxgi_harness::prelude::*;
use vxgi_harness::run::{grid_for, Pass};

vxgi_harness::bindings! {
    /// triangle_setup's bindings: the mesh and its materials in; the lattice triangles and
    /// voxelize's indirect dispatch out.
    pub struct Io {
        inputs: {
            setup_params: Block<SetupParams>,
            mesh_positions: Vec<[f32; 4]>,
            mesh_normals: Vec<[f32; 4]>,
            mesh_uvs: Vec<[f32; 2]>,
            mesh_triangles: Vec<[u32; 4]>,
            setup_materials: Structs<SetupMaterial>,
        }
        outputs: {
            // Correctly rounded subtraction and multiplication, round half to even and integer
            // arithmetic (the WGSL header): exact.
            vox_triangles: Structs<VoxTriangle> => Tolerance::Exact,
            // Integer maxima: exact in any order.
            vox_dispatch: Vec<u32> => Tolerance::Exact,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "triangle_setup",
    includes: &[super::VOX_TRIANGLE],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerItem {
        what: "triangle (invocation 0 also writes the dispatch's x and z)",
    },
    mirror: "vxgi_cpu_mirror::triangle_setup::setup",
    summary: "a mesh's triangles on voxelize's integer lattice (vertices, sample count, fixed-point normals, albedo, texture coordinates) and voxelize's indirect dispatch",
);

/// A mesh as triangle_setup reads it, with voxelize's texture atlas and sRGB table.
#[derive(Clone, Debug)]
pub struct MeshInput {
    pub params: SetupParams,
    pub positions: Vec<[f32; 4]>,
    pub normals: Vec<[f32; 4]>,
    /// One per vertex (zeros where the mesh has none).
    pub uvs: Vec<[f32; 2]>,
    /// `[a, b, c, material]`.
    pub triangles: Vec<[u32; 4]>,
    /// The scene's materials, then one default (grey 0.8, untextured) that an index past them reads.
    pub materials: Vec<SetupMaterial>,
    /// voxelize's texture atlas and sRGB-to-fixed-point table.
    pub texels: Vec<u32>,
    pub lut: Vec<u32>,
}

impl MeshInput {
    /// `scene`'s mesh in the grid `frame`.
    pub fn of(scene: &Scene, frame: VoxelFrame) -> Self {
        let mesh = &scene.mesh;
        let (texels, placement) = crate::trace::texture_atlas(scene);
        let albedo = |kd: [f32; 3]| {
            let q = |c: f32| (c.clamp(0.0, 1.0) * FIXED).round() as u32;
            [q(kd[0]), q(kd[1]), q(kd[2]), 0]
        };
        let mut materials: Vec<SetupMaterial> = scene
            .materials
            .iter()
            .zip(&placement)
            .map(|(m, &texture)| SetupMaterial {
                albedo: albedo(m.diffuse),
                texture,
            })
            .collect();
        materials.push(SetupMaterial {
            albedo: albedo([0.8; 3]),
            texture: [0; 4],
        });
        let vec4 = |v: &glam::Vec3| [v.x, v.y, v.z, 0.0];
        Self {
            params: SetupParams {
                origin: [
                    frame.origin.x,
                    frame.origin.y,
                    frame.origin.z,
                    SUB as f32 / frame.voxel,
                ],
                side: frame.side,
                triangles: mesh.triangles.len() as u32,
                _pad: [0; 2],
            },
            positions: mesh.positions.iter().map(vec4).collect(),
            normals: mesh.normals.iter().map(vec4).collect(),
            uvs: (0..mesh.positions.len())
                .map(|i| mesh.uvs.get(i).map_or([0.0; 2], |t| [t.x, t.y]))
                .collect(),
            triangles: mesh
                .triangles
                .iter()
                .zip(&mesh.material)
                .map(|(t, &m)| [t[0], t[1], t[2], m])
                .collect(),
            materials,
            texels,
            lut: fixed_lut(),
        }
    }

    /// The mirror's triangles and voxelize's input ([`VoxInput`]), and voxelize's dispatch.
    pub fn mirror(&self) -> (VoxInput, [u32; 3]) {
        let (tris, dispatch) = setup(
            &self.params,
            &self.positions,
            &self.normals,
            &self.uvs,
            &self.triangles,
            &self.materials,
        );
        let input = VoxInput {
            tris,
            texels: self.texels.clone(),
            lut: self.lut.clone(),
        };
        (input, dispatch)
    }

    /// The first triangle whose texture coordinates voxelize's 32-bit interpolation cannot hold
    /// ([`uv_range_fits`] of the mirror's setup, run for the textured triangles alone: untextured
    /// ones always fit), checked at load before the GPU sets the triangles up.
    pub fn uv_range_error(&self) -> Option<usize> {
        let last = self.materials.len() - 1;
        self.triangles.iter().position(|&t| {
            let texture = self.materials[(t[3] as usize).min(last)].texture;
            texture[1] != 0
                && texture[2] != 0
                && !uv_range_fits(&setup_triangle(
                    &self.params,
                    &self.positions,
                    &self.normals,
                    &self.uvs,
                    t,
                    &self.materials,
                ))
        })
    }

    /// The kernel's bindings (outputs zeroed; one zero element where a list is empty: a binding
    /// cannot be).
    pub fn io(&self) -> Io {
        use super::or_one;
        Io {
            setup_params: Block(self.params),
            mesh_positions: or_one(&self.positions),
            mesh_normals: or_one(&self.normals),
            mesh_uvs: or_one(&self.uvs),
            mesh_triangles: or_one(&self.triangles),
            setup_materials: Structs(self.materials.clone()),
            vox_triangles: Structs(or_one(&vec![VoxTriangle::default(); self.triangles.len()])),
            vox_dispatch: vec![0; 3],
        }
    }

    /// The one pass, a triangle per invocation.
    pub fn pass(&self, ctx: &GpuContext) -> Pass {
        let max = ctx.limits().max_compute_workgroups_per_dimension;
        Pass::direct(
            "triangle_setup",
            "main",
            DECL.bind_by_name(),
            grid_for(self.triangles.len() as u64, 64, max),
        )
    }
}

/// A case of `input`.
pub fn case_for(ctx: &GpuContext, input: &MeshInput, label: String, seed: u64) -> Case {
    input.io().case(label, seed, vec![input.pass(ctx)])
}

/// `mesh`'s values made hard for the setup, by `rng`: vertices at lattice ties and outside the grid,
/// normals at fixed-point ties, huge and subnormal, texture coordinates at ties and far from the
/// origin, degenerate triangles and material indices past the table.
fn stressed(mut m: MeshInput, rng: &mut ChaCha8Rng) -> MeshInput {
    let [ox, oy, oz, scale] = m.params.origin;
    let o = [ox, oy, oz];
    let side = m.params.side as f32;
    for p in &mut m.positions {
        match rng.random_range(0..6) {
            // Half a lattice step past a lattice point (a tie where the arithmetic is exact).
            0 => {
                for k in 0..3 {
                    let q = rng.random_range(0..(side as u32 * SUB as u32)) as f32 + 0.5;
                    p[k] = o[k] + q / scale;
                }
            }
            // Outside the grid: clamped to its faces.
            1 => {
                p[rng.random_range(0..3)] +=
                    [-1.0, 1.0][rng.random_range(0..2)] * side * 2.0 / scale * SUB as f32
            }
            _ => {}
        }
    }
    for n in &mut m.normals {
        match rng.random_range(0..8) {
            0 => n[0] = (rng.random_range(-4096..4096) as f32 + 0.5) / FIXED,
            1 => n[1] = [1e9, -1e9, 3e5][rng.random_range(0..3)],
            2 => n[2] = f32::from_bits(rng.random_range(1..0x0080_0000)),
            _ => {}
        }
    }
    for t in &mut m.uvs {
        match rng.random_range(0..8) {
            0 => t[0] = (rng.random_range(-1000..1000) as f32 + 0.5) / 64.0,
            1 => t[1] = [1e6, -1e6, 12345.678][rng.random_range(0..3)],
            _ => {}
        }
    }
    let materials = m.materials.len() as u32;
    for t in &mut m.triangles {
        match rng.random_range(0..10) {
            0 => t[1] = t[0],
            1 => t[2] = t[1],
            2 => t[3] = materials + rng.random_range(0..3),
            _ => {}
        }
    }
    m
}

pub struct TriangleSetup;

/// Grid sides of the cases: small grids as the generated scenes' others, and the largest lattice.
const SIDES: [u32; 5] = [8, 16, 64, 128, 512];

impl Kernel for TriangleSetup {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (scene, label) = generated_scene(seed, index);
        let side = SIDES[(index / 4) % SIDES.len()];
        let input = MeshInput::of(&scene, frame_of(&scene.mesh, side));
        let (input, label) = if index % 3 == 2 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed ^ (index as u64).wrapping_mul(0x9e37));
            (
                stressed(input, &mut rng),
                format!("{label}, {side}^3, stressed"),
            )
        } else {
            (input, format!("{label}, {side}^3"))
        };
        case_for(ctx, &input, label, seed)
    }

    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        // Flushing subnormals changes nothing: a subnormal position difference, normal or texture
        // coordinate rounds to 0 either way, and no other value can be one.
        let mut io = Io::read(data);
        let n = io.setup_params.0.triangles as usize;
        let (tris, dispatch) = setup(
            &io.setup_params.0,
            &io.mesh_positions,
            &io.mesh_normals,
            &io.mesh_uvs,
            &io.mesh_triangles[..n],
            &io.setup_materials.0,
        );
        if n > 0 {
            io.vox_triangles.0 = tris;
        }
        io.vox_dispatch = dispatch.to_vec();
        io.outputs()
    }
}
