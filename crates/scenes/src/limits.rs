//! Limits that keep a hostile or broken file from exhausting memory or time. Every loader checks
//! them before it allocates, and a file over a limit gets [`crate::SceneError::Limit`], which
//! names the limit and its value.
//!
//! They sit far above every scene of this workbench (the largest builtin scene has 8 million
//! triangles, `blob` objects at most 8 million each).

/// Largest file a loader reads (scene file, glTF, GLB or an external glTF buffer): 1 GiB.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Most triangles a scene may have, counted per instance (what is uploaded to the GPU, about
/// 14 bytes per triangle: 32 million is about 450 MB).
pub const MAX_TRIANGLES: usize = 32_000_000;

/// Most vertices one glTF primitive may have (checked on the accessor before it is read).
pub const MAX_VERTICES: usize = 32_000_000;

/// Most mesh instances a scene may have (glTF node uses and `[[object]]` tables).
pub const MAX_INSTANCES: usize = 100_000;

/// Deepest glTF node hierarchy (deeper is treated as a cycle).
pub const MAX_NODE_DEPTH: usize = 256;

/// Most glTF nodes visited while walking the node graph: a graph whose nodes reuse their
/// children names 2^depth paths in a few hundred bytes, with or without meshes.
pub const MAX_NODE_VISITS: usize = 1_000_000;

/// Every limit on a file built to cross it, and the regression inputs of the fuzz targets
/// (docs/STABILITY.md): each must give its one-line error, fast, without exhausting memory.
#[cfg(test)]
mod tests {
    use std::path::Path;

    use serde_json::json;

    use crate::SceneError;

