//! The viewer's state and UI: scene and technique pickers, the parameter panel generated from the
//! technique's [`ParamSpec`]s, light and camera controls, GPU timings, the progressive reference
//! and the live error, view modes, and the error-against-time plot.
//!
//! [`ViewerApp::ui`] lays out one egui pass and renders one GPU frame; the winit window
//! ([`crate::window`]) and the egui_kittest tests drive the same function.

use std::{
    collections::BTreeMap,
    path::{Path, PathBuf},
    sync::Arc,
    time::Instant,
};

use egui::mutex::RwLock;
use softshadow_bench::registry;
use softshadow_core::{
    glam::Vec3, scene::Fnv1a, wgpu, AreaLight, Camera, FrameOutput, Gpu, ParamKind, ParamSet,
    ParamSpec, ParamValue, Renderer, Scene, SceneGpu, ShadingMode, ShadowTechnique, TechniqueInfo,
};
use softshadow_metrics::ErrorReport;
use softshadow_reference::{AccumulatedReference, Progress, ReferenceSettings};

use crate::{
    display::{DisplayPass, DisplayTarget, ViewMode},
    orbit::Orbit,
    state::{ViewerState, STATE_VERSION},
    timing::{median, PassRow, RollingTimings},
    tradeoff::{pareto_front, sweep_toml, TradeoffPoint},
    ViewerError,
};

/// Light samples per axis of the viewer's reference unless the state or the user says otherwise:
/// 16 x 16 converges in 16 frames (one batch of 16 samples per frame) and is within a few
/// thousandths of 32 x 32 on the builtin scenes.
pub const DEFAULT_REFERENCE_SAMPLES: i64 = 16;
/// Batches of 16 light samples the reference adds per frame.
pub const REFERENCE_BATCHES_PER_FRAME: u32 = 1;
/// Frames a setting must have been timed before its point in the plot counts.
const MIN_TIMED_FRAMES: usize = 5;
/// Frame times kept for the frame-time readout.
const FRAME_TIME_WINDOW: usize = 60;
/// Smallest render edge (the image area can be tiny while a window is being resized).
const MIN_RENDER_EDGE: u32 = 16;

/// How the viewer starts.
#[derive(Clone, Debug)]
pub struct ViewerOptions {
    /// Builtin id, `.toml` scene file or glTF file.
    pub scene: String,
    pub technique: String,
    /// Technique parameters, `name=value` already parsed.
    pub params: Vec<(String, ParamValue)>,
    /// A saved viewer state to start from (overrides scene, technique and params).
    pub state: Option<PathBuf>,
}

