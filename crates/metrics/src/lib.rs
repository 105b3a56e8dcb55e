//! softshadow-metrics: compare a technique's per-pixel visibility with a reference.
//!
//! Every soft-shadow technique in the workbench writes, for each screen pixel, a
//! visibility `V` in `[0, 1]`: the fraction of the area light visible from the
//! surface point seen through that pixel (`1` = fully lit, `0` = umbra). This
//! crate compares such a buffer with a reference `V_ref` and summarises the
//! difference. It is pure CPU code and does not depend on the GPU crates.
//!
//! Conventions shared by every function here:
//!
//! * Buffers are row-major, top-left first, one value per pixel
//!   (`index = y * width + x`); RGB8 buffers are tightly packed (`3` bytes per
//!   pixel).
//! * A `receiver_mask` marks the pixels that show a shadow receiver; error
//!   statistics ([`compare`]) only look at those pixels.
//! * A non-finite technique value (NaN or ±Inf) is a failure of the technique,
//!   not of the comparison: it is scored as an absolute error of `1.0` (the
//!   worst possible for visibilities in `[0, 1]`) and counted by [`stability`].
//! * A non-finite *reference* value on a receiver pixel means the reference is
//!   broken, and is reported as [`MetricsError::NonFiniteReference`].
//!
//! Entry points: [`compare`] (error statistics), [`stability`] (NaN/Inf/range
//! counts), [`flip_mean`] (NVIDIA FLIP on 8-bit sRGB images),
//! [`difference_image`] (false-colour signed-error image), [`flicker`] (the change between two
//! frames that the exact answer does not show) and
//! [`visibility_to_gray8`] (8-bit preview of a visibility buffer).

#![warn(missing_docs)]

use serde::{Deserialize, Serialize};

/// Errors returned by the metrics functions. Each message names the problem
/// and what to do about it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MetricsError {
    /// The visibility buffers and the receiver mask have different lengths.
    #[error(
        "input lengths differ: v has {v} values, v_ref has {v_ref}, receiver_mask has {mask}; \
         all three must hold one entry per pixel of the same image"
    )]
    LengthMismatch {
        /// Length of the technique's visibility buffer.
        v: usize,
        /// Length of the reference visibility buffer.
        v_ref: usize,
        /// Length of the receiver mask.
        mask: usize,
    },
    /// The receiver mask has no `true` entry, so there is nothing to measure.
    #[error("no receiver pixels in view: point the camera at a shadow receiver")]
    NoReceivers,
    /// The reference visibility is NaN or infinite on a receiver pixel.
    #[error(
        "reference visibility is non-finite ({value}) at pixel {index}: the reference is broken; \
         re-render the reference before comparing"
    )]
    NonFiniteReference {
        /// Pixel index (`y * width + x`) of the first offending value.
        index: usize,
        /// The offending value.
        value: f32,
    },
    /// A buffer does not match the image size it was passed with.
    #[error(
        "{what} has {actual} entries but the image size requires {expected}; \
         pass buffers that match width and height"
    )]
    SizeMismatch {
        /// Which buffer is wrong.
        what: &'static str,
        /// Entries required by `width` and `height`.
        expected: u64,
        /// Entries actually passed.
        actual: usize,
    },
    /// Width or height is zero.
    #[error("image size {width}x{height} is empty: width and height must both be at least 1")]
    EmptyImage {
        /// Image width in pixels.
        width: u32,
        /// Image height in pixels.
        height: u32,
    },
    /// The image is too large for the FLIP bindings (`width * height * 3` must fit in `u32`).
    #[error(
        "image size {width}x{height} is too large for FLIP (width*height*3 must fit in u32); \
         compare a downscaled or cropped image"
    )]
    ImageTooLarge {
        /// Image width in pixels.
        width: u32,
        /// Image height in pixels.
        height: u32,
    },
}

