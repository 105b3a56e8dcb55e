//! Ground truth for the workbench.
//!
//! - [`Reference`] (technique id `reference`): accumulated hard shadows from N x N
//!   stratified (optionally jittered) point samples on the light, one depth map each, averaged
//!   per pixel into the visibility buffer. Cached by a hash of scene, light, camera, parameters
//!   and resolution, so it is not recomputed while nothing changed.
//! - [`exact`]: closed-form visibility for rectangles parallel to the light.
//! - [`analytic`]: analytic visibility of any opaque triangle mesh under a rectangle light (the
//!   union of the casters' projections onto the light, in f64), and the exact irradiance from
//!   the visible part of the light.
//! - [`raycast`]: CPU ray-cast visibility (BVH over the casters, N x N stratified light samples)
//!   for any scene.
//! - [`traced`]: the same estimate as the ray cast, traced on the device with ray queries (more
//!   samples affordable; needs `EXPERIMENTAL_RAY_QUERY`).
//! - [`exact_visibility`]: the closed form where it applies, else the analytic answer (a light
//!   with area), else the ray cast, and which one; [`exact_answer`]: the same with the exact
//!   irradiance, the ray-traced answer where the analytic one is not asked for or cannot be had
//!   and the device has ray queries, and each answer's sampling error.
//!
//! Reads: the casters and the G-buffer. Writes: the visibility buffer.

#![warn(missing_docs)]

pub mod analytic;
pub mod exact;
pub mod raycast;
pub mod traced;

use encase::{ShaderSize, ShaderType};
use softshadow_core::{
    glam::{Vec2, Vec3, Vec4},
    light_shape::SunView,
    pass::{FullscreenPass, Pass, Resource, Slot},
    scene::Fnv1a,
    shader::{DefValue, ShaderSpec},
    shader_file,
    shadow_map::{
        create_depth_maps, fit_caster_view, fit_hard_view, layer_view, DepthMapRenderer,
        ShadowViewUniform,
    },
    uniform::uniform_bytes,
    wgpu, AreaLight, Frame, Gpu, LightKind, Requirements, SceneGpu, ShadowInputs, ShadowTechnique,
    TechniqueError, TechniqueSettings, TechniqueStats, VisibilityBuffer,
};

mod info;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "reference";

/// The sun's orthographic sample views (accumulate.wgsl).
const SUN: (&str, DefValue) = ("SUN", DefValue::Bool(true));
/// A sphere's samples, each weighed by the silhouette disk it stands for (accumulate.wgsl).
const SPHERE: (&str, DefValue) = ("SPHERE", DefValue::Bool(true));

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "reference/accumulate.wgsl",
        source: shader_file!("reference/accumulate.wgsl").1,
        permutations: &[&[], &[SUN], &[SPHERE]],
    },
    ShaderSpec {
        path: "reference/resolve.wgsl",
        source: shader_file!("reference/resolve.wgsl").1,
        permutations: &[&[]],
    },
    traced::SHADER,
];

/// Depth maps per accumulation pass (`MAX_BATCH` in `accumulate.wgsl`).
const BATCH: u32 = 16;
/// Bytes per batch slot in the uniform buffer (dynamic offsets need 256-byte alignment).
const BATCH_SLOT: u64 = 2048;
/// Bytes of one batch's uniform (`BatchUniform`), the view the accumulation binds per slot.
const BATCH_UNIFORM_BYTES: u64 = BatchUniform::SHADER_SIZE.get();

softshadow_core::technique_settings! {
    /// Settings of the accumulated reference.
    pub struct ReferenceSettings {
        /// Light samples per axis (N x N depth maps, averaged)
        samples_per_axis: u32 = 32, in 1..=64;
        /// Edge of each depth map in texels
        shadow_map_size: u32 = 1024, in 64..=4096;
        /// Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes)
        bias_texels: f32 = 1.5, in 0.0..=16.0;
        /// Jitter each sample inside its stratum (deterministic, from `seed`)
        jitter: bool = true;
        /// Seed of the jitter
        seed: u32 = 1, in 0..=2147483647;
    }
}

/// Which answer [`exact_visibility`] gave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroundTruth {
    /// [`exact::visibility_image`]: every caster a rectangle parallel to the light.
    ClosedForm,
    /// [`analytic::light_seen_image`]: any opaque mesh under a light with area, no sampling.
    Analytic,
    /// [`raycast::visibility_image`] with this many light samples per axis.
    RayCast {
        /// Light samples per axis.
        samples_per_axis: u32,
    },
    /// [`traced::visibility_image`] (ray queries on the device) with this many light samples per
    /// axis.
    RayTraced {
        /// Light samples per axis.
        samples_per_axis: u32,
    },
}

impl std::fmt::Display for GroundTruth {
    /// `closed-form`, `analytic`, `raytraced(samples_per_axis=N)` or
    /// `raycast(samples_per_axis=N)`, as results.json records it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::ClosedForm => write!(f, "closed-form"),
            Self::Analytic => write!(f, "analytic"),
            Self::RayCast { samples_per_axis } => {
                write!(f, "raycast(samples_per_axis={samples_per_axis})")
            }
            Self::RayTraced { samples_per_axis } => {
                write!(f, "raytraced(samples_per_axis={samples_per_axis})")
            }
        }
    }
}

