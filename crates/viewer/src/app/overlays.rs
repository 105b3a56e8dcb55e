//! What appears and goes while the viewer runs, drawn over the image so that no control of the
//! side panels moves when it appears: a precompute's progress (from [`super::build_panel`]),
//! errors, warnings and confirmations (top left, growing downwards, so their buttons stay put) and
//! the legend of the view mode (bottom left).

use super::{technique_panel::debug_legend, ViewerApp};
use crate::display::ViewMode;

/// Errors are kept until dismissed; only the latest few.
const MAX_ERRORS: usize = 8;

/// Errors shown until dismissed, and the last confirmation (where a file went).
#[derive(Default)]
pub(super) struct Messages {
    pub(super) errors: Vec<String>,
    pub(super) status: Option<String>,
}

impl Messages {
    /// Shows `message` until dismissed; one already shown is not shown twice (a yardstick that
    /// fails every frame, as the reference under the sun, would fill the list with one line).
    pub(super) fn push_error(&mut self, message: String) {
        if self.errors.contains(&message) {
            log::debug!("{message}");
            return;
        }
        log::warn!("{message}");
        self.errors.push(message);
        if self.errors.len() > MAX_ERRORS {
            self.errors.remove(0);
        }
    }
}

/// Margin between an overlay and the image's edge, points.
const MARGIN: f32 = 8.0;

impl ViewerApp {
    /// Draws the overlays over `image`, the image area's rectangle.
    pub(super) fn overlays_ui(&mut self, ctx: &egui::Context, image: egui::Rect) {
        // The popup frame's own margins come on top of the content's width.
        let width = (image.width() - 4.0 * MARGIN - 8.0).max(80.0);
        if self.has_legend() {
            egui::Area::new(egui::Id::unique("viewer/legend"))
                .order(egui::Order::Foreground)
                .fixed_pos(image.left_bottom() + egui::vec2(MARGIN, -MARGIN))
                .pivot(egui::Align2::LEFT_BOTTOM)
                .constrain_to(image)
                .show(ctx, |ui| {
                    egui::Frame::popup(ui.style()).show(ui, |ui| {
                        ui.set_max_width(width.min(320.0));
                        self.legend_ui(ui);
                    });
                });
        }
        if self.has_messages() {
            egui::Area::new(egui::Id::unique("viewer/messages"))
                .order(egui::Order::Foreground)
                .fixed_pos(image.left_top() + egui::vec2(MARGIN, MARGIN))
                .constrain_to(image)
                .show(ctx, |ui| {
                    egui::Frame::popup(ui.style()).show(ui, |ui| {
                        ui.set_max_width(width);
                        self.messages_ui(ui);
                    });
                });
        }
    }

    fn has_legend(&self) -> bool {
        matches!(
            self.image.view_mode,
            ViewMode::Split | ViewMode::Difference | ViewMode::Debug
        )
    }

    /// What the colours of the current view mode mean.
    fn legend_ui(&mut self, ui: &mut egui::Ui) {
        match self.image.view_mode {
            ViewMode::Split => {
                ui.small("Left: technique, right: reference. Drag the divider on the image.");
            }
            ViewMode::Difference => {
                ui.small(
                    "Red: too dark, blue: too bright, full colour at |V - V_ref| = 0.25; \
                     white exact, grey off-receiver, magenta NaN/inf.",
                );
            }
            ViewMode::Debug => {
                let legend = self.technique.worker.as_ref().and_then(|w| {
                    w.debug_views
                        .get(self.image.debug_view)
                        .or(w.debug_views.first())
                        .map(|(_, legend)| legend.clone())
                });
                if let Some(message) = &self.image.debug_message {
                    ui.colored_label(egui::Color32::LIGHT_RED, message);
                }
                debug_legend(ui, legend.as_ref(), self.image.debug_mapping.as_ref());
            }
            _ => {}
        }
    }

    fn has_messages(&self) -> bool {
        self.technique.error.is_some()
            || self.file_reload.error().is_some()
            || !self.messages.errors.is_empty()
            || !self.scene.loaded.warnings.is_empty()
            || self.messages.status.is_some()
            || self.technique.build.is_running()
            || self.build_cancelled()
            || self.slow_frame_seconds().is_some()
            || self.cancelled_frame().is_some()
    }

    fn messages_ui(&mut self, ui: &mut egui::Ui) {
        self.technique.build.ui(ui, &self.technique.id);
        self.slow_frame_ui(ui);
        if let Some(error) = &self.technique.error {
            ui.colored_label(egui::Color32::LIGHT_RED, error);
        }
        if let Some(error) = self.file_reload.error() {
            ui.colored_label(egui::Color32::LIGHT_RED, error);
        }
        if !self.messages.errors.is_empty() {
            for error in &self.messages.errors {
                ui.colored_label(egui::Color32::LIGHT_RED, error);
            }
            if ui.button("Dismiss errors").clicked() {
                self.messages.errors.clear();
            }
        }
        for warning in &self.scene.loaded.warnings {
            ui.colored_label(egui::Color32::YELLOW, warning);
        }
        if let Some(status) = self.messages.status.clone() {
            let mut dismissed = false;
            ui.horizontal_wrapped(|ui| {
                // Where the last screenshot, state or sweep went, whichever section is open.
                ui.colored_label(egui::Color32::LIGHT_GREEN, status);
                dismissed = ui.small_button("OK").clicked();
            });
            if dismissed {
                self.messages.status = None;
            }
        }
    }

    /// A technique frame that runs longer than [`super::technique::SLOW_FRAME`]: how long so
    /// far against its last frame, and Cancel; after a Cancel, Render again.
    fn slow_frame_ui(&mut self, ui: &mut egui::Ui) {
        if let Some(seconds) = self.slow_frame_seconds() {
            let in_flight = self.technique.worker.as_ref().and_then(|w| w.in_flight());
            // Only this setting's earlier frame of the same kind says how long it takes.
            let last = in_flight
                .and_then(|f| {
                    self.technique
                        .estimate_ms(f.setting_key, f.invalidate, f.exact)
                })
                .map(|ms| ms / 1e3);
            let exact = in_flight.is_some_and(|f| f.exact);
            ui.group(|ui| {
                ui.label(if exact {
                    format!(
                        "{}: computing a frame and its exact answer (path step {})",
                        self.technique.id, self.timeline.step
                    )
                } else {
                    format!("{}: computing a frame", self.technique.id)
                });
                let text = match last {
                    Some(last) => {
                        format!("{seconds:.1} s of about {last:.1} s (its last such frame)")
                    }
                    None => format!("{seconds:.1} s (no earlier frame of this setting to go by)"),
                };
                let fraction = last.map_or(0.0, |last| (seconds / last.max(1e-3)).min(0.99));
                let bar = egui::ProgressBar::new(fraction as f32);
                // Without an estimate the bar only shows that work goes on.
                ui.add(if last.is_some() {
                    bar
                } else {
                    bar.animate(true)
                });
                ui.label(text);
                if ui
                    .button("Cancel")
                    .on_hover_text(
                        "Stop waiting for this frame: nothing is drawn until Render again (the \
                         device finishes the frame in the background)",
                    )
                    .clicked()
                {
                    self.cancel_frame();
                }
            });
        } else if let Some(message) = self.cancelled_frame().map(str::to_string) {
            ui.group(|ui| {
                ui.label(message);
                if ui.button("Render again").clicked() {
                    self.render_again();
                }
            });
        }
    }
}
