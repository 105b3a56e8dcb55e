//! `workbench report`: one self-contained HTML page of error against run time.
//!
//! Per scene: error (mae_shadowed against the exact answer where the run has it, else against
//! the reference) and FLIP against frame time on a log axis, drawn with plotters' SVG backend,
//! one colour and marker per technique, the Pareto front as a staircase; a table of the runs and
//! image strips of the runs on the front. Above them a headline table: per scene and technique,
//! the lowest error within 1x, 2x, 4x and 8x the `hard` frame time, and the cost of reaching
//! mae_shadowed <= 0.01. Images are embedded as data URIs: the page loads nothing.

use std::{collections::BTreeMap, fmt::Write as _, path::Path};

use base64::Engine as _;
use plotters::prelude::*;

use softshadow_core::{Registry, COST_FLOOR_TECHNIQUE, YARDSTICK_TECHNIQUE};
use softshadow_metrics::{ErrorReport, IrradianceReport};

use crate::{
    merge::Merged,
    results::{Run, Status},
    BenchError,
};

/// Stroke colour of the Pareto staircase (the parse-level test finds the polyline by it).
pub const PARETO_COLOUR: RGBColor = RGBColor(20, 20, 20);
/// The Pareto polyline's `stroke` attribute as plotters writes it.
pub const PARETO_STROKE: &str = "#141414";
/// Error at which the headline table reports a technique's cost.
pub const TARGET_MAE: f64 = 0.01;
/// Time budgets of the headline and summary tables, in multiples of the `hard` frame time. Wide:
/// a frame here rebuilds all light-space work, and on a CPU device the soft techniques' frames
/// are 2 to 130 times `hard`'s (docs/BENCHMARKS.md, the overview).
pub const BUDGETS: [f64; 5] = [1.0, 3.0, 8.0, 32.0, 128.0];
/// Frame-time budgets in milliseconds, where the timing is a GPU's (timestamp queries): what a
/// game can spend on shadows at 1920 x 1080.
pub const MS_BUDGETS: [f64; 4] = [0.5, 1.0, 2.0, 4.0];
/// The image size the millisecond budgets are for.
pub const MS_BUDGET_SIZE: (u32, u32) = (1920, 1080);

/// How a budget's frame-time limit is set: a multiple of the fastest cost-floor run on the scene
/// ([`BUDGETS`], on any adapter), or milliseconds ([`MS_BUDGETS`], only for GPU timing).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Budgets {
    /// [`BUDGETS`] x the cost floor's frame time.
    FloorMultiples,
    /// [`MS_BUDGETS`] milliseconds.
    Milliseconds,
}

impl Budgets {
    /// The budgets' numbers (multiples or milliseconds).
    pub fn values(self) -> &'static [f64] {
        match self {
            Budgets::FloorMultiples => &BUDGETS,
            Budgets::Milliseconds => &MS_BUDGETS,
        }
    }

    /// The frame-time limit of each budget on a scene whose fastest cost-floor run takes
    /// `floor_ms` (infinite when there is none: no multiple fits then).
    fn limits_ms(self, floor_ms: f64) -> Vec<f64> {
        match self {
            Budgets::FloorMultiples => BUDGETS
                .iter()
                .map(|b| {
                    if floor_ms.is_finite() {
                        b * floor_ms
                    } else {
                        -1.0
                    }
                })
                .collect(),
            Budgets::Milliseconds => MS_BUDGETS.to_vec(),
        }
    }

    /// The time a run is held to the budget by: the whole frame's (G-buffer, technique,
    /// shading) against multiples of the cost floor; the technique's own passes' against
    /// milliseconds, what a renderer that already draws its G-buffer spends on shadows.
    pub fn time_ms(self, run: &Run) -> Option<f64> {
        match self {
            Budgets::FloorMultiples => frame_time_ms(run),
            Budgets::Milliseconds => technique_time_ms(run),
        }
    }

    /// A budget's column label: `3x` or `1 ms`.
    pub fn label(self, value: f64) -> String {
        match self {
            Budgets::FloorMultiples => format!("{value}x"),
            Budgets::Milliseconds => format!("{value} ms"),
        }
    }
}

const PLOT_SIZE: (u32, u32) = (600, 380);

/// One run as a point of a plot.
#[derive(Clone, Debug)]
pub struct PlotPoint {
    /// Index into the merged runs.
    pub run: usize,
    pub technique: String,
    pub time_ms: f64,
    pub value: f64,
    pub tooltip: String,
}

/// Frame time of a run: the median of `timing.frame_ms`, else of its wall time.
pub fn frame_time_ms(run: &Run) -> Option<f64> {
    let timing = run.timing.as_ref()?;
    let ms = timing
        .frame_ms
        .as_ref()
        .map_or(timing.cpu_ms.median, |p| p.median);
    (ms.is_finite() && ms > 0.0).then_some(ms)
}

/// The technique's own passes' time: the median of `timing.technique_ms`.
pub fn technique_time_ms(run: &Run) -> Option<f64> {
    let ms = run.timing.as_ref()?.technique_ms.as_ref()?.median;
    (ms.is_finite() && ms > 0.0).then_some(ms)
}

/// Time of the run's first frame, with nothing built or loaded yet (`cold.timing`).
pub fn cold_frame_ms(run: &Run) -> Option<f64> {
    let ms = run.cold.as_ref()?.timing.frame_ms.as_ref()?.median;
    ms.is_finite().then_some(ms)
}

/// A field of the run's error report against the exact answer when the run has one, else
/// against the reference; `None` without error metrics or when it is not finite.
fn error_field(run: &Run, field: fn(&ErrorReport) -> f64) -> Option<f64> {
    let error = run.error.as_ref()?;
    let value = field(error.vs_exact.as_ref().unwrap_or(&error.report));
    value.is_finite().then_some(value)
}

/// A field of the run's irradiance errors against the exact irradiance, where it has them.
fn irradiance_field(run: &Run, field: fn(&IrradianceReport) -> f64) -> Option<f64> {
    let value = field(&run.error.as_ref()?.irradiance.as_ref()?.vs_exact);
    value.is_finite().then_some(value)
}

/// mae_shadowed against the exact answer when the run has one, else against the reference.
pub fn mae_shadowed(run: &Run) -> Option<f64> {
    error_field(run, |r| r.mae_shadowed)
}

/// The error a run is ranked by across scenes: [`mae_shadowed`] of its settled frame for a
/// technique that accumulates over frames ([`Run::settled`]: what a user sees after a moment),
/// else of its first frame.
pub fn scored_mae(run: &Run) -> Option<f64> {
    let Some(settled) = &run.settled else {
        return mae_shadowed(run);
    };
    let mae = settled
        .vs_exact
        .as_ref()
        .unwrap_or(&settled.report)
        .mae_shadowed;
    mae.is_finite().then_some(mae)
}

/// The error in irradiance over shadowed receivers against the exact irradiance
/// (`IrradianceReport::irradiance_mae_shadowed`), where the run has it.
pub fn irradiance_mae_shadowed(run: &Run) -> Option<f64> {
    irradiance_field(run, |r| r.irradiance_mae_shadowed)
}

/// The error in irradiance over all receivers (`IrradianceReport::irradiance_mae`).
pub fn irradiance_mae(run: &Run) -> Option<f64> {
    irradiance_field(run, |r| r.irradiance_mae)
}

/// What the across-scenes tables rank by (docs/EXACT.md, "The irradiance error").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Score {
    /// [`scored_mae`]: the visibility error over shadowed receivers (the default).
    Visibility,
    /// [`irradiance_mae_shadowed`]: the error where the shaded image shows it (runs without an
    /// analytic exact answer have none and are left out).
    Irradiance,
}

impl Score {
    /// The run's error by this score.
    pub fn of(self, run: &Run) -> Option<f64> {
        match self {
            Score::Visibility => scored_mae(run),
            Score::Irradiance => irradiance_mae_shadowed(run),
        }
    }
}

/// The too-dark part of [`mae_shadowed`], against the same answer (`ErrorReport::darker_shadowed`).
pub fn darker_shadowed(run: &Run) -> Option<f64> {
    error_field(run, |r| r.darker_shadowed)
}

/// Light leaking: how much too bright the run is inside umbrae, against the same answer as
/// [`mae_shadowed`] (`ErrorReport::brighter_umbra`).
pub fn brighter_umbra(run: &Run) -> Option<f64> {
    error_field(run, |r| r.brighter_umbra)
}

/// Which answer [`mae_shadowed`] was measured against.
pub fn mae_against(run: &Run) -> &'static str {
    match run.error.as_ref().and_then(|e| e.vs_exact.as_ref()) {
        Some(_) => "exact",
        None => YARDSTICK_TECHNIQUE,
    }
}

