//! Sweep files: scenes x techniques x parameter grids, in TOML.
//!
//! ```toml
//! size = "256x256"        # optional, default 256x256
//! # sizes = ["256x256", "1920x1080"]  # or: every run at each size, one size after the other
//! frames = 10             # optional, default 10
//! warmup = 2              # optional, default 2
//! scenes = ["atty-square", "blob-floating"]
//! path = "light-sweep"    # optional: every run along this path, `frames` frames (docs/BENCHMARKS.md)
//! paths = ["orbit", "light-sweep"]  # or: every run along each of these paths (not with `path`)
//!
//! [reference]             # optional: settings of the reference
//! samples_per_axis = 16
//!
//! [camera]                # optional: every scene is seen from this camera instead of its own,
//! eye = [0.0, 5.0, 6.0]   # with the keys and defaults of a scene file's [camera]
//! target = [0.0, 0.0, 0.0]  # (docs/SCENES.md): up, fov_y_degrees, near, far may be left out
//!
//! [light]                 # optional, likewise, a scene file's [light]: center, direction or
//! width = 2.0             # target, up, width, height, intensity
//!
//! every_technique = true  # optional: every registered technique at its crate's overview
//!                         # settings (`TechniqueInfo::overview`), then the tables below
//!
//! [[technique]]           # an id or a .wgsl file
//! id = "pcss"
//! [technique.params]      # a value or a list of values; lists multiply (a grid)
//! filter_samples = [16, 32, 64]
//! kernel = ["vogel", "grid"]
//! ```

use std::{collections::BTreeMap, path::Path};

use serde::Deserialize;
use softshadow_core::{
    expectations::EXPECTATION_SIZE, AreaLight, Camera, ParamValue, Registry, TechniqueInfo,
    TimingSource,
};
use softshadow_scenes::file::{CameraDef, LightDef};

