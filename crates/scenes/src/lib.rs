//! Scenes for the soft-shadow workbench: builtin paper set-ups, procedural primitives, TOML
//! scene files and glTF 2.0 models, all producing a validated [`softshadow_core::Scene`].
//!
//! Entry point: [`load`], which accepts
//! * a builtin id, optionally with parameters: `atty-square`,
//!   `atty-square:occluder_height=1.5,light_width=0.2` (see [`builtin_scenes`]);
//! * a `.toml` scene file (format in `docs/SCENES.md` and [`file`](mod@file));
//! * a `.gltf` / `.glb` model, wrapped into a scene (see [`wrap_gltf`]).
//!
//! Every loaded scene has had [`Mesh::repair`] run on all meshes (what was dropped becomes a
//! warning) and has passed [`Scene::validate`].

#![warn(missing_docs)]

pub mod builtin;
pub mod engine;
mod error;
pub mod file;
pub mod file_material;
pub mod gltf_export;
pub mod gltf_import;
mod gltf_lights;
pub mod gltf_materials;
pub mod limits;
pub mod materials;
pub mod outdoor;
pub mod path;
pub mod primitives;
pub mod stiff;
pub mod textures;

use std::path::Path;

use glam::{Mat4, Vec3};
use softshadow_core::{AreaLight, Camera, Instance, LightKind, Mesh, MeshRepair, Scene};

pub use builtin::{builtin_scenes, AttySquare, BuiltinInfo, ParamInfo};
pub use error::SceneError;
pub use gltf_import::{load_gltf, parse_gltf, GltfGeometry};

/// A loaded, repaired and validated scene with what the loader had to fix or skip.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The scene.
    pub scene: Scene,
    /// One line each, e.g. "mesh `x` from file.glb: dropped 3 degenerate and 2 non-finite
    /// triangles".
    pub warnings: Vec<String>,
    /// Paths the scene file declares (`[[path]]`, [`path`]); empty for other scenes.
    pub paths: Vec<path::Path>,
}

/// A scene spec `glb:SPEC` is builtin scene `SPEC` written as a `.glb`
/// ([`gltf_export::builtin_as_glb`]) and read back through the glTF loader: how the load
/// benchmark times real glTF files of millions of triangles without committing them.
pub const GLB_PREFIX: &str = "glb:";

/// Loads a scene from a builtin id (`id` or `id:key=value,...`), a `.toml` scene file, a
/// `.gltf` / `.glb` model or `glb:` and a builtin id ([`GLB_PREFIX`]).
pub fn load(spec: &str) -> Result<Loaded, SceneError> {
    let spec = spec.trim();
    if let Some(builtin_spec) = spec.strip_prefix(GLB_PREFIX) {
        let path = gltf_export::builtin_as_glb(builtin_spec)?;
        let geometry = load_gltf(&path)?;
        return load_gltf_geometry(&path, geometry);
    }
    let path = Path::new(spec);
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match extension.as_deref() {
        Some("toml") => load_scene_file(path),
        Some("gltf" | "glb") => {
            let geometry = load_gltf(path)?;
            load_gltf_geometry(path, geometry)
        }
        _ if path.is_file() => Err(SceneError::UnsupportedFile { path: spec.into() }),
        _ => {
            let (spec_without_kind, kind) = split_light_kind(spec)?;
            let (id, params) = builtin::parse_spec(&spec_without_kind)?;
            let mut scene = builtin::build(&id, &params)?;
            if let Some(kind) = kind {
                scene.light = scene.light.as_kind(kind);
            }
            finalize(scene, &format!("builtin scene `{id}`"))
        }
    }
}

/// Takes `light=KIND` out of a builtin spec (`atty-square:light=disk,light_width=2`): the
/// scene's light made that kind as the light-kind bounds take it ([`AreaLight::as_kind`]), so
/// a sweep can run the paper scenes under every kind.
///
/// [`AreaLight::as_kind`]: softshadow_core::AreaLight::as_kind
fn split_light_kind(spec: &str) -> Result<(String, Option<LightKind>), SceneError> {
    let Some((id, rest)) = spec.split_once(':') else {
        return Ok((spec.to_string(), None));
    };
    let mut kind = None;
    let mut kept = Vec::new();
    for item in rest.split(',') {
        match item.split_once('=') {
            Some((key, value)) if key.trim() == "light" => {
                let name = value.trim();
                kind = Some(
                    LightKind::from_name(name).ok_or_else(|| SceneError::BadSpec {
                        spec: spec.into(),
                        detail: format!(
                            "light `{name}` is not a light kind: use {}",
                            LightKind::names()
                        ),
                    })?,
                );
            }
            _ => kept.push(item),
        }
    }
    Ok((format!("{id}:{}", kept.join(",")), kind))
}

