//! The stiff-case family (issue 6): scenes built to break soft-shadow techniques where they
//! divide by distances that go to zero, sum many tiny numbers or search areas that blow up, and
//! to break the references too. Every id starts with `stiff-`; `workbench bench --suite stiff`
//! runs every registered technique on every one of them.
//!
//! Every case has a class, what it stresses ([`StiffClass`]): a technique states a bound per class
//! and names only the cases whose bound differs, so a new case of a known class is one entry in
//! [`cases`] (and its scene in `build`).
//!
//! Most cases use only rectangles parallel to the light, so the benchmark can score them against
//! the exact closed form (`softshadow_reference::exact`); the others (contact, grazing light,
//! occluder crossing the light plane) are scored against a sampled exact answer (ray-traced with
//! ray queries, else the CPU ray cast).
//!
//! Conventions as in [`crate::builtin`](mod@crate::builtin): an 8 x 8 receiver-only ground at
//! y = 0, casters are not receivers unless said, lights face the ground.

use glam::{Mat4, Vec3};
use softshadow_core::{
    AreaLight, Camera, LightKind, Mesh, Scene,
    StiffClass::{self, *},
};

use crate::builtin::{camera, down_light, light_width, Builder, BuiltinInfo, ParamInfo};
use crate::primitives::{self, face, push_quad};
use crate::SceneError;

mod kinds;
mod masks;

/// Every stiff-case id starts with this.
pub const PREFIX: &str = "stiff-";

/// A stiff case: what it stresses (a technique's bound for it comes from the rule it states for
/// the class, unless it names the case) and its scene's id, description and parameters.
#[derive(Clone, Debug)]
pub struct StiffCase {
    /// What the case stresses.
    pub class: StiffClass,
    /// Its id (`stiff-...`), description and parameters.
    pub info: BuiltinInfo,
}

impl StiffCase {
    /// The kind of the case's light, as its scene is built with its default parameters: a
    /// technique that does not support it (`TechniqueInfo::light_kinds`) is not run on the case
    /// and promises nothing for it.
    pub fn light_kind(&self) -> LightKind {
        let default = |name: &str| {
            let param = self.info.params.iter().find(|p| p.name == name);
            param.map_or(0.0, |p| p.default)
        };
        build(self.info.id, &default).map_or(LightKind::Rect, |scene| scene.light.kind)
    }
}

/// Every stiff case with its class and parameters: the rectangle light's, then the other light
/// kinds' (`kinds.rs`), then the alpha-tested casters' (`masks.rs`).
pub fn cases() -> Vec<StiffCase> {
    let mut cases = first_cases();
    cases.extend(later_cases());
    cases.extend(kinds::cases());
    cases.extend(masks::cases());
    cases
}

