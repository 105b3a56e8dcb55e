//! Headless benchmark: runs techniques on scenes, times every pass on the GPU, compares the
//! result with the accumulated reference, and writes `results.json` plus images.
//!
//! A run that fails (bad parameter, technique error, device error) is recorded with its message
//! and the rest of the runs go on.

pub mod compare;
pub mod doc_tables;
pub mod expectations;
pub mod fault;
pub mod isolate;
pub mod merge;
pub mod motion;
pub mod output;
pub mod reference_cache;
pub mod report;
pub mod results;
pub mod stress;
pub mod sweep;
pub mod video_metric;

use std::{
    collections::{BTreeMap, HashMap},
    path::{Path, PathBuf},
};

use softshadow_core::{
    disk_cache::DiskCache, AreaLight, BuildControl, Camera, FrameOutput, Gpu, LightKind, MemoryUse,
    ParamError, ParamValue, Registry, RegistryError, RenderError, Renderer, Scene, SceneGpu,
    ShadingMode, ShadowTechnique, TechniqueError, TechniqueInfo, TimingSource, YARDSTICK_TECHNIQUE,
};
use softshadow_metrics::ErrorReport;

use reference_cache::{CachedReference, ReferenceCacheUse, ReferenceKey};
use thiserror::Error;

pub use results::{ProcessRecord, Results, Run, Shard, Status, SweepInfo};
pub use sweep::Sweep;

#[derive(Debug, Error)]
pub enum BenchError {
    #[error(transparent)]
    Registry(#[from] RegistryError),
    #[error(transparent)]
    Scene(#[from] softshadow_scenes::SceneError),
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("resolution {width}x{height} is invalid: width and height must be 1 to {max} pixels (e.g. --size 256x256)")]
    BadResolution { width: u32, height: u32, max: u32 },
    #[error("{what} is over this device's {limit}: {fix}")]
    OverDeviceLimit {
        what: String,
        limit: String,
        fix: String,
    },
    #[error("--size `{0}` is not WIDTHxHEIGHT: write it like 256x256")]
    BadSize(String),
    #[error("--frames must be at least 1")]
    NoFrames,
    #[error("cannot write `{path}`: {message}. Check the --out folder exists and is writable")]
    Write { path: String, message: String },
    #[error("unknown suite `{name}`: built-in suites are {known}; or give a sweep file with --sweep FILE")]
    UnknownSuite { name: String, known: String },
    #[error("sweep file `{path}`: {message}")]
    Sweep { path: String, message: String },
    #[error("--shard `{0}` is not INDEX/COUNT with 0 <= INDEX < COUNT: write it like 0/3 (the first of three shards)")]
    BadShard(String),
    #[error("--timing `{0}` is unknown: use `timestamps` or `serial`")]
    BadTiming(String),
    #[error("cannot read `{path}`: {message}")]
    Read { path: String, message: String },
    #[error("{0}")]
    Merge(String),
    /// A run along a path that cannot be made (the message says what to change).
    #[error("{0}")]
    Motion(String),
    #[error(transparent)]
    Gpu(#[from] softshadow_core::GpuError),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Technique(#[from] TechniqueError),
    #[error(transparent)]
    Metrics(#[from] softshadow_metrics::MetricsError),
    #[error(transparent)]
    Exact(#[from] softshadow_reference::analytic::AnalyticError),
    /// A fault asked for by `SOFTSHADOW_FAULT` ([`fault`]), or a bad value of it.
    #[error("{0}")]
    Fault(String),
    /// The output folder has less room than the benchmark's files need.
    #[error("the output folder `{path}` has {free_mib} MiB free, but this benchmark's results and images need about {need_mib} MiB: free some space, give another --out, or leave the images out with --no-images")]
    OutOfSpace {
        path: String,
        free_mib: u64,
        need_mib: u64,
    },
}

/// One benchmark run: a scene, a technique with settings, a resolution.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunSpec {
    pub scene: String,
    pub technique: String,
    /// Already parsed and range-checked (see [`parse_params`]).
    pub params: Vec<(String, ParamValue)>,
    pub width: u32,
    pub height: u32,
    /// The path this run follows (`bench --path`, a sweep's `path` or `paths`; docs/MOTION.md); `None`: [`BenchOptions::path`], and without that a still frame.
    pub path: Option<String>,
}

/// Options shared by all runs.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct BenchOptions {
    /// Timed frames per run (after `warmup` untimed ones).
    pub frames: u32,
    pub warmup: u32,
    /// Compute the reference and the error metrics (otherwise only timings: no reference passes run).
    pub error: bool,
    /// Settings of the reference (`reference` technique parameters).
    pub reference_params: Vec<(String, ParamValue)>,
    /// Write EXR / PNG images.
    pub images: bool,
    /// Exact ground truth for `error.vs_exact` and `error.reference_vs_exact` (only with
    /// `error`): `None` skips it; `Some(n)` uses the closed form when every caster is a rectangle
    /// parallel to the light, else (with [`analytic`](Self::analytic)) the analytic answer where
    /// the light has area, else the ray-traced answer with
    /// [`traced_samples_per_axis`](Self::traced_samples_per_axis) where the device has ray
    /// queries, else the CPU ray cast with `n x n` light samples
    /// (`softshadow_reference::exact_answer`).
    pub exact_samples_per_axis: Option<u32>,
    /// Light samples per axis of the ray-traced exact answer where the device has ray queries;
    /// `None` always uses the CPU ray cast.
    pub traced_samples_per_axis: Option<u32>,
    /// Use the analytic exact answer wherever the light has area (the default); `false` (`bench
    /// --no-analytic`) makes the sampled answers the exact answer, as a cross-check. Missing
    /// (read as `false`) in results written before it existed, whose exact answers were sampled.
    #[serde(default)]
    pub analytic: bool,
    /// Also time frames in which only the camera moves (`timing_camera_only`): light-space work
    /// is then kept from the first frame.
    pub camera_only: bool,
    /// A folder of reference images shared across benchmarks and shards ([`reference_cache`]):
    /// `None` renders every reference. Motion runs keep their per-frame exact answers there
    /// too ([`reference_cache::exact_in_dir`]).
    pub reference_cache: Option<PathBuf>,
    /// Render every run whose [`RunSpec::path`] is `None` along this path ([`motion`]; a
    /// built-in path's name, a path its scene file declares, or a `.toml` path file) for
    /// `frames` frames, instead of the still frames.
    pub path: Option<String>,
}

impl Default for BenchOptions {
    fn default() -> Self {
        Self {
            frames: 10,
            warmup: 2,
            error: true,
            reference_params: Vec::new(),
            images: true,
            exact_samples_per_axis: Some(DEFAULT_EXACT_SAMPLES),
            traced_samples_per_axis: Some(DEFAULT_TRACED_SAMPLES),
            analytic: true,
            camera_only: true,
            reference_cache: None,
            path: None,
        }
    }
}

/// Light samples per axis of the ray-cast ground truth by default: its own error is then about
/// 0.001 (mean) on penumbra pixels (docs/TECHNIQUES.md, `reference`).
pub const DEFAULT_EXACT_SAMPLES: u32 = 16;

/// Light samples per axis of the ray-traced ground truth by default (where the device has ray
/// queries), chosen by measurement of time against agreement with the closed form
/// (docs/EXACT.md, "The exact answer").
pub const DEFAULT_TRACED_SAMPLES: u32 = 32;

impl BenchOptions {
    /// The exact method these options ask for, if any.
    pub fn exact_method(&self) -> Option<softshadow_reference::ExactMethod> {
        self.exact_samples_per_axis
            .map(|n| softshadow_reference::ExactMethod {
                analytic: self.analytic,
                raycast_samples_per_axis: n,
                traced_samples_per_axis: self.traced_samples_per_axis,
            })
    }
}

/// Parses `WIDTHxHEIGHT`.
pub fn parse_size(text: &str) -> Result<(u32, u32), BenchError> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| BenchError::BadSize(text.into()))?;
    let w = w
        .trim()
        .parse()
        .map_err(|_| BenchError::BadSize(text.into()))?;
    let h = h
        .trim()
        .parse()
        .map_err(|_| BenchError::BadSize(text.into()))?;
    check_size(w, h)?;
    Ok((w, h))
}

