//! Paths: a scene animated over time, what the benchmark's motion runs render frame by frame
//! (docs/MOTION.md; the format in docs/SCENES.md, "Paths").
//!
//! A [`Path`] moves three things, each by keyframes over `[0, duration]` seconds (or not at all):
//!
//! * the camera: keyframes (eye, target, up) or an orbit about the vertical axis through the
//!   scene camera's target;
//! * the light: keyframes of its centre, orientation, width and height;
//! * `dynamic = true` instances: keyframes of their transform (translation, rotation, scale).
//!
//! Interpolation: linear for positions, sizes, scales and camera vectors; spherical linear
//! (slerp, the shorter arc) for orientations (the light's frame, an instance's rotation). Before
//! the first keyframe a track holds its first value, after the last its last one.
//!
//! Built-in paths ([`BUILTIN_PATHS`]) are made for any scene from its own camera, light and
//! casters ([`resolve`]). A path file is TOML ([`PathDef`]); a scene file may declare paths as
//! `[[path]]` tables.

use std::path::Path as FilePath;

use glam::{Mat3, Mat4, Quat, Vec3};
use serde::Deserialize;
use softshadow_core::{AreaLight, Camera, Scene};

use crate::file::ScaleDef;
use crate::SceneError;

/// The built-in paths (name, what moves), made for every scene by [`resolve`].
pub const BUILTIN_PATHS: [(&str, &str); 4] = [
    (
        "still",
        "nothing moves: every frame is the scene's own view (a deterministic technique's flicker is 0)",
    ),
    (
        "orbit",
        "the camera turns 90 degrees about the vertical axis through its target; light and casters stand still (camera-only frames)",
    ),
    (
        "light-sweep",
        "the light holds, then slides sideways by 0.3 of its distance to the casters while turning to keep aiming at the same point and growing 1.25x wide, 0.8x high; then holds (light-space work redone; the hold measures lag)",
    ),
    (
        "object-move",
        "a dynamic caster slides along x by its own width over the static receiver, then holds; a scene without a dynamic instance has its first caster made dynamic",
    ),
];

/// Seconds every built-in path lasts.
pub const BUILTIN_DURATION: f32 = 2.0;

/// Most keyframes one track may hold (a typo multiplying keys fails early).
pub const MAX_KEYS: usize = 100_000;

/// An animation of a scene over `[0, duration]` seconds.
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    /// Its name (a built-in's, a `[[path]]`'s `name`, or a path file's stem).
    pub name: String,
    /// Seconds from the first frame to the last.
    pub duration: f32,
    /// How the camera moves.
    pub camera: CameraTrack,
    /// Keyframes of the light (empty: the scene's light stands still).
    pub light: Vec<LightKey>,
    /// Keyframes of dynamic instances' transforms.
    pub objects: Vec<ObjectTrack>,
}

/// How the camera moves along a path.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraTrack {
    /// The scene's camera, every frame.
    Fixed,
    /// The scene's camera turned about the vertical (+y) axis through its target, from 0 at
    /// time 0 to `degrees` at the end, at a constant rate.
    Orbit {
        /// The whole turn, degrees.
        degrees: f32,
    },
    /// Keyframes (eye, target and up interpolated linearly; field of view, near and far are the
    /// scene camera's).
    Keys(Vec<CameraKey>),
}

/// A camera keyframe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraKey {
    /// Seconds.
    pub time: f32,
    /// Camera position.
    pub eye: Vec3,
    /// The point looked at.
    pub target: Vec3,
    /// Up direction.
    pub up: Vec3,
}

/// A light keyframe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightKey {
    /// Seconds.
    pub time: f32,
    /// Centre of the light rectangle.
    pub center: Vec3,
    /// Rotation from light space to world space (its columns are [`AreaLight::basis`]).
    pub orientation: Quat,
    /// Extent along light space x.
    pub width: f32,
    /// Extent along light space y.
    pub height: f32,
    /// Radius of a disk, sphere or spot light (`None`: the scene's).
    pub radius: Option<f32>,
    /// The sun's angular diameter, degrees (`None`: the scene's).
    pub angular_diameter_degrees: Option<f32>,
}