use crate::{parse_size, resolve_technique, results::Shard, BenchError, BenchOptions, RunSpec};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepFile {
    #[serde(default)]
    size: Option<String>,
    /// Every run at each of these sizes, smallest first in the file's order (not with `size`).
    #[serde(default)]
    sizes: Vec<String>,
    #[serde(default)]
    frames: Option<u32>,
    #[serde(default)]
    warmup: Option<u32>,
    scenes: Vec<String>,
    #[serde(default)]
    reference: BTreeMap<String, toml::Value>,
    /// The keys and defaults of a scene file's `[camera]` (docs/SCENES.md).
    #[serde(default)]
    camera: Option<CameraDef>,
    /// The keys and defaults of a scene file's `[light]` (docs/SCENES.md).
    #[serde(default)]
    light: Option<LightDef>,
    /// Render every run along this path (`bench --path`, docs/MOTION.md).
    #[serde(default)]
    path: Option<String>,
    /// Render every run along each of these paths (the runs multiply; not with `path`).
    #[serde(default)]
    paths: Vec<String>,
    /// Every registered technique at the settings its crate gives for the overview
    /// ([`TechniqueInfo::overview`]), before the `[[technique]]` tables.
    #[serde(default)]
    every_technique: bool,
    #[serde(default)]
    technique: Vec<TechniqueGrid>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TechniqueGrid {
    id: String,
    #[serde(default)]
    params: BTreeMap<String, toml::Value>,
}

/// Most runs one sweep file may expand to (its grids multiply, so a few lines can name more runs
/// than memory holds; 100,000 runs take days even at 32²).
pub const MAX_SWEEP_RUNS: usize = 100_000;

/// A parsed sweep: the runs and the shared options.
#[derive(Debug)]
pub struct Sweep {
    pub runs: Vec<RunSpec>,
    pub frames: Option<u32>,
    pub warmup: Option<u32>,
    pub reference_params: Vec<(String, ParamValue)>,
    /// Camera and light that replace every scene's own (see [`crate::Bench::set_view`]).
    pub camera: Option<Camera>,
    pub light: Option<AreaLight>,
}

fn value_text(v: &toml::Value) -> Option<String> {
    match v {
        toml::Value::String(s) => Some(s.clone()),
        toml::Value::Integer(i) => Some(i.to_string()),
        toml::Value::Float(f) => Some(f.to_string()),
        toml::Value::Boolean(b) => Some(b.to_string()),
        _ => None,
    }
}

impl Sweep {
    /// Reads and parses the sweep file at `path`, whose techniques `registry` knows.
    pub fn load(path: &Path, registry: &Registry) -> Result<Self, BenchError> {
        let err = |message: String| BenchError::Sweep {
            path: path.display().to_string(),
            message,
        };
        let text = std::fs::read_to_string(path)
            .map_err(|e| err(format!("cannot read it ({e}): check the path")))?;
        Self::parse(&text, registry).map_err(|e| match e {
            BenchError::Sweep { message, .. } => err(message),
            other => other,
        })
    }

    /// The `[[technique]]` ids of the sweep file at `path` that name WGSL files (end in
    /// `.wgsl`): what a caller registers (`softshadow_wgsl::register_file`) before [`Sweep::load`].
    pub fn technique_files(path: &Path) -> Result<Vec<String>, BenchError> {
        let err = |message: String| BenchError::Sweep {
            path: path.display().to_string(),
            message,
        };
        let text = std::fs::read_to_string(path)
            .map_err(|e| err(format!("cannot read it ({e}): check the path")))?;
        let file: SweepFile =
            toml::from_str(&text).map_err(|e| err(e.to_string().replace('\n', " ")))?;
        Ok(file
            .technique
            .into_iter()
            .map(|t| t.id)
            .filter(|id| id.ends_with(".wgsl"))
            .collect())
    }

    /// Parses a sweep file's text; its techniques must be in `registry` (or be .wgsl files).
    pub fn parse(text: &str, registry: &Registry) -> Result<Self, BenchError> {
        let file: SweepFile =
            toml::from_str(text).map_err(|e| sweep_error(e.to_string().replace('\n', " ")))?;
        let sizes = file.sizes()?;
        if file.scenes.is_empty() {
            return Err(sweep_error(
                "`scenes` is empty: list at least one scene id or file".into(),
            ));
        }
        if file.technique.is_empty() && !file.every_technique {
            return Err(sweep_error(
                "no technique: add `every_technique = true` or a [[technique]] table with an `id`"
                    .into(),
            ));
        }
        let (camera, light) = file.view()?;
        let paths = file.paths()?;
        let reference_params = file.reference_params(registry)?;
        let grids = file.grids(registry)?;
        let runs = expand_runs(&grids, &file.scenes, &paths, &sizes)?;
        Ok(Self {
            runs,
            frames: file.frames,
            warmup: file.warmup,
            reference_params,
            camera,
            light,
        })
    }
}

/// An error in the sweep file's text (the caller names the file).
fn sweep_error(message: String) -> BenchError {
    BenchError::Sweep {
        path: "<sweep>".into(),
        message,
    }
}

impl SweepFile {
    /// `size` or `sizes` (256x256 without either).
    fn sizes(&self) -> Result<Vec<(u32, u32)>, BenchError> {
        match (&self.size, self.sizes.is_empty()) {
            (Some(_), false) => Err(sweep_error(
                "both `size` and `sizes`: give one size with `size` or a list with `sizes`".into(),
            )),
            (_, false) => self.sizes.iter().map(|s| parse_size(s)).collect(),
            (size, true) => Ok(vec![parse_size(size.as_deref().unwrap_or("256x256"))?]),
        }
    }

    /// The `[camera]` and `[light]` that replace every scene's own, checked.
    fn view(&self) -> Result<(Option<Camera>, Option<AreaLight>), BenchError> {
        let camera = self.camera.as_ref().map(CameraDef::to_camera);
        if let Some(camera) = &camera {
            camera
                .validate()
                .map_err(|e| sweep_error(format!("[camera]: {e}")))?;
        }
        let light = match &self.light {
            Some(def) => Some(
                def.to_light("the sweep file")
                    .map_err(|e| sweep_error(e.to_string()))?,
            ),
            None => None,
        };
        if let Some(light) = &light {
            light
                .validate()
                .map_err(|e| sweep_error(format!("[light]: {e}")))?;
        }
        Ok((camera, light))
    }

    /// Each run once per path (a still frame when the sweep names none).
    fn paths(&self) -> Result<Vec<Option<String>>, BenchError> {
        match (&self.path, self.paths.is_empty()) {
            (Some(_), false) => Err(sweep_error(
                "both `path` and `paths`: give one path with `path` or a list with `paths`".into(),
            )),
            (Some(path), true) => Ok(vec![Some(path.clone())]),
            (None, false) => Ok(self.paths.iter().cloned().map(Some).collect()),
            (None, true) => Ok(vec![None]),
        }
    }

    /// The `[reference]` settings, parsed against the registry's yardstick.
    fn reference_params(
        &self,
        registry: &Registry,
    ) -> Result<Vec<(String, ParamValue)>, BenchError> {
        let mut reference_params = Vec::new();
        if !self.reference.is_empty() {
            let yardstick = registry.yardstick()?;
            for (name, value) in &self.reference {
                let text = value_text(value)
                    .ok_or_else(|| sweep_error(format!("reference.{name}: give a single value")))?;
                reference_params.push(yardstick.parse_param(&format!("{name}={text}"))?);
            }
        }
        Ok(reference_params)
    }

    /// Each technique with its grid, in the order they run: with `every_technique` every
    /// registered one at its overview settings, then the `[[technique]]` tables.
    fn grids(&self, registry: &Registry) -> Result<Vec<(TechniqueInfo, Grid)>, BenchError> {
        let mut grids: Vec<(TechniqueInfo, Grid)> = Vec::new();
        if self.every_technique {
            for info in registry {
                let grid = info
                    .overview
                    .iter()
                    .map(|(name, values)| {
                        (
                            name.to_string(),
                            values.iter().map(|v| v.to_string()).collect(),
                        )
                    })
                    .collect();
                grids.push((info.clone(), grid));
            }
        }
        for table in &self.technique {
            let info = resolve_technique(registry, &table.id)?;
            grids.push((info, table.grid()?));
        }
        Ok(grids)
    }
}

impl TechniqueGrid {
    /// Its parameters, each with its values as text (a single value is a list of one).
    fn grid(&self) -> Result<Grid, BenchError> {
        let mut grid = Vec::new();
        for (name, value) in &self.params {
            let values: Vec<&toml::Value> = match value {
                toml::Value::Array(items) => items.iter().collect(),
                single => vec![single],
            };
            let texts = values
                .into_iter()
                .map(|v| {
                    value_text(v).ok_or_else(|| {
                        sweep_error(format!(
                            "{}.{name}: values must be numbers, booleans or strings",
                            self.id
                        ))
                    })
                })
                .collect::<Result<Vec<_>, _>>()?;
            grid.push((name.clone(), texts));
        }
        Ok(grid)
    }
}

/// Every run of the sweep: each technique's grid on each scene along each path, the whole at
/// each size, one size after the other; refused over [`MAX_SWEEP_RUNS`].
fn expand_runs(
    grids: &[(TechniqueInfo, Grid)],
    scenes: &[String],
    paths: &[Option<String>],
    sizes: &[(u32, u32)],
) -> Result<Vec<RunSpec>, BenchError> {
    let (width, height) = sizes[0];
    let mut runs = Vec::new();
    for (info, grid) in grids {
        let combos = expand_grid(info, grid, scenes.len()).map_err(|e| match e {
            GridError::Param(e) => BenchError::from(e),
            GridError::Message(message) => sweep_error(message),
        })?;
        if runs.len() + combos.len() * scenes.len() * paths.len() * sizes.len() > MAX_SWEEP_RUNS {
            return Err(sweep_error(format!(
                "the sweep has more than {MAX_SWEEP_RUNS} runs (sweep::MAX_SWEEP_RUNS): split it into several files"
            )));
        }
        for path in paths {
            for scene in scenes {
                for combo in &combos {
                    runs.push(RunSpec {
                        scene: scene.clone(),
                        technique: info.id.to_string(),
                        params: combo.clone(),
                        width,
                        height,
                        path: path.clone(),
                    });
                }
            }
        }
    }
    // Each size runs the whole sweep, the sizes one after the other.
    Ok(sizes
        .iter()
        .flat_map(|&(width, height)| {
            runs.iter().map(move |run| RunSpec {
                width,
                height,
                ..run.clone()
            })
        })
        .collect())
}

/// A technique's parameter grid: each parameter with the values to try, as text.
type Grid = Vec<(String, Vec<String>)>;

/// Why a technique's grid could not be expanded.
enum GridError {
    Param(softshadow_core::ParamError),
    Message(String),
}

/// Every combination of `grid`'s values (each parameter a list; lists multiply), parsed against
/// `info`'s specs; refused before it is expanded when it would exceed [`MAX_SWEEP_RUNS`] over
/// `scenes` scenes.
fn expand_grid(
    info: &TechniqueInfo,
    grid: &[(String, Vec<String>)],
    scenes: usize,
) -> Result<Vec<Vec<(String, ParamValue)>>, GridError> {
    let mut combos: Vec<Vec<(String, ParamValue)>> = vec![Vec::new()];
    for (name, texts) in grid {
        if texts.is_empty() {
            return Err(GridError::Message(format!(
                "{}.{name} is an empty list: give at least one value",
                info.id
            )));
        }
        let parsed = texts
            .iter()
            .map(|text| info.parse_param(&format!("{name}={text}")))
            .collect::<Result<Vec<_>, _>>()
            .map_err(GridError::Param)?;
        let expanded = combos.len().saturating_mul(parsed.len());
        if expanded.saturating_mul(scenes) > MAX_SWEEP_RUNS {
            return Err(GridError::Message(format!(
                "the grid of [[technique]] `{}` has more than {MAX_SWEEP_RUNS} runs (sweep::MAX_SWEEP_RUNS): split the sweep into several files",
                info.id
            )));
        }
        combos = combos
            .into_iter()
            .flat_map(|combo| {
                parsed.iter().map(move |p| {
                    let mut c = combo.clone();
                    c.push(p.clone());
                    c
                })
            })
            .collect();
    }
    Ok(combos)
}

/// Parses `INDEX/COUNT` (0-based index), e.g. `2/8`.
pub fn parse_shard(text: &str) -> Result<Shard, BenchError> {
    let bad = || BenchError::BadShard(text.into());
    let (index, count) = text.split_once('/').ok_or_else(bad)?;
    let index: usize = index.trim().parse().map_err(|_| bad())?;
    let count: usize = count.trim().parse().map_err(|_| bad())?;
    if count == 0 || index >= count {
        return Err(bad());
    }
    Ok(Shard { index, count })
}

/// FNV-1a, 64 bits: stable across platforms and Rust versions (unlike `DefaultHasher`).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3)
    })
}