pub fn flip(run: &Run) -> Option<f64> {
    run.error
        .as_ref()?
        .report
        .flip_mean
        .filter(|f| f.is_finite())
}

pub fn params_text(run: &Run) -> String {
    let params: Vec<String> = run.params.iter().map(|(n, v)| format!("{n}={v}")).collect();
    params.join(" ")
}

/// Indices (into `points`) of the Pareto front, fastest first: the points no other point beats
/// in both time and value (ties in time keep the lower value).
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in order {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

fn plot_error(e: impl std::fmt::Display) -> BenchError {
    BenchError::Merge(format!("cannot draw the report's plot: {e}"))
}

/// Colour and marker of each technique: registry order first, so a technique looks the same in
/// every report, then techniques the registry lacks in the order their runs come.
fn technique_styles(runs: &[Run], registry: &Registry) -> BTreeMap<String, usize> {
    let mut ids: Vec<String> = registry.ids().into_iter().map(String::from).collect();
    for run in runs {
        if !ids.contains(&run.technique) {
            ids.push(run.technique.clone());
        }
    }
    ids.into_iter().enumerate().map(|(k, id)| (id, k)).collect()
}

fn colour(style: usize) -> RGBColor {
    const COLOURS: [RGBColor; 10] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
    ];
    COLOURS[style % COLOURS.len()]
}

/// A time axis label: as many decimals as a log axis from 0.01 ms to minutes needs.
fn tick_ms(t: f64) -> String {
    if t >= 10.0 {
        format!("{t:.0}")
    } else if t >= 1.0 {
        format!("{t:.1}")
    } else {
        format!("{t:.3}")
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// One plot: `points` (time, value) on a log time axis, one colour and marker per technique,
/// the Pareto staircase in [`PARETO_COLOUR`], and over every point an invisible circle with
/// class `run`, `data-run`, `data-time` and `data-value` attributes and a `<title>` tooltip
/// (the parameters), which plotters has no element for.
pub fn plot_svg(
    points: &[PlotPoint],
    styles: &BTreeMap<String, usize>,
    caption: &str,
    value_label: &str,
) -> Result<String, BenchError> {
    plot_svg_over(points, styles, caption, "frame time, ms (log)", value_label)
}

/// [`plot_svg`] with another quantity on the log x axis (`time_ms` then holds it, e.g. MiB).
pub fn plot_svg_over(
    points: &[PlotPoint],
    styles: &BTreeMap<String, usize>,
    caption: &str,
    x_label: &str,
    value_label: &str,
) -> Result<String, BenchError> {
    let mut svg = String::new();
    let mut hits = Vec::new();
    {
        let root = SVGBackend::with_string(&mut svg, PLOT_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let (t_min, t_max) = points.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
            (lo.min(p.time_ms), hi.max(p.time_ms))
        });
        let (t_min, t_max) = if points.is_empty() {
            (0.1, 10.0)
        } else {
            (t_min / 1.6, t_max * 1.6)
        };
        let v_max = points.iter().map(|p| p.value).fold(0.0f64, f64::max);
        let v_max = if v_max > 0.0 { v_max * 1.12 } else { 0.01 };
        let mut chart = ChartBuilder::on(&root)
            .caption(caption, ("sans-serif", 16))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d((t_min..t_max).log_scale(), 0.0..v_max)
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(value_label)
            .x_label_formatter(&|t| tick_ms(*t))
            .y_label_formatter(&|v| format!("{v:.3}"))
            .draw()
            .map_err(plot_error)?;
        let mut techniques: Vec<&str> = points.iter().map(|p| p.technique.as_str()).collect();
        techniques.sort_by_key(|t| styles.get(*t).copied().unwrap_or(usize::MAX));
        techniques.dedup();
        for technique in techniques {
            let style = styles.get(technique).copied().unwrap_or(0);
            let of_technique: Vec<&PlotPoint> =
                points.iter().filter(|p| p.technique == technique).collect();
            chart
                .draw_series(
                    of_technique
                        .iter()
                        .map(|p| EmptyElement::at((p.time_ms, p.value)) + marker(style, (0, 0))),
                )
                .map_err(plot_error)?
                .label(technique)
                .legend(move |at| marker(style, at));
        }
        let stairs = pareto_stairs(points);
        if !stairs.is_empty() {
            chart
                .draw_series(LineSeries::new(stairs, PARETO_COLOUR.stroke_width(2)))
                .map_err(plot_error)?
                .label("Pareto front")
                // A bar, not a path: the front stays the plot's only polyline of its colour.
                .legend(|(x, y)| {
                    Rectangle::new([(x - 8, y - 1), (x + 8, y + 1)], PARETO_COLOUR.filled())
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.6))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(plot_error)?;
        for p in points {
            hits.push((p, chart.backend_coord(&(p.time_ms, p.value))));
        }
        root.present().map_err(plot_error)?;
    }
    with_point_overlay(svg, &hits)
}

/// The marker of technique style `style` at pixel offset `at`: one of six shapes (filled or
/// outlined) in the style's colour.
fn marker<DB: DrawingBackend>(style: usize, at: (i32, i32)) -> DynElement<'static, DB, (i32, i32)> {
    let c = colour(style);
    let square = [(at.0 - 4, at.1 - 4), (at.0 + 4, at.1 + 4)];
    match (style / 10 + style) % 6 {
        0 => Circle::new(at, 4, c.filled()).into_dyn(),
        1 => TriangleMarker::new(at, 6, c.filled()).into_dyn(),
        2 => Cross::new(at, 4, c.stroke_width(2)).into_dyn(),
        3 => Rectangle::new(square, c.filled()).into_dyn(),
        4 => Circle::new(at, 4, c.stroke_width(2)).into_dyn(),
        _ => Rectangle::new(square, c.stroke_width(2)).into_dyn(),
    }
}

/// The Pareto front of `points` as a staircase: from each front point right to the next one's
/// time, then down.
fn pareto_stairs(points: &[PlotPoint]) -> Vec<(f64, f64)> {
    let front = pareto_front(
        &points
            .iter()
            .map(|p| (p.time_ms, p.value))
            .collect::<Vec<_>>(),
    );
    let mut stairs = Vec::new();
    for (k, &i) in front.iter().enumerate() {
        if k > 0 {
            stairs.push((points[i].time_ms, points[front[k - 1]].value));
        }
        stairs.push((points[i].time_ms, points[i].value));
    }
    stairs
}

/// `svg` with an invisible circle over every point (its pixel position in `hits`): class `run`,
/// `data-run`, `data-time` and `data-value` attributes and a `<title>` tooltip.
fn with_point_overlay(
    mut svg: String,
    hits: &[(&PlotPoint, (i32, i32))],
) -> Result<String, BenchError> {
    let mut overlay = String::new();
    for (p, (x, y)) in hits {
        let _ = write!(
            overlay,
            r##"<circle class="run" data-run="{}" data-time="{}" data-value="{}" cx="{x}" cy="{y}" r="7" fill="#000" fill-opacity="0"><title>{}</title></circle>"##,
            p.run,
            p.time_ms,
            p.value,
            escape(&p.tooltip)
        );
    }
    let end = svg.rfind("</svg>").ok_or_else(|| plot_error("no </svg>"))?;
    svg.insert_str(end, &overlay);
    Ok(svg)
}

/// Edge, in pixels, of the images embedded in the report (larger ones are scaled down, which
/// keeps a report of a 256x256 sweep small).
pub const THUMBNAIL_EDGE: u32 = 128;

/// A PNG of the image at `path`, scaled to fit [`THUMBNAIL_EDGE`], as a data URI.
fn data_uri(path: &Path) -> Option<String> {
    let image = image::open(path).ok()?;
    let image = if image.width() > THUMBNAIL_EDGE || image.height() > THUMBNAIL_EDGE {
        image.resize(
            THUMBNAIL_EDGE,
            THUMBNAIL_EDGE,
            image::imageops::FilterType::Triangle,
        )
    } else {
        image
    };
    let mut png = std::io::Cursor::new(Vec::new());
    image.write_to(&mut png, image::ImageFormat::Png).ok()?;
    Some(format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(png.into_inner())
    ))
}

/// What the report contains, for the CLI's summary line and the tests.
#[derive(Clone, Debug, Default)]
pub struct ReportSummary {
    pub scenes: usize,
    pub points: usize,
    /// Failed runs and runs without a time or an error (listed in the tables, not plotted).
    pub unplotted: usize,
    pub warnings: Vec<String>,
}

