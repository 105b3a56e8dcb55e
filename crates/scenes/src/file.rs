//! The TOML scene file format (documented with an example in `docs/SCENES.md`).
//!
//! ```toml
//! name = "two-boxes"
//! [light]
//! center = [0, 4, 0]
//! target = [0, 0, 0]
//! width = 1.0
//! [camera]
//! eye = [0, 3, 5]
//! target = [0, 0.5, 0]
//! [[object]]
//! plane = { size = [8, 8] }
//! casts_shadow = false
//! [[object]]
//! box = { size = [1, 1, 1] }
//! translation = [0, 0.5, 0]
//! ```
//!
//! Every table rejects unknown keys, so a typo is reported with its line.

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use serde::Deserialize;
use softshadow_core::{AreaLight, Camera, Instance, LightKind, Scene};

use crate::builtin::trs;
use crate::{primitives, SceneError};

/// A whole scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Scene name; defaults to the file stem.
    pub name: Option<String>,
    /// `[light]`.
    #[serde(default)]
    pub light: LightDef,
    /// `[camera]`.
    #[serde(default)]
    pub camera: CameraDef,
    /// The `[[object]]` array.
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectDef>,
    /// The `[[path]]` array: animations of this scene over time ([`crate::path`]).
    #[serde(default, rename = "path")]
    pub paths: Vec<crate::path::PathDef>,
}

/// `[light]`: an area light of one of the kinds (`kind`, default `rect`; docs/SCENES.md,
/// "Light kinds"). Give `direction` or `target`, not both (default: facing straight down; the
/// sun's `direction` is the direction its light travels and its `center` is ignored).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightDef {
    /// Centre of the light rectangle (default 0, 4, 0).
    #[serde(default = "LightDef::default_center")]
    pub center: [f32; 3],
    /// Direction the light faces.
    pub direction: Option<[f32; 3]>,
    /// A point the light faces (instead of `direction`).
    pub target: Option<[f32; 3]>,
    /// Light +y (the `height` edge); default +z for lights facing (nearly) straight up or down,
    /// +y otherwise.
    pub up: Option<[f32; 3]>,
    /// Edge along the light's x axis (default 1).
    #[serde(default = "one")]
    pub width: f32,
    /// Defaults to `width` (a square light).
    pub height: Option<f32>,
    /// Radiant scale of the light (default 1).
    #[serde(default = "one")]
    pub intensity: f32,
    /// `rect` (default), `disk`, `sphere`, `spot` or `sun`.
    pub kind: Option<String>,
    /// Radius of a disk, sphere or spot source (default 0.5; 0 is a point light).
    pub radius: Option<f32>,
    /// A spot's inner cone angle from its axis, degrees (default 30).
    pub cone_inner_degrees: Option<f32>,
    /// A spot's outer cone angle from its axis, degrees (default 45).
    pub cone_outer_degrees: Option<f32>,
    /// The sun's angular diameter, degrees (default 0.53; below 180).
    pub angular_diameter_degrees: Option<f32>,
}

impl LightDef {
    fn default_center() -> [f32; 3] {
        [0.0, 4.0, 0.0]
    }

