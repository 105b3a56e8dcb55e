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
//!
//! The same [`Worker`] also runs in a child process ([`super::worker_process`]): a frame that
//! never ends (a WGSL file that loops) stalls every lavapipe device of its process, the UI's
//! included, and only killing the process stops it. Both kinds look the same to the UI: requests
//! go into a channel, finished frames come out of one.

use std::{
    sync::{mpsc, Arc},
    thread,
    time::{Duration, Instant},
};

use softshadow_core::{
    readback, AreaLight, BuildControl, Camera, DebugLegend, Gpu, MemoryUse, Mesh, ParamValue,
    RenderError, Renderer, Scene, SceneGpu, ShadowTechnique, TechniqueInfo, TechniqueStats,
};

use super::{
    timeline::{LiveExact, LiveMetrics},
    worker_process::ProcessLink,
};
use crate::display::{DebugMapping, DisplayPass, DisplayTarget};
use softshadow_reference::{ExactIrradiance, GroundTruth};

/// How long the viewer waits for a worker process to make its first technique.
const PROCESS_START_LIMIT: Duration = Duration::from_secs(60);

/// Largest debug image edge sent back (as the display draws them).
const DEBUG_EDGE: u32 = 1024;

/// One frame the UI asks for: everything it depends on, so the worker keeps no UI state.
/// (A worker process is sent the scene once per scene, not with every request.)
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct FrameRequest {
    /// The UI's key of this setting (technique, parameters, scene, light, camera, size).
    pub(super) setting_key: u64,
    #[serde(skip, default = "no_scene")]
    pub(super) scene: Arc<Scene>,
    pub(super) scene_hash: u64,
    pub(super) camera: Camera,
    pub(super) light: AreaLight,
    pub(super) size: (u32, u32),
    #[serde(with = "wire_params")]
    pub(super) params: Vec<(String, ParamValue)>,
    /// Drop the technique's caches first (a cost frame, as the benchmark's `timing`).
    pub(super) invalidate: bool,
    /// The debug view to draw after the frame (index into its debug views), if one is shown.
    pub(super) debug_view: Option<usize>,
    /// Measure the frame against its exact answer (closed form) and, within the same run of
    /// a path (this id), the frame before it: the timeline's live error and flicker.
    pub(super) exact: Option<u64>,
}

/// The scene of a request read from a pipe until the worker sets the one it was sent.
fn no_scene() -> Arc<Scene> {
    Arc::new(Scene {
        materials: Vec::new(),
        textures: Vec::new(),
        name: String::new(),
        meshes: Vec::new(),
        instances: Vec::new(),
        light: AreaLight::default(),
        camera: Camera::default(),
    })
}

/// A debug image drawn by the worker, as RGBA8 bytes of the display format.
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct DebugImage {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) rgba: Vec<u8>,
    pub(super) mapping: DebugMapping,
}

/// Creates the worker's technique on its device (on the worker's thread).
pub(super) type CreateOnWorker =
    Box<dyn FnOnce(&Gpu) -> Result<Box<dyn ShadowTechnique>, String> + Send>;

/// What came of one [`FrameRequest`] (sent over a pipe by a worker process: the render error
/// travels as its message, [`wire_result`]).
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct FrameDone {
    pub(super) setting_key: u64,
    pub(super) camera: Camera,
    pub(super) light: AreaLight,
    pub(super) size: (u32, u32),
    pub(super) scene_hash: u64,
    pub(super) invalidated: bool,
    /// The frame's passes and times, and its visibility read out (row-major, `size`).
    #[serde(with = "wire_result")]
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
    /// Wall time from the request to the answer, ms (set by [`RenderWorker::receive`]).
    pub(super) wall_ms: f64,
    /// The GPU memory the technique held at the frame's peak: the worker's device beyond what
    /// it held before the technique was made, less the scene's and the renderer's
    /// (`softshadow_core::memory`); `None` where the device counts none.
    pub(super) technique_memory: Option<MemoryUse>,
    /// The driver's message when the worker's device was lost (the worker is of no further use:
    /// the UI starts a new one).
    pub(super) device_lost: Option<String>,
    /// A worker process's precompute progress after the frame (done, total, unit), which the UI
    /// copies into its own [`BuildControl`]; `None` from a thread, which shares the UI's.
    pub(super) build: Option<(u32, u32, String)>,
}

