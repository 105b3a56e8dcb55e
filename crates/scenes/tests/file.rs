//! TOML scene files: the shipped examples, every mesh source, errors with lines, repair warnings.

mod common;

use std::path::{Path, PathBuf};

use common::{broken_model, write_gltf, GltfKind};
use glam::Vec3;
use softshadow_core::{Instance, Mesh, Scene};
use softshadow_scenes::{finalize, load, load_scene_file, SceneError};

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets")
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn shipped_procedural_example_loads() {
    let loaded = load_scene_file(assets().join("scenes/primitives.toml")).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let scene = &loaded.scene;
    assert_eq!(scene.name, "primitives-example");
    assert_eq!(scene.instances.len(), 5);
    let names: Vec<&str> = scene.meshes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["ground", "crate", "ball", "pillar", "rock"]);
    assert!(!scene.instances[0].casts_shadow && scene.instances[0].receives_shadow);
    assert!(scene.instances[2].dynamic && !scene.instances[1].dynamic);
    assert_eq!(scene.light.height, 0.8);
    let to_target = (Vec3::ZERO - scene.light.center).normalize();
    assert!(scene.light.direction.abs_diff_eq(to_target, 1e-6));
    // The crate (box 0.6, at y = 0.3) rests on the ground.
    let b = scene.bounds(|i| i.mesh == 1);
    assert!(
        b.min.y.abs() < 1e-6 && (b.max.y - 0.6).abs() < 1e-6,
        "{b:?}"
    );
}

#[test]
fn shipped_gltf_example_loads_through_load() {
    let path = assets().join("scenes/tetrahedron.toml");
    let loaded = load(path.to_str().unwrap()).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let scene = &loaded.scene;
    assert_eq!(scene.instances.len(), 3);
    assert_eq!(scene.triangle_count(), 2 + 4 + 4);
    // tetra-high: the unit-ish tetrahedron (corners at ±0.5) scaled 0.6 around (-0.6, 1, 0).
    let b = scene.bounds(|i| i.mesh == 1);
    assert!(b.min.abs_diff_eq(Vec3::new(-0.9, 0.7, -0.3), 1e-5), "{b:?}");
    assert!(b.max.abs_diff_eq(Vec3::new(-0.3, 1.3, 0.3), 1e-5), "{b:?}");
    // The model's meshes are outward-facing: positive signed volume.
    let mesh = &scene.meshes[1];
    let volume: f32 = mesh
        .indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[t[k] as usize]);
            a.dot(b.cross(c))
        })
        .sum();
    assert!(volume > 0.0);
}

#[test]
fn defaults_scale_and_integers() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "mini.toml",
        r#"
[[object]]
plane = { size = [4, 4] }
casts_shadow = false
[[object]]
sphere = { radius = 1 }
translation = [0, 2, 0]
scale = [1, 0.5, 1]
[[object]]
cylinder = { radius = 0.2, height = 1, segments = 8 }
scale = 2
"#,
    );
    let scene = load_scene_file(&path).unwrap().scene;
    assert_eq!(scene.name, "mini");
    assert_eq!(scene.light.center, Vec3::new(0.0, 4.0, 0.0));
    assert_eq!(scene.light.direction, Vec3::NEG_Y);
    assert_eq!((scene.light.width, scene.light.height), (1.0, 1.0));
    assert_eq!(scene.camera.fov_y_degrees, 45.0);
    let sphere = scene.bounds(|i| i.mesh == 1);
    assert!((sphere.max.y - 2.5).abs() < 1e-5 && (sphere.min.y - 1.5).abs() < 1e-5);
    let cylinder = scene.bounds(|i| i.mesh == 2);
    assert!((cylinder.max.y - 1.0).abs() < 1e-5, "{cylinder:?}");
    let flags: Vec<(bool, bool, bool)> = scene
        .instances
        .iter()
        .map(|i| (i.casts_shadow, i.receives_shadow, i.dynamic))
        .collect();
    assert_eq!(flags[1], (true, true, false));
}

fn file_error(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "x.toml", text);
    let message = load_scene_file(&path).unwrap_err().to_string();
    assert!(!message.contains('\n'), "{message}");
    assert!(message.contains("x.toml"), "{message}");
    message
}

#[test]
fn unknown_field_reports_the_line() {
    let message =
        file_error("name = \"a\"\n\n[[object]]\ncolour = [1, 0, 0]\nplane = { size = [1, 1] }\n");
    assert!(
        message.starts_with("scene file `")
            && message.contains("x.toml` line 4: unknown field `colour`, expected one of"),
        "{message}"
    );
    let message = file_error("[light]\ncenter = [0, 4, 0]\nwidht = 2\n");
    assert!(
        message.contains("line 3") && message.contains("`widht`"),
        "{message}"
    );
    let message = file_error("[[object]]\nplane = { size = [1, 1], color = 2 }\n");
    assert!(message.contains("unknown field `color`"), "{message}");
}

