//! A perceptual video metric beside the plain motion measures (never instead of them): the
//! ColorVideoVDP score (Mantiuk et al. 2024, base model v0.5.7, through the `colorvideovdp`
//! crate) of a run's sequence of visibility images against its sequence of exact answers, both
//! shown as grey-level video on a stated display (docs/MOTION.md).
//!
//! The metric needs the whole sequence at once (its temporal filters run over all frames), so
//! a run keeps every frame's visibility and exact answer as 8-bit grey (what a display shows)
//! up to [`MAX_PIXEL_FRAMES`]; past it the figure is left out and the run says why, so a long
//! path stays bounded in memory as the rest of the runner is.

use crate::results::VideoQuality;

/// The display model the sequences are shown on: a 24-inch 1920x1080 monitor, 200 cd/m² peak,
/// contrast 1000:1, 250 lux office light, seen from 0.6 m (one of the reference's display
/// models). A 64² image covers 64x64 of its pixels, about 1.4 degrees of the view.
pub const DISPLAY: &str = "standard_fhd";

/// What the score is: the model and the crate that computes it.
pub const METRIC: &str = "ColorVideoVDP v0.5.7 base model (colorvideovdp 0.1.1)";

/// Frames per second when the path gives no rate (one frame, or a path lasting no time).
pub const DEFAULT_FPS: f64 = 30.0;

/// Most pixel-frames (width x height x frames) a run keeps for the metric: 16 Mi, 32 MiB of grey
/// for the two sequences and a few hundred MiB of the metric's f32 working set (256² x 256
/// frames fits).
pub const MAX_PIXEL_FRAMES: u64 = 16 << 20;

/// The rate a path's frames are played at: its own (`frames - 1` steps over its duration), so a
/// flicker is judged at the frequency a user playing the path in real time would see.
pub fn path_fps(duration_s: f32, frames: u32) -> f64 {
    let fps = (frames.saturating_sub(1)) as f64 / duration_s as f64;
    if frames > 1 && fps.is_finite() && fps > 0.0 {
        fps
    } else {
        DEFAULT_FPS
    }
}

/// The two grey sequences a run collects frame by frame.
pub struct Sequences {
    width: u32,
    height: u32,
    /// Why no score will be given (set before any frame is kept when over the budget).
    skipped: Option<String>,
    test: Vec<Vec<u8>>,
    reference: Vec<Vec<u8>>,
}

impl Sequences {
    /// Ready for `frames` frames of `width` x `height`.
    pub fn new(width: u32, height: u32, frames: u32) -> Self {
        let pixel_frames = width as u64 * height as u64 * frames as u64;
        let skipped = if !cfg!(feature = "video-metric") {
            Some("no perceptual video metric: the bench was built without its `video-metric` feature".to_string())
        } else if pixel_frames > MAX_PIXEL_FRAMES {
            Some(format!(
                "no perceptual video metric: {width}x{height} x {frames} frames is over its {MAX_PIXEL_FRAMES} pixel-frames; use fewer frames or a smaller size"
            ))
        } else {
            None
        };
        Self {
            width,
            height,
            skipped,
            test: Vec::new(),
            reference: Vec::new(),
        }
    }

    /// Keeps one frame: the technique's visibility and the exact answer.
    pub fn push(&mut self, visibility: &[f32], exact: &[f32]) {
        if self.skipped.is_none() {
            self.test
                .push(softshadow_metrics::visibility_to_gray8(visibility));
            self.reference
                .push(softshadow_metrics::visibility_to_gray8(exact));
        }
    }

    /// The score of the sequences played at `fps`, or why there is none.
    pub fn score(self, fps: f64) -> Result<VideoQuality, String> {
        if let Some(why) = self.skipped {
            return Err(why);
        }
        score_gray8(&self.test, &self.reference, self.width, self.height, fps)
    }
}

