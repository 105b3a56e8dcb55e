//! The viewer's state and UI: scene and technique pickers, the parameter panel generated from the
//! technique's [`ParamSpec`](softshadow_core::ParamSpec)s, light and camera controls, GPU
//! timings, the progressive reference and the live error, view modes, and the error-against-time
//! plot.
//!
//! [`ViewerApp::ui`] lays out one egui pass and renders one GPU frame; the winit window
//! ([`crate::window`]) and the egui_kittest tests drive the same function.
//!
//! The app is made of components that each own their state, one module each (private, so named
//! rather than linked): `scene_panel` (scene, camera, light: `SceneState`), `technique` (the
//! active technique, every technique's settings, its frame: `TechniqueState`) with its panel
//! `technique_panel` and `build_panel` (a precompute building off the UI thread), `image` (the
//! renderers, the display pass, view mode and render size: `ImageState`), `reference` (the
//! progressive reference and the metrics against it: `ReferenceState`), `timing_panel`
//! (`TimingState`), `error_panel` (the metrics), `plot_panel` (the error-against-time plot:
//! `PlotPanel`, drawn by its own `ui` and answering with a `PlotAction`), `files_panel`
//! (`FilesState`), `timeline` (a path played over the scene: `TimelineState`),
//! `render_worker` (the threads the technique and the reference render on) and
//! `worker_process` (the technique's worker in a child process instead, with
//! [`ViewerOptions::worker`]: Cancel then stops any frame). This file holds the app, the frame's
//! order and the queries the window and the tests use.

mod build_panel;
mod error_panel;
mod file_reload;
mod files_panel;
mod image;
mod overlays;
mod plot_panel;
mod reference;
mod render_worker;
mod scene_panel;
mod technique;
mod technique_panel;
mod timeline;
mod timing_panel;
mod worker_process;

pub use plot_panel::{format_tick, linear_ticks, log_ticks, series_style};
pub use technique::{DEFAULT_HISTORY_FRAMES, FRAME_WAIT, SLOW_FRAME};
pub use technique_panel::param_widget;
pub use timeline::{
    LiveExact, LiveMetrics, PathTimings, ANIMATION_FILE, COARSE_TRACED_SAMPLES, DEFAULT_STEPS,
    LIVE_WINDOW,
};
pub(crate) use worker_process::serve as serve_worker;
pub use worker_process::WorkerCommand;

use std::{
    path::{Path, PathBuf},
    sync::Arc,
    time::Instant,
};

use egui::mutex::RwLock;
use softshadow_core::{AreaLight, Camera, Gpu, ParamValue, Registry, ShadowTechnique};
use softshadow_reference::{Reference, ReferenceSettings};

use crate::{
    display::{DisplayPass, ViewMode},
    state::ViewerState,
    tradeoff::TradeoffPoint,
    ViewerError,
};

/// Light samples per axis of the viewer's reference unless the state or the user says otherwise:
/// the benchmark's 32 x 32 (16 x 16 is visibly banded and moved backprojection's max_abs from
/// 0.068 to 0.041 when raised to 64 x 64). Progressive, so the first frames still come fast.
pub const DEFAULT_REFERENCE_SAMPLES: i64 = 32;
/// Batches of 16 light samples the reference adds per frame (32 x 32 converges in 32 frames).
pub const REFERENCE_BATCHES_PER_FRAME: u32 = 2;
/// Frames of one setting rendered with the technique's caches dropped (as the benchmark's
/// `timing` does) before its point in the plot counts: the point's time is their median, the
/// cost of computing the technique, not of showing a kept result.
const COST_FRAMES: usize = 5;
/// Frame times kept for the frame-time readout.
const FRAME_TIME_WINDOW: usize = 60;
/// Width of the left (controls) panel, points.
pub const LEFT_PANEL_WIDTH: f32 = 300.0;
/// Width of the right (measurements) panel, points.
pub const RIGHT_PANEL_WIDTH: f32 = 280.0;
/// Smallest render edge (the image area can be tiny while a window is being resized).
const MIN_RENDER_EDGE: u32 = 16;
/// The plot panel's default (and least) share of the window's height.
pub const PLOT_SHARE: f32 = 1.0 / 3.0;

