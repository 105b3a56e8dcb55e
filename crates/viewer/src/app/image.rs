//! The central image and the camera / divider interaction on it.

use softshadow_core::{wgpu, Renderer};

use super::{ViewerApp, ViewerError, MIN_RENDER_EDGE};
use crate::display::{DebugMapping, DisplayPass, DisplayTarget, ViewMode};

/// Half-width, in points, of the band around the split divider where a drag moves the divider
/// rather than the camera (generous: egui reports a drag only after the pointer has moved).
pub const DIVIDER_GRAB_HALF_WIDTH: f32 = 24.0;

/// The renderers of the technique and the reference, the colour-mapping pass and how the image
/// is shown.
pub(super) struct ImageState {
    pub(super) renderers: Option<Renderers>,
    pub(super) display: DisplayPass,
    pub(super) view_mode: ViewMode,
    /// Divider of the split view, fraction of the width.
    pub(super) split: f32,
    /// A drag that started on the split view's divider.
    pub(super) dragging_divider: bool,
    /// The camera is being dragged or zoomed this frame: the reference waits (each frame would
    /// restart it) so the technique gets the whole frame.
    pub(super) interacting: bool,
    pub(super) debug_view: usize,
    /// How the shown debug image was mapped (its value range), for the legend.
    pub(super) debug_mapping: Option<DebugMapping>,
    pub(super) debug_target: Option<(DisplayTarget, egui::TextureId)>,
    pub(super) debug_message: Option<String>,
    /// A render size chosen by the user (`None`: fit).
    pub(super) render_size: Option<(u32, u32)>,
    /// The "fit" size, points: the window less the side panels' fixed widths, whatever the
    /// panels hold.
    pub(super) fit_size: egui::Vec2,
}

impl ImageState {
    pub(super) fn new(display: DisplayPass, view_mode: ViewMode, split: f32) -> Self {
        Self {
            renderers: None,
            display,
            view_mode,
            split,
            dragging_divider: false,
            interacting: false,
            debug_view: 0,
            debug_mapping: None,
            debug_target: None,
            debug_message: None,
            render_size: None,
            fit_size: egui::Vec2::ZERO,
        }
    }
}

impl ViewerApp {
    /// The image, with camera interaction; returns the render size in pixels.
    pub(super) fn image_ui(&mut self, ui: &mut egui::Ui) -> (u32, u32) {
        self.image.interacting = false;
        // The visible image area: the central panel may reach under the right panel's margin.
        let area = ui.available_rect_before_wrap();
        let area = egui::Rect::from_min_size(area.min, area.size().min(self.image.fit_size));
        let ctx = ui.ctx().clone();
        self.overlays_ui(&ctx, area);
        let available = ui.available_size();
        let ppp = ui.ctx().pixels_per_point();
        // "fit" follows the window only: a size taken from the image area would follow the
        // panels' content, and every change of it restarts the reference.
        let fit = self.image.fit_size;
        let (width, height) = self.image.render_size.unwrap_or((
            ((fit.x * ppp).round() as u32).max(MIN_RENDER_EDGE),
            ((fit.y * ppp).round() as u32).max(MIN_RENDER_EDGE),
        ));
        let debug = self.image.view_mode == ViewMode::Debug;
        let texture = if debug {
            self.image.debug_target.as_ref().map(|(t, id)| {
                let (w, h) = (t.texture.width() as f32, t.texture.height() as f32);
                let scale = (available.x / w).min(available.y / h);
                (*id, egui::vec2(w * scale, h * scale))
            })
        } else {
            self.image.renderers.as_ref().map(|r| {
                let size = egui::vec2(r.width as f32, r.height as f32) / ppp;
                // A fixed size is scaled to fit; "fit" is drawn 1:1 unless the image area is
                // smaller than the window less the panels.
                let fits = (available.x / size.x).min(available.y / size.y);
                let scale = if self.image.render_size.is_some() {
                    fits
                } else {
                    fits.min(1.0)
                };
                (r.texture_id, size * scale)
            })
        };
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

    pub(super) fn camera_input(&mut self, ui: &egui::Ui, response: &egui::Response) {
        let delta = response.drag_delta();
        self.image.interacting = response.dragged()
            || response.hovered() && ui.input(|i| i.smooth_scroll_delta.y != 0.0);
        if self.image.view_mode == ViewMode::Split {
            // In the split view a primary drag that starts on the divider moves it.
            let x_of = |pos: egui::Pos2| {
                ((pos.x - response.rect.left()) / response.rect.width().max(1.0)).clamp(0.0, 1.0)
            };
            let divider_x = response.rect.left() + self.image.split * response.rect.width();
            let near_divider =
                |pos: egui::Pos2| (pos.x - divider_x).abs() < DIVIDER_GRAB_HALF_WIDTH;
            // The press position, not where the drag was recognised (a few points later).
            let press = ui.input(|i| i.pointer.press_origin());
            if response.drag_started_by(egui::PointerButton::Primary) {
                self.image.dragging_divider = press
                    .or(response.interact_pointer_pos())
                    .is_some_and(near_divider);
            }
            let hovered = response.hover_pos().is_some_and(near_divider);
            if hovered || self.image.dragging_divider {
                ui.ctx().set_cursor_icon(egui::CursorIcon::ResizeHorizontal);
            }
            // A visible handle: a line down the image and a grip in its middle.
            let painter = ui.painter_at(response.rect);
            let strong = hovered || self.image.dragging_divider;
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
            if self.image.dragging_divider {
                if let Some(pos) = response.interact_pointer_pos() {
                    self.image.split = x_of(pos);
                }
                if !response.dragged() {
                    self.image.dragging_divider = false;
                }
                return;
            }
        }
        if response.dragged_by(egui::PointerButton::Primary) {
            self.scene.orbit.rotate(delta.x, delta.y);
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
        {
            self.scene.orbit.pan(
                delta.x,
                delta.y,
                response.rect.height(),
                self.scene.camera.fov_y_degrees,
            );
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.scene.orbit.zoom(scroll / 50.0);
            }
        }
    }
}

pub(super) struct Renderers {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) technique: Renderer,
    pub(super) reference: Renderer,
    pub(super) display: DisplayTarget,
    pub(super) texture_id: egui::TextureId,
}