impl Default for ViewerOptions {
    fn default() -> Self {
        Self {
            scene: "atty-square".into(),
            technique: "pcss".into(),
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
    techniques: Vec<TechniqueInfo>,

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
    debug_contrast: f32,
    debug_target: Option<(DisplayTarget, egui::TextureId)>,
    debug_message: Option<String>,

    reference: AccumulatedReference,
    /// Key of the inputs whose reference the reference renderer holds (partial or complete).
    reference_key: Option<u64>,
    reference_progress: Progress,

    timings: RollingTimings,
    last_output: Option<FrameOutput>,
    frame_times: std::collections::VecDeque<f64>,
    last_frame: Option<Instant>,
    frames: u64,
    measured: Option<Measured>,
    points: Vec<TradeoffPoint>,
    points_key: Option<u64>,

    errors: Vec<String>,
    technique_error: Option<String>,
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
        let technique_id = state
            .as_ref()
            .map_or(options.technique.clone(), |s| s.technique.clone());
        registry::find(&technique_id)?;
        let mut reference = AccumulatedReference::new(&gpu, ReferenceSettings::default())?;
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
            techniques: registry::techniques(),
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
            debug_contrast: 1.0,
            debug_target: None,
            debug_message: None,
            reference,
            reference_key: None,
            reference_progress: Progress::default(),
            timings: RollingTimings::default(),
            last_output: None,
            frame_times: Default::default(),
            last_frame: None,
            frames: 0,
            measured: None,
            points: Vec::new(),
            points_key: None,
            errors: Vec::new(),
            technique_error: None,
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

    /// Error metrics of the current setting, once the reference has converged.
    pub fn metrics(&self) -> Option<&ErrorReport> {
        self.measured.as_ref().map(|m| &m.report)
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
        self.technique_error = None;
        self.prepared = None;
        self.timings.clear();
        self.measured = None;
        let result = registry::find(id)
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
            Ok(technique) => self.technique = Some(technique),
            Err(e) => {
                let message = format!("technique `{id}` failed to start: {e}");
                self.technique_error = Some(message.clone());
                self.report_error(message);
            }
        }
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
                self.measured = None;
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
                self.timings.clear();
                self.measured = None;
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
        if let Err(e) = self.state().save(path) {
            self.report_error(e.to_string());
        }
    }

    /// Loads a saved state; on any error the current state stays.
    pub fn load_state(&mut self, path: &Path) {
        let result = ViewerState::load(path).and_then(|state| {
            let scene = load_scene(&self.gpu, &state.scene)?;
            registry::find(&state.technique)?;
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
            &self.scene.spec,
            r.width,
            r.height,
            &reference,
        );
        if let Err(e) = std::fs::write(path, text) {
            self.report_error(format!(
                "cannot write `{}`: {e}: check the folder exists",
                path.display()
            ));
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
                egui::ScrollArea::vertical().show(ui, |ui| self.measurements_ui(ui));
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
        self.measured = None;
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
        match r.technique.render(
            &self.scene.gpu,
            &self.camera,
            &self.light,
            technique.as_mut(),
            Some(ShadingMode::Shaded),
        ) {
            Ok(output) => {
                if let Some(gpu) = &output.gpu {
                    self.timings.push(gpu.clone());
                }
                self.last_output = Some(output);
                self.technique_error = None;
            }
            Err(e) => {
                // Keep running: the error is shown and the next frame tries again.
                let _ = self.gpu.take_errors();
                self.technique_error = Some(format!("{} failed: {e}", self.technique_id));
                self.timings.clear();
            }
        }
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
        if self.points_key != Some(key) {
            // Points are only comparable for one scene, light, camera and reference.
            self.points.clear();
            self.points_key = Some(key);
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
        if !converged || self.technique_error.is_some() || self.technique.is_none() {
            return;
        }
        let setting = self.setting();
        let mut h = Fnv1a::default();
        h.write_u64(self.reference_key.unwrap_or(0));
        h.write_str(&self.technique_id);
        for (name, value) in &setting {
            h.write_str(name);
            h.write_str(&value.to_string());
        }
        let key = h.finish();
        if self.measured.as_ref().map(|m| m.key) != Some(key) {
            match self.compute_metrics() {
                Ok(report) => self.measured = Some(Measured { key, report }),
                Err(e) => {
                    self.report_error(format!("cannot measure the error: {e}"));
                    return;
                }
            }
        }
        let (Some(measured), Some(gpu_ms)) = (&self.measured, self.timings.technique_ms()) else {
            return;
        };
        if self.timings.len() < MIN_TIMED_FRAMES {
            return;
        }
        let point = TradeoffPoint {
            technique: self.technique_id.clone(),
            params: setting,
            gpu_ms,
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
                    if let Err(message) = self.display.record_debug(
                        &self.gpu,
                        &mut encoder,
                        &view.texture,
                        self.debug_contrast,
                        target,
                    ) {
                        self.debug_message = Some(format!("{}: {message}", view.name));
                    }
                }
                None => {
                    self.debug_message =
                        Some(format!("`{}` has no debug views", self.technique_id));
                }
            }
        }
        self.gpu.queue.submit([encoder.finish()]);
    }

    // ----- Panels -----

    fn controls_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Soft-shadow viewer");
        self.errors_ui(ui);

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

    fn scene_ui(&mut self, ui: &mut egui::Ui) {
        let mut open = None;
        egui::ComboBox::from_label("Scene")
            .selected_text(self.scene.spec.clone())
            .show_ui(ui, |ui| {
                for info in softshadow_scenes::builtin_scenes() {
                    if ui
                        .selectable_label(self.scene.spec == info.id, info.id)
                        .on_hover_text(info.description)
                        .clicked()
                    {
                        open = Some(info.id.to_string());
                    }
                }
            });
        ui.horizontal(|ui| {
            ui.add(
                egui::TextEdit::singleline(&mut self.scene_path)
                    .hint_text("scene.toml / model.glb")
                    .desired_width(170.0),
            );
            if ui.button("Open").clicked() && !self.scene_path.trim().is_empty() {
                open = Some(self.scene_path.trim().to_string());
            }
        });
        ui.small("Or drop a .toml / .gltf / .glb file on the window.");
        ui.label(format!("{} triangles", self.scene.scene.triangle_count()));
        if let Some(spec) = open {
            self.open_scene(&spec);
        }
    }

    fn technique_ui(&mut self, ui: &mut egui::Ui) {
        let mut chosen = None;
        egui::ComboBox::from_label("Technique")
            .selected_text(self.technique_id.clone())
            .show_ui(ui, |ui| {
                for info in &self.techniques {
                    if ui
                        .selectable_label(self.technique_id == info.id, info.id)
                        .on_hover_text(format!("{} [{}]", info.description, info.source))
                        .clicked()
                    {
                        chosen = Some(info.id);
                    }
                }
            });
        if let Some(id) = chosen {
            if id != self.technique_id {
                self.select_technique(id);
            }
        }
        let Some(technique) = &self.technique else {
            return;
        };
        let mut changes = Vec::new();
        for (spec, value) in technique.params().entries {
            if let Some(new) = param_widget(ui, &spec, &value) {
                changes.push((spec.name, new));
            }
        }
        if ui.button("Defaults").clicked() {
            let info = self.techniques.iter().find(|t| t.id == self.technique_id);
            for spec in info.map(|i| (i.params)()).unwrap_or_default() {
                changes.push((spec.name, spec.default_value()));
            }
        }
        for (name, value) in changes {
            self.set_param(name, value);
        }
    }

    fn view_ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            for mode in ViewMode::ALL {
                ui.selectable_value(&mut self.view_mode, mode, mode.label());
            }
        });
        match self.view_mode {
            ViewMode::Split => {
                ui.add(egui::Slider::new(&mut self.split, 0.0..=1.0).text("divider"));
                ui.small("Left: technique, right: reference. Drag the divider on the image.");
            }
            ViewMode::Difference => {
                ui.small(
                    "Red: too dark, blue: too bright, full colour at |V - V_ref| = 0.25; \
                     white exact, grey off-receiver, magenta NaN/inf.",
                );
            }
            ViewMode::Debug => {
                let names: Vec<String> = self
                    .technique
                    .as_ref()
                    .map(|t| t.debug_views().into_iter().map(|v| v.name).collect())
                    .unwrap_or_default();
                egui::ComboBox::from_label("Debug image")
                    .selected_text(names.get(self.debug_view).cloned().unwrap_or_default())
                    .show_ui(ui, |ui| {
                        for (i, name) in names.iter().enumerate() {
                            ui.selectable_value(&mut self.debug_view, i, name);
                        }
                    });
                ui.add(
                    egui::Slider::new(&mut self.debug_contrast, 1.0..=1000.0)
                        .logarithmic(true)
                        .text("depth contrast"),
                );
            }
            _ => {}
        }
    }

    fn light_ui(&mut self, ui: &mut egui::Ui) {
        let light = &mut self.light;
        ui.horizontal(|ui| {
            ui.label("position");
            ui.add(
                egui::DragValue::new(&mut light.center.x)
                    .speed(0.02)
                    .prefix("x "),
            );
            ui.add(
                egui::DragValue::new(&mut light.center.y)
                    .speed(0.02)
                    .prefix("y "),
            );
            ui.add(
                egui::DragValue::new(&mut light.center.z)
                    .speed(0.02)
                    .prefix("z "),
            );
        });
        // Orientation as yaw (around +y) and tilt below the horizon, degrees.
        let d = light.direction.normalize_or(Vec3::NEG_Y);
        let mut tilt = (-d.y).clamp(-1.0, 1.0).asin().to_degrees();
        let mut yaw = d.x.atan2(d.z).to_degrees();
        let tilt_changed = ui
            .add(egui::Slider::new(&mut tilt, -90.0..=90.0).text("tilt (deg below horizon)"))
            .changed();
        let yaw_changed = ui
            .add(egui::Slider::new(&mut yaw, -180.0..=180.0).text("yaw (deg)"))
            .changed();
        if tilt_changed || yaw_changed {
            let (t, y) = (tilt.to_radians(), yaw.to_radians());
            light.direction = Vec3::new(t.cos() * y.sin(), -t.sin(), t.cos() * y.cos());
        }
        ui.add(egui::Slider::new(&mut light.width, 0.0..=4.0).text("width"));
        ui.add(egui::Slider::new(&mut light.height, 0.0..=4.0).text("height"));
        ui.add(egui::Slider::new(&mut light.intensity, 0.0..=4.0).text("intensity"));
        if ui.button("Reset light").clicked() {
            self.light = self.scene.scene.light;
        }
    }

    fn camera_ui(&mut self, ui: &mut egui::Ui) {
        ui.small("Image: left drag orbits, right or middle drag pans, scroll zooms.");
        ui.add(egui::Slider::new(&mut self.camera.fov_y_degrees, 10.0..=120.0).text("fov (deg)"));
        ui.add(
            egui::Slider::new(&mut self.orbit.distance, 0.1..=100.0)
                .logarithmic(true)
                .text("distance"),
        );
        if ui.button("Reset camera and light").clicked() {
            self.reset_view();
        }
    }

    fn files_ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.add(egui::TextEdit::singleline(&mut self.screenshot_path).desired_width(150.0));
            if ui.button("Screenshot").clicked() {
                self.screenshot_request = Some(PathBuf::from(self.screenshot_path.trim()));
            }
        });
        ui.horizontal(|ui| {
            ui.add(egui::TextEdit::singleline(&mut self.state_path).desired_width(150.0));
            if ui.button("Save state").clicked() {
                let path = PathBuf::from(self.state_path.trim());
                self.save_state(&path);
            }
            if ui.button("Load").clicked() {
                let path = PathBuf::from(self.state_path.trim());
                self.load_state(&path);
            }
        });
        let mut puffin = self.puffin_server.is_some();
        if ui
            .checkbox(&mut puffin, "Serve CPU scopes to puffin_viewer")
            .changed()
        {
            self.set_puffin(puffin);
        }
        if let Some(message) = &self.puffin_message {
            ui.small(message);
        }
    }

    fn measurements_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("GPU time");
        let stats = self.stats();
        ui.label(format!(
            "frame time {} (median of {} frames)",
            stats
                .frame_ms
                .map_or("-".into(), |ms| format!("{ms:.1} ms, {:.1} fps", 1e3 / ms)),
            self.frame_times.len()
        ));
        if let Some(output) = &self.last_output {
            ui.label(format!(
                "technique frame CPU wall time {:.1} ms",
                output.cpu_ms
            ));
        }
        let rows = self.timings.rows();
        if rows.is_empty() {
            ui.label(if self.gpu.has_timestamps() {
                "no GPU timings yet"
            } else {
                "this adapter has no timestamp queries: GPU times unavailable"
            });
        } else {
            ui.small(format!(
                "median of the last {} frames, from timestamp queries",
                self.timings.len()
            ));
            egui::Grid::new("timings").striped(true).show(ui, |ui| {
                ui.strong("pass");
                ui.strong("ms");
                ui.end_row();
                for row in &rows {
                    ui.label(&row.name);
                    ui.label(format!("{:.2}", row.median_ms));
                    ui.end_row();
                }
                ui.strong("technique");
                ui.strong(format!("{:.2}", self.timings.technique_ms().unwrap_or(0.0)));
                ui.end_row();
                ui.strong("frame");
                ui.strong(format!("{:.2}", self.timings.total_ms().unwrap_or(0.0)));
                ui.end_row();
            });
            timing_chart(ui, &rows);
        }

        ui.separator();
        ui.heading("Error against the reference");
        let p = self.reference_progress;
        ui.add(
            egui::ProgressBar::new(p.fraction())
                .text(format!("reference {} / {} light samples", p.done, p.total)),
        );
        let mut samples = self
            .reference
            .params()
            .get("samples_per_axis")
            .and_then(ParamValue::as_f64)
            .unwrap_or(DEFAULT_REFERENCE_SAMPLES as f64) as i64;
        if ui
            .add(egui::Slider::new(&mut samples, 1..=64).text("reference samples per axis"))
            .changed()
        {
            if let Err(e) = self
                .reference
                .set_param("samples_per_axis", ParamValue::Int(samples))
            {
                self.report_error(e.to_string());
            }
        }
        match &self.measured {
            Some(m) => metrics_grid(ui, &m.report),
            None => {
                ui.label(if p.is_complete() {
                    "measuring..."
                } else {
                    "the metrics appear once the reference has converged"
                });
            }
        }

        ui.separator();
        ui.heading("Error against time");
        self.tradeoff_ui(ui);
    }

    fn tradeoff_ui(&mut self, ui: &mut egui::Ui) {
        ui.small("One point per technique setting measured for this scene, light and camera; the Pareto front is the line.");
        let front = pareto_front(&self.points);
        let colours = [
            egui::Color32::from_rgb(230, 160, 60),
            egui::Color32::from_rgb(90, 170, 250),
            egui::Color32::from_rgb(120, 210, 120),
            egui::Color32::from_rgb(220, 110, 200),
        ];
        let defaults: BTreeMap<&str, Vec<(String, ParamValue)>> = self
            .techniques
            .iter()
            .map(|t| {
                (
                    t.id,
                    (t.params)()
                        .iter()
                        .map(|s| (s.name.to_string(), s.default_value()))
                        .collect(),
                )
            })
            .collect();
        egui_plot::Plot::new("tradeoff")
            .height(200.0)
            .x_axis_label("technique GPU ms")
            .y_axis_label("mae_shadowed")
            .legend(egui_plot::Legend::default())
            .show(ui, |plot| {
                for (i, info) in self.techniques.iter().enumerate() {
                    let series: Vec<[f64; 2]> = self
                        .points
                        .iter()
                        .filter(|p| p.technique == info.id)
                        .map(|p| [p.gpu_ms, p.error])
                        .collect();
                    if !series.is_empty() {
                        plot.points(
                            egui_plot::Points::new(info.id, series)
                                .radius(4.0)
                                .color(colours[i % colours.len()]),
                        );
                    }
                }
                if !front.is_empty() {
                    let line: Vec<[f64; 2]> = front
                        .iter()
                        .map(|&i| [self.points[i].gpu_ms, self.points[i].error])
                        .collect();
                    plot.line(
                        egui_plot::Line::new("Pareto front", line.clone())
                            .color(egui::Color32::WHITE)
                            .width(1.5),
                    );
                    plot.points(
                        egui_plot::Points::new("Pareto front", line)
                            .radius(6.0)
                            .filled(false)
                            .color(egui::Color32::WHITE),
                    );
                }
            });
        for &i in &front {
            let p = &self.points[i];
            let label = p.label(defaults.get(p.technique.as_str()).map_or(&[][..], |d| d));
            ui.small(format!(
                "front: {label}: {:.2} ms, {:.4}",
                p.gpu_ms, p.error
            ));
        }
        ui.horizontal(|ui| {
            ui.add(egui::TextEdit::singleline(&mut self.export_path).desired_width(150.0));
            if ui
                .add_enabled(!self.points.is_empty(), egui::Button::new("Export sweep"))
                .on_hover_text("Writes the points as a sweep file for `workbench bench --sweep`")
                .clicked()
            {
                let path = PathBuf::from(self.export_path.trim());
                self.export_sweep(&path);
            }
        });
    }

    /// The image, with camera interaction; returns the render size in pixels.
    fn image_ui(&mut self, ui: &mut egui::Ui) -> (u32, u32) {
        self.interacting = false;
        let available = ui.available_size();
        let ppp = ui.ctx().pixels_per_point();
        let width = ((available.x * ppp).round() as u32).max(MIN_RENDER_EDGE);
        let height = ((available.y * ppp).round() as u32).max(MIN_RENDER_EDGE);
        let debug = self.view_mode == ViewMode::Debug;
        let texture = if debug {
            self.debug_target.as_ref().map(|(t, id)| {
                let (w, h) = (t.texture.width() as f32, t.texture.height() as f32);
                let scale = (available.x / w).min(available.y / h);
                (*id, egui::vec2(w * scale, h * scale))
            })
        } else {
            self.renderers.as_ref().map(|r| {
                (
                    r.texture_id,
                    egui::vec2(r.width as f32, r.height as f32) / ppp,
                )
            })
        };
        if let Some(message) = &self.debug_message {
            ui.colored_label(egui::Color32::LIGHT_RED, message);
        }
        let Some((id, size)) = texture else {
            ui.allocate_space(available);
            return (width, height);
        };
        let response = ui.add(
            egui::Image::new(egui::load::SizedTexture::new(id, size))
                .sense(egui::Sense::click_and_drag()),
        );
        if !debug {
            self.camera_input(ui, &response);
        }
        (width, height)
    }

    fn camera_input(&mut self, ui: &egui::Ui, response: &egui::Response) {
        let delta = response.drag_delta();
        self.interacting = response.dragged()
            || response.hovered() && ui.input(|i| i.smooth_scroll_delta.y != 0.0);
        if self.view_mode == ViewMode::Split {
            // In the split view a primary drag that starts on the divider moves it.
            let x_of = |pos: egui::Pos2| {
                ((pos.x - response.rect.left()) / response.rect.width().max(1.0)).clamp(0.0, 1.0)
            };
            if response.drag_started_by(egui::PointerButton::Primary) {
                self.dragging_divider = response.interact_pointer_pos().is_some_and(|pos| {
                    (x_of(pos) - self.split).abs() * response.rect.width() < 12.0
                });
            }
            if self.dragging_divider {
                if let Some(pos) = response.interact_pointer_pos() {
                    self.split = x_of(pos);
                }
                if !response.dragged() {
                    self.dragging_divider = false;
                }
                return;
            }
        }
        if response.dragged_by(egui::PointerButton::Primary) {
            self.orbit.rotate(delta.x, delta.y);
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
        {
            self.orbit.pan(
                delta.x,
                delta.y,
                response.rect.height(),
                self.camera.fov_y_degrees,
            );
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.orbit.zoom(scroll / 50.0);
            }
        }
    }
}