/// Builds builtin scene `id` with parameters given as (name, value); missing parameters take
/// their defaults. The result is repaired and validated; procedural meshes never need repair,
/// so any repair warning is only logged.
pub fn builtin(id: &str, params: &[(String, f64)]) -> Result<Scene, SceneError> {
    let loaded = finalize(
        builtin::build(id, params)?,
        &format!("builtin scene `{id}`"),
    )?;
    for warning in &loaded.warnings {
        log::warn!("{warning}");
    }
    Ok(loaded.scene)
}

/// Loads a `.gltf` / `.glb` model held in memory as [`load`] loads the file `path` (wrapped
/// into a scene, repaired, validated). With `external_buffers`, buffers in other files are
/// read next to `path`; without, they are refused (only embedded data and the GLB binary chunk
/// are read: how the fuzz targets load untrusted bytes without touching the file system).
pub fn load_gltf_bytes(
    bytes: &[u8],
    path: &Path,
    external_buffers: bool,
) -> Result<Loaded, SceneError> {
    let base = external_buffers.then(|| path.parent().unwrap_or_else(|| Path::new(".")));
    let geometry = parse_gltf(bytes, base, path)?;
    load_gltf_geometry(path, geometry)
}

fn load_gltf_geometry(path: &Path, geometry: GltfGeometry) -> Result<Loaded, SceneError> {
    let mut scene = wrap_gltf(path, geometry.meshes, &geometry.instances);
    // A model with lights (`KHR_lights_punctual`) is lit by its first, not the one made for it.
    if let Some(light) = geometry.lights.first() {
        scene.light = *light;
    }
    // The model's instances come first, in `geometry.instances`' order (the ground after).
    for (instance, &(mesh, _)) in scene.instances.iter_mut().zip(&geometry.instances) {
        instance.material = geometry.mesh_materials.get(mesh).copied().flatten();
    }
    scene.materials = geometry.materials.materials;
    scene.textures = geometry.materials.textures;
    let mut loaded = finalize(scene, &format!("glTF file `{}`", path.display()))?;
    let mut warnings = geometry.warnings;
    warnings.append(&mut loaded.warnings);
    loaded.warnings = warnings;
    Ok(loaded)
}

/// Loads a `.toml` scene file (see [`file`](mod@file) and `docs/SCENES.md`).
pub fn load_scene_file(path: impl AsRef<Path>) -> Result<Loaded, SceneError> {
    let path = path.as_ref();
    let bytes = read_file(path, "scene file")?;
    load_scene_bytes(&bytes, path)
}

/// Loads scene-file bytes as [`load_scene_file`] loads the file `path` (glTF objects are resolved
/// relative to `path`'s folder).
pub fn load_scene_bytes(bytes: &[u8], path: &Path) -> Result<Loaded, SceneError> {
    let text = std::str::from_utf8(bytes).map_err(|_| SceneError::SceneFile {
        path: path.display().to_string(),
        line: None,
        message: "is not UTF-8 text: save it as UTF-8".into(),
    })?;
    let def = file::parse(text, path)?;
    let (scene, mut warnings) = file::build(&def, path)?;
    let mut loaded = finalize(scene, &format!("scene file `{}`", path.display()))?;
    warnings.append(&mut loaded.warnings);
    loaded.warnings = warnings;
    for (k, declared) in def.paths.iter().enumerate() {
        let Some(name) = &declared.name else {
            return Err(SceneError::Path {
                name: format!("{} [[path]] {}", path.display(), k + 1),
                message: "has no `name`: name it so `--path NAME` can find it".into(),
            });
        };
        let made = declared.to_path(name)?;
        made.check(&loaded.scene)?;
        loaded.paths.push(made);
    }
    Ok(loaded)
}