const STYLE: &str = "body{font-family:sans-serif;margin:20px;max-width:1240px;color:#222}\
table{border-collapse:collapse;font-size:13px;margin:8px 0 16px}\
td,th{border:1px solid #ccc;padding:3px 6px;text-align:right}\
td.l,th.l{text-align:left}\
.plots{display:flex;flex-wrap:wrap;gap:8px}\
.strip{display:flex;flex-wrap:wrap;gap:12px}\
.strip figure{margin:0;font-size:12px}\
.strip img{width:128px;height:128px;image-rendering:pixelated;display:block}\
.warn{color:#a40}\
tr.front td{background:#eef6ee}\
.animation img{image-rendering:pixelated;width:512px;height:auto}";

/// Writes the report of `merged` to `out` (and the runs as CSV to `csv`).
pub fn write_report(
    merged: &Merged,
    registry: &Registry,
    out: &Path,
    csv: Option<&Path>,
    cpu: Option<&[Run]>,
) -> Result<ReportSummary, BenchError> {
    let (html, summary) = render_html_beside(merged, registry, cpu)?;
    crate::output::write_atomic(out, html.as_bytes())?;
    if let Some(csv) = csv {
        crate::output::write_atomic(csv, runs_csv(merged).as_bytes())?;
    }
    Ok(summary)
}

/// A time in ms with as many digits as it needs.
pub fn ms(v: f64) -> String {
    if v >= 100.0 {
        format!("{v:.0}")
    } else if v >= 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

/// The report as one HTML string; `registry` orders the techniques' colours and markers.
pub fn render_html(
    merged: &Merged,
    registry: &Registry,
) -> Result<(String, ReportSummary), BenchError> {
    render_html_beside(merged, registry, None)
}

/// [`render_html`] with, when `cpu` holds the same runs made on a CPU adapter, a section on how
/// the ranking moves from the CPU to this adapter ([`crate::compare`]).
pub fn render_html_beside(
    merged: &Merged,
    registry: &Registry,
    cpu: Option<&[Run]>,
) -> Result<(String, ReportSummary), BenchError> {
    let all_runs = &merged.results.runs;
    let styles = technique_styles(all_runs, registry);
    // Runs along a path have their own section; the still-frame tables and plots leave them out.
    let still: Vec<Run> = all_runs
        .iter()
        .filter(|r| r.motion.is_none())
        .cloned()
        .collect();
    let runs = &still;
    let motion_runs: Vec<usize> = (0..all_runs.len())
        .filter(|&i| all_runs[i].motion.is_some())
        .collect();
    let mut summary = ReportSummary {
        warnings: merged.warnings.clone(),
        ..Default::default()
    };
    let scenes = scenes_of(runs);
    let motion_scenes: Vec<Run> = motion_runs.iter().map(|&i| all_runs[i].clone()).collect();
    summary.scenes = scenes.len()
        + scenes_of(&motion_scenes)
            .iter()
            .filter(|s| !scenes.contains(s))
            .count();
    let mut body = report_heading(merged);
    if !runs.is_empty() {
        // Still-frame tables; a report of runs along paths only has the motion section.
        body.push_str(&still_tables(runs, &scenes, cpu));
    }
    for scene in &scenes {
        body.push_str(&scene_section(merged, runs, scene, &styles, &mut summary)?);
    }
    if !motion_runs.is_empty() {
        body.push_str(&motion_section(
            merged,
            &motion_runs,
            &styles,
            &mut summary,
        )?);
    }
    let html = format!(
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>softshadow report</title><style>{STYLE}</style></head><body>{body}</body></html>\n"
    );
    Ok((html, summary))
}

/// The report's title paragraph (runs, adapter, timing, sweep) and the merge's warnings.
fn report_heading(merged: &Merged) -> String {
    let all_runs = &merged.results.runs;
    let adapter = &merged.results.adapter;
    let sources: Vec<String> = {
        let mut s: Vec<String> = all_runs
            .iter()
            .filter_map(|r| Some(r.timing.as_ref()?.source.to_string()))
            .collect();
        s.sort();
        s.dedup();
        s
    };
    let mut body = String::new();
    let _ = write!(
        body,
        "<h1>Soft shadows: error against run time</h1><p>{} runs on <b>{}</b> ({}, {}); timing: <b>{}</b>{}. Error: mae_shadowed (mean absolute visibility error over shadowed receiver pixels) against the exact answer where the run has it, else against the reference; FLIP: mean FLIP of the shaded image against the reference's.</p>",
        all_runs.len(),
        escape(&adapter.name),
        escape(&adapter.backend),
        escape(&adapter.driver),
        if sources.is_empty() { "-".to_string() } else { sources.join(", ") },
        merged
            .results
            .sweep
            .as_ref()
            .map(|s| format!("; sweep {} ({} runs)", s.hash, s.runs_total))
            .unwrap_or_default()
    );
    for w in &merged.warnings {
        let _ = write!(body, "<p class=\"warn\">warning: {}</p>", escape(w));
    }
    body
}

/// The tables over every scene of the still runs: the summaries (visibility, irradiance where
/// measured, millisecond budgets where they apply), the CPU-to-GPU section with `cpu`, the
/// headline table.
fn still_tables(runs: &[Run], scenes: &[(String, u32, u32)], cpu: Option<&[Run]>) -> String {
    let mut body = summary_table(runs, scenes, Budgets::FloorMultiples, Score::Visibility);
    if runs.iter().any(|r| irradiance_mae_shadowed(r).is_some()) {
        body.push_str(&summary_table(
            runs,
            scenes,
            Budgets::FloorMultiples,
            Score::Irradiance,
        ));
    }
    let ms_scenes = ms_budget_scenes(runs, scenes);
    if !ms_scenes.is_empty() {
        body.push_str(&summary_table(
            runs,
            &ms_scenes,
            Budgets::Milliseconds,
            Score::Visibility,
        ));
    }
    if let Some(cpu) = cpu {
        body.push_str(&cpu_to_gpu_section(cpu, runs));
    }
    body.push_str(&headline_table(runs, scenes));
    body
}

/// One scene's section of the still runs `runs`: its plots, its runs' table and the images of
/// its Pareto front; counts its plotted and unplotted runs in `summary`.
fn scene_section(
    merged: &Merged,
    runs: &[Run],
    (scene, width, height): &(String, u32, u32),
    styles: &BTreeMap<String, usize>,
    summary: &mut ReportSummary,
) -> Result<String, BenchError> {
    let in_scene: Vec<usize> = (0..runs.len())
        .filter(|&i| {
            let r = &runs[i];
            &r.scene == scene && r.width == *width && r.height == *height
        })
        .collect();
    let mae_points: Vec<PlotPoint> = in_scene
        .iter()
        .filter_map(|&i| plot_point(runs, i, mae_shadowed(&runs[i])))
        .collect();
    summary.points += mae_points.len();
    summary.unplotted += in_scene.len() - mae_points.len();
    let mut body = String::new();
    let title = format!("{scene} ({width}x{height})");
    let _ = write!(
        body,
        "<h2 id=\"{}\">{}</h2><div class=\"plots\" data-scene=\"{}\">",
        escape(&crate::sanitize(scene)),
        escape(&title),
        escape(scene)
    );
    body.push_str(&scene_plots(runs, &in_scene, &mae_points, styles)?);
    body.push_str("</div>");
    let front: Vec<usize> = pareto_front(
        &mae_points
            .iter()
            .map(|p| (p.time_ms, p.value))
            .collect::<Vec<_>>(),
    )
    .into_iter()
    .map(|k| mae_points[k].run)
    .collect();
    body.push_str(&runs_table(runs, &in_scene, &front));
    body.push_str(&band_table(runs, &in_scene));
    // `front` indexes the still runs; the strip reads images through the merged runs.
    let all_runs = &merged.results.runs;
    let still_index: Vec<usize> = (0..all_runs.len())
        .filter(|&i| all_runs[i].motion.is_none())
        .collect();
    let front_merged: Vec<usize> = front.iter().map(|&k| still_index[k]).collect();
    body.push_str(&image_strip(merged, &front_merged));
    Ok(body)
}

/// The error against the exact answer per camera-distance band (`error.distance_bands`) of the
/// runs `in_scene` that have it: mae_all with the band's receiver pixels; empty when none has.
fn band_table(runs: &[Run], in_scene: &[usize]) -> String {
    let rows: Vec<(&Run, &Vec<softshadow_metrics::BandError>)> = in_scene
        .iter()
        .filter_map(|&i| {
            let bands = runs[i].error.as_ref()?.distance_bands.as_ref()?;
            Some((&runs[i], bands))
        })
        .collect();
    let Some((_, first)) = rows.first() else {
        return String::new();
    };
    let mut body = String::from(
        "<table><caption>mae_all against the exact answer per camera distance (receiver pixels)</caption><tr><th>technique</th><th>settings</th>",
    );
    for band in first.iter() {
        let to = band.to_m.map_or(String::new(), |t| format!("{t}"));
        let _ = write!(body, "<th>{} {}-{to} m</th>", band.band, band.from_m);
    }
    body.push_str("</tr>");
    for (run, bands) in rows {
        let _ = write!(
            body,
            "<tr><td>{}</td><td>{}</td>",
            escape(&run.technique),
            escape(&params_text(run))
        );
        for band in bands {
            let _ = match band.receiver_pixels {
                0 => write!(body, "<td>-</td>"),
                n => write!(body, "<td>{:.4} ({n})</td>", band.mae_all),
            };
        }
        body.push_str("</tr>");
    }
    body.push_str("</table>");
    body
}

/// A scene's plots: mae_shadowed (`mae_points`) and FLIP against frame time, and mae_shadowed
/// against GPU memory where it was counted.
fn scene_plots(
    runs: &[Run],
    in_scene: &[usize],
    mae_points: &[PlotPoint],
    styles: &BTreeMap<String, usize>,
) -> Result<String, BenchError> {
    let flip_points: Vec<PlotPoint> = in_scene
        .iter()
        .filter_map(|&i| plot_point(runs, i, flip(&runs[i])))
        .collect();
    let mut body = format!(
        "<div class=\"plot mae\">{}</div>",
        plot_svg(
            mae_points,
            styles,
            "mae_shadowed against frame time",
            "mae_shadowed"
        )?
    );
    body.push_str(&format!(
        "<div class=\"plot flip\">{}</div>",
        plot_svg(
            &flip_points,
            styles,
            "FLIP against frame time",
            "FLIP (mean)"
        )?
    ));
    // Error against the GPU memory the technique holds at its peak, where it was counted.
    let memory_points: Vec<PlotPoint> = in_scene
        .iter()
        .filter_map(|&i| {
            let mib = runs[i].memory.as_ref()?.peak.total_mib();
            Some(PlotPoint {
                time_ms: mib.max(1e-3),
                ..plot_point(runs, i, mae_shadowed(&runs[i]))?
            })
        })
        .collect();
    if !memory_points.is_empty() {
        body.push_str(&format!(
            "<div class=\"plot memory\">{}</div>",
            plot_svg_over(
                &memory_points,
                styles,
                "mae_shadowed against GPU memory",
                "technique's GPU memory at its peak, MiB (log)",
                "mae_shadowed"
            )?
        ));
    }
    Ok(body)
}

/// Run `i` of `runs` as a point at its frame time with `value`; none for a run that failed or
/// lacks either.
fn plot_point(runs: &[Run], i: usize, value: Option<f64>) -> Option<PlotPoint> {
    let run = &runs[i];
    if run.status != Status::Ok {
        return None;
    }
    Some(PlotPoint {
        run: i,
        technique: run.technique.clone(),
        time_ms: frame_time_ms(run)?,
        value: value?,
        tooltip: format!(
            "{} {}\n{} ms, mae_shadowed {}, FLIP {}",
            run.technique,
            params_text(run),
            frame_time_ms(run).map_or("-".into(), ms),
            mae_shadowed(run).map_or("-".into(), |v| format!("{v:.4}")),
            flip(run).map_or("-".into(), |v| format!("{v:.4}")),
        ),
    })
}

/// Per-frame lines: `lines` holds (technique, value per frame), one colour per technique.
pub fn series_svg(
    lines: &[(String, Vec<f64>)],
    styles: &BTreeMap<String, usize>,
    caption: &str,
    value_label: &str,
) -> Result<String, BenchError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, PLOT_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let frames = lines.iter().map(|(_, v)| v.len()).max().unwrap_or(1).max(2);
        let v_max = lines
            .iter()
            .flat_map(|(_, v)| v.iter().copied())
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max);
        let v_max = if v_max > 0.0 { v_max * 1.12 } else { 0.01 };
        let mut chart = ChartBuilder::on(&root)
            .caption(caption, ("sans-serif", 16))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..(frames - 1) as f64, 0.0..v_max)
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc("frame")
            .y_desc(value_label)
            .x_label_formatter(&|t| format!("{t:.0}"))
            .y_label_formatter(&|v| format!("{v:.4}"))
            .draw()
            .map_err(plot_error)?;
        for (technique, values) in lines {
            let base = technique.split(' ').next().unwrap_or(technique);
            let c = colour(styles.get(base).copied().unwrap_or(0));
            chart
                .draw_series(LineSeries::new(
                    values
                        .iter()
                        .enumerate()
                        .filter(|(_, v)| v.is_finite())
                        .map(|(k, v)| (k as f64, *v)),
                    c.stroke_width(2),
                ))
                .map_err(plot_error)?
                .label(technique.as_str())
                .legend(move |(x, y)| Rectangle::new([(x - 8, y - 1), (x + 8, y + 1)], c.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.6))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(plot_error)?;
        root.present().map_err(plot_error)?;
    }
    Ok(svg)
}

