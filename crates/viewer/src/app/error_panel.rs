//! The right panel's error section (metrics against the reference, greyed and labelled stale
//! while the reference re-accumulates) and the error-against-time plot (one colour and marker per
//! technique, the Pareto front, axes fitted to the points, optional log time axis).

use std::{collections::BTreeMap, path::PathBuf};

use softshadow_core::{ParamValue, ShadowTechnique};
use softshadow_metrics::ErrorReport;

use super::{format_ms, ViewerApp, DEFAULT_REFERENCE_SAMPLES};
use crate::tradeoff::{pareto_front, TradeoffPoint};

#[cfg(test)]
mod tests;

/// Colours told apart on the dark theme (Okabe and Ito's colour-blind-safe set, plus two), in an
/// order where the first eight (the built-ins) hold no two near blues.
const SERIES_COLOURS: [egui::Color32; 10] = [
    egui::Color32::from_rgb(230, 159, 0),
    egui::Color32::from_rgb(86, 180, 233),
    egui::Color32::from_rgb(0, 158, 115),
    egui::Color32::from_rgb(240, 228, 66),
    egui::Color32::from_rgb(213, 94, 0),
    egui::Color32::from_rgb(204, 121, 167),
    egui::Color32::from_rgb(160, 120, 255),
    egui::Color32::from_rgb(170, 170, 170),
    egui::Color32::from_rgb(0, 114, 178),
    egui::Color32::from_rgb(255, 120, 120),
];

/// Markers, so two techniques differ in shape as well as colour.
const SERIES_MARKERS: [egui_plot::MarkerShape; 7] = [
    egui_plot::MarkerShape::Circle,
    egui_plot::MarkerShape::Square,
    egui_plot::MarkerShape::Diamond,
    egui_plot::MarkerShape::Up,
    egui_plot::MarkerShape::Down,
    egui_plot::MarkerShape::Cross,
    egui_plot::MarkerShape::Plus,
];

/// Colour and marker of the technique at `index` in the registry: every pair differs in colour
/// for up to 10 techniques and in (colour, marker) for up to 70.
pub fn series_style(index: usize) -> (egui::Color32, egui_plot::MarkerShape) {
    (
        SERIES_COLOURS[index % SERIES_COLOURS.len()],
        SERIES_MARKERS[index % SERIES_MARKERS.len()],
    )
}

/// The legend's copy of a plot marker (the default font has no geometric-shape glyphs).
fn legend_marker(ui: &mut egui::Ui, colour: egui::Color32, shape: egui_plot::MarkerShape) {
    use egui_plot::MarkerShape as M;
    let (rect, _) = ui.allocate_exact_size(egui::vec2(12.0, 12.0), egui::Sense::hover());
    let painter = ui.painter();
    let (c, r) = (rect.center(), 5.0);
    let stroke = egui::Stroke::new(2.0, colour);
    let polygon = |points: Vec<egui::Pos2>| {
        painter.add(egui::Shape::convex_polygon(
            points,
            colour,
            egui::Stroke::NONE,
        ));
    };
    match shape {
        M::Circle => {
            painter.circle_filled(c, r, colour);
        }
        M::Square => {
            painter.rect_filled(
                egui::Rect::from_center_size(c, egui::vec2(2.0 * r, 2.0 * r)),
                0.0,
                colour,
            );
        }
        M::Diamond => polygon(vec![
            c + egui::vec2(0.0, -r),
            c + egui::vec2(r, 0.0),
            c + egui::vec2(0.0, r),
            c + egui::vec2(-r, 0.0),
        ]),
        M::Up => polygon(vec![
            c + egui::vec2(0.0, -r),
            c + egui::vec2(r, r),
            c + egui::vec2(-r, r),
        ]),
        M::Down => polygon(vec![
            c + egui::vec2(-r, -r),
            c + egui::vec2(r, -r),
            c + egui::vec2(0.0, r),
        ]),
        M::Cross => {
            painter.line_segment([c + egui::vec2(-r, -r), c + egui::vec2(r, r)], stroke);
            painter.line_segment([c + egui::vec2(-r, r), c + egui::vec2(r, -r)], stroke);
        }
        _ => {
            painter.line_segment([c + egui::vec2(-r, 0.0), c + egui::vec2(r, 0.0)], stroke);
            painter.line_segment([c + egui::vec2(0.0, -r), c + egui::vec2(0.0, r)], stroke);
        }
    }
}

