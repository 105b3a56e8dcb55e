//! `results.json`, versioned. Documented field by field in `docs/BENCHMARKS.md`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use softshadow_core::{ParamValue, TimingSource};
use softshadow_metrics::{ErrorReport, Stability};

/// Bump when a field changes meaning or is removed (adding a field keeps the version).
/// 3: `timing.gpu_ms` / `technique_gpu_ms` / `passes[].gpu_ms_median` became `frame_ms` /
/// `technique_ms` / `passes[].ms_median`, measured as `timing.source` says (version 2 files still
/// read, as `timestamps`).
pub const SCHEMA_VERSION: u32 = 3;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Results {
    pub schema_version: u32,
    pub adapter: Adapter,
    /// The command that made these runs (`workbench` arguments, e.g. `["bench", "--suite",
    /// "stiff", "--out", "DIR"]`), so a figure can be made again (`workbench docs --rerun`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub command: Vec<String>,
    /// The binary that ran `command` when it is not the workspace's `workbench` (a crate's own
    /// workbench with its technique, e.g. `custom-technique`); empty: `workbench`.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub program: String,
    /// The day the runs were made (UTC, `YYYY-MM-DD`).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub date: String,
    /// How busy the machine was while the runs were made: times measured on a shared CPU device
    /// are only comparable within one run of the benchmark.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load: Option<MachineLoad>,
    /// Which sweep these runs come from and which shard of it (absent for a single run).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<SweepInfo>,
    pub runs: Vec<Run>,
}

/// Today's date in UTC, `YYYY-MM-DD` (the civil date of the Unix day, Hinnant's algorithm).
pub fn today_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    civil_date((secs / 86_400) as i64)
}

/// The proleptic Gregorian date of `days` since 1970-01-01.
fn civil_date(days: i64) -> String {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

/// The machine's CPUs and its 1-minute load average (`/proc/loadavg`) when the benchmark started
/// and when it last wrote its results.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MachineLoad {
    pub cpus: usize,
    pub start: f64,
    pub end: f64,
}

impl MachineLoad {
    /// The load now as both start and end; `None` where the system does not say (not Linux).
    pub fn now() -> Option<Self> {
        let load = load_average()?;
        Some(Self {
            cpus: std::thread::available_parallelism().map_or(1, |n| n.get()),
            start: load,
            end: load,
        })
    }

    /// Records the load now as the end.
    pub fn update(&mut self) {
        if let Some(load) = load_average() {
            self.end = load;
        }
    }
}

impl std::fmt::Display for MachineLoad {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "load average {:.1} at the start and {:.1} at the end on {} CPUs",
            self.start, self.end, self.cpus
        )
    }
}

fn load_average() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/loadavg").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

/// The sweep a results.json belongs to.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SweepInfo {
    /// Hash of the expanded run list and shared options (see `Sweep::hash`): shards of one sweep
    /// share it.
    pub hash: String,
    /// Runs in the whole (unsharded) sweep.
    pub runs_total: usize,
    /// `None` for the whole sweep (or a merge of all its shards).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<Shard>,
}

/// Shard `index` of `count` (0-based): the runs whose sweep index is `index` modulo `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Adapter {
    pub name: String,
    pub backend: String,
    pub driver: String,
}

/// How a run ended.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// It finished and measured everything asked.
    Ok,
    /// It failed with the error in its `message` (bad parameter, technique error, lost device,
    /// out of memory); the process went on.
    Error,
    /// Isolated: it did not end within its time limit and its process was killed.
    Timeout,
    /// Isolated: its process ended without a result (a signal, an abort, a panic).
    Crashed,
    /// Not made: the technique does not support the scene's light kind (its `message` says
    /// why, from the technique's descriptor); no GPU work was done.
    Unsupported,
}

impl std::fmt::Display for Status {
    /// As in results.json: `ok`, `error`, `timeout`, `crashed` (padded to a width if asked).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(match self {
            Status::Ok => "ok",
            Status::Error => "error",
            Status::Timeout => "timeout",
            Status::Crashed => "crashed",
            Status::Unsupported => "unsupported",
        })
    }
}

