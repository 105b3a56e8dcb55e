//! Combining results.json files: the shards of one sweep (`workbench merge`), or any runs for a
//! report (`workbench report`).
//!
//! Shards of one sweep share `sweep.hash`; shards of different sweeps, or a run present twice,
//! are refused with a message that names the files. Missing shards are a warning, by index.

use std::{
    collections::{BTreeMap, BTreeSet, HashMap},
    path::{Path, PathBuf},
};

use crate::{
    results::{Results, Run, SweepInfo},
    BenchError,
};

/// One results.json and the folder its images are in.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub file: PathBuf,
    pub dir: PathBuf,
    pub results: Results,
}

/// Reads `path`: a results.json file, or a folder that holds one.
pub fn load(path: &Path) -> Result<Loaded, BenchError> {
    let file = if path.is_dir() {
        path.join("results.json")
    } else {
        path.to_path_buf()
    };
    let read_err = |message: String| BenchError::Read {
        path: file.display().to_string(),
        message,
    };
    let text = std::fs::read_to_string(&file).map_err(|e| {
        read_err(format!(
            "{e}: give a benchmark output folder or its results.json"
        ))
    })?;
    let results: Results = serde_json::from_str(&text).map_err(|e| {
        read_err(format!(
            "not a results.json this workbench can read ({e}); schema versions 2 and {} are read",
            crate::results::SCHEMA_VERSION
        ))
    })?;
    let dir = file
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    Ok(Loaded { file, dir, results })
}

/// Runs of several results.json files, checked and in order.
#[derive(Clone, Debug)]
pub struct Merged {
    /// The merged runs (a sweep's runs by sweep index, other files' runs after, in input order).
    pub results: Results,
    /// Folder of each run's images, parallel to `results.runs`.
    pub run_dirs: Vec<PathBuf>,
    /// Missing shards, differing adapters.
    pub warnings: Vec<String>,
}

fn run_key(run: &Run) -> String {
    let params: Vec<String> = run.params.iter().map(|(n, v)| format!("{n}={v}")).collect();
    format!(
        "{} / {} {}x{} [{}]",
        run.scene,
        run.technique,
        run.width,
        run.height,
        params.join(",")
    )
}

/// Merges `inputs`. Refuses shards of different sweeps (different `sweep.hash`), two splits of
/// one sweep into different shard counts, and runs present twice; warns of missing shards.
pub fn merge(inputs: &[Loaded]) -> Result<Merged, BenchError> {
    if inputs.is_empty() {
        return Err(BenchError::Merge(
            "nothing to merge: give at least one results.json or output folder".into(),
        ));
    }
    let mut warnings = Vec::new();
    let complete_sweep = match shards_of_one_sweep(inputs)? {
        Some((hash, shards)) => complete_sweep(hash, &shards, &mut warnings)?,
        None => None,
    };
    let entries = runs_in_order(inputs)?;
    warnings.extend(adapter_warnings(inputs));
    let all_one_sweep = inputs.iter().all(|l| {
        l.results.sweep.as_ref().map(|s| &s.hash)
            == inputs[0].results.sweep.as_ref().map(|s| &s.hash)
    });
    let sweep = if all_one_sweep {
        complete_sweep.or_else(|| {
            (inputs.len() == 1)
                .then(|| inputs[0].results.sweep.clone())
                .flatten()
        })
    } else {
        None
    };
    let run_dirs = entries.iter().map(|e| e.dir.clone()).collect();
    Ok(Merged {
        results: Results {
            sweep,
            runs: entries.into_iter().map(|e| e.run).collect(),
            ..merged_header(inputs)
        },
        run_dirs,
        warnings,
    })
}

/// The inputs that are shards, by their sweep's hash: none, or the shards of one sweep (shards
/// of different sweeps are refused).
fn shards_of_one_sweep(inputs: &[Loaded]) -> Result<Option<(&str, Vec<&Loaded>)>, BenchError> {
    let shard_hashes: BTreeMap<&str, Vec<&Loaded>> =
        inputs.iter().fold(BTreeMap::new(), |mut m, l| {
            if let Some(sweep) = l.results.sweep.as_ref().filter(|s| s.shard.is_some()) {
                m.entry(sweep.hash.as_str())
                    .or_insert_with(Vec::new)
                    .push(l);
            }
            m
        });
    if shard_hashes.len() > 1 {
        let list: Vec<String> = shard_hashes
            .iter()
            .map(|(hash, files)| {
                let names: Vec<String> =
                    files.iter().map(|l| l.file.display().to_string()).collect();
                format!("sweep {hash}: {}", names.join(", "))
            })
            .collect();
        return Err(BenchError::Merge(format!(
            "these are shards of different sweeps (or of one sweep run with different options), which cannot be merged: {}. Merge each sweep's shards on its own",
            list.join("; ")
        )));
    }
    Ok(shard_hashes.into_iter().next())
}

/// The sweep `files` (the shards of sweep `hash`) make whole when none is missing; a missing
/// shard is a warning. Shards of different splits of the sweep are refused.
fn complete_sweep(
    hash: &str,
    files: &[&Loaded],
    warnings: &mut Vec<String>,
) -> Result<Option<SweepInfo>, BenchError> {
    let counts: BTreeSet<usize> = files
        .iter()
        .filter_map(|l| l.results.sweep.as_ref()?.shard.map(|s| s.count))
        .collect();
    if counts.len() > 1 {
        return Err(BenchError::Merge(format!(
            "sweep {hash} was split into different shard counts ({counts:?}): merge the shards of one split"
        )));
    }
    let count = *counts.iter().next().expect("at least one shard");
    let present: BTreeSet<usize> = files
        .iter()
        .filter_map(|l| l.results.sweep.as_ref()?.shard.map(|s| s.index))
        .collect();
    let missing: Vec<String> = (0..count)
        .filter(|i| !present.contains(i))
        .map(|i| i.to_string())
        .collect();
    if !missing.is_empty() {
        warnings.push(format!(
            "sweep {hash}: shard{} {} of {count} missing (shards are 0-based; the runs they hold are absent)",
            if missing.len() == 1 { "" } else { "s" },
            missing.join(", ")
        ));
        return Ok(None);
    }
    let runs_total = files[0].results.sweep.as_ref().map_or(0, |s| s.runs_total);
    Ok(Some(SweepInfo {
        hash: hash.to_string(),
        runs_total,
        shard: None,
    }))
}

