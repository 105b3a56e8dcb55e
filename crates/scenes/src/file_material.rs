//! A TOML scene file's per-object material (`[object.material]`, docs/SCENES.md): a base colour,
//! a texture (an image file next to the scene file, or the built-in procedural `checker`), the
//! alpha mode and cut-off, double-sidedness and the texture filter.

use std::path::Path;

use glam::{Vec2, Vec4};
use serde::Deserialize;
use softshadow_core::{AlphaMode, Material, Mesh, Scene, Texture, TextureFilter, TextureWrap};

/// `[object.material]`.
#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub struct MaterialDef {
    /// Linear RGBA base colour factor (default: the object's `albedo`, alpha 1).
    pub color: Option<[f32; 4]>,
    /// A PNG or JPEG file (relative to the scene file), or `checker` (the built-in procedural
    /// checkerboard, [`CheckerDef`]).
    pub texture: Option<String>,
    /// The checker's parameters (with `texture = "checker"`).
    pub checker: Option<CheckerDef>,
    /// `opaque` (default), `mask` or `blend` (cast as a mask at 0.5, with a warning).
    #[serde(default)]
    pub alpha_mode: AlphaModeDef,
    /// The mask's cut-off (default 0.5), in [0, 1].
    pub alpha_cutoff: Option<f32>,
    /// Both faces seen (default false; every pass draws both faces in any case).
    #[serde(default)]
    pub double_sided: bool,
    /// `linear` (default) or `nearest` texel filtering.
    #[serde(default)]
    pub filter: FilterDef,
    /// How often the texture repeats across the object (default 1): texcoords times this.
    pub texture_repeat: Option<f32>,
}

/// `alpha_mode = "opaque" | "mask" | "blend"`.
#[derive(Debug, Deserialize, Clone, Copy, Default, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum AlphaModeDef {
    /// Solid.
    #[default]
    Opaque,
    /// Texels below the cut-off are holes.
    Mask,
    /// Cast as a mask at 0.5.
    Blend,
}

/// `filter = "linear" | "nearest"`.
#[derive(Debug, Deserialize, Clone, Copy, Default, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum FilterDef {
    /// Bilinear.
    #[default]
    Linear,
    /// Nearest texel.
    Nearest,
}

/// `checker = { cells = 8, texels_per_cell = 8, color = [r, g, b] }`: solid cells of `color`
/// (sRGB bytes) alternating with holes (alpha 0).
#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub struct CheckerDef {
    /// Cells per side (default 8), 1 to 1024.
    #[serde(default = "eight")]
    pub cells: u32,
    /// Texels per cell side (default 8), 1 to 256.
    #[serde(default = "eight")]
    pub texels_per_cell: u32,
    /// The solid cells' colour, sRGB bytes (default light grey).
    #[serde(default = "grey")]
    pub color: [u8; 3],
}

fn eight() -> u32 {
    8
}

fn grey() -> [u8; 3] {
    [200, 200, 200]
}

/// Gives the instances `instances` of `scene` the material `def` (a new material, and a new
/// texture if it names one); meshes without texcoords get planar ones over their two largest
/// extents. `base` is the scene file's folder; `albedo` the object's. Returns warnings, or one
/// line saying what is wrong (the caller names the object).
pub(crate) fn apply(
    scene: &mut Scene,
    instances: std::ops::Range<usize>,
    def: &MaterialDef,
    albedo: [f32; 3],
    base: &Path,
) -> Result<Vec<String>, String> {
    let mut warnings = Vec::new();
    let alpha_mode = match def.alpha_mode {
        AlphaModeDef::Opaque => AlphaMode::Opaque,
        AlphaModeDef::Mask => AlphaMode::Mask {
            cutoff: def.alpha_cutoff.unwrap_or(0.5),
        },
        AlphaModeDef::Blend => {
            warnings.push(
                "alpha_mode = \"blend\": its shadows are cast as an alpha mask with cut-off 0.5"
                    .to_string(),
            );
            AlphaMode::Blend
        }
    };
    if let Some(cutoff) = def.alpha_cutoff {
        if !(0.0..=1.0).contains(&cutoff) {
            return Err(format!(
                "material.alpha_cutoff is {cutoff}: give a value in [0, 1] (0.5 is usual)"
            ));
        }
    }
    let color = def
        .color
        .map_or(Vec4::new(albedo[0], albedo[1], albedo[2], 1.0), Vec4::from);
    if !color.is_finite() || color.min_element() < 0.0 || color.max_element() > 1.0 {
        return Err(format!(
            "material.color is {:?}: give four numbers in [0, 1] (linear RGBA)",
            color.to_array()
        ));
    }
    let texture = match &def.texture {
        None => None,
        Some(name) => Some(read_texture(name, def, base)?),
    };
    if let Some(mut texture) = texture {
        texture.filter = match def.filter {
            FilterDef::Linear => TextureFilter::Linear,
            FilterDef::Nearest => TextureFilter::Nearest,
        };
        scene.textures.push(texture);
    }
    let base_color_texture = def.texture.as_ref().map(|_| scene.textures.len() - 1);
    let repeat = def.texture_repeat.unwrap_or(1.0);
    if !(repeat.is_finite() && repeat > 0.0) {
        return Err(format!(
            "material.texture_repeat is {repeat}: give a positive number (1 = once across the object)"
        ));
    }
    scene.materials.push(Material {
        name: "material".into(),
        base_color: color,
        base_color_texture,
        alpha_mode,
        double_sided: def.double_sided,
    });
    let material = scene.materials.len() - 1;
    for k in instances {
        let mesh = scene.instances[k].mesh;
        scene.instances[k].material = Some(material);
        if base_color_texture.is_some() && scene.meshes[mesh].texcoords.is_empty() {
            planar_texcoords(&mut scene.meshes[mesh], repeat);
        }
    }
    Ok(warnings)
}

