//! Builtin scenes: the set-ups of the papers this workbench reproduces, plus polygon-count
//! scaling scenes. Every scene is deterministic.
//!
//! All ground planes are 8 x 8 at y = 0, centred on the origin, and are receivers only
//! (`casts_shadow = false`). Lights face the receivers and every caster lies in front of the
//! light plane.

use glam::{Mat4, Quat, Vec3};
use softshadow_core::{AreaLight, Camera, Instance, Mesh, Scene};

use crate::primitives;
use crate::SceneError;

/// A builtin scene as a CLI lists it.
#[derive(Clone, Debug, PartialEq)]
pub struct BuiltinInfo {
    /// The id to pass to [`crate::load`] / [`crate::builtin()`], e.g. `atty-square`.
    pub id: &'static str,
    /// One line: what the scene shows and where it comes from.
    pub description: &'static str,
    /// Parameters accepted as `id:name=value,...`.
    pub params: Vec<ParamInfo>,
}

/// One numeric parameter of a builtin scene.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamInfo {
    /// Parameter name, as in `atty-square:occluder_height=1.5`.
    pub name: &'static str,
    /// Value when not given.
    pub default: f64,
    /// What it changes.
    pub description: &'static str,
    /// Smallest accepted value (excluded when `min_exclusive`).
    pub min: f64,
    /// Largest accepted value (included).
    pub max: f64,
    /// `min` itself is not accepted.
    pub min_exclusive: bool,
}

impl ParamInfo {
    pub(crate) const fn new(
        name: &'static str,
        default: f64,
        min: f64,
        max: f64,
        description: &'static str,
    ) -> Self {
        Self {
            name,
            default,
            description,
            min,
            max,
            min_exclusive: false,
        }
    }

    pub(crate) const fn min_exclusive(mut self) -> Self {
        self.min_exclusive = true;
        self
    }

    /// The accepted range in words, e.g. "use 0 to 4" or "use a value > 0 and <= 8".
    pub fn range_text(&self) -> String {
        if self.min_exclusive {
            format!("use a value > {} and <= {}", self.min, self.max)
        } else {
            format!("use {} to {}", self.min, self.max)
        }
    }

    /// Checks `value` for scene `scene`.
    pub fn check(&self, scene: &str, value: f64) -> Result<(), SceneError> {
        if !value.is_finite() {
            return Err(SceneError::ParameterNotFinite {
                name: self.name.into(),
                value,
            });
        }
        let above_min = if self.min_exclusive {
            value > self.min
        } else {
            value >= self.min
        };
        if above_min && value <= self.max {
            Ok(())
        } else {
            Err(SceneError::ParameterOutOfRange {
                scene: scene.into(),
                name: self.name.into(),
                value,
                expected: self.range_text(),
            })
        }
    }
}

const LIGHT_WIDTH_RANGE: (f64, f64) = (0.0, 4.0);
const TRIANGLES_RANGE: (f64, f64) = (1_000.0, 2_000_000.0);

pub(crate) fn light_width(default: f64) -> ParamInfo {
    ParamInfo::new(
        "light_width",
        default,
        LIGHT_WIDTH_RANGE.0,
        LIGHT_WIDTH_RANGE.1,
        "side of the square area light (0 = point light)",
    )
}

fn triangles(default: f64) -> ParamInfo {
    ParamInfo::new(
        "triangles",
        default,
        TRIANGLES_RANGE.0,
        TRIANGLES_RANGE.1,
        "target triangle count of the blob",
    )
}

/// Parameters of `atty-square`, in the same order as [`AttySquare`]'s fields.
fn atty_params() -> Vec<ParamInfo> {
    let d = AttySquare::default();
    vec![
        light_width(d.light_width),
        ParamInfo::new(
            "light_height",
            d.light_height,
            0.0,
            50.0,
            "height of the light plane above the ground; must exceed occluder_height",
        )
        .min_exclusive(),
        ParamInfo::new(
            "occluder_height",
            d.occluder_height,
            0.0,
            50.0,
            "height of the occluder square (0 = lying on the receiver); below light_height",
        ),
        ParamInfo::new(
            "occluder_size",
            d.occluder_size,
            0.0,
            8.0,
            "side of the occluder square",
        )
        .min_exclusive(),
        ParamInfo::new(
            "occluder_offset_x",
            d.occluder_offset_x,
            -3.0,
            3.0,
            "x position of the occluder centre",
        ),
    ]
}

/// Polygon-count scenes: id and total triangle count.
const POLYCOUNTS: [(&str, u32); 4] = [
    ("polycount-1k", 1_000),
    ("polycount-10k", 10_000),
    ("polycount-100k", 100_000),
    ("polycount-1m", 1_000_000),
];

