//! The error-against-time plot, a panel of its own under the image: one point per technique
//! setting measured for the current scene, light and camera (one colour and marker per
//! technique, one more marker per saved version of a file technique), the Pareto front as a line,
//! labelled ticks on both axes (log time too), a hover that names the point's setting, error and
//! cost, and a click that restores that setting. The component owns its points and options and
//! draws them ([`PlotPanel::ui`]); what the app must do (restore a setting, export) comes back
//! as a [`PlotAction`].

use std::{collections::BTreeMap, path::PathBuf};

use softshadow_core::{ParamValue, Registry};

use super::format_ms;
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

/// Colour of the Pareto front and its legend entry.
const FRONT_COLOUR: egui::Color32 = egui::Color32::from_gray(200);

/// Share of the panel's width the legend column beside the plot takes, and its bounds, points.
const LEGEND_SHARE: f32 = 0.3;
const LEGEND_WIDTH: std::ops::RangeInclusive<f32> = 130.0..=250.0;

/// A pointer this close to a point (points) hovers and clicks it.
const PICK_RADIUS: f32 = 12.0;

/// Colour and marker of the technique at `index` in the registry: every pair differs in colour
/// for up to 10 techniques and in (colour, marker) for up to 70. A file technique's version `v`
/// keeps the colour and moves the marker on, so its versions tell apart.
pub fn series_style(index: usize, version: Option<u32>) -> (egui::Color32, egui_plot::MarkerShape) {
    let shift = version.map_or(0, |v| v.saturating_sub(1) as usize);
    (
        SERIES_COLOURS[index % SERIES_COLOURS.len()],
        SERIES_MARKERS[(index + shift) % SERIES_MARKERS.len()],
    )
}

/// The points measured from one scene, light and camera (errors of other views are not
/// comparable: another camera sees other pixels).
pub(super) struct ViewPoints {
    /// The scene's content hash: "other views" are this scene's other cameras and lights.
    pub(super) scene: u64,
    /// Scene, light and camera ([`super::ViewerApp::current_view_key`]); not the size or the
    /// reference's samples: errors are per-pixel means, comparable across both.
    pub(super) key: u64,
    pub(super) points: Vec<TradeoffPoint>,
}

/// Where the plot stands: the current scene and view, the registry (styles, defaults), and the
/// setting shown now (outlined in the plot).
pub(super) struct PlotContext<'a> {
    pub(super) registry: &'a Registry,
    pub(super) scene: u64,
    pub(super) view: u64,
    /// No yardstick runs under the current light (no point can be measured).
    pub(super) no_yardstick: bool,
}

/// What the user asked of the plot.
#[derive(Debug)]
pub(super) enum PlotAction {
    /// A click on a point: show that technique with that setting.
    Restore(TradeoffPoint),
    /// "Export sweep" with the typed path.
    Export(PathBuf),
}

/// The plot's points per view, its options, and where it drew the current view's points.
pub(super) struct PlotPanel {
    /// Every view a point was measured from, in the order first measured: moving the camera
    /// deletes nothing.
    views: Vec<ViewPoints>,
    /// The panel is shown (it takes the bottom of the image column).
    pub(super) open: bool,
    /// Also draw this scene's other views' points (hollow).
    pub(super) show_other_views: bool,
    /// The time axis is log10(ms).
    pub(super) log_time_axis: bool,
    /// Where "Export sweep" writes.
    pub(super) export_path: String,
    /// Screen positions of the current view's points as last drawn (hover, click, tests).
    drawn: Vec<(egui::Pos2, TradeoffPoint)>,
    /// The point under the pointer last frame: described at the top of the legend at once
    /// (egui's tooltip beside the pointer comes after its delay).
    hovered: Option<TradeoffPoint>,
}

impl PlotPanel {
    pub(super) fn new(export_path: String) -> Self {
        Self {
            views: Vec::new(),
            open: true,
            show_other_views: false,
            log_time_axis: false,
            export_path,
            drawn: Vec::new(),
            hovered: None,
        }
    }

    /// The points of the view `key` (none yet: empty).
    pub(super) fn points_of(&self, key: u64) -> &[TradeoffPoint] {
        self.views
            .iter()
            .find(|v| v.key == key)
            .map_or(&[][..], |v| &v.points)
    }