impl LightKey {
    /// The light at this key: `scene_light` (its kind, cone and intensity) placed and sized here.
    fn light(&self, scene_light: &AreaLight) -> AreaLight {
        AreaLight {
            center: self.center,
            direction: self.orientation * Vec3::Z,
            up: self.orientation * Vec3::Y,
            width: self.width,
            height: self.height,
            radius: self.radius.unwrap_or(scene_light.radius),
            angular_diameter_degrees: self
                .angular_diameter_degrees
                .unwrap_or(scene_light.angular_diameter_degrees),
            ..*scene_light
        }
    }
}

/// Keyframes of one instance's transform.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectTrack {
    /// Index into [`Scene::instances`]; the instance must be `dynamic`.
    pub instance: usize,
    /// Its keyframes, by time.
    pub keys: Vec<TransformKey>,
}

/// A transform keyframe: object to world = translation * rotation * scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransformKey {
    /// Seconds.
    pub time: f32,
    /// Translation.
    pub translation: Vec3,
    /// Rotation.
    pub rotation: Quat,
    /// Scale per axis.
    pub scale: Vec3,
}

/// What a path shows at one time.
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    /// The camera.
    pub camera: Camera,
    /// The light.
    pub light: AreaLight,
    /// (instance index, object-to-world transform) of every instance the path moves.
    pub transforms: Vec<(usize, Mat4)>,
}

impl Pose {
    /// Puts this pose into `scene` (camera, light, moved transforms).
    pub fn apply(&self, scene: &mut Scene) {
        scene.camera = self.camera;
        scene.light = self.light;
        for &(index, transform) in &self.transforms {
            if let Some(instance) = scene.instances.get_mut(index) {
                instance.transform = transform;
            }
        }
    }
}

/// The light's frame as a rotation from light space (x, y, z) to world space.
pub fn light_orientation(light: &AreaLight) -> Quat {
    let (x, y, z) = light.basis();
    Quat::from_mat3(&Mat3::from_cols(x, y, z)).normalize()
}

/// Index of the keyframe segment holding `t` and the fraction of the way through it.
fn segment(times: &[f32], t: f32) -> (usize, usize, f32) {
    let last = times.len() - 1;
    if t <= times[0] {
        return (0, 0, 0.0);
    }
    if t >= times[last] {
        return (last, last, 0.0);
    }
    let next = times.partition_point(|&k| k <= t).min(last);
    let prev = next - 1;
    let span = times[next] - times[prev];
    (prev, next, ((t - times[prev]) / span).clamp(0.0, 1.0))
}

impl Path {
    /// The time of frame `k` of `frames` at fixed steps: the first frame at 0, the last at
    /// `duration` (one frame: 0).
    pub fn frame_time(&self, k: u32, frames: u32) -> f32 {
        if frames <= 1 {
            return 0.0;
        }
        self.duration * k as f32 / (frames - 1) as f32
    }