    /// The light this table describes (defaults filled in); `path` names the file in the error.
    /// Used by scene files and by sweep files' `[light]`, so both take the same keys.
    pub fn to_light(&self, path: &str) -> Result<AreaLight, SceneError> {
        let center = Vec3::from(self.center);
        let direction = match (self.direction, self.target) {
            (Some(_), Some(_)) => {
                return Err(SceneError::SceneFile {
                    path: path.into(),
                    line: None,
                    message: "[light] gives both `direction` and `target`: keep only one".into(),
                })
            }
            (Some(d), None) => Vec3::from(d),
            (None, Some(t)) => Vec3::from(t) - center,
            (None, None) => Vec3::NEG_Y,
        };
        // Zero or non-finite directions are left for `AreaLight::validate` to report.
        let direction = direction.try_normalize().unwrap_or(direction);
        let up = self
            .up
            .map(Vec3::from)
            .unwrap_or(if direction.y.abs() > 0.9 {
                Vec3::Z
            } else {
                Vec3::Y
            });
        let defaults = AreaLight::default();
        Ok(AreaLight {
            center,
            direction,
            up,
            width: self.width,
            height: self.height.unwrap_or(self.width),
            intensity: self.intensity,
            kind: self.kind(path)?,
            radius: self.radius.unwrap_or(defaults.radius),
            cone_inner_degrees: self
                .cone_inner_degrees
                .unwrap_or(defaults.cone_inner_degrees),
            cone_outer_degrees: self
                .cone_outer_degrees
                .unwrap_or(defaults.cone_outer_degrees),
            angular_diameter_degrees: self
                .angular_diameter_degrees
                .unwrap_or(defaults.angular_diameter_degrees),
        })
    }

    /// The `kind` key (default `rect`); an unknown name names the kinds.
    fn kind(&self, path: &str) -> Result<LightKind, SceneError> {
        let Some(name) = self.kind.as_deref() else {
            return Ok(LightKind::Rect);
        };
        LightKind::from_name(name).ok_or_else(|| SceneError::SceneFile {
            path: path.into(),
            line: None,
            message: format!(
                "[light] kind = \"{name}\" is not a light kind: give one of {}",
                LightKind::names()
            ),
        })
    }
}

impl Default for LightDef {
    fn default() -> Self {
        Self {
            center: Self::default_center(),
            direction: None,
            target: None,
            up: None,
            width: 1.0,
            height: None,
            intensity: 1.0,
            kind: None,
            radius: None,
            cone_inner_degrees: None,
            cone_outer_degrees: None,
            angular_diameter_degrees: None,
        }
    }
}

/// `[camera]`; every field has a default.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraDef {
    /// Camera position.
    pub eye: [f32; 3],
    /// The point looked at.
    pub target: [f32; 3],
    /// Up direction.
    pub up: [f32; 3],
    /// Vertical field of view in degrees.
    pub fov_y_degrees: f32,
    /// Near clipping distance.
    pub near: f32,
    /// Far clipping distance.
    pub far: f32,
}

impl CameraDef {
    /// The camera this table describes (defaults filled in). Used by scene files and by sweep
    /// files' `[camera]`, so both take the same keys.
    pub fn to_camera(&self) -> Camera {
        Camera {
            eye: Vec3::from(self.eye),
            target: Vec3::from(self.target),
            up: Vec3::from(self.up),
            fov_y_degrees: self.fov_y_degrees,
            near: self.near,
            far: self.far,
        }
    }
}

impl Default for CameraDef {
    fn default() -> Self {
        Self {
            eye: [0.0, 3.0, 5.0],
            target: [0.0, 0.5, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y_degrees: 45.0,
            near: 0.05,
            far: 100.0,
        }
    }
}

/// `scale = 2.0` or `scale = [1, 2, 1]`.
#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(untagged)]
pub enum ScaleDef {
    /// The same factor on every axis.
    Uniform(f32),
    /// One factor per axis.
    PerAxis([f32; 3]),
}

impl ScaleDef {
    pub(crate) fn to_vec3(self) -> Vec3 {
        match self {
            ScaleDef::Uniform(s) => Vec3::splat(s),
            ScaleDef::PerAxis(v) => Vec3::from(v),
        }
    }
}

/// One `[[object]]`: exactly one mesh source plus placement and shadow flags.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectDef {
    /// Object name (for messages).
    pub name: Option<String>,
    /// A plane mesh.
    pub plane: Option<PlaneDef>,
    /// A box mesh (`box = { ... }` in the file).
    #[serde(rename = "box")]
    pub cuboid: Option<BoxDef>,
    /// A sphere mesh.
    pub sphere: Option<SphereDef>,
    /// A random blob mesh.
    pub blob: Option<BlobDef>,
    /// A cylinder mesh.
    pub cylinder: Option<CylinderDef>,
    /// Path of a `.gltf`/`.glb` file, relative to the scene file (or absolute).
    pub gltf: Option<PathBuf>,
    /// Translation (default 0).
    #[serde(default)]
    pub translation: [f32; 3],
    /// Rotation about x, then y, then z, in degrees (default 0).
    #[serde(default)]
    pub rotation_degrees: [f32; 3],
    /// Scale: one number or one per axis (default 1).
    pub scale: Option<ScaleDef>,
    /// Linear RGB albedo in [0, 1] (default light grey).
    #[serde(default = "default_albedo")]
    pub albedo: [f32; 3],
    /// Casts shadows (default true).
    #[serde(default = "yes")]
    pub casts_shadow: bool,
    /// Receives shadows (default true).
    #[serde(default = "yes")]
    pub receives_shadow: bool,
    /// Moves between frames (default false): precomputes over static casters leave it out.
    #[serde(default)]
    pub dynamic: bool,
    /// Its material (`[object.material]`: colour, texture, alpha mode; docs/SCENES.md). A glTF
    /// object without one keeps the file's own materials.
    pub material: Option<crate::file_material::MaterialDef>,
}