/// Plot bounds that hold every point with a margin, from zero (linear) or one decade around the
/// points (log), so a single point is not drawn beside a lone "0" tick.
pub fn fitted_bounds(points: &[[f64; 2]], log_x: bool) -> ([f64; 2], [f64; 2]) {
    let max_x = points
        .iter()
        .map(|p| p[0])
        .fold(f64::NEG_INFINITY, f64::max);
    let min_x = points.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
    let max_y = points.iter().map(|p| p[1]).fold(0.0, f64::max);
    let y = [0.0, if max_y > 0.0 { max_y * 1.2 } else { 1.0 }];
    if points.is_empty() {
        return ([0.0, 1.0], y);
    }
    if log_x {
        (
            [(min_x.floor() - 0.2), (max_x.ceil() + 0.2).max(min_x + 1.0)],
            y,
        )
    } else {
        ([0.0, if max_x > 0.0 { max_x * 1.2 } else { 1.0 }], y)
    }
}

/// The points measured from one scene, light and camera (errors of other views are not
/// comparable: another camera sees other pixels).
pub(super) struct ViewPoints {
    /// Scene, light and camera ([`ViewerApp::current_view_key`]); not the size or the
    /// reference's samples: errors are per-pixel means, comparable across both.
    pub(super) key: u64,
    pub(super) points: Vec<TradeoffPoint>,
}

/// The error-against-time plot's points, per view, and its options.
pub(super) struct PlotState {
    /// Every view a point was measured from, in the order first measured: moving the camera
    /// deletes nothing.
    pub(super) views: Vec<ViewPoints>,
    /// Also draw the other views' points (hollow).
    pub(super) show_other_views: bool,
    /// The time axis is log10(ms).
    pub(super) log_time_axis: bool,
    /// Where "Export sweep" writes.
    pub(super) export_path: String,
}

impl Default for PlotState {
    fn default() -> Self {
        Self {
            views: Vec::new(),
            show_other_views: false,
            log_time_axis: false,
            export_path: "viewer-sweep.toml".into(),
        }
    }
}

impl PlotState {
    /// The points of the view `key` (none yet: empty).
    pub(super) fn points_of(&self, key: u64) -> &[TradeoffPoint] {
        self.views
            .iter()
            .find(|v| v.key == key)
            .map_or(&[][..], |v| &v.points)
    }

    /// Adds a point to the view `key`, replacing that view's point of the same setting.
    pub(super) fn insert(&mut self, key: u64, point: TradeoffPoint) {
        let index = match self.views.iter().position(|v| v.key == key) {
            Some(index) => index,
            None => {
                self.views.push(ViewPoints {
                    key,
                    points: Vec::new(),
                });
                self.views.len() - 1
            }
        };
        let points = &mut self.views[index].points;
        match points
            .iter_mut()
            .find(|p| p.same_setting(&point.technique, &point.params))
        {
            Some(existing) => *existing = point,
            None => points.push(point),
        }
    }
}

