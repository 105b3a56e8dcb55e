//! Tables of figures in the documents are generated from committed results, never typed: a
//! Markdown file marks each table with the kind of table and the results it comes from,
//!
//! ```text
//! <!-- generated: stiff-matrix docs/results/stiff.json -->
//! (the table, rewritten by `workbench docs`)
//! <!-- end generated -->
//! ```
//!
//! and [`regenerate`] rewrites what stands between the markers from the results file (compact
//! results.json: no images). Under every table a line says how its figures were made: the
//! command, the date and the adapter and driver they ran on. `workbench docs --check` (and the
//! test `tests/doc_tables.rs`) fails when a committed table differs from what its committed
//! results give; `workbench docs --rerun` makes the results again with their recorded commands.
//!
//! Kinds:
//! - `stiff-matrix FILE`: one row per case, one column per technique; each cell the measured
//!   `mae_shadowed` and what the technique's crate states for it (the run's verdict).
//! - `headline FILE`: per scene and technique, the lowest mae_shadowed within 1x, 2x, 4x and 8x
//!   the cost floor's frame time, and the cost of reaching mae_shadowed 0.01 (as in the report).
//! - `summary FILE`: per technique across scenes, as the report's first table: scenes where it
//!   is on the Pareto front, its median lowest error within each budget, its mean rank.
//! - `runs FILE columns=a,b,.. [technique=ID] [scene=SCENE]`: one row per run, the columns named
//!   (see [`COLUMNS`]).
//! - `grid FILE [technique=ID] [rows=scenes|settings]`: runs as a grid, one row per scene and one
//!   column per setting (the technique and the parameters that differ between its runs), or
//!   the other way round; each cell "mae_shadowed / frame ms", or for a run along a path "mean
//!   error over its frames / the last frame's error".
//! - `cpu-gpu FILE cpu=CPU_FILE`: per technique setting, the median frame time over the scenes
//!   both ran on the CPU adapter's results and on FILE's (a GPU's), and their ratio.
//! - `rank-moves FILE cpu=CPU_FILE`: per scene, Spearman's correlation of the settings' frame
//!   times on the two adapters; per technique, its mean rank and frame time over the cost floor
//!   on each (the ones that move most first).
//! - `timestamps FILE`: per technique, its own passes timed with timestamp queries against the
//!   same passes submitted and waited for one by one (the calibration frame).
//! - `pass-timestamps FILE`: the same per pass (the G-buffer and the shading included).
//! - `resolution FILE`: frame time per setting (rows) and image size (columns).
//! - `ms-budgets FILE`: the summary with budgets in milliseconds over the scenes at 1920x1080.
//! - `memory FILE`: per technique setting, the GPU memory it holds (after its frames / peak) and
//!   its median error over the scenes.
//! - `settled FILE`: runs of techniques that accumulate over frames: first-frame and settled
//!   error and frame time.
//! - `motion FILE scene=SCENE`: runs along paths (docs/MOTION.md), one row per
//!   technique and settings, per path its mean error, mean flicker, lag (where a run has one)
//!   and the median frame time of the frames the path is about (light moving, else camera only,
//!   else still) over the cost floor's on the same path.

use std::{
    collections::BTreeMap,
    fmt::Write as _,
    path::{Path, PathBuf},
};

use softshadow_core::COST_FLOOR_TECHNIQUE;

use crate::{
    report::{
        best_per_budget, brighter_umbra, cold_frame_ms, darker_shadowed, flip, frame_time_ms,
        headline_rows, irradiance_mae_shadowed, mae_shadowed, ms, params_text, scenes_of,
        still_flicker_text, summary_rows_within, Budgets, Score, SummaryRow, BUDGETS, TARGET_MAE,
    },
    results::{Results, Run, Status},
    BenchError,
};

mod adapters;
use adapters::{
    cpu_gpu_table, memory_table, ms_budgets_table, pass_timestamps_table, rank_moves_table,
    resolution_table, settled_table, timestamps_table,
};

const BEGIN: &str = "<!-- generated:";
const END: &str = "<!-- end generated -->";

