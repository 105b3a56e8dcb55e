//! The one trait every technique implements (shaped like wgpu's `Example`), and the descriptor
//! through which the workspace knows a technique ([`TechniqueInfo`]).

use std::{
    borrow::Cow,
    collections::BTreeMap,
    sync::{
        atomic::{AtomicBool, AtomicU32, Ordering},
        Arc, Mutex,
    },
};

use crate::{
    cost::CostModel,
    error::{ParamError, TechniqueError},
    expectations::Expectations,
    frame::{Frame, ShadowInputs},
    params::{ParamSet, ParamSpec, ParamValue, TechniqueSettings},
    shader::ShaderSpec,
    visibility::VisibilityBuffer,
    Gpu, LightKind,
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
    /// How the viewer maps it to colours and what its legend says.
    pub legend: DebugLegend,
}

impl DebugView {
    /// A view of `texture` called `name` with `legend`.
    pub fn new(name: impl Into<String>, texture: &wgpu::Texture, legend: DebugLegend) -> Self {
        Self {
            name: name.into(),
            texture: texture.clone(),
            legend,
        }
    }
}

/// How a debug image is shown and what its colours mean: the technique says, the viewer draws.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum DebugLegend {
    /// A depth map (a depth format, or light-space depth in the red channel): texels holding a
    /// caster mapped black (nearest) to white (farthest) over their own range, empty texels
    /// (depth 1 or more) dark blue.
    Depth,
    /// A number per texel in the red channel, mapped black to white over the finite values'
    /// range (non-finite texels magenta): `meaning` names the number, `notes` add lines (what a
    /// special value means).
    Value {
        /// What the number is, e.g. "gather level".
        meaning: Cow<'static, str>,
        /// Extra legend lines.
        notes: Vec<Cow<'static, str>>,
    },
    /// A colour-coded image shown as it is; each entry is a colour the shader writes (sRGB
    /// bytes) and what it means.
    Palette(Vec<([u8; 3], Cow<'static, str>)>),
}

impl DebugLegend {
    /// A [`DebugLegend::Value`] without notes.
    pub fn value(meaning: &'static str) -> Self {
        DebugLegend::Value {
            meaning: Cow::Borrowed(meaning),
            notes: Vec::new(),
        }
    }
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
    /// What the running build counts, named by the technique ("PDSM rows").
    unit: Arc<Mutex<Cow<'static, str>>>,
}

/// A running build's progress: `done` of `total` units of what `unit` names.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildProgress {
    /// Units finished.
    pub done: u32,
    /// Units of the build.
    pub total: u32,
    /// What a unit is ("PDSM rows", "sample maps").
    pub unit: Cow<'static, str>,
}

impl BuildControl {
    /// `(done, total)` while a build runs, `None` otherwise.
    pub fn progress(&self) -> Option<(u32, u32)> {
        self.building.load(Ordering::Relaxed).then(|| {
            let total = self.total.load(Ordering::Relaxed);
            (self.done.load(Ordering::Relaxed).min(total), total)
        })
    }

