//! An interrupted sweep keeps its finished runs, and `bench --resume DIR` finishes the rest
//! (docs/STABILITY.md, "Long runs"). Spawns the workbench binary, kills it once the first run is
//! in results.json, resumes, and checks the merged results.

use std::{
    process::{Command, Stdio},
    time::{Duration, Instant},
};

use anyhow::{bail, ensure, Context, Result};
use serde_json::Value;

/// One fast run, then three slow ones (the `reference` technique with many light samples), so
/// the sweep is still running when the first run is written.
const SWEEP: &str = r#"
size = "32x32"
frames = 2
warmup = 0
scenes = ["atty-square"]

[[technique]]
id = "hard"
params = { shadow_map_size = 64 }

[[technique]]
id = "reference"
params = { samples_per_axis = [12, 13, 14], shadow_map_size = 1024 }
"#;

fn results(dir: &std::path::Path) -> Result<Value> {
    let text = std::fs::read_to_string(dir.join("results.json"))?;
    Ok(serde_json::from_str(&text)?)
}

fn indices(v: &Value) -> Vec<u64> {
    v["runs"]
        .as_array()
        .map(|runs| runs.iter().filter_map(|r| r["index"].as_u64()).collect())
        .unwrap_or_default()
}

#[test]
fn a_killed_sweep_keeps_its_finished_runs_and_resume_finishes_the_rest() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(&sweep, SWEEP)?;
    let out = dir.path().join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args([
            "bench",
            "--no-error",
            "--no-images",
            "--no-camera-only",
            "--sweep",
        ])
        .arg(&sweep)
        .arg("--out")
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .context("the workbench binary runs")?;
    // Kill it as soon as results.json holds a run (written atomically after each run).
    let start = Instant::now();
    let killed_with = loop {
        if let Ok(v) = results(&out) {
            if !indices(&v).is_empty() {
                child.kill()?;
                break v;
            }
        }
        if let Some(status) = child.try_wait()? {
            let mut err = String::new();
            std::io::Read::read_to_string(&mut child.stderr.take().context("stderr")?, &mut err)?;
            bail!("the sweep ended ({status}) before it could be interrupted: {err}");
        }
        ensure!(
            start.elapsed() < Duration::from_secs(600),
            "no run was written in 10 minutes"
        );
        std::thread::sleep(Duration::from_millis(5));
    };
    child.wait()?;
    let after_kill = results(&out).context("results.json survives the kill")?;
    let done = indices(&after_kill);
    ensure!(
        !done.is_empty() && done.len() < 4,
        "killed after the first run, results.json holds runs {done:?} of 4"
    );
    ensure!(
        done.starts_with(&indices(&killed_with)),
        "runs {done:?} after the kill, {:?} before",
        indices(&killed_with)
    );

    let o = Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(["bench", "--resume"])
        .arg(&out)
        .output()?;
    ensure!(
        o.status.success(),
        "resume failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let resumed = results(&out)?;
    ensure!(
        indices(&resumed) == [0, 1, 2, 3],
        "after the resume: runs {:?}",
        indices(&resumed)
    );
    ensure!(resumed["sweep"]["hash"] == after_kill["sweep"]["hash"]);
    for run in resumed["runs"].as_array().context("runs")? {
        ensure!(run["status"] == "ok", "{run}");
    }
    // The runs finished before the kill are kept as they were, not run again.
    for (k, run) in after_kill["runs"]
        .as_array()
        .context("runs")?
        .iter()
        .enumerate()
    {
        ensure!(&resumed["runs"][k] == run, "run {k} changed on resume");
    }
    let samples: Vec<u64> = resumed["runs"]
        .as_array()
        .context("runs")?
        .iter()
        .skip(1)
        .filter_map(|r| r["params"]["samples_per_axis"].as_u64())
        .collect();
    ensure!(samples == [12, 13, 14], "{samples:?}");

    // Resuming a finished sweep runs nothing and keeps the results.
    let o = Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(["bench", "--resume"])
        .arg(&out)
        .output()?;
    ensure!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    ensure!(results(&out)?["runs"] == resumed["runs"]);
    Ok(())
}

#[test]
fn resume_of_a_folder_that_is_no_benchmark_says_so() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let o = Command::new(env!("CARGO_BIN_EXE_workbench"))
        .args(["bench", "--resume"])
        .arg(dir.path())
        .output()?;
    let err = String::from_utf8_lossy(&o.stderr);
    ensure!(o.status.code() == Some(2), "{err}");
    ensure!(err.contains("bench-args.json"), "{err}");
    Ok(())
}
