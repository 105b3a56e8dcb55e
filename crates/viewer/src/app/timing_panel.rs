//! The right panel's GPU time section: frame time, the passes this frame ran (light-space passes
//! are absent while only the camera moves), per-pass rolling medians, and the cost of computing
//! the technique (frames with its caches dropped, as the benchmark's `timing`).

use std::{collections::VecDeque, time::Instant};

use softshadow_bench::results::FrameKind;
use softshadow_core::FrameOutput;

use super::{format_ms, timeline::PathTimings, FrameStats, ViewerApp, COST_FRAMES};
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
    /// The GPU memory the technique held at its last frame's peak, where the device counts it.
    pub(super) last_memory: Option<softshadow_core::MemoryUse>,
    pub(super) frame_times: VecDeque<f64>,
    pub(super) last_frame: Option<Instant>,
    /// Frames rendered so far.
    pub(super) frames: u64,
    /// A frame of this setting with the caches dropped took longer than [`SLOW_COST_FRAME_MS`]:
    /// the cost rests on the frames measured so far instead of [`COST_FRAMES`].
    pub(super) slow_cost_frames: bool,
}

/// A cost frame slower than this (CPU wall time, ms) is not repeated: five frames of the
/// reference technique took three minutes on lavapipe, during which nothing else could be done.
pub(super) const SLOW_COST_FRAME_MS: f64 = 1000.0;

impl TimingState {
    /// Frames with the caches dropped that the cost of the current setting rests on.
    pub(super) fn cost_frames_wanted(&self) -> usize {
        if self.slow_cost_frames {
            self.cost.len().max(1)
        } else {
            COST_FRAMES
        }
    }

    /// The UI frame interval's median and the frames drawn.
    pub(super) fn stats(&self) -> FrameStats {
        FrameStats {
            frame_ms: (!self.frame_times.is_empty())
                .then(|| median(self.frame_times.iter().copied())),
            frames: self.frames,
        }
    }

    /// Empties the windows when the setting changes (a median never mixes two settings).
    pub(super) fn new_setting(&mut self, key: u64) {
        self.setting_key = Some(key);
        self.rolling.clear();
        self.cost.clear();
        self.frame_times.clear();
        self.slow_cost_frames = false;
    }
}

/// What the timing panel shows besides its own state.
pub(super) struct TimingContext<'a> {
    pub(super) technique: &'a str,
    /// Time from picking the technique to its first frame, ms.
    pub(super) first_frame_ms: Option<f64>,
    /// The technique's frame was cancelled (no cost is being measured).
    pub(super) cancelled: bool,
    /// A path plays (every step is a setting of its own).
    pub(super) playing: bool,
    /// The played path's step timings, when a path is open.
    pub(super) path: Option<Vec<PathTimings>>,
}

impl TimingState {
    /// The GPU time section: frame interval, the cost of computing, this frame's passes.
    pub(super) fn ui(&self, ui: &mut egui::Ui, cx: &TimingContext<'_>) {
        ui.heading("GPU time");
        let stats = self.stats();
        ui.label(format!(
            "UI frame interval {} (median of {} frames of this setting)",
            stats
                .frame_ms
                .map_or("-".into(), |ms| format!("{ms:.1} ms, {:.1} fps", 1e3 / ms)),
            self.frame_times.len()
        ))
        .on_hover_text(
            "Wall time between two drawn viewer frames: the technique's frame, the reference's \
             accumulation step while it converges, the display and egui. The table below holds \
             the technique's own GPU passes only.",
        );
        if let Some(output) = &self.last_output {
            ui.label(format!(
                "technique frame CPU wall time {:.1} ms",
                output.cpu_ms
            ))
            .on_hover_text(
                "Wall time of the technique's last frame on the CPU: recording, \
                 submitting and (with serial timing) waiting for every pass",
            );
        }
        if let Some(ms) = cx.first_frame_ms {
            ui.label(format!(
                "first frame {:.0} ms after {} was picked",
                ms, cx.technique
            ))
            .on_hover_text(
                "From the click that picked the technique to its first frame on screen: device \
                 and pipeline creation and the frame, beside any abandoned frame still running",
            );
        }
        if let Some(m) = &self.last_memory {
            ui.label(format!(
                "GPU memory of the technique {:.1} MiB ({:.1} MiB textures)",
                m.total_mib(),
                m.textures as f64 / (1024.0 * 1024.0)
            ))
            .on_hover_text(
                "The buffers and textures the technique held at its last frame's peak, as the \
                 driver layer counts them (the scene's and the renderer's left out; acceleration \
                 structures are not counted on Vulkan): what the benchmark records as memory.peak",
            );
        }
        let source = self.last_output.as_ref().map(|o| o.timing_source);
        if let Some(source) = source {
            ui.label(format!("pass times: {source}")).on_hover_text(
                "serial: each pass submitted on its own and waited for, its wall time is the \
                 pass time (the default on a CPU adapter, where timestamps do not wait for \
                 compute work); timestamps: GPU timestamp queries (the default on a GPU)",
            );
        }
        if self.last_output.as_ref().is_some_and(|o| o.gpu.is_none()) {
            ui.label("this adapter has no timestamp queries: GPU times unavailable");
            return;
        }

        self.cost_ui(ui, cx.cancelled);

        // A played path makes every step a new setting: its own table, split by what moved.
        if let Some(path) = &cx.path {
            path_timing_ui(ui, path);
        }
        let rows = self.rolling.rows();
        if rows.is_empty() {
            ui.label(if cx.playing {
                "no GPU timings of one setting while the path plays (each step is a new one): \
                 see the path's table above"
            } else {
                "no GPU timings yet"
            });
            return;
        }
        self.passes_ui(ui, &rows, source);
    }

