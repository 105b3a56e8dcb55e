//! `pdsm`: penumbra deep shadow maps (St-Amour, Paquette & Poulin 2005).
//!
//! Precompute (section 3, Algorithm 1), for the static casters only: k stratified samples on the
//! light, one shadow map per sample parallel to the light plane, rendered on the GPU and read
//! back once; then, on the CPU with rayon over PDSM rows, every PDSM texel's ray (from the light
//! centre) scan-converted in every map into +-1/k events, summed into one attenuation function,
//! merged and compressed piecewise-linearly (section 3.2). The result goes to two storage
//! buffers (Fig. 6) and to a versioned file in the cache folder ([`cache`]), keyed by the static
//! geometry, the light and the build parameters, so a second run loads it.
//!
//! Per frame (section 4): one fullscreen pass evaluates the four nearest texels' functions at the
//! pixel's depth and filters bilinearly; instances marked `dynamic` are not in the precompute and
//! shadow through a per-frame PCF map of the dynamic casters, multiplied in (section 5).
//!
//! Watching and cancelling a build: [`Pdsm::build_control`] hands out the cancel flag and
//! the row counter (`done` of `pdsm_size` rows) a viewer or CLI can poll from another thread, or
//! [`ShadowTechnique::set_build_control`] installs the caller's. With
//! [`ShadowTechnique::set_background_build`] the CPU construction runs on a thread of its own and
//! `render` fails with [`TechniqueError::Building`] until it is done (the viewer); without it
//! (the default, the benchmark) it runs inside `render` and counts in that frame's cost.

#![warn(missing_docs)]

pub mod build;
pub mod cache;
pub mod function;

use std::{
    path::PathBuf,
    sync::atomic::Ordering,
    time::{Duration, Instant},
};

use encase::ShaderType;
use softshadow_core::{
    background::BackgroundJob,
    fullscreen::{FullscreenPipeline, STENCIL_FORMAT},
    glam::{Vec2, Vec3, Vec4},
    light_shape::concentric_disk,
    pass::{PassGroup, Slot},
    scene::{Aabb, Fnv1a},
    shader::{DefValue, ShaderSpec},
    shader_file,
    shadow_map::{fit_caster_view, DepthMapRenderer, ShadowViewUniform, SHADOW_DEPTH_FORMAT},
    uniform::{uniform_bytes, zeroed_uniform_buffer},
    wgpu::{self, util::DeviceExt},
    AreaLight, BuildControl, DebugLegend, DebugView, Frame, Gpu, GpuError, LightKind, ShadowInputs,
    ShadowTechnique, SlopeFrustum, TechniqueError, TechniqueSettings, TechniqueStats,
    VisibilityBuffer,
};

pub use build::{BuildStats, PdsmData};

mod info;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "pdsm";

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[ShaderSpec {
    path: "pdsm/evaluate.wgsl",
    source: shader_file!("pdsm/evaluate.wgsl").1,
    permutations: &[
        &[],
        &[("DYNAMIC", DefValue::Bool(true))],
        &[("ENDS_PASS", DefValue::Bool(true))],
        &[
            ("ENDS_PASS", DefValue::Bool(true)),
            ("DYNAMIC", DefValue::Bool(true)),
        ],
    ],
}];

softshadow_core::technique_settings! {
    /// Settings of penumbra deep shadow maps.
    pub struct PdsmSettings {
        /// Light samples k of the precompute (one shadow map each, stratified over the light)
        samples: u32 = 64, in 1..=1024 log;
        /// PDSM edge in texels (one attenuation function per texel)
        pdsm_size: u32 = 256, in 16..=2048 log;
        /// Edge in texels of each light sample's shadow map
        shadow_map_size: u32 = 512, in 64..=4096 log;
        /// Largest visibility error the piecewise-linear compression may add
        compression_error: f32 = 0.02, in 0.0..=0.5;
        /// Depth bias in light-sample map texel footprints, times 1 + the receiver's slope (tan of its angle to the light), at most 2 % of the depth
        bias_texels: f32 = 0.5, in 0.0..=16.0;
        /// Edge in texels of the per-frame shadow map of the dynamic casters
        dynamic_map_size: u32 = 1024, in 64..=4096 log;
        /// PCF kernel radius in texels for the dynamic casters (kernel (2r+1)²)
        pcf_radius: u32 = 2, in 0..=8;
        /// Memory the precompute may use, MiB (read-back maps plus the PDSM); a larger estimate fails before building
        memory_budget_mib: u32 = 2048, in 16..=65536 log;
        /// Load and store built PDSMs in the cache folder (SOFTSHADOW_CACHE_DIR, else $XDG_CACHE_HOME/softshadow or ~/.cache/softshadow)
        disk_cache: bool = true;
        /// Depth of the `attenuation_at_depth` debug view, as a fraction of the PDSM's depth range
        debug_depth: f32 = 0.5, in 0.0..=1.0;
    }
}

/// Name of the debug view of the static casters seen from the light centre.
const CENTRE_MAP_VIEW: &str = "shadow_map";
/// Seed of the jitter inside the light strata (fixed: the same inputs build the same PDSM).
const JITTER_SEED: u64 = 0x5d5_2005;
/// Most sample-map texels a background build renders and reads back per frame (two 512² maps):
/// the caller's thread waits for them, so a frame of the viewer stays well under 0.1 s.
const MAP_TEXELS_PER_FRAME: u64 = 1 << 19;
/// Most bytes of read-back maps per GPU round trip.
const READBACK_BATCH_BYTES: u64 = 64 << 20;
/// Compressed vertices per texel assumed by the memory estimate before building (the paper's
/// park scene averages 5 events after compression, 40 at most, section 5).
const ESTIMATED_VERTICES_PER_TEXEL: u64 = 16;

#[derive(ShaderType)]
struct PdsmParams {
    window: Vec4,
    size_bias: Vec4,
    dynamic_map_texel: Vec4,
}

/// This crate's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![softshadow_core::uniform_mirror!(
        PdsmParams { window, size_bias, dynamic_map_texel } => "pdsm/evaluate.wgsl", PdsmParams
    )]
}

/// A built (or loaded) PDSM on the GPU.
struct Kept {
    key: u64,
    data: PdsmData,
    offsets: wgpu::Buffer,
    vertices: wgpu::Buffer,
    /// Each texel's last and first vertex, and its longest segment (`Rgba32Float`, `2n x n`, see
    /// [`texel_ends`]).
    ends: wgpu::TextureView,
    construction_ms: f64,
    from_cache: bool,
}

/// A CPU construction running on a thread of its own (background builds, the viewer). The job
/// counts rows in a control of its own, copied to the shared one on every poll, and stops alone
/// (cancelled, superseded by other inputs, or the technique dropped).
struct Pending {
    key: u64,
    job: BackgroundJob<Result<PdsmData, build::Cancelled>>,
    /// When the build started (its sample maps), for `construction_ms`.
    started: Instant,
    cache_dir: Option<PathBuf>,
}