/// Error statistics of a technique's visibility against the reference,
/// computed by [`compare`] over receiver pixels only.
///
/// The per-pixel error is `e = |V - V_ref|`, computed in `f64`; a non-finite
/// `V` scores `e = 1.0`. Finite `V` outside `[0, 1]` is used as is (so `e` may
/// exceed 1 there; [`stability`] counts such values).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorReport {
    /// Mean of `e` over receiver pixels in shadow, i.e. where `V_ref < 1.0`
    /// (umbra and penumbra), the "shadowed pixels" error of Atty et al. 2006,
    /// sec. 4.2.1. The test is the exact comparison `v_ref < 1.0`: the reference
    /// writes exactly `1.0` for fully lit pixels. `0.0` when there are no
    /// shadowed pixels.
    pub mae_shadowed: f64,
    /// The part of [`mae_shadowed`](Self::mae_shadowed) where the technique is too dark: the sum
    /// of `e` over the shadowed pixels with `V < V_ref`, divided by all shadowed pixels (so
    /// `mae_shadowed - darker_shadowed` is the too-light part). Overlapping occluders that a
    /// technique counts twice (gather backprojection's missing occluder fusion, Schwarz and
    /// Stamminger 2007, section 3) show here. `0.0` when there are no shadowed pixels; missing
    /// (read as 0) in results written before it existed.
    #[serde(default)]
    pub darker_shadowed: f64,
    /// Light leaking: the mean, over the receiver pixels in umbra (`V_ref <=`
    /// [`UMBRA_THRESHOLD`]), of how much brighter than the reference the technique is there,
    /// `max(0, V - V_ref)` (a non-finite `V` counts 1). The too-bright part of
    /// [`mae_shadowed`](Self::mae_shadowed) inside umbrae: what filterable shadow maps
    /// (variance, exponential, moment) get wrong where casters at very different depths overlap.
    /// `0.0` when there are no umbra pixels; missing (read as 0) in results written before it
    /// existed.
    #[serde(default)]
    pub brighter_umbra: f64,
    /// Number of receiver pixels with `V_ref <=` [`UMBRA_THRESHOLD`] (0 in results written
    /// before it existed).
    #[serde(default)]
    pub umbra_pixels: u64,
    /// Mean of `e` over all receiver pixels.
    pub mae_all: f64,
    /// Root mean square of `e` over all receiver pixels.
    pub rmse: f64,
    /// Maximum of `e` over all receiver pixels.
    pub max_abs: f64,
    /// 99th percentile of `e` over receiver pixels, nearest-rank definition:
    /// with the `n` errors sorted ascending, the value at 1-based rank
    /// `ceil(0.99 * n)` (no interpolation; for `n <= 100` this is the maximum).
    pub p99_abs: f64,
    /// Number of receiver pixels with `V_ref < 1.0`.
    pub shadowed_pixels: u64,
    /// Number of receiver pixels (`true` entries in the mask).
    pub receiver_pixels: u64,
    /// Mean NVIDIA FLIP error of the rendered images, if computed. [`compare`]
    /// leaves this `None`; set it from [`flip_mean`].
    pub flip_mean: Option<f64>,
}

/// The error in irradiance, where the shaded image shows it: each pixel's technique irradiance
/// is `V x E0` (its visibility times the exact unoccluded irradiance `E0`) against the exact
/// irradiance `E` from the visible part of the light (docs/EXACT.md, "The irradiance
/// error"). A receiver that faces away from the whole light has `E0 = E = 0`: it counts zero
/// here, whatever its visibility error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IrradianceReport {
    /// Mean of `|V E0 - E|` over receiver pixels over the mean of `E0` over them.
    pub irradiance_mae: f64,
    /// The same over the shadowed receiver pixels (`V_ref < 1`, those `mae_shadowed` averages
    /// over), normalised by the mean of `E0` over them.
    pub irradiance_mae_shadowed: f64,
    /// Receiver pixels facing away from the whole light (`E0 = 0`).
    pub facing_away_pixels: u64,
}

/// Largest reference visibility of a pixel counted as umbra by [`ErrorReport::brighter_umbra`]:
/// the exact answers (closed form, ray cast) write 0 there; the margin keeps an accumulated
/// reference's last-sample rounding in.
pub const UMBRA_THRESHOLD: f32 = 0.01;

