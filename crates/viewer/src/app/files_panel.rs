//! The left panel's files section: screenshot, save / load state, puffin.

use std::path::{Path, PathBuf};

use softshadow_core::{ParamValue, ShadowTechnique};

use super::{create_parent, output_dir, scene_panel::load_scene, shown_path, ViewerApp};
use crate::{
    orbit::Orbit,
    state::{ViewerState, STATE_VERSION},
    tradeoff::{sweep_toml, View},
};

/// Paths typed in the Files section, the screenshot asked for, and the puffin server.
pub(super) struct FilesState {
    pub(super) state_path: String,
    pub(super) screenshot_path: String,
    pub(super) screenshot_request: Option<PathBuf>,
    pub(super) puffin_server: Option<puffin_http::Server>,
    pub(super) puffin_message: Option<String>,
}

impl Default for FilesState {
    fn default() -> Self {
        Self {
            state_path: output_dir().join("viewer-state.json").display().to_string(),
            screenshot_path: output_dir().join("screenshot.png").display().to_string(),
            screenshot_request: None,
            puffin_server: None,
            puffin_message: None,
        }
    }
}

/// What the user asked of the files section.
pub(super) enum FilesAction {
    SaveState(PathBuf),
    LoadState(PathBuf),
    Puffin(bool),
}

impl FilesState {
    /// The screenshot, state and puffin controls; returns what the app must do.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui) -> Option<FilesAction> {
        let mut action = None;
        // Each path on its own row, its buttons below: nothing is clipped at the panel's width.
        let width = ui.available_width();
        ui.add(egui::TextEdit::singleline(&mut self.screenshot_path).desired_width(width))
            .on_hover_text(self.screenshot_path.clone());
        if ui.button("Screenshot").clicked() {
            self.screenshot_request = Some(PathBuf::from(self.screenshot_path.trim()));
        }
        ui.add(egui::TextEdit::singleline(&mut self.state_path).desired_width(width))
            .on_hover_text(self.state_path.clone());
        ui.horizontal(|ui| {
            let path = PathBuf::from(self.state_path.trim());
            if ui.button("Save state").clicked() {
                action = Some(FilesAction::SaveState(path.clone()));
            }
            if ui.button("Load").clicked() {
                action = Some(FilesAction::LoadState(path));
            }
        });
        let mut puffin = self.puffin_server.is_some();
        if ui
            .checkbox(&mut puffin, "Serve CPU scopes to puffin_viewer")
            .changed()
        {
            action = Some(FilesAction::Puffin(puffin));
        }
        if let Some(message) = &self.puffin_message {
            ui.small(message);
        }
        action
    }
}

impl ViewerApp {
    pub fn state(&self) -> ViewerState {
        ViewerState {
            version: STATE_VERSION,
            scene: self.scene.loaded.spec.clone(),
            technique: self.technique.id.clone(),
            params: self.technique.settings.clone(),
            camera: self.scene.camera,
            light: self.scene.light,
            view_mode: self.image.view_mode,
            split: self.image.split,
            reference_params: self
                .reference
                .yardstick
                .params()
                .to_map()
                .into_iter()
                .collect(),
        }
    }

    pub fn save_state(&mut self, path: &Path) {
        if let Err(e) = create_parent(path) {
            self.report_error(format!("cannot save the state: {e}"));
            return;
        }
        match self.state().save(path) {
            Ok(()) => self.confirm(format!("saved the state to {}", shown_path(path))),
            Err(e) => self.report_error(e.to_string()),
        }
    }

    /// Loads a saved state; on any error the current state stays.
    pub fn load_state(&mut self, path: &Path) {
        let result = ViewerState::load(path).and_then(|state| {
            let scene = load_scene(&self.gpu, &state.scene)?;
            self.registry.find(&state.technique)?;
            Ok((state, scene))
        });
        match result {
            Ok((state, scene)) => {
                self.scene.loaded = scene;
                self.technique.settings = state.params.clone();
                self.scene.camera = state.camera;
                self.scene.light = state.light;
                self.scene.orbit = Orbit::from_camera(&self.scene.camera);
                self.image.view_mode = state.view_mode;
                self.image.split = state.split;
                for (name, value) in &state.reference_params {
                    if let Err(e) = self.reference.yardstick.set_param(name, value.clone()) {
                        self.report_error(format!("{}: {e}", path.display()));
                    }
                }
                self.select_technique(&state.technique);
                self.confirm(format!("loaded the state from {}", shown_path(path)));
            }
            Err(e) => self.report_error(e.to_string()),
        }
    }

    /// Writes the plot's points as a benchmark sweep file; points of an earlier version of a
    /// file technique are left out (the file no longer holds that shader) and the confirmation
    /// says how many.
    pub fn export_sweep(&mut self, path: &Path) {
        if let Err(e) = create_parent(path) {
            self.report_error(format!("cannot export the sweep: {e}"));
            return;
        }
        let Some(r) = &self.image.renderers else {
            return;
        };
        let current = |p: &&crate::tradeoff::TradeoffPoint| {
            p.version.is_none() || p.version == self.file_reload.version_of(&p.technique)
        };
        let points: Vec<_> = self.points().iter().filter(current).cloned().collect();
        let left_out = self.points().len() - points.len();
        let reference: Vec<(String, ParamValue)> = self
            .reference
            .yardstick
            .params()
            .to_map()
            .into_iter()
            .collect();
        let text = sweep_toml(
            &points,
            View {
                scene: &self.scene.loaded.spec,
                width: r.width,
                height: r.height,
                camera: &self.scene.camera,
                light: &self.scene.light,
            },
            &reference,
        );
        match std::fs::write(path, text) {
            Ok(()) => self.confirm(format!(
                "wrote {} points to {}{}",
                points.len(),
                shown_path(path),
                if left_out > 0 {
                    format!(" ({left_out} of earlier file versions left out: not in the file now)")
                } else {
                    String::new()
                }
            )),
            Err(e) => self.report_error(format!(
                "cannot write `{}`: {e}: check the folder exists",
                path.display()
            )),
        }
    }

    /// Starts or stops serving puffin CPU scopes to `puffin_viewer` on port 8585.
    pub fn set_puffin(&mut self, on: bool) {
        if on == self.files.puffin_server.is_some() {
            return;
        }
        if on {
            let address = format!("127.0.0.1:{}", puffin_http::DEFAULT_PORT);
            match puffin_http::Server::new(&address) {
                Ok(server) => {
                    puffin::set_scopes_on(true);
                    self.files.puffin_server = Some(server);
                    self.files.puffin_message = Some(format!(
                        "serving on {address}: run `puffin_viewer --url {address}`"
                    ));
                }
                Err(e) => self.report_error(format!(
                    "cannot serve puffin on {address}: {e} (is another viewer running?)"
                )),
            }
        } else {
            puffin::set_scopes_on(false);
            self.files.puffin_server = None;
            self.files.puffin_message = None;
        }
    }

    /// A screenshot asked for through the UI (the window saves it after painting).
    pub fn take_screenshot_request(&mut self) -> Option<PathBuf> {
        self.files.screenshot_request.take()
    }
}
