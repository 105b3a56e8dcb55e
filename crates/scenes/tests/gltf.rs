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

/// `f32` values as little-endian bytes.
fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

#[test]
fn triangle_strips_and_fans_load_as_lists_with_the_specification_winding() {
    // Every triangle below lies in y = 0 and faces +y in the winding of the glTF 2.0
    // specification (3.7.2.1), so computed normals of +y check the order.
    // mesh 0: a non-indexed strip of 4 vertices (2 triangles).
    let strip = [0., 0., 0., 0., 0., 1., 1., 0., 0., 1., 0., 1.];
    // mesh 1: a non-indexed fan around the origin, 5 vertices (3 triangles).
    let fan = [0., 0., 0., 1., 0., 0., 0., 0., -1., -1., 0., 0., 0., 0., 1.];
    // mesh 2: an indexed strip of two quads joined by repeated indices (4 triangles and 4
    // joining ones, which are not damage and so are dropped without a warning).
    let mut quads = strip.to_vec();
    quads.extend(strip.chunks(3).flat_map(|p| [p[0] + 2.0, p[1], p[2]]));
    let join: Vec<u8> = [0u16, 1, 2, 3, 3, 4, 4, 5, 6, 7]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let mut buffer = f32_bytes(&strip);
    let fan_at = buffer.len();
    buffer.extend(f32_bytes(&fan));
    let quads_at = buffer.len();
    buffer.extend(f32_bytes(&quads));
    let join_at = buffer.len();
    buffer.extend(&join);
    buffer.extend([0, 0, 0, 0]);
    let json = serde_json::json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": [0, 1, 2] }],
        "nodes": [{ "mesh": 0 }, { "mesh": 1 }, { "mesh": 2 }],
        "meshes": [
            { "name": "strip", "primitives": [{ "attributes": { "POSITION": 0 }, "mode": 5 }] },
            { "name": "fan", "primitives": [{ "attributes": { "POSITION": 1 }, "mode": 6 }] },
            { "name": "joined", "primitives": [{ "attributes": { "POSITION": 2 }, "indices": 3, "mode": 5 }] }
        ],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 48 },
            { "buffer": 0, "byteOffset": fan_at, "byteLength": 60 },
            { "buffer": 0, "byteOffset": quads_at, "byteLength": 96 },
            { "buffer": 0, "byteOffset": join_at, "byteLength": 20 }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0] },
            { "bufferView": 1, "componentType": 5126, "count": 5, "type": "VEC3",
              "min": [-1.0, 0.0, -1.0], "max": [1.0, 0.0, 1.0] },
            { "bufferView": 2, "componentType": 5126, "count": 8, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [3.0, 0.0, 1.0] },
            { "bufferView": 3, "componentType": 5123, "count": 10, "type": "SCALAR" }
        ]
    });
    let dir = tempfile::tempdir().unwrap();
    for kind in KINDS {
        let path = write_gltf(
            dir.path(),
            &format!("strips-{kind:?}"),
            kind,
            json.clone(),
            &buffer,
        );
        let geometry = load_gltf(&path).unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        assert!(geometry.warnings.is_empty(), "{:?}", geometry.warnings);
        let counts: Vec<usize> = geometry.meshes.iter().map(|m| m.triangle_count()).collect();
        assert_eq!(counts, [2, 3, 4], "{kind:?}");
        assert_eq!(geometry.meshes[0].indices, [0, 1, 2, 1, 3, 2]);
        assert_eq!(geometry.meshes[1].indices, [1, 2, 0, 2, 3, 0, 3, 4, 0]);
        assert_eq!(
            geometry.meshes[2].indices,
            [0, 1, 2, 1, 3, 2, 4, 5, 6, 5, 7, 6]
        );
        for mesh in &geometry.meshes {
            assert!(
                mesh.normals.iter().all(|n| n.abs_diff_eq(Vec3::Y, 1e-6)),
                "{}: {:?}",
                mesh.name,
                mesh.normals
            );
        }
        assert_eq!(geometry.instances.len(), 3);
    }
}

#[test]
fn a_gltf_1_file_says_it_is_gltf_1_and_to_re_export_it() {
    let dir = tempfile::tempdir().unwrap();
    // glTF 1.0 keeps its objects in dictionaries keyed by id; with and without `asset`.
    let json_1 = serde_json::json!({
        "asset": { "version": "1.0" },
        "scene": "defaultScene",
        "scenes": { "defaultScene": { "nodes": ["node"] } },
        "nodes": { "node": { "meshes": ["mesh"] } },
        "meshes": { "mesh": { "primitives": [{ "attributes": { "POSITION": "positions" }, "mode": 4 }] } },
        "accessors": { "positions": { "bufferView": "view", "byteOffset": 0, "componentType": 5126, "count": 3, "type": "VEC3" } }
    });
    let mut no_asset = json_1.clone();
    no_asset.as_object_mut().unwrap().remove("asset");
    // Binary glTF 1.0 (KHR_binary_glTF): header version 1, then content length and format 0.
    let content = serde_json::to_vec(&json_1).unwrap();
    let mut glb_1 = b"glTF".to_vec();
    glb_1.extend(1u32.to_le_bytes());
    glb_1.extend((20 + content.len() as u32).to_le_bytes());
    glb_1.extend((content.len() as u32).to_le_bytes());
    glb_1.extend(0u32.to_le_bytes());
    glb_1.extend(&content);
    let files = [
        ("old.gltf", serde_json::to_vec(&json_1).unwrap(), "1.0"),
        (
            "no-asset.gltf",
            serde_json::to_vec(&no_asset).unwrap(),
            "1.0",
        ),
        ("old.glb", glb_1, "1.0 (binary"),
    ];
    for (name, bytes, version) in files {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let err = load_gltf(&path).unwrap_err();
        assert!(matches!(err, SceneError::GltfVersion { .. }), "{err:?}");
        let message = err.to_string();
        assert!(
            message.contains(name)
                && message.contains(&format!("is glTF {version}"))
                && message.contains("re-export it as glTF 2.0")
                && !message.contains("malformed"),
            "{message}"
        );
        // Through `load` too, as the CLI and the viewer call it.
        let message = load(path.to_str().unwrap()).unwrap_err().to_string();
        assert!(message.contains("re-export it as glTF 2.0"), "{message}");
    }
}