    /// What the path shows at time `t` (seconds) of `scene` (the scene's camera and light where
    /// the path does not move them).
    pub fn pose(&self, scene: &Scene, t: f32) -> Pose {
        let camera = match &self.camera {
            CameraTrack::Fixed => scene.camera,
            CameraTrack::Orbit { degrees } => {
                let fraction = if self.duration > 0.0 {
                    (t / self.duration).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let rotation = Quat::from_axis_angle(Vec3::Y, (degrees * fraction).to_radians());
                let c = scene.camera;
                Camera {
                    eye: c.target + rotation * (c.eye - c.target),
                    up: rotation * c.up,
                    ..c
                }
            }
            CameraTrack::Keys(keys) => {
                let times: Vec<f32> = keys.iter().map(|k| k.time).collect();
                let (a, b, f) = segment(&times, t);
                let (a, b) = (keys[a], keys[b]);
                Camera {
                    eye: a.eye.lerp(b.eye, f),
                    target: a.target.lerp(b.target, f),
                    up: a.up.lerp(b.up, f),
                    ..scene.camera
                }
            }
        };
        let light = if self.light.is_empty() {
            scene.light
        } else {
            let times: Vec<f32> = self.light.iter().map(|k| k.time).collect();
            let (a, b, f) = segment(&times, t);
            let (a, b) = (self.light[a], self.light[b]);
            let orientation = a.orientation.slerp(b.orientation, f).normalize();
            let (la, lb) = (a.light(&scene.light), b.light(&scene.light));
            // Every kind's size interpolates (a sun's angular diameter, a disk's radius).
            AreaLight {
                center: a.center.lerp(b.center, f),
                direction: orientation * Vec3::Z,
                up: orientation * Vec3::Y,
                width: a.width + (b.width - a.width) * f,
                height: a.height + (b.height - a.height) * f,
                radius: la.radius + (lb.radius - la.radius) * f,
                angular_diameter_degrees: la.angular_diameter_degrees
                    + (lb.angular_diameter_degrees - la.angular_diameter_degrees) * f,
                ..scene.light
            }
        };
        let transforms = self
            .objects
            .iter()
            .map(|track| {
                let times: Vec<f32> = track.keys.iter().map(|k| k.time).collect();
                let (a, b, f) = segment(&times, t);
                let (a, b) = (track.keys[a], track.keys[b]);
                let transform = Mat4::from_scale_rotation_translation(
                    a.scale.lerp(b.scale, f),
                    a.rotation.slerp(b.rotation, f).normalize(),
                    a.translation.lerp(b.translation, f),
                );
                (track.instance, transform)
            })
            .collect();
        Pose {
            camera,
            light,
            transforms,
        }
    }

    /// Checks the path against `scene`: finite values, keyframe times increasing within
    /// `[0, duration]`, every moved instance present and `dynamic`, and every keyframe's camera
    /// and light valid.
    pub fn check(&self, scene: &Scene) -> Result<(), SceneError> {
        if !(self.duration.is_finite() && self.duration >= 0.0 && self.duration <= 1e6) {
            return Err(self.fail(format!(
                "duration {} is not a number of seconds from 0 to 1e6",
                self.duration
            )));
        }
        self.check_camera(scene)?;
        self.check_light(scene)?;
        self.check_objects(scene)
    }

    /// What is wrong with this path.
    fn fail(&self, message: String) -> SceneError {
        SceneError::Path {
            name: self.name.clone(),
            message,
        }
    }

    /// `what`'s keyframe times: at least one, at most [`MAX_KEYS`], increasing, within
    /// `[0, duration]`.
    fn check_times(&self, what: &str, times: Vec<f32>) -> Result<(), SceneError> {
        if times.is_empty() {
            return Err(self.fail(format!("{what} has no keyframe: give at least one")));
        }
        if times.len() > MAX_KEYS {
            return Err(self.fail(format!(
                "{what} has {} keyframes, more than {MAX_KEYS}",
                times.len()
            )));
        }
        for (k, &time) in times.iter().enumerate() {
            if !time.is_finite() || time < 0.0 || time > self.duration {
                return Err(self.fail(format!(
                    "{what}: keyframe {} has time {time}, outside 0 to the duration ({}); give times within it or a longer duration",
                    k + 1,
                    self.duration
                )));
            }
            if k > 0 && time <= times[k - 1] {
                return Err(self.fail(format!(
                    "{what}: keyframe {} (time {time}) does not come after the one before it; list keyframes in increasing time",
                    k + 1
                )));
            }
        }
        Ok(())
    }

    /// A finite orbit, or camera keyframes each a valid camera (with `scene`'s lens).
    fn check_camera(&self, scene: &Scene) -> Result<(), SceneError> {
        match &self.camera {
            CameraTrack::Fixed => {}
            CameraTrack::Orbit { degrees } => {
                if !degrees.is_finite() || degrees.abs() > 1e5 {
                    return Err(
                        self.fail(format!("orbit of {degrees} degrees: give a finite turn"))
                    );
                }
            }
            CameraTrack::Keys(keys) => {
                self.check_times("the camera", keys.iter().map(|k| k.time).collect())?;
                for (k, key) in keys.iter().enumerate() {
                    Camera {
                        eye: key.eye,
                        target: key.target,
                        up: key.up,
                        ..scene.camera
                    }
                    .validate()
                    .map_err(|e| self.fail(format!("camera keyframe {}: {e}", k + 1)))?;
                }
            }
        }
        Ok(())
    }

    /// Light keyframes, if any, each a valid light (with `scene`'s intensity).
    fn check_light(&self, scene: &Scene) -> Result<(), SceneError> {
        if self.light.is_empty() {
            return Ok(());
        }
        self.check_times("the light", self.light.iter().map(|k| k.time).collect())?;
        for (k, key) in self.light.iter().enumerate() {
            let light = key.light(&scene.light);
            if !key.orientation.is_finite() {
                return Err(self.fail(format!(
                    "light keyframe {}: its orientation is not finite",
                    k + 1
                )));
            }
            light
                .validate()
                .map_err(|e| self.fail(format!("light keyframe {}: {e}", k + 1)))?;
        }
        Ok(())
    }

    /// Every moved instance present in `scene` and `dynamic`, its keyframes finite with a
    /// positive scale.
    fn check_objects(&self, scene: &Scene) -> Result<(), SceneError> {
        for track in &self.objects {
            let what = format!("instance {}", track.instance);
            let Some(instance) = scene.instances.get(track.instance) else {
                return Err(self.fail(format!(
                    "{what} does not exist: the scene has {} instances (numbered from 0)",
                    scene.instances.len()
                )));
            };
            if !instance.dynamic {
                return Err(self.fail(format!(
                    "{what} is not dynamic: set `dynamic = true` on its object so that precomputes over static casters leave it out"
                )));
            }
            self.check_times(&what, track.keys.iter().map(|k| k.time).collect())?;
            for (k, key) in track.keys.iter().enumerate() {
                let finite = key.translation.is_finite()
                    && key.rotation.is_finite()
                    && key.scale.is_finite();
                if !finite || key.scale.min_element() <= 0.0 {
                    return Err(self.fail(format!(
                        "{what} keyframe {}: translation, rotation and a positive scale must be finite",
                        k + 1
                    )));
                }
            }
        }
        Ok(())
    }

    /// Whether frame pose `b` differs from `a` in the light or a moved instance (light-space work
    /// must be redone), and whether the camera differs.
    pub fn changes(a: &Pose, b: &Pose) -> (bool, bool) {
        let light = a.light != b.light || a.transforms != b.transforms;
        (light, a.camera != b.camera)
    }
}

/// `[[path]]` in a scene file, or a whole path file: see docs/SCENES.md, "Paths".
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathDef {
    /// The path's name (required in a scene file; a path file's default is its stem).
    pub name: Option<String>,
    /// Seconds from the first frame to the last (default 1).
    #[serde(default = "one")]
    pub duration: f32,
    /// Turn the scene's camera this many degrees about the vertical axis through its target
    /// over the path (instead of `[[camera]]` keyframes).
    pub orbit_degrees: Option<f32>,
    /// Camera keyframes.
    #[serde(default)]
    pub camera: Vec<CameraKeyDef>,
    /// Light keyframes.
    #[serde(default)]
    pub light: Vec<LightKeyDef>,
    /// Keyframes of dynamic instances.
    #[serde(default)]
    pub object: Vec<ObjectTrackDef>,
}

/// `[[camera]]` keyframe of a path.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraKeyDef {
    /// Seconds.
    pub time: f32,
    /// Camera position.
    pub eye: [f32; 3],
    /// The point looked at.
    pub target: [f32; 3],
    /// Up (default +y).
    pub up: Option<[f32; 3]>,
}