/// The exact visibility of each receiver pixel: the closed form where the scene has one, else the
/// analytic answer where the light has area, else the CPU ray cast with `samples_per_axis`²
/// light samples (1 at non-receivers, as all give).
pub fn exact_visibility(
    scene: &softshadow_core::Scene,
    positions: &[Option<softshadow_core::glam::Vec3>],
    receiver: &[bool],
    samples_per_axis: u32,
) -> (Vec<f32>, GroundTruth) {
    if let Some(v) = exact::visibility_image(scene, positions, receiver) {
        return (v, GroundTruth::ClosedForm);
    }
    match analytic::visibility_image(scene, positions, receiver) {
        Ok(v) => (v, GroundTruth::Analytic),
        Err(_) => (
            raycast::visibility_image(scene, positions, receiver, samples_per_axis),
            GroundTruth::RayCast { samples_per_axis },
        ),
    }
}

/// How [`exact_answer`] computes the exact answer where the closed form does not apply.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ExactMethod {
    /// Use the analytic answer ([`analytic`]) wherever the closed form does not apply and the
    /// light has area; `false` makes the sampled answers the exact answer (a cross-check).
    pub analytic: bool,
    /// Light samples per axis of the CPU ray cast ([`raycast`]): the fallback.
    pub raycast_samples_per_axis: u32,
    /// Light samples per axis of the ray-traced answer ([`traced`]), used when the device has ray
    /// queries; `None` never uses it.
    pub traced_samples_per_axis: Option<u32>,
}

impl ExactMethod {
    /// The sampled answer [`exact_answer`] gives on `gpu` where the closed form does not apply:
    /// [`GroundTruth::RayTraced`] when the device has ray queries and a traced sample count is
    /// set, else [`GroundTruth::RayCast`]. (A scene whose casters exceed the device's
    /// acceleration-structure limits still falls back to the ray cast; [`ExactAnswer::fallback`]
    /// says so.)
    pub fn sampled_on(&self, gpu: Option<&Gpu>) -> GroundTruth {
        match (self.traced_samples_per_axis, gpu) {
            (Some(samples_per_axis), Some(gpu))
                if gpu.features().contains(softshadow_core::accel::RAY_QUERY) =>
            {
                GroundTruth::RayTraced { samples_per_axis }
            }
            _ => GroundTruth::RayCast {
                samples_per_axis: self.raycast_samples_per_axis,
            },
        }
    }

    /// The method as text, for cache keys: the sampled answer on `gpu`, after `analytic, ` when
    /// the analytic answer is asked for (it is used wherever the light has area).
    pub fn key_on(&self, gpu: Option<&Gpu>) -> String {
        let sampled = self.sampled_on(gpu);
        if self.analytic {
            format!("analytic, else {sampled}")
        } else {
            sampled.to_string()
        }
    }
}

/// The exact irradiance per pixel ([`analytic::LightSeen`]), as form factors.
#[derive(Clone, Debug, PartialEq)]
pub struct ExactIrradiance {
    /// From the visible part of the light (0 off receivers).
    pub irradiance: Vec<f32>,
    /// From the whole light, as if nothing were in the way (0 off receivers and where the
    /// receiver faces away from all of the light).
    pub unoccluded: Vec<f32>,
}

/// An exact answer with what made it (see [`exact_answer`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ExactAnswer {
    /// Per-pixel visibility, row-major (1 at non-receivers).
    pub visibility: Vec<f32>,
    /// The method that gave it.
    pub truth: GroundTruth,
    /// Per-pixel standard-error estimate of a sampled answer (collapsed strata,
    /// [`raycast::visibility_and_error`]); all 0 for the closed form.
    pub standard_error: Vec<f32>,
    /// Why the ray-traced answer was asked for and not used (the ray cast was), if so.
    pub fallback: Option<String>,
    /// The exact irradiance, where the analytic answer applies and normals were given.
    pub irradiance: Option<ExactIrradiance>,
}

impl ExactAnswer {
    /// The answer's sampling error as results.json records it: the mean of the per-pixel
    /// standard-error estimate over the receiver pixels the answer shadows (`V < 1`, the pixels
    /// `mae_shadowed` averages over); 0 for the closed form or with no shadowed pixel, `None`
    /// when it cannot be estimated (one sample per axis).
    pub fn sampling_error(&self, receiver: &[bool]) -> Option<f64> {
        let mut sum = 0.0f64;
        let mut count = 0u64;
        for ((&v, &e), &r) in self
            .visibility
            .iter()
            .zip(&self.standard_error)
            .zip(receiver)
        {
            if r && v < 1.0 {
                if !e.is_finite() {
                    return None;
                }
                sum += e as f64;
                count += 1;
            }
        }
        Some(if count == 0 { 0.0 } else { sum / count as f64 })
    }
}