/// Repairs every mesh (turning what was dropped into warnings naming the mesh and `source`),
/// computes missing normals and validates the scene. `source` says where the scene came from,
/// e.g. "scene file `x.toml`"; it starts every warning and the validation error.
pub fn finalize(mut scene: Scene, source: &str) -> Result<Loaded, SceneError> {
    check_instances(scene.instances.len(), source)?;
    check_triangles(scene.triangle_count(), source)?;
    let mut warnings = Vec::new();
    for mesh in &mut scene.meshes {
        let had_triangles = !mesh.indices.is_empty();
        let repair = mesh.repair();
        warnings.extend(repair_warnings(&mesh.name, source, &repair));
        if had_triangles && mesh.indices.is_empty() {
            warnings.push(format!(
                "mesh `{}` from {source}: no triangles left after repair; it will not be drawn",
                mesh.name
            ));
        }
    }
    scene.validate().map_err(|message| SceneError::Invalid {
        origin: source.to_string(),
        message,
    })?;
    Ok(Loaded {
        scene,
        warnings,
        paths: Vec::new(),
    })
}

/// Turns a repair report into a warning such as
/// "mesh `x` from file.glb: dropped 3 degenerate and 2 non-finite triangles" (none if nothing
/// was dropped).
pub fn repair_warnings(mesh: &str, source: &str, repair: &MeshRepair) -> Option<String> {
    let parts: Vec<String> = [
        (repair.degenerate_triangles, "degenerate"),
        (repair.non_finite_triangles, "non-finite"),
        (repair.out_of_range_triangles, "out-of-range"),
    ]
    .into_iter()
    .filter(|(count, _)| *count > 0)
    .map(|(count, kind)| format!("{count} {kind}"))
    .collect();
    let list = match parts.as_slice() {
        [] => return None,
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    };
    let noun = if repair.total() == 1 {
        "triangle"
    } else {
        "triangles"
    };
    Some(format!(
        "mesh `{mesh}` from {source}: dropped {list} {noun}"
    ))
}

/// Wraps glTF geometry into a scene: every node use becomes a caster + receiver instance; a
/// square ground plane (4 x the model's largest extent, receiver only) is put under the model's
/// bounds (at their lowest y); a square light of 0.3 x that extent faces straight down from
/// 2 extents above the top; the camera looks at the bounds' centre from the front (+z) and above.
pub fn wrap_gltf(path: &Path, mut meshes: Vec<Mesh>, instances: &[(usize, Mat4)]) -> Scene {
    let name = path
        .file_stem()
        .map_or_else(|| "gltf".into(), |s| s.to_string_lossy().into_owned());
    let mut scene = Scene {
        materials: Vec::new(),
        textures: Vec::new(),
        name,
        meshes: Vec::new(),
        instances: instances
            .iter()
            .map(|&(mesh, transform)| Instance::new(mesh, transform))
            .collect(),
        light: AreaLight::default(),
        camera: Camera::default(),
    };
    scene.meshes.append(&mut meshes);
    let bounds = scene.bounds(|_| true);
    let (min, max) = if bounds.is_empty() {
        (Vec3::ZERO, Vec3::ZERO)
    } else {
        (bounds.min, bounds.max)
    };
    let extent = (max - min).max_element().max(1e-3);
    let center = (min + max) * 0.5;
    let ground = softshadow_core::Mesh {
        name: "ground".into(),
        ..primitives::plane(4.0 * extent, 4.0 * extent)
    };
    scene.meshes.push(ground);
    scene.instances.push(Instance {
        casts_shadow: false,
        receives_shadow: true,
        ..Instance::new(
            scene.meshes.len() - 1,
            Mat4::from_translation(Vec3::new(center.x, min.y, center.z)),
        )
    });
    scene.light = AreaLight {
        center: Vec3::new(center.x, max.y + 2.0 * extent, center.z),
        direction: Vec3::NEG_Y,
        up: Vec3::Z,
        width: 0.3 * extent,
        height: 0.3 * extent,
        ..AreaLight::default()
    };
    scene.camera = Camera {
        eye: center + Vec3::new(0.0, 1.2, 2.0) * extent,
        target: center,
        up: Vec3::Y,
        fov_y_degrees: 45.0,
        near: 0.01 * extent,
        far: 50.0 * extent,
    };
    scene
}

