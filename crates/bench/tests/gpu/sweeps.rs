//! Sharded sweeps and the report (issue 14): a sweep run as three shards and merged lists the
//! same runs with the same errors as the unsharded run; merging refuses duplicate runs and shards
//! of different sweeps and warns of a missing shard; every scene of the report has an SVG plot
//! with one point per run and a Pareto polyline that dominates every other point.

use std::path::Path;

use crate::common::gpu;
use anyhow::{ensure, Context, Result};
use softshadow_bench::{
    merge::{self, Loaded},
    report, run_indexed, BenchOptions, RunSetup, Shard, Status, Sweep, SweepInfo,
};

const SWEEP: &str = r#"
size = "64x64"
frames = 1
warmup = 0
scenes = ["atty-square", "balls-3x3x3"]
[reference]
samples_per_axis = 4
[[technique]]
id = "hard"
[[technique]]
id = "pcss"
[technique.params]
filter_samples = [16, 64]
[[technique]]
id = "ssm"
"#;

fn options() -> BenchOptions {
    BenchOptions {
        frames: 1,
        warmup: 0,
        images: true,
        exact_samples_per_axis: Some(4),
        camera_only: false,
        ..BenchOptions::default()
    }
}

fn run_shard(sweep: &Sweep, shard: Option<Shard>, dir: &Path) -> Result<()> {
    let options = options();
    let info = SweepInfo {
        hash: sweep.hash(&options, None),
        runs_total: sweep.runs.len(),
        shard,
    };
    let setup = RunSetup {
        registry: softshadow::registry(),
        sweep: Some(info),
        ..Default::default()
    };
    let results = run_indexed(gpu()?, &sweep.shard(shard), setup, options, dir, |_, _| {})?;
    for run in &results.runs {
        ensure!(
            run.status == Status::Ok,
            "{} / {}: {}",
            run.scene,
            run.technique,
            run.message
        );
    }
    Ok(())
}

fn error_figures(run: &softshadow_bench::Run) -> Result<[f64; 4]> {
    let e = run.error.as_ref().context("error metrics")?;
    let exact = e.vs_exact.as_ref().context("vs_exact")?;
    Ok([
        e.report.mae_shadowed,
        e.report.mae_all,
        e.report.flip_mean.context("flip")?,
        exact.mae_shadowed,
    ])
}

/// Value of attribute `name` in the tag text `tag`.
fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
    let end = start + tag[start..].find('"')?;
    Some(&tag[start..end])
}

/// Every `<name ...>` tag in `svg`.
fn tags<'a>(svg: &'a str, name: &str) -> Vec<&'a str> {
    let open = format!("<{name} ");
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(at) = rest.find(&open) {
        let end = rest[at..].find('>').map_or(rest.len(), |e| at + e);
        out.push(&rest[at..end]);
        rest = &rest[end..];
    }
    out
}

/// Checks one plot: one `run` circle per expected run, one Pareto polyline, and every run point
/// dominated by (at or right of and at or above, in pixels) a vertex of that polyline.
fn check_plot(svg: &str, expected_runs: usize, what: &str) -> Result<()> {
    let points: Vec<(f64, f64)> = tags(svg, "circle")
        .into_iter()
        .filter(|t| attr(t, "class") == Some("run"))
        .map(|t| -> Result<(f64, f64)> {
            Ok((
                attr(t, "cx").context("cx")?.parse()?,
                attr(t, "cy").context("cy")?.parse()?,
            ))
        })
        .collect::<Result<_>>()?;
    ensure!(
        points.len() == expected_runs,
        "{what}: {} points for {expected_runs} runs",
        points.len()
    );
    let pareto: Vec<&str> = tags(svg, "polyline")
        .into_iter()
        .filter(|t| attr(t, "stroke") == Some(report::PARETO_STROKE))
        .collect();
    ensure!(
        pareto.len() == 1,
        "{what}: {} Pareto polylines",
        pareto.len()
    );
    let vertices: Vec<(f64, f64)> = attr(pareto[0], "points")
        .context("points")?
        .split_whitespace()
        .map(|p| -> Result<(f64, f64)> {
            let (x, y) = p.split_once(',').context("x,y")?;
            Ok((x.parse()?, y.parse()?))
        })
        .collect::<Result<_>>()?;
    ensure!(!vertices.is_empty(), "{what}: empty Pareto polyline");
    // Pixels: x grows with time, y shrinks as the error grows. Vertices are rounded to whole
    // pixels like the points, so "at or better" allows no slack.
    for (x, y) in &points {
        ensure!(
            vertices.iter().any(|(vx, vy)| vx <= x && vy >= y),
            "{what}: point ({x}, {y}) is not dominated by the front {vertices:?}"
        );
    }
    // And the front is made of runs: each vertex that is not a stair corner is a point.
    let on_points = vertices.iter().filter(|v| points.contains(v)).count();
    ensure!(
        on_points * 2 > vertices.len(),
        "{what}: the front's vertices {vertices:?} are not runs {points:?}"
    );
    Ok(())
}