impl Sweep {
    /// Identifies the sweep as run: its expanded run list and the options that change results
    /// (frames, warm-up, reference settings, error and exact flags, timing source). Shards of
    /// one sweep share it; `merge` and `report` refuse to mix different ones.
    pub fn hash(&self, options: &BenchOptions, timing: Option<TimingSource>) -> String {
        let mut text = String::new();
        for run in &self.runs {
            let params: Vec<String> = run.params.iter().map(|(n, v)| format!("{n}={v}")).collect();
            text.push_str(&format!(
                "{}|{}|{}x{}|{}",
                run.scene,
                run.technique,
                run.width,
                run.height,
                params.join(",")
            ));
            // Along a path (only then, so the hashes of still sweeps stay what they were).
            if let Some(path) = &run.path {
                text.push_str(&format!("|path={path}"));
            }
            text.push('\n');
        }
        text.push_str(&format!(
            "frames={} warmup={} error={} images={} exact={:?} camera_only={} timing={:?} reference={:?}",
            options.frames,
            options.warmup,
            options.error,
            options.images,
            options.exact_samples_per_axis,
            options.camera_only,
            timing,
            options.reference_params
        ));
        // A sweep seen from another camera or light measures something else.
        text.push_str(&format!(" camera={:?} light={:?}", self.camera, self.light));
        // The runs' default path (only when set, as above).
        if let Some(path) = &options.path {
            text.push_str(&format!(" path={path}"));
        }
        // The ray-traced exact answer's samples (only when not the default, so the hashes of
        // sweeps run at the default stay what they were).
        if options.traced_samples_per_axis != Some(crate::DEFAULT_TRACED_SAMPLES) {
            text.push_str(&format!(" traced={:?}", options.traced_samples_per_axis));
        }
        // The analytic exact answer (so a sweep begun with sampled answers is not resumed with
        // analytic ones).
        if options.analytic {
            text.push_str(" analytic");
        }
        format!("{:016x}", fnv1a(text.as_bytes()))
    }

