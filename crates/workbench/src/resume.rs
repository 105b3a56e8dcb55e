//! `bench --resume DIR`: a benchmark saves its arguments next to its results.json before the
//! first run (`bench-args.json`), and results.json is rewritten after every run, so an
//! interrupted benchmark can be finished with the same arguments, running only what is missing.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use softshadow_bench::Run;

use crate::BenchArgs;

/// The file in the output folder holding the arguments a benchmark was started with.
pub const ARGS_FILE: &str = "bench-args.json";

/// What an interrupted benchmark left behind.
pub struct Previous {
    /// The arguments it was started with (`out` = the folder being resumed).
    pub args: BenchArgs,
    /// Its finished runs (failed ones included: they finished, with their message).
    pub runs: Vec<Run>,
    /// The sweep hash its results.json recorded, if it ran a sweep.
    pub sweep_hash: Option<String>,
    /// The command line it was started with (recorded in results.json).
    pub command: Vec<String>,
}

/// Writes `out/bench-args.json`: the arguments, with the sweep file and the working folder made
/// absolute so that a resume from another folder reads the same files.
pub fn save(args: &BenchArgs, command: &[String], out: &Path) -> Result<()> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create the output folder `{}`", out.display()))?;
    let absolute = |p: &PathBuf| std::path::absolute(p).unwrap_or_else(|_| p.clone());
    let saved = Saved {
        working_dir: std::env::current_dir().context("cannot read the current folder")?,
        args: BenchArgs {
            sweep: args.sweep.as_ref().map(absolute),
            ..args.clone()
        },
        command: command.to_vec(),
    };
    let json = serde_json::to_vec_pretty(&saved)?;
    softshadow_bench::output::write_atomic(&out.join(ARGS_FILE), &json)?;
    Ok(())
}

/// Reads what the benchmark in `dir` was started with and what it finished.
pub fn load(dir: &Path) -> Result<Previous> {
    let dir =
        std::path::absolute(dir).with_context(|| format!("cannot resolve `{}`", dir.display()))?;
    let args_path = dir.join(ARGS_FILE);
    let text = match std::fs::read_to_string(&args_path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!(
            "cannot resume `{}`: it has no {ARGS_FILE}, so it is not the output folder of a `workbench bench` (or was written by an older workbench); start the benchmark again",
            dir.display()
        ),
        Err(e) => bail!("cannot read `{}`: {e}", args_path.display()),
    };
    let saved: Saved = serde_json::from_str(&text).with_context(|| {
        format!(
            "`{}` is not a benchmark's saved arguments; start the benchmark again",
            args_path.display()
        )
    })?;
    // Relative scene paths in the arguments and sweep file start at the original folder.
    std::env::set_current_dir(&saved.working_dir).with_context(|| {
        format!(
            "cannot resume in `{}`, the folder the benchmark started in",
            saved.working_dir.display()
        )
    })?;
    let (runs, sweep_hash) = if dir.join("results.json").is_file() {
        let loaded = softshadow_bench::merge::load(&dir)?;
        let hash = loaded.results.sweep.map(|s| s.hash);
        (loaded.results.runs, hash)
    } else {
        // Interrupted before its first run finished.
        (Vec::new(), None)
    };
    let mut args = saved.args;
    args.out = Some(dir);
    Ok(Previous {
        args,
        runs,
        sweep_hash,
        command: saved.command,
    })
}

#[derive(serde::Serialize, serde::Deserialize)]
struct Saved {
    working_dir: PathBuf,
    args: BenchArgs,
    #[serde(default)]
    command: Vec<String>,
}