/// The columns a `runs` table can show.
pub const COLUMNS: &[(&str, &str)] = &[
    ("scene", "scene"),
    ("technique", "technique"),
    ("params", "parameters"),
    ("size", "size"),
    ("frame_ms", "frame ms (median)"),
    ("technique_ms", "technique ms (median)"),
    ("pass_ms", "its passes, ms (median)"),
    ("cold_frame_ms", "cold frame ms"),
    ("camera_only_ms", "camera-only frame ms"),
    ("floor_ratio", "frame / fastest cost floor"),
    ("mae_shadowed", "mae_shadowed"),
    ("darker_shadowed", "of it too dark"),
    ("brighter_umbra", "too bright in umbra"),
    ("irradiance", "irradiance error"),
    ("flip", "FLIP"),
    ("still_flicker", "still flicker"),
    ("exact", "exact answer"),
    ("reference_vs_exact", "reference vs exact (mae_shadowed)"),
    ("all_lit_vs_exact", "no shadow vs exact (mae_shadowed)"),
    ("near_error", "mae_all 0-20 m"),
    ("middle_error", "mae_all 20-80 m"),
    ("far_error", "mae_all 80+ m"),
    ("status", "status"),
    ("triangles", "triangles"),
    ("load_s", "load s"),
    ("upload_s", "upload s"),
    ("load_peak_mib", "load peak MiB"),
];

fn problem(file: &Path, line: usize, message: impl std::fmt::Display) -> BenchError {
    BenchError::Read {
        path: format!("{}:{line}", file.display()),
        message: message.to_string(),
    }
}

/// One marked table of a document.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Marked {
    /// 1-based line of the opening marker.
    pub line: usize,
    /// What the marker says after `generated:` (kind, results file, options).
    pub spec: String,
    /// The text between the markers.
    pub body: String,
}

/// The marked tables of `text` (`file` names it in errors).
pub fn marked_tables(text: &str, file: &Path) -> Result<Vec<Marked>, BenchError> {
    let mut found = Vec::new();
    let mut open: Option<(usize, String, String)> = None;
    for (k, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if let Some(rest) = trimmed.strip_prefix(BEGIN) {
            if open.is_some() {
                return Err(problem(
                    file,
                    k + 1,
                    "a table opens inside another: close the first with `<!-- end generated -->`",
                ));
            }
            let spec = rest.trim().trim_end_matches("-->").trim().to_string();
            open = Some((k + 1, spec, String::new()));
        } else if trimmed == END {
            let (line, spec, body) = open.take().ok_or_else(|| {
                problem(
                    file,
                    k + 1,
                    "`<!-- end generated -->` without an opening marker",
                )
            })?;
            found.push(Marked { line, spec, body });
        } else if let Some((_, _, body)) = &mut open {
            body.push_str(line);
            body.push('\n');
        }
    }
    if let Some((line, ..)) = open {
        return Err(problem(
            file,
            line,
            "a generated table is never closed: add `<!-- end generated -->`",
        ));
    }
    Ok(found)
}

/// `text` with every marked table rewritten from its results (paths relative to `root`, the
/// repository).
pub fn regenerate(text: &str, file: &Path, root: &Path) -> Result<String, BenchError> {
    let mut out = String::with_capacity(text.len());
    let mut inside = false;
    for (k, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if let Some(rest) = trimmed.strip_prefix(BEGIN) {
            let spec = rest.trim().trim_end_matches("-->").trim();
            out.push_str(line);
            out.push('\n');
            out.push_str(&table(spec, root).map_err(|e| problem(file, k + 1, e))?);
            inside = true;
        } else if trimmed == END {
            inside = false;
            out.push_str(line);
            out.push('\n');
        } else if !inside {
            out.push_str(line);
            out.push('\n');
        }
    }
    Ok(out)
}

/// The tables of `file` that differ from what their results give (empty: all current), each as
/// `file:line: spec`.
pub fn drift(file: &Path, root: &Path) -> Result<Vec<String>, BenchError> {
    let text = read(file)?;
    let current = regenerate(&text, file, root)?;
    let before = marked_tables(&text, file)?;
    let after = marked_tables(&current, file)?;
    Ok(before
        .iter()
        .zip(&after)
        .filter(|(b, a)| b.body != a.body)
        .map(|(b, _)| format!("{}:{}: {}", file.display(), b.line, b.spec))
        .collect())
}

/// The results files `file`'s tables read (relative to `root`), each once.
pub fn results_files(file: &Path) -> Result<Vec<PathBuf>, BenchError> {
    let mut files: Vec<PathBuf> = Vec::new();
    for table in marked_tables(&read(file)?, file)? {
        if let Some(path) = table.spec.split_whitespace().nth(1) {
            let path = PathBuf::from(path);
            if !files.contains(&path) {
                files.push(path);
            }
        }
    }
    Ok(files)
}

fn read(file: &Path) -> Result<String, BenchError> {
    std::fs::read_to_string(file).map_err(|e| BenchError::Read {
        path: file.display().to_string(),
        message: e.to_string(),
    })
}

/// Results as committed under `docs/results/`: everything but the image file names, which
/// point into an output folder that is not committed.
pub fn compact(mut results: Results) -> Results {
    for run in &mut results.runs {
        run.images.clear();
    }
    results
}