impl ViewerApp {
    pub(super) fn ensure_renderers(&mut self, width: u32, height: u32) -> Result<(), ViewerError> {
        if self
            .image
            .renderers
            .as_ref()
            .is_some_and(|r| (r.width, r.height) == (width, height))
        {
            return Ok(());
        }
        let technique = Renderer::new(&self.gpu, width, height)?;
        let reference = Renderer::new(&self.gpu, width, height)?;
        let display = DisplayTarget::new(&self.gpu, "viewer/display", width, height);
        let mut egui_renderer = self.egui_renderer.write();
        let texture_id = match self.image.renderers.take() {
            Some(old) => {
                egui_renderer.update_egui_texture_from_wgpu_texture(
                    &self.gpu.device,
                    &display.view,
                    wgpu::FilterMode::Nearest,
                    old.texture_id,
                );
                old.texture_id
            }
            None => egui_renderer.register_native_texture(
                &self.gpu.device,
                &display.view,
                wgpu::FilterMode::Nearest,
            ),
        };
        self.image.renderers = Some(Renderers {
            width,
            height,
            technique,
            reference,
            display,
            texture_id,
        });
        self.reference.key = None;
        self.technique.shown_key = None;
        self.timing.rolling.clear();
        Ok(())
    }

    pub(super) fn record_display(&mut self) {
        puffin::profile_function!();
        let Some(r) = &self.image.renderers else {
            return;
        };
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("viewer/display"),
            });
        let current = self.reference.key == Some(self.current_reference_key());
        let reference = current.then_some(&r.reference);
        self.image.display.record(
            &self.gpu,
            &mut encoder,
            &r.technique,
            reference,
            (self.image.view_mode, self.image.split),
            &r.display,
        );
        self.gpu.queue.submit([encoder.finish()]);
        // The debug image, its mapping and any message come with the technique's frame
        // (`technique::show_frame`): the worker draws it on its own device.
    }

    /// Renders at `size` whatever the panels leave for the image (`None`: fit the image area).
    pub fn set_render_size(&mut self, size: Option<(u32, u32)>) {
        self.image.render_size = size;
    }

    /// Size of the last rendered frame.
    pub fn render_size(&self) -> Option<(u32, u32)> {
        self.image.renderers.as_ref().map(|r| (r.width, r.height))
    }

    /// How the shown debug image was mapped to black and white (its value range).
    pub fn debug_mapping(&self) -> Option<&DebugMapping> {
        self.image.debug_mapping.as_ref()
    }

    /// Shows the technique's debug image `index` (in [`softshadow_core::ShadowTechnique::debug_views`] order).
    pub fn set_debug_view(&mut self, index: usize) {
        self.image.debug_view = index;
    }

    pub fn set_view_mode(&mut self, mode: ViewMode) {
        self.image.view_mode = mode;
    }

    pub fn view_mode(&self) -> ViewMode {
        self.image.view_mode
    }
}