/// The runs along paths: per scene and path, error and flicker over time (one line per
/// technique), flicker against frame time with its Pareto front, a table of the per-path
/// summaries, and the animation of the run that flickers most (technique left, exact right).
fn motion_section(
    merged: &Merged,
    motion_runs: &[usize],
    styles: &BTreeMap<String, usize>,
    summary: &mut ReportSummary,
) -> Result<String, BenchError> {
    let runs = &merged.results.runs;
    let mut groups: Vec<(String, String, u32, u32)> = Vec::new();
    for &i in motion_runs {
        let r = &runs[i];
        let key = (
            r.scene.clone(),
            r.motion.as_ref().map_or(String::new(), |m| m.path.clone()),
            r.width,
            r.height,
        );
        if !groups.contains(&key) {
            groups.push(key);
        }
    }
    let mut out = String::from(
        "<h2 id=\"motion\">Motion: error and flicker along paths</h2><p>Every frame against its own exact answer. Flicker: mean over receiver pixels of |(V<sub>t</sub> - V<sub>t-1</sub>) - (E<sub>t</sub> - E<sub>t-1</sub>)|, the change the technique shows that the exact answer does not. Lag: error right after the last moving frame minus the settled error. Frame times split into frames where only the camera moved and frames where the light or a caster moved (docs/BENCHMARKS.md, \"Motion\").</p>",
    );
    for group in groups {
        out.push_str(&motion_group(merged, motion_runs, group, styles, summary)?);
    }
    Ok(out)
}

/// The motion section of one scene, path and size: its plots, its table and the animation of the
/// run that flickers most; counts its plotted and unplotted runs in `summary`.
fn motion_group(
    merged: &Merged,
    motion_runs: &[usize],
    (scene, path, width, height): (String, String, u32, u32),
    styles: &BTreeMap<String, usize>,
    summary: &mut ReportSummary,
) -> Result<String, BenchError> {
    let runs = &merged.results.runs;
    let in_group: Vec<usize> = motion_runs
        .iter()
        .copied()
        .filter(|&i| {
            let r = &runs[i];
            r.scene == scene
                && r.width == width
                && r.height == height
                && r.motion.as_ref().is_some_and(|m| m.path == path)
        })
        .collect();
    let ok: Vec<usize> = in_group
        .iter()
        .copied()
        .filter(|&i| runs[i].status == Status::Ok)
        .collect();
    let (plots, points) = motion_plots(runs, &ok, styles)?;
    summary.points += points;
    summary.unplotted += in_group.len() - points;
    let mut out = String::new();
    let title = format!("{scene} along {path} ({width}x{height})");
    let _ = write!(
        out,
        "<h3 id=\"motion-{}-{}\">{}</h3><div class=\"plots motion\" data-scene=\"{}\" data-path=\"{}\">",
        escape(&crate::sanitize(&scene)),
        escape(&crate::sanitize(&path)),
        escape(&title),
        escape(&scene),
        escape(&path)
    );
    out.push_str(&plots);
    out.push_str(&motion_table(runs, &in_group));
    out.push_str(&flickering_most_animation(merged, &ok, &path));
    Ok(out)
}