/// How an isolated run's process went (`bench --isolate`, `crate::isolate`).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct ProcessRecord {
    /// Wall time of the process, from its start to its end, seconds.
    pub wall_s: f64,
    /// Its time limit, seconds.
    pub limit_s: f64,
    /// The signal that ended it (`SIGABRT`, `SIGSEGV`, ...), when one did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub signal: Option<String>,
    /// Its exit code when it exited without a result.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exit_code: Option<i32>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Run {
    /// Position in the sweep's expanded run list (the same in every shard and after a merge).
    #[serde(default)]
    pub index: usize,
    pub scene: String,
    pub technique: String,
    pub params: BTreeMap<String, ParamValue>,
    pub width: u32,
    pub height: u32,
    pub status: Status,
    /// The kind of the light it ran under (`rect`, `disk`, `sphere`, `spot`, `sun`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_kind: Option<String>,
    /// What went wrong when `status` is not `ok` (one line); empty otherwise.
    pub message: String,
    /// Full cost: every frame rebuilds everything (`invalidate_cache` before each).
    pub timing: Option<Timing>,
    /// Frames in which only the camera moves (a small orbit): light-space work is kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timing_camera_only: Option<Timing>,
    /// The run's first frame, with nothing built yet (the first warm-up frame): what a
    /// technique's caches cost to fill or load (a precompute built, or read from its disk cache).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cold: Option<ColdFrame>,
    /// Where the run's reference images came from when a reference cache is set (`hit`,
    /// `stored`, `rebuilt` with the reason, `not_stored` with the reason).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_cache: Option<crate::reference_cache::ReferenceCacheUse>,
    pub error: Option<ErrorFields>,
    pub stability: Option<Stability>,
    /// Flicker on a still frame (docs/MOTION.md): the mean over receiver pixels of
    /// |V_next - V_last| between the run's last frame and one more frame in which nothing
    /// changed (caches kept, as a renderer's next frame). 0 for a deterministic technique; the
    /// per-frame noise of one that changes its answer every frame (`varies_per_frame`), or the
    /// change of one that keeps accumulating.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub still_flicker: Option<f64>,
    pub stats: BTreeMap<String, f64>,
    pub passes_run: Vec<String>,
    /// kind (`visibility`, `reference`, `shaded`, `reference_shaded`, `difference`) -> file name in the
    /// output folder.
    pub images: BTreeMap<String, String>,
    /// Scene loader warnings (repaired geometry).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// The run held against the bound its technique's crate states for this case (only for runs
    /// at the expectation settings: defaults at 64², against the exact answer).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expectation: Option<crate::expectations::Verdict>,
    /// A run along a path (`bench --path`): per-frame error against each frame's exact answer,
    /// flicker, lag and frame times (docs/MOTION.md). Such a run has no
    /// still-frame `error`; its `timing` covers every frame of the path.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<Motion>,
    /// The GPU memory the technique holds (docs/BENCHMARKS.md, "Memory"): buffers, textures and
    /// acceleration structures on the device beyond what it held before the technique was made.
    /// `None` on a device whose driver layer counts no memory, and for runs along a path.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub memory: Option<TechniqueMemory>,
    /// For a technique that accumulates over frames (its descriptor's settle frames, e.g. its
    /// history length): the still frame after it settled, beside the first frame's `error` and
    /// `timing` (docs/BENCHMARKS.md, "Settled error").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settled: Option<Settled>,
    /// An isolated run's process: wall time, time limit, and the signal that ended it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub process: Option<ProcessRecord>,
    /// Loading the run's scene (file or procedure, repair, validation) and uploading it, in
    /// the process that made the run (docs/BENCHMARKS.md, "Loading").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene_load: Option<SceneLoad>,
}

/// What loading a run's scene cost.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneLoad {
    /// Triangles over every instance.
    pub triangles: usize,
    /// Wall time of `softshadow_scenes::load`: reading, parsing, repairing and validating.
    pub load_s: f64,
    /// Wall time of uploading it (`SceneGpu::upload`, acceleration structures not included).
    pub upload_s: f64,
    /// The process's peak resident memory after loading, less its resident memory before
    /// (`VmHWM` and `VmRSS`, Linux only): what the load itself took at its peak, in MiB.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_peak_mib: Option<f64>,
}

