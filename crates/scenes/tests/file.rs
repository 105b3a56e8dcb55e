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
        materials: Vec::new(),
        textures: Vec::new(),
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

/// The per-field defaults that `serde` fills in when a table is present but the field is not
/// (found by `cargo mutants`: `defaults_scale_and_integers` leaves `[light]` out altogether, so
/// `LightDef::default` was used instead): width 1, height = width, intensity 1, albedo 0.8,
/// blob triangles 20000 and seed 1, segments 32; a given albedo is kept.
#[test]
fn field_defaults_inside_given_tables() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "defaults.toml",
        r#"
[light]
center = [0, 5, 0]
[[object]]
plane = { size = [4, 4] }
[[object]]
blob = { radius = 0.5 }
[[object]]
sphere = { radius = 0.5 }
[[object]]
box = { size = [1, 1, 1] }
albedo = [0.25, 0.5, 1]
"#,
    );
    let scene = load_scene_file(&path).unwrap().scene;
    let light = &scene.light;
    assert_eq!(light.center, Vec3::new(0.0, 5.0, 0.0));
    assert_eq!(
        (light.width, light.height, light.intensity),
        (1.0, 1.0, 1.0)
    );
    assert!(scene.instances[..3]
        .iter()
        .all(|i| i.albedo == Vec3::splat(0.8)));
    assert_eq!(scene.instances[3].albedo, Vec3::new(0.25, 0.5, 1.0));
    let blob = softshadow_scenes::primitives::blob(0.5, 20_000, 1);
    assert_eq!(scene.meshes[1].positions, blob.positions);
    assert_eq!(scene.meshes[1].indices, blob.indices);
    let sphere = softshadow_scenes::primitives::uv_sphere(0.5, 32);
    assert_eq!(scene.meshes[2].triangle_count(), sphere.triangle_count());
}

/// A glTF object after another object: its meshes are appended (instance mesh indices offset
/// by the meshes before them) and each node use is placed by the object's transform times the
/// node's (found by `cargo mutants`: the shipped example's model has one mesh and identity
/// nodes). The sample model: `quad` under translate (1, 2, 3) scale 2, `tri` at (0, 0, -5).
#[test]
fn gltf_objects_offset_mesh_indices_and_compose_transforms() {
    use common::sample_model;
    let dir = tempfile::tempdir().unwrap();
    let (json, buffer) = sample_model();
    write_gltf(dir.path(), "sample", GltfKind::Binary, json, &buffer);
    let path = write(
        dir.path(),
        "placed.toml",
        "[[object]]\nplane = { size = [4, 4] }\n[[object]]\ngltf = \"sample.glb\"\ntranslation = [0, 1, 0]\nalbedo = [0.5, 0.5, 0.5]\n",
    );
    let scene = load_scene_file(&path).unwrap().scene;
    let names: Vec<&str> = scene.meshes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names[1..], ["quad", "tri/0"]);
    let uses: Vec<usize> = scene.instances.iter().map(|i| i.mesh).collect();
    assert_eq!(uses, [0, 1, 2]);
    let shift = glam::Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0));
    let quad_node = glam::Mat4::from_scale_rotation_translation(
        Vec3::splat(2.0),
        glam::Quat::IDENTITY,
        Vec3::new(1.0, 2.0, 3.0),
    );
    let tri_node = glam::Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0));
    assert!(scene.instances[1]
        .transform
        .abs_diff_eq(shift * quad_node, 1e-6));
    assert!(scene.instances[2]
        .transform
        .abs_diff_eq(shift * tri_node, 1e-6));
    // The object's other settings reach every node use.
    assert!(scene.instances[1..]
        .iter()
        .all(|i| i.albedo == Vec3::splat(0.5) && i.casts_shadow));
}

/// The light's default `up`: +z when it faces (nearly) straight up or down, |y| of the unit
/// direction above 0.9, +y otherwise (found by `cargo mutants`: no test read `up`). The
/// direction (0.43588993, -0.9, 0) normalises to y = -0.9 exactly in f32: not above 0.9.
#[test]
fn light_up_defaults_by_how_steep_the_light_is() {
    let up = |direction: &str| {
        let text = format!("[light]\n{direction}\n[[object]]\nplane = {{ size = [4, 4] }}\n");
        let dir = tempfile::tempdir().unwrap();
        let path = write(dir.path(), "up.toml", &text);
        let light = load_scene_file(&path).unwrap().scene.light;
        (light.direction, light.up)
    };
    assert_eq!(up(""), (Vec3::NEG_Y, Vec3::Z));
    assert_eq!(up("direction = [0, 2, 0]"), (Vec3::Y, Vec3::Z));
    assert_eq!(up("direction = [0.1, -1, 0]").1, Vec3::Z);
    assert_eq!(up("direction = [1, -1, 0]").1, Vec3::Y);
    assert_eq!(up("direction = [1, 0, 0]"), (Vec3::X, Vec3::Y));
    let (d, u) = up("direction = [0.43588993, -0.9, 0]");
    assert_eq!((d.y, u), (-0.9, Vec3::Y));
    // A given `up` is kept.
    assert_eq!(up("up = [1, 0, 0]").1, Vec3::X);
}

