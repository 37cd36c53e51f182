//! Declaration of `kernels/cprc_pixels.wgsl` (mirror: `vxgi_cpu_mirror::cprc_pixels`): cprc's
//! per-pixel inputs from the G-buffer (`inputs`) and its indirect and AO images from the gather's
//! results (`compose`). Cases are generated G-buffers: unit, non-unit, zero and NaN normals, back
//! faces and background, triangles out of range, materials past the lobe table, infinite positions,
//! gathered values over a wide range of magnitudes.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::bvh_trace::GpuTriangle;
use vxgi_cpu_mirror::cprc_pixels::{self as m, GPixel};
use vxgi_cpu_mirror::gbuffer::Frame;
use vxgi_harness::compare::bound_name;
use vxgi_harness::run::{grid_for, Pass, Workgroups};
use vxgi_harness::{
    Case, Check, DispatchRule, FloatMode, GpuContext, HostBuffer, HostResource, Indexing, Kernel,
    KernelDecl, Output, Resources, ScalarKind, Shader, Tolerance,
};

pub static DECL: KernelDecl = KernelDecl {
    name: "cprc_pixels",
    wgsl_path: "kernels/cprc_pixels.wgsl",
    wgsl: include_str!("../../kernels/cprc_pixels.wgsl"),
    includes: &[super::SCENE_TYPES],
    entry: "inputs",
    inputs: &[
        "frame", "triangles", "lobes", "gb_position", "gb_normal", "gb_triangle", "gb_albedo", "diffuse",
        "glossy",
    ],
    outputs: &[
        // One correctly rounded product and round per component, integer packing: exact.
        Output { binding: "normals", tolerance: Tolerance::Exact },
        // A difference and a dot product (see `cprc_pixels::pixel_bounds`).
        Output { binding: "depth", tolerance: Tolerance::MirrorBound },
        // Copies.
        Output { binding: "positions", tolerance: Tolerance::Exact },
        // Two normalisations and a reflection (see `cprc_pixels::pixel_bounds`).
        Output { binding: "pixel_dirs", tolerance: Tolerance::MirrorBound },
        // A table lookup.
        Output { binding: "px_specular", tolerance: Tolerance::Exact },
        // Three products and a sum per component (see `cprc_pixels::compose_bound`).
        Output { binding: "indirect", tolerance: Tolerance::MirrorBound },
        // Constants chosen by exact comparisons.
        Output { binding: "ao", tolerance: Tolerance::Exact },
    ],
    dispatch: DispatchRule::PerElement { binding: "depth" },
    mirror: "vxgi_cpu_mirror::cprc_pixels::pixel",
    summary: "cprc's per-pixel inputs from the G-buffer (packed normals, depth, directions, Ks) and its indirect and AO images from the gather (CPRC 3.2-3.3)",
};

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

/// The resources `inputs` writes for `pixels` pixels, zeroed (an earlier stage of a chain, or the
/// kernel, fills them), by binding.
pub fn outputs(pixels: usize) -> Resources {
    let z = |bytes: usize, s: ScalarKind| HostResource::Buffer(HostBuffer::zeroed(bytes, s));
    Resources::from([
        ("normals".into(), z(pixels * 8, ScalarKind::U32)),
        ("depth".into(), z(pixels * 4, ScalarKind::F32)),
        ("positions".into(), z(pixels * 16, ScalarKind::F32)),
        ("pixel_dirs".into(), z(pixels * 32, ScalarKind::F32)),
        ("px_specular".into(), z(pixels * 16, ScalarKind::F32)),
    ])
}

/// The pass of `entry` (`inputs` or `compose`) over `pixels` pixels.
pub fn pass(ctx: &GpuContext, entry: &str, pixels: usize) -> Pass {
    Pass {
        label: entry.into(),
        entry: entry.into(),
        bindings: DECL.bind_by_name(),
        workgroups: Workgroups::Direct(grid_for(
            pixels as u64,
            64,
            ctx.limits().max_compute_workgroups_per_dimension,
        )),
    }
}

