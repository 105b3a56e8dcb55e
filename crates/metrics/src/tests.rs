//! Known-answer tests. Values are chosen to be exactly representable in `f32`
//! so that most expected results are exact.

use super::*;

#[test]
fn identical_images_give_zero_error() {
    let v: Vec<f32> = (0..64).map(|i| (i % 9) as f32 / 8.0).collect();
    let mask = vec![true; v.len()];
    let r = compare(&v, &v, &mask).unwrap();
    assert_eq!(r.mae_shadowed, 0.0);
    assert_eq!(r.mae_all, 0.0);
    assert_eq!(r.rmse, 0.0);
    assert_eq!(r.max_abs, 0.0);
    assert_eq!(r.p99_abs, 0.0);
    assert_eq!(r.receiver_pixels, 64);
    // i % 9 == 8 gives exactly 1.0 (lit); 64 values contain 7 such (i = 8, 17, ..., 62).
    assert_eq!(r.shadowed_pixels, 64 - 7);
    assert_eq!(r.flip_mean, None);
}

/// Hand-computed case: five pixels, one masked out, two lit reference pixels.
///
/// | pixel | V     | V_ref | receiver | e     | shadowed |
/// |-------|-------|-------|----------|-------|----------|
/// | 0     | 0.5   | 0.25  | yes      | 0.25  | yes      |
/// | 1     | 0.0   | 0.5   | yes      | 0.5   | yes      |
/// | 2     | 1.0   | 1.0   | yes      | 0     | no (lit) |
/// | 3     | 0.875 | 1.0   | yes      | 0.125 | no (lit) |
/// | 4     | 0.2   | 0.0   | no       | -     | -        |
///
/// mae_shadowed = (0.25 + 0.5) / 2 = 0.375, of it darker (pixel 1, V < V_ref) 0.5 / 2 = 0.25;
/// mae_all = 0.875 / 4 = 0.21875;
/// rmse = sqrt((0.0625 + 0.25 + 0 + 0.015625) / 4) = sqrt(0.08203125) = 0.2864109809...;
/// max = 0.5; p99 rank = ceil(0.99 * 4) = 4, i.e. the maximum 0.5.
#[test]
fn hand_computed_small_case() {
    let v = [0.5, 0.0, 1.0, 0.875, 0.2];
    let v_ref = [0.25, 0.5, 1.0, 1.0, 0.0];
    let mask = [true, true, true, true, false];
    let r = compare(&v, &v_ref, &mask).unwrap();
    let expected = ErrorReport {
        mae_shadowed: 0.375,
        darker_shadowed: 0.25,
        // Pixel 4, the only umbra pixel, is not a receiver.
        brighter_umbra: 0.0,
        umbra_pixels: 0,
        mae_all: 0.21875,
        rmse: 0.08203125f64.sqrt(),
        max_abs: 0.5,
        p99_abs: 0.5,
        shadowed_pixels: 2,
        receiver_pixels: 4,
        flip_mean: None,
    };
    assert_eq!(r, expected);
    assert!((r.rmse - 0.286_410_980_9).abs() < 1e-9);
}

#[test]
fn p99_is_nearest_rank_not_interpolated() {
    // Errors i / 256 for i in 0..n (exact in f32), reference all in shadow.
    for (n, expected_i) in [(1u32, 0u32), (100, 98), (101, 99), (200, 197), (1000, 989)] {
        let v: Vec<f32> = (0..n).rev().map(|i| i as f32 / 256.0 / 8.0).collect();
        let v_ref = vec![0.0; n as usize];
        let mask = vec![true; n as usize];
        let r = compare(&v, &v_ref, &mask).unwrap();
        // rank = ceil(0.99 n): 1 -> 1, 100 -> 99, 101 -> 100, 200 -> 198, 1000 -> 990.
        assert_eq!(r.p99_abs, f64::from(expected_i) / 2048.0, "n = {n}");
        assert_eq!(r.max_abs, f64::from(n - 1) / 2048.0);
    }
}

#[test]
fn no_shadowed_pixels_gives_zero_mae_shadowed() {
    let v = [0.5, 1.0];
    let v_ref = [1.0, 1.0];
    let r = compare(&v, &v_ref, &[true, true]).unwrap();
    assert_eq!(r.shadowed_pixels, 0);
    assert_eq!(r.mae_shadowed, 0.0);
    assert_eq!(r.mae_all, 0.25);
}