/// The suite's first cases, in its order (two tables only so that each reads on one screen).
// Long: one entry per stiff case; the table reads best whole.
fn first_cases() -> Vec<StiffCase> {
    vec![
        StiffCase {
            class: VanishingDistance,
            info: BuiltinInfo {
                id: "stiff-contact",
                description: "stiff: a cube resting on the ground and a quad leaning on it at 30 degrees (occluder touching the receiver: z_R - z_O -> 0)",
                params: vec![
                    light_width(1.0),
                    ParamInfo::new("gap", 0.0, 0.0, 1.0, "height of the occluders' lowest points above the ground (0 = touching)"),
                ],
            },
        },
        StiffCase {
            class: VanishingDistance,
            info: BuiltinInfo {
                id: "stiff-near-light",
                description: "stiff: a square occluder just below the light (distance light_gap x light height: z_O -> 0)",
                params: vec![
                    light_width(1.0),
                    ParamInfo::new("light_gap", 1e-3, 0.0, 0.5, "distance between occluder and light, as a fraction of the light's height (2)")
                        .min_exclusive(),
                ],
            },
        },
        StiffCase {
            class: PointLight,
            info: BuiltinInfo {
                id: "stiff-point-light",
                description: "stiff: the atty-square set-up under a point-like light (width 1e-4): soft techniques must reduce to hard shadows",
                params: vec![ParamInfo::new("light_width", 1e-4, 0.0, 0.01, "side of the square light")],
            },
        },
        StiffCase {
            class: LightShape,
            info: BuiltinInfo {
                id: "stiff-wide-light",
                description: "stiff: a 0.3 square occluder under a light light_ratio times wider (no umbra, wide penumbra)",
                params: vec![ParamInfo::new("light_ratio", 10.0, 1.0, 20.0, "light width over occluder width")],
            },
        },
        StiffCase {
            class: LightShape,
            info: BuiltinInfo {
                id: "stiff-grazing",
                description: "stiff: light at angle_degrees from the receiver normal, occluder square parallel to the light (shadow stretched ~11x)",
                params: vec![ParamInfo::new("angle_degrees", 85.0, 0.0, 89.0, "angle between the ground normal and the direction to the light")],
            },
        },
        StiffCase {
            class: VanishingDistance,
            info: BuiltinInfo {
                id: "stiff-depth-range",
                description: "stiff: light at height 10, one occluder `near` below it and one 0.1 above the ground (caster near/far ~ 1e-4)",
                params: vec![
                    ParamInfo::new("near", 1e-3, 0.0, 1.0, "distance of the upper occluder below the light")
                        .min_exclusive(),
                ],
            },
        },
        StiffCase {
            class: ThinGeometry,
            info: BuiltinInfo {
                id: "stiff-zero-thickness",
                description: "stiff: zero-thickness occluders: one-sided quads facing the light and facing away, and a box flattened to zero height",
                params: vec![light_width(1.0)],
            },
        },
    ]
}

/// The suite's later cases, in its order.
// Long: one entry per stiff case; the table reads best whole.
fn later_cases() -> Vec<StiffCase> {
    vec![
        StiffCase {
            class: LightPlane,
            info: BuiltinInfo {
                id: "stiff-partly-outside",
                description: "stiff: a vertical wall that crosses the light plane beside the light (part of the occluder behind the light, outside every light frustum)",
                params: vec![light_width(1.0)],
            },
        },
        StiffCase {
            class: Unshadowed,
            info: BuiltinInfo {
                id: "stiff-no-occluder",
                description: "stiff: the ground alone (nothing casts a shadow: V = 1 everywhere)",
                params: vec![light_width(1.0)],
            },
        },
        StiffCase {
            class: LightShape,
            info: BuiltinInfo {
                id: "stiff-aspect-100",
                description: "stiff: a 4-wide light of aspect ratio `aspect`:1 over a square occluder",
                params: vec![ParamInfo::new("aspect", 100.0, 1.0, 1000.0, "light width over light height")],
            },
        },
        StiffCase {
            class: VanishingDistance,
            info: BuiltinInfo {
                id: "stiff-tiny-patches",
                description: "stiff (FP16 trap, Atty et al. appendix A): a large square just below a large light, so thousands of micro-patches each hide ~1e-3 of the light",
                params: vec![
                    ParamInfo::new("occluder_gap", 0.1, 0.0, 1.0, "distance between the occluder and the light (height 2)")
                        .min_exclusive(),
                ],
            },
        },
        StiffCase {
            class: ThinGeometry,
            info: BuiltinInfo {
                id: "stiff-degenerate",
                description: "stiff: an occluder mesh with degenerate, non-finite and out-of-range triangles (repaired with a warning naming them)",
                params: Vec::new(),
            },
        },
        StiffCase {
            class: LightPlane,
            info: BuiltinInfo {
                id: "stiff-behind-light",
                description: "stiff: receivers on both sides of the light plane (a raised platform above a downward light at height 1): V = 0 behind the one-sided light",
                params: vec![light_width(1.0)],
            },
        },
        StiffCase {
            class: LightPlane,
            info: BuiltinInfo {
                id: "stiff-receiver-behind-light",
                description: "stiff: an oblique light (at (6, 3, 0), aimed at (-3, 0, 0)) over a 20 x 14 ground that reaches behind its plane, a 2 x 2 square at height 1 between them (a hard shadow map fitted to the receivers must ignore the part behind the light)",
                params: vec![light_width(1.0)],
            },
        },
        StiffCase {
            class: LightPlane,
            info: BuiltinInfo {
                id: "stiff-light-up",
                description: "stiff: a light facing straight up between the ground (behind it: V = 0) and a ceiling that receives a square's shadow",
                params: vec![light_width(1.0)],
            },
        },
        StiffCase {
            class: OccluderOverlap,
            info: BuiltinInfo {
                id: "stiff-fusion",
                description: "stiff: three overlapping squares at different heights (occluder fusion: the exact answer is the area of the union)",
                params: vec![light_width(1.0)],
            },
        },
        StiffCase {
            class: OccluderOverlap,
            info: BuiltinInfo {
                id: "stiff-light-leak",
                description: "stiff (light leaking): a small square just below the light, one halfway and a wide one (3 x 3) 0.15 above the ground, overlapping, seen from low down; filterable shadow maps (variance, exponential, moment) brighten the wide one's umbra",
                params: vec![light_width(1.0)],
            },
        },
        StiffCase {
            class: LightShape,
            info: BuiltinInfo {
                id: "stiff-large-light",
                description: "stiff (large penumbrae, issue 30): a light_width x light_width/2 light 2 above the ground, a 0.6 x 0.4 rectangle 0.25 below it and a 1.0 x 0.5 rectangle 0.7 above the ground (penumbrae wider than the casters; coarse hierarchy levels over-darken)",
                params: vec![light_width(1.2)],
            },
        },
        StiffCase {
            class: ThinGeometry,
            info: BuiltinInfo {
                id: "stiff-thin-roof",
                description: "stiff (issue 38): a roof `thickness` thick (below a shadow map's bias) over a wall, the light high above: under the eaves the wall sees the light at a grazing angle and the roof's underside faces away from it; the V error and the irradiance error disagree there",
                params: vec![
                    light_width(1.0),
                    ParamInfo::new("thickness", 0.002, 0.0005, 0.05, "thickness of the roof slab"),
                ],
            },
        },
    ]
}

