//! The left panel's scene, light and camera sections.

use softshadow_core::glam::Vec3;

use super::ViewerApp;

impl ViewerApp {
    pub(super) fn scene_ui(&mut self, ui: &mut egui::Ui) {
        let mut open = None;
        egui::ComboBox::from_label("Scene")
            .selected_text(self.scene.spec.clone())
            .show_ui(ui, |ui| {
                for info in softshadow_scenes::builtin_scenes() {
                    if ui
                        .selectable_label(self.scene.spec == info.id, info.id)
                        .on_hover_text(info.description)
                        .clicked()
                    {
                        open = Some(info.id.to_string());
                    }
                }
            });
        ui.horizontal(|ui| {
            let field = ui.add(
                egui::TextEdit::singleline(&mut self.scene_path)
                    .hint_text("scene.toml / model.glb")
                    .desired_width(170.0),
            );
            // Enter in the field opens, as the Open button does.
            let entered = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if (ui.button("Open").clicked() || entered) && !self.scene_path.trim().is_empty() {
                open = Some(self.scene_path.trim().to_string());
            }
        });
        ui.small("Or drop a .toml / .gltf / .glb file on the window.");
        ui.label(format!("{} triangles", self.scene.scene.triangle_count()));
        if let Some(spec) = open {
            self.open_scene(&spec);
        }
    }

    pub(super) fn light_ui(&mut self, ui: &mut egui::Ui) {
        let light = &mut self.light;
        ui.horizontal(|ui| {
            ui.label("position");
            ui.add(
                egui::DragValue::new(&mut light.center.x)
                    .speed(0.02)
                    .prefix("x "),
            );
            ui.add(
                egui::DragValue::new(&mut light.center.y)
                    .speed(0.02)
                    .prefix("y "),
            );
            ui.add(
                egui::DragValue::new(&mut light.center.z)
                    .speed(0.02)
                    .prefix("z "),
            );
        });
        // Orientation as yaw (around +y) and tilt below the horizon, degrees.
        let d = light.direction.normalize_or(Vec3::NEG_Y);
        let mut tilt = (-d.y).clamp(-1.0, 1.0).asin().to_degrees();
        let mut yaw = d.x.atan2(d.z).to_degrees();
        let tilt_changed = ui
            .add(egui::Slider::new(&mut tilt, -90.0..=90.0).text("tilt (deg below horizon)"))
            .changed();
        let yaw_changed = ui
            .add(egui::Slider::new(&mut yaw, -180.0..=180.0).text("yaw (deg)"))
            .changed();
        if tilt_changed || yaw_changed {
            let (t, y) = (tilt.to_radians(), yaw.to_radians());
            light.direction = Vec3::new(t.cos() * y.sin(), -t.sin(), t.cos() * y.cos());
        }
        ui.add(egui::Slider::new(&mut light.width, 0.0..=4.0).text("width"));
        ui.add(egui::Slider::new(&mut light.height, 0.0..=4.0).text("height"));
        ui.add(egui::Slider::new(&mut light.intensity, 0.0..=4.0).text("intensity"));
        if ui.button("Reset light").clicked() {
            self.light = self.scene.scene.light;
        }
    }

    pub(super) fn camera_ui(&mut self, ui: &mut egui::Ui) {
        ui.small("Image: left drag orbits, right or middle drag pans, scroll zooms.");
        ui.add(egui::Slider::new(&mut self.camera.fov_y_degrees, 10.0..=120.0).text("fov (deg)"));
        ui.add(
            egui::Slider::new(&mut self.orbit.distance, 0.1..=100.0)
                .logarithmic(true)
                .text("distance"),
        );
        if ui.button("Reset camera and light").clicked() {
            self.reset_view();
        }
    }
}