/// Background mode: the sample maps rendered so far (a few per frame) before the CPU build.
struct MapsInProgress {
    key: u64,
    windows: Vec<SlopeFrustum>,
    maps: Vec<build::SampleMap>,
    /// The PDSM window.
    frustum: SlopeFrustum,
    /// When the first map was drawn, for `construction_ms`.
    started: Instant,
    cache_dir: Option<PathBuf>,
}

/// A PDSM set aside by `invalidate_cache` in background mode (see [`Pdsm::background`]).
struct Shelved {
    key: u64,
    data: PdsmData,
    construction_ms: f64,
    from_cache: bool,
}

/// The debug view's map of the static casters from the light centre.
struct CentreMap {
    size: u32,
    texture: wgpu::Texture,
    /// Drawn for the kept PDSM (cleared by a rebuild and by `invalidate_cache`).
    drawn: bool,
}

/// The per-frame map of the dynamic casters.
struct DynamicMap {
    size: u32,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    drawn: bool,
}

/// The `pdsm` technique: a [`ShadowTechnique`] with its settings.
pub struct Pdsm {
    /// Its settings; changes take effect on the next frame.
    pub settings: PdsmSettings,
    /// Where built PDSMs are cached; `None` =
    /// [`softshadow_core::disk_cache::default_dir`].
    pub cache_dir: Option<PathBuf>,
    depth: DepthMapRenderer,
    dynamic_depth: DepthMapRenderer,
    /// The evaluation without dynamic casters, and with them (`DYNAMIC`: the PCF lookup of the
    /// dynamic map): a permutation, not a uniform flag (docs/DEVICES.md, "Lavapipe's
    /// branches").
    evaluate: Evaluation,
    evaluate_dynamic: Evaluation,
    /// The stencil of the evaluation's two draws, at the size of the last visibility buffer.
    stencil: Option<(u32, u32, wgpu::TextureView)>,
    /// Draw the ends first and search only where they do not answer ([`Evaluation`]); off, the
    /// whole evaluation runs at every pixel ([`Self::set_two_draw_evaluation`]).
    two_draw: bool,
    /// The evaluation's group 1: params, the texel offsets and vertices, the dynamic map's view
    /// and map, the ends texture.
    group: PassGroup,
    params_buffer: wgpu::Buffer,
    dynamic_view_buffer: wgpu::Buffer,
    /// Bound when there is no dynamic map (never read: the permutation without `DYNAMIC` runs).
    placeholder_map: wgpu::TextureView,
    kept: Option<Kept>,
    /// The static casters seen from the light centre (the `shadow_map` debug view): allocated
    /// with the PDSM so the view can be chosen, drawn only while a caller shows it
    /// ([`ShadowTechnique::show_debug_view`]), once per built or loaded PDSM.
    centre_map: Option<CentreMap>,
    /// The `shadow_map` debug view is shown: draw the centre map.
    show_centre_map: bool,
    dynamic: Option<DynamicMap>,
    control: BuildControl,
    /// Builds run on a thread of their own ([`ShadowTechnique::set_background_build`]). Then
    /// `invalidate_cache` sets the built PDSM aside in memory instead of dropping it (a background
    /// build takes seconds; rebuilding it for every frame the viewer times would never end), and
    /// the next frame uploads it again, as a disk-cache load does.
    background: bool,
    pending: Option<Pending>,
    /// Background mode: the sample maps of the build being prepared, before `pending`.
    maps_in_progress: Option<MapsInProgress>,
    shelved: Option<Shelved>,
    warnings: Vec<String>,
    stats: TechniqueStats,
    debug: Vec<DebugView>,
}

fn technique_error(message: String) -> TechniqueError {
    TechniqueError::Other {
        technique: ID.into(),
        message,
    }
}

/// `samples` points on the light (light-space x, y): [`stratified_samples`] on the rectangle; on
/// a disk, sphere (its disk in the light plane) or spot, the same strata carried onto the disk by
/// the concentric map, which keeps areas, so each point still stands for an equal share of the
/// light (docs/LIGHTS.md, "Round lights in the seed techniques").
pub fn light_eyes(samples: u32, light: &AreaLight) -> Vec<Vec2> {
    let half = light.half_extent();
    let points = stratified_samples(samples, half);
    if light.kind == LightKind::Rect || light.radius <= 0.0 {
        return points;
    }
    let to_unit = |p: Vec2| (p / half + Vec2::ONE) * 0.5;
    points
        .into_iter()
        .map(|p| concentric_disk(to_unit(p)) * light.radius)
        .collect()
}

