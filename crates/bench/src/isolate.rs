//! Each run of a sweep in a process of its own (`bench --isolate`, the default for sweeps;
//! docs/STABILITY.md, "Isolated runs"): a run that never ends is killed at its time limit and
//! recorded `timeout`, a process that crashes (a signal, an abort in a driver, a panic) is
//! recorded `crashed`, and the sweep goes on with a fresh process and device.
//!
//! The parent writes a [`Job`] as JSON to the child's stdin; the child (`workbench bench-run`,
//! [`run_job`]) makes the run on a device of its own and writes the [`Run`] as JSON to its
//! stdout. The parent does no GPU work. The reference images, the dearest part of most runs,
//! are shared through a reference cache ([`crate::reference_cache`]): the user's
//! `--reference-cache`, else a private one in the output folder ([`PRIVATE_CACHE_DIR`]) that is
//! removed when the sweep is done and whose use is not recorded, so the results read as a sweep
//! in one process would write them.

use std::{
    collections::VecDeque,
    ffi::OsString,
    io::{BufRead, Read, Write},
    path::PathBuf,
    process::{Child, Command, ExitStatus, Stdio},
    thread,
    time::{Duration, Instant},
};

use serde::{Deserialize, Serialize};
use softshadow_core::{
    cost::rates, AreaLight, Camera, Gpu, ParamValue, Registry, TechniqueInfo, TimingSource,
};

use crate::{
    reference_cache::ReferenceCacheUse, resolve_technique, results::ProcessRecord, Bench,
    BenchOptions, Run, RunSpec, Status,
};

/// The private reference cache of an isolated sweep without `--reference-cache`, in its output
/// folder.
pub const PRIVATE_CACHE_DIR: &str = "reference-cache.isolated";

/// A run's default time limit is this many times its predicted time ([`predicted_seconds`])...
pub const LIMIT_FACTOR: f64 = 20.0;
/// ...and at least this: a process start, a device and a reference cost seconds whatever the
/// cost model says.
pub const MIN_LIMIT: Duration = Duration::from_secs(60);

/// Seconds per camera pixel of a frame's own passes (G-buffer, shading, readback), which no
/// technique's model counts: lavapipe, release build, 2 cores, rounded up.
const FRAME_PIXEL: f64 = 50e-9;
/// Seconds per camera pixel of the error metrics (FLIP, the exact answer's closed form or ray
/// cast): likewise.
const ERROR_PIXEL: f64 = 2e-6;

/// How often the parent looks at its child (exit, time limit, Ctrl-C).
const POLL: Duration = Duration::from_millis(10);

/// Lines of a child's stderr kept to explain how it ended.
const STDERR_LINES: usize = 40;

/// The environment variable that tells a child its parent's process id ([`die_with_parent`]).
pub const PARENT_ENV: &str = "SOFTSHADOW_BENCH_PARENT";

/// Everything a child needs to make one run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Job {
    /// The run's index in the sweep.
    pub index: usize,
    pub spec: RunSpec,
    pub options: BenchOptions,
    pub timing: Option<TimingSource>,
    pub camera: Option<Camera>,
    pub light: Option<AreaLight>,
    pub out_dir: PathBuf,
}

/// In the child: makes `job`'s run on a new device, as [`Bench::run`] would in one process.
/// Never fails: a device that cannot be made is that run's error.
pub fn run_job(registry: Registry, job: &Job) -> Run {
    let made = Gpu::new_headless()
        .map_err(crate::BenchError::from)
        .and_then(|gpu| Bench::new(gpu, registry, job.options.clone()));
    match made {
        Ok(mut bench) => {
            bench.set_timing(job.timing);
            bench.set_view(job.camera, job.light);
            bench.run(job.index, &job.spec, &job.out_dir)
        }
        Err(e) => Run::failed(job.index, &job.spec, Status::Error, e.to_string()),
    }
}

/// In the child, first thing: ends this process when its parent ends (Linux: the parent's
/// death sends it `SIGKILL`), so a killed sweep leaves no run behind it. Elsewhere a child
/// outlives a killed parent until its run ends or it is killed.
pub fn die_with_parent() {
    #[cfg(target_os = "linux")]
    {
        use nix::{sys::prctl, sys::signal::Signal, unistd::getppid};
        let _ = prctl::set_pdeathsig(Signal::SIGKILL);
        // The parent may have ended before the line above took effect.
        let parent = std::env::var(PARENT_ENV).ok().and_then(|p| p.parse().ok());
        if parent.is_some_and(|parent: i32| getppid().as_raw() != parent) {
            std::process::exit(1);
        }
    }
}