/// Whether the technique was created on a worker: its device (a thread's, for reuse; `None`
/// from a process), or why not.
pub(super) type Started = Result<Option<Gpu>, StartError>;

/// The technique's thread or process: requests go in, finished frames come out.
pub(super) struct RenderWorker {
    /// `None` once retired: the thread then ends.
    requests: Option<mpsc::Sender<FrameRequest>>,
    /// Whether the technique was created on the worker (its error otherwise); taken once read.
    started: Option<mpsc::Receiver<Started>>,
    /// The worker's device (a clone), once it exists: reused by the next worker once this one
    /// has ended.
    gpu: Option<Gpu>,
    thread: Option<thread::JoinHandle<()>>,
    /// The worker's process, when it runs in one (killed when retired).
    process: Option<ProcessLink>,
    frames: mpsc::Receiver<FrameDone>,
    /// The request being rendered.
    in_flight: Option<InFlight>,
    /// Debug views of the last frame: name and legend.
    pub(super) debug_views: Vec<(String, DebugLegend)>,
}

/// The request a worker is rendering: when it was sent and what it asked.
#[derive(Clone, Copy, Debug)]
pub(super) struct InFlight {
    pub(super) since: Instant,
    pub(super) setting_key: u64,
    /// A cost frame (caches dropped).
    pub(super) invalidate: bool,
    /// The frame also computes the exact answer of a path step.
    pub(super) exact: bool,
}

/// Why a [`RenderWorker`] could not start.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
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

/// What is left of a retired worker: its device when it was idle (for the next worker), or
/// its thread when it was abandoned mid-frame (it ends when that frame does).
pub(super) struct Retired {
    pub(super) device: Option<Gpu>,
    pub(super) running: Option<thread::JoinHandle<()>>,
}

impl RenderWorker {
    /// Starts a thread named `name` that makes its own device on `gpu`'s adapter (or takes
    /// `device`, a retired worker's) and creates the technique there with `create`. Returns at
    /// once: the UI never waits for a device or a pipeline to compile; requests sent meanwhile
    /// wait in the channel, and a creation error comes back through [`Self::poll_started`].
    pub(super) fn spawn(
        gpu: &Gpu,
        device: Option<Gpu>,
        name: &str,
        create: CreateOnWorker,
    ) -> Result<Self, StartError> {
        let instance = match &device {
            Some(_) => None,
            None => Some(gpu.instance.clone().ok_or_else(|| {
                StartError::Device("the viewer's GPU context has no instance".into())
            })?),
        };
        let adapter = gpu.adapter.clone();
        let (request_tx, request_rx) = mpsc::channel::<FrameRequest>();
        let (frame_tx, frame_rx) = mpsc::channel::<FrameDone>();
        let (started_tx, started_rx) = mpsc::channel::<Started>();
        let thread = thread::Builder::new()
            .name(format!("render worker: {name}"))
            .spawn(move || {
                let device = match (device, instance) {
                    (Some(device), _) => device,
                    (None, Some(instance)) => match pollster::block_on(Gpu::from_adapter_with(
                        instance,
                        adapter,
                        crate::MEMORY_HINTS,
                    )) {
                        Ok(device) => device,
                        Err(e) => {
                            let _ = started_tx.send(Err(StartError::Device(e.to_string())));
                            return;
                        }
                    },
                    (None, None) => return,
                };
                // Before the technique: what it holds is counted from here.
                let _ = device.wait_idle();
                let baseline = device.memory_in_use();
                let technique = match create(&device) {
                    Ok(technique) => {
                        let _ = started_tx.send(Ok(Some(device.clone())));
                        technique
                    }
                    Err(e) => {
                        let _ = started_tx.send(Err(StartError::Technique(e)));
                        return;
                    }
                };
                Worker::new(device, technique, baseline).run(&request_rx, &frame_tx);
            })
            .map_err(|e| StartError::Device(format!("cannot start its thread: {e}")))?;
        let mut worker = Self::from_channels(request_tx, started_rx, frame_rx);
        worker.thread = Some(thread);
        Ok(worker)
    }

