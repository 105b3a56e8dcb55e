//! `workbench bench`: checks everything it can before the GPU starts, then makes the runs, each
//! in a process of its own for a sweep (`--isolate`, docs/STABILITY.md, "Isolated runs"), and
//! prints a line per run. `workbench bench-run` is that process: it reads one run on stdin and
//! writes its result on stdout.

use std::{
    io::Read,
    path::PathBuf,
    process::ExitCode,
    sync::atomic::{AtomicBool, Ordering},
    time::Duration,
};

use anyhow::{bail, Context, Result};
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use softshadow_bench::{
    isolate::{Isolation, Job},
    BenchOptions, Results, Run, RunSetup, RunSpec, Status, Sweep, SweepInfo,
};
use softshadow_core::{
    gpu::AdapterSummary, AreaLight, BuildControl, Camera, Gpu, Registry, TimingSource,
};

use crate::{program_name, register_technique_files, resume, stress, BenchArgs};

/// `--suite NAME`: a built-in suite, else `sweeps/NAME.toml` (from the current folder or the
/// repository this binary was built from).
fn load_suite(registry: &Registry, name: &str) -> Result<Sweep> {
    let file = format!("{name}.toml");
    let candidates = [
        PathBuf::from("sweeps").join(&file),
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../sweeps")
            .join(&file),
    ];
    if softshadow_bench::sweep::SUITES
        .iter()
        .any(|(n, _)| *n == name)
    {
        return Ok(Sweep::suite(name, registry)?);
    }
    match candidates.iter().find(|p| p.is_file()) {
        Some(path) => Ok(Sweep::load(path, registry)?),
        None => Ok(Sweep::suite(name, registry)?),
    }
}

/// The camera and light that replace every scene's own (a sweep's `[camera]`, `[light]`).
type View = (Option<Camera>, Option<AreaLight>);

/// Where the runs are made.
enum Device {
    /// In this process, on this device.
    Here(Gpu),
    /// Each in a process of its own, on a device of its own on this adapter.
    PerRun(AdapterSummary),
}

/// A benchmark checked and ready to run.
struct Plan {
    args: BenchArgs,
    registry: Registry,
    out: PathBuf,
    /// The runs (of the shard) with their index in the sweep.
    indexed: Vec<(usize, RunSpec)>,
    /// Runs a resumed benchmark already holds.
    finished: Vec<Run>,
    options: BenchOptions,
    sweep: Option<SweepInfo>,
    timing: Option<TimingSource>,
    view: View,
    command: Vec<String>,
    /// Each run in a process of its own, with this time limit (`None`: from the cost model).
    isolate: Option<Option<Duration>>,
}

pub(crate) fn bench(registry: &Registry, args: BenchArgs) -> Result<ExitCode> {
    if let Some(seconds) = args.stress {
        let out = args
            .out
            .context("--stress needs --out DIR for stress.json")?;
        return stress::run(registry, seconds, args.seed, &out);
    }
    let resuming = args.resume.is_some();
    let plan = plan(registry, args)?;
    let device = match plan.isolate {
        // Each run makes its own device: here, only check there is an adapter.
        Some(_) => Device::PerRun(Gpu::headless_adapter_summary().context("cannot start the GPU")?),
        None => Device::Here(Gpu::new_headless().context("cannot start the GPU")?),
    };
    // The output folder is writable and has room, before any run.
    let todo = softshadow_bench::remaining(&plan.indexed, &plan.finished);
    softshadow_bench::output::prepare_out_dir(&plan.out, &todo, &plan.options)?;
    // After the last check that can fail, so bad input and a missing GPU write nothing.
    if !resuming {
        resume::save(&plan.args, &plan.command, &plan.out)?;
    }
    let control = BuildControl::default();
    let results = execute(&plan, device, &control)?;
    print_runs(&results);
    println!("wrote {}", plan.out.join("results.json").display());
    if control.is_cancelled() {
        eprintln!(
            "interrupted (Ctrl-C): {} of {} runs done and in results.json (the cancelled one left out); `workbench bench --resume {}` finishes the rest",
            results.runs.len(),
            plan.indexed.len(),
            plan.out.display()
        );
        return Ok(ExitCode::from(130));
    }
    // A run of a light kind its technique does not support is recorded, not failed.
    let failed = results
        .runs
        .iter()
        .filter(|r| !matches!(r.status, Status::Ok | Status::Unsupported))
        .count();
    let invalid = results
        .runs
        .iter()
        .filter(|r| {
            r.stability
                .as_ref()
                .is_some_and(|s| s.nan + s.inf + s.out_of_range > 0)
        })
        .count();
    if failed > 0 || invalid > 0 {
        eprintln!(
            "{failed} of {} runs failed and {invalid} wrote NaN, Inf or values outside [0, 1]; details are in results.json",
            results.runs.len()
        );
        return Ok(ExitCode::from(3));
    }
    Ok(ExitCode::SUCCESS)
}