/// `samples` points on the light rectangle (light-space x, y), one per cell of equal area: rows
/// of equal counts where possible (row heights proportional to their counts), jittered inside
/// each cell (section 3.1: stratified sampling).
pub fn stratified_samples(samples: u32, half: Vec2) -> Vec<Vec2> {
    let k = samples.max(1);
    let rows = ((k as f32).sqrt().floor() as u32).max(1);
    let mut rng = JITTER_SEED;
    let mut next = move || {
        // splitmix64
        rng = rng.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = rng;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut out = Vec::with_capacity(k as usize);
    let mut y0 = 0.0f32;
    for row in 0..rows {
        let count = k / rows + u32::from(row < k % rows);
        let height = count as f32 / k as f32;
        for column in 0..count {
            let u = (column as f32 + next()) / count as f32;
            let v = y0 + next() * height;
            out.push(Vec2::new(
                (2.0 * u - 1.0) * half.x,
                (2.0 * v - 1.0) * half.y,
            ));
        }
        y0 += height;
    }
    out
}

/// Light-space corners of a world-space box.
fn light_corners(light: &AreaLight, bounds: &Aabb) -> Vec<Vec3> {
    if bounds.is_empty() {
        return Vec::new();
    }
    let view = light.view();
    bounds
        .corners()
        .iter()
        .map(|c| view.transform_point3(*c))
        .collect()
}

/// The PDSM's window from the light centre: every point the static casters can shadow. A point X
/// shadowed from light point p lies behind a caster C on the line through p, so its slope from the
/// centre is C's slope from p plus `p / z_X`; with |p| <= the half extent and z_X >= the casters'
/// nearest depth, the centre's caster window widened by twice `half / z_near` on each side covers
/// every shadowed point (outside it the shader returns lit); it is clipped to the slopes of the
/// static scene, where anything the PDSM is evaluated for usually is. Depths run from the casters' nearest
/// (nothing in front of every caster is shadowed) to the scene's farthest. When casters cross the
/// light plane their slopes are unbounded and the window covers the static scene instead.
fn pdsm_window(
    light: &AreaLight,
    casters: &[Vec3],
    crosses: bool,
    everything: &[Vec3],
) -> Option<SlopeFrustum> {
    let fit = SlopeFrustum::fit_casters(Vec2::ZERO, casters, crosses, everything)?;
    let far = everything.iter().map(|p| p.z).fold(fit.far, f32::max) * 1.02;
    if crosses {
        return Some(SlopeFrustum { far, ..fit });
    }
    let grow = 2.0 * light.half_extent() / fit.near.max(1e-4);
    let mut window = [
        fit.s_min - grow.x,
        fit.s_max + grow.x,
        fit.t_min - grow.y,
        fit.t_max + grow.y,
    ];
    // No need to cover slopes where the static scene has nothing (a caster next to the light
    // widens the first window far beyond the receivers, stiff-near-light).
    if let Some(scene) = SlopeFrustum::fit(Vec2::ZERO, everything) {
        window = [
            window[0].max(scene.s_min),
            window[1].min(scene.s_max),
            window[2].max(scene.t_min),
            window[3].min(scene.t_max),
        ];
    }
    let half = ((window[1] - window[0]) * 0.5)
        .max((window[3] - window[2]) * 0.5)
        .max(1e-3);
    let centre = Vec2::new(window[0] + window[1], window[2] + window[3]) * 0.5;
    Some(SlopeFrustum {
        s_min: centre.x - half,
        s_max: centre.x + half,
        t_min: centre.y - half,
        t_max: centre.y + half,
        far,
        ..fit
    })
}

/// What the CPU construction starts from.
enum BuildInput {
    /// No static caster in front of the light: lit everywhere.
    Empty(PdsmData),
    /// The light samples' map windows, still to render.
    Windows {
        windows: Vec<SlopeFrustum>,
        frustum: SlopeFrustum,
    },
}

/// The units a build counts: the sample maps rendered first, then the PDSM's rows built from them.
const SAMPLE_MAPS: &str = "light sample maps";
const PDSM_ROWS: &str = "PDSM rows";

/// A background build's progress in `unit` ([`SAMPLE_MAPS`], [`PDSM_ROWS`]).
fn building(done: u32, total: u32, unit: &'static str) -> TechniqueError {
    TechniqueError::Building {
        technique: ID.into(),
        done,
        total,
        unit,
    }
}

fn cancelled() -> TechniqueError {
    TechniqueError::Cancelled {
        technique: ID.into(),
    }
}

fn cache_write_warning(dir: &std::path::Path, e: &std::io::Error) -> String {
    cache::in_dir(dir).write_warning(e)
}

/// Bytes the precompute is estimated to need: read-back maps (light-space depth, f32) and the
/// PDSM (index plus `ESTIMATED_VERTICES_PER_TEXEL` vertices per texel).
pub fn estimate_bytes(settings: &PdsmSettings) -> (u64, u64) {
    let m = settings.shadow_map_size as u64;
    let n = settings.pdsm_size as u64;
    let maps = settings.samples as u64 * m * m * 4;
    let pdsm = n * n * (4 + 8 * ESTIMATED_VERTICES_PER_TEXEL.min(2 * settings.samples as u64 + 2));
    (maps, pdsm)
}

/// Two texels of the `pdsm/ends` texture (`2n x n`) per PDSM texel, for the evaluation's fetches
/// that answer most depths without the buffers:
/// - its last and first vertex, `[last depth, last visibility, first depth, first visibility]`:
///   the constant ends of the function; a texel without vertices gets `[-f32::MAX, 1, -f32::MAX,
///   1]`, which every depth lies behind (lit, as an empty function evaluates);
/// - its longest segment, `[start depth, start visibility, end depth, end visibility]`: on a
///   receiver's ray usually the gap between the casters' events and the receiver's own, where the
///   receiver's point lies; `[1, 1, 0, 1]` (matching no depth) for fewer than two vertices.
pub fn texel_ends(data: &PdsmData) -> Vec<[f32; 4]> {
    data.offsets
        .windows(2)
        .flat_map(|w| {
            let texel = &data.vertices[w[0] as usize..w[1] as usize];
            let ends = match (texel.first(), texel.last()) {
                (Some(first), Some(last)) => [last[0], last[1], first[0], first[1]],
                _ => [-f32::MAX, 1.0, -f32::MAX, 1.0],
            };
            let longest = texel
                .windows(2)
                .filter(|pair| pair[1][0] > pair[0][0])
                .max_by(|a, b| (a[1][0] - a[0][0]).total_cmp(&(b[1][0] - b[0][0])))
                .map_or([1.0, 1.0, 0.0, 1.0], |pair| {
                    [pair[0][0], pair[0][1], pair[1][0], pair[1][1]]
                });
            [ends, longest]
        })
        .collect()
}

/// Section 4's evaluation as two draws into one pass, so the four texels' searches run only
/// inside penumbrae (docs/DEVICES.md, "Lavapipe's branches"). The first draw (`ENDS_PASS`)
/// answers every pixel whose four texels are constant at its depth from the ends texture and
/// marks it in the stencil; the rest it discards. The second draw, the whole evaluation, runs
/// where the stencil is still clear.
struct Evaluation {
    ends: FullscreenPipeline,
    penumbra: FullscreenPipeline,
}

impl Evaluation {
    fn new(
        gpu: &Gpu,
        label: &str,
        defs: &[(&str, DefValue)],
        layout: &wgpu::BindGroupLayout,
    ) -> Result<Self, GpuError> {
        let mut ends_defs = defs.to_vec();
        ends_defs.push(("ENDS_PASS", DefValue::Bool(true)));
        let mark = wgpu::StencilFaceState {
            compare: wgpu::CompareFunction::Always,
            fail_op: wgpu::StencilOperation::Keep,
            depth_fail_op: wgpu::StencilOperation::Keep,
            pass_op: wgpu::StencilOperation::Replace,
        };
        let unmarked = wgpu::StencilFaceState {
            compare: wgpu::CompareFunction::Equal,
            fail_op: wgpu::StencilOperation::Keep,
            depth_fail_op: wgpu::StencilOperation::Keep,
            pass_op: wgpu::StencilOperation::Keep,
        };
        Ok(Self {
            ends: FullscreenPipeline::with_stencil(
                gpu,
                &format!("{label} (ends)"),
                &SHADERS[0],
                &ends_defs,
                layout,
                mark,
            )?,
            penumbra: FullscreenPipeline::with_stencil(
                gpu,
                &format!("{label} (penumbrae)"),
                &SHADERS[0],
                defs,
                layout,
                unmarked,
            )?,
        })
    }

    /// Both draws as the pass `pdsm/evaluate` into `target`; without `two_draw`, only the
    /// second, which then runs at every pixel (the stencil stays clear).
    fn record(
        &self,
        frame: &mut Frame<'_>,
        frame_bind_group: &wgpu::BindGroup,
        bind_group: &wgpu::BindGroup,
        target: &wgpu::TextureView,
        stencil: &wgpu::TextureView,
        two_draw: bool,
    ) {
        frame.render_pass(
            "pdsm/evaluate",
            wgpu::RenderPassDescriptor {
                label: None,
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::WHITE),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: stencil,
                    depth_ops: None,
                    stencil_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0),
                        store: wgpu::StoreOp::Discard,
                    }),
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            },
            |pass| {
                pass.set_bind_group(0, frame_bind_group, &[]);
                pass.set_bind_group(1, bind_group, &[]);
                if two_draw {
                    pass.set_pipeline(&self.ends.pipeline);
                    pass.set_stencil_reference(1);
                    pass.draw(0..3, 0..1);
                }
                pass.set_pipeline(&self.penumbra.pipeline);
                pass.set_stencil_reference(0);
                pass.draw(0..3, 0..1);
            },
        );
    }
}