/// [`IrradianceReport`] of the technique's visibility `v` against the exact answer: its
/// visibility `v_ref` (which pixels are shadowed), irradiance `irradiance` and unoccluded
/// irradiance `unoccluded`, over the pixels of `receiver_mask`. A non-finite `V` scores the
/// worse of `V = 0` and `V = 1`. Errors as [`compare`]'s, and [`MetricsError::LengthMismatch`]
/// when the irradiance images differ in length from `v`.
pub fn compare_irradiance(
    v: &[f32],
    v_ref: &[f32],
    irradiance: &[f32],
    unoccluded: &[f32],
    receiver_mask: &[bool],
) -> Result<IrradianceReport, MetricsError> {
    check_lengths(v, v_ref, receiver_mask)?;
    for other in [irradiance, unoccluded] {
        if other.len() != v.len() {
            check_lengths(v, other, receiver_mask)?;
        }
    }
    // (sum of errors, sum of E0) over receivers and over shadowed receivers.
    let (mut all, mut shadowed) = ([0.0f64; 2], [0.0f64; 2]);
    let mut facing_away_pixels = 0;
    for (index, &receiver) in receiver_mask.iter().enumerate() {
        if !receiver {
            continue;
        }
        let (e, e0, r) = (irradiance[index], unoccluded[index], v_ref[index]);
        for value in [e, e0, r] {
            if !value.is_finite() {
                return Err(MetricsError::NonFiniteReference { index, value });
            }
        }
        let (e, e0) = (e as f64, e0 as f64);
        let vi = v[index];
        let error = if vi.is_finite() {
            (vi.clamp(0.0, 1.0) as f64 * e0 - e).abs()
        } else {
            e.max(e0 - e)
        };
        facing_away_pixels += (e0 == 0.0) as u64;
        all = [all[0] + error, all[1] + e0];
        if r < 1.0 {
            shadowed = [shadowed[0] + error, shadowed[1] + e0];
        }
    }
    let ratio = |[error, e0]: [f64; 2]| if e0 > 0.0 { error / e0 } else { 0.0 };
    Ok(IrradianceReport {
        irradiance_mae: ratio(all),
        irradiance_mae_shadowed: ratio(shadowed),
        facing_away_pixels,
    })
}

/// Counts of numerically unhealthy values in a visibility buffer (see [`stability`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Stability {
    /// Number of NaN values.
    pub nan: u64,
    /// Number of `+Inf` or `-Inf` values.
    pub inf: u64,
    /// Number of finite values outside `[0, 1]` (`-0.0` counts as in range).
    pub out_of_range: u64,
}

/// Absolute error of one pixel: `|v - v_ref|` in `f64`, or `1.0` for a
/// non-finite technique value. `v_ref` must be finite.
fn pixel_error(v: f32, v_ref: f32) -> f64 {
    if v.is_finite() {
        (f64::from(v) - f64::from(v_ref)).abs()
    } else {
        1.0
    }
}

