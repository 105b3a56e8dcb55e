//! Rolling GPU timings: per pass, the median over the last frames.

use std::collections::VecDeque;

use softshadow_core::GpuFrameTiming;

/// Frames kept for the rolling medians.
pub const WINDOW: usize = 30;

/// The last [`WINDOW`] frames' timings of one technique (reset when the technique or its
/// settings change, so the table only lists what the current settings run).
#[derive(Default)]
pub struct RollingTimings {
    frames: VecDeque<GpuFrameTiming>,
}

/// One table row.
#[derive(Clone, Debug, PartialEq)]
pub struct PassRow {
    pub name: String,
    pub median_ms: f64,
}

impl RollingTimings {
    pub fn push(&mut self, timing: GpuFrameTiming) {
        if self.frames.len() == WINDOW {
            self.frames.pop_front();
        }
        self.frames.push_back(timing);
    }

    pub fn clear(&mut self) {
        self.frames.clear();
    }

    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Passes of the latest frame, in the order they ran, with their rolling medians (a pass
    /// missing from a frame counts as 0 ms there).
    pub fn rows(&self) -> Vec<PassRow> {
        let Some(latest) = self.frames.back() else {
            return Vec::new();
        };
        latest
            .passes
            .iter()
            .map(|(name, _)| PassRow {
                name: name.clone(),
                median_ms: median(self.frames.iter().map(|f| {
                    f.passes
                        .iter()
                        .find(|(n, _)| n == name)
                        .map_or(0.0, |(_, ms)| *ms)
                })),
            })
            .collect()
    }

    /// Median whole-frame GPU time.
    pub fn total_ms(&self) -> Option<f64> {
        (!self.frames.is_empty()).then(|| median(self.frames.iter().map(|f| f.total_ms)))
    }

    /// Smallest and largest GPU time of the technique's own passes over the window: how noisy
    /// its median is.
    pub fn technique_range(&self) -> Option<(f64, f64)> {
        let times = self.frames.iter().map(|f| f.technique_ms());
        let lo = times.clone().fold(f64::INFINITY, f64::min);
        let hi = times.fold(f64::NEG_INFINITY, f64::max);
        (!self.frames.is_empty() && lo.is_finite() && hi.is_finite()).then_some((lo, hi))
    }

    /// Median GPU time of the technique's own passes.
    pub fn technique_ms(&self) -> Option<f64> {
        (!self.frames.is_empty()).then(|| median(self.frames.iter().map(|f| f.technique_ms())))
    }
}

/// Median of the values (mean of the middle two for an even count); 0 for none.
pub fn median(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let mid = v.len() / 2;
    if v.len() % 2 == 1 {
        v[mid]
    } else {
        (v[mid - 1] + v[mid]) * 0.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(passes: &[(&str, f64)]) -> GpuFrameTiming {
        GpuFrameTiming {
            total_ms: passes.iter().map(|(_, ms)| ms).sum(),
            passes: passes.iter().map(|(n, ms)| (n.to_string(), *ms)).collect(),
        }
    }

    #[test]
    fn medians_roll_over_the_window_and_follow_the_latest_passes() {
        let mut t = RollingTimings::default();
        assert!(t.rows().is_empty() && t.total_ms().is_none());
        for ms in [1.0, 2.0, 100.0] {
            t.push(frame(&[("gbuffer", 1.0), ("pcss/filter", ms)]));
        }
        let rows = t.rows();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].name, "pcss/filter");
        assert_eq!(rows[1].median_ms, 2.0);
        assert_eq!(t.technique_ms(), Some(2.0));
        assert_eq!(t.technique_range(), Some((1.0, 100.0)));
        for _ in 0..WINDOW {
            t.push(frame(&[("gbuffer", 1.0), ("hard/lookup", 5.0)]));
        }
        assert_eq!(t.len(), WINDOW);
        assert_eq!(t.rows()[1].name, "hard/lookup");
        assert_eq!(t.rows()[1].median_ms, 5.0);
        assert_eq!(median([4.0, 1.0, 3.0, 2.0].into_iter()), 2.5);
    }
}