/// Every stiff case's scene (listed by `workbench list` with the other builtins).
pub fn infos() -> Vec<BuiltinInfo> {
    cases().into_iter().map(|case| case.info).collect()
}

/// The class of the stiff case `spec` names exactly (`stiff-contact`; not `stiff-contact:gap=0.1`,
/// whose bounds nobody states), or `None`.
pub fn class_of(spec: &str) -> Option<StiffClass> {
    cases()
        .into_iter()
        .find(|case| case.info.id == spec)
        .map(|case| case.class)
}

/// Builds stiff case `id`; `value(name)` returns its (checked) parameters.
// Long: one arm per rectangle-light case (the other kinds' and the alpha-tested cases build in
// `kinds.rs` and `masks.rs`); the match reads best whole.
pub(crate) fn build(id: &str, value: &dyn Fn(&str) -> f64) -> Result<Scene, SceneError> {
    let v = |name: &str| value(name) as f32;
    let scene = match id {
        "stiff-contact" => contact(v("light_width"), v("gap")),
        "stiff-near-light" => {
            let height = 2.0;
            let occluder_y = height * (1.0 - v("light_gap"));
            squares(
                id,
                down_light(Vec3::Y * height, v("light_width")),
                &[Square::at(0.0, occluder_y, 0.0, 0.5)],
            )
        }
        "stiff-point-light" => squares(
            id,
            down_light(Vec3::Y * 2.0, v("light_width")),
            &[Square::at(0.0, 1.0, 0.0, 1.0)],
        ),
        "stiff-wide-light" => {
            let size = 0.3;
            squares(
                id,
                down_light(Vec3::Y * 2.0, size * v("light_ratio")),
                &[Square::at(0.0, 1.0, 0.0, size)],
            )
        }
        "stiff-grazing" => grazing(v("angle_degrees")),
        "stiff-depth-range" => {
            let height = 10.0;
            let mut scene = squares(
                id,
                down_light(Vec3::Y * height, 0.5),
                &[
                    Square::at(0.0, height - v("near"), 0.0, 0.25),
                    Square::at(0.6, 0.1, 0.0, 0.5),
                ],
            );
            scene.camera.eye = Vec3::new(0.0, 3.0, 4.0);
            scene
        }
        "stiff-zero-thickness" => zero_thickness(v("light_width")),
        "stiff-partly-outside" => partly_outside(v("light_width")),
        "stiff-no-occluder" => squares(id, down_light(Vec3::Y * 2.0, v("light_width")), &[]),
        "stiff-aspect-100" => {
            let mut light = down_light(Vec3::Y * 2.0, 4.0);
            light.height = 4.0 / v("aspect");
            squares(id, light, &[Square::at(0.0, 1.0, 0.0, 0.8)])
        }
        "stiff-tiny-patches" => squares(
            id,
            down_light(Vec3::Y * 2.0, 2.0),
            &[Square::at(0.0, 2.0 - v("occluder_gap"), 0.0, 1.6)],
        ),
        "stiff-degenerate" => degenerate(),
        "stiff-behind-light" => behind_light(v("light_width")),
        "stiff-receiver-behind-light" => receiver_behind_light(v("light_width")),
        "stiff-light-up" => light_up(v("light_width")),
        "stiff-fusion" => squares(
            id,
            down_light(Vec3::Y * 2.5, v("light_width")),
            &[
                Square::at(-0.3, 0.6, 0.0, 0.8),
                Square::at(0.2, 1.1, 0.2, 0.7),
                Square::at(0.5, 1.6, -0.2, 0.5),
            ],
        ),
        "stiff-light-leak" => {
            let mut scene = squares(
                id,
                down_light(Vec3::Y * 2.5, v("light_width")),
                &[
                    Square::at(-0.1, 2.2, 0.6, 0.5),
                    Square::at(0.2, 1.2, 0.7, 0.8),
                    Square::at(0.0, 0.15, 0.0, 3.0),
                ],
            );
            // Low, so that it sees the ground under the wide square.
            scene.camera.eye = Vec3::new(0.0, 0.5, 4.5);
            scene.camera.target = Vec3::new(0.0, 0.0, 0.5);
            scene
        }
        "stiff-large-light" => {
            let width = v("light_width");
            let mut light = down_light(Vec3::Y * 2.0, width);
            light.height = 0.5 * width;
            squares(
                id,
                light,
                &[
                    Square::rect(-0.2, 1.75, 0.1, 0.6, 0.4),
                    Square::rect(0.4, 0.7, -0.1, 1.0, 0.5),
                ],
            )
        }
        "stiff-thin-roof" => thin_roof(v("light_width"), v("thickness")),
        _ => {
            let other = kinds::build(id, &v).or_else(|| masks::build(id, &v));
            return other.ok_or_else(|| SceneError::UnknownScene { spec: id.into() });
        }
    };
    Ok(scene)
}