    /// Every run along `path` instead of the path (or paths) the file names (`bench --path`):
    /// runs that differ only in their path become one.
    pub fn set_path(&mut self, path: &str) {
        let mut runs: Vec<RunSpec> = Vec::with_capacity(self.runs.len());
        for mut run in std::mem::take(&mut self.runs) {
            run.path = Some(path.to_string());
            if !runs.contains(&run) {
                runs.push(run);
            }
        }
        self.runs = runs;
    }

    /// Every run at `width` x `height` instead of the size the file gives (`bench --size`).
    pub fn set_size(&mut self, width: u32, height: u32) {
        for run in &mut self.runs {
            (run.width, run.height) = (width, height);
        }
    }

    /// Only the runs of these techniques (`bench --techniques`); the error names any id the
    /// sweep does not run, so a typo does not make an empty sweep.
    pub fn retain_techniques(&mut self, ids: &[String]) -> Result<(), BenchError> {
        if let Some(missing) = ids
            .iter()
            .find(|id| !self.runs.iter().any(|r| &r.technique == *id))
        {
            return Err(BenchError::Sweep {
                path: "--techniques".into(),
                message: format!(
                    "the sweep runs no technique `{missing}`: give ids it runs (see `workbench list`)"
                ),
            });
        }
        self.runs.retain(|r| ids.contains(&r.technique));
        Ok(())
    }

