use super::{format_tick, linear_ticks, log_ticks};

/// The linear time axis: every plot range gets two or three round ticks, each labelled, a
/// label per tick (egui_plot's default labelled only "0" on a narrow plot).
#[test]
fn the_linear_time_axis_has_two_or_three_labelled_ticks_at_every_scale() {
    for max_ms in [0.05, 0.7, 3.0, 12.0, 48.0, 660.0, 1_200.0, 48_000.0] {
        let bounds = (0.0, max_ms * 1.2);
        let ticks = linear_ticks(bounds, 3);
        let labels: Vec<String> = ticks.iter().map(|t| format_tick(t.value)).collect();
        assert!((2..=4).contains(&ticks.len()), "{bounds:?}: {labels:?}");
        assert!(ticks
            .iter()
            .all(|t| t.value >= bounds.0 && t.value <= bounds.1));
        let mut distinct = labels.clone();
        distinct.dedup();
        assert_eq!(distinct, labels, "{bounds:?}: every tick has its own label");
        assert!(
            labels.iter().all(|l| !l.is_empty() && l.len() <= 6),
            "{labels:?}"
        );
    }
    assert!(linear_ticks((1.0, 1.0), 3).is_empty());
    assert!(linear_ticks((0.0, f64::NAN), 3).is_empty());
    assert_eq!(format_tick(0.25), "0.25");
    assert_eq!(format_tick(20_000.0), "20000");
}

/// The log time axis (issue 43: it had no tick labels): at least two ticks over every range the
/// plot fits, each with its own non-empty label, at most the asked number, inside the bounds.
#[test]
fn the_log_time_axis_has_labelled_ticks_at_every_scale() {
    for (lo_ms, hi_ms) in [
        (0.4, 0.6),
        (1.0, 3.0),
        (0.05, 40.0),
        (2.0, 2_000.0),
        (0.01, 60_000.0),
    ] {
        // As the panel fits them: whole decades around the points, with a margin.
        let bounds = (
            f64::log10(lo_ms).floor() - 0.2,
            (f64::log10(hi_ms).ceil() + 0.2).max(f64::log10(lo_ms) + 1.0),
        );
        for max_ticks in [3, 6, 10] {
            let ticks = log_ticks(bounds, max_ticks);
            let labels: Vec<String> = ticks
                .iter()
                .map(|t| format_tick(10f64.powf(t.value)))
                .collect();
            assert!(
                (2..=max_ticks).contains(&ticks.len()),
                "{bounds:?}, {max_ticks}: {labels:?}"
            );
            assert!(ticks
                .iter()
                .all(|t| t.value >= bounds.0 && t.value <= bounds.1 && t.step_size > 0.0));
            let mut distinct = labels.clone();
            distinct.dedup();
            assert_eq!(distinct, labels, "{bounds:?}: every tick has its own label");
            assert!(labels.iter().all(|l| !l.is_empty()), "{labels:?}");
        }
    }
    assert_eq!(format_tick(10f64.powf(f64::log10(2.0))), "2");
    assert_eq!(format_tick(0.05), "0.05");
    assert!(log_ticks((1.0, 1.0), 3).is_empty());
}