#[test]
fn three_shards_merged_equal_the_whole_sweep_and_the_report_plots_every_run() -> Result<()> {
    let sweep = Sweep::parse(SWEEP, &softshadow::registry())?;
    let n = sweep.runs.len();
    ensure!(n == 8, "{n} runs");
    let root = tempfile::tempdir()?;
    let whole = root.path().join("whole");
    run_shard(&sweep, None, &whole)?;
    let shard_dirs: Vec<_> = (0..3)
        .map(|i| root.path().join(format!("shard{i}")))
        .collect();
    for (index, dir) in shard_dirs.iter().enumerate() {
        run_shard(&sweep, Some(Shard { index, count: 3 }), dir)?;
    }
    let shards: Vec<Loaded> = shard_dirs
        .iter()
        .map(|d| merge::load(d))
        .collect::<Result<_, _>>()?;
    // Round robin: shard i holds runs i, i + 3, ...
    ensure!(shards[0].results.runs.iter().map(|r| r.index).eq([0, 3, 6]));
    let merged = merge::merge(&shards)?;
    ensure!(merged.warnings.is_empty(), "{:?}", merged.warnings);
    let merged_dir = root.path().join("merged");
    merge::write_merged(&merged, &merged_dir)?;
    let merged = merge::load(&merged_dir)?;
    let whole = merge::load(&whole)?;
    ensure!(
        merged.results.sweep.as_ref().map(|s| (&s.hash, s.shard))
            == whole.results.sweep.as_ref().map(|s| (&s.hash, s.shard)),
        "merged {:?}, whole {:?}",
        merged.results.sweep,
        whole.results.sweep
    );
    ensure!(merged.results.runs.len() == n);
    let mut largest_difference = 0.0f64;
    for (m, w) in merged.results.runs.iter().zip(&whole.results.runs) {
        ensure!(
            (m.index, &m.scene, &m.technique, &m.params)
                == (w.index, &w.scene, &w.technique, &w.params),
            "run {} differs: {} / {} vs {} / {}",
            w.index,
            m.scene,
            m.technique,
            w.scene,
            w.technique
        );
        for (a, b) in error_figures(m)?.iter().zip(error_figures(w)?) {
            largest_difference = largest_difference.max((a - b).abs());
        }
        for name in m.images.values() {
            ensure!(
                merged_dir.join(name).is_file(),
                "merged image {name} missing"
            );
        }
    }
    // Rendering is deterministic: measured difference 0 (bound 1e-9).
    eprintln!("largest error difference, merged shards vs whole sweep: {largest_difference:e}");
    ensure!(largest_difference <= 1e-9, "{largest_difference}");

    // Refusals and warnings.
    let twice = merge::merge(&[shards[0].clone(), shards[1].clone(), shards[0].clone()])
        .unwrap_err()
        .to_string();
    ensure!(
        twice.contains("is in both") && twice.contains("shard0"),
        "{twice}"
    );
    let mut other = shards[2].clone();
    other.results.sweep.as_mut().context("sweep")?.hash = "0123456789abcdef".into();
    let mixed = merge::merge(&[shards[0].clone(), other])
        .unwrap_err()
        .to_string();
    ensure!(mixed.contains("different sweeps"), "{mixed}");
    let partial = merge::merge(&[shards[0].clone(), shards[2].clone()])?;
    ensure!(
        partial
            .warnings
            .iter()
            .any(|w| w.contains("shard 1 of 3 missing")),
        "{:?}",
        partial.warnings
    );

    // The report of the shards: self-contained, one plot pair per scene, every run a point.
    let all = merge::merge(&shards)?;
    let (html, summary) = report::render_html(&all, &softshadow::registry())?;
    ensure!(summary.scenes == 2 && summary.points == n && summary.unplotted == 0);
    // Nothing to fetch: no scripts, no stylesheets, no external sources (the SVG namespace URI
    // is a name, not a fetch).
    for fetch in [
        "<script",
        "<link",
        "src=\"http",
        "href=\"http",
        "url(http",
        "@import",
    ] {
        ensure!(
            !html.contains(fetch),
            "the report fetches something: {fetch}"
        );
    }
    ensure!(
        html.contains("src=\"data:image/png;base64,"),
        "no embedded images"
    );
    for scene in ["atty-square", "balls-3x3x3"] {
        let at = html
            .find(&format!("<div class=\"plots\" data-scene=\"{scene}\">"))
            .with_context(|| format!("no plots for {scene}"))?;
        let runs = all.results.runs.iter().filter(|r| r.scene == scene).count();
        for (k, kind) in ["mae", "flip"].iter().enumerate() {
            let start = at + html[at..].match_indices("<svg").nth(k).context("svg")?.0;
            let end = start + html[start..].find("</svg>").context("</svg>")?;
            check_plot(&html[start..end], runs, &format!("{scene} {kind}"))?;
        }
    }
    let csv = report::runs_csv(&all);
    ensure!(csv.lines().count() == n + 1, "{csv}");

    // The summary across scenes: every technique ran on both scenes, each scene's Pareto front
    // holds at least one technique, and the fastest budget names a winner on both scenes.
    ensure!(html.contains("Across scenes: which technique for which budget"));
    let scenes = [
        ("atty-square".to_string(), 64, 64),
        ("balls-3x3x3".to_string(), 64, 64),
    ];
    let rows = report::summary_rows(&all.results.runs, &scenes);
    ensure!(rows.len() == 3, "three techniques: {rows:?}");
    ensure!(rows.iter().all(|r| r.scenes == 2), "{rows:?}");
    let on_front: usize = rows.iter().map(|r| r.on_front.len()).sum();
    ensure!(on_front >= 2, "each scene has a Pareto front: {rows:?}");
    let wins_at_largest: usize = rows.iter().map(|r| *r.best_within.last().unwrap()).sum();
    ensure!(wins_at_largest == 2, "one winner per scene: {rows:?}");
    ensure!(report::best_per_budget(&rows).last().unwrap().is_some());
    Ok(())
}