/// One widget per parameter, from its spec; returns the new value when the user changed it.
pub fn param_widget(ui: &mut egui::Ui, spec: &ParamSpec, value: &ParamValue) -> Option<ParamValue> {
    let new = match &spec.kind {
        ParamKind::Float {
            min,
            max,
            logarithmic,
            ..
        } => {
            let mut x = value.as_f64().unwrap_or(*min);
            ui.add(
                egui::Slider::new(&mut x, *min..=*max)
                    .logarithmic(*logarithmic)
                    .text(spec.name),
            )
            .on_hover_text(spec.description)
            .changed()
            .then_some(ParamValue::Float(x))
        }
        ParamKind::Int { min, max, .. } => {
            let mut i = match value {
                ParamValue::Int(i) => *i,
                other => other.as_f64().unwrap_or(*min as f64) as i64,
            };
            // Wide integer ranges (seeds, sizes) are easier to hit on a log scale.
            let logarithmic = *max > 1000 && *min > 0;
            ui.add(
                egui::Slider::new(&mut i, *min..=*max)
                    .logarithmic(logarithmic)
                    .text(spec.name),
            )
            .on_hover_text(spec.description)
            .changed()
            .then_some(ParamValue::Int(i))
        }
        ParamKind::Bool { .. } => {
            let mut b = matches!(value, ParamValue::Bool(true));
            ui.checkbox(&mut b, spec.name)
                .on_hover_text(spec.description)
                .changed()
                .then_some(ParamValue::Bool(b))
        }
        ParamKind::Choice { options, .. } => {
            let current = value.to_string();
            let mut chosen = None;
            egui::ComboBox::from_label(spec.name)
                .selected_text(current.clone())
                .show_ui(ui, |ui| {
                    for option in options.iter() {
                        if ui.selectable_label(current == *option, *option).clicked()
                            && current != *option
                        {
                            chosen = Some(ParamValue::Choice(option.to_string()));
                        }
                    }
                })
                .response
                .on_hover_text(spec.description);
            chosen
        }
    };
    new
}

