//! A sweep survives what breaks (docs/STABILITY.md, "Faults", "Isolated runs"): faults injected
//! with `SOFTSHADOW_FAULT` into chosen runs are recorded with their cause and every other run
//! comes out as in a clean sweep; a sweep killed with SIGKILL at random moments and resumed each
//! time ends as a clean sweep; an output folder that is read-only or too small is refused before
//! the first run. Everything runs the real workbench binary.

use std::{
    path::{Path, PathBuf},
    process::{Command, Output, Stdio},
    time::Duration,
};

use anyhow::{ensure, Context, Result};
use serde_json::Value;

/// Six runs at 32²: four of `hard` and two of `pcss`, against a 4 x 4-sample reference (the
/// default 32 x 32 would be most of the test's time).
const SWEEP: &str = r#"
size = "32x32"
frames = 1
warmup = 1
scenes = ["atty-square"]
[reference]
samples_per_axis = 4
[[technique]]
id = "hard"
params = { shadow_map_size = [64, 128, 256, 512] }
[[technique]]
id = "pcss"
params = { shadow_map_size = [256, 512] }
"#;

/// Time limit of each isolated run in the fault sweep: the hanging run costs the test this
/// long; every other run takes a few seconds even on a loaded 2-core machine.
const RUN_TIMEOUT: &str = "20";

fn workbench() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_workbench"));
    // With SOFTSHADOW_GPU_ERRORS=panic (CI) the first GPU error a fault causes would panic in
    // the run instead of being recorded: these runs are the user's, without it.
    command.env_remove("SOFTSHADOW_GPU_ERRORS");
    command.env_remove("SOFTSHADOW_FAULT");
    command
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The workbench's own lines of stderr: without the log lines of wgpu's adapter search
/// (`[date ERROR wgpu_hal...]`) and Mesa's, which come before any check that needs no GPU.
fn error_lines(o: &Output) -> Vec<String> {
    stderr(o)
        .lines()
        .filter(|l| l.starts_with("error:"))
        .map(str::to_string)
        .collect()
}

fn write_sweep(dir: &Path) -> Result<PathBuf> {
    let path = dir.join("sweep.toml");
    std::fs::write(&path, SWEEP)?;
    Ok(path)
}

/// Runs `bench --sweep SWEEP --out OUT` plus `extra`, with `faults` in `SOFTSHADOW_FAULT`.
fn bench(sweep: &Path, out: &Path, extra: &[&str], faults: Option<&str>) -> Result<Output> {
    let mut command = workbench();
    command
        .args(["bench", "--no-camera-only", "--sweep"])
        .arg(sweep)
        .arg("--out")
        .arg(out)
        .args(extra);
    if let Some(faults) = faults {
        command.env("SOFTSHADOW_FAULT", faults);
    }
    Ok(command.output()?)
}

fn results(out: &Path) -> Result<Value> {
    let text = std::fs::read_to_string(out.join("results.json"))
        .with_context(|| format!("{} has no results.json", out.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}/results.json", out.display()))
}

fn runs(v: &Value) -> Result<&Vec<Value>> {
    v["runs"].as_array().context("no runs")
}

/// Whether two JSON values are equal, numbers within 1e-6.
fn close(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (
                x.as_f64().unwrap_or(f64::NAN),
                y.as_f64().unwrap_or(f64::NAN),
            );
            (x - y).abs() <= 1e-6
        }
        (Value::Array(x), Value::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(x, y)| close(x, y))
        }
        (Value::Object(x), Value::Object(y)) => {
            x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| close(v, w)))
        }
        _ => a == b,
    }
}

/// Run `run` is ok and measured what the clean sweep's run of its index measured.
fn same_as_clean(run: &Value, clean: &[Value]) -> Result<()> {
    let index = run["index"].as_u64().context("index")? as usize;
    let clean = &clean[index];
    ensure!(run["status"] == "ok", "run {index}: {run}");
    for field in [
        "scene",
        "technique",
        "params",
        "error",
        "stability",
        "still_flicker",
    ] {
        ensure!(
            !clean[field].is_null() || field == "still_flicker",
            "the clean run {index} has no {field}"
        );
        ensure!(
            close(&run[field], &clean[field]),
            "run {index}: {field} {} differs from the clean sweep's {}",
            run[field],
            clean[field]
        );
    }
    Ok(())
}

fn message(run: &Value) -> &str {
    run["message"].as_str().unwrap_or_default()
}