/// The shared reference cache (issue 29): a second run of a sweep reads every reference from the
/// cache and gets the same errors; a corrupt entry is rendered again with a warning, never
/// trusted.
#[test]
fn a_second_sweep_reads_every_reference_from_the_cache_and_a_corrupt_entry_is_rebuilt() -> Result<()>
{
    use softshadow_bench::reference_cache::ReferenceCacheUse;
    let sweep = Sweep::parse(SWEEP, &softshadow::registry())?;
    let cache = tempfile::tempdir()?;
    let run = |dir: &Path| -> Result<softshadow_bench::Results> {
        let options = BenchOptions {
            reference_cache: Some(cache.path().to_path_buf()),
            ..options()
        };
        let setup = RunSetup {
            registry: softshadow::registry(),
            ..Default::default()
        };
        Ok(run_indexed(
            gpu()?,
            &sweep.shard(None),
            setup,
            options,
            dir,
            |_, _| {},
        )?)
    };
    let uses = |results: &softshadow_bench::Results| -> Vec<Option<ReferenceCacheUse>> {
        results
            .runs
            .iter()
            .map(|r| r.reference_cache.clone())
            .collect()
    };

    let first_dir = tempfile::tempdir()?;
    let first = run(first_dir.path())?;
    ensure!(
        uses(&first)
            .iter()
            .all(|u| *u == Some(ReferenceCacheUse::Stored)),
        "first sweep: every reference rendered and stored, got {:?}",
        uses(&first)
    );
    let entries: Vec<_> = std::fs::read_dir(cache.path())?.collect::<Result<_, _>>()?;
    ensure!(
        entries.len() == 2,
        "one entry per scene, got {}",
        entries.len()
    );

    let second_dir = tempfile::tempdir()?;
    let second = run(second_dir.path())?;
    ensure!(
        uses(&second)
            .iter()
            .all(|u| *u == Some(ReferenceCacheUse::Hit)),
        "second sweep: every run a cache hit, got {:?}",
        uses(&second)
    );
    let same_errors = |other: &softshadow_bench::Results| -> Result<()> {
        for (a, b) in first.runs.iter().zip(&other.runs) {
            let (a, b) = (error_figures(a)?, error_figures(b)?);
            for (x, y) in a.iter().zip(&b) {
                ensure!(
                    (x - y).abs() <= 1e-6,
                    "the cache changed an error: {a:?} vs {b:?}"
                );
            }
        }
        Ok(())
    };
    same_errors(&second)?;

    // Flip one byte in the middle of every entry: the checksum no longer matches.
    for entry in &entries {
        let mut bytes = std::fs::read(entry.path())?;
        let middle = bytes.len() / 2;
        bytes[middle] ^= 0x5a;
        std::fs::write(entry.path(), bytes)?;
    }
    let third_dir = tempfile::tempdir()?;
    let third = run(third_dir.path())?;
    let mut rebuilt = 0;
    for run in &third.runs {
        match &run.reference_cache {
            Some(ReferenceCacheUse::Rebuilt(why)) => {
                rebuilt += 1;
                ensure!(
                    run.warnings.iter().any(|w| w == why) && why.contains("cannot be trusted"),
                    "a rebuilt entry is warned of: {:?}",
                    run.warnings
                );
            }
            Some(ReferenceCacheUse::Stored) => {}
            other => anyhow::bail!("a corrupt entry was used: {other:?}"),
        }
    }
    ensure!(rebuilt == 2, "one rebuild per scene, got {rebuilt}");
    same_errors(&third)?;
    let fourth_dir = tempfile::tempdir()?;
    ensure!(uses(&run(fourth_dir.path())?)
        .iter()
        .all(|u| *u == Some(ReferenceCacheUse::Hit)));
    Ok(())
}
