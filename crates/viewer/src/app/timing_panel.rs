//! The right panel's GPU time section: frame time, the passes this frame ran (light-space passes
//! are absent while only the camera moves), per-pass rolling medians, and the cost of computing
//! the technique (frames with its caches dropped, as the benchmark's `timing`).

use std::{collections::VecDeque, time::Instant};

use softshadow_core::FrameOutput;

use super::{format_ms, FrameStats, ViewerApp, COST_FRAMES};
use crate::timing::{median, PassRow, RollingTimings};

/// GPU timings of the current setting and the frame-time window.
#[derive(Default)]
pub(super) struct TimingState {
    /// GPU timings of the latest frames of the current setting (what the table shows).
    pub(super) rolling: RollingTimings,
    /// GPU timings of frames rendered after `invalidate_cache()`: the cost of computing.
    pub(super) cost: RollingTimings,
    /// Everything the timings and the frame-time window belong to (technique, parameters,
    /// scene, light, camera, size): a change empties both.
    pub(super) setting_key: Option<u64>,
    pub(super) last_output: Option<FrameOutput>,
    pub(super) frame_times: VecDeque<f64>,
    pub(super) last_frame: Option<Instant>,
    /// Frames rendered so far.
    pub(super) frames: u64,
}

impl ViewerApp {
    pub(super) fn timing_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("GPU time");
        let stats = self.stats();
        ui.label(format!(
            "frame time {} (median of {} frames of this setting)",
            stats
                .frame_ms
                .map_or("-".into(), |ms| format!("{ms:.1} ms, {:.1} fps", 1e3 / ms)),
            self.timing.frame_times.len()
        ));
        if let Some(output) = &self.timing.last_output {
            ui.label(format!(
                "technique frame CPU wall time {:.1} ms",
                output.cpu_ms
            ));
        }
        let source = self.timing.last_output.as_ref().map(|o| o.timing_source);
        if let Some(source) = source {
            ui.label(format!("pass times: {source}")).on_hover_text(
                "serial: each pass submitted on its own and waited for, its wall time is the \
                 pass time (the default on a CPU adapter, where timestamps do not wait for \
                 compute work); timestamps: GPU timestamp queries (the default on a GPU)",
            );
        }
        if self
            .timing
            .last_output
            .as_ref()
            .is_some_and(|o| o.gpu.is_none())
        {
            ui.label("this adapter has no timestamp queries: GPU times unavailable");
            return;
        }

        // The cost of computing: what the plot and the benchmark's `timing` use.
        match self.timing.cost.technique_ms() {
            Some(ms) if self.timing.cost.len() >= COST_FRAMES => {
                ui.strong(format!("cost of the technique {} ms", format_ms(ms)))
                    .on_hover_text(
                        "median GPU time of the technique's passes over frames rendered with its \
                         kept results dropped (invalidate_cache), as the benchmark's `timing`",
                    );
            }
            _ => {
                ui.label(format!(
                    "measuring the cost: frame {} of {COST_FRAMES} with caches dropped",
                    self.timing.cost.len()
                ));
            }
        }

        let rows = self.timing.rolling.rows();
        if rows.is_empty() {
            ui.label("no GPU timings yet");
            return;
        }
        ui.small(format!(
            "this frame's passes, median of the last {} frames ({})",
            self.timing.rolling.len(),
            source.map_or("-", |s| s.as_str())
        ));
        egui::Grid::new("timings").striped(true).show(ui, |ui| {
            ui.strong("pass");
            ui.strong("ms");
            ui.end_row();
            for row in &rows {
                ui.label(&row.name);
                ui.label(format_ms(row.median_ms));
                ui.end_row();
            }
            ui.strong("technique");
            ui.strong(format_ms(self.timing.rolling.technique_ms().unwrap_or(0.0)));
            ui.end_row();
            ui.strong("frame");
            ui.strong(format_ms(self.timing.rolling.total_ms().unwrap_or(0.0)));
            ui.end_row();
        });
        // Passes the full computation runs that this frame left out (kept results).
        let passes_run = self.passes_run();
        let skipped: Vec<String> = self
            .timing
            .cost
            .rows()
            .into_iter()
            .map(|r| r.name)
            .filter(|name| !passes_run.contains(name))
            .collect();
        if !skipped.is_empty() {
            ui.label(format!("kept, not run this frame: {}", skipped.join(", ")))
                .on_hover_text(
                    "light-space results are kept while only the camera moves \
                     (FrameChanges::light_space)",
                );
        }
        timing_chart(ui, &rows);
    }
}

/// One bar per pass, longest = the chart's width, with the pass's name and time written over its
/// bar: every bar is labelled, one row each, whatever the number of passes (an egui_plot bar
/// chart labelled through its axis showed only the names its tick spacing allowed, often one).
fn timing_chart(ui: &mut egui::Ui, rows: &[PassRow]) {
    let longest = rows.iter().map(|r| r.median_ms).fold(0.0, f64::max);
    let font = egui::TextStyle::Small.resolve(ui.style());
    let row_height = ui.text_style_height(&egui::TextStyle::Small) + 6.0;
    let width = ui.available_width();
    let (rect, _) = ui.allocate_exact_size(
        egui::vec2(width, row_height * rows.len() as f32),
        egui::Sense::hover(),
    );
    let painter = ui.painter_at(rect);
    let bar_colour = egui::Color32::from_rgb(90, 170, 250).gamma_multiply(0.45);
    let text_colour = ui.visuals().strong_text_color();
    for (i, row) in rows.iter().enumerate() {
        let top = rect.top() + row_height * i as f32;
        let fraction = if longest > 0.0 {
            (row.median_ms / longest).clamp(0.0, 1.0) as f32
        } else {
            0.0
        };
        let bar = egui::Rect::from_min_size(
            egui::pos2(rect.left(), top + 1.0),
            egui::vec2(width * fraction, row_height - 2.0),
        );
        painter.rect_filled(bar, 2.0, bar_colour);
        painter.text(
            egui::pos2(rect.left() + 4.0, top + row_height * 0.5),
            egui::Align2::LEFT_CENTER,
            format!("{}  {} ms", row.name, format_ms(row.median_ms)),
            font.clone(),
            text_colour,
        );
    }
}

impl ViewerApp {
    /// Rows of the timing table (passes of the current technique, rolling medians).
    pub fn timing_rows(&self) -> Vec<PassRow> {
        self.timing.rolling.rows()
    }

    /// Passes the technique's last frame ran (light-space passes are absent on camera-only
    /// frames), G-buffer and shading included.
    pub fn passes_run(&self) -> &[String] {
        self.timing
            .last_output
            .as_ref()
            .map_or(&[][..], |o| o.passes_run.as_slice())
    }

    /// Rolling GPU timings of frames rendered with the caches dropped (the cost of computing).
    pub fn cost_rows(&self) -> Vec<PassRow> {
        self.timing.cost.rows()
    }

    /// Median technique GPU time of the frames rendered with the caches dropped, ms.
    pub fn cost_ms(&self) -> Option<f64> {
        self.timing.cost.technique_ms()
    }

    pub fn stats(&self) -> FrameStats {
        FrameStats {
            frame_ms: (!self.timing.frame_times.is_empty())
                .then(|| median(self.timing.frame_times.iter().copied())),
            frames: self.timing.frames,
        }
    }
}
