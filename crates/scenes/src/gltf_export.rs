//! Writes a scene's geometry and materials as one binary glTF 2.0 file (`.glb`): every mesh with
//! positions, normals, texture coordinates and 32-bit indices, one node per instance with its
//! matrix, materials (base colour factor and texture, alpha mode and cut-off, double-sided) and
//! their textures as PNG images inside the file. The light, the camera and the shadow flags are
//! not written (glTF has no shadow flags; the light and camera belong to the scene file that
//! names the model).
//!
//! Used to take the procedural scenes to other tools and by the load benchmark
//! (`workbench export`, docs/BENCHMARKS.md "Loading"), which times [`crate::load`] on what this
//! writes.

use std::path::Path;

use glam::{Vec2, Vec3};
use serde_json::{json, Value};
use softshadow_core::{AlphaMode, Scene, Texture, TextureFilter, TextureWrap};

use crate::SceneError;

/// The binary chunk being built: views into it, their accessors.
#[derive(Default)]
struct Binary {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Binary {
    /// Appends `data` as a buffer view (4-byte aligned); returns its index.
    fn view(&mut self, data: &[u8], target: Option<u32>) -> usize {
        while self.bytes.len() % 4 != 0 {
            self.bytes.push(0);
        }
        let mut view =
            json!({ "buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len() });
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.bytes.extend_from_slice(data);
        self.views.push(view);
        self.views.len() - 1
    }

    /// An accessor of `count` `kind` elements of float components over a new view.
    fn floats(
        &mut self,
        values: &[f32],
        count: usize,
        kind: &str,
        bounds: Option<(Vec3, Vec3)>,
    ) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34962));
        let mut accessor =
            json!({ "bufferView": view, "componentType": 5126, "count": count, "type": kind });
        if let Some((min, max)) = bounds {
            accessor["min"] = json!(min.to_array());
            accessor["max"] = json!(max.to_array());
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    fn indices(&mut self, indices: &[u32]) -> usize {
        let bytes: Vec<u8> = indices.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34963));
        self.accessors.push(json!({ "bufferView": view, "componentType": 5125, "count": indices.len(), "type": "SCALAR" }));
        self.accessors.len() - 1
    }
}

/// Builtin scene `spec` (`id` or `id:key=value,...`) written as
/// `<temp>/softshadow-glb/<spec>.glb`, unless that file is already there; returns its path. The
/// scenes are deterministic, so a file once written is reused (delete the folder to rewrite).
pub fn builtin_as_glb(spec: &str) -> Result<std::path::PathBuf, SceneError> {
    let folder = std::env::temp_dir().join("softshadow-glb");
    let stem: String = spec
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect();
    let path = folder.join(format!("{stem}.glb"));
    if path.is_file() {
        return Ok(path);
    }
    let (id, params) = crate::builtin::parse_spec(spec)?;
    let scene = crate::builtin::build(&id, &params)?;
    std::fs::create_dir_all(&folder).map_err(|e| write_error(&folder, &e.to_string()))?;
    // Written to a temporary name and renamed, so a killed run leaves no half file to reuse.
    let partial = path.with_extension("glb.partial");
    write_glb(&scene, &partial)?;
    std::fs::rename(&partial, &path).map_err(|e| write_error(&path, &e.to_string()))?;
    Ok(path)
}

/// Writes `scene` to `path` as a `.glb`.
pub fn write_glb(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    let mut binary = Binary::default();
    let meshes = scene_meshes(scene, &mut binary);
    let nodes: Vec<Value> = scene
        .instances
        .iter()
        .map(|i| json!({ "mesh": mesh_index(scene, i), "matrix": i.transform.to_cols_array() }))
        .collect();
    let TextureArrays {
        images,
        textures,
        samplers,
    } = scene_textures(scene, &mut binary, path)?;
    let materials: Vec<Value> = scene.materials.iter().map(material_json).collect();
    let mut root = json!({
        "asset": { "version": "2.0", "generator": "softshadow-scenes gltf_export" },
        "scene": 0,
        "scenes": [{ "nodes": (0..nodes.len()).collect::<Vec<_>>() }],
        "nodes": nodes,
        "meshes": meshes,
        "bufferViews": binary.views,
        "accessors": binary.accessors,
        "buffers": [{ "byteLength": binary.bytes.len() }],
    });
    if !scene.materials.is_empty() {
        root["materials"] = json!(materials);
    }
    if !images.is_empty() {
        root["images"] = json!(images);
        root["textures"] = json!(textures);
        root["samplers"] = json!(samplers);
    }
    let bytes = glb_container(&root, binary.bytes);
    std::fs::write(path, bytes).map_err(|e| write_error(path, &e.to_string()))
}

fn write_error(path: &Path, reason: &str) -> SceneError {
    SceneError::Write {
        path: path.display().to_string(),
        message: format!("{reason}: choose a writable folder with room for the file"),
    }
}