    /// The cost of computing: what the plot and the benchmark's `timing` use.
    fn cost_ui(&self, ui: &mut egui::Ui, cancelled: bool) {
        let wanted = self.cost_frames_wanted();
        match (self.cost.technique_ms(), self.cost.technique_range()) {
            (Some(ms), Some((lo, hi))) if self.cost.len() >= wanted => {
                ui.strong(format!("cost of the technique {} ms", format_ms(ms)))
                    .on_hover_text(
                        "median GPU time of the technique's passes over frames rendered with its \
                         kept results dropped (invalidate_cache), as the benchmark's `timing`",
                    );
                let frames = self.cost.len();
                ui.label(if frames == 1 {
                    "one frame: its spread is not known".to_string()
                } else {
                    format!(
                        "range {} to {} ms over {frames} frames",
                        format_ms(lo),
                        format_ms(hi)
                    )
                })
                .on_hover_text(
                    "the fastest and slowest of the frames the cost rests on: how far a \
                     re-measurement of the same setting may move",
                );
                if self.slow_cost_frames {
                    ui.small(format!(
                        "a frame took over {SLOW_COST_FRAME_MS:.0} ms: not repeated {COST_FRAMES} \
                         times"
                    ));
                }
            }
            _ if cancelled => {
                ui.label("cost not measured: its frame was cancelled");
            }
            _ => {
                ui.label(format!(
                    "measuring the cost: frame {} of {wanted} with caches dropped, each alone \
                     on the CPU",
                    self.cost.len()
                ));
            }
        }
    }

    /// This frame's passes: the table of rolling medians, what was kept, the bar chart.
    fn passes_ui(
        &self,
        ui: &mut egui::Ui,
        rows: &[PassRow],
        source: Option<softshadow_core::TimingSource>,
    ) {
        ui.small(format!(
            "this frame's passes, median of the last {} frames ({})",
            self.rolling.len(),
            source.map_or("-", |s| s.as_str())
        ));
        egui::Grid::new("timings").striped(true).show(ui, |ui| {
            ui.strong("pass");
            ui.strong("ms");
            ui.end_row();
            for row in rows {
                ui.label(&row.name);
                ui.label(format_ms(row.median_ms));
                ui.end_row();
            }
            ui.strong("technique")
                .on_hover_text("the technique's own passes");
            ui.strong(format_ms(self.rolling.technique_ms().unwrap_or(0.0)));
            ui.end_row();
            ui.strong("frame (GPU passes)")
                .on_hover_text("G-buffer, technique and shading passes of the technique's frame");
            ui.strong(format_ms(self.rolling.total_ms().unwrap_or(0.0)));
            ui.end_row();
        });
        // Passes the full computation runs that this frame left out (kept results).
        let passes_run = self
            .last_output
            .as_ref()
            .map_or(&[][..], |o| o.passes_run.as_slice());
        let skipped: Vec<String> = self
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
        timing_chart(ui, rows);
    }
}

/// The timing panel's table of the path's steps: per pass, the median over the last steps
/// of each kind (camera only, light or caster moving, still), as `bench --path` splits its
/// frame times. Nothing without a path or before a step was timed.
fn path_timing_ui(ui: &mut egui::Ui, groups: &[PathTimings]) {
    if groups.is_empty() {
        ui.small("along the path: GPU timings appear as steps are played");
        return;
    }
    let kind_name = |kind: FrameKind| match kind {
        FrameKind::Camera => "camera only",
        FrameKind::Light => "light moving",
        FrameKind::Still => "still",
        FrameKind::First => "first",
    };
    ui.small(format!(
        "along the path: median of the last steps of each kind ({})",
        groups
            .iter()
            .map(|g| format!("{} {}", g.steps, kind_name(g.kind)))
            .collect::<Vec<_>>()
            .join(", ")
    ))
    .on_hover_text(
        "Each step of the path is timed once, as it is first shown, and counted by what \
         changed since the step before: light-space work is redone when the light or a \
         caster moves and may be kept while only the camera moves (FrameChanges), as \
         `bench --path`'s camera-only / light-moving frame times",
    );
    // Every pass any kind ran, in the order first seen.
    let mut names: Vec<&str> = Vec::new();
    for g in groups {
        for p in &g.passes {
            if !names.contains(&p.name.as_str()) {
                names.push(&p.name);
            }
        }
    }
    egui::Grid::new("path timings")
        .striped(true)
        .show(ui, |ui| {
            ui.strong("pass");
            for g in groups {
                ui.strong(format!("{} ms", kind_name(g.kind)));
            }
            ui.end_row();
            for name in names {
                ui.label(name);
                for g in groups {
                    let ms = g.passes.iter().find(|p| p.name == name);
                    ui.label(ms.map_or("-".into(), |p| format_ms(p.median_ms)));
                }
                ui.end_row();
            }
            ui.strong("technique");
            for g in groups {
                ui.strong(format_ms(g.technique_ms));
            }
            ui.end_row();
            ui.strong("frame (GPU passes)");
            for g in groups {
                ui.strong(format_ms(g.total_ms));
            }
            ui.end_row();
        });
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
        self.timing.stats()
    }
}