#[test]
fn shadowed_test_is_exact_below_one() {
    // The largest f32 below 1.0 is in shadow (penumbra); 1.0 exactly is lit.
    let just_below = f32::from_bits(1.0f32.to_bits() - 1);
    let r = compare(&[1.0, 1.0], &[just_below, 1.0], &[true, true]).unwrap();
    assert_eq!(r.shadowed_pixels, 1);
}

#[test]
fn non_finite_technique_values_score_error_one() {
    let v = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.5, f32::NAN];
    let v_ref = [0.0, 1.0, 0.5, 0.5, 0.0];
    // Last pixel is not a receiver: its NaN is ignored by compare.
    let mask = [true, true, true, true, false];
    let r = compare(&v, &v_ref, &mask).unwrap();
    assert_eq!(r.mae_all, 0.75);
    assert_eq!(r.max_abs, 1.0);
    assert_eq!(r.p99_abs, 1.0);
    assert_eq!(r.rmse, 0.75f64.sqrt());
    // Shadowed: pixels 0 (e = 1), 2 (e = 1), 3 (e = 0).
    assert_eq!(r.shadowed_pixels, 3);
    assert_eq!(r.mae_shadowed, 2.0 / 3.0);
    assert_eq!(r.receiver_pixels, 4);

    // stability counts over all values, receivers or not.
    assert_eq!(
        stability(&v),
        Stability {
            nan: 2,
            inf: 2,
            out_of_range: 0
        }
    );
}

#[test]
fn stability_counts_out_of_range() {
    let v = [-0.1, 1.5, 0.0, -0.0, 1.0, 0.5, f32::NAN, f32::MAX];
    assert_eq!(
        stability(&v),
        Stability {
            nan: 1,
            inf: 0,
            out_of_range: 3
        }
    );
    assert_eq!(stability(&[]), Stability::default());
}

#[test]
fn mismatched_lengths_error() {
    let e = compare(&[0.0; 3], &[0.0; 4], &[true; 3]).unwrap_err();
    assert_eq!(
        e,
        MetricsError::LengthMismatch {
            v: 3,
            v_ref: 4,
            mask: 3
        }
    );
    let e = compare(&[0.0; 3], &[0.0; 3], &[true; 2]).unwrap_err();
    assert!(matches!(e, MetricsError::LengthMismatch { mask: 2, .. }));
}

#[test]
fn no_receivers_error() {
    let e = compare(&[0.0; 3], &[0.0; 3], &[false; 3]).unwrap_err();
    assert_eq!(e, MetricsError::NoReceivers);
    assert_eq!(
        e.to_string(),
        "no receiver pixels in view: point the camera at a shadow receiver"
    );
    assert_eq!(
        compare(&[], &[], &[]).unwrap_err(),
        MetricsError::NoReceivers
    );
}

#[test]
fn non_finite_reference_is_an_error_on_receivers_only() {
    let e = compare(&[0.0, 0.0], &[0.0, f32::INFINITY], &[true, true]).unwrap_err();
    assert!(matches!(
        e,
        MetricsError::NonFiniteReference { index: 1, .. }
    ));
    assert!(e.to_string().contains("reference is broken"));
    // Ignored where there is no receiver.
    let r = compare(&[0.0, 0.0], &[0.0, f32::NAN], &[true, false]).unwrap();
    assert_eq!(r.receiver_pixels, 1);
}

#[test]
fn report_serde_round_trip() {
    let r = compare(&[0.5, 1.0], &[0.25, 1.0], &[true, true]).unwrap();
    let r = ErrorReport {
        flip_mean: Some(0.125),
        ..r
    };
    let json = serde_json::to_string(&r).unwrap();
    assert!(json.contains("\"mae_shadowed\":0.25"));
    assert!(json.contains("\"flip_mean\":0.125"));
    let back: ErrorReport = serde_json::from_str(&json).unwrap();
    assert_eq!(back, r);
}

/// Results written before `darker_shadowed` existed still load (as 0), and a too-light technique
/// has none of its error in it while a too-dark one has all of it.
#[test]
fn darker_shadowed_is_the_too_dark_part_and_old_results_load() {
    let json = r#"{"mae_shadowed":0.25,"mae_all":0.125,"rmse":0.1,"max_abs":0.25,"p99_abs":0.25,"shadowed_pixels":1,"receiver_pixels":2,"flip_mean":null}"#;
    let old: ErrorReport = serde_json::from_str(json).unwrap();
    assert_eq!(old.darker_shadowed, 0.0);
    let v_ref = [0.25, 0.5, 1.0];
    let mask = [true; 3];
    let light = compare(&[0.5, 0.75, 1.0], &v_ref, &mask).unwrap();
    assert_eq!((light.mae_shadowed, light.darker_shadowed), (0.25, 0.0));
    let dark = compare(&[0.0, 0.25, 0.5], &v_ref, &mask).unwrap();
    // Pixel 2 is lit in the reference: not a shadowed pixel, so in neither mean.
    assert_eq!((dark.mae_shadowed, dark.darker_shadowed), (0.25, 0.25));
    let equal = compare(&v_ref, &v_ref, &mask).unwrap();
    assert_eq!(equal.darker_shadowed, 0.0);
}

