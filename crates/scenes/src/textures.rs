//! Procedural textures for the built-in scenes: deterministic RGBA8 images (sRGB colour, alpha as a
//! mask) made from closed-form shapes, so no image file is committed.
//!
//! Every mask but [`texel_holes`] is binary (alpha 0 or 255): the scenes test alpha-tested
//! casters, and a binary mask makes the cut-off irrelevant to where the holes are; in
//! `texel_holes` only the cut-off makes the holes.

use glam::Vec2;

/// An RGBA8 image, rows top to bottom, sRGB-encoded colour and linear alpha.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width * height * 4` bytes.
    pub rgba8: Vec<u8>,
}

impl Image {
    /// Fills a `size` x `size` image from `texel(uv)`, sampled at texel centres (uv in [0, 1]²,
    /// v down), returning `[r, g, b, a]` in [0, 1].
    fn from_fn(size: u32, texel: impl Fn(Vec2) -> [f32; 4]) -> Self {
        let mut rgba8 = Vec::with_capacity((size * size * 4) as usize);
        for y in 0..size {
            for x in 0..size {
                let uv = (Vec2::new(x as f32, y as f32) + 0.5) / size as f32;
                rgba8.extend(texel(uv).map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8));
            }
        }
        Self {
            width: size,
            height: size,
            rgba8,
        }
    }

    /// Fraction of texels with alpha below one half (the holes of a mask).
    pub fn hole_fraction(&self) -> f64 {
        let texels = self.rgba8.len() / 4;
        let holes = self.rgba8.chunks_exact(4).filter(|t| t[3] < 128).count();
        holes as f64 / texels.max(1) as f64
    }
}

/// Alpha 1 inside, 0 outside.
fn mask(inside: bool) -> f32 {
    if inside {
        1.0
    } else {
        0.0
    }
}

/// A card of three leaves on one stalk, the kind foliage renderers draw as alpha-tested quads.
/// Each leaf is a pointed ellipse (lens) with a lighter midrib; the rest of the card is a hole.
pub fn leaf_cluster(size: u32) -> Image {
    // (base, tip) of each leaf in card uv; the stalk is the bottom centre.
    let leaves = [
        (Vec2::new(0.5, 0.95), Vec2::new(0.5, 0.08)),
        (Vec2::new(0.5, 0.8), Vec2::new(0.1, 0.35)),
        (Vec2::new(0.5, 0.8), Vec2::new(0.9, 0.35)),
    ];
    Image::from_fn(size, |uv| {
        for (base, tip) in leaves {
            let axis = tip - base;
            let length = axis.length();
            let t = (uv - base).dot(axis) / (length * length);
            let across = (uv - base).perp_dot(axis).abs() / length;
            // Lens profile: half-width 0.28 x length x sin(pi t).
            let half_width = 0.28 * length * (std::f32::consts::PI * t).sin();
            if (0.0..=1.0).contains(&t) && across <= half_width {
                let rib = across < 0.012;
                let green = if rib { 0.55 } else { 0.35 + 0.1 * t };
                return [0.12, green, 0.08, 1.0];
            }
        }
        [0.1, 0.3, 0.08, 0.0]
    })
}

/// One cell of a chain-link fence: two wires along the cell's diagonals, `wire` their width as a
/// fraction of the cell. Repeat it over a quad (wrap mode repeat) for a fence of many cells.
pub fn chain_link(size: u32, wire: f32) -> Image {
    Image::from_fn(size, |uv| {
        // Distance to the diagonals x = y and x = 1 - y, in cell units.
        let d = (uv.x - uv.y).abs().min((uv.x + uv.y - 1.0).abs()) / std::f32::consts::SQRT_2;
        [0.55, 0.57, 0.6, mask(d <= wire * 0.5)]
    })
}

/// A hanging cloth with a lace band: opaque striped fabric with rows of round holes and a fringe at
/// the bottom (v near 1).
pub fn lace_cloth(size: u32) -> Image {
    Image::from_fn(size, |uv| {
        let stripe = ((uv.x * 6.0).floor() as i32) % 2 == 0;
        let colour = if stripe {
            [0.55, 0.12, 0.1]
        } else {
            [0.75, 0.6, 0.3]
        };
        let fringe = uv.y > 0.9 && (uv.x * 40.0).fract() > 0.5;
        let lace_row = uv.y > 0.55 && uv.y < 0.85;
        let cell = (uv * Vec2::new(10.0, 10.0)).fract() - 0.5;
        let hole = lace_row && cell.length() < 0.3;
        [colour[0], colour[1], colour[2], mask(!(fringe || hole))]
    })
}

/// A checkerboard of `cells` x `cells` squares: the even ones opaque, the odd ones holes.
pub fn checker_mask(size: u32, cells: u32) -> Image {
    Image::from_fn(size, |uv| {
        let cell = (uv * cells as f32).floor();
        let even = (cell.x as i32 + cell.y as i32) % 2 == 0;
        [0.8, 0.8, 0.8, mask(even)]
    })
}

/// Alpha 1 everywhere but one texel of every `every` x `every` (the centre of each block), which
/// holds alpha 0.45: opaque without an alpha test, single-texel holes under glTF's default
/// cut-off of 0.5 (with nearest filtering).
pub fn texel_holes(size: u32, every: u32) -> Image {
    let every = every.max(1);
    Image::from_fn(size, |uv| {
        let texel = (uv * size as f32).floor();
        let (x, y) = (texel.x as u32 % every, texel.y as u32 % every);
        let hole = x == every / 2 && y == every / 2;
        [0.7, 0.7, 0.72, if hole { 0.45 } else { 1.0 }]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masks_have_holes_and_substance() {
        for (name, image, low, high) in [
            ("leaf", leaf_cluster(64), 0.4, 0.9),
            ("chain link", chain_link(64, 0.1), 0.6, 0.9),
            ("lace", lace_cloth(128), 0.05, 0.4),
            ("checker", checker_mask(64, 8), 0.49, 0.51),
            // One texel in nine: 5 x 5 blocks of 3 in 16 texels (the last block cut short).
            (
                "texel holes",
                texel_holes(16, 3),
                25.0 / 256.0,
                25.0 / 256.0,
            ),
        ] {
            let holes = image.hole_fraction();
            assert!(
                (low..=high).contains(&holes),
                "{name}: hole fraction {holes} outside [{low}, {high}]"
            );
            assert_eq!(image.rgba8.len(), (image.width * image.height * 4) as usize);
        }
    }

    #[test]
    fn images_are_deterministic() {
        assert_eq!(leaf_cluster(32), leaf_cluster(32));
        assert_eq!(lace_cloth(32), lace_cloth(32));
    }
}
