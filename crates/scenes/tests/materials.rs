//! glTF materials and textures (issue 40): a textured, alpha-masked quad written in a temporary
//! folder with its image embedded (data URI, GLB buffer view) or beside it (PNG, JPEG), and the
//! broken cases, each one error naming the file and the texture.

mod common;

use common::{base64, write_gltf, GltfKind};
use serde_json::{json, Value};
use softshadow_core::{AlphaMode, TextureFilter, TextureWrap};
use softshadow_scenes::{load, SceneError};

/// A 4 x 4 RGBA checker: opaque red where (x + y) is even, transparent elsewhere.
fn checker_png() -> Vec<u8> {
    encode(image::ImageFormat::Png)
}

fn encode(format: image::ImageFormat) -> Vec<u8> {
    let img = image::RgbaImage::from_fn(4, 4, |x, y| {
        if (x + y) % 2 == 0 {
            image::Rgba([255, 0, 0, 255])
        } else {
            image::Rgba([0, 0, 255, 0])
        }
    });
    let mut bytes = std::io::Cursor::new(Vec::new());
    if format == image::ImageFormat::Jpeg {
        image::DynamicImage::ImageRgba8(img)
            .to_rgb8()
            .write_to(&mut bytes, format)
            .unwrap();
    } else {
        img.write_to(&mut bytes, format).unwrap();
    }
    bytes.into_inner()
}

fn f32s(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A unit quad with TEXCOORD_0 and one material (`material`), whose base colour texture is
/// image 0 (`image`, set by the caller), sampler nearest / clamp. Returns the JSON and the
/// geometry buffer; `extra` bytes (an image) are appended to the buffer as buffer view 3.
fn textured_quad(material: Value, image: Value, extra: &[u8]) -> (Value, Vec<u8>) {
    let positions = f32s(&[0., 0., 0., 0., 0., 1., 1., 0., 1., 1., 0., 0.]);
    let texcoords = f32s(&[0., 0., 0., 1., 1., 1., 1., 0.]);
    let indices: Vec<u8> = [0u16, 1, 2, 0, 2, 3]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let mut buffer = positions.clone();
    buffer.extend_from_slice(&texcoords);
    buffer.extend_from_slice(&indices);
    buffer.extend_from_slice(&[0, 0]);
    let image_offset = buffer.len();
    buffer.extend_from_slice(extra);
    let json = json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "translation": [0.0, 1.0, 0.0] }],
        "meshes": [{ "name": "leaf", "primitives": [{
            "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "indices": 2, "material": 0
        }] }],
        "materials": [material],
        "textures": [{ "source": 0, "sampler": 0 }],
        "samplers": [{ "magFilter": 9728, "wrapS": 33071, "wrapT": 33071 }],
        "images": [image],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 48 },
            { "buffer": 0, "byteOffset": 48, "byteLength": 32 },
            { "buffer": 0, "byteOffset": 80, "byteLength": 12 },
            { "buffer": 0, "byteOffset": image_offset, "byteLength": extra.len().max(1) }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0] },
            { "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2" },
            { "bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR" }
        ]
    });
    (json, buffer)
}

fn masked() -> Value {
    json!({
        "name": "leaf",
        "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "baseColorTexture": { "index": 0 } },
        "alphaMode": "MASK", "alphaCutoff": 0.4, "doubleSided": true
    })
}

fn check_masked_quad(loaded: &softshadow_scenes::Loaded) {
    let scene = &loaded.scene;
    assert_eq!(scene.materials.len(), 1);
    let m = &scene.materials[0];
    assert_eq!(m.alpha_mode, AlphaMode::Mask { cutoff: 0.4 });
    assert!(m.double_sided);
    let t = &scene.textures[m.base_color_texture.unwrap()];
    assert_eq!((t.width, t.height), (4, 4));
    assert_eq!(t.filter, TextureFilter::Nearest);
    assert_eq!(t.wrap, [TextureWrap::ClampToEdge; 2]);
    assert_eq!(&t.rgba8[..4], &[255, 0, 0, 255]);
    assert_eq!(t.rgba8[7], 0, "the second texel is a hole");
    assert_eq!(scene.instances[0].material, Some(0));
    assert_eq!(scene.meshes[0].texcoords.len(), 4);
    assert!(scene.has_masked_casters());
}