/// The exact visibility of each receiver pixel and how it was had: the closed form where every
/// caster is a rectangle parallel to the light; else, with `method.analytic` and a light with
/// area, the analytic answer ([`analytic`]); else, when `gpu` has ray queries and
/// `method.traced_samples_per_axis` is set, the ray-traced answer ([`traced`]); else (or when
/// tracing fails: [`ExactAnswer::fallback`] says why) the CPU ray cast ([`raycast`]). With
/// `method.analytic`, `normals` (world space, per pixel) and a light with area, the exact
/// irradiance too ([`ExactAnswer::irradiance`]). `control` follows the analytic answer and can
/// cancel it: `Err` only then.
pub fn exact_answer(
    gpu: Option<&Gpu>,
    scene: &softshadow_core::Scene,
    positions: &[Option<softshadow_core::glam::Vec3>],
    normals: Option<&[softshadow_core::glam::Vec3]>,
    receiver: &[bool],
    method: ExactMethod,
    control: Option<&softshadow_core::BuildControl>,
) -> Result<ExactAnswer, analytic::AnalyticError> {
    if method.analytic {
        match analytic_answer(scene, positions, normals, receiver, control) {
            Err(
                analytic::AnalyticError::NoArea { .. }
                | analytic::AnalyticError::MaskedCasters { .. }
                | analytic::AnalyticError::NotRect { .. },
            ) => {}
            answer => return answer,
        }
    }
    if let Some(visibility) = exact::visibility_image(scene, positions, receiver) {
        let standard_error = vec![0.0; visibility.len()];
        return Ok(ExactAnswer {
            visibility,
            truth: GroundTruth::ClosedForm,
            standard_error,
            fallback: None,
            irradiance: None,
        });
    }
    Ok(sampled_answer(gpu, scene, positions, receiver, method))
}

/// The analytic answer ([`analytic::light_seen_image`]) as an [`ExactAnswer`]: the closed
/// form's visibility where it applies (equal within 1e-9, and the fast path it always was), the
/// exact irradiance where `normals` are given. `Err` when the light has no area or `control`
/// cancelled it.
pub fn analytic_answer(
    scene: &softshadow_core::Scene,
    positions: &[Option<softshadow_core::glam::Vec3>],
    normals: Option<&[softshadow_core::glam::Vec3]>,
    receiver: &[bool],
    control: Option<&softshadow_core::BuildControl>,
) -> Result<ExactAnswer, analytic::AnalyticError> {
    let seen = analytic::light_seen_image(scene, positions, normals, receiver, control)?;
    let irradiance = normals.is_some().then(|| ExactIrradiance {
        irradiance: seen.iter().map(|s| s.irradiance as f32).collect(),
        unoccluded: seen.iter().map(|s| s.unoccluded as f32).collect(),
    });
    let (visibility, truth) = match exact::visibility_image(scene, positions, receiver) {
        Some(v) => (v, GroundTruth::ClosedForm),
        None => (
            seen.iter().map(|s| s.visibility as f32).collect(),
            GroundTruth::Analytic,
        ),
    };
    Ok(ExactAnswer {
        standard_error: vec![0.0; visibility.len()],
        visibility,
        truth,
        fallback: None,
        irradiance,
    })
}

/// The sampled exact answer: ray-traced on a device with ray queries when asked for, else (or
/// when tracing fails) the CPU ray cast.
fn sampled_answer(
    gpu: Option<&Gpu>,
    scene: &softshadow_core::Scene,
    positions: &[Option<softshadow_core::glam::Vec3>],
    receiver: &[bool],
    method: ExactMethod,
) -> ExactAnswer {
    let mut fallback = None;
    if let (GroundTruth::RayTraced { samples_per_axis }, Some(gpu)) = (method.sampled_on(gpu), gpu)
    {
        match traced::visibility_image_and_error(gpu, scene, positions, receiver, samples_per_axis)
        {
            Ok((visibility, standard_error)) => {
                return ExactAnswer {
                    visibility,
                    truth: GroundTruth::RayTraced { samples_per_axis },
                    standard_error,
                    fallback: None,
                    irradiance: None,
                }
            }
            Err(e) => {
                fallback = Some(format!(
                    "the ray-traced exact answer failed ({e}): the CPU ray cast with {n} x {n} samples was used instead",
                    n = method.raycast_samples_per_axis
                ))
            }
        }
    }
    let samples_per_axis = method.raycast_samples_per_axis;
    let (visibility, standard_error) =
        raycast::visibility_image_and_error(scene, positions, receiver, samples_per_axis);
    ExactAnswer {
        visibility,
        truth: GroundTruth::RayCast { samples_per_axis },
        standard_error,
        fallback,
        irradiance: None,
    }
}

/// Stratified sample positions on the light, light-space `(u, v)` (row-major): on the
/// rectangle, or on the disk of a disk or spot light (the strata through the concentric map).
/// A sphere's and the sun's samples are the strata of the unit square: points of the sphere's
/// surface ([`sphere_point`], [`sphere_view`]) or directions of the sun's cone
/// ([`AreaLight::sample`], [`sun_view`]).
pub fn light_samples(settings: &ReferenceSettings, light: &AreaLight) -> Vec<Vec2> {
    let jitter_seed = settings
        .jitter
        .then_some(settings.seed as u64 ^ 0x9e37_79b9_7f4a_7c15);
    let n = settings.samples_per_axis.max(1);
    match light.kind {
        LightKind::Rect => stratified_samples(n, light.half_extent(), jitter_seed).collect(),
        LightKind::Disk | LightKind::Spot => stratified_unit(n, jitter_seed)
            .map(|u| softshadow_core::light_shape::concentric_disk(u) * light.radius)
            .collect(),
        LightKind::Sphere | LightKind::Sun => stratified_unit(n, jitter_seed).collect(),
    }
}

