//! Runs along a path (`bench --path NAME|FILE --frames N`): the scene animated by a
//! [`softshadow_scenes::path::Path`] and rendered at fixed time steps as a user's renderer would,
//! one technique instance carried from frame to frame (its caches kept where it keeps them, its
//! `FrameChanges` what the renderer finds changed), every frame measured against that frame's
//! exact answer. Definitions of the measures in docs/BENCHMARKS.md, "Motion".
//!
//! Memory stays bounded however long the path: a frame's images are compared, streamed to disk
//! (one JSON line per frame, one animated-PNG frame) and dropped; only the previous frame's
//! visibility, exact answer and receiver mask are kept (for the flicker) beside the per-frame
//! numbers.

use std::{
    collections::BTreeMap,
    io::{BufWriter, Write},
    path::Path,
};

use serde::{Deserialize, Serialize};
use softshadow_core::{Scene, SceneGpu, ShadingMode};
use softshadow_metrics::ErrorReport;
use softshadow_scenes::path::{Path as ScenePath, Pose};

use crate::{
    reference_cache, resolve_technique,
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
        let mut technique = info.create_with(&self.gpu, &spec.params)?;
        if let Some(control) = &self.build_control {
            technique.set_build_control(control.clone());
        }
        run.params = technique.params().to_map();
        self.load_scene_and_renderer(spec)?;
        self.faults.in_the_middle(index, &self.gpu);
        let loaded = &self.scenes[&spec.scene];
        run.warnings = loaded.warnings.clone();
        // The scene as this benchmark sees it (a sweep's camera and light replace its own), then
        // as the path may change it (object-move makes a caster dynamic).
        let mut scene = Scene {
            camera: self.camera.unwrap_or(loaded.scene.camera),
            light: self.light.unwrap_or(loaded.scene.light),
            ..loaded.scene.clone()
        };
        let path = softshadow_scenes::path::resolve(path_spec, &mut scene, &loaded.paths)?;
        // What poses are made from: the scene's own camera and light (no geometry needed).
        let base = Scene {
            name: String::new(),
            meshes: Vec::new(),
            instances: Vec::new(),
            ..scene.clone()
        };
        let frames = self.options.frames;
        let (width, height) = (spec.width, spec.height);
        let pixels = (width * height) as usize;
        let cache = self
            .options
            .reference_cache
            .as_deref()
            .map(reference_cache::exact_in_dir);
        let timing_source = self.timing;
        let gpu = self.gpu.clone();
        let renderer = self
            .renderers
            .get_mut(&(width, height))
            .expect("made by load_scene_and_renderer");
        renderer.timing = timing_source;

        let stem = format!(
            "{index:03}_{}_{}_{}",
            sanitize(&spec.scene),
            spec.technique,
            sanitize(path_spec)
        );
        let frames_name = format!("{stem}_frames.jsonl");
        let frames_path = out_dir.join(&frames_name);
        let mut lines = BufWriter::new(
            std::fs::File::create(&frames_path).map_err(|e| write_error(&frames_path, e))?,
        );
        let animation_name = format!("{stem}_animation.png");
        let mut animation = if self.options.images {
            Some(Animation::new(
                &out_dir.join(&animation_name),
                width,
                height,
                frames,
            )?)
        } else {
            None
        };

        let mut video = crate::video_metric::Sequences::new(width, height, frames);
        let mut gpu_scene: Option<SceneGpu> = None;
        let mut previous: Option<Previous> = None;
        let mut series = Series::default();
        let mut error_all = Vec::new();
        let mut timings = TimingAccumulator::default();
        let mut exact_methods: BTreeMap<String, u32> = BTreeMap::new();
        let mut sampling_errors = Vec::new();
        let sampled = method.key_on(Some(&gpu));
        let mut cache_counts = cache.as_ref().map(|_| ExactCacheCounts::default());
        let mut passes: BTreeMap<String, u32> = BTreeMap::new();
        let mut last_passes = Vec::new();
        for k in 0..frames {
            let time = path.frame_time(k, frames);
            let pose = path.pose(&base, time);
            let kind = match &previous {
                None => FrameKind::First,
                Some(before) => match ScenePath::changes(&before.pose, &pose) {
                    (true, _) => FrameKind::Light,
                    (false, true) => FrameKind::Camera,
                    (false, false) => FrameKind::Still,
                },
            };
            let moved = previous
                .as_ref()
                .is_none_or(|before| before.pose.transforms != pose.transforms);
            pose.apply(&mut scene);
            if moved || gpu_scene.is_none() {
                // A moved dynamic instance is uploaded again, as the design has it
                // (docs/ARCHITECTURE.md, "Design decisions").
                gpu_scene = Some(SceneGpu::upload(&gpu, &scene));
            }
            let scene_gpu = gpu_scene.as_ref().expect("uploaded above");
            if k == 0 {
                technique.prepare(&gpu, &renderer.inputs(scene_gpu, &pose.camera, &pose.light))?;
            }
            let output = renderer.render(
                scene_gpu,
                &pose.camera,
                &pose.light,
                technique.as_mut(),
                Some(ShadingMode::Shaded),
            )?;
            timings.push(&output);
            let frame_ms = output.gpu.as_ref().map_or(output.cpu_ms, |g| g.total_ms);
            let visibility = renderer.read_visibility()?;
            let mask = renderer.read_receiver_mask()?;

            // This frame's exact answer: from the cache, or computed (and stored).
            let key = reference_cache::exact_key(&scene, width, height, &sampled);
            let mut cache_use = None;
            let mut found = None;
            if let Some(cache) = &cache {
                match cache
                    .load(key)
                    .and_then(|p| p.map(|p| reference_cache::decode_exact(&p, pixels)).transpose())
                {
                    Ok(Some(hit)) => found = Some(hit),
                    Ok(None) => cache_use = Some(reference_cache::ReferenceCacheUse::Stored),
                    Err(why) => {
                        cache_use = Some(reference_cache::ReferenceCacheUse::Rebuilt(format!(
                            "an exact-answer cache entry cannot be trusted ({why}): computed again and stored"
                        )))
                    }
                }
            }
            let reference_cache::CachedExact {
                label: exact_label,
                visibility: exact,
                sampling_error,
            } = match found {
                Some(hit) => {
                    cache_use = Some(reference_cache::ReferenceCacheUse::Hit);
                    hit
                }
                None => {
                    puffin::profile_scope!("exact answer of a path frame");
                    let positions = renderer.read_world_positions()?;
                    // Visibility only: the irradiance error is measured on still runs.
                    let answer = softshadow_reference::exact_answer(
                        Some(&gpu),
                        &scene,
                        &positions,
                        None,
                        &mask,
                        method,
                        None,
                    )?;
                    if let Some(why) = &answer.fallback {
                        if !run.warnings.contains(why) {
                            run.warnings.push(why.clone());
                        }
                    }
                    let made = reference_cache::CachedExact {
                        label: answer.truth.to_string(),
                        sampling_error: answer.sampling_error(&mask),
                        visibility: answer.visibility,
                    };
                    if let Some(cache) = &cache {
                        let payload = reference_cache::encode_exact(&made);
                        if let Err(e) = cache.store(key, &payload) {
                            cache_use = Some(reference_cache::ReferenceCacheUse::NotStored(
                                format!(
                                    "cannot write the exact-answer cache in {} ({e}): point --reference-cache at a writable folder",
                                    cache.dir.display()
                                ),
                            ));
                        }
                    }
                    made
                }
            };
            if let Some(e) = sampling_error {
                sampling_errors.push(e);
            }
            if let (Some(counts), Some(used)) = (&mut cache_counts, &cache_use) {
                match used {
                    reference_cache::ReferenceCacheUse::Hit => counts.hit += 1,
                    reference_cache::ReferenceCacheUse::Stored => counts.stored += 1,
                    reference_cache::ReferenceCacheUse::Rebuilt(why) => {
                        counts.rebuilt += 1;
                        if !run.warnings.contains(why) {
                            run.warnings.push(why.clone());
                        }
                    }
                    reference_cache::ReferenceCacheUse::NotStored(why) => {
                        counts.not_stored += 1;
                        if !run.warnings.contains(why) {
                            run.warnings.push(why.clone());
                        }
                    }
                }
            }
            *exact_methods.entry(exact_label.clone()).or_default() += 1;

            let error = softshadow_metrics::compare(&visibility, &exact, &mask)?;
            let flicker = match &previous {
                Some(before) => Some(softshadow_metrics::flicker(
                    (&before.visibility, &before.exact, &before.mask),
                    (&visibility, &exact, &mask),
                )?),
                None => None,
            };
            if let Some(animation) = &mut animation {
                animation.frame(width, &visibility, &exact)?;
            }
            video.push(&visibility, &exact);
            for pass in &output.passes_run {
                *passes.entry(pass.clone()).or_default() += 1;
            }
            let record = FrameRecord {
                frame: k,
                time,
                kind,
                error: error.clone(),
                flicker,
                frame_ms,
                cpu_ms: output.cpu_ms,
                passes_run: output.passes_run.clone(),
                exact: exact_label,
                exact_sampling_error: sampling_error,
                exact_cache: cache_use,
            };
            serde_json::to_writer(&mut lines, &record).map_err(|e| write_error(&frames_path, e))?;
            lines
                .write_all(b"\n")
                .map_err(|e| write_error(&frames_path, e))?;
            series.error.push(error.mae_shadowed);
            series.flicker.push(flicker.unwrap_or(0.0));
            series.frame_ms.push(frame_ms);
            series.kind.push(kind);
            error_all.push(error.mae_all);
            last_passes = output.passes_run;
            previous = Some(Previous {
                pose,
                visibility,
                exact,
                mask,
            });
        }
        lines.flush().map_err(|e| write_error(&frames_path, e))?;
        // Listed among the images too, so `merge` copies it with them.
        run.images.insert("frames".into(), frames_name.clone());
        if let Some(animation) = animation {
            animation.finish()?;
            run.images
                .insert("animation".into(), animation_name.clone());
        }

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
        let video_quality = {
            puffin::profile_scope!("perceptual video metric of a path run");
            match video.score(crate::video_metric::path_fps(path.duration, frames)) {
                Ok(score) => Some(score),
                Err(why) => {
                    run.warnings.push(why);
                    None
                }
            }
        };
        let motion = Motion {
            path: path_spec.to_string(),
            duration_s: path.duration,
            frames,
            frames_file: frames_name,
            animation: self.options.images.then_some(animation_name),
            error: SeriesSummary::of(&series.error).expect("at least one frame"),
            error_all: SeriesSummary::of(&error_all).expect("at least one frame"),
            flicker: SeriesSummary::of(&series.flicker[1.min(series.flicker.len())..]),
            lag: lag(&series.error, &series.kind),
            frame_ms: FrameTimes {
                first: series.frame_ms[0],
                camera_only: by_kind(FrameKind::Camera),
                light_moving: by_kind(FrameKind::Light),
                still: by_kind(FrameKind::Still),
            },
            exact_methods,
            exact_sampling_error: SeriesSummary::of(&sampling_errors),
            exact_cache: cache_counts,
            passes,
            series,
            video_quality,
        };
        run.timing = Some(timings.finish());
        run.passes_run = last_passes;
        run.stats = technique.stats();
        if let Some(last) = &previous {
            run.stability = Some(softshadow_metrics::stability(&last.visibility));
        }
        run.motion = Some(motion);
        Ok(())
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