/// Compares a technique's visibility `v` with the reference `v_ref` over the
/// pixels where `receiver_mask` is `true`.
///
/// See [`ErrorReport`] for the definition of every field. In short, with
/// `e = |V - V_ref|`:
///
/// * `mae_shadowed` / `shadowed_pixels`: mean of `e` / count over receiver
///   pixels with `v_ref < 1.0` exactly (the reference writes exactly `1.0`
///   when fully lit); `0.0` / `0` if there are none.
/// * `mae_all`, `rmse`, `max_abs`, `p99_abs` (nearest rank): over all receiver
///   pixels.
/// * `flip_mean` is `None`; fill it in with [`flip_mean`].
///
/// Non-finite technique values never make this fail nor produce NaN: each one
/// scores the worst error, `1.0`. Values on non-receiver pixels are ignored
/// entirely (including non-finite ones).
///
/// # Errors
///
/// * [`MetricsError::LengthMismatch`] if the three slices differ in length.
/// * [`MetricsError::NoReceivers`] if no mask entry is `true`.
/// * [`MetricsError::NonFiniteReference`] if `v_ref` is NaN or infinite on a
///   receiver pixel.
pub fn compare(
    v: &[f32],
    v_ref: &[f32],
    receiver_mask: &[bool],
) -> Result<ErrorReport, MetricsError> {
    check_lengths(v, v_ref, receiver_mask)?;

    let mut errors: Vec<f64> = Vec::new();
    let mut sum = 0.0f64;
    let mut sum_sq = 0.0f64;
    let mut max_abs = 0.0f64;
    let mut sum_shadowed = 0.0f64;
    let mut sum_darker = 0.0f64;
    let mut shadowed_pixels = 0u64;
    let mut sum_brighter_umbra = 0.0f64;
    let mut umbra_pixels = 0u64;

    for (index, ((&vi, &ri), &receiver)) in v.iter().zip(v_ref).zip(receiver_mask).enumerate() {
        if !receiver {
            continue;
        }
        if !ri.is_finite() {
            return Err(MetricsError::NonFiniteReference { index, value: ri });
        }
        let e = pixel_error(vi, ri);
        sum += e;
        sum_sq += e * e;
        max_abs = max_abs.max(e);
        // Exact test: the reference writes exactly 1.0 for fully lit pixels.
        if ri < 1.0 {
            sum_shadowed += e;
            if vi < ri {
                sum_darker += e;
            }
            shadowed_pixels += 1;
        }
        if ri <= UMBRA_THRESHOLD {
            if !vi.is_finite() || vi > ri {
                sum_brighter_umbra += e;
            }
            umbra_pixels += 1;
        }
        errors.push(e);
    }

    if errors.is_empty() {
        return Err(MetricsError::NoReceivers);
    }
    let n = errors.len() as u64;
    let nf = n as f64;

    Ok(ErrorReport {
        mae_shadowed: if shadowed_pixels == 0 {
            0.0
        } else {
            sum_shadowed / shadowed_pixels as f64
        },
        darker_shadowed: if shadowed_pixels == 0 {
            0.0
        } else {
            sum_darker / shadowed_pixels as f64
        },
        brighter_umbra: if umbra_pixels == 0 {
            0.0
        } else {
            sum_brighter_umbra / umbra_pixels as f64
        },
        umbra_pixels,
        mae_all: sum / nf,
        rmse: (sum_sq / nf).sqrt(),
        max_abs,
        p99_abs: percentile_nearest_rank(&mut errors, 99),
        shadowed_pixels,
        receiver_pixels: n,
        flip_mean: None,
    })
}

/// Nearest-rank percentile `p` (in percent, `1..=100`) of a non-empty slice of
/// finite values: the value of 1-based rank `ceil(p * n / 100)` in ascending
/// order. Reorders `values`.
fn percentile_nearest_rank(values: &mut [f64], p: u64) -> f64 {
    debug_assert!(!values.is_empty() && (1..=100).contains(&p));
    let n = values.len() as u64;
    // ceil(p * n / 100) in integer arithmetic; at least 1 because n >= 1, p >= 1.
    let rank = (p * n).div_ceil(100);
    let index = (rank - 1) as usize;
    let (_, value, _) = values.select_nth_unstable_by(index, f64::total_cmp);
    *value
}

fn check_lengths(v: &[f32], v_ref: &[f32], receiver_mask: &[bool]) -> Result<(), MetricsError> {
    if v.len() != v_ref.len() || v.len() != receiver_mask.len() {
        return Err(MetricsError::LengthMismatch {
            v: v.len(),
            v_ref: v_ref.len(),
            mask: receiver_mask.len(),
        });
    }
    Ok(())
}

/// The camera-distance bands [`distance_bands`] reports, metres: near 0-20, middle 20-80, far
/// 80 and beyond. Fixed rather than thirds of a technique's cascade range, so every technique
/// and scene is cut the same way (a paper scene a few metres across is all "near").
pub const DISTANCE_BANDS: [(&str, f64, f64); 3] = [
    ("near", 0.0, 20.0),
    ("middle", 20.0, 80.0),
    ("far", 80.0, f64::INFINITY),
];

