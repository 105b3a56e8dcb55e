//! The active technique runs on a thread of its own, on a device of its own, so the UI answers
//! input whatever a frame costs (a `reference` cost frame takes 30 s and more on lavapipe).
//!
//! Why a second device: lavapipe runs one queue's submissions in order, so an egui frame
//! submitted on a shared device would wait behind the technique's (docs/ARCHITECTURE.md, "The
//! viewer's render worker"). The worker creates the technique from its
//! [`TechniqueInfo`] (a `ShadowTechnique` is not `Send`), uploads the scene once per scene,
//! renders the visibility at the camera, light and parameters of each [`FrameRequest`] and sends
//! it back read out, with the shown debug image drawn by its own [`DisplayPass`]. The UI shades
//! it on its own renderer ([`softshadow_core::Renderer::show_visibility`]), measures it against
//! the reference and shows it.
//!
//! Dropping a [`RenderWorker`] abandons it: its thread finishes the frame it is in (a GPU frame
//! cannot be interrupted), sees the request channel closed and ends, freeing its device. That is
//! how Cancel and a switch away from a slow technique are immediate for the user.

use std::{
    sync::{mpsc, Arc},
    thread,
    time::{Duration, Instant},
};

use softshadow_core::{
    readback, AreaLight, BuildControl, Camera, DebugLegend, Gpu, ParamValue, RenderError, Renderer,
    Scene, SceneGpu, ShadowTechnique, TechniqueInfo, TechniqueStats,
};

use super::timeline::LiveMetrics;
use softshadow_reference::GroundTruth;

/// Light samples per axis of the timeline's ray-traced exact answer: the benchmark's ray-cast
/// default (16 x 16, own error about 0.004 mae_shadowed; docs/BENCHMARKS.md, "The exact answer"),
/// not its ray-traced 32 x 32, which costs 4x per played step at the viewer's image sizes.
const LIVE_TRACED_SAMPLES: u32 = 16;
use crate::display::{DebugMapping, DisplayPass, DisplayTarget};

/// Largest debug image edge sent back (as the display draws them).
const DEBUG_EDGE: u32 = 1024;

/// One frame the UI asks for: everything it depends on, so the worker keeps no UI state.
pub(super) struct FrameRequest {
    /// The UI's key of this setting (technique, parameters, scene, light, camera, size).
    pub(super) setting_key: u64,
    pub(super) scene: Arc<Scene>,
    pub(super) scene_hash: u64,
    pub(super) camera: Camera,
    pub(super) light: AreaLight,
    pub(super) size: (u32, u32),
    pub(super) params: Vec<(String, ParamValue)>,
    /// Drop the technique's caches first (a cost frame, as the benchmark's `timing`).
    pub(super) invalidate: bool,
    /// The debug view to draw after the frame (index into its debug views), if one is shown.
    pub(super) debug_view: Option<usize>,
    /// Measure the frame against its exact answer (closed form) and, within the same run of
    /// a path (this id), the frame before it: the timeline's live error and flicker.
    pub(super) exact: Option<u64>,
}

/// A debug image drawn by the worker, as RGBA8 bytes of the display format.
pub(super) struct DebugImage {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) rgba: Vec<u8>,
    pub(super) mapping: DebugMapping,
}

/// Creates the worker's technique on its device (on the worker's thread).
pub(super) type CreateOnWorker =
    Box<dyn FnOnce(&Gpu) -> Result<Box<dyn ShadowTechnique>, String> + Send>;

/// What came of one [`FrameRequest`].
pub(super) struct FrameDone {
    pub(super) setting_key: u64,
    pub(super) camera: Camera,
    pub(super) light: AreaLight,
    pub(super) size: (u32, u32),
    pub(super) scene_hash: u64,
    pub(super) invalidated: bool,
    /// The frame's passes and times, and its visibility read out (row-major, `size`).
    pub(super) result: Result<(softshadow_core::FrameOutput, Vec<f32>), RenderError>,
    /// The technique's debug views after the frame: name and legend.
    pub(super) debug_views: Vec<(String, DebugLegend)>,
    /// The requested debug image, or why it could not be drawn.
    pub(super) debug_image: Option<Result<DebugImage, String>>,
    /// The technique's counters after the frame.
    pub(super) stats: TechniqueStats,
    /// With [`FrameRequest::exact`]: the live metrics, or why there are none.
    pub(super) live: Option<Result<LiveMetrics, String>>,
    /// With [`FrameRequest::exact`]: the frame's exact answer (row-major).
    pub(super) exact: Option<Vec<f32>>,
}