/// Appends a glTF object's materials and textures to `scene` (texture indices shifted); returns
/// the index its first material got.
pub(crate) fn append_gltf(
    scene: &mut Scene,
    materials: crate::gltf_materials::GltfMaterials,
) -> usize {
    let (first_material, first_texture) = (scene.materials.len(), scene.textures.len());
    scene
        .materials
        .extend(materials.materials.into_iter().map(|mut m| {
            m.base_color_texture = m.base_color_texture.map(|t| first_texture + t);
            m
        }));
    scene.textures.extend(materials.textures);
    first_material
}

/// The texture `name` names: `checker`, or an image file relative to `base`.
fn read_texture(name: &str, def: &MaterialDef, base: &Path) -> Result<Texture, String> {
    if name == "checker" {
        let c = def.checker.clone().unwrap_or(CheckerDef {
            cells: 8,
            texels_per_cell: 8,
            color: grey(),
        });
        if !(1..=1024).contains(&c.cells) || !(1..=256).contains(&c.texels_per_cell) {
            return Err(format!(
                "material.checker has cells = {} and texels_per_cell = {}: give cells in 1..=1024 and texels_per_cell in 1..=256",
                c.cells, c.texels_per_cell
            ));
        }
        let mut t = crate::materials::checker_texture(c.cells, c.texels_per_cell, c.color);
        t.wrap = [TextureWrap::Repeat; 2];
        return Ok(t);
    }
    if def.checker.is_some() {
        return Err(format!(
            "material.checker is given but texture = \"{name}\": use texture = \"checker\" or drop the checker table"
        ));
    }
    let path = base.join(name);
    if !path.is_file() {
        return Err(format!(
            "material.texture `{}` is missing: give a PNG or JPEG file relative to the scene file, or \"checker\"",
            path.display()
        ));
    }
    let bytes = crate::read_file(&path, "texture file").map_err(|e| e.to_string())?;
    let image = image::load_from_memory(&bytes).map_err(|e| {
        format!(
            "material.texture `{}` cannot be decoded ({}): give a PNG or JPEG file",
            path.display(),
            crate::error::one_line(&e.to_string())
        )
    })?;
    let rgba = image.to_rgba8();
    Ok(Texture {
        name: name.to_string(),
        width: rgba.width(),
        height: rgba.height(),
        rgba8: rgba.into_raw(),
        wrap: [TextureWrap::Repeat; 2],
        filter: TextureFilter::Linear,
    })
}

/// Texcoords projected along the mesh's smallest extent: (0, 0) to (`repeat`, `repeat`) over
/// its bounds on the other two axes (a plane or quad gets its texture once across it).
fn planar_texcoords(mesh: &mut Mesh, repeat: f32) {
    let (mut lo, mut hi) = (glam::Vec3::splat(f32::MAX), glam::Vec3::splat(f32::MIN));
    for p in &mesh.positions {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let size = (hi - lo).max(glam::Vec3::splat(1e-12));
    let flat = if size.x <= size.y && size.x <= size.z {
        0
    } else if size.y <= size.z {
        1
    } else {
        2
    };
    let (u, v) = match flat {
        0 => (2, 1),
        1 => (0, 2),
        _ => (0, 1),
    };
    mesh.texcoords = mesh
        .positions
        .iter()
        .map(|p| {
            let q = (*p - lo) / size;
            Vec2::new(q[u], q[v]) * repeat
        })
        .collect();
}