/// The plots of the runs `ok` along one path (error and flicker over time, mean flicker against
/// frame time) with the closing tag of their `plots` element; and how many runs the last one
/// plots.
fn motion_plots(
    runs: &[Run],
    ok: &[usize],
    styles: &BTreeMap<String, usize>,
) -> Result<(String, usize), BenchError> {
    let label = |i: usize| {
        let r = &runs[i];
        if ok
            .iter()
            .filter(|&&j| runs[j].technique == r.technique)
            .count()
            > 1
        {
            format!("{} {}", r.technique, params_text(r))
        } else {
            r.technique.clone()
        }
    };
    let error_lines: Vec<(String, Vec<f64>)> = ok
        .iter()
        .filter_map(|&i| Some((label(i), runs[i].motion.as_ref()?.series.error.clone())))
        .collect();
    let flicker_lines: Vec<(String, Vec<f64>)> = ok
        .iter()
        .filter_map(|&i| {
            let mut f = runs[i].motion.as_ref()?.series.flicker.clone();
            // Frame 0 has no flicker: not drawn.
            if let Some(first) = f.first_mut() {
                *first = f64::NAN;
            }
            Some((label(i), f))
        })
        .collect();
    let points: Vec<PlotPoint> = ok
        .iter()
        .filter_map(|&i| {
            let r = &runs[i];
            let m = r.motion.as_ref()?;
            let flicker = m.flicker.as_ref()?.mean;
            Some(PlotPoint {
                run: i,
                technique: r.technique.clone(),
                time_ms: frame_time_ms(r)?,
                value: flicker,
                tooltip: format!(
                    "{} {}\n{} ms, flicker {flicker:.5}, error {:.4}",
                    r.technique,
                    params_text(r),
                    frame_time_ms(r).map_or("-".into(), ms),
                    m.error.mean
                ),
            })
        })
        .collect();
    let plots = format!(
        "<div class=\"plot error-series\">{}</div><div class=\"plot flicker-series\">{}</div><div class=\"plot flicker-time\">{}</div></div>",
        series_svg(&error_lines, styles, "error over time", "mae_shadowed vs exact")?,
        series_svg(&flicker_lines, styles, "flicker over time", "flicker")?,
        plot_svg(&points, styles, "mean flicker against frame time", "flicker (mean)")?
    );
    Ok((plots, points.len()))
}

/// The animation of the run of `ok` that flickers most along `path`, as it moves; empty when no
/// run has both a flicker and an animation file.
fn flickering_most_animation(merged: &Merged, ok: &[usize], path: &str) -> String {
    let runs = &merged.results.runs;
    let flicker_of = |i: usize| {
        runs[i]
            .motion
            .as_ref()
            .and_then(|m| m.flicker.as_ref())
            .map(|f| f.mean)
    };
    let worst = ok
        .iter()
        .copied()
        .filter(|&i| flicker_of(i).is_some())
        .max_by(|&a, &b| {
            flicker_of(a)
                .unwrap_or(0.0)
                .total_cmp(&flicker_of(b).unwrap_or(0.0))
        });
    let animation = worst.and_then(|i| {
        let name = runs[i].motion.as_ref()?.animation.as_ref()?;
        Some((i, std::fs::read(merged.run_dirs[i].join(name)).ok()?))
    });
    let Some((i, bytes)) = animation else {
        return String::new();
    };
    format!(
        "<figure class=\"animation\"><img src=\"data:image/png;base64,{}\" alt=\"{} along {}\"><figcaption>the run that flickers most: {} {} (left) beside the exact answer (right), {} frames per second</figcaption></figure>",
        base64::engine::general_purpose::STANDARD.encode(bytes),
        escape(&runs[i].technique),
        escape(path),
        escape(&runs[i].technique),
        escape(&params_text(&runs[i])),
        crate::motion::ANIMATION_FPS
    )
}

/// The per-path summaries of `in_group`'s runs, least flicker first.
fn motion_table(runs: &[Run], in_group: &[usize]) -> String {
    let mut t = String::from(
        "<table><tr><th class=\"l\">technique</th><th class=\"l\">parameters</th><th>frames</th><th>error mean</th><th>error p95</th><th>error max</th><th>flicker mean</th><th>flicker p95</th><th>flicker max</th><th title=\"ColorVideoVDP of the sequence against the sequence of exact answers, shown as grey on a 24-inch FHD display at the frame rate of the path: 10 = no visible difference (docs/BENCHMARKS.md, Motion)\">JOD</th><th title=\"error right after the last moving frame minus the settled error, and frames until settled\">lag</th><th>frame ms (median)</th><th>camera-only ms</th><th>light-moving ms</th><th class=\"l\">exact (frames)</th><th class=\"l\">status</th></tr>",
    );
    let flicker_of = |i: usize| {
        runs[i]
            .motion
            .as_ref()
            .and_then(|m| m.flicker.as_ref())
            .map_or(f64::INFINITY, |f| f.mean)
    };
    let mut order = in_group.to_vec();
    order.sort_by(|&a, &b| flicker_of(a).total_cmp(&flicker_of(b)));
    for i in order {
        let run = &runs[i];
        let Some(m) = run.motion.as_ref().filter(|_| run.status == Status::Ok) else {
            let _ = write!(
                t,
                "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td colspan=\"13\"></td><td class=\"l\"><span class=\"warn\">error: {}</span></td></tr>",
                escape(&run.technique),
                escape(&params_text(run)),
                escape(&run.message)
            );
            continue;
        };
        let four = |v: f64| format!("{v:.4}");
        let flicker = |pick: fn(&crate::results::SeriesSummary) -> f64| {
            m.flicker
                .as_ref()
                .map_or("-".into(), |s| format!("{:.5}", pick(s)))
        };
        let exact: Vec<String> = m
            .exact_methods
            .iter()
            .map(|(method, frames)| format!("{method} ({frames})"))
            .collect();
        let _ = write!(
            t,
            "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"l\">{}</td><td class=\"l\">ok</td></tr>",
            escape(&run.technique),
            escape(&params_text(run)),
            m.frames,
            four(m.error.mean),
            four(m.error.p95),
            four(m.error.max),
            flicker(|s| s.mean),
            flicker(|s| s.p95),
            flicker(|s| s.max),
            m.video_quality
                .as_ref()
                .map_or("-".into(), |q| format!("{:.2}", q.jod)),
            m.lag.as_ref().map_or("-".into(), |l| format!(
                "{:+.4} ({} frames)",
                l.extra_error, l.frames_to_settle
            )),
            frame_time_ms(run).map_or("-".into(), ms),
            m.frame_ms
                .camera_only
                .as_ref()
                .map_or("-".into(), |p| ms(p.median)),
            m.frame_ms
                .light_moving
                .as_ref()
                .map_or("-".into(), |p| ms(p.median)),
            escape(&exact.join(", ")),
        );
    }
    t.push_str("</table>");
    t
}

fn runs_table(runs: &[Run], in_scene: &[usize], front: &[usize]) -> String {
    let mut t = String::from(
        "<table><tr><th class=\"l\">technique</th><th class=\"l\">parameters</th><th>frame ms</th><th title=\"the run's first frame, with nothing built or loaded yet\">cold frame ms</th><th>technique ms</th><th class=\"l\">timing</th><th>mae_shadowed</th><th>of it too dark</th><th title=\"mean over umbra pixels of how much too bright (light leaking)\">too bright in umbra</th><th title=\"mean |V E0 - E| over shadowed receivers over their mean unoccluded irradiance E0, against the exact irradiance E: the error where the shaded image shows it (receivers facing away from the light count 0)\">irradiance error</th><th class=\"l\">vs</th><th>FLIP</th><th title=\"mean over receiver pixels of the change between the run's last frame and one more in which nothing moved\">still flicker</th><th title=\"for a technique that accumulates over frames: mae_shadowed once settled, after that many still frames\">settled mae_shadowed</th><th title=\"GPU memory the technique holds: after its frames / at its peak\">GPU memory MiB</th><th class=\"l\">status</th></tr>",
    );
    let mut order = in_scene.to_vec();
    order.sort_by(|&a, &b| {
        frame_time_ms(&runs[a])
            .unwrap_or(f64::INFINITY)
            .total_cmp(&frame_time_ms(&runs[b]).unwrap_or(f64::INFINITY))
    });
    for i in order {
        let run = &runs[i];
        let timing = run.timing.as_ref();
        let warnings: Vec<String> = timing
            .map(|t| t.warnings.clone())
            .unwrap_or_default()
            .into_iter()
            .chain(run.warnings.iter().cloned())
            .collect();
        let status = match run.status {
            Status::Ok if warnings.is_empty() => "ok".to_string(),
            Status::Ok => format!(
                "<span class=\"warn\">ok; {}</span>",
                escape(&warnings.join("; "))
            ),
            failed => format!(
                "<span class=\"warn\">{failed}: {}</span>",
                escape(&run.message)
            ),
        };
        let _ = write!(
            t,
            "<tr{}><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"l\">{}</td></tr>",
            if front.contains(&i) { " class=\"front\"" } else { "" },
            escape(&run.technique),
            escape(&params_text(run)),
            frame_time_ms(run).map_or("-".into(), ms),
            cold_frame_ms(run).map_or("-".into(), ms),
            timing
                .and_then(|t| t.technique_ms.as_ref())
                .map_or("-".into(), |p| ms(p.median)),
            timing.map_or("-".into(), |t| t.source.to_string()),
            mae_shadowed(run).map_or("-".into(), |v| format!("{v:.4}")),
            darker_shadowed(run).map_or("-".into(), |v| format!("{v:.4}")),
            brighter_umbra(run).map_or("-".into(), |v| format!("{v:.4}")),
            irradiance_mae_shadowed(run).map_or("-".into(), |v| format!("{v:.4}")),
            if run.error.is_some() { mae_against(run) } else { "-" },
            flip(run).map_or("-".into(), |v| format!("{v:.4}")),
            still_flicker_text(run.still_flicker),
            settled_text(run),
            memory_text(run),
            status
        );
    }
    t.push_str("</table>");
    t
}