/// The orthographic depth view of the sun sample `u` (a point of the unit square; the direction
/// toward the sun [`AreaLight::sample`] gives for it), fitted to the casters and receivers, in
/// the form accumulate.wgsl's `SUN` reads: `light_view_proj` its world-to-clip,
/// `eye_near_far.xyz` the unit direction toward the sun and `.w` the depth range, `window.x` the
/// texel edge in world units. `None` without casters.
pub fn sun_view(
    scene: &SceneGpu,
    light: &AreaLight,
    u: Vec2,
    size: u32,
) -> Option<ShadowViewUniform> {
    if scene.caster_bounds.is_empty() {
        return None;
    }
    let to_sun = light.sample(u, Vec3::ZERO).to_light.normalize();
    let along = AreaLight {
        direction: -to_sun,
        ..*light
    };
    let mut points = scene.caster_bounds.corners().to_vec();
    if !scene.receiver_bounds.is_empty() {
        points.extend(scene.receiver_bounds.corners());
    }
    let view = SunView::fit(&along, &points)?;
    let n = size as f32;
    Some(ShadowViewUniform {
        light_view_proj: view.view_projection(),
        window: Vec4::new(view.texel_size(size), 0.0, 0.0, 0.0),
        eye_near_far: to_sun.extend(view.far - view.near),
        size: Vec4::new(n, n, 1.0 / n, 1.0 / n),
    })
}

/// The point of the unit sphere that `u` (the unit square) maps to, uniform in area
/// (z = 1 - 2 u.x, the angle around z 2 pi u.y).
pub fn sphere_point(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let ring = (1.0 - z * z).max(0.0).sqrt();
    let angle = std::f32::consts::TAU * u.y;
    Vec3::new(ring * angle.cos(), ring * angle.sin(), z)
}

/// The depth view from the point of a sphere light's surface that `u` stands for
/// ([`sphere_point`], light space) and that point's light-space z: the view from the point's
/// `(x, y)` of the light plane moved along the light's axis to its z. accumulate.wgsl (`SPHERE`)
/// weighs each sample by the silhouette disk it stands for at each receiver.
pub fn sphere_view(
    scene: &SceneGpu,
    light: &AreaLight,
    u: Vec2,
    size: u32,
) -> (Option<ShadowViewUniform>, f32) {
    let eye = sphere_point(u) * light.radius;
    let (_, _, axis) = light.basis();
    let moved = AreaLight {
        center: light.center + axis * eye.z,
        ..*light
    };
    let view = sample_view(scene, &moved, eye.truncate())
        .map(|frustum| ShadowViewUniform::new(&moved, &frustum, size));
    (view, eye.z)
}

/// The depth views of a reference's light samples and the light-space z of each view's eye
/// (0 but for a sphere's samples).
#[derive(Default)]
struct SampleViews {
    views: Vec<ShadowViewUniform>,
    eye_depths: Vec<f32>,
}

/// The depth views of the light samples `samples` taken in `order` (indices into them):
/// perspective views from points of the light plane (a sphere's: of the plane moved to each
/// point, [`sphere_view`]), or under the sun orthographic views along directions of its cone
/// ([`sun_view`]).
fn sample_views(
    inputs: &ShadowInputs<'_>,
    samples: &[Vec2],
    order: impl Iterator<Item = usize>,
    size: u32,
) -> SampleViews {
    let (scene, light) = (inputs.scene, inputs.light);
    let mut out = SampleViews::default();
    for k in order {
        let (view, eye_depth) = match light.kind {
            LightKind::Sun => (sun_view(scene, light, samples[k], size), 0.0),
            LightKind::Sphere => sphere_view(scene, light, samples[k], size),
            _ => (
                sample_view(scene, light, samples[k])
                    .map(|frustum| ShadowViewUniform::new(light, &frustum, size)),
                0.0,
            ),
        };
        if let Some(view) = view {
            out.views.push(view);
            out.eye_depths.push(eye_depth);
        }
    }
    out
}

/// `n x n` stratified points on the rectangle `[-half.x, half.x] x [-half.y, half.y]`, row-major.
/// With `jitter_seed` each point is jittered inside its stratum (deterministically, two draws per
/// point, u then v); without it, points sit at the strata centres. Shared by the accumulated and
/// the ray-cast references.
pub(crate) fn stratified_samples(
    n: u32,
    half: Vec2,
    jitter_seed: Option<u64>,
) -> impl Iterator<Item = Vec2> {
    let mut rng = jitter_seed.map(SplitMix64);
    (0..n * n).map(move |k| {
        let (i, j) = (k % n, k / n);
        let (ju, jv) = match rng.as_mut() {
            Some(rng) => (rng.next_f32(), rng.next_f32()),
            None => (0.5, 0.5),
        };
        let u = ((i as f32 + ju) / n as f32) * 2.0 - 1.0;
        let v = ((j as f32 + jv) / n as f32) * 2.0 - 1.0;
        Vec2::new(u * half.x, v * half.y)
    })
}

/// `n x n` stratified points of the unit square `[0, 1)^2`, row by row, jittered inside their
/// strata when `jitter_seed` is given (else the strata centres): what `AreaLight::sample`
/// (softshadow_core) maps onto each light shape.
pub(crate) fn stratified_unit(n: u32, jitter_seed: Option<u64>) -> impl Iterator<Item = Vec2> {
    let mut rng = jitter_seed.map(SplitMix64);
    (0..n * n).map(move |k| {
        let (i, j) = (k % n, k / n);
        let (ju, jv) = match rng.as_mut() {
            Some(rng) => (rng.next_f32(), rng.next_f32()),
            None => (0.5, 0.5),
        };
        Vec2::new((i as f32 + ju) / n as f32, (j as f32 + jv) / n as f32)
    })
}