/// Every builtin scene with its description and parameters.
pub fn builtin_scenes() -> Vec<BuiltinInfo> {
    let mut list = vec![
        BuiltinInfo {
            id: "atty-square",
            description: "Atty et al. 2006 sec. 4.2.1: a square occluder parallel to a square light over a ground plane (closed-form penumbra)",
            params: atty_params(),
        },
        BuiltinInfo {
            id: "blob-floating",
            description: "a closed bumpy blob (~100k triangles, self-shadowing) floating 0.6 above the ground",
            params: vec![light_width(1.2), triangles(100_000.0)],
        },
        BuiltinInfo {
            id: "blob-contact",
            description: "the blob of blob-floating resting on the ground (contact shadow, penumbra shrinking to zero)",
            params: vec![light_width(1.2), triangles(100_000.0)],
        },
        BuiltinInfo {
            id: "balls-3x3x3",
            description: "bitmask soft shadows paper Fig. 2: 27 spheres on a 3x3x3 grid, overlapping occluders",
            params: vec![light_width(1.5)],
        },
        BuiltinInfo {
            id: "single-silhouette",
            description: "bitmask soft shadows paper Fig. 9: a box under a large light, showing the single-silhouette artifact",
            params: vec![light_width(2.0)],
        },
        BuiltinInfo {
            id: "pdsm-cylinder",
            description: "PDSM paper Fig. 8a/8b: a standing cylinder lit from the side (Fig. 8b: light_width=1.5)",
            params: vec![light_width(0.4)],
        },
        BuiltinInfo {
            id: "pdsm-quads",
            description: "PDSM paper Fig. 8c: three quads at rising heights, penumbra width grows with blocker-receiver distance",
            params: vec![light_width(1.0)],
        },
    ];
    for (id, count) in POLYCOUNTS {
        list.push(BuiltinInfo {
            id,
            description: match count {
                1_000 => "2x2 blobs + ground, about 1k triangles in total (scaling series)",
                10_000 => "2x2 blobs + ground, about 10k triangles in total (scaling series)",
                100_000 => "2x2 blobs + ground, about 100k triangles in total (scaling series)",
                _ => "2x2 blobs + ground, about 1M triangles in total (scaling series)",
            },
            params: vec![light_width(1.2)],
        });
    }
    list.extend(crate::stiff::infos());
    list
}

/// Splits `id:key=value,key=value` into the id and its parameters. Values are parsed as `f64`
/// (NaN and infinities parse and are rejected later with a clearer message).
pub fn parse_spec(spec: &str) -> Result<(String, Vec<(String, f64)>), SceneError> {
    let (id, rest) = match spec.split_once(':') {
        Some((id, rest)) => (id.trim(), rest.trim()),
        None => (spec.trim(), ""),
    };
    let mut params: Vec<(String, f64)> = Vec::new();
    for item in rest.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let Some((key, value)) = item.split_once('=') else {
            return Err(SceneError::BadSpec {
                spec: spec.into(),
                detail: format!("parameter `{item}` has no value"),
            });
        };
        let (key, value) = (key.trim(), value.trim());
        if key.is_empty() {
            return Err(SceneError::BadSpec {
                spec: spec.into(),
                detail: format!("`{item}` has no parameter name"),
            });
        }
        if params.iter().any(|(k, _)| k == key) {
            return Err(SceneError::BadSpec {
                spec: spec.into(),
                detail: format!("parameter `{key}` is given twice"),
            });
        }
        let number = value
            .parse::<f64>()
            .map_err(|_| SceneError::ParameterNotANumber {
                scene: id.into(),
                name: key.into(),
                value: value.into(),
            })?;
        params.push((key.to_string(), number));
    }
    Ok((id.to_string(), params))
}