pub fn check_size(width: u32, height: u32) -> Result<(), BenchError> {
    let max = softshadow_core::renderer::MAX_RESOLUTION;
    if width == 0 || height == 0 || width > max || height > max {
        return Err(BenchError::BadResolution { width, height, max });
    }
    Ok(())
}

/// Checks a size against the largest texture edge of the device the run is made on
/// (`max_texture_dimension_2d`), before any GPU work: [`check_size`]'s bound is the least every
/// WebGPU device offers, but a device made with lower limits has less.
pub fn check_size_within(width: u32, height: u32, limit: u32) -> Result<(), BenchError> {
    check_size(width, height)?;
    if width.max(height) > limit {
        return Err(BenchError::OverDeviceLimit {
            what: format!("resolution {width}x{height}"),
            limit: format!("max_texture_dimension_2d of {limit}"),
            fix: format!("give --size {limit}x{limit} or smaller"),
        });
    }
    Ok(())
}

/// The technique `name` names: a registered id, or a `.wgsl` file registered under its stem
/// (the caller registers the file first, `softshadow_wgsl::register_file`).
pub fn resolve_technique(registry: &Registry, name: &str) -> Result<TechniqueInfo, BenchError> {
    if name.ends_with(".wgsl") {
        let stem = std::path::Path::new(name)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned());
        // A file technique's `source` names the path it was registered from; a built-in of
        // the same stem is not that file.
        if let Some(info) = stem
            .and_then(|stem| registry.get(&stem))
            .filter(|info| info.source.ends_with(name))
        {
            return Ok(info.clone());
        }
    }
    Ok(registry.find(name)?.clone())
}

/// Parses `name=value` texts for technique `technique`.
pub fn parse_params(
    registry: &Registry,
    technique: &str,
    texts: &[String],
) -> Result<Vec<(String, ParamValue)>, BenchError> {
    let info = resolve_technique(registry, technique)?;
    texts
        .iter()
        .map(|t| info.parse_param(t).map_err(BenchError::from))
        .collect()
}

/// Checks a run before any GPU work: scene loads, technique exists, parameters are valid.
pub fn validate(registry: &Registry, spec: &RunSpec) -> Result<(), BenchError> {
    check_size(spec.width, spec.height)?;
    resolve_technique(registry, &spec.technique)?.check_params(&spec.params)?;
    softshadow_scenes::load(&spec.scene)?;
    Ok(())
}

/// The kind of light `spec` would run under (`light`, a sweep's `[light]`, else its scene's)
/// and, when its technique does not support it, the one line refusing the run, naming technique
/// and kind. Reads the scene file only (no GPU work).
pub fn light_refusal(
    registry: &Registry,
    spec: &RunSpec,
    light: Option<&AreaLight>,
) -> Result<(LightKind, Option<String>), BenchError> {
    let info = resolve_technique(registry, &spec.technique)?;
    let kind = match light {
        Some(light) => light.kind,
        None => softshadow_scenes::load(&spec.scene)?.scene.light.kind,
    };
    Ok((kind, info.check_light(kind).err()))
}

/// Checks options before any run: frames, and the reference's settings (so a typo fails before
/// the first run).
fn check_options(registry: &Registry, options: &BenchOptions) -> Result<(), BenchError> {
    if options.frames == 0 {
        return Err(BenchError::NoFrames);
    }
    if options.error || !options.reference_params.is_empty() {
        registry
            .yardstick()?
            .check_params(&options.reference_params)?;
    }
    Ok(())
}

struct LoadedScene {
    scene: Scene,
    gpu: SceneGpu,
    warnings: Vec<String>,
    /// Paths its scene file declares.
    paths: Vec<softshadow_scenes::path::Path>,
    /// What loading it cost (every run on it reports this).
    load: results::SceneLoad,
}

/// A `/proc/self/status` memory line (`VmRSS`, `VmHWM`) in MiB; `None` off Linux.
fn resident_mib(field: &str) -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

struct ReferenceResult {
    visibility: Vec<f32>,
    shaded_rgb: Vec<u8>,
    label: String,
    images: BTreeMap<String, String>,
    exact: Option<ExactResult>,
    /// Where it came from, when a reference cache is set.
    cache_use: Option<ReferenceCacheUse>,
    /// Why the exact answer is not the one asked for (the ray-traced answer failed), if so.
    exact_warning: Option<String>,
}

/// The exact ground truth of one scene and size, and the reference's error against it.
struct ExactResult {
    visibility: Vec<f32>,
    label: String,
    sampling_error: Option<f64>,
    reference_vs_exact: ErrorReport,
    /// An answer with no shadow at all (V = 1) against the exact one: the error a technique that
    /// draws nothing would get, the floor every bound must stay below.
    all_lit_vs_exact: ErrorReport,
    /// The exact irradiance and the same two comparisons in irradiance, where the analytic
    /// answer gave it.
    irradiance: Option<ExactIrradianceResult>,
}

/// The exact irradiance of one scene and size, and the reference's and no shadow's irradiance
/// errors against it.
struct ExactIrradianceResult {
    images: softshadow_reference::ExactIrradiance,
    reference_vs_exact: softshadow_metrics::IrradianceReport,
    all_lit_vs_exact: softshadow_metrics::IrradianceReport,
}

/// Runs benchmark runs on one GPU, caching scenes, renderers and reference images between runs.
pub struct Bench {
    gpu: Gpu,
    registry: Registry,
    options: BenchOptions,
    timing: TimingSource,
    scenes: HashMap<String, LoadedScene>,
    renderers: HashMap<(u32, u32), Renderer>,
    reference: Option<Box<dyn ShadowTechnique>>,
    references: HashMap<(String, u32, u32), ReferenceResult>,
    /// Camera and light replacing every scene's own (a sweep exported by the viewer).
    camera: Option<Camera>,
    light: Option<AreaLight>,
    /// Installed in every technique ([`ShadowTechnique::set_build_control`]).
    build_control: Option<BuildControl>,
    /// Faults to inject (`SOFTSHADOW_FAULT`, [`fault`]).
    faults: fault::Faults,
}

