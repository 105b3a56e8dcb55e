//! The progressive reference (the yardstick) and the metrics of the technique against it: once
//! per setting, after the reference has converged.

use std::time::Duration;

use softshadow_core::{scene::Fnv1a, ParamValue, ShadingMode, ShadowTechnique, TechniqueStats};
use softshadow_metrics::ErrorReport;
use softshadow_reference::{Progress, Reference, ReferenceSettings};

use super::{
    render_worker::{CreateOnWorker, FrameRequest, RenderWorker},
    ViewerApp, ViewerError, REFERENCE_BATCHES_PER_FRAME,
};
use crate::tradeoff::TradeoffPoint;

/// The progressive reference and the metrics of the technique against it.
pub(super) struct ReferenceState {
    /// The reference's settings (what the panel shows and the worker's copy is set to).
    pub(super) yardstick: Reference,
    /// The thread that accumulates it, on a device of its own ([`super::render_worker`]).
    pub(super) worker: Option<RenderWorker>,
    /// Key of the inputs whose reference the reference renderer holds (partial or complete).
    pub(super) key: Option<u64>,
    pub(super) progress: Progress,
    pub(super) measured: Option<Measured>,
    /// Accumulations begun (the first included): each new scene, light, camera, size or
    /// reference setting begins one.
    pub(super) restarts: u64,
}

impl ReferenceState {
    pub(super) fn new(yardstick: Reference) -> Self {
        Self {
            yardstick,
            worker: None,
            key: None,
            progress: Progress::default(),
            measured: None,
            restarts: 0,
        }
    }
}

/// Metrics of one technique setting against the converged reference.
pub(super) struct Measured {
    pub(super) key: u64,
    pub(super) report: ErrorReport,
    /// For a technique that keeps a history: the frames of history the measured frame rests on
    /// once settled; `None` for a frame before that (or a technique without a history).
    pub(super) settled_after: Option<u32>,
}

/// The name of the reference's worker thread.
const YARDSTICK_WORKER: &str = "reference (yardstick)";

/// The progressive reference, created on its worker (its settings come with every request).
fn yardstick_on_worker() -> CreateOnWorker {
    Box::new(|gpu| {
        let mut reference =
            Reference::new(gpu, ReferenceSettings::default()).map_err(|e| e.to_string())?;
        reference.set_progressive(Some(REFERENCE_BATCHES_PER_FRAME));
        Ok(Box::new(reference) as Box<dyn ShadowTechnique>)
    })
}

/// The reference's progress from its counters: depth maps accumulated of all it will draw
/// (`depth_maps_done` while progressive, all of them once complete or served from its cache).
fn progress_of(stats: &TechniqueStats) -> Progress {
    let total = stats.get("depth_maps").copied().unwrap_or(0.0) as u32;
    let done = stats
        .get("depth_maps_done")
        .map_or(total, |done| *done as u32);
    Progress { done, total }
}

pub(super) fn rgba_to_rgb(rgba: &[u8]) -> Vec<u8> {
    rgba.chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect()
}

impl ViewerApp {
    /// Sets one parameter of the reference (e.g. `samples_per_axis`); it restarts accumulating.
    pub fn set_reference_param(&mut self, name: &str, value: ParamValue) {
        if let Err(e) = self.reference.yardstick.set_param(name, value) {
            self.report_error(e.to_string());
        }
    }

    pub(super) fn current_reference_key(&self) -> u64 {
        let mut h = Fnv1a::default();
        h.write_u64(self.scene.loaded.gpu.content_hash);
        h.write_u64(self.scene.camera.content_hash());
        h.write_u64(self.scene.light.content_hash());
        if let Some(r) = &self.image.renderers {
            h.write_u64(u64::from(r.width) << 32 | u64::from(r.height));
        }
        for (_, value) in self.reference.yardstick.params().entries {
            h.write_str(&value.to_string());
        }
        h.finish()
    }

