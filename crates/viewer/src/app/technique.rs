//! The active technique: switching, its parameters, and its frames, which run on a render
//! worker ([`super::render_worker`]) so the UI stays responsive whatever they cost.

use std::{
    collections::BTreeMap,
    sync::Arc,
    thread::JoinHandle,
    time::{Duration, Instant},
};

use softshadow_core::{scene::Fnv1a, ParamSet, ParamValue, Scene, ShadingMode, TechniqueInfo};

use super::{
    build_panel::BuildState,
    render_worker::{FrameDone, FrameRequest, RenderWorker},
    timing_panel::SLOW_COST_FRAME_MS,
    worker_process::{Start, TechniqueSource, WorkerCommand},
    ViewerApp,
};
use crate::display::{DisplayTarget, ViewMode};

/// How long one UI frame waits for the technique's frame before it draws the last one again: a
/// fast technique's frame is shown in the frame that asked for it, a slow one never holds the UI
/// (which answers input within about this plus its own drawing).
pub const FRAME_WAIT: Duration = Duration::from_millis(40);

/// A frame running longer than this shows its progress with a Cancel button.
pub const SLOW_FRAME: Duration = Duration::from_secs(1);

/// Workers started again in a row, without a frame shown in between, after a lost device or a
/// worker process that died: past this the technique is left stopped (it would only fail again)
/// until it is picked again.
const MAX_RESTARTS: u32 = 2;

/// The active technique, every technique's settings, and its last error.
pub(super) struct TechniqueState {
    pub(super) id: String,
    /// The thread that renders it; `None` when it failed to start or its frame was cancelled.
    pub(super) worker: Option<RenderWorker>,
    /// Its parameters (its specs with the values set); `None` when it failed to start.
    pub(super) params: Option<ParamSet>,
    /// Settings per technique id, so switching back and forth keeps them.
    pub(super) settings: BTreeMap<String, BTreeMap<String, ParamValue>>,
    /// The scene as the worker gets it (uploaded there once per scene hash).
    scene: Option<(u64, Arc<Scene>)>,
    /// The setting (technique, parameters, scene, light, camera, size) the shown image is of.
    pub(super) shown_key: Option<u64>,
    /// Why no frame is asked for (the user cancelled one) until Render again.
    pub(super) cancelled_frame: Option<String>,
    /// The last idle worker's device, for the next one ([`RenderWorker::retire`]).
    spare_device: Option<softshadow_core::Gpu>,
    /// How long a UI frame waits for the technique's ([`FRAME_WAIT`] unless set).
    pub(super) frame_wait: Duration,
    /// The last frame's failure (or its failure to start).
    pub(super) error: Option<String>,
    /// Its precompute when it builds off the UI thread ([`super::build_panel`]).
    pub(super) build: BuildState,
    /// Threads of workers abandoned mid-frame, until their frame ends: while one runs, no cost
    /// frame is asked for (it would share the CPU with it and read slow).
    abandoned: Vec<JoinHandle<()>>,
    /// Wall time of the last finished frame per setting and kind (cost frame or not, with the
    /// exact answer of a path step or not), ms: what a running frame's progress is estimated
    /// from.
    frame_ms: BTreeMap<(u64, bool, bool), f64>,
    /// The still frames of the current setting, for a technique that keeps a history.
    pub(super) history: HistoryState,
    /// When the active technique was picked, until its first frame is shown.
    picked_at: Option<Instant>,
    /// Time from picking the active technique to its first frame shown, ms.
    pub(super) first_frame_ms: Option<f64>,
    /// The program a worker process runs ([`super::ViewerOptions::worker`]); `None`: threads.
    worker_command: Option<WorkerCommand>,
    /// Worker processes started this session: the next one's index (`SOFTSHADOW_FAULT`'s K).
    processes_started: usize,
    /// Faults to inject into worker processes (`SOFTSHADOW_FAULT`'s text; empty: none).
    pub(super) faults: String,
    /// Workers started again since the last frame shown ([`MAX_RESTARTS`]).
    restarts: u32,
}

/// Frames of history a technique that keeps one is settled after when it declares no
/// `max_history` parameter.
pub const DEFAULT_HISTORY_FRAMES: u32 = 16;

/// Still frames (no cache dropped) of one setting in a row, and the history the technique
/// reports after them (its `history_frames` counter, where it has one).
#[derive(Default)]
pub(super) struct HistoryState {
    key: Option<u64>,
    pub(super) still_frames: u32,
    history_frames: Option<f64>,
    /// The frames of history the shown frame rests on once settled.
    pub(super) settled_after: Option<u32>,
}