/// Resolves `params` against the declared parameters of `info`: rejects unknown names and
/// out-of-range values, fills in defaults. The result is in declaration order.
fn resolve(info: &BuiltinInfo, params: &[(String, f64)]) -> Result<Vec<f64>, SceneError> {
    for (name, _) in params {
        if !info.params.iter().any(|p| p.name == name) {
            let known = if info.params.is_empty() {
                "none".to_string()
            } else {
                info.params
                    .iter()
                    .map(|p| format!("`{}`", p.name))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            return Err(SceneError::UnknownParameter {
                scene: info.id.into(),
                name: name.clone(),
                known,
            });
        }
    }
    info.params
        .iter()
        .map(|p| {
            let value = params
                .iter()
                .rev()
                .find(|(name, _)| name == p.name)
                .map_or(p.default, |(_, v)| *v);
            p.check(info.id, value).map(|()| value)
        })
        .collect()
}

/// Builds builtin scene `id` with `params` (name, value); unnamed parameters take their
/// defaults. Meshes are not yet repaired and the scene is not yet validated: use
/// [`crate::builtin()`] for that.
pub fn build(id: &str, params: &[(String, f64)]) -> Result<Scene, SceneError> {
    let info = builtin_scenes()
        .into_iter()
        .find(|info| info.id == id)
        .ok_or_else(|| SceneError::UnknownScene { spec: id.into() })?;
    let values = resolve(&info, params)?;
    let value = |name: &str| {
        info.params
            .iter()
            .position(|p| p.name == name)
            .map_or(f64::NAN, |k| values[k])
    };
    let width = value("light_width") as f32;
    match id {
        "atty-square" => AttySquare {
            light_width: value("light_width"),
            light_height: value("light_height"),
            occluder_height: value("occluder_height"),
            occluder_size: value("occluder_size"),
            occluder_offset_x: value("occluder_offset_x"),
        }
        .scene(),
        "blob-floating" => Ok(blob_scene(id, width, value("triangles") as u32, false)),
        "blob-contact" => Ok(blob_scene(id, width, value("triangles") as u32, true)),
        "balls-3x3x3" => Ok(balls(width)),
        "single-silhouette" => Ok(single_silhouette(width)),
        "pdsm-cylinder" => Ok(pdsm_cylinder(width)),
        "pdsm-quads" => Ok(pdsm_quads(width)),
        _ if id.starts_with(crate::stiff::PREFIX) => crate::stiff::build(id, &value),
        _ => match POLYCOUNTS.iter().find(|(pid, _)| *pid == id) {
            Some(&(_, total)) => Ok(polycount(id, total, width)),
            None => Err(SceneError::UnknownScene { spec: id.into() }),
        },
    }
}

/// The set-up of Atty et al. 2006, sec. 4.2.1 ("Soft shadow maps: efficient sampling of light
/// source visibility"): a square occluder parallel to a square light above a ground plane, with
/// the occluder/receiver split. A closed-form penumbra test depends on this exact geometry:
///
/// * ground: plane 8 x 8 at y = 0, centred on the origin, receiver only;
/// * occluder: a zero-thickness, two-sided (4 triangles) axis-aligned square of side
///   `occluder_size` in the plane y = `occluder_height`, centred at (`occluder_offset_x`, _, 0),
///   caster only;
/// * light: centre (0, `light_height`, 0), facing -y, up +z, `light_width` x `light_width`;
/// * camera: eye (0, 3.2, 4.0), target (0, 0, 0.4), fov 45, near 0.05, far 50.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttySquare {
    /// Side of the square light, 0 to 4.
    pub light_width: f64,
    /// Height of the light above the ground, greater than `occluder_height`.
    pub light_height: f64,
    /// Height of the occluder, 0 (touching the receiver) up to `light_height` (excluded).
    pub occluder_height: f64,
    /// Side of the occluder square, > 0.
    pub occluder_size: f64,
    /// x of the occluder centre, -3 to 3.
    pub occluder_offset_x: f64,
}

impl Default for AttySquare {
    fn default() -> Self {
        Self {
            light_width: 1.0,
            light_height: 2.0,
            occluder_height: 1.0,
            occluder_size: 1.0,
            occluder_offset_x: 0.0,
        }
    }
}

impl AttySquare {
    /// Checks the parameters and builds the scene.
    pub fn scene(&self) -> Result<Scene, SceneError> {
        const ID: &str = "atty-square";
        let values = [
            self.light_width,
            self.light_height,
            self.occluder_height,
            self.occluder_size,
            self.occluder_offset_x,
        ];
        for (info, value) in atty_params().iter().zip(values) {
            info.check(ID, value)?;
        }
        if self.occluder_height >= self.light_height {
            return Err(SceneError::ParameterOutOfRange {
                scene: ID.into(),
                name: "occluder_height".into(),
                value: self.occluder_height,
                expected: format!(
                    "use 0 <= occluder_height < light_height (= {}), or raise light_height",
                    self.light_height
                ),
            });
        }
        let mut b = Builder::new(ID);
        b.ground();
        let size = self.occluder_size as f32;
        let occluder = b.mesh(primitives::two_sided_quad(size, size), "occluder square");
        b.caster(
            occluder,
            Mat4::from_translation(Vec3::new(
                self.occluder_offset_x as f32,
                self.occluder_height as f32,
                0.0,
            )),
            false,
        );
        let width = self.light_width as f32;
        Ok(b.finish(
            down_light(Vec3::new(0.0, self.light_height as f32, 0.0), width),
            camera(Vec3::new(0.0, 3.2, 4.0), Vec3::new(0.0, 0.0, 0.4)),
        ))
    }
}

