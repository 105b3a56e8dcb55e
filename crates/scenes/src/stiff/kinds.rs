//! Stiff cases for the light kinds other than the rectangle (issue 39, item 5): a tiny and a huge
//! disk, a sphere close to its casters, the sun at a grazing elevation, a narrow spot and a
//! sphere half sunk in the ground. A technique that does not support a case's kind is not run on
//! it and promises nothing for it ([`super::StiffCase::light_kind`]).

use glam::{Mat4, Vec3};
use softshadow_core::{
    AreaLight, LightKind, Scene,
    StiffClass::{LightPlane, LightShape, PointLight},
};

use super::{squares, Square, StiffCase};
use crate::builtin::{camera, down_light, Builder, BuiltinInfo, ParamInfo};
use crate::primitives;

/// The light-kind cases, in the suite's order.
// Long: one entry per stiff case; the table reads best whole.
pub(super) fn cases() -> Vec<StiffCase> {
    vec![
        StiffCase {
            class: PointLight,
            info: BuiltinInfo {
                id: "stiff-disk-tiny",
                description: "stiff: the stiff-point-light set-up under a disk light of radius `radius` (a point light in all but name: soft techniques must reduce to hard shadows)",
                params: vec![ParamInfo::new("radius", 5e-5, 0.0, 0.01, "the disk's radius")],
            },
        },
        StiffCase {
            class: LightShape,
            info: BuiltinInfo {
                id: "stiff-disk-huge",
                description: "stiff: a 0.3 square occluder at height 1 under a disk light of radius `radius` at height 2 (no umbra, a penumbra twenty times the occluder's width)",
                params: vec![ParamInfo::new("radius", 3.0, 0.5, 10.0, "the disk's radius")],
            },
        },
        StiffCase {
            class: LightShape,
            info: BuiltinInfo {
                id: "stiff-sphere-near",
                description: "stiff: a sphere light of radius 0.5 at height 2 with two squares just below it (0.1 and 0.3 under its lowest point): the disk it shows turns from receiver to receiver",
                params: vec![ParamInfo::new("radius", 0.5, 0.05, 0.5, "the sphere's radius (the squares stay where they are)")],
            },
        },
        StiffCase {
            class: LightShape,
            info: BuiltinInfo {
                id: "stiff-sun-grazing",
                description: "stiff: the sun (0.53 degrees wide) `elevation_degrees` above the horizon and a post 0.3 high: a shadow about twenty times the post's height, its penumbra stretched along it",
                params: vec![ParamInfo::new("elevation_degrees", 3.0, 1.0, 45.0, "the sun's elevation above the ground")],
            },
        },
        StiffCase {
            class: LightShape,
            info: BuiltinInfo {
                id: "stiff-spot-narrow",
                description: "stiff: a spot light (source radius 0.2) at height 3 with a cone `cone_outer_degrees` wide over two squares, one inside its cone and one outside (its shadow unlit, but V is still the source's fraction seen)",
                params: vec![ParamInfo::new("cone_outer_degrees", 10.0, 1.0, 60.0, "the cone's outer angle from the axis (the inner is 0.6 of it)")],
            },
        },
        StiffCase {
            class: LightPlane,
            info: BuiltinInfo {
                id: "stiff-sphere-in-ground",
                description: "stiff: a downward sphere light of radius 0.5 with its centre 0.25 above the ground (partly behind the receiver, the ground inside it unreached: V = 0), a low square and a cube reaching above its centre plane beside it",
                params: vec![ParamInfo::new("height", 0.25, 0.05, 0.45, "height of the sphere's centre above the ground")],
            },
        },
    ]
}