    /// Asks the reference's worker for the next batches while the reference of the current
    /// inputs is not complete, and shows what it finished (progressive: a partial sum over the
    /// whole light until done).
    pub(super) fn render_reference(&mut self) {
        puffin::profile_function!();
        if self.reference_refusal().is_some() {
            return; // No yardstick for this light kind: the error panel says so.
        }
        let key = self.current_reference_key();
        let Some(r) = self.image.renderers.as_ref() else {
            return;
        };
        let size = (r.width, r.height);
        if self.reference.worker.is_none() {
            match RenderWorker::spawn(&self.gpu, None, YARDSTICK_WORKER, yardstick_on_worker()) {
                Ok(worker) => self.reference.worker = Some(worker),
                Err(e) => {
                    self.report_error(format!("reference failed to start: {e}"));
                    return;
                }
            }
        }
        let complete = self.reference.key == Some(key) && self.reference.progress.is_complete();
        let scene_hash = self.scene.loaded.gpu.content_hash;
        // A technique cost frame runs alone: no batch beside it.
        let cost_frame_running = self
            .technique
            .worker
            .as_ref()
            .and_then(|w| w.in_flight())
            .is_some_and(|f| f.invalidate);
        let scene = self.technique.worker_scene(&self.scene.loaded);
        let params: Vec<(String, ParamValue)> = self
            .reference
            .yardstick
            .params()
            .entries
            .into_iter()
            .map(|(spec, value)| (spec.name.to_string(), value))
            .collect();
        let worker = self.reference.worker.as_mut().expect("started above");
        if let Some(Err(e)) = worker.poll_started() {
            self.reference.worker = None;
            self.report_error(format!("reference failed to start: {e}"));
            return;
        }
        // Not while the camera is dragged: each frame would restart it.
        // Nor while a path plays: every step would restart it.
        if !worker.busy()
            && !complete
            && !self.image.interacting
            && !self.timeline.playing
            && !cost_frame_running
        {
            let request = FrameRequest {
                setting_key: key,
                scene,
                scene_hash,
                camera: self.scene.camera,
                light: self.scene.light,
                size,
                params,
                invalidate: false,
                debug_view: None,
                exact: None,
            };
            if !worker.request(request) {
                self.reference.worker = None;
                self.report_error("the reference's render worker stopped (the log says why)");
                return;
            }
        }
        self.receive_reference(scene_hash, size);
    }

    /// Shows the batches the reference's worker finished, when they are of the shown scene and
    /// size.
    fn receive_reference(&mut self, scene_hash: u64, size: (u32, u32)) {
        let Some(worker) = self.reference.worker.as_mut() else {
            return;
        };
        // The technique's frame has the UI frame's wait; the reference's batches are shown when
        // they arrive (tests wait for both).
        let wait = if self.technique.frame_wait == Duration::MAX {
            Duration::MAX
        } else {
            Duration::ZERO
        };
        let done = match worker.receive(wait) {
            Ok(Some(done)) => done,
            Ok(None) => return,
            Err(()) => {
                self.reference.worker = None;
                self.report_error("the reference's render worker stopped (the log says why)");
                return;
            }
        };
        if done.scene_hash != scene_hash || done.size != size {
            return;
        }
        let shown = done.result.and_then(|(_, visibility)| {
            let r = self.image.renderers.as_mut().expect("checked above");
            r.reference.show_visibility(
                &self.scene.loaded.gpu,
                &done.camera,
                &done.light,
                &visibility,
                ShadingMode::Shaded,
            )
        });
        match shown {
            Ok(()) => {
                if self.reference.key != Some(done.setting_key) {
                    self.reference.restarts += 1;
                    log::info!(
                        "reference accumulation {} begun at {}x{}",
                        self.reference.restarts,
                        size.0,
                        size.1
                    );
                }
                self.reference.key = Some(done.setting_key);
                self.reference.progress = progress_of(&done.stats);
            }
            Err(e) => {
                self.reference.key = None;
                self.report_error(format!("reference failed: {e}"));
            }
        }
    }

    /// Why no yardstick can measure the current light (the reference technique does not sample
    /// its kind: `softshadow_reference::info().light_kinds`), or `None` where it can.
    pub(super) fn reference_refusal(&self) -> Option<String> {
        let kind = self.scene.light.kind;
        let info = softshadow_reference::info();
        let why = info.light_kinds.why_not(kind)?;
        Some(format!(
            "the yardstick `reference` cannot sample a `{kind}` light: {why}"
        ))
    }

    /// The progress of the reference of the current inputs: none done while the reference
    /// renderer still holds another view's (it waits while the camera moves).
    pub(super) fn shown_reference_progress(&self) -> Progress {
        let mut progress = self.reference.progress;
        if self.reference.key != Some(self.current_reference_key()) {
            progress.done = 0;
        }
        progress
    }