/// How the viewer starts.
#[derive(Clone, Debug)]
pub struct ViewerOptions {
    /// The techniques it offers (`softshadow::registry()`, plus any of the user's own).
    pub registry: Registry,
    /// Builtin id, `.toml` scene file or glTF file.
    pub scene: String,
    /// The technique shown first; empty: the registry's default ([`Registry::default_technique`]).
    pub technique: String,
    /// Technique parameters, `name=value` already parsed.
    pub params: Vec<(String, ParamValue)>,
    /// A saved viewer state to start from (overrides scene, technique and params).
    pub state: Option<PathBuf>,
    /// The program each technique's render worker runs in, a process per technique
    /// (`workbench view-worker`; docs/ARCHITECTURE.md, "The viewer's render worker"): a frame
    /// that never ends is then stopped by Cancel. `None`: the worker is a thread of the viewer,
    /// which cannot stop such a frame (for a host whose registry no program of its own serves).
    pub worker: Option<WorkerCommand>,
}

impl Default for ViewerOptions {
    fn default() -> Self {
        Self {
            registry: Registry::default(),
            scene: "atty-square".into(),
            technique: String::new(),
            params: Vec::new(),
            state: None,
            worker: None,
        }
    }
}

/// What the window asks the app after each pass.
#[derive(Clone, Debug, Default)]
pub struct FrameStats {
    /// Median wall time between the last frames, ms.
    pub frame_ms: Option<f64>,
    /// Frames rendered so far.
    pub frames: u64,
}

/// The viewer: one component per part of the window, each owning its state, and the GPU context
/// they share.
pub struct ViewerApp {
    gpu: Gpu,
    egui_renderer: Arc<RwLock<egui_wgpu::Renderer>>,
    registry: Registry,
    /// Scene, camera and light ([`scene_panel`]).
    scene: scene_panel::SceneState,
    /// The active technique and every technique's settings ([`technique`]).
    technique: technique::TechniqueState,
    /// The renderers, the display pass and how the image is shown ([`image`]).
    image: image::ImageState,
    /// The progressive reference and the metrics against it ([`reference`]).
    reference: reference::ReferenceState,
    /// The path being played ([`timeline`]).
    timeline: timeline::TimelineState,
    /// Frame and pass timings ([`timing_panel`]).
    timing: timing_panel::TimingState,
    /// The error-against-time plot: its points, options and panel ([`plot_panel`]).
    plot: plot_panel::PlotPanel,
    /// File paths, the screenshot request and the puffin server ([`files_panel`]).
    files: files_panel::FilesState,
    /// Errors and confirmations.
    messages: overlays::Messages,
    /// The active technique's WGSL file, watched for new versions ([`file_reload`]).
    file_reload: file_reload::FileReload,
    /// Side panels paint their background (egui's default). The window turns this off and clears
    /// to the panel colour instead: on a CPU rasteriser the two full-height fills cost ~20 ms.
    opaque_panels: bool,
}

impl ViewerApp {
    /// Builds the app on `gpu`; native textures are registered with `egui_renderer`, which must
    /// draw on the same device.
    pub fn new(
        gpu: Gpu,
        egui_renderer: Arc<RwLock<egui_wgpu::Renderer>>,
        options: &ViewerOptions,
    ) -> Result<Self, ViewerError> {
        let state = options
            .state
            .as_deref()
            .map(ViewerState::load)
            .transpose()?;
        let scene_spec = state.as_ref().map_or(options.scene.as_str(), |s| &s.scene);
        let scene = scene_panel::load_scene(&gpu, scene_spec)?;
        let registry = options.registry.clone();
        let default_technique = || -> Result<String, ViewerError> {
            if !options.technique.is_empty() {
                return Ok(options.technique.clone());
            }
            let info = registry
                .default_technique()
                .ok_or(ViewerError::NoTechnique)?;
            Ok(info.id.to_string())
        };
        let technique_id = match &state {
            Some(s) => s.technique.clone(),
            None => default_technique()?,
        };
        registry.find(&technique_id)?;
        let mut reference = Reference::new(&gpu, ReferenceSettings::default())?;
        reference.set_progressive(Some(REFERENCE_BATCHES_PER_FRAME));
        reference.set_param(
            "samples_per_axis",
            ParamValue::Int(DEFAULT_REFERENCE_SAMPLES),
        )?;
        let mut settings = state.as_ref().map(|s| s.params.clone()).unwrap_or_default();
        if state.is_none() && !options.params.is_empty() {
            settings.insert(
                technique_id.clone(),
                options.params.iter().cloned().collect(),
            );
        }
        let (camera, light) = match &state {
            Some(s) => (s.camera, s.light),
            None => (scene.scene.camera, scene.scene.light),
        };
        let mut app = Self {
            registry,
            egui_renderer,
            scene: scene_panel::SceneState::new(scene, camera, light),
            technique: technique::TechniqueState::new(settings, options.worker.clone()),
            image: image::ImageState::new(
                DisplayPass::new(&gpu)?,
                state.as_ref().map_or(ViewMode::Shaded, |s| s.view_mode),
                state.as_ref().map_or(0.5, |s| s.split),
            ),
            reference: reference::ReferenceState::new(reference),
            timeline: Default::default(),
            timing: Default::default(),
            plot: plot_panel::PlotPanel::new(
                output_dir().join("viewer-sweep.toml").display().to_string(),
            ),
            files: Default::default(),
            messages: Default::default(),
            file_reload: Default::default(),
            opaque_panels: true,
            gpu,
        };
        if let Some(state) = &state {
            for (name, value) in &state.reference_params {
                app.reference.yardstick.set_param(name, value.clone())?;
            }
        }
        app.select_technique(&technique_id);
        // A technique that cannot even be created with the given settings is bad input.
        app.wait_technique_started()
            .map_err(ViewerError::TechniqueStart)?;
        Ok(app)
    }