/// Issue 38's architecture in small: a 2 x 1 wall 0.1 thick and over it a 2.6 x 1.4 roof slab
/// `thickness` thick (both cast and receive), overhanging the wall's front by 0.75, over the
/// ground; the light 5 above, slightly in front. The roof's underside (facing away from the
/// light) and the wall under the eaves (lit at a grazing angle when at all) are in the roof's
/// umbra, which a shadow map whose bias exceeds the roof's thickness misses; the camera looks up
/// at them from the front.
fn thin_roof(light_width: f32, thickness: f32) -> Scene {
    let mut b = Builder::new("stiff-thin-roof");
    b.ground();
    let wall = b.mesh(primitives::cuboid(Vec3::new(2.0, 1.0, 0.1)), "wall");
    b.caster(wall, Mat4::from_translation(Vec3::new(0.0, 0.5, 0.0)), true);
    let roof = b.mesh(
        primitives::cuboid(Vec3::new(2.6, thickness, 1.4)),
        "thin roof",
    );
    let roof_at = Vec3::new(0.0, 1.0 + 0.5 * thickness, 0.1);
    b.caster(roof, Mat4::from_translation(roof_at), true);
    let light = AreaLight::looking_at(
        Vec3::new(0.8, 5.0, 1.2),
        Vec3::new(0.0, 0.5, 0.2),
        light_width,
        light_width,
    );
    let camera = camera(Vec3::new(1.6, 0.45, 4.2), Vec3::new(0.0, 0.7, 0.0));
    b.finish(light, camera)
}