/// Small deterministic generator for the jitter (splitmix64).
pub(crate) struct SplitMix64(pub(crate) u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
}

#[derive(ShaderType)]
struct BatchUniform {
    count_bias: Vec4,
    views: [ShadowViewUniform; BATCH as usize],
    eye_depths: [Vec4; BATCH as usize / 4],
}

/// This crate's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    let mut mirrors = vec![softshadow_core::uniform_mirror!(
        BatchUniform { count_bias, views, eye_depths } => "reference/accumulate.wgsl", Batch
    )];
    mirrors.extend(traced::uniform_mirrors());
    mirrors
}

struct Cached {
    key: u64,
    texture: wgpu::Texture,
}

/// The `reference` technique: accumulated hard shadows, with its settings.
pub struct Reference {
    /// Its settings; changes take effect on the next frame.
    pub settings: ReferenceSettings,
    depth: DepthMapRenderer,
    accumulate: FullscreenPass,
    /// The same over the sun's orthographic views (`SUN`).
    accumulate_sun: FullscreenPass,
    /// The same from points of a sphere, weighed (`SPHERE`).
    accumulate_sphere: FullscreenPass,
    resolve: FullscreenPass,
    batches: wgpu::Buffer,
    batch_capacity: u32,
    maps: Option<(u32, wgpu::Texture)>,
    cache: Option<Cached>,
    stats: TechniqueStats,
    /// Batches of [`BATCH`] light samples added per `render` in progressive mode (the viewer);
    /// `None` computes the whole reference in one frame (the benchmark).
    batches_per_frame: Option<u32>,
    progress: Option<InProgress>,
}

/// How far a progressive reference has come: `done` of `total` light samples accumulated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Progress {
    /// Light samples accumulated so far.
    pub done: u32,
    /// Light samples in all.
    pub total: u32,
}

impl Progress {
    /// Every sample has been accumulated.
    pub fn is_complete(&self) -> bool {
        self.done >= self.total
    }

    /// Fraction done, 0 to 1 (1 when there is nothing to do).
    pub fn fraction(&self) -> f32 {
        if self.total == 0 {
            1.0
        } else {
            self.done as f32 / self.total as f32
        }
    }
}

/// A reference being accumulated over several frames.
struct InProgress {
    key: u64,
    /// Depth views in accumulation order (strata interleaved, so partial sums cover the light).
    views: SampleViews,
    light_samples: usize,
    done: usize,
    sums: WeightSums,
    result: VisibilityBuffer,
}

impl Reference {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: ReferenceSettings) -> Result<Self, TechniqueError> {
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let blend = wgpu::BlendState {
            color: add,
            alpha: add,
        };
        let requirements = Self::requirements_static();
        softshadow_core::technique::check_requirements(gpu, ID, &requirements)?;
        let accumulate = |defs: &[(&str, DefValue)]| {
            Pass::new(gpu, "reference/accumulate", &SHADERS[0])
                .defs(defs)
                .after_frame_group()
                .slot(Slot::DynamicUniform {
                    size: BATCH_UNIFORM_BYTES,
                })
                .texture(Slot::DEPTH_ARRAY)
                .fullscreen_into(WeightSums::FORMAT, Some(blend))
        };
        Ok(Self {
            depth: DepthMapRenderer::new(gpu)?,
            // accumulate.wgsl: one batch's views (a slot of `batches`), its depth maps.
            accumulate: accumulate(&[])?,
            accumulate_sun: accumulate(&[SUN])?,
            accumulate_sphere: accumulate(&[SPHERE])?,
            // resolve.wgsl: the summed weights.
            resolve: Pass::new(gpu, "reference/resolve", &SHADERS[1])
                .after_frame_group()
                .texture(Slot::FLOAT)
                .fullscreen(None)?,
            batches: Self::batch_buffer(gpu, 4),
            batch_capacity: 4,
            settings,
            maps: None,
            cache: None,
            stats: TechniqueStats::new(),
            batches_per_frame: None,
            progress: None,
        })
    }

    pub(crate) fn requirements_static() -> Requirements {
        Requirements {
            // Summing per-batch weights into an Rg32Float target by additive blending.
            features: wgpu::Features::FLOAT32_BLENDABLE,
            ..Requirements::default()
        }
    }

    fn batch_buffer(gpu: &Gpu, capacity: u32) -> wgpu::Buffer {
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("reference/batches"),
            size: BATCH_SLOT * capacity as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    fn cache_key(&self, inputs: &ShadowInputs<'_>) -> u64 {
        let mut h = Fnv1a::default();
        h.write_u64(inputs.scene.content_hash);
        h.write_u64(inputs.light.content_hash());
        // The camera as the frame sees it (a host renderer has no workbench `Camera`).
        h.write_f32s(&inputs.uniforms.view_proj.to_cols_array());
        h.write_f32s(&inputs.uniforms.camera_pos.to_array());
        h.write_u64(inputs.width as u64 | (inputs.height as u64) << 32);
        for (_, v) in self.params().entries {
            h.write_str(&v.to_string());
        }
        h.finish()
    }

    /// Forgets the cached result (the next frame recomputes).
    pub fn invalidate(&mut self) {
        self.cache = None;
        self.progress = None;
    }

    /// Progressive mode for interactive use: each `render` adds at most `batches` batches of
    /// 16 light samples to a running sum and resolves the average of the samples summed so far,
    /// so a viewer shows a converging reference without stalling. `None` (the default) computes
    /// everything in one frame. The finished result is bit-identical either way (whole-number
    /// counts) and cached the same way.
    pub fn set_progressive(&mut self, batches: Option<u32>) {
        self.batches_per_frame = batches.map(|b| b.max(1));
    }

    /// Progress of the reference for the inputs of the last `render`: complete when it was
    /// served from the cache or finished in that frame.
    pub fn progress(&self) -> Progress {
        match &self.progress {
            Some(p) => Progress {
                done: p.done as u32,
                total: p.views.views.len() as u32,
            },
            None => {
                let total = self.stats.get("depth_maps").copied().unwrap_or(0.0) as u32;
                Progress { done: total, total }
            }
        }
    }

    /// The finished reference for `inputs`, if it is cached (no GPU work).
    pub fn is_cached_for(&self, inputs: &ShadowInputs<'_>) -> bool {
        let key = self.cache_key(inputs);
        self.cache.as_ref().is_some_and(|c| c.key == key)
    }
}

