//! The active technique: switching, its parameters, and its GPU frame.

use std::collections::BTreeMap;

use softshadow_core::{scene::Fnv1a, ParamSet, ParamValue, ShadingMode, ShadowTechnique};

use super::{build_panel::BuildState, timing_panel::SLOW_COST_FRAME_MS, ViewerApp, ViewerError};
use crate::display::ViewMode;

/// The active technique, every technique's settings, and its last error.
#[derive(Default)]
pub(super) struct TechniqueState {
    pub(super) id: String,
    /// `None` when it failed to start.
    pub(super) active: Option<Box<dyn ShadowTechnique>>,
    /// Settings per technique id, so switching back and forth keeps them.
    pub(super) settings: BTreeMap<String, BTreeMap<String, ParamValue>>,
    /// Inputs `prepare` last ran for (scene hash, light hash).
    pub(super) prepared: Option<(u64, u64)>,
    /// The last frame's failure (or its failure to start).
    pub(super) error: Option<String>,
    /// Its precompute when it builds off the UI thread ([`super::build_panel`]).
    pub(super) build: BuildState,
}

impl TechniqueState {
    pub(super) fn new(settings: BTreeMap<String, BTreeMap<String, ParamValue>>) -> Self {
        Self {
            settings,
            ..Self::default()
        }
    }
}

impl ViewerApp {
    /// Switches the technique; its settings from earlier in the session are restored. A technique
    /// that fails to build shows its error and leaves no active technique.
    pub fn select_technique(&mut self, id: &str) {
        self.technique.id = id.to_string();
        self.technique.active = None;
        self.release_memory();
        self.technique.error = None;
        self.technique.prepared = None;
        self.timing.rolling.clear();
        let result = self
            .registry
            .find(id)
            .map_err(ViewerError::from)
            .and_then(|info| {
                let saved: Vec<(String, ParamValue)> = self
                    .technique
                    .settings
                    .get(id)
                    .map(|m| m.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
                    .unwrap_or_default();
                Ok(info.create_with(&self.gpu, &saved)?)
            });
        match result {
            Ok(mut technique) => {
                self.technique.build.attach(technique.as_mut());
                self.technique.active = Some(technique);
            }
            Err(e) => {
                let message = format!("technique `{id}` failed to start: {e}");
                self.technique.error = Some(message.clone());
                self.report_error(message);
            }
        }
    }

    /// Sets one parameter of the active technique (range-checked; an error is shown).
    pub fn set_param(&mut self, name: &str, value: ParamValue) {
        let Some(technique) = self.technique.active.as_mut() else {
            return;
        };
        match technique.set_param(name, value.clone()) {
            Ok(()) => {
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

    pub(super) fn render_technique(&mut self) {
        puffin::profile_function!();
        let (Some(r), Some(technique)) = (
            self.image.renderers.as_mut(),
            self.technique.active.as_mut(),
        ) else {
            return;
        };
        let prepared = (
            self.scene.loaded.gpu.content_hash,
            self.scene.light.content_hash(),
        );
        if self.technique.prepared != Some(prepared) {
            let inputs = r.technique.inputs(
                &self.scene.loaded.gpu,
                &self.scene.camera,
                &self.scene.light,
            );
            if let Err(e) = technique.prepare(&self.gpu, &inputs) {
                self.technique.error = Some(format!("{}: {e}", self.technique.id));
                return;
            }
            self.technique.prepared = Some(prepared);
        }
        // The first frames of a setting pay the whole cost (as the benchmark's `timing` does);
        // later ones may keep light-space results while only the camera moves. Not while the
        // user drags: the camera-only frames are what keeps that interactive.
        let measuring_cost =
            self.timing.cost.len() < self.timing.cost_frames_wanted() && !self.image.interacting;
        if measuring_cost {
            technique.invalidate_cache();
        }
        // Images only a debug view reads (the PDSM's centre map) are drawn only while shown.
        let shown = (self.image.view_mode == ViewMode::Debug).then(|| {
            let views = technique.debug_views();
            views
                .get(self.image.debug_view)
                .or(views.first())
                .map(|v| v.name.clone())
        });
        technique.show_debug_view(shown.flatten().as_deref());
        match r.technique.render(
            &self.scene.loaded.gpu,
            &self.scene.camera,
            &self.scene.light,
            technique.as_mut(),
            Some(ShadingMode::Shaded),
        ) {
            Ok(output) => {
                self.technique.build.note(Ok(()));
                if let Some(gpu) = &output.gpu {
                    self.timing.rolling.push(gpu.clone());
                    if measuring_cost {
                        self.timing.cost.push(gpu.clone());
                        self.timing.slow_cost_frames |= output.cpu_ms > SLOW_COST_FRAME_MS;
                    }
                }
                self.timing.last_output = Some(output);
                self.technique.error = None;
            }
            Err(e) if self.technique.build.note(Err(&e)) => {
                // The precompute builds off the UI thread: nothing drawn, nothing timed.
                self.technique.error = None;
                self.timing.rolling.clear();
                self.timing.cost.clear();
            }
            Err(e) => {
                // Keep running: the error is shown and the next frame tries again.
                let _ = self.gpu.take_errors();
                self.technique.error = Some(format!("{} failed: {e}", self.technique.id));
                self.timing.rolling.clear();
                self.timing.cost.clear();
            }
        }
    }

    pub(super) fn setting(&self) -> Vec<(String, ParamValue)> {
        self.technique
            .active
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
        self.technique.active.as_ref().map(|t| t.params())
    }

    /// The active technique's last render error, if its last frame failed.
    pub fn technique_error(&self) -> Option<&str> {
        self.technique.error.as_deref()
    }
}