/// ColorVideoVDP's JOD of `test` against `reference`, each a sequence of 8-bit grey frames of
/// `width` x `height` (row-major), shown as sRGB-encoded grey on [`DISPLAY`] at `fps`: 10 when no
/// difference is visible, lower the more visible it is. The error says what went wrong.
#[cfg(feature = "video-metric")]
pub fn score_gray8(
    test: &[Vec<u8>],
    reference: &[Vec<u8>],
    width: u32,
    height: u32,
    fps: f64,
) -> Result<VideoQuality, String> {
    use colorvideovdp::{Color, Cvvdp, DisplayModel, Image, Options};
    let started = std::time::Instant::now();
    let fail = |e: colorvideovdp::Error| format!("no perceptual video metric: {e}");
    if test.len() != reference.len() || test.is_empty() {
        return Err(format!(
            "no perceptual video metric: {} test frames against {} reference frames",
            test.len(),
            reference.len()
        ));
    }
    let (w, h) = (width as usize, height as usize);
    let frames = |seq: &[Vec<u8>]| -> Result<Vec<Image>, String> {
        seq.iter()
            .map(|f| {
                let data = f.iter().map(|&g| g as f32 / 255.0).collect();
                Image::new(w, h, 1, data).map_err(fail)
            })
            .collect()
    };
    let (test, reference) = (frames(test)?, frames(reference)?);
    let display = DisplayModel::from_name(DISPLAY).map_err(fail)?;
    let metric = Cvvdp::new(display, Options::default()).map_err(fail)?;
    let prediction = metric
        .predict_video(&test, &reference, fps as f32, Color::Srgb)
        .map_err(fail)?;
    Ok(VideoQuality {
        metric: METRIC.into(),
        jod: prediction.jod as f64,
        display: DISPLAY.into(),
        fps,
        cpu_s: started.elapsed().as_secs_f64(),
    })
}

/// Without the `video-metric` feature there is no score.
#[cfg(not(feature = "video-metric"))]
pub fn score_gray8(
    _test: &[Vec<u8>],
    _reference: &[Vec<u8>],
    _width: u32,
    _height: u32,
    _fps: f64,
) -> Result<VideoQuality, String> {
    Err("no perceptual video metric: the bench was built without its `video-metric` feature".into())
}

#[cfg(all(test, feature = "video-metric"))]
mod tests {
    use super::*;

    const SIZE: u32 = 64;
    const FRAMES: usize = 12;

    /// A soft shadow edge drifting half a pixel a frame, grey levels 50..200.
    fn edge(t: usize) -> Vec<u8> {
        let s = SIZE as usize;
        (0..s * s)
            .map(|i| {
                let x = (i % s) as f32 - 0.4 * s as f32 - 0.5 * t as f32;
                (125.0 + 75.0 * (x / 6.0).tanh()).round() as u8
            })
            .collect()
    }

    fn offset(frame: &[u8], by: i16) -> Vec<u8> {
        frame
            .iter()
            .map(|&g| (g as i16 + by).clamp(0, 255) as u8)
            .collect()
    }

    fn score(test: &[Vec<u8>], reference: &[Vec<u8>]) -> f64 {
        score_gray8(test, reference, SIZE, SIZE, 30.0).unwrap().jod
    }

    #[test]
    fn identical_sequences_score_its_maximum_and_flicker_scores_below_a_steady_error() {
        let reference: Vec<Vec<u8>> = (0..FRAMES).map(edge).collect();
        let identical = score(&reference, &reference);
        assert!((identical - 10.0).abs() < 1e-4, "{identical}");
        // The same mean absolute error (8 grey levels on every pixel of every frame), steady or
        // alternating in sign from frame to frame: the flicker is the more visible.
        let steady: Vec<Vec<u8>> = reference.iter().map(|f| offset(f, 8)).collect();
        let flicker: Vec<Vec<u8>> = reference
            .iter()
            .enumerate()
            .map(|(t, f)| offset(f, if t % 2 == 0 { 8 } else { -8 }))
            .collect();
        let (steady, flicker) = (score(&steady, &reference), score(&flicker, &reference));
        assert!(steady < identical - 0.05, "steady {steady}");
        assert!(flicker < steady - 0.5, "flicker {flicker}, steady {steady}");
        assert!(flicker > 0.0 && flicker.is_finite());
    }

    #[test]
    fn mismatched_or_oversized_sequences_say_why_instead_of_scoring() {
        let reference: Vec<Vec<u8>> = (0..3).map(edge).collect();
        let why = score_gray8(&reference[..2], &reference, SIZE, SIZE, 30.0).unwrap_err();
        assert!(why.contains("2 test frames against 3"), "{why}");
        let why = Sequences::new(4096, 4096, 10).score(30.0).unwrap_err();
        assert!(why.contains("fewer frames"), "{why}");
        assert_eq!(path_fps(4.0, 121), 30.0);
        assert_eq!(path_fps(0.0, 5), DEFAULT_FPS);
        assert_eq!(path_fps(4.0, 1), DEFAULT_FPS);
    }
}