impl Run {
    /// Run `index` of `spec` with nothing measured yet (status `ok`).
    pub fn new(index: usize, spec: &crate::RunSpec) -> Self {
        Self {
            index,
            scene: spec.scene.clone(),
            technique: spec.technique.clone(),
            params: spec.params.iter().cloned().collect(),
            width: spec.width,
            height: spec.height,
            status: Status::Ok,
            light_kind: None,
            message: String::new(),
            timing: None,
            timing_camera_only: None,
            cold: None,
            reference_cache: None,
            error: None,
            stability: None,
            still_flicker: None,
            stats: BTreeMap::new(),
            passes_run: Vec::new(),
            images: BTreeMap::new(),
            warnings: Vec::new(),
            expectation: None,
            motion: None,
            memory: None,
            settled: None,
            process: None,
            scene_load: None,
        }
    }

    /// Run `index` of `spec` that ended with `status` and `message`, nothing measured.
    pub fn failed(index: usize, spec: &crate::RunSpec, status: Status, message: String) -> Self {
        Self {
            status,
            message,
            ..Self::new(index, spec)
        }
    }
}

/// GPU memory a technique holds, in bytes per kind ([`softshadow_core::MemoryUse`]).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct TechniqueMemory {
    /// After its last full-cost frame: what it keeps between frames.
    pub current: softshadow_core::MemoryUse,
    /// The most at any point of its frames (after any pass): what it needs while drawing.
    pub peak: softshadow_core::MemoryUse,
}

/// A technique that accumulates over frames, measured once it has settled.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Settled {
    /// Still frames rendered with caches and history kept, after the full-cost frames.
    pub frames: u32,
    /// The per-frame cost in the settled state (the frames after the first of them).
    pub timing: Timing,
    /// The last frame against the reference (`error.report`'s measure).
    pub report: ErrorReport,
    /// The last frame against the exact answer, when the run has one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vs_exact: Option<ErrorReport>,
}

/// What a run along a path measured (docs/MOTION.md).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Motion {
    /// The path as given (`orbit`, `light-sweep`, `object-move`, `still`, a name a scene file
    /// declares, or a path file).
    pub path: String,
    /// Seconds the path lasts; frame `k` of `frames` is at `duration_s * k / (frames - 1)`.
    pub duration_s: f32,
    pub frames: u32,
    /// Every frame's record, one JSON object a line (`motion::FrameRecord`), in the output
    /// folder: written frame by frame, never held.
    pub frames_file: String,
    /// The technique's visibility beside the exact answer, every frame, as an animated PNG
    /// (with images).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub animation: Option<String>,
    /// mae_shadowed against each frame's exact answer, over the frames.
    pub error: SeriesSummary,
    /// mae_all against each frame's exact answer, over the frames.
    pub error_all: SeriesSummary,
    /// Flicker (`softshadow_metrics::flicker`) from each frame to the next, over frames 1.. ;
    /// absent with one frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flicker: Option<SeriesSummary>,
    /// Error right after the last moving frame against the settled error at the end of the path;
    /// absent when the path does not end with at least `2 * motion::LAG_FRAMES` still frames.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lag: Option<Lag>,
    /// Frame times by what changed since the frame before.
    pub frame_ms: FrameTimes,
    /// Exact method (`closed-form`, `raytraced(samples_per_axis=N)`,
    /// `raycast(samples_per_axis=N)`) -> frames measured against it.
    pub exact_methods: BTreeMap<String, u32>,
    /// The per-frame exact answers' sampling error (`ErrorFields::exact_sampling_error`), over
    /// the frames; absent when no frame's could be estimated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exact_sampling_error: Option<SeriesSummary>,
    /// Where the per-frame exact answers came from when a cache folder is set
    /// (`--reference-cache`): frames read, computed and stored, rebuilt, not stored.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exact_cache: Option<ExactCacheCounts>,
    /// Pass name -> frames in which it ran.
    pub passes: BTreeMap<String, u32>,
    /// Per-frame series for the report's plots: error (mae_shadowed), flicker (from frame k - 1
    /// to k; 0 for frame 0), frame time, and what changed.
    pub series: Series,
    /// A perceptual video metric of the whole sequence against the exact answers' (beside the
    /// plain measures above, never instead of them); absent, with a warning of the run saying
    /// why, when it could not be computed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub video_quality: Option<VideoQuality>,
}