/// A two-sided horizontal rectangle occluder (`size` along x and z), caster only.
#[derive(Clone, Copy)]
struct Square {
    center: Vec3,
    size: (f32, f32),
}

impl Square {
    fn at(x: f32, y: f32, z: f32, size: f32) -> Self {
        Self::rect(x, y, z, size, size)
    }

    fn rect(x: f32, y: f32, z: f32, size_x: f32, size_z: f32) -> Self {
        Self {
            center: Vec3::new(x, y, z),
            size: (size_x, size_z),
        }
    }
}

/// The atty-square layout with any light and any set of horizontal squares (all parallel to a
/// downward light, so the closed form applies).
fn squares(id: &str, light: AreaLight, squares: &[Square]) -> Scene {
    let mut b = Builder::new(id);
    b.ground();
    for (k, square) in squares.iter().enumerate() {
        let mesh = b.mesh(
            primitives::two_sided_quad(square.size.0, square.size.1),
            &format!("square {k}"),
        );
        b.caster(mesh, Mat4::from_translation(square.center), false);
    }
    b.finish(
        light,
        camera(Vec3::new(0.0, 3.2, 4.0), Vec3::new(0.0, 0.0, 0.4)),
    )
}

/// A unit cube whose bottom face lies `gap` above the ground, and a 1 x 1 quad leaning at 30
/// degrees whose lowest edge is `gap` above the ground: the occluder-receiver distance goes to
/// zero along both contact lines.
fn contact(light_width: f32, gap: f32) -> Scene {
    let mut b = Builder::new("stiff-contact");
    b.ground();
    let cube = b.mesh(primitives::cuboid(Vec3::ONE), "cube");
    b.caster(
        cube,
        Mat4::from_translation(Vec3::new(-0.8, 0.5 + gap, 0.0)),
        false,
    );
    // The quad's lower edge runs along z at (0.3, gap); it rises towards +x at 30 degrees.
    let (c, s) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
    let along = Vec3::new(c, s, 0.0) * 0.5;
    let across = Vec3::Z * 0.5;
    let center = Vec3::new(0.3, gap, 0.0) + along;
    let lean = b.mesh(two_sided(center, along, across), "leaning quad");
    b.caster(lean, Mat4::IDENTITY, false);
    b.finish(
        down_light(Vec3::new(0.0, 3.0, 0.0), light_width),
        camera(Vec3::new(0.0, 3.0, 3.6), Vec3::new(0.0, 0.2, 0.0)),
    )
}

/// A 0.6 x 0.6 light at `angle_degrees` from the ground normal, 7 units from the point it aims
/// at, (2, 0, 0); a 0.4 square occluder halfway, parallel to the light.
fn grazing(angle_degrees: f32) -> Scene {
    let mut b = Builder::new("stiff-grazing");
    b.ground();
    let angle = angle_degrees.to_radians();
    let target = Vec3::new(2.0, 0.0, 0.0);
    let center = target + 7.0 * Vec3::new(-angle.sin(), angle.cos(), 0.0);
    let light = AreaLight::looking_at(center, target, 0.6, 0.6);
    let (x, y, z) = light.basis();
    let occluder = b.mesh(
        two_sided(center + z * 3.5, x * 0.2, y * 0.2),
        "square parallel to the light",
    );
    b.caster(occluder, Mat4::IDENTITY, false);
    b.finish(
        light,
        camera(Vec3::new(1.0, 3.5, 4.5), Vec3::new(1.5, 0.0, 0.0)),
    )
}

