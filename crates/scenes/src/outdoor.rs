//! `outdoor`: the sun over a large scene (issue 39): rolling terrain some hundreds of metres across,
//! a street of buildings, utility poles with thin wires, and a camera at eye height looking down
//! the street to the horizon. One shadow map fitted to all of it gives a texel of tens of
//! centimetres; a wire's shadow is 3 cm wide and the nearest post's penumbra a few centimetres:
//! the case cascaded shadow maps exist for.

use glam::{Mat4, Vec3};
use softshadow_core::{AreaLight, Camera, LightKind, Mesh, Scene};

use crate::builtin::{Builder, BuiltinInfo, ParamInfo};
use crate::primitives::{self, SplitMix64};

/// Grid cells along each side of the terrain.
const TERRAIN_CELLS: u32 = 128;
/// Spacing of the poles along the street, metres.
const POLE_SPACING: f32 = 30.0;
/// Height of the poles' cross-arms, metres.
const POLE_HEIGHT: f32 = 9.0;

/// `outdoor`'s id, description and parameters.
pub fn info() -> BuiltinInfo {
    BuiltinInfo {
        id: "outdoor",
        description: "the sun over a large scene: rolling terrain `extent` metres across, a street of 40 buildings, utility poles with 3 cm wires, camera at eye height looking down the street to the horizon",
        params: vec![
            ParamInfo::new("sun_elevation", 35.0, 1.0, 90.0, "the sun's elevation above the horizon, degrees"),
            ParamInfo::new("sun_azimuth", 60.0, -180.0, 180.0, "the sun's azimuth from the street's far end (-z) towards +x, degrees"),
            ParamInfo::new("angular_diameter", 0.53, 0.0, 10.0, "the sun's angular diameter, degrees (0.53 for the real one; 0 = hard)"),
            ParamInfo::new("extent", 400.0, 100.0, 2000.0, "side of the terrain, metres").min_exclusive(),
        ],
    }
}

/// Builds `outdoor` from its parameter lookup.
pub(crate) fn build(value: &dyn Fn(&str) -> f64) -> Scene {
    let extent = value("extent") as f32;
    let mut b = Builder::new("outdoor");
    let ground = b.mesh(terrain(extent), "terrain");
    b.receiver(ground, Mat4::IDENTITY);
    let buildings = b.mesh(buildings(extent), "buildings");
    b.caster(buildings, Mat4::IDENTITY, true);
    let poles = b.mesh(poles_and_wires(extent), "poles and wires");
    b.caster(poles, Mat4::IDENTITY, true);
    let sun = sun(
        value("sun_elevation") as f32,
        value("sun_azimuth") as f32,
        value("angular_diameter") as f32,
        extent,
    );
    let eye = Vec3::new(2.0, height(2.0, 0.0) + 1.7, 0.0);
    let camera = Camera {
        eye,
        target: Vec3::new(0.0, eye.y, -100.0),
        up: Vec3::Y,
        fov_y_degrees: 60.0,
        near: 0.1,
        far: extent * 1.5,
    };
    b.finish(sun, camera)
}

/// The sun: travelling along the direction from (elevation, azimuth) towards the ground; light
/// space's origin set back along it beyond the scene, so every point has a positive light depth.
fn sun(elevation: f32, azimuth: f32, angular_diameter: f32, extent: f32) -> AreaLight {
    let (e, a) = (elevation.to_radians(), azimuth.to_radians());
    let towards_sun = Vec3::new(e.cos() * a.sin(), e.sin(), -e.cos() * a.cos());
    AreaLight {
        kind: LightKind::Sun,
        center: towards_sun * extent * 2.0,
        direction: -towards_sun,
        up: if elevation > 80.0 { Vec3::Z } else { Vec3::Y },
        angular_diameter_degrees: angular_diameter,
        ..AreaLight::default()
    }
}

/// Terrain height at (x, z): gentle hills, flat along the street (|x| < 70 m) so the buildings
/// and poles stand on it.
fn height(x: f32, z: f32) -> f32 {
    let hills = 6.0 * (x / 61.0).sin() * (z / 47.0).cos() + 2.5 * (x / 23.0 + z / 31.0).sin();
    let street = ((x.abs() - 70.0) / 60.0).clamp(0.0, 1.0);
    hills * street * street
}

/// The terrain: a `TERRAIN_CELLS`² height-field grid `extent` across, centred on the origin.
fn terrain(extent: f32) -> Mesh {
    let n = TERRAIN_CELLS;
    let mut mesh = Mesh::default();
    let step = extent / n as f32;
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (
                -extent * 0.5 + i as f32 * step,
                -extent * 0.5 + j as f32 * step,
            );
            mesh.positions.push(Vec3::new(x, height(x, z), z));
        }
    }
    let at = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            // Counter-clockwise seen from above: (i, j) -> (i, j+1) -> (i+1, j+1).
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            mesh.indices.extend_from_slice(&[a, d, c, a, c, b]);
        }
    }
    mesh.ensure_normals();
    mesh
}