impl HistoryState {
    /// Notes a shown frame of setting `key`; `target`: the history length it settles at.
    fn note(&mut self, key: u64, invalidated: bool, history_frames: Option<f64>, target: u32) {
        if self.key != Some(key) || invalidated {
            *self = Self {
                key: Some(key),
                ..Self::default()
            };
            if invalidated {
                return;
            }
        }
        self.still_frames += 1;
        let before = self.history_frames.replace(history_frames.unwrap_or(0.0));
        let settled = match history_frames {
            // Its counter reached the history length, or stopped growing after enough frames.
            Some(h) => h >= f64::from(target) || (before == Some(h) && self.still_frames > target),
            None => self.still_frames >= target,
        };
        if settled && self.settled_after.is_none() {
            self.settled_after = Some(history_frames.map_or(self.still_frames, |h| h as u32));
        }
    }

    /// Frames of history the frame of `key` settled after, if it has.
    pub(super) fn settled(&self, key: u64) -> Option<u32> {
        self.settled_after.filter(|_| self.key == Some(key))
    }
}

impl TechniqueState {
    pub(super) fn new(
        settings: BTreeMap<String, BTreeMap<String, ParamValue>>,
        worker_command: Option<WorkerCommand>,
    ) -> Self {
        Self {
            id: String::new(),
            worker: None,
            params: None,
            settings,
            scene: None,
            shown_key: None,
            cancelled_frame: None,
            spare_device: None,
            frame_wait: FRAME_WAIT,
            error: None,
            build: BuildState::default(),
            abandoned: Vec::new(),
            frame_ms: BTreeMap::new(),
            history: HistoryState::default(),
            picked_at: None,
            first_frame_ms: None,
            worker_command,
            processes_started: 0,
            faults: std::env::var(softshadow_bench::fault::FAULT_ENV).unwrap_or_default(),
            restarts: 0,
        }
    }

    /// A worker for `info` with `params`: in a process of its own when the viewer has a worker
    /// program, else on a thread (reusing the last idle worker's device).
    fn start_worker(
        &mut self,
        gpu: &softshadow_core::Gpu,
        info: &TechniqueInfo,
        params: Vec<(String, ParamValue)>,
        build: softshadow_core::BuildControl,
    ) -> Result<RenderWorker, super::render_worker::StartError> {
        let Some(command) = &self.worker_command else {
            return RenderWorker::for_technique(gpu, self.spare_device.take(), info, params, build);
        };
        let technique = match softshadow_wgsl::file_of(info) {
            Some(path) => TechniqueSource::File(path),
            None => TechniqueSource::Registered(info.id.to_string()),
        };
        let start = Start {
            technique,
            params,
            index: self.processes_started,
            faults: self.faults.clone(),
        };
        self.processes_started += 1;
        RenderWorker::in_process(command, start, build)
    }

    /// Retires the worker; an abandoned one's thread is kept until its frame ends.
    fn retire_worker(&mut self) {
        if let Some(worker) = self.worker.take() {
            let retired = worker.retire();
            self.spare_device = retired.device;
            self.abandoned.extend(retired.running);
        }
    }

    /// Whether a worker abandoned mid-frame still runs (its frame shares the CPU).
    pub(super) fn abandoned_running(&mut self) -> bool {
        let (done, running): (Vec<_>, Vec<_>) = std::mem::take(&mut self.abandoned)
            .into_iter()
            .partition(|t| t.is_finished());
        for thread in done {
            let _ = thread.join();
        }
        self.abandoned = running;
        !self.abandoned.is_empty()
    }

    /// The last frame's wall time of this setting and kind, ms: what a running frame is
    /// compared with (`None`: no earlier frame to go by).
    pub(super) fn estimate_ms(&self, key: u64, invalidate: bool, exact: bool) -> Option<f64> {
        self.frame_ms.get(&(key, invalidate, exact)).copied()
    }
}

impl TechniqueState {
    /// The scene as the render workers get it: shared, copied once per scene.
    pub(super) fn worker_scene(&mut self, loaded: &super::scene_panel::LoadedScene) -> Arc<Scene> {
        let hash = loaded.gpu.content_hash;
        if self.scene.as_ref().map(|(h, _)| *h) != Some(hash) {
            self.scene = Some((hash, Arc::new(loaded.scene.clone())));
        }
        self.scene.as_ref().expect("set above").1.clone()
    }
}