/// Three 0.6 squares at height 1: one-sided facing the light, one-sided facing the ground, and a
/// box of zero height (its side faces are degenerate and are dropped by the repair).
fn zero_thickness(light_width: f32) -> Scene {
    let mut b = Builder::new("stiff-zero-thickness");
    b.ground();
    let h = 0.3;
    let facing_light = b.mesh(
        one_sided(Vec3::ZERO, Vec3::Z * h, Vec3::X * h),
        "one-sided quad facing the light",
    );
    let facing_ground = b.mesh(
        one_sided(Vec3::ZERO, Vec3::X * h, Vec3::Z * h),
        "one-sided quad facing the ground",
    );
    let flat_box = b.mesh(
        primitives::cuboid(Vec3::new(0.6, 0.0, 0.6)),
        "box of zero height",
    );
    for (mesh, x) in [(facing_light, -1.2), (facing_ground, 0.0), (flat_box, 1.2)] {
        b.caster(mesh, Mat4::from_translation(Vec3::new(x, 1.0, 0.0)), false);
    }
    b.finish(
        down_light(Vec3::Y * 2.0, light_width),
        camera(Vec3::new(0.0, 3.2, 4.0), Vec3::new(0.0, 0.0, 0.4)),
    )
}

/// A vertical two-sided wall in the plane x = 0.8 (beside the light's edge), from y = 1 to
/// y = 3, crossing the light plane y = 2: its upper half lies behind the light.
fn partly_outside(light_width: f32) -> Scene {
    let mut b = Builder::new("stiff-partly-outside");
    b.ground();
    let wall = b.mesh(
        two_sided(Vec3::new(0.8, 2.0, 0.0), Vec3::Y, Vec3::Z * 0.6),
        "wall through the light plane",
    );
    b.caster(wall, Mat4::IDENTITY, false);
    b.finish(
        down_light(Vec3::Y * 2.0, light_width),
        camera(Vec3::new(0.0, 3.2, 4.0), Vec3::new(0.4, 0.0, 0.2)),
    )
}

/// A receiver-only platform, two-sided so it is seen from above and below.
fn receiver_quad(b: &mut Builder, name: &str, size: f32, transform: Mat4) {
    let mesh = b.mesh(primitives::two_sided_quad(size, size), name);
    b.receiver(mesh, transform);
}

/// A downward 1-high light over the ground with a 0.5 square occluder halfway, and a 1.5 square
/// receiver platform at height 1.5 beside it: behind the light plane, so its pixels hold 0 while
/// the ground in front is shadowed normally (the contract for one-sided lights).
fn behind_light(light_width: f32) -> Scene {
    let mut b = Builder::new("stiff-behind-light");
    b.ground();
    let square = b.mesh(primitives::two_sided_quad(0.5, 0.5), "square occluder");
    b.caster(square, Mat4::from_translation(Vec3::Y * 0.5), false);
    receiver_quad(
        &mut b,
        "platform behind the light",
        1.5,
        Mat4::from_translation(Vec3::new(2.0, 1.5, 0.0)),
    );
    b.finish(
        down_light(Vec3::Y, light_width),
        camera(Vec3::new(0.0, 3.2, 4.0), Vec3::new(0.8, 0.5, 0.2)),
    )
}