#[test]
fn syntax_and_type_errors_report_the_line() {
    let message = file_error("name = \"a\"\n[camera]\neye = [0, 1\n");
    assert!(message.contains("line 3"), "{message}");
    let message = file_error("[camera]\nfov_y_degrees = \"wide\"\n");
    assert!(message.contains("line 2"), "{message}");
}

#[test]
fn object_mistakes_are_named() {
    let message = file_error(
        "[[object]]\nname = \"thing\"\nplane = { size = [1, 1] }\nbox = { size = [1, 1, 1] }\n",
    );
    assert!(
        message.contains("object 1 (`thing`)")
            && message.contains("found 2 mesh sources (plane, box)")
            && message.contains("exactly one"),
        "{message}"
    );
    let message = file_error("[[object]]\ntranslation = [0, 1, 0]\n");
    assert!(message.contains("found 0 mesh sources (none)"), "{message}");
    let message =
        file_error("[[object]]\nplane = { size = [1, 1] }\n[[object]]\nsphere = { radius = -1 }\n");
    assert!(
        message.contains("object 2") && message.contains("must be finite and > 0"),
        "{message}"
    );
    let message = file_error("[[object]]\nblob = { radius = 1, triangles = 1 }\n");
    assert!(message.contains("use 8 to"), "{message}");
    let message = file_error("[light]\ndirection = [0, -1, 0]\ntarget = [0, 0, 0]\n[[object]]\nplane = { size = [1, 1] }\n");
    assert!(message.contains("keep only one"), "{message}");
    let message = file_error("[[object]]\ngltf = \"missing.glb\"\n");
    assert!(
        message.contains("missing.glb") && message.contains("not found"),
        "{message}"
    );
    let message = file_error(
        "[[object]]\nplane = { size = [1, 1] }\ncasts_shadow = false\nreceives_shadow = false\n",
    );
    assert!(message.contains("no shadow receiver"), "{message}");
    let message = file_error("[light]\nwidth = -1\n[[object]]\nplane = { size = [1, 1] }\n");
    assert!(message.contains("negative"), "{message}");
}

#[test]
fn missing_scene_file() {
    let err = load("does/not/exist.toml").unwrap_err();
    assert_eq!(
        err.to_string(),
        "scene file `does/not/exist.toml` not found: check the path"
    );
}

#[test]
fn unsupported_existing_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "model.obj", "v 0 0 0\n");
    let err = load(path.to_str().unwrap()).unwrap_err();
    assert!(matches!(err, SceneError::UnsupportedFile { .. }), "{err:?}");
}

#[test]
fn broken_gltf_referenced_from_toml_is_repaired_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let (json, buffer) = broken_model();
    write_gltf(dir.path(), "broken", GltfKind::Binary, json, &buffer);
    let path = write(
        dir.path(),
        "uses-broken.toml",
        "[[object]]\nplane = { size = [4, 4] }\ncasts_shadow = false\n[[object]]\ngltf = \"broken.glb\"\ntranslation = [0, 1, 0]\n",
    );
    let loaded = load_scene_file(&path).unwrap();
    assert_eq!(
        loaded.warnings,
        ["mesh `broken` from broken.glb: dropped 1 degenerate, 1 non-finite and 1 out-of-range triangles"]
    );
    assert_eq!(loaded.scene.triangle_count(), 2 + 1);
    assert!(loaded
        .scene
        .meshes
        .iter()
        .all(|m| m.positions.iter().all(|p| p.is_finite())));
}

#[test]
fn procedural_mesh_with_bad_triangles_is_repaired_with_a_warning() {
    let mut mesh = softshadow_scenes::primitives::plane(1.0, 1.0);
    mesh.name = "patched".into();
    let n = mesh.positions.len() as u32;
    mesh.positions.push(Vec3::new(f32::NAN, 0.0, 0.0));
    mesh.indices.extend_from_slice(&[0, 1, n, 0, 0, 1, 0, 2, 2]);
    let scene = Scene {
        name: "patched-scene".into(),
        meshes: vec![mesh, Mesh::default()],
        instances: vec![Instance::new(0, glam::Mat4::IDENTITY)],
        light: Default::default(),
        camera: Default::default(),
    };
    let loaded = finalize(scene, "test").unwrap();
    assert_eq!(loaded.scene.meshes[0].triangle_count(), 2);
    assert_eq!(
        loaded.warnings,
        ["mesh `patched` from test: dropped 2 degenerate and 1 non-finite triangles"]
    );
}

#[test]
fn documented_example_loads() {
    let doc = std::fs::read_to_string(assets().join("../docs/SCENES.md")).unwrap();
    let start = doc
        .find("### Example\n\n```toml\n")
        .expect("example heading")
        + 20;
    let end = start + doc[start..].find("```").unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("scenes")).unwrap();
    std::fs::create_dir_all(dir.path().join("models")).unwrap();
    std::fs::copy(
        assets().join("models/tetrahedron.gltf"),
        dir.path().join("models/tetrahedron.gltf"),
    )
    .unwrap();
    let path = write(&dir.path().join("scenes"), "example.toml", &doc[start..end]);
    let loaded = load_scene_file(&path).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    assert_eq!(loaded.scene.instances.len(), 5);
}