/// The technique's thread: requests go in, finished frames come out.
pub(super) struct RenderWorker {
    /// `None` once retired: the thread then ends.
    requests: Option<mpsc::Sender<FrameRequest>>,
    /// The worker's device (a clone): reused by the next worker once this one has ended.
    gpu: Gpu,
    thread: Option<thread::JoinHandle<()>>,
    frames: mpsc::Receiver<FrameDone>,
    /// The request being rendered: when it was sent and whether it is a cost frame.
    in_flight: Option<(Instant, u64)>,
    /// Wall time of the last frame that came back, ms.
    pub(super) last_frame_ms: Option<f64>,
    /// Debug views of the last frame: name and legend.
    pub(super) debug_views: Vec<(String, DebugLegend)>,
}

/// Why a [`RenderWorker`] could not start.
#[derive(Debug)]
pub(super) enum StartError {
    Device(String),
    Technique(String),
}

impl std::fmt::Display for StartError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StartError::Device(e) => write!(f, "cannot create the render worker's device: {e}"),
            StartError::Technique(e) => f.write_str(e),
        }
    }
}

impl RenderWorker {
    /// Starts a thread named `name` with its own device on `gpu`'s adapter and creates the
    /// technique there with `create`; waits until it exists (its creation error is returned
    /// here).
    /// `device` is a retired worker's device to reuse ([`RenderWorker::retire`]); without one a
    /// new device is created.
    pub(super) fn spawn(
        gpu: &Gpu,
        device: Option<Gpu>,
        name: &str,
        create: CreateOnWorker,
    ) -> Result<Self, StartError> {
        let device = match device {
            Some(device) => device,
            None => {
                let instance = gpu.instance.clone().ok_or_else(|| {
                    StartError::Device("the viewer's GPU context has no instance".into())
                })?;
                pollster::block_on(Gpu::from_adapter_with(
                    instance,
                    gpu.adapter.clone(),
                    crate::MEMORY_HINTS,
                ))
                .map_err(|e| StartError::Device(e.to_string()))?
            }
        };
        let worker_gpu = device.clone();
        let (request_tx, request_rx) = mpsc::channel::<FrameRequest>();
        let (frame_tx, frame_rx) = mpsc::channel::<FrameDone>();
        let (started_tx, started_rx) = mpsc::channel::<Result<(), String>>();
        let thread = thread::Builder::new()
            .name(format!("render worker: {name}"))
            .spawn(move || {
                let technique = match create(&device) {
                    Ok(technique) => {
                        let _ = started_tx.send(Ok(()));
                        technique
                    }
                    Err(e) => {
                        let _ = started_tx.send(Err(e));
                        return;
                    }
                };
                Worker::new(device, technique).run(&request_rx, &frame_tx);
            })
            .map_err(|e| StartError::Device(format!("cannot start its thread: {e}")))?;
        match started_rx.recv() {
            Ok(Ok(())) => Ok(Self {
                requests: Some(request_tx),
                gpu: worker_gpu,
                thread: Some(thread),
                frames: frame_rx,
                in_flight: None,
                last_frame_ms: None,
                debug_views: Vec::new(),
            }),
            Ok(Err(e)) => Err(StartError::Technique(e)),
            Err(_) => Err(StartError::Technique(
                "the render worker stopped while creating the technique (see the log)".into(),
            )),
        }
    }