    /// A worker behind these channels (its thread or process is set by the caller).
    pub(super) fn from_channels(
        requests: mpsc::Sender<FrameRequest>,
        started: mpsc::Receiver<Started>,
        frames: mpsc::Receiver<FrameDone>,
    ) -> Self {
        Self {
            requests: Some(requests),
            started: Some(started),
            gpu: None,
            thread: None,
            process: None,
            frames,
            in_flight: None,
            debug_views: Vec::new(),
        }
    }

    /// Ties the worker to its process, which [`Self::retire`] kills.
    pub(super) fn set_process(&mut self, process: ProcessLink) {
        self.process = Some(process);
    }

    /// Why the worker stopped, when it ran in a process: how the process ended and its last
    /// words (its stderr).
    pub(super) fn why_stopped(&mut self) -> Option<String> {
        self.process.as_mut().map(ProcessLink::why_ended)
    }

    /// Waits until the technique exists on the worker; its creation error otherwise. A worker
    /// process has [`PROCESS_START_LIMIT`] to answer (a program that is no worker may never).
    pub(super) fn wait_started(&mut self) -> Result<(), StartError> {
        let Some(started) = self.started.take() else {
            return Ok(());
        };
        let answer = if self.process.is_some() {
            started.recv_timeout(PROCESS_START_LIMIT)
        } else {
            started
                .recv()
                .map_err(|_| mpsc::RecvTimeoutError::Disconnected)
        };
        match answer {
            Ok(Ok(device)) => {
                self.gpu = device;
                Ok(())
            }
            Ok(Err(e)) => Err(e),
            Err(mpsc::RecvTimeoutError::Timeout) => {
                // The caller drops this worker, which kills its process.
                Err(StartError::Device(format!(
                    "the render worker's process did not start the technique within {} s: \
                     check that ViewerOptions::worker runs a program that calls \
                     softshadow_viewer::serve_render_worker",
                    PROCESS_START_LIMIT.as_secs()
                )))
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                Err(StartError::Technique(match self.why_stopped() {
                    Some(how) => {
                        format!("the render worker stopped while creating the technique: {how}")
                    }
                    None => "the render worker stopped while creating the technique (see the log)"
                        .into(),
                }))
            }
        }
    }