fn timing_chart(ui: &mut egui::Ui, rows: &[PassRow]) {
    let bars: Vec<egui_plot::Bar> = rows
        .iter()
        .enumerate()
        .map(|(i, row)| {
            egui_plot::Bar::new(i as f64, row.median_ms)
                .name(&row.name)
                .width(0.7)
        })
        .collect();
    let names: Vec<String> = rows.iter().map(|r| r.name.clone()).collect();
    egui_plot::Plot::new("pass bars")
        .height(30.0 + 22.0 * rows.len() as f32)
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .show_grid(false)
        .y_axis_formatter(move |mark, _| {
            let i = mark.value.round();
            if (mark.value - i).abs() < 1e-6 && i >= 0.0 {
                names.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .x_axis_label("ms")
        .show(ui, |plot| {
            plot.bar_chart(
                egui_plot::BarChart::new("GPU ms", bars)
                    .horizontal()
                    .color(egui::Color32::from_rgb(90, 170, 250)),
            );
        });
}

fn metrics_grid(ui: &mut egui::Ui, report: &ErrorReport) {
    egui::Grid::new("metrics").striped(true).show(ui, |ui| {
        let mut row = |name: &str, value: String, hint: &str| {
            ui.label(name).on_hover_text(hint);
            ui.label(value);
            ui.end_row();
        };
        row(
            "mae_shadowed",
            format!("{:.4}", report.mae_shadowed),
            "mean |V - V_ref| where V_ref < 1 (Atty et al. 4.2.1)",
        );
        row(
            "mae_all",
            format!("{:.4}", report.mae_all),
            "over all receivers",
        );
        row("rmse", format!("{:.4}", report.rmse), "over all receivers");
        row(
            "max_abs",
            format!("{:.4}", report.max_abs),
            "largest |V - V_ref|",
        );
        row(
            "p99_abs",
            format!("{:.4}", report.p99_abs),
            "99th percentile",
        );
        row(
            "flip_mean",
            report.flip_mean.map_or("-".into(), |f| format!("{f:.4}")),
            "mean FLIP of the shaded images",
        );
        row(
            "shadowed / receiver px",
            format!("{} / {}", report.shadowed_pixels, report.receiver_pixels),
            "",
        );
    });
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