    const TRIANGLE: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];

    /// A glTF document with one triangle (embedded), `nodes`, and the first node in the scene.
    fn gltf(nodes: serde_json::Value, accessor_count: u64) -> Vec<u8> {
        let bytes: Vec<u8> = TRIANGLE.iter().flat_map(|f| f.to_le_bytes()).collect();
        let uri = format!("data:application/octet-stream;base64,{}", base64(&bytes));
        json!({
            "asset": {"version": "2.0"},
            "buffers": [{"byteLength": bytes.len(), "uri": uri}],
            "bufferViews": [{"buffer": 0, "byteLength": bytes.len()}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": accessor_count,
                           "type": "VEC3", "min": [0, 0, 0], "max": [1, 0, 1]}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "nodes": nodes,
            "scenes": [{"nodes": [0]}],
            "scene": 0,
        })
        .to_string()
        .into_bytes()
    }

    fn base64(bytes: &[u8]) -> String {
        const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut out = String::new();
        for chunk in bytes.chunks(3) {
            let n = chunk
                .iter()
                .enumerate()
                .fold(0u32, |n, (k, &b)| n | (b as u32) << (16 - 8 * k));
            for k in 0..4 {
                if k <= chunk.len() {
                    out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
                } else {
                    out.push('=');
                }
            }
        }
        out
    }

    fn load_gltf(bytes: &[u8]) -> Result<crate::Loaded, SceneError> {
        crate::load_gltf_bytes(bytes, Path::new("limits.gltf"), false)
    }

    #[test]
    fn the_test_document_loads() {
        let loaded = load_gltf(&gltf(json!([{"mesh": 0}]), 3)).unwrap();
        assert_eq!(
            loaded.scene.triangle_count(),
            1 + 2,
            "the triangle and the ground"
        );
    }

    #[test]
    fn nodes_that_reuse_their_children_stop_at_the_visit_limit() {
        // 40 levels, each node using both nodes of the next: 2^40 paths in a few kB.
        let nodes: Vec<_> = (0..40)
            .flat_map(|level| {
                let children = if level < 39 {
                    json!([2 * level + 2, 2 * level + 3])
                } else {
                    json!([])
                };
                [json!({"children": children}), json!({"children": children})]
            })
            .collect();
        let message = load_gltf(&gltf(json!(nodes), 3)).unwrap_err().to_string();
        assert!(message.contains("limits::MAX_NODE_VISITS"), "{message}");
        assert_eq!(message.lines().count(), 1, "{message}");
    }

    #[test]
    fn nodes_that_reuse_a_mesh_stop_at_the_instance_limit() {
        let nodes: Vec<_> = (0..40)
            .flat_map(|level| {
                let children = if level < 39 {
                    json!([2 * level + 2, 2 * level + 3])
                } else {
                    json!([])
                };
                [
                    json!({"mesh": 0, "children": children}),
                    json!({"mesh": 0, "children": children}),
                ]
            })
            .collect();
        let message = load_gltf(&gltf(json!(nodes), 3)).unwrap_err().to_string();
        assert!(message.contains("limits::MAX_INSTANCES"), "{message}");
    }

    /// Fuzz finding (`gltf` target, crash-31b61e5f, minimised): a GLB header whose length is
    /// below its own 12 bytes panicked inside the gltf crate.
    #[test]
    fn a_glb_header_shorter_than_itself_is_malformed_not_a_panic() {
        let mut bytes = b"glTF\x02\x00\x00\x00\x00\x00\x00\x00".to_vec();
        bytes.resize(434, 0);
        let message = load_gltf(&bytes).unwrap_err().to_string();
        assert!(
            message.contains("less than the 12-byte header"),
            "{message}"
        );
    }

    /// Fuzz finding (`gltf` target, crash-0cb480e6 after 5,704 executions): a primitive whose
    /// POSITION attribute names an accessor past the end panicked inside gltf-json's validation
    /// (`mesh.rs:151`, index out of bounds).
    #[test]
    fn a_position_accessor_past_the_end_is_malformed_not_a_panic() {
        let mut doc: serde_json::Value =
            serde_json::from_slice(&gltf(json!([{"mesh": 0}]), 3)).unwrap();
        doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(5);
        let message = load_gltf(doc.to_string().as_bytes())
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("POSITION attribute names accessor 5, but the file has 1 accessors"),
            "{message}"
        );
        assert_eq!(message.lines().count(), 1, "{message}");
        // The fuzzer's input itself, as found.
        let found = include_bytes!("../tests/data/fuzz-gltf-position-accessor-past-the-end.gltf");
        assert!(load_gltf(found).is_err());
    }

    /// Fuzz finding (`gltf` target, crash-98769d54 after 311,165 executions): a VEC2 POSITION
    /// accessor tripped gltf's debug assertion that an element is 12 bytes. Every accessor the
    /// loader reads is now checked first, and the primitive is skipped with a warning.
    #[test]
    fn accessors_of_the_wrong_type_or_shape_are_skipped_not_a_panic() {
        let found = include_bytes!("../tests/data/fuzz-gltf-vec2-positions.glb");
        assert!(load_gltf(found).is_err());
        // A second, good primitive (own accessor and view) keeps the file loadable, so the
        // skipped one's warning is what the test reads.
        let mut base: serde_json::Value =
            serde_json::from_slice(&gltf(json!([{"mesh": 0}]), 3)).unwrap();
        let view = base["bufferViews"][0].clone();
        base["bufferViews"].as_array_mut().unwrap().push(view);
        let mut accessor = base["accessors"][0].clone();
        accessor["bufferView"] = json!(1);
        base["accessors"].as_array_mut().unwrap().push(accessor);
        let primitive = json!({"attributes": {"POSITION": 1}});
        base["meshes"][0]["primitives"]
            .as_array_mut()
            .unwrap()
            .push(primitive);
        let cases = [
            (
                "accessors",
                "type",
                json!("VEC2"),
                "POSITION accessor holds Vec2 of F32",
            ),
            (
                "accessors",
                "componentType",
                json!(5123),
                "POSITION accessor holds Vec3 of U16",
            ),
            (
                "accessors",
                "count",
                json!(0),
                "POSITION accessor has no elements",
            ),
            (
                "bufferViews",
                "byteStride",
                json!(4),
                "byte stride (4) is smaller than one element (12 bytes)",
            ),
        ];
        for (array, key, value, expected) in cases {
            let mut doc = base.clone();
            doc[array][0][key] = value;
            let result = load_gltf(doc.to_string().as_bytes());
            let message = match result {
                Err(e) => e.to_string(),
                Ok(loaded) => loaded.warnings.join("\n"),
            };
            assert!(message.contains(expected), "{array}/0/{key}: {message}");
        }
        // Indices that are floats, or vectors.
        for (accessor, expected) in [
            (
                json!({"bufferView": 0, "componentType": 5126, "count": 3, "type": "SCALAR"}),
                "index accessor holds Scalar of F32",
            ),
            (
                json!({"bufferView": 0, "componentType": 5125, "count": 3, "type": "VEC2"}),
                "index accessor holds Vec2 of U32",
            ),
        ] {
            let mut doc = base.clone();
            doc["accessors"].as_array_mut().unwrap().push(accessor);
            doc["meshes"][0]["primitives"][0]["indices"] = json!(2);
            let message = match load_gltf(doc.to_string().as_bytes()) {
                Err(e) => e.to_string(),
                Ok(loaded) => loaded.warnings.join("\n"),
            };
            assert!(message.contains(expected), "{message}");
        }
    }

    #[test]
    fn a_cyclic_node_graph_stops_at_the_depth_limit() {
        let nodes = json!([{"mesh": 0, "children": [1]}, {"children": [0]}]);
        let message = load_gltf(&gltf(nodes, 3)).unwrap_err().to_string();
        assert!(message.contains("limits::MAX_NODE_DEPTH"), "{message}");
    }

    #[test]
    fn an_absurd_accessor_count_is_refused_before_reading() {
        let message = load_gltf(&gltf(json!([{"mesh": 0}]), 4_000_000_000))
            .unwrap_err()
            .to_string();
        assert!(message.contains("limits.gltf"), "{message}");
        assert_eq!(message.lines().count(), 1, "{message}");
    }

    #[test]
    fn a_buffer_that_is_a_device_is_refused() {
        let dir = std::env::temp_dir();
        let mut doc: serde_json::Value =
            serde_json::from_slice(&gltf(json!([{"mesh": 0}]), 3)).unwrap();
        doc["buffers"][0]["uri"] = json!("file:///dev/zero");
        let bytes = doc.to_string().into_bytes();
        let message = crate::parse_gltf(&bytes, Some(&dir), Path::new("zero.gltf"))
            .unwrap_err()
            .to_string();
        assert!(message.contains("not a regular file"), "{message}");
    }

    #[test]
    fn a_scene_file_over_the_triangle_limit_is_refused_before_building() {
        let text = "[[object]]\nsphere = { radius = 1, segments = 4096 }\n".repeat(3);
        let message = crate::load_scene_bytes(text.as_bytes(), Path::new("big.toml"))
            .unwrap_err()
            .to_string();
        assert!(message.contains("limits::MAX_TRIANGLES"), "{message}");
        assert!(message.contains("big.toml"), "{message}");
    }

    #[test]
    fn a_file_that_is_a_device_is_refused() {
        let message = crate::load_scene_file("/dev/zero.toml")
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(message.contains("not found"), "{message}");
        let message = crate::check_file(Path::new("/dev/zero"), "scene file")
            .unwrap_err()
            .to_string();
        assert!(message.contains("not a regular file"), "{message}");
    }
}