    /// Whether the technique has been created: `None` while it is being created, then once
    /// `Some(Ok)` or `Some(Err)` with why it could not be.
    pub(super) fn poll_started(&mut self) -> Option<Result<(), StartError>> {
        let result = match self.started.as_ref()?.try_recv() {
            Err(mpsc::TryRecvError::Empty) => return None,
            Ok(Ok(device)) => {
                self.gpu = device;
                Ok(())
            }
            Ok(Err(e)) => Err(e),
            Err(mpsc::TryRecvError::Disconnected) => Err(StartError::Technique(
                "the render worker stopped while creating the technique (see the log)".into(),
            )),
        };
        self.started = None;
        Some(result)
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
    /// 0.5 MiB per switch); a busy one (or one still creating its technique) is abandoned: its
    /// thread comes back, and ends when its frame does (a submitted GPU frame cannot be
    /// stopped), taking its device with it.
    pub(super) fn retire(mut self) -> Retired {
        self.requests = None;
        if let Some(mut process) = self.process.take() {
            // Killing a process stops any frame at once, even one that never ends.
            process.kill();
            return Retired {
                device: None,
                running: None,
            };
        }
        // A technique created since the last look is idle, not abandoned.
        let _ = self.poll_started();
        let thread = self.thread.take();
        if self.busy() || self.started.is_some() {
            return Retired {
                device: None,
                running: thread,
            };
        }
        if let Some(thread) = thread {
            if thread.join().is_err() {
                // It panicked: do not reuse its device.
                return Retired {
                    device: None,
                    running: None,
                };
            }
        }
        let device = self.gpu.take();
        if let Some(device) = &device {
            let _ = device.wait_idle();
        }
        Retired {
            device,
            running: None,
        }
    }

    /// Whether a frame is being rendered.
    pub(super) fn busy(&self) -> bool {
        self.in_flight.is_some()
    }

    /// The request being rendered, if one is.
    pub(super) fn in_flight(&self) -> Option<InFlight> {
        self.in_flight
    }

    /// How long the frame being rendered has taken so far.
    pub(super) fn busy_for(&self) -> Option<Duration> {
        self.in_flight.map(|f| f.since.elapsed())
    }

    /// Sends a request; `false` when the worker has stopped.
    pub(super) fn request(&mut self, request: FrameRequest) -> bool {
        let in_flight = InFlight {
            since: Instant::now(),
            setting_key: request.setting_key,
            invalidate: request.invalidate,
            exact: request.exact.is_some(),
        };
        let Some(requests) = &self.requests else {
            return false;
        };
        if requests.send(request).is_err() {
            return false;
        }
        self.in_flight = Some(in_flight);
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
        let in_flight = self.in_flight.take().expect("checked above");
        let mut done = received?;
        // Once a frame is back the technique exists: take its device for reuse.
        if self.started.is_some() {
            let _ = self.wait_started();
        }
        done.wall_ms = in_flight.since.elapsed().as_secs_f64() * 1e3;
        self.debug_views = done.debug_views.clone();
        Ok(Some(done))
    }
}

/// Light rays the ray-traced exact answer of one timeline step may trace: about a second a step
/// on lavapipe with 2 loaded cores (1.3 s for 4 x 4 samples over atty-square's receivers at the
/// viewer's 700x800, measured), so 3 or 4 samples per axis at the
/// viewer's full size, 11 at 256², the maximum at 128².
pub(super) const LIVE_TRACED_RAYS: usize = 1 << 23;

/// The longest a live frame's analytic exact answer may be expected to take (on an adapter with
/// ray queries; above it the GPU traces), seconds.
pub(super) const LIVE_ANALYTIC_SECONDS: f64 = 2.0;

/// Expected seconds of the analytic exact answer of `receivers` pixels over `caster_triangles`,
/// from its measured cost (docs/EXACT.md, "What each exact answer costs", 2 lavapipe cores): about
/// 1.2 us a pixel at 1k triangles and 18 us at 100k.
pub(super) fn analytic_seconds(receivers: usize, caster_triangles: usize) -> f64 {
    receivers as f64 * (1.0 + caster_triangles as f64 / 6000.0) * 1e-6
}

/// Light samples per axis of a live ray-traced exact answer over `receivers` receiver pixels:
/// as many as [`LIVE_TRACED_RAYS`] allows, at least 2 (4 rays a pixel: a coarse answer, its
/// error up to about `1/N` at a penumbra point; the panel says which N and suggests a smaller
/// render size) and at most 16 (256 rays, the CPU ray cast's default).
pub(super) fn traced_samples_per_axis(receivers: usize) -> u32 {
    let per_pixel = LIVE_TRACED_RAYS / receivers.max(1);
    ((per_pixel as f64).sqrt().floor() as u32).clamp(2, 16)
}

/// A frame measured for the timeline: its path run, visibility, exact answer and receiver mask.
type MeasuredFrame = (u64, Vec<f32>, Vec<f32>, Vec<bool>);

/// The worker's state (on its thread, or in its process).
pub(super) struct Worker {
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
    /// The device's memory before the technique was made.
    memory_baseline: MemoryUse,
    /// The scene's and the renderer's memory on this device (counted when they are made).
    memory_of_scene: MemoryUse,
    memory_of_renderer: MemoryUse,
}

impl Worker {
    pub(super) fn new(
        gpu: Gpu,
        technique: Box<dyn ShadowTechnique>,
        memory_baseline: MemoryUse,
    ) -> Self {
        Self {
            gpu,
            technique,
            scene: None,
            renderer: None,
            prepared: None,
            display: None,
            debug_target: None,
            previous: None,
            memory_baseline,
            memory_of_scene: MemoryUse::default(),
            memory_of_renderer: MemoryUse::default(),
        }
    }

    /// What the technique held at `frame_peak`: the device's memory less the baseline, the
    /// scene's and the renderer's.
    fn technique_memory(&self, frame_peak: MemoryUse) -> Option<MemoryUse> {
        self.gpu.counts_memory().then(|| {
            frame_peak
                .since(self.memory_baseline)
                .since(self.memory_of_scene)
                .since(self.memory_of_renderer)
        })
    }

