//! The timeline (issue 28): plays a path (docs/SCENES.md, "Paths") over the open scene: play,
//! pause, scrub, loop; the error and the flicker against the exact answer of every frame shown
//! live over a rolling window, with the GPU pass times of the played steps split by what moved;
//! Record writes each played frame, technique beside the exact answer, as PNG files, and on
//! Stop one animated PNG of them.
//!
//! A played path steps at fixed times (`steps` frames from its start to its end, as
//! `bench --path NAME --frames N` does) and moves on only once the technique's frame of the
//! current step is shown, so every step is rendered and measured whatever a frame costs. The
//! exact answer of each frame is computed on the render worker (`render_worker`): the closed
//! form where the scene has one, else the GPU ray-traced answer on an adapter with ray queries
//! (as many light samples as a step can afford; the panel says which method and how many); on
//! an adapter without ray queries such a frame shows no live error (the benchmark's path runs
//! use the CPU ray cast there).

use std::{collections::VecDeque, path::PathBuf};

use softshadow_bench::results::FrameKind;
use softshadow_core::{GpuFrameTiming, Scene, SceneGpu};
use softshadow_scenes::path::{self, Path, Pose, BUILTIN_PATHS};

use super::{shown_path, ViewerApp};
use crate::{
    orbit::Orbit,
    timing::{PassRow, RollingTimings},
};

/// Frames of the rolling window the live error and flicker are averaged over.
pub const LIVE_WINDOW: usize = 30;

/// The animated PNG Record writes beside the frames when it stops.
pub const ANIMATION_FILE: &str = "animation.png";

/// Below this many light samples per axis the panel calls a live ray-traced exact answer coarse.
pub const COARSE_TRACED_SAMPLES: u32 = 8;

/// Frames a path is played in unless the user says otherwise.
pub const DEFAULT_STEPS: u32 = 60;

/// Error and flicker of one shown frame against its exact answer.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LiveMetrics {
    /// `mae_shadowed` against the frame's exact answer.
    pub mae_shadowed: f64,
    /// The irradiance error over shadowed receivers (`irradiance_mae_shadowed`,
    /// docs/EXACT.md, "The irradiance error"), where the exact answer was analytic.
    pub irradiance_mae_shadowed: Option<f64>,
    /// Flicker against the frame before it (`None` for the first frame of a run).
    pub flicker: Option<f64>,
    /// How the frame's exact answer was computed.
    pub exact: LiveExact,
    /// Wall time of computing it on the render worker, ms.
    pub exact_ms: f64,
}

/// The exact answer a live measurement used.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum LiveExact {
    /// The closed form (rectangles parallel to the light).
    ClosedForm,
    /// The analytic answer (`softshadow_reference::analytic`): any mesh under a light with area.
    Analytic,
    /// The GPU ray-traced answer (`softshadow_reference::traced`) with this many stratified
    /// light samples per axis.
    Traced { samples_per_axis: u32 },
}

impl std::fmt::Display for LiveExact {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LiveExact::ClosedForm => f.write_str("closed form"),
            LiveExact::Analytic => f.write_str("analytic (exact, computed on the CPU)"),
            LiveExact::Traced {
                samples_per_axis: n,
            } => {
                write!(f, "ray traced on the GPU, {n}x{n} light samples a pixel")
            }
        }
    }
}

/// GPU pass times of the path's steps of one kind (what changed since the step before), as the
/// benchmark's motion summary splits them.
#[derive(Clone, Debug, PartialEq)]
pub struct PathTimings {
    /// Camera-only, light (or caster) moving, or still steps.
    pub kind: FrameKind,
    /// Steps the medians rest on (the last [`crate::timing::WINDOW`] of this kind).
    pub steps: usize,
    /// Per pass, the median over those steps (a pass a step left out counts 0 there).
    pub passes: Vec<PassRow>,
    /// Median of the technique's own passes.
    pub technique_ms: f64,
    /// Median of the whole frame's passes.
    pub total_ms: f64,
}