    /// A worker for a registered technique with `params`, its precompute watched by `build`
    /// and run in the background.
    pub(super) fn for_technique(
        gpu: &Gpu,
        device: Option<Gpu>,
        info: &TechniqueInfo,
        params: Vec<(String, ParamValue)>,
        build: BuildControl,
    ) -> Result<Self, StartError> {
        let info = info.clone();
        let name = info.id.to_string();
        Self::spawn(
            gpu,
            device,
            &name,
            Box::new(move |device| {
                let mut technique = info
                    .create_with(device, &params)
                    .map_err(|e| e.to_string())?;
                technique.set_build_control(build);
                technique.set_background_build(true);
                Ok(technique)
            }),
        )
    }

    /// Ends the worker. An idle one ends at once, its technique's resources freed, and its device
    /// comes back for the next worker (a new device per switch grew resident memory by about
    /// 0.5 MiB per switch); a busy one is abandoned: its thread ends when its frame does (a
    /// submitted GPU frame cannot be stopped) and takes its device with it.
    pub(super) fn retire(mut self) -> Option<Gpu> {
        self.requests = None;
        if self.busy() {
            return None;
        }
        if let Some(thread) = self.thread.take() {
            if thread.join().is_err() {
                return None; // It panicked: do not reuse its device.
            }
        }
        let _ = self.gpu.wait_idle();
        Some(self.gpu.clone())
    }

    /// Whether a frame is being rendered.
    pub(super) fn busy(&self) -> bool {
        self.in_flight.is_some()
    }

    /// How long the frame being rendered has taken so far.
    pub(super) fn busy_for(&self) -> Option<Duration> {
        self.in_flight.map(|(since, _)| since.elapsed())
    }

    /// Sends a request; `false` when the worker has stopped.
    pub(super) fn request(&mut self, request: FrameRequest) -> bool {
        let key = request.setting_key;
        let Some(requests) = &self.requests else {
            return false;
        };
        if requests.send(request).is_err() {
            return false;
        }
        self.in_flight = Some((Instant::now(), key));
        true
    }

    /// The finished frame, waiting at most `wait` for it. `Err` when the worker has stopped
    /// (a panic on its thread: the log says why).
    pub(super) fn receive(&mut self, wait: Duration) -> Result<Option<FrameDone>, ()> {
        if self.in_flight.is_none() {
            return Ok(None);
        }
        let received = if wait.is_zero() {
            match self.frames.try_recv() {
                Ok(done) => Ok(done),
                Err(mpsc::TryRecvError::Empty) => return Ok(None),
                Err(mpsc::TryRecvError::Disconnected) => Err(()),
            }
        } else {
            match self.frames.recv_timeout(wait) {
                Ok(done) => Ok(done),
                Err(mpsc::RecvTimeoutError::Timeout) => return Ok(None),
                Err(mpsc::RecvTimeoutError::Disconnected) => Err(()),
            }
        };
        let (since, _) = self.in_flight.take().expect("checked above");
        let done = received?;
        self.last_frame_ms = Some(since.elapsed().as_secs_f64() * 1e3);
        self.debug_views = done.debug_views.clone();
        Ok(Some(done))
    }
}

/// A frame measured for the timeline: its path run, visibility, exact answer and receiver mask.
type MeasuredFrame = (u64, Vec<f32>, Vec<f32>, Vec<bool>);

/// The worker thread's state.
struct Worker {
    gpu: Gpu,
    technique: Box<dyn ShadowTechnique>,
    scene: Option<(u64, SceneGpu)>,
    renderer: Option<Renderer>,
    /// Scene and light hashes `prepare` last ran for.
    prepared: Option<(u64, u64)>,
    display: Option<DisplayPass>,
    debug_target: Option<DisplayTarget>,
    /// The last measured frame, for flicker.
    previous: Option<MeasuredFrame>,
}

impl Worker {
    fn new(gpu: Gpu, technique: Box<dyn ShadowTechnique>) -> Self {
        Self {
            gpu,
            technique,
            scene: None,
            renderer: None,
            prepared: None,
            display: None,
            debug_target: None,
            previous: None,
        }
    }