fn load(path: &Path) -> Result<Results, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read the results `{}`: {e}", path.display()))?;
    serde_json::from_str(&text)
        .map_err(|e| format!("`{}` is not a results.json: {e}", path.display()))
}

/// The table a marker's spec asks for (Markdown, with its provenance line).
fn table(spec: &str, root: &Path) -> Result<String, String> {
    let mut words = spec.split_whitespace();
    let kind = words
        .next()
        .ok_or("an empty marker: name a kind and a results file")?;
    let file = words
        .next()
        .ok_or_else(|| format!("`{kind}` needs a results file, e.g. docs/results/stiff.json"))?;
    let options: BTreeMap<&str, &str> = words
        .map(|w| {
            w.split_once('=')
                .ok_or_else(|| format!("option `{w}` is not name=value"))
        })
        .collect::<Result<_, _>>()?;
    let results = load(&root.join(file))?;
    let cpu = |options: &BTreeMap<&str, &str>| -> Result<Results, String> {
        let path = options
            .get("cpu")
            .ok_or_else(|| format!("`{kind}` needs cpu=FILE, the same runs on a CPU adapter"))?;
        load(&root.join(path))
    };
    let mut t = match kind {
        "cpu-gpu" => cpu_gpu_table(&cpu(&options)?.runs, &results.runs),
        "rank-moves" => rank_moves_table(&cpu(&options)?.runs, &results.runs),
        "timestamps" => timestamps_table(&results.runs),
        "pass-timestamps" => pass_timestamps_table(&results.runs),
        "resolution" => resolution_table(&results.runs),
        "ms-budgets" => ms_budgets_table(&results.runs),
        "memory" => memory_table(&results.runs),
        "settled" => settled_table(&results.runs),
        "stiff-matrix" => stiff_matrix(&results.runs),
        "headline" => headline(&results.runs),
        "summary" => summary(&results.runs, Score::Visibility),
        "summary-irradiance" => summary(&results.runs, Score::Irradiance),
        "runs" => runs_table(&results.runs, &options)?,
        "motion" => motion_table(&results.runs, &options)?,
        "grid" => grid_table(&results.runs, &options)?,
        other => {
            return Err(format!(
                "unknown table kind `{other}`: use stiff-matrix, headline, summary, summary-irradiance, runs, grid, motion, cpu-gpu, rank-moves, timestamps, pass-timestamps, resolution, ms-budgets, memory or settled"
            ))
        }
    };
    let command = if results.command.is_empty() {
        "(command not recorded)".to_string()
    } else {
        let program = if results.program.is_empty() {
            "workbench"
        } else {
            &results.program
        };
        format!("`{program} {}`", results.command.join(" "))
    };
    let load = results
        .load
        .as_ref()
        .map_or(String::new(), |l| format!(", {l}"));
    let _ = writeln!(
        t,
        "\nMade by {command} on {}, {} ({}{load}); results: `{file}`.",
        if results.date.is_empty() {
            "an unrecorded date"
        } else {
            &results.date
        },
        results.adapter.name,
        results.adapter.driver
    );
    Ok(t)
}

/// Items in first-seen order.
fn ordered<'a>(items: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    let mut out: Vec<&str> = Vec::new();
    for item in items {
        if !out.contains(&item) {
            out.push(item);
        }
    }
    out
}

fn stiff_matrix(runs: &[Run]) -> String {
    let techniques = ordered(runs.iter().map(|r| r.technique.as_str()));
    let cases = ordered(runs.iter().map(|r| r.scene.as_str()));
    let mut t = String::from("| case |");
    for technique in &techniques {
        let _ = write!(t, " `{technique}` |");
    }
    t.push_str("\n|---|");
    t.push_str(&"---|".repeat(techniques.len()));
    t.push('\n');
    for case in &cases {
        let _ = write!(t, "| `{case}` |");
        for technique in &techniques {
            let run = runs
                .iter()
                .find(|r| r.scene == *case && r.technique == *technique);
            let cell = match run {
                None => "-".to_string(),
                // A light kind the technique does not support: refused, nothing promised.
                Some(run) if run.status == Status::Unsupported => "unsupported".to_string(),
                Some(run) if run.status != Status::Ok => "failed".to_string(),
                Some(run) => match &run.expectation {
                    Some(v) if v.met => format!("{:.4} ({})", v.value, bound_text(&v.stated)),
                    Some(v) => format!("**{:.4} ({}): not met**", v.value, bound_text(&v.stated)),
                    None => mae_shadowed(run).map_or("-".into(), |e| format!("{e:.4}")),
                },
            };
            let _ = write!(t, " {cell} |");
        }
        t.push('\n');
    }
    t
}