/// Light leaking: only umbra pixels count, only where the technique is brighter, over all umbra
/// pixels; old results load as 0.
#[test]
fn brighter_umbra_is_the_too_bright_part_inside_umbrae() {
    let json = r#"{"mae_shadowed":0.25,"mae_all":0.125,"rmse":0.1,"max_abs":0.25,"p99_abs":0.25,"shadowed_pixels":1,"receiver_pixels":2,"flip_mean":null}"#;
    let old: ErrorReport = serde_json::from_str(json).unwrap();
    assert_eq!((old.brighter_umbra, old.umbra_pixels), (0.0, 0));
    // Two umbra pixels (0 and 0.005), one penumbra, one lit.
    let v_ref = [0.0, 0.005, 0.5, 1.0];
    let mask = [true; 4];
    let leaking = compare(&[0.5, 0.005, 0.9, 1.0], &v_ref, &mask).unwrap();
    assert_eq!(leaking.umbra_pixels, 2);
    assert_eq!(leaking.brighter_umbra, 0.25);
    // Too dark in the penumbra and exact in the umbra: no leak.
    let dark = compare(&[0.0, 0.0, 0.1, 1.0], &v_ref, &mask).unwrap();
    assert_eq!(dark.brighter_umbra, 0.0);
    // A NaN in the umbra counts as the worst leak.
    let nan = compare(&[f32::NAN, 0.005, 0.5, 1.0], &v_ref, &mask).unwrap();
    assert_eq!(nan.brighter_umbra, 0.5);
    let lit = compare(&[1.0; 4], &[1.0; 4], &mask).unwrap();
    assert_eq!((lit.brighter_umbra, lit.umbra_pixels), (0.0, 0));
}

fn rgb_from_gray(gray: &[u8]) -> Vec<u8> {
    gray.iter().flat_map(|&g| [g, g, g]).collect()
}

#[test]
fn flip_identical_is_zero_and_black_vs_white_is_large() {
    let (w, h) = (32u32, 24u32);
    let v: Vec<f32> = (0..w * h)
        .map(|i| ((i % w) as f32 / (w - 1) as f32) * ((i / w) as f32 / (h - 1) as f32))
        .collect();
    let img = rgb_from_gray(&visibility_to_gray8(&v));
    let same = flip_mean(&img, &img, w, h).unwrap();
    assert!(same.abs() < 1e-6, "identical images: FLIP mean {same}");

    let black = vec![0u8; (w * h * 3) as usize];
    let white = vec![255u8; (w * h * 3) as usize];
    let bw = flip_mean(&black, &white, w, h).unwrap();
    assert!(bw > 0.5 && bw <= 1.0, "black vs white: FLIP mean {bw}");
    // A mild difference lies strictly between the two.
    let grey = vec![200u8; (w * h * 3) as usize];
    let mild = flip_mean(&grey, &white, w, h).unwrap();
    assert!(mild > 0.0 && mild < bw, "grey vs white: FLIP mean {mild}");
}

#[test]
fn flip_validates_sizes() {
    let a = vec![0u8; 4 * 4 * 3];
    let e = flip_mean(&a, &a[..47], 4, 4).unwrap_err();
    assert_eq!(
        e,
        MetricsError::SizeMismatch {
            what: "reference_rgb8",
            expected: 48,
            actual: 47
        }
    );
    assert!(matches!(
        flip_mean(&a, &a, 4, 5).unwrap_err(),
        MetricsError::SizeMismatch {
            what: "test_rgb8",
            ..
        }
    ));
    assert_eq!(
        flip_mean(&[], &[], 0, 4).unwrap_err(),
        MetricsError::EmptyImage {
            width: 0,
            height: 4
        }
    );
}