/// `[[light]]` keyframe of a path. Give `direction` or `target`, not both.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightKeyDef {
    /// Seconds.
    pub time: f32,
    /// Centre of the light rectangle.
    pub center: [f32; 3],
    /// Direction the light faces.
    pub direction: Option<[f32; 3]>,
    /// A point the light faces.
    pub target: Option<[f32; 3]>,
    /// Light +y hint (default as in a scene file's `[light]`).
    pub up: Option<[f32; 3]>,
    /// Extent along light x (a rect light; default 1).
    #[serde(default = "one")]
    pub width: f32,
    /// Extent along light y (default `width`).
    pub height: Option<f32>,
    /// Radius of a disk, sphere or spot light (default: the scene's).
    pub radius: Option<f32>,
    /// The sun's angular diameter in degrees (default: the scene's).
    pub angular_diameter_degrees: Option<f32>,
}

fn one() -> f32 {
    1.0
}

impl LightKeyDef {
    /// The keyframe this table describes; the error (keyframe `number`, from 1) says what to fix.
    fn to_key(&self, number: usize) -> Result<LightKey, String> {
        let center = Vec3::from(self.center);
        let direction = match (self.direction, self.target) {
            (Some(_), Some(_)) => {
                return Err(format!(
                    "light keyframe {number}: give `direction` or `target`, not both"
                ))
            }
            (Some(d), None) => Vec3::from(d),
            (None, Some(target)) => Vec3::from(target) - center,
            (None, None) => Vec3::NEG_Y,
        };
        if !(direction.length_squared() > 1e-12 && direction.is_finite()) {
            return Err(format!(
                "light keyframe {number}: the direction is zero or not finite"
            ));
        }
        let direction = direction.normalize();
        let up = self.up.map_or(
            if direction.y.abs() > 0.9 {
                Vec3::Z
            } else {
                Vec3::Y
            },
            Vec3::from,
        );
        let frame = AreaLight {
            center,
            direction,
            up,
            width: self.width,
            height: self.height.unwrap_or(self.width),
            ..AreaLight::default()
        };
        Ok(LightKey {
            time: self.time,
            center,
            orientation: light_orientation(&frame),
            width: frame.width,
            height: frame.height,
            radius: self.radius,
            angular_diameter_degrees: self.angular_diameter_degrees,
        })
    }
}

