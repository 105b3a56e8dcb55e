//! `workbench`: the soft-shadow workbench.
//!
//! - `workbench` or `workbench view [--scene ID|FILE] [--technique ID] [--state FILE]
//!   [--screenshot FILE --frames N]`: the interactive viewer.
//! - `workbench list [--json]`: scenes, techniques and every parameter with range and default.
//! - `workbench bench --scene ID|FILE --technique ID [--param name=value]... --out DIR`
//! - `workbench bench --sweep FILE --out DIR`
//! - `workbench bench --scene ID --technique ID --path NAME|FILE --frames N --out DIR`: along a
//!   path (error per frame, flicker, lag)
//! - `workbench bench --suite NAME --out DIR` (`stiff`, or a sweep file `sweeps/NAME.toml`)
//! - `workbench bench --sweep FILE --shard I/N --out DIR`: shard I (0-based) of N
//! - `workbench bench --resume DIR`: finish an interrupted benchmark (its results.json keeps every
//!   finished run)
//! - `workbench bench --stress SECONDS [--seed N] --out DIR`: random parameter stress
//!   (docs/STABILITY.md)
//! - `workbench merge DIR... --out DIR`: the shards of one sweep as one results.json
//! - `workbench report DIR_OR_RESULTS_JSON... --out report.html [--csv runs.csv]`
//!
//! The whole command line is a library function, [`main_with`], so that a crate with a technique
//! of its own ships a binary that is the workbench plus that technique:
//!
//! ```no_run
//! fn main() -> std::process::ExitCode {
//!     # let my_technique_info = || softshadow_workbench::builtin_registry().iter().next().unwrap().clone();
//!     softshadow_workbench::main_with(vec![my_technique_info()])
//! }
//! ```

use std::{path::PathBuf, process::ExitCode};

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use softshadow_bench::Sweep;
use softshadow_core::{ParamKind, Registry, TechniqueInfo};

mod bench;
mod resume;
mod stress;

#[derive(Parser)]
#[command(
    name = "workbench",
    version,
    about = "Measure soft-shadow techniques: error against run time"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

// Parsed once per process: the size of the bench's arguments costs nothing worth a box.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum Command {
    /// List scenes, techniques and their parameters.
    List {
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Run techniques headless and write results.json and images.
    Bench(BenchArgs),
    /// One run of an isolated benchmark, read as JSON on stdin (started by `bench`).
    #[command(hide = true)]
    BenchRun {
        /// A .wgsl technique file the benchmark registered (repeatable).
        #[arg(long = "technique-file")]
        technique_files: Vec<String>,
    },
    /// The interactive viewer (the default without a subcommand).
    View(ViewArgs),
    /// The viewer's render worker: one technique's frames over stdin and stdout (started by
    /// `view` for every technique it shows).
    #[command(hide = true)]
    ViewWorker,
    /// Merge the shards of one sweep (output folders of `bench --shard`) into one folder.
    Merge {
        /// Output folders (or their results.json) of the shards.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Folder for the merged results.json and images (created if missing).
        #[arg(long)]
        out: PathBuf,
    },
    /// Rewrite the generated tables of the documents from their committed results
    /// (docs/results/*.json); see `softshadow_bench::doc_tables`.
    Docs {
        /// Markdown files (default: every docs/*.md).
        files: Vec<PathBuf>,
        /// Only check: exit 1 naming every table that differs from its results.
        #[arg(long, conflicts_with = "rerun")]
        check: bool,
        /// First make every results file again with the command it records (as slow as the
        /// benchmarks themselves), then rewrite the tables.
        #[arg(long)]
        rerun: bool,
    },
    /// Write one self-contained HTML report (error against frame time) of any results.
    Report {
        /// Benchmark output folders or results.json files (shards are merged).
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// The HTML file to write.
        #[arg(long)]
        out: PathBuf,
        /// Also write every run as one row of this CSV file.
        #[arg(long)]
        csv: Option<PathBuf>,
        /// The same runs made on a CPU adapter (a results.json or its folder): adds a section on
        /// how the ranking moves from that adapter to this one.
        #[arg(long, value_name = "RESULTS")]
        cpu: Option<PathBuf>,
    },
}