/// The perceptual video metric of a run along a path (`video_metric`; docs/MOTION.md).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct VideoQuality {
    /// The metric and the crate version that computed it.
    pub metric: String,
    /// Just-objectionable differences: 10 when the technique's sequence cannot be told from the
    /// exact answers', lower the more visible the difference (1 JOD apart: 75% of observers
    /// prefer the higher).
    pub jod: f64,
    /// The display model the grey-level sequences were shown on.
    pub display: String,
    /// Frames per second they were played at (the path's own rate).
    pub fps: f64,
    /// CPU seconds the metric took.
    pub cpu_s: f64,
}

/// Mean, 95th percentile and maximum of a per-frame quantity.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SeriesSummary {
    pub mean: f64,
    pub p95: f64,
    pub max: f64,
}

impl SeriesSummary {
    /// The summary of `values` (`None` when empty).
    pub fn of(values: &[f64]) -> Option<Self> {
        if values.is_empty() {
            return None;
        }
        Some(Self {
            mean: values.iter().sum::<f64>() / values.len() as f64,
            p95: percentile(values, 0.95),
            max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        })
    }
}

/// Lag of a run along a path (docs/MOTION.md).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Lag {
    /// The last frame in which anything moved.
    pub last_moving_frame: u32,
    /// Mean error of the `LAG_FRAMES` frames after it.
    pub error_after: f64,
    /// Mean error of the last `LAG_FRAMES` frames (settled).
    pub error_settled: f64,
    /// `error_after - error_settled`: 0 for a technique that keeps nothing from earlier frames.
    pub extra_error: f64,
    /// Frames after the last moving one until the error is within 1% (plus 1e-6) of the settled
    /// error.
    pub frames_to_settle: u32,
}

/// Frame times of a run along a path, split by what changed since the frame before.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct FrameTimes {
    /// The first frame (nothing built yet).
    pub first: f64,
    /// Frames in which only the camera moved: light-space work may be kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera_only: Option<Percentiles>,
    /// Frames in which the light or a caster moved: light-space work is redone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_moving: Option<Percentiles>,
    /// Frames in which nothing moved.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub still: Option<Percentiles>,
}

/// Counts of where a motion run's exact answers came from.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct ExactCacheCounts {
    pub hit: u32,
    pub stored: u32,
    pub rebuilt: u32,
    pub not_stored: u32,
}

/// What changed in a frame of a path since the frame before.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FrameKind {
    /// The first frame.
    First,
    /// Nothing.
    Still,
    /// Only the camera.
    Camera,
    /// The light or a caster (and maybe the camera).
    Light,
}

/// Per-frame series of a run along a path.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Series {
    pub error: Vec<f64>,
    pub flicker: Vec<f64>,
    pub frame_ms: Vec<f64>,
    pub kind: Vec<FrameKind>,
}

fn timestamps() -> TimingSource {
    TimingSource::Timestamps
}