    // ----- Queries (tests, the window loop) -----

    pub fn scene_spec(&self) -> &str {
        &self.scene.loaded.spec
    }

    pub fn camera(&self) -> &Camera {
        &self.scene.camera
    }

    pub fn light(&self) -> &AreaLight {
        &self.scene.light
    }

    /// Errors shown in the UI, oldest first.
    pub fn errors(&self) -> &[String] {
        &self.messages.errors
    }

    /// The last confirmation shown under Files (where a screenshot, state or sweep went).
    pub fn status(&self) -> Option<&str> {
        self.messages.status.as_deref()
    }

    /// Shows where a file went (the window calls this after writing the screenshot).
    pub fn confirm(&mut self, message: impl Into<String>) {
        self.messages.status = Some(message.into());
    }

    /// Points of this scene's other views (light or camera) measured this session: kept,
    /// shown hollow on request.
    pub fn points_of_other_views(&self) -> usize {
        self.plot
            .other_views(self.scene.loaded.gpu.content_hash, self.current_view_key())
            .map(|v| v.points.len())
            .sum()
    }

    /// Where the plot drew the current view's points last frame (screen points), with them:
    /// what a hover or a click there picks.
    pub fn plot_point_positions(&self) -> Vec<(egui::Pos2, TradeoffPoint)> {
        self.plot.drawn().to_vec()
    }

    /// Shows a plot point's setting: its technique with its parameters (a click on the point).
    /// A point of an earlier version of a file technique restores its parameters on the version
    /// in the file now, and says so.
    pub fn restore_point(&mut self, point: &TradeoffPoint) {
        if self.registry.get(&point.technique).is_none() {
            self.report_error(format!(
                "`{}` is no longer offered: its point cannot be shown",
                point.technique
            ));
            return;
        }
        if self.technique.id != point.technique || self.technique.worker.is_none() {
            self.select_technique(&point.technique);
        }
        for (name, value) in &point.params {
            self.set_param(name, value.clone());
        }
        let now = self.file_version();
        if point.version.is_some() && point.version != now {
            self.confirm(format!(
                "{}: showing {}'s parameters on v{} (the file holds no other version now)",
                point.technique,
                point.series(),
                now.unwrap_or(1)
            ));
        }
    }

    /// Points of the error-against-time plot for the current scene, light and camera.
    pub fn points(&self) -> &[TradeoffPoint] {
        self.plot.points_of(self.current_view_key())
    }

    pub fn report_error(&mut self, message: impl Into<String>) {
        self.messages.push_error(message.into());
    }

    // ----- Actions -----

    /// Hands back what a dropped scene or technique held: wgpu frees dropped GPU resources once
    /// the device has been polled, and glibc keeps freed heap pages (a 1 M triangle scene's
    /// vertex arrays) until asked to trim.
    fn release_memory(&mut self) {
        if let Err(e) = self.gpu.wait_idle() {
            log::warn!("waiting for the GPU before releasing memory: {e}");
        }
        trim_heap();
    }

    /// Whether the side panels paint their own background (see [`ViewerApp::ui`]); a host that
    /// turns this off clears its frame to `egui::Visuals::panel_fill` first.
    pub fn set_opaque_panels(&mut self, opaque: bool) {
        self.opaque_panels = opaque;
    }