/// `mae_shadowed <= 0.082 (measured 0.0327)` -> `<= 0.082`; a known failure keeps its words.
fn bound_text(stated: &str) -> String {
    let without_measured = stated.split(" (measured").next().unwrap_or(stated);
    without_measured
        .split_once(' ')
        .map_or(without_measured, |(_, rest)| rest)
        .to_string()
}

fn headline(runs: &[Run]) -> String {
    let scenes = scenes_of(runs);
    let mut t = String::from("| scene | technique |");
    for b in BUDGETS {
        let _ = write!(t, " <= {b}x `{COST_FLOOR_TECHNIQUE}` |");
    }
    let _ = writeln!(
        t,
        " cost to mae_shadowed <= {TARGET_MAE} | still flicker (largest) |"
    );
    t.push_str("|---|---|");
    t.push_str(&"---|".repeat(BUDGETS.len() + 2));
    t.push('\n');
    for row in headline_rows(runs, &scenes) {
        let _ = write!(t, "| `{}` | `{}` |", row.scene, row.technique);
        for best in &row.best_within {
            let _ = write!(t, " {} |", best.map_or("-".into(), |b| format!("{b:.4}")));
        }
        let _ = writeln!(
            t,
            " {} | {} |",
            row.cost_text(),
            still_flicker_text(row.still_flicker)
        );
    }
    t
}

/// The across-scenes table ranked by `score` (the visibility or the irradiance error).
fn summary(runs: &[Run], score: Score) -> String {
    let scenes = scenes_of(runs);
    let rows = summary_rows_within(runs, &scenes, Budgets::FloorMultiples, score);
    across_scenes_table(&rows, scenes.len(), Budgets::FloorMultiples)
}

/// The markdown of an across-scenes table: per technique its scenes on the Pareto front, its
/// median lowest error within each of `budgets` (with the scenes where it is best) and its mean
/// rank, then which technique wins each budget on the most of the `scenes`.
pub(super) fn across_scenes_table(rows: &[SummaryRow], scenes: usize, budgets: Budgets) -> String {
    let mut t = String::from("| technique | on the Pareto front |");
    for b in budgets.values() {
        let _ = match budgets {
            Budgets::FloorMultiples => write!(
                t,
                " median error <= {b}x `{COST_FLOOR_TECHNIQUE}` (scenes best) |"
            ),
            Budgets::Milliseconds => write!(
                t,
                " median error within {b} ms of its own passes (scenes best) |"
            ),
        };
    }
    t.push_str(" mean rank |\n|---|---|");
    t.push_str(&"---|".repeat(budgets.values().len() + 1));
    t.push('\n');
    for row in rows {
        let _ = write!(
            t,
            "| `{}` | {} of {} |",
            row.technique,
            row.on_front.len(),
            row.scenes
        );
        for (median, wins) in row.median_within.iter().zip(&row.best_within) {
            let _ = write!(
                t,
                " {} |",
                median.map_or("-".into(), |m| format!("{m:.4} ({wins})"))
            );
        }
        let _ = writeln!(
            t,
            " {} |",
            row.mean_rank.map_or("-".into(), |r| format!("{r:.1}"))
        );
    }
    let picks: Vec<String> = best_per_budget(rows)
        .iter()
        .zip(budgets.values())
        .map(|(pick, b)| match (pick, budgets) {
            (Some((technique, wins)), Budgets::FloorMultiples) => {
                format!("within {b}x: `{technique}` ({wins} of {scenes} scenes)")
            }
            (None, Budgets::FloorMultiples) => format!("within {b}x: none fits"),
            (Some((technique, wins)), Budgets::Milliseconds) => {
                format!("within {b} ms `{technique}` ({wins} of {scenes} scenes)")
            }
            (None, Budgets::Milliseconds) => format!("within {b} ms nothing fits"),
        })
        .collect();
    let lead = match budgets {
        Budgets::FloorMultiples => "Lowest error on the most scenes",
        Budgets::Milliseconds => "Lowest error",
    };
    let _ = writeln!(t, "\n{lead}: {}.", picks.join("; "));
    t
}

fn runs_table(runs: &[Run], options: &BTreeMap<&str, &str>) -> Result<String, String> {
    let columns: Vec<&str> = options
        .get("columns")
        .ok_or("a `runs` table needs columns=a,b,...")?
        .split(',')
        .collect();
    for column in &columns {
        if !COLUMNS.iter().any(|(name, _)| name == column) {
            let known: Vec<&str> = COLUMNS.iter().map(|(name, _)| *name).collect();
            return Err(format!(
                "unknown column `{column}`: use {}",
                known.join(", ")
            ));
        }
    }
    for key in options.keys() {
        if !["columns", "technique", "scene"].contains(key) {
            return Err(format!(
                "unknown option `{key}`: use columns, technique or scene"
            ));
        }
    }
    let mut t = String::from("|");
    for column in &columns {
        let header = COLUMNS
            .iter()
            .find(|(n, _)| n == column)
            .map_or("", |c| c.1);
        let _ = write!(t, " {header} |");
    }
    t.push_str("\n|");
    t.push_str(&"---|".repeat(columns.len()));
    t.push('\n');
    let selected = runs.iter().filter(|r| {
        options.get("technique").is_none_or(|t| r.technique == *t)
            && options.get("scene").is_none_or(|s| r.scene == *s)
    });
    for run in selected {
        t.push('|');
        for column in &columns {
            let value = run_cell(column, run, runs);
            let _ = write!(t, " {} |", value.replace('|', "\\|"));
        }
        t.push('\n');
    }
    Ok(t)
}

