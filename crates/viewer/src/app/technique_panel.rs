//! The left panel's technique section (one widget per parameter, from its spec) and view modes.

use softshadow_core::{
    cascades::CASCADE_PARAMS, DebugLegend, LightKind, ParamKind, ParamSpec, ParamValue, Registry,
};

use super::{technique::TechniqueState, ViewerApp};

/// Fixed render sizes offered besides the image area's own.
const RENDER_SIZES: [(u32, u32); 4] = [(320, 200), (640, 400), (800, 500), (1280, 800)];
use crate::display::{DebugMapping, ViewMode};

/// What the user asked of the technique section: another technique, new parameter values.
#[derive(Default)]
pub(super) struct TechniqueAction {
    pub(super) select: Option<String>,
    pub(super) changes: Vec<(String, ParamValue)>,
}

impl TechniqueState {
    /// The technique picker (every technique of `registry`, those `features` cannot run marked,
    /// those that do not support `light_kind` disabled with why on hover) and one widget per
    /// parameter; returns what was asked.
    pub(super) fn ui(
        &self,
        ui: &mut egui::Ui,
        registry: &Registry,
        features: softshadow_core::wgpu::Features,
        light_kind: LightKind,
    ) -> TechniqueAction {
        // Narrower sliders than egui's 100 points: more names fit beside their widget.
        ui.spacing_mut().slider_width = 80.0;
        let mut action = TechniqueAction::default();
        egui::ComboBox::from_label("Technique")
            .selected_text(self.id.clone())
            // Every technique listed without scrolling (egui's default height scrolled the last
            // of eleven out of sight).
            .height(f32::INFINITY)
            .show_ui(ui, |ui| {
                for info in registry {
                    // A technique this device cannot run (no ray queries, say) stays listed,
                    // marked, with why and what to install; choosing it shows the same message.
                    let (label, hover) = match info.unavailable_on(features) {
                        Some(why) => (
                            format!("{} (unavailable)", info.id),
                            format!("{} [{}]\nunavailable: {why}", info.description, info.source),
                        ),
                        None => (
                            info.id.to_string(),
                            format!("{} [{}]", info.description, info.source),
                        ),
                    };
                    // A light kind it does not support: listed, disabled, the reason on hover.
                    let refusal = info.check_light(light_kind).err();
                    let label = match &refusal {
                        Some(_) => format!("{label} (not for {light_kind})"),
                        None => label,
                    };
                    let response = ui
                        .add_enabled(
                            refusal.is_none(),
                            egui::Button::selectable(self.id == info.id, label),
                        )
                        .on_hover_text(hover)
                        .on_disabled_hover_text(refusal.unwrap_or_default());
                    if response.clicked() && self.id != info.id {
                        action.select = Some(info.id.to_string());
                    }
                }
            });
        let Some(params) = &self.params else {
            return action;
        };
        // The cascades' parameters matter only under the sun: shown then, under their own heading.
        let is_cascade = |spec: &ParamSpec| CASCADE_PARAMS.contains(&spec.name.as_ref());
        let mut widgets = |ui: &mut egui::Ui, cascades: bool| {
            for (spec, value) in params
                .entries
                .iter()
                .filter(|(s, _)| is_cascade(s) == cascades)
            {
                if let Some(new) = param_widget(ui, spec, value) {
                    action.changes.push((spec.name.to_string(), new));
                }
            }
        };
        widgets(ui, false);
        if light_kind == LightKind::Sun && params.entries.iter().any(|(s, _)| is_cascade(s)) {
            egui::CollapsingHeader::new("Sun: cascades")
                .default_open(true)
                .show(ui, |ui| widgets(ui, true));
        }
        if ui.button("Defaults").clicked() {
            if let Some(info) = registry.get(&self.id) {
                for spec in &info.params {
                    action
                        .changes
                        .push((spec.name.to_string(), spec.default_value()));
                }
            }
        }
        action
    }
}

impl ViewerApp {
    /// Draws the technique section and carries out what was asked.
    pub(super) fn technique_ui(&mut self, ui: &mut egui::Ui) {
        let kind = self.scene.light.kind;
        let action = self
            .technique
            .ui(ui, &self.registry, self.gpu.features(), kind);
        if let Some(id) = action.select {
            self.select_technique(&id);
        }
        for (name, value) in action.changes {
            self.set_param(&name, value);
        }
    }
}