impl Bench {
    /// A benchmark of `registry`'s techniques on `gpu`. Its yardstick
    /// ([`YARDSTICK_TECHNIQUE`]) must be registered when `options.error` asks for error metrics.
    pub fn new(gpu: Gpu, registry: Registry, options: BenchOptions) -> Result<Self, BenchError> {
        check_options(&registry, &options)?;
        let timing = TimingSource::default_for(&gpu);
        Ok(Self {
            gpu,
            registry,
            options,
            timing,
            scenes: HashMap::new(),
            renderers: HashMap::new(),
            reference: None,
            references: HashMap::new(),
            camera: None,
            light: None,
            build_control: None,
            faults: fault::Faults::from_env()?,
        })
    }

    /// Shares `control` with every technique this benchmark creates: a long precompute (the
    /// PDSM's) counts its progress there and stops when its `cancel` flag is set (the run then
    /// fails with "cancelled").
    pub fn set_build_control(&mut self, control: Option<BuildControl>) {
        self.build_control = control;
    }

    /// How this benchmark times passes: [`TimingSource::default_for`] the adapter (`serial` on a
    /// CPU adapter, `timestamps` on a GPU) unless set with [`Bench::set_timing`].
    pub fn timing_source(&self) -> TimingSource {
        self.timing
    }

    /// Times passes with `source` (`None`: the adapter's default). With `timestamps` every run
    /// also renders one calibration frame serially and warns (`timing.warnings`) of passes whose
    /// timestamps miss their work.
    pub fn set_timing(&mut self, source: Option<TimingSource>) {
        self.timing = source.unwrap_or_else(|| TimingSource::default_for(&self.gpu));
    }

    /// The techniques this benchmark knows.
    pub fn registry(&self) -> &Registry {
        &self.registry
    }

    pub fn adapter(&self) -> results::Adapter {
        let s = self.gpu.summary();
        results::Adapter {
            name: s.name,
            backend: s.backend,
            driver: s.driver,
        }
    }

    /// Sees every scene from `camera` and lights it with `light` instead of the scene's own
    /// (`None` keeps the scene's): how a sweep exported by the viewer measures the view it plotted.
    pub fn set_view(&mut self, camera: Option<Camera>, light: Option<AreaLight>) {
        self.camera = camera;
        self.light = light;
        // References were computed for the previous view.
        self.references.clear();
    }

    /// Runs one spec; never fails: errors are recorded in the returned [`Run`]. A run that
    /// loses the device is recorded with the driver's message, and a new device is made for
    /// the next run, on the same adapter.
    pub fn run(&mut self, index: usize, spec: &RunSpec, out_dir: &Path) -> Run {
        puffin::profile_function!();
        let mut run = Run::new(index, spec);
        // A light kind the technique does not support: recorded, no GPU work, the sweep goes on.
        match light_refusal(&self.registry, spec, self.light.as_ref()) {
            Ok((kind, None)) => run.light_kind = Some(kind.to_string()),
            Ok((kind, Some(why))) => {
                run.light_kind = Some(kind.to_string());
                run.status = Status::Unsupported;
                run.message = why;
                return run;
            }
            Err(e) => {
                run.status = Status::Error;
                run.message = e.to_string();
                return run;
            }
        }
        let result = self.faults.at_start(index, &self.gpu).and_then(|()| {
            match spec.path.clone().or_else(|| self.options.path.clone()) {
                Some(path) => self.run_path(index, spec, &path, out_dir, &mut run),
                None => self.run_inner(index, spec, out_dir, &mut run),
            }
        });
        if let Err(e) = result {
            run.status = Status::Error;
            run.message = e.to_string();
            // A failed run may leave GPU errors behind; clear them so the next run starts clean.
            let _ = self.gpu.take_errors();
        }
        if let Some(why) = self.gpu.lost() {
            run.status = Status::Error;
            run.message = format!("the GPU device was lost during this run: {why}");
            if let Err(e) = self.recover() {
                run.message
                    .push_str(&format!("; and no new device could be made: {e}"));
            }
        }
        run
    }

    /// Replaces a lost device with a new one on the same adapter. Everything made on the old
    /// device goes (scenes, renderers, the reference technique); the references already
    /// computed are CPU data and stay.
    fn recover(&mut self) -> Result<(), BenchError> {
        let gpu = self.gpu.new_device()?;
        self.scenes.clear();
        self.renderers.clear();
        self.reference = None;
        self.gpu = gpu;
        Ok(())
    }

    /// Loads `spec`'s scene (once per benchmark) and makes a renderer of its size (once per size).
    fn load_scene_and_renderer(&mut self, spec: &RunSpec) -> Result<(), BenchError> {
        if !self.scenes.contains_key(&spec.scene) {
            let resident_before = resident_mib("VmRSS");
            let start = std::time::Instant::now();
            let loaded = softshadow_scenes::load(&spec.scene)?;
            let load_s = start.elapsed().as_secs_f64();
            let load_peak_mib = resident_mib("VmHWM")
                .zip(resident_before)
                .map(|(p, b)| p - b);
            let start = std::time::Instant::now();
            let gpu_scene = SceneGpu::upload(&self.gpu, &loaded.scene);
            let load = results::SceneLoad {
                triangles: loaded.scene.triangle_count(),
                load_s,
                upload_s: start.elapsed().as_secs_f64(),
                load_peak_mib,
            };
            self.scenes.insert(
                spec.scene.clone(),
                LoadedScene {
                    scene: loaded.scene,
                    gpu: gpu_scene,
                    warnings: loaded.warnings,
                    paths: loaded.paths,
                    load,
                },
            );
        }
        let key = (spec.width, spec.height);
        if !self.renderers.contains_key(&key) {
            self.renderers
                .insert(key, Renderer::new(&self.gpu, spec.width, spec.height)?);
        }
        Ok(())
    }