impl ViewerApp {
    pub(super) fn reference_error_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Error against the reference");
        let p = self.shown_reference_progress();
        let samples = self
            .reference
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
        let mut new_samples = samples;
        if ui
            .add(egui::Slider::new(&mut new_samples, 1..=64).text("samples per axis"))
            .on_hover_text("light samples per axis of the reference: N x N in all")
            .changed()
        {
            if let Err(e) = self
                .reference
                .yardstick
                .set_param("samples_per_axis", ParamValue::Int(new_samples))
            {
                self.report_error(e.to_string());
            }
        }
        if let Some(report) = self.metrics() {
            ui.label(format!(
                "metrics rest on {} light samples ({samples} x {samples})",
                p.total
            ));
            metrics_grid(ui, report);
        } else if let Some(report) = self.stale_metrics() {
            // Metrics belong to one setting: an earlier one's are shown greyed, never as current.
            ui.colored_label(
                ui.visuals().warn_fg_color,
                format!(
                    "stale: these metrics are of an earlier setting; the reference is \
                     re-accumulating ({} / {} light samples)",
                    p.done, p.total
                ),
            );
            let report = report.clone();
            ui.add_enabled_ui(false, |ui| metrics_grid(ui, &report));
        } else {
            ui.label(if p.is_complete() {
                "measuring..."
            } else {
                "the metrics appear once the reference has converged"
            });
        }
    }

    pub(super) fn tradeoff_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Error against time");
        ui.small(
            "One point per technique setting measured for this scene, light and camera (time: \
             the cost of computing, caches dropped); the Pareto front is the line.",
        );
        let view = self.current_view_key();
        let points: Vec<TradeoffPoint> = self.plot.points_of(view).to_vec();
        let other_views = self.plot.views.iter().filter(|v| v.key != view);
        let other_view_count = other_views.clone().count();
        let other_count: usize = other_views.clone().map(|v| v.points.len()).sum();
        let others: Vec<TradeoffPoint> = if self.plot.show_other_views {
            other_views.flat_map(|v| v.points.iter().cloned()).collect()
        } else {
            Vec::new()
        };
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut self.plot.log_time_axis, "log time axis");
            ui.add_enabled(
                other_count > 0,
                egui::Checkbox::new(
                    &mut self.plot.show_other_views,
                    format!("show {other_count} points of {other_view_count} other views"),
                ),
            )
            .on_hover_text(
                "Points measured from another camera, light or scene, drawn hollow: kept when \
                 the camera moves, but their errors are of other pixels",
            );
        });
        let log_x = self.plot.log_time_axis;
        let x_of = move |ms: f64| if log_x { ms.max(1e-3).log10() } else { ms };
        let front = pareto_front(&points);
        let defaults: BTreeMap<&str, Vec<(String, ParamValue)>> = self
            .registry
            .iter()
            .map(|t| {
                (
                    t.id.as_ref(),
                    t.params
                        .iter()
                        .map(|s| (s.name.to_string(), s.default_value()))
                        .collect(),
                )
            })
            .collect();
        let all: Vec<[f64; 2]> = points
            .iter()
            .chain(&others)
            .map(|p| [x_of(p.gpu_ms), p.error])
            .collect();
        let (x_range, y_range) = fitted_bounds(&all, log_x);
        let mut plot = egui_plot::Plot::new("tradeoff")
            .height(220.0)
            .x_axis_label(if log_x {
                "technique GPU ms (log)"
            } else {
                "technique GPU ms"
            })
            .y_axis_label("mae_shadowed")
            // The bounds follow the data every frame; the legend is drawn below the plot.
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false);
        if log_x {
            plot = plot.x_axis_formatter(|mark, _| format_log_ms(mark.value));
        } else {
            // Few enough ticks that egui_plot has room to label each (its default spacing
            // labelled only "0" on this narrow plot).
            plot = plot
                .x_grid_spacer(|input| linear_ticks(input.bounds, TIME_TICKS))
                .x_axis_formatter(|mark, _| format_tick(mark.value));
        }
        let series = techniques_with_points(&self.registry, &points, &others);
        plot.show(ui, |plot| {
            plot.set_plot_bounds(egui_plot::PlotBounds::from_min_max(
                [x_range[0], y_range[0]],
                [x_range[1], y_range[1]],
            ));
            if !front.is_empty() {
                let line: Vec<[f64; 2]> = front
                    .iter()
                    .map(|&i| [x_of(points[i].gpu_ms), points[i].error])
                    .collect();
                plot.line(
                    egui_plot::Line::new("Pareto front", line)
                        .color(egui::Color32::from_gray(200))
                        .width(1.0),
                );
            }
            for (index, id) in &series {
                let (colour, shape) = series_style(*index);
                let of = |points: &[TradeoffPoint]| -> Vec<[f64; 2]> {
                    points
                        .iter()
                        .filter(|p| p.technique == *id)
                        .map(|p| [x_of(p.gpu_ms), p.error])
                        .collect()
                };
                plot.points(
                    egui_plot::Points::new(*id, of(&points))
                        .radius(5.0)
                        .shape(shape)
                        .filled(true)
                        .color(colour),
                );
                let other = of(&others);
                if !other.is_empty() {
                    plot.points(
                        egui_plot::Points::new(format!("{id} (other views)"), other)
                            .radius(5.0)
                            .shape(shape)
                            .filled(false)
                            .color(colour.gamma_multiply(0.7)),
                    );
                }
            }
        });
        // The legend, outside the data.
        ui.horizontal_wrapped(|ui| {
            for (index, id) in &series {
                let (colour, shape) = series_style(*index);
                legend_marker(ui, colour, shape);
                ui.colored_label(colour, *id);
            }
            if !front.is_empty() {
                let (rect, _) =
                    ui.allocate_exact_size(egui::vec2(14.0, 12.0), egui::Sense::hover());
                ui.painter().hline(
                    rect.x_range(),
                    rect.center().y,
                    egui::Stroke::new(1.5, egui::Color32::from_gray(200)),
                );
                ui.colored_label(egui::Color32::from_gray(200), "Pareto front");
            }
        });
        for &i in &front {
            let p = &points[i];
            let label = p.label(defaults.get(p.technique.as_str()).map_or(&[][..], |d| d));
            ui.small(format!(
                "front: {label}: {} ms, {:.4}",
                format_ms(p.gpu_ms),
                p.error
            ));
        }
        ui.horizontal(|ui| {
            ui.add(egui::TextEdit::singleline(&mut self.plot.export_path).desired_width(140.0));
            if ui
                .add_enabled(!points.is_empty(), egui::Button::new("Export sweep"))
                .on_hover_text("Writes the points as a sweep file for `workbench bench --sweep`")
                .clicked()
            {
                let path = PathBuf::from(self.plot.export_path.trim());
                self.export_sweep(&path);
            }
        });
    }
}