impl Pdsm {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: PdsmSettings) -> Result<Self, TechniqueError> {
        let group = PassGroup::new(
            gpu,
            "pdsm/evaluate",
            &[
                Slot::Uniform,
                Slot::Storage,
                Slot::Storage,
                Slot::Uniform,
                Slot::DEPTH,
                Slot::FLOAT,
            ],
            wgpu::ShaderStages::FRAGMENT,
        );
        let layout = group.layout();
        let placeholder = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("pdsm/no dynamic map"),
            size: wgpu::Extent3d {
                width: 1,
                height: 1,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: SHADOW_DEPTH_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        Ok(Self {
            settings,
            cache_dir: None,
            depth: DepthMapRenderer::new(gpu)?,
            dynamic_depth: DepthMapRenderer::new(gpu)?,
            evaluate: Evaluation::new(gpu, "pdsm/evaluate", &[], layout)?,
            evaluate_dynamic: Evaluation::new(
                gpu,
                "pdsm/evaluate dynamic",
                &[("DYNAMIC", DefValue::Bool(true))],
                layout,
            )?,
            stencil: None,
            two_draw: true,
            group,
            params_buffer: zeroed_uniform_buffer::<PdsmParams>(gpu, "pdsm/params"),
            dynamic_view_buffer: zeroed_uniform_buffer::<ShadowViewUniform>(
                gpu,
                "pdsm/dynamic view",
            ),
            placeholder_map: placeholder.create_view(&Default::default()),
            kept: None,
            centre_map: None,
            show_centre_map: false,
            dynamic: None,
            control: BuildControl::default(),
            background: false,
            pending: None,
            maps_in_progress: None,
            shelved: None,
            warnings: Vec::new(),
            stats: TechniqueStats::new(),
            debug: Vec::new(),
        })
    }

    /// The cancel flag and progress counter of the precompute, to poll from another thread: a
    /// build counts finished PDSM rows in `done` (out of `total` = `pdsm_size`, reset when a build
    /// starts; `building` is set meanwhile) and stops at the next row once `cancel` is set;
    /// `render` then fails with [`TechniqueError::Cancelled`], and keeps failing at once until the
    /// caller clears `cancel`.
    pub fn build_control(&self) -> BuildControl {
        self.control.clone()
    }

    /// Cache warnings since the technique was created (a file refused and rebuilt, a failed
    /// write); also logged with `log::warn!`.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// Whether the evaluation draws the ends first and searches only the pixels they leave
    /// (on by default). Off, one draw evaluates every pixel in full: the same
    /// image bit for bit (tested), for measuring what the split saves.
    pub fn set_two_draw_evaluation(&mut self, on: bool) {
        self.two_draw = on;
    }

    /// The PDSM in use (after a frame), for inspection and tests.
    pub fn data(&self) -> Option<&PdsmData> {
        self.kept.as_ref().map(|k| &k.data)
    }

    fn warn(&mut self, message: String) {
        log::warn!("{message}");
        self.warnings.push(message);
    }

    /// The cache key: format version, static geometry, light (without intensity), build
    /// parameters, and whether casters cross the light plane (it changes the map windows).
    fn key(&self, inputs: &ShadowInputs<'_>) -> u64 {
        let mut h = Fnv1a::default();
        h.write_str("pdsm");
        h.write_u64(cache::FORMAT_VERSION as u64);
        h.write_u64(inputs.scene.static_hash);
        let light = inputs.light;
        h.write_f32s(&light.center.to_array());
        h.write_f32s(&light.direction.to_array());
        h.write_f32s(&light.up.to_array());
        h.write_f32s(&[light.width, light.height]);
        if light.kind != LightKind::Rect {
            // Under the rectangle the key is as it was before light kinds (kept caches load).
            h.write_u64(light.kind as u64);
            h.write_f32s(&[light.radius]);
        }
        let s = &self.settings;
        h.write_u64(s.samples as u64);
        h.write_u64(s.pdsm_size as u64);
        h.write_u64(s.shadow_map_size as u64);
        h.write_f32s(&[s.compression_error]);
        h.write_u64(
            inputs
                .scene
                .light_bounds(light)
                .casters_cross_light_plane
                .into(),
        );
        h.finish()
    }