    fn run_inner(
        &mut self,
        index: usize,
        spec: &RunSpec,
        out_dir: &Path,
        run: &mut Run,
    ) -> Result<(), BenchError> {
        let edge = self.gpu.device.limits().max_texture_dimension_2d;
        check_size_within(spec.width, spec.height, edge)?;
        let info = resolve_technique(&self.registry, &spec.technique)?;
        self.load_scene_and_renderer(spec)?;
        let memory_baseline = self.memory_without_technique()?;
        let mut technique = self.create_technique(&info, spec, run)?;
        self.faults.in_the_middle(index, &self.gpu);
        let scene = &self.scenes[&spec.scene];
        run.warnings = scene.warnings.clone();
        run.scene_load = Some(scene.load);
        let renderer = self
            .renderers
            .get_mut(&(spec.width, spec.height))
            .expect("inserted above");
        renderer.timing = self.timing;
        let mut still = StillView {
            renderer,
            scene: &scene.gpu,
            camera: self.camera.unwrap_or(scene.scene.camera),
            light: self.light.unwrap_or(scene.scene.light),
            technique: technique.as_mut(),
        };
        let inputs = still
            .renderer
            .inputs(still.scene, &still.camera, &still.light);
        still.technique.prepare(&self.gpu, &inputs)?;

        let memory_peak = still.time_frames(&self.options, run)?;
        if self.gpu.counts_memory() {
            run.memory = Some(results::TechniqueMemory {
                current: self.gpu.memory_in_use().since(memory_baseline),
                peak: memory_peak.since(memory_baseline),
            });
        }
        run.stats = still.technique.stats();
        let images = still.last_images(info.settle_frames_at(&spec.params), run)?;

        let stem = format!("{index:03}_{}_{}", sanitize(&spec.scene), spec.technique);
        if self.options.images {
            let name = format!("{stem}_visibility.exr");
            let (width, height) = (spec.width, spec.height);
            output::write_exr_gray(&out_dir.join(&name), width, height, &images.visibility)?;
            run.images.insert("visibility".into(), name);
            let name = format!("{stem}_shaded.png");
            output::write_png(&out_dir.join(&name), width, height, 3, &images.shaded)?;
            run.images.insert("shaded".into(), name);
        }
        if self.options.error {
            let write_images = self.options.images;
            let reference = self.reference_for(spec, out_dir)?;
            measure_against_reference(reference, &images, spec, run)?;
            if write_images {
                let name = format!("{stem}_difference.png");
                write_difference_image(&images, reference, spec, &out_dir.join(&name))?;
                run.images.insert("difference".into(), name);
            }
        }
        Ok(())
    }

    /// `spec`'s technique with its settings, sharing this benchmark's build control; its
    /// settings, defaults filled in, go into `run.params`.
    fn create_technique(
        &self,
        info: &TechniqueInfo,
        spec: &RunSpec,
        run: &mut Run,
    ) -> Result<Box<dyn ShadowTechnique>, BenchError> {
        let mut technique = info.create_with(&self.gpu, &spec.params)?;
        if let Some(control) = &self.build_control {
            technique.set_build_control(control.clone());
        }
        run.params = technique.params().to_map();
        Ok(technique)
    }

    /// What the device holds without the technique: the scene, the renderer, the reference kept
    /// from earlier runs (the wait frees what earlier runs dropped). The empty submit first
    /// flushes the queue's pending writes, whose staging buffers (a scene's `create_buffer_init`
    /// uploads) would otherwise be in the baseline and freed by the technique's first frame,
    /// hiding as many bytes of what it creates.
    fn memory_without_technique(&self) -> Result<MemoryUse, BenchError> {
        self.gpu.queue.submit([]);
        self.gpu.wait_idle()?;
        Ok(self.gpu.memory_in_use())
    }

    /// The reference for this scene and size, computed once per benchmark (or read from the
    /// reference cache).
    fn reference_for(
        &mut self,
        spec: &RunSpec,
        out_dir: &Path,
    ) -> Result<&ReferenceResult, BenchError> {
        let key = (spec.scene.clone(), spec.width, spec.height);
        match self.references.get_mut(&key) {
            // Only the first run says the entry was rebuilt; later ones use what is now stored.
            Some(known) => {
                if let Some(ReferenceCacheUse::Rebuilt(_)) = known.cache_use {
                    known.cache_use = Some(ReferenceCacheUse::Stored);
                }
            }
            None => {
                let result = self.make_reference(spec, out_dir)?;
                self.references.insert(key.clone(), result);
            }
        }
        Ok(&self.references[&key])
    }

    fn make_reference(
        &mut self,
        spec: &RunSpec,
        out_dir: &Path,
    ) -> Result<ReferenceResult, BenchError> {
        let info = self.registry.yardstick()?;
        let shaders = info.shaders;
        if self.reference.is_none() {
            self.reference = Some(info.create_with(&self.gpu, &self.options.reference_params)?);
        }
        let scene = &self.scenes[&spec.scene];
        let mut view = StillView {
            renderer: self
                .renderers
                .get_mut(&(spec.width, spec.height))
                .expect("created by the run"),
            scene: &scene.gpu,
            camera: self.camera.unwrap_or(scene.scene.camera),
            light: self.light.unwrap_or(scene.scene.light),
            technique: self.reference.as_deref_mut().expect("created above"),
        };
        let label = yardstick_label(view.technique);
        let method = self.options.exact_method();
        let sampled = method.map(|m| m.key_on(Some(&self.gpu)));
        let cache = self.options.reference_cache.as_deref().map(|dir| {
            let key = ReferenceKey {
                scene: &scene.scene,
                camera: &view.camera,
                light: &view.light,
                width: spec.width,
                height: spec.height,
                label: &label,
                shaders,
                exact_method: sampled.as_deref(),
            };
            (reference_cache::in_dir(dir), key.hash())
        });

        let pixels = (spec.width * spec.height) as usize;
        let (found, mut cache_use) = match &cache {
            Some((cache, key)) => look_up_reference(cache, *key, pixels),
            None => (None, None),
        };
        let mut exact_warning = None;
        let cached = match found {
            Some(found) => {
                cache_use = Some(ReferenceCacheUse::Hit);
                found
            }
            None => {
                let control = self.build_control.as_ref();
                let (made, warning) =
                    view.reference_images(&scene.scene, label, method, &self.gpu, control)?;
                exact_warning = warning;
                if let Some((cache, key)) = &cache {
                    if let Err(e) = cache.store(*key, &reference_cache::encode(&made)) {
                        cache_use = Some(not_stored(&cache.dir, e));
                    }
                }
                made
            }
        };

        let CachedReference {
            label,
            visibility,
            shaded_rgb,
            exact,
            exact_sampling_error,
            exact_irradiance,
        } = cached;
        let exact = match exact {
            Some((label, exact)) => Some(ExactResult::of_reference(
                label,
                exact,
                &visibility,
                exact_sampling_error,
                exact_irradiance.as_ref(),
                &view.renderer.read_receiver_mask()?,
            )?),
            None => None,
        };
        let images = if self.options.images {
            write_reference_images(out_dir, spec, &visibility, &shaded_rgb, exact.as_ref())?
        } else {
            BTreeMap::new()
        };
        Ok(ReferenceResult {
            visibility,
            shaded_rgb,
            label,
            images,
            exact,
            cache_use,
            exact_warning,
        })
    }
}

/// `reference(name=value,...)`: the yardstick with its settings, as results name it.
fn yardstick_label(reference: &dyn ShadowTechnique) -> String {
    let settings: Vec<String> = reference
        .params()
        .entries
        .iter()
        .map(|(s, v)| format!("{}={v}", s.name))
        .collect();
    format!("{YARDSTICK_TECHNIQUE}({})", settings.join(","))
}

/// The reference cached under `key`, or (none and) what rendering it will count as.
fn look_up_reference(
    cache: &DiskCache,
    key: u64,
    pixels: usize,
) -> (Option<CachedReference>, Option<ReferenceCacheUse>) {
    match cache.load(key).and_then(|payload| {
        payload
            .map(|p| reference_cache::decode(&p, pixels))
            .transpose()
    }) {
        Ok(Some(found)) => (Some(found), None),
        Ok(None) => (None, Some(ReferenceCacheUse::Stored)),
        Err(why) => (
            None,
            Some(ReferenceCacheUse::Rebuilt(format!(
                "a reference cache entry cannot be trusted ({why}): rendered again and stored"
            ))),
        ),
    }
}