/// Everything that can be checked without a GPU, checked, so bad input fails fast and writes
/// nothing: the runs, options and the isolation.
fn plan(registry: &Registry, args: BenchArgs) -> Result<Plan> {
    let (args, finished, finished_hash, command) = match &args.resume {
        Some(dir) => {
            let previous = resume::load(dir)?;
            let command = previous.command;
            (previous.args, previous.runs, previous.sweep_hash, command)
        }
        None => (args, Vec::new(), None, std::env::args().skip(1).collect()),
    };
    let out = args.out.clone().context("give --out DIR")?;
    // A technique given as a .wgsl file joins the registry first.
    let registry = crate::with_technique_files(registry, &args)?;
    let mut sweep = match (&args.sweep, &args.suite) {
        (Some(path), _) => Some(Sweep::load(path, &registry)?),
        (None, Some(name)) => Some(load_suite(&registry, name)?),
        (None, None) => None,
    };
    // `--path` replaces the path (or paths) a sweep names, `--size` its size, and
    // `--techniques` / `--scenes` keep some of its runs.
    if let (Some(sweep), Some(path)) = (&mut sweep, &args.path) {
        sweep.set_path(path);
    }
    if let (Some(sweep), Some(size)) = (&mut sweep, &args.size) {
        let (width, height) = softshadow_bench::parse_size(size)?;
        sweep.set_size(width, height);
    }
    match (&mut sweep, args.techniques.is_empty() && args.scenes.is_empty()) {
        (Some(sweep), false) => {
            if !args.techniques.is_empty() {
                sweep.retain_techniques(&args.techniques)?;
            }
            if !args.scenes.is_empty() {
                sweep.retain_scenes(&args.scenes)?;
            }
        }
        (None, false) => bail!("--techniques and --scenes pick runs of a sweep: give --sweep FILE or --suite NAME (or one --technique and --scene)"),
        _ => {}
    }
    let shard = args
        .shard
        .as_deref()
        .map(softshadow_bench::sweep::parse_shard)
        .transpose()?;
    if shard.is_some() && sweep.is_none() {
        bail!("--shard splits a sweep: give --sweep FILE or --suite NAME with it");
    }
    let timing = args
        .timing
        .as_deref()
        .map(|t| {
            TimingSource::parse(t).ok_or_else(|| softshadow_bench::BenchError::BadTiming(t.into()))
        })
        .transpose()?;
    let (specs, options, view) = runs_and_options(&registry, &args, sweep.as_ref())?;
    let sweep_info = sweep.as_ref().map(|sweep| SweepInfo {
        hash: sweep.hash(&options, timing),
        runs_total: sweep.runs.len(),
        shard,
    });
    if let (Some(info), Some(hash)) = (&sweep_info, &finished_hash) {
        if &info.hash != hash {
            bail!(
                "cannot resume: the sweep (or its options) changed since its results.json was written (hash {hash}, now {}); start it again with a new --out",
                info.hash
            );
        }
    }
    let indexed: Vec<(usize, RunSpec)> = match &sweep {
        Some(sweep) => sweep.shard(shard),
        None => specs.into_iter().enumerate().collect(),
    };
    let isolate = isolation(&args, sweep.is_some())?;
    // A bad SOFTSHADOW_FAULT fails here, not in every run.
    softshadow_bench::fault::Faults::from_env()?;
    Ok(Plan {
        args,
        registry,
        out,
        indexed,
        finished,
        options,
        sweep: sweep_info,
        timing,
        view,
        command,
        isolate,
    })
}

