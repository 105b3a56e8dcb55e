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

/// Device limits a technique needs beyond nothing at all. Every technique of the workspace fits in
/// [`wgpu::Limits::default`] at its default settings; a host that creates its device with
/// `wgpu::Limits::downlevel_defaults()` or smaller limits is told which of these it lacks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MinLimits {
    /// Largest 2D texture edge the technique creates (shadow maps at the largest settable size).
    pub max_texture_dimension_2d: u32,
    /// Layers of the largest texture array (shadow-map arrays, depth-peeled layers).
    pub max_texture_array_layers: u32,
    /// Largest storage-buffer binding, in bytes.
    pub max_storage_buffer_binding_size: u64,
    /// Storage textures one shader stage binds.
    pub max_storage_textures_per_shader_stage: u32,
}

impl Default for MinLimits {
    /// What the core passes need: the 8192-texel frame edge ([`crate::renderer::MAX_RESOLUTION`])
    /// is not required, the 4096-texel shadow maps every technique allows are.
    fn default() -> Self {
        Self {
            max_texture_dimension_2d: 4096,
            max_texture_array_layers: 1,
            max_storage_buffer_binding_size: 0,
            max_storage_textures_per_shader_stage: 0,
        }
    }
}

impl MinLimits {
    /// The larger of each limit (what a device running both techniques needs).
    pub fn max(self, other: Self) -> Self {
        Self {
            max_texture_dimension_2d: self
                .max_texture_dimension_2d
                .max(other.max_texture_dimension_2d),
            max_texture_array_layers: self
                .max_texture_array_layers
                .max(other.max_texture_array_layers),
            max_storage_buffer_binding_size: self
                .max_storage_buffer_binding_size
                .max(other.max_storage_buffer_binding_size),
            max_storage_textures_per_shader_stage: self
                .max_storage_textures_per_shader_stage
                .max(other.max_storage_textures_per_shader_stage),
        }
    }

    /// `limits` raised to at least these values: what to pass as
    /// `wgpu::DeviceDescriptor::required_limits`.
    pub fn apply_to(&self, limits: wgpu::Limits) -> wgpu::Limits {
        wgpu::Limits {
            max_texture_dimension_2d: limits
                .max_texture_dimension_2d
                .max(self.max_texture_dimension_2d),
            max_texture_array_layers: limits
                .max_texture_array_layers
                .max(self.max_texture_array_layers),
            max_storage_buffer_binding_size: limits
                .max_storage_buffer_binding_size
                .max(self.max_storage_buffer_binding_size),
            max_storage_textures_per_shader_stage: limits
                .max_storage_textures_per_shader_stage
                .max(self.max_storage_textures_per_shader_stage),
            ..limits
        }
    }

    /// `name: needs N, device has M` for every limit `device` falls short of.
    pub fn shortfalls(&self, device: &wgpu::Limits) -> Vec<String> {
        let mut out = Vec::new();
        let mut check = |name: &str, needs: u64, has: u64| {
            if has < needs {
                out.push(format!("{name}: needs {needs}, device has {has}"));
            }
        };
        check(
            "max_texture_dimension_2d",
            self.max_texture_dimension_2d.into(),
            device.max_texture_dimension_2d.into(),
        );
        check(
            "max_texture_array_layers",
            self.max_texture_array_layers.into(),
            device.max_texture_array_layers.into(),
        );
        check(
            "max_storage_buffer_binding_size",
            self.max_storage_buffer_binding_size,
            device.max_storage_buffer_binding_size,
        );
        check(
            "max_storage_textures_per_shader_stage",
            self.max_storage_textures_per_shader_stage.into(),
            device.max_storage_textures_per_shader_stage.into(),
        );
        out
    }
}

/// What a technique needs from the adapter and the scene.
#[derive(Clone, Copy, Debug, Default)]
pub struct Requirements {
    /// Adapter features without which the technique cannot run.
    pub features: wgpu::Features,
    /// Device limits the technique needs at any of its settings.
    pub limits: MinLimits,
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
    /// Name shown in the viewer's view list.
    pub name: String,
    /// The image.
    pub texture: wgpu::Texture,
}