impl ShadowTechnique for Reference {
    fn id(&self) -> &str {
        ID
    }

    fn requirements(&self) -> Requirements {
        Self::requirements_static()
    }

    fn settings(&self) -> &dyn TechniqueSettings {
        &self.settings
    }

    fn settings_mut(&mut self) -> &mut dyn TechniqueSettings {
        &mut self.settings
    }

    fn render(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
    ) -> Result<(), TechniqueError> {
        let gpu = frame.gpu;
        let key = self.cache_key(inputs);
        if let Some(cached) = self.cache.as_ref().filter(|c| c.key == key) {
            out.copy_from(frame.encoder, &cached.texture);
            frame.note_pass("reference/cached_copy");
            self.stats.insert("cached".into(), 1.0);
            return Ok(());
        }
        if let Some(batches) = self.batches_per_frame {
            return self.render_progressive(frame, inputs, out, key, batches);
        }
        self.progress = None;
        let samples = light_samples(&self.settings, inputs.light);
        let size = self.settings.shadow_map_size;
        let views = sample_views(inputs, &samples, 0..samples.len(), size);
        let result = VisibilityBuffer::new(gpu, "reference/result", inputs.width, inputs.height);
        if views.views.is_empty() {
            // No caster in front of the light: receivers in front of it are lit, no depth map.
            result.write_unshadowed(frame, inputs.frame_bind_group, "reference/no_casters")?;
        } else {
            let sums = WeightSums::new(gpu, inputs.width, inputs.height);
            self.accumulate_views(frame, inputs, &views, 0..views.views.len(), &sums);
            self.resolve_sums(frame, inputs, &sums, &result);
        }
        out.copy_from(frame.encoder, &result.texture);
        self.stats = TechniqueStats::from([
            ("cached".into(), 0.0),
            ("light_samples".into(), samples.len() as f64),
            ("depth_maps".into(), views.views.len() as f64),
        ]);
        self.cache = Some(Cached {
            key,
            texture: result.texture,
        });
        Ok(())
    }

    fn invalidate_cache(&mut self) {
        self.invalidate();
    }

    fn stats(&self) -> TechniqueStats {
        self.stats.clone()
    }
}

impl Reference {
    /// One step of progressive accumulation (see [`Reference::set_progressive`]).
    fn render_progressive(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
        key: u64,
        batches: u32,
    ) -> Result<(), TechniqueError> {
        let gpu = frame.gpu;
        if self.progress.as_ref().map(|p| p.key) != Some(key) {
            let samples = light_samples(&self.settings, inputs.light);
            let size = self.settings.shadow_map_size;
            let order = interleaved(self.settings.samples_per_axis);
            let views = sample_views(inputs, &samples, order, size);
            self.progress = Some(InProgress {
                key,
                views,
                light_samples: samples.len(),
                done: 0,
                sums: WeightSums::new(gpu, inputs.width, inputs.height),
                result: VisibilityBuffer::new(gpu, "reference/result", inputs.width, inputs.height),
            });
        }
        let mut progress = self.progress.take().expect("set above");
        if progress.views.views.is_empty() {
            progress.result.write_unshadowed(
                frame,
                inputs.frame_bind_group,
                "reference/no_casters",
            )?;
        } else {
            let start = progress.done;
            let end = (start + (batches * BATCH) as usize).min(progress.views.views.len());
            self.accumulate_views(frame, inputs, &progress.views, start..end, &progress.sums);
            progress.done = end;
            self.resolve_sums(frame, inputs, &progress.sums, &progress.result);
        }
        out.copy_from(frame.encoder, &progress.result.texture);
        let complete = progress.done >= progress.views.views.len();
        self.stats = TechniqueStats::from([
            ("cached".into(), 0.0),
            ("light_samples".into(), progress.light_samples as f64),
            ("depth_maps".into(), progress.views.views.len() as f64),
            ("depth_maps_done".into(), progress.done as f64),
        ]);
        if complete {
            self.cache = Some(Cached {
                key,
                texture: progress.result.texture,
            });
        } else {
            self.progress = Some(progress);
        }
        Ok(())
    }