/// `--isolate` / `--no-isolate` / `--run-timeout`: whether each run gets a process of its own
/// (by default a sweep's do, a single run does not) and its time limit.
fn isolation(args: &BenchArgs, sweep: bool) -> Result<Option<Option<Duration>>> {
    let isolate = (sweep || args.isolate) && !args.no_isolate;
    let timeout = match args.run_timeout {
        None => None,
        Some(_) if !isolate => bail!(
            "--run-timeout limits runs made in processes of their own: drop --no-isolate (a sweep's runs are isolated by default), or add --isolate to a single run"
        ),
        Some(seconds) => Some(
            Duration::try_from_secs_f64(seconds)
                .ok()
                .filter(|d| !d.is_zero())
                .with_context(|| {
                    format!("--run-timeout {seconds} is not a time: give seconds above 0, e.g. --run-timeout 600")
                })?,
        ),
    };
    Ok(isolate.then_some(timeout))
}

/// The runs of the sweep (or the single run the arguments name), the options they share and
/// the camera and light that replace every scene's own.
fn runs_and_options(
    registry: &Registry,
    args: &BenchArgs,
    sweep: Option<&Sweep>,
) -> Result<(Vec<RunSpec>, BenchOptions, View)> {
    let (specs, sweep_frames, sweep_warmup, mut reference_params, view) = if let Some(sweep) = sweep
    {
        (
            sweep.runs.clone(),
            sweep.frames,
            sweep.warmup,
            sweep.reference_params.clone(),
            (sweep.camera, sweep.light),
        )
    } else {
        let (Some(scene), Some(technique)) = (&args.scene, &args.technique) else {
            bail!("give --scene and --technique, or --sweep FILE, or --suite NAME (see `workbench list`)");
        };
        let (width, height) =
            softshadow_bench::parse_size(args.size.as_deref().unwrap_or(crate::DEFAULT_SIZE))?;
        let params = softshadow_bench::parse_params(registry, technique, &args.params)?;
        let spec = RunSpec {
            scene: scene.clone(),
            // The id (a .wgsl file's stem), not the path given.
            technique: softshadow_bench::resolve_technique(registry, technique)?
                .id
                .to_string(),
            params,
            width,
            height,
            path: args.path.clone(),
        };
        softshadow_bench::validate(registry, &spec)?;
        // A single run of a light kind its technique does not support: refused before any GPU
        // work (a sweep records such a run as `unsupported` and goes on).
        if let (_, Some(why)) = softshadow_bench::light_refusal(registry, &spec, None)? {
            bail!(why);
        }
        (vec![spec], None, None, Vec::new(), (None, None))
    };
    if !args.reference_params.is_empty() {
        let reference = registry.yardstick()?;
        for text in &args.reference_params {
            reference_params.push(reference.parse_param(text)?);
        }
    }
    let frames = args.frames.or(sweep_frames).unwrap_or(10);
    if frames == 0 {
        bail!("--frames must be at least 1");
    }
    let options = BenchOptions {
        frames,
        warmup: args.warmup.or(sweep_warmup).unwrap_or(2),
        error: !args.no_error,
        reference_params,
        images: !args.no_images,
        exact_samples_per_axis: (!args.no_exact).then_some(args.exact_samples.max(1)),
        traced_samples_per_axis: (args.traced_samples > 0).then_some(args.traced_samples),
        analytic: !args.no_analytic,
        camera_only: !args.no_camera_only,
        reference_cache: args.reference_cache.clone(),
        // Each run names its own path (`RunSpec::path`).
        path: None,
    };
    check_paths(&specs, &options)?;
    Ok((specs, options, view))
}

/// Runs along a path need their exact answers, and each path must fit its scene: checked here,
/// before any GPU work.
fn check_paths(specs: &[RunSpec], options: &BenchOptions) -> Result<()> {
    if specs.iter().any(|s| s.path.is_some())
        && (!options.error || options.exact_samples_per_axis.is_none())
    {
        bail!(
            "--path measures every frame against its exact answer: drop --no-error and --no-exact"
        );
    }
    let mut checked: Vec<(&str, &str)> = Vec::new();
    for spec in specs {
        let Some(path) = &spec.path else { continue };
        if checked.contains(&(spec.scene.as_str(), path.as_str())) {
            continue;
        }
        checked.push((&spec.scene, path));
        let mut loaded = softshadow_scenes::load(&spec.scene)?;
        softshadow_scenes::path::resolve(path, &mut loaded.scene, &loaded.paths)
            .with_context(|| format!("scene `{}`, path `{path}`", spec.scene))?;
    }
    Ok(())
}

