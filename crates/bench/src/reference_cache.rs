//! The reference images of a benchmark on disk, shared by every process that points at the same
//! folder (the shards of a sweep, docs/CLUSTER.md): the dearest part of a sweep is computed once.
//!
//! One file per key in a [`DiskCache`] (versioned, checksummed, written atomically, so shards
//! writing the same entry at once never leave a torn file). The key hashes everything the images
//! depend on: the scene's content (geometry, flags), the camera and light it is seen with, the
//! size, the reference's settings and shader sources (with the common modules they import) and
//! the exact answer's method and samples per axis (`raytraced(samples_per_axis=32)`,
//! `raycast(samples_per_axis=16)`: the one the device would use). A file that cannot be trusted
//! is never used: the reference is rendered again and the run says why
//! ([`ReferenceCacheUse::Rebuilt`]).
//!
//! Payload layout (little endian): reference label (u32 length, UTF-8), visibility count u32,
//! visibility f32s, shaded RGB count u32, bytes, then a u32 flag for the exact answer and, when
//! set, its label and visibility in the same encodings and its sampling error (f64; NaN for
//! none), then a u32 flag for the exact irradiance and, when set, its irradiance and unoccluded
//! irradiance images (f32s each).

use std::path::Path;

use serde::{Deserialize, Serialize};
use softshadow_core::{
    disk_cache::{DiskCache, Reader},
    scene::Fnv1a,
    shader::{ShaderSpec, COMMON_MODULES},
    AreaLight, Camera, Scene,
};
use softshadow_reference::ExactIrradiance;

/// Bump when the layout changes, or when the reference or the exact answer changes what they
/// compute in code the key cannot see (the CPU ray cast): older files are then rebuilt.
pub const FORMAT_VERSION: u32 = 3;

/// Where a run's reference images came from, in results.json (`reference_cache`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceCacheUse {
    /// Read from the cache.
    Hit,
    /// Not in the cache: rendered and stored.
    Stored,
    /// An entry was there but could not be trusted (the reason): rendered again and stored.
    Rebuilt(String),
    /// Rendered, but the cache could not be written (why).
    NotStored(String),
}

/// The reference cache in `dir`.
pub fn in_dir(dir: &Path) -> DiskCache {
    DiskCache {
        dir: dir.to_path_buf(),
        kind: "yardstick",
        magic: *b"SSREF001",
        version: FORMAT_VERSION,
    }
}

/// What a reference entry depends on.
pub struct ReferenceKey<'a> {
    pub scene: &'a Scene,
    pub camera: &'a Camera,
    pub light: &'a AreaLight,
    pub width: u32,
    pub height: u32,
    /// The reference's label: its technique id and every setting.
    pub label: &'a str,
    /// The reference technique's shaders.
    pub shaders: &'a [ShaderSpec],
    /// The exact method the bench would use where the closed form does not apply
    /// (`softshadow_reference::ExactMethod::key_on`), `None` without an exact answer.
    pub exact_method: Option<&'a str>,
}

impl ReferenceKey<'_> {
    /// The 64-bit key.
    pub fn hash(&self) -> u64 {
        let mut h = Fnv1a::default();
        h.write_u64(self.scene.content_hash());
        h.write_u64(self.camera.content_hash());
        h.write_u64(self.light.content_hash());
        h.write_u64(u64::from(self.width) << 32 | u64::from(self.height));
        h.write_bytes(self.label.as_bytes());
        for shader in self.shaders {
            h.write_bytes(shader.path.as_bytes());
            h.write_bytes(shader.source.as_bytes());
        }
        for (name, source) in COMMON_MODULES {
            h.write_bytes(name.as_bytes());
            h.write_bytes(source.as_bytes());
        }
        match self.exact_method {
            Some(method) => h.write_bytes(method.as_bytes()),
            None => h.write_u64(u64::MAX),
        }
        h.finish()
    }
}

/// A cached reference: the images the bench compares runs with.
#[derive(Clone, Debug, PartialEq)]
pub struct CachedReference {
    pub label: String,
    pub visibility: Vec<f32>,
    pub shaded_rgb: Vec<u8>,
    /// The exact answer's label and visibility.
    pub exact: Option<(String, Vec<f32>)>,
    /// The exact answer's sampling error (`softshadow_reference::ExactAnswer::sampling_error`).
    pub exact_sampling_error: Option<f64>,
    /// The exact irradiance, where the analytic answer gave it.
    pub exact_irradiance: Option<ExactIrradiance>,
}

fn put_str(out: &mut Vec<u8>, text: &str) {
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(text.as_bytes());
}