/// How the parent runs each run in a child.
#[derive(Clone, Debug)]
pub struct Isolation {
    /// Program and arguments of the child, which reads a [`Job`] on stdin and writes its
    /// [`Run`] on stdout (`[current_exe, "bench-run"]` for the workbench).
    pub command: Vec<OsString>,
    /// Time limit of every run; `None`: each run's from the cost model ([`time_limit`]).
    pub run_timeout: Option<Duration>,
    /// The adapter the children pick, when the caller has asked already
    /// ([`Gpu::headless_adapter_summary`]); `None`: asked before the first run.
    pub adapter: Option<softshadow_core::gpu::AdapterSummary>,
}

/// How a child ended.
enum Ended {
    Exited(ExitStatus),
    TimedOut,
    Cancelled,
}

impl Isolation {
    /// Makes `job`'s run in a child with time limit `limit`; `None` when `cancelled` turned true
    /// first (the child is killed and the run left out, so a resume makes it again).
    pub fn run(&self, job: &Job, limit: Duration, cancelled: impl Fn() -> bool) -> Option<Run> {
        let start = Instant::now();
        let mut child = match self.spawn() {
            Ok(child) => child,
            Err(e) => {
                let program = self.command.first().cloned().unwrap_or_default();
                let message = format!(
                    "cannot start the run's process `{}`: {e}",
                    program.to_string_lossy()
                );
                return Some(Run::failed(job.index, &job.spec, Status::Crashed, message));
            }
        };
        let stdout = read_all(child.stdout.take());
        let stderr = read_tail(child.stderr.take());
        if let Some(mut stdin) = child.stdin.take() {
            // A child that ended at once leaves the pipe closed: its exit says why.
            let json = serde_json::to_vec(job).unwrap_or_default();
            let _ = stdin.write_all(&json);
        }
        let ended = wait(&mut child, limit, &cancelled);
        let stdout = stdout.join().unwrap_or_default();
        let stderr = stderr.join().unwrap_or_default();
        let ended = match ended {
            Ok(Ended::Cancelled) => return None,
            Ok(ended) => ended,
            Err(e) => {
                let message = format!("lost track of the run's process: {e}");
                return Some(Run::failed(job.index, &job.spec, Status::Crashed, message));
            }
        };
        let mut run = outcome(job, ended, &stdout, &stderr, limit);
        run.process = Some(ProcessRecord {
            wall_s: start.elapsed().as_secs_f64(),
            limit_s: limit.as_secs_f64(),
            ..run.process.take().unwrap_or_default()
        });
        Some(run)
    }

    fn spawn(&self) -> std::io::Result<Child> {
        let (program, args) = self.command.split_first().ok_or_else(|| {
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "no program given")
        })?;
        let mut command = Command::new(program);
        command
            .args(args)
            .env(PARENT_ENV, std::process::id().to_string())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        #[cfg(unix)]
        {
            // Its own process group: Ctrl-C in the terminal reaches the parent only, which
            // then stops the child itself and leaves its run out.
            std::os::unix::process::CommandExt::process_group(&mut command, 0);
        }
        command.spawn()
    }
}

/// Waits for `child` until it exits, `limit` passes (it is killed) or `cancelled` (likewise).
fn wait(
    child: &mut Child,
    limit: Duration,
    cancelled: &dyn Fn() -> bool,
) -> std::io::Result<Ended> {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait()? {
            return Ok(Ended::Exited(status));
        }
        let ended = if cancelled() {
            Ended::Cancelled
        } else if start.elapsed() >= limit {
            Ended::TimedOut
        } else {
            thread::sleep(POLL);
            continue;
        };
        child.kill()?;
        child.wait()?;
        return Ok(ended);
    }
}