    /// Only the runs on these scenes (`bench --scenes`); the error names any scene the sweep does
    /// not run.
    pub fn retain_scenes(&mut self, scenes: &[String]) -> Result<(), BenchError> {
        if let Some(missing) = scenes
            .iter()
            .find(|scene| !self.runs.iter().any(|r| &r.scene == *scene))
        {
            return Err(BenchError::Sweep {
                path: "--scenes".into(),
                message: format!("the sweep runs no scene `{missing}`: give scenes it lists"),
            });
        }
        self.runs.retain(|r| scenes.contains(&r.scene));
        Ok(())
    }

    /// The runs of `shard` with their index in the whole sweep: round robin over the expanded
    /// list (run `k` goes to shard `k % count`), so neighbouring runs, which tend to cost about
    /// the same, spread over all shards. `None`: every run.
    pub fn shard(&self, shard: Option<Shard>) -> Vec<(usize, RunSpec)> {
        self.runs
            .iter()
            .cloned()
            .enumerate()
            .filter(|(k, _)| shard.is_none_or(|s| k % s.count == s.index))
            .collect()
    }
}

/// Suites built into the workbench (`workbench bench --suite NAME`), besides the sweep files in
/// `sweeps/` that `--suite` also accepts by file stem.
pub const SUITES: &[(&str, &str)] = &[(
    "stiff",
    "every registered technique, default settings, on every `stiff-*` scene at 64x64, each run held against the bound its crate states (docs/STABILITY.md)",
)];