/// A scene-load cell (`triangles`, `load_s`, `upload_s`, `load_peak_mib`) of `run`.
fn load_cell(column: &str, run: &Run) -> String {
    let Some(load) = run.scene_load else {
        return "-".into();
    };
    match column {
        "triangles" => load.triangles.to_string(),
        "load_s" => format!("{:.2}", load.load_s),
        "upload_s" => format!("{:.2}", load.upload_s),
        _ => load.load_peak_mib.map_or("-".into(), |m| format!("{m:.0}")),
    }
}

/// The `column` cell of `run` in a `runs` table (its cost floor from `runs`).
fn run_cell(column: &str, run: &Run, runs: &[Run]) -> String {
    match column {
        "scene" => format!("`{}`", run.scene),
        "technique" => format!("`{}`", run.technique),
        "params" => params_text(run),
        "size" => format!("{}x{}", run.width, run.height),
        "frame_ms" => frame_time_ms(run).map_or("-".into(), ms),
        "technique_ms" => run
            .timing
            .as_ref()
            .and_then(|t| t.technique_ms.as_ref())
            .map_or("-".into(), |p| ms(p.median)),
        "pass_ms" => technique_passes_text(run),
        "triangles" | "load_s" | "upload_s" | "load_peak_mib" => load_cell(column, run),
        "cold_frame_ms" => cold_frame_ms(run).map_or("-".into(), ms),
        "camera_only_ms" => run
            .timing_camera_only
            .as_ref()
            .and_then(|t| t.frame_ms.as_ref())
            .map_or("-".into(), |p| ms(p.median)),
        "floor_ratio" => match (frame_time_ms(run), floor_frame_ms(runs, run)) {
            (Some(time), f) if f.is_finite() => format!("{:.2}", time / f),
            _ => "-".into(),
        },
        "mae_shadowed" => mae_shadowed(run).map_or("-".into(), |e| format!("{e:.4}")),
        "darker_shadowed" => darker_shadowed(run).map_or("-".into(), |e| format!("{e:.4}")),
        "brighter_umbra" => brighter_umbra(run).map_or("-".into(), |e| format!("{e:.4}")),
        "irradiance" => irradiance_mae_shadowed(run).map_or("-".into(), |e| format!("{e:.4}")),
        "flip" => flip(run).map_or("-".into(), |e| format!("{e:.4}")),
        "still_flicker" => still_flicker_text(run.still_flicker),
        "reference_vs_exact" => run
            .error
            .as_ref()
            .and_then(|e| e.reference_vs_exact.as_ref())
            .map_or("-".into(), |e| format!("{:.4}", e.mae_shadowed)),
        "all_lit_vs_exact" => run
            .error
            .as_ref()
            .and_then(|e| e.all_lit_vs_exact.as_ref())
            .map_or("-".into(), |e| format!("{:.4}", e.mae_shadowed)),
        "exact" => run
            .error
            .as_ref()
            .and_then(|e| e.exact.clone())
            .unwrap_or_else(|| "-".into()),
        "near_error" => band_cell(run, 0),
        "middle_error" => band_cell(run, 1),
        "far_error" => band_cell(run, 2),
        "status" => match run.status {
            Status::Ok => "ok".into(),
            failed => format!("{failed}: {}", run.message),
        },
        _ => unreachable!("runs_table checks the columns first"),
    }
}

/// Each of the technique's own passes with its median time (`` `hard/lookup` 0.84``), the
/// renderer's G-buffer and shading left out; `-` without timing.
fn technique_passes_text(run: &Run) -> String {
    let Some(timing) = &run.timing else {
        return "-".into();
    };
    let passes: Vec<String> = timing
        .passes
        .iter()
        .filter(|p| !softshadow_core::renderer::is_core_pass(&p.name))
        .map(|p| format!("`{}` {}", p.name, ms(p.ms_median)))
        .collect();
    if passes.is_empty() {
        "-".into()
    } else {
        passes.join(", ")
    }
}