/// The kinds a played step's timings are split into, in the order the panel shows them.
const TIMED_KINDS: [FrameKind; 3] = [FrameKind::Camera, FrameKind::Light, FrameKind::Still];

/// The path being played and where it is.
pub(super) struct TimelineState {
    /// The path and the scene it moves (as opened: the path's poses apply to a copy).
    pub(super) active: Option<(Path, Scene)>,
    /// The current step, 0 ..= steps - 1.
    pub(super) step: u32,
    pub(super) steps: u32,
    pub(super) playing: bool,
    pub(super) looping: bool,
    /// The step whose pose is in the scene (`None`: not applied yet).
    applied: Option<u32>,
    /// The step whose frame was last measured (and recorded): each step counts once, however
    /// many frames show it while paused.
    measured: Option<u32>,
    /// Counts path runs (see [`TimelineState::exact_run`]).
    run: u64,
    /// The pose of the step applied before the current one, and what changed from it to the
    /// current one (`None` for the first step of a path: nothing to compare with).
    last_pose: Option<Pose>,
    step_kind: Option<FrameKind>,
    /// GPU timings of the steps played, one window per kind of [`TIMED_KINDS`] (each step once).
    timings: [RollingTimings; 3],
    /// Live metrics of the last frames played, newest last.
    pub(super) live: VecDeque<LiveMetrics>,
    /// Why there are no live metrics (no closed form, or the worker's error).
    pub(super) live_message: Option<String>,
    /// Folder Record writes to, and which steps are written while recording.
    pub(super) record_folder: String,
    pub(super) recording: Option<Recording>,
}

/// A recording under way: one pass over the path, one PNG per step.
pub(super) struct Recording {
    folder: PathBuf,
    /// Per step, whether its frame is written.
    written: Vec<bool>,
}

impl Default for TimelineState {
    fn default() -> Self {
        Self {
            active: None,
            step: 0,
            steps: DEFAULT_STEPS,
            playing: false,
            looping: true,
            applied: None,
            measured: None,
            run: 0,
            last_pose: None,
            step_kind: None,
            timings: Default::default(),
            live: VecDeque::new(),
            live_message: None,
            record_folder: super::output_dir().join("recording").display().to_string(),
            recording: None,
        }
    }
}

impl TimelineState {
    /// With a path open: the run the worker's flicker history belongs to (a new one each time a
    /// path is opened or scrubbed, so flicker never spans two runs); `None` without a path (no
    /// exact answers computed).
    pub(super) fn exact_run(&self) -> Option<u64> {
        self.active.as_ref().map(|_| self.run)
    }

    /// The run to compute the exact answer for with the next frame: only while the current
    /// step is not measured yet (a paused path computes nothing more once its step is).
    pub(super) fn exact_wanted(&self) -> Option<u64> {
        self.exact_run()
            .filter(|_| self.measured != Some(self.step))
    }

    fn time(&self) -> f32 {
        self.active
            .as_ref()
            .map_or(0.0, |(path, _)| path.frame_time(self.step, self.steps))
    }
}

impl ViewerApp {
    /// Opens path `spec` (a built-in, one the scene file declares, or a `.toml` path file) over
    /// the open scene, paused at its start; `None` closes the timeline and restores the scene.
    pub fn open_path(&mut self, spec: Option<&str>) {
        if let Some((_, scene)) = self.timeline.active.take() {
            self.restore_scene(scene);
        }
        self.timeline.live.clear();
        self.timeline.live_message = None;
        self.timeline.playing = false;
        self.timeline.recording = None;
        self.timeline.step = 0;
        self.timeline.applied = None;
        self.timeline.measured = None;
        self.timeline.run += 1;
        self.timeline.last_pose = None;
        self.timeline.step_kind = None;
        self.timeline.timings = Default::default();
        let Some(spec) = spec else {
            return;
        };
        let mut scene = self.scene.loaded.scene.clone();
        scene.camera = self.scene.camera;
        scene.light = self.scene.light;
        match path::resolve(spec, &mut scene, &self.scene.loaded.paths) {
            Ok(path) => self.timeline.active = Some((path, scene)),
            Err(e) => self.report_error(format!("cannot open path `{spec}`: {e}")),
        }
    }

