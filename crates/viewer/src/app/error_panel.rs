//! The right panel's error section: metrics against the reference, greyed and labelled stale
//! (with what is happening now) until they are of the current setting. The error-against-time
//! plot is its own panel (`plot_panel`).

use softshadow_core::{ParamValue, ShadowTechnique};
use softshadow_metrics::ErrorReport;

use softshadow_reference::Progress;

use super::{reference::ReferenceState, ViewerApp, DEFAULT_REFERENCE_SAMPLES};

/// What the error section shows besides the reference's own state.
pub(super) struct MetricsContext {
    /// The reference of the current inputs: light samples done of all.
    pub(super) progress: Progress,
    /// The metrics: of the current setting (`true`), or an earlier one's, shown stale.
    pub(super) report: Option<(ErrorReport, bool)>,
    /// What the current setting's metrics wait for, now.
    pub(super) pending: String,
    /// For a technique that keeps a history: what its metrics are of.
    pub(super) history_note: Option<String>,
    /// Why no yardstick runs under the current light, if none can.
    pub(super) refused: Option<String>,
}

impl ReferenceState {
    /// The error section: the reference's progress and samples, the metrics (current, or
    /// stale with what they wait for). Returns an error to show, if the samples were refused.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, cx: &MetricsContext) -> Option<String> {
        ui.heading("Error against the reference");
        if let Some(why) = &cx.refused {
            ui.colored_label(ui.visuals().warn_fg_color, no_yardstick_text(why));
            return None;
        }
        let p = cx.progress;
        let samples = self
            .yardstick
            .params()
            .get("samples_per_axis")
            .and_then(ParamValue::as_f64)
            .unwrap_or(DEFAULT_REFERENCE_SAMPLES as f64) as i64;
        ui.add(
            egui::ProgressBar::new(p.fraction())
                .text(format!("reference {} / {} light samples", p.done, p.total)),
        )
        .on_hover_text(
            "Light samples the reference has accumulated for the current scene, light, camera \
             and size; it restarts when one of them changes",
        );
        let mut error = None;
        let mut new_samples = samples;
        if ui
            .add(egui::Slider::new(&mut new_samples, 1..=64).text("samples per axis"))
            .on_hover_text("light samples per axis of the reference: N x N in all")
            .changed()
        {
            error = self
                .yardstick
                .set_param("samples_per_axis", ParamValue::Int(new_samples))
                .err()
                .map(|e| e.to_string());
        }
        match &cx.report {
            Some((report, true)) => {
                ui.label(format!(
                    "metrics rest on {} light samples ({samples} x {samples})",
                    p.total
                ));
                if let Some(note) = &cx.history_note {
                    ui.colored_label(ui.visuals().warn_fg_color, note);
                }
                metrics_grid(ui, report);
            }
            Some((report, false)) => {
                // Metrics belong to one setting: an earlier one's are shown greyed, never as
                // current, with what is happening now.
                ui.colored_label(
                    ui.visuals().warn_fg_color,
                    format!(
                        "stale: these metrics are of an earlier setting; {}",
                        cx.pending
                    ),
                );
                ui.add_enabled_ui(false, |ui| metrics_grid(ui, report));
            }
            None => {
                ui.label(format!("no metrics yet: {}", cx.pending));
            }
        }
        error
    }
}

impl ViewerApp {
    /// The error section's context: progress, metrics, what they wait for.
    pub(super) fn metrics_context(&self) -> MetricsContext {
        let report = match (self.metrics(), self.stale_metrics()) {
            (Some(report), _) => Some((report.clone(), true)),
            (None, Some(report)) => Some((report.clone(), false)),
            (None, None) => None,
        };
        MetricsContext {
            progress: self.shown_reference_progress(),
            report,
            pending: self.metrics_pending(),
            history_note: self.history_note(),
            refused: self.reference_refusal(),
        }
    }

    /// What the metrics of the current setting wait for, now.
    pub(super) fn metrics_pending(&self) -> String {
        let p = self.shown_reference_progress();
        let id = &self.technique.id;
        if !p.is_complete() {
            format!(
                "the reference is accumulating ({} / {} light samples)",
                p.done, p.total
            )
        } else if let Some(error) = &self.technique.error {
            format!("{id} has no frame: {error}")
        } else if self.technique.build.is_running() {
            format!("{id} is building its precompute")
        } else if self.technique.cancelled_frame.is_some() {
            format!("{id}'s frame was cancelled (Render again)")
        } else if self.technique.shown_key != Some(self.current_setting_key()) {
            format!("waiting for {id}'s frame of this setting")
        } else {
            "measuring".into()
        }
    }

    /// For a technique that keeps a history: what its shown metrics are of (its history is
    /// still settling, or settled after how many frames).
    fn history_note(&self) -> Option<String> {
        let measured = self.reference.measured.as_ref()?;
        let id = &self.technique.id;
        match (self.history_length(), measured.settled_after) {
            (None, _) => None,
            (Some(_), Some(n)) => Some(format!(
                "{id} keeps a history: these are of its settled frame, after {n} still frames"
            )),
            (Some(target), None) => Some(format!(
                "{id} keeps a history: these are of a frame whose history is still settling                  ({} of about {target} still frames); the settled error replaces them",
                self.technique.history.still_frames
            )),
        }
    }
}

/// What the error section says under a light no yardstick samples: why, and what measures it.
pub(super) fn no_yardstick_text(why: &str) -> String {
    format!(
        "no metrics here: {why}. The timeline's error against the exact answer \
         (a path's steps, ray-traced or ray cast for every light kind) measures it; \
         `workbench bench` does too"
    )
}

fn metrics_grid(ui: &mut egui::Ui, report: &ErrorReport) {
    egui::Grid::new("metrics").striped(true).show(ui, |ui| {
        let mut row = |name: &str, value: String, hint: &str| {
            ui.label(name).on_hover_text(hint);
            ui.label(value);
            ui.end_row();
        };
        row(
            "mae_shadowed",
            format!("{:.4}", report.mae_shadowed),
            "mean |V - V_ref| where V_ref < 1 (Atty et al. 4.2.1)",
        );
        row(
            "mae_all",
            format!("{:.4}", report.mae_all),
            "over all receivers",
        );
        row("rmse", format!("{:.4}", report.rmse), "over all receivers");
        row(
            "max_abs",
            format!("{:.4}", report.max_abs),
            "largest |V - V_ref|",
        );
        row(
            "p99_abs",
            format!("{:.4}", report.p99_abs),
            "99th percentile",
        );
        row(
            "flip_mean",
            report.flip_mean.map_or("-".into(), |f| format!("{f:.4}")),
            "mean FLIP of the shaded images",
        );
        row(
            "shadowed / receiver px",
            format!("{} / {}", report.shadowed_pixels, report.receiver_pixels),
            "",
        );
    });
}
