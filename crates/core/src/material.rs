//! Materials and textures of a scene: a base colour (factor and texture, glTF 2.0 section
//! 3.9.2 "Metallic-Roughness Material", base colour only), an alpha mode with its cut-off
//! (section 3.9.4 "Alpha Coverage") and double-sidedness (section 3.9.5).
//!
//! An instance without a material ([`crate::Instance::material`] `None`) is drawn as before:
//! its flat `albedo`, opaque. Only the alpha test changes what casts a shadow; everything else a
//! material holds changes only the shaded image. Texels are sampled the same way on the GPU
//! (`softshadow::material`, WGSL) and on the CPU ([`Texture::sample`]): texcoord set 0, the
//! texture's wrap per axis, nearest or bilinear by its filter, no mipmaps, in f32, so the ray
//! cast and the rasterised passes see the same holes.

use glam::{Vec2, Vec4};

/// How a material's alpha is used (glTF `alphaMode`).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum AlphaMode {
    /// Alpha is ignored: the surface is solid.
    #[default]
    Opaque,
    /// A texel with alpha below `cutoff` is a hole: neither seen, nor receiver, nor caster.
    Mask {
        /// Alpha below which a texel is cut away, in [0, 1] (glTF's default is 0.5).
        cutoff: f32,
    },
    /// Blended in glTF. Shadows here have no partial coverage, so it is cast as
    /// `Mask { cutoff: 0.5 }` ([`AlphaMode::effective_cutoff`]) and the loaders warn that they do.
    Blend,
}

/// The cut-off a blended material is cast with ([`AlphaMode::Blend`]).
pub const BLEND_AS_MASK_CUTOFF: f32 = 0.5;

impl AlphaMode {
    /// The alpha below which a texel is a hole, or `None` for an opaque material.
    pub fn effective_cutoff(self) -> Option<f32> {
        match self {
            AlphaMode::Opaque => None,
            AlphaMode::Mask { cutoff } => Some(cutoff),
            AlphaMode::Blend => Some(BLEND_AS_MASK_CUTOFF),
        }
    }
}

/// A surface's material.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Material {
    /// Name (glTF material name or the TOML object's), used in messages.
    pub name: String,
    /// Linear RGBA factor; multiplied by the texture's decoded texel.
    pub base_color: Vec4,
    /// Index into [`crate::Scene::textures`] (sampled with texcoord set 0).
    pub base_color_texture: Option<usize>,
    /// Whether and how alpha cuts holes.
    pub alpha_mode: AlphaMode,
    /// Both faces are seen. The workbench draws and casts both faces of every triangle in any
    /// case (no pass culls), so this is kept for the loaders' round trip and the viewer's label.
    pub double_sided: bool,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: String::new(),
            base_color: Vec4::ONE,
            base_color_texture: None,
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
        }
    }
}

/// How texcoords outside [0, 1] wrap (glTF sampler `wrapS` / `wrapT`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum TextureWrap {
    /// The texture tiles (glTF's default).
    #[default]
    Repeat,
    /// Coordinates clamp to the edge texels.
    ClampToEdge,
    /// The texture tiles, every other copy mirrored.
    MirroredRepeat,
}

/// How a texel is read between texel centres (glTF sampler `magFilter`; no mipmaps are made).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum TextureFilter {
    /// The nearest texel.
    Nearest,
    /// Bilinear between the four nearest texel centres (glTF's usual choice).
    #[default]
    Linear,
}

/// An RGBA8 image, sRGB-encoded colour and linear alpha (glTF's base colour texture).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Texture {
    /// Name (file name or glTF image name), used in messages.
    pub name: String,
    /// Texels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width * height * 4` bytes, rows top to bottom (texcoord v = 0 is the first row).
    pub rgba8: Vec<u8>,
    /// Wrap along u (`wrap[0]`) and v (`wrap[1]`).
    pub wrap: [TextureWrap; 2],
    /// Filter.
    pub filter: TextureFilter,
}

impl Texture {
    /// The texel at integer coordinates, wrapped, as linear RGB (sRGB decoded) and alpha.
    pub fn texel(&self, x: i64, y: i64) -> Vec4 {
        let x = wrap_index(x, self.width, self.wrap[0]);
        let y = wrap_index(y, self.height, self.wrap[1]);
        let at = 4 * (y as usize * self.width as usize + x as usize);
        let Some(t) = self.rgba8.get(at..at + 4) else {
            return Vec4::ONE;
        };
        Vec4::new(
            srgb_to_linear(t[0]),
            srgb_to_linear(t[1]),
            srgb_to_linear(t[2]),
            t[3] as f32 / 255.0,
        )
    }