    /// Puts the scene the timeline moved back as it was opened.
    fn restore_scene(&mut self, scene: Scene) {
        self.scene.camera = scene.camera;
        self.scene.light = scene.light;
        self.scene.orbit = Orbit::from_camera(&self.scene.camera);
        if scene.content_hash() != self.scene.loaded.scene.content_hash() {
            self.scene.loaded.gpu = SceneGpu::upload(&self.gpu, &scene);
            self.scene.loaded.scene = scene;
        }
    }

    /// Whether playing goes on from the start after the last frame (default) or stops there.
    pub fn set_path_looping(&mut self, looping: bool) {
        self.timeline.looping = looping;
    }

    /// Starts or stops playing the open path.
    pub fn set_playing(&mut self, playing: bool) {
        self.timeline.playing = playing && self.timeline.active.is_some();
    }

    /// Moves the open path to `step` (0 ..= steps - 1).
    pub fn scrub_to(&mut self, step: u32) {
        self.timeline.step = step.min(self.timeline.steps.saturating_sub(1));
        // A frame scrubbed to is not the next of the one measured before it.
        self.timeline.measured = None;
        self.timeline.run += 1;
    }

    /// Plays the open path in `steps` frames from its start to its end (2 to 600).
    pub fn set_path_steps(&mut self, steps: u32) {
        if self.timeline.recording.is_some() {
            // A recording is one frame per step of one pass: other steps end it.
            self.finish_recording();
        }
        self.timeline.steps = steps.clamp(2, 600);
        self.scrub_to(self.timeline.step);
        self.timeline.applied = None;
    }

    /// The open path's name and its current step, if one is open.
    pub fn path_position(&self) -> Option<(&str, u32, u32)> {
        self.timeline
            .active
            .as_ref()
            .map(|(path, _)| (path.name.as_str(), self.timeline.step, self.timeline.steps))
    }

    /// Why the timeline shows no live metrics (no closed form for the scene, or the worker's
    /// error), if it shows none.
    pub fn live_message(&self) -> Option<&str> {
        self.timeline.live_message.as_deref()
    }

    /// Live metrics of the frames played, oldest first (at most [`LIVE_WINDOW`]).
    pub fn live_metrics(&self) -> Vec<LiveMetrics> {
        self.timeline.live.iter().copied().collect()
    }

    /// GPU pass times of the steps played so far, split by what changed since the step before
    /// (only the kinds played).
    pub fn path_timings(&self) -> Vec<PathTimings> {
        TIMED_KINDS
            .iter()
            .zip(&self.timeline.timings)
            .filter(|(_, t)| !t.is_empty())
            .map(|(&kind, t)| PathTimings {
                kind,
                steps: t.len(),
                passes: t.rows(),
                technique_ms: t.technique_ms().unwrap_or(0.0),
                total_ms: t.total_ms().unwrap_or(0.0),
            })
            .collect()
    }