/// One widget per parameter, from its spec; returns the new value when the user changed it.
/// A name too long to fit beside its widget goes on a row of its own above it (wrapped, its
/// description on hover), so no name is cut at the panel's edge.
pub fn param_widget(ui: &mut egui::Ui, spec: &ParamSpec, value: &ParamValue) -> Option<ParamValue> {
    let name = spec.name.as_ref();
    let description = spec.description.as_ref();
    let spacing = ui.spacing().clone();
    let beside = match &spec.kind {
        ParamKind::Float { .. } | ParamKind::Int { .. } => {
            spacing.slider_width + spacing.interact_size.x + 3.0 * spacing.item_spacing.x
        }
        ParamKind::Choice { .. } => spacing.combo_width + 3.0 * spacing.item_spacing.x,
        ParamKind::Bool { .. } => spacing.icon_width + 2.0 * spacing.item_spacing.x,
    };
    let fits = text_width(ui, name) + beside <= ui.available_width();
    let text = if fits {
        name
    } else {
        ui.add(egui::Label::new(name).wrap())
            .on_hover_text(description);
        ""
    };
    let new = match &spec.kind {
        ParamKind::Float {
            min,
            max,
            logarithmic,
            ..
        } => {
            let mut x = value.as_f64().unwrap_or(*min);
            ui.add(
                egui::Slider::new(&mut x, *min..=*max)
                    .logarithmic(*logarithmic)
                    .text(text),
            )
            .on_hover_text(description)
            .changed()
            .then_some(ParamValue::Float(x))
        }
        ParamKind::Int { min, max, .. } => {
            let mut i = match value {
                ParamValue::Int(i) => *i,
                other => other.as_f64().unwrap_or(*min as f64) as i64,
            };
            // Wide integer ranges (seeds, sizes) are easier to hit on a log scale.
            let logarithmic = *max > 1000 && *min > 0;
            ui.add(
                egui::Slider::new(&mut i, *min..=*max)
                    .logarithmic(logarithmic)
                    .text(text),
            )
            .on_hover_text(description)
            .changed()
            .then_some(ParamValue::Int(i))
        }
        ParamKind::Bool { .. } => {
            let mut b = matches!(value, ParamValue::Bool(true));
            ui.checkbox(&mut b, text)
                .on_hover_text(description)
                .changed()
                .then_some(ParamValue::Bool(b))
        }
        ParamKind::Choice { options, .. } => {
            let current = value.to_string();
            let mut chosen = None;
            let combo = if fits {
                egui::ComboBox::from_label(name)
            } else {
                egui::ComboBox::from_id_salt(name).width(ui.available_width())
            };
            combo
                .selected_text(current.clone())
                .truncate()
                .show_ui(ui, |ui| {
                    for option in options.iter() {
                        if ui.selectable_label(current == *option, *option).clicked()
                            && current != *option
                        {
                            chosen = Some(ParamValue::Choice(option.to_string()));
                        }
                    }
                })
                .response
                .on_hover_text(format!("{current}: {description}"));
            chosen
        }
    };
    new
}

/// Width of `text` in the body font on one line, points.
fn text_width(ui: &egui::Ui, text: &str) -> f32 {
    let font = egui::TextStyle::Body.resolve(ui.style());
    ui.painter()
        .layout_no_wrap(text.to_string(), font, egui::Color32::WHITE)
        .size()
        .x
}

