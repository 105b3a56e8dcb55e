//! Results too dear to compute twice, on disk: one file per key (a 64-bit hash of everything the
//! result depends on), versioned, checksummed and written atomically (a temporary file in the
//! same folder, renamed over the final name), so that several processes (the shards of a sweep)
//! can share one folder. A file that is truncated, corrupt, of another format version or for
//! another key is never trusted: [`DiskCache::load`] says why and the caller computes the result
//! again (and says so).
//!
//! File layout (little endian): an 8-byte magic naming the kind of result, the format version
//! (u32), the key (u64), the payload the caller encodes, then an FNV-1a checksum (u64) of
//! everything before it.

use std::{io::Write, path::PathBuf};

use crate::scene::Fnv1a;

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

/// One kind of cached result in one folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DiskCache {
    /// The folder (created on the first store).
    pub dir: PathBuf,
    /// File-name prefix of this kind (`pdsm` gives `pdsm-<key>.bin`).
    pub kind: &'static str,
    /// The file's first 8 bytes.
    pub magic: [u8; 8],
    /// Bump when the payload's layout or meaning changes: older files are then rebuilt.
    pub version: u32,
}

/// Bytes before the payload: magic, version, key.
const HEADER: usize = 8 + 4 + 8;
/// Bytes after it: the checksum.
const TRAILER: usize = 8;

fn checksum(bytes: &[u8]) -> u64 {
    let mut h = Fnv1a::default();
    h.write_bytes(bytes);
    h.finish()
}

impl DiskCache {
    /// The file of `key`.
    pub fn path(&self, key: u64) -> PathBuf {
        self.dir.join(format!("{}-{key:016x}.bin", self.kind))
    }

    /// The whole file for `payload` under `key`.
    pub fn encode(&self, key: u64, payload: &[u8]) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER + payload.len() + TRAILER);
        out.extend_from_slice(&self.magic);
        out.extend_from_slice(&self.version.to_le_bytes());
        out.extend_from_slice(&key.to_le_bytes());
        out.extend_from_slice(payload);
        let sum = checksum(&out);
        out.extend_from_slice(&sum.to_le_bytes());
        out
    }

    /// The payload of a file written by [`DiskCache::encode`] for `key`, or why it cannot be
    /// trusted.
    pub fn decode<'a>(&self, bytes: &'a [u8], key: u64) -> Result<&'a [u8], String> {
        if bytes.len() < HEADER + TRAILER || bytes[..8] != self.magic {
            return Err(format!(
                "not a {} cache file (bad magic or truncated header)",
                self.kind
            ));
        }
        let mut header = Reader::new(&bytes[8..HEADER]);
        let version = header.u32()?;
        if version != self.version {
            return Err(format!(
                "format version {version}, this build reads version {}",
                self.version
            ));
        }
        let file_key = header.u64()?;
        if file_key != key {
            return Err(format!("built for key {file_key:016x}, wanted {key:016x}"));
        }
        let body_end = bytes.len() - TRAILER;
        let stored = u64::from_le_bytes(bytes[body_end..].try_into().expect("8 bytes"));
        if checksum(&bytes[..body_end]) != stored {
            return Err("checksum mismatch (truncated or corrupt)".into());
        }
        Ok(&bytes[HEADER..body_end])
    }

    /// The payload stored for `key`: `Ok(None)` when there is none, `Err(reason)` when a file
    /// exists but cannot be trusted (the reason names the file).
    pub fn load(&self, key: u64) -> Result<Option<Vec<u8>>, String> {
        let path = self.path(key);
        match std::fs::read(&path) {
            Ok(bytes) => self
                .decode(&bytes, key)
                .map(|payload| Some(payload.to_vec()))
                .map_err(|reason| format!("{}: {reason}", path.display())),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(format!("{}: {e}", path.display())),
        }
    }

    /// Stores `payload` as the file of `key` (creating the folder): first a temporary file in the
    /// same folder, then a rename over the final name, so a reader never sees half a file.
    pub fn store(&self, key: u64, payload: &[u8]) -> std::io::Result<PathBuf> {
        std::fs::create_dir_all(&self.dir)?;
        let path = self.path(key);
        let temporary = self.dir.join(format!(
            "{}-{key:016x}.{}.{:?}.tmp",
            self.kind,
            std::process::id(),
            std::thread::current().id()
        ));
        let result = (|| {
            let mut file = std::fs::File::create(&temporary)?;
            file.write_all(&self.encode(key, payload))?;
            file.sync_all()?;
            std::fs::rename(&temporary, &path)
        })();
        if result.is_err() {
            let _ = std::fs::remove_file(&temporary);
        }
        result.map(|()| path)
    }

    /// The warning to show when a store failed (the result is still used, only not kept).
    pub fn write_warning(&self, error: &std::io::Error) -> String {
        format!(
            "{}: cannot write the cache in {} ({error}); the result is used but not kept: set SOFTSHADOW_CACHE_DIR to a writable folder",
            self.kind,
            self.dir.display()
        )
    }
}

/// Reads little-endian fields of a payload in order, failing (never panicking) past its end.
pub struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// A reader at the start of `bytes`.
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, at: 0 }
    }

    /// The next `n` bytes.
    pub fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| format!("truncated at byte {}", self.at))?;
        let slice = &self.bytes[self.at..end];
        self.at = end;
        Ok(slice)
    }

    /// The next u32.
    pub fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }

    /// The next u64.
    pub fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }

    /// The next f32.
    pub fn f32(&mut self) -> Result<f32, String> {
        Ok(f32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }

    /// The next f64.
    pub fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }

    /// The next `count` f32s.
    pub fn f32s(&mut self, count: usize) -> Result<Vec<f32>, String> {
        let bytes = self.take(count.checked_mul(4).ok_or("count overflows")?)?;
        Ok(bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect())
    }

    /// Bytes not read yet.
    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.at
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    fn cache(dir: &Path) -> DiskCache {
        DiskCache {
            dir: dir.to_path_buf(),
            kind: "test",
            magic: *b"SSTEST01",
            version: 3,
        }
    }

    #[test]
    fn round_trip_and_every_damaged_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let c = cache(dir.path());
        let payload: Vec<u8> = (0..40).collect();
        c.store(7, &payload).unwrap();
        assert_eq!(c.load(7).unwrap(), Some(payload.clone()));
        assert_eq!(c.load(8).unwrap(), None);
        let bytes = c.encode(7, &payload);
        for len in 0..bytes.len() {
            assert!(c.decode(&bytes[..len], 7).is_err(), "truncated to {len}");
        }
        for at in 0..bytes.len() {
            let mut damaged = bytes.clone();
            damaged[at] ^= 0x40;
            assert!(c.decode(&damaged, 7).is_err(), "byte {at} flipped");
        }
        let newer = DiskCache {
            version: 4,
            ..c.clone()
        };
        let reason = newer.decode(&bytes, 7).unwrap_err();
        assert!(reason.contains("version 3"), "{reason}");
        // A corrupt file on disk names itself.
        std::fs::write(c.path(9), b"SSTEST01 garbage").unwrap();
        let reason = c.load(9).unwrap_err();
        assert!(reason.contains("test-0000000000000009.bin"), "{reason}");
        // No temporary files are left behind.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
    }

    #[test]
    fn the_reader_fails_past_the_end() {
        let bytes = 7u32.to_le_bytes();
        let mut r = Reader::new(&bytes);
        assert_eq!(r.u32(), Ok(7));
        assert_eq!(r.remaining(), 0);
        assert!(r.u32().is_err());
        assert!(Reader::new(&bytes).f32s(usize::MAX).is_err());
    }
}