    /// Records one pass over the open path into `folder`: plays it from its first step and
    /// writes each step's frame (technique beside the exact answer) once, as
    /// `frame-NNNN.png` by step; after the last step it stops recording and joins the frames
    /// into one animated PNG there ([`ANIMATION_FILE`]). `None` stops early (the frames so far
    /// are joined when they run from the first step without a gap).
    pub fn record_path(&mut self, folder: Option<&str>) {
        let Some(folder) = folder else {
            self.finish_recording();
            return;
        };
        if self.timeline.active.is_none() {
            self.report_error("Record: no path is open; pick one under Path first");
            return;
        }
        let folder = PathBuf::from(folder.trim());
        if let Err(e) = std::fs::create_dir_all(&folder) {
            self.report_error(format!("cannot record into `{}`: {e}", folder.display()));
            return;
        }
        // Frames of an earlier recording would join this one's animation.
        for step in 0..600 {
            let _ = std::fs::remove_file(folder.join(format!("frame-{step:04}.png")));
        }
        self.timeline.recording = Some(Recording {
            folder,
            written: vec![false; self.timeline.steps as usize],
        });
        self.scrub_to(0);
        self.timeline.playing = true;
    }

    /// Ends the recording: the animated PNG of the frames written from the first step on.
    fn finish_recording(&mut self) {
        let Some(recording) = self.timeline.recording.take() else {
            return;
        };
        let folder = shown_path(&recording.folder);
        let frames = recording.written.iter().take_while(|w| **w).count() as u32;
        let total = recording.written.iter().filter(|w| **w).count();
        if frames == 0 {
            self.confirm(format!("recorded {total} frames in {folder}"));
            return;
        }
        match write_animation(&recording.folder, frames) {
            Ok(()) => self.confirm(format!(
                "recorded {total} frames in {folder} (and {ANIMATION_FILE} of {frames} at {} \
                 fps)",
                softshadow_bench::motion::ANIMATION_FPS
            )),
            Err(e) => self.report_error(format!(
                "recorded {total} frames in {folder}, but not {ANIMATION_FILE}: {e}"
            )),
        }
    }

    /// Puts the current step's pose into the scene (before the frame is asked for).
    pub(super) fn apply_path_pose(&mut self) {
        let step = self.timeline.step;
        if self.timeline.applied == Some(step) {
            return;
        }
        let time = self.timeline.time();
        let Some((path, base)) = &self.timeline.active else {
            return;
        };
        let pose = path.pose(base, time);
        // What the render worker's renderer will find changed since the step it drew before.
        self.timeline.step_kind =
            self.timeline
                .last_pose
                .as_ref()
                .map(|before| match Path::changes(before, &pose) {
                    (true, _) => FrameKind::Light,
                    (false, true) => FrameKind::Camera,
                    (false, false) => FrameKind::Still,
                });
        self.scene.camera = pose.camera;
        self.scene.light = pose.light;
        self.scene.orbit = Orbit::from_camera(&pose.camera);
        if !pose.transforms.is_empty() {
            let mut moved = base.clone();
            pose.apply(&mut moved);
            self.scene.loaded.gpu = SceneGpu::upload(&self.gpu, &moved);
            self.scene.loaded.scene = moved;
        }
        self.timeline.last_pose = Some(pose);
        self.timeline.applied = Some(step);
    }

    /// Notes a shown frame of the current step: its live metrics, its recorded image, and the
    /// next step when playing.
    pub(super) fn path_frame_shown(
        &mut self,
        live: Option<Result<LiveMetrics, String>>,
        exact: Option<&[f32]>,
        timing: Option<&GpuFrameTiming>,
    ) {
        let step = self.timeline.step;
        if self.timeline.active.is_none() || self.timeline.applied != Some(step) {
            return;
        }
        if self.timeline.measured != Some(step) {
            self.timeline.measured = Some(step);
            if let (Some(kind), Some(timing)) = (self.timeline.step_kind, timing) {
                if let Some(i) = TIMED_KINDS.iter().position(|k| *k == kind) {
                    self.timeline.timings[i].push(timing.clone());
                }
            }
            self.note_step(live, exact);
        }
        let recorded_all = self
            .timeline
            .recording
            .as_ref()
            .is_some_and(|r| r.written.iter().all(|w| *w));
        if recorded_all {
            // One pass: the recording ends with the path's last step, loop or not.
            self.finish_recording();
        }
        if self.timeline.playing {
            let last = self.timeline.steps.saturating_sub(1);
            if step < last {
                self.timeline.step = step + 1;
            } else if self.timeline.looping {
                self.timeline.step = 0;
            } else {
                self.timeline.playing = false;
            }
        }
    }

