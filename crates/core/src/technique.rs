//! The one trait every technique implements (GUIDE.md section 2, shaped like wgpu's `Example`).

use std::{
    collections::BTreeMap,
    sync::{
        atomic::{AtomicBool, AtomicU32, Ordering},
        Arc,
    },
};

use crate::{
    error::{ParamError, TechniqueError},
    frame::{Frame, ShadowInputs},
    params::{ParamSet, ParamSpec, ParamValue, TechniqueSettings},
    visibility::VisibilityBuffer,
    Gpu,
};

/// What a technique needs from the adapter and the scene.
#[derive(Clone, Copy, Debug, Default)]
pub struct Requirements {
    /// Adapter features without which the technique cannot run.
    pub features: wgpu::Features,
    /// Needs the occluder / receiver split (Atty et al.): casters must not also be receivers to
    /// get correct results (receiver pixels on casters are still shaded, without self-shadowing).
    pub occluder_receiver_split: bool,
    /// Caches scene-only work in `prepare` (PDSM): only valid while instances are static.
    pub static_scene: bool,
}

/// Named counters for the report (`stats` in results.json).
pub type TechniqueStats = BTreeMap<String, f64>;

/// A technique-specific image for the viewer (shadow map, chosen level, ...).
pub struct DebugView {
    pub name: String,
    pub texture: wgpu::Texture,
}

/// Progress and cancellation of a long precompute (the PDSM's), shared between the thread that
/// builds and those that watch it (the workbench's progress bar and Ctrl-C handler, the viewer's
/// panel). A technique counts `done` of `total` units (PDSM rows) while `building` is set; setting
/// `cancel` stops the build at the next unit, and the technique then fails with
/// [`TechniqueError::Cancelled`] until the flag is cleared.
#[derive(Clone, Debug, Default)]
pub struct BuildControl {
    pub cancel: Arc<AtomicBool>,
    pub done: Arc<AtomicU32>,
    pub total: Arc<AtomicU32>,
    pub building: Arc<AtomicBool>,
}

impl BuildControl {
    /// `(done, total)` while a build runs, `None` otherwise.
    pub fn progress(&self) -> Option<(u32, u32)> {
        self.building.load(Ordering::Relaxed).then(|| {
            let total = self.total.load(Ordering::Relaxed);
            (self.done.load(Ordering::Relaxed).min(total), total)
        })
    }

    /// Asks the running build (and any later one, until [`BuildControl::clear_cancel`]) to stop.
    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    pub fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    pub fn clear_cancel(&self) {
        self.cancel.store(false, Ordering::Relaxed);
    }

    /// Marks a build of `total` units as started (`done` = 0).
    pub fn start(&self, total: u32) {
        self.done.store(0, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
        self.building.store(true, Ordering::Relaxed);
    }

    /// Marks the build as over (finished, failed or cancelled).
    pub fn finish(&self) {
        self.building.store(false, Ordering::Relaxed);
    }
}

/// A soft-shadow technique: fills the visibility buffer for the current frame.
pub trait ShadowTechnique {
    /// Stable id used on the command line, in JSON and in the GUI.
    fn id(&self) -> &'static str;
    fn requirements(&self) -> Requirements {
        Requirements::default()
    }
    /// The technique's settings (declared with [`technique_settings!`](crate::technique_settings)).
    fn settings(&self) -> &dyn TechniqueSettings;
    fn settings_mut(&mut self) -> &mut dyn TechniqueSettings;
    /// Current parameter values with their specs.
    fn params(&self) -> ParamSet {
        self.settings().param_set()
    }
    /// Sets one parameter (range-checked). Takes effect on the next `render`.
    fn set_param(&mut self, name: &str, value: ParamValue) -> Result<(), ParamError> {
        let id = self.id();
        self.settings_mut().set_param(id, name, value)
    }
    /// Work that depends only on the scene and light; not timed per frame. Default: nothing.
    fn prepare(&mut self, _gpu: &Gpu, _inputs: &ShadowInputs<'_>) -> Result<(), TechniqueError> {
        Ok(())
    }
    /// Records the passes that fill `out` (every pixel). Each pass is a named, timed scope.
    fn render(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
    ) -> Result<(), TechniqueError>;
    /// Drops results cached across frames (light-space maps kept while only the camera moves,
    /// the reference's image), so that the next `render` does the full work whatever
    /// [`ShadowInputs::changes`] says. The benchmark calls it before every frame of its `timing`
    /// block so that timings measure the technique, not a cache hit. Default: nothing.
    fn invalidate_cache(&mut self) {}
    /// Shares the progress counter and cancel flag of the technique's long precompute (the
    /// PDSM's) with `control`, which a progress bar or a Cancel button watches from elsewhere.
    /// Default: nothing (no long precompute).
    fn set_build_control(&mut self, _control: BuildControl) {}
    /// With `true`, a long precompute runs on a thread of its own: `render` starts it and fails
    /// with [`TechniqueError::Building`] (nothing drawn) until it is done, so an interactive
    /// caller stays responsive. With `false` (the default, and what the benchmark uses) it runs
    /// inside `render` and counts in that frame's cost. Default: ignored (nothing to build).
    fn set_background_build(&mut self, _on: bool) {}
    /// Counters of the last frame.
    fn stats(&self) -> TechniqueStats {
        TechniqueStats::new()
    }
    fn debug_views(&self) -> Vec<DebugView> {
        Vec::new()
    }
}

/// A registry entry: what `workbench list` prints without a GPU, and how to build the technique.
#[derive(Clone, Copy)]
pub struct TechniqueInfo {
    pub id: &'static str,
    pub description: &'static str,
    /// Paper or source the technique follows.
    pub source: &'static str,
    pub params: fn() -> Vec<ParamSpec>,
    pub create: fn(&Gpu) -> Result<Box<dyn ShadowTechnique>, TechniqueError>,
}

impl TechniqueInfo {
    /// Builds the technique and applies `name=value` settings (strings from a CLI or a sweep).
    pub fn create_with(
        &self,
        gpu: &Gpu,
        settings: &[(String, ParamValue)],
    ) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
        let mut technique = (self.create)(gpu)?;
        for (name, value) in settings {
            technique.set_param(name, value.clone())?;
        }
        Ok(technique)
    }

    /// Parses `name=value` text against this technique's specs.
    pub fn parse_param(&self, text: &str) -> Result<(String, ParamValue), ParamError> {
        let specs = (self.params)();
        let (name, value) = text.split_once('=').ok_or_else(|| ParamError::WrongType {
            name: text.into(),
            expected: "name=value".into(),
            value: text.into(),
        })?;
        let spec = crate::params::find_spec(self.id, &specs, name.trim())?;
        Ok((spec.name.to_string(), spec.parse(value)?))
    }
}

/// Checks the adapter has what `requirements` lists.
pub fn check_requirements(
    gpu: &Gpu,
    id: &str,
    requirements: &Requirements,
) -> Result<(), TechniqueError> {
    let missing = requirements.features - gpu.features();
    if missing.is_empty() {
        Ok(())
    } else {
        Err(TechniqueError::MissingFeatures {
            technique: id.into(),
            adapter: gpu.summary().name,
            missing,
        })
    }
}