    fn run(mut self, requests: &mpsc::Receiver<FrameRequest>, frames: &mpsc::Sender<FrameDone>) {
        while let Ok(mut request) = requests.recv() {
            // Only the newest request matters: the UI sends one at a time, but be safe.
            while let Ok(newer) = requests.try_recv() {
                request = newer;
            }
            let result = self.frame(&request);
            let debug_image = match (&result, request.debug_view) {
                (Ok(_), Some(index)) => self.debug_image(index),
                _ => None,
            };
            let (live, exact) = match (&result, request.exact) {
                (Ok((_, visibility)), Some(run)) => {
                    match self.live_metrics(&request, run, visibility) {
                        Ok((metrics, exact)) => (Some(Ok(metrics)), Some(exact)),
                        Err(message) => {
                            self.previous = None;
                            (Some(Err(message)), None)
                        }
                    }
                }
                _ => {
                    self.previous = None;
                    (None, None)
                }
            };
            let done = FrameDone {
                setting_key: request.setting_key,
                camera: request.camera,
                light: request.light,
                size: request.size,
                scene_hash: request.scene_hash,
                invalidated: request.invalidate,
                result,
                debug_views: self
                    .technique
                    .debug_views()
                    .into_iter()
                    .map(|v| (v.name, v.legend))
                    .collect(),
                debug_image,
                stats: self.technique.stats(),
                live,
                exact,
            };
            if frames.send(done).is_err() {
                return; // The UI dropped this worker.
            }
        }
    }

    fn frame(
        &mut self,
        request: &FrameRequest,
    ) -> Result<(softshadow_core::FrameOutput, Vec<f32>), RenderError> {
        if self.scene.as_ref().map(|(hash, _)| *hash) != Some(request.scene_hash) {
            self.scene = None;
            self.prepared = None;
            self.scene = Some((
                request.scene_hash,
                SceneGpu::upload(&self.gpu, &request.scene),
            ));
        }
        let (width, height) = request.size;
        if self
            .renderer
            .as_ref()
            .is_none_or(|r| (r.width, r.height) != (width, height))
        {
            self.renderer = None;
            self.renderer = Some(Renderer::new(&self.gpu, width, height)?);
            self.prepared = None;
        }
        let current = self.technique.params();
        for (name, value) in &request.params {
            if current.get(name) != Some(value) {
                self.technique
                    .set_param(name, value.clone())
                    .map_err(|e| RenderError::Scene(e.to_string()))?;
            }
        }
        let (_, scene) = self.scene.as_ref().expect("uploaded above");
        let renderer = self.renderer.as_mut().expect("created above");
        let prepared = (request.scene_hash, request.light.content_hash());
        if self.prepared != Some(prepared) {
            let inputs = renderer.inputs(scene, &request.camera, &request.light);
            self.technique.prepare(&self.gpu, &inputs)?;
            self.prepared = Some(prepared);
        }
        if request.invalidate {
            self.technique.invalidate_cache();
        }
        // Images only a debug view reads (the PDSM's centre map) are drawn only while shown.
        let shown = request.debug_view.map(|index| {
            let views = self.technique.debug_views();
            views.get(index).or(views.first()).map(|v| v.name.clone())
        });
        self.technique.show_debug_view(shown.flatten().as_deref());
        let output = renderer.render(
            scene,
            &request.camera,
            &request.light,
            self.technique.as_mut(),
            None,
        );
        let output = match output {
            Ok(output) => output,
            Err(e) => {
                let _ = self.gpu.take_errors();
                return Err(e);
            }
        };
        let visibility = renderer.read_visibility()?;
        Ok((output, visibility))
    }