    /// The live metrics and the recorded image of the current step's frame.
    fn note_step(&mut self, live: Option<Result<LiveMetrics, String>>, exact: Option<&[f32]>) {
        match live {
            Some(Ok(metrics)) => {
                if self.timeline.live.len() == LIVE_WINDOW {
                    self.timeline.live.pop_front();
                }
                self.timeline.live.push_back(metrics);
                self.timeline.live_message = None;
            }
            Some(Err(message)) => self.timeline.live_message = Some(message),
            None => {}
        }
        let step = self.timeline.step;
        let Some(recording) = &self.timeline.recording else {
            return;
        };
        if recording.written.get(step as usize) != Some(&false) {
            return;
        }
        match self.write_recorded_frame(&recording.folder, step, exact) {
            Ok(()) => {
                if let Some(r) = self.timeline.recording.as_mut() {
                    r.written[step as usize] = true;
                }
            }
            Err(e) => {
                self.report_error(format!("cannot record the frame: {e}"));
                self.timeline.recording = None;
            }
        }
    }

    /// One PNG per frame: the technique's shaded image, and beside it the exact answer as grey
    /// (white lit, black umbra) where the scene has one.
    fn write_recorded_frame(
        &self,
        folder: &std::path::Path,
        index: u32,
        exact: Option<&[f32]>,
    ) -> Result<(), String> {
        let r = self.image.renderers.as_ref().ok_or("nothing rendered")?;
        let (w, h) = (r.width, r.height);
        let shaded = r.technique.read_shaded().map_err(|e| e.to_string())?;
        let columns = if exact.is_some() { 2 } else { 1 };
        let mut image = image::RgbaImage::new(w * columns, h);
        for y in 0..h {
            for x in 0..w {
                let i = ((y * w + x) * 4) as usize;
                image.put_pixel(
                    x,
                    y,
                    image::Rgba([shaded[i], shaded[i + 1], shaded[i + 2], 255]),
                );
                if let Some(exact) = exact {
                    let v = exact[(y * w + x) as usize].clamp(0.0, 1.0);
                    let g = (v * 255.0).round() as u8;
                    image.put_pixel(w + x, y, image::Rgba([g, g, g, 255]));
                }
            }
        }
        let file = folder.join(format!("frame-{index:04}.png"));
        image
            .save(&file)
            .map_err(|e| format!("{}: {e}", file.display()))
    }
}

/// Joins the `frames` PNG files Record wrote in `folder` into one animated PNG,
/// [`ANIMATION_FILE`], looping, at the bench's [`softshadow_bench::motion::ANIMATION_FPS`]; one
/// frame is read at a time, so a long recording needs the memory of one frame. Frames of
/// another size than the first (the render size changed while recording) make it an error
/// (the PNG frames stay), and a half-written file is removed.
fn write_animation(folder: &std::path::Path, frames: u32) -> Result<(), String> {
    let out = folder.join(ANIMATION_FILE);
    let frame_path = |i: u32| folder.join(format!("frame-{i:04}.png"));
    let read = |i: u32| -> Result<image::RgbaImage, String> {
        let path = frame_path(i);
        image::open(&path)
            .map(|f| f.to_rgba8())
            .map_err(|e| format!("{}: {e}", path.display()))
    };
    let write = || -> Result<(), String> {
        let first = read(0)?;
        let (width, height) = first.dimensions();
        let file = std::fs::File::create(&out).map_err(|e| format!("{}: {e}", out.display()))?;
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width, height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        encoder
            .set_animated(frames, 0)
            .and_then(|()| encoder.set_frame_delay(1, softshadow_bench::motion::ANIMATION_FPS))
            .map_err(|e| e.to_string())?;
        let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
        writer
            .write_image_data(first.as_raw())
            .map_err(|e| e.to_string())?;
        for i in 1..frames {
            let frame = read(i)?;
            if frame.dimensions() != (width, height) {
                return Err(format!(
                    "frame {i} is {}x{}, the first {width}x{height}: the render size changed \
                     while recording (keep it fixed for an animation)",
                    frame.width(),
                    frame.height()
                ));
            }
            writer
                .write_image_data(frame.as_raw())
                .map_err(|e| e.to_string())?;
        }
        writer.finish().map_err(|e| e.to_string())
    };
    write().inspect_err(|_| {
        let _ = std::fs::remove_file(&out);
    })
}

