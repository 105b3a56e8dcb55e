//! The central image and the camera / divider interaction on it.

use super::{ViewerApp, MIN_RENDER_EDGE};

/// Half-width, in points, of the band around the split divider where a drag moves the divider
/// rather than the camera (generous: egui reports a drag only after the pointer has moved).
pub const DIVIDER_GRAB_HALF_WIDTH: f32 = 24.0;
use crate::display::ViewMode;

impl ViewerApp {
    /// The image, with camera interaction; returns the render size in pixels.
    pub(super) fn image_ui(&mut self, ui: &mut egui::Ui) -> (u32, u32) {
        self.interacting = false;
        let available = ui.available_size();
        let ppp = ui.ctx().pixels_per_point();
        // A fixed render size does not follow the panels (opening a section that widens the
        // left panel would otherwise restart the reference); the image is scaled to fit.
        let (width, height) = self.render_size.unwrap_or((
            ((available.x * ppp).round() as u32).max(MIN_RENDER_EDGE),
            ((available.y * ppp).round() as u32).max(MIN_RENDER_EDGE),
        ));
        let debug = self.view_mode == ViewMode::Debug;
        let texture = if debug {
            self.debug_target.as_ref().map(|(t, id)| {
                let (w, h) = (t.texture.width() as f32, t.texture.height() as f32);
                let scale = (available.x / w).min(available.y / h);
                (*id, egui::vec2(w * scale, h * scale))
            })
        } else {
            self.renderers.as_ref().map(|r| {
                let size = egui::vec2(r.width as f32, r.height as f32) / ppp;
                let scale = if self.render_size.is_some() {
                    (available.x / size.x).min(available.y / size.y)
                } else {
                    1.0
                };
                (r.texture_id, size * scale)
            })
        };
        if let Some(message) = &self.debug_message {
            ui.colored_label(egui::Color32::LIGHT_RED, message);
        }
        let Some((id, size)) = texture else {
            ui.allocate_space(available);
            return (width, height);
        };
        let response = ui.add(
            egui::Image::new(egui::load::SizedTexture::new(id, size))
                .sense(egui::Sense::click_and_drag()),
        );
        if !debug {
            self.camera_input(ui, &response);
        }
        (width, height)
    }

    fn camera_input(&mut self, ui: &egui::Ui, response: &egui::Response) {
        let delta = response.drag_delta();
        self.interacting = response.dragged()
            || response.hovered() && ui.input(|i| i.smooth_scroll_delta.y != 0.0);
        if self.view_mode == ViewMode::Split {
            // In the split view a primary drag that starts on the divider moves it.
            let x_of = |pos: egui::Pos2| {
                ((pos.x - response.rect.left()) / response.rect.width().max(1.0)).clamp(0.0, 1.0)
            };
            let divider_x = response.rect.left() + self.split * response.rect.width();
            let near_divider =
                |pos: egui::Pos2| (pos.x - divider_x).abs() < DIVIDER_GRAB_HALF_WIDTH;
            // The press position, not where the drag was recognised (a few points later).
            let press = ui.input(|i| i.pointer.press_origin());
            if response.drag_started_by(egui::PointerButton::Primary) {
                self.dragging_divider = press
                    .or(response.interact_pointer_pos())
                    .is_some_and(near_divider);
            }
            let hovered = response.hover_pos().is_some_and(near_divider);
            if hovered || self.dragging_divider {
                ui.ctx().set_cursor_icon(egui::CursorIcon::ResizeHorizontal);
            }
            // A visible handle: a line down the image and a grip in its middle.
            let painter = ui.painter_at(response.rect);
            let strong = hovered || self.dragging_divider;
            let colour = if strong {
                egui::Color32::WHITE
            } else {
                egui::Color32::from_white_alpha(160)
            };
            painter.vline(
                divider_x,
                response.rect.y_range(),
                egui::Stroke::new(if strong { 2.0 } else { 1.0 }, colour),
            );
            let grip = egui::Rect::from_center_size(
                egui::pos2(divider_x, response.rect.center().y),
                egui::vec2(10.0, 44.0),
            );
            painter.rect_filled(grip, 4.0, colour);
            for dy in [-8.0, 0.0, 8.0] {
                painter.hline(
                    grip.x_range().shrink(2.5),
                    grip.center().y + dy,
                    egui::Stroke::new(1.0, egui::Color32::from_gray(60)),
                );
            }
            if self.dragging_divider {
                if let Some(pos) = response.interact_pointer_pos() {
                    self.split = x_of(pos);
                }
                if !response.dragged() {
                    self.dragging_divider = false;
                }
                return;
            }
        }
        if response.dragged_by(egui::PointerButton::Primary) {
            self.orbit.rotate(delta.x, delta.y);
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
        {
            self.orbit.pan(
                delta.x,
                delta.y,
                response.rect.height(),
                self.camera.fov_y_degrees,
            );
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.orbit.zoom(scroll / 50.0);
            }
        }
    }
}