    /// The worker's device.
    pub(super) fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    fn run(mut self, requests: &mpsc::Receiver<FrameRequest>, frames: &mpsc::Sender<FrameDone>) {
        while let Ok(mut request) = requests.recv() {
            // Only the newest request matters: the UI sends one at a time, but be safe.
            while let Ok(newer) = requests.try_recv() {
                request = newer;
            }
            if frames.send(self.answer(&request)).is_err() {
                return; // The UI dropped this worker.
            }
        }
    }

    /// Renders `request` and everything the UI wants with it.
    pub(super) fn answer(&mut self, request: &FrameRequest) -> FrameDone {
        let result = self.frame(request);
        let technique_memory = result
            .as_ref()
            .ok()
            .and_then(|(output, _)| self.technique_memory(output.memory_peak));
        let debug_image = match (&result, request.debug_view) {
            (Ok(_), Some(index)) => self.debug_image(index),
            _ => None,
        };
        let (live, exact) = match (&result, request.exact) {
            (Ok((_, visibility)), Some(run)) => match self.live_metrics(request, run, visibility) {
                Ok((metrics, exact)) => (Some(Ok(metrics)), Some(exact)),
                Err(message) => {
                    self.previous = None;
                    (Some(Err(message)), None)
                }
            },
            _ => {
                self.previous = None;
                (None, None)
            }
        };
        FrameDone {
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
            wall_ms: 0.0,
            technique_memory,
            device_lost: self.gpu.lost(),
            build: None,
        }
    }

    fn frame(
        &mut self,
        request: &FrameRequest,
    ) -> Result<(softshadow_core::FrameOutput, Vec<f32>), RenderError> {
        if self.scene.as_ref().map(|(hash, _)| *hash) != Some(request.scene_hash) {
            self.scene = None;
            self.prepared = None;
            let _ = self.gpu.wait_idle();
            let before = self.gpu.memory_in_use();
            let scene = SceneGpu::upload(&self.gpu, &request.scene);
            self.gpu.queue.submit([]);
            let _ = self.gpu.wait_idle();
            self.memory_of_scene = self.gpu.memory_in_use().since(before);
            self.scene = Some((request.scene_hash, scene));
        }
        let (width, height) = request.size;
        if self
            .renderer
            .as_ref()
            .is_none_or(|r| (r.width, r.height) != (width, height))
        {
            self.renderer = None;
            let _ = self.gpu.wait_idle();
            let before = self.gpu.memory_in_use();
            self.renderer = Some(Renderer::new(&self.gpu, width, height)?);
            self.memory_of_renderer = self.gpu.memory_in_use().since(before);
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

    /// The frame's error against its exact answer and its flicker against the frame measured
    /// before it; the exact answer with them. The exact answer is the closed form where the
    /// scene has one; else the analytic answer (with the exact irradiance) where the light has
    /// area and it is expected to take at most [`LIVE_ANALYTIC_SECONDS`] ([`analytic_seconds`])
    /// or the adapter has no ray queries; else the GPU ray-traced one (its sample count from
    /// [`traced_samples_per_axis`]).
    fn live_metrics(
        &mut self,
        request: &FrameRequest,
        run: u64,
        visibility: &[f32],
    ) -> Result<(LiveMetrics, Vec<f32>), String> {
        let renderer = self.renderer.as_ref().ok_or("no frame rendered")?;
        let positions = renderer.read_world_positions().map_err(|e| e.to_string())?;
        let normals = renderer.read_world_normals().map_err(|e| e.to_string())?;
        let mask = renderer.read_receiver_mask().map_err(|e| e.to_string())?;
        let lit_as_shown = Scene {
            camera: request.camera,
            light: request.light,
            ..(*request.scene).clone()
        };
        let started = Instant::now();
        let receivers = mask.iter().filter(|&&m| m).count();
        let (exact, method, irradiance): (Vec<f32>, _, _) =
            self.live_exact(&lit_as_shown, &positions, &normals, &mask, receivers)?;
        let exact_ms = started.elapsed().as_secs_f64() * 1e3;
        let report =
            softshadow_metrics::compare(visibility, &exact, &mask).map_err(|e| e.to_string())?;
        let irradiance_mae_shadowed = match &irradiance {
            Some(e) => Some(
                softshadow_metrics::compare_irradiance(
                    visibility,
                    &exact,
                    &e.irradiance,
                    &e.unoccluded,
                    &mask,
                )
                .map_err(|e| e.to_string())?
                .irradiance_mae_shadowed,
            ),
            None => None,
        };
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
                irradiance_mae_shadowed,
                flicker,
                exact: method,
                exact_ms,
            },
            exact,
        ))
    }

