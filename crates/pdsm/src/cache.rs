//! The on-disk cache of built PDSMs: one versioned binary file per key (a hash of the static
//! geometry, the light and the build parameters), written atomically (temporary file + rename).
//! A file that is truncated, corrupt, of another version or for another key is never trusted:
//! [`load`] says why and the caller rebuilds.
//!
//! Layout (little endian): magic `SSPDSM01`, version u32, key u64, size u32, frustum 8 x f32
//! (eye x, eye y, s_min, s_max, t_min, t_max, near, far), stats (events mean f64, events max u32,
//! vertices mean f64, vertices max u32, max compression error f32), offset count u32, offsets,
//! vertex count u32, vertices (2 x f32 each), then an FNV-1a checksum u64 of everything before it.

use std::{
    io::Write,
    path::{Path, PathBuf},
};

use softshadow_core::{glam::Vec2, scene::Fnv1a, SlopeFrustum};

use crate::build::{BuildStats, PdsmData};

const MAGIC: &[u8; 8] = b"SSPDSM01";
/// Bump when the layout or the meaning of the data changes (old files are then rebuilt).
pub const FORMAT_VERSION: u32 = 1;

/// The cache folder: `SOFTSHADOW_CACHE_DIR`, else `$XDG_CACHE_HOME/softshadow`, else
/// `~/.cache/softshadow`; `None` when none of these can be found.
pub fn default_dir() -> Option<PathBuf> {
    let from_env = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
    if let Some(dir) = from_env("SOFTSHADOW_CACHE_DIR") {
        return Some(PathBuf::from(dir));
    }
    if let Some(dir) = from_env("XDG_CACHE_HOME") {
        return Some(PathBuf::from(dir).join("softshadow"));
    }
    from_env("HOME").map(|home| PathBuf::from(home).join(".cache").join("softshadow"))
}

/// The file of `key` in `dir`.
pub fn file_path(dir: &Path, key: u64) -> PathBuf {
    dir.join(format!("pdsm-{key:016x}.bin"))
}

/// The cache file's bytes for `pdsm` under `key`.
pub fn encode(key: u64, pdsm: &PdsmData) -> Vec<u8> {
    let mut out = Vec::with_capacity(96 + pdsm.offsets.len() * 4 + pdsm.vertices.len() * 8);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&key.to_le_bytes());
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
    let checksum = checksum(&out);
    out.extend_from_slice(&checksum.to_le_bytes());
    out
}

fn checksum(bytes: &[u8]) -> u64 {
    let mut h = Fnv1a::default();
    h.write_bytes(bytes);
    h.finish()
}

/// Reads little-endian fields in order, failing (not panicking) past the end.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| format!("truncated at byte {}", self.at))?;
        let slice = &self.bytes[self.at..end];
        self.at = end;
        Ok(slice)
    }
    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    fn f32(&mut self) -> Result<f32, String> {
        Ok(f32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
}

/// Decodes a file written by [`encode`] for `key`, or says why it cannot be trusted.
pub fn decode(bytes: &[u8], key: u64) -> Result<PdsmData, String> {
    if bytes.len() < MAGIC.len() + 12 || &bytes[..8] != MAGIC {
        return Err("not a PDSM cache file (bad magic or truncated header)".into());
    }
    let mut r = Reader { bytes, at: 8 };
    let version = r.u32()?;
    if version != FORMAT_VERSION {
        return Err(format!(
            "format version {version}, this build reads version {FORMAT_VERSION}"
        ));
    }
    let file_key = r.u64()?;
    if file_key != key {
        return Err(format!("built for key {file_key:016x}, wanted {key:016x}"));
    }
    if bytes.len() < 8 {
        return Err("truncated".into());
    }
    let body_end = bytes.len() - 8;
    let stored = u64::from_le_bytes(bytes[body_end..].try_into().expect("8 bytes"));
    if checksum(&bytes[..body_end]) != stored {
        return Err("checksum mismatch (truncated or corrupt)".into());
    }
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
    if r.at != body_end {
        return Err(format!("{} unexpected trailing bytes", body_end - r.at));
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

/// Loads the file of `key` from `dir`: `Ok(None)` when there is none, `Err(reason)` when it
/// exists but cannot be trusted.
pub fn load(dir: &Path, key: u64) -> Result<Option<PdsmData>, String> {
    let path = file_path(dir, key);
    match std::fs::read(&path) {
        Ok(bytes) => decode(&bytes, key)
            .map(Some)
            .map_err(|reason| format!("{}: {reason}", path.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(format!("{}: {e}", path.display())),
    }
}

/// Writes `pdsm` as the file of `key` in `dir` (creating the folder): first to a temporary file
/// in the same folder, then renamed over the final name, so a reader never sees half a file.
pub fn store(dir: &Path, key: u64, pdsm: &PdsmData) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    let path = file_path(dir, key);
    let temporary = dir.join(format!(
        "pdsm-{key:016x}.{}.{:?}.tmp",
        std::process::id(),
        std::thread::current().id()
    ));
    let result = (|| {
        let mut file = std::fs::File::create(&temporary)?;
        file.write_all(&encode(key, pdsm))?;
        file.sync_all()?;
        std::fs::rename(&temporary, &path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    result.map(|()| path)
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
        let bytes = encode(7, &pdsm);
        // Every truncation and every single flipped byte is refused, never trusted.
        for len in 0..bytes.len() {
            assert!(decode(&bytes[..len], 7).is_err(), "truncated to {len}");
        }
        for at in 0..bytes.len() {
            let mut damaged = bytes.clone();
            damaged[at] ^= 0x40;
            assert!(decode(&damaged, 7).is_err(), "byte {at} flipped");
        }
        let mut other_version = bytes.clone();
        other_version[8] = 99;
        let reason = decode(&other_version, 7).unwrap_err();
        assert!(reason.contains("version 99"), "{reason}");
        // No temporary files are left behind.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }
}