/// What the debug image's colours mean: the mapped value range, and what the technique says its
/// values or colours are ([`DebugLegend`], from the technique's crate).
pub(super) fn debug_legend(
    ui: &mut egui::Ui,
    legend: Option<&DebugLegend>,
    mapping: Option<&DebugMapping>,
) {
    let swatch = |ui: &mut egui::Ui, colour: egui::Color32, meaning: &str| {
        ui.horizontal(|ui| {
            let (rect, _) = ui.allocate_exact_size(egui::vec2(12.0, 12.0), egui::Sense::hover());
            ui.painter().rect_filled(rect, 2.0, colour);
            ui.small(meaning);
        });
    };
    match mapping {
        Some(DebugMapping::Depth { lo, hi, count }) => {
            if *count == 0 {
                ui.small("no texel holds a surface: the whole map is empty");
            } else if lo == hi {
                ui.small(format!(
                    "all {count} surface texels at depth {lo:.5} (a surface parallel to the \
                     light): shown mid grey"
                ));
            } else {
                ui.small(format!(
                    "depth of the {count} surface texels: black {lo:.5} (nearest) to white {hi:.5}"
                ));
            }
            swatch(
                ui,
                egui::Color32::from_rgb(20, 31, 89),
                "empty (no surface, depth 1)",
            );
        }
        Some(DebugMapping::Float { lo, hi, count }) => {
            let (meaning, notes) = match legend {
                Some(DebugLegend::Value { meaning, notes }) => (meaning.as_ref(), notes.as_slice()),
                _ => ("value (red channel)", &[][..]),
            };
            if *count == 0 {
                ui.small("no finite texel");
            } else {
                ui.small(format!(
                    "{meaning}: black {lo:.4} to white {hi:.4} over {count} texels"
                ));
            }
            for note in notes {
                ui.small(note.as_ref());
            }
            swatch(ui, egui::Color32::from_rgb(255, 0, 255), "NaN or infinite");
        }
        Some(DebugMapping::Colour) => match legend {
            Some(DebugLegend::Palette(entries)) => {
                for ([r, g, b], meaning) in entries {
                    swatch(ui, egui::Color32::from_rgb(*r, *g, *b), meaning);
                }
            }
            _ => {
                ui.small("the image's own colours");
            }
        },
        None => {}
    }
}

impl super::image::ImageState {
    /// The View section: render size, view mode, the plot panel's switch and the mode's own
    /// control (the split's divider, the debug image among `debug_views`).
    pub(super) fn view_ui(
        &mut self,
        ui: &mut egui::Ui,
        debug_views: &[String],
        plot_open: &mut bool,
    ) {
        let current = self
            .renderers
            .as_ref()
            .map_or((0, 0), |r| (r.width, r.height));
        let label = |size: Option<(u32, u32)>| match size {
            None => format!("fit ({}x{})", current.0, current.1),
            Some((w, h)) => format!("{w}x{h}"),
        };
        egui::ComboBox::from_label("render size")
            .selected_text(label(self.render_size))
            .show_ui(ui, |ui| {
                let mut options = vec![None, Some(current)];
                for size in RENDER_SIZES {
                    if size != current {
                        options.push(Some(size));
                    }
                }
                for option in options {
                    ui.selectable_value(&mut self.render_size, option, label(option));
                }
            })
            .response
            .on_hover_text(
                "fit: the window less the side panels (fixed widths), so only resizing the \
                 window changes it; a fixed size also keeps the reference and the timings when \
                 the window is resized, and the image is scaled to fit",
            );
        ui.horizontal_wrapped(|ui| {
            for mode in ViewMode::ALL {
                ui.selectable_value(&mut self.view_mode, mode, mode.label());
            }
        });
        ui.checkbox(plot_open, "error-against-time plot")
            .on_hover_text(
                "The plot's panel under the image (at least a third of the window; drag its top \
                 edge to resize). A \"fit\" render size follows it.",
            );
        // One row reserved for the mode's own control, so nothing below moves when the mode
        // changes; the mode's legend floats over the image (`overlays`).
        let row = egui::vec2(ui.available_width(), ui.spacing().interact_size.y);
        ui.allocate_ui_with_layout(
            row,
            egui::Layout::left_to_right(egui::Align::Center),
            |ui| {
                ui.set_min_size(row);
                match self.view_mode {
                    ViewMode::Split => {
                        ui.add(egui::Slider::new(&mut self.split, 0.0..=1.0).text("divider"));
                    }
                    ViewMode::Debug => {
                        let names = debug_views;
                        // The worker shows the first view when the index is past this
                        // technique's views; so does the picker.
                        let shown = names
                            .get(self.debug_view)
                            .or(names.first())
                            .cloned()
                            .unwrap_or_else(|| "none".into());
                        egui::ComboBox::from_label("Debug image")
                            .selected_text(shown)
                            .truncate()
                            .show_ui(ui, |ui| {
                                for (i, name) in names.iter().enumerate() {
                                    ui.selectable_value(&mut self.debug_view, i, name);
                                }
                            });
                    }
                    _ => {}
                }
            },
        );
    }
}