#[test]
fn an_embedded_png_loads_as_a_masked_material() {
    let dir = tempfile::tempdir().unwrap();
    let uri = format!("data:image/png;base64,{}", base64(&checker_png()));
    let (json, buffer) = textured_quad(masked(), json!({ "uri": uri }), &[]);
    let path = write_gltf(dir.path(), "embedded", GltfKind::Embedded, json, &buffer);
    check_masked_quad(&load(path.to_str().unwrap()).unwrap());
}

#[test]
fn a_png_in_the_glb_binary_chunk_loads() {
    let dir = tempfile::tempdir().unwrap();
    let png = checker_png();
    let image = json!({ "bufferView": 3, "mimeType": "image/png" });
    let (json, buffer) = textured_quad(masked(), image, &png);
    let path = write_gltf(dir.path(), "binary", GltfKind::Binary, json, &buffer);
    check_masked_quad(&load(path.to_str().unwrap()).unwrap());
}

#[test]
fn side_car_png_and_jpeg_load() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("leaf map.png"), checker_png()).unwrap();
    let (json, buffer) = textured_quad(masked(), json!({ "uri": "leaf%20map.png" }), &[]);
    let path = write_gltf(dir.path(), "sidecar", GltfKind::External, json, &buffer);
    check_masked_quad(&load(path.to_str().unwrap()).unwrap());

    std::fs::write(
        dir.path().join("leaf.jpg"),
        encode(image::ImageFormat::Jpeg),
    )
    .unwrap();
    let opaque = json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } });
    let (json, buffer) = textured_quad(opaque, json!({ "uri": "leaf.jpg" }), &[]);
    let path = write_gltf(dir.path(), "jpeg", GltfKind::External, json, &buffer);
    let loaded = load(path.to_str().unwrap()).unwrap();
    let t = &loaded.scene.textures[0];
    assert_eq!((t.width, t.height), (4, 4));
    assert!(
        t.rgba8[0] > 100,
        "JPEG's first texel is reddish: {:?}",
        &t.rgba8[..4]
    );
    assert!(!loaded.scene.has_masked_casters(), "an opaque material");
    assert!(loaded.scene.has_textured_instances());
}

#[test]
fn a_blended_material_is_cast_as_a_mask_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let uri = format!("data:image/png;base64,{}", base64(&checker_png()));
    let mut material = masked();
    material["alphaMode"] = json!("BLEND");
    let (json, buffer) = textured_quad(material, json!({ "uri": uri }), &[]);
    let path = write_gltf(dir.path(), "blend", GltfKind::Embedded, json, &buffer);
    let loaded = load(path.to_str().unwrap()).unwrap();
    assert_eq!(loaded.scene.materials[0].alpha_mode, AlphaMode::Blend);
    assert!(loaded.scene.has_masked_casters());
    assert!(
        loaded
            .warnings
            .iter()
            .any(|w| w.contains("alpha-blended") && w.contains("cut-off 0.5")),
        "{:?}",
        loaded.warnings
    );
}

