//! Lights of a glTF file (`KHR_lights_punctual`): the workbench's light kinds with the source
//! size read from each light's `extras` (docs/SCENES.md, "glTF models"):
//!
//! - `directional` -> `sun`, travelling along the node's -z; `extras.angular_diameter_degrees`
//!   (default 0.53);
//! - `point` -> `sphere` at the node's position, `extras.radius` (default 0: a point light),
//!   lighting the half space below it (the workbench's lights are one-sided);
//! - `spot` -> `spot` at the node's position, aimed along its -z, the cone from `innerConeAngle` /
//!   `outerConeAngle`, `extras.radius` (default 0).
//!
//! Intensities stay 1 (the workbench shades with a normalised light; only V is compared).

use glam::{Mat4, Vec3};
use gltf::khr_lights_punctual::{Kind, Light};
use softshadow_core::{AreaLight, LightKind};

/// The light `light` of the node with world transform `world`, or why it cannot be used.
pub(crate) fn light_of(light: &Light<'_>, world: Mat4) -> Result<AreaLight, String> {
    let extras: serde_json::Value = match light.extras() {
        Some(raw) => serde_json::from_str(raw.get())
            .map_err(|e| format!("light {}: its extras are not JSON ({e})", light.index()))?,
        None => serde_json::Value::Null,
    };
    let number = |key: &str, default: f32| -> Result<f32, String> {
        match &extras[key] {
            serde_json::Value::Null => Ok(default),
            value => value
                .as_f64()
                .map(|v| v as f32)
                .ok_or_else(|| format!("light {}: extras.{key} is not a number", light.index())),
        }
    };
    let center = world.transform_point3(Vec3::ZERO);
    let forward = world
        .transform_vector3(Vec3::NEG_Z)
        .normalize_or(Vec3::NEG_Y);
    let up = if forward.y.abs() > 0.9 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let base = AreaLight {
        center,
        direction: forward,
        up,
        radius: number("radius", 0.0)?,
        ..AreaLight::default()
    };
    let light = match light.kind() {
        Kind::Directional => AreaLight {
            kind: LightKind::Sun,
            angular_diameter_degrees: number("angular_diameter_degrees", 0.53)?,
            ..base
        },
        Kind::Point => AreaLight {
            kind: LightKind::Sphere,
            direction: Vec3::NEG_Y,
            up: Vec3::Z,
            ..base
        },
        Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => AreaLight {
            kind: LightKind::Spot,
            cone_inner_degrees: inner_cone_angle.to_degrees(),
            cone_outer_degrees: outer_cone_angle.to_degrees(),
            ..base
        },
    };
    light.validate().map(|()| light)
}