    /// The points of the other views of scene `scene` (not `view`).
    pub(super) fn other_views(&self, scene: u64, view: u64) -> impl Iterator<Item = &ViewPoints> {
        self.views
            .iter()
            .filter(move |v| v.scene == scene && v.key != view)
    }

    /// Adds a point to the view `key` of scene `scene`, replacing that view's point of the
    /// same setting.
    pub(super) fn insert(&mut self, scene: u64, key: u64, point: TradeoffPoint) {
        let index = match self.views.iter().position(|v| v.key == key) {
            Some(index) => index,
            None => {
                self.views.push(ViewPoints {
                    scene,
                    key,
                    points: Vec::new(),
                });
                self.views.len() - 1
            }
        };
        let points = &mut self.views[index].points;
        match points.iter_mut().find(|p| p.same_setting(&point)) {
            Some(existing) => *existing = point,
            None => points.push(point),
        }
    }

    /// Where the current view's points were drawn last frame, with the points.
    pub(super) fn drawn(&self) -> &[(egui::Pos2, TradeoffPoint)] {
        &self.drawn
    }

    /// Draws the panel: options, the plot, its legend and front; returns what was asked.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, cx: &PlotContext<'_>) -> Option<PlotAction> {
        let mut action = None;
        let points: Vec<TradeoffPoint> = self.points_of(cx.view).to_vec();
        let other_count: usize = self
            .other_views(cx.scene, cx.view)
            .map(|v| v.points.len())
            .sum();
        let other_view_count = self.other_views(cx.scene, cx.view).count();
        let others: Vec<TradeoffPoint> = if self.show_other_views {
            self.other_views(cx.scene, cx.view)
                .flat_map(|v| v.points.iter().cloned())
                .collect()
        } else {
            Vec::new()
        };
        ui.horizontal_wrapped(|ui| {
            ui.heading("Error against time");
            ui.checkbox(&mut self.log_time_axis, "log time axis");
            ui.add_enabled(
                other_count > 0,
                egui::Checkbox::new(
                    &mut self.show_other_views,
                    format!("show {other_count} points of {other_view_count} other views"),
                ),
            )
            .on_hover_text(
                "Points measured from another camera or light of this scene, drawn hollow: kept \
                 when the camera moves, but their errors are of other pixels",
            );
            ui.add(egui::TextEdit::singleline(&mut self.export_path).desired_width(220.0))
                .on_hover_text(self.export_path.clone());
            if ui
                .add_enabled(!points.is_empty(), egui::Button::new("Export sweep"))
                .on_hover_text("Writes the points as a sweep file for `workbench bench --sweep`")
                .clicked()
            {
                action = Some(PlotAction::Export(PathBuf::from(self.export_path.trim())));
            }
        });
        let defaults = defaults_of(cx.registry);
        let series = series_of(cx.registry, &points, &others);
        let front = pareto_front(&points);
        // A narrow window (1000 x 700) leaves the plot most of the width.
        let legend_width =
            (ui.available_width() * LEGEND_SHARE).clamp(*LEGEND_WIDTH.start(), *LEGEND_WIDTH.end());
        egui::Panel::right("plot legend")
            .exact_size(legend_width)
            .resizable(false)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    if let Some(point) = &self.hovered {
                        ui.group(|ui| describe_ui(ui, point, &defaults));
                    }
                    if series.is_empty() && cx.no_yardstick {
                        ui.weak(
                            "No point under this light: a point rests on the yardstick, which \
                             cannot sample it (the error section says why).",
                        );
                    } else {
                        legend_ui(ui, &series, &points, &front, &defaults);
                    }
                });
            });
        let clicked = self.plot_ui(ui, &points, &others, &series, &front, &defaults);
        if let Some(point) = clicked {
            action = Some(PlotAction::Restore(point));
        }
        action
    }

    /// The plot itself; returns the point clicked, if one was.
    fn plot_ui(
        &mut self,
        ui: &mut egui::Ui,
        points: &[TradeoffPoint],
        others: &[TradeoffPoint],
        series: &[Series],
        front: &[usize],
        defaults: &Defaults,
    ) -> Option<TradeoffPoint> {
        let log_x = self.log_time_axis;
        let x_of = move |ms: f64| if log_x { ms.max(1e-3).log10() } else { ms };
        let all: Vec<[f64; 2]> = points
            .iter()
            .chain(others)
            .map(|p| [x_of(p.gpu_ms), p.error])
            .collect();
        let (x_range, y_range) = fitted_bounds(&all, log_x);
        // About one labelled tick per 90 points of width: each label has room.
        let max_ticks = ((ui.available_width() / 90.0) as usize).clamp(2, 10);
        let mut plot = egui_plot::Plot::new("tradeoff")
            .x_axis_label(if log_x {
                "technique GPU ms (log scale)"
            } else {
                "technique GPU ms"
            })
            .y_axis_label("mae_shadowed")
            // The bounds follow the data every frame; the hover is the plot's own (below).
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .allow_double_click_reset(false)
            .show_x(false)
            .show_y(false)
            .y_grid_spacer(move |input| linear_ticks(input.bounds, 6))
            .y_axis_formatter(|mark, _| format_error_tick(mark.value));
        plot = if log_x {
            plot.x_grid_spacer(move |input| log_ticks(input.bounds, max_ticks))
                .x_axis_formatter(|mark, _| format_tick(10f64.powf(mark.value)))
        } else {
            plot.x_grid_spacer(move |input| linear_ticks(input.bounds, max_ticks))
                .x_axis_formatter(|mark, _| format_tick(mark.value))
        };
        let items = PlotItems {
            points,
            others,
            series,
            front,
            log_x,
        };
        let response = plot.show(ui, |plot| {
            plot.set_plot_bounds(egui_plot::PlotBounds::from_min_max(
                [x_range[0], y_range[0]],
                [x_range[1], y_range[1]],
            ));
            items.draw(plot);
        });
        self.drawn = points
            .iter()
            .map(|p| {
                let at = egui_plot::PlotPoint::new(x_of(p.gpu_ms), p.error);
                (response.transform.position_from_point(&at), p.clone())
            })
            .collect();
        let hovered = response.response.hover_pos().and_then(|pos| {
            self.drawn
                .iter()
                .map(|(at, p)| (at.distance(pos), p))
                .filter(|(d, _)| *d <= PICK_RADIUS)
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, p)| p.clone())
        });
        let clicked = response.response.clicked();
        if let Some(point) = &hovered {
            response
                .response
                .on_hover_ui_at_pointer(|ui| describe_ui(ui, point, defaults));
        }
        self.hovered = hovered.clone();
        hovered.filter(|_| clicked)
    }
}