/// A reference cache in `dir` that cannot be written (`error`): that costs time, not results.
fn not_stored(dir: &Path, error: impl std::fmt::Display) -> ReferenceCacheUse {
    ReferenceCacheUse::NotStored(format!(
        "cannot write the reference cache in {} ({error}): the reference is used but not kept; point --reference-cache at a writable folder",
        dir.display()
    ))
}

impl ExactResult {
    /// The exact answer `exact` (named `label`) with the reference's (`reference`) and no
    /// shadow's errors against it, in visibility and, with the exact `irradiance`, in irradiance.
    fn of_reference(
        label: String,
        exact: Vec<f32>,
        reference: &[f32],
        sampling_error: Option<f64>,
        irradiance: Option<&softshadow_reference::ExactIrradiance>,
        mask: &[bool],
    ) -> Result<Self, BenchError> {
        let reference_vs_exact = softshadow_metrics::compare(reference, &exact, mask)?;
        let all_lit = vec![1.0; exact.len()];
        let all_lit_vs_exact = softshadow_metrics::compare(&all_lit, &exact, mask)?;
        let irradiance_of = |v: &[f32], e: &softshadow_reference::ExactIrradiance| {
            softshadow_metrics::compare_irradiance(v, &exact, &e.irradiance, &e.unoccluded, mask)
        };
        let irradiance = match irradiance {
            Some(e) => Some(ExactIrradianceResult {
                reference_vs_exact: irradiance_of(reference, e)?,
                all_lit_vs_exact: irradiance_of(&all_lit, e)?,
                images: e.clone(),
            }),
            None => None,
        };
        Ok(Self {
            visibility: exact,
            label,
            sampling_error,
            reference_vs_exact,
            all_lit_vs_exact,
            irradiance,
        })
    }
}

/// Writes the reference's images (visibility, shaded, and the exact answer when there is one)
/// to `out_dir`; returns their file names by image name.
fn write_reference_images(
    out_dir: &Path,
    spec: &RunSpec,
    visibility: &[f32],
    shaded_rgb: &[u8],
    exact: Option<&ExactResult>,
) -> Result<BTreeMap<String, String>, BenchError> {
    let (width, height) = (spec.width, spec.height);
    let stem = format!("reference_{}_{width}x{height}", sanitize(&spec.scene));
    let mut images = BTreeMap::new();
    let name = format!("{stem}.exr");
    output::write_exr_gray(&out_dir.join(&name), width, height, visibility)?;
    images.insert(YARDSTICK_TECHNIQUE.into(), name);
    let name = format!("{stem}_shaded.png");
    output::write_png(&out_dir.join(&name), width, height, 3, shaded_rgb)?;
    images.insert(format!("{YARDSTICK_TECHNIQUE}_shaded"), name);
    if let Some(exact) = exact {
        let name = format!("{stem}_exact.exr");
        output::write_exr_gray(&out_dir.join(&name), width, height, &exact.visibility)?;
        images.insert("exact".into(), name);
    }
    Ok(images)
}

/// A still run's view: `technique` drawn by `renderer` on one scene from one camera under one
/// light.
struct StillView<'a> {
    renderer: &'a mut Renderer,
    scene: &'a SceneGpu,
    camera: Camera,
    light: AreaLight,
    technique: &'a mut dyn ShadowTechnique,
}

/// The last frame of a still run as read back, for its images and its error.
struct StillImages {
    visibility: Vec<f32>,
    /// RGB.
    shaded: Vec<u8>,
    mask: Vec<bool>,
    /// Each pixel's distance from the camera (infinite where no surface is seen), for the
    /// errors per distance band.
    distance: Vec<f32>,
    /// A technique that accumulates: the still frames it took to settle, their timing and the
    /// last one's visibility.
    settled: Option<(u32, results::Timing, Vec<f32>)>,
}