/// `[[object]]` of a path: one dynamic instance's keyframes.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectTrackDef {
    /// Index of the instance in the scene (from 0, in object order).
    pub instance: usize,
    /// `[[object.key]]` keyframes.
    pub key: Vec<TransformKeyDef>,
}

/// A transform keyframe of a path's `[[object]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformKeyDef {
    /// Seconds.
    pub time: f32,
    /// Translation (default 0).
    #[serde(default)]
    pub translation: [f32; 3],
    /// Rotation about x, then y, then z, degrees (default 0).
    #[serde(default)]
    pub rotation_degrees: [f32; 3],
    /// One factor or one per axis (default 1).
    pub scale: Option<ScaleDef>,
}

impl PathDef {
    /// The path this definition describes, named `default_name` when it has no `name`.
    pub fn to_path(&self, default_name: &str) -> Result<Path, SceneError> {
        let name = self.name.clone().unwrap_or_else(|| default_name.into());
        let fail = |message: String| SceneError::Path {
            name: name.clone(),
            message,
        };
        let camera = match (self.orbit_degrees, self.camera.is_empty()) {
            (Some(_), false) => {
                return Err(fail(
                    "give `orbit_degrees` or `[[camera]]` keyframes, not both".into(),
                ))
            }
            (Some(degrees), true) => CameraTrack::Orbit { degrees },
            (None, true) => CameraTrack::Fixed,
            (None, false) => CameraTrack::Keys(
                self.camera
                    .iter()
                    .map(|k| CameraKey {
                        time: k.time,
                        eye: k.eye.into(),
                        target: k.target.into(),
                        up: k.up.map_or(Vec3::Y, Vec3::from),
                    })
                    .collect(),
            ),
        };
        let light = (self.light.iter().enumerate())
            .map(|(k, key)| key.to_key(k + 1).map_err(&fail))
            .collect::<Result<Vec<_>, _>>()?;
        let objects = self
            .object
            .iter()
            .map(|track| ObjectTrack {
                instance: track.instance,
                keys: track
                    .key
                    .iter()
                    .map(|k| {
                        let r = Vec3::from(k.rotation_degrees) * (std::f32::consts::PI / 180.0);
                        TransformKey {
                            time: k.time,
                            translation: k.translation.into(),
                            rotation: Quat::from_euler(glam::EulerRot::XYZ, r.x, r.y, r.z),
                            scale: k.scale.map_or(Vec3::ONE, ScaleDef::to_vec3),
                        }
                    })
                    .collect(),
            })
            .collect();
        Ok(Path {
            name,
            duration: self.duration,
            camera,
            light,
            objects,
        })
    }
}

/// Reads a path file (`.toml`, [`PathDef`] at its top level; named by its stem unless it says).
pub fn load_path_file(path: &FilePath) -> Result<Path, SceneError> {
    let bytes = crate::read_file(path, "path file")?;
    let shown = path.display().to_string();
    let text = String::from_utf8(bytes).map_err(|_| SceneError::Path {
        name: shown.clone(),
        message: "the file is not UTF-8 text: save it as UTF-8".into(),
    })?;
    let def: PathDef = toml::from_str(&text).map_err(|e| SceneError::Path {
        name: shown.clone(),
        message: crate::error::one_line(e.message()),
    })?;
    let stem = path
        .file_stem()
        .map_or_else(|| "path".into(), |s| s.to_string_lossy().into_owned());
    def.to_path(&stem)
}