#[test]
fn every_fault_is_recorded_with_its_cause_and_the_other_runs_match_a_clean_sweep() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let sweep = write_sweep(dir.path())?;
    // The clean sweep in one process: also what isolated runs must reproduce.
    let clean_out = dir.path().join("clean");
    let o = bench(&sweep, &clean_out, &["--no-images", "--no-isolate"], None)?;
    ensure!(o.status.success(), "clean sweep: {}", stderr(&o));
    let clean = results(&clean_out)?;
    let clean = runs(&clean)?;
    ensure!(clean.len() == 6, "{} clean runs", clean.len());

    // Isolated (the default for a sweep): each fault once, runs 0 and 5 clean.
    let out = dir.path().join("isolated");
    let faults = "lost:1,oom:2,hang:3,crash:4";
    let extra = ["--no-images", "--run-timeout", RUN_TIMEOUT];
    let o = bench(&sweep, &out, &extra, Some(faults))?;
    ensure!(
        o.status.code() == Some(3),
        "exit {:?}: {}",
        o.status,
        stderr(&o)
    );
    let v = results(&out)?;
    let got = runs(&v)?;
    ensure!(got.len() == 6, "{} runs: {v}", got.len());
    same_as_clean(&got[0], clean)?;
    same_as_clean(&got[5], clean)?;
    check_lost_and_oom(got)?;
    ensure!(got[3]["status"] == "timeout", "{}", got[3]);
    ensure!(
        message(&got[3]).contains("time limit of 20 s"),
        "{}",
        got[3]
    );
    ensure!(got[3]["process"]["limit_s"] == 20.0, "{}", got[3]);
    ensure!(got[4]["status"] == "crashed", "{}", got[4]);
    ensure!(got[4]["process"]["signal"] == "SIGABRT", "{}", got[4]);
    ensure!(
        message(&got[4]).contains("signal 6 (SIGABRT)"),
        "{}",
        got[4]
    );
    // The private reference cache of an isolated sweep is gone once it is done.
    ensure!(!out.join("reference-cache.isolated").exists());

    // In one process: the lost device is replaced and the sweep goes on.
    let out = dir.path().join("in-process");
    let o = bench(
        &sweep,
        &out,
        &["--no-images", "--no-isolate"],
        Some("lost:1,oom:2"),
    )?;
    ensure!(
        o.status.code() == Some(3),
        "exit {:?}: {}",
        o.status,
        stderr(&o)
    );
    let v = results(&out)?;
    let got = runs(&v)?;
    ensure!(got.len() == 6, "{} runs: {v}", got.len());
    check_lost_and_oom(got)?;
    for k in [0, 3, 4, 5] {
        same_as_clean(&got[k], clean)?;
    }
    Ok(())
}

/// Run 1 lost its device and says so with the driver's word; run 2's allocation failed.
fn check_lost_and_oom(runs: &[Value]) -> Result<()> {
    ensure!(runs[1]["status"] == "error", "{}", runs[1]);
    ensure!(
        message(&runs[1]).contains("GPU device was lost during this run: the device was destroyed"),
        "{}",
        runs[1]
    );
    ensure!(runs[2]["status"] == "error", "{}", runs[2]);
    ensure!(message(&runs[2]).contains("out of memory"), "{}", runs[2]);
    Ok(())
}

/// Kills of the soak, as the issue asks: each at a random moment in the first third of the time
/// a clean run of the sweep (8 isolated `hard` runs at 16², a few seconds) took, resumed after
/// every kill. The moments, spread over whole runs, land in every phase of a run (process start,
/// device, frames, reference, results.json); twenty of them cost about ten seconds.
const KILLS: usize = 20;

/// A small deterministic generator for the kill moments (SplitMix64).
fn next_random(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[test]
fn a_sweep_killed_at_random_moments_and_resumed_ends_as_a_clean_sweep() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let sweep = dir.path().join("soak.toml");
    std::fs::write(
        &sweep,
        "size = \"16x16\"\nframes = 1\nwarmup = 1\nscenes = [\"atty-square\", \"stiff-fusion\"]\n\
         [reference]\nsamples_per_axis = 2\n[[technique]]\nid = \"hard\"\n\
         params = { shadow_map_size = [64, 128, 256, 512] }\n",
    )?;
    let clean_out = dir.path().join("clean");
    let start = std::time::Instant::now();
    let o = bench(&sweep, &clean_out, &[], None)?;
    // Only to place the kills (never asserted).
    let sweep_ms = start.elapsed().as_millis() as u64;
    ensure!(o.status.success(), "clean sweep: {}", stderr(&o));
    let clean = results(&clean_out)?;
    let total = runs(&clean)?.len();
    let mut interrupted = 0;

    let out = dir.path().join("killed");
    let mut state = 42;
    for kill in 0..KILLS {
        let mut command = workbench();
        if out.join("bench-args.json").is_file() {
            command.args(["bench", "--resume"]).arg(&out);
        } else {
            // Killed before it saved its arguments: start it again, as a user would.
            command
                .args(["bench", "--no-camera-only", "--sweep"])
                .arg(&sweep)
                .arg("--out")
                .arg(&out);
        }
        let mut child = command
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()?;
        let moment = Duration::from_millis(next_random(&mut state) % (sweep_ms / 3).max(1));
        std::thread::sleep(moment);
        child.kill()?; // SIGKILL
        child.wait()?;
        let mut held = 0;
        if out.join("results.json").exists() {
            let v = results(&out).with_context(|| format!("after kill {kill} at {moment:?}"))?;
            for run in runs(&v)? {
                same_as_clean(run, runs(&clean)?)?;
            }
            held = runs(&v)?.len();
        }
        interrupted += usize::from(held < total);
        eprintln!("kill {kill} at {moment:?}: results.json holds {held} runs");
    }
    ensure!(interrupted > 0, "no kill came before the sweep's end");
    let o = workbench().args(["bench", "--resume"]).arg(&out).output()?;
    ensure!(o.status.success(), "final resume: {}", stderr(&o));
    let v = results(&out)?;
    let (got, clean) = (runs(&v)?, runs(&clean)?);
    ensure!(
        got.len() == clean.len(),
        "{} runs of {}",
        got.len(),
        clean.len()
    );
    for run in got {
        same_as_clean(run, clean)?;
    }
    Ok(())
}