#[derive(Args, Default)]
struct ViewArgs {
    /// Scene id (see `list`), optionally `id:param=value,...`, or a .toml / .gltf / .glb file.
    #[arg(long, default_value = "atty-square")]
    scene: String,
    /// Technique id (see `list`) or a .wgsl technique file (docs/WGSL.md); default: the first
    /// soft technique registered.
    #[arg(long)]
    technique: Option<String>,
    /// Technique parameter, `name=value` (repeatable).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    params: Vec<String>,
    /// Start from a viewer state saved with "Save state".
    #[arg(long)]
    state: Option<PathBuf>,
    /// Window size in pixels.
    #[arg(long, default_value = "1280x800", value_name = "WxH")]
    size: String,
    /// Render this many frames, then exit (prints the mean frame time).
    #[arg(long)]
    frames: Option<u64>,
    /// Save the last frame, UI included, to this PNG file (with --frames).
    #[arg(long, requires = "frames")]
    screenshot: Option<PathBuf>,
}

#[derive(Args, Clone, serde::Serialize, serde::Deserialize)]
struct BenchArgs {
    /// Scene id (see `list`), optionally `id:param=value,...`, or a .toml / .gltf / .glb file.
    #[arg(long, conflicts_with_all = ["sweep", "suite"])]
    scene: Option<String>,
    /// Technique id (see `list`) or a .wgsl technique file (docs/WGSL.md).
    #[arg(long, conflicts_with_all = ["sweep", "suite"])]
    technique: Option<String>,
    /// Technique parameter, `name=value` (repeatable).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    params: Vec<String>,
    /// Reference parameter, `name=value` (repeatable), e.g. samples_per_axis=16.
    #[arg(long = "reference-param", value_name = "NAME=VALUE")]
    reference_params: Vec<String>,
    /// Image size (default 256x256); with --sweep or --suite it replaces the size the sweep
    /// gives, for every run.
    #[arg(long, value_name = "WxH")]
    size: Option<String>,
    /// With --sweep or --suite: only the runs of these techniques (comma-separated ids).
    #[arg(long, value_name = "ID,ID,...", value_delimiter = ',')]
    #[serde(default)]
    techniques: Vec<String>,
    /// With --sweep or --suite: only the runs on these scenes (comma-separated, as the sweep
    /// names them).
    #[arg(long, value_name = "SCENE,SCENE,...", value_delimiter = ',')]
    #[serde(default)]
    scenes: Vec<String>,
    /// Timed frames per run; with --path, the frames along the path (at fixed time steps, the
    /// first at its start and the last at its end).
    #[arg(long)]
    frames: Option<u32>,
    /// Render every run along a path: `still`, `orbit`, `light-sweep`, `object-move` (see
    /// `workbench list`), a `[[path]]` its scene file declares, or a .toml path file;
    /// measures error against every frame's exact answer, flicker, lag and frame times
    /// (docs/MOTION.md).
    #[arg(long, value_name = "NAME|FILE")]
    path: Option<String>,
    /// Untimed warm-up frames per run.
    #[arg(long)]
    warmup: Option<u32>,
    /// A sweep file (scenes x techniques x parameter grids), see docs/BENCHMARKS.md.
    #[arg(long, conflicts_with = "suite")]
    sweep: Option<PathBuf>,
    /// A named suite: `stiff` (every technique on every stiff case, docs/STABILITY.md) or the
    /// stem of a sweep file in `sweeps/` (e.g. `pcss`).
    #[arg(long)]
    suite: Option<String>,
    /// Skip the reference and the error metrics (timings only).
    #[arg(long)]
    no_error: bool,
    /// Skip the exact ground truth (closed form, analytic, ray-traced or CPU ray cast) and
    /// `error.reference_vs_exact`.
    #[arg(long)]
    no_exact: bool,
    /// Use the sampled ground truth (ray-traced or CPU ray cast) where the analytic answer
    /// would apply: a cross-check of the analytic answer.
    #[arg(long)]
    no_analytic: bool,
    /// Light samples per axis of the CPU ray-cast ground truth (scenes without a closed form,
    /// under a light without area or with --no-analytic, on a device without ray queries).
    #[arg(long, default_value_t = softshadow_bench::DEFAULT_EXACT_SAMPLES)]
    exact_samples: u32,
    /// Light samples per axis of the ray-traced ground truth (where the sampled answer is used,
    /// on a device with ray queries); 0 uses the CPU ray cast there too.
    #[arg(long, default_value_t = softshadow_bench::DEFAULT_TRACED_SAMPLES)]
    traced_samples: u32,
    /// Do not write images.
    #[arg(long)]
    no_images: bool,
    /// Skip `timing_camera_only` (frames in which only the camera moves and light-space work is
    /// kept).
    #[arg(long)]
    no_camera_only: bool,
    /// How passes are timed: `timestamps` (GPU timestamp queries) or `serial` (each pass
    /// submitted on its own and waited for). Default: serial on a CPU adapter, timestamps on a
    /// GPU.
    #[arg(long, value_name = "timestamps|serial")]
    timing: Option<String>,
    /// Read reference images from DIR and store the ones it lacks there (a folder every shard
    /// of a sweep can share, docs/CLUSTER.md); each run says whether its reference was a hit.
    #[arg(long, value_name = "DIR")]
    reference_cache: Option<PathBuf>,
    /// Run only shard INDEX of COUNT (0-based) of the sweep: runs INDEX, INDEX+COUNT, ...
    /// (docs/CLUSTER.md).
    #[arg(long, value_name = "INDEX/COUNT")]
    shard: Option<String>,
    /// Make every run in a process of its own, with a time limit: a run that hangs is killed
    /// and recorded `timeout`, one whose process crashes `crashed`, and the rest go on (the
    /// default for --sweep, --suite and --shard; docs/STABILITY.md, "Isolated runs").
    #[arg(long, conflicts_with = "no_isolate")]
    #[serde(default)]
    isolate: bool,
    /// Make every run in this process (the default for a single run): no process start per
    /// run, but a run that hangs or crashes stops the benchmark.
    #[arg(long)]
    #[serde(default)]
    no_isolate: bool,
    /// Time limit of each isolated run, in seconds (default: 20 times what its technique's
    /// cost model predicts, at least 60 s).
    #[arg(long, value_name = "SECONDS")]
    #[serde(default)]
    run_timeout: Option<f64>,
    /// Output folder (created if missing).
    #[arg(long, required_unless_present = "resume")]
    out: Option<PathBuf>,
    /// Finish the benchmark interrupted in DIR (Ctrl-C, killed): runs what its results.json
    /// lacks, with the arguments it was started with, and adds them to it.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["scene", "technique", "sweep", "suite", "out", "stress"])]
    #[serde(skip)]
    resume: Option<PathBuf>,
    /// Random parameter stress for SECONDS seconds: every technique, random parameters in their
    /// ranges, random lights, 32² to 48²; writes stress.json to --out (docs/STABILITY.md).
    #[arg(long, value_name = "SECONDS", conflicts_with_all = ["scene", "technique", "sweep", "suite"])]
    #[serde(skip)]
    stress: Option<u64>,
    /// Seed of the random cases of --stress.
    #[arg(long, default_value_t = 1, requires = "stress")]
    #[serde(skip)]
    seed: u64,
}

