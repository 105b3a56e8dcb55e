//! Stiff cases for alpha-tested casters (issue 40, item 4): the masked checkerboard quad, leaf
//! cards seen edge-on from the light's centre, and a mask whose cut-off makes single-texel
//! holes. The exact answers test alpha at every hit; a light-space pass that does not sees an
//! opaque quad, one from the light's centre sees no card at all.

use glam::{Mat4, Quat, Vec2, Vec3};
use softshadow_core::{Scene, StiffClass::ThinGeometry, TextureFilter};

use super::StiffCase;
use crate::builtin::{camera, down_light, light_width, Builder, BuiltinInfo, ParamInfo};
use crate::{engine, materials, textures};

/// The alpha-tested cases, in the suite's order.
pub(super) fn cases() -> Vec<StiffCase> {
    vec![
        StiffCase {
            class: ThinGeometry,
            info: BuiltinInfo {
                id: "stiff-masked-checker",
                description: "stiff (alpha test): a 1.2 x 1.2 quad at height 1 whose texture cuts a checkerboard of `cells` x `cells` holes, under a light_width light at height 3 (an opaque quad's shadow is wrong)",
                params: vec![
                    light_width(0.2),
                    ParamInfo::new("cells", 6.0, 1.0, 32.0, "checker cells per side"),
                ],
            },
        },
        StiffCase {
            class: ThinGeometry,
            info: BuiltinInfo {
                id: "stiff-leaves-edge-on",
                description: "stiff (alpha test): sixteen alpha-masked leaf cards standing vertical at height 1, edge-on to the light's centre; from the rest of a light_width light they cast thin shadows",
                params: vec![light_width(1.0)],
            },
        },
        StiffCase {
            class: ThinGeometry,
            info: BuiltinInfo {
                id: "stiff-texel-holes",
                description: "stiff (alpha test): a 1.2 x 1.2 quad at height 1 whose 48 x 48 mask (nearest filtering) holds alpha 0.45 in one texel of every `every` x `every`: the cut-off 0.5 makes single-texel holes 0.025 wide",
                params: vec![
                    light_width(1.0),
                    ParamInfo::new("every", 3.0, 2.0, 8.0, "one hole per every x every texels"),
                ],
            },
        },
    ]
}

/// Builds alpha-tested case `id`, `None` for an id that is not one.
pub(super) fn build(id: &str, v: &dyn Fn(&str) -> f32) -> Option<Scene> {
    let mut scene = match id {
        "stiff-masked-checker" => {
            materials::masked_checker(v("light_width"), v("cells").round() as u32, true)
        }
        "stiff-leaves-edge-on" => leaves_edge_on(v("light_width")),
        "stiff-texel-holes" => texel_holes(v("light_width"), v("every").round() as u32),
        _ => return None,
    };
    scene.name = id.into();
    Some(scene)
}

/// Sixteen 0.4 leaf cards (`textures::leaf_cluster`) on a 4 x 4 grid 0.5 apart at height 1,
/// each vertical and turned about y by its own angle, so every card contains the downward
/// light's axis direction: edge-on from the light's centre.
fn leaves_edge_on(light_width: f32) -> Scene {
    let mut b = Builder::new("stiff-leaves-edge-on");
    b.ground();
    let card = engine::card(0.4, 0.4, Vec2::ONE);
    let mut cards = softshadow_core::Mesh::default();
    for k in 0..16 {
        let (i, j) = ((k % 4) as f32 - 1.5, (k / 4) as f32 - 1.5);
        let yaw = k as f32 * 0.7;
        let place = Mat4::from_rotation_translation(
            Quat::from_rotation_y(yaw),
            Vec3::new(i * 0.5, 1.0, j * 0.5),
        );
        engine::append(&mut cards, &card, place);
    }
    let texture = b.texture(textures::leaf_cluster(64), "leaf cluster");
    let leaf = b.masked_material("leaf", Vec3::new(0.35, 0.6, 0.25), texture);
    let mesh = b.mesh(cards, "leaf cards");
    b.masked_caster(mesh, Mat4::IDENTITY, leaf);
    let mut scene = b.finish(
        down_light(Vec3::Y * 3.0, light_width),
        camera(Vec3::new(0.0, 3.2, 4.0), Vec3::new(0.0, 0.0, 0.4)),
    );
    // Casters only, as every stiff case's occluders.
    scene
        .instances
        .last_mut()
        .expect("the cards")
        .receives_shadow = false;
    scene
}

/// The masked checker's quad with [`textures::texel_holes`] (nearest filtering, so a hole is one
/// whole texel) instead of the checker.
fn texel_holes(light_width: f32, every: u32) -> Scene {
    let mut scene = materials::masked_checker(light_width, 1, true);
    let holes = textures::texel_holes(48, every);
    let texture = &mut scene.textures[0];
    texture.name = "single-texel holes".into();
    (texture.width, texture.height, texture.rgba8) = (holes.width, holes.height, holes.rgba8);
    texture.filter = TextureFilter::Nearest;
    scene
}