    /// The running build's progress with its unit, `None` when nothing builds.
    pub fn progress_with_unit(&self) -> Option<BuildProgress> {
        let (done, total) = self.progress()?;
        let unit = self.unit.lock().map(|u| u.clone()).unwrap_or_default();
        Some(BuildProgress { done, total, unit })
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

    /// Marks a build of `total` units of `unit` ("PDSM rows") as started (`done` = 0).
    pub fn start(&self, total: u32, unit: &'static str) {
        if let Ok(mut current) = self.unit.lock() {
            *current = Cow::Borrowed(unit);
        }
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
    fn id(&self) -> &str;
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
        let id = self.id().to_string();
        self.settings_mut().set_param(&id, name, value)
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

/// The technique every error is measured against when no exact answer is asked for, and whose
/// error against the exact answer is reported beside every run: accumulated hard shadows
/// (`softshadow-reference`).
pub const YARDSTICK_TECHNIQUE: &str = "reference";

/// The cheapest technique, the floor of every cost comparison (ratios to its frame time in the
/// report) and the wrong answer every soft technique's bounds must reject: one hard shadow map
/// (`softshadow-hard`).
pub const COST_FLOOR_TECHNIQUE: &str = "hard";

/// Builds a technique on a device with its default settings.
pub type CreateFn = dyn Fn(&Gpu) -> Result<Box<dyn ShadowTechnique>, TechniqueError> + Send + Sync;

/// Everything the workspace knows about a technique, all of it from the technique's own crate
/// (or, for a technique defined by a WGSL file, from that file): what `workbench list` prints
/// without a GPU, how to build it, what it needs from the device, what it costs, which error it
/// promises on which case, and how the overview sweep runs it. The benchmark, the viewer, the
/// report and the tests read only this; none of them names a technique.
#[derive(Clone)]
pub struct TechniqueInfo {
    /// Stable id ([`ShadowTechnique::id`]).
    pub id: Cow<'static, str>,
    /// One line for `workbench list` and the GUI.
    pub description: Cow<'static, str>,
    /// Paper or source the technique follows.
    pub source: Cow<'static, str>,
    /// The parameters with their specs (defaults are the technique's defaults).
    pub params: Vec<ParamSpec>,
    /// What the technique needs from the device at its default settings (features and limits),
    /// known without a device: what a host checks or requests when it creates its own device
    /// ([`Gpu::from_host`], [`Requirements::all`]).
    pub requirements: Requirements,
    /// Its WGSL entry files and their permutations, validated by the workspace's naga test
    /// (empty for a technique whose shader is compiled when it is loaded).
    pub shaders: &'static [ShaderSpec],
    /// Builds the technique on a device with its default settings.
    pub create: Arc<CreateFn>,
    /// Its cost as a function of its parameters (the stress cap's model).
    pub cost: CostModel,
    /// Its error bounds per stiff class and named case ([`crate::expectations`]).
    pub expectations: Expectations,
    /// The settings the overview sweep (`sweeps/overview.toml`) runs it at: parameter name and
    /// the values to try, as text (each list multiplies, as in a sweep file). Empty: its defaults.
    pub overview: Vec<(Cow<'static, str>, Vec<Cow<'static, str>>)>,
    /// Why its answer changes from frame to frame with nothing moving (a per-frame sample
    /// pattern, a history), if it does: its flicker on a still path is what it trades, not a
    /// fault. `None`: the same inputs give the same frame.
    pub varies_per_frame: Option<Cow<'static, str>>,
    /// The setting under which [`Self::varies_per_frame`] holds, as parameter name and value
    /// text (`("temporal", "true")`); `None`: at every setting. Read it through
    /// [`Self::varies_per_frame_at`].
    pub varies_per_frame_when: Option<(Cow<'static, str>, Cow<'static, str>)>,
    /// The integer parameter holding how many still frames its answer takes to settle (its
    /// history length), where it [varies per frame](Self::varies_per_frame): the benchmark
    /// renders that many still frames and reports the settled error beside the first frame's.
    /// Read it through [`Self::settle_frames_at`].
    pub settle_frames_param: Option<Cow<'static, str>>,
    /// The light kinds it supports, with one line of why for each it does not.
    pub light_kinds: LightSupport,
    /// Its bound per light kind on [`LIGHT_KIND_SCENE`] with the scene's light made that kind
    /// ([`AreaLight::as_kind`](crate::AreaLight::as_kind)), at its defaults, 64², against the
    /// exact answer, with the value measured beside each (the GPU test `light_kinds` holds it).
    pub light_kind_bounds: Vec<(LightKind, crate::expectations::Expect)>,
}

/// The scene of [`TechniqueInfo::light_kind_bounds`].
pub const LIGHT_KIND_SCENE: &str = "atty-square";

/// Why a technique made for the seed papers' light supports no other kind until its crate says so.
pub const RECT_ONLY: &str =
    "its light-space passes assume the seed papers' rectangle light and have not been extended to this kind";

/// The light kinds a technique supports ([`TechniqueInfo::light_kinds`]), and for each kind it
/// does not, one line of why (shown by `list`, the viewer and the benchmark's refusal).
#[derive(Clone, Debug, PartialEq)]
pub struct LightSupport {
    unsupported: Vec<(LightKind, Cow<'static, str>)>,
}

impl LightSupport {
    /// Every kind.
    pub fn all() -> Self {
        Self {
            unsupported: Vec::new(),
        }
    }

    /// The rectangle only; every other kind for `why`.
    pub fn rect_only(why: &'static str) -> Self {
        Self {
            unsupported: LightKind::ALL[1..]
                .iter()
                .map(|k| (*k, Cow::Borrowed(why)))
                .collect(),
        }
    }

    /// Without `kind`, for `why`.
    pub fn except(mut self, kind: LightKind, why: &'static str) -> Self {
        self.unsupported.retain(|(k, _)| *k != kind);
        self.unsupported.push((kind, Cow::Borrowed(why)));
        self
    }

    /// Whether `kind` is supported.
    pub fn supports(&self, kind: LightKind) -> bool {
        self.why_not(kind).is_none()
    }

    /// Why `kind` is not supported, or `None` where it is.
    pub fn why_not(&self, kind: LightKind) -> Option<&str> {
        self.unsupported
            .iter()
            .find(|(k, _)| *k == kind)
            .map(|(_, why)| why.as_ref())
    }

    /// The supported kinds, in [`LightKind::ALL`]'s order.
    pub fn supported(&self) -> Vec<LightKind> {
        LightKind::ALL
            .into_iter()
            .filter(|k| self.supports(*k))
            .collect()
    }

    /// The unsupported kinds with their reasons, in [`LightKind::ALL`]'s order.
    pub fn unsupported(&self) -> Vec<(LightKind, &str)> {
        LightKind::ALL
            .into_iter()
            .filter_map(|k| self.why_not(k).map(|why| (k, why)))
            .collect()
    }
}

impl TechniqueInfo {
    /// A technique with its id, description, source, parameter specs and constructor; no
    /// special requirements, no shaders to validate, no cost model, no bounds and the defaults
    /// in the overview until the `with_*` methods add them.
    pub fn new(
        id: impl Into<Cow<'static, str>>,
        description: impl Into<Cow<'static, str>>,
        source: impl Into<Cow<'static, str>>,
        params: Vec<ParamSpec>,
        create: impl Fn(&Gpu) -> Result<Box<dyn ShadowTechnique>, TechniqueError>
            + Send
            + Sync
            + 'static,
    ) -> Self {
        Self {
            id: id.into(),
            description: description.into(),
            source: source.into(),
            params,
            requirements: Requirements::default(),
            shaders: &[],
            create: Arc::new(create),
            cost: CostModel::unmodelled(),
            expectations: Expectations::default(),
            overview: Vec::new(),
            varies_per_frame: None,
            varies_per_frame_when: None,
            settle_frames_param: None,
            light_kinds: LightSupport::rect_only(RECT_ONLY),
            light_kind_bounds: Vec::new(),
        }
    }

    /// With these bounds per light kind ([`Self::light_kind_bounds`]).
    pub fn with_light_kind_bounds(
        mut self,
        bounds: &[(LightKind, crate::expectations::Expect)],
    ) -> Self {
        self.light_kind_bounds = bounds.to_vec();
        self
    }

    /// With these supported light kinds.
    pub fn with_light_kinds(mut self, light_kinds: LightSupport) -> Self {
        self.light_kinds = light_kinds;
        self
    }

    /// `Ok` where it supports `kind`, else the one line a user sees: technique, kind and why.
    pub fn check_light(&self, kind: LightKind) -> Result<(), String> {
        match self.light_kinds.why_not(kind) {
            None => Ok(()),
            Some(why) => Err(format!(
                "technique `{}` does not support the `{kind}` light: {why}; pick a light kind it lists in `workbench list` (light kinds) or another technique",
                self.id
            )),
        }
    }

    /// With these device requirements.
    pub fn with_requirements(mut self, requirements: Requirements) -> Self {
        self.requirements = requirements;
        self
    }

    /// With these shaders for the naga validation test.
    pub fn with_shaders(mut self, shaders: &'static [ShaderSpec]) -> Self {
        self.shaders = shaders;
        self
    }

    /// With this cost model.
    pub fn with_cost(mut self, cost: CostModel) -> Self {
        self.cost = cost;
        self
    }

    /// With these error bounds.
    pub fn with_expectations(mut self, expectations: Expectations) -> Self {
        self.expectations = expectations;
        self
    }

    /// With these overview-sweep settings (`(parameter, values)`).
    pub fn with_overview(mut self, grid: &[(&'static str, &[&'static str])]) -> Self {
        self.overview = grid
            .iter()
            .map(|(name, values)| {
                (
                    Cow::Borrowed(*name),
                    values.iter().map(|v| Cow::Borrowed(*v)).collect(),
                )
            })
            .collect();
        self
    }

    /// Its answer changes from frame to frame with nothing moving, for this reason.
    pub fn with_varies_per_frame(mut self, why: &'static str) -> Self {
        self.varies_per_frame = Some(Cow::Borrowed(why));
        self
    }

    /// Its answer changes from frame to frame with nothing moving, for this reason, only while
    /// parameter `param` has the value written `value` (a mode its defaults leave off).
    pub fn with_varies_per_frame_when(
        mut self,
        param: &'static str,
        value: &'static str,
        why: &'static str,
    ) -> Self {
        self.varies_per_frame = Some(Cow::Borrowed(why));
        self.varies_per_frame_when = Some((Cow::Borrowed(param), Cow::Borrowed(value)));
        self
    }

    /// Its answer settles over as many still frames as integer parameter `param` says (its
    /// history length).
    pub fn with_settle_frames_from(mut self, param: &'static str) -> Self {
        self.settle_frames_param = Some(Cow::Borrowed(param));
        self
    }

    /// How many still frames its answer takes to settle at these settings (`params` over its
    /// defaults): the value of [`Self::settle_frames_param`] where it
    /// [varies per frame](Self::varies_per_frame_at) at them, else `None` (one frame is its
    /// answer).
    pub fn settle_frames_at(&self, params: &[(String, ParamValue)]) -> Option<u32> {
        self.varies_per_frame_at(params)?;
        let param = self.settle_frames_param.as_deref()?;
        let value = params
            .iter()
            .rev()
            .find(|(name, _)| name == param)
            .map(|(_, v)| v.clone())
            .or_else(|| {
                self.params
                    .iter()
                    .find(|s| s.name == *param)
                    .map(ParamSpec::default_value)
            })?;
        value.as_f64().map(|n| n.max(1.0) as u32)
    }

    /// Why its answer changes from frame to frame with nothing moving at these settings
    /// (`params` over its defaults, as a run gives them), or `None` when the same inputs give
    /// the same frame.
    pub fn varies_per_frame_at(&self, params: &[(String, ParamValue)]) -> Option<&str> {
        let why = self.varies_per_frame.as_deref()?;
        let Some((param, value)) = &self.varies_per_frame_when else {
            return Some(why);
        };
        let set = params
            .iter()
            .rev()
            .find(|(name, _)| name == param)
            .map(|(_, v)| v.clone())
            .or_else(|| {
                self.params
                    .iter()
                    .find(|s| s.name == *param)
                    .map(ParamSpec::default_value)
            })?;
        (set.to_string() == *value).then_some(why)
    }

    /// Builds the technique on `gpu` with its default settings.
    pub fn create(&self, gpu: &Gpu) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
        (self.create)(gpu)
    }

    /// Builds the technique and applies `name=value` settings (strings from a CLI or a sweep).
    pub fn create_with(
        &self,
        gpu: &Gpu,
        settings: &[(String, ParamValue)],
    ) -> Result<Box<dyn ShadowTechnique>, TechniqueError> {
        let mut technique = self.create(gpu)?;
        for (name, value) in settings {
            technique.set_param(name, value.clone())?;
        }
        Ok(technique)
    }

    /// The spec of parameter `name`, or an error listing the names there are.
    pub fn param(&self, name: &str) -> Result<&ParamSpec, ParamError> {
        crate::params::find_spec(&self.id, &self.params, name)
    }

    /// Parses `name=value` text against this technique's specs.
    pub fn parse_param(&self, text: &str) -> Result<(String, ParamValue), ParamError> {
        let (name, value) = text.split_once('=').ok_or_else(|| ParamError::WrongType {
            name: text.into(),
            expected: "name=value".into(),
            value: text.into(),
        })?;
        let spec = self.param(name.trim())?;
        Ok((spec.name.to_string(), spec.parse(value)?))
    }

    /// Checks already-typed settings against the specs (name, type, range).
    pub fn check_params(&self, settings: &[(String, ParamValue)]) -> Result<(), ParamError> {
        for (name, value) in settings {
            self.param(name)?.check(value.clone())?;
        }
        Ok(())
    }
}

impl std::fmt::Debug for TechniqueInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TechniqueInfo")
            .field("id", &self.id)
            .field("source", &self.source)
            .field("params", &self.params.len())
            .finish_non_exhaustive()
    }
}