/// Fails with [`SceneError::Limit`] when a scene would have more than
/// [`limits::MAX_TRIANGLES`] triangles (counted per instance). `origin` says where from.
pub(crate) fn check_triangles(triangles: usize, origin: &str) -> Result<(), SceneError> {
    if triangles <= limits::MAX_TRIANGLES {
        return Ok(());
    }
    Err(SceneError::Limit {
        origin: origin.into(),
        what: format!("the triangle count ({triangles}, every instance counted)"),
        limit: format!(
            "{} triangles (limits::MAX_TRIANGLES)",
            limits::MAX_TRIANGLES
        ),
        advice: "decimate the model or use fewer instances".into(),
    })
}

/// Fails with [`SceneError::Limit`] above [`limits::MAX_INSTANCES`] instances.
pub(crate) fn check_instances(instances: usize, origin: &str) -> Result<(), SceneError> {
    if instances <= limits::MAX_INSTANCES {
        return Ok(());
    }
    Err(SceneError::Limit {
        origin: origin.into(),
        what: format!("the instance count ({instances})"),
        limit: format!(
            "{} instances (limits::MAX_INSTANCES)",
            limits::MAX_INSTANCES
        ),
        advice: "merge meshes or use fewer node uses / objects".into(),
    })
}

/// Checks that `path` is a regular file no larger than [`limits::MAX_FILE_BYTES`] (a device such
/// as `/dev/zero` or a FIFO would never end), describing it as `kind` in errors.
pub(crate) fn check_file(path: &Path, kind: &'static str) -> Result<(), SceneError> {
    let shown = path.display().to_string();
    let metadata = std::fs::metadata(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => SceneError::FileNotFound {
            kind,
            path: shown.clone(),
        },
        _ => SceneError::Io {
            path: shown.clone(),
            message: error::one_line(&e.to_string()),
        },
    })?;
    if !metadata.is_file() {
        return Err(SceneError::NotAFile { kind, path: shown });
    }
    if metadata.len() > limits::MAX_FILE_BYTES {
        return Err(SceneError::Limit {
            origin: format!("{kind} `{shown}`"),
            what: format!("the file size ({} bytes)", metadata.len()),
            limit: format!("{} bytes (limits::MAX_FILE_BYTES)", limits::MAX_FILE_BYTES),
            advice: "split or decimate the model".into(),
        });
    }
    Ok(())
}

