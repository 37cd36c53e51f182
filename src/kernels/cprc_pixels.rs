//! Declaration of `kernels/cprc_pixels.wgsl` (mirror: `vxgi_cpu_mirror::cprc_pixels`): cprc's
//! per-pixel inputs from the G-buffer (`inputs`) and its indirect and AO images from the gather's
//! results (`compose`). Cases are generated G-buffers: unit, non-unit, zero and NaN normals, back
//! faces and background, triangles out of range, materials past the lobe table, infinite positions,
//! gathered values over a wide range of magnitudes.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vxgi_cpu_mirror::bvh_trace::GpuTriangle;
use vxgi_cpu_mirror::cprc_pixels::{self as m, GPixel};
use vxgi_cpu_mirror::gbuffer::Frame;
use vxgi_harness::prelude::*;
use vxgi_harness::run::Pass;

vxgi_harness::bindings! {
    /// cprc_pixels' bindings: the G-buffer, the lobe table and the gather's results in; the
    /// per-pixel inputs of the distribution (`inputs`) and the indirect and AO images (`compose`) out.
    pub struct Io {
        inputs: {
            frame: Block<Frame>,
            // Six vec4<f32> per triangle (`GpuTriangle`).
            triangles: Vec<[f32; 4]>,
            lobes: Vec<[f32; 4]>,
            gb_position: Vec<[f32; 4]>,
            gb_normal: Vec<[f32; 4]>,
            gb_triangle: Vec<u32>,
            gb_albedo: Vec<[f32; 4]>,
            diffuse: Vec<[f32; 4]>,
            glossy: Vec<[f32; 4]>,
        }
        outputs: {
            // One correctly rounded product and round per component, integer packing: exact.
            normals: Vec<[u32; 2]> => Tolerance::Exact,
            // A difference and a dot product (see `cprc_pixels::pixel_bounds`).
            depth: Vec<f32> => Tolerance::MirrorBound,
            // Copies.
            positions: Vec<[f32; 4]> => Tolerance::Exact,
            // Two normalisations and a reflection (see `cprc_pixels::pixel_bounds`).
            pixel_dirs: Vec<[f32; 4]> => Tolerance::MirrorBound,
            // A table lookup.
            px_specular: Vec<[f32; 4]> => Tolerance::Exact,
            // Three products and a sum per component (see `cprc_pixels::compose_bound`).
            indirect: Vec<[f32; 4]> => Tolerance::MirrorBound,
            // Constants chosen by exact comparisons.
            ao: Vec<[f32; 4]> => Tolerance::Exact,
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "cprc_pixels",
    includes: &[super::SCENE_TYPES],
    entry: "inputs",
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "depth" },
    mirror: "vxgi_cpu_mirror::cprc_pixels::pixel",
    summary: "cprc's per-pixel inputs from the G-buffer (packed normals, depth, directions, Ks) and its indirect and AO images from the gather (CPRC 3.2-3.3)",
);

/// A G-buffer and what the two entries read besides it, by binding.
pub struct PixelData<'a> {
    pub frame: &'a Frame,
    pub triangles: &'a [GpuTriangle],
    pub lobes: &'a [[f32; 4]],
    pub position: &'a [[f32; 4]],
    pub normal: &'a [[f32; 4]],
    pub triangle: &'a [u32],
    pub albedo: &'a [[f32; 4]],
    /// The gather's results (`compose` reads them).
    pub diffuse: &'a [[f32; 4]],
    pub glossy: &'a [[f32; 4]],
}

/// The bindings over `d`, outputs zeroed.
fn io(d: &PixelData) -> Io {
    let n = d.position.len();
    Io {
        frame: Block(*d.frame),
        triangles: bytemuck::cast_slice(d.triangles).to_vec(),
        lobes: d.lobes.to_vec(),
        gb_position: d.position.to_vec(),
        gb_normal: d.normal.to_vec(),
        gb_triangle: d.triangle.to_vec(),
        gb_albedo: d.albedo.to_vec(),
        diffuse: d.diffuse.to_vec(),
        glossy: d.glossy.to_vec(),
        normals: vec![[0; 2]; n],
        depth: vec![0.0; n],
        positions: vec![[0.0; 4]; n],
        pixel_dirs: vec![[0.0; 4]; 2 * n],
        px_specular: vec![[0.0; 4]; n],
        indirect: vec![[0.0; 4]; n],
        ao: vec![[0.0; 4]; n],
    }
}

