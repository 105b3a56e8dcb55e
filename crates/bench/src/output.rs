//! Files the benchmark writes. Every file is written to a temporary name in the same folder and
//! renamed into place, so an interrupted run never leaves a half-written file.

use std::path::{Path, PathBuf};

use crate::BenchError;

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
