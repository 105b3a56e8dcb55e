//! Files the benchmark writes. Every file is written to a temporary name in the same folder and
//! renamed into place, so an interrupted run never leaves a half-written file; results.json is
//! also flushed to the disk before the rename ([`write_durable`]). Before the first run the
//! output folder is checked: writable, and with room for what the benchmark will write
//! ([`prepare_out_dir`]).

use std::{
    collections::HashSet,
    io::Write,
    path::{Path, PathBuf},
};

use crate::{BenchError, BenchOptions, RunSpec};

fn temp_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(format!(".{}.tmp", std::process::id()));
    path.with_file_name(name)
}

fn io_error(path: &Path, e: impl std::fmt::Display) -> BenchError {
    BenchError::Write {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Writes bytes atomically (temp file + rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), BenchError> {
    let tmp = temp_path(path);
    std::fs::write(&tmp, bytes).map_err(|e| io_error(path, e))?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io_error(path, e)
    })
}

/// Writes bytes atomically and durably: a temporary file in the same folder, flushed to the disk,
/// then renamed over `path` (what results.json and the saved arguments need: a kill, a crash or
/// a power cut at any moment leaves the old file or the new one, whole).
pub fn write_durable(path: &Path, bytes: &[u8]) -> Result<(), BenchError> {
    let dir = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        // tempfile makes its files private (0600); results are for everyone who may read the
        // folder, as a file `std::fs::write` makes (0666 less the umask).
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut file = builder
        .tempfile_in(dir)
        .map_err(|e| io_error(path, os_error(e)))?;
    file.write_all(bytes).map_err(|e| io_error(path, e))?;
    file.as_file().sync_all().map_err(|e| io_error(path, e))?;
    file.persist(path)
        .map_err(|e| io_error(path, os_error(e.error)))?;
    Ok(())
}

/// The words of `e` without the random name of tempfile's file, which tempfile adds as
/// ` at path "..."`: the caller names the file.
fn os_error(e: std::io::Error) -> String {
    let text = e.to_string();
    match text.split_once(" at path \"") {
        Some((words, _)) => words.to_string(),
        None => text,
    }
}

/// Creates `dir` (and its parents) if missing.
pub fn create_dir(dir: &Path) -> Result<(), BenchError> {
    std::fs::create_dir_all(dir).map_err(|e| BenchError::Write {
        path: dir.display().to_string(),
        message: e.to_string(),
    })
}

/// Readies the output folder before the first run: creates it, writes and removes a file there
/// (flushed to the disk, so a read-only or full folder fails here, not after hours of runs), and
/// checks it has room for about [`estimate_bytes`] of `specs`.
pub fn prepare_out_dir(
    dir: &Path,
    specs: &[(usize, RunSpec)],
    options: &BenchOptions,
) -> Result<(), BenchError> {
    let existed = dir.exists();
    create_dir(dir)?;
    let checked = check_out_dir(dir, estimate_bytes(specs, options));
    if checked.is_err() && !existed {
        // Refused: leave nothing behind (`remove_dir` only removes it empty).
        let _ = std::fs::remove_dir(dir);
    }
    checked
}

/// Writes and removes a file in `dir`, then checks it has `need` bytes free.
fn check_out_dir(dir: &Path, need: u64) -> Result<(), BenchError> {
    let probe = dir.join("write-test");
    write_durable(&probe, &[0; 4096]).map_err(|e| match e {
        BenchError::Write { message, .. } => BenchError::Write {
            path: dir.display().to_string(),
            message,
        },
        other => other,
    })?;
    let _ = std::fs::remove_file(&probe);
    match free_bytes(dir) {
        Some(free) if free < need => Err(BenchError::OutOfSpace {
            path: dir.display().to_string(),
            free_mib: free >> 20,
            need_mib: need.div_ceil(1 << 20),
        }),
        _ => Ok(()),
    }
}

/// Bytes the file system of `dir` has free for this user; `None` where that cannot be asked.
pub fn free_bytes(dir: &Path) -> Option<u64> {
    #[cfg(unix)]
    {
        let stat = nix::sys::statvfs::statvfs(dir).ok()?;
        // Both are u64 here, narrower on some 32-bit systems.
        #[allow(clippy::useless_conversion)]
        Some(u64::from(stat.blocks_available()).saturating_mul(u64::from(stat.fragment_size())))
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        None
    }
}