/// Reads a whole file after [`check_file`]; a missing file becomes
/// [`SceneError::FileNotFound`] naming `kind`.
pub(crate) fn read_file(path: &Path, kind: &'static str) -> Result<Vec<u8>, SceneError> {
    check_file(path, kind)?;
    std::fs::read(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => SceneError::FileNotFound {
            kind,
            path: path.display().to_string(),
        },
        _ => SceneError::Io {
            path: path.display().to_string(),
            message: error::one_line(&e.to_string()),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The wrapper's set-up in exact numbers (found by `cargo mutants`: the glTF tests only
    /// checked that ground, light and camera are on the right sides). A model spanning
    /// (1, 2, 3) to (3, 3, 7): extent 4 (its largest side, z), centre (2, 2.5, 5).
    #[test]
    fn wrap_gltf_sizes_ground_light_and_camera_from_the_model_bounds() {
        let mesh = Mesh {
            texcoords: Vec::new(),
            name: "model".into(),
            positions: vec![
                Vec3::new(1.0, 2.0, 3.0),
                Vec3::new(3.0, 3.0, 7.0),
                Vec3::new(1.0, 3.0, 3.0),
            ],
            normals: Vec::new(),
            indices: vec![0, 1, 2],
        };
        let shift = Mat4::from_translation(Vec3::new(0.0, 0.0, -1.0));
        // The second use of the mesh, moved 1 back, spans z in [2, 6]: within the first's x and
        // y, so the bounds become (1, 2, 2) to (3, 3, 7): extent 5, centre (2, 2.5, 4.5).
        let scene = wrap_gltf(
            Path::new("dir/model.glb"),
            vec![mesh],
            &[(0, Mat4::IDENTITY), (0, shift)],
        );
        assert_eq!(scene.name, "model");
        assert_eq!(scene.meshes.len(), 2);
        assert_eq!(scene.instances.len(), 3);
        for (instance, transform) in scene.instances[..2].iter().zip([Mat4::IDENTITY, shift]) {
            assert_eq!(instance.mesh, 0);
            assert_eq!(instance.transform, transform);
            assert!(instance.casts_shadow && instance.receives_shadow);
        }
        // Ground: a 20 x 20 plane (4 extents) named "ground", receiver only, its centre under the
        // bounds' centre at their lowest y.
        let ground = &scene.instances[2];
        assert_eq!(ground.mesh, 1);
        assert_eq!(scene.meshes[1].name, "ground");
        assert!(!ground.casts_shadow && ground.receives_shadow);
        let floor = scene.bounds(|i| !i.casts_shadow);
        assert_eq!(floor.min, Vec3::new(-8.0, 2.0, -5.5));
        assert_eq!(floor.max, Vec3::new(12.0, 2.0, 14.5));
        // Light: 0.3 extents square, 2 extents above the top, facing down.
        let light = &scene.light;
        assert_eq!(light.center, Vec3::new(2.0, 13.0, 4.5));
        assert_eq!((light.direction, light.up), (Vec3::NEG_Y, Vec3::Z));
        assert_eq!(
            (light.width, light.height, light.intensity),
            (0.3 * 5.0, 0.3 * 5.0, 1.0)
        );
        // Camera: from centre + (0, 1.2, 2) extents, looking at the centre.
        let camera = &scene.camera;
        assert_eq!(camera.eye, Vec3::new(2.0, 2.5 + 1.2 * 5.0, 14.5));
        assert_eq!(camera.target, Vec3::new(2.0, 2.5, 4.5));
        assert_eq!(camera.up, Vec3::Y);
        assert_eq!(camera.fov_y_degrees, 45.0);
        assert_eq!((camera.near, camera.far), (0.01 * 5.0, 250.0));
        // Without geometry: the bounds are the origin and the extent its 1e-3 floor.
        let empty = wrap_gltf(Path::new(""), Vec::new(), &[]);
        assert_eq!(empty.name, "gltf");
        assert_eq!(empty.instances.len(), 1);
        assert_eq!(empty.light.center, Vec3::new(0.0, 2e-3, 0.0));
        assert_eq!(empty.light.width, 0.3 * 1e-3);
        assert_eq!(empty.camera.far, 50.0 * 1e-3);
    }

    /// The count limits at their boundary: equal is allowed, one more refused with the limit
    /// named (the loaders' tests only reach them through glTF node graphs and huge spheres).
    #[test]
    fn count_limits_allow_the_limit_and_refuse_one_more() {
        assert!(check_instances(limits::MAX_INSTANCES, "here").is_ok());
        let message = check_instances(limits::MAX_INSTANCES + 1, "here")
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("here") && message.contains("(100001)"),
            "{message}"
        );
        assert!(message.contains("limits::MAX_INSTANCES"), "{message}");
        assert!(check_triangles(limits::MAX_TRIANGLES, "here").is_ok());
        let message = check_triangles(limits::MAX_TRIANGLES + 1, "here")
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("here") && message.contains("(32000001, every instance counted)"),
            "{message}"
        );
    }

    /// The file-size limit at its boundary, on sparse files (no disk space used): exactly
    /// `MAX_FILE_BYTES` is read, one byte more is refused before reading.
    #[test]
    fn file_size_limit_allows_the_limit_and_refuses_one_byte_more() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.glb");
        let file = std::fs::File::create(&path).unwrap();
        file.set_len(limits::MAX_FILE_BYTES).unwrap();
        assert!(check_file(&path, "glTF file").is_ok());
        file.set_len(limits::MAX_FILE_BYTES + 1).unwrap();
        let message = check_file(&path, "glTF file").unwrap_err().to_string();
        assert!(
            message.contains("(1073741825 bytes)") && message.contains("limits::MAX_FILE_BYTES"),
            "{message}"
        );
    }
}