/// What the plot draws: the current view's points (and the other views' shown), the series,
/// the front.
struct PlotItems<'a> {
    points: &'a [TradeoffPoint],
    others: &'a [TradeoffPoint],
    series: &'a [Series],
    front: &'a [usize],
    log_x: bool,
}

impl PlotItems<'_> {
    fn draw(&self, plot: &mut egui_plot::PlotUi<'_>) {
        let log_x = self.log_x;
        let x_of = move |ms: f64| if log_x { ms.max(1e-3).log10() } else { ms };
        let (points, others, series, front) = (self.points, self.others, self.series, self.front);
        if front.len() > 1 {
            let line: Vec<[f64; 2]> = front
                .iter()
                .map(|&i| [x_of(points[i].gpu_ms), points[i].error])
                .collect();
            // No band: egui_plot merges points that share a pixel column into a filled
            // band, which drew the front as a grey triangle on the linear axis.
            plot.line(
                egui_plot::Line::new("Pareto front", line)
                    .color(FRONT_COLOUR)
                    .width(1.5)
                    .allow_band(false)
                    .allow_hover(false),
            );
        }
        for s in series {
            let of = |points: &[TradeoffPoint]| -> Vec<[f64; 2]> {
                points
                    .iter()
                    .filter(|p| s.holds(p))
                    .map(|p| [x_of(p.gpu_ms), p.error])
                    .collect()
            };
            plot.points(
                egui_plot::Points::new(s.name.clone(), of(points))
                    .radius(5.0)
                    .shape(s.shape)
                    .filled(true)
                    .color(s.colour)
                    .allow_hover(false),
            );
            let other = of(others);
            if !other.is_empty() {
                plot.points(
                    egui_plot::Points::new(format!("{} (other views)", s.name), other)
                        .radius(5.0)
                        .shape(s.shape)
                        .filled(false)
                        .color(s.colour.gamma_multiply(0.7))
                        .allow_hover(false),
                );
            }
        }
        for p in points.iter().filter(|p| p.settled_after.is_some()) {
            plot.text(
                egui_plot::Text::new(
                    format!("settled {}", p.series()),
                    egui_plot::PlotPoint::new(x_of(p.gpu_ms), p.error),
                    egui::RichText::new("  settled").small(),
                )
                .anchor(egui::Align2::LEFT_CENTER)
                .color(egui::Color32::from_gray(210)),
            );
        }
    }
}

