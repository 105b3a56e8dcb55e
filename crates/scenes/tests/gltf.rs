//! glTF 2.0 import: the three storage kinds, node transforms, skipped primitives and errors.

mod common;

use common::{broken_model, sample_model, write_gltf, GltfKind};
use glam::{Mat4, Vec3};
use softshadow_scenes::{load, load_gltf, SceneError};

const KINDS: [GltfKind; 3] = [GltfKind::External, GltfKind::Embedded, GltfKind::Binary];

#[test]
fn all_three_kinds_load_with_node_transforms() {
    let dir = tempfile::tempdir().unwrap();
    for kind in KINDS {
        let (json, buffer) = sample_model();
        let path = write_gltf(dir.path(), &format!("sample-{kind:?}"), kind, json, &buffer);
        let geometry = load_gltf(&path).unwrap_or_else(|e| panic!("{kind:?}: {e}"));

        // quad (2 triangles) and the triangle primitive of `tri` (1); the LINES one is skipped.
        assert_eq!(geometry.meshes.len(), 2, "{kind:?}");
        let quad = &geometry.meshes[0];
        let tri = &geometry.meshes[1];
        assert_eq!(quad.name, "quad");
        assert_eq!(quad.triangle_count(), 2);
        assert_eq!(tri.triangle_count(), 1);
        assert_eq!(
            tri.indices,
            vec![0, 1, 2],
            "non-indexed primitive gets 0..n"
        );
        for mesh in &geometry.meshes {
            assert_eq!(mesh.normals.len(), mesh.positions.len(), "normals computed");
        }
        assert!(quad.normals.iter().all(|n| n.abs_diff_eq(Vec3::Y, 1e-6)));
        assert!(
            geometry
                .warnings
                .iter()
                .any(|w| w.contains("Lines") && w.contains("tri")),
            "{kind:?}: {:?}",
            geometry.warnings
        );

        // Node transforms: root (translate (1,2,3), scale 2) -> child with the quad.
        assert_eq!(geometry.instances.len(), 2);
        let (quad_index, quad_world) = geometry.instances[0];
        assert_eq!(quad_index, 0);
        let corner = quad_world.transform_point3(Vec3::new(1.0, 0.0, 1.0));
        assert!(
            corner.abs_diff_eq(Vec3::new(3.0, 2.0, 5.0), 1e-6),
            "{corner}"
        );
        let (tri_index, tri_world) = geometry.instances[1];
        assert_eq!(tri_index, 1);
        assert!(tri_world.abs_diff_eq(Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0)), 1e-6));
    }
}

#[test]
fn loading_a_model_as_a_scene_wraps_it() {
    let dir = tempfile::tempdir().unwrap();
    let (json, buffer) = sample_model();
    let path = write_gltf(dir.path(), "wrapped", GltfKind::Binary, json, &buffer);
    let loaded = load(path.to_str().unwrap()).unwrap();
    let scene = &loaded.scene;
    assert_eq!(scene.name, "wrapped");
    // 2 model instances + ground.
    assert_eq!(scene.instances.len(), 3);
    let ground = scene.instances.last().unwrap();
    assert!(!ground.casts_shadow && ground.receives_shadow);
    let model = scene.bounds(|i| i.casts_shadow);
    let floor = scene.bounds(|i| !i.casts_shadow);
    assert_eq!(
        floor.max.y, model.min.y,
        "ground sits under the model's bounds"
    );
    assert!(floor.min.x < model.min.x && floor.max.z > model.max.z);
    assert!(scene.light.center.y > model.max.y);
    for p in model.corners() {
        assert!((p - scene.light.center).dot(scene.light.direction) > 0.0);
    }
    assert_eq!(scene.triangle_count(), 2 + 1 + 2);
}

#[test]
fn repaired_triangles_become_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let (json, buffer) = broken_model();
    let path = write_gltf(dir.path(), "broken", GltfKind::Embedded, json, &buffer);
    let geometry = load_gltf(&path).unwrap();
    assert_eq!(geometry.meshes[0].triangle_count(), 1);
    assert!(
        geometry.warnings.iter().any(|w| w
            == "mesh `broken` from broken.gltf: dropped 1 degenerate, 1 non-finite and 1 out-of-range triangles"),
        "{:?}",
        geometry.warnings
    );
}

#[test]
fn missing_file_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nowhere.glb");
    let err = load_gltf(&path).unwrap_err();
    assert!(matches!(err, SceneError::FileNotFound { .. }), "{err:?}");
    let message = err.to_string();
    assert!(
        message.contains("nowhere.glb") && message.contains("check the path"),
        "{message}"
    );
    // Through `load` too.
    let message = load(path.to_str().unwrap()).unwrap_err().to_string();
    assert!(message.contains("nowhere.glb"), "{message}");
}

#[test]
fn truncated_glb_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let (json, buffer) = sample_model();
    let path = write_gltf(dir.path(), "cut", GltfKind::Binary, json, &buffer);
    let bytes = std::fs::read(&path).unwrap();
    for keep in [bytes.len() - 10, bytes.len() / 2, 20, 5] {
        std::fs::write(&path, &bytes[..keep]).unwrap();
        let err = load_gltf(&path).unwrap_err();
        let message = err.to_string();
        assert!(matches!(err, SceneError::GltfMalformed { .. }), "{err:?}");
        assert!(
            message.contains("cut.glb") && message.contains("re-export"),
            "{message}"
        );
        assert!(!message.contains('\n'));
    }
}

#[test]
fn json_syntax_error_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.gltf");
    std::fs::write(&path, br#"{ "asset": { "version": "2.0" }, "scenes": [ "#).unwrap();
    let message = load_gltf(&path).unwrap_err().to_string();
    assert!(
        message.contains("bad.gltf") && message.contains("malformed"),
        "{message}"
    );
    assert!(!message.contains('\n'));
}

#[test]
fn missing_external_buffer_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let (json, buffer) = sample_model();
    let path = write_gltf(dir.path(), "lonely", GltfKind::External, json, &buffer);
    std::fs::remove_file(dir.path().join("lonely.bin")).unwrap();
    let message = load_gltf(&path).unwrap_err().to_string();
    assert!(
        message.contains("lonely.gltf") && message.contains("buffers"),
        "{message}"
    );
}

#[test]
fn a_file_without_triangles_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let (mut json, buffer) = sample_model();
    json["scenes"] = serde_json::json!([{ "nodes": [] }]);
    let path = write_gltf(dir.path(), "empty", GltfKind::Embedded, json, &buffer);
    let err = load_gltf(&path).unwrap_err();
    assert!(matches!(err, SceneError::GltfNoGeometry { .. }), "{err:?}");
}