/// The parameters `info` declares with `saved` values over their defaults.
fn param_set_of(info: &TechniqueInfo, saved: &BTreeMap<String, ParamValue>) -> ParamSet {
    ParamSet {
        entries: info
            .params
            .iter()
            .map(|spec| {
                let value = saved
                    .get(spec.name.as_ref())
                    .cloned()
                    .unwrap_or_else(|| spec.default_value());
                (spec.clone(), value)
            })
            .collect(),
    }
}

impl ViewerApp {
    /// Switches the technique; its settings from earlier in the session are restored. A technique
    /// that fails to build shows its error and leaves no active technique. The old technique's
    /// frame, if one is running, is abandoned (its worker ends when the frame does).
    pub fn select_technique(&mut self, id: &str) {
        if self.technique.id != id {
            // Another technique's debug views: start from its first.
            self.image.debug_view = 0;
        }
        self.technique.id = id.to_string();
        self.technique.retire_worker();
        self.technique.params = None;
        self.technique.shown_key = None;
        self.technique.cancelled_frame = None;
        self.technique.picked_at = Some(Instant::now());
        self.technique.first_frame_ms = None;
        self.technique.restarts = 0;
        self.release_memory();
        self.technique.error = None;
        self.timing.rolling.clear();
        let saved = self.technique.settings.get(id).cloned().unwrap_or_default();
        let control = self.technique.build.fresh_control();
        let result = self
            .registry
            .find(id)
            .map_err(|e| e.to_string())
            .and_then(|info| {
                let params: Vec<(String, ParamValue)> = saved.clone().into_iter().collect();
                let worker = self
                    .technique
                    .start_worker(&self.gpu, info, params, control)
                    .map_err(|e| e.to_string())?;
                Ok((worker, param_set_of(info, &saved)))
            });
        match result {
            Ok((worker, params)) => {
                self.technique.worker = Some(worker);
                self.technique.params = Some(params);
            }
            Err(e) => {
                let message = format!("technique `{id}` failed to start: {e}");
                self.technique.error = Some(message.clone());
                self.report_error(message);
            }
        }
    }

    /// Waits until the active technique exists on its worker (the app's first technique: a
    /// technique that cannot be created with the given settings is bad input).
    pub(super) fn wait_technique_started(&mut self) -> Result<(), String> {
        let Some(worker) = self.technique.worker.as_mut() else {
            return Err(self.technique.error.clone().unwrap_or_default());
        };
        worker.wait_started().map_err(|e| {
            self.technique.worker = None;
            format!("technique `{}` failed to start: {e}", self.technique.id)
        })
    }

    /// Sets one parameter of the active technique (range-checked; an error is shown). The next
    /// frame the worker renders uses it.
    pub fn set_param(&mut self, name: &str, value: ParamValue) {
        let Some(params) = self.technique.params.as_mut() else {
            return;
        };
        let Some((spec, current)) = params.entries.iter_mut().find(|(s, _)| s.name == name) else {
            self.report_error(format!(
                "`{}` has no parameter `{name}`: see its panel for the ones it has",
                self.technique.id
            ));
            return;
        };
        match spec.check(value) {
            Ok(value) => {
                *current = value.clone();
                self.technique
                    .settings
                    .entry(self.technique.id.clone())
                    .or_default()
                    .insert(name.to_string(), value);
                self.timing.rolling.clear();
            }
            Err(e) => self.report_error(e.to_string()),
        }
    }

    /// Stops waiting for the technique's running frame (the Cancel button): its worker is
    /// abandoned and no frame is asked for until [`ViewerApp::render_again`].
    pub fn cancel_frame(&mut self) {
        let Some(seconds) = self.technique.worker.as_ref().map(|w| w.busy_for()) else {
            return;
        };
        let seconds = seconds.map_or(0.0, |d| d.as_secs_f64());
        // A worker process is killed here: its frame stops at once, whatever it runs.
        self.technique.retire_worker();
        // A precompute running inside the technique stops too.
        self.technique.build.cancel_control();
        self.technique.cancelled_frame = Some(format!(
            "{}: frame cancelled after {seconds:.1} s; nothing is drawn until Render again",
            self.technique.id
        ));
        // The cost measured so far stays: its frames were whole and clean.
    }

    /// Starts the technique again after [`ViewerApp::cancel_frame`] (the Render again button).
    pub fn render_again(&mut self) {
        let id = self.technique.id.clone();
        self.select_technique(&id);
    }