/// Progress and cancellation of a long precompute (the PDSM's), shared between the thread that
/// builds and those that watch it (the workbench's progress bar and Ctrl-C handler, the viewer's
/// panel). A technique counts `done` of `total` units (PDSM rows) while `building` is set; setting
/// `cancel` stops the build at the next unit, and the technique then fails with
/// [`TechniqueError::Cancelled`] until the flag is cleared.
#[derive(Clone, Debug, Default)]
pub struct BuildControl {
    /// Set to stop the build at its next unit.
    pub cancel: Arc<AtomicBool>,
    /// Units finished so far.
    pub done: Arc<AtomicU32>,
    /// Units of the running build.
    pub total: Arc<AtomicU32>,
    /// Set while a build runs.
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

    /// Whether a cancel was asked for and not cleared since.
    pub fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// Lets the next build run (after a cancel).
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
    /// What the technique needs from the device at its current settings (checked before every
    /// frame).
    fn requirements(&self) -> Requirements {
        Requirements::default()
    }
    /// The technique's settings (declared with [`technique_settings!`](crate::technique_settings)).
    fn settings(&self) -> &dyn TechniqueSettings;
    /// The settings, to change (through [`ShadowTechnique::set_param`] or directly).
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
    /// Technique-specific images of the last frame for the viewer (empty by default).
    fn debug_views(&self) -> Vec<DebugView> {
        Vec::new()
    }
    /// Which of [`ShadowTechnique::debug_views`] the caller will show after the next `render`
    /// (by name), or `None` when it shows none (the benchmark never calls this). A technique may
    /// draw an image that only a debug view reads (the PDSM's map from the light centre) only
    /// while it is shown; it still lists it, so that it can be chosen. Default: ignored.
    fn show_debug_view(&mut self, _name: Option<&str>) {}
}

/// A registry entry: what `workbench list` prints without a GPU, and how to build the technique.
#[derive(Clone, Copy)]
pub struct TechniqueInfo {
    /// Stable id ([`ShadowTechnique::id`]).
    pub id: &'static str,
    /// One line for `workbench list` and the GUI.
    pub description: &'static str,
    /// Paper or source the technique follows.
    pub source: &'static str,
    /// The parameters with their specs.
    pub params: fn() -> Vec<ParamSpec>,
    /// What the technique needs from the device at its default settings (features and limits),
    /// known without a device: what a host checks or requests when it creates its own device
    /// ([`Gpu::from_host`], [`Requirements::all`]).
    pub requirements: fn() -> Requirements,
    /// Builds the technique on `gpu` with its default settings.
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

impl Requirements {
    /// The union of what `techniques` need: the features and limits to request when creating a
    /// device for them (`required_features: r.features`,
    /// `required_limits: r.limits.apply_to(wgpu::Limits::default())`).
    pub fn all(techniques: &[TechniqueInfo]) -> Self {
        techniques.iter().fold(Self::default(), |acc, t| {
            let r = (t.requirements)();
            Self {
                features: acc.features | r.features,
                limits: acc.limits.max(r.limits),
                occluder_receiver_split: acc.occluder_receiver_split || r.occluder_receiver_split,
                static_scene: acc.static_scene || r.static_scene,
            }
        })
    }

    /// What `device` lacks of these requirements: missing features and the limits it falls
    /// short of (empty when it has everything).
    pub fn missing_on(&self, device: &wgpu::Device) -> (wgpu::Features, Vec<String>) {
        (
            self.features - device.features(),
            self.limits.shortfalls(&device.limits()),
        )
    }
}

/// Checks the device has what `requirements` lists.
pub fn check_requirements(
    gpu: &Gpu,
    id: &str,
    requirements: &Requirements,
) -> Result<(), TechniqueError> {
    let (missing, limits) = requirements.missing_on(&gpu.device);
    if missing.is_empty() && limits.is_empty() {
        Ok(())
    } else {
        Err(TechniqueError::MissingFeatures {
            technique: id.into(),
            adapter: gpu.summary().name,
            missing,
            limits: limits.join("; "),
        })
    }
}