impl StillView<'_> {
    /// One shaded frame, seen from `camera`.
    fn frame_from(&mut self, camera: &Camera) -> Result<FrameOutput, RenderError> {
        self.renderer.render(
            self.scene,
            camera,
            &self.light,
            &mut *self.technique,
            Some(ShadingMode::Shaded),
        )
    }

    /// One shaded frame from the view's camera.
    fn frame(&mut self) -> Result<FrameOutput, RenderError> {
        let camera = self.camera;
        self.frame_from(&camera)
    }

    /// One shaded frame that builds everything again (nothing kept from the frame before).
    fn rebuilt_frame(&mut self) -> Result<FrameOutput, RenderError> {
        self.technique.invalidate_cache();
        self.frame()
    }

    /// The timed frames of a run: the cold first frame (`run.cold`), the warm-up, the frames in
    /// which only the camera moves (`run.timing_camera_only`, when `options` ask for them) and
    /// the full-cost frames (`run.timing`, `run.passes_run`). Returns the most GPU memory the
    /// device held in any of them.
    fn time_frames(
        &mut self,
        options: &BenchOptions,
        run: &mut Run,
    ) -> Result<MemoryUse, BenchError> {
        // The first frame, cold (nothing built or loaded yet), is timed on its own and counts
        // as the first warm-up frame.
        let (cold, cold_passes, mut memory_peak) = time_frames(1, |_| self.frame())?;
        run.cold = Some(results::ColdFrame {
            timing: results::Timing {
                passes_run: Some(cold_passes),
                ..cold
            },
            stats: self.technique.stats(),
        });
        for _ in 1..options.warmup {
            self.rebuilt_frame()?;
        }
        if options.camera_only {
            let (timing, peak) = self.time_camera_only(options.frames)?;
            run.timing_camera_only = Some(timing);
            memory_peak = memory_peak.max_by_total(peak);
        }
        // Full cost: every frame rebuilds everything (the reference keeps its image between
        // frames, every technique its light-space maps), so the timing measures the work.
        let (mut timing, passes, peak) = time_frames(options.frames, |_| self.rebuilt_frame())?;
        if self.renderer.timing == TimingSource::Timestamps {
            self.calibrate(&mut timing)?;
        }
        run.timing = Some(timing);
        run.passes_run = passes;
        Ok(memory_peak.max_by_total(peak))
    }

    /// `frames` frames in which only the camera moves (an orbit), light-space work built once
    /// before them (untimed); their timing and memory peak.
    fn time_camera_only(
        &mut self,
        frames: u32,
    ) -> Result<(results::Timing, MemoryUse), BenchError> {
        self.rebuilt_frame()?;
        let camera = self.camera;
        let (timing, passes, peak) =
            time_frames(frames, |k| self.frame_from(&orbit_camera(&camera, k)))?;
        let timing = results::Timing {
            passes_run: Some(passes),
            ..timing
        };
        Ok((timing, peak))
    }

    /// Calibration of timestamp timings (issue 14): one full-cost frame timed serially on the
    /// same adapter; each pass's serial time goes beside its timestamp time, and a pass whose
    /// timestamps miss its work is warned of.
    fn calibrate(&mut self, timing: &mut results::Timing) -> Result<(), BenchError> {
        let timing_source = self.renderer.timing;
        self.renderer.timing = TimingSource::Serial;
        let serial = self.rebuilt_frame();
        self.renderer.timing = timing_source;
        if let Some(serial) = serial?.gpu {
            timing.warnings = calibration_warnings(&timing.passes, &serial.passes);
            for pass in &mut timing.passes {
                pass.serial_ms = serial
                    .passes
                    .iter()
                    .find(|(n, _)| *n == pass.name)
                    .map(|(_, ms)| *ms);
            }
        }
        Ok(())
    }

    /// Reads the last frame back, measures its stability and the flicker of one more frame with
    /// nothing changed (`run.stability`, `run.still_flicker`), then renders the `settle_frames`
    /// of a technique that accumulates.
    fn last_images(
        &mut self,
        settle_frames: Option<u32>,
        run: &mut Run,
    ) -> Result<StillImages, BenchError> {
        let visibility = self.renderer.read_visibility()?;
        let shaded = output::rgba_to_rgb(&self.renderer.read_shaded()?);
        let mask = self.renderer.read_receiver_mask()?;
        let eye = self.camera.eye;
        let distance = (self.renderer.read_world_positions()?.iter())
            .map(|p| p.map_or(f32::INFINITY, |p| p.distance(eye)))
            .collect();
        run.stability = Some(softshadow_metrics::stability(&visibility));
        // One more frame with nothing changed, as a renderer's next frame: what a still picture
        // shows changing (the exact answer does not change, so it stands in for both).
        self.frame()?;
        let next = self.renderer.read_visibility()?;
        run.still_flicker = Some(softshadow_metrics::flicker(
            (&visibility, &visibility, &mask),
            (&next, &visibility, &mask),
        )?);
        // A technique that accumulates: the still frames it takes to settle (after the one
        // above), timed, then its last frame (measured with the error).
        let settled = match settle_frames {
            Some(frames) => {
                let (timing, _, _) = time_frames(frames.saturating_sub(1).max(1), |_| {
                    let (scene, camera, light) = (self.scene, &self.camera, &self.light);
                    self.renderer
                        .render(scene, camera, light, &mut *self.technique, None)
                })?;
                Some((frames, timing, self.renderer.read_visibility()?))
            }
            None => None,
        };
        Ok(StillImages {
            visibility,
            shaded,
            mask,
            distance,
            settled,
        })
    }

    /// Renders the view's technique (the yardstick) and, with `method`, the exact answer of
    /// `scene` as the view sees and lights it (a sweep's `[camera]` / `[light]` replace the
    /// scene's own); returns them as the reference cache keeps them (named `label`), with why the
    /// exact answer is not the one asked for, if so.
    fn reference_images(
        &mut self,
        scene: &Scene,
        label: String,
        method: Option<softshadow_reference::ExactMethod>,
        gpu: &Gpu,
        control: Option<&BuildControl>,
    ) -> Result<(CachedReference, Option<String>), BenchError> {
        self.frame()?;
        let mut made = CachedReference {
            label,
            visibility: self.renderer.read_visibility()?,
            shaded_rgb: output::rgba_to_rgb(&self.renderer.read_shaded()?),
            exact: None,
            exact_sampling_error: None,
            exact_irradiance: None,
        };
        let Some(method) = method else {
            return Ok((made, None));
        };
        puffin::profile_scope!("exact ground truth");
        let positions = self.renderer.read_world_positions()?;
        let normals = self.renderer.read_world_normals()?;
        let mask = self.renderer.read_receiver_mask()?;
        let viewed = Scene {
            camera: self.camera,
            light: self.light,
            ..scene.clone()
        };
        let answer = softshadow_reference::exact_answer(
            Some(gpu),
            &viewed,
            &positions,
            Some(&normals),
            &mask,
            method,
            control,
        )?;
        made.exact_sampling_error = answer.sampling_error(&mask);
        made.exact_irradiance = answer.irradiance;
        made.exact = Some((answer.truth.to_string(), answer.visibility));
        Ok((made, answer.fallback))
    }
}

/// Measures a still run's last frame against `reference` (and its exact answer, when it has one)
/// into `run.error` and `run.settled`; takes the reference's cache use, warnings and images into
/// `run`.
fn measure_against_reference(
    reference: &ReferenceResult,
    images: &StillImages,
    spec: &RunSpec,
    run: &mut Run,
) -> Result<(), BenchError> {
    run.reference_cache = reference.cache_use.clone();
    if let Some(why) = &reference.exact_warning {
        run.warnings.push(why.clone());
    }
    if let Some(ReferenceCacheUse::Rebuilt(why) | ReferenceCacheUse::NotStored(why)) =
        &run.reference_cache
    {
        run.warnings.push(why.clone());
    }
    let StillImages {
        visibility,
        mask,
        distance,
        ..
    } = images;
    let mut report = softshadow_metrics::compare(visibility, &reference.visibility, mask)?;
    report.flip_mean = Some(softshadow_metrics::flip_mean(
        &images.shaded,
        &reference.shaded_rgb,
        spec.width,
        spec.height,
    )?);
    let exact = reference.exact.as_ref();
    let vs_exact = match exact {
        Some(exact) => Some(softshadow_metrics::compare(
            visibility,
            &exact.visibility,
            mask,
        )?),
        None => None,
    };
    if let Some((frames, timing, settled)) = &images.settled {
        run.settled = Some(results::Settled {
            frames: *frames,
            timing: timing.clone(),
            report: softshadow_metrics::compare(settled, &reference.visibility, mask)?,
            vs_exact: match exact {
                Some(exact) => Some(softshadow_metrics::compare(
                    settled,
                    &exact.visibility,
                    mask,
                )?),
                None => None,
            },
        });
    }
    let irradiance = match exact.map(|e| (e, &e.irradiance)) {
        Some((exact, Some(i))) => Some(results::IrradianceFields {
            vs_exact: softshadow_metrics::compare_irradiance(
                visibility,
                &exact.visibility,
                &i.images.irradiance,
                &i.images.unoccluded,
                mask,
            )?,
            reference_vs_exact: i.reference_vs_exact,
            all_lit_vs_exact: i.all_lit_vs_exact,
        }),
        _ => None,
    };
    run.error = Some(results::ErrorFields {
        reference: reference.label.clone(),
        report,
        exact: exact.map(|e| e.label.clone()),
        exact_sampling_error: exact.and_then(|e| e.sampling_error),
        vs_exact,
        reference_vs_exact: exact.map(|e| e.reference_vs_exact.clone()),
        all_lit_vs_exact: exact.map(|e| e.all_lit_vs_exact.clone()),
        irradiance,
        distance_bands: match exact {
            Some(exact) => Some(softshadow_metrics::distance_bands(
                visibility,
                &exact.visibility,
                mask,
                distance,
            )?),
            None => None,
        },
    });
    run.images.extend(reference.images.clone());
    Ok(())
}

