//! Built-in procedural textures (TOML `texture = "checker"`, docs/SCENES.md) and the masked
//! checkerboard scene the alpha test is checked on (a quad whose texture cuts a checkerboard of
//! holes, over a ground).

use glam::{Mat4, Vec2, Vec3, Vec4};
use softshadow_core::{AlphaMode, Material, Mesh, Scene, Texture, TextureFilter, TextureWrap};

use crate::builtin::{camera, down_light, Builder};

/// A `cells` x `cells` checkerboard of `texels_per_cell`² texels per cell: the cell at (0, 0)
/// and every other one solid (`color`, alpha 255), the rest holes (alpha 0, colour black).
/// Nearest filtering, so a cell's edge is sharp and the alpha test cuts exactly along it.
pub fn checker_texture(cells: u32, texels_per_cell: u32, color: [u8; 3]) -> Texture {
    let cells = cells.max(1);
    let per = texels_per_cell.max(1);
    let side = cells * per;
    let mut rgba8 = Vec::with_capacity((side * side * 4) as usize);
    for y in 0..side {
        for x in 0..side {
            let solid = (x / per + y / per) % 2 == 0;
            if solid {
                rgba8.extend_from_slice(&[color[0], color[1], color[2], 255]);
            } else {
                rgba8.extend_from_slice(&[0, 0, 0, 0]);
            }
        }
    }
    Texture {
        name: format!("checker {cells}x{cells}"),
        width: side,
        height: side,
        rgba8,
        wrap: [TextureWrap::ClampToEdge; 2],
        filter: TextureFilter::Nearest,
    }
}

/// A horizontal `size` x `size` quad (2 triangles) at y = 0 with texcoords (0, 0) .. (1, 1)
/// across it.
pub fn textured_quad(size: f32) -> Mesh {
    let h = size * 0.5;
    Mesh {
        name: "textured quad".into(),
        positions: vec![
            Vec3::new(-h, 0.0, -h),
            Vec3::new(h, 0.0, -h),
            Vec3::new(h, 0.0, h),
            Vec3::new(-h, 0.0, h),
        ],
        normals: vec![Vec3::Y; 4],
        indices: vec![0, 2, 1, 0, 3, 2],
        texcoords: vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ],
    }
}

/// The masked checkerboard: a 1.2 x 1.2 quad 1 unit above the ground whose `cells` x `cells`
/// checker texture cuts every other cell away (alpha mask, cut-off 0.5), under a square light
/// `light_width` wide 3 units up. With `masked = false` the same quad is opaque (the answer the
/// alpha test must differ from).
pub fn masked_checker(light_width: f32, cells: u32, masked: bool) -> Scene {
    let mut b = Builder::new(if masked {
        "masked-checker"
    } else {
        "masked-checker-opaque"
    });
    b.ground();
    let quad = b.mesh(textured_quad(1.2), "checker quad");
    b.caster(
        quad,
        Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0)),
        false,
    );
    let mut scene = b.finish(
        down_light(Vec3::new(0.0, 3.0, 0.0), light_width),
        camera(Vec3::new(0.0, 3.2, 4.0), Vec3::new(0.0, 0.0, 0.4)),
    );
    if masked {
        scene
            .textures
            .push(checker_texture(cells, 8, [200, 120, 60]));
        scene.materials.push(Material {
            name: "checker".into(),
            base_color: Vec4::ONE,
            base_color_texture: Some(0),
            alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
            double_sided: true,
        });
        let last = scene.instances.len() - 1;
        scene.instances[last].material = Some(0);
    }
    scene
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_checker_alternates_solid_and_holes_and_the_scene_is_valid() {
        let t = checker_texture(4, 2, [255, 0, 0]);
        assert_eq!((t.width, t.height), (8, 8));
        assert_eq!(t.sample(Vec2::new(0.1, 0.1)).w, 1.0);
        assert_eq!(t.sample(Vec2::new(0.3, 0.1)).w, 0.0);
        assert_eq!(t.sample(Vec2::new(0.3, 0.3)).w, 1.0);
        let scene = masked_checker(0.4, 6, true);
        scene.validate().unwrap();
        assert!(scene.has_masked_casters());
        assert!(!masked_checker(0.4, 6, false).has_masked_casters());
    }
}