/// mae_all against the exact answer in camera-distance band `band` (`error.distance_bands`), or
/// `-` without it or without a receiver pixel in the band.
fn band_cell(run: &Run, band: usize) -> String {
    run.error
        .as_ref()
        .and_then(|e| e.distance_bands.as_ref())
        .and_then(|b| b.get(band))
        .filter(|b| b.receiver_pixels > 0)
        .map_or("-".into(), |b| format!("{:.4}", b.mae_all))
}

/// The fastest frame time of the cost-floor technique on `run`'s scene and size in `runs`
/// (infinite when it has none).
fn floor_frame_ms(runs: &[Run], run: &Run) -> f64 {
    runs.iter()
        .filter(|r| {
            r.technique == COST_FLOOR_TECHNIQUE
                && r.scene == run.scene
                && (r.width, r.height) == (run.width, run.height)
        })
        .filter_map(frame_time_ms)
        .fold(f64::INFINITY, f64::min)
}

/// The parameters (name=value) of `run` whose values differ among `runs` of its technique.
/// The parameters of `run` that differ between the runs of its technique in `runs`, as
/// `name=value` words (every run records every parameter; the shared ones repeat the defaults).
pub(crate) fn varying_params(run: &Run, runs: &[&Run]) -> String {
    // A run refused for its light kind recorded only the parameters it was given (its technique
    // was never made): it is compared with the others, not they with it.
    run.params
        .iter()
        .filter(|(name, value)| {
            runs.iter()
                .filter(|o| o.technique == run.technique && o.status != Status::Unsupported)
                .any(|o| o.params.get(*name) != Some(*value))
        })
        .map(|(name, value)| format!("{name}={value}"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn grid_table(runs: &[Run], options: &BTreeMap<&str, &str>) -> Result<String, String> {
    for key in options.keys() {
        if !["technique", "rows"].contains(key) {
            return Err(format!(
                "unknown option `{key}`: a `grid` table takes technique=ID and rows=scenes|settings"
            ));
        }
    }
    let settings_as_rows = match options.get("rows").copied().unwrap_or("scenes") {
        "scenes" => false,
        "settings" => true,
        other => return Err(format!("rows={other}: use rows=scenes or rows=settings")),
    };
    let technique = options.get("technique").copied();
    let mine: Vec<&Run> = runs
        .iter()
        .filter(|r| technique.is_none_or(|t| r.technique == t))
        .collect();
    if mine.is_empty() {
        return Err(format!(
            "no run of `{}` in the results",
            technique.unwrap_or("any technique")
        ));
    }
    // A run's setting: the parameters that differ between its technique's runs (and the
    // technique, when the table holds several).
    let setting_of = |r: &Run| {
        let varying = varying_params(r, &mine);
        match technique {
            Some(_) if varying.is_empty() => "as run".to_string(),
            Some(_) => varying,
            None if varying.is_empty() => format!("`{}`", r.technique),
            None => format!("`{}` {varying}", r.technique),
        }
    };
    let all_settings: Vec<String> = mine.iter().map(|r| setting_of(r)).collect();
    let settings = ordered(all_settings.iter().map(|s| s.as_str()));
    let scenes = ordered(mine.iter().map(|r| r.scene.as_str()));
    let cell = |scene: &str, setting: &str| {
        mine.iter()
            .find(|r| r.scene == scene && setting_of(r) == setting)
            .map_or("-".to_string(), |r| match (&r.status, &r.motion) {
                (Status::Error | Status::Timeout | Status::Crashed | Status::Unsupported, _) => {
                    r.status.to_string()
                }
                // Along a path: the mean error over its frames / the last frame's.
                (Status::Ok, Some(m)) => format!(
                    "{:.4} / {}",
                    m.error.mean,
                    m.series
                        .error
                        .last()
                        .map_or("-".into(), |e| format!("{e:.4}"))
                ),
                (Status::Ok, None) => format!(
                    "{} / {}",
                    mae_shadowed(r).map_or("-".into(), |e| format!("{e:.4}")),
                    frame_time_ms(r).map_or("-".into(), |m| format!("{m:.0}"))
                ),
            })
    };
    let (rows, columns, corner) = if settings_as_rows {
        (&settings, &scenes, "setting")
    } else {
        (&scenes, &settings, "scene")
    };
    let label = |text: &str, is_scene: bool| {
        if is_scene {
            format!("`{text}`")
        } else {
            text.replace('|', "\\|")
        }
    };
    let mut t = format!("| {corner} |");
    for column in columns.iter() {
        let _ = write!(t, " {} |", label(column, !settings_as_rows));
    }
    t.push_str("\n|---|");
    t.push_str(&"---|".repeat(columns.len()));
    t.push('\n');
    for row in rows.iter() {
        let _ = write!(t, "| {} |", label(row, settings_as_rows));
        for column in columns.iter() {
            let (scene, setting) = if settings_as_rows {
                (*column, *row)
            } else {
                (*row, *column)
            };
            let _ = write!(t, " {} |", cell(scene, setting));
        }
        t.push('\n');
    }
    Ok(t)
}

/// The frame time a path is about: light-moving frames, else camera-only ones, else still ones
/// (median ms), and which kind it was.
fn path_frame_ms(run: &Run) -> Option<(&'static str, f64)> {
    let times = &run.motion.as_ref()?.frame_ms;
    times
        .light_moving
        .as_ref()
        .map(|p| ("light moving", p.median))
        .or_else(|| {
            times
                .camera_only
                .as_ref()
                .map(|p| ("camera only", p.median))
        })
        .or_else(|| times.still.as_ref().map(|p| ("still", p.median)))
}

/// A ratio to about three significant figures (0.742, 5.34, 130, 1030).
fn three_figures(x: f64) -> String {
    match x.abs() {
        a if a >= 100.0 => format!("{x:.0}"),
        a if a >= 10.0 => format!("{x:.1}"),
        a if a >= 1.0 => format!("{x:.2}"),
        _ => format!("{x:.3}"),
    }
}

fn motion_table(runs: &[Run], options: &BTreeMap<&str, &str>) -> Result<String, String> {
    for key in options.keys() {
        if *key != "scene" {
            return Err(format!(
                "unknown option `{key}`: a `motion` table takes scene=SCENE"
            ));
        }
    }
    let scene = *options
        .get("scene")
        .ok_or("a `motion` table needs scene=SCENE")?;
    let on_scene: Vec<&Run> = runs
        .iter()
        .filter(|r| r.scene == scene && r.motion.is_some())
        .collect();
    if on_scene.is_empty() {
        return Err(format!("no run along a path on `{scene}` in the results"));
    }
    let paths = ordered(
        on_scene
            .iter()
            .filter_map(|r| r.motion.as_ref().map(|m| m.path.as_str())),
    );
    // Settings that differ between a technique's runs here name its rows (all runs record
    // every parameter; the ones they share would only repeat the defaults).
    let row_of = |r: &Run| (r.technique.clone(), varying_params(r, &on_scene));
    let mut rows: Vec<(String, String)> = Vec::new();
    for run in &on_scene {
        if !rows.contains(&row_of(run)) {
            rows.push(row_of(run));
        }
    }
    let find = |row: &(String, String), path: &str| {
        on_scene
            .iter()
            .copied()
            .find(|r| row_of(r) == *row && r.motion.as_ref().is_some_and(|m| m.path == path))
    };
    let floor_ms = |run: &Run, path: &str| {
        on_scene
            .iter()
            .filter(|r| {
                r.technique == COST_FLOOR_TECHNIQUE
                    && (r.width, r.height) == (run.width, run.height)
                    && r.motion.as_ref().is_some_and(|m| m.path == path)
            })
            .filter_map(|r| path_frame_ms(r).map(|(_, ms)| ms))
            .fold(f64::INFINITY, f64::min)
    };
    let mut t = motion_header(&on_scene, &paths);
    let dash = || "-".to_string();
    for row in &rows {
        let _ = write!(t, "| `{}` | {} |", row.0, row.1.replace('|', "\\|"));
        for path in &paths {
            let run = find(row, path);
            let motion = run.and_then(|r| r.motion.as_ref());
            let error = motion.map_or_else(dash, |m| format!("{:.4}", m.error.mean));
            let flicker = motion
                .and_then(|m| m.flicker.as_ref())
                .map_or_else(dash, |f| format!("{:.4}", f.mean));
            let _ = write!(t, " {error} | {flicker} |");
            if has_lag(&on_scene, path) {
                let lag = motion.and_then(|m| m.lag.as_ref()).map_or_else(dash, |l| {
                    format!("{:.4}, {}", l.extra_error, l.frames_to_settle)
                });
                let _ = write!(t, " {lag} |");
            }
        }
        for path in &paths {
            let ratio = find(row, path)
                .and_then(|r| {
                    let (_, ms) = path_frame_ms(r)?;
                    let floor = floor_ms(r, path);
                    floor.is_finite().then(|| ms / floor)
                })
                .map_or_else(dash, three_figures);
            let _ = write!(t, " {ratio} |");
        }
        t.push('\n');
    }
    Ok(t)
}

/// The header of a `motion` table of the runs `on_scene` along `paths`: per path its error,
/// flicker and (where some run lags) lag columns, then per path the frame time against the cost
/// floor's.
fn motion_header(on_scene: &[&Run], paths: &[&str]) -> String {
    let mut t = String::from("| technique | settings that differ |");
    let mut columns = 2;
    for path in paths {
        let _ = write!(t, " error {path} | flicker {path} |");
        columns += 2;
        if has_lag(on_scene, path) {
            let _ = write!(t, " lag {path} (extra error, frames) |");
            columns += 1;
        }
    }
    for path in paths {
        let kind = on_scene
            .iter()
            .filter(|r| r.motion.as_ref().is_some_and(|m| m.path == *path))
            .find_map(|r| path_frame_ms(r).map(|(kind, _)| kind))
            .unwrap_or("still");
        let _ = write!(t, " {kind} frame / `{COST_FLOOR_TECHNIQUE}`'s ({path}) |");
        columns += 1;
    }
    t.push_str("\n|");
    t.push_str(&"---|".repeat(columns));
    t.push('\n');
    t
}

/// Whether a `motion` table has a lag column for `path`: only where some run of `on_scene` keeps
/// history (a non-zero lag).
fn has_lag(on_scene: &[&Run], path: &str) -> bool {
    on_scene.iter().any(|r| {
        r.motion.as_ref().is_some_and(|m| {
            m.path == path && m.lag.as_ref().is_some_and(|l| l.frames_to_settle > 0)
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markers_are_found_and_bad_ones_named() {
        let file = Path::new("doc.md");
        let text =
            "a\n<!-- generated: runs r.json columns=scene -->\nold\n<!-- end generated -->\nb\n";
        let tables = marked_tables(text, file).unwrap();
        assert_eq!(tables.len(), 1);
        assert_eq!(tables[0].line, 2);
        assert_eq!(tables[0].spec, "runs r.json columns=scene");
        assert_eq!(tables[0].body, "old\n");
        let e = marked_tables("<!-- generated: runs r.json -->\n", file)
            .unwrap_err()
            .to_string();
        assert!(e.contains("doc.md:1") && e.contains("never closed"), "{e}");
        let e = marked_tables("<!-- end generated -->\n", file)
            .unwrap_err()
            .to_string();
        assert!(e.contains("without an opening"), "{e}");
    }

    #[test]
    fn a_run_refused_for_its_light_kind_shares_its_techniques_row() {
        let spec = crate::RunSpec {
            scene: "atty-square".into(),
            technique: "msm".into(),
            params: Vec::new(),
            width: 64,
            height: 64,
            path: None,
        };
        let mut ok = Run::new(0, &spec);
        ok.params.insert(
            "shadow_map_size".into(),
            softshadow_core::ParamValue::Int(512),
        );
        let mut refused = Run::new(1, &spec);
        refused.status = Status::Unsupported;
        let runs = [&ok, &refused];
        assert_eq!(varying_params(&ok, &runs), "");
        assert_eq!(varying_params(&refused, &runs), "");
    }

    /// `pass_ms` lists the technique's own passes, not the renderer's G-buffer and shading.
    #[test]
    fn the_pass_column_shows_the_techniques_passes_only() {
        use crate::results::{Median, PassTiming, Percentiles, Timing};
        let spec = crate::RunSpec {
            scene: "atty-square".into(),
            technique: "hard".into(),
            params: Vec::new(),
            width: 64,
            height: 64,
            path: None,
        };
        let mut run = Run::new(0, &spec);
        assert_eq!(run_cell("pass_ms", &run, &[]), "-");
        let pass = |name: &str, ms_median| PassTiming {
            name: name.into(),
            ms_median,
            serial_ms: None,
        };
        let median = Percentiles {
            median: 2.5,
            p10: 2.0,
            p90: 3.0,
        };
        run.timing = Some(Timing {
            frames: 1,
            source: softshadow_core::TimingSource::Serial,
            frame_ms: Some(median.clone()),
            technique_ms: Some(median),
            passes: vec![
                pass("gbuffer", 1.0),
                pass("hard/shadow_map", 2.0),
                pass("hard/lookup", 0.5),
                pass("shading", 1.0),
            ],
            cpu_ms: Median { median: 5.0 },
            passes_run: None,
            warnings: Vec::new(),
        });
        assert_eq!(
            run_cell("pass_ms", &run, &[]),
            "`hard/shadow_map` 2.00, `hard/lookup` 0.500"
        );
        assert_eq!(run_cell("technique_ms", &run, &[]), "2.50");
    }

    #[test]
    fn bound_text_keeps_the_bound() {
        assert_eq!(
            bound_text("mae_shadowed <= 0.082 (measured 0.0327)"),
            "<= 0.082"
        );
        assert_eq!(
            bound_text("mae_shadowed = 0.25 +- 0.02 (known failure)"),
            "= 0.25 +- 0.02 (known failure)"
        );
    }
}
