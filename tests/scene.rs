//! Scene input: the built-in Cornell box, and every kind of bad file a user can hand us — each an error
//! with file and line, never a panic.
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