/// Radius and centre height of the blob in `blob-floating` / `blob-contact`.
const BLOB_RADIUS: f32 = 0.6;
const BLOB_CENTER_Y: f32 = 1.2;

/// `blob-floating` / `blob-contact`: one bumpy closed blob (self-shadowing caster and receiver)
/// above or touching the ground. For `contact`, the lowest vertex lies exactly on y = 0.
fn blob_scene(id: &str, light_width: f32, triangles: u32, contact: bool) -> Scene {
    let mut b = Builder::new(id);
    b.ground();
    let mesh = primitives::blob(BLOB_RADIUS, triangles, 1);
    let lowest = mesh
        .positions
        .iter()
        .map(|p| p.y)
        .fold(f32::INFINITY, f32::min);
    let y = if contact { -lowest } else { BLOB_CENTER_Y };
    let blob = b.mesh(mesh, "blob");
    b.caster(blob, Mat4::from_translation(Vec3::Y * y), true);
    b.finish(
        down_light(Vec3::new(0.4, 4.0, 0.2), light_width),
        camera(Vec3::new(0.0, 3.0, 4.5), Vec3::new(0.0, 0.6, 0.0)),
    )
}

/// Bitmask soft shadows paper, Fig. 2: 27 UV spheres (radius 0.18) on a 3 x 3 x 3 grid with
/// spacing 0.55 centred at (0, 1.4, 0) under a 1.5 x 1.5 light: many overlapping occluders.
fn balls(light_width: f32) -> Scene {
    let mut b = Builder::new("balls-3x3x3");
    b.ground();
    let sphere = b.mesh(primitives::uv_sphere(0.18, 24), "ball");
    for i in -1..=1 {
        for j in -1..=1 {
            for k in -1..=1 {
                let offset = Vec3::new(i as f32, j as f32, k as f32) * 0.55;
                let t = Mat4::from_translation(Vec3::new(0.0, 1.4, 0.0) + offset);
                b.caster(sphere, t, true);
            }
        }
    }
    b.finish(
        down_light(Vec3::new(0.0, 4.0, 0.0), light_width),
        camera(Vec3::new(0.0, 3.4, 5.0), Vec3::new(0.0, 0.8, 0.0)),
    )
}

/// Bitmask soft shadows paper, Fig. 9 (single-silhouette artifact): a closed unit box with its
/// bottom at y = 0.4 under a large 2 x 2 light at height 3, so that side faces not seen from the
/// light centre still block part of the light.
fn single_silhouette(light_width: f32) -> Scene {
    let mut b = Builder::new("single-silhouette");
    b.ground();
    let cube = b.mesh(primitives::cuboid(Vec3::ONE), "box");
    b.caster(cube, Mat4::from_translation(Vec3::new(0.0, 0.9, 0.0)), true);
    b.finish(
        down_light(Vec3::new(0.0, 3.0, 0.0), light_width),
        camera(Vec3::new(2.2, 2.8, 3.4), Vec3::new(0.0, 0.4, 0.0)),
    )
}

/// PDSM paper, Fig. 8a/8b: a closed vertical cylinder (radius 0.25, height 1.4) standing on the
/// ground at the origin, lit from the side by a light at (2.5, 3, 0) aimed at (0, 0.3, 0).
/// Fig. 8a uses the default 0.4 light; Fig. 8b a larger one (`light_width=1.5`).
fn pdsm_cylinder(light_width: f32) -> Scene {
    let mut b = Builder::new("pdsm-cylinder");
    b.ground();
    let cylinder = b.mesh(primitives::cylinder(0.25, 1.4, 48), "cylinder");
    b.caster(cylinder, Mat4::from_translation(Vec3::Y * 0.7), true);
    let light = AreaLight::looking_at(
        Vec3::new(2.5, 3.0, 0.0),
        Vec3::new(0.0, 0.3, 0.0),
        light_width,
        light_width,
    );
    // The shadow falls towards -x: look at it from the front-left.
    b.finish(
        light,
        camera(Vec3::new(0.3, 2.6, 4.2), Vec3::new(-0.6, 0.3, 0.0)),
    )
}

