//! Scene input: the built-in Cornell box, and every kind of bad file a user can hand us — each an error
//! with file and line, never a panic.
use crate::common;

use std::path::{Path, PathBuf};
use vxgi::scene::{Light, Scene, SceneError};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vxgi-scene-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const TRI_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// Asserts that one of `s`'s warnings holds every one of `parts`.
#[track_caller]
fn assert_warns(s: &Scene, parts: &[&str]) {
    assert!(
        (s.warnings.iter()).any(|w| parts.iter().all(|p| w.contains(p))),
        "no warning holds {parts:?}: {:?}",
        s.warnings
    );
}

fn scene_toml(obj: &str, extra: &str) -> String {
    format!(
        "[mesh]\nobj = \"{obj}\"\n\n[camera]\neye = [0.0, 0.5, 3.0]\ntarget = [0.0, 0.5, 0.0]\nup = [0.0, 1.0, 0.0]\nfov_y_deg = 40.0\nwidth = 32\nheight = 32\n{extra}"
    )
}

fn write(name: &str, obj: &str, toml: &str) -> PathBuf {
    let d = dir(name);
    std::fs::write(d.join("mesh.obj"), obj).unwrap();
    let p = d.join("scene.toml");
    std::fs::write(&p, toml).unwrap();
    p
}

#[test]
fn built_in_cornell_box_matches_the_shipped_files() {
    let s = Scene::cornell_box();
    assert_eq!(s.mesh.triangles.len(), 30);
    assert_eq!(
        s.materials.len(),
        4,
        "white, red, green and the grey fallback"
    );
    assert!(matches!(s.lights[0], Light::Point { .. }));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // The floor faces up: counter-clockwise seen from above.
    let floor = s
        .mesh
        .triangles
        .iter()
        .find(|t| t.iter().all(|&v| s.mesh.positions[v as usize].y == 0.0))
        .unwrap();
    assert!(s.mesh.normals[floor[0] as usize].y > 0.99);
    let file = Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell_box.toml"
    ))
    .unwrap();
    assert_eq!(file.mesh.triangles, s.mesh.triangles);
    assert_eq!(file.materials, s.materials);
    assert_eq!(file.camera, s.camera);
}

#[test]
fn a_mesh_without_mtl_is_grey_with_a_warning() {
    let p = write("nomtl", TRI_OBJ, &scene_toml("mesh.obj", "[[lights]]\ntype = \"directional\"\ndirection = [0.0, -1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n"));
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.materials[s.mesh.material[0] as usize].diffuse, [0.8; 3]);
    assert_warns(&s, &["grey diffuse 0.8"]);
    // An mtllib that names a missing file: the warning names it.
    let obj = format!("mtllib nothere.mtl\n{TRI_OBJ}");
    let s = Scene::load(write("mtlmissing", &obj, &scene_toml("mesh.obj", ""))).unwrap();
    assert_warns(&s, &["no usable .mtl", "nothere.mtl"]);
    let s2 = Scene::load(write("nolights", TRI_OBJ, &scene_toml("mesh.obj", ""))).unwrap();
    assert_warns(&s2, &["no lights"]);
}

#[test]
fn bad_toml_reports_file_line_and_column() {
    let p = write(
        "badtoml",
        TRI_OBJ,
        &scene_toml("mesh.obj", "[render]\nvoxels = = 3\n"),
    );
    let e = Scene::load(&p).unwrap_err();
    assert!(matches!(e, SceneError::Toml { line: 12, .. }), "{e}");
    assert!(e.to_string().contains("scene.toml:12:"), "{e}");
}

#[test]
fn unknown_light_types_and_keys_are_errors_with_line() {
    let p = write("badlight", TRI_OBJ, &scene_toml("mesh.obj", "[[lights]]\ntype = \"area\"\nposition = [0.0, 1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n"));
    let e = Scene::load(&p).unwrap_err();
    assert!(
        matches!(e, SceneError::Toml { .. }) && e.to_string().contains("area"),
        "{e}"
    );
    let p = write(
        "badkey",
        TRI_OBJ,
        &scene_toml("mesh.obj", "[render]\nvoxel = 64\n"),
    );
    let e = Scene::load(&p).unwrap_err();
    assert!(e.to_string().contains("voxel"), "{e}");
}

#[test]
fn missing_obj_is_an_error_naming_it() {
    let p = write("missing", TRI_OBJ, &scene_toml("nope.obj", ""));
    let e = Scene::load(&p).unwrap_err();
    assert!(
        matches!(e, SceneError::Obj { .. }) && e.to_string().contains("nope.obj"),
        "{e}"
    );
    let e = Scene::load(dir("nofile").join("absent.toml")).unwrap_err();
    assert!(matches!(e, SceneError::Read { .. }), "{e}");
}

