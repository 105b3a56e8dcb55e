//! Helpers shared by the integration tests: writing small glTF files of every kind.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

/// How a test glTF file stores its buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GltfKind {
    /// `.gltf` JSON plus an external `.bin` file.
    External,
    /// `.gltf` JSON with a base64 data URI buffer.
    Embedded,
    /// Binary `.glb` container.
    Binary,
}

fn f32s(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn u16s(values: &[u16]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn pad4(bytes: &mut Vec<u8>, fill: u8) {
    while bytes.len() % 4 != 0 {
        bytes.push(fill);
    }
}

/// Standard base64 with padding (tests only; avoids a dependency).
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
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

/// Writes `json` + `buffer` as a glTF file of `kind` named `stem.gltf` / `stem.glb` in `dir`.
pub fn write_gltf(
    dir: &Path,
    stem: &str,
    kind: GltfKind,
    mut json: Value,
    buffer: &[u8],
) -> PathBuf {
    let length = buffer.len();
    match kind {
        GltfKind::External => {
            let bin = format!("{stem}.bin");
            std::fs::write(dir.join(&bin), buffer).unwrap();
            json["buffers"] = json!([{ "byteLength": length, "uri": bin }]);
            let path = dir.join(format!("{stem}.gltf"));
            std::fs::write(&path, serde_json::to_vec_pretty(&json).unwrap()).unwrap();
            path
        }
        GltfKind::Embedded => {
            let uri = format!("data:application/octet-stream;base64,{}", base64(buffer));
            json["buffers"] = json!([{ "byteLength": length, "uri": uri }]);
            let path = dir.join(format!("{stem}.gltf"));
            std::fs::write(&path, serde_json::to_vec_pretty(&json).unwrap()).unwrap();
            path
        }
        GltfKind::Binary => {
            json["buffers"] = json!([{ "byteLength": length }]);
            let mut json_chunk = serde_json::to_vec(&json).unwrap();
            pad4(&mut json_chunk, b' ');
            let mut bin_chunk = buffer.to_vec();
            pad4(&mut bin_chunk, 0);
            let total = 12 + 8 + json_chunk.len() + 8 + bin_chunk.len();
            let mut glb = Vec::with_capacity(total);
            glb.extend_from_slice(b"glTF");
            glb.extend_from_slice(&2u32.to_le_bytes());
            glb.extend_from_slice(&(total as u32).to_le_bytes());
            glb.extend_from_slice(&(json_chunk.len() as u32).to_le_bytes());
            glb.extend_from_slice(b"JSON");
            glb.extend_from_slice(&json_chunk);
            glb.extend_from_slice(&(bin_chunk.len() as u32).to_le_bytes());
            glb.extend_from_slice(b"BIN\0");
            glb.extend_from_slice(&bin_chunk);
            let path = dir.join(format!("{stem}.glb"));
            std::fs::write(&path, glb).unwrap();
            path
        }
    }
}

/// A small test model:
/// * mesh 0 `quad`: 2 indexed (u16) triangles in the y = 0 plane, unit square [0,1]x[0,1];
/// * mesh 1 `tri`: primitive 0 is 1 non-indexed triangle; primitive 1 is a LINES primitive
///   (to be skipped with a warning);
/// * node 0 `root` (translation [1, 2, 3], scale 2) with child node 1 using `quad`;
/// * node 2 using `tri` with a matrix translation (0, 0, -5).
pub fn sample_model() -> (Value, Vec<u8>) {
    let quad_positions = f32s(&[0., 0., 0., 0., 0., 1., 1., 0., 1., 1., 0., 0.]);
    let mut quad_indices = u16s(&[0, 1, 2, 0, 2, 3]);
    pad4(&mut quad_indices, 0);
    let tri_positions = f32s(&[0., 0., 0., 1., 0., 0., 0., 1., 0.]);
    let mut buffer = quad_positions.clone();
    let idx_offset = buffer.len();
    buffer.extend_from_slice(&quad_indices);
    let tri_offset = buffer.len();
    buffer.extend_from_slice(&tri_positions);
    let json = json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0, 2] }],
        "nodes": [
            { "name": "root", "translation": [1.0, 2.0, 3.0], "scale": [2.0, 2.0, 2.0], "children": [1] },
            { "name": "quad-node", "mesh": 0 },
            { "name": "tri-node", "mesh": 1,
              "matrix": [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -5.0, 1.0] }
        ],
        "meshes": [
            { "name": "quad", "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1 }] },
            { "name": "tri", "primitives": [
                { "attributes": { "POSITION": 2 } },
                { "attributes": { "POSITION": 0 }, "mode": 1 }
            ] }
        ],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": quad_positions.len() },
            { "buffer": 0, "byteOffset": idx_offset, "byteLength": 12 },
            { "buffer": 0, "byteOffset": tri_offset, "byteLength": tri_positions.len() }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0] },
            { "bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR" },
            { "bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0] }
        ]
    });
    (json, buffer)
}

/// A model with one good triangle, one degenerate (repeated index), one with a NaN vertex and
/// one with an out-of-range index, under a single identity node.
pub fn broken_model() -> (Value, Vec<u8>) {
    let positions = f32s(&[0., 0., 0., 1., 0., 0., 0., 0., 1., f32::NAN, 0., 0.]);
    let mut buffer = positions.clone();
    let idx_offset = buffer.len();
    buffer.extend_from_slice(&u16s(&[0, 2, 1, 0, 0, 1, 0, 3, 1, 0, 9, 1]));
    let json = json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "name": "broken", "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1 }] }],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": positions.len() },
            { "buffer": 0, "byteOffset": idx_offset, "byteLength": 24 }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0] },
            { "bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR" }
        ]
    });
    (json, buffer)
}