/// The run a child's end makes: its own [`Run`] when it wrote one, else a `timeout` or
/// `crashed` run saying how it ended.
fn outcome(job: &Job, ended: Ended, stdout: &str, stderr: &[String], limit: Duration) -> Run {
    let why = last_words(stderr)
        .map(|line| format!("; its last words: {line}"))
        .unwrap_or_default();
    let status = match ended {
        Ended::TimedOut => {
            let message = format!(
                "stopped at its time limit of {:.0} s{why}; give it longer with --run-timeout SECONDS",
                limit.as_secs_f64()
            );
            return Run::failed(job.index, &job.spec, Status::Timeout, message);
        }
        Ended::Exited(status) => status,
        Ended::Cancelled => unreachable!("handled by the caller"),
    };
    if status.success() {
        // The run is the last line: anything a library printed before it is not.
        let last = stdout.lines().rev().find(|line| !line.trim().is_empty());
        match serde_json::from_str::<Run>(last.unwrap_or_default()) {
            Ok(run) if run.index == job.index => return run,
            Ok(run) => {
                let message = format!("the run's process answered for run {}", run.index);
                return Run::failed(job.index, &job.spec, Status::Crashed, message);
            }
            Err(e) => {
                let message = format!("the run's process wrote no result ({e}){why}");
                return Run::failed(job.index, &job.spec, Status::Crashed, message);
            }
        }
    }
    let (how, signal) = match signal_of(status) {
        Some((number, name)) => {
            let hint = if name == "SIGKILL" {
                " (not by this benchmark: the system may have run out of memory)"
            } else {
                ""
            };
            (
                format!("was killed by signal {number} ({name}){hint}"),
                Some(name),
            )
        }
        None => (format!("ended with {status}"), None),
    };
    let mut run = Run::failed(
        job.index,
        &job.spec,
        Status::Crashed,
        format!("the run's process {how}{why}"),
    );
    run.process = Some(ProcessRecord {
        signal,
        exit_code: status.code(),
        ..ProcessRecord::default()
    });
    run
}

/// The signal that ended a process, with its name.
fn signal_of(status: ExitStatus) -> Option<(i32, String)> {
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        let number = status.signal()?;
        let name = nix::sys::signal::Signal::try_from(number)
            .map_or_else(|_| format!("signal {number}"), |s| s.as_str().to_string());
        Some((number, name))
    }
    #[cfg(not(unix))]
    {
        let _ = status;
        None
    }
}

/// The line of a child's stderr that best says why it ended: a panic's message, else the last
/// line that is not a hint of Rust's.
pub fn last_words(stderr: &[String]) -> Option<String> {
    let panic = stderr
        .iter()
        .rposition(|line| line.contains("panicked at"))
        .map(|k| {
            let message = stderr.get(k + 1).map(String::as_str).unwrap_or_default();
            format!("{} {message}", stderr[k].trim())
        });
    let line = panic.or_else(|| {
        stderr
            .iter()
            .rev()
            .map(|line| line.trim())
            .find(|line| !line.is_empty() && !line.starts_with("note:"))
            .map(str::to_string)
    })?;
    Some(line.chars().take(400).collect())
}

/// Reads a child's stdout to its end on a thread of its own (a full pipe would block the child).
fn read_all(pipe: Option<impl Read + Send + 'static>) -> thread::JoinHandle<String> {
    thread::spawn(move || {
        let mut text = String::new();
        if let Some(mut pipe) = pipe {
            let _ = pipe.read_to_string(&mut text);
        }
        text
    })
}

/// Reads a child's stderr to its end, keeping the last [`STDERR_LINES`] lines.
fn read_tail(pipe: Option<impl Read + Send + 'static>) -> thread::JoinHandle<Vec<String>> {
    thread::spawn(move || {
        let mut tail = VecDeque::new();
        if let Some(pipe) = pipe {
            for line in std::io::BufReader::new(pipe).lines() {
                let Ok(line) = line else { break };
                if tail.len() == STDERR_LINES {
                    tail.pop_front();
                }
                tail.push_back(line);
            }
        }
        tail.into()
    })
}

/// The time limit of `spec`'s run: [`LIMIT_FACTOR`] times [`predicted_seconds`], at least
/// [`MIN_LIMIT`].
pub fn time_limit(registry: &Registry, spec: &RunSpec, options: &BenchOptions) -> Duration {
    let predicted = predicted_seconds(registry, spec, options);
    Duration::from_secs_f64((LIMIT_FACTOR * predicted).max(MIN_LIMIT.as_secs_f64()))
}