fn put_f32s(out: &mut Vec<u8>, values: &[f32]) {
    out.extend_from_slice(&(values.len() as u32).to_le_bytes());
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

fn take_str(r: &mut Reader) -> Result<String, String> {
    let len = r.u32()? as usize;
    String::from_utf8(r.take(len)?.to_vec()).map_err(|_| "a label is not UTF-8".to_string())
}

fn take_f32s(r: &mut Reader) -> Result<Vec<f32>, String> {
    let count = r.u32()? as usize;
    r.f32s(count)
}

/// The payload of `reference`.
pub fn encode(reference: &CachedReference) -> Vec<u8> {
    let mut out = Vec::new();
    put_str(&mut out, &reference.label);
    put_f32s(&mut out, &reference.visibility);
    out.extend_from_slice(&(reference.shaded_rgb.len() as u32).to_le_bytes());
    out.extend_from_slice(&reference.shaded_rgb);
    match &reference.exact {
        Some((label, visibility)) => {
            out.extend_from_slice(&1u32.to_le_bytes());
            put_str(&mut out, label);
            put_f32s(&mut out, visibility);
            let error = reference.exact_sampling_error.unwrap_or(f64::NAN);
            out.extend_from_slice(&error.to_le_bytes());
        }
        None => out.extend_from_slice(&0u32.to_le_bytes()),
    }
    match &reference.exact_irradiance {
        Some(e) => {
            out.extend_from_slice(&1u32.to_le_bytes());
            put_f32s(&mut out, &e.irradiance);
            put_f32s(&mut out, &e.unoccluded);
        }
        None => out.extend_from_slice(&0u32.to_le_bytes()),
    }
    out
}

fn take_f64(r: &mut Reader) -> Result<Option<f64>, String> {
    let bytes: [u8; 8] = r.take(8)?.try_into().expect("took 8 bytes");
    let value = f64::from_le_bytes(bytes);
    Ok((!value.is_nan()).then_some(value))
}

/// Decodes a payload written by [`encode`] for an image of `pixels` pixels, or says why it
/// cannot be trusted.
pub fn decode(payload: &[u8], pixels: usize) -> Result<CachedReference, String> {
    let mut r = Reader::new(payload);
    let label = take_str(&mut r)?;
    let visibility = take_f32s(&mut r)?;
    let shaded_len = r.u32()? as usize;
    let shaded_rgb = r.take(shaded_len)?.to_vec();
    let (exact, exact_sampling_error) = match r.u32()? {
        0 => (None, None),
        1 => (
            Some((take_str(&mut r)?, take_f32s(&mut r)?)),
            take_f64(&mut r)?,
        ),
        flag => return Err(format!("bad exact-answer flag {flag}")),
    };
    let exact_irradiance = match r.u32()? {
        0 => None,
        1 => Some(ExactIrradiance {
            irradiance: take_f32s(&mut r)?,
            unoccluded: take_f32s(&mut r)?,
        }),
        flag => return Err(format!("bad exact-irradiance flag {flag}")),
    };
    if r.remaining() != 0 {
        return Err(format!("{} bytes after the payload", r.remaining()));
    }
    let exact_len = exact.as_ref().map_or(pixels, |(_, v)| v.len());
    let irradiance_ok = exact_irradiance
        .as_ref()
        .is_none_or(|e| e.irradiance.len() == pixels && e.unoccluded.len() == pixels);
    if visibility.len() != pixels
        || shaded_rgb.len() != 3 * pixels
        || exact_len != pixels
        || !irradiance_ok
    {
        return Err(format!("image sizes do not match {pixels} pixels"));
    }
    if visibility.iter().any(|v| !v.is_finite()) {
        return Err("a visibility is not finite".into());
    }
    Ok(CachedReference {
        label,
        visibility,
        shaded_rgb,
        exact,
        exact_sampling_error,
        exact_irradiance,
    })
}

/// Bump when the per-frame exact answer changes in code its key cannot see (the closed form,
/// the ray cast, the G-buffer positions it starts from): older entries are then rebuilt.
pub const EXACT_FORMAT_VERSION: u32 = 3;

/// The per-frame exact answers of motion runs ([`crate::motion`]) in `dir`: one file per frame's
/// scene (its moved instances, light and camera), size and exact method, shared by every
/// technique and every later run on the same path.
pub fn exact_in_dir(dir: &Path) -> DiskCache {
    DiskCache {
        dir: dir.to_path_buf(),
        kind: "exact",
        magic: *b"SSEXA001",
        version: EXACT_FORMAT_VERSION,
    }
}

/// The key of one frame's exact answer: `scene` holds the frame's pose (camera, light, moved
/// instances), so [`Scene::content_hash`] covers them. `method` is the method the frame would use
/// where the closed form does not apply (`softshadow_reference::ExactMethod::key_on`).
pub fn exact_key(scene: &Scene, width: u32, height: u32, method: &str) -> u64 {
    let mut h = Fnv1a::default();
    h.write_u64(scene.content_hash());
    h.write_u64(u64::from(width) << 32 | u64::from(height));
    h.write_bytes(method.as_bytes());
    h.finish()
}

/// One frame's exact answer as the cache keeps it.
#[derive(Clone, Debug, PartialEq)]
pub struct CachedExact {
    /// `closed-form`, `analytic`, `raytraced(...)` or `raycast(...)`.
    pub label: String,
    pub visibility: Vec<f32>,
    /// Its sampling error (`softshadow_reference::ExactAnswer::sampling_error`).
    pub sampling_error: Option<f64>,
}

/// The payload of one frame's exact answer: its label, visibility and sampling error (f64,
/// NaN for none).
pub fn encode_exact(exact: &CachedExact) -> Vec<u8> {
    let mut out = Vec::new();
    put_str(&mut out, &exact.label);
    put_f32s(&mut out, &exact.visibility);
    out.extend_from_slice(&exact.sampling_error.unwrap_or(f64::NAN).to_le_bytes());
    out
}

/// Decodes [`encode_exact`]'s payload for `pixels` pixels, or says why it cannot be trusted.
pub fn decode_exact(payload: &[u8], pixels: usize) -> Result<CachedExact, String> {
    let mut r = Reader::new(payload);
    let label = take_str(&mut r)?;
    let visibility = take_f32s(&mut r)?;
    let sampling_error = take_f64(&mut r)?;
    if r.remaining() != 0 {
        return Err(format!("{} bytes after the payload", r.remaining()));
    }
    if visibility.len() != pixels {
        return Err(format!(
            "{} values for an image of {pixels} pixels",
            visibility.len()
        ));
    }
    if visibility.iter().any(|v| !v.is_finite()) {
        return Err("a visibility is not finite".into());
    }
    Ok(CachedExact {
        label,
        visibility,
        sampling_error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reference_round_trips_and_a_wrong_size_is_refused() {
        let reference = CachedReference {
            label: "reference(samples_per_axis=4)".into(),
            visibility: vec![0.0, 0.25, 0.5, 1.0],
            shaded_rgb: (0..12).collect(),
            exact: Some(("closed form".into(), vec![0.0, 0.2, 0.6, 1.0])),
            exact_sampling_error: Some(0.004),
            exact_irradiance: Some(ExactIrradiance {
                irradiance: vec![0.0, 0.1, 0.2, 0.3],
                unoccluded: vec![0.0, 0.3, 0.3, 0.3],
            }),
        };
        let payload = encode(&reference);
        assert_eq!(decode(&payload, 4).unwrap(), reference);
        assert!(decode(&payload, 5).unwrap_err().contains("sizes"));
        assert!(decode(&payload[..payload.len() - 1], 4).is_err());
    }

    #[test]
    fn an_exact_answer_round_trips_and_its_key_sees_the_pose() {
        let exact = CachedExact {
            label: "raytraced(samples_per_axis=32)".into(),
            visibility: vec![0.0, 0.5, 1.0],
            sampling_error: Some(0.003),
        };
        let payload = encode_exact(&exact);
        assert_eq!(decode_exact(&payload, 3).unwrap(), exact);
        assert!(decode_exact(&payload, 4).is_err());
        assert!(decode_exact(&payload[..payload.len() - 2], 3).is_err());
        let mut scene = softshadow_scenes_free_scene();
        let (rt, rc) = (
            "raytraced(samples_per_axis=32)",
            "raycast(samples_per_axis=32)",
        );
        let key = exact_key(&scene, 64, 64, rt);
        assert_eq!(key, exact_key(&scene, 64, 64, rt));
        assert_ne!(key, exact_key(&scene, 64, 32, rt));
        assert_ne!(key, exact_key(&scene, 64, 64, rc));
        assert_ne!(
            key,
            exact_key(&scene, 64, 64, "raytraced(samples_per_axis=16)")
        );
        scene.light.width += 0.5;
        assert_ne!(key, exact_key(&scene, 64, 64, rt));
    }

    fn softshadow_scenes_free_scene() -> Scene {
        Scene {
            materials: Vec::new(),
            textures: Vec::new(),
            name: "empty".into(),
            meshes: Vec::new(),
            instances: Vec::new(),
            light: AreaLight::default(),
            camera: Camera::default(),
        }
    }
}