/// Sizes must be strictly positive: zero is refused like a negative size.
#[test]
fn zero_sizes_are_refused() {
    for source in [
        "plane = { size = [0, 1] }",
        "box = { size = [1, 0, 1] }",
        "sphere = { radius = 0 }",
        "cylinder = { radius = 1, height = 0 }",
    ] {
        let message = file_error(&format!(
            "[[object]]\nplane = {{ size = [1, 1] }}\n[[object]]\n{source}\n"
        ));
        assert!(
            message.contains("object 2") && message.contains("must be finite and > 0"),
            "{source}: {message}"
        );
    }
}

/// A `[camera]` table is used field by field (found by `cargo mutants`: no test gave one, and
/// the default camera has the same field of view as `CameraDef`'s).
#[test]
fn camera_fields_are_used() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "camera.toml",
        "[camera]\neye = [1, 2, 3]\ntarget = [0, 1, 0]\nup = [0, 0, 1]\nfov_y_degrees = 30\nnear = 0.5\nfar = 20\n[[object]]\nplane = { size = [4, 4] }\n",
    );
    let camera = load_scene_file(&path).unwrap().scene.camera;
    assert_eq!(
        (camera.eye, camera.target, camera.up),
        (Vec3::new(1.0, 2.0, 3.0), Vec3::Y, Vec3::Z)
    );
    assert_eq!(
        (camera.fov_y_degrees, camera.near, camera.far),
        (30.0, 0.5, 20.0)
    );
}

/// `[light]`'s kinds (issue 39): each kind and its keys load; bad values are refused in one line
/// naming the field and its range.
#[test]
fn light_kinds_load_and_bad_values_are_refused() {
    use softshadow_core::LightKind;
    let dir = tempfile::tempdir().unwrap();
    let scene = |light: &str| {
        let text = format!("[light]\n{light}\n[[object]]\nplane = {{ size = [1, 1] }}\n");
        load_scene_file(write(dir.path(), "k.toml", &text)).map(|s| s.scene.light)
    };
    let rect = scene("").unwrap();
    assert_eq!((rect.kind, rect.width), (LightKind::Rect, 1.0));
    let disk = scene("kind = \"disk\"\nradius = 0.25").unwrap();
    assert_eq!((disk.kind, disk.radius), (LightKind::Disk, 0.25));
    let spot =
        scene("kind = \"spot\"\nradius = 0.1\ncone_inner_degrees = 10\ncone_outer_degrees = 20")
            .unwrap();
    assert_eq!(
        (spot.kind, spot.cone_inner_degrees, spot.cone_outer_degrees),
        (LightKind::Spot, 10.0, 20.0)
    );
    let sun = scene("kind = \"sun\"\ndirection = [0.3, -1, 0]").unwrap();
    assert_eq!(
        (sun.kind, sun.angular_diameter_degrees),
        (LightKind::Sun, 0.53)
    );
    assert_eq!(scene("kind = \"sphere\"").unwrap().kind, LightKind::Sphere);
    for (light, words) in [
        (
            "kind = \"lamp\"",
            &[
                "\"lamp\" is not a light kind",
                "rect | disk | sphere | spot | sun",
            ][..],
        ),
        ("kind = \"disk\"\nradius = -0.5", &["radius", ">= 0"]),
        (
            "kind = \"spot\"\ncone_inner_degrees = 40\ncone_outer_degrees = 20",
            &["cone_outer_degrees", "outer >= inner"],
        ),
        ("kind = \"spot\"\ncone_outer_degrees = 120", &["0..=90"]),
        (
            "kind = \"sun\"\nangular_diameter_degrees = 180",
            &["angular_diameter_degrees", "0..180"],
        ),
    ] {
        let message = file_error(&format!(
            "[light]\n{light}\n[[object]]\nplane = {{ size = [1, 1] }}\n"
        ));
        for word in words {
            assert!(message.contains(word), "{light}: {message}");
        }
    }
}