impl Requirements {
    /// The union of what `techniques` need: the features and limits to request when creating a
    /// device for them (`required_features: r.features`,
    /// `required_limits: r.limits.apply_to(wgpu::Limits::default())`).
    pub fn all(techniques: &[TechniqueInfo]) -> Self {
        techniques.iter().fold(Self::default(), |acc, t| {
            let r = t.requirements;
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
            hint: missing_hint(missing).into(),
            missing,
            limits: limits.join("; "),
        })
    }
}

/// What to do when a device lacks `missing`: what to install for ray queries
/// ([`crate::accel::RAY_QUERY_HINT`]), else how to request the features.
pub fn missing_hint(missing: wgpu::Features) -> &'static str {
    if missing.contains(crate::accel::RAY_QUERY) {
        crate::accel::RAY_QUERY_HINT
    } else {
        "request them when creating the device (`required_features` / `required_limits`, see `Requirements::all`), or use an adapter that has them (lavapipe does)"
    }
}

impl TechniqueInfo {
    /// `None` when a device with `features` can run the technique at its default settings, else
    /// one line saying why not and what to install (`workbench list`, the viewer, results.json).
    pub fn unavailable_on(&self, features: wgpu::Features) -> Option<String> {
        let missing = self.requirements.features - features;
        (!missing.is_empty()).then(|| {
            if missing.contains(crate::accel::RAY_QUERY) {
                crate::accel::RAY_QUERY_HINT.to_string()
            } else {
                format!("this adapter lacks {missing:?}")
            }
        })
    }
}