    /// Builds (or loads) the PDSM for this frame's static scene and light. In background mode a
    /// build runs on its own thread and this fails with [`TechniqueError::Building`] until it is
    /// done.
    // Long: the cache, the background build and the foreground build are one decision read
    // top to bottom; each branch is a few lines.
    fn prepare_pdsm(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
    ) -> Result<(), TechniqueError> {
        let key = self.key(inputs);
        if let Some(kept) = &self.kept {
            if kept.key == key || !inputs.changes.static_light_space() {
                return Ok(());
            }
        }
        self.kept = None;
        if let Some(shelved) = self.shelved.take() {
            if shelved.key == key {
                let elapsed = Duration::from_secs_f64(shelved.construction_ms / 1e3);
                return self.keep_timed(frame, key, shelved.data, elapsed, shelved.from_cache);
            }
        }
        if self.poll_pending(frame.gpu, key)? {
            return Ok(());
        }
        if let Some(progress) = self.maps_in_progress.take() {
            if progress.key == key {
                return self.continue_sample_maps(frame, inputs, progress);
            }
            // Superseded by other inputs: its maps are dropped.
            self.control.finish();
        }
        let (maps_bytes, pdsm_bytes) = estimate_bytes(&self.settings);
        let budget = self.settings.memory_budget_mib as u64 * (1 << 20);
        if maps_bytes + pdsm_bytes > budget {
            let mib = |b: u64| b as f64 / (1 << 20) as f64;
            let lower = if maps_bytes >= pdsm_bytes {
                "lower `samples` or `shadow_map_size`"
            } else {
                "lower `pdsm_size`"
            };
            return Err(technique_error(format!(
                "the precompute needs an estimated {:.0} MiB ({} maps of {}² read back: {:.0} MiB; \
                 a {}² PDSM: {:.0} MiB), over memory_budget_mib = {}: {lower}, or raise memory_budget_mib",
                mib(maps_bytes + pdsm_bytes),
                self.settings.samples,
                self.settings.shadow_map_size,
                mib(maps_bytes),
                self.settings.pdsm_size,
                mib(pdsm_bytes),
                self.settings.memory_budget_mib
            )));
        }
        let started = Instant::now();
        let cache_dir = if self.settings.disk_cache {
            self.cache_dir
                .clone()
                .or_else(softshadow_core::disk_cache::default_dir)
        } else {
            None
        };
        if let Some(dir) = &cache_dir {
            let clock = frame.begin_cpu_pass();
            let loaded = cache::load(dir, key);
            frame.end_cpu_pass("pdsm/cache_load", clock);
            match loaded {
                Ok(Some(data)) if data.size == self.settings.pdsm_size => {
                    self.keep_timed(frame, key, data, started.elapsed(), true)?;
                    return Ok(());
                }
                Ok(_) => {}
                Err(reason) => self.warn(format!("pdsm: cache file refused, rebuilding: {reason}")),
            }
        }
        if self.control.is_cancelled() {
            return Err(cancelled());
        }
        let (windows, frustum) = match self.build_input(inputs) {
            BuildInput::Empty(data) => {
                return self.keep_timed(frame, key, data, started.elapsed(), false)
            }
            BuildInput::Windows { windows, frustum } => (windows, frustum),
        };
        if self.background {
            // The sample maps over this and the next frames, a few per frame, then the CPU
            // construction on a thread of its own.
            self.control.start(windows.len() as u32, SAMPLE_MAPS);
            let progress = MapsInProgress {
                key,
                maps: Vec::with_capacity(windows.len()),
                windows,
                frustum,
                started,
                cache_dir,
            };
            return self.continue_sample_maps(frame, inputs, progress);
        }
        let maps = self.render_sample_maps(frame, inputs, &windows)?;
        let size = self.settings.pdsm_size;
        let max_error = self.settings.compression_error;
        self.control.start(size, PDSM_ROWS);
        let clock = frame.begin_cpu_pass();
        let built = build::build(&maps, &frustum, size, max_error, &self.control);
        frame.end_cpu_pass("pdsm/build", clock);
        self.control.finish();
        let data = built.map_err(|build::Cancelled| cancelled())?;
        self.store_in_cache(frame, cache_dir.as_deref(), key, &data);
        self.keep_timed(frame, key, data, started.elapsed(), false)
    }

    /// Background mode: renders and reads back the next few sample maps of `progress` (at most
    /// [`MAP_TEXELS_PER_FRAME`] texels, at least one map), so that no frame of the caller's
    /// thread waits for all k of them; fails with [`TechniqueError::Building`] (unit "light
    /// sample maps") while maps remain, and once all are read back starts the CPU construction
    /// on a thread of its own (then [`TechniqueError::Building`] in PDSM rows).
    fn continue_sample_maps(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        mut progress: MapsInProgress,
    ) -> Result<(), TechniqueError> {
        if self.control.is_cancelled() {
            self.control.finish();
            return Err(cancelled());
        }
        let m = self.settings.shadow_map_size as u64;
        let per_frame = (MAP_TEXELS_PER_FRAME / (m * m)).max(1) as usize;
        let next = progress.maps.len();
        let end = (next + per_frame).min(progress.windows.len());
        let rendered = match self.render_sample_maps(frame, inputs, &progress.windows[next..end]) {
            Ok(rendered) => rendered,
            Err(e) => {
                self.control.finish();
                return Err(e);
            }
        };
        progress.maps.extend(rendered.maps);
        let (done, total) = (progress.maps.len() as u32, progress.windows.len() as u32);
        if done < total {
            self.control.done.store(done, Ordering::Relaxed);
            self.maps_in_progress = Some(progress);
            return Err(building(done, total, SAMPLE_MAPS));
        }
        let MapsInProgress {
            key,
            maps,
            frustum,
            started,
            cache_dir,
            ..
        } = progress;
        let maps = build::SampleMaps {
            size: self.settings.shadow_map_size,
            maps,
        };
        let size = self.settings.pdsm_size;
        let max_error = self.settings.compression_error;
        self.control.start(size, PDSM_ROWS);
        let job = BackgroundJob::spawn("pdsm build", size, PDSM_ROWS, move |control| {
            build::build(&maps, &frustum, size, max_error, control)
        })
        .map_err(|e| {
            self.control.finish();
            technique_error(format!("cannot start the PDSM build thread: {e}"))
        })?;
        self.pending = Some(Pending {
            key,
            job,
            started,
            cache_dir,
        });
        Err(building(0, size, PDSM_ROWS))
    }

    /// Background mode: looks at the build running for `key`. `Ok(true)`: it finished and the
    /// PDSM is kept; `Ok(false)`: no build runs for `key` (one for other inputs is stopped);
    /// [`TechniqueError::Building`] while it runs, [`TechniqueError::Cancelled`] once it ended
    /// with the cancel flag set (its result, if it got to the end, is dropped).
    fn poll_pending(&mut self, gpu: &Gpu, key: u64) -> Result<bool, TechniqueError> {
        let Some(pending) = &self.pending else {
            return Ok(false);
        };
        if pending.key != key {
            // Superseded: it stops at its next row and its result is never read.
            pending.job.cancel();
            self.pending = None;
            self.control.finish();
            return Ok(false);
        }
        if self.control.is_cancelled() {
            pending.job.cancel();
        }
        pending.job.report_to(&self.control);
        if !pending.job.is_finished() {
            let (done, total) = pending.job.progress();
            return Err(building(done, total, PDSM_ROWS));
        }
        let pending = self.pending.take().expect("looked at above");
        self.control.finish();
        let built = pending
            .job
            .join()
            .map_err(|_| technique_error("the PDSM build thread panicked; see the log".into()))?;
        // A cancel discards the result even when the build got to its end first.
        if self.control.is_cancelled() {
            return Err(cancelled());
        }
        let data = built.map_err(|build::Cancelled| cancelled())?;
        if let Some(dir) = &pending.cache_dir {
            if let Err(e) = cache::store(dir, key, &data) {
                self.warn(cache_write_warning(dir, &e));
            }
        }
        self.keep(gpu, key, data, pending.started.elapsed(), false)?;
        Ok(true)
    }

    fn store_in_cache(
        &mut self,
        frame: &mut Frame<'_>,
        dir: Option<&std::path::Path>,
        key: u64,
        data: &PdsmData,
    ) {
        let Some(dir) = dir else { return };
        let clock = frame.begin_cpu_pass();
        let stored = cache::store(dir, key, data);
        frame.end_cpu_pass("pdsm/cache_store", clock);
        if let Err(e) = stored {
            self.warn(cache_write_warning(dir, &e));
        }
    }

