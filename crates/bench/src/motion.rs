//! Runs along a path (`bench --path NAME|FILE --frames N`): the scene animated by a
//! [`softshadow_scenes::path::Path`] and rendered at fixed time steps as a user's renderer would,
//! one technique instance carried from frame to frame (its caches kept where it keeps them, its
//! `FrameChanges` what the renderer finds changed), every frame measured against that frame's
//! exact answer. Definitions of the measures in docs/MOTION.md.
//!
//! Memory stays bounded however long the path: a frame's images are compared, streamed to disk
//! (one JSON line per frame, one animated-PNG frame) and dropped; only the previous frame's
//! visibility, exact answer and receiver mask are kept (for the flicker) beside the per-frame
//! numbers.

use std::{
    collections::BTreeMap,
    io::{BufWriter, Write},
    path::{Path, PathBuf},
};

use serde::{Deserialize, Serialize};
use softshadow_core::{
    disk_cache::DiskCache, FrameOutput, Gpu, Renderer, Scene, SceneGpu, ShadingMode, TechniqueStats,
};
use softshadow_metrics::ErrorReport;
use softshadow_reference::ExactMethod;
use softshadow_scenes::path::{Path as ScenePath, Pose};

use crate::{
    reference_cache::{self, CachedExact, ReferenceCacheUse},
    resolve_technique,
    results::{self, ExactCacheCounts, FrameKind, FrameTimes, Lag, Motion, Series, SeriesSummary},
    sanitize, Bench, BenchError, Run, RunSpec, TimingAccumulator,
};

/// Frames averaged right after the last moving frame and at the end of a path for the lag.
pub const LAG_FRAMES: usize = 3;

/// Frames per second of the animated PNG of a run.
pub const ANIMATION_FPS: u16 = 12;

/// One frame of a run along a path: a line of the run's `frames_file`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrameRecord {
    pub frame: u32,
    /// Seconds along the path.
    pub time: f32,
    /// What changed since the frame before.
    pub kind: FrameKind,
    /// The technique against this frame's exact answer.
    pub error: ErrorReport,
    /// Flicker from the frame before (absent for the first frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flicker: Option<f64>,
    /// The frame's time (the sum of its pass times, as `timing.frame_ms`; its CPU wall time when
    /// the adapter gives no pass times).
    pub frame_ms: f64,
    /// CPU wall time of the frame.
    pub cpu_ms: f64,
    /// The passes the frame ran.
    pub passes_run: Vec<String>,
    /// The exact method of this frame (`closed-form`, `raytraced(samples_per_axis=N)`,
    /// `raycast(samples_per_axis=N)`).
    pub exact: String,
    /// Its exact answer's sampling error (`ErrorFields::exact_sampling_error`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exact_sampling_error: Option<f64>,
    /// Where its exact answer came from when a cache folder is set.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exact_cache: Option<reference_cache::ReferenceCacheUse>,
}

/// Reads a run's `frames_file` back (the tests, the report).
pub fn read_frames(path: &Path) -> Result<Vec<FrameRecord>, BenchError> {
    let text = std::fs::read_to_string(path).map_err(|e| BenchError::Read {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            serde_json::from_str(l).map_err(|e| BenchError::Read {
                path: path.display().to_string(),
                message: e.to_string(),
            })
        })
        .collect()
}