/// The error over the receiver pixels whose camera distance lies in one band of
/// [`DISTANCE_BANDS`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BandError {
    /// `near`, `middle` or `far`.
    pub band: String,
    /// The band's nearest camera distance, metres.
    pub from_m: f64,
    /// Its farthest (exclusive), metres; absent for the last band (no bound).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to_m: Option<f64>,
    /// Receiver pixels in the band.
    pub receiver_pixels: u64,
    /// Of them, those the reference shadows (`V_ref < 1`).
    pub shadowed_pixels: u64,
    /// Mean of `e = |V - V_ref|` over the band's receiver pixels (0 with none).
    pub mae_all: f64,
    /// Mean of `e` over the band's shadowed pixels (0 with none), as
    /// [`ErrorReport::mae_shadowed`].
    pub mae_shadowed: f64,
}

/// The error of `v` against `v_ref` per camera-distance band ([`DISTANCE_BANDS`]): `distance`
/// holds each pixel's distance from the camera (non-finite where no surface is seen).
///
/// # Errors
///
/// [`MetricsError::LengthMismatch`] if the slices differ in length.
pub fn distance_bands(
    v: &[f32],
    v_ref: &[f32],
    receiver_mask: &[bool],
    distance: &[f32],
) -> Result<Vec<BandError>, MetricsError> {
    check_lengths(v, v_ref, receiver_mask)?;
    check_lengths(v, distance, receiver_mask)?;
    let mut bands: Vec<BandError> = DISTANCE_BANDS
        .iter()
        .map(|(band, from, to)| BandError {
            band: band.to_string(),
            from_m: *from,
            to_m: to.is_finite().then_some(*to),
            receiver_pixels: 0,
            shadowed_pixels: 0,
            mae_all: 0.0,
            mae_shadowed: 0.0,
        })
        .collect();
    for i in 0..v.len() {
        let d = f64::from(distance[i]);
        if !receiver_mask[i] || !d.is_finite() || !v_ref[i].is_finite() {
            continue;
        }
        let Some(k) = DISTANCE_BANDS
            .iter()
            .position(|(_, a, b)| d >= *a && d < *b)
        else {
            continue;
        };
        let e = pixel_error(v[i], v_ref[i]);
        let band = &mut bands[k];
        band.receiver_pixels += 1;
        band.mae_all += e;
        if v_ref[i] < 1.0 {
            band.shadowed_pixels += 1;
            band.mae_shadowed += e;
        }
    }
    for band in &mut bands {
        band.mae_all /= band.receiver_pixels.max(1) as f64;
        band.mae_shadowed /= band.shadowed_pixels.max(1) as f64;
    }
    Ok(bands)
}

/// Counts, over **all** values of `v` (receiver or not), the NaNs, the
/// infinities (either sign) and the finite values outside `[0, 1]`.
pub fn stability(v: &[f32]) -> Stability {
    let mut s = Stability::default();
    for &x in v {
        if x.is_nan() {
            s.nan += 1;
        } else if x.is_infinite() {
            s.inf += 1;
        } else if !(0.0..=1.0).contains(&x) {
            s.out_of_range += 1;
        }
    }
    s
}

/// Pixel count `width * height` as `u64`, rejecting empty images.
fn pixel_count(width: u32, height: u32) -> Result<u64, MetricsError> {
    if width == 0 || height == 0 {
        return Err(MetricsError::EmptyImage { width, height });
    }
    Ok(u64::from(width) * u64::from(height))
}

fn check_size(what: &'static str, len: usize, expected: u64) -> Result<(), MetricsError> {
    if len as u64 != expected {
        return Err(MetricsError::SizeMismatch {
            what,
            expected,
            actual: len,
        });
    }
    Ok(())
}