/// What `spec`'s run should take by its technique's cost model (and the reference's, with error
/// metrics): the frames it renders times the model's time of one frame. A technique without a
/// model costs [`rates::FRAME`] a frame.
pub fn predicted_seconds(registry: &Registry, spec: &RunSpec, options: &BenchOptions) -> f64 {
    let pixels = f64::from(spec.width) * f64::from(spec.height);
    // A model estimates two frames (the full work and one with the camera moved) from every
    // parameter: the defaults fill in those not given.
    let frame = |info: &TechniqueInfo, given: &[(String, ParamValue)]| {
        let params: Vec<(String, ParamValue)> = info
            .params
            .iter()
            .map(|spec| {
                let value = given.iter().find(|(name, _)| *name == spec.name);
                let value = value.map_or_else(|| spec.default_value(), |(_, v)| v.clone());
                (spec.name.to_string(), value)
            })
            .collect();
        info.cost.estimate(&params, pixels).seconds / 2.0 + rates::FRAME + pixels * FRAME_PIXEL
    };
    let technique = resolve_technique(registry, &spec.technique)
        .map_or(rates::FRAME, |info| frame(&info, &spec.params));
    let camera_only = u32::from(options.camera_only);
    let frames = if spec.path.is_some() || options.path.is_some() {
        options.frames + 1
    } else {
        // Cold frame and warm-up, camera-only frames and the one that builds them, the timed
        // frames, a calibration frame and the still frame after them.
        options.warmup.max(1) + (options.frames + 1) * camera_only + options.frames + 2
    };
    let error = match registry.yardstick() {
        Ok(info) if options.error => frame(info, &options.reference_params) + pixels * ERROR_PIXEL,
        _ => 0.0,
    };
    technique * f64::from(frames) + error
}

/// Forgets what a run of an isolated sweep says of the private reference cache
/// ([`PRIVATE_CACHE_DIR`]): a sweep in one process has none.
pub fn forget_private_cache(run: &mut Run) {
    if let Some(ReferenceCacheUse::Rebuilt(why) | ReferenceCacheUse::NotStored(why)) =
        run.reference_cache.take()
    {
        run.warnings.retain(|w| w != &why);
    }
    if let Some(motion) = &mut run.motion {
        motion.exact_cache = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(technique: &str, size: u32) -> RunSpec {
        RunSpec {
            scene: "atty-square".into(),
            technique: technique.into(),
            params: Vec::new(),
            width: size,
            height: size,
            path: None,
        }
    }

    #[test]
    fn time_limits_follow_the_cost_model_and_keep_a_minute() {
        let registry = softshadow::registry();
        let options = BenchOptions::default();
        let without_error = BenchOptions {
            error: false,
            ..options.clone()
        };
        // A small run of a cheap technique without the reference gets the floor.
        assert!(predicted_seconds(&registry, &spec("hard", 32), &without_error) < 2.0);
        let limit = time_limit(&registry, &spec("hard", 32), &without_error);
        assert_eq!(limit, MIN_LIMIT);
        // The default 32 x 32-sample reference at 1024² maps alone is predicted at about
        // 1024 x 1024² x 12 ns = 12.9 s: twenty times that is above the floor.
        let predicted = predicted_seconds(&registry, &spec("hard", 32), &options);
        assert!(predicted > 12.0, "{predicted}");
        let limit = time_limit(&registry, &spec("hard", 32), &options);
        assert!(limit.as_secs_f64() > LIMIT_FACTOR * 12.0, "{limit:?}");
        // Every frame's own passes grow with the image.
        let big = predicted_seconds(&registry, &spec("hard", 8192), &without_error);
        assert!(big > 10.0 * predicted_seconds(&registry, &spec("hard", 32), &without_error));
    }

    fn lines(text: &str) -> Vec<String> {
        text.lines().map(str::to_string).collect()
    }

    #[test]
    fn the_last_words_of_a_panic_are_its_message() {
        let stderr = lines(
            "warning: slow\nthread 'main' panicked at src/lib.rs:3:5:\nindex out of bounds\nnote: run with `RUST_BACKTRACE=1`",
        );
        assert_eq!(
            last_words(&stderr).as_deref(),
            Some("thread 'main' panicked at src/lib.rs:3:5: index out of bounds")
        );
        let stderr = lines("wgpu device lost (Unknown): Device lost\n\n");
        assert_eq!(
            last_words(&stderr).as_deref(),
            Some("wgpu device lost (Unknown): Device lost")
        );
        assert_eq!(last_words(&[]), None);
    }
}