/// 40 boxes in two rows along the street (x from ±12 to ±60 m), 6 to 20 m wide and 5 to 25 m high,
/// sunk 2 m into the ground.
fn buildings(extent: f32) -> Mesh {
    let mut rng = SplitMix64::new(39);
    let mut mesh = Mesh::default();
    let length = (extent * 0.45).min(180.0);
    for k in 0..40 {
        let side = if k % 2 == 0 { 1.0 } else { -1.0 };
        let size = Vec3::new(
            6.0 + 14.0 * rng.next_f32(),
            5.0 + 20.0 * rng.next_f32(),
            6.0 + 14.0 * rng.next_f32(),
        );
        let x = side * (12.0 + size.x * 0.5 + 30.0 * rng.next_f32());
        let z = -length + 2.0 * length * (k / 2) as f32 / 20.0 + 4.0 * rng.next_f32();
        let base = height(x, z) - 2.0;
        let block = primitives::cuboid(size + Vec3::Y * 2.0);
        let place = Mat4::from_translation(Vec3::new(x, base + (size.y + 2.0) * 0.5, z));
        crate::engine::append(&mut mesh, &block, place);
    }
    mesh
}

/// Utility poles every `POLE_SPACING` m at x = 7 along the street, each with a cross-arm, and three
/// 3 cm wires from arm to arm, each span sagging 0.4 m in four straight pieces.
fn poles_and_wires(extent: f32) -> Mesh {
    let mut mesh = Mesh::default();
    let length = (extent * 0.45).min(180.0);
    let count = (2.0 * length / POLE_SPACING) as i32;
    let pole_z = |k: i32| length - k as f32 * POLE_SPACING;
    let pole = primitives::cylinder(0.15, POLE_HEIGHT + 1.0, 8);
    let arm = primitives::cuboid(Vec3::new(2.0, 0.12, 0.12));
    for k in 0..=count {
        let base = Vec3::new(7.0, height(7.0, pole_z(k)), pole_z(k));
        let centre = base + Vec3::Y * (POLE_HEIGHT - 1.0) * 0.5;
        crate::engine::append(&mut mesh, &pole, Mat4::from_translation(centre));
        let top = base + Vec3::Y * (POLE_HEIGHT - 0.3);
        crate::engine::append(&mut mesh, &arm, Mat4::from_translation(top));
    }
    let wire = primitives::cuboid(Vec3::new(0.03, 1.0, 0.03));
    for k in 0..count {
        for offset in [-0.9, 0.0, 0.9] {
            let at = |z: f32| Vec3::new(7.0 + offset, height(7.0, z) + POLE_HEIGHT - 0.2, z);
            let (a, b) = (at(pole_z(k)), at(pole_z(k + 1)));
            for piece in 0..4 {
                let point = |t: f32| a.lerp(b, t) - Vec3::Y * 1.6 * t * (1.0 - t);
                let (t0, t1) = (piece as f32 / 4.0, (piece + 1) as f32 / 4.0);
                let segment = crate::engine::along(point(t0), point(t1));
                crate::engine::append(&mut mesh, &wire, segment);
            }
        }
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    fn defaults() -> Scene {
        let info = info();
        build(&|name: &str| info.params.iter().find(|p| p.name == name).unwrap().default)
    }

    #[test]
    fn outdoor_is_valid_large_and_lit_by_the_sun() {
        let scene = defaults();
        scene.validate().unwrap();
        assert_eq!(scene.light.kind, LightKind::Sun);
        let bounds = scene.bounds(|_| true);
        assert!(bounds.max.x - bounds.min.x >= 399.0, "{bounds:?}");
        assert!(scene.light.direction.y < 0.0, "the sun shines downwards");
        let wires = &scene.meshes[scene.instances[2].mesh];
        assert!(wires.triangle_count() > 100);
    }

    #[test]
    fn everything_stands_on_the_terrain() {
        let scene = defaults();
        // Poles are sunk 1 m, buildings 2 m, so no gap shows where they meet the slope.
        for (instance, sunk) in [(1, 2.0), (2, 1.0)] {
            let mesh = &scene.meshes[scene.instances[instance].mesh];
            for p in &mesh.positions {
                assert!(
                    p.y >= height(p.x, p.z) - sunk - 0.01,
                    "{}: {p} below ground",
                    mesh.name
                );
            }
        }
    }
}
