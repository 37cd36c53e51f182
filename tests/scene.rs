//! Scene input: the built-in Cornell box, and every kind of bad file a user can hand us — each an error
//! with file and line, never a panic.
mod common;

use std::path::PathBuf;
use vxgi::scene::{Light, Scene, SceneError};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vxgi-scene-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const TRI_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

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
    assert!(
        s.warnings.iter().any(|w| w.contains("grey diffuse 0.8")),
        "{:?}",
        s.warnings
    );
    let s2 = Scene::load(write("nolights", TRI_OBJ, &scene_toml("mesh.obj", ""))).unwrap();
    assert!(
        s2.warnings.iter().any(|w| w.contains("no lights")),
        "{:?}",
        s2.warnings
    );
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
    let p = write(
        "degenerate",
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
        &scene_toml("mesh.obj", ""),
    );
    let e = Scene::load(&p).unwrap_err();
    assert!(
        matches!(
            e,
            SceneError::DegenerateTriangle {
                lines: [1, 2, 3],
                ..
            }
        ),
        "{e}"
    );
    let p = write("empty", "v 0 0 0\n", &scene_toml("mesh.obj", ""));
    assert!(matches!(
        Scene::load(&p).unwrap_err(),
        SceneError::EmptyMesh { .. } | SceneError::Obj { .. }
    ));
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
    assert!(
        scene.warnings.iter().any(|w| w.contains("nowhere.png")),
        "{:?}",
        scene.warnings
    );

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
/// the instances equal the Cornell box's boxes in kind (12 triangles each, their own materials); a
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
    // Materials: the room's (white, red, green, grey) then each box OBJ's (yellow, grey).
    assert_eq!(s.materials.len(), 8);
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
/// a missing OBJ, unknown keys; and a scene with neither a mesh nor instances.
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