/// Both entries over `d` (`inputs`, then `compose` on what `inputs` wrote), checking every output.
pub fn case_for(ctx: &GpuContext, d: &PixelData, label: String, seed: u64) -> Case {
    let n = d.position.len();
    let f4 = |v: &[[f32; 4]]| HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(v)));
    let mut resources = outputs(n);
    resources.insert(
        "frame".into(),
        HostResource::Buffer(HostBuffer::pod(d.frame)),
    );
    resources.insert(
        "triangles".into(),
        HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(d.triangles))),
    );
    resources.insert("lobes".into(), f4(d.lobes));
    resources.insert("gb_position".into(), f4(d.position));
    resources.insert("gb_normal".into(), f4(d.normal));
    resources.insert(
        "gb_triangle".into(),
        HostResource::Buffer(HostBuffer::u32(d.triangle)),
    );
    resources.insert("gb_albedo".into(), f4(d.albedo));
    resources.insert("diffuse".into(), f4(d.diffuse));
    resources.insert("glossy".into(), f4(d.glossy));
    for name in ["indirect", "ao"] {
        resources.insert(
            name.into(),
            HostResource::Buffer(HostBuffer::zeroed(n * 16, ScalarKind::F32)),
        );
    }
    let check = |name: &'static str| Check {
        resource: name.into(),
        output: name,
        indexing: Indexing::Linear,
    };
    Case {
        label,
        seed,
        passes: vec![pass(ctx, "inputs", n), pass(ctx, "compose", n)],
        resources,
        checks: [
            "normals",
            "depth",
            "positions",
            "pixel_dirs",
            "px_specular",
            "indirect",
            "ao",
        ]
        .map(check)
        .to_vec(),
        effective_bytes: n as u64 * (16 * 4 + 4 + 8 + 4 + 16 + 32 + 16 + 32),
    }
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

    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        let b = |k: &str| &data[k].buffer().expect("a buffer").bytes;
        let f4 = |k: &str| -> &[[f32; 4]] { bytemuck::cast_slice(b(k)) };
        let frame: Frame = *bytemuck::from_bytes(b("frame"));
        let triangles: &[GpuTriangle] = bytemuck::cast_slice(b("triangles"));
        let material = |t: u32| triangles[t as usize].material();
        let s = m::Scene {
            eye: frame.eye,
            forward: frame.forward,
            materials: &material,
            triangles: triangles.len() as u32,
            lobes: f4("lobes"),
        };
        let (pos, nrm, tri) = (
            f4("gb_position"),
            f4("gb_normal"),
            bytemuck::cast_slice::<u8, u32>(b("gb_triangle")),
        );
        // What the GPU's `inputs` wrote: where the mirror's depth is within its bound of 0, whether
        // the normal is dropped is rounding's choice, and either packing is accepted.
        let gpu_normals: &[[u32; 2]] = bytemuck::cast_slice(b("normals"));
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
        let (gpos, gspec) = (f4("positions"), f4("px_specular"));
        let (alb, dif, glo) = (f4("gb_albedo"), f4("diffuse"), f4("glossy"));
        let mut ind = Vec::with_capacity(n);
        let mut ind_b = Vec::with_capacity(n);
        let mut ao = Vec::with_capacity(n);
        for i in 0..n {
            let (c, a) = m::compose(gpos[i], nrm[i], alb[i], gspec[i], dif[i], glo[i]);
            ind.push(c);
            ao.push(a);
            ind_b.push(m::compose_bound(gpos[i], alb[i], gspec[i], dif[i], glo[i]));
        }
        let f = |v: &[[f32; 4]]| HostBuffer::f32(bytemuck::cast_slice(v));
        BTreeMap::from([
            (
                "normals".to_string(),
                HostBuffer::u32(bytemuck::cast_slice(&out_n)),
            ),
            ("depth".to_string(), HostBuffer::f32(&depth)),
            (bound_name("depth"), HostBuffer::f32(&depth_b)),
            ("positions".to_string(), f(&positions)),
            ("pixel_dirs".to_string(), f(&dirs)),
            (bound_name("pixel_dirs"), f(&dirs_b)),
            ("px_specular".to_string(), f(&spec)),
            ("indirect".to_string(), f(&ind)),
            (bound_name("indirect"), f(&ind_b)),
            ("ao".to_string(), f(&ao)),
        ])
    }
}