/// What the user asked of the Path section.
pub(super) enum TimelineAction {
    Open(Option<String>),
    Play(bool),
    Scrub(u32),
    Steps(u32),
    Record(Option<String>),
}

impl TimelineState {
    /// The Path section: the path picker, play / pause and loop, scrub, steps, the live error
    /// and Record; returns what the app must do (`declared`: the paths the scene file declares).
    pub(super) fn ui(&mut self, ui: &mut egui::Ui, declared: &[String]) -> Option<TimelineAction> {
        let mut action = None;
        let current = self.active.as_ref().map(|(path, _)| path.name.clone());
        let mut chosen: Option<Option<String>> = None;
        egui::ComboBox::from_label("path")
            .selected_text(current.clone().unwrap_or_else(|| "none".into()))
            .show_ui(ui, |ui| {
                if ui.selectable_label(current.is_none(), "none").clicked() {
                    chosen = Some(None);
                }
                let declared = declared.iter().cloned();
                let builtin = BUILTIN_PATHS.iter().map(|(name, _)| name.to_string());
                for name in builtin.chain(declared) {
                    let what = BUILTIN_PATHS
                        .iter()
                        .find(|(n, _)| *n == name)
                        .map_or("declared by the scene file", |(_, what)| what);
                    if ui
                        .selectable_label(current.as_deref() == Some(&name), &name)
                        .on_hover_text(what)
                        .clicked()
                    {
                        chosen = Some(Some(name));
                    }
                }
            })
            .response
            .on_hover_text("Play the scene along a path: camera, light and dynamic casters move");
        if let Some(choice) = chosen {
            return Some(TimelineAction::Open(choice));
        }
        // Nothing more without a path.
        self.active.as_ref()?;
        ui.horizontal(|ui| {
            let label = if self.playing { "Pause" } else { "Play" };
            if ui.button(label).clicked() {
                action = Some(TimelineAction::Play(!self.playing));
            }
            ui.checkbox(&mut self.looping, "loop");
        });
        let last = self.steps.saturating_sub(1);
        let mut step = self.step;
        if ui
            .add(egui::Slider::new(&mut step, 0..=last).text("frame"))
            .on_hover_text("Scrub: the frame of the path shown (fixed time steps)")
            .changed()
        {
            action = Some(TimelineAction::Scrub(step));
        }
        let mut steps = self.steps;
        if ui
            .add(egui::Slider::new(&mut steps, 2..=600).text("frames"))
            .on_hover_text("Frames from the path's start to its end")
            .changed()
        {
            action = Some(TimelineAction::Steps(steps));
        }
        self.live_ui(ui);
        ui.horizontal(|ui| {
            ui.add(egui::TextEdit::singleline(&mut self.record_folder).desired_width(130.0))
                .on_hover_text(self.record_folder.clone());
            if let Some(r) = &self.recording {
                let done = r.written.iter().filter(|w| **w).count();
                if ui
                    .button("Stop")
                    .on_hover_text(format!("{done} of {} frames recorded", r.written.len()))
                    .clicked()
                {
                    action = Some(TimelineAction::Record(None));
                }
            } else if ui
                .button("Record")
                .on_hover_text(
                    "Play the path once from its first step and write each step's frame, \
                     technique beside the exact answer, as PNG into the folder, then one animated \
                     PNG of them",
                )
                .clicked()
            {
                action = Some(TimelineAction::Record(Some(self.record_folder.clone())));
            }
        });
        action
    }