    /// Time from picking the active technique to its first frame shown, ms (`None` until
    /// then).
    pub fn first_frame_ms(&self) -> Option<f64> {
        self.technique.first_frame_ms
    }

    /// Seconds the technique's running frame has taken so far, once it counts as slow
    /// ([`SLOW_FRAME`]); `None` otherwise.
    pub fn slow_frame_seconds(&self) -> Option<f64> {
        self.technique
            .worker
            .as_ref()
            .and_then(|w| w.busy_for())
            .filter(|d| *d >= SLOW_FRAME)
            .map(|d| d.as_secs_f64())
    }

    /// Whether the render worker is computing a frame of the technique.
    pub fn technique_frame_running(&self) -> bool {
        self.technique.worker.as_ref().is_some_and(|w| w.busy())
    }

    /// Why no frame is being rendered after a Cancel, if one was cancelled.
    pub fn cancelled_frame(&self) -> Option<&str> {
        self.technique.cancelled_frame.as_deref()
    }

    /// How long each UI frame waits for the technique's frame (default [`FRAME_WAIT`]). Tests
    /// and `view --frames N` wait for every frame (`Duration::MAX`) so that each UI frame shows
    /// the frame it asked for.
    pub fn set_frame_wait(&mut self, wait: Duration) {
        self.technique.frame_wait = wait;
    }

    /// Asks the worker for a frame when it is idle, and shows the frame it finishes.
    pub(super) fn render_technique(&mut self) {
        puffin::profile_function!();
        if self.image.renderers.is_none() || self.technique.cancelled_frame.is_some() {
            return;
        }
        if let Some(Err(e)) = self
            .technique
            .worker
            .as_mut()
            .and_then(|w| w.poll_started())
        {
            self.technique.worker = None;
            let message = format!("technique `{}` failed to start: {e}", self.technique.id);
            self.technique.error = Some(message.clone());
            self.report_error(message);
            return;
        }
        let request = self.frame_request();
        let Some(worker) = self.technique.worker.as_mut() else {
            return;
        };
        if !worker.busy() && !worker.request(request) {
            self.worker_stopped();
            return;
        }
        match worker.receive(self.technique.frame_wait) {
            Ok(Some(done)) => {
                let lost = done.device_lost.clone();
                self.show_frame(done);
                if let Some(why) = lost {
                    self.restart_worker(format!("its render worker's device was lost ({why})"));
                }
            }
            Ok(None) => {}
            Err(()) => self.worker_stopped(),
        }
    }

    /// The frame to ask for now. The first frames of a setting pay the whole cost (as the
    /// benchmark's `timing` does), and only when they run alone: no abandoned frame and no
    /// reference batch on the CPU beside them (a frame that shared it read up to 12x slow). Not
    /// while the user drags or a path plays: camera-only frames keep those interactive.
    fn frame_request(&mut self) -> FrameRequest {
        let alone = !self.technique.abandoned_running()
            && !self.reference.worker.as_ref().is_some_and(|w| w.busy());
        let invalidate = self.timing.cost.len() < self.timing.cost_frames_wanted()
            && !self.image.interacting
            && !self.timeline.playing
            && alone;
        let r = self
            .image
            .renderers
            .as_ref()
            .expect("checked by the caller");
        FrameRequest {
            setting_key: self.current_setting_key(),
            scene: self.technique.worker_scene(&self.scene.loaded),
            scene_hash: self.scene.loaded.gpu.content_hash,
            camera: self.scene.camera,
            light: self.scene.light,
            size: (r.width, r.height),
            params: self.setting(),
            invalidate,
            debug_view: (self.image.view_mode == ViewMode::Debug).then_some(self.image.debug_view),
            exact: self.timeline.exact_wanted(),
        }
    }

    /// The worker ended without answering: a thread that panicked, a process that died (a
    /// crash in the driver, a lost device, killed from outside). A process is started again;
    /// a thread's panic would only repeat, so the technique waits to be picked again.
    fn worker_stopped(&mut self) {
        let Some(mut worker) = self.technique.worker.take() else {
            return;
        };
        let id = self.technique.id.clone();
        if let Some(Err(e)) = worker.poll_started() {
            self.technique.error = Some(format!("{id}: it failed to start: {e}"));
            return;
        }
        match worker.why_stopped() {
            Some(how) => {
                drop(worker);
                self.restart_worker(format!("its render worker stopped: {how}"));
            }
            None => {
                self.technique.error = Some(format!(
                    "{id}: its render worker stopped (a panic on its thread; the log says why); \
                     pick the technique again to restart it"
                ));
            }
        }
    }