/// One technique (and version) with points: its legend name and style.
struct Series {
    technique: String,
    version: Option<u32>,
    name: String,
    colour: egui::Color32,
    shape: egui_plot::MarkerShape,
}

impl Series {
    fn holds(&self, p: &TradeoffPoint) -> bool {
        p.technique == self.technique && p.version == self.version
    }
}

/// Each technique's parameters at their defaults (labels name only the changed ones).
type Defaults = BTreeMap<String, Vec<(String, ParamValue)>>;

fn defaults_of(registry: &Registry) -> Defaults {
    registry
        .iter()
        .map(|t| {
            (
                t.id.to_string(),
                t.params
                    .iter()
                    .map(|s| (s.name.to_string(), s.default_value()))
                    .collect(),
            )
        })
        .collect()
}

/// The series with points, in registry order and then by version; a technique no longer
/// registered keeps the style after the registry's.
fn series_of(
    registry: &Registry,
    points: &[TradeoffPoint],
    others: &[TradeoffPoint],
) -> Vec<Series> {
    let mut keys: Vec<(usize, String, Option<u32>)> = Vec::new();
    for p in points.iter().chain(others) {
        let index = registry
            .iter()
            .position(|t| t.id == p.technique)
            .unwrap_or(registry.iter().count());
        let key = (index, p.technique.clone(), p.version);
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    keys.sort();
    keys.into_iter()
        .map(|(index, technique, version)| {
            let (colour, shape) = series_style(index, version);
            let name = match version {
                Some(v) => format!("{technique} v{v}"),
                None => technique.clone(),
            };
            Series {
                technique,
                version,
                name,
                colour,
                shape,
            }
        })
        .collect()
}

/// The legend (markers drawn as in the plot: the default font has no geometric glyphs), the
/// front's points by name, and what "settled" means.
fn legend_ui(
    ui: &mut egui::Ui,
    series: &[Series],
    points: &[TradeoffPoint],
    front: &[usize],
    defaults: &Defaults,
) {
    if series.is_empty() {
        ui.weak(
            "No point yet: a setting becomes a point once the reference has converged and its \
             cost is measured.",
        );
        return;
    }
    ui.horizontal_wrapped(|ui| {
        for s in series {
            legend_marker(ui, s.colour, s.shape);
            ui.colored_label(s.colour, &s.name);
            ui.add_space(6.0);
        }
        if front.len() > 1 {
            let (rect, _) = ui.allocate_exact_size(egui::vec2(14.0, 12.0), egui::Sense::hover());
            ui.painter().hline(
                rect.x_range(),
                rect.center().y,
                egui::Stroke::new(1.5, FRONT_COLOUR),
            );
            ui.colored_label(FRONT_COLOUR, "Pareto front");
        }
    });
    if points.iter().any(|p| p.settled_after.is_some()) {
        ui.small(
            "settled: a technique that keeps a history, measured once its history has settled \
             (still frames up to its history length), not its first frame",
        );
    }
    for &i in front {
        let p = &points[i];
        let label = p.label(defaults.get(p.technique.as_str()).map_or(&[], |d| d));
        ui.small(format!(
            "front: {label}: {} ms, {:.4}",
            format_ms(p.gpu_ms),
            p.error
        ))
        .on_hover_text(format!("{}\n{}", describe_error(p), describe_cost(p)));
    }
}

/// A point named: its technique and settings, error and cost, and what a click does.
fn describe_ui(ui: &mut egui::Ui, point: &TradeoffPoint, defaults: &Defaults) {
    let label = point.label(defaults.get(point.technique.as_str()).map_or(&[], |d| d));
    ui.strong(label);
    ui.label(describe_error(point));
    ui.label(describe_cost(point));
    ui.weak("click: show this setting");
}

/// The point's error, and what it is of.
fn describe_error(p: &TradeoffPoint) -> String {
    match p.settled_after {
        Some(n) => format!(
            "mae_shadowed {:.4}, settled: after {n} still frames of history",
            p.error
        ),
        None => format!("mae_shadowed {:.4}", p.error),
    }
}

/// The point's cost and the frames it rests on.
fn describe_cost(p: &TradeoffPoint) -> String {
    let (lo, hi) = p.gpu_range;
    if p.cost_frames > 1 {
        format!(
            "cost {} ms: median of {} clean frames (caches dropped, nothing else running), \
             range {} to {} ms",
            format_ms(p.gpu_ms),
            p.cost_frames,
            format_ms(lo),
            format_ms(hi)
        )
    } else {
        format!(
            "cost {} ms: one clean frame (caches dropped, nothing else running)",
            format_ms(p.gpu_ms)
        )
    }
}

/// The legend's copy of a plot marker.
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

/// Plot bounds that hold every point with a margin, from zero (linear) or whole decades around
/// the points (log), so a single point is not drawn beside a lone "0" tick.
fn fitted_bounds(points: &[[f64; 2]], log_x: bool) -> ([f64; 2], [f64; 2]) {
    let min_x = points.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
    let max_x = points
        .iter()
        .map(|p| p[0])
        .fold(f64::NEG_INFINITY, f64::max);
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

/// Grid marks of a log10 axis over `bounds` (log10 values): the densest of decades, 1-3,
/// 1-2-5 and 1..9 per decade that gives at most `max_ticks`, or every n-th decade when even
/// decades are too many. Each mark's step is the distance to its nearest neighbour, which is
/// what egui_plot weighs to give a tick its label.
pub fn log_ticks(bounds: (f64, f64), max_ticks: usize) -> Vec<egui_plot::GridMark> {
    let (lo, hi) = bounds;
    if !(lo.is_finite() && hi.is_finite() && hi > lo) || max_ticks == 0 {
        return Vec::new();
    }
    // Not in the last few percent, where its label would be cut at the plot's edge.
    let hi_mark = hi - 0.03 * (hi - lo);
    let decades = (lo.floor() as i64)..=(hi.ceil() as i64);
    let values_of = |mantissas: &[f64], every: i64| -> Vec<f64> {
        decades
            .clone()
            .filter(|d| d.rem_euclid(every) == 0)
            .flat_map(|d| mantissas.iter().map(move |m| d as f64 + m.log10()))
            .filter(|v| *v >= lo && *v <= hi_mark)
            .collect()
    };
    let sets: [&[f64]; 4] = [
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
        &[1.0, 2.0, 5.0],
        &[1.0, 3.0],
        &[1.0],
    ];
    let mut values = Vec::new();
    for set in sets {
        values = values_of(set, 1);
        if values.len() <= max_ticks {
            break;
        }
    }
    let mut every = 2;
    while values.len() > max_ticks {
        values = values_of(&[1.0], every);
        every += 1;
    }
    let step_of = |i: usize| {
        let before = i.checked_sub(1).map(|j| values[i] - values[j]);
        let after = values.get(i + 1).map(|v| v - values[i]);
        match (before, after) {
            (Some(a), Some(b)) => a.min(b),
            (Some(a), None) | (None, Some(a)) => a,
            (None, None) => hi - lo,
        }
    };
    (0..values.len())
        .map(|i| egui_plot::GridMark {
            value: values[i],
            step_size: step_of(i),
        })
        .collect()
}

/// Tick label of an ms axis: whole numbers from 10 ms up, otherwise as few decimals as the
/// value needs (three significant digits at most).
pub fn format_tick(ms: f64) -> String {
    if ms.abs() < 1e-9 {
        "0".into()
    } else if ms.abs() >= 10.0 {
        format!("{ms:.0}")
    } else {
        let decimals = (2 - ms.abs().log10().floor() as i32).clamp(0, 6) as usize;
        let text = format!("{ms:.decimals$}");
        if text.contains('.') {
            text.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            text
        }
    }
}

/// Tick label of the error axis.
fn format_error_tick(value: f64) -> String {
    if value.abs() < 1e-12 {
        "0".into()
    } else {
        let text = format!("{value:.4}");
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}