/// The bindings take `u32` byte counts: `width * height * 3` may be `u32::MAX` but no more. The
/// limit is checked before the buffers, so no 4 GiB buffer is needed to test it.
#[test]
fn flip_refuses_images_past_u32_max_bytes_and_accepts_exactly_that() {
    // 65537 * 21845 * 3 = 4294967295 = u32::MAX: allowed, so the (empty) buffers are checked.
    assert!(matches!(
        flip_mean(&[], &[], 65537, 21845).unwrap_err(),
        MetricsError::SizeMismatch {
            what: "test_rgb8",
            ..
        }
    ));
    // One row more is past the limit.
    assert_eq!(
        flip_mean(&[], &[], 65537, 21846).unwrap_err(),
        MetricsError::ImageTooLarge {
            width: 65537,
            height: 21846
        }
    );
}

#[test]
fn difference_image_colours_at_known_pixels() {
    // 3x2 image, row-major.
    //   (0,0) d = 0      -> white
    //   (1,0) d = -0.25  -> full red
    //   (2,0) d = +0.5   -> full blue (saturated beyond the full scale)
    //   (0,1) d = -0.125 -> half red (255, 128, 128)
    //   (1,1) not a receiver -> mid-grey
    //   (2,1) V = NaN    -> magenta
    let v = [0.5, 0.25, 1.0, 0.375, 0.0, f32::NAN];
    let v_ref = [0.5, 0.5, 0.5, 0.5, 1.0, 0.5];
    let mask = [true, true, true, true, false, true];
    let img = difference_image(&v, &v_ref, &mask, 3, 2).unwrap();
    assert_eq!((img.width(), img.height()), (3, 2));
    assert_eq!(img.get_pixel(0, 0).0, [255, 255, 255]);
    assert_eq!(img.get_pixel(1, 0).0, [255, 0, 0]);
    assert_eq!(img.get_pixel(2, 0).0, [0, 0, 255]);
    assert_eq!(img.get_pixel(0, 1).0, [255, 128, 128]);
    assert_eq!(img.get_pixel(1, 1).0, DIFFERENCE_NON_RECEIVER);
    assert_eq!(img.get_pixel(2, 1).0, DIFFERENCE_NON_FINITE);
    assert_eq!(DIFFERENCE_NON_FINITE, [255, 0, 255]);

    // Half-scale too bright: (128, 128, 255).
    let img = difference_image(&[0.625], &[0.5], &[true], 1, 1).unwrap();
    assert_eq!(img.get_pixel(0, 0).0, [128, 128, 255]);
}

#[test]
fn difference_image_validates_sizes() {
    let e = difference_image(&[0.0; 5], &[0.0; 6], &[true; 6], 3, 2).unwrap_err();
    assert!(matches!(
        e,
        MetricsError::SizeMismatch {
            what: "v",
            expected: 6,
            actual: 5
        }
    ));
    let e = difference_image(&[0.0; 6], &[0.0; 6], &[true; 5], 3, 2).unwrap_err();
    assert!(matches!(
        e,
        MetricsError::SizeMismatch {
            what: "receiver_mask",
            ..
        }
    ));
    let e = difference_image(&[0.0], &[f32::NAN], &[true], 1, 1).unwrap_err();
    assert!(matches!(
        e,
        MetricsError::NonFiniteReference { index: 0, .. }
    ));
}

#[test]
fn gray8_clamps_and_rounds() {
    let v = [
        0.0,
        1.0,
        0.5,
        -3.0,
        2.0,
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
    ];
    assert_eq!(
        visibility_to_gray8(&v),
        vec![0, 255, 128, 0, 255, 0, 255, 0]
    );
}

/// Flicker counts the technique's change beyond the truth's: a steady error (a constant offset)
/// gives 0, a change the truth also makes gives 0, noise gives its mean absolute change.
#[test]
fn flicker_counts_only_the_change_the_truth_does_not_make() {
    let e0 = [0.5f32, 0.25, 1.0, 0.0];
    let e1 = [0.75f32, 0.25, 1.0, 0.5];
    let mask = [true, true, true, true];
    // The exact answer itself: no flicker however much it changes.
    assert_eq!(flicker((&e0, &e0, &mask), (&e1, &e1, &mask)).unwrap(), 0.0);
    // A steady offset of 0.25 on every pixel: the error is large, the flicker 0.
    let v0: Vec<f32> = e0.iter().map(|e| e - 0.25).collect();
    let v1: Vec<f32> = e1.iter().map(|e| e - 0.25).collect();
    assert_eq!(flicker((&v0, &e0, &mask), (&v1, &e1, &mask)).unwrap(), 0.0);
    // A still technique on a changing truth: the truth's mean absolute change, 0.75 / 4.
    assert_eq!(
        flicker((&e0, &e0, &mask), (&e0, &e1, &mask)).unwrap(),
        0.1875
    );
    // Pixels that are receivers in only one frame do not count; NaN scores 1.
    let partial = [true, false, true, true];
    let v1 = [0.5f32, 0.0, f32::NAN, 0.0];
    assert_eq!(
        flicker((&e0, &e0, &mask), (&v1, &e0, &partial)).unwrap(),
        1.0 / 3.0
    );
    assert!(matches!(
        flicker((&e0, &e0, &[false; 4]), (&e0, &e0, &mask)),
        Err(MetricsError::NoReceivers)
    ));
    assert!(matches!(
        flicker((&e0, &e0, &mask), (&e0[..3], &e0[..3], &mask[..3])),
        Err(MetricsError::LengthMismatch { .. })
    ));
}