/// `bench --size` without a sweep, when not given.
pub(crate) const DEFAULT_SIZE: &str = "256x256";

/// The built-in techniques (`softshadow::registry()`).
pub fn builtin_registry() -> Registry {
    softshadow::registry()
}

/// The workbench's command line (`list`, `bench`, `view`, `merge`, `report`) over the built-in
/// techniques plus `extra` ones (a user's own, from their crate): what `workbench` runs with no
/// extra techniques. Parses the process's arguments; returns the exit code (2 for bad input, 3
/// when a benchmark run failed).
pub fn main_with(extra: Vec<TechniqueInfo>) -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let mut registry = builtin_registry();
    for info in extra {
        if let Err(e) = registry.add(info) {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::List { json }) => list(&registry, json),
        Some(Command::Bench(args)) => bench::bench(&registry, args),
        Some(Command::BenchRun { technique_files }) => {
            bench::bench_run(&registry, &technique_files)
        }
        Some(Command::View(args)) => view(&registry, args),
        Some(Command::ViewWorker) => Ok(softshadow_viewer::serve_render_worker(&registry)),
        Some(Command::Merge { inputs, out }) => merge(&inputs, &out),
        Some(Command::Docs {
            files,
            check,
            rerun,
        }) => docs(files, check, rerun),
        Some(Command::Report {
            inputs,
            out,
            csv,
            cpu,
        }) => report(&registry, &inputs, &out, csv.as_deref(), cpu.as_deref()),
        None => view(
            &registry,
            ViewArgs {
                scene: "atty-square".into(),
                size: "1280x800".into(),
                ..ViewArgs::default()
            },
        ),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            // One line: the chain of causes, most specific last.
            let message: Vec<String> = e.chain().map(|c| c.to_string()).collect();
            eprintln!("error: {}", message.join(": "));
            ExitCode::from(2)
        }
    }
}

