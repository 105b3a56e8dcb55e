//! The viewer's state and UI: scene and technique pickers, the parameter panel generated from the
//! technique's [`ParamSpec`](softshadow_core::ParamSpec)s, light and camera controls, GPU
//! timings, the progressive reference and the live error, view modes, and the error-against-time
//! plot.
//!
//! [`ViewerApp::ui`] lays out one egui pass and renders one GPU frame; the winit window
//! ([`crate::window`]) and the egui_kittest tests drive the same function.
//!
//! The modules (private, so named rather than linked) follow the window: the left panel's
//! `scene_panel` (scene, light, camera), `technique_panel` (parameters, view modes),
//! `build_panel` (a precompute building off the UI thread) and `files_panel`; the right panel's
//! `timing_panel` and `error_panel` (metrics and the error-against-time plot); the central
//! `image`. This file holds the state, the actions and the GPU frame.

mod build_panel;
mod error_panel;
mod file_reload;
mod files_panel;
mod image;
mod scene_panel;
mod technique_panel;
mod timing_panel;

pub use technique_panel::param_widget;

use std::{
    collections::BTreeMap,
    path::{Path, PathBuf},
    sync::Arc,
    time::Instant,
};

use egui::mutex::RwLock;
use softshadow_core::{
    scene::Fnv1a, wgpu, AreaLight, Camera, FrameOutput, Gpu, ParamSet, ParamValue, Registry,
    Renderer, Scene, SceneGpu, ShadingMode, ShadowTechnique,
};
use softshadow_metrics::ErrorReport;
use softshadow_reference::{Progress, Reference, ReferenceSettings};

use crate::{
    display::{DebugMapping, DisplayPass, DisplayTarget, ViewMode},
    orbit::Orbit,
    state::{ViewerState, STATE_VERSION},
    timing::{median, PassRow, RollingTimings},
    tradeoff::{sweep_toml, TradeoffPoint, View},
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
/// Smallest render edge (the image area can be tiny while a window is being resized).
const MIN_RENDER_EDGE: u32 = 16;

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
}