/// Hand-computed irradiance errors: four receivers and one masked out.
///
/// | pixel | V    | V_ref | E     | E0  | \|V E0 - E\| | shadowed |
/// |-------|------|-------|-------|-----|------------|----------|
/// | 0     | 0.5  | 0.25  | 0.125 | 0.5 | 0.125      | yes      |
/// | 1     | 1.0  | 0.0   | 0.0   | 0.0 | 0 (faces away) | yes  |
/// | 2     | 1.0  | 1.0   | 0.25  | 0.25| 0          | no       |
/// | 3     | NaN  | 0.5   | 0.25  | 1.0 | 0.75 (worse of 0 and 1) | yes |
/// | 4     | 0.0  | 1.0   | 1.0   | 1.0 | -          | masked   |
///
/// All: 0.875 / 1.75 = 0.5; shadowed: 0.875 / 1.5.
#[test]
fn irradiance_errors_by_hand() {
    let v = [0.5, 1.0, 1.0, f32::NAN, 0.0];
    let v_ref = [0.25, 0.0, 1.0, 0.5, 1.0];
    let e = [0.125, 0.0, 0.25, 0.25, 1.0];
    let e0 = [0.5, 0.0, 0.25, 1.0, 1.0];
    let mask = [true, true, true, true, false];
    let r = compare_irradiance(&v, &v_ref, &e, &e0, &mask).unwrap();
    assert_eq!(r.irradiance_mae, 0.5);
    assert_eq!(r.irradiance_mae_shadowed, 0.875 / 1.5);
    assert_eq!(r.facing_away_pixels, 1);
    // V = E / E0 where E0 > 0 scores 0, whatever V is where the pixel faces away (pixel 1).
    let matching = [0.25, 1.0, 1.0, 0.25, 0.0];
    let exact = compare_irradiance(&matching, &v_ref, &e, &e0, &mask).unwrap();
    assert_eq!(exact.irradiance_mae, 0.0);
    assert!(compare_irradiance(&v, &v_ref, &e[..4], &e0, &mask).is_err());
}

/// Hand-computed band errors: one pixel per band, one in the near band lit by the reference, a
/// masked pixel and one with no surface (infinite distance) left out.
#[test]
fn distance_bands_split_the_error_by_camera_distance() {
    let v = [0.5, 1.0, 0.0, 0.2, 0.0, 0.0];
    let v_ref = [0.0, 0.5, 0.5, 1.0, 1.0, 1.0];
    let mask = [true, true, true, true, false, true];
    let distance = [5.0, 30.0, 200.0, 19.9, 1.0, f32::INFINITY];
    let bands = distance_bands(&v, &v_ref, &mask, &distance).unwrap();
    let got: Vec<(&str, u64, u64, f64, f64)> = bands
        .iter()
        .map(|b| {
            let band = b.band.as_str();
            (
                band,
                b.receiver_pixels,
                b.shadowed_pixels,
                b.mae_all,
                b.mae_shadowed,
            )
        })
        .collect();
    let expected = [
        ("near", 2, 1, 0.65, 0.5),
        ("middle", 1, 1, 0.5, 0.5),
        ("far", 1, 1, 0.5, 0.5),
    ];
    for (g, e) in got.iter().zip(expected) {
        assert_eq!((g.0, g.1, g.2), (e.0, e.1, e.2));
        assert!(
            (g.3 - e.3).abs() < 1e-6 && (g.4 - e.4).abs() < 1e-6,
            "{g:?}"
        );
    }
    assert_eq!(bands[2].to_m, None);
    assert_eq!(bands[0].to_m, Some(20.0));
}