    /// The frame's error against its exact answer (closed form, else ray-traced with
    /// [`LIVE_TRACED_SAMPLES`] where the device has ray queries) and its flicker against the
    /// frame measured before it; the exact answer with them.
    fn live_metrics(
        &mut self,
        request: &FrameRequest,
        run: u64,
        visibility: &[f32],
    ) -> Result<(LiveMetrics, Vec<f32>), String> {
        let renderer = self.renderer.as_ref().ok_or("no frame rendered")?;
        let positions = renderer.read_world_positions().map_err(|e| e.to_string())?;
        let mask = renderer.read_receiver_mask().map_err(|e| e.to_string())?;
        let lit_as_shown = Scene {
            camera: request.camera,
            light: request.light,
            ..(*request.scene).clone()
        };
        let (exact, truth) =
            match softshadow_reference::exact::visibility_image(&lit_as_shown, &positions, &mask) {
                Some(exact) => (exact, GroundTruth::ClosedForm),
                None if self
                    .gpu
                    .features()
                    .contains(softshadow_core::accel::RAY_QUERY) =>
                {
                    let samples_per_axis = LIVE_TRACED_SAMPLES;
                    let exact = softshadow_reference::traced::visibility_image(
                        &self.gpu,
                        &lit_as_shown,
                        &positions,
                        &mask,
                        samples_per_axis,
                    )
                    .map_err(|e| {
                        format!("no live error: the ray-traced exact answer failed: {e}")
                    })?;
                    (exact, GroundTruth::RayTraced { samples_per_axis })
                }
                None => {
                    return Err(
                        "no live error: this scene has casters that are not rectangles parallel \
                         to the light and the device has no ray queries (Mesa 24.1 or newer, or a \
                         GPU), so its exact answer is a CPU ray cast: run `workbench bench --path` \
                         for it"
                            .into(),
                    )
                }
            };
        let report =
            softshadow_metrics::compare(visibility, &exact, &mask).map_err(|e| e.to_string())?;
        let flicker = match &self.previous {
            Some((previous_run, v0, e0, m0))
                if *previous_run == run && v0.len() == visibility.len() =>
            {
                Some(
                    softshadow_metrics::flicker((v0, e0, m0), (visibility, &exact, &mask))
                        .map_err(|e| e.to_string())?,
                )
            }
            _ => None,
        };
        self.previous = Some((run, visibility.to_vec(), exact.clone(), mask));
        Ok((
            LiveMetrics {
                mae_shadowed: report.mae_shadowed,
                flicker,
                exact: truth,
            },
            exact,
        ))
    }

    /// Draws debug view `index` (or the first) as the display shows it and reads it out.
    fn debug_image(&mut self, index: usize) -> Option<Result<DebugImage, String>> {
        let views = self.technique.debug_views();
        let view = views.get(index).or(views.first())?;
        Some(
            self.draw_debug(&view.texture)
                .map_err(|e| format!("{}: {e}", view.name)),
        )
    }

    fn draw_debug(
        &mut self,
        texture: &softshadow_core::wgpu::Texture,
    ) -> Result<DebugImage, String> {
        if self.display.is_none() {
            self.display = Some(DisplayPass::new(&self.gpu).map_err(|e| e.to_string())?);
        }
        let display = self.display.as_ref().expect("created above");
        let (width, height) = (
            texture.width().min(DEBUG_EDGE),
            texture.height().min(DEBUG_EDGE),
        );
        if self
            .debug_target
            .as_ref()
            .is_none_or(|t| (t.texture.width(), t.texture.height()) != (width, height))
        {
            self.debug_target = Some(DisplayTarget::new(&self.gpu, "viewer/debug", width, height));
        }
        let target = self.debug_target.as_ref().expect("created above");
        let mut encoder = self.gpu.device.create_command_encoder(
            &softshadow_core::wgpu::CommandEncoderDescriptor {
                label: Some("viewer/debug"),
            },
        );
        let kind = display.record_debug(&self.gpu, &mut encoder, texture, target)?;
        self.gpu.queue.submit([encoder.finish()]);
        let mapping = display
            .read_debug_mapping(&self.gpu, kind)
            .map_err(|e| format!("cannot read the debug image's range: {e}"))?;
        let rgba = readback::read_texture(&self.gpu, &target.texture).map_err(|e| e.to_string())?;
        Ok(DebugImage {
            width,
            height,
            rgba,
            mapping,
        })
    }
}
