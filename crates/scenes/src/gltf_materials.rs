//! glTF 2.0 materials (section 3.9): the base colour factor and texture (texcoord set 0, its
//! sampler's wrap and magnification filter), the alpha mode with its cut-off and double-sidedness.
//! Images are decoded with the `image` crate (PNG and JPEG) from the GLB binary chunk or a
//! buffer view, a `data:` URI, or a side-car file next to the model. Only images a used
//! material's base colour names are decoded. A missing, broken or unsupported image is one
//! error naming the file, the texture and the reason.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec4;
use softshadow_core::{AlphaMode, Material, Texture, TextureFilter, TextureWrap};

use crate::SceneError;

/// Materials and textures read from a glTF file.
#[derive(Clone, Debug, Default)]
pub struct GltfMaterials {
    /// One per glTF material some primitive uses.
    pub materials: Vec<Material>,
    /// One per (image, sampler) pair a used material's base colour names.
    pub textures: Vec<Texture>,
    /// glTF material index to index in `materials`.
    pub(crate) index_of: HashMap<usize, usize>,
}

impl GltfMaterials {
    /// The material a primitive with glTF material `gltf_index` gets.
    pub fn of(&self, gltf_index: Option<usize>) -> Option<usize> {
        gltf_index.and_then(|i| self.index_of.get(&i).copied())
    }
}

/// Where to read images from, and how the file is named in messages.
pub(crate) struct ImageSource<'a> {
    pub buffers: &'a [gltf::buffer::Data],
    /// The model's folder; `None` refuses side-car files.
    pub base: Option<&'a Path>,
    pub file: &'a str,
}

/// Reads every material a primitive of `document` uses, decoding the images their base colour
/// textures name; `warnings` gets one line per blended material (cast as a mask at 0.5) and per
/// texture on another texcoord set than 0 (ignored).
pub(crate) fn read_materials(
    document: &gltf::Document,
    source: &ImageSource<'_>,
    warnings: &mut Vec<String>,
) -> Result<GltfMaterials, SceneError> {
    let mut out = GltfMaterials::default();
    let mut texture_of: HashMap<(usize, Option<usize>), usize> = HashMap::new();
    let used = document
        .meshes()
        .flat_map(|m| m.primitives().collect::<Vec<_>>())
        .filter_map(|p| p.material().index());
    let mut used: Vec<usize> = used.collect();
    used.sort_unstable();
    used.dedup();
    for index in used {
        let Some(material) = document.materials().nth(index) else {
            continue;
        };
        let name = material
            .name()
            .map_or_else(|| format!("material{index}"), str::to_string);
        let pbr = material.pbr_metallic_roughness();
        let alpha_mode = match material.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask {
                cutoff: material.alpha_cutoff().unwrap_or(0.5),
            },
            gltf::material::AlphaMode::Blend => {
                warnings.push(format!(
                    "material `{name}` in {} is alpha-blended: its shadows are cast as an alpha mask with cut-off 0.5",
                    source.file
                ));
                AlphaMode::Blend
            }
        };
        let mut base_color_texture = None;
        if let Some(info) = pbr.base_color_texture() {
            if info.tex_coord() != 0 {
                warnings.push(format!(
                    "material `{name}` in {}: its base colour texture uses texcoord set {}; only set 0 is read, so the texture is ignored",
                    source.file,
                    info.tex_coord()
                ));
            } else {
                let texture = info.texture();
                let key = (texture.source().index(), texture.sampler().index());
                let slot = match texture_of.get(&key) {
                    Some(&slot) => slot,
                    None => {
                        let decoded = read_texture(&texture, source, &name)?;
                        out.textures.push(decoded);
                        texture_of.insert(key, out.textures.len() - 1);
                        out.textures.len() - 1
                    }
                };
                base_color_texture = Some(slot);
            }
        }
        out.index_of.insert(index, out.materials.len());
        out.materials.push(Material {
            name,
            base_color: Vec4::from(pbr.base_color_factor()),
            base_color_texture,
            alpha_mode,
            double_sided: material.double_sided(),
        });
    }
    Ok(out)
}