/// The path `spec` names for `scene`: a built-in ([`BUILTIN_PATHS`]), a path declared by the
/// scene's file (`declared`), or a `.toml` path file. The path is checked against the scene.
///
/// `object-move` moves the scene's dynamic instances; a scene without one has its first caster
/// made `dynamic` here (in `scene`), so the run measures a dynamic caster over a static receiver.
pub fn resolve(spec: &str, scene: &mut Scene, declared: &[Path]) -> Result<Path, SceneError> {
    let spec = spec.trim();
    let path = if spec.to_ascii_lowercase().ends_with(".toml") {
        load_path_file(FilePath::new(spec))?
    } else if let Some(found) = declared.iter().find(|p| p.name == spec) {
        found.clone()
    } else {
        builtin_path(spec, scene)?
    };
    path.check(scene)?;
    Ok(path)
}

/// Built-in path `name` made for `scene` (see [`BUILTIN_PATHS`]; `object-move` may mark the first
/// caster dynamic, [`resolve`]).
pub fn builtin_path(name: &str, scene: &mut Scene) -> Result<Path, SceneError> {
    let fixed = |camera| Path {
        name: name.into(),
        duration: BUILTIN_DURATION,
        camera,
        light: Vec::new(),
        objects: Vec::new(),
    };
    match name {
        "still" => Ok(fixed(CameraTrack::Fixed)),
        "orbit" => Ok(fixed(CameraTrack::Orbit { degrees: 90.0 })),
        "light-sweep" => Ok(Path {
            light: light_sweep_keys(scene),
            ..fixed(CameraTrack::Fixed)
        }),
        "object-move" => Ok(Path {
            objects: object_move_tracks(name, scene)?,
            ..fixed(CameraTrack::Fixed)
        }),
        _ => Err(SceneError::Path {
            name: name.into(),
            message: format!(
                "not a built-in path ({}), nor a path the scene file declares, nor a .toml path file",
                BUILTIN_PATHS.map(|(n, _)| n).join(", ")
            ),
        }),
    }
}

/// `light-sweep`'s keyframes: the scene's light, then the light moved sideways by 0.3 of its
/// distance to the casters (still aimed at the same point) and stretched 1.25 x 0.8.
fn light_sweep_keys(scene: &Scene) -> Vec<LightKey> {
    let light = scene.light;
    let casters = scene.bounds(|i| i.casts_shadow);
    let aim_distance = if casters.is_empty() {
        1.0
    } else {
        (0.5 * (casters.min + casters.max) - light.center)
            .dot(light.direction.normalize_or(Vec3::NEG_Y))
            .max(0.1)
    };
    let (x, _, z) = light.basis();
    let aim = light.center + z * aim_distance;
    let center = light.center + x * (0.3 * aim_distance);
    let moved = AreaLight {
        center,
        direction: (aim - center).normalize(),
        up: light.basis().1,
        ..light
    };
    let key = |time, l: &AreaLight, grow: (f32, f32)| LightKey {
        time,
        center: l.center,
        orientation: light_orientation(l),
        width: light.width * grow.0,
        height: light.height * grow.1,
        radius: Some(light.radius * grow.0),
        angular_diameter_degrees: Some(light.angular_diameter_degrees * grow.0),
    };
    let d = BUILTIN_DURATION;
    vec![
        key(0.15 * d, &light, (1.0, 1.0)),
        key(0.65 * d, &moved, (1.25, 0.8)),
    ]
}

/// `object-move`'s tracks: every dynamic caster of `scene` (else its first caster, made
/// dynamic) slides along x by its size.
fn object_move_tracks(name: &str, scene: &mut Scene) -> Result<Vec<ObjectTrack>, SceneError> {
    let mut moving: Vec<usize> = (0..scene.instances.len())
        .filter(|&i| scene.instances[i].dynamic && scene.instances[i].casts_shadow)
        .collect();
    if moving.is_empty() {
        let first = scene
            .instances
            .iter()
            .position(|i| i.casts_shadow)
            .ok_or_else(|| SceneError::Path {
                name: name.into(),
                message: format!(
                    "scene `{}` has no caster to move: use `orbit` or `light-sweep`",
                    scene.name
                ),
            })?;
        scene.instances[first].dynamic = true;
        moving.push(first);
    }
    Ok(moving
        .into_iter()
        .map(|index| sliding_track(scene, index))
        .collect())
}