/// Techniques with at least one point, with their index in the registry (their style).
fn techniques_with_points<'a>(
    registry: &'a softshadow_core::Registry,
    points: &[TradeoffPoint],
    others: &[TradeoffPoint],
) -> Vec<(usize, &'a str)> {
    registry
        .iter()
        .enumerate()
        .filter(|(_, t)| points.iter().chain(others).any(|p| p.technique == t.id))
        .map(|(i, t)| (i, t.id.as_ref()))
        .collect()
}

/// Ticks of the linear time axis at most.
const TIME_TICKS: usize = 3;

/// Grid marks of a linear axis over `bounds`: at most `max_ticks` at a round step (1, 2 or 5
/// times a power of ten), so that each has room for its label.
pub fn linear_ticks(bounds: (f64, f64), max_ticks: usize) -> Vec<egui_plot::GridMark> {
    let range = bounds.1 - bounds.0;
    if !(range.is_finite() && range > 0.0) || max_ticks == 0 {
        return Vec::new();
    }
    let rough = range / max_ticks as f64;
    let power = 10f64.powf(rough.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * power)
        .find(|step| *step >= rough)
        .unwrap_or(10.0 * power);
    let first = (bounds.0 / step).ceil() as i64;
    // Not in the last few percent, where its label would be cut at the plot's edge.
    let last = ((bounds.1 - 0.05 * range) / step).floor() as i64;
    (first..=last)
        .map(|i| egui_plot::GridMark {
            value: i as f64 * step,
            step_size: step,
        })
        .collect()
}

/// Tick label of a linear ms axis: whole numbers from 10 ms up, otherwise as few decimals as
/// the value needs.
pub fn format_tick(ms: f64) -> String {
    if ms.abs() < 1e-9 {
        "0".into()
    } else if ms.abs() >= 10.0 {
        format!("{ms:.0}")
    } else {
        let text = format!("{ms:.3}");
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// Tick label of a log10(ms) axis: whole decades read "1 ms", "10 ms", others nothing.
fn format_log_ms(log_ms: f64) -> String {
    let decade = log_ms.round();
    if (log_ms - decade).abs() > 1e-6 {
        return String::new();
    }
    let ms = 10f64.powf(decade);
    if ms >= 1.0 {
        format!("{ms:.0}")
    } else {
        format!("{ms}")
    }
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