    fn live_ui(&mut self, ui: &mut egui::Ui) {
        if let Some(message) = &self.live_message {
            ui.weak(message);
            return;
        }
        let live = &self.live;
        if live.is_empty() {
            ui.weak("error and flicker appear as frames are played");
            return;
        }
        let error = live.iter().map(|m| m.mae_shadowed).sum::<f64>() / live.len() as f64;
        let flickers: Vec<f64> = live.iter().filter_map(|m| m.flicker).collect();
        let flicker = if flickers.is_empty() {
            "-".to_string()
        } else {
            format!(
                "{:.4}",
                flickers.iter().sum::<f64>() / flickers.len() as f64
            )
        };
        let irradiance: Vec<f64> = live
            .iter()
            .filter_map(|m| m.irradiance_mae_shadowed)
            .collect();
        let irradiance = match irradiance.len() {
            0 => String::new(),
            n if n == live.len() => {
                format!(
                    ", irradiance error {:.4}",
                    irradiance.iter().sum::<f64>() / n as f64
                )
            }
            n => format!(
                ", irradiance error {:.4} ({n} of {} frames)",
                irradiance.iter().sum::<f64>() / n as f64,
                live.len()
            ),
        };
        ui.label(format!("error {error:.4}, flicker {flicker}{irradiance}"))
            .on_hover_text(format!(
                "Means over the last {} frames played, against each frame's exact answer: \
                 error = mae_shadowed; flicker = mean over receiver pixels of \
                 |(V_t - V_t-1) - (E_t - E_t-1)|, the change the technique shows that the truth \
                 does not (docs/BENCHMARKS.md, \"Motion\"); irradiance error (with the analytic \
                 answer) = mean |V E0 - E| over shadowed receivers over their mean E0, the error \
                 where the shaded image shows it (\"The irradiance error\")",
                live.len()
            ));
        if let Some(last) = live.back() {
            ui.small(format!(
                "exact answer: {} ({:.0} ms a frame)",
                last.exact, last.exact_ms
            ))
            .on_hover_text(
                "The closed form where every caster is a rectangle parallel to the light; \
                 elsewhere the analytic answer (no sampling error) where the light has area and \
                 it takes about 2 s at most (receiver pixels times caster triangles), else the \
                 GPU ray-traced answer, whose sampling error (O(1/N) at a penumbra point for N x N samples) is \
                 part of the error and flicker shown",
            );
            if let LiveExact::Traced { samples_per_axis } = last.exact {
                if samples_per_axis < COARSE_TRACED_SAMPLES {
                    ui.small(format!(
                        "coarse: its own error reaches about {:.2} at a penumbra pixel; a \
                         smaller render size affords more samples",
                        1.0 / samples_per_axis as f64
                    ));
                }
            }
        }
    }
}

impl ViewerApp {
    /// Draws the Path section and carries out what was asked.
    pub(super) fn timeline_ui(&mut self, ui: &mut egui::Ui) {
        let declared: Vec<String> = self
            .scene
            .loaded
            .paths
            .iter()
            .map(|p| p.name.clone())
            .collect();
        match self.timeline.ui(ui, &declared) {
            Some(TimelineAction::Open(path)) => self.open_path(path.as_deref()),
            Some(TimelineAction::Play(playing)) => self.set_playing(playing),
            Some(TimelineAction::Scrub(step)) => self.scrub_to(step),
            Some(TimelineAction::Steps(steps)) => self.set_path_steps(steps),
            Some(TimelineAction::Record(folder)) => self.record_path(folder.as_deref()),
            None => {}
        }
    }
}