/// Mean NVIDIA FLIP error (LDR-FLIP, via the `nv-flip` crate) between a test
/// image and a reference image, at the default viewing condition
/// ([`nv_flip::DEFAULT_PIXELS_PER_DEGREE`], about 67 pixels per degree).
///
/// Both images are tightly packed, row-major 8-bit sRGB RGB (no alpha),
/// `width * height * 3` bytes each. The result is the mean of FLIP's per-pixel
/// error map, in `[0, 1]` (`0` = indistinguishable). For visibility buffers,
/// convert with [`visibility_to_gray8`] and replicate each byte to R, G and B.
///
/// # Errors
///
/// * [`MetricsError::EmptyImage`] if `width` or `height` is zero.
/// * [`MetricsError::ImageTooLarge`] if `width * height * 3` does not fit in
///   `u32` (a limit of the bindings), whatever the buffers.
/// * [`MetricsError::SizeMismatch`] if either buffer is not exactly
///   `width * height * 3` bytes.
pub fn flip_mean(
    test_rgb8: &[u8],
    reference_rgb8: &[u8],
    width: u32,
    height: u32,
) -> Result<f64, MetricsError> {
    let bytes = pixel_count(width, height)? * 3;
    // The size limit first: it depends on the dimensions alone (and so can be tested without
    // buffers of 4 GiB).
    if bytes > u64::from(u32::MAX) {
        return Err(MetricsError::ImageTooLarge { width, height });
    }
    check_size("test_rgb8", test_rgb8.len(), bytes)?;
    check_size("reference_rgb8", reference_rgb8.len(), bytes)?;

    let reference = nv_flip::FlipImageRgb8::with_data(width, height, reference_rgb8);
    let test = nv_flip::FlipImageRgb8::with_data(width, height, test_rgb8);
    let error_map = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let values = error_map.to_vec();
    let sum: f64 = values.iter().map(|&e| f64::from(e)).sum();
    Ok(sum / values.len() as f64)
}

/// Signed error at which [`difference_image`] reaches full colour: a quarter
/// of the visibility range.
pub const DIFFERENCE_FULL_SCALE: f32 = 0.25;

/// Colour of non-receiver pixels in [`difference_image`] (neutral mid-grey).
pub const DIFFERENCE_NON_RECEIVER: [u8; 3] = [128, 128, 128];

/// Colour of non-finite technique values in [`difference_image`] (magenta).
pub const DIFFERENCE_NON_FINITE: [u8; 3] = [255, 0, 255];

/// False-colour image of the signed error `d = V - V_ref`.
///
/// Colour map, per pixel, first rule that applies:
///
/// 1. `V` non-finite (NaN or ±Inf), receiver or not: magenta
///    [`DIFFERENCE_NON_FINITE`] `(255, 0, 255)`.
/// 2. Not a receiver pixel: mid-grey [`DIFFERENCE_NON_RECEIVER`] `(128, 128, 128)`.
/// 3. Otherwise, with `t = min(|d| / DIFFERENCE_FULL_SCALE, 1)` and
///    `c = round(255 * (1 - t))`:
///    * `d < 0` (technique too dark): `(255, c, c)`, white fading to pure red
///      `(255, 0, 0)` at `d <= -0.25`;
///    * `d > 0` (technique too bright): `(c, c, 255)`, white fading to pure
///      blue `(0, 0, 255)` at `d >= 0.25`;
///    * `d = 0`: white `(255, 255, 255)`.
///
/// For example `d = -0.125` gives `(255, 128, 128)`.
///
/// # Errors
///
/// * [`MetricsError::EmptyImage`] if `width` or `height` is zero.
/// * [`MetricsError::SizeMismatch`] if any slice is not `width * height` long.
/// * [`MetricsError::NonFiniteReference`] if `v_ref` is non-finite on a
///   receiver pixel.
pub fn difference_image(
    v: &[f32],
    v_ref: &[f32],
    receiver_mask: &[bool],
    width: u32,
    height: u32,
) -> Result<image::RgbImage, MetricsError> {
    let pixels = pixel_count(width, height)?;
    check_size("v", v.len(), pixels)?;
    check_size("v_ref", v_ref.len(), pixels)?;
    check_size("receiver_mask", receiver_mask.len(), pixels)?;

    let mut data = Vec::with_capacity(v.len() * 3);
    for (index, ((&vi, &ri), &receiver)) in v.iter().zip(v_ref).zip(receiver_mask).enumerate() {
        let rgb = if !vi.is_finite() {
            DIFFERENCE_NON_FINITE
        } else if !receiver {
            DIFFERENCE_NON_RECEIVER
        } else {
            if !ri.is_finite() {
                return Err(MetricsError::NonFiniteReference { index, value: ri });
            }
            difference_colour(vi - ri)
        };
        data.extend_from_slice(&rgb);
    }
    // The buffer holds exactly width * height * 3 bytes, checked above.
    Ok(image::RgbImage::from_raw(width, height, data)
        .expect("buffer size matches width * height * 3"))
}

