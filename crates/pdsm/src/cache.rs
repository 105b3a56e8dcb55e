//! The on-disk cache of built PDSMs: one file per key (a hash of the static geometry, the light
//! and the build parameters) in a [`DiskCache`] (versioned, checksummed, written atomically; a
//! file that cannot be trusted is never used: the caller rebuilds).
//!
//! Payload layout (little endian): size u32, frustum 8 x f32 (eye x, eye y, s_min, s_max,
//! t_min, t_max, near, far), stats (events mean f64, events max u32, vertices mean f64, vertices
//! max u32, max compression error f32), offset count u32, offsets, vertex count u32, vertices
//! (2 x f32 each).

use std::path::Path;

use softshadow_core::{
    disk_cache::{DiskCache, Reader},
    glam::Vec2,
    SlopeFrustum,
};

use crate::build::{BuildStats, PdsmData};

/// Bump when the layout or the meaning of the data changes, or how it is built (the windows
/// `pdsm_window` fits): the key holds the scene, light and settings, not the code, so a PDSM an
/// older build made is otherwise loaded as it is (old files are rebuilt after a bump). 2: the
/// light-space bounds of issue 44.
pub const FORMAT_VERSION: u32 = 2;

/// The PDSM cache in `dir`.
pub fn in_dir(dir: &Path) -> DiskCache {
    DiskCache {
        dir: dir.to_path_buf(),
        kind: "pdsm",
        magic: *b"SSPDSM01",
        version: FORMAT_VERSION,
    }
}