    /// Replaces a worker whose device was lost or whose process ended with a new one (a new
    /// device, a new process), saying why; after [`MAX_RESTARTS`] in a row without a frame
    /// shown, leaves the technique stopped.
    fn restart_worker(&mut self, why: String) {
        let id = self.technique.id.clone();
        if let Some(worker) = self.technique.worker.take() {
            // Its device is not reused.
            let _ = worker.retire();
        }
        self.technique.spare_device = None;
        let restarts = self.technique.restarts;
        if restarts >= MAX_RESTARTS {
            let message = format!(
                "{id}: {why}; not restarted again after {restarts} new workers failed the same \
                 way: pick the technique again to retry"
            );
            self.technique.error = Some(message.clone());
            self.report_error(message);
            return;
        }
        self.report_error(format!("{id}: {why}; a new render worker was started"));
        self.select_technique(&id);
        self.technique.restarts = restarts + 1;
    }

    /// Faults to inject into the render worker processes started from now on, as
    /// `SOFTSHADOW_FAULT` would (`lost:K`: the K-th worker process of the session, counted from
    /// 0, loses its device before its first frame; `hang`, `oom`, `crash` likewise): for tests.
    pub fn set_faults(&mut self, faults: &str) -> Result<(), crate::ViewerError> {
        faults.parse::<softshadow_bench::fault::Faults>()?;
        self.technique.faults = faults.to_string();
        Ok(())
    }

    /// Worker processes started this session (0 with thread workers).
    pub fn worker_processes_started(&self) -> usize {
        self.technique.processes_started
    }

    /// The history length the active technique settles at when it keeps a history at its
    /// current setting (its descriptor's `varies_per_frame`): its `max_history` parameter, else
    /// [`DEFAULT_HISTORY_FRAMES`]; `None` when its frames do not depend on earlier ones.
    pub(super) fn history_length(&self) -> Option<u32> {
        let info = self.registry.get(&self.technique.id)?;
        let setting = self.setting();
        info.varies_per_frame_at(&setting)?;
        let declared = setting
            .iter()
            .find(|(name, _)| name == "max_history")
            .and_then(|(_, v)| v.as_f64())
            .map(|v| v.max(1.0) as u32);
        Some(declared.unwrap_or(DEFAULT_HISTORY_FRAMES))
    }

    /// Shades and shows a finished frame, and counts its timings where they belong to the
    /// current setting.
    fn show_frame(&mut self, done: FrameDone) {
        if done.scene_hash != self.scene.loaded.gpu.content_hash {
            return; // Of a scene no longer open.
        }
        let current = done.setting_key == self.current_setting_key();
        self.technique.frame_ms.insert(
            (done.setting_key, done.invalidated, done.live.is_some()),
            done.wall_ms,
        );
        let shown_ok = done.result.is_ok();
        let mut path_timing = None;
        match done.result {
            Ok((output, visibility)) => {
                self.technique.restarts = 0;
                path_timing = output.gpu.clone();
                self.technique.build.note(Ok(()));
                if let Some(r) = self.image.renderers.as_mut() {
                    if (r.width, r.height) == done.size {
                        if let Err(e) = r.technique.show_visibility(
                            &self.scene.loaded.gpu,
                            &done.camera,
                            &done.light,
                            &visibility,
                            ShadingMode::Shaded,
                        ) {
                            self.report_error(format!("cannot show the frame: {e}"));
                            return;
                        }
                        self.technique.shown_key = Some(done.setting_key);
                        self.note_first_frame();
                    }
                }
                if current {
                    self.count_frame(&output, done.invalidated, &done.stats);
                }
                self.timing.last_output = Some(output);
                self.timing.last_memory = done.technique_memory;
                self.technique.error = None;
            }
            Err(e) if self.technique.build.note(Err(&e)) => {
                // The precompute builds off the worker's thread: nothing drawn, nothing timed.
                self.technique.error = None;
                self.timing.rolling.clear();
                self.timing.cost.clear();
            }
            Err(e) => {
                // Keep running: the error is shown and the next frame tries again.
                self.technique.error = Some(format!("{} failed: {e}", self.technique.id));
                self.timing.rolling.clear();
                self.timing.cost.clear();
            }
        }
        if current && shown_ok {
            self.path_frame_shown(done.live, done.exact.as_deref(), path_timing.as_ref());
        }
        self.show_debug(done.debug_image, done.debug_views.is_empty());
    }