/// Colour of a finite signed error `d` (rule 3 of [`difference_image`]).
fn difference_colour(d: f32) -> [u8; 3] {
    let t = (d.abs() / DIFFERENCE_FULL_SCALE).min(1.0);
    let c = (255.0 * (1.0 - t)).round() as u8;
    if d < 0.0 {
        [255, c, c]
    } else if d > 0.0 {
        [c, c, 255]
    } else {
        [255, 255, 255]
    }
}

/// Flicker between two frames: the mean, over pixels that show a receiver in both frames, of
/// `|(V_t - V_t-1) - (E_t - E_t-1)|`, the change the technique shows that the exact answer `E`
/// does not. It is 0 for an exact technique and for one whose error stays the same from frame to
/// frame, whatever its size; a technique that adds noise of standard deviation `s`, drawn anew each
/// frame and independent between frames, gets about `2 s / sqrt(pi)` (the mean of `|N(0, 2 s²)|`).
/// Defined in docs/MOTION.md.
///
/// A non-finite technique value in either frame scores the worst change, `1.0`, at its pixel.
///
/// # Errors
///
/// * [`MetricsError::LengthMismatch`] if the buffers of a frame differ in length, or the two
///   frames differ in size.
/// * [`MetricsError::NoReceivers`] if no pixel shows a receiver in both frames.
/// * [`MetricsError::NonFiniteReference`] if an exact value is NaN or infinite on such a pixel.
pub fn flicker(
    previous: (&[f32], &[f32], &[bool]),
    current: (&[f32], &[f32], &[bool]),
) -> Result<f64, MetricsError> {
    let (v0, e0, m0) = previous;
    let (v1, e1, m1) = current;
    check_lengths(v0, e0, m0)?;
    check_lengths(v1, e1, m1)?;
    check_lengths(v0, v1, m1)?;
    let mut sum = 0.0f64;
    let mut pixels = 0u64;
    for index in 0..v1.len() {
        if !(m0[index] && m1[index]) {
            continue;
        }
        for value in [e0[index], e1[index]] {
            if !value.is_finite() {
                return Err(MetricsError::NonFiniteReference { index, value });
            }
        }
        let change = if v0[index].is_finite() && v1[index].is_finite() {
            let technique = f64::from(v1[index]) - f64::from(v0[index]);
            let truth = f64::from(e1[index]) - f64::from(e0[index]);
            (technique - truth).abs()
        } else {
            1.0
        };
        sum += change;
        pixels += 1;
    }
    if pixels == 0 {
        return Err(MetricsError::NoReceivers);
    }
    Ok(sum / pixels as f64)
}

/// Converts visibility to 8-bit grey for previews: `round(255 * clamp(v, 0, 1))`,
/// one byte per value. NaN maps to `0`, `+Inf` to `255`, `-Inf` to `0`.
/// The values are linear visibility written as bytes, with no sRGB encoding.
pub fn visibility_to_gray8(v: &[f32]) -> Vec<u8> {
    v.iter()
        .map(|&x| {
            if x.is_nan() {
                0
            } else {
                (255.0 * x.clamp(0.0, 1.0)).round() as u8
            }
        })
        .collect()
}

#[cfg(test)]
mod tests;