/// Makes the plan's runs (in this process on `gpu`, or each in its own on the adapter it
/// names), with a progress bar and Ctrl-C stopping cleanly.
fn execute(plan: &Plan, device: Device, control: &BuildControl) -> Result<Results> {
    // Bars on stderr (indicatif draws nothing when it is not a terminal): the runs, and below
    // them the progress of a long precompute while one builds.
    let bars = MultiProgress::new();
    let progress = bars.add(ProgressBar::new(plan.indexed.len() as u64));
    progress.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {elapsed_precise} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    progress.set_position(plan.finished.len() as u64);
    interrupt_on_ctrl_c(control, &bars, plan.isolate.is_some())?;
    let setup = RunSetup {
        registry: plan.registry.clone(),
        command: plan.command.clone(),
        program: program_name(),
        sweep: plan.sweep.clone(),
        timing: plan.timing,
        camera: plan.view.0,
        light: plan.view.1,
        build_control: Some(control.clone()),
    };
    let on_run = |_: usize, run: &Run| {
        progress.set_message(format!("{} / {}", run.scene, run.technique));
        progress.inc(1);
        if run.status != Status::Ok {
            progress.println(format!(
                "run {} {}: {} / {}: {}",
                run.index, run.status, run.scene, run.technique, run.message
            ));
        }
    };
    let (indexed, finished, options) = (&plan.indexed, plan.finished.clone(), plan.options.clone());
    let all_done = AtomicBool::new(false);
    let results = std::thread::scope(|scope| {
        scope.spawn(|| watch_builds(control, &bars, &all_done));
        let results = match device {
            Device::Here(gpu) => softshadow_bench::run_resumed(
                gpu, indexed, setup, options, &plan.out, finished, on_run,
            ),
            Device::PerRun(adapter) => softshadow_bench::run_isolated(
                &child_command(&plan.args, plan.isolate.flatten(), adapter)?,
                indexed,
                setup,
                options,
                &plan.out,
                finished,
                on_run,
            ),
        };
        all_done.store(true, Ordering::Relaxed);
        Ok::<_, anyhow::Error>(results?)
    })?;
    progress.finish_and_clear();
    Ok(results)
}

/// The child every isolated run is made in: this binary's `bench-run`, with the technique files
/// this benchmark registered.
fn child_command(
    args: &BenchArgs,
    run_timeout: Option<Duration>,
    adapter: AdapterSummary,
) -> Result<Isolation> {
    let exe = std::env::current_exe().context("cannot find this program to run each run in")?;
    let mut command = vec![exe.into_os_string(), "bench-run".into()];
    let mut files: Vec<String> = args.technique.iter().cloned().collect();
    if let Some(sweep) = &args.sweep {
        files.extend(Sweep::technique_files(sweep)?);
    }
    for file in files
        .into_iter()
        .filter(|f| softshadow_wgsl::is_technique_file(f))
    {
        command.extend(["--technique-file".into(), file.into()]);
    }
    Ok(Isolation {
        command,
        run_timeout,
        adapter: Some(adapter),
    })
}