#[test]
fn an_output_folder_without_room_is_refused_before_the_first_run() -> Result<()> {
    let dir = tempfile::tempdir()?;
    // 4 scenes x 64 x 256 settings of 8192² images: about 40 TB of images, more than any disk.
    let sweep = dir.path().join("huge.toml");
    std::fs::write(
        &sweep,
        "size = \"8192x8192\"\nscenes = [\"atty-square\", \"stiff-fusion\", \"stiff-contact\", \"stiff-grazing\"]\n\
         [[technique]]\nid = \"pcss\"\n\
         params = { blocker_samples = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 47, 48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59, 60, 61, 62, 63, 64], filter_samples = [",
    )?;
    let mut text = std::fs::read_to_string(&sweep)?;
    text.push_str(
        &(1..=256)
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(", "),
    );
    text.push_str("] }\n");
    std::fs::write(&sweep, text)?;
    let out = dir.path().join("out");
    let o = workbench()
        .args(["bench", "--sweep"])
        .arg(&sweep)
        .arg("--out")
        .arg(&out)
        .output()?;
    let err = stderr(&o);
    ensure!(o.status.code() == Some(2), "exit {:?}: {err}", o.status);
    ensure!(error_lines(&o).len() == 1, "{err}");
    ensure!(
        err.contains("MiB free, but this benchmark's results and images need about"),
        "{err}"
    );
    ensure!(!out.exists(), "a refused benchmark left {}", out.display());
    Ok(())
}

#[test]
fn a_read_only_output_folder_is_refused_before_the_first_run() -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir()?;
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755))?;
    let sweep = write_sweep(dir.path())?;
    let out = dir.path().join("read-only");
    std::fs::create_dir(&out)?;
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o555))?;
    // Root writes anywhere: as root, the benchmark runs as `nobody`, as CI's census does.
    let root = std::fs::read_to_string("/proc/self/status")?
        .lines()
        .any(|l| l.starts_with("Uid:") && l.split_whitespace().nth(1) == Some("0"));
    let mut command = if root {
        let mut c = Command::new("setpriv");
        c.args(["--reuid=nobody", "--regid=nogroup", "--clear-groups"])
            .arg(env!("CARGO_BIN_EXE_workbench"));
        c
    } else {
        workbench()
    };
    let o = command
        .args(["bench", "--sweep"])
        .arg(&sweep)
        .arg("--out")
        .arg(&out)
        .output()
        .context("setpriv (util-linux) runs the benchmark as nobody")?;
    let err = stderr(&o);
    ensure!(o.status.code() == Some(2), "exit {:?}: {err}", o.status);
    ensure!(
        error_lines(&o)
            == [format!(
                "error: cannot write `{}`: Permission denied (os error 13). Check the --out folder exists and is writable",
                out.display()
            )],
        "{err}"
    );
    ensure!(
        std::fs::read_dir(&out)?.next().is_none(),
        "it wrote into {}",
        out.display()
    );
    Ok(())
}

#[test]
fn bad_limits_and_fault_switches_are_one_line_before_any_run() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let sweep = write_sweep(dir.path())?;
    let out = dir.path().join("out");
    let cases: [(&[&str], Option<&str>, &str); 4] = [
        (
            &["--run-timeout", "0"],
            None,
            "--run-timeout 0 is not a time",
        ),
        (
            &["--run-timeout", "inf"],
            None,
            "--run-timeout inf is not a time",
        ),
        (
            &["--run-timeout", "5", "--no-isolate"],
            None,
            "--run-timeout limits runs made in processes of their own",
        ),
        (
            &[],
            Some("melt:1"),
            "SOFTSHADOW_FAULT=`melt:1`: `melt` is no fault kind",
        ),
    ];
    for (args, fault, expected) in cases {
        let o = bench(&sweep, &out, args, fault)?;
        let err = stderr(&o);
        ensure!(
            o.status.code() == Some(2),
            "{args:?}: exit {:?}: {err}",
            o.status
        );
        ensure!(
            err.lines().count() == 1 && err.contains(expected),
            "{args:?}: {err}"
        );
        ensure!(!out.exists(), "{args:?} wrote {}", out.display());
    }
    Ok(())
}