/// One run to merge and where it sorts.
struct Entry {
    /// Its sweep's hash and its index in that sweep.
    sweep_index: Option<(String, usize)>,
    /// Which input it came from.
    input: usize,
    run: Run,
    /// Its images' folder.
    dir: PathBuf,
}

/// Every input's runs: a sweep's runs by sweep index, other files' runs after, in input order.
/// A run present twice (the same sweep index of the same sweep, or the same settings outside a
/// sweep) is refused.
fn runs_in_order(inputs: &[Loaded]) -> Result<Vec<Entry>, BenchError> {
    let mut seen: HashMap<String, &Path> = HashMap::new();
    let mut entries: Vec<Entry> = Vec::new();
    for (order, input) in inputs.iter().enumerate() {
        let hash = input.results.sweep.as_ref().map(|s| s.hash.clone());
        for run in &input.results.runs {
            let key = match &hash {
                Some(h) => format!("sweep {h} run {} ({})", run.index, run_key(run)),
                None => run_key(run),
            };
            if let Some(first) = seen.insert(key.clone(), &input.file) {
                return Err(BenchError::Merge(format!(
                    "run {key} is in both {} and {}: give each shard once",
                    first.display(),
                    input.file.display()
                )));
            }
            entries.push(Entry {
                sweep_index: hash.clone().map(|h| (h, run.index)),
                input: order,
                run: run.clone(),
                dir: input.dir.clone(),
            });
        }
    }
    entries.sort_by(|a, b| match (&a.sweep_index, &b.sweep_index) {
        (Some(x), Some(y)) => x.cmp(y),
        (Some(_), None) => std::cmp::Ordering::Less,
        (None, Some(_)) => std::cmp::Ordering::Greater,
        (None, None) => a.input.cmp(&b.input),
    });
    Ok(entries)
}

/// A warning for every input that ran on another adapter than the first.
fn adapter_warnings(inputs: &[Loaded]) -> Vec<String> {
    let adapter = &inputs[0].results.adapter;
    inputs[1..]
        .iter()
        .filter(|input| input.results.adapter.name != adapter.name)
        .map(|input| {
            format!(
                "{} ran on `{}`, {} on `{}`: times from different adapters are not comparable",
                inputs[0].file.display(),
                adapter.name,
                input.file.display(),
                input.results.adapter.name
            )
        })
        .collect()
}

/// The merged results without sweep and runs: the first input's adapter, command and program,
/// the latest date, and the busiest machine load.
fn merged_header(inputs: &[Loaded]) -> Results {
    Results {
        schema_version: crate::results::SCHEMA_VERSION,
        adapter: inputs[0].results.adapter.clone(),
        command: inputs
            .first()
            .map(|i| i.results.command.clone())
            .unwrap_or_default(),
        program: inputs
            .first()
            .map(|i| i.results.program.clone())
            .unwrap_or_default(),
        date: inputs
            .iter()
            .map(|i| i.results.date.clone())
            .max()
            .unwrap_or_default(),
        // Shards ran apart: the busiest start and end any of them saw.
        load: inputs
            .iter()
            .filter_map(|i| i.results.load.clone())
            .reduce(|a, b| crate::results::MachineLoad {
                cpus: a.cpus.max(b.cpus),
                start: a.start.max(b.start),
                end: a.end.max(b.end),
            }),
        sweep: None,
        runs: Vec::new(),
    }
}

/// Writes `merged` to `out_dir`: results.json and a copy of every image its runs name. Images
/// of the same name and content (a scene's reference, computed by every shard) are copied once;
/// a different file under a name already taken is renamed.
pub fn write_merged(merged: &Merged, out_dir: &Path) -> Result<Results, BenchError> {
    std::fs::create_dir_all(out_dir).map_err(|e| BenchError::Write {
        path: out_dir.display().to_string(),
        message: e.to_string(),
    })?;
    let mut results = merged.results.clone();
    let mut copied: HashMap<String, PathBuf> = HashMap::new();
    for (k, (run, dir)) in results.runs.iter_mut().zip(&merged.run_dirs).enumerate() {
        for name in run.images.values_mut() {
            let source = dir.join(&*name);
            let bytes = std::fs::read(&source).map_err(|e| BenchError::Read {
                path: source.display().to_string(),
                message: format!("{e}: the run's image is missing; was the folder moved?"),
            })?;
            let target_name = match copied.get(name.as_str()) {
                None => name.clone(),
                Some(first) if std::fs::read(first).is_ok_and(|b| b == bytes) => continue,
                Some(_) => format!("m{k:04}_{name}"),
            };
            crate::output::write_atomic(&out_dir.join(&target_name), &bytes)?;
            copied.insert(target_name.clone(), source);
            *name = target_name;
        }
        // A run along a path names its per-frame records and animation among its images too.
        if let Some(motion) = &mut run.motion {
            if let Some(name) = run.images.get("frames") {
                motion.frames_file = name.clone();
            }
            motion.animation = run.images.get("animation").cloned();
        }
    }
    crate::write_results(&results, out_dir)?;
    Ok(results)
}