impl Default for ViewerOptions {
    fn default() -> Self {
        Self {
            registry: Registry::default(),
            scene: "atty-square".into(),
            technique: String::new(),
            params: Vec::new(),
            state: None,
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

struct LoadedScene {
    spec: String,
    scene: Scene,
    gpu: SceneGpu,
    warnings: Vec<String>,
}

struct Renderers {
    width: u32,
    height: u32,
    technique: Renderer,
    reference: Renderer,
    display: DisplayTarget,
    texture_id: egui::TextureId,
}

/// Metrics of one technique setting against the converged reference.
struct Measured {
    key: u64,
    report: ErrorReport,
}

pub struct ViewerApp {
    gpu: Gpu,
    egui_renderer: Arc<RwLock<egui_wgpu::Renderer>>,
    registry: Registry,

    scene: LoadedScene,
    technique_id: String,
    technique: Option<Box<dyn ShadowTechnique>>,
    /// Settings per technique id, so switching back and forth keeps them.
    settings: BTreeMap<String, BTreeMap<String, ParamValue>>,
    camera: Camera,
    orbit: Orbit,
    light: AreaLight,
    /// Inputs `prepare` last ran for (scene hash, light hash, technique instance).
    prepared: Option<(u64, u64)>,

    renderers: Option<Renderers>,
    display: DisplayPass,
    view_mode: ViewMode,
    split: f32,
    /// A drag that started on the split view's divider.
    dragging_divider: bool,
    /// Side panels paint their background (egui's default). The window turns this off and clears
    /// to the panel colour instead: on a CPU rasteriser the two full-height fills cost ~20 ms.
    opaque_panels: bool,
    /// The camera is being dragged or zoomed this frame: the reference waits (each frame would
    /// restart it) so the technique gets the whole frame.
    interacting: bool,
    debug_view: usize,
    /// How the shown debug image was mapped (its value range), for the legend.
    debug_mapping: Option<DebugMapping>,
    debug_target: Option<(DisplayTarget, egui::TextureId)>,
    debug_message: Option<String>,

    reference: Reference,
    /// Key of the inputs whose reference the reference renderer holds (partial or complete).
    reference_key: Option<u64>,
    reference_progress: Progress,

    /// GPU timings of the latest frames of the current setting (what the table shows).
    timings: RollingTimings,
    /// GPU timings of frames rendered after `invalidate_cache()`: the cost of computing.
    cost_timings: RollingTimings,
    /// Everything the timings and the frame-time window belong to (technique, parameters,
    /// scene, light, camera, size): a change empties both.
    setting_key: Option<u64>,
    last_output: Option<FrameOutput>,
    frame_times: std::collections::VecDeque<f64>,
    last_frame: Option<Instant>,
    frames: u64,
    measured: Option<Measured>,
    points: Vec<TradeoffPoint>,
    /// Scene, light and camera the points were measured for (not the size or the reference's
    /// samples: errors are per-pixel means, comparable across both).
    points_key: Option<u64>,
    /// Where the last screenshot / state / sweep went, shown under the Files section.
    status: Option<String>,
    /// A render size chosen by the user (`None`: the image area's size).
    render_size: Option<(u32, u32)>,
    /// The error-against-time plot's time axis is log10(ms).
    log_time_axis: bool,

    errors: Vec<String>,
    technique_error: Option<String>,
    /// The active technique's precompute when it builds off the UI thread ([`build_panel`]).
    build: build_panel::BuildState,
    /// The active technique's WGSL file, watched for new versions ([`file_reload`]).
    file_reload: file_reload::FileReload,
    scene_path: String,
    state_path: String,
    screenshot_path: String,
    export_path: String,
    screenshot_request: Option<PathBuf>,
    puffin_server: Option<puffin_http::Server>,
    puffin_message: Option<String>,
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
        let scene = load_scene(&gpu, scene_spec)?;
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
            display: DisplayPass::new(&gpu)?,
            registry,
            egui_renderer,
            scene,
            technique_id: String::new(),
            technique: None,
            settings,
            orbit: Orbit::from_camera(&camera),
            camera,
            light,
            prepared: None,
            renderers: None,
            view_mode: state.as_ref().map_or(ViewMode::Shaded, |s| s.view_mode),
            split: state.as_ref().map_or(0.5, |s| s.split),
            dragging_divider: false,
            interacting: false,
            opaque_panels: true,
            debug_view: 0,
            debug_mapping: None,
            debug_target: None,
            debug_message: None,
            reference,
            reference_key: None,
            reference_progress: Progress::default(),
            timings: RollingTimings::default(),
            cost_timings: RollingTimings::default(),
            setting_key: None,
            last_output: None,
            frame_times: Default::default(),
            last_frame: None,
            frames: 0,
            measured: None,
            points: Vec::new(),
            points_key: None,
            status: None,
            log_time_axis: false,
            render_size: None,
            errors: Vec::new(),
            technique_error: None,
            build: Default::default(),
            file_reload: Default::default(),
            scene_path: String::new(),
            state_path: "viewer-state.json".into(),
            screenshot_path: "screenshot.png".into(),
            export_path: "viewer-sweep.toml".into(),
            screenshot_request: None,
            puffin_server: None,
            puffin_message: None,
            gpu,
        };
        if let Some(state) = &state {
            for (name, value) in &state.reference_params {
                app.reference.set_param(name, value.clone())?;
            }
        }
        app.select_technique(&technique_id);
        if let Some(error) = app.technique_error.clone() {
            // A technique that cannot even be created with the given settings is bad input.
            return Err(ViewerError::TechniqueStart(error));
        }
        Ok(app)
    }

    // ----- Queries (tests, the window loop) -----

    pub fn technique_id(&self) -> &str {
        &self.technique_id
    }

    /// Current parameters of the active technique (`None` when it failed to build).
    pub fn technique_params(&self) -> Option<ParamSet> {
        self.technique.as_ref().map(|t| t.params())
    }

    pub fn scene_spec(&self) -> &str {
        &self.scene.spec
    }

    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    pub fn light(&self) -> &AreaLight {
        &self.light
    }

    pub fn view_mode(&self) -> ViewMode {
        self.view_mode
    }

    /// Renders at `size` whatever the panels leave for the image (`None`: fit the image area).
    pub fn set_render_size(&mut self, size: Option<(u32, u32)>) {
        self.render_size = size;
    }

    /// Size of the last rendered frame.
    pub fn render_size(&self) -> Option<(u32, u32)> {
        self.renderers.as_ref().map(|r| (r.width, r.height))
    }

    /// How the shown debug image was mapped to black and white (its value range).
    pub fn debug_mapping(&self) -> Option<&DebugMapping> {
        self.debug_mapping.as_ref()
    }

    /// Shows the technique's debug image `index` (in [`ShadowTechnique::debug_views`] order).
    pub fn set_debug_view(&mut self, index: usize) {
        self.debug_view = index;
    }

    pub fn set_view_mode(&mut self, mode: ViewMode) {
        self.view_mode = mode;
    }

    /// Rows of the timing table (passes of the current technique, rolling medians).
    pub fn timing_rows(&self) -> Vec<PassRow> {
        self.timings.rows()
    }

    /// Errors shown in the UI, oldest first.
    pub fn errors(&self) -> &[String] {
        &self.errors
    }

    /// The active technique's last render error, if its last frame failed.
    pub fn technique_error(&self) -> Option<&str> {
        self.technique_error.as_deref()
    }

    pub fn reference_progress(&self) -> Progress {
        self.reference_progress
    }

    /// Error metrics of the current setting, once the reference has converged (`None` while
    /// the shown ones are stale).
    pub fn metrics(&self) -> Option<&ErrorReport> {
        self.measured
            .as_ref()
            .filter(|_| self.metrics_are_current())
            .map(|m| &m.report)
    }

    /// Metrics on screen that belong to an earlier setting (greyed and labelled stale).
    pub fn stale_metrics(&self) -> Option<&ErrorReport> {
        self.measured
            .as_ref()
            .filter(|_| !self.metrics_are_current())
            .map(|m| &m.report)
    }

    /// Passes the technique's last frame ran (light-space passes are absent on camera-only
    /// frames), G-buffer and shading included.
    pub fn passes_run(&self) -> &[String] {
        self.last_output
            .as_ref()
            .map_or(&[][..], |o| o.passes_run.as_slice())
    }

    /// Rolling GPU timings of frames rendered with the caches dropped (the cost of computing).
    pub fn cost_rows(&self) -> Vec<PassRow> {
        self.cost_timings.rows()
    }

    /// Median technique GPU time of the frames rendered with the caches dropped, ms.
    pub fn cost_ms(&self) -> Option<f64> {
        self.cost_timings.technique_ms()
    }

    /// The last confirmation shown under Files (where a screenshot, state or sweep went).
    pub fn status(&self) -> Option<&str> {
        self.status.as_deref()
    }

    /// Shows where a file went (the window calls this after writing the screenshot).
    pub fn confirm(&mut self, message: impl Into<String>) {
        self.status = Some(message.into());
    }

    pub fn points(&self) -> &[TradeoffPoint] {
        &self.points
    }

    pub fn stats(&self) -> FrameStats {
        FrameStats {
            frame_ms: (!self.frame_times.is_empty())
                .then(|| median(self.frame_times.iter().copied())),
            frames: self.frames,
        }
    }

    /// A screenshot asked for through the UI (the window saves it after painting).
    pub fn take_screenshot_request(&mut self) -> Option<PathBuf> {
        self.screenshot_request.take()
    }

    pub fn report_error(&mut self, message: impl Into<String>) {
        let message = message.into();
        log::warn!("{message}");
        self.errors.push(message);
        if self.errors.len() > 8 {
            self.errors.remove(0);
        }
    }

    // ----- Actions -----

    /// Switches the technique; its settings from earlier in the session are restored. A technique
    /// that fails to build shows its error and leaves no active technique.
    pub fn select_technique(&mut self, id: &str) {
        self.technique_id = id.to_string();
        self.technique = None;
        self.release_memory();
        self.technique_error = None;
        self.prepared = None;
        self.timings.clear();
        let result = self
            .registry
            .find(id)
            .map_err(ViewerError::from)
            .and_then(|info| {
                let saved: Vec<(String, ParamValue)> = self
                    .settings
                    .get(id)
                    .map(|m| m.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
                    .unwrap_or_default();
                Ok(info.create_with(&self.gpu, &saved)?)
            });
        match result {
            Ok(mut technique) => {
                self.build.attach(technique.as_mut());
                self.technique = Some(technique);
            }
            Err(e) => {
                let message = format!("technique `{id}` failed to start: {e}");
                self.technique_error = Some(message.clone());
                self.report_error(message);
            }
        }
    }

    /// Hands back what a dropped scene or technique held: wgpu frees dropped GPU resources once
    /// the device has been polled, and glibc keeps freed heap pages (a 1 M triangle scene's
    /// vertex arrays) until asked to trim.
    fn release_memory(&mut self) {
        if let Err(e) = self.gpu.wait_idle() {
            log::warn!("waiting for the GPU before releasing memory: {e}");
        }
        trim_heap();
    }

    /// Sets one parameter of the active technique (range-checked; an error is shown).
    pub fn set_param(&mut self, name: &str, value: ParamValue) {
        let Some(technique) = self.technique.as_mut() else {
            return;
        };
        match technique.set_param(name, value.clone()) {
            Ok(()) => {
                self.settings
                    .entry(self.technique_id.clone())
                    .or_default()
                    .insert(name.to_string(), value);
                self.timings.clear();
            }
            Err(e) => self.report_error(e.to_string()),
        }
    }

    /// Whether the side panels paint their own background (see [`ViewerApp::ui`]); a host that
    /// turns this off clears its frame to `egui::Visuals::panel_fill` first.
    pub fn set_opaque_panels(&mut self, opaque: bool) {
        self.opaque_panels = opaque;
    }

    /// Sets one parameter of the reference (e.g. `samples_per_axis`); it restarts accumulating.
    pub fn set_reference_param(&mut self, name: &str, value: ParamValue) {
        if let Err(e) = self.reference.set_param(name, value) {
            self.report_error(e.to_string());
        }
    }

    /// Loads a scene (builtin id, scene file or glTF). On failure the error is shown and the
    /// current scene stays.
    pub fn open_scene(&mut self, spec: &str) {
        match load_scene(&self.gpu, spec) {
            Ok(scene) => {
                for warning in &scene.warnings {
                    log::warn!("{warning}");
                }
                self.camera = scene.scene.camera;
                self.light = scene.scene.light;
                self.orbit = Orbit::from_camera(&self.camera);
                self.scene = scene;
                self.prepared = None;
                self.release_memory();
                self.timings.clear();
            }
            Err(e) => self.report_error(format!("cannot open scene `{spec}`: {e}")),
        }
    }

    /// Camera and light back to the scene's own.
    pub fn reset_view(&mut self) {
        self.camera = self.scene.scene.camera;
        self.light = self.scene.scene.light;
        self.orbit = Orbit::from_camera(&self.camera);
    }

    pub fn state(&self) -> ViewerState {
        ViewerState {
            version: STATE_VERSION,
            scene: self.scene.spec.clone(),
            technique: self.technique_id.clone(),
            params: self.settings.clone(),
            camera: self.camera,
            light: self.light,
            view_mode: self.view_mode,
            split: self.split,
            reference_params: self.reference.params().to_map().into_iter().collect(),
        }
    }

    pub fn save_state(&mut self, path: &Path) {
        match self.state().save(path) {
            Ok(()) => self.confirm(format!("saved the state to {}", shown_path(path))),
            Err(e) => self.report_error(e.to_string()),
        }
    }

    /// Loads a saved state; on any error the current state stays.
    pub fn load_state(&mut self, path: &Path) {
        let result = ViewerState::load(path).and_then(|state| {
            let scene = load_scene(&self.gpu, &state.scene)?;
            self.registry.find(&state.technique)?;
            Ok((state, scene))
        });
        match result {
            Ok((state, scene)) => {
                self.scene = scene;
                self.settings = state.params.clone();
                self.camera = state.camera;
                self.light = state.light;
                self.orbit = Orbit::from_camera(&self.camera);
                self.view_mode = state.view_mode;
                self.split = state.split;
                for (name, value) in &state.reference_params {
                    if let Err(e) = self.reference.set_param(name, value.clone()) {
                        self.report_error(format!("{}: {e}", path.display()));
                    }
                }
                self.select_technique(&state.technique);
            }
            Err(e) => self.report_error(e.to_string()),
        }
    }

    /// Writes the plot's points as a benchmark sweep file.
    pub fn export_sweep(&mut self, path: &Path) {
        let Some(r) = &self.renderers else {
            return;
        };
        let reference: Vec<(String, ParamValue)> =
            self.reference.params().to_map().into_iter().collect();
        let text = sweep_toml(
            &self.points,
            View {
                scene: &self.scene.spec,
                width: r.width,
                height: r.height,
                camera: &self.camera,
                light: &self.light,
            },
            &reference,
        );
        match std::fs::write(path, text) {
            Ok(()) => self.confirm(format!(
                "wrote {} points to {}",
                self.points.len(),
                shown_path(path)
            )),
            Err(e) => self.report_error(format!(
                "cannot write `{}`: {e}: check the folder exists",
                path.display()
            )),
        }
    }

    /// Starts or stops serving puffin CPU scopes to `puffin_viewer` on port 8585.
    pub fn set_puffin(&mut self, on: bool) {
        if on == self.puffin_server.is_some() {
            return;
        }
        if on {
            let address = format!("127.0.0.1:{}", puffin_http::DEFAULT_PORT);
            match puffin_http::Server::new(&address) {
                Ok(server) => {
                    puffin::set_scopes_on(true);
                    self.puffin_server = Some(server);
                    self.puffin_message = Some(format!(
                        "serving on {address}: run `puffin_viewer --url {address}`"
                    ));
                }
                Err(e) => self.report_error(format!(
                    "cannot serve puffin on {address}: {e} (is another viewer running?)"
                )),
            }
        } else {
            puffin::set_scopes_on(false);
            self.puffin_server = None;
            self.puffin_message = None;
        }
    }

    // ----- One frame -----

    /// Lays out the whole UI in `ui` and renders one GPU frame at the image area's size.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        puffin::GlobalProfiler::lock().new_frame();
        puffin::profile_function!();
        let now = Instant::now();
        if let Some(last) = self.last_frame.replace(now) {
            if self.frame_times.len() == FRAME_TIME_WINDOW {
                self.frame_times.pop_front();
            }
            self.frame_times.push_back((now - last).as_secs_f64() * 1e3);
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

        let mut panel_frame = egui::Frame::side_top_panel(ui.style());
        if !self.opaque_panels {
            panel_frame = panel_frame.fill(egui::Color32::TRANSPARENT);
        }
        egui::Panel::left("controls")
            .frame(panel_frame)
            .default_size(250.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.controls_ui(ui));
            });
        egui::Panel::right("measurements")
            .frame(panel_frame)
            .default_size(270.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| {
                    self.timing_ui(ui);
                    ui.separator();
                    self.reference_error_ui(ui);
                    ui.separator();
                    self.tradeoff_ui(ui);
                });
            });
        // No panel fill under the image: on a CPU rasteriser every covered pixel costs.
        let size = egui::CentralPanel::no_frame()
            .show(ui, |ui| self.image_ui(ui))
            .inner;
        self.render_frame(size);
        self.frames += 1;
        ui.ctx().request_repaint();
    }

    fn render_frame(&mut self, (width, height): (u32, u32)) {
        puffin::profile_function!();
        if let Err(e) = self.ensure_renderers(width, height) {
            self.report_error(format!("cannot render at {width}x{height}: {e}"));
            return;
        }
        self.orbit.apply(&mut self.camera);
        let setting_key = self.current_setting_key();
        if self.setting_key != Some(setting_key) {
            // Frames of another setting would mix into the medians (issue: ssm read 190 ms right
            // after a switch and 700 ms once settled).
            self.setting_key = Some(setting_key);
            self.timings.clear();
            self.cost_timings.clear();
            self.frame_times.clear();
        }
        self.render_technique();
        self.render_reference();
        self.measure();
        self.record_display();
    }

    fn ensure_renderers(&mut self, width: u32, height: u32) -> Result<(), ViewerError> {
        if self
            .renderers
            .as_ref()
            .is_some_and(|r| (r.width, r.height) == (width, height))
        {
            return Ok(());
        }
        let technique = Renderer::new(&self.gpu, width, height)?;
        let reference = Renderer::new(&self.gpu, width, height)?;
        let display = DisplayTarget::new(&self.gpu, "viewer/display", width, height);
        let mut egui_renderer = self.egui_renderer.write();
        let texture_id = match self.renderers.take() {
            Some(old) => {
                egui_renderer.update_egui_texture_from_wgpu_texture(
                    &self.gpu.device,
                    &display.view,
                    wgpu::FilterMode::Nearest,
                    old.texture_id,
                );
                old.texture_id
            }
            None => egui_renderer.register_native_texture(
                &self.gpu.device,
                &display.view,
                wgpu::FilterMode::Nearest,
            ),
        };
        self.renderers = Some(Renderers {
            width,
            height,
            technique,
            reference,
            display,
            texture_id,
        });
        self.reference_key = None;
        self.prepared = None;
        self.timings.clear();
        Ok(())
    }

    fn render_technique(&mut self) {
        puffin::profile_function!();
        let (Some(r), Some(technique)) = (self.renderers.as_mut(), self.technique.as_mut()) else {
            return;
        };
        let prepared = (self.scene.gpu.content_hash, self.light.content_hash());
        if self.prepared != Some(prepared) {
            let inputs = r
                .technique
                .inputs(&self.scene.gpu, &self.camera, &self.light);
            if let Err(e) = technique.prepare(&self.gpu, &inputs) {
                self.technique_error = Some(format!("{}: {e}", self.technique_id));
                return;
            }
            self.prepared = Some(prepared);
        }
        // The first frames of a setting pay the whole cost (as the benchmark's `timing` does);
        // later ones may keep light-space results while only the camera moves. Not while the
        // user drags: the camera-only frames are what keeps that interactive.
        let measuring_cost = self.cost_timings.len() < COST_FRAMES && !self.interacting;
        if measuring_cost {
            technique.invalidate_cache();
        }
        // Images only a debug view reads (the PDSM's centre map) are drawn only while shown.
        let shown = (self.view_mode == ViewMode::Debug).then(|| {
            let views = technique.debug_views();
            views
                .get(self.debug_view)
                .or(views.first())
                .map(|v| v.name.clone())
        });
        technique.show_debug_view(shown.flatten().as_deref());
        match r.technique.render(
            &self.scene.gpu,
            &self.camera,
            &self.light,
            technique.as_mut(),
            Some(ShadingMode::Shaded),
        ) {
            Ok(output) => {
                self.build.note(Ok(()));
                if let Some(gpu) = &output.gpu {
                    self.timings.push(gpu.clone());
                    if measuring_cost {
                        self.cost_timings.push(gpu.clone());
                    }
                }
                self.last_output = Some(output);
                self.technique_error = None;
            }
            Err(e) if self.build.note(Err(&e)) => {
                // The precompute builds off the UI thread: nothing drawn, nothing timed.
                self.technique_error = None;
                self.timings.clear();
                self.cost_timings.clear();
            }
            Err(e) => {
                // Keep running: the error is shown and the next frame tries again.
                let _ = self.gpu.take_errors();
                self.technique_error = Some(format!("{} failed: {e}", self.technique_id));
                self.timings.clear();
                self.cost_timings.clear();
            }
        }
    }

    /// Technique, parameters, scene, light, camera and size: what one timing window belongs to.
    fn current_setting_key(&self) -> u64 {
        let mut h = Fnv1a::default();
        h.write_u64(self.current_view_key());
        h.write_str(&self.technique_id);
        for (name, value) in self.setting() {
            h.write_str(&name);
            h.write_str(&value.to_string());
        }
        if let Some(r) = &self.renderers {
            h.write_u64(u64::from(r.width) << 32 | u64::from(r.height));
        }
        h.finish()
    }

    /// Scene, light and camera: what the plot's points are comparable for.
    fn current_view_key(&self) -> u64 {
        let mut h = Fnv1a::default();
        h.write_u64(self.scene.gpu.content_hash);
        h.write_u64(self.camera.content_hash());
        h.write_u64(self.light.content_hash());
        h.finish()
    }

    fn current_reference_key(&self) -> u64 {
        let mut h = Fnv1a::default();
        h.write_u64(self.scene.gpu.content_hash);
        h.write_u64(self.camera.content_hash());
        h.write_u64(self.light.content_hash());
        if let Some(r) = &self.renderers {
            h.write_u64(u64::from(r.width) << 32 | u64::from(r.height));
        }
        for (_, value) in self.reference.params().entries {
            h.write_str(&value.to_string());
        }
        h.finish()
    }

    fn render_reference(&mut self) {
        puffin::profile_function!();
        let key = self.current_reference_key();
        if self.reference_key == Some(key) && self.reference_progress.is_complete() {
            return;
        }
        if self.interacting {
            return;
        }
        let Some(r) = self.renderers.as_mut() else {
            return;
        };
        match r.reference.render(
            &self.scene.gpu,
            &self.camera,
            &self.light,
            &mut self.reference,
            Some(ShadingMode::Shaded),
        ) {
            Ok(_) => {
                self.reference_key = Some(key);
                self.reference_progress = self.reference.progress();
            }
            Err(e) => {
                let _ = self.gpu.take_errors();
                self.reference_key = None;
                self.report_error(format!("reference failed: {e}"));
            }
        }
        let view = self.current_view_key();
        if self.points_key != Some(view) {
            // Points are only comparable for one scene, light and camera; a new size or more
            // reference samples keep them (per-pixel means), and the point is re-measured.
            self.points.clear();
            self.points_key = Some(view);
        }
    }

    fn setting(&self) -> Vec<(String, ParamValue)> {
        self.technique
            .as_ref()
            .map(|t| {
                t.params()
                    .entries
                    .into_iter()
                    .map(|(s, v)| (s.name.to_string(), v))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Metrics once the reference has converged and whenever the setting or the inputs changed;
    /// the plot point's time follows the rolling median.
    fn measure(&mut self) {
        puffin::profile_function!();
        // A reference for other inputs (the camera moved while it waited) does not count.
        let converged = self.reference_key == Some(self.current_reference_key())
            && self.reference_progress.is_complete();
        if !converged
            || self.technique_error.is_some()
            || self.technique.is_none()
            || self.build.is_running()
        {
            return;
        }
        let setting = self.setting();
        let key = self.current_measure_key();
        if self.measured.as_ref().map(|m| m.key) != Some(key) {
            match self.compute_metrics() {
                Ok(report) => self.measured = Some(Measured { key, report }),
                Err(e) => {
                    self.report_error(format!("cannot measure the error: {e}"));
                    return;
                }
            }
        }
        let (Some(measured), Some(gpu_ms)) = (&self.measured, self.cost_timings.technique_ms())
        else {
            return;
        };
        if self.cost_timings.len() < COST_FRAMES {
            return;
        }
        let point = TradeoffPoint {
            technique: self.technique_id.clone(),
            params: setting,
            // Timestamp noise can put a tiny pass below zero; a cost is never negative.
            gpu_ms: gpu_ms.max(0.0),
            error: measured.report.mae_shadowed,
        };
        match self
            .points
            .iter_mut()
            .find(|p| p.same_setting(&point.technique, &point.params))
        {
            Some(existing) => *existing = point,
            None => self.points.push(point),
        }
    }

    /// The converged reference's inputs, the technique and its parameters: what one set of
    /// metrics belongs to.
    fn current_measure_key(&self) -> u64 {
        let mut h = Fnv1a::default();
        h.write_u64(self.current_reference_key());
        h.write_str(&self.technique_id);
        for (name, value) in self.setting() {
            h.write_str(&name);
            h.write_str(&value.to_string());
        }
        h.finish()
    }

    /// Whether the shown metrics belong to the current setting and a converged reference.
    fn metrics_are_current(&self) -> bool {
        self.reference_key == Some(self.current_reference_key())
            && self.reference_progress.is_complete()
            && self
                .measured
                .as_ref()
                .is_some_and(|m| m.key == self.current_measure_key())
    }

    fn compute_metrics(&self) -> Result<ErrorReport, ViewerError> {
        let r = self.renderers.as_ref().expect("rendered this frame");
        let v = r.technique.read_visibility()?;
        let v_ref = r.reference.read_visibility()?;
        let mask = r.technique.read_receiver_mask()?;
        let mut report = softshadow_metrics::compare(&v, &v_ref, &mask)?;
        let shaded = rgba_to_rgb(&r.technique.read_shaded()?);
        let shaded_ref = rgba_to_rgb(&r.reference.read_shaded()?);
        report.flip_mean = Some(softshadow_metrics::flip_mean(
            &shaded,
            &shaded_ref,
            r.width,
            r.height,
        )?);
        Ok(report)
    }

    fn record_display(&mut self) {
        puffin::profile_function!();
        let Some(r) = &self.renderers else {
            return;
        };
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("viewer/display"),
            });
        let current = self.reference_key == Some(self.current_reference_key());
        let reference = current.then_some(&r.reference);
        self.display.record(
            &self.gpu,
            &mut encoder,
            &r.technique,
            reference,
            (self.view_mode, self.split),
            &r.display,
        );
        self.debug_message = None;
        let mut debug_kind = None;
        if self.view_mode == ViewMode::Debug {
            let views = self
                .technique
                .as_ref()
                .map(|t| t.debug_views())
                .unwrap_or_default();
            match views.get(self.debug_view).or(views.first()) {
                Some(view) => {
                    let (w, h) = (
                        view.texture.width().min(1024),
                        view.texture.height().min(1024),
                    );
                    let stale = self
                        .debug_target
                        .as_ref()
                        .is_none_or(|(t, _)| (t.texture.width(), t.texture.height()) != (w, h));
                    if stale {
                        let target = DisplayTarget::new(&self.gpu, "viewer/debug", w, h);
                        let mut egui_renderer = self.egui_renderer.write();
                        let id = match self.debug_target.take() {
                            Some((_, id)) => {
                                egui_renderer.update_egui_texture_from_wgpu_texture(
                                    &self.gpu.device,
                                    &target.view,
                                    wgpu::FilterMode::Nearest,
                                    id,
                                );
                                id
                            }
                            None => egui_renderer.register_native_texture(
                                &self.gpu.device,
                                &target.view,
                                wgpu::FilterMode::Nearest,
                            ),
                        };
                        self.debug_target = Some((target, id));
                    }
                    let (target, _) = self.debug_target.as_ref().expect("created above");
                    match self
                        .display
                        .record_debug(&self.gpu, &mut encoder, &view.texture, target)
                    {
                        Ok(kind) => debug_kind = Some(kind),
                        Err(message) => {
                            self.debug_message = Some(format!("{}: {message}", view.name));
                        }
                    }
                }
                None => {
                    self.debug_message =
                        Some(format!("`{}` has no debug views", self.technique_id));
                }
            }
        }
        self.gpu.queue.submit([encoder.finish()]);
        self.debug_mapping = None;
        if let Some(kind) = debug_kind {
            match self.display.read_debug_mapping(&self.gpu, kind) {
                Ok(mapping) => self.debug_mapping = Some(mapping),
                Err(e) => self.report_error(format!("cannot read the debug image's range: {e}")),
            }
        }
    }

    // ----- Panels -----

    fn controls_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Soft-shadow viewer");
        self.errors_ui(ui);
        self.build_ui(ui);
        if let Some(status) = &self.status {
            // Where the last screenshot, state or sweep went, whichever section is open.
            ui.colored_label(egui::Color32::LIGHT_GREEN, status);
        }

        ui.collapsing("Scene", |ui| self.scene_ui(ui))
            .header_response
            .on_hover_text("Builtin scenes, or a scene / glTF file by path or drag and drop");
        egui::CollapsingHeader::new("Technique")
            .default_open(true)
            .show(ui, |ui| self.technique_ui(ui));
        egui::CollapsingHeader::new("View")
            .default_open(true)
            .show(ui, |ui| self.view_ui(ui));
        ui.collapsing("Light", |ui| self.light_ui(ui));
        ui.collapsing("Camera", |ui| self.camera_ui(ui));
        ui.collapsing("Files", |ui| self.files_ui(ui));
    }

    fn errors_ui(&mut self, ui: &mut egui::Ui) {
        if let Some(error) = &self.technique_error {
            ui.colored_label(egui::Color32::LIGHT_RED, error);
        }
        if let Some(error) = self.file_reload.error() {
            ui.colored_label(egui::Color32::LIGHT_RED, error);
        }
        if !self.errors.is_empty() {
            let mut clear = false;
            ui.group(|ui| {
                for error in &self.errors {
                    ui.colored_label(egui::Color32::LIGHT_RED, error);
                }
                clear = ui.button("Dismiss errors").clicked();
            });
            if clear {
                self.errors.clear();
            }
        }
        for warning in &self.scene.warnings {
            ui.colored_label(egui::Color32::YELLOW, warning);
        }
    }
}

fn load_scene(gpu: &Gpu, spec: &str) -> Result<LoadedScene, ViewerError> {
    let loaded = softshadow_scenes::load(spec)?;
    let scene_gpu = SceneGpu::upload(gpu, &loaded.scene);
    Ok(LoadedScene {
        spec: spec.trim().to_string(),
        gpu: scene_gpu,
        scene: loaded.scene,
        warnings: loaded.warnings,
    })
}

fn rgba_to_rgb(rgba: &[u8]) -> Vec<u8> {
    rgba.chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect()
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