/// The resources `inputs` writes for `pixels` pixels, zeroed (an earlier stage of a chain, or the
/// kernel, fills them), by binding.
pub fn outputs(pixels: usize) -> Resources {
    let none: [[f32; 4]; 0] = [];
    let zero = vec![[0.0; 4]; pixels];
    let d = PixelData {
        frame: &Frame::default(),
        triangles: &[],
        lobes: &none,
        position: &zero,
        normal: &none,
        triangle: &[],
        albedo: &none,
        diffuse: &none,
        glossy: &none,
    };
    let mut r = io(&d).resources();
    r.retain(|name, _| {
        ["normals", "depth", "positions", "pixel_dirs", "px_specular"].contains(&name.as_str())
    });
    r
}

/// The pass of `entry` (`inputs` or `compose`) over `pixels` pixels.
pub fn pass(ctx: &GpuContext, entry: &str, pixels: usize) -> Pass {
    Pass::linear(ctx, entry, entry, DECL.bind_by_name(), pixels as u64)
}

/// Both entries over `d` (`inputs`, then `compose` on what `inputs` wrote), checking every output.
pub fn case_for(ctx: &GpuContext, d: &PixelData, label: String, seed: u64) -> Case {
    let n = d.position.len();
    let passes = vec![pass(ctx, "inputs", n), pass(ctx, "compose", n)];
    io(d)
        .case(label, seed, passes)
        .with_linear_indexing()
        .with_effective_bytes(n as u64 * (16 * 4 + 4 + 8 + 4 + 16 + 32 + 16 + 32))
}

/// The lobe table of a scene's materials: (Ks, glossy mip level in a cache of `res`^2 texels, -1
/// without Ks), as `inputs` reads it.
pub fn lobes(materials: &[vxgi_cpu_mirror::direct_light::GpuMaterial], res: u32) -> Vec<[f32; 4]> {
    let mut t: Vec<[f32; 4]> = materials
        .iter()
        .map(|m| {
            let glossy = m.specular[..3].iter().any(|&k| k != 0.0);
            let lf = if glossy {
                crate::cprc::glossy_level(m.diffuse[3], res)
            } else {
                -1.0
            };
            [m.specular[0], m.specular[1], m.specular[2], lf]
        })
        .collect();
    if t.is_empty() {
        t.push([0.0, 0.0, 0.0, -1.0]);
    }
    t
}

/// A generated G-buffer of `w` x `h` pixels seen from `frame`'s eye: surface pixels in front of the
/// camera with unit normals (some non-unit, zero, NaN or infinite), back faces, background; some
/// triangle indices out of range and some positions infinite.
#[allow(clippy::type_complexity)]
pub fn generated(
    seed: u64,
    w: u32,
    h: u32,
    frame: &Frame,
    triangles: u32,
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<u32>, Vec<[f32; 4]>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let eye = glam::Vec3::from_slice(&frame.eye[..3]);
    let fwd = glam::Vec3::from_slice(&frame.forward[..3]);
    let n = (w * h) as usize;
    let (mut pos, mut nrm, mut tri, mut alb) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    for _ in 0..n {
        let kind = rng.random_range(0..20);
        if kind == 0 {
            pos.push([0.0, 0.0, 0.0, -1.0]);
            nrm.push([0.0; 4]);
            tri.push(u32::MAX);
            alb.push([0.0; 4]);
            continue;
        }
        let jitter = glam::Vec3::new(
            rng.random_range(-3.0..3.0),
            rng.random_range(-3.0..3.0),
            rng.random_range(-3.0..3.0),
        );
        let p = eye + fwd * rng.random_range(0.2f32..50.0) + jitter * 0.5;
        let dir = glam::Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .normalize_or(glam::Vec3::Y);
        let normal = match kind {
            1 => [dir.x * 3.0, dir.y * 3.0, dir.z * 3.0],
            2 => [0.0; 3],
            3 => [f32::NAN, 0.0, 1.0],
            4 => [f32::INFINITY, 0.0, 0.0],
            // Axis-aligned: components on the quantisation's exact values.
            5 => [0.0, 1.0, 0.0],
            _ => dir.to_array(),
        };
        let side = if kind == 6 { -1.0 } else { 1.0 };
        let mut p4 = [p.x, p.y, p.z, (p - eye).length()];
        if kind == 7 {
            p4[0] = f32::INFINITY;
        }
        pos.push(p4);
        nrm.push([normal[0], normal[1], normal[2], side]);
        tri.push(if kind == 8 {
            triangles + 3
        } else {
            rng.random_range(0..triangles)
        });
        alb.push([rng.random(), rng.random(), rng.random(), 0.0]);
    }
    (pos, nrm, tri, alb)
}

pub struct CprcPixels;