/// The lag of a run whose per-frame errors are `error` and kinds `kind` (docs/BENCHMARKS.md).
pub fn lag(error: &[f64], kind: &[FrameKind]) -> Option<Lag> {
    let last_moving = kind
        .iter()
        .rposition(|k| matches!(k, FrameKind::Camera | FrameKind::Light))?;
    let after = &error[last_moving + 1..];
    if after.len() < 2 * LAG_FRAMES {
        return None;
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let error_after = mean(&after[..LAG_FRAMES]);
    let error_settled = mean(&after[after.len() - LAG_FRAMES..]);
    let tolerance = 0.01 * error_settled.abs() + 1e-6;
    let frames_to_settle = after
        .iter()
        .position(|e| (e - error_settled).abs() <= tolerance)
        .unwrap_or(after.len()) as u32;
    Some(Lag {
        last_moving_frame: last_moving as u32,
        error_after,
        error_settled,
        extra_error: error_after - error_settled,
        frames_to_settle,
    })
}

fn write_error(path: &Path, e: impl std::fmt::Display) -> BenchError {
    BenchError::Write {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// The technique's visibility beside the exact answer, grey, one animated-PNG frame per path
/// frame, written as the frames come.
struct Animation {
    writer: png::Writer<BufWriter<std::fs::File>>,
    path: std::path::PathBuf,
}

impl Animation {
    fn new(path: &Path, width: u32, height: u32, frames: u32) -> Result<Self, BenchError> {
        let file = std::fs::File::create(path).map_err(|e| write_error(path, e))?;
        let mut encoder = png::Encoder::new(BufWriter::new(file), 2 * width, height);
        encoder.set_color(png::ColorType::Grayscale);
        encoder.set_depth(png::BitDepth::Eight);
        encoder
            .set_animated(frames, 0)
            .and_then(|()| encoder.set_frame_delay(1, ANIMATION_FPS))
            .map_err(|e| write_error(path, e))?;
        let writer = encoder.write_header().map_err(|e| write_error(path, e))?;
        Ok(Self {
            writer,
            path: path.to_path_buf(),
        })
    }

    fn frame(&mut self, width: u32, visibility: &[f32], exact: &[f32]) -> Result<(), BenchError> {
        let width = width as usize;
        let v = softshadow_metrics::visibility_to_gray8(visibility);
        let e = softshadow_metrics::visibility_to_gray8(exact);
        let mut rows = Vec::with_capacity(2 * v.len());
        for (a, b) in v.chunks(width).zip(e.chunks(width)) {
            rows.extend_from_slice(a);
            rows.extend_from_slice(b);
        }
        self.writer
            .write_image_data(&rows)
            .map_err(|e| write_error(&self.path, e))
    }

    fn finish(self) -> Result<(), BenchError> {
        let path = self.path.clone();
        self.writer.finish().map_err(|e| write_error(&path, e))
    }
}

/// The frame before: all a run keeps of it (for the flicker and what changed).
struct Previous {
    pose: Pose,
    visibility: Vec<f32>,
    exact: Vec<f32>,
    mask: Vec<bool>,
}

impl Bench {
    /// One run along `path_spec` (see the module documentation); fills `run`.
    pub(crate) fn run_path(
        &mut self,
        index: usize,
        spec: &RunSpec,
        path_spec: &str,
        out_dir: &Path,
        run: &mut Run,
    ) -> Result<(), BenchError> {
        let edge = self.gpu.device.limits().max_texture_dimension_2d;
        crate::check_size_within(spec.width, spec.height, edge)?;
        let Some(method) = self.options.exact_method().filter(|_| self.options.error) else {
            return Err(BenchError::Motion(
                "a run along a path measures every frame against its exact answer: drop --no-error and --no-exact".into(),
            ));
        };
        let info = resolve_technique(&self.registry, &spec.technique)?;
        let mut technique = self.create_technique(&info, spec, run)?;
        self.load_scene_and_renderer(spec)?;
        self.faults.in_the_middle(index, &self.gpu);
        let (mut scene, base, path) = self.scene_along_path(spec, path_spec, run)?;
        let frames = self.options.frames;
        let (width, height) = (spec.width, spec.height);
        let exact_answers = FrameExact {
            gpu: &self.gpu,
            method,
            sampled: method.key_on(Some(&self.gpu)),
            cache: self
                .options
                .reference_cache
                .as_deref()
                .map(reference_cache::exact_in_dir),
            width,
            height,
        };
        let renderer = self
            .renderers
            .get_mut(&(width, height))
            .expect("made by load_scene_and_renderer");
        renderer.timing = self.timing;
        let stem = format!(
            "{index:03}_{}_{}_{}",
            sanitize(&spec.scene),
            spec.technique,
            sanitize(path_spec)
        );
        let mut recorder = PathRecorder::new(
            out_dir,
            &stem,
            self.options.images,
            (width, height, frames),
            exact_answers.cache.is_some(),
        )?;

        let mut gpu_scene: Option<SceneGpu> = None;
        for k in 0..frames {
            let time = path.frame_time(k, frames);
            let pose = path.pose(&base, time);
            let kind = frame_kind(recorder.previous.as_ref(), &pose);
            let moved = recorder
                .previous
                .as_ref()
                .is_none_or(|before| before.pose.transforms != pose.transforms);
            pose.apply(&mut scene);
            if moved || gpu_scene.is_none() {
                // A moved dynamic instance is uploaded again, as the design has it
                // (docs/ARCHITECTURE.md, "Design decisions").
                gpu_scene = Some(SceneGpu::upload(&self.gpu, &scene));
            }
            let scene_gpu = gpu_scene.as_ref().expect("uploaded above");
            if k == 0 {
                let inputs = renderer.inputs(scene_gpu, &pose.camera, &pose.light);
                technique.prepare(&self.gpu, &inputs)?;
            }
            let output = renderer.render(
                scene_gpu,
                &pose.camera,
                &pose.light,
                technique.as_mut(),
                Some(ShadingMode::Shaded),
            )?;
            let visibility = renderer.read_visibility()?;
            let mask = renderer.read_receiver_mask()?;
            let (exact, cache_use) =
                exact_answers.of_frame(renderer, &scene, &mask, &mut run.warnings)?;
            let frame = PathFrame {
                index: k,
                time,
                kind,
                output,
                pose,
                visibility,
                mask,
                exact,
                cache_use,
            };
            recorder.record(frame, &mut run.warnings)?;
        }
        recorder.finish(path_spec, &path, technique.stats(), run)
    }

    /// The scene of `spec` as this benchmark sees it (a sweep's camera and light replace its
    /// own), then as the path `path_spec` may change it (object-move makes a caster dynamic); the
    /// scene poses are made from (its camera and light, no geometry); and that path. Takes the
    /// scene's warnings into `run`.
    fn scene_along_path(
        &self,
        spec: &RunSpec,
        path_spec: &str,
        run: &mut Run,
    ) -> Result<(Scene, Scene, ScenePath), BenchError> {
        let loaded = &self.scenes[&spec.scene];
        run.warnings = loaded.warnings.clone();
        let mut scene = Scene {
            camera: self.camera.unwrap_or(loaded.scene.camera),
            light: self.light.unwrap_or(loaded.scene.light),
            ..loaded.scene.clone()
        };
        let path = softshadow_scenes::path::resolve(path_spec, &mut scene, &loaded.paths)?;
        let base = Scene {
            name: String::new(),
            meshes: Vec::new(),
            instances: Vec::new(),
            ..scene.clone()
        };
        Ok((scene, base, path))
    }
}

/// What changed from the frame before to `pose`.
fn frame_kind(before: Option<&Previous>, pose: &Pose) -> FrameKind {
    match before {
        None => FrameKind::First,
        Some(before) => match ScenePath::changes(&before.pose, pose) {
            (true, _) => FrameKind::Light,
            (false, true) => FrameKind::Camera,
            (false, false) => FrameKind::Still,
        },
    }
}

/// Each path frame's exact answer: from the exact-answer cache when one is set and holds it,
/// else computed (and stored there).
struct FrameExact<'a> {
    gpu: &'a Gpu,
    method: ExactMethod,
    /// The method as the cache key has it ([`ExactMethod::key_on`]).
    sampled: String,
    cache: Option<DiskCache>,
    width: u32,
    height: u32,
}

impl FrameExact<'_> {
    /// The exact answer of `scene` as `renderer` last drew it, and where it came from when a cache
    /// is set. A fallback the exact answer took is added to `warnings`.
    fn of_frame(
        &self,
        renderer: &Renderer,
        scene: &Scene,
        mask: &[bool],
        warnings: &mut Vec<String>,
    ) -> Result<(CachedExact, Option<ReferenceCacheUse>), BenchError> {
        let key = reference_cache::exact_key(scene, self.width, self.height, &self.sampled);
        let (found, mut cache_use) = match &self.cache {
            Some(cache) => self.look_up(cache, key),
            None => (None, None),
        };
        if let Some(hit) = found {
            return Ok((hit, Some(ReferenceCacheUse::Hit)));
        }
        let made = self.compute(renderer, scene, mask, warnings)?;
        if let Some(cache) = &self.cache {
            let payload = reference_cache::encode_exact(&made);
            if let Err(e) = cache.store(key, &payload) {
                cache_use = Some(ReferenceCacheUse::NotStored(format!(
                    "cannot write the exact-answer cache in {} ({e}): point --reference-cache at a writable folder",
                    cache.dir.display()
                )));
            }
        }
        Ok((made, cache_use))
    }

    /// The cached answer under `key`, or (none and) what computing it will count as.
    fn look_up(
        &self,
        cache: &DiskCache,
        key: u64,
    ) -> (Option<CachedExact>, Option<ReferenceCacheUse>) {
        let pixels = (self.width * self.height) as usize;
        match cache
            .load(key)
            .and_then(|p| p.map(|p| reference_cache::decode_exact(&p, pixels)).transpose())
        {
            Ok(Some(hit)) => (Some(hit), None),
            Ok(None) => (None, Some(ReferenceCacheUse::Stored)),
            Err(why) => (
                None,
                Some(ReferenceCacheUse::Rebuilt(format!(
                    "an exact-answer cache entry cannot be trusted ({why}): computed again and stored"
                ))),
            ),
        }
    }

    fn compute(
        &self,
        renderer: &Renderer,
        scene: &Scene,
        mask: &[bool],
        warnings: &mut Vec<String>,
    ) -> Result<CachedExact, BenchError> {
        puffin::profile_scope!("exact answer of a path frame");
        let positions = renderer.read_world_positions()?;
        // Visibility only: the irradiance error is measured on still runs.
        let answer = softshadow_reference::exact_answer(
            Some(self.gpu),
            scene,
            &positions,
            None,
            mask,
            self.method,
            None,
        )?;
        if let Some(why) = &answer.fallback {
            if !warnings.contains(why) {
                warnings.push(why.clone());
            }
        }
        Ok(CachedExact {
            label: answer.truth.to_string(),
            sampling_error: answer.sampling_error(mask),
            visibility: answer.visibility,
        })
    }
}

/// One rendered frame of a path with its exact answer, as [`PathRecorder::record`] takes it.
struct PathFrame {
    index: u32,
    /// Seconds along the path.
    time: f32,
    kind: FrameKind,
    output: FrameOutput,
    pose: Pose,
    visibility: Vec<f32>,
    mask: Vec<bool>,
    exact: CachedExact,
    cache_use: Option<ReferenceCacheUse>,
}

/// What a run along a path keeps of its frames: the per-frame numbers, the frame before, and the
/// files every frame is streamed to.
struct PathRecorder {
    frames_name: String,
    frames_path: PathBuf,
    lines: BufWriter<std::fs::File>,
    animation_name: String,
    animation: Option<Animation>,
    width: u32,
    frames: u32,
    video: crate::video_metric::Sequences,
    previous: Option<Previous>,
    series: Series,
    error_all: Vec<f64>,
    timings: TimingAccumulator,
    exact_methods: BTreeMap<String, u32>,
    sampling_errors: Vec<f64>,
    /// Counted only when an exact-answer cache is set.
    cache_counts: Option<ExactCacheCounts>,
    passes: BTreeMap<String, u32>,
    last_passes: Vec<String>,
}

impl PathRecorder {
    /// Creates the frames file `<stem>_frames.jsonl` in `out_dir` and, with `images`, the
    /// animation `<stem>_animation.png`.
    fn new(
        out_dir: &Path,
        stem: &str,
        images: bool,
        (width, height, frames): (u32, u32, u32),
        counts_cache_use: bool,
    ) -> Result<Self, BenchError> {
        let frames_name = format!("{stem}_frames.jsonl");
        let frames_path = out_dir.join(&frames_name);
        let lines = BufWriter::new(
            std::fs::File::create(&frames_path).map_err(|e| write_error(&frames_path, e))?,
        );
        let animation_name = format!("{stem}_animation.png");
        let animation = if images {
            let path = out_dir.join(&animation_name);
            Some(Animation::new(&path, width, height, frames)?)
        } else {
            None
        };
        Ok(Self {
            frames_name,
            frames_path,
            lines,
            animation_name,
            animation,
            width,
            frames,
            video: crate::video_metric::Sequences::new(width, height, frames),
            previous: None,
            series: Series::default(),
            error_all: Vec::new(),
            timings: TimingAccumulator::default(),
            exact_methods: BTreeMap::new(),
            sampling_errors: Vec::new(),
            cache_counts: counts_cache_use.then(ExactCacheCounts::default),
            passes: BTreeMap::new(),
            last_passes: Vec::new(),
        })
    }

    /// Measures `frame` against its exact answer and the frame before, writes its line and its
    /// animation frame, and keeps it as the frame before the next. A cache entry rebuilt or not
    /// stored is added to `warnings`.
    fn record(&mut self, frame: PathFrame, warnings: &mut Vec<String>) -> Result<(), BenchError> {
        let PathFrame {
            index,
            time,
            kind,
            output,
            pose,
            visibility,
            mask,
            exact,
            cache_use,
        } = frame;
        self.timings.push(&output);
        let frame_ms = output.gpu.as_ref().map_or(output.cpu_ms, |g| g.total_ms);
        if let Some(e) = exact.sampling_error {
            self.sampling_errors.push(e);
        }
        if let (Some(counts), Some(used)) = (&mut self.cache_counts, &cache_use) {
            count_cache_use(counts, used, warnings);
        }
        *self.exact_methods.entry(exact.label.clone()).or_default() += 1;

        let error = softshadow_metrics::compare(&visibility, &exact.visibility, &mask)?;
        let flicker = match &self.previous {
            Some(before) => Some(softshadow_metrics::flicker(
                (&before.visibility, &before.exact, &before.mask),
                (&visibility, &exact.visibility, &mask),
            )?),
            None => None,
        };
        if let Some(animation) = &mut self.animation {
            animation.frame(self.width, &visibility, &exact.visibility)?;
        }
        self.video.push(&visibility, &exact.visibility);
        for pass in &output.passes_run {
            *self.passes.entry(pass.clone()).or_default() += 1;
        }
        let record = FrameRecord {
            frame: index,
            time,
            kind,
            error: error.clone(),
            flicker,
            frame_ms,
            cpu_ms: output.cpu_ms,
            passes_run: output.passes_run.clone(),
            exact: exact.label,
            exact_sampling_error: exact.sampling_error,
            exact_cache: cache_use,
        };
        self.write_line(&record)?;
        self.series.error.push(error.mae_shadowed);
        self.series.flicker.push(flicker.unwrap_or(0.0));
        self.series.frame_ms.push(frame_ms);
        self.series.kind.push(kind);
        self.error_all.push(error.mae_all);
        self.last_passes = output.passes_run;
        self.previous = Some(Previous {
            pose,
            visibility,
            exact: exact.visibility,
            mask,
        });
        Ok(())
    }

    fn write_line(&mut self, record: &FrameRecord) -> Result<(), BenchError> {
        let path = &self.frames_path;
        serde_json::to_writer(&mut self.lines, record).map_err(|e| write_error(path, e))?;
        self.lines
            .write_all(b"\n")
            .map_err(|e| write_error(path, e))
    }

    /// Closes the files and fills `run` with the summary of the frames (`motion`), the last
    /// frame's passes and stability, and the technique's counters `stats`.
    fn finish(
        mut self,
        path_spec: &str,
        path: &ScenePath,
        stats: TechniqueStats,
        run: &mut Run,
    ) -> Result<(), BenchError> {
        let frames = self.frames;
        self.lines
            .flush()
            .map_err(|e| write_error(&self.frames_path, e))?;
        // Listed among the images too, so `merge` copies it with them.
        run.images.insert("frames".into(), self.frames_name.clone());
        let animation = match self.animation.take() {
            Some(animation) => {
                animation.finish()?;
                run.images
                    .insert("animation".into(), self.animation_name.clone());
                Some(self.animation_name)
            }
            None => None,
        };
        let video_quality = {
            puffin::profile_scope!("perceptual video metric of a path run");
            let fps = crate::video_metric::path_fps(path.duration, frames);
            match self.video.score(fps) {
                Ok(score) => Some(score),
                Err(why) => {
                    run.warnings.push(why);
                    None
                }
            }
        };
        let series = self.series;
        let motion = Motion {
            path: path_spec.to_string(),
            duration_s: path.duration,
            frames,
            frames_file: self.frames_name,
            animation,
            error: SeriesSummary::of(&series.error).expect("at least one frame"),
            error_all: SeriesSummary::of(&self.error_all).expect("at least one frame"),
            flicker: SeriesSummary::of(&series.flicker[1.min(series.flicker.len())..]),
            lag: lag(&series.error, &series.kind),
            frame_ms: frame_times(&series),
            exact_methods: self.exact_methods,
            exact_sampling_error: SeriesSummary::of(&self.sampling_errors),
            exact_cache: self.cache_counts,
            passes: self.passes,
            series,
            video_quality,
        };
        run.timing = Some(self.timings.finish());
        run.passes_run = self.last_passes;
        run.stats = stats;
        if let Some(last) = &self.previous {
            run.stability = Some(softshadow_metrics::stability(&last.visibility));
        }
        run.motion = Some(motion);
        Ok(())
    }
}

/// Counts where a frame's exact answer came from; an entry rebuilt or not stored says why in
/// `warnings` (once).
fn count_cache_use(
    counts: &mut ExactCacheCounts,
    used: &ReferenceCacheUse,
    warnings: &mut Vec<String>,
) {
    let why = match used {
        ReferenceCacheUse::Hit => {
            counts.hit += 1;
            return;
        }
        ReferenceCacheUse::Stored => {
            counts.stored += 1;
            return;
        }
        ReferenceCacheUse::Rebuilt(why) => {
            counts.rebuilt += 1;
            why
        }
        ReferenceCacheUse::NotStored(why) => {
            counts.not_stored += 1;
            why
        }
    };
    if !warnings.contains(why) {
        warnings.push(why.clone());
    }
}

/// The frame times of a path's frames: the first, and the percentiles of each kind of frame.
fn frame_times(series: &Series) -> FrameTimes {
    let by_kind = |wanted: FrameKind| {
        let ms: Vec<f64> = series
            .frame_ms
            .iter()
            .zip(&series.kind)
            .filter(|(_, k)| **k == wanted)
            .map(|(ms, _)| *ms)
            .collect();
        (!ms.is_empty()).then(|| results::percentiles(&ms))
    };
    FrameTimes {
        first: series.frame_ms[0],
        camera_only: by_kind(FrameKind::Camera),
        light_moving: by_kind(FrameKind::Light),
        still: by_kind(FrameKind::Still),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lag_compares_the_frames_after_the_motion_with_the_settled_ones() {
        use FrameKind::*;
        let kind = [
            First, Light, Light, Still, Still, Still, Still, Still, Still, Still,
        ];
        // A technique that keeps nothing: the same error once the light stops.
        let steady = [0.1, 0.2, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3];
        let l = lag(&steady, &kind).unwrap();
        assert_eq!(l.last_moving_frame, 2);
        assert_eq!((l.extra_error, l.frames_to_settle), (0.0, 0));
        // One that blends over frames: too dark right after, settling on the fourth frame.
        let blending = [0.1, 0.2, 0.3, 0.5, 0.4, 0.32, 0.3, 0.3, 0.3, 0.3];
        let l = lag(&blending, &kind).unwrap();
        assert!((l.error_after - 0.4066666).abs() < 1e-6, "{l:?}");
        assert!((l.extra_error - 0.1066666).abs() < 1e-6);
        assert_eq!(l.frames_to_settle, 3);
        // Too few still frames at the end, or nothing moving: no lag.
        assert!(lag(&steady[..7], &kind[..7]).is_none());
        assert!(lag(&steady, &[Still; 10]).is_none());
    }
}