/// Decodes the image of `texture` with its sampler's wrap and filter.
fn read_texture(
    texture: &gltf::Texture<'_>,
    source: &ImageSource<'_>,
    material: &str,
) -> Result<Texture, SceneError> {
    let image = texture.source();
    let image_name = image
        .name()
        .map_or_else(|| format!("image{}", image.index()), str::to_string);
    let fail = |message: String| SceneError::GltfTexture {
        path: source.file.to_string(),
        texture: format!("`{image_name}` (base colour of material `{material}`)"),
        message: crate::error::one_line(&message),
    };
    let bytes = image_bytes(&image, source).map_err(&fail)?;
    let decoded = image::load_from_memory(&bytes).map_err(|e| {
        fail(format!(
            "cannot decode it ({e}); only PNG and JPEG are read"
        ))
    })?;
    let rgba = decoded.to_rgba8();
    let sampler = texture.sampler();
    let wrap = |mode: gltf::texture::WrappingMode| match mode {
        gltf::texture::WrappingMode::ClampToEdge => TextureWrap::ClampToEdge,
        gltf::texture::WrappingMode::MirroredRepeat => TextureWrap::MirroredRepeat,
        gltf::texture::WrappingMode::Repeat => TextureWrap::Repeat,
    };
    let filter = match sampler.mag_filter() {
        Some(gltf::texture::MagFilter::Nearest) => TextureFilter::Nearest,
        _ => TextureFilter::Linear,
    };
    Ok(Texture {
        name: image_name,
        width: rgba.width(),
        height: rgba.height(),
        rgba8: rgba.into_raw(),
        wrap: [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
        filter,
    })
}

/// The encoded bytes of `image`, or why they cannot be had.
fn image_bytes(image: &gltf::Image<'_>, source: &ImageSource<'_>) -> Result<Vec<u8>, String> {
    match image.source() {
        gltf::image::Source::View { view, mime_type } => {
            check_mime(Some(mime_type))?;
            let buffer = source
                .buffers
                .get(view.buffer().index())
                .ok_or("its buffer view names a buffer that is not there")?;
            let (start, length) = (view.offset(), view.length());
            buffer
                .0
                .get(start..start.saturating_add(length))
                .map(<[u8]>::to_vec)
                .ok_or_else(|| {
                    format!(
                        "its buffer view ({length} bytes at {start}) lies outside its buffer ({} bytes)",
                        buffer.0.len()
                    )
                })
        }
        gltf::image::Source::Uri { uri, mime_type } => {
            if let Some(data) = uri.strip_prefix("data:") {
                let (header, payload) = data.split_once(',').ok_or("its data URI has no comma")?;
                check_mime(
                    header
                        .split(';')
                        .next()
                        .filter(|m| !m.is_empty())
                        .or(mime_type),
                )?;
                if !header.ends_with(";base64") {
                    return Err("its data URI is not base64".into());
                }
                return decode_base64(payload);
            }
            let Some(base) = source.base else {
                return Err(format!(
                    "it is in another file (`{uri}`), which is not read here; embed it (save as .glb)"
                ));
            };
            let path = base.join(percent_decode(uri.strip_prefix("file://").unwrap_or(uri)));
            if !path.is_file() {
                return Err(format!(
                    "its file `{}` is missing; put it next to the model or embed it",
                    path.display()
                ));
            }
            crate::read_file(&path, "glTF image file").map_err(|e| e.to_string())
        }
    }
}

/// Refuses image types the decoder does not read (KTX2, WebP, ...).
fn check_mime(mime: Option<&str>) -> Result<(), String> {
    match mime {
        None | Some("image/png" | "image/jpeg") => Ok(()),
        Some(other) => Err(format!(
            "its type `{other}` is not read here (only image/png and image/jpeg): convert it to PNG or JPEG"
        )),
    }
}

/// `%xx` escapes of a URI path decoded (glTF URIs are percent-encoded, section 2.8).
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut k = 0;
    while k < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[k] == b'%' && k + 2 < bytes.len() {
            if let (Some(h), Some(l)) = (hex(bytes[k + 1]), hex(bytes[k + 2])) {
                out.push((h * 16 + l) as u8);
                k += 3;
                continue;
            }
        }
        out.push(bytes[k]);
        k += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Standard base64 (RFC 4648, with or without padding).
fn decode_base64(text: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let (mut acc, mut bits) = (0u32, 0u32);
    for c in text.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' | b'\n' | b'\r' | b' ' => continue,
            _ => return Err(format!("its data URI holds `{}`, not base64", c as char)),
        };
        acc = acc << 6 | v as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_and_percent_decoding() {
        assert_eq!(decode_base64("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(decode_base64("aGVsbG8").unwrap(), b"hello");
        assert!(decode_base64("a*b").is_err());
        assert_eq!(percent_decode("leaf%20map.png"), "leaf map.png");
        assert_eq!(percent_decode("100%"), "100%");
    }
}