    /// What the construction starts from (Algorithm 1 step 1): the PDSM window and the light
    /// samples' map windows, or an empty PDSM when no static caster is in front of the light.
    fn build_input(&self, inputs: &ShadowInputs<'_>) -> BuildInput {
        let light = inputs.light;
        let scene = inputs.scene;
        let crosses = scene.light_bounds(light).casters_cross_light_plane;
        let casters = light_corners(light, &scene.static_caster_bounds);
        let everything = light_corners(light, &scene.static_bounds);
        let size = self.settings.pdsm_size;
        let empty = |frustum| {
            BuildInput::Empty(PdsmData {
                size,
                frustum,
                offsets: vec![0; (size * size + 1) as usize],
                vertices: Vec::new(),
                stats: BuildStats::default(),
            })
        };
        let unit = SlopeFrustum {
            eye: Vec2::ZERO,
            s_min: -1.0,
            s_max: 1.0,
            t_min: -1.0,
            t_max: 1.0,
            near: 1.0,
            far: 2.0,
        };
        // Without static casters in front of the light the PDSM is empty (lit everywhere).
        let Some(frustum) = pdsm_window(light, &casters, crosses, &everything) else {
            return empty(unit);
        };
        if scene.static_casters.is_none() {
            return empty(frustum);
        }
        let eyes = light_eyes(self.settings.samples, light);
        let windows: Vec<SlopeFrustum> = eyes
            .iter()
            .filter_map(|&eye| SlopeFrustum::fit_casters(eye, &casters, crosses, &everything))
            .collect();
        if windows.len() != eyes.len() {
            return empty(frustum);
        }
        BuildInput::Windows { windows, frustum }
    }

    /// Algorithm 1 step 2 on the GPU: one depth map of the static casters per window, copied to
    /// buffers in batches and read back as light-space depth.
    // Long: one loop over batches (render, copy, read back, cancel check) whose steps share the
    // batch's buffers.
    fn render_sample_maps(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        windows: &[SlopeFrustum],
    ) -> Result<build::SampleMaps, TechniqueError> {
        let gpu = frame.gpu;
        let m = self.settings.shadow_map_size;
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("pdsm/sample map"),
            size: wgpu::Extent3d {
                width: m,
                height: m,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: SHADOW_DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        let views: Vec<ShadowViewUniform> = windows
            .iter()
            .map(|w| ShadowViewUniform::new(inputs.light, w, m))
            .collect();
        self.depth.set_views(gpu, &views);
        let row_bytes = (m * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let map_bytes = row_bytes as u64 * m as u64;
        let per_batch = (READBACK_BATCH_BYTES / map_bytes).max(1) as usize;
        let mut maps = Vec::with_capacity(windows.len());
        for (batch_index, batch) in windows.chunks(per_batch).enumerate() {
            let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pdsm/sample map readback"),
                size: map_bytes * batch.len() as u64,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            });
            for j in 0..batch.len() {
                let slot = (batch_index * per_batch + j) as u32;
                self.depth.record_list(
                    frame,
                    "pdsm/sample_maps",
                    inputs.scene,
                    inputs.scene.static_casters.as_ref(),
                    slot,
                    &view,
                );
                frame.encoder.copy_texture_to_buffer(
                    texture.as_image_copy(),
                    wgpu::TexelCopyBufferInfo {
                        buffer: &buffer,
                        layout: wgpu::TexelCopyBufferLayout {
                            offset: map_bytes * j as u64,
                            bytes_per_row: Some(row_bytes),
                            rows_per_image: Some(m),
                        },
                    },
                    wgpu::Extent3d {
                        width: m,
                        height: m,
                        depth_or_array_layers: 1,
                    },
                );
            }
            let clock = frame.begin_cpu_pass();
            frame.submit_and_wait()?;
            let slice = buffer.slice(..);
            let (sender, receiver) = std::sync::mpsc::channel();
            slice.map_async(wgpu::MapMode::Read, move |r| {
                let _ = sender.send(r);
            });
            gpu.wait_idle()?;
            receiver
                .recv()
                .map_err(|e| GpuError::Readback(e.to_string()))?
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            {
                let bytes = slice
                    .get_mapped_range()
                    .map_err(|e| GpuError::Readback(e.to_string()))?;
                for (j, window) in batch.iter().enumerate() {
                    let (near, far) = (window.near, window.far);
                    let mut depth = Vec::with_capacity((m * m) as usize);
                    for row in 0..m as usize {
                        let start = j * map_bytes as usize + row * row_bytes as usize;
                        let texels: &[f32] =
                            bytemuck::cast_slice(&bytes[start..start + 4 * m as usize]);
                        // Hardware depth to light-space z; the cleared far plane is "no caster".
                        depth.extend(texels.iter().map(|&d| {
                            if d >= 1.0 {
                                f32::INFINITY
                            } else {
                                far * near / (far - d * (far - near))
                            }
                        }));
                    }
                    maps.push(build::SampleMap {
                        frustum: *window,
                        depth,
                    });
                }
            }
            buffer.unmap();
            frame.end_cpu_pass("pdsm/readback", clock);
        }
        Ok(build::SampleMaps { size: m, maps })
    }

    /// [`Self::keep`] inside a frame, timed as the CPU pass `pdsm/upload` (buffer creation and
    /// the ends texture are real work of the frame that builds or loads a PDSM).
    fn keep_timed(
        &mut self,
        frame: &mut Frame<'_>,
        key: u64,
        data: PdsmData,
        elapsed: Duration,
        from_cache: bool,
    ) -> Result<(), TechniqueError> {
        let clock = frame.begin_cpu_pass();
        let kept = self.keep(frame.gpu, key, data, elapsed, from_cache);
        frame.end_cpu_pass("pdsm/upload", clock);
        kept
    }