/// One line per run: along a path its error and flicker, else its frame time and errors.
fn print_runs(results: &Results) {
    for run in results.runs.iter().filter(|r| r.motion.is_some()) {
        let motion = run.motion.as_ref().expect("filtered");
        println!(
            "{:<24} {:<16} {:<12} {} frames: error mean {:.4} max {:.4}, flicker mean {}, frame median {} ms{}",
            run.scene,
            run.technique,
            motion.path,
            motion.frames,
            motion.error.mean,
            motion.error.max,
            motion.flicker.as_ref().map_or("-".into(), |f| format!("{:.5}", f.mean)),
            run.timing
                .as_ref()
                .and_then(|t| t.frame_ms.as_ref())
                .map_or("-".into(), |f| format!("{:.2}", f.median)),
            motion.lag.as_ref().map_or(String::new(), |l| format!(", lag {:+.4}", l.extra_error)),
        );
    }
    for run in results.runs.iter().filter(|r| r.motion.is_none()) {
        let frame = run
            .timing
            .as_ref()
            .and_then(|t| {
                Some(format!(
                    "{:.2} ms {}",
                    t.frame_ms.as_ref()?.median,
                    t.source
                ))
            })
            .unwrap_or_else(|| "-".to_string());
        let err = run
            .error
            .as_ref()
            .map_or("-".to_string(), |e| format!("{:.4}", e.report.mae_shadowed));
        let exact = run
            .error
            .as_ref()
            .and_then(|e| e.vs_exact.as_ref())
            .map_or("-".to_string(), |r| format!("{:.4}", r.mae_all));
        let invalid = run
            .stability
            .as_ref()
            .map_or(0, |s| s.nan + s.inf + s.out_of_range);
        println!(
            "{:<24} {:<16} {:<7} frame {:>20}  mae_shadowed {:<7} exact mae_all {:<7} invalid {}",
            run.scene, run.technique, run.status, frame, err, exact, invalid
        );
    }
}

/// Ctrl-C stops the benchmark cleanly: no further run starts and results.json holds the runs
/// done. In one process a long precompute stops at its next unit (its run fails with
/// "cancelled" and is left out); an isolated run's process is killed at once and its run left
/// out. A second Ctrl-C quits at once without writing results.json.
fn interrupt_on_ctrl_c(control: &BuildControl, bars: &MultiProgress, isolated: bool) -> Result<()> {
    let control = control.clone();
    let bars = bars.clone();
    let message = if isolated {
        "interrupted: the current run is stopped and left out (`--resume` makes it again); \
         Ctrl-C again quits without writing results.json"
    } else {
        "interrupted: stopping after the current run (a precompute stops at once); \
         Ctrl-C again quits without writing results.json"
    };
    ctrlc::set_handler(move || {
        if control.is_cancelled() {
            std::process::exit(130);
        }
        control.cancel();
        if bars.println(message).is_err() || bars.is_hidden() {
            eprintln!("{message}");
        }
    })
    .context("cannot install the Ctrl-C handler")
}

/// Shows a bar of a long precompute while one runs, in the units its technique counts (polls
/// `control` until `finished`).
fn watch_builds(control: &BuildControl, bars: &MultiProgress, finished: &AtomicBool) {
    let style = ProgressStyle::with_template("precompute {bar:30} {pos}/{len} {msg} {elapsed}")
        .unwrap_or_else(|_| ProgressStyle::default_bar());
    let mut bar: Option<ProgressBar> = None;
    while !finished.load(Ordering::Relaxed) {
        match (control.progress_with_unit(), &bar) {
            (Some(p), Some(b)) => {
                b.set_length(p.total.into());
                b.set_position(p.done.into());
                b.set_message(p.unit.to_string());
            }
            (Some(p), None) => {
                let b = bars.add(ProgressBar::new(p.total.into()).with_style(style.clone()));
                b.set_position(p.done.into());
                b.set_message(p.unit.to_string());
                bar = Some(b);
            }
            (None, Some(b)) => {
                b.finish_and_clear();
                bars.remove(b);
                bar = None;
            }
            (None, None) => {}
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    if let Some(b) = bar {
        b.finish_and_clear();
        bars.remove(&b);
    }
}

/// `workbench bench-run`: makes the one run of the [`Job`] on stdin, in this process, and
/// writes its [`Run`] as JSON on stdout. Started by `bench` for every isolated run.
pub(crate) fn bench_run(registry: &Registry, technique_files: &[String]) -> Result<ExitCode> {
    softshadow_bench::isolate::die_with_parent();
    let mut input = String::new();
    std::io::stdin()
        .read_to_string(&mut input)
        .context("cannot read the run on stdin")?;
    let job: Job = serde_json::from_str(&input).context(
        "`bench-run` reads a run as JSON on stdin: `workbench bench` starts it, not a user",
    )?;
    let mut registry = registry.clone();
    register_technique_files(&mut registry, technique_files)?;
    let run = softshadow_bench::isolate::run_job(registry, &job);
    println!("{}", serde_json::to_string(&run)?);
    Ok(ExitCode::SUCCESS)
}