fn list(registry: &Registry, json: bool) -> Result<ExitCode> {
    let scenes = softshadow_scenes::builtin_scenes();
    let techniques = registry;
    // What the adapter `bench` and `view` would pick offers, without creating a device: a
    // technique needing more is listed as unavailable, with what to install. Only asked when some
    // technique needs an optional feature (listing needs no GPU otherwise).
    let needs_features = techniques
        .iter()
        .any(|t| !t.requirements.features.is_empty());
    let offered = needs_features.then(softshadow_core::Gpu::headless_adapter_features);
    let unavailable = |t: &TechniqueInfo| -> Option<String> {
        match &offered {
            None => None,
            Some(Ok((_, features))) => t.unavailable_on(*features),
            Some(Err(e)) if !t.requirements.features.is_empty() => Some(e.to_string()),
            Some(Err(_)) => None,
        }
    };
    if json {
        let value = serde_json::json!({
            "scenes": scenes.iter().map(|s| serde_json::json!({
                "id": s.id,
                "description": s.description,
                "params": s.params.iter().map(|p| serde_json::json!({
                    "name": p.name, "default": p.default, "description": p.description,
                    "range": p.range_text(),
                })).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
            "paths": softshadow_scenes::path::BUILTIN_PATHS.iter().map(|(name, description)| serde_json::json!({
                "name": name, "description": description,
            })).collect::<Vec<_>>(),
            "techniques": techniques.iter().map(|t| serde_json::json!({
                "id": t.id,
                "description": t.description,
                "source": t.source,
                "params": t.params,
                "unavailable": unavailable(t),
                "light_kinds": t.light_kinds.supported().iter().map(|k| k.name()).collect::<Vec<_>>(),
                "light_kinds_unsupported": t.light_kinds.unsupported().iter().map(|(k, why)| serde_json::json!({
                    "kind": k.name(), "why": why,
                })).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
        });
        println!("{}", serde_json::to_string_pretty(&value)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!("Scenes:");
    for s in &scenes {
        println!("  {:<20} {}", s.id, s.description);
        for p in &s.params {
            println!(
                "      {:<20} default {:<8} {} ({})",
                p.name,
                p.default,
                p.description,
                p.range_text()
            );
        }
    }
    println!("\nTechniques:");
    for t in techniques {
        // Unavailable on this adapter: said on the technique's own line (one line, what to
        // install), so a parameter line is never mistaken for it.
        let why = unavailable(t)
            .map(|why| format!(" (unavailable: {why})"))
            .unwrap_or_default();
        println!(
            "  {:<20} {} [{}] ({}){why}",
            t.id,
            t.description,
            t.source,
            light_kinds_text(t)
        );
        for p in &t.params {
            let default = match &p.kind {
                ParamKind::Float { default, .. } => default.to_string(),
                ParamKind::Int { default, .. } => default.to_string(),
                ParamKind::Bool { default } => default.to_string(),
                ParamKind::Choice { default, .. } => default.to_string(),
            };
            println!(
                "      {:<20} default {:<8} {} ({})",
                p.name,
                default,
                p.description,
                p.range_text()
            );
        }
    }
    println!(
        "\nPaths (bench --path NAME, made for any scene; or a [[path]] of a scene file, or a .toml path file):"
    );
    for (name, description) in softshadow_scenes::path::BUILTIN_PATHS {
        println!("  {name:<20} {description}");
    }
    Ok(ExitCode::SUCCESS)
}

/// `light kinds: rect, disk; not sphere, sun: WHY`: the kinds a technique supports and, grouped
/// by reason, the ones it does not (said on its own line, so it is never read as a parameter).
fn light_kinds_text(t: &TechniqueInfo) -> String {
    let kinds: Vec<&str> = t.light_kinds.supported().iter().map(|k| k.name()).collect();
    let mut text = format!("light kinds: {}", kinds.join(", "));
    let mut reasons: Vec<(Vec<&str>, &str)> = Vec::new();
    for (kind, why) in t.light_kinds.unsupported() {
        match reasons.iter_mut().find(|(_, w)| *w == why) {
            Some((kinds, _)) => kinds.push(kind.name()),
            None => reasons.push((vec![kind.name()], why)),
        }
    }
    for (kinds, why) in reasons {
        text.push_str(&format!("; not {}: {why}", kinds.join(", ")));
    }
    text
}

/// `docs`: rewrites (or checks) the generated tables; with `rerun`, first makes their results
/// again by running the command each results file records.
fn docs(files: Vec<PathBuf>, check: bool, rerun: bool) -> Result<ExitCode> {
    use softshadow_bench::doc_tables;
    let root = std::env::current_dir().context("cannot read the current folder")?;
    let files = if files.is_empty() {
        let mut found: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
            .context("no docs/ folder here: run from the repository root or name the files")?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "md"))
            .collect();
        found.sort();
        found
    } else {
        files
    };
    if rerun {
        let mut done: Vec<PathBuf> = Vec::new();
        for file in &files {
            for results in doc_tables::results_files(file)? {
                if !done.contains(&results) {
                    rerun_results(&root.join(&results))?;
                    done.push(results);
                }
            }
        }
    }
    let mut drifted = Vec::new();
    for file in &files {
        if check {
            drifted.extend(doc_tables::drift(file, &root)?);
        } else {
            let text = std::fs::read_to_string(file)
                .with_context(|| format!("cannot read {}", file.display()))?;
            let new = doc_tables::regenerate(&text, file, &root)?;
            if new != text {
                softshadow_bench::output::write_atomic(file, new.as_bytes())?;
                println!("rewrote the tables of {}", file.display());
            }
        }
    }
    if !drifted.is_empty() {
        eprintln!(
            "{} generated tables differ from their committed results (run `workbench docs` to rewrite them):\n{}",
            drifted.len(),
            drifted.join("\n")
        );
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

/// The running binary's file name when it is not `workbench` (a crate's own workbench), for
/// `Results::program`; empty for `workbench`.
fn program_name() -> String {
    let name = std::env::current_exe()
        .ok()
        .and_then(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .unwrap_or_default();
    if name == "workbench" {
        String::new()
    } else {
        name
    }
}

/// Makes the results file `path` again: runs the benchmark command it records into a temporary
/// folder and writes its results, without images, over `path`.
fn rerun_results(path: &std::path::Path) -> Result<()> {
    let recorded = softshadow_bench::merge::load(path)?.results;
    if recorded.program != program_name() {
        let made_by = if recorded.program.is_empty() {
            "workbench"
        } else {
            recorded.program.as_str()
        };
        bail!(
            "{} was made by `{made_by}`, which knows techniques this binary may not: make it again with that binary's `docs --rerun` (for examples/custom-technique: `cargo run --release -p custom-technique -- docs --rerun`)",
            path.display()
        );
    }
    if recorded.command.first().map(String::as_str) != Some("bench") {
        bail!(
            "{} records no `bench` command to make it again: make it with `workbench bench ... --out DIR` and copy DIR/results.json there",
            path.display()
        );
    }
    let out = tempfile_dir()?;
    let mut args = recorded.command.clone();
    match args.iter().position(|a| a == "--out") {
        Some(k) if k + 1 < args.len() => args[k + 1] = out.display().to_string(),
        _ => args.extend(["--out".into(), out.display().to_string()]),
    }
    println!(
        "making {} again: workbench {}",
        path.display(),
        args.join(" ")
    );
    let status = std::process::Command::new(std::env::current_exe()?)
        .args(&args)
        .status()
        .context("cannot run the workbench again")?;
    // Exit 3 (a run failed) still leaves results worth showing: the failure is in them.
    if !(status.success() || status.code() == Some(3)) {
        bail!("`workbench {}` failed ({status})", args.join(" "));
    }
    let mut fresh = softshadow_bench::merge::load(&out)?.results;
    fresh.command = recorded.command;
    let json = serde_json::to_vec_pretty(&softshadow_bench::doc_tables::compact(fresh))?;
    softshadow_bench::output::write_atomic(path, &json)?;
    let _ = std::fs::remove_dir_all(&out);
    Ok(())
}

/// A new empty folder under the system's temporary folder.
fn tempfile_dir() -> Result<PathBuf> {
    let dir = std::env::temp_dir().join(format!(
        "softshadow-docs-{}-{}",
        std::process::id(),
        softshadow_bench::results::today_utc()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

fn merge(inputs: &[PathBuf], out: &std::path::Path) -> Result<ExitCode> {
    let loaded = inputs
        .iter()
        .map(|p| softshadow_bench::merge::load(p))
        .collect::<Result<Vec<_>, _>>()?;
    let merged = softshadow_bench::merge::merge(&loaded)?;
    for w in &merged.warnings {
        eprintln!("warning: {w}");
    }
    let results = softshadow_bench::merge::write_merged(&merged, out)?;
    println!(
        "merged {} runs from {} files into {}",
        results.runs.len(),
        loaded.len(),
        out.join("results.json").display()
    );
    Ok(ExitCode::SUCCESS)
}

fn report(
    registry: &Registry,
    inputs: &[PathBuf],
    out: &std::path::Path,
    csv: Option<&std::path::Path>,
    cpu: Option<&std::path::Path>,
) -> Result<ExitCode> {
    let loaded = inputs
        .iter()
        .map(|p| softshadow_bench::merge::load(p))
        .collect::<Result<Vec<_>, _>>()?;
    let merged = softshadow_bench::merge::merge(&loaded)?;
    for w in &merged.warnings {
        eprintln!("warning: {w}");
    }
    let cpu = cpu
        .map(softshadow_bench::merge::load)
        .transpose()?
        .map(|loaded| softshadow_bench::merge::merge(&[loaded]))
        .transpose()?;
    let summary = softshadow_bench::report::write_report(
        &merged,
        registry,
        out,
        csv,
        cpu.as_ref().map(|c| c.results.runs.as_slice()),
    )?;
    println!(
        "wrote {}: {} scenes, {} plotted runs, {} not plotted (failed or without error metrics){}",
        out.display(),
        summary.scenes,
        summary.points,
        summary.unplotted,
        csv.map(|c| format!("; {}", c.display()))
            .unwrap_or_default()
    );
    Ok(ExitCode::SUCCESS)
}

/// `registry` plus the technique files (`.wgsl`) named by `--technique` or by the
/// `[[technique]]` tables of `--sweep`.
fn with_technique_files(registry: &Registry, args: &BenchArgs) -> Result<Registry> {
    let mut files: Vec<String> = args.technique.iter().cloned().collect();
    if let Some(sweep) = &args.sweep {
        files.extend(Sweep::technique_files(sweep)?);
    }
    let mut registry = registry.clone();
    register_technique_files(&mut registry, &files)?;
    Ok(registry)
}

/// Registers every value of `values` that names a technique file (`softshadow_wgsl`).
fn register_technique_files(registry: &mut Registry, values: &[String]) -> Result<()> {
    for value in values
        .iter()
        .filter(|v| softshadow_wgsl::is_technique_file(v))
    {
        softshadow_wgsl::register_file(registry, std::path::Path::new(value))?;
    }
    Ok(())
}

fn view(registry: &Registry, args: ViewArgs) -> Result<ExitCode> {
    // Bad input fails before a window opens.
    let (width, height) = softshadow_bench::parse_size(&args.size)?;
    let mut registry = registry.clone();
    register_technique_files(&mut registry, args.technique.as_slice())?;
    let registry = &registry;
    let technique = match args.technique {
        Some(technique) => softshadow_bench::resolve_technique(registry, &technique)?
            .id
            .to_string(),
        None => registry
            .default_technique()
            .context("no technique is registered")?
            .id
            .to_string(),
    };
    let params = softshadow_bench::parse_params(registry, &technique, &args.params)?;
    let options = softshadow_viewer::ViewOptions {
        app: softshadow_viewer::ViewerOptions {
            registry: registry.clone(),
            scene: args.scene,
            technique,
            params,
            state: args.state,
            // Each technique renders in a process of its own, so Cancel stops any frame.
            worker: Some(softshadow_viewer::WorkerCommand {
                program: std::env::current_exe()
                    .context("cannot find this program to run the render worker in")?
                    .into_os_string(),
                args: vec!["view-worker".into()],
                env: Vec::new(),
            }),
        },
        width,
        height,
        frames: args.frames,
        screenshot: args.screenshot.clone(),
    };
    let summary = softshadow_viewer::run(options)?;
    if args.frames.is_some() {
        println!(
            "{} frames at {width}x{height} on {}: frame time mean {} ms, median {} ms, mean after the reference converged {} ms; technique GPU {} ms; reference {}/{} light samples",
            summary.frames,
            summary.adapter,
            summary.mean_frame_ms.map_or("-".into(), |ms| format!("{ms:.1}")),
            summary.median_frame_ms.map_or("-".into(), |ms| format!("{ms:.1}")),
            summary
                .converged_mean_frame_ms
                .map_or("-".into(), |ms| format!("{ms:.1}")),
            summary.technique_gpu_ms.map_or("-".into(), |ms| format!("{ms:.1}")),
            summary.reference_progress.0,
            summary.reference_progress.1,
        );
    }
    if let Some(path) = &args.screenshot {
        println!("wrote {}", path.display());
    }
    Ok(ExitCode::SUCCESS)
}