/// Bytes of results.json taken by one run (its timings, passes and error blocks), rounded up.
const RUN_JSON_BYTES: u64 = 16 << 10;

/// An upper estimate of what a benchmark of `specs` writes: each run's share of results.json and,
/// with images, its images as if stored uncompressed (a float visibility, two RGB images; along a
/// path a line of records and an animation frame per frame); each scene and size's reference
/// images and reference-cache entry.
pub fn estimate_bytes(specs: &[(usize, RunSpec)], options: &BenchOptions) -> u64 {
    let mut bytes: u64 = 1 << 20;
    let mut references = HashSet::new();
    for (_, spec) in specs {
        let pixels = u64::from(spec.width) * u64::from(spec.height);
        let along_path = spec.path.is_some() || options.path.is_some();
        let frames = if along_path {
            u64::from(options.frames)
        } else {
            0
        };
        bytes += RUN_JSON_BYTES + frames * 2048;
        if options.images {
            bytes += pixels * (4 + 3 + 3) + frames * pixels * 2 * 3;
        }
        if options.error && references.insert((&spec.scene, spec.width, spec.height)) {
            // Reference and exact visibility (f32) and shaded reference (RGB), in the folder
            // with images and in the reference cache.
            let images = if options.images { 2 } else { 1 };
            bytes += images * pixels * (4 + 4 + 3);
        }
    }
    bytes
}

/// Single-channel 32-bit float OpenEXR (channel `V`).
pub fn write_exr_gray(
    path: &Path,
    width: u32,
    height: u32,
    data: &[f32],
) -> Result<(), BenchError> {
    use exr::prelude::*;
    let channel = AnyChannel::new("V", FlatSamples::F32(data.to_vec()));
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::named("visibility"),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(vec![channel])),
    );
    let tmp = temp_path(path);
    Image::from_layer(layer)
        .write()
        .to_file(&tmp)
        .map_err(|e| io_error(path, e))?;
    std::fs::rename(&tmp, path).map_err(|e| io_error(path, e))
}

/// 8-bit PNG from RGB or RGBA bytes.
pub fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    channels: u8,
    data: &[u8],
) -> Result<(), BenchError> {
    let color = match channels {
        3 => image::ExtendedColorType::Rgb8,
        4 => image::ExtendedColorType::Rgba8,
        1 => image::ExtendedColorType::L8,
        _ => return Err(io_error(path, "unsupported channel count")),
    };
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(data, width, height, color)
        .map_err(|e| io_error(path, e))?;
    write_atomic(path, &bytes)
}

use image::ImageEncoder;

/// RGBA8 -> RGB8.
pub fn rgba_to_rgb(rgba: &[u8]) -> Vec<u8> {
    rgba.chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(scene: &str, size: u32) -> (usize, RunSpec) {
        let spec = RunSpec {
            scene: scene.into(),
            technique: "hard".into(),
            params: Vec::new(),
            width: size,
            height: size,
            path: None,
        };
        (0, spec)
    }

    #[test]
    fn the_estimate_counts_images_per_run_and_references_per_scene_and_size() {
        let options = BenchOptions::default();
        let one = estimate_bytes(&[spec("a", 100)], &options);
        let two = estimate_bytes(&[spec("a", 100), spec("a", 100)], &options);
        // A second run of the same scene and size adds its own images, not a reference.
        assert_eq!(two - one, RUN_JSON_BYTES + 10 * 100 * 100);
        let other = estimate_bytes(&[spec("a", 100), spec("b", 100)], &options);
        assert_eq!(other - two, 2 * 11 * 100 * 100);
        let no_images = BenchOptions {
            images: false,
            ..options
        };
        assert!(estimate_bytes(&[spec("a", 8192)], &no_images) < one * 1000);
    }

    #[test]
    fn durable_writes_replace_the_file_whole_and_leave_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("results.json");
        write_durable(&path, b"first").unwrap();
        write_durable(&path, b"second").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        // Readable as any file the user writes, not private as tempfile's own.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&path).unwrap().permissions().mode();
            let plain = dir.path().join("plain");
            std::fs::write(&plain, b"").unwrap();
            let expected = std::fs::metadata(&plain).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, expected & 0o777);
        }
    }
}