/// The difference of a still run's last frame from `reference`, as a PNG at `path`.
fn write_difference_image(
    images: &StillImages,
    reference: &ReferenceResult,
    spec: &RunSpec,
    path: &Path,
) -> Result<(), BenchError> {
    let diff = softshadow_metrics::difference_image(
        &images.visibility,
        &reference.visibility,
        &images.mask,
        spec.width,
        spec.height,
    )?;
    output::write_png(path, spec.width, spec.height, 3, diff.as_raw())
}

/// File-name-safe form of a scene spec (ids may carry `:key=value,...`; paths have slashes).
/// Degrees the camera turns about the scene's up axis per camera-only frame.
pub const ORBIT_STEP_DEGREES: f32 = 1.0;

/// The camera of camera-only frame `k`: the scene's camera turned `(k + 1)` x
/// [`ORBIT_STEP_DEGREES`] about the vertical axis through its target (a small deterministic
/// orbit, so the G-buffer changes every frame while light and casters stand still).
pub fn orbit_camera(camera: &Camera, k: u32) -> Camera {
    let angle = ((k + 1) as f32 * ORBIT_STEP_DEGREES).to_radians();
    let rotation =
        softshadow_core::glam::Quat::from_axis_angle(softshadow_core::glam::Vec3::Y, angle);
    Camera {
        eye: camera.target + rotation * (camera.eye - camera.target),
        up: rotation * camera.up,
        ..*camera
    }
}

/// A timestamp pass time below this fraction of the pass's serial wall time is flagged.
pub const CALIBRATION_FRACTION: f64 = 0.25;
/// Passes whose serial wall time is below this are not flagged: there the round trip of the
/// serial submission, not the pass's work, dominates.
pub const CALIBRATION_FLOOR_MS: f64 = 0.5;

/// Warnings for passes whose timestamp time (`timestamps`, medians) is below
/// [`CALIBRATION_FRACTION`] of their serial wall time (`serial`, one frame).
pub fn calibration_warnings(
    timestamps: &[results::PassTiming],
    serial: &[(String, f64)],
) -> Vec<String> {
    serial
        .iter()
        .filter_map(|(name, serial_ms)| {
            let stamped = timestamps.iter().find(|p| &p.name == name)?.ms_median;
            (*serial_ms >= CALIBRATION_FLOOR_MS && stamped < CALIBRATION_FRACTION * serial_ms)
                .then(|| {
                    format!(
                        "{name}: timestamps read {stamped:.3} ms but the pass takes {serial_ms:.3} ms submitted on its own; \
                         this adapter's timestamps do not cover its work: use --timing serial"
                    )
                })
        })
        .collect()
}

/// Renders `frames` frames (`render(k)` draws frame `k`) and summarises their timings; returns
/// them with the passes the last frame ran and the most GPU memory the device held in any.
fn time_frames(
    frames: u32,
    mut render: impl FnMut(u32) -> Result<FrameOutput, RenderError>,
) -> Result<(results::Timing, Vec<String>, MemoryUse), BenchError> {
    let mut timings = TimingAccumulator::default();
    let mut passes_run = Vec::new();
    let mut memory_peak = MemoryUse::default();
    for k in 0..frames {
        let output = render(k)?;
        timings.push(&output);
        memory_peak = memory_peak.max_by_total(output.memory_peak);
        passes_run = output.passes_run;
    }
    Ok((timings.finish(), passes_run, memory_peak))
}

/// Frame timings gathered one frame at a time and summarised as a [`results::Timing`] (only the
/// per-frame numbers are kept, never images).
#[derive(Default)]
pub(crate) struct TimingAccumulator {
    frames: u32,
    gpu_total: Vec<f64>,
    gpu_technique: Vec<f64>,
    cpu: Vec<f64>,
    per_pass: BTreeMap<String, Vec<f64>>,
    pass_order: Vec<String>,
    source: Option<TimingSource>,
}

impl TimingAccumulator {
    pub(crate) fn push(&mut self, output: &FrameOutput) {
        self.frames += 1;
        self.source = Some(output.timing_source);
        self.cpu.push(output.cpu_ms);
        if let Some(gpu) = &output.gpu {
            self.gpu_total.push(gpu.total_ms);
            self.gpu_technique.push(gpu.technique_ms());
            for (name, ms) in &gpu.passes {
                self.per_pass.entry(name.clone()).or_default().push(*ms);
                if !self.pass_order.contains(name) {
                    self.pass_order.push(name.clone());
                }
            }
        }
    }

    pub(crate) fn finish(self) -> results::Timing {
        results::Timing {
            frames: self.frames,
            source: self.source.unwrap_or(TimingSource::Timestamps),
            frame_ms: (!self.gpu_total.is_empty()).then(|| results::percentiles(&self.gpu_total)),
            technique_ms: (!self.gpu_technique.is_empty())
                .then(|| results::percentiles(&self.gpu_technique)),
            passes: self
                .pass_order
                .iter()
                .map(|name| results::PassTiming {
                    name: name.clone(),
                    ms_median: results::percentile(&self.per_pass[name], 0.5),
                    serial_ms: None,
                })
                .collect(),
            cpu_ms: results::Median {
                median: results::percentile(&self.cpu, 0.5),
            },
            passes_run: None,
            warnings: Vec::new(),
        }
    }
}

pub fn sanitize(text: &str) -> String {
    let name = Path::new(text)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| text.to_string());
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Runs all specs, writes `out_dir/results.json` (atomically) and returns the results.
/// `progress` is called after each run.
pub fn run_all(
    gpu: Gpu,
    registry: &Registry,
    specs: &[RunSpec],
    options: BenchOptions,
    out_dir: &Path,
    progress: impl FnMut(usize, &Run),
) -> Result<Results, BenchError> {
    let indexed: Vec<(usize, RunSpec)> = specs.iter().cloned().enumerate().collect();
    run_indexed(
        gpu,
        &indexed,
        RunSetup {
            registry: registry.clone(),
            ..RunSetup::default()
        },
        options,
        out_dir,
        progress,
    )
}

/// How a set of runs is made beyond [`BenchOptions`]: the techniques it may run, which sweep
/// (and shard) they belong to, the timing source ([`Bench::set_timing`]) and a camera and light
/// that replace every scene's own ([`Bench::set_view`]; a sweep's `[camera]` and `[light]`).
#[derive(Clone, Debug, Default)]
pub struct RunSetup {
    /// The techniques the runs name (the built-ins and any a user adds).
    pub registry: Registry,
    /// The command that makes these runs, recorded in results.json (`Results::command`).
    pub command: Vec<String>,
    /// The binary that ran it (`Results::program`).
    pub program: String,
    pub sweep: Option<SweepInfo>,
    pub timing: Option<TimingSource>,
    pub camera: Option<Camera>,
    pub light: Option<AreaLight>,
    /// Progress and cancellation of long precomputes ([`Bench::set_build_control`]); once its
    /// `cancel` flag is set no further run starts: the results hold the runs done so far (the
    /// one cancelled included, failed with its message).
    pub build_control: Option<BuildControl>,
}