/// "0.0123 after 32 frames", or "-" for a run that does not accumulate.
pub fn settled_text(run: &Run) -> String {
    match (&run.settled, scored_mae(run)) {
        (Some(settled), Some(mae)) => format!("{mae:.4} after {} frames", settled.frames),
        _ => "-".into(),
    }
}

/// "12.0 / 16.5" MiB after the frames / at the peak, or "-" where memory was not counted.
pub fn memory_text(run: &Run) -> String {
    run.memory.as_ref().map_or("-".into(), |m| {
        format!("{:.1} / {:.1}", m.current.total_mib(), m.peak.total_mib())
    })
}

fn image_strip(merged: &Merged, front: &[usize]) -> String {
    let runs = &merged.results.runs;
    let mut strip = String::from("<div class=\"strip\">");
    let mut any = false;
    if let Some(&first) = front.first() {
        if let Some(uri) = runs[first]
            .images
            .get(&format!("{YARDSTICK_TECHNIQUE}_shaded"))
            .and_then(|n| data_uri(&merged.run_dirs[first].join(n)))
        {
            let _ = write!(
                strip,
                "<figure><img src=\"{uri}\" alt=\"{YARDSTICK_TECHNIQUE}\"><figcaption>{YARDSTICK_TECHNIQUE}</figcaption></figure>"
            );
            any = true;
        }
    }
    for &i in front {
        let run = &runs[i];
        for kind in ["shaded", "difference"] {
            if let Some(uri) = run
                .images
                .get(kind)
                .and_then(|n| data_uri(&merged.run_dirs[i].join(n)))
            {
                let _ = write!(
                    strip,
                    "<figure><img src=\"{uri}\" alt=\"{kind}\" title=\"{}\"><figcaption>{} {kind}<br>{}</figcaption></figure>",
                    escape(&params_text(run)),
                    escape(&run.technique),
                    frame_time_ms(run).map_or("-".into(), |t| format!("{} ms", ms(t)))
                );
                any = true;
            }
        }
    }
    strip.push_str("</div>");
    if any {
        format!("<h3>Runs on the Pareto front</h3>{strip}")
    } else {
        String::new()
    }
}

/// One row of the headline: a technique on a scene (and size).
#[derive(Clone, Debug, PartialEq)]
pub struct HeadlineRow {
    pub scene: String,
    pub technique: String,
    /// Per budget of [`BUDGETS`]: the lowest mae_shadowed of the technique's settings whose frame
    /// time is within that multiple of the fastest cost-floor run on the scene (`None`: none is).
    pub best_within: Vec<Option<f64>>,
    /// The lowest frame time at which the technique reaches [`TARGET_MAE`], ms (`None`: never).
    pub cost_to_target_ms: Option<f64>,
    /// The fastest cost-floor frame time on the scene, ms (`None`: no cost-floor run).
    pub floor_ms: Option<f64>,
    /// The largest still-frame flicker ([`crate::results::Run::still_flicker`]) of the
    /// technique's settings on the scene (`None`: no run measured one).
    pub still_flicker: Option<f64>,
}

/// The scenes (with their size) of `runs`, in first-seen order.
pub fn scenes_of(runs: &[Run]) -> Vec<(String, u32, u32)> {
    let mut scenes: Vec<(String, u32, u32)> = Vec::new();
    for run in runs {
        let key = (run.scene.clone(), run.width, run.height);
        if !scenes.contains(&key) {
            scenes.push(key);
        }
    }
    scenes
}

/// The runs of `scene` at `width` x `height` that finished.
fn ok_runs_in<'a>(runs: &'a [Run], scene: &str, width: u32, height: u32) -> Vec<&'a Run> {
    runs.iter()
        .filter(|r| {
            r.scene == scene && r.width == width && r.height == height && r.status == Status::Ok
        })
        .collect()
}

/// Per scene (with its size, in the order given) and technique (by name): the lowest
/// mae_shadowed within each budget of [`BUDGETS`] x the fastest cost-floor run's frame time on
/// that scene, and the lowest frame time at which the technique reaches [`TARGET_MAE`].
pub fn headline_rows(runs: &[Run], scenes: &[(String, u32, u32)]) -> Vec<HeadlineRow> {
    headline_rows_within(runs, scenes, Budgets::FloorMultiples, Score::Visibility)
}

/// [`headline_rows`] with `budgets` (multiples of the cost floor, or milliseconds), ranked by
/// `score`.
pub fn headline_rows_within(
    runs: &[Run],
    scenes: &[(String, u32, u32)],
    budgets: Budgets,
    score: Score,
) -> Vec<HeadlineRow> {
    let mut rows = Vec::new();
    for (scene, width, height) in scenes {
        let in_scene = ok_runs_in(runs, scene, *width, *height);
        let floor = in_scene
            .iter()
            .filter(|r| r.technique == COST_FLOOR_TECHNIQUE)
            .filter_map(|r| frame_time_ms(r))
            .fold(f64::INFINITY, f64::min);
        let mut techniques: Vec<&str> = in_scene.iter().map(|r| r.technique.as_str()).collect();
        techniques.sort();
        techniques.dedup();
        for technique in techniques {
            let points: Vec<(f64, f64)> = in_scene
                .iter()
                .filter(|r| r.technique == technique)
                .filter_map(|r| Some((budgets.time_ms(r)?, score.of(r)?)))
                .collect();
            let best_within = budgets
                .limits_ms(floor)
                .iter()
                .map(|limit| {
                    let best = points
                        .iter()
                        .filter(|(time, _)| *time <= *limit)
                        .map(|(_, e)| *e)
                        .fold(f64::INFINITY, f64::min);
                    best.is_finite().then_some(best)
                })
                .collect();
            let cost = points
                .iter()
                .filter(|(_, e)| *e <= TARGET_MAE)
                .map(|(time, _)| *time)
                .fold(f64::INFINITY, f64::min);
            rows.push(HeadlineRow {
                scene: scene.clone(),
                technique: technique.to_string(),
                best_within,
                cost_to_target_ms: cost.is_finite().then_some(cost),
                floor_ms: floor.is_finite().then_some(floor),
                still_flicker: in_scene
                    .iter()
                    .filter(|r| r.technique == technique)
                    .filter_map(|r| r.still_flicker)
                    .reduce(f64::max),
            });
        }
    }
    rows
}

impl HeadlineRow {
    /// The last column as text: "12.3 ms (2.1x hard)", or "not reached".
    pub fn cost_text(&self) -> String {
        match (self.cost_to_target_ms, self.floor_ms) {
            (None, _) => "not reached".to_string(),
            (Some(cost), Some(floor)) => {
                format!(
                    "{} ms ({:.1}x {COST_FLOOR_TECHNIQUE})",
                    ms(cost),
                    cost / floor
                )
            }
            (Some(cost), None) => format!("{} ms", ms(cost)),
        }
    }
}

/// One technique across every scene of a report: the first screen's answer to "which technique
/// for which budget".
#[derive(Clone, Debug, PartialEq)]
pub struct SummaryRow {
    pub technique: String,
    /// Scenes the technique has a measured run on.
    pub scenes: usize,
    /// Scenes where one of its runs is on the Pareto front of mae_shadowed against frame time.
    pub on_front: Vec<String>,
    /// Per budget of [`BUDGETS`]: the median over scenes of its lowest mae_shadowed within the
    /// budget (scenes where no setting fits are left out; `None`: it fits on none).
    pub median_within: Vec<Option<f64>>,
    /// Per budget: the scenes where its lowest error within the budget is the lowest of all
    /// techniques.
    pub best_within: Vec<usize>,
    /// Its mean rank over every (scene, budget) of the scenes it ran on: by lowest error among
    /// the techniques with a setting within the budget (1 = best); where none of its settings
    /// fits, one below all that fit.
    pub mean_rank: Option<f64>,
}

fn median(mut values: Vec<f64>) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    Some(if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    })
}

/// Per technique (by name), its standing across `scenes`, from the headline rows and each
/// scene's Pareto front.
pub fn summary_rows(runs: &[Run], scenes: &[(String, u32, u32)]) -> Vec<SummaryRow> {
    summary_rows_within(runs, scenes, Budgets::FloorMultiples, Score::Visibility)
}