    /// Uploads `data` (Fig. 6: index and data buffers) and keeps it.
    fn keep(
        &mut self,
        gpu: &Gpu,
        key: u64,
        data: PdsmData,
        elapsed: Duration,
        from_cache: bool,
    ) -> Result<(), TechniqueError> {
        let limit = gpu.device.limits().max_storage_buffer_binding_size;
        let vertex_bytes = data.vertices.len() as u64 * 8;
        if vertex_bytes > limit {
            return Err(technique_error(format!(
                "the compressed PDSM holds {vertex_bytes} bytes of vertices, over this GPU's \
                 storage-buffer limit of {limit}: raise `compression_error` or lower `pdsm_size`"
            )));
        }
        let buffer = |label: &str, bytes: &[u8]| {
            gpu.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: if bytes.is_empty() { &[0u8; 8] } else { bytes },
                    usage: wgpu::BufferUsages::STORAGE,
                })
        };
        let offsets = buffer("pdsm/index", bytemuck::cast_slice(&data.offsets));
        let vertices = buffer("pdsm/data", bytemuck::cast_slice(&data.vertices));
        let ends = gpu
            .device
            .create_texture_with_data(
                &gpu.queue,
                &wgpu::TextureDescriptor {
                    label: Some("pdsm/ends"),
                    size: wgpu::Extent3d {
                        width: 2 * data.size,
                        height: data.size,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba32Float,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                },
                wgpu::util::TextureDataOrder::LayerMajor,
                bytemuck::cast_slice(&texel_ends(&data)),
            )
            .create_view(&Default::default());
        self.kept = Some(Kept {
            key,
            data,
            offsets,
            vertices,
            ends,
            construction_ms: elapsed.as_secs_f64() * 1e3,
            from_cache,
        });
        Ok(())
    }

    /// One map of the static casters from the light centre, for the `shadow_map` debug view:
    /// allocated whenever a PDSM is kept (so the view is listed), drawn when the view is shown
    /// and not yet drawn for this PDSM. Returns whether `pdsm/centre_map` ran.
    fn update_centre_map(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        rebuilt: bool,
    ) -> bool {
        let size = self.settings.shadow_map_size;
        if self.centre_map.as_ref().is_some_and(|c| c.size != size) {
            self.centre_map = None;
        }
        if let Some(c) = self.centre_map.as_mut().filter(|_| rebuilt) {
            c.drawn = false;
        }
        let centre = self.centre_map.get_or_insert_with(|| CentreMap {
            size,
            texture: softshadow_core::shadow_map::create_depth_maps(
                frame.gpu,
                "pdsm/centre map",
                size,
                1,
            ),
            drawn: false,
        });
        if centre.drawn || !self.show_centre_map {
            return false;
        }
        centre.drawn = true;
        let light = inputs.light;
        let crosses = inputs.scene.light_bounds(light).casters_cross_light_plane;
        let casters = light_corners(light, &inputs.scene.static_caster_bounds);
        let everything = light_corners(light, &inputs.scene.static_bounds);
        let Some(window) = SlopeFrustum::fit_casters(Vec2::ZERO, &casters, crosses, &everything)
        else {
            return false;
        };
        let view = centre.texture.create_view(&Default::default());
        self.depth
            .set_views(frame.gpu, &[ShadowViewUniform::new(light, &window, size)]);
        self.depth.record_list(
            frame,
            "pdsm/centre_map",
            inputs.scene,
            inputs.scene.static_casters.as_ref(),
            0,
            &view,
        );
        true
    }

    /// The per-frame PCF map of the dynamic casters (kept while nothing in light space moves).
    fn render_dynamic_map(&mut self, frame: &mut Frame<'_>, inputs: &ShadowInputs<'_>) -> bool {
        let Some(list) = inputs.scene.dynamic_casters.as_ref() else {
            self.dynamic = None;
            return false;
        };
        let size = self.settings.dynamic_map_size;
        if let Some(d) = &self.dynamic {
            if d.size == size && d.drawn && !inputs.changes.light_space() {
                return true;
            }
        }
        let Some(window) = fit_caster_view(inputs.scene, inputs.light, Vec2::ZERO) else {
            self.dynamic = None;
            return false;
        };
        let gpu = frame.gpu;
        if self.dynamic.as_ref().map(|d| d.size) != Some(size) {
            let texture =
                softshadow_core::shadow_map::create_depth_maps(gpu, "pdsm/dynamic map", size, 1);
            let view = texture.create_view(&Default::default());
            self.dynamic = Some(DynamicMap {
                size,
                texture,
                view,
                drawn: false,
            });
        }
        let view = ShadowViewUniform::new(inputs.light, &window, size);
        self.dynamic_depth.set_views(gpu, &[view]);
        gpu.queue
            .write_buffer(&self.dynamic_view_buffer, 0, &uniform_bytes(&view));
        let dynamic = self.dynamic.as_mut().expect("created above");
        self.dynamic_depth.record_list(
            frame,
            "pdsm/dynamic_map",
            inputs.scene,
            Some(list),
            0,
            &dynamic.view,
        );
        dynamic.drawn = true;
        true
    }

    /// Debug views: compressed vertices per texel and the attenuation at `debug_depth`.
    fn update_debug_views(&mut self, gpu: &Gpu) {
        let Some(kept) = &self.kept else {
            self.debug.clear();
            return;
        };
        let data = &kept.data;
        let n = data.size;
        let depth =
            data.frustum.near + self.settings.debug_depth * (data.frustum.far - data.frustum.near);
        let texel =
            |i: usize| &data.vertices[data.offsets[i] as usize..data.offsets[i + 1] as usize];
        let counts: Vec<f32> = (0..(n * n) as usize)
            .map(|i| texel(i).len() as f32)
            .collect();
        let attenuation: Vec<f32> = (0..(n * n) as usize)
            .map(|i| function::evaluate(texel(i), depth))
            .collect();
        let image = |name: &str, legend: DebugLegend, values: &[f32]| {
            let texture = gpu.device.create_texture_with_data(
                &gpu.queue,
                &wgpu::TextureDescriptor {
                    label: Some(name),
                    size: wgpu::Extent3d {
                        width: n,
                        height: n,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::R32Float,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
                    view_formats: &[],
                },
                wgpu::util::TextureDataOrder::LayerMajor,
                bytemuck::cast_slice(values),
            );
            DebugView::new(name, &texture, legend)
        };
        self.debug = vec![
            image(
                "vertices_per_texel",
                DebugLegend::value("vertices of the texel's compressed attenuation function"),
                &counts,
            ),
            image(
                "attenuation_at_depth",
                DebugLegend::value("light visible at the depth set by debug_depth (1 = lit)"),
                &attenuation,
            ),
        ];
    }
}

impl Pdsm {
    /// The evaluation's parameters for the kept PDSM, with or without a dynamic map.
    fn write_params(&self, gpu: &Gpu, has_dynamic: bool) {
        let kept = self.kept.as_ref().expect("prepared by render");
        let f = &kept.data.frustum;
        gpu.queue.write_buffer(
            &self.params_buffer,
            0,
            &uniform_bytes(&PdsmParams {
                window: Vec4::new(f.s_min, f.s_max, f.t_min, f.t_max),
                size_bias: Vec4::new(
                    kept.data.size as f32,
                    self.settings.bias_texels,
                    // How far a tap's tangent-plane depth may reach along its ray.
                    (f.s_max - f.s_min) / kept.data.size as f32,
                    self.settings.pcf_radius as f32,
                ),
                dynamic_map_texel: Vec4::new(
                    f32::from(u8::from(has_dynamic)),
                    // Each sample map's window is fitted to the casters, inside the PDSM's
                    // window (fitted to all they shadow): this bounds a map texel's extent.
                    (f.s_max - f.s_min) / self.settings.shadow_map_size as f32,
                    0.0,
                    0.0,
                ),
            }),
        );
    }