    /// The texture at texcoord `uv`, by its wrap and filter: what `softshadow::material`'s
    /// `sample_texture` computes on the GPU (the same f32 steps).
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        let size = Vec2::new(self.width as f32, self.height as f32);
        let p = uv * size;
        match self.filter {
            TextureFilter::Nearest => {
                let i = p.floor();
                self.texel(i.x as i64, i.y as i64)
            }
            TextureFilter::Linear => {
                let q = p - Vec2::splat(0.5);
                let i = q.floor();
                let f = q - i;
                let (x, y) = (i.x as i64, i.y as i64);
                let top = self.texel(x, y).lerp(self.texel(x + 1, y), f.x);
                let bottom = self.texel(x, y + 1).lerp(self.texel(x + 1, y + 1), f.x);
                top.lerp(bottom, f.y)
            }
        }
    }

    /// Bytes the texels take.
    pub fn byte_len(&self) -> usize {
        self.width as usize * self.height as usize * 4
    }
}

/// `i` wrapped into `0..n` by `mode`.
fn wrap_index(i: i64, n: u32, mode: TextureWrap) -> u32 {
    let n = n.max(1) as i64;
    let k = match mode {
        TextureWrap::Repeat => i.rem_euclid(n),
        TextureWrap::ClampToEdge => i.clamp(0, n - 1),
        TextureWrap::MirroredRepeat => {
            let m = i.rem_euclid(2 * n);
            if m < n {
                m
            } else {
                2 * n - 1 - m
            }
        }
    };
    k as u32
}

/// An sRGB-encoded byte as a linear value (IEC 61966-2-1's curve).
pub fn srgb_to_linear(byte: u8) -> f32 {
    let c = byte as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(filter: TextureFilter, wrap: TextureWrap) -> Texture {
        // 2 x 2: opaque white, transparent black / transparent black, opaque white.
        let w = [255, 255, 255, 255];
        let b = [0, 0, 0, 0];
        Texture {
            name: "checker".into(),
            width: 2,
            height: 2,
            rgba8: [w, b, b, w].concat(),
            wrap: [wrap; 2],
            filter,
        }
    }

    #[test]
    fn nearest_reads_the_texel_under_the_coordinate_and_wraps() {
        let t = checker(TextureFilter::Nearest, TextureWrap::Repeat);
        assert_eq!(t.sample(Vec2::new(0.25, 0.25)).w, 1.0);
        assert_eq!(t.sample(Vec2::new(0.75, 0.25)).w, 0.0);
        assert_eq!(t.sample(Vec2::new(1.25, 0.25)).w, 1.0, "repeat");
        assert_eq!(t.sample(Vec2::new(-0.25, 0.25)).w, 0.0, "repeat below 0");
        let c = checker(TextureFilter::Nearest, TextureWrap::ClampToEdge);
        assert_eq!(
            c.sample(Vec2::new(3.0, 0.25)).w,
            0.0,
            "clamped to the last column"
        );
        let m = checker(TextureFilter::Nearest, TextureWrap::MirroredRepeat);
        assert_eq!(m.sample(Vec2::new(1.25, 0.25)).w, 0.0, "mirrored copy");
    }

    #[test]
    fn linear_blends_between_texel_centres() {
        let t = checker(TextureFilter::Linear, TextureWrap::Repeat);
        assert_eq!(t.sample(Vec2::new(0.25, 0.25)).w, 1.0, "a texel centre");
        assert!((t.sample(Vec2::new(0.5, 0.25)).w - 0.5).abs() < 1e-6);
        assert!((t.sample(Vec2::new(0.5, 0.5)).w - 0.5).abs() < 1e-6);
    }

    #[test]
    fn srgb_decoding_matches_the_standard_at_its_ends_and_middle() {
        assert_eq!(srgb_to_linear(0), 0.0);
        assert_eq!(srgb_to_linear(255), 1.0);
        assert!((srgb_to_linear(188) - 0.5029).abs() < 1e-3);
    }

    #[test]
    fn blend_is_cast_as_mask_at_one_half() {
        assert_eq!(AlphaMode::Blend.effective_cutoff(), Some(0.5));
        assert_eq!(AlphaMode::Opaque.effective_cutoff(), None);
        assert_eq!(
            AlphaMode::Mask { cutoff: 0.3 }.effective_cutoff(),
            Some(0.3)
        );
    }
}