/// PDSM paper, Fig. 8c: three zero-thickness two-sided horizontal quads (0.6 x 0.6) at heights
/// 0.25, 0.8 and 1.5 (x = -1.2, 0, 1.2) under a 1 x 1 light: the penumbra widens with the
/// blocker-receiver distance.
fn pdsm_quads(light_width: f32) -> Scene {
    let mut b = Builder::new("pdsm-quads");
    b.ground();
    let quad = b.mesh(primitives::two_sided_quad(0.6, 0.6), "quad");
    for (x, y) in [(-1.2, 0.25), (0.0, 0.8), (1.2, 1.5)] {
        b.caster(quad, Mat4::from_translation(Vec3::new(x, y, 0.0)), false);
    }
    b.finish(
        down_light(Vec3::new(0.0, 3.5, 0.0), light_width),
        camera(Vec3::new(0.0, 3.3, 4.2), Vec3::new(0.0, 0.3, 0.0)),
    )
}

/// `polycount-N`: a 2 x 2 arrangement of distinct blobs (radius 0.4, centres (±0.7, 1.0, ±0.7))
/// plus the 2-triangle ground, with `total` triangles in all (within a few percent).
fn polycount(id: &str, total: u32, light_width: f32) -> Scene {
    let mut b = Builder::new(id);
    b.ground();
    let per_blob = (total.saturating_sub(2) / 4).max(8);
    let mut seed = 11;
    for x in [-0.7f32, 0.7] {
        for z in [-0.7f32, 0.7] {
            let mesh = b.mesh(primitives::blob(0.4, per_blob, seed), "blob");
            seed += 1;
            b.caster(mesh, Mat4::from_translation(Vec3::new(x, 1.0, z)), true);
        }
    }
    b.finish(
        down_light(Vec3::new(0.0, 4.0, 0.0), light_width),
        camera(Vec3::new(0.0, 3.2, 4.5), Vec3::new(0.0, 0.6, 0.0)),
    )
}

/// A square light facing straight down, its +y (height edge) along world +z.
pub(crate) fn down_light(center: Vec3, width: f32) -> AreaLight {
    AreaLight {
        center,
        direction: Vec3::NEG_Y,
        up: Vec3::Z,
        width,
        height: width,
        ..AreaLight::default()
    }
}

/// The builtin cameras: fov 45, near 0.05, far 50, +y up.
pub(crate) fn camera(eye: Vec3, target: Vec3) -> Camera {
    Camera {
        eye,
        target,
        up: Vec3::Y,
        fov_y_degrees: 45.0,
        near: 0.05,
        far: 50.0,
    }
}

/// Small helper that collects meshes and instances.
pub(crate) struct Builder {
    name: String,
    meshes: Vec<Mesh>,
    instances: Vec<Instance>,
}

impl Builder {
    pub(crate) fn new(name: &str) -> Self {
        Self {
            name: name.into(),
            meshes: Vec::new(),
            instances: Vec::new(),
        }
    }

    pub(crate) fn mesh(&mut self, mut mesh: Mesh, name: &str) -> usize {
        mesh.name = name.into();
        self.meshes.push(mesh);
        self.meshes.len() - 1
    }

    /// The 8 x 8 ground plane at y = 0: receiver only.
    pub(crate) fn ground(&mut self) {
        let mesh = self.mesh(primitives::plane(8.0, 8.0), "ground");
        self.instances.push(Instance {
            casts_shadow: false,
            receives_shadow: true,
            ..Instance::new(mesh, Mat4::IDENTITY)
        });
    }

    /// A receiver that casts no shadow (a platform, a ceiling).
    pub(crate) fn receiver(&mut self, mesh: usize, transform: Mat4) {
        self.instances.push(Instance {
            casts_shadow: false,
            receives_shadow: true,
            ..Instance::new(mesh, transform)
        });
    }

    /// A caster; `receives` also makes it a receiver (self-shadowing).
    pub(crate) fn caster(&mut self, mesh: usize, transform: Mat4, receives: bool) {
        self.instances.push(Instance {
            albedo: Vec3::new(0.75, 0.55, 0.4),
            casts_shadow: true,
            receives_shadow: receives,
            ..Instance::new(mesh, transform)
        });
    }

    pub(crate) fn finish(self, light: AreaLight, camera: Camera) -> Scene {
        Scene {
            name: self.name,
            meshes: self.meshes,
            instances: self.instances,
            light,
            camera,
        }
    }
}

/// Object-to-world transform from translation, XYZ Euler angles in degrees and scale.
pub(crate) fn trs(translation: Vec3, rotation_degrees: Vec3, scale: Vec3) -> Mat4 {
    let r = rotation_degrees * (std::f32::consts::PI / 180.0);
    let rotation = Quat::from_euler(glam::EulerRot::XYZ, r.x, r.y, r.z);
    Mat4::from_scale_rotation_translation(scale, rotation, translation)
}