    /// The exact answer of one live frame, how it was had and, when analytic, the exact
    /// irradiance (see [`Self::live_metrics`]).
    fn live_exact(
        &self,
        scene: &Scene,
        positions: &[Option<softshadow_core::glam::Vec3>],
        normals: &[softshadow_core::glam::Vec3],
        mask: &[bool],
        receivers: usize,
    ) -> Result<(Vec<f32>, LiveExact, Option<ExactIrradiance>), String> {
        let has_closed_form = softshadow_reference::exact::parallel_rects(scene).is_some();
        let has_area = scene.light.width > 0.0 && scene.light.height > 0.0;
        let caster_triangles: usize = scene
            .instances
            .iter()
            .filter(|i| i.casts_shadow)
            .filter_map(|i| scene.meshes.get(i.mesh))
            .map(Mesh::triangle_count)
            .sum();
        let analytic_fits = analytic_seconds(receivers, caster_triangles) <= LIVE_ANALYTIC_SECONDS
            || !self.gpu.has_ray_query();
        if has_area && (has_closed_form || analytic_fits) {
            let answer =
                softshadow_reference::analytic_answer(scene, positions, Some(normals), mask, None)
                    .map_err(|e| format!("no live error: the analytic exact answer failed: {e}"))?;
            let method = match answer.truth {
                GroundTruth::ClosedForm => LiveExact::ClosedForm,
                _ => LiveExact::Analytic,
            };
            return Ok((answer.visibility, method, answer.irradiance));
        }
        if let Some(exact) = softshadow_reference::exact::visibility_image(scene, positions, mask) {
            return Ok((exact, LiveExact::ClosedForm, None));
        }
        if !self.gpu.has_ray_query() {
            return Err(
                "no live error: under a point light this scene needs a sampled exact \
                 answer, and this adapter has no ray queries for the ray-traced one (run \
                 `workbench bench --path` for the CPU ray cast)"
                    .into(),
            );
        }
        let samples_per_axis = traced_samples_per_axis(receivers);
        let exact = softshadow_reference::traced::visibility_image(
            &self.gpu,
            scene,
            positions,
            mask,
            samples_per_axis,
        )
        .map_err(|e| format!("no live error: the ray-traced exact answer failed: {e}"))?;
        Ok((exact, LiveExact::Traced { samples_per_axis }, None))
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

/// A frame's result as it crosses a pipe: the render error as its message, except the two a
/// precompute building off the worker's thread reports (the build panel reads their fields).
mod wire_result {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    use softshadow_core::{FrameOutput, RenderError, TechniqueError};

    use super::intern_unit;

    #[derive(Serialize, Deserialize)]
    enum WireError {
        Building {
            technique: String,
            done: u32,
            total: u32,
            unit: String,
        },
        Cancelled {
            technique: String,
        },
        Other(String),
    }

    type Frame = (FrameOutput, Vec<f32>);

    pub(super) fn serialize<S: Serializer>(
        result: &Result<Frame, RenderError>,
        serializer: S,
    ) -> Result<S::Ok, S::Error> {
        let wire: Result<&Frame, WireError> = match result {
            Ok(frame) => Ok(frame),
            Err(RenderError::Technique(TechniqueError::Building {
                technique,
                done,
                total,
                unit,
            })) => Err(WireError::Building {
                technique: technique.clone(),
                done: *done,
                total: *total,
                unit: unit.to_string(),
            }),
            Err(RenderError::Technique(TechniqueError::Cancelled { technique })) => {
                Err(WireError::Cancelled {
                    technique: technique.clone(),
                })
            }
            Err(e) => Err(WireError::Other(e.to_string())),
        };
        wire.serialize(serializer)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<Result<Frame, RenderError>, D::Error> {
        let wire = Result::<Frame, WireError>::deserialize(deserializer)?;
        Ok(wire.map_err(|e| match e {
            WireError::Building {
                technique,
                done,
                total,
                unit,
            } => RenderError::Technique(TechniqueError::Building {
                technique,
                done,
                total,
                unit: intern_unit(&unit),
            }),
            WireError::Cancelled { technique } => {
                RenderError::Technique(TechniqueError::Cancelled { technique })
            }
            WireError::Other(message) => RenderError::Remote(message),
        }))
    }
}

/// Parameter values as they cross a pipe: tagged (`ParamValue` is untagged for JSON, which
/// bincode cannot read back).
pub(super) mod wire_params {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    use softshadow_core::ParamValue;

    #[derive(Serialize, Deserialize)]
    enum Wire {
        Bool(bool),
        Int(i64),
        Float(f64),
        Choice(String),
    }

    pub(in super::super) fn serialize<S: Serializer>(
        params: &[(String, ParamValue)],
        serializer: S,
    ) -> Result<S::Ok, S::Error> {
        let wire: Vec<(&String, Wire)> = params
            .iter()
            .map(|(name, value)| {
                let value = match value {
                    ParamValue::Bool(b) => Wire::Bool(*b),
                    ParamValue::Int(i) => Wire::Int(*i),
                    ParamValue::Float(x) => Wire::Float(*x),
                    ParamValue::Choice(c) => Wire::Choice(c.clone()),
                };
                (name, value)
            })
            .collect();
        wire.serialize(serializer)
    }

    pub(in super::super) fn deserialize<'de, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<Vec<(String, ParamValue)>, D::Error> {
        let wire = Vec::<(String, Wire)>::deserialize(deserializer)?;
        Ok(wire
            .into_iter()
            .map(|(name, value)| {
                let value = match value {
                    Wire::Bool(b) => ParamValue::Bool(b),
                    Wire::Int(i) => ParamValue::Int(i),
                    Wire::Float(x) => ParamValue::Float(x),
                    Wire::Choice(c) => ParamValue::Choice(c),
                };
                (name, value)
            })
            .collect())
    }
}

/// A precompute's unit name ("PDSM rows") as the `'static` string [`TechniqueError::Building`]
/// and [`BuildControl::start`] hold: each name is leaked once, and techniques have a handful.
pub(super) fn intern_unit(unit: &str) -> &'static str {
    static UNITS: std::sync::Mutex<Vec<&'static str>> = std::sync::Mutex::new(Vec::new());
    let mut units = UNITS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(known) = units.iter().find(|u| **u == unit) {
        return known;
    }
    let leaked: &'static str = Box::leak(unit.to_string().into_boxed_str());
    units.push(leaked);
    leaked
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cost model picks the analytic answer for a small scene at a large frame and for a
    /// large scene at a small one, and the ray-traced answer for 100k triangles at 700 x 533.
    #[test]
    fn the_live_analytic_answer_is_used_where_it_is_cheap() {
        assert!(analytic_seconds(700 * 533, 30) <= LIVE_ANALYTIC_SECONDS);
        assert!(analytic_seconds(256 * 256, 100_000) <= LIVE_ANALYTIC_SECONDS);
        assert!(analytic_seconds(700 * 533, 100_000) > LIVE_ANALYTIC_SECONDS);
    }

    #[test]
    fn the_live_traced_samples_follow_the_ray_budget_within_their_bounds() {
        // The viewer's full size (700x800, most pixels receivers), 256², the UI test's 96x64.
        assert_eq!(traced_samples_per_axis(560_000), 3);
        assert_eq!(traced_samples_per_axis(256 * 256), 11);
        assert_eq!(traced_samples_per_axis(96 * 64), 16);
        assert_eq!(traced_samples_per_axis(0), 16);
        assert_eq!(traced_samples_per_axis(usize::MAX), 2);
    }
}
