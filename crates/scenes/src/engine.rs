//! Scenes like the ones engines light (issue 40): a tree of alpha-tested leaf cards, a chain-link
//! fence in front of a wall, and an atrium in the manner of Sponza with hanging lace cloths.
//!
//! Everything is procedural and deterministic (the textures come from [`crate::textures`]); the
//! masked casters are cards of two one-sided faces, as [`primitives::two_sided_quad`] is, so no
//! pass has to turn off back-face culling for them.

use glam::{Mat4, Quat, Vec2, Vec3};
use softshadow_core::{AreaLight, Mesh, Scene};

use crate::builtin::{camera, light_width, Builder, BuiltinInfo, ParamInfo};
use crate::primitives::{self, SplitMix64};
use crate::textures;

/// The engine-like scenes' ids, descriptions and parameters.
pub fn infos() -> Vec<BuiltinInfo> {
    vec![
        BuiltinInfo {
            id: "foliage",
            description: "a tree: trunk and branches plus alpha-masked leaf cards (three leaves each, procedural texture) over a ground; rectangle light above one side",
            params: vec![
                light_width(1.0),
                ParamInfo::new("leaves", 2000.0, 50.0, 20000.0, "number of leaf cards"),
                ParamInfo::new("leaf_size", 0.22, 0.02, 1.0, "side of a leaf card, world units")
                    .min_exclusive(),
            ],
        },
        BuiltinInfo {
            id: "fence",
            description: "a chain-link fence (one alpha-masked quad, the high-frequency caster) between two posts in front of a wall; oblique rectangle light",
            params: vec![
                light_width(0.8),
                ParamInfo::new("cells", 32.0, 2.0, 256.0, "chain-link cells across the fence's 4-unit width"),
                ParamInfo::new("wire", 0.12, 0.02, 0.8, "wire width as a fraction of a cell"),
            ],
        },
        BuiltinInfo {
            id: "atrium",
            description: "a courtyard in the manner of Sponza: two storeys of arches on columns around it, galleries, alpha-masked lace cloths hanging from the upper arcade, light through the roof opening",
            params: vec![
                light_width(2.0),
                ParamInfo::new("bays", 3.0, 2.0, 8.0, "arches per side and storey"),
            ],
        },
    ]
}

/// Builds engine-like scene `id` from its parameter lookup, or `None` when `id` is not one.
pub(crate) fn build(id: &str, value: &dyn Fn(&str) -> f64) -> Option<Scene> {
    let width = value("light_width") as f32;
    Some(match id {
        "foliage" => foliage(width, value("leaves") as u32, value("leaf_size") as f32),
        "fence" => fence(width, value("cells") as f32, value("wire") as f32),
        "atrium" => atrium(width, value("bays") as u32),
        _ => return None,
    })
}