/// Like [`run_all`] for runs that carry their index in a sweep (a shard, see
/// [`Sweep::shard`]), made as `setup` says (recorded in results.json).
pub fn run_indexed(
    gpu: Gpu,
    specs: &[(usize, RunSpec)],
    setup: RunSetup,
    options: BenchOptions,
    out_dir: &Path,
    progress: impl FnMut(usize, &Run),
) -> Result<Results, BenchError> {
    run_resumed(gpu, specs, setup, options, out_dir, Vec::new(), progress)
}

/// Like [`run_indexed`], continuing an interrupted benchmark: `finished` are the runs its
/// results.json already holds; runs of `specs` whose index is among them are skipped. The
/// results.json is rewritten (atomically) after every run, so an interrupted benchmark keeps
/// every finished run; runs are kept in index order.
pub fn run_resumed(
    gpu: Gpu,
    specs: &[(usize, RunSpec)],
    setup: RunSetup,
    options: BenchOptions,
    out_dir: &Path,
    finished: Vec<Run>,
    progress: impl FnMut(usize, &Run),
) -> Result<Results, BenchError> {
    output::prepare_out_dir(out_dir, &remaining(specs, &finished), &options)?;
    let mut bench = Bench::new(gpu, setup.registry.clone(), options)?;
    bench.set_timing(setup.timing);
    bench.set_view(setup.camera, setup.light);
    bench.set_build_control(setup.build_control.clone());
    let adapter = bench.adapter();
    let cancelled = cancel_flag(&setup);
    let run_one = |index: usize, spec: &RunSpec| {
        let run = bench.run(index, spec, out_dir);
        // The run the cancel interrupted is left out, so `bench --resume` makes it again.
        (!(cancelled() && run.status == Status::Error)).then_some(run)
    };
    sweep(adapter, specs, &setup, out_dir, finished, progress, run_one)
}

/// Like [`run_resumed`], each run in a process of its own ([`isolate`]): a run that hangs is
/// killed at its time limit, one whose process crashes is recorded with how it ended, and the
/// next run gets a fresh process and device. This process does no GPU work.
#[allow(clippy::too_many_arguments)]
pub fn run_isolated(
    isolation: &isolate::Isolation,
    specs: &[(usize, RunSpec)],
    setup: RunSetup,
    options: BenchOptions,
    out_dir: &Path,
    finished: Vec<Run>,
    progress: impl FnMut(usize, &Run),
) -> Result<Results, BenchError> {
    output::prepare_out_dir(out_dir, &remaining(specs, &finished), &options)?;
    check_options(&setup.registry, &options)?;
    // What every run's process would refuse, refused once here.
    fault::Faults::from_env()?;
    let adapter = match &isolation.adapter {
        Some(adapter) => adapter.clone(),
        None => Gpu::headless_adapter_summary()?,
    };
    let adapter = results::Adapter {
        name: adapter.name,
        backend: adapter.backend,
        driver: adapter.driver,
    };
    // Without a cache of the user's, a private one spares each run's process the references.
    let private_cache = out_dir.join(isolate::PRIVATE_CACHE_DIR);
    let private = options.reference_cache.is_none();
    let job_options = BenchOptions {
        reference_cache: Some(
            options
                .reference_cache
                .clone()
                .unwrap_or(private_cache.clone()),
        ),
        ..options.clone()
    };
    let cancelled = cancel_flag(&setup);
    let run_one = |index: usize, spec: &RunSpec| {
        let job = isolate::Job {
            index,
            spec: spec.clone(),
            options: job_options.clone(),
            timing: setup.timing,
            camera: setup.camera,
            light: setup.light,
            out_dir: out_dir.to_path_buf(),
        };
        let limit = isolation
            .run_timeout
            .unwrap_or_else(|| isolate::time_limit(&setup.registry, spec, &options));
        let mut run = isolation.run(&job, limit, &cancelled)?;
        if private {
            isolate::forget_private_cache(&mut run);
        }
        Some(run)
    };
    let results = sweep(adapter, specs, &setup, out_dir, finished, progress, run_one)?;
    if private && !cancelled() {
        let _ = std::fs::remove_dir_all(&private_cache);
    }
    Ok(results)
}

/// The runs of `specs` that `finished` lacks.
pub fn remaining(specs: &[(usize, RunSpec)], finished: &[Run]) -> Vec<(usize, RunSpec)> {
    specs
        .iter()
        .filter(|(index, _)| !finished.iter().any(|run| run.index == *index))
        .cloned()
        .collect()
}

/// Whether `setup`'s build control has been cancelled (Ctrl-C).
fn cancel_flag(setup: &RunSetup) -> impl Fn() -> bool + '_ {
    || {
        setup
            .build_control
            .as_ref()
            .is_some_and(BuildControl::is_cancelled)
    }
}

/// Makes the runs of `specs` not in `finished` with `run_one` (`None`: cancelled, left out and
/// the sweep stopped), rewriting `out_dir/results.json` after each.
fn sweep(
    adapter: results::Adapter,
    specs: &[(usize, RunSpec)],
    setup: &RunSetup,
    out_dir: &Path,
    finished: Vec<Run>,
    mut progress: impl FnMut(usize, &Run),
    mut run_one: impl FnMut(usize, &RunSpec) -> Option<Run>,
) -> Result<Results, BenchError> {
    let mut results = Results {
        schema_version: results::SCHEMA_VERSION,
        adapter,
        command: setup.command.clone(),
        program: setup.program.clone(),
        date: results::today_utc(),
        load: results::MachineLoad::now(),
        sweep: setup.sweep.clone(),
        runs: finished,
    };
    let cancelled = cancel_flag(setup);
    let done: std::collections::HashSet<usize> = results.runs.iter().map(|r| r.index).collect();
    let todo: Vec<&(usize, RunSpec)> = specs.iter().filter(|(i, _)| !done.contains(i)).collect();
    for (k, (index, spec)) in todo.into_iter().enumerate() {
        let Some(run) = run_one(*index, spec) else {
            break;
        };
        progress(k, &run);
        results.runs.push(run);
        results.runs.sort_by_key(|r| r.index);
        expectations::judge(&setup.registry, &mut results.runs);
        if let Some(load) = &mut results.load {
            load.update();
        }
        write_results(&results, out_dir)?;
        if cancelled() {
            break;
        }
    }
    write_results(&results, out_dir)?;
    Ok(results)
}

/// Writes `out_dir/results.json` atomically and durably ([`output::write_durable`]).
pub fn write_results(results: &Results, out_dir: &Path) -> Result<(), BenchError> {
    let json = serde_json::to_vec_pretty(results).map_err(|e| BenchError::Write {
        path: "results.json".into(),
        message: e.to_string(),
    })?;
    output::write_durable(&out_dir.join("results.json"), &json)
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_size_over_the_device_limit_names_the_limit() {
        assert!(super::check_size_within(4096, 4096, 4096).is_ok());
        let message = super::check_size_within(8192, 64, 4096)
            .unwrap_err()
            .to_string();
        assert_eq!(
            message,
            "resolution 8192x64 is over this device's max_texture_dimension_2d of 4096: give --size 4096x4096 or smaller"
        );
    }
}