    /// Metrics once the reference has converged and whenever the setting or the inputs changed
    /// (for a technique that keeps a history, again once it has settled); a plot point once the
    /// cost is measured on clean frames and, for such a technique, of its settled frame.
    pub(super) fn measure(&mut self) {
        puffin::profile_function!();
        // A reference for other inputs (the camera moved while it waited) does not count.
        let converged = self.reference.key == Some(self.current_reference_key())
            && self.reference.progress.is_complete();
        if !converged
            || self.technique.error.is_some()
            || self.technique.params.is_none()
            || self.technique.shown_key != Some(self.current_setting_key())
            || self.technique.build.is_running()
        {
            return;
        }
        let key = self.current_measure_key();
        let history = self.history_length();
        let settled = self
            .technique
            .history
            .settled(self.current_setting_key())
            .filter(|_| history.is_some());
        let stale = match &self.reference.measured {
            Some(m) => m.key != key || (settled.is_some() && m.settled_after.is_none()),
            None => true,
        };
        if stale {
            match self.compute_metrics() {
                Ok(report) => {
                    self.reference.measured = Some(Measured {
                        key,
                        report,
                        settled_after: settled,
                    })
                }
                Err(e) => {
                    self.report_error(format!("cannot measure the error: {e}"));
                    return;
                }
            }
        }
        let (Some(measured), Some(gpu_ms), Some(range)) = (
            &self.reference.measured,
            self.timing.cost.technique_ms(),
            self.timing.cost.technique_range(),
        ) else {
            return;
        };
        if self.timing.cost.len() < self.timing.cost_frames_wanted()
            || (history.is_some() && measured.settled_after.is_none())
        {
            return;
        }
        // Timestamp noise can put a tiny pass below zero; a cost is never negative.
        let point = TradeoffPoint {
            technique: self.technique.id.clone(),
            version: self.file_version(),
            params: self.setting(),
            gpu_ms: gpu_ms.max(0.0),
            gpu_range: (range.0.max(0.0), range.1.max(0.0)),
            cost_frames: self.timing.cost.len(),
            error: measured.report.mae_shadowed,
            settled_after: measured.settled_after,
        };
        let (scene, view) = (self.scene.loaded.gpu.content_hash, self.current_view_key());
        self.plot.insert(scene, view, point);
    }

    /// The converged reference's inputs, the technique and its parameters: what one set of
    /// metrics belongs to.
    pub(super) fn current_measure_key(&self) -> u64 {
        let mut h = Fnv1a::default();
        h.write_u64(self.current_reference_key());
        h.write_str(&self.technique.id);
        for (name, value) in self.setting() {
            h.write_str(&name);
            h.write_str(&value.to_string());
        }
        h.finish()
    }

    /// Whether the shown metrics belong to the current setting and a converged reference.
    pub(super) fn metrics_are_current(&self) -> bool {
        self.reference.key == Some(self.current_reference_key())
            && self.reference.progress.is_complete()
            && self
                .reference
                .measured
                .as_ref()
                .is_some_and(|m| m.key == self.current_measure_key())
    }

    pub(super) fn compute_metrics(&self) -> Result<ErrorReport, ViewerError> {
        let r = self.image.renderers.as_ref().expect("rendered this frame");
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

    pub fn reference_progress(&self) -> Progress {
        self.reference.progress
    }

    /// Accumulations of the reference begun so far, the first included: a restart costs the
    /// whole accumulation again.
    pub fn reference_accumulations(&self) -> u64 {
        self.reference.restarts
    }

    /// Error metrics of the current setting, once the reference has converged (`None` while
    /// the shown ones are stale).
    pub fn metrics(&self) -> Option<&ErrorReport> {
        self.reference
            .measured
            .as_ref()
            .filter(|_| self.metrics_are_current())
            .map(|m| &m.report)
    }

    /// Metrics on screen that belong to an earlier setting (greyed and labelled stale).
    pub fn stale_metrics(&self) -> Option<&ErrorReport> {
        self.reference
            .measured
            .as_ref()
            .filter(|_| !self.metrics_are_current())
            .map(|m| &m.report)
    }
}