    // ----- One frame -----

    /// Lays out the whole UI in `ui` and renders one GPU frame at the image area's size.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        puffin::GlobalProfiler::lock().new_frame();
        puffin::profile_function!();
        let now = Instant::now();
        if let Some(last) = self.timing.last_frame.replace(now) {
            if self.timing.frame_times.len() == FRAME_TIME_WINDOW {
                self.timing.frame_times.pop_front();
            }
            self.timing
                .frame_times
                .push_back((now - last).as_secs_f64() * 1e3);
        }

        let dropped: Vec<PathBuf> = ui.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_path_buf())
                .filter(|p| !p.as_os_str().is_empty())
                .collect()
        });
        for path in dropped {
            self.open_scene(&path.display().to_string());
        }
        self.reload_technique_file();

        let window = ui.max_rect().size();
        let mut panel_frame = egui::Frame::side_top_panel(ui.style());
        if !self.opaque_panels {
            panel_frame = panel_frame.fill(egui::Color32::TRANSPARENT);
        }
        egui::Panel::left("controls")
            .frame(panel_frame)
            // Fixed widths: the image area, and so a "fit" render size, follows the window
            // only (a panel following its content restarted the reference).
            .exact_size(LEFT_PANEL_WIDTH)
            .resizable(false)
            .show(ui, |ui| {
                side_scroll_area(ui).show(ui, |ui| self.controls_ui(ui));
            });
        egui::Panel::right("measurements")
            .frame(panel_frame)
            .exact_size(RIGHT_PANEL_WIDTH)
            .resizable(false)
            .show(ui, |ui| {
                side_scroll_area(ui).show(ui, |ui| {
                    let cx = timing_panel::TimingContext {
                        technique: &self.technique.id,
                        first_frame_ms: self.technique.first_frame_ms,
                        cancelled: self.technique.cancelled_frame.is_some(),
                        playing: self.timeline.playing,
                        path: self.timeline.active.is_some().then(|| self.path_timings()),
                    };
                    self.timing.ui(ui, &cx);
                    ui.separator();
                    let cx = self.metrics_context();
                    if let Some(error) = self.reference.ui(ui, &cx) {
                        self.report_error(error);
                    }
                });
            });
        let plot_height = if self.plot.open {
            // Between the side panels, at least a third of the window: the plot is the answer.
            let response = egui::Panel::bottom("plot")
                .frame(panel_frame)
                .resizable(true)
                .default_size(window.y * PLOT_SHARE)
                .size_range(window.y * PLOT_SHARE..=window.y * 0.7)
                .show(ui, |ui| self.plot_ui(ui));
            response.response.rect.height().round()
        } else {
            0.0
        };
        // "fit" follows the window and the plot panel, whose size is taken once a resize drag
        // ends (each size on the way would restart the reference).
        if !ui.input(|i| i.pointer.any_down()) || self.image.fit_size == egui::Vec2::ZERO {
            self.image.fit_size = egui::vec2(
                window.x - LEFT_PANEL_WIDTH - RIGHT_PANEL_WIDTH,
                window.y - plot_height,
            );
        }
        // No panel fill under the image: on a CPU rasteriser every covered pixel costs.
        let size = egui::CentralPanel::no_frame()
            .show(ui, |ui| self.image_ui(ui))
            .inner;
        self.render_frame(size);
        self.timing.frames += 1;
        ui.ctx().request_repaint();
    }

    fn render_frame(&mut self, (width, height): (u32, u32)) {
        puffin::profile_function!();
        if let Err(e) = self.ensure_renderers(width, height) {
            self.report_error(format!("cannot render at {width}x{height}: {e}"));
            return;
        }
        self.apply_path_pose();
        self.scene.orbit.apply(&mut self.scene.camera);
        let setting_key = self.current_setting_key();
        if self.timing.setting_key != Some(setting_key) {
            // Frames of another setting would mix into the medians (issue: ssm read 190 ms right
            // after a switch and 700 ms once settled).
            self.timing.new_setting(setting_key);
        }
        self.render_technique();
        self.render_reference();
        self.measure();
        self.record_display();
    }

    // ----- Panels -----

    fn plot_ui(&mut self, ui: &mut egui::Ui) {
        let cx = plot_panel::PlotContext {
            registry: &self.registry,
            scene: self.scene.loaded.gpu.content_hash,
            view: self.current_view_key(),
            no_yardstick: self.reference_refusal().is_some(),
        };
        match self.plot.ui(ui, &cx) {
            Some(plot_panel::PlotAction::Restore(point)) => self.restore_point(&point),
            Some(plot_panel::PlotAction::Export(path)) => self.export_sweep(&path),
            None => {}
        }
    }

    fn controls_ui(&mut self, ui: &mut egui::Ui) {
        // Messages, progress and legends float over the image (`overlays`): nothing here moves.
        ui.heading("Soft-shadow viewer");

        let mut open = None;
        ui.collapsing("Scene", |ui| open = self.scene.ui(ui))
            .header_response
            .on_hover_text("Builtin scenes, or a scene / glTF file by path or drag and drop");
        if let Some(spec) = open {
            self.open_scene(&spec);
        }
        egui::CollapsingHeader::new("Technique")
            .default_open(true)
            .show(ui, |ui| self.technique_ui(ui));
        let debug_views: Vec<String> = self
            .technique
            .worker
            .as_ref()
            .map(|w| w.debug_views.iter().map(|(name, _)| name.clone()).collect())
            .unwrap_or_default();
        egui::CollapsingHeader::new("View")
            .default_open(true)
            .show(ui, |ui| {
                self.image.view_ui(ui, &debug_views, &mut self.plot.open)
            });
        ui.collapsing("Light", |ui| self.scene.light_ui(ui));
        ui.collapsing("Camera", |ui| self.scene.camera_ui(ui));
        ui.collapsing("Path", |ui| self.timeline_ui(ui))
            .header_response
            .on_hover_text(
                "Play, scrub and record the scene along a path, with live error and flicker",
            );
        let mut files = None;
        ui.collapsing("Files", |ui| files = self.files.ui(ui));
        match files {
            Some(files_panel::FilesAction::SaveState(path)) => self.save_state(&path),
            Some(files_panel::FilesAction::LoadState(path)) => self.load_state(&path),
            Some(files_panel::FilesAction::Puffin(on)) => self.set_puffin(on),
            None => {}
        }
    }
}