/// [`summary_rows`] with `budgets` (multiples of the cost floor, or milliseconds), ranked by
/// `score`.
pub fn summary_rows_within(
    runs: &[Run],
    scenes: &[(String, u32, u32)],
    budgets: Budgets,
    score: Score,
) -> Vec<SummaryRow> {
    let count = budgets.values().len();
    // Per scene and size, so that one scene at two sizes is two scenes here as in the headline.
    let per_scene: Vec<Vec<HeadlineRow>> = scenes
        .iter()
        .map(|key| headline_rows_within(runs, std::slice::from_ref(key), budgets, score))
        .collect();
    let headline: Vec<&HeadlineRow> = per_scene.iter().flatten().collect();
    let mut techniques: Vec<&str> = headline.iter().map(|r| r.technique.as_str()).collect();
    techniques.sort();
    techniques.dedup();
    let mut rows: Vec<SummaryRow> = techniques
        .iter()
        .map(|t| SummaryRow {
            technique: t.to_string(),
            scenes: headline.iter().filter(|r| r.technique == *t).count(),
            on_front: Vec::new(),
            median_within: vec![None; count],
            best_within: vec![0; count],
            mean_rank: None,
        })
        .collect();
    let index = |t: &str| techniques.iter().position(|x| *x == t).expect("listed");
    let mut ranks: Vec<Vec<f64>> = vec![Vec::new(); techniques.len()];
    let mut within: Vec<Vec<Vec<f64>>> = vec![vec![Vec::new(); count]; techniques.len()];
    for ((scene, width, height), scene_rows) in scenes.iter().zip(&per_scene) {
        let in_scene = ok_runs_in(runs, scene, *width, *height);
        let points: Vec<(&str, f64, f64)> = in_scene
            .iter()
            .filter_map(|r| Some((r.technique.as_str(), budgets.time_ms(r)?, score.of(r)?)))
            .collect();
        let front = pareto_front(&points.iter().map(|p| (p.1, p.2)).collect::<Vec<_>>());
        let mut front_techniques: Vec<&str> = front.iter().map(|&k| points[k].0).collect();
        front_techniques.sort();
        front_techniques.dedup();
        for t in front_techniques {
            rows[index(t)].on_front.push(scene.clone());
        }
        // `b` indexes the budget in every row's per-budget vectors.
        #[allow(clippy::needless_range_loop)]
        for b in 0..count {
            let mut fitting: Vec<(&str, f64)> = scene_rows
                .iter()
                .filter_map(|r| Some((r.technique.as_str(), r.best_within[b]?)))
                .collect();
            fitting.sort_by(|a, b| a.1.total_cmp(&b.1));
            for (rank, (t, error)) in fitting.iter().enumerate() {
                let k = index(t);
                ranks[k].push(rank as f64 + 1.0);
                within[k][b].push(*error);
                if rank == 0 {
                    rows[k].best_within[b] += 1;
                }
            }
            for row in scene_rows {
                if row.best_within[b].is_none() {
                    ranks[index(&row.technique)].push(fitting.len() as f64 + 1.0);
                }
            }
        }
    }
    for (k, row) in rows.iter_mut().enumerate() {
        row.mean_rank =
            (!ranks[k].is_empty()).then(|| ranks[k].iter().sum::<f64>() / ranks[k].len() as f64);
        row.median_within = within[k].iter().map(|v| median(v.clone())).collect();
    }
    rows.sort_by(|a, b| {
        a.mean_rank
            .unwrap_or(f64::INFINITY)
            .total_cmp(&b.mean_rank.unwrap_or(f64::INFINITY))
    });
    rows
}

/// Per budget, the technique with the lowest error on the most scenes (ties: the better mean
/// rank, i.e. the earlier row), with its count: "which technique for which budget".
pub fn best_per_budget(rows: &[SummaryRow]) -> Vec<Option<(String, usize)>> {
    let count = rows.first().map_or(0, |r| r.best_within.len());
    (0..count)
        .map(|b| {
            let mut best: Option<(&SummaryRow, usize)> = None;
            for row in rows {
                let wins = row.best_within[b];
                if wins > 0 && best.is_none_or(|(_, w)| wins > w) {
                    best = Some((row, wins));
                }
            }
            best.map(|(row, wins)| (row.technique.clone(), wins))
        })
        .collect()
}

fn summary_table(
    runs: &[Run],
    scenes: &[(String, u32, u32)],
    budgets: Budgets,
    score: Score,
) -> String {
    let rows = summary_rows_within(runs, scenes, budgets, score);
    let mut t = match (budgets, score) {
        (Budgets::FloorMultiples, Score::Visibility) => format!("<h2>Across scenes: which technique for which budget</h2><p>Budgets are multiples of the fastest <code>{COST_FLOOR_TECHNIQUE}</code> run's frame time on each scene. "),
        (Budgets::FloorMultiples, Score::Irradiance) => format!("<h2>Across scenes, ranked by the irradiance error</h2><p>The same budgets (multiples of the fastest <code>{COST_FLOOR_TECHNIQUE}</code> run's frame time), each run scored by its irradiance error over shadowed receivers (<code>irradiance_mae_shadowed</code>: where the shaded image shows the error; runs without an analytic exact answer left out) instead of <code>mae_shadowed</code>. "),
        (Budgets::Milliseconds, _) => format!("<h2>Across scenes at {}x{}: the lowest error within a budget in milliseconds</h2><p>GPU time (timestamp queries) of the technique's own passes, without the G-buffer and the shading a renderer draws anyway, on the scenes at that size. ", MS_BUDGET_SIZE.0, MS_BUDGET_SIZE.1),
    };
    if runs.iter().any(|r| r.settled.is_some()) {
        t.push_str("Techniques that accumulate over frames (marked <i>settled</i> in the runs) are scored by their error once settled. ");
    }
    let picks: Vec<String> = best_per_budget(&rows)
        .iter()
        .zip(budgets.values())
        .map(|(pick, b)| match pick {
            Some((technique, wins)) => format!(
                "within {}: <b>{}</b> (lowest error on {wins} of {} scenes)",
                budgets.label(*b),
                escape(technique),
                scenes.len()
            ),
            None => format!("within {}: no technique fits", budgets.label(*b)),
        })
        .collect();
    let _ = write!(t, "{}.</p>", picks.join("; "));
    t.push_str("<table><tr><th class=\"l\">technique</th><th title=\"scenes where one of its settings is on the Pareto front of error against frame time\">on the Pareto front</th>");
    for b in budgets.values() {
        let b = budgets.label(*b);
        let _ = write!(
            t,
            "<th title=\"median over scenes of its lowest mae_shadowed within {b}; in brackets: scenes where it is the lowest of all\">median error &le; {b}</th>"
        );
    }
    t.push_str("<th title=\"its mean rank by lowest error over every scene and budget (1 = best; where none of its settings fits the budget, below all that fit)\">mean rank</th></tr>");
    for row in &rows {
        let _ = write!(
            t,
            "<tr><td class=\"l\">{}</td><td title=\"{}\">{} of {}</td>",
            escape(&row.technique),
            escape(&row.on_front.join(", ")),
            row.on_front.len(),
            row.scenes
        );
        for (median, wins) in row.median_within.iter().zip(&row.best_within) {
            let _ = write!(
                t,
                "<td>{}</td>",
                median.map_or("-".into(), |m| format!("{m:.4} ({wins})"))
            );
        }
        let _ = write!(
            t,
            "<td>{}</td></tr>",
            row.mean_rank.map_or("-".into(), |r| format!("{r:.1}"))
        );
    }
    t.push_str("</table>");
    t
}

/// How the ranking moves from the CPU adapter's runs to these: per scene the rank correlation
/// of the settings' frame times, per technique its mean rank and frame time over the cost
/// floor's on each, the ones that move most first.
fn cpu_to_gpu_section(cpu: &[Run], gpu: &[Run]) -> String {
    let mut t = String::from("<h2>From the CPU adapter to this one: how the ranking moves</h2><p>Per scene, Spearman's rank correlation of the frame times of the settings both ran (1: the same order).</p><table><tr><th class=\"l\">scene</th><th>settings</th><th>rank correlation</th></tr>");
    for m in crate::compare::scene_rank_moves(cpu, gpu) {
        let _ = write!(
            t,
            "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td></tr>",
            escape(&m.scene),
            m.settings,
            m.frame_time_rho.map_or("-".into(), |r| format!("{r:.2}"))
        );
    }
    let _ = write!(t, "</table><p>Per technique, its mean rank by lowest error within multiples of <code>{COST_FLOOR_TECHNIQUE}</code> (as above) and its fastest setting's frame time over <code>{COST_FLOOR_TECHNIQUE}</code>'s, on each adapter; the largest moves first.</p><table><tr><th class=\"l\">technique</th><th>mean rank, CPU</th><th>mean rank, here</th><th>change</th><th>frame / floor, CPU</th><th>frame / floor, here</th></tr>");
    let num = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.1}"));
    for m in crate::compare::technique_moves(cpu, gpu) {
        let _ = write!(
            t,
            "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(&m.technique),
            num(m.cpu_mean_rank),
            num(m.gpu_mean_rank),
            m.rank_change().map_or("-".into(), |c| format!("{c:+.1}")),
            num(m.cpu_floor_ratio),
            num(m.gpu_floor_ratio)
        );
    }
    t.push_str("</table>");
    t
}