#[test]
fn a_draco_compressed_file_names_the_extension_and_says_to_re_export_without_it() {
    let dir = tempfile::tempdir().unwrap();
    for kind in KINDS {
        let (mut json, buffer) = sample_model();
        let draco = "KHR_draco_mesh_compression";
        json["extensionsUsed"] = serde_json::json!([draco]);
        json["extensionsRequired"] = serde_json::json!([draco]);
        json["meshes"][0]["primitives"][0]["extensions"] = serde_json::json!({
            draco: { "bufferView": 0, "attributes": { "POSITION": 0 } }
        });
        let path = write_gltf(dir.path(), &format!("draco-{kind:?}"), kind, json, &buffer);
        let err = load_gltf(&path).unwrap_err();
        assert!(matches!(err, SceneError::GltfExtension { .. }), "{err:?}");
        let message = err.to_string();
        assert!(
            message.contains("draco-")
                && message.contains("requires the extension `KHR_draco_mesh_compression` (Draco")
                && message.contains("re-export it without `KHR_draco_mesh_compression`")
                && !message.contains("malformed"),
            "{message}"
        );
    }
}

#[test]
fn an_unknown_required_extension_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let (mut json, buffer) = sample_model();
    json["extensionsUsed"] = serde_json::json!(["EXT_made_up"]);
    json["extensionsRequired"] = serde_json::json!(["EXT_made_up"]);
    let path = write_gltf(dir.path(), "made-up", GltfKind::Binary, json, &buffer);
    let message = load_gltf(&path).unwrap_err().to_string();
    assert_eq!(
        message,
        format!(
            "glTF file `{}` requires the extension `EXT_made_up`, which is not read here: \
             re-export it without `EXT_made_up`",
            path.display()
        )
    );
}

/// `KHR_lights_punctual` lights become the workbench's kinds with their source size from
/// `extras` (issue 39): a model loaded alone is lit by its first light.
#[test]
fn punctual_lights_become_light_kinds_with_their_size_from_extras() {
    use softshadow_core::LightKind;
    let dir = tempfile::tempdir().unwrap();
    let (mut json, buffer) = sample_model();
    json["extensionsUsed"] = serde_json::json!(["KHR_lights_punctual"]);
    json["extensions"] = serde_json::json!({ "KHR_lights_punctual": { "lights": [
        { "type": "spot", "spot": { "innerConeAngle": 0.2, "outerConeAngle": 0.5 },
          "extras": { "radius": 0.1 } },
        { "type": "directional", "extras": { "angular_diameter_degrees": 2.0 } },
        { "type": "point" }
    ] } });
    // Three light nodes: a spot 3 above the origin aimed down (-z rotated onto -y), the sun, a
    // point light.
    let down = [
        -std::f32::consts::FRAC_1_SQRT_2,
        0.0,
        0.0,
        std::f32::consts::FRAC_1_SQRT_2,
    ];
    let nodes = json["nodes"].as_array_mut().unwrap();
    nodes.push(
        serde_json::json!({ "translation": [0.0, 3.0, 0.0], "rotation": down,
        "extensions": { "KHR_lights_punctual": { "light": 0 } } }),
    );
    nodes.push(serde_json::json!({ "extensions": { "KHR_lights_punctual": { "light": 1 } } }));
    nodes.push(serde_json::json!({ "translation": [1.0, 5.0, 0.0],
        "extensions": { "KHR_lights_punctual": { "light": 2 } } }));
    json["scenes"][0]["nodes"] = serde_json::json!([0, 2, 3, 4, 5]);
    let path = write_gltf(dir.path(), "lit", GltfKind::Embedded, json, &buffer);
    let lights = load_gltf(&path).unwrap().lights;
    assert_eq!(lights.len(), 3);
    let spot = lights[0];
    assert_eq!((spot.kind, spot.radius), (LightKind::Spot, 0.1));
    assert!(
        (spot.center - Vec3::new(0.0, 3.0, 0.0)).length() < 1e-5,
        "{spot:?}"
    );
    assert!((spot.direction - Vec3::NEG_Y).length() < 1e-5, "{spot:?}");
    assert!((spot.cone_inner_degrees - 0.2f32.to_degrees()).abs() < 1e-4);
    assert!((spot.cone_outer_degrees - 0.5f32.to_degrees()).abs() < 1e-4);
    let sun = lights[1];
    assert_eq!(
        (sun.kind, sun.angular_diameter_degrees),
        (LightKind::Sun, 2.0)
    );
    assert!((sun.direction - Vec3::NEG_Z).length() < 1e-5, "{sun:?}");
    let point = lights[2];
    assert_eq!((point.kind, point.radius), (LightKind::Sphere, 0.0));
    assert_eq!(
        load(path.to_str().unwrap()).unwrap().scene.light.kind,
        LightKind::Spot
    );
}