#[test]
fn nan_vertices_and_degenerate_triangles_name_their_lines() {
    let p = write(
        "nan",
        "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n",
        &scene_toml("mesh.obj", ""),
    );
    let e = Scene::load(&p).unwrap_err();
    assert!(
        matches!(e, SceneError::NonFiniteVertex { line: 3, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("mesh.obj:3"), "{e}");
    // A triangle past the renderable range is named as such, not as "zero area".
    let p = write(
        "huge",
        "v 0 0 0\nv 1e30 0 0\nv 0 1e30 0\nf 1 2 3\n",
        &scene_toml("mesh.obj", ""),
    );
    let e = Scene::load(&p).unwrap_err();
    assert!(
        matches!(e, SceneError::VertexOutOfRange { line: 2, .. })
            && e.to_string().contains("mesh.obj:2")
            && e.to_string().contains("renderable range"),
        "{e}"
    );
    let p = write("empty", "v 0 0 0\n", &scene_toml("mesh.obj", ""));
    assert!(matches!(
        Scene::load(&p).unwrap_err(),
        SceneError::EmptyMesh { .. } | SceneError::Obj { .. }
    ));
}

/// Zero-area triangles (three on a line, a repeated vertex) are dropped with one warning that counts
/// them, as every renderer drops them; a mesh of nothing else is empty.
#[test]
fn zero_area_triangles_are_dropped_with_one_warning() {
    let obj = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 4\nf 1 2 4\n";
    let s = Scene::load(write("degenerate", obj, &scene_toml("mesh.obj", ""))).unwrap();
    assert_eq!(s.mesh.triangles.len(), 1);
    let w: Vec<_> = s
        .warnings
        .iter()
        .filter(|w| w.contains("zero area"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", s.warnings);
    assert!(
        w[0].contains("2 of 3 triangles") && w[0].contains("1 with a repeated vertex"),
        "{}",
        w[0]
    );
    // A dropped triangle's own vertices go with it: they do not stretch the scene's bounds.
    let far = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 100 100 100\nv 101 100 100\nv 102 100 100\nf 1 2 3\nf 4 5 6\n";
    let s = Scene::load(write("far-degenerate", far, &scene_toml("mesh.obj", ""))).unwrap();
    assert!(
        s.mesh.positions.iter().all(|p| p.max_element() <= 1.0),
        "{:?}",
        s.mesh.positions
    );
    let e = Scene::load(write(
        "all-degenerate",
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
        &scene_toml("mesh.obj", ""),
    ))
    .unwrap_err();
    assert!(
        matches!(e, SceneError::EmptyMesh { dropped: 1, .. })
            && e.to_string().contains("1 zero-area"),
        "{e}"
    );
}

/// The Dabrovic Sponza from the `bvh` package (scenes/sponza.toml names it `crate:bvh/...`): 66k
/// triangles, of which six have zero area.
#[test]
fn sponza_loads_from_the_bvh_package() {
    let s = Scene::load(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sponza.toml")).unwrap();
    assert_eq!(s.mesh.triangles.len(), 66444);
    assert_warns(&s, &["6 of 66450 triangles have zero area"]);
    let e = Scene::load(write("crate", TRI_OBJ, &scene_toml("crate:nope/x.obj", ""))).unwrap_err();
    assert!(e.to_string().contains("only the bvh package"), "{e}");
    assert!(s.mesh.far_geometry().is_none());
}

/// Geometry far from the rest stretches the voxel grid (it covers the scene's bounds): a box behind
/// the Cornell box's back wall at z = -8 made its voxels 3.4 times coarser with no word said. The
/// loader names the empty space and the triangles at the bounds' ends, also for a box on each side
/// (two gaps, neither half the grid) and a sliver reaching far out from the room (a bad vertex: no
/// gap at all); a box just behind the wall, and no shipped scene, is not named.
#[test]
fn geometry_far_from_the_rest_is_named() {
    let cornell = include_str!("../scenes/cornell_box.obj");
    let base = cornell.lines().filter(|l| l.starts_with("v ")).count();
    let cube = |at: [f32; 3], first: usize| {
        let mut obj = String::from("o box\n");
        for k in 0..8 {
            let d = [k & 1, (k >> 1) & 1, k >> 2].map(|b| [-0.3, 0.3][b]);
            obj += &format!("v {} {} {}\n", at[0] + d[0], at[1] + d[1], at[2] + d[2]);
        }
        for f in [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ] {
            let [a, b, c, d] = f.map(|i| first + 1 + i);
            obj += &format!("f {a} {b} {c}\nf {a} {c} {d}\n");
        }
        obj
    };
    let load = |name: &str, extra: &str| {
        let obj = format!("{cornell}\n{extra}");
        Scene::load(write(name, &obj, &scene_toml("mesh.obj", ""))).unwrap()
    };
    let far = load("far", &cube([5.0, 0.3, -8.0], base));
    let f = far.mesh.far_geometry().expect("the far box is named");
    assert_eq!((f.axis, f.ends[0].1), (2, -8.3));
    assert!(f.empty / f.side > 0.6, "{f:?}");
    assert_warns(&far, &["along z holds almost no surface", "at z = -8.3"]);
    let both = load(
        "both",
        &(cube([-30.0, 1.0, 0.0], base) + &cube([30.0, 1.0, 0.0], base + 8)),
    );
    let f = both
        .mesh
        .far_geometry()
        .expect("a box on each side is named");
    assert!(f.axis == 0 && f.empty / f.side > 0.9, "{f:?}");
    let sliver = load(
        "sliver",
        &format!(
            "v 0 1 -1\nv 0.0000001 1 -1\nv 0 1 -500\nf {} {} {}\n",
            base + 1,
            base + 2,
            base + 3
        ),
    );
    let f = sliver.mesh.far_geometry().expect("the sliver is named");
    assert_eq!((f.axis, f.ends[0]), (2, (30, -500.0)), "{f:?}");
    // Just behind the back wall (z = -1): the grid grows, but most of it holds surface.
    let near = load("near", &cube([0.0, 0.3, -1.6], base));
    assert!(near.mesh.far_geometry().is_none());
    // A 100 x 100 ground and a backdrop 60 above it: y is mostly empty, but the grid's side stays
    // the ground's without that space.
    let (g, b) = (base + 1, base + 5);
    let wide = load(
        "wide",
        &format!(
            "v -50 0 -50\nv 50 0 -50\nv 50 0 50\nv -50 0 50\nv -50 60 -50\nv 50 60 -50\nv 50 61 -50\nv -50 61 -50\nf {g} {} {}\nf {g} {} {}\nf {b} {} {}\nf {b} {} {}\n",
            g + 2, g + 1, g + 3, g + 2, b + 1, b + 2, b + 2, b + 3
        ),
    );
    assert!(wide.mesh.far_geometry().is_none());
    // The Cornell box 1e19 times its size (areas past f32's range) is measured in f64: not named;
    // the far box at that scale is.
    for (s, named) in [(&near, false), (&far, true)] {
        let mut m = s.mesh.clone();
        m.positions.iter_mut().for_each(|p| *p *= 1e19);
        assert_eq!(m.far_geometry().is_some(), named);
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for name in ["cornell_box", "thin_wall", "instances", "textured_cornell"] {
        let s = Scene::load(root.join(format!("{name}.toml"))).unwrap();
        assert!(s.mesh.far_geometry().is_none(), "{name}");
        assert!(
            !s.warnings.iter().any(|w| w.contains("almost no surface")),
            "{name}"
        );
    }
}

#[test]
fn bad_cameras_lights_and_settings_are_errors() {
    let cam = "[mesh]\nobj = \"mesh.obj\"\n[camera]\neye = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\nfov_y_deg = 40.0\nwidth = 8\nheight = 8\n";
    assert!(matches!(
        Scene::load(write("cam", TRI_OBJ, cam)).unwrap_err(),
        SceneError::Camera { .. }
    ));
    let spot = "[[lights]]\ntype = \"spot\"\nposition = [0.0, 1.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\ncone_deg = 30.0\nfalloff_deg = 40.0\n";
    let e = Scene::load(write("spot", TRI_OBJ, &scene_toml("mesh.obj", spot))).unwrap_err();
    assert!(
        matches!(e, SceneError::Light { index: 0, .. }) && e.to_string().contains("falloff_deg"),
        "{e}"
    );
    let neg =
        "[[lights]]\ntype = \"point\"\nposition = [0.0, 1.0, 0.0]\nintensity = [-1.0, 1.0, 1.0]\n";
    assert!(matches!(
        Scene::load(write("neg", TRI_OBJ, &scene_toml("mesh.obj", neg))).unwrap_err(),
        SceneError::Light { .. }
    ));
    let vox = "[render]\nvoxels = 100\n";
    let e = Scene::load(write("vox", TRI_OBJ, &scene_toml("mesh.obj", vox))).unwrap_err();
    assert!(
        matches!(e, SceneError::Render { .. }) && e.to_string().contains("voxels = 100"),
        "{e}"
    );
    // A march step whose opacity the GPU's f32 pow rounds away (and, far shorter, one too short to
    // advance the march distance) is refused, naming the smallest step.
    for step in ["1e-30", "0.001"] {
        let text = format!("[render]\ncone_step = {step}\n");
        let e = Scene::load(write("step", TRI_OBJ, &scene_toml("mesh.obj", &text))).unwrap_err();
        assert!(
            matches!(e, SceneError::Render { .. })
                && e.to_string().contains("cone_step")
                && e.to_string().contains("[0.015625, 1]")
                && e.to_string().contains("f32 pow"),
            "{e}"
        );
    }
}

/// A quad with `vt` and a `map_Kd` texture of four coloured texels, seen head-on: the G-buffer kernel
/// reads each quadrant's texel (row 0 of the image is the top, v = 1), decoded from sRGB to linear.
/// A texture that cannot be read is a warning and the material keeps its Kd.
#[test]
fn map_kd_textures_are_loaded_and_sampled_by_the_gbuffer() {
    use vxgi::harness::run::run;
    use vxgi::kernels::gbuffer::{case_for, DECL};
    let d = dir("textured");
    // Top row red, green; bottom row blue, mid grey (sRGB 128 -> linear 0.2158605).
    let texels = vec![255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128];
    image::RgbImage::from_raw(2, 2, texels)
        .unwrap()
        .save(d.join("tex.png"))
        .unwrap();
    std::fs::write(
        d.join("mesh.mtl"),
        "newmtl tex\nKd 0.5 0.5 0.5\nmap_Kd tex.png\nnewmtl missing\nKd 0.25 0.5 0.75\nmap_Kd nowhere.png\n",
    )
    .unwrap();
    let obj =
        "mtllib mesh.mtl\nv -1 0 0\nv 1 0 0\nv 1 2 0\nv -1 2 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
               o textured\nusemtl tex\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n\
               o plain\nusemtl missing\nv -1 0 -1\nv 1 0 -1\nv 1 2 -1\nf 5 6 7\n";
    std::fs::write(d.join("mesh.obj"), obj).unwrap();
    let p = d.join("scene.toml");
    std::fs::write(
        &p,
        scene_toml("mesh.obj", "")
            .replace("eye = [0.0, 0.5, 3.0]", "eye = [0.0, 1.0, 3.0]")
            .replace("target = [0.0, 0.5, 0.0]", "target = [0.0, 1.0, 0.0]"),
    )
    .unwrap();
    let scene = Scene::load(&p).unwrap();
    let tex = scene.materials[0]
        .diffuse_map
        .as_ref()
        .expect("map_Kd loaded");
    assert_eq!((tex.width, tex.height), (2, 2));
    assert!(scene.materials[1].diffuse_map.is_none());
    assert_warns(&scene, &["nowhere.png"]);

    let data = vxgi::trace::SceneData::new(&scene);
    let case = case_for(&data, "textured quad".into(), 1);
    let shader = DECL.shader().unwrap();
    let out = run(
        common::gpu(),
        &shader,
        DECL.name,
        &case.resources,
        &case.passes,
        &["gb_albedo"],
    )
    .unwrap();
    let albedo: &[[f32; 4]] = bytemuck::cast_slice(&out.buffer("gb_albedo").bytes);
    let at = |x: usize, y: usize| albedo[y * 32 + x];
    let grey = 0.215_860_5;
    assert_eq!(at(8, 8), [1.0, 0.0, 0.0, 0.0], "top left: red");
    assert_eq!(at(23, 8), [0.0, 1.0, 0.0, 0.0], "top right: green");
    assert_eq!(at(8, 23), [0.0, 0.0, 1.0, 0.0], "bottom left: blue");
    for c in 0..3 {
        approx::assert_abs_diff_eq!(at(23, 23)[c], grey, epsilon = 1e-6);
    }
}

/// `[[instances]]`: the shipped instance scene loads (room as `[mesh]`, a static and a dynamic box);
/// the instances equal the Cornell box's boxes in kind (12 triangles each, one OBJ's materials); a
/// dynamic instance follows its keyframes (held before the first and after the last, linear between);
/// a static one never moves; frame k's mesh is `[mesh]` + every instance placed at k.
#[test]
fn instances_load_and_follow_their_keyframes() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let s = Scene::load(root.join("scenes/instances.toml")).unwrap();
    assert_eq!(s.instances.list.len(), 2);
    assert_eq!(s.mesh.triangles.len(), 10 + 12 + 12);
    let (a, b) = (&s.instances.list[0], &s.instances.list[1]);
    assert!(!a.dynamic && b.dynamic && b.keyframes.len() == 2);
    // Materials: the room's (white, red, green, grey) then the box OBJ's yellow; its grey is the
    // room's, and the second box's are the first's (an equal material is loaded once), so the two
    // instances of one OBJ have equal meshes (one voxelization serves both).
    assert_eq!(s.materials.len(), 5);
    assert_eq!(s.instances.list[0].local, s.instances.list[1].local);
    assert_eq!(s.materials[s.mesh.material[10] as usize].name, "yellow");
    let centre = |frame: u32| {
        let m = b.placed(frame);
        m.positions.iter().copied().sum::<glam::Vec3>() / m.positions.len() as f32
    };
    let close = |p: glam::Vec3, q: [f32; 3]| (p - glam::Vec3::from(q)).length() < 1e-5;
    assert!(close(centre(0), [-0.45, 0.45, -0.45]));
    assert!(close(centre(3), [-0.45, 0.45, 0.0]), "{}", centre(3));
    assert!(close(centre(6), [-0.45, 0.45, 0.45]));
    assert!(
        close(centre(60), [-0.45, 0.45, 0.45]),
        "held after the last keyframe"
    );
    assert_eq!(a.placed(0), a.placed(5), "static");
    let f3 = s.at_frame(3);
    assert_eq!(f3.instances.frame, 3);
    assert_ne!(f3.mesh, s.mesh);
    assert_eq!(f3.mesh.triangles, s.mesh.triangles);
    assert_eq!(s.at_frame(0).mesh, s.mesh);
    // A scene without instances is every frame the same.
    let c = Scene::cornell_box();
    assert_eq!(c.at_frame(4).mesh, c.mesh);
}

/// A 4x4 matrix transform (row-major as written) places the instance like the equivalent parts; a
/// mirroring matrix keeps the faces' fronts (winding reversed) and its normals unit length.
#[test]
fn matrix_transforms_and_mirrors() {
    let d = dir("matrix");
    std::fs::write(d.join("mesh.obj"), TRI_OBJ).unwrap();
    std::fs::write(d.join("inst.obj"), TRI_OBJ).unwrap();
    let load = |t: &str| {
        let p = d.join("scene.toml");
        let extra = format!("\n[[instances]]\nobj = \"inst.obj\"\ntransform = {t}\n");
        std::fs::write(&p, scene_toml("mesh.obj", &extra)).unwrap();
        Scene::load(&p)
    };
    let m = load("{ matrix = [[1.0, 0.0, 0.0, 2.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]] }").unwrap();
    let p = load("{ translate = [2.0, 0.0, 0.0] }").unwrap();
    assert_eq!(m.mesh.positions, p.mesh.positions);
    let mirrored = load("{ scale = [-1.0, 1.0, 1.0] }").unwrap();
    let t = mirrored.mesh.triangles[1];
    let [a, b, c] = t.map(|v| mirrored.mesh.positions[v as usize]);
    let face = (b - a).cross(c - a).normalize();
    let n = mirrored.mesh.normals[t[0] as usize];
    assert!(
        (face - n).length() < 1e-5,
        "front kept: face {face} normal {n}"
    );
}

/// Every way an instance can be wrong is an error naming the instance: a matrix with parts, a last row
/// that is not 0 0 0 1, a singular transform, keyframes on a static instance, keyframes out of order,
/// vertices past the renderable range, a missing OBJ, unknown keys; and a scene with neither a mesh
/// nor instances.
#[test]
fn bad_instances_are_errors() {
    let d = dir("bad-instances");
    std::fs::write(d.join("mesh.obj"), TRI_OBJ).unwrap();
    let cam = "[camera]\neye = [0.0, 0.5, 3.0]\ntarget = [0.0, 0.5, 0.0]\nup = [0.0, 1.0, 0.0]\nfov_y_deg = 40.0\nwidth = 32\nheight = 32\n";
    let cases = [
        ("transform = { translate = [1.0, 0.0, 0.0], matrix = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]] }", "matrix excludes"),
        ("transform = { matrix = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0]] }", "last row"),
        ("transform = { scale = 0.0 }", "singular"),
        ("keyframes = [{ frame = 0 }]", "dynamic = true"),
        ("dynamic = true\nkeyframes = [{ frame = 3 }, { frame = 1 }]", "must increase"),
        // Past the renderable range (the `bvh` crate panicked on it): as placed, at a keyframe, or in
        // between two keyframes in range (scale and translation interpolate apart).
        ("transform = { scale = 1e30 }", "at frame 0"),
        ("dynamic = true\nkeyframes = [{ frame = 0 }, { frame = 2, scale = 3e19 }]", "keyframes 0 and 2"),
        ("dynamic = true\nkeyframes = [{ frame = 0, scale = 5e8 }, { frame = 2, translate = [6e8, 0.0, 0.0] }]", "keyframes 0 and 2"),
        ("dynamic = true\nkeyframes = [{ frame = 0, scale = [-1.0, 1.0, 1.0] }, { frame = 2 }]", "changes sign"),
        ("dynamic = true\nkeyframes = [{ frame = 0 }, { frame = 2, scale = 0.0 }]", "keyframe 2"),
        ("colour = 1", "unknown field"),
    ];
    for (i, (body, want)) in cases.iter().enumerate() {
        let p = d.join(format!("s{i}.toml"));
        std::fs::write(
            &p,
            format!(
                "[mesh]\nobj = \"mesh.obj\"\n\n[[instances]]\nobj = \"mesh.obj\"\n{body}\n\n{cam}"
            ),
        )
        .unwrap();
        let e = Scene::load(&p).unwrap_err().to_string();
        assert!(e.contains(want), "{body}: {e}");
        assert!(e.contains(&p.display().to_string()), "{e}");
    }
    let p = d.join("missing.toml");
    std::fs::write(&p, format!("[[instances]]\nobj = \"nope.obj\"\n\n{cam}")).unwrap();
    assert!(matches!(Scene::load(&p), Err(SceneError::Obj { .. })));
    let p = d.join("empty.toml");
    std::fs::write(&p, cam).unwrap();
    assert!(matches!(
        Scene::load(&p),
        Err(SceneError::NoGeometry { .. })
    ));
}

#[test]
fn supersampling_scales_the_camera_and_the_pixel_tile() {
    let mut scene = vxgi::scene::Scene::cornell_box();
    scene.render.supersample = 3;
    scene.render.cache_tile = 8;
    let s = scene.supersampled().unwrap();
    assert_eq!((s.camera.width, s.camera.height), (768, 768));
    assert_eq!((s.render.cache_tile, s.render.supersample), (24, 1));
    assert_eq!(s.camera.eye, scene.camera.eye);
    // Past the camera's limit, or a tile past 64 samples: refused, naming the setting.
    scene.camera.width = 4000;
    let e = scene.supersampled().unwrap_err();
    assert!(e.contains("supersample = 3") && e.contains("8192"), "{e}");
    scene.camera.width = 256;
    scene.render.cache_tile = 32;
    let e = scene.render.validate().unwrap_err();
    assert!(e.contains("cache_tile = 32 x supersample = 3"), "{e}");
    scene.render.cache_tile = 16;
    scene.render.supersample = 0;
    assert!(scene
        .render
        .validate()
        .unwrap_err()
        .contains("supersample = 0"));
}

/// A scene file beside a triangle OBJ with `mtl` as its .mtl (`usemtl m`).
fn with_mtl(name: &str, mtl: &str, extra: &str) -> PathBuf {
    let d = dir(name);
    std::fs::write(d.join("mesh.mtl"), mtl).unwrap();
    let obj = format!("mtllib mesh.mtl\nusemtl m\n{TRI_OBJ}");
    std::fs::write(d.join("mesh.obj"), obj).unwrap();
    let p = d.join("scene.toml");
    std::fs::write(&p, scene_toml("mesh.obj", extra)).unwrap();
    p
}

/// Materials are checked at load: Kd and Ks finite and in [0, 1], Ns finite and >= 0; the error names
/// the .mtl's line.
#[test]
fn bad_materials_are_errors_with_their_mtl_line() {
    for (mtl, line, want) in [
        ("newmtl m\nKd nan 0.5 0.5\n", 2, "Kd"),
        ("newmtl m\nKd 0.5 0.5 0.5\nKs inf 0 0\n", 3, "Ks"),
        ("newmtl m\nKd -1 0.5 0.5\n", 2, "Kd"),
        (
            "newmtl m\nKd 0.5 0.5 0.5\nKs 0.2 0.2 0.2\nNs -10\n",
            4,
            "Ns",
        ),
        // Two numbers are neither MTL's `Kd r` (g = b = r) nor `Kd r g b`.
        ("newmtl m\nKd 0.5 0.5\n", 2, "Kd needs one or three numbers"),
        (
            "newmtl m\nKd 0.5 0.5 0.5\nNs high\n",
            3,
            "Ns needs a number",
        ),
    ] {
        let e = Scene::load(with_mtl("badmtl", mtl, "")).unwrap_err();
        assert!(
            matches!(&e, SceneError::Material { line: l, .. } if *l == line)
                && e.to_string()
                    .contains(&format!("mesh.mtl:{line}: material m: {want}")),
            "{mtl:?}: {e}"
        );
    }
    Scene::load(with_mtl(
        "goodmtl",
        "newmtl m\nKd 1 0 0.5\nKs 0 0 0\nNs 0\n",
        "",
    ))
    .unwrap();
}

/// OBJ errors tobj reports without a line get the line that holds the problem.
#[test]
fn obj_errors_name_their_line() {
    for (obj, line) in [
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", 4),
        ("v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n", 2),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", 4),
        ("v 0 0 0\nvn 0 0 1\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//4\n", 5),
    ] {
        let e = Scene::load(write("badobj", obj, &scene_toml("mesh.obj", ""))).unwrap_err();
        assert!(
            e.to_string().contains(&format!("mesh.obj:{line}")),
            "{obj:?}: {e}"
        );
    }
    // Not UTF-8: read as Latin-1 (statements are ASCII), the first such line named; a statement it
    // breaks is an error with its line as any other.
    let d = dir("binobj");
    std::fs::write(d.join("mesh.obj"), b"v 0 0 0\nv 1 0 0\n\xff\xfe garbage\n").unwrap();
    std::fs::write(d.join("scene.toml"), scene_toml("mesh.obj", "")).unwrap();
    let e = Scene::load(d.join("scene.toml")).unwrap_err().to_string();
    assert!(e.contains("mesh.obj: the mesh has no triangles"), "{e}");
    let mut latin1 = b"# mod".to_vec();
    latin1.push(0xE8);
    latin1.extend(format!("le\n{TRI_OBJ}").as_bytes());
    std::fs::write(d.join("mesh.obj"), latin1).unwrap();
    let s = Scene::load(d.join("scene.toml")).unwrap();
    assert_warns(&s, &["mesh.obj:1: not UTF-8", "Latin-1"]);
    assert_eq!(s.mesh.triangles.len(), 1);
}

/// Files as exporters and scene archives write them: a byte-order mark, carriage returns, tabs and
/// Latin-1 comments, an `mtllib` and a `map_Kd` with Windows separators, quotes and another letter
/// case than the files, the texture beside its .mtl in a subfolder and in TGA, MTL colour forms tobj
/// would reject as a whole file (`Kd r`, `Ka xyz`, `Ks spectral`, `illum 2.0`, `d -halo`), a polyline,
/// vertex colours and a concave polygon. Everything is read as meant; what is not used is named.
#[test]
fn files_as_archives_write_them_are_read_as_meant() {
    let d = dir("archive");
    std::fs::create_dir_all(d.join("Mats")).unwrap();
    let mut mtl =
        b"\xEF\xBB\xBF# mat\xE9riaux\r\nnewmtl floor\r\nKd\t0.5\r\nKa xyz 0.9505 1 1.089\r\n"
            .to_vec();
    mtl.extend(b"Ks spectral steel.rfl 1\r\nillum 2.0\r\nd -halo 1\r\nmap_Kd \"Tex.TGA\"\r\n");
    std::fs::write(d.join("Mats/scene.mtl"), mtl).unwrap();
    let tex = image::RgbImage::from_fn(4, 2, |x, _| image::Rgb([x as u8 * 60, 10, 200]));
    tex.save(d.join("Mats/tex.tga")).unwrap();
    // An L-shaped floor (a hexagon with a reflex vertex at (1, 0, 1)): a fan from its first vertex
    // would cover the missing quarter and fold over the reflex corner.
    let obj = "\u{feff}mtllib mats\\scene.mtl\r\nusemtl\tfloor\r\n\
        v 0 0 0 1 0 0\r\nv 0 0 2\r\nv 2 0 2\r\nv 2 0 1\r\nv 1 0 1\r\nv 1 0 0\r\n\
        vt 0 0\r\nvn 0 1 0\r\nl 1 2 3\r\nf 5/1/1 6/1/1 1/1/1 2/1/1 3/1/1 4/1/1\r\n";
    std::fs::write(d.join("floor.obj"), obj).unwrap();
    std::fs::write(d.join("scene.toml"), scene_toml("floor.obj", "")).unwrap();
    let s = Scene::load(d.join("scene.toml")).unwrap();
    let m = &s.materials[0];
    assert_eq!(m.name, "floor");
    assert_eq!(m.diffuse, [0.5; 3]);
    let t = m
        .diffuse_map
        .as_ref()
        .expect("the TGA beside the .mtl is read");
    assert_eq!((t.width, t.height, t.rgb[1]), (4, 2, [60, 10, 200]));
    assert_warns(&s, &["scene.mtl:1: not UTF-8"]);
    assert_warns(&s, &["scene.mtl:5: material floor: Ks spectral"]);
    assert_warns(&s, &["1 polylines"]);
    assert_warns(&s, &["the colours of 1 vertices"]);
    assert!(
        !s.warnings
            .iter()
            .any(|w| w.contains("no usable") || w.contains("not used")),
        "{:?}",
        s.warnings
    );
    // The L's four triangles, each facing up, cover its area (3) once.
    assert_eq!(s.mesh.triangles.len(), 4);
    let mut area = 0.0;
    for t in &s.mesh.triangles {
        let [a, b, c] = t.map(|v| s.mesh.positions[v as usize]);
        let n = (b - a).cross(c - a);
        assert!(n.y > 0.0, "{t:?} faces down");
        area += 0.5 * n.length();
    }
    assert!((area - 3.0).abs() < 1e-5, "{area}");
}

/// Textures past the atlas's texels are read at lower resolution, largest first, and named.
#[test]
fn textures_past_the_atlas_are_read_smaller() {
    use std::sync::Arc;
    use vxgi::scene::{fit_textures, Material, Texture};
    let tex = |w: u32, h: u32| {
        Arc::new(Texture {
            path: format!("t{w}.png").into(),
            width: w,
            height: h,
            rgb: vec![[200, 100, 50]; (w * h) as usize],
        })
    };
    let big = tex(64, 64);
    let mut materials: Vec<Material> = [Some(big.clone()), Some(big), Some(tex(32, 16)), None]
        .into_iter()
        .map(|t| Material {
            diffuse_map: t,
            ..Material::grey()
        })
        .collect();
    assert_eq!(fit_textures(&mut materials, 64 * 64 + 32 * 16), None);
    let w = fit_textures(&mut materials, 2000).expect("past the budget");
    assert!(
        w.contains("t64.png 64x64 -> 32x32") && !w.contains("t32.png"),
        "{w}"
    );
    let a = materials[0].diffuse_map.as_ref().unwrap();
    assert!(Arc::ptr_eq(a, materials[1].diffuse_map.as_ref().unwrap()));
    assert_eq!((a.width, a.height, a.rgb[0]), (32, 32, [200, 100, 50]));
    // Filtered in linear albedo: a black and white checker reads 0.5 at half size.
    let mut checker = Material {
        diffuse_map: Some(Arc::new(Texture {
            path: "checker.png".into(),
            width: 4,
            height: 4,
            rgb: (0..16)
                .map(|i| [if (i + i / 4) % 2 == 0 { 0 } else { 255 }; 3])
                .collect(),
        })),
        ..Material::grey()
    };
    fit_textures(std::slice::from_mut(&mut checker), 4).unwrap();
    let half = checker.diffuse_map.unwrap();
    let lut = vxgi::trace::srgb_lut();
    assert_eq!((half.width, half.height), (2, 2));
    assert!(
        half.rgb
            .iter()
            .all(|c| (lut[c[0] as usize] - 0.5).abs() < 0.01),
        "{:?}",
        half.rgb
    );
}

/// A floating-point texture (EXR) holds linear values: stored as the sRGB code that decodes nearest.
#[test]
fn float_textures_are_encoded_as_srgb() {
    let d = dir("exrtex");
    let img = image::Rgb32FImage::from_pixel(2, 2, image::Rgb([0.5, 0.0, 2.0]));
    img.save(d.join("lin.exr")).unwrap();
    let (t, note) = vxgi::scene::Texture::read(&d.join("lin.exr")).unwrap();
    assert_eq!(note, None);
    let lut = vxgi::trace::srgb_lut();
    assert!(
        (lut[t.rgb[0][0] as usize] - 0.5).abs() < 0.003,
        "{:?}",
        t.rgb[0]
    );
    assert_eq!((t.rgb[0][1], t.rgb[0][2]), (0, 255));
}

/// The scene of `TRI_OBJ` in `d` with its material `usemtl` from the MTL text `mtl` (a `vt` given, so
/// a texture is read at (0, 0)).
fn load_with_mtl(d: &std::path::Path, mtl: &str, usemtl: &str) -> Scene {
    std::fs::write(d.join("mesh.mtl"), mtl).unwrap();
    std::fs::write(
        d.join("mesh.obj"),
        format!("mtllib mesh.mtl\nusemtl {usemtl}\nvt 0 0\n{TRI_OBJ}"),
    )
    .unwrap();
    std::fs::write(d.join("scene.toml"), scene_toml("mesh.obj", "")).unwrap();
    Scene::load(d.join("scene.toml")).unwrap()
}

/// A `map_Kd` that is not a valid image: a short warning (no dump of its bytes), Kd used instead.
#[test]
fn a_corrupt_texture_is_a_short_warning() {
    let d = dir("corrupt-png");
    let mut bytes = b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR".to_vec();
    bytes.extend((0..200u32).map(|i| (i * 37 % 251) as u8));
    std::fs::write(d.join("bad.png"), bytes).unwrap();
    let s = load_with_mtl(&d, "newmtl m\nKd 0.5 0.5 0.5\nmap_Kd bad.png\n", "m");
    let w = s
        .warnings
        .iter()
        .find(|w| w.contains("bad.png"))
        .expect("a warning");
    assert!(w.len() < 300 && !w.contains('['), "{w}");
    assert!(w.contains("not a valid PNG"), "{w}");
}

/// `map_Kd` with options (`-s 2 2 1 -o 0.5 0.5 0 tex.png`) reads its file and names the options as
/// ignored; the file was looked up under the whole statement before.
#[test]
fn texture_options_are_named_and_the_file_read() {
    let d = dir("map-options");
    image::RgbImage::from_raw(2, 2, vec![255; 12])
        .unwrap()
        .save(d.join("tex.png"))
        .unwrap();
    std::fs::copy(d.join("tex.png"), d.join("my tex.png")).unwrap();
    // The second: a file name with spaces after options with word values.
    for (options, file) in [
        ("-s 2 2 1 -o 0.5 0.5 0", "tex.png"),
        ("-blendu off -bm 1.0 -imfchan l", "my tex.png"),
    ] {
        let mtl = format!("newmtl m\nKd 0.5 0.5 0.5\nmap_Kd {options} {file}\n");
        let s = load_with_mtl(&d, &mtl, "m");
        assert!(s.materials[0].diffuse_map.is_some(), "{:?}", s.warnings);
        assert_warns(&s, &[&format!("`{options}` ignored")]);
    }
}

/// MTL statements the light-transport contract has no term for (emission, transparency) are named
/// in a warning, not dropped silently; a `Ke 0 0 0` or `d 1` (what exporters write by default) is
/// not.
#[test]
fn emission_and_transparency_are_named_as_ignored() {
    let d = dir("ignored-mtl");
    let s = load_with_mtl(
        &d,
        "newmtl glow\nKd 0.5 0.5 0.5\nKe 5 5 5\nnewmtl glass\nKd 0.5 0.5 0.5\nd 0.5\nnewmtl plain\nKd 0.5 0.5 0.5\nKe 0 0 0\nd 1\n",
        "glow",
    );
    let ignored: Vec<&String> = s
        .warnings
        .iter()
        .filter(|w| w.contains("ignored"))
        .collect();
    assert_eq!(ignored.len(), 2, "{:?}", s.warnings);
    assert!(
        ignored[0].contains("glow") && ignored[0].contains("Ke"),
        "{ignored:?}"
    );
    assert!(
        ignored[1].contains("glass") && ignored[1].contains("transparency"),
        "{ignored:?}"
    );
}

/// Values out of range name the file and line of their key; coordinates past f32's reach are named
/// as such; long directions are rescaled (no overflow); a bound set by two keys names both.
#[test]
fn out_of_range_values_name_their_line_and_key() {
    let e = Scene::load(write(
        "vox-line",
        TRI_OBJ,
        &scene_toml(
            "mesh.obj",
            "[render]\n# voxels = 64 was the old value\nanisotropic_voxels = true\nvoxels = 100\n",
        ),
    ))
    .unwrap_err();
    // Neither the comment nor `anisotropic_voxels` is the key: line 14 is.
    assert!(
        e.to_string()
            .contains("scene.toml:14: [render] voxels = 100"),
        "{e}"
    );
    // Camera far past the range: named, with its line (eye is line 6).
    let far = scene_toml("mesh.obj", "").replace("eye = [0.0, 0.5, 3.0]", "eye = [0.0, 1.0, 1e30]");
    let e = Scene::load(write("far-eye", TRI_OBJ, &far))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("scene.toml:5:") && e.contains("eye") && e.contains("renderable range"),
        "{e}"
    );
    // A huge directional light direction: the same light as its unit direction.
    let sun = "[[lights]]\ntype = \"directional\"\ndirection = [1e19, -3e19, -1e20]\nintensity = [1.0, 1.0, 1.0]\n";
    let s = Scene::load(write("long-dir", TRI_OBJ, &scene_toml("mesh.obj", sun))).unwrap();
    let Light::Directional { direction, .. } = s.lights[0] else {
        panic!("a directional light")
    };
    let d = glam::Vec3::from(direction).normalize();
    assert!(
        d.is_finite() && (d - glam::Vec3::new(0.1, -0.3, -1.0).normalize()).length() < 1e-6,
        "{d}"
    );
    // Light position past the range.
    let far_light =
        "[[lights]]\ntype = \"point\"\nposition = [0.0, 1e20, 0.0]\nintensity = [1.0, 1.0, 1.0]\n";
    let e = Scene::load(write(
        "far-light",
        TRI_OBJ,
        &scene_toml("mesh.obj", far_light),
    ))
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("light 0") && e.contains("renderable range") && e.contains("scene.toml:13:"),
        "{e}"
    );
    // Depth splits that make the default overlap too wide: both keys named, the default marked.
    let e = Scene::load(write(
        "splits",
        TRI_OBJ,
        &scene_toml("mesh.obj", "[render]\nlrsm_depth_splits = 20\n"),
    ))
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("lrsm_overlap = 0.05 (the default)")
            && e.contains("lrsm_depth_splits = 20")
            && e.contains("at most 19"),
        "{e}"
    );
    // A negative overlap is out of range whatever the layers: no advice about their width.
    let e = Scene::load(write(
        "overlap",
        TRI_OBJ,
        &scene_toml("mesh.obj", "[render]\nlrsm_overlap = -1.0\n"),
    ))
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("lrsm_overlap = -1 must be a number in [0, 0.5]") && !e.contains("raise"),
        "{e}"
    );
}

/// Resource limits are checked from the settings, before anything is allocated: light views x layers
/// (lrsm), photon maps (vct-svo), samples (every pipeline), voxels.
#[test]
fn resource_limits_are_checked_from_the_settings() {
    use vxgi::render::Pipeline;
    // lavapipe's storage-binding limit, and the storage buffers per stage the kernels bind.
    let limits = wgpu::Limits {
        max_storage_buffer_binding_size: 128 << 20,
        max_buffer_size: (2 << 30) - 1,
        max_storage_buffers_per_shader_stage: 32,
        ..Default::default()
    };
    let mut s = Scene::cornell_box();
    let light = s.lights[0].clone();
    s.lights = vec![light.clone(); 200];
    let e = vxgi::limits::check(&s, Pipeline::Lrsm, &limits).unwrap_err();
    assert!(
        e.contains("1200 light views") && e.contains("rsm_side = 128") && e.contains("at most 768"),
        "{e}"
    );
    vxgi::limits::check(&s, Pipeline::VctDense, &limits).unwrap();
    s.lights = vec![light; 64];
    vxgi::limits::check(&s, Pipeline::Lrsm, &limits).unwrap();
    let mut s = Scene::cornell_box();
    s.render.photon_map = 2048;
    let e = vxgi::limits::check(&s, Pipeline::VctSvo, &limits).unwrap_err();
    assert!(
        e.contains("photon_map = 2048") && e.contains("at most photon_map = 512"),
        "{e}"
    );
    let mut s = Scene::cornell_box();
    s.camera.width = 4096;
    s.camera.height = 4096;
    s.render.supersample = 2;
    let e = vxgi::limits::check(&s, Pipeline::Cprc, &limits).unwrap_err();
    assert!(e.contains("supersample = 2"), "{e}");
    // What a pipeline does not implement is reported by the same check (so by `vxgi scene`).
    let mut s = Scene::cornell_box();
    s.render.bounces = 2;
    let e = vxgi::limits::check(&s, Pipeline::Lrsm, &limits).unwrap_err();
    assert!(e.contains("vct-svo only"), "{e}");
    vxgi::limits::check(&s, Pipeline::VctSvo, &limits).unwrap();
    // Grids past one binding are voxelized, lit and sampled in windows (the accumulators one
    // window at a time); the colour and normal grids must each fit one buffer (256 MiB at 256^3,
    // 2 GiB at 512^3), and the depth-ordered blend's normal pyramid one binding.
    let mut s = Scene::cornell_box();
    s.render.voxels = 256;
    for p in [Pipeline::VctDense, Pipeline::VctSvo, Pipeline::Cprc] {
        vxgi::limits::check(&s, p, &limits).unwrap();
    }
    s.render.depth_ordered_blend = true;
    let e = vxgi::limits::check(&s, Pipeline::VctDense, &limits).unwrap_err();
    assert!(
        e.contains("voxels = 256") && e.contains("depth_ordered_blend = false"),
        "{e}"
    );
    s.render.depth_ordered_blend = false;
    // Instanced hierarchies bind their grids whole.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut inst = Scene::load(root.join("instances.toml")).unwrap();
    inst.render.voxels = 256;
    let e = vxgi::limits::check(&inst, Pipeline::Cprc, &limits).unwrap_err();
    assert!(
        e.contains("[[instances]]") && e.contains("lower voxels"),
        "{e}"
    );
    vxgi::limits::check(&inst, Pipeline::VctSvo, &limits).unwrap();
    s.render.voxels = 512;
    for p in [Pipeline::VctDense, Pipeline::VctSvo, Pipeline::Cprc] {
        // vct-svo lit by photons voxelizes into occupancy bits (`coverage_alone`); lit by
        // voxel_light it needs the dense grids.
        s.render.photon_map = if p == Pipeline::VctSvo { 0 } else { 256 };
        let e = vxgi::limits::check(&s, p, &limits).unwrap_err();
        assert!(
            e.contains("voxels = 512") && e.contains("max_buffer_size"),
            "{p:?}: {e}"
        );
    }
    s.render.photon_map = 256;
    vxgi::limits::check(&s, Pipeline::VctSvo, &limits).unwrap();
}

/// Fuzzing the loader: arbitrary scene text, and the shipped Cornell box's TOML, OBJ and MTL with
/// random edits (bytes replaced, removed, or tokens that break parsers: nan, inf, 1e30, brackets,
/// indices) — loading returns a scene or an error, never panics. 256 cases per file and 256 of arbitrary
/// text in the default run (a fraction of a second); `cargo test --test integration scene:: -- --ignored` runs 8192
/// of each.
mod fuzz {
    use super::*;
    use proptest::prelude::*;

    const TOKENS: &[&str] = &[
        "nan",
        "inf",
        "-inf",
        "1e30",
        "-1e30",
        "3e38",
        "1e-45",
        "-1",
        "0",
        "999999",
        "[",
        "]",
        "{",
        "}",
        "=",
        "\"",
        "\n",
        "/",
        "#",
        "f ",
        "v ",
        "vt ",
        "vn ",
        "usemtl ",
        "newmtl ",
        "Kd ",
        "map_Kd x.png",
        "mtllib nope.mtl",
        "[[lights]]",
        "[render]",
        "type = \"spot\"",
        "\u{ff}",
    ];

    #[derive(Clone, Debug)]
    enum Edit {
        Replace(usize, u8),
        Remove(usize, usize),
        Insert(usize, usize),
    }

    fn edit() -> impl Strategy<Value = Edit> {
        prop_oneof![
            (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Edit::Replace(i, b)),
            (any::<usize>(), 1usize..16).prop_map(|(i, n)| Edit::Remove(i, n)),
            (any::<usize>(), 0..TOKENS.len()).prop_map(|(i, t)| Edit::Insert(i, t)),
        ]
    }

    fn mutate(text: &str, edits: &[Edit]) -> Vec<u8> {
        let mut b = text.as_bytes().to_vec();
        for e in edits {
            let n = b.len().max(1);
            match *e {
                Edit::Replace(i, v) if !b.is_empty() => b[i % n] = v,
                Edit::Remove(i, k) if !b.is_empty() => {
                    let at = i % n;
                    b.drain(at..(at + k).min(b.len()));
                }
                Edit::Insert(i, t) => {
                    let at = i % (b.len() + 1);
                    b.splice(at..at, TOKENS[t].bytes());
                }
                _ => {}
            }
        }
        b
    }

    const TOML: &str = include_str!("../scenes/cornell_box.toml");
    const OBJ: &str = include_str!("../scenes/cornell_box.obj");
    const MTL: &str = include_str!("../scenes/cornell_box.mtl");

    static LOADS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

    /// Writes the three files (one of them mutated) to a fresh folder and loads the scene.
    fn load_with(which: usize, bytes: &[u8]) {
        let d = dir(&format!(
            "fuzz-{}",
            LOADS.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
        ));
        let files = [
            ("scene.toml", TOML),
            ("cornell_box.obj", OBJ),
            ("cornell_box.mtl", MTL),
        ];
        for (i, (name, text)) in files.iter().enumerate() {
            let content = if i == which {
                bytes.to_vec()
            } else {
                text.as_bytes().to_vec()
            };
            std::fs::write(d.join(name), content).unwrap();
        }
        // Ok or Err: both fine; a panic fails the property.
        let _ = Scene::load(d.join("scene.toml"));
        let _ = std::fs::remove_dir_all(&d);
    }

    fn config(cases: u32) -> ProptestConfig {
        ProptestConfig {
            cases,
            failure_persistence: None,
            ..ProptestConfig::default()
        }
    }

    fn run(cases: u32) {
        let runner = || proptest::test_runner::TestRunner::new(config(cases));
        for which in 0..3 {
            let text = [TOML, OBJ, MTL][which];
            runner()
                .run(&proptest::collection::vec(edit(), 1..8), |edits| {
                    load_with(which, &mutate(text, &edits));
                    Ok(())
                })
                .unwrap();
        }
        runner()
            .run(&"(?s).{0,400}", |text| {
                load_with(0, text.as_bytes());
                Ok(())
            })
            .unwrap();
    }

    #[test]
    fn the_loader_never_panics_on_mutated_or_arbitrary_files() {
        run(256);
    }

    #[test]
    #[ignore = "a long fuzz run: cargo test --test integration scene:: -- --ignored"]
    fn the_loader_never_panics_long_run() {
        run(8192);
        eprintln!(
            "loads: {}",
            LOADS.load(std::sync::atomic::Ordering::Relaxed)
        );
    }
}

/// A face whose vertex normals all point to its back renders black from the side they claim (one
/// sided, its front is its winding's): named, with the count; agreeing normals are not.
#[test]
fn normals_against_the_winding_are_named() {
    let agree = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n";
    let s = Scene::load(write("vnok", agree, &scene_toml("mesh.obj", ""))).unwrap();
    assert!(
        !s.warnings.iter().any(|w| w.contains("winding")),
        "{:?}",
        s.warnings
    );
    let against = agree.replace("vn 0 0 1", "vn 0 0 -1");
    let s = Scene::load(write("vnback", &against, &scene_toml("mesh.obj", ""))).unwrap();
    assert_warns(
        &s,
        &["1 of 1 triangles have every vertex normal (vn) against their winding"],
    );
}

/// A `usemtl` before the `mtllib` line that defines its material finds it (tobj resolves names as
/// it reads: the .mtl files are read first).
#[test]
fn usemtl_before_its_mtllib_finds_its_material() {
    let d = dir("usemtlfirst");
    std::fs::write(d.join("m.mtl"), "newmtl red\nKd 0.7 0.1 0.1\n").unwrap();
    let obj = format!("usemtl red\n{TRI_OBJ}mtllib m.mtl\n");
    std::fs::write(d.join("mesh.obj"), obj).unwrap();
    std::fs::write(d.join("scene.toml"), scene_toml("mesh.obj", "")).unwrap();
    let s = Scene::load(d.join("scene.toml")).unwrap();
    assert_eq!(
        s.materials[s.mesh.material[0] as usize].diffuse,
        [0.7, 0.1, 0.1]
    );
    assert!(
        !s.warnings.iter().any(|w| w.contains("no material")),
        "{:?}",
        s.warnings
    );
}