/// Builds light-kind case `id`, `None` for an id that is not one.
pub(super) fn build(id: &str, v: &dyn Fn(&str) -> f32) -> Option<Scene> {
    let disk = |center: Vec3, radius: f32| AreaLight {
        kind: LightKind::Disk,
        radius,
        ..down_light(center, 2.0 * radius)
    };
    let scene = match id {
        "stiff-disk-tiny" => squares(
            id,
            disk(Vec3::Y * 2.0, v("radius")),
            &[Square::at(0.0, 1.0, 0.0, 1.0)],
        ),
        "stiff-disk-huge" => squares(
            id,
            disk(Vec3::Y * 2.0, v("radius")),
            &[Square::at(0.0, 1.0, 0.0, 0.3)],
        ),
        "stiff-sphere-near" => {
            let light = AreaLight {
                kind: LightKind::Sphere,
                ..disk(Vec3::Y * 2.0, v("radius"))
            };
            let bottom = 2.0 - v("radius");
            squares(
                id,
                light,
                &[
                    Square::at(-0.3, bottom - 0.1, 0.0, 0.5),
                    Square::rect(0.5, bottom - 0.3, 0.2, 0.3, 0.6),
                ],
            )
        }
        "stiff-sun-grazing" => sun_grazing(v("elevation_degrees")),
        "stiff-spot-narrow" => spot_narrow(v("cone_outer_degrees")),
        "stiff-sphere-in-ground" => sphere_in_ground(v("height")),
        _ => return None,
    };
    Some(scene)
}

/// The sun at `elevation` degrees, shining towards +x, over a 0.15 x 0.3 x 0.15 post at x = -3:
/// its shadow runs 0.3 / tan(elevation) along the ground (5.7 at 3 degrees).
fn sun_grazing(elevation: f32) -> Scene {
    let mut b = Builder::new("stiff-sun-grazing");
    b.ground();
    let post = b.mesh(primitives::cuboid(Vec3::new(0.15, 0.3, 0.15)), "post");
    b.caster(
        post,
        Mat4::from_translation(Vec3::new(-3.0, 0.15, 0.0)),
        false,
    );
    let e = elevation.to_radians();
    let towards_sun = Vec3::new(-e.cos(), e.sin(), 0.0);
    let light = AreaLight {
        kind: LightKind::Sun,
        center: towards_sun * 20.0,
        direction: -towards_sun,
        up: Vec3::Y,
        angular_diameter_degrees: 0.53,
        ..AreaLight::default()
    };
    b.finish(
        light,
        camera(Vec3::new(0.0, 4.0, 4.5), Vec3::new(0.0, 0.0, 0.3)),
    )
}

/// A downward spot (source radius 0.2) at height 3, cone `outer` degrees (inner 0.6 of it): a
/// 0.6 square at height 1 under its axis, a 0.4 square at (1.5, 1, 0) outside a narrow cone.
fn spot_narrow(outer: f32) -> Scene {
    let light = AreaLight {
        kind: LightKind::Spot,
        radius: 0.2,
        cone_inner_degrees: 0.6 * outer,
        cone_outer_degrees: outer,
        ..down_light(Vec3::Y * 3.0, 0.4)
    };
    squares(
        "stiff-spot-narrow",
        light,
        &[
            Square::at(0.0, 1.0, 0.0, 0.6),
            Square::at(1.5, 1.0, 0.0, 0.4),
        ],
    )
}

/// A downward sphere light of radius 0.5 centred `height` above the ground: the ground within
/// sqrt(0.25 - height²) of its foot is inside it (unreached, V = 0), the rest sees the part of
/// it above the horizon. A 0.5 square 0.15 high at x = -1.2 (below its centre plane) and a 0.4
/// cube on the ground at x = 1.2 (reaching above that plane) cast shadows outwards.
fn sphere_in_ground(height: f32) -> Scene {
    let mut b = Builder::new("stiff-sphere-in-ground");
    b.ground();
    let square = b.mesh(primitives::two_sided_quad(0.5, 0.5), "low square");
    b.caster(
        square,
        Mat4::from_translation(Vec3::new(-1.2, 0.15, 0.0)),
        false,
    );
    let cube = b.mesh(primitives::cuboid(Vec3::splat(0.4)), "cube");
    b.caster(
        cube,
        Mat4::from_translation(Vec3::new(1.2, 0.2, 0.0)),
        false,
    );
    let light = AreaLight {
        kind: LightKind::Sphere,
        radius: 0.5,
        ..down_light(Vec3::Y * height, 1.0)
    };
    b.finish(
        light,
        camera(Vec3::new(0.0, 3.2, 4.0), Vec3::new(0.0, 0.0, 0.4)),
    )
}