/// The first frame of a run: its timing, passes and counters (what it built or loaded).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ColdFrame {
    /// Its timing (one frame), its passes in `passes_run`.
    pub timing: Timing,
    /// The technique's counters after it (e.g. a precompute's `construction_ms`, `from_cache`).
    pub stats: BTreeMap<String, f64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Timing {
    pub frames: u32,
    /// How pass times were measured: `timestamps` (GPU timestamp queries) or `serial` (each pass
    /// submitted on its own and waited for; its wall time). Version 2 files: `timestamps`.
    #[serde(default = "timestamps")]
    pub source: TimingSource,
    /// Time of the whole frame (G-buffer + technique + shading): the sum of its pass times.
    /// `None` when timing with timestamps on an adapter without timestamp queries.
    #[serde(alias = "gpu_ms")]
    pub frame_ms: Option<Percentiles>,
    /// Time of the technique's own passes only.
    #[serde(alias = "technique_gpu_ms")]
    pub technique_ms: Option<Percentiles>,
    /// Median time per pass (passes of the same name in one frame are summed).
    pub passes: Vec<PassTiming>,
    /// Wall time of a frame: recording, submission and waiting for the GPU.
    pub cpu_ms: Median,
    /// Passes the last frame of this block ran (only in `timing_camera_only`; the full block's
    /// are the run's `passes_run`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub passes_run: Option<Vec<String>>,
    /// With `timestamps`: passes whose timestamp time is far below their serial wall time on the
    /// same adapter (one calibration frame), i.e. timestamps that do not cover the pass's work.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Percentiles {
    pub median: f64,
    pub p10: f64,
    pub p90: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Median {
    pub median: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PassTiming {
    pub name: String,
    #[serde(alias = "gpu_ms_median")]
    pub ms_median: f64,
    /// With `timestamps`: the pass's wall time when submitted on its own and waited for, in the
    /// run's one calibration frame (docs/BENCHMARKS.md, "Timing").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub serial_ms: Option<f64>,
}

/// The error block: which reference, then the metrics of `softshadow_metrics::ErrorReport`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ErrorFields {
    /// Technique id and settings of the reference, e.g. `reference(samples_per_axis=32,...)`.
    pub reference: String,
    #[serde(flatten)]
    pub report: ErrorReport,
    /// The exact ground truth used for the fields below: `closed-form` (every caster is a
    /// rectangle parallel to the light), `raytraced(samples_per_axis=N)` (ray queries on the
    /// device) or `raycast(samples_per_axis=N)` (the CPU ray cast). Absent when the benchmark ran
    /// without it (`--no-exact`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exact: Option<String>,
    /// The exact answer's own sampling error: the mean, over the receiver pixels it shadows, of
    /// each pixel's collapsed-strata standard-error estimate (docs/EXACT.md, "The exact
    /// answer"); 0 for the closed form. Absent without an exact answer, with one sample per
    /// axis, or in results written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exact_sampling_error: Option<f64>,
    /// The technique against the exact ground truth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vs_exact: Option<ErrorReport>,
    /// The reference's own error against the exact ground truth (issue 6): how far the yardstick
    /// of `report` is from the truth on this scene.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_vs_exact: Option<ErrorReport>,
    /// No shadow at all (V = 1 everywhere) against the exact ground truth: what a technique that
    /// draws nothing would score, so a reader (and the tests) can tell a bound from "no shadow".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub all_lit_vs_exact: Option<ErrorReport>,
    /// The same three comparisons in irradiance (`V x E0` against the exact `E`,
    /// docs/EXACT.md, "The irradiance error"), where the exact answer is analytic (or the
    /// closed form, with the analytic irradiance beside it). Absent otherwise and in results
    /// written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub irradiance: Option<IrradianceFields>,
    /// The technique against the exact ground truth per camera-distance band (near 0-20 m,
    /// middle 20-80 m, far 80 m and beyond: `softshadow_metrics::DISTANCE_BANDS`), where cascaded
    /// maps trade resolution near the camera for resolution far from it. Absent without the exact
    /// answer and in results written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance_bands: Option<Vec<softshadow_metrics::BandError>>,
}

/// The irradiance errors of a run (`error.irradiance` in results.json).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct IrradianceFields {
    /// The technique against the exact irradiance.
    pub vs_exact: softshadow_metrics::IrradianceReport,
    /// The reference against it.
    pub reference_vs_exact: softshadow_metrics::IrradianceReport,
    /// No shadow at all (V = 1) against it.
    pub all_lit_vs_exact: softshadow_metrics::IrradianceReport,
}

/// Percentile by linear interpolation between closest ranks (`q` in [0, 1]).
pub fn percentile(values: &[f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let pos = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
}

pub fn percentiles(values: &[f64]) -> Percentiles {
    Percentiles {
        median: percentile(values, 0.5),
        p10: percentile(values, 0.1),
        p90: percentile(values, 0.9),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates_match_known_days() {
        assert_eq!(civil_date(0), "1970-01-01");
        assert_eq!(civil_date(11_016), "2000-02-29");
        assert_eq!(civil_date(20_789), "2026-12-02");
        assert_eq!(civil_date(-1), "1969-12-31");
    }

    #[test]
    fn percentiles_interpolate() {
        let v = [4.0, 1.0, 3.0, 2.0, 5.0];
        assert_eq!(percentile(&v, 0.5), 3.0);
        assert_eq!(percentile(&v, 0.0), 1.0);
        assert_eq!(percentile(&v, 1.0), 5.0);
        assert!((percentile(&v, 0.1) - 1.4).abs() < 1e-12);
        assert_eq!(percentile(&[2.0], 0.9), 2.0);
        // Between two ranks above the lowest (pos = 3.6): only the fraction 0.6 of the step
        // counts (cargo mutants: `pos - lo` made `pos + lo` survived the cases above).
        assert!((percentile(&v, 0.9) - 4.6).abs() < 1e-12);
    }
}