/// A side panel's scroll area, its scroll bar in a lane of its own (egui's floating bar
/// covered the legend and the right edge of the controls).
fn side_scroll_area(ui: &mut egui::Ui) -> egui::ScrollArea {
    ui.spacing_mut().scroll = egui::style::ScrollStyle::solid();
    egui::ScrollArea::vertical()
}

/// Where the viewer writes by default (screenshots, the state, recordings, exported sweeps):
/// `SOFTSHADOW_VIEWER_DIR`, else `$XDG_STATE_HOME/softshadow/viewer`, else
/// `~/.local/state/softshadow/viewer`; created when something is written there.
pub fn output_dir() -> PathBuf {
    let from_env = |name: &str| {
        std::env::var_os(name)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if let Some(dir) = from_env("SOFTSHADOW_VIEWER_DIR") {
        return dir;
    }
    if let Some(dir) = from_env("XDG_STATE_HOME") {
        return dir.join("softshadow").join("viewer");
    }
    match from_env("HOME") {
        Some(home) => home.join(".local/state/softshadow/viewer"),
        None => PathBuf::from("softshadow-viewer"),
    }
}

/// Creates the folder `path` is written into (a default output folder may not exist yet).
pub(crate) fn create_parent(path: &Path) -> Result<(), String> {
    match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(parent) => std::fs::create_dir_all(parent)
            .map_err(|e| format!("cannot create the folder `{}`: {e}", parent.display())),
        None => Ok(()),
    }
}

/// The absolute path when it can be had (a confirmation says exactly where the file went).
pub fn shown_path(path: &Path) -> String {
    std::path::absolute(path)
        .unwrap_or_else(|_| path.to_path_buf())
        .display()
        .to_string()
}

/// Milliseconds with two decimals, never "-0.00" (timestamp noise can make a tiny pass negative).
pub fn format_ms(ms: f64) -> String {
    let ms = if ms.abs() < 0.005 { 0.0 } else { ms };
    format!("{ms:.2}")
}

/// Returns free heap pages to the system (glibc only; elsewhere the allocator decides).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn trim_heap() {
    extern "C" {
        fn malloc_trim(pad: usize) -> i32;
    }
    // SAFETY: malloc_trim only releases free memory of glibc's own heap; it touches no live
    // allocation and is thread-safe.
    unsafe {
        malloc_trim(0);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn trim_heap() {}