    /// Adds the weights of the views `range` of `views` to `sums` (cleared first when the range
    /// starts at the first view).
    fn accumulate_views(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        views: &SampleViews,
        range: std::ops::Range<usize>,
        sums: &WeightSums,
    ) {
        let gpu = frame.gpu;
        let clear = range.start == 0;
        let (eye_depths, views) = (&views.eye_depths[range.clone()], &views.views[range]);
        let size = self.settings.shadow_map_size;
        if self.maps.as_ref().map(|m| m.0) != Some(size) {
            self.maps = Some((
                size,
                create_depth_maps(gpu, "reference/depth_maps", size, BATCH),
            ));
        }
        let batch_count = self.write_batches(gpu, inputs.light, views, eye_depths);
        self.depth.set_views(gpu, views);

        let (_, maps) = self.maps.as_ref().expect("created above");
        let layer_views: Vec<wgpu::TextureView> = (0..BATCH).map(|l| layer_view(maps, l)).collect();
        let array_view = maps.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        for b in 0..batch_count {
            let first = b * BATCH;
            let count = (views.len() as u32 - first).min(BATCH);
            for layer in 0..count {
                self.depth.record(
                    frame,
                    "reference/depth",
                    inputs.scene,
                    first + layer,
                    &layer_views[layer as usize],
                );
            }
            let batch = Resource::BufferRange(&self.batches, 0, BATCH_UNIFORM_BYTES);
            let pass = match inputs.light.kind {
                LightKind::Sun => &self.accumulate_sun,
                LightKind::Sphere => &self.accumulate_sphere,
                _ => &self.accumulate,
            };
            pass.run(frame)
                .frame_group(inputs.frame_bind_group)
                .read(batch)
                .read(&array_view)
                .offsets(&[(b as u64 * BATCH_SLOT) as u32])
                .draw(&sums.view, if b == 0 && clear { Some(0.0) } else { None });
        }
    }

    /// Writes one batch uniform per [`BATCH`] views into `batches` (grown as needed) and returns
    /// how many. All are written before the frame is submitted, so each batch (and each depth
    /// view) gets its own slot.
    fn write_batches(
        &mut self,
        gpu: &Gpu,
        light: &AreaLight,
        views: &[ShadowViewUniform],
        eye_depths: &[f32],
    ) -> u32 {
        let batch_count = views.len().div_ceil(BATCH as usize) as u32;
        if batch_count > self.batch_capacity {
            self.batch_capacity = batch_count.next_power_of_two();
            self.batches = Self::batch_buffer(gpu, self.batch_capacity);
        }
        let mut bytes = vec![0u8; (BATCH_SLOT * batch_count as u64) as usize];
        let batches = views
            .chunks(BATCH as usize)
            .zip(eye_depths.chunks(BATCH as usize));
        for (b, (chunk, depths)) in batches.enumerate() {
            let mut uniform = BatchUniform {
                count_bias: Vec4::new(
                    chunk.len() as f32,
                    self.settings.bias_texels,
                    light.radius,
                    0.0,
                ),
                views: [ShadowViewUniform::ZERO; BATCH as usize],
                eye_depths: [Vec4::ZERO; BATCH as usize / 4],
            };
            uniform.views[..chunk.len()].copy_from_slice(chunk);
            for (i, depth) in depths.iter().enumerate() {
                uniform.eye_depths[i / 4][i % 4] = *depth;
            }
            let uniform = uniform_bytes(&uniform);
            let at = b * BATCH_SLOT as usize;
            bytes[at..at + uniform.len()].copy_from_slice(&uniform);
        }
        gpu.queue.write_buffer(&self.batches, 0, &bytes);
        batch_count
    }

    /// Writes `sums.r / sums.g` (0 behind the light, 1 off receivers) into `result`.
    fn resolve_sums(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        sums: &WeightSums,
        result: &VisibilityBuffer,
    ) {
        self.resolve
            .run(frame)
            .frame_group(inputs.frame_bind_group)
            .read(&sums.view)
            .draw(&result.view, Some(1.0));
    }
}

/// Per pixel, the summed weights of the light samples that see it (`r`) and of all (`g`): for
/// every kind but the sphere a sample weighs 1, so these are counts.
struct WeightSums {
    view: wgpu::TextureView,
}

impl WeightSums {
    const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;

    fn new(gpu: &Gpu, width: u32, height: u32) -> Self {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let texture = softshadow_core::gbuffer::create_texture(
            gpu,
            "reference/weight_sums",
            width,
            height,
            Self::FORMAT,
            usage,
        );
        Self {
            view: texture.create_view(&Default::default()),
        }
    }
}

/// The depth-map window of the light sample `eye`: clipped to the receivers' slopes (a hard
/// shadow map; keeps its texels where receivers are when casters subtend a huge angle, as next
/// to the light). When no caster can shadow a receiver through `eye` the clipped window is
/// empty; the caster window then serves (every receiver is outside it, so lit), keeping one
/// view per sample so the resolve divides by the right count. `None` only without casters.
fn sample_view(
    scene: &softshadow_core::SceneGpu,
    light: &softshadow_core::AreaLight,
    eye: Vec2,
) -> Option<softshadow_core::SlopeFrustum> {
    fit_hard_view(scene, light, eye).or_else(|| fit_caster_view(scene, light, eye))
}