    /// Counts a frame of the current setting: its timings, a cost frame's cost, the history.
    fn count_frame(
        &mut self,
        output: &softshadow_core::FrameOutput,
        invalidated: bool,
        stats: &softshadow_core::TechniqueStats,
    ) {
        if let Some(gpu) = &output.gpu {
            self.timing.rolling.push(gpu.clone());
            if invalidated && self.timing.cost.len() < self.timing.cost_frames_wanted() {
                self.timing.cost.push(gpu.clone());
                self.timing.slow_cost_frames |= output.cpu_ms > SLOW_COST_FRAME_MS;
            }
        }
        if let Some(target) = self.history_length() {
            let key = self.current_setting_key();
            let counter = stats.get("history_frames").copied();
            self.technique
                .history
                .note(key, invalidated, counter, target);
        }
    }

    /// Logs and keeps the time from picking the technique to its first frame shown.
    fn note_first_frame(&mut self) {
        if let Some(picked) = self.technique.picked_at.take() {
            let ms = picked.elapsed().as_secs_f64() * 1e3;
            log::info!(
                "{}: first frame shown {ms:.0} ms after it was picked",
                self.technique.id
            );
            self.technique.first_frame_ms = Some(ms);
        }
    }

    /// The debug image (or why there is none) that came with a frame.
    fn show_debug(
        &mut self,
        image: Option<Result<super::render_worker::DebugImage, String>>,
        no_views: bool,
    ) {
        self.image.debug_message = None;
        self.image.debug_mapping = None;
        match image {
            Some(Ok(image)) => {
                self.show_debug_image(&image);
                self.image.debug_mapping = Some(image.mapping);
            }
            Some(Err(message)) => self.image.debug_message = Some(message),
            None if self.image.view_mode == ViewMode::Debug && no_views => {
                self.image.debug_message =
                    Some(format!("`{}` has no debug views", self.technique.id));
            }
            None => {}
        }
    }

    /// Copies a debug image drawn by the worker into the texture the image area shows.
    fn show_debug_image(&mut self, image: &super::render_worker::DebugImage) {
        let stale = self.image.debug_target.as_ref().is_none_or(|(t, _)| {
            (t.texture.width(), t.texture.height()) != (image.width, image.height)
        });
        if stale {
            let target = DisplayTarget::new(&self.gpu, "viewer/debug", image.width, image.height);
            let mut egui_renderer = self.egui_renderer.write();
            let id = match self.image.debug_target.take() {
                Some((_, id)) => {
                    egui_renderer.update_egui_texture_from_wgpu_texture(
                        &self.gpu.device,
                        &target.view,
                        softshadow_core::wgpu::FilterMode::Nearest,
                        id,
                    );
                    id
                }
                None => egui_renderer.register_native_texture(
                    &self.gpu.device,
                    &target.view,
                    softshadow_core::wgpu::FilterMode::Nearest,
                ),
            };
            self.image.debug_target = Some((target, id));
        }
        let (target, _) = self.image.debug_target.as_ref().expect("created above");
        target.write(&self.gpu, &image.rgba);
    }

    pub(super) fn setting(&self) -> Vec<(String, ParamValue)> {
        self.technique
            .params
            .as_ref()
            .map(|p| {
                p.entries
                    .iter()
                    .map(|(s, v)| (s.name.to_string(), v.clone()))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Technique, parameters, scene, light, camera and size: what one timing window belongs to.
    pub(super) fn current_setting_key(&self) -> u64 {
        let mut h = Fnv1a::default();
        h.write_u64(self.current_view_key());
        h.write_str(&self.technique.id);
        for (name, value) in self.setting() {
            h.write_str(&name);
            h.write_str(&value.to_string());
        }
        if let Some(r) = &self.image.renderers {
            h.write_u64(u64::from(r.width) << 32 | u64::from(r.height));
        }
        h.finish()
    }

    pub fn technique_id(&self) -> &str {
        &self.technique.id
    }

    /// Current parameters of the active technique (`None` when it failed to build).
    pub fn technique_params(&self) -> Option<ParamSet> {
        self.technique.params.clone()
    }

    /// The active technique's last render error, if its last frame failed.
    pub fn technique_error(&self) -> Option<&str> {
        self.technique.error.as_deref()
    }
}