/// `plane = { size = [sx, sz] }`: facing +y at the object's origin.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneDef {
    /// Extent along x and z.
    pub size: [f32; 2],
}

/// `box = { size = [x, y, z] }`: centred on the object's origin.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxDef {
    /// Extent along x, y and z.
    pub size: [f32; 3],
}

/// `sphere = { radius, segments = 32 }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereDef {
    /// Radius.
    pub radius: f32,
    /// Segments around (default 32).
    #[serde(default = "default_segments")]
    pub segments: u32,
}

/// `blob = { radius, triangles = 20000, seed = 1 }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlobDef {
    /// Mean radius.
    pub radius: f32,
    /// Triangle count (default 20000).
    #[serde(default = "default_blob_triangles")]
    pub triangles: u32,
    /// Random seed (default 1).
    #[serde(default = "one_u64")]
    pub seed: u64,
}

/// `cylinder = { radius, height, segments = 32 }`: axis +y, centred on the object's origin.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderDef {
    /// Radius.
    pub radius: f32,
    /// Height along y.
    pub height: f32,
    /// Segments around (default 32).
    #[serde(default = "default_segments")]
    pub segments: u32,
}

fn one() -> f32 {
    1.0
}
fn one_u64() -> u64 {
    1
}
fn yes() -> bool {
    true
}
fn default_albedo() -> [f32; 3] {
    [0.8, 0.8, 0.8]
}
fn default_segments() -> u32 {
    32
}
fn default_blob_triangles() -> u32 {
    20_000
}

/// Parses scene-file text. `path` is only used in error messages.
pub fn parse(text: &str, path: &Path) -> Result<SceneFile, SceneError> {
    toml::from_str(text).map_err(|e| SceneError::SceneFile {
        path: path.display().to_string(),
        line: e.span().map(|span| line_of(text, span.start)),
        message: crate::error::one_line(e.message()),
    })
}

