//! The left panel's files section: screenshot, save / load state, puffin.

use std::path::PathBuf;

use super::ViewerApp;

impl ViewerApp {
    pub(super) fn files_ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.add(egui::TextEdit::singleline(&mut self.screenshot_path).desired_width(150.0));
            if ui.button("Screenshot").clicked() {
                self.screenshot_request = Some(PathBuf::from(self.screenshot_path.trim()));
            }
        });
        ui.horizontal(|ui| {
            ui.add(egui::TextEdit::singleline(&mut self.state_path).desired_width(150.0));
            if ui.button("Save state").clicked() {
                let path = PathBuf::from(self.state_path.trim());
                self.save_state(&path);
            }
            if ui.button("Load").clicked() {
                let path = PathBuf::from(self.state_path.trim());
                self.load_state(&path);
            }
        });
        let mut puffin = self.puffin_server.is_some();
        if ui
            .checkbox(&mut puffin, "Serve CPU scopes to puffin_viewer")
            .changed()
        {
            self.set_puffin(puffin);
        }
        if let Some(message) = &self.puffin_message {
            ui.small(message);
        }
    }
}