impl Kernel for CprcPixels {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, _shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (w, h) = [(64, 48), (37, 23), (1, 1), (256, 128)][index % 4];
        let seed = seed ^ (index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let frame = Frame {
            eye: [
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
                1e-4,
            ],
            forward: {
                let f = glam::Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )
                .normalize_or(glam::Vec3::Z);
                [f.x, f.y, f.z, 0.0]
            },
            size: [w, h, 1, 0],
            ..Default::default()
        };
        // Triangles whose materials run one past the lobe table (clamped to its last entry).
        let lobes = vec![
            [0.0, 0.0, 0.0, -1.0],
            [0.5, 0.4, 0.3, 2.25],
            [0.04, 0.04, 0.04, 0.0],
        ];
        let triangles: Vec<GpuTriangle> = (0..7)
            .map(|t| GpuTriangle {
                a: [0.0, 0.0, 0.0, (t % 4) as f32],
                ..Default::default()
            })
            .collect();
        let (pos, nrm, tri, alb) = generated(seed, w, h, &frame, triangles.len() as u32);
        let n = pos.len();
        let magnitude = |r: &mut ChaCha8Rng| {
            let e = r.random_range(-20..20);
            [0, 1, 2].map(|_| r.random::<f32>() * 2f32.powi(e))
        };
        let (diffuse, glossy): (Vec<[f32; 4]>, Vec<[f32; 4]>) = (0..n)
            .map(|_| {
                let (d, g) = (magnitude(&mut rng), magnitude(&mut rng));
                ([d[0], d[1], d[2], 0.0], [g[0], g[1], g[2], 0.0])
            })
            .unzip();
        let d = PixelData {
            frame: &frame,
            triangles: &triangles,
            lobes: &lobes,
            position: &pos,
            normal: &nrm,
            triangle: &tri,
            albedo: &alb,
            diffuse: &diffuse,
            glossy: &glossy,
        };
        case_for(ctx, &d, format!("#{index} {w}x{h}"), seed)
    }

    fn mirror(&self, _case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(data);
        let frame = io.frame.0;
        let triangles: &[GpuTriangle] = bytemuck::cast_slice(&io.triangles);
        let material = |t: u32| triangles[t as usize].material();
        let s = m::Scene {
            eye: frame.eye,
            forward: frame.forward,
            materials: &material,
            triangles: triangles.len() as u32,
            lobes: &io.lobes,
        };
        let (pos, nrm, tri) = (&io.gb_position, &io.gb_normal, &io.gb_triangle);
        // What the GPU's `inputs` wrote: where the mirror's depth is within its bound of 0, whether
        // the normal is dropped is rounding's choice, and either packing is accepted.
        let gpu_normals = &io.normals;
        let n = pos.len();
        let mut out_n = Vec::with_capacity(n);
        let (mut depth, mut depth_b) = (Vec::with_capacity(n), Vec::with_capacity(n));
        let (mut positions, mut dirs, mut dirs_b, mut spec) = (
            Vec::with_capacity(n),
            Vec::with_capacity(2 * n),
            Vec::with_capacity(2 * n),
            Vec::with_capacity(n),
        );
        for i in 0..n {
            let g = GPixel {
                position: pos[i],
                normal: nrm[i],
                triangle: tri[i],
            };
            let o = m::pixel(&s, &g);
            let front = o.position[3] == 1.0;
            let (bd, bn, br) = if front {
                m::pixel_bounds(&s, &g)
            } else {
                (0.0, 0.0, 0.0)
            };
            let mut q = o.normal;
            if front && o.depth.abs() <= bd && gpu_normals[i] != q {
                let other = if q == [0, 0] {
                    m::quantised(nrm[i])
                } else {
                    [0, 0]
                };
                if gpu_normals[i] == other {
                    q = other;
                }
            }
            out_n.push(q);
            depth.push(o.depth);
            depth_b.push(bd);
            positions.push(o.position);
            dirs.extend(o.dirs);
            dirs_b.extend([[bn, bn, bn, 0.0], [br, br, br, 0.0]]);
            spec.push(o.specular);
        }
        // compose on what the GPU's `inputs` wrote (positions and Ks).
        let (gpos, gspec) = (&io.positions, &io.px_specular);
        let (alb, dif, glo) = (&io.gb_albedo, &io.diffuse, &io.glossy);
        let mut ind = Vec::with_capacity(n);
        let mut ind_b = Vec::with_capacity(n);
        let mut ao = Vec::with_capacity(n);
        for i in 0..n {
            let (c, a) = m::compose(gpos[i], nrm[i], alb[i], gspec[i], dif[i], glo[i]);
            ind.push(c);
            ao.push(a);
            ind_b.push(m::compose_bound(gpos[i], alb[i], gspec[i], dif[i], glo[i]));
        }
        (io.normals, io.depth, io.positions) = (out_n, depth, positions);
        (io.pixel_dirs, io.px_specular, io.indirect, io.ao) = (dirs, spec, ind, ao);
        let mut out = io.outputs();
        out.extend([bound("depth", &depth_b)]);
        out.extend([bound("pixel_dirs", &dirs_b), bound("indirect", &ind_b)]);
        out
    }
}