/// 1-based line of byte `offset`; an offset at the end of the text (an unexpected end of file)
/// counts as the last non-blank line.
fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.trim_end().len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Builds the scene described by `file`, resolving glTF paths relative to `path`'s directory.
/// Returns the (unrepaired, unvalidated) scene and the warnings of any glTF import.
pub fn build(file: &SceneFile, path: &Path) -> Result<(Scene, Vec<String>), SceneError> {
    let shown = path.display().to_string();
    let base = path.parent().unwrap_or_else(|| Path::new("."));
    let name = file.name.clone().unwrap_or_else(|| {
        path.file_stem()
            .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned())
    });
    let mut scene = Scene {
        materials: Vec::new(),
        textures: Vec::new(),
        name,
        meshes: Vec::new(),
        instances: Vec::new(),
        light: file.light.to_light(&shown)?,
        camera: file.camera.to_camera(),
    };
    let mut warnings = Vec::new();
    let origin = format!("scene file `{shown}`");
    crate::check_instances(file.objects.len(), &origin)?;
    // Triangles so far (every instance counted), checked before each object is built.
    let mut triangles = 0usize;
    for (k, object) in file.objects.iter().enumerate() {
        let object_error = |message: String| SceneError::SceneObject {
            path: shown.clone(),
            index: k + 1,
            name: object.name.clone(),
            message,
        };
        let transform = object_transform(object);
        let template = Instance {
            albedo: Vec3::from(object.albedo),
            casts_shadow: object.casts_shadow,
            receives_shadow: object.receives_shadow,
            dynamic: object.dynamic,
            ..Instance::new(0, transform)
        };
        let label = object
            .name
            .clone()
            .unwrap_or_else(|| format!("object {}", k + 1));
        triangles = triangles.saturating_add(expected_triangles(object));
        crate::check_triangles(triangles, &origin)?;
        let first_instance = scene.instances.len();
        match mesh_source(object).map_err(&object_error)? {
            Source::Procedural(mut mesh) => {
                mesh.name = label.clone();
                scene.meshes.push(mesh);
                scene.instances.push(Instance {
                    mesh: scene.meshes.len() - 1,
                    ..template
                });
            }
            Source::Gltf(relative) => {
                let gltf_path = base.join(relative);
                let geometry =
                    crate::gltf_import::load_gltf(&gltf_path).map_err(|e| match e {
                        SceneError::FileNotFound { path, .. } => object_error(format!(
                            "glTF file `{path}` not found: check the path (relative paths start at the scene file's folder)"
                        )),
                        other => other,
                    })?;
                let instanced: usize = geometry
                    .instances
                    .iter()
                    .map(|(mesh, _)| geometry.meshes[*mesh].triangle_count())
                    .sum();
                triangles = triangles.saturating_add(instanced);
                crate::check_triangles(triangles, &origin)?;
                crate::check_instances(scene.instances.len() + geometry.instances.len(), &origin)?;
                let first = scene.meshes.len();
                let first_material =
                    crate::file_material::append_gltf(&mut scene, geometry.materials);
                scene.meshes.extend(geometry.meshes);
                for (mesh, node_transform) in geometry.instances {
                    scene.instances.push(Instance {
                        mesh: first + mesh,
                        transform: transform * node_transform,
                        material: geometry.mesh_materials[mesh].map(|m| first_material + m),
                        ..template.clone()
                    });
                }
                warnings.extend(geometry.warnings);
            }
        }
        if let Some(material) = &object.material {
            let instances = first_instance..scene.instances.len();
            let applied =
                crate::file_material::apply(&mut scene, instances, material, object.albedo, base)
                    .map_err(&object_error)?;
            warnings.extend(applied.into_iter().map(|w| format!("{label}: {w}")));
        }
    }
    Ok((scene, warnings))
}

/// Triangles a procedural `[[object]]` will have, computed before it is built (0 for glTF, which
/// is counted once read, and for invalid sources, which `mesh_source` rejects).
fn expected_triangles(object: &ObjectDef) -> usize {
    if object.plane.is_some() {
        2
    } else if object.cuboid.is_some() {
        12
    } else if let Some(s) = &object.sphere {
        let segments = s.segments.max(3);
        primitives::latitude_longitude_triangles((segments / 2).max(2), segments)
    } else if let Some(b) = &object.blob {
        b.triangles as usize
    } else if let Some(c) = &object.cylinder {
        4 * c.segments.max(3) as usize
    } else {
        0
    }
}

enum Source<'a> {
    Procedural(softshadow_core::Mesh),
    Gltf(&'a Path),
}

