//! The timeline (issue 28): plays a path (docs/SCENES.md, "Paths") over the open scene: play,
//! pause, scrub, loop; the error and the flicker against the exact answer of every frame shown
//! live over a rolling window; Record writes each played frame, technique beside the exact
//! answer, as PNG files.
//!
//! A played path steps at fixed times (`steps` frames from its start to its end, as
//! `bench --path NAME --frames N` does) and moves on only once the technique's frame of the
//! current step is shown, so every step is rendered and measured whatever a frame costs. The
//! exact answer of each frame is computed on the render worker (`render_worker`): the closed form
//! where it applies, else the ray-traced answer (16 x 16 samples) on a device with ray queries; a
//! scene with neither shows no live error (the benchmark's path runs use the CPU ray cast there).

use std::{collections::VecDeque, path::PathBuf};

use softshadow_core::{Scene, SceneGpu};
use softshadow_scenes::path::{self, Path, BUILTIN_PATHS};

use super::{shown_path, ViewerApp};
use crate::orbit::Orbit;

/// Frames of the rolling window the live error and flicker are averaged over.
pub const LIVE_WINDOW: usize = 30;

/// Frames a path is played in unless the user says otherwise.
pub const DEFAULT_STEPS: u32 = 60;

/// Error and flicker of one shown frame against its exact answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LiveMetrics {
    /// `mae_shadowed` against the frame's exact answer.
    pub mae_shadowed: f64,
    /// Flicker against the frame before it (`None` for the first frame of a run).
    pub flicker: Option<f64>,
    /// The exact answer it was measured against.
    pub exact: softshadow_reference::GroundTruth,
}

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
    /// Live metrics of the last frames played, newest last.
    pub(super) live: VecDeque<LiveMetrics>,
    /// Why there are no live metrics (no closed form, or the worker's error).
    pub(super) live_message: Option<String>,
    /// Folder Record writes to, and the frames written so far while recording.
    pub(super) record_folder: String,
    pub(super) recording: Option<u32>,
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
            live: VecDeque::new(),
            live_message: None,
            record_folder: "viewer-path".into(),
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

    /// Writes every played frame (technique beside the exact answer) as PNG into `folder`.
    pub fn record_path(&mut self, folder: Option<&str>) {
        match folder {
            Some(folder) => match std::fs::create_dir_all(folder) {
                Ok(()) => {
                    self.timeline.record_folder = folder.to_string();
                    self.timeline.recording = Some(0);
                }
                Err(e) => self.report_error(format!("cannot record into `{folder}`: {e}")),
            },
            None => {
                if let Some(frames) = self.timeline.recording.take() {
                    let folder = shown_path(std::path::Path::new(&self.timeline.record_folder));
                    self.confirm(format!("recorded {frames} frames in {folder}"));
                }
            }
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
        self.scene.camera = pose.camera;
        self.scene.light = pose.light;
        self.scene.orbit = Orbit::from_camera(&pose.camera);
        if !pose.transforms.is_empty() {
            let mut moved = base.clone();
            pose.apply(&mut moved);
            self.scene.loaded.gpu = SceneGpu::upload(&self.gpu, &moved);
            self.scene.loaded.scene = moved;
        }
        self.timeline.applied = Some(step);
    }

    /// Notes a shown frame of the current step: its live metrics, its recorded image, and the
    /// next step when playing.
    pub(super) fn path_frame_shown(
        &mut self,
        live: Option<Result<LiveMetrics, String>>,
        exact: Option<&[f32]>,
    ) {
        let step = self.timeline.step;
        if self.timeline.active.is_none() || self.timeline.applied != Some(step) {
            return;
        }
        if self.timeline.measured != Some(step) {
            self.timeline.measured = Some(step);
            self.note_step(live, exact);
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
        if let Some(written) = self.timeline.recording {
            if let Err(e) = self.write_recorded_frame(written, exact) {
                self.report_error(format!("cannot record the frame: {e}"));
                self.timeline.recording = None;
            } else {
                self.timeline.recording = Some(written + 1);
            }
        }
    }

    /// One PNG per frame: the technique's shaded image, and beside it the exact answer as grey
    /// (white lit, black umbra) where the scene has one.
    fn write_recorded_frame(&self, index: u32, exact: Option<&[f32]>) -> Result<(), String> {
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
        let file =
            PathBuf::from(&self.timeline.record_folder).join(format!("frame-{index:04}.png"));
        image
            .save(&file)
            .map_err(|e| format!("{}: {e}", file.display()))
    }

    pub(super) fn timeline_ui(&mut self, ui: &mut egui::Ui) {
        let current = self
            .timeline
            .active
            .as_ref()
            .map(|(path, _)| path.name.clone());
        let mut chosen: Option<Option<String>> = None;
        egui::ComboBox::from_label("path")
            .selected_text(current.clone().unwrap_or_else(|| "none".into()))
            .show_ui(ui, |ui| {
                if ui.selectable_label(current.is_none(), "none").clicked() {
                    chosen = Some(None);
                }
                let declared = self.scene.loaded.paths.iter().map(|p| p.name.clone());
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
            self.open_path(choice.as_deref());
        }
        if self.timeline.active.is_none() {
            return;
        }
        ui.horizontal(|ui| {
            let label = if self.timeline.playing {
                "Pause"
            } else {
                "Play"
            };
            if ui.button(label).clicked() {
                let playing = !self.timeline.playing;
                self.set_playing(playing);
            }
            ui.checkbox(&mut self.timeline.looping, "loop");
        });
        let last = self.timeline.steps.saturating_sub(1);
        let mut step = self.timeline.step;
        if ui
            .add(egui::Slider::new(&mut step, 0..=last).text("frame"))
            .on_hover_text("Scrub: the frame of the path shown (fixed time steps)")
            .changed()
        {
            self.scrub_to(step);
        }
        let mut steps = self.timeline.steps;
        if ui
            .add(egui::Slider::new(&mut steps, 2..=600).text("frames"))
            .on_hover_text("Frames from the path's start to its end")
            .changed()
        {
            self.set_path_steps(steps);
        }
        self.live_ui(ui);
        ui.horizontal(|ui| {
            ui.add(
                egui::TextEdit::singleline(&mut self.timeline.record_folder).desired_width(130.0),
            );
            if self.timeline.recording.is_some() {
                if ui.button("Stop").clicked() {
                    self.record_path(None);
                }
            } else if ui
                .button("Record")
                .on_hover_text(
                    "Write every played frame, technique beside the exact answer, as PNG",
                )
                .clicked()
            {
                let folder = self.timeline.record_folder.clone();
                self.record_path(Some(&folder));
            }
        });
    }

    fn live_ui(&mut self, ui: &mut egui::Ui) {
        if let Some(message) = &self.timeline.live_message {
            ui.weak(message);
            return;
        }
        let live = &self.timeline.live;
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
        let exact = live.back().map(|m| m.exact.to_string()).unwrap_or_default();
        ui.label(format!("error {error:.4}, flicker {flicker}"))
            .on_hover_text(format!(
                "Means over the last {} frames played, against each frame's exact answer \
                 (the last: {exact}): error = mae_shadowed; flicker = mean over receiver pixels of \
                 |(V_t - V_t-1) - (E_t - E_t-1)|, the change the technique shows that the truth \
                 does not (docs/BENCHMARKS.md, \"Motion\")",
                live.len()
            ));
    }
}