/// One glTF mesh per scene mesh and material pair an instance uses: glTF puts the material on the
/// primitive, the scene on the instance. Instances name their mesh through [`mesh_index`].
fn scene_meshes(scene: &Scene, binary: &mut Binary) -> Vec<Value> {
    mesh_keys(scene)
        .into_iter()
        .map(|(mesh, material)| {
            let m = &scene.meshes[mesh];
            let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for p in &m.positions {
                min = min.min(*p);
                max = max.max(*p);
            }
            let flat = |v: &[Vec3]| v.iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>();
            let count = m.positions.len();
            let mut attributes = json!({
                "POSITION": binary.floats(&flat(&m.positions), count, "VEC3", Some((min, max))),
            });
            if m.normals.len() == count {
                attributes["NORMAL"] = json!(binary.floats(&flat(&m.normals), count, "VEC3", None));
            }
            if m.texcoords.len() == count {
                let uv: Vec<f32> = m.texcoords.iter().flat_map(|t: &Vec2| t.to_array()).collect();
                attributes["TEXCOORD_0"] = json!(binary.floats(&uv, count, "VEC2", None));
            }
            let mut primitive = json!({ "attributes": attributes, "indices": binary.indices(&m.indices), "mode": 4 });
            if let Some(material) = material {
                primitive["material"] = json!(material);
            }
            json!({ "name": m.name, "primitives": [primitive] })
        })
        .collect()
}

/// The (mesh, material) pairs the instances use, in first-use order.
fn mesh_keys(scene: &Scene) -> Vec<(usize, Option<usize>)> {
    let mut keys = Vec::new();
    for i in &scene.instances {
        let key = (i.mesh, i.material);
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    keys
}

fn mesh_index(scene: &Scene, instance: &softshadow_core::Instance) -> usize {
    let key = (instance.mesh, instance.material);
    mesh_keys(scene).iter().position(|k| *k == key).unwrap_or(0)
}

fn material_json(material: &softshadow_core::Material) -> Value {
    let mut pbr =
        json!({ "baseColorFactor": material.base_color.to_array(), "metallicFactor": 0.0 });
    if let Some(texture) = material.base_color_texture {
        pbr["baseColorTexture"] = json!({ "index": texture });
    }
    let mut value = json!({ "name": material.name, "pbrMetallicRoughness": pbr, "doubleSided": material.double_sided });
    match material.alpha_mode {
        AlphaMode::Opaque => {}
        AlphaMode::Mask { cutoff } => {
            value["alphaMode"] = json!("MASK");
            value["alphaCutoff"] = json!(cutoff);
        }
        AlphaMode::Blend => value["alphaMode"] = json!("BLEND"),
    }
    value
}

/// The glTF arrays `images`, `textures` and `samplers`.
#[derive(Default)]
struct TextureArrays {
    images: Vec<Value>,
    textures: Vec<Value>,
    samplers: Vec<Value>,
}

/// Images (PNG in the binary chunk), textures and one sampler per texture.
fn scene_textures(
    scene: &Scene,
    binary: &mut Binary,
    path: &Path,
) -> Result<TextureArrays, SceneError> {
    let TextureArrays {
        mut images,
        mut textures,
        mut samplers,
    } = TextureArrays::default();
    for (k, texture) in scene.textures.iter().enumerate() {
        let png = encode_png(texture).map_err(|e| write_error(path, &e))?;
        let view = binary.view(&png, None);
        images.push(json!({ "name": texture.name, "bufferView": view, "mimeType": "image/png" }));
        textures.push(json!({ "source": k, "sampler": k }));
        samplers.push(sampler_json(texture));
    }
    Ok(TextureArrays {
        images,
        textures,
        samplers,
    })
}

fn sampler_json(texture: &Texture) -> Value {
    let wrap = |w: TextureWrap| match w {
        TextureWrap::Repeat => 10497,
        TextureWrap::ClampToEdge => 33071,
        TextureWrap::MirroredRepeat => 33648,
    };
    let filter = match texture.filter {
        TextureFilter::Nearest => 9728,
        TextureFilter::Linear => 9729,
    };
    json!({ "magFilter": filter, "minFilter": filter, "wrapS": wrap(texture.wrap[0]), "wrapT": wrap(texture.wrap[1]) })
}

fn encode_png(texture: &Texture) -> Result<Vec<u8>, String> {
    use image::ImageEncoder as _;
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(
            &texture.rgba8,
            texture.width,
            texture.height,
            image::ExtendedColorType::Rgba8,
        )
        .map_err(|e| {
            format!(
                "texture `{}` could not be encoded as PNG ({e})",
                texture.name
            )
        })?;
    Ok(png)
}

/// The GLB container: a 12-byte header, the JSON chunk (space-padded) and the binary chunk
/// (zero-padded), glTF 2.0 section 4.4.
fn glb_container(root: &Value, mut bin: Vec<u8>) -> Vec<u8> {
    let mut json = serde_json::to_vec(root).expect("a JSON value always serialises");
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    for (chunk, kind) in [(&json, b"JSON"), (&bin, b"BIN\0")] {
        out.extend_from_slice(&(chunk.len() as u32).to_le_bytes());
        out.extend_from_slice(kind);
        out.extend_from_slice(chunk);
    }
    out
}