/// Checks that exactly one mesh source is given, that its sizes are usable, and builds it.
fn mesh_source(object: &ObjectDef) -> Result<Source<'_>, String> {
    let given: Vec<&str> = [
        ("plane", object.plane.is_some()),
        ("box", object.cuboid.is_some()),
        ("sphere", object.sphere.is_some()),
        ("blob", object.blob.is_some()),
        ("cylinder", object.cylinder.is_some()),
        ("gltf", object.gltf.is_some()),
    ]
    .into_iter()
    .filter_map(|(name, set)| set.then_some(name))
    .collect();
    if given.len() != 1 {
        return Err(format!(
            "found {} mesh sources ({}): give exactly one of plane, box, sphere, blob, cylinder or gltf",
            given.len(),
            if given.is_empty() { "none".into() } else { given.join(", ") }
        ));
    }
    let positive = |what: &str, values: &[f32]| {
        if values.iter().all(|v| v.is_finite() && *v > 0.0) {
            Ok(())
        } else {
            Err(format!("{what} must be finite and > 0, got {values:?}"))
        }
    };
    let segments = |n: u32| {
        if (3..=4096).contains(&n) {
            Ok(())
        } else {
            Err(format!("segments = {n} is out of range: use 3 to 4096"))
        }
    };
    let mesh = if let Some(p) = &object.plane {
        positive("plane size", &p.size)?;
        primitives::plane(p.size[0], p.size[1])
    } else if let Some(b) = &object.cuboid {
        positive("box size", &b.size)?;
        primitives::cuboid(Vec3::from(b.size))
    } else if let Some(s) = &object.sphere {
        positive("sphere radius", &[s.radius])?;
        segments(s.segments)?;
        primitives::uv_sphere(s.radius, s.segments)
    } else if let Some(b) = &object.blob {
        positive("blob radius", &[b.radius])?;
        let (lo, hi) = primitives::BLOB_TRIANGLES_RANGE;
        if !(lo..=hi).contains(&b.triangles) {
            return Err(format!(
                "blob triangles = {} is out of range: use {lo} to {hi}",
                b.triangles
            ));
        }
        primitives::blob(b.radius, b.triangles, b.seed)
    } else if let Some(c) = &object.cylinder {
        positive("cylinder radius and height", &[c.radius, c.height])?;
        segments(c.segments)?;
        primitives::cylinder(c.radius, c.height, c.segments)
    } else if let Some(path) = &object.gltf {
        return Ok(Source::Gltf(path));
    } else {
        unreachable!("exactly one source was checked above")
    };
    Ok(Source::Procedural(mesh))
}

/// The transform a `[[object]]` applies (exposed for tests and tools).
pub fn object_transform(object: &ObjectDef) -> Mat4 {
    trs(
        Vec3::from(object.translation),
        Vec3::from(object.rotation_degrees),
        object.scale.map_or(Vec3::ONE, ScaleDef::to_vec3),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The triangle count checked before building is the built mesh's (found by `cargo
    /// mutants`: the limit test's spheres are refused either way, by `finalize` if not before
    /// building). Spheres of 8 and 7 segments have 4 and 3 rings (2 * 8 * 3 = 48, 2 * 7 * 2 =
    /// 28 triangles), a cylinder 4 per segment; a blob counts what was asked for.
    #[test]
    fn expected_triangles_match_the_built_meshes() {
        let text = r#"
[[object]]
plane = { size = [1, 2] }
[[object]]
box = { size = [1, 2, 3] }
[[object]]
sphere = { radius = 1, segments = 8 }
[[object]]
sphere = { radius = 1, segments = 7 }
[[object]]
cylinder = { radius = 1, height = 2, segments = 5 }
[[object]]
blob = { radius = 1, triangles = 500 }
[[object]]
gltf = "model.glb"
"#;
        let file = parse(text, Path::new("t.toml")).unwrap();
        let expected: Vec<usize> = file.objects.iter().map(expected_triangles).collect();
        assert_eq!(expected, [2, 12, 48, 28, 20, 500, 0]);
        for (object, &count) in file.objects[..5].iter().zip(&expected) {
            match mesh_source(object).unwrap() {
                Source::Procedural(mesh) => assert_eq!(mesh.triangle_count(), count),
                Source::Gltf(_) => unreachable!(),
            }
        }
    }
}