    /// Section 4's evaluation into `out` (see [`Evaluation`]).
    fn evaluate(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
        has_dynamic: bool,
    ) {
        self.ensure_stencil(frame.gpu, out.width, out.height);
        let kept = self.kept.as_ref().expect("prepared by render");
        let dynamic_view = match (&self.dynamic, has_dynamic) {
            (Some(d), true) => &d.view,
            _ => &self.placeholder_map,
        };
        let bind_group = self.group.bind(
            frame.gpu,
            &[
                (&self.params_buffer).into(),
                (&kept.offsets).into(),
                (&kept.vertices).into(),
                (&self.dynamic_view_buffer).into(),
                dynamic_view.into(),
                (&kept.ends).into(),
            ],
        );
        let evaluation = if has_dynamic {
            &self.evaluate_dynamic
        } else {
            &self.evaluate
        };
        let (_, _, stencil) = self.stencil.as_ref().expect("created above");
        let group = inputs.frame_bind_group;
        evaluation.record(frame, group, &bind_group, &out.view, stencil, self.two_draw);
    }

    /// The evaluation's stencil, of `width` x `height`.
    fn ensure_stencil(&mut self, gpu: &Gpu, width: u32, height: u32) {
        if matches!(&self.stencil, Some((w, h, _)) if (*w, *h) == (width, height)) {
            return;
        }
        let texture = softshadow_core::gbuffer::create_texture(
            gpu,
            "pdsm/penumbra stencil",
            width,
            height,
            STENCIL_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let view = texture.create_view(&Default::default());
        self.stencil = Some((width, height, view));
    }

    /// The stats of a frame of the kept PDSM.
    fn frame_stats(
        &self,
        rebuilt: bool,
        has_dynamic: bool,
        centre_map_drawn: bool,
    ) -> TechniqueStats {
        let kept = self.kept.as_ref().expect("prepared by render");
        let s = &kept.data.stats;
        let ends_bytes = kept.data.size as u64 * kept.data.size as u64 * 32;
        let gpu_bytes = kept.offsets.size() + kept.vertices.size() + ends_bytes;
        let dynamic_bytes = self
            .dynamic
            .as_ref()
            .map(|d| d.size as u64 * d.size as u64 * 4)
            .unwrap_or(0);
        let (maps_estimate, pdsm_estimate) = estimate_bytes(&self.settings);
        TechniqueStats::from([
            ("construction_ms".into(), kept.construction_ms),
            ("from_cache".into(), f64::from(u8::from(kept.from_cache))),
            ("rebuilt_this_frame".into(), f64::from(u8::from(rebuilt))),
            ("samples".into(), self.settings.samples as f64),
            ("events_per_texel_mean".into(), s.events_mean),
            ("events_per_texel_max".into(), s.events_max as f64),
            ("vertices_per_texel_mean".into(), s.vertices_mean),
            ("vertices_per_texel_max".into(), s.vertices_max as f64),
            (
                "compression_max_error".into(),
                s.max_compression_error as f64,
            ),
            ("gpu_bytes".into(), (gpu_bytes + dynamic_bytes) as f64),
            ("pdsm_gpu_bytes".into(), gpu_bytes as f64),
            (
                "estimated_build_bytes".into(),
                (maps_estimate + pdsm_estimate) as f64,
            ),
            ("pcf_map_passes".into(), f64::from(u8::from(has_dynamic))),
            // 1 when `pdsm/centre_map` ran: only while the `shadow_map` debug view is shown.
            (
                "centre_map_passes".into(),
                f64::from(u8::from(centre_map_drawn)),
            ),
        ])
    }
}

impl ShadowTechnique for Pdsm {
    fn id(&self) -> &str {
        ID
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
        if inputs.scene.light_bounds(inputs.light).casters.is_none() {
            out.write_unshadowed(frame, inputs.frame_bind_group, "pdsm/no_casters")?;
            self.stats = TechniqueStats::from([("sample_maps".into(), 0.0)]);
            return Ok(());
        }
        let had = self.kept.as_ref().map(|k| k.key);
        self.prepare_pdsm(frame, inputs)?;
        let rebuilt = self.kept.as_ref().map(|k| k.key) != had;
        let centre_map_drawn = self.update_centre_map(frame, inputs, rebuilt);
        let has_dynamic = self.render_dynamic_map(frame, inputs);
        self.write_params(frame.gpu, has_dynamic);
        self.evaluate(frame, inputs, out, has_dynamic);
        self.stats = self.frame_stats(rebuilt, has_dynamic, centre_map_drawn);
        let gpu = frame.gpu;
        if rebuilt || inputs.changes.params || self.debug.is_empty() {
            // CPU work of this frame (every texel evaluated at debug_depth): timed like a pass.
            let clock = frame.begin_cpu_pass();
            self.update_debug_views(gpu);
            frame.end_cpu_pass("pdsm/debug_views", clock);
        }
        Ok(())
    }

    fn invalidate_cache(&mut self) {
        if let Some(kept) = self.kept.take().filter(|_| self.background) {
            self.shelved = Some(Shelved {
                key: kept.key,
                data: kept.data,
                construction_ms: kept.construction_ms,
                from_cache: kept.from_cache,
            });
        }
        if let Some(c) = &mut self.centre_map {
            c.drawn = false;
        }
        if let Some(d) = &mut self.dynamic {
            d.drawn = false;
        }
    }

    fn set_build_control(&mut self, control: BuildControl) {
        self.control = control;
    }

    fn set_background_build(&mut self, on: bool) {
        self.background = on;
        if !on {
            self.shelved = None;
        }
    }

    fn stats(&self) -> TechniqueStats {
        self.stats.clone()
    }

    fn show_debug_view(&mut self, name: Option<&str>) {
        self.show_centre_map = name == Some(CENTRE_MAP_VIEW);
    }

    fn debug_views(&self) -> Vec<DebugView> {
        let mut views: Vec<DebugView> = self
            .debug
            .iter()
            .map(|d| DebugView::new(d.name.clone(), &d.texture, d.legend.clone()))
            .collect();
        if let Some(c) = &self.centre_map {
            views.push(DebugView::new(
                CENTRE_MAP_VIEW,
                &c.texture,
                DebugLegend::Depth,
            ));
        }
        if let Some(d) = &self.dynamic {
            views.push(DebugView::new(
                "dynamic_map",
                &d.texture,
                DebugLegend::Depth,
            ));
        }
        views
    }
}

impl Drop for Pdsm {
    fn drop(&mut self) {
        // A build running on its own thread stops at its next row; nobody reads its result.
        if let Some(pending) = &self.pending {
            pending.job.cancel();
            self.control.finish();
        }
    }
}