impl Sweep {
    /// A built-in suite by name (see [`SUITES`]) over `registry`'s techniques. Generated, not
    /// read from a file, so that a newly registered technique or stiff case joins it without
    /// editing anything.
    pub fn suite(name: &str, registry: &Registry) -> Result<Self, BenchError> {
        match name {
            "stiff" => {
                let scenes: Vec<String> = softshadow_scenes::builtin_scenes()
                    .into_iter()
                    .filter(|s| s.id.starts_with(softshadow_scenes::stiff::PREFIX))
                    .map(|s| s.id.to_string())
                    .collect();
                let runs = registry
                    .iter()
                    .flat_map(|t| {
                        scenes.iter().map(|scene| RunSpec {
                            scene: scene.clone(),
                            technique: t.id.to_string(),
                            params: Vec::new(),
                            width: EXPECTATION_SIZE,
                            height: EXPECTATION_SIZE,
                            path: None,
                        })
                    })
                    .collect();
                Ok(Self {
                    runs,
                    frames: Some(3),
                    warmup: Some(1),
                    reference_params: Vec::new(),
                    camera: None,
                    light: None,
                })
            }
            _ => Err(BenchError::UnknownSuite {
                name: name.into(),
                known: SUITES
                    .iter()
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", "),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn registry() -> Registry {
        softshadow::registry()
    }

    /// A sweep's `[camera]` and `[light]` take a scene file's keys and defaults (issue 44): only
    /// `eye` and `target`, only `width`, and `target` instead of `direction`.
    #[test]
    fn camera_and_light_overrides_take_the_scene_files_keys_and_defaults() {
        let base = "scenes = [\"atty-square\"]\n[[technique]]\nid = \"hard\"\n";
        let text = format!("{base}[camera]\neye = [1.0, 2.0, 3.0]\ntarget = [0.0, 0.5, 0.0]\n[light]\nwidth = 2.0\n");
        let sweep = Sweep::parse(&text, &registry()).unwrap();
        let (camera, light) = (sweep.camera.unwrap(), sweep.light.unwrap());
        let defaults = softshadow_scenes::file::CameraDef::default().to_camera();
        assert_eq!(camera.eye, softshadow_core::glam::Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(
            (camera.up, camera.fov_y_degrees),
            (defaults.up, defaults.fov_y_degrees)
        );
        assert_eq!((light.width, light.height), (2.0, 2.0));
        assert_eq!(
            (light.center, light.direction),
            (
                softshadow_core::glam::Vec3::new(0.0, 4.0, 0.0),
                softshadow_core::glam::Vec3::NEG_Y
            )
        );
        let text = format!("{base}[light]\ncenter = [6.0, 3.0, 0.0]\ntarget = [-3.0, 0.0, 0.0]\n");
        let light = Sweep::parse(&text, &registry()).unwrap().light.unwrap();
        assert!(
            (light.direction - softshadow_core::glam::Vec3::new(-3.0, -1.0, 0.0).normalize())
                .length()
                < 1e-6
        );
        // What a scene file refuses, a sweep refuses, naming the table.
        let text =
            format!("{base}[light]\ndirection = [0.0, -1.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n");
        let message = Sweep::parse(&text, &registry()).unwrap_err().to_string();
        assert!(
            message.contains("both `direction` and `target`"),
            "{message}"
        );
        let text = format!("{base}[camera]\neye = [0.0, 1.0, 0.0]\nfov = 30\n");
        let message = Sweep::parse(&text, &registry()).unwrap_err().to_string();
        assert!(message.contains("fov"), "{message}");
    }

    #[test]
    fn a_grid_over_the_run_limit_is_refused_before_it_is_expanded() {
        let list = |range: std::ops::RangeInclusive<u32>| {
            range.map(|v| v.to_string()).collect::<Vec<_>>().join(",")
        };
        // 256 x 64 x 137 = 2.2 million runs from five lines.
        let text = format!(
            "scenes = [\"atty-square\"]\n[[technique]]\nid = \"pcss\"\n[technique.params]\nfilter_samples = [{}]\nblocker_samples = [{}]\nshadow_map_size = [{}]\n",
            list(1..=256),
            list(1..=64),
            list(64..=200)
        );
        let message = Sweep::parse(&text, &registry()).unwrap_err().to_string();
        assert!(message.contains("MAX_SWEEP_RUNS"), "{message}");
        // Just under the limit in total but over it across two tables.
        let table = format!(
            "[[technique]]\nid = \"pcss\"\n[technique.params]\nfilter_samples = [{}]\nblocker_samples = [{}]\n",
            list(1..=256),
            list(1..=64)
        );
        let text =
            format!("scenes = [\"atty-square\", \"stiff-fusion\"]\n{table}{table}{table}{table}");
        let message = Sweep::parse(&text, &registry()).unwrap_err().to_string();
        assert!(message.contains("MAX_SWEEP_RUNS"), "{message}");
    }

    /// Exactly `MAX_SWEEP_RUNS` runs are allowed, by the grid check and the total check alike
    /// (found by `cargo mutants`: `>` made `>=` or `==` went unnoticed, every case was far
    /// over): 250 x 40 settings on 10 scenes.
    #[test]
    fn a_sweep_of_exactly_the_run_limit_is_accepted() {
        let list = |range: std::ops::RangeInclusive<u32>| {
            range.map(|v| v.to_string()).collect::<Vec<_>>().join(",")
        };
        let scenes = (0..10)
            .map(|k| format!("\"s{k}\""))
            .collect::<Vec<_>>()
            .join(",");
        let text = format!(
            "scenes = [{scenes}]\n[[technique]]\nid = \"pcss\"\n[technique.params]\nfilter_samples = [{}]\nblocker_samples = [{}]\n",
            list(1..=250),
            list(1..=40)
        );
        assert_eq!(
            Sweep::parse(&text, &registry()).unwrap().runs.len(),
            MAX_SWEEP_RUNS
        );
        // One scene more is over it.
        let text = text.replacen("scenes = [", "scenes = [\"extra\",", 1);
        let message = Sweep::parse(&text, &registry()).unwrap_err().to_string();
        assert!(message.contains("MAX_SWEEP_RUNS"), "{message}");
        // Two tables of 250 x 20 settings: 50,000 runs each on 10 scenes, 100,000 in all, are
        // allowed; on 11 scenes each table (55,000) is under the limit but the two (110,000) are
        // not (the total counts runs so far plus settings times scenes).
        let table = format!(
            "[[technique]]\nid = \"pcss\"\n[technique.params]\nfilter_samples = [{}]\nblocker_samples = [{}]\n",
            list(1..=250),
            list(1..=20)
        );
        let text = format!("scenes = [{scenes}]\n{table}{table}");
        assert_eq!(
            Sweep::parse(&text, &registry()).unwrap().runs.len(),
            MAX_SWEEP_RUNS
        );
        let text = text.replacen("scenes = [", "scenes = [\"extra\",", 1);
        let message = Sweep::parse(&text, &registry()).unwrap_err().to_string();
        assert!(message.contains("the sweep has more than"), "{message}");
    }

    /// The sweep hash is FNV-1a (64 bits) as published: the empty input gives the offset basis,
    /// "a" and "foobar" the reference vectors.
    #[test]
    fn paths_multiply_the_runs_and_path_on_the_command_line_replaces_them() {
        let text = "scenes = [\"atty-square\", \"balls-3x3x3\"]\npaths = [\"orbit\", \"light-sweep\"]\n[[technique]]\nid = \"pcss\"\n";
        let mut sweep = Sweep::parse(text, &registry()).unwrap();
        let paths: Vec<Option<&str>> = sweep.runs.iter().map(|r| r.path.as_deref()).collect();
        assert_eq!(
            paths,
            [
                Some("orbit"),
                Some("orbit"),
                Some("light-sweep"),
                Some("light-sweep")
            ]
        );
        sweep.set_path("still");
        assert_eq!(
            sweep.runs.len(),
            2,
            "runs that differ only in their path become one"
        );
        assert!(sweep
            .runs
            .iter()
            .all(|r| r.path.as_deref() == Some("still")));

        let both = format!("path = \"orbit\"\n{text}");
        let message = Sweep::parse(&both, &registry()).unwrap_err().to_string();
        assert!(message.contains("both `path` and `paths`"), "{message}");
        let still = Sweep::parse(
            &text.replace("paths = [\"orbit\", \"light-sweep\"]\n", ""),
            &registry(),
        )
        .unwrap();
        assert!(still.runs.iter().all(|r| r.path.is_none()));
    }

    #[test]
    fn fnv1a_matches_the_published_vectors() {
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn the_stiff_suite_runs_every_technique_on_every_stiff_case() {
        let sweep = Sweep::suite("stiff", &registry()).unwrap();
        let stiff = softshadow_scenes::builtin_scenes()
            .iter()
            .filter(|s| s.id.starts_with("stiff-"))
            .count();
        assert!(stiff >= 12, "{stiff} stiff cases");
        assert_eq!(sweep.runs.len(), stiff * registry().len());
        let e = Sweep::suite("nope", &registry()).unwrap_err().to_string();
        assert!(
            e.contains("unknown suite `nope`") && e.contains("stiff"),
            "{e}"
        );
    }

    #[test]
    fn overview_lists_every_technique() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../sweeps/overview.toml");
        let sweep = Sweep::load(&path, &registry()).unwrap();
        for t in &registry() {
            let settings = sweep.runs.iter().filter(|r| r.technique == t.id).count();
            assert!(
                settings >= 2 * 7,
                "sweeps/overview.toml has {settings} runs of `{}`: give it two or three settings with `TechniqueInfo::with_overview` in its crate (issue 14)",
                t.id
            );
        }
    }

    /// Every sweep file in `sweeps/` parses (techniques and parameters checked) and each of its
    /// scenes loads: a renamed scene or parameter fails here, not an hour into a sweep.
    #[test]
    fn every_sweep_file_parses_and_its_scenes_load() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../sweeps");
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        assert!(files.len() >= 20, "{} sweep files", files.len());
        let mut scenes = std::collections::BTreeSet::new();
        for file in &files {
            // Its WGSL file techniques registered first (by their ids, paths from the
            // repository root, where sweeps run), as `workbench bench` does.
            let mut known = registry();
            for technique in Sweep::technique_files(file).unwrap() {
                let path = dir.join("..").join(&technique);
                softshadow_wgsl::register_file(&mut known, &path).unwrap();
            }
            let text = std::fs::read_to_string(file).unwrap();
            let sweep =
                Sweep::parse(&text, &known).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
            scenes.extend(sweep.runs.iter().map(|r| r.scene.clone()));
        }
        for scene in scenes
            .iter()
            .filter(|s| !s.starts_with(softshadow_scenes::GLB_PREFIX))
        {
            // A scene file is named from the repository root, where sweeps run.
            let spec = match scene.contains('/') {
                true => dir.join("..").join(scene).display().to_string(),
                false => scene.clone(),
            };
            let loaded = softshadow_scenes::load(&spec);
            assert!(loaded.is_ok(), "scene `{scene}`: {:?}", loaded.err());
        }
    }

    #[test]
    fn shards_partition_the_runs_round_robin() {
        let sweep = Sweep::parse(
            "scenes = [\"a\", \"b\"]\n[[technique]]\nid = \"pcss\"\n[technique.params]\nfilter_samples = [16, 32, 64]",
            &registry(),
        )
        .unwrap();
        let all: Vec<usize> = sweep.shard(None).iter().map(|(k, _)| *k).collect();
        assert_eq!(all, (0..6).collect::<Vec<_>>());
        let mut seen = Vec::new();
        for index in 0..4 {
            let shard = sweep.shard(Some(Shard { index, count: 4 }));
            assert!(shard.iter().all(|(k, _)| k % 4 == index));
            seen.extend(shard.iter().map(|(k, _)| *k));
        }
        seen.sort();
        assert_eq!(seen, all);
        assert_eq!(parse_shard("2/3").unwrap(), Shard { index: 2, count: 3 });
        for bad in ["3/3", "1/0", "x/2", "2"] {
            let e = parse_shard(bad).unwrap_err().to_string();
            assert!(e.contains("INDEX/COUNT"), "{e}");
        }
        let options = BenchOptions::default();
        let other = BenchOptions {
            frames: 3,
            ..BenchOptions::default()
        };
        assert_eq!(sweep.hash(&options, None), sweep.hash(&options, None));
        assert_ne!(sweep.hash(&options, None), sweep.hash(&other, None));
        let serial = Some(TimingSource::Serial);
        assert_ne!(sweep.hash(&options, None), sweep.hash(&options, serial));
    }

    #[test]
    fn grid_expands_to_the_product() {
        let sweep = Sweep::parse(
            r#"
            size = "64x32"
            scenes = ["a", "b"]
            [reference]
            samples_per_axis = 8
            [[technique]]
            id = "pcss"
            [technique.params]
            filter_samples = [16, 32, 64]
            kernel = ["vogel", "grid"]
            [[technique]]
            id = "hard"
            "#,
            &registry(),
        )
        .unwrap();
        assert_eq!(sweep.runs.len(), 2 * 3 * 2 + 2);
        assert_eq!((sweep.runs[0].width, sweep.runs[0].height), (64, 32));
        assert_eq!(sweep.reference_params.len(), 1);
    }

    #[test]
    fn bad_sweeps_say_what_is_wrong() {
        let e = Sweep::parse("scenes = []\n[[technique]]\nid = \"hard\"", &registry())
            .unwrap_err()
            .to_string();
        assert!(e.contains("scenes"), "{e}");
        let e = Sweep::parse(
            "scenes = [\"a\"]\n[[technique]]\nid = \"nope\"",
            &registry(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("unknown technique `nope`"), "{e}");
        let e = Sweep::parse("scenes = [\"a\"]\n[[technique]]\nid = \"pcss\"\n[technique.params]\nfilter_samples = 100000", &registry())
            .unwrap_err()
            .to_string();
        assert!(e.contains("out of range"), "{e}");
        let e = Sweep::parse(
            "scenes = [\"a\"]\ncolour = 1\n[[technique]]\nid = \"hard\"",
            &registry(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("colour"), "{e}");
    }
}
