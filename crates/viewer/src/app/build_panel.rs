//! The precompute of a technique that builds off the UI thread (the PDSM's, issue 13): every
//! technique is switched to background builds when created, so a long precompute runs on a thread
//! of its own and the viewer keeps drawing. While it runs the technique's frames fail with
//! [`TechniqueError::Building`] (nothing drawn, no timing kept, no plot point); this panel shows
//! its progress with a Cancel button, and a Build again button once cancelled.

use softshadow_core::{BuildControl, RenderError, TechniqueError};

use super::ViewerApp;

/// What the active technique's precompute is doing, as the last frame found it.
#[derive(Default)]
pub(super) struct BuildState {
    /// Shared with the technique ([`ShadowTechnique::set_build_control`]): Cancel sets its flag.
    control: BuildControl,
    /// `(done, total, unit)` while a build runs.
    running: Option<(u32, u32, &'static str)>,
    cancelled: bool,
}

impl BuildState {
    /// A new control for a newly created technique (the render worker hands it over and turns
    /// on background builds), forgetting the last technique's build.
    pub(super) fn fresh_control(&mut self) -> BuildControl {
        self.control = BuildControl::default();
        self.running = None;
        self.cancelled = false;
        self.control.clone()
    }

    /// Asks a running precompute to stop (its frame was cancelled).
    pub(super) fn cancel_control(&self) {
        self.control.cancel();
    }

    /// Notes a technique frame's outcome; `true` when the frame only found the build still
    /// running (not an error to show).
    pub(super) fn note(&mut self, result: Result<(), &RenderError>) -> bool {
        self.running = None;
        self.cancelled = false;
        match result {
            Err(RenderError::Technique(TechniqueError::Building {
                done, total, unit, ..
            })) => {
                self.running = Some((*done, *total, unit));
                true
            }
            Err(RenderError::Technique(TechniqueError::Cancelled { .. })) => {
                self.cancelled = true;
                false
            }
            _ => false,
        }
    }

    pub(super) fn is_running(&self) -> bool {
        self.running.is_some()
    }

    /// The running precompute's progress with Cancel, or Build again once cancelled, for
    /// technique `id`.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, id: &str) {
        if let Some((done, total, unit)) = self.running {
            let fraction = if total == 0 {
                0.0
            } else {
                done as f32 / total as f32
            };
            let cancelling = self.control.is_cancelled();
            ui.group(|ui| {
                ui.label(format!("{id}: building its precompute"));
                ui.add(egui::ProgressBar::new(fraction).text(format!(
                    "{:.0} % ({done} of {total} {unit})",
                    fraction * 100.0
                )));
                ui.horizontal(|ui| {
                    if cancelling {
                        ui.label("cancelling...");
                    } else if ui
                        .button("Cancel")
                        .on_hover_text("Stop the build; nothing is drawn until it builds again")
                        .clicked()
                    {
                        self.control.cancel();
                    }
                });
                ui.weak("The frame is drawn, timed and plotted once it is done.");
            });
        } else if self.cancelled {
            ui.group(|ui| {
                ui.label(format!("{id}: precompute cancelled"));
                if ui.button("Build again").clicked() {
                    self.control.clear_cancel();
                    self.cancelled = false;
                }
            });
        }
    }
}

impl ViewerApp {
    /// `(done, total)` units of the precompute building off the UI thread, if one is.
    pub fn build_progress(&self) -> Option<(u32, u32)> {
        self.technique
            .build
            .running
            .map(|(done, total, _)| (done, total))
    }

    /// Whether the last frame found the precompute cancelled.
    pub fn build_cancelled(&self) -> bool {
        self.technique.build.cancelled
    }

    /// Stops the running precompute (the Cancel button); the technique fails with "cancelled"
    /// until [`ViewerApp::build_again`].
    pub fn cancel_build(&mut self) {
        self.technique.build.control.cancel();
    }

    /// Clears the cancel flag: the next frame builds again (the Build again button).
    pub fn build_again(&mut self) {
        self.technique.build.control.clear_cancel();
        self.technique.build.cancelled = false;
    }
}