/// Instance `index` of `scene` sliding along x from half its size (at least 0.2) one way to half
/// its size the other, over 0.7 of the path.
fn sliding_track(scene: &Scene, index: usize) -> ObjectTrack {
    let instance = &scene.instances[index];
    let (scale, rotation, translation) = instance.transform.to_scale_rotation_translation();
    let mut bounds = softshadow_core::Aabb::EMPTY;
    for p in &scene.meshes[instance.mesh].positions {
        bounds.extend(instance.transform.transform_point3(*p));
    }
    let size = if bounds.is_empty() {
        0.2
    } else {
        (bounds.max - bounds.min).max_element().max(0.2)
    };
    let key = |time, offset: f32| TransformKey {
        time,
        translation: translation + Vec3::X * offset,
        rotation,
        scale,
    };
    let d = BUILTIN_DURATION;
    ObjectTrack {
        instance: index,
        keys: vec![key(0.0, -0.5 * size), key(0.7 * d, 0.5 * size)],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use softshadow_core::LightKind;

    fn scene() -> Scene {
        crate::builtin("atty-square", &[]).unwrap()
    }

    #[test]
    fn keyframes_interpolate_linearly_and_orientations_by_slerp() {
        let mut s = scene();
        let path = builtin_path("light-sweep", &mut s).unwrap();
        path.check(&s).unwrap();
        // Before the first key and after the last the light holds.
        assert_eq!(path.pose(&s, 0.0).light.center, s.light.center);
        let end = path.pose(&s, path.duration).light;
        // atty-square: light at height 2, occluder at 1: slide 0.3 along light x.
        let (x, _, _) = s.light.basis();
        assert!((end.center - (s.light.center + 0.3 * x)).length() < 1e-5);
        assert!((end.width - 1.25).abs() < 1e-6 && (end.height - 0.8).abs() < 1e-6);
        // Halfway through the motion: centre and sizes half way, direction at half the angle.
        let mid = path.pose(&s, 0.8).light;
        assert!((mid.center - (s.light.center + 0.15 * x)).length() < 1e-5);
        assert!((mid.width - 1.125).abs() < 1e-6);
        let full = s.light.direction.angle_between(end.direction);
        let half = s.light.direction.angle_between(mid.direction);
        assert!((full - 0.3f32.atan()).abs() < 1e-4, "{full}");
        assert!((half - 0.5 * full).abs() < 1e-4, "{half} {full}");
    }

    #[test]
    fn every_kinds_size_interpolates_and_the_kind_stays_the_scenes() {
        let mut s = scene();
        for kind in [LightKind::Disk, LightKind::Sun] {
            s.light = s.light.as_kind(kind);
            let path = builtin_path("light-sweep", &mut s).unwrap();
            path.check(&s).unwrap();
            // light-sweep grows the first size 1.25 times: a radius, an angular diameter.
            let (start, mid, end) = (
                path.pose(&s, 0.0).light,
                path.pose(&s, 0.8).light,
                path.pose(&s, path.duration).light,
            );
            assert!([start.kind, mid.kind, end.kind].iter().all(|k| *k == kind));
            let size = |l: &AreaLight| match kind {
                LightKind::Sun => l.angular_diameter_degrees,
                _ => l.radius,
            };
            let base = size(&s.light);
            assert!((size(&end) - 1.25 * base).abs() < 1e-5 * base.max(1.0));
            assert!((size(&mid) - 1.125 * base).abs() < 1e-5 * base.max(1.0));
            assert_eq!(mid.cone_outer_degrees, s.light.cone_outer_degrees);
        }
    }

    #[test]
    fn orbit_turns_the_camera_only_and_still_moves_nothing() {
        let mut s = scene();
        let orbit = builtin_path("orbit", &mut s).unwrap();
        let start = orbit.pose(&s, 0.0);
        let end = orbit.pose(&s, orbit.duration);
        assert_eq!(start.camera, s.camera);
        let (a, b) = (
            s.camera.eye - s.camera.target,
            end.camera.eye - s.camera.target,
        );
        assert!((a.length() - b.length()).abs() < 1e-5);
        assert!(
            (Vec3::new(a.x, 0.0, a.z).angle_between(Vec3::new(b.x, 0.0, b.z)) - 90f32.to_radians())
                .abs()
                < 1e-4
        );
        assert_eq!(Path::changes(&start, &end), (false, true));
        let still = builtin_path("still", &mut s).unwrap();
        assert_eq!(still.pose(&s, 0.0), still.pose(&s, 2.0));
    }

    #[test]
    fn object_move_makes_the_first_caster_dynamic_and_slides_it() {
        let mut s = scene();
        assert!(!s.instances.iter().any(|i| i.dynamic));
        let path = resolve("object-move", &mut s, &[]).unwrap();
        let moved = path.objects[0].instance;
        assert!(s.instances[moved].dynamic && s.instances[moved].casts_shadow);
        let start = path.pose(&s, 0.0).transforms[0].1;
        let end = path.pose(&s, path.duration).transforms[0].1;
        // The 1 x 1 occluder slides from x = -0.5 to 0.5 at its height.
        assert!((start.w_axis.truncate() - Vec3::new(-0.5, 1.0, 0.0)).length() < 1e-6);
        assert!((end.w_axis.truncate() - Vec3::new(0.5, 1.0, 0.0)).length() < 1e-6);
        assert_eq!(
            Path::changes(&path.pose(&s, 0.0), &path.pose(&s, 1.0)),
            (true, false)
        );
    }

    #[test]
    fn path_files_parse_and_bad_ones_say_what_to_fix() {
        let mut s = scene();
        s.instances[1].dynamic = true;
        let def: PathDef = toml::from_str(
            r#"
            duration = 2.0
            [[camera]]
            time = 0.0
            eye = [0, 3, 4]
            target = [0, 0, 0]
            [[camera]]
            time = 2.0
            eye = [2, 3, 4]
            target = [0, 0, 0]
            [[light]]
            time = 0.0
            center = [0, 2, 0]
            width = 1.0
            [[object]]
            instance = 1
            [[object.key]]
            time = 1.0
            translation = [0, 1, 0]
            scale = 2.0
            "#,
        )
        .unwrap();
        let path = def.to_path("mine").unwrap();
        path.check(&s).unwrap();
        let pose = path.pose(&s, 1.0);
        assert_eq!(pose.camera.eye, Vec3::new(1.0, 3.0, 4.0));
        assert!((pose.light.direction - Vec3::NEG_Y).length() < 1e-6);
        assert_eq!(
            pose.transforms[0].1,
            Mat4::from_scale_rotation_translation(Vec3::splat(2.0), Quat::IDENTITY, Vec3::Y)
        );
        // A static instance cannot move; a key past the duration and keys out of order fail.
        s.instances[1].dynamic = false;
        let message = path.check(&s).unwrap_err().to_string();
        assert!(
            message.contains("not dynamic") && message.contains("dynamic = true"),
            "{message}"
        );
        let mut late = path.clone();
        late.duration = 0.5;
        assert!(late
            .check(&scene())
            .unwrap_err()
            .to_string()
            .contains("outside 0 to the duration"));
        let mut backwards = path.clone();
        backwards.objects.clear();
        if let CameraTrack::Keys(keys) = &mut backwards.camera {
            keys[1].time = 0.0;
        }
        assert!(backwards
            .check(&scene())
            .unwrap_err()
            .to_string()
            .contains("increasing time"));
        assert!(builtin_path("nope", &mut s)
            .unwrap_err()
            .to_string()
            .contains("light-sweep"));
    }

    #[test]
    fn a_scene_file_declares_paths_by_name() {
        let text = r#"
            [[object]]
            plane = { size = [8, 8] }
            casts_shadow = false
            [[object]]
            box = { size = [1, 1, 1] }
            translation = [0, 1, 0]
            dynamic = true
            [[path]]
            name = "lift"
            duration = 2.0
            [[path.object]]
            instance = 1
            [[path.object.key]]
            time = 0.0
            translation = [0, 1, 0]
            [[path.object.key]]
            time = 2.0
            translation = [0, 2, 0]
        "#;
        let mut loaded =
            crate::load_scene_bytes(text.as_bytes(), FilePath::new("lift.toml")).unwrap();
        assert_eq!(loaded.paths.len(), 1);
        let path = resolve("lift", &mut loaded.scene, &loaded.paths).unwrap();
        let mid = path.pose(&loaded.scene, 1.0).transforms[0].1;
        assert!((mid.w_axis.truncate() - Vec3::new(0.0, 1.5, 0.0)).length() < 1e-6);
        // A path without a name cannot be found: refused with what to do.
        let nameless = text.replace("name = \"lift\"", "");
        let message = crate::load_scene_bytes(nameless.as_bytes(), FilePath::new("lift.toml"))
            .unwrap_err()
            .to_string();
        assert!(message.contains("has no `name`"), "{message}");
    }
}