/// The scene of issue 44: a light at (6, 3, 0) aimed at (-3, 0, 0) over a 20 x 14 ground from
/// x = -7 to 13, which its plane cuts at x = 7; a 2 x 2 square at height 1 (caster only) throws
/// its shadow over x = -4.5 to -1.5, seen from straight above. A hard map fitted to the
/// receivers' vertices in front of the light saw only the ground's far edge and drew no shadow.
fn receiver_behind_light(light_width: f32) -> Scene {
    let mut b = Builder::new("stiff-receiver-behind-light");
    let ground = b.mesh(
        primitives::plane(20.0, 14.0),
        "ground through the light plane",
    );
    b.receiver(ground, Mat4::from_translation(Vec3::X * 3.0));
    let square = b.mesh(primitives::two_sided_quad(2.0, 2.0), "square occluder");
    b.caster(square, Mat4::from_translation(Vec3::Y), false);
    let light = AreaLight::looking_at(
        Vec3::new(6.0, 3.0, 0.0),
        Vec3::new(-3.0, 0.0, 0.0),
        light_width,
        light_width,
    );
    let camera = Camera {
        fov_y_degrees: 30.0,
        ..camera(Vec3::new(-3.0, 6.0, 0.01), Vec3::new(-3.0, 0.0, 0.0))
    };
    b.finish(light, camera)
}

/// A light at height 1 facing straight up: the ground lies behind it (V = 0 everywhere on it);
/// a 0.8 square at height 2 shadows a 6 x 6 ceiling at height 3.5.
fn light_up(light_width: f32) -> Scene {
    let mut b = Builder::new("stiff-light-up");
    b.ground();
    let square = b.mesh(primitives::two_sided_quad(0.8, 0.8), "square occluder");
    b.caster(square, Mat4::from_translation(Vec3::Y * 2.0), false);
    receiver_quad(
        &mut b,
        "ceiling",
        6.0,
        Mat4::from_translation(Vec3::Y * 3.5),
    );
    let light = AreaLight {
        direction: Vec3::Y,
        up: Vec3::Z,
        ..down_light(Vec3::Y, light_width)
    };
    b.finish(
        light,
        camera(Vec3::new(0.0, 1.8, 6.0), Vec3::new(0.0, 1.6, 0.0)),
    )
}

/// The atty-square occluder (1 x 1 at height 1, two-sided) in a mesh that also carries two
/// degenerate triangles (a repeated index, three collinear points), two non-finite ones (NaN
/// and infinite vertices) and one with an index past the vertex array. Loading repairs it and
/// warns: "dropped 2 degenerate, 2 non-finite and 1 out-of-range triangles".
fn degenerate() -> Scene {
    let mut b = Builder::new("stiff-degenerate");
    b.ground();
    let mut mesh = primitives::two_sided_quad(1.0, 1.0);
    let base = mesh.positions.len() as u32;
    mesh.positions.extend_from_slice(&[
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.1, 0.0, 0.0),
        Vec3::new(0.2, 0.0, 0.0),
        Vec3::new(f32::NAN, 0.0, 0.0),
        Vec3::new(0.0, f32::INFINITY, 0.0),
    ]);
    mesh.normals.extend_from_slice(&[Vec3::Y; 5]);
    mesh.indices.extend_from_slice(&[
        base,
        base,
        base + 1, // repeated index
        base,
        base + 1,
        base + 2, // collinear
        base,
        base + 1,
        base + 3, // NaN vertex
        base,
        base + 4,
        base + 1, // infinite vertex
        base,
        base + 1,
        base + 99, // index out of range
    ]);
    let occluder = b.mesh(mesh, "occluder with bad triangles");
    b.caster(
        occluder,
        Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0)),
        false,
    );
    b.finish(
        down_light(Vec3::Y * 2.0, 1.0),
        camera(Vec3::new(0.0, 3.2, 4.0), Vec3::new(0.0, 0.0, 0.4)),
    )
}

/// A one-sided quad centred at `center` spanned by half-extents `u`, `v`, facing `u x v`.
fn one_sided(center: Vec3, u: Vec3, v: Vec3) -> Mesh {
    let mut mesh = Mesh::default();
    push_quad(&mut mesh, face(center, u, v), u.cross(v).normalize());
    mesh
}

/// The same quad facing both ways (so back-face culling never removes it).
fn two_sided(center: Vec3, u: Vec3, v: Vec3) -> Mesh {
    let mut mesh = one_sided(center, u, v);
    push_quad(&mut mesh, face(center, v, u), v.cross(u).normalize());
    mesh
}