/// The message of loading a quad whose image is `image` (and `extra` in the buffer).
fn texture_error(
    stem: &str,
    image: Value,
    extra: &[u8],
    side_car: Option<(&str, &[u8])>,
) -> String {
    let dir = tempfile::tempdir().unwrap();
    if let Some((name, bytes)) = side_car {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    let (json, buffer) = textured_quad(masked(), image, extra);
    let path = write_gltf(dir.path(), stem, GltfKind::External, json, &buffer);
    let error = load(path.to_str().unwrap()).unwrap_err();
    assert!(matches!(error, SceneError::GltfTexture { .. }), "{error:?}");
    let message = error.to_string();
    assert!(!message.contains('\n'), "one line: {message}");
    assert!(message.contains(stem), "names the file: {message}");
    assert!(
        message.contains("material `leaf`"),
        "names the material: {message}"
    );
    message
}

#[test]
fn missing_broken_and_unsupported_textures_are_one_clear_line_each() {
    let missing = texture_error("missing", json!({ "uri": "gone.png" }), &[], None);
    assert!(
        missing.contains("gone.png") && missing.contains("missing"),
        "{missing}"
    );

    let garbage: &[u8] = b"not a png at all";
    let broken = texture_error(
        "broken",
        json!({ "uri": "bad.png" }),
        &[],
        Some(("bad.png", garbage)),
    );
    assert!(broken.contains("cannot decode"), "{broken}");

    let truncated = &checker_png()[..20];
    let cut = texture_error(
        "cut",
        json!({ "uri": "cut.png" }),
        &[],
        Some(("cut.png", truncated)),
    );
    assert!(cut.contains("cannot decode"), "{cut}");

    let ktx = json!({ "bufferView": 3, "mimeType": "image/ktx2" });
    let unsupported = texture_error("ktx", ktx, b"\xabKTX 20\xbb", None);
    assert!(unsupported.contains("image/ktx2"), "{unsupported}");

    let bad_uri = json!({ "uri": "data:image/png;base64,@@@" });
    let not_base64 = texture_error("datauri", bad_uri, &[], None);
    assert!(not_base64.contains("base64"), "{not_base64}");
}

fn write_scene(dir: &std::path::Path, text: &str) -> String {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

const GROUND: &str = r#"
[light]
center = [0.0, 3.0, 0.0]
target = [0.0, 0.0, 0.0]
width = 0.3

[[object]]
name = "ground"
plane = { size = [6.0, 6.0] }
casts_shadow = false
"#;

#[test]
fn a_toml_object_gets_a_checker_mask_with_planar_texcoords() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "{GROUND}
[[object]]
name = \"grate\"
plane = {{ size = [1.0, 1.0] }}
translation = [0.0, 1.0, 0.0]
receives_shadow = false
[object.material]
texture = \"checker\"
checker = {{ cells = 4, texels_per_cell = 2, color = [255, 0, 0] }}
alpha_mode = \"mask\"
alpha_cutoff = 0.3
filter = \"nearest\"
double_sided = true
"
    );
    let loaded = load(&write_scene(dir.path(), &text)).unwrap();
    let scene = &loaded.scene;
    assert!(scene.has_masked_casters());
    assert_eq!(
        scene.instances[0].material, None,
        "the ground keeps its albedo"
    );
    let m = &scene.materials[scene.instances[1].material.unwrap()];
    assert_eq!(m.alpha_mode, AlphaMode::Mask { cutoff: 0.3 });
    let t = &scene.textures[m.base_color_texture.unwrap()];
    assert_eq!(
        (t.width, t.height, t.filter),
        (8, 8, TextureFilter::Nearest)
    );
    let mesh = &scene.meshes[scene.instances[1].mesh];
    assert_eq!(mesh.texcoords.len(), mesh.positions.len());
    let (lo, hi) = mesh.texcoords.iter().fold((1.0f32, 0.0f32), |(lo, hi), t| {
        (lo.min(t.min_element()), hi.max(t.max_element()))
    });
    assert_eq!((lo, hi), (0.0, 1.0), "texcoords span the plane once");
}

#[test]
fn a_toml_image_texture_loads_and_bad_materials_are_one_line_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("leaf.png"), checker_png()).unwrap();
    let object = |material: &str| {
        format!("{GROUND}\n[[object]]\nname = \"leaf\"\nbox = {{ size = [1.0, 0.1, 1.0] }}\n[object.material]\n{material}\n")
    };
    let loaded = load(&write_scene(
        dir.path(),
        &object("texture = \"leaf.png\"\ncolor = [1.0, 1.0, 1.0, 0.9]\nalpha_mode = \"blend\""),
    ))
    .unwrap();
    assert_eq!(loaded.scene.textures[0].width, 4);
    assert!(loaded
        .warnings
        .iter()
        .any(|w| w.contains("leaf") && w.contains("cut-off 0.5")));
    for (material, expected) in [
        ("texture = \"gone.png\"", "material.texture"),
        ("texture = \"scene.toml\"", "cannot be decoded"),
        (
            "alpha_mode = \"mask\"\nalpha_cutoff = 1.5",
            "material.alpha_cutoff",
        ),
        ("color = [2.0, 0.0, 0.0, 1.0]", "material.color"),
        (
            "texture = \"checker\"\nchecker = { cells = 0 }",
            "material.checker",
        ),
        (
            "alpha_mode = \"sometimes\"",
            "expected one of `opaque`, `mask`, `blend`",
        ),
    ] {
        let message = load(&write_scene(dir.path(), &object(material)))
            .unwrap_err()
            .to_string();
        assert!(!message.contains('\n'), "one line: {message}");
        assert!(message.contains(expected), "`{material}`: {message}");
    }
}