/// The payload of `pdsm`.
pub fn encode(pdsm: &PdsmData) -> Vec<u8> {
    let mut out = Vec::with_capacity(76 + pdsm.offsets.len() * 4 + pdsm.vertices.len() * 8);
    out.extend_from_slice(&pdsm.size.to_le_bytes());
    let f = &pdsm.frustum;
    for v in [
        f.eye.x, f.eye.y, f.s_min, f.s_max, f.t_min, f.t_max, f.near, f.far,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    let s = &pdsm.stats;
    out.extend_from_slice(&s.events_mean.to_le_bytes());
    out.extend_from_slice(&s.events_max.to_le_bytes());
    out.extend_from_slice(&s.vertices_mean.to_le_bytes());
    out.extend_from_slice(&s.vertices_max.to_le_bytes());
    out.extend_from_slice(&s.max_compression_error.to_le_bytes());
    out.extend_from_slice(&(pdsm.offsets.len() as u32).to_le_bytes());
    out.extend_from_slice(bytemuck::cast_slice(&pdsm.offsets));
    out.extend_from_slice(&(pdsm.vertices.len() as u32).to_le_bytes());
    out.extend_from_slice(bytemuck::cast_slice(&pdsm.vertices));
    out
}

/// Decodes a payload written by [`encode`], or says why it cannot be trusted.
pub fn decode(payload: &[u8]) -> Result<PdsmData, String> {
    let mut r = Reader::new(payload);
    let size = r.u32()?;
    let mut f = [0.0f32; 8];
    for v in &mut f {
        *v = r.f32()?;
    }
    let frustum = SlopeFrustum {
        eye: Vec2::new(f[0], f[1]),
        s_min: f[2],
        s_max: f[3],
        t_min: f[4],
        t_max: f[5],
        near: f[6],
        far: f[7],
    };
    let stats = BuildStats {
        events_mean: r.f64()?,
        events_max: r.u32()?,
        vertices_mean: r.f64()?,
        vertices_max: r.u32()?,
        max_compression_error: r.f32()?,
    };
    let offset_count = r.u32()? as usize;
    let texels = size as usize * size as usize;
    if offset_count != texels + 1 {
        return Err(format!(
            "{offset_count} index entries for a {size}² map (expected {})",
            texels + 1
        ));
    }
    let offsets: Vec<u32> = r
        .take(offset_count * 4)?
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")))
        .collect();
    let vertex_count = r.u32()? as usize;
    let vertices: Vec<[f32; 2]> = r
        .take(
            vertex_count
                .checked_mul(8)
                .ok_or("vertex count overflows")?,
        )?
        .chunks_exact(8)
        .map(|c| {
            [
                f32::from_le_bytes(c[..4].try_into().expect("4 bytes")),
                f32::from_le_bytes(c[4..].try_into().expect("4 bytes")),
            ]
        })
        .collect();
    if r.remaining() != 0 {
        return Err(format!("{} unexpected trailing bytes", r.remaining()));
    }
    let monotone = offsets.first() == Some(&0) && offsets.windows(2).all(|w| w[0] <= w[1]);
    if !monotone || offsets.last().copied() != Some(vertex_count as u32) {
        return Err("index does not match the data".into());
    }
    let finite = f.iter().all(|v| v.is_finite())
        && vertices
            .iter()
            .all(|v| v[0].is_finite() && v[1].is_finite());
    if !finite {
        return Err("non-finite values".into());
    }
    Ok(PdsmData {
        size,
        frustum,
        offsets,
        vertices,
        stats,
    })
}

/// Loads the PDSM of `key` from `dir`: `Ok(None)` when there is none, `Err(reason)` when a file
/// exists but cannot be trusted.
pub fn load(dir: &Path, key: u64) -> Result<Option<PdsmData>, String> {
    let cache = in_dir(dir);
    match cache.load(key)? {
        Some(payload) => decode(&payload)
            .map(Some)
            .map_err(|reason| format!("{}: {reason}", cache.path(key).display())),
        None => Ok(None),
    }
}

/// Stores `pdsm` as the file of `key` in `dir` (atomically, creating the folder).
pub fn store(dir: &Path, key: u64, pdsm: &PdsmData) -> std::io::Result<std::path::PathBuf> {
    in_dir(dir).store(key, &encode(pdsm))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> PdsmData {
        PdsmData {
            size: 2,
            frustum: SlopeFrustum {
                eye: Vec2::ZERO,
                s_min: -1.0,
                s_max: 1.0,
                t_min: -0.5,
                t_max: 0.5,
                near: 0.1,
                far: 9.0,
            },
            offsets: vec![0, 2, 2, 3, 3],
            vertices: vec![[1.0, 1.0], [1.0, 0.5], [2.0, 0.25]],
            stats: BuildStats {
                events_mean: 0.75,
                events_max: 2,
                vertices_mean: 0.75,
                vertices_max: 2,
                max_compression_error: 0.01,
            },
        }
    }

    #[test]
    fn round_trip_and_every_damaged_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let pdsm = sample();
        store(dir.path(), 7, &pdsm).unwrap();
        assert_eq!(load(dir.path(), 7).unwrap(), Some(pdsm.clone()));
        assert_eq!(load(dir.path(), 8).unwrap(), None);
        let cache = in_dir(dir.path());
        let bytes = cache.encode(7, &encode(&pdsm));
        // Every truncation and every single flipped byte is refused, never trusted.
        let decode_file = |bytes: &[u8]| cache.decode(bytes, 7).and_then(decode);
        for len in 0..bytes.len() {
            assert!(decode_file(&bytes[..len]).is_err(), "truncated to {len}");
        }
        for at in 0..bytes.len() {
            let mut damaged = bytes.clone();
            damaged[at] ^= 0x40;
            assert!(decode_file(&damaged).is_err(), "byte {at} flipped");
        }
        let mut other_version = bytes.clone();
        other_version[8] = 99;
        let reason = decode_file(&other_version).unwrap_err();
        assert!(reason.contains("version 99"), "{reason}");
        // A payload whose index does not match its data is refused even under a good checksum.
        let mut bad_index = pdsm.clone();
        bad_index.offsets[4] = 2;
        let reason = decode(&encode(&bad_index)).unwrap_err();
        assert!(reason.contains("index"), "{reason}");
        // No temporary files are left behind.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }
}