/// A `width` x `height` card in the plane z = 0, centred on the origin, x across and y up, seen
/// from both sides (two one-sided faces). Texture coordinates run from (0, 0) at the top left to
/// `repeat` at the bottom right (v down, as glTF's).
pub fn card(width: f32, height: f32, repeat: Vec2) -> Mesh {
    let mut mesh = Mesh {
        name: "card".into(),
        ..Mesh::default()
    };
    let (hx, hy) = (width * 0.5, height * 0.5);
    let corners = [
        Vec3::new(-hx, -hy, 0.0),
        Vec3::new(hx, -hy, 0.0),
        Vec3::new(hx, hy, 0.0),
        Vec3::new(-hx, hy, 0.0),
    ];
    let uvs = [
        Vec2::new(0.0, repeat.y),
        Vec2::new(repeat.x, repeat.y),
        Vec2::new(repeat.x, 0.0),
        Vec2::ZERO,
    ];
    for (normal, order) in [(Vec3::Z, [0, 1, 2, 3]), (Vec3::NEG_Z, [1, 0, 3, 2])] {
        let base = mesh.positions.len() as u32;
        for k in order {
            mesh.positions.push(corners[k]);
            mesh.normals.push(normal);
            mesh.texcoords.push(uvs[k]);
        }
        mesh.indices
            .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    mesh
}

/// Appends `part` placed by `transform` to `mesh` (positions, normals, texture coordinates).
pub(crate) fn append(mesh: &mut Mesh, part: &Mesh, transform: Mat4) {
    let base = mesh.positions.len() as u32;
    let normal_matrix = transform.inverse().transpose();
    mesh.positions.extend(
        part.positions
            .iter()
            .map(|&p| transform.transform_point3(p)),
    );
    mesh.normals.extend(
        part.normals
            .iter()
            .map(|&n| normal_matrix.transform_vector3(n).normalize_or(Vec3::Y)),
    );
    mesh.texcoords.extend_from_slice(&part.texcoords);
    mesh.indices.extend(part.indices.iter().map(|&i| base + i));
}

/// The transform that places a unit-height primitive centred on the origin along y (a
/// [`primitives::cylinder`] of height 1) as the segment from `a` to `b`.
pub(crate) fn along(a: Vec3, b: Vec3) -> Mat4 {
    let axis = b - a;
    let rotation = Quat::from_rotation_arc(Vec3::Y, axis.normalize_or(Vec3::Y));
    Mat4::from_scale_rotation_translation(
        Vec3::new(1.0, axis.length(), 1.0),
        rotation,
        (a + b) * 0.5,
    )
}

/// `foliage`: a trunk (radius 0.1, 1.5 high) with six branches rising outwards, and `leaves`
/// leaf cards scattered around the branches' outer halves with random orientations.
fn foliage(light_width: f32, leaves: u32, leaf_size: f32) -> Scene {
    let mut rng = SplitMix64::new(40);
    let mut wood = Mesh::default();
    let trunk_top = Vec3::Y * 1.5;
    append(
        &mut wood,
        &primitives::cylinder(0.1, 1.0, 12),
        along(Vec3::ZERO, trunk_top),
    );
    let mut tips = Vec::new();
    for k in 0..6 {
        let azimuth = k as f32 * std::f32::consts::TAU / 6.0 + 0.4 * rng.next_f32();
        let start = Vec3::Y * (0.9 + 0.1 * k as f32);
        let out = Vec3::new(azimuth.cos(), 0.0, azimuth.sin());
        let end = start + out * 0.8 + Vec3::Y * (0.5 + 0.3 * rng.next_f32());
        append(
            &mut wood,
            &primitives::cylinder(0.035, 1.0, 8),
            along(start, end),
        );
        tips.push((start, end));
    }
    let cluster = card(leaf_size, leaf_size, Vec2::ONE);
    let mut foliage = Mesh::default();
    for _ in 0..leaves {
        let (start, end) = tips[(rng.next_f32() * tips.len() as f32) as usize % tips.len()];
        let along_branch = start.lerp(end, 0.3 + 0.9 * rng.next_f32());
        let offset = rng.in_unit_ball() * 0.45;
        let rotation = Quat::from_euler(
            glam::EulerRot::YXZ,
            std::f32::consts::TAU * rng.next_f32(),
            (rng.next_f32() - 0.5) * 2.0,
            (rng.next_f32() - 0.5) * 1.0,
        );
        let place = Mat4::from_rotation_translation(rotation, along_branch + offset);
        append(&mut foliage, &cluster, place);
    }
    let mut b = Builder::new("foliage");
    b.ground();
    let bark = b.mesh(wood, "trunk and branches");
    b.caster(bark, Mat4::IDENTITY, true);
    let leaf_texture = b.texture(textures::leaf_cluster(128), "leaf cluster");
    let leaf = b.masked_material("leaf", Vec3::new(0.35, 0.6, 0.25), leaf_texture);
    let cards = b.mesh(foliage, "leaf cards");
    b.masked_caster(cards, Mat4::IDENTITY, leaf);
    let light = AreaLight::looking_at(
        Vec3::new(1.6, 5.0, 1.2),
        Vec3::new(0.0, 0.8, 0.0),
        light_width,
        light_width,
    );
    b.finish(
        light,
        camera(Vec3::new(0.0, 2.4, 5.4), Vec3::new(0.0, 0.9, 0.0)),
    )
}

/// `fence`: a 4 x 1.6 chain-link quad (its mask repeated `cells` times across) 0.1 above the
/// ground at z = 0 between two posts, a 8 x 3 wall at z = -1.5 behind it; the light shines from
/// the front right and above, so the fence's shadow falls on the ground and climbs the wall.
fn fence(light_width: f32, cells: f32, wire: f32) -> Scene {
    let mut b = Builder::new("fence");
    b.ground();
    let wall = b.mesh(card(8.0, 3.0, Vec2::ONE), "wall");
    b.receiver(wall, Mat4::from_translation(Vec3::new(0.0, 1.5, -1.5)));
    let post = b.mesh(primitives::cylinder(0.04, 1.8, 12), "post");
    for x in [-2.04, 2.04] {
        b.caster(post, Mat4::from_translation(Vec3::new(x, 0.9, 0.0)), true);
    }
    let mesh = card(4.0, 1.6, Vec2::new(cells, cells * 0.4));
    let mesh = b.mesh(mesh, "chain-link fence");
    let texture = b.texture(textures::chain_link(64, wire), "chain link");
    let material = b.masked_material("chain link", Vec3::splat(0.6), texture);
    b.masked_caster(
        mesh,
        Mat4::from_translation(Vec3::new(0.0, 0.9, 0.0)),
        material,
    );
    let light = AreaLight::looking_at(
        Vec3::new(1.5, 3.5, 3.5),
        Vec3::new(0.0, 0.6, -1.0),
        light_width,
        light_width,
    );
    b.finish(
        light,
        camera(Vec3::new(3.4, 2.2, 5.4), Vec3::new(-0.3, 0.6, -0.8)),
    )
}

/// Courtyard half-size (the column lines), gallery depth and storey height of `atrium`.
const COURT: f32 = 3.0;
const GALLERY: f32 = 1.5;
const STOREY: f32 = 2.4;

/// `atrium`: a 6 x 6 courtyard floor inside a 9 x 9 building of two storeys. Each storey has an
/// arcade on every side (`bays` round arches on square piers), a gallery slab behind it and the
/// outer wall; the roof covers the galleries and leaves the courtyard open. Lace cloths hang in
/// the upper arcade on two sides. The light (above the roof opening, facing down) lights the
/// courtyard through it, so the roof's rim, the arcades and the cloths all cast.
fn atrium(light_width: f32, bays: u32) -> Scene {
    let mut b = Builder::new("atrium");
    let floor = b.mesh(primitives::plane(9.0, 9.0), "floor");
    b.receiver(floor, Mat4::IDENTITY);
    let mut stone = Mesh::default();
    for storey in 0..2 {
        let y = storey as f32 * STOREY;
        for side in 0..4 {
            let to_side = Mat4::from_rotation_y(side as f32 * std::f32::consts::FRAC_PI_2);
            append(&mut stone, &arcade(bays, y), to_side);
            append(&mut stone, &gallery(y), to_side);
        }
    }
    for side in 0..4 {
        let to_side = Mat4::from_rotation_y(side as f32 * std::f32::consts::FRAC_PI_2);
        append(&mut stone, &gallery(2.0 * STOREY), to_side);
    }
    let stone = b.mesh(stone, "arcades, galleries and walls");
    b.caster(stone, Mat4::IDENTITY, true);
    let texture = b.texture(textures::lace_cloth(128), "lace cloth");
    let lace = b.masked_material("lace cloth", Vec3::ONE, texture);
    let bay = 2.0 * COURT / bays as f32;
    let cloth = b.mesh(card(bay * 0.7, 1.5, Vec2::ONE), "cloth");
    for side in [0.0, std::f32::consts::PI] {
        for k in 0..bays {
            let x = -COURT + bay * (k as f32 + 0.5);
            let hang = Mat4::from_translation(Vec3::new(x, STOREY + 1.6, COURT - 0.25));
            b.masked_caster(cloth, Mat4::from_rotation_y(side) * hang, lace);
        }
    }
    // Oblique, as the sun through Sponza's opening: the roof's rim, the arcades and the cloths
    // shadow the courtyard floor the camera looks across.
    let light = AreaLight::looking_at(
        Vec3::new(2.0, 8.0, 1.2),
        Vec3::new(-0.8, 0.0, -0.5),
        light_width,
        light_width,
    );
    b.finish(
        light,
        camera(Vec3::new(2.3, 1.7, 2.3), Vec3::new(-1.5, 1.0, -1.5)),
    )
}

/// One side's arcade of one storey (the side facing -z... +z at z = COURT): square piers and,
/// above them, a wall pierced by `bays` round arches, as a solid 0.3 thick.
fn arcade(bays: u32, y: f32) -> Mesh {
    let mut mesh = Mesh::default();
    let bay = 2.0 * COURT / bays as f32;
    let pier = primitives::cuboid(Vec3::new(0.3, 1.0, 0.3));
    let spring = 1.5;
    for k in 0..=bays {
        let x = -COURT + bay * k as f32;
        let place = Mat4::from_translation(Vec3::new(x, y + spring * 0.5, COURT))
            * Mat4::from_scale(Vec3::new(1.0, spring, 1.0));
        append(&mut mesh, &pier, place);
    }
    for k in 0..bays {
        let x0 = -COURT + bay * k as f32 + 0.15;
        let x1 = x0 + bay - 0.3;
        append(
            &mut mesh,
            &arch(x0, x1, y + spring, y + STOREY),
            Mat4::from_translation(Vec3::Z * COURT),
        );
    }
    mesh
}

/// The wall over one round arch from `x0` to `x1` springing at `spring`, up to `top`: a front and
/// a back face (z = ±0.15) made of vertical strips between the arch and the top, and the arch's
/// underside.
fn arch(x0: f32, x1: f32, spring: f32, top: f32) -> Mesh {
    const SEGMENTS: usize = 12;
    let mut mesh = Mesh::default();
    let (centre, radius) = ((x0 + x1) * 0.5, (x1 - x0) * 0.5);
    let rise = (top - spring).min(radius);
    let point = |i: usize| {
        let angle = std::f32::consts::PI * (1.0 - i as f32 / SEGMENTS as f32);
        Vec2::new(centre + radius * angle.cos(), spring + rise * angle.sin())
    };
    for i in 0..SEGMENTS {
        let (p, q) = (point(i), point(i + 1));
        for z in [0.15f32, -0.15] {
            let normal = Vec3::Z * z.signum();
            let strip = [
                Vec3::new(p.x, p.y, z),
                Vec3::new(q.x, q.y, z),
                Vec3::new(q.x, top, z),
                Vec3::new(p.x, top, z),
            ];
            let strip = if z > 0.0 {
                strip
            } else {
                [strip[1], strip[0], strip[3], strip[2]]
            };
            primitives::push_quad(&mut mesh, strip, normal);
        }
        let inward = (Vec2::new(centre, spring) - (p + q) * 0.5).normalize_or_zero();
        primitives::push_quad(
            &mut mesh,
            [
                Vec3::new(p.x, p.y, -0.15),
                Vec3::new(q.x, q.y, -0.15),
                Vec3::new(q.x, q.y, 0.15),
                Vec3::new(p.x, p.y, 0.15),
            ],
            inward.extend(0.0),
        );
    }
    mesh
}

/// One side's gallery floor at height `y` (0.2 thick, from the arcade to the outer wall) and, below
/// it, the outer wall of that storey. At `y` = the roof's height only the slab (the roof) is used.
fn gallery(y: f32) -> Mesh {
    let mut mesh = Mesh::default();
    let depth = GALLERY;
    let span = 2.0 * (COURT + depth);
    if y > 0.0 {
        let slab = primitives::cuboid(Vec3::new(span, 0.2, depth));
        let place = Mat4::from_translation(Vec3::new(0.0, y + 0.1, COURT + depth * 0.5));
        append(&mut mesh, &slab, place);
    }
    if y < 2.0 * STOREY {
        let wall = primitives::cuboid(Vec3::new(span, STOREY, 0.2));
        let place = Mat4::from_translation(Vec3::new(0.0, y + STOREY * 0.5, COURT + depth + 0.1));
        append(&mut mesh, &wall, place);
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    fn defaults(id: &str) -> Scene {
        let info = infos().into_iter().find(|i| i.id == id).unwrap();
        let value = |name: &str| info.params.iter().find(|p| p.name == name).unwrap().default;
        build(id, &value).unwrap()
    }

    #[test]
    fn engine_scenes_are_valid_and_deterministic() {
        for info in infos() {
            let scene = defaults(info.id);
            scene
                .validate()
                .unwrap_or_else(|e| panic!("{}: {e}", info.id));
            assert!(
                scene.has_masked_casters(),
                "{} has no masked caster",
                info.id
            );
            let again = defaults(info.id);
            assert_eq!(scene.triangle_count(), again.triangle_count());
            for (a, b) in scene.meshes.iter().zip(&again.meshes) {
                assert_eq!(a.positions, b.positions, "{}: {}", info.id, a.name);
            }
        }
    }

    #[test]
    fn casters_lie_in_front_of_the_light() {
        for info in infos() {
            let scene = defaults(info.id);
            let bounds = scene.bounds(|i| i.casts_shadow);
            for corner in bounds.corners() {
                let z = scene.light.to_light_space(corner).z;
                assert!(
                    z > 0.0,
                    "{}: caster corner {corner} at light z {z}",
                    info.id
                );
            }
        }
    }

    #[test]
    fn cards_carry_texture_coordinates() {
        let mesh = card(2.0, 1.0, Vec2::new(4.0, 2.0));
        assert_eq!(mesh.texcoords.len(), mesh.positions.len());
        assert_eq!(mesh.triangle_count(), 4);
        let max = mesh.texcoords.iter().fold(Vec2::ZERO, |m, &t| m.max(t));
        assert_eq!(max, Vec2::new(4.0, 2.0));
    }
}