/// The scenes of `runs` at [`MS_BUDGET_SIZE`] whose every run was timed with timestamp queries
/// (a GPU's): where millisecond budgets mean something. Empty on a CPU adapter.
pub fn ms_budget_scenes(runs: &[Run], scenes: &[(String, u32, u32)]) -> Vec<(String, u32, u32)> {
    scenes
        .iter()
        .filter(|(scene, width, height)| {
            (*width, *height) == MS_BUDGET_SIZE && {
                let timed: Vec<&Run> = ok_runs_in(runs, scene, *width, *height);
                !timed.is_empty()
                    && timed.iter().all(|r| {
                        r.timing.as_ref().is_some_and(|t| {
                            t.source == softshadow_core::TimingSource::Timestamps
                                && t.frame_ms.is_some()
                        })
                    })
            }
        })
        .cloned()
        .collect()
}

fn headline_table(runs: &[Run], scenes: &[(String, u32, u32)]) -> String {
    let mut t = format!("<h2>Headline: lowest error at matched time budgets</h2><p>Budgets are multiples of the fastest <code>{COST_FLOOR_TECHNIQUE}</code> run's frame time on the same scene; a dash: no setting of the technique fits the budget. Cost column: the fastest setting with mae_shadowed &le; {TARGET_MAE}. Still flicker: the largest, over its settings, of the change between two frames in which nothing moved (0: its picture holds still).</p><table><tr><th class=\"l\">scene</th><th class=\"l\">technique</th>");
    for b in BUDGETS {
        let _ = write!(t, "<th>&le; {b}x {COST_FLOOR_TECHNIQUE}</th>");
    }
    let _ = write!(
        t,
        "<th>cost to mae &le; {TARGET_MAE}</th><th title=\"mean over receiver pixels of the change between two frames in which nothing moved, the largest over its settings\">still flicker</th></tr>"
    );
    for row in headline_rows(runs, scenes) {
        let _ = write!(
            t,
            "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td>",
            escape(&row.scene),
            escape(&row.technique)
        );
        for best in &row.best_within {
            let _ = write!(
                t,
                "<td>{}</td>",
                best.map_or("-".into(), |b| format!("{b:.4}"))
            );
        }
        let _ = write!(
            t,
            "<td>{}</td><td>{}</td></tr>",
            escape(&row.cost_text()),
            still_flicker_text(row.still_flicker)
        );
    }
    t.push_str("</table>");
    t
}

/// A still-frame flicker as text: exactly 0 says so, a dash for none measured.
pub fn still_flicker_text(flicker: Option<f64>) -> String {
    match flicker {
        None => "-".into(),
        Some(0.0) => "0".into(),
        Some(f) => format!("{f:.5}"),
    }
}

fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// The runs as one flat CSV (one row per run), for pandas or R.
pub fn runs_csv(merged: &Merged) -> String {
    let mut out = String::from(
        "index,scene,technique,params,width,height,status,timing_source,frame_ms,frame_ms_p10,frame_ms_p90,technique_ms,cpu_ms,camera_only_frame_ms,cold_frame_ms,mae_shadowed,darker_shadowed,brighter_umbra,irradiance_mae_shadowed,irradiance_mae,facing_away_pixels,mae_against,mae_shadowed_vs_reference,mae_all_vs_reference,rmse_vs_reference,flip_mean,still_flicker,settled_frames,settled_mae_shadowed,settled_frame_ms,memory_bytes,memory_peak_bytes,message\n",
    );
    let num = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    for run in &merged.results.runs {
        let timing = run.timing.as_ref();
        let frame = timing.and_then(|t| t.frame_ms.as_ref());
        let error = run.error.as_ref();
        let row = [
            run.index.to_string(),
            csv_field(&run.scene),
            csv_field(&run.technique),
            csv_field(&params_text(run)),
            run.width.to_string(),
            run.height.to_string(),
            format!("{:?}", run.status).to_lowercase(),
            timing.map_or(String::new(), |t| t.source.to_string()),
            num(frame.map(|p| p.median)),
            num(frame.map(|p| p.p10)),
            num(frame.map(|p| p.p90)),
            num(timing
                .and_then(|t| t.technique_ms.as_ref())
                .map(|p| p.median)),
            num(timing.map(|t| t.cpu_ms.median)),
            num(run
                .timing_camera_only
                .as_ref()
                .and_then(|t| t.frame_ms.as_ref())
                .map(|p| p.median)),
            num(cold_frame_ms(run)),
            num(mae_shadowed(run)),
            num(darker_shadowed(run)),
            num(brighter_umbra(run)),
            num(irradiance_mae_shadowed(run)),
            num(irradiance_mae(run)),
            num(error
                .and_then(|e| e.irradiance.as_ref())
                .map(|i| i.vs_exact.facing_away_pixels as f64)),
            if error.is_some() {
                mae_against(run).to_string()
            } else {
                String::new()
            },
            num(error.map(|e| e.report.mae_shadowed)),
            num(error.map(|e| e.report.mae_all)),
            num(error.map(|e| e.report.rmse)),
            num(flip(run)),
            num(run.still_flicker),
            num(run.settled.as_ref().map(|s| s.frames as f64)),
            num(run.settled.as_ref().and(scored_mae(run))),
            num(run
                .settled
                .as_ref()
                .and_then(|s| Some(s.timing.frame_ms.as_ref()?.median))),
            num(run.memory.as_ref().map(|m| m.current.total() as f64)),
            num(run.memory.as_ref().map(|m| m.peak.total() as f64)),
            csv_field(&run.message),
        ];
        out.push_str(&row.join(","));
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_the_undominated_points() {
        let points = [
            (1.0, 0.5),
            (2.0, 0.6),
            (2.0, 0.3),
            (4.0, 0.3),
            (8.0, 0.1),
            (0.5, 0.9),
        ];
        assert_eq!(pareto_front(&points), vec![5, 0, 2, 4]);
        assert!(pareto_front(&[]).is_empty());
    }

    fn committed(name: &str) -> Merged {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../docs/results")
            .join(name);
        crate::merge::merge(&[crate::merge::load(&path).expect("committed results")])
            .expect("one file merges")
    }

    /// The millisecond budgets appear for a GPU's timestamps at 1920x1080 and never for serial
    /// timing (a CPU adapter): the same runs with their source changed lose the table.
    #[test]
    fn millisecond_budgets_only_for_timestamp_timing() {
        let registry = Registry::default();
        let heading = "the lowest error within a budget in milliseconds";
        let mut gpu = committed("gpu/nvidia-h200/overview-1080.json");
        let (html, _) = render_html(&gpu, &registry).unwrap();
        assert!(html.contains(heading));
        assert!(html.contains("within 0.5 ms") && html.contains("within 4 ms"));
        for run in &mut gpu.results.runs {
            if let Some(timing) = &mut run.timing {
                timing.source = softshadow_core::TimingSource::Serial;
            }
        }
        let (html, _) = render_html(&gpu, &registry).unwrap();
        assert!(!html.contains(heading));
        let (html, _) = render_html(&committed("overview.json"), &registry).unwrap();
        assert!(!html.contains(heading));
    }

    /// With the CPU's runs beside the GPU's, the report says how the ranking moves.
    #[test]
    fn the_cpu_to_gpu_section_ranks_both_adapters() {
        let (gpu, cpu) = (
            committed("gpu/nvidia-h200/overview-256.json"),
            committed("overview.json"),
        );
        let (html, _) =
            render_html_beside(&gpu, &Registry::default(), Some(&cpu.results.runs)).unwrap();
        assert!(html.contains("how the ranking moves"));
        let moves = crate::compare::scene_rank_moves(&cpu.results.runs, &gpu.results.runs);
        assert_eq!(moves.len(), 7);
        assert!(moves
            .iter()
            .all(|m| m.frame_time_rho.is_some_and(|r| (-1.0..=1.0).contains(&r))));
    }
}