/// Indices of the `n x n` row-major strata in an order whose every prefix is spread over the
/// whole light: strata sorted by their bit-reversed Morton code, so the first 4 lie in the four
/// quadrants, the first 16 in the 16 sub-quadrants, and so on. A partial progressive sum is then a
/// coarse estimate of the full one, not the average over one edge of the light.
fn interleaved(n: u32) -> impl Iterator<Item = usize> {
    let bits = n.max(1).next_power_of_two().trailing_zeros();
    let key = move |k: u32| -> u64 {
        let (i, j) = (k % n, k / n);
        let mut morton = 0u64;
        for bit in 0..bits {
            morton |= (((i >> bit) & 1) as u64) << (2 * bit);
            morton |= (((j >> bit) & 1) as u64) << (2 * bit + 1);
        }
        if bits == 0 {
            0
        } else {
            morton.reverse_bits() >> (64 - 2 * bits)
        }
    };
    let mut order: Vec<u32> = (0..n * n).collect();
    order.sort_by_key(|&k| key(k));
    order.into_iter().map(|k| k as usize)
}

#[cfg(test)]
mod progressive_tests {
    use super::*;

    #[test]
    fn interleaved_order_visits_every_stratum_once_and_spreads_prefixes() {
        for n in [1, 2, 3, 7, 16, 32] {
            let mut all: Vec<usize> = interleaved(n).collect();
            assert_eq!(all.len(), (n * n) as usize);
            all.sort_unstable();
            all.dedup();
            assert_eq!(all.len(), (n * n) as usize, "n = {n}");
        }
        // The first 4 of 16 x 16 strata lie in different quadrants of the light.
        let first: Vec<(usize, usize)> =
            interleaved(16).take(4).map(|k| (k % 16, k / 16)).collect();
        let quadrants: std::collections::BTreeSet<(bool, bool)> =
            first.iter().map(|&(i, j)| (i < 8, j < 8)).collect();
        assert_eq!(quadrants.len(), 4, "{first:?}");
    }
}

#[cfg(test)]
mod ground_truth_tests {
    use super::*;
    use softshadow_core::glam::Vec3;

    /// The labels results.json records, and the choice between the two answers.
    #[test]
    fn exact_visibility_names_the_answer_it_gave() {
        assert_eq!(GroundTruth::ClosedForm.to_string(), "closed-form");
        assert_eq!(
            GroundTruth::RayCast {
                samples_per_axis: 16
            }
            .to_string(),
            "raycast(samples_per_axis=16)"
        );
        assert_eq!(GroundTruth::Analytic.to_string(), "analytic");
        // atty-square's caster is a square parallel to the light: closed form. The balls are
        // not: analytic; under a point light (no area): ray cast. Each at one ground point under
        // the scene's caster and one far outside.
        for (id, point_light, expected) in [
            ("atty-square", false, GroundTruth::ClosedForm),
            ("balls-3x3x3", false, GroundTruth::Analytic),
            (
                "balls-3x3x3",
                true,
                GroundTruth::RayCast {
                    samples_per_axis: 4,
                },
            ),
        ] {
            let mut scene = softshadow_scenes::builtin(id, &[]).unwrap();
            if point_light {
                (scene.light.width, scene.light.height) = (0.0, 0.0);
            }
            let positions = [
                Some(Vec3::new(0.0, 0.0, 0.0)),
                Some(Vec3::new(1e4, 0.0, 1e4)),
            ];
            let (v, truth) = exact_visibility(&scene, &positions, &[true, true], 4);
            assert_eq!(truth, expected, "{id}");
            assert!(v[0] < 1.0 && v[1] == 1.0, "{id}: {v:?}");
        }
    }

    /// Without a device `exact_answer` gives the closed form or the ray cast (never the traced
    /// answer), with a sampling error of 0 for the closed form and a positive one for the ray
    /// cast's penumbra; the sampled method it would use needs ray queries on a device.
    #[test]
    fn exact_answer_without_a_device_and_its_sampling_error() {
        let method = ExactMethod {
            analytic: false,
            raycast_samples_per_axis: 8,
            traced_samples_per_axis: Some(32),
        };
        assert_eq!(
            method.sampled_on(None),
            GroundTruth::RayCast {
                samples_per_axis: 8
            }
        );
        let positions = [
            Some(Vec3::new(0.0, 0.0, 0.0)),
            Some(Vec3::new(1e4, 0.0, 1e4)),
        ];
        let square = softshadow_scenes::builtin("atty-square", &[]).unwrap();
        let closed =
            exact_answer(None, &square, &positions, None, &[true, true], method, None).unwrap();
        assert_eq!(closed.truth, GroundTruth::ClosedForm);
        assert_eq!(closed.sampling_error(&[true, true]), Some(0.0));
        let blob = softshadow_scenes::builtin("blob-floating", &[]).unwrap();
        // Ground points across the blob's penumbra.
        let ground: Vec<Option<Vec3>> = (0..64)
            .map(|i| Some(Vec3::new(-1.5 + 3.0 * i as f32 / 63.0, 0.0, 0.0)))
            .collect();
        let mask = vec![true; ground.len()];
        let cast = exact_answer(None, &blob, &ground, None, &mask, method, None).unwrap();
        assert_eq!(cast.truth, method.sampled_on(None));
        assert!(cast.fallback.is_none());
        let error = cast.sampling_error(&mask).unwrap();
        assert!(error > 0.0 && error < 0.1, "{error}");
    }
}
