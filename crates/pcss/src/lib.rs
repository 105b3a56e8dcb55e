//! `pcss`: percentage-closer soft shadows (Fernando 2005, "Percentage-closer soft shadows").
//!
//! Reads: the casters (one shadow map from the light centre) and the G-buffer.
//! Writes: the visibility buffer. Passes: `pcss/shadow_map`, `pcss/filter` (blocker search,
//! penumbra estimate and percentage-closer filtering in one fullscreen pass).
//!
//! With the setting `temporal` (off by default), the temporal mode engines ship (Bevy's
//! `ShadowFilteringMethod::Temporal`): `pcss/filter` rotates its kernel by another angle every
//! frame and draws into a texture of its own, and `pcss/temporal` blends it into a history
//! reprojected with the previous camera, rejected where the pixel saw another surface and
//! clipped to this frame's neighbourhood (docs/TECHNIQUES.md, `pcss`, "Temporal mode"). Off,
//! the technique is plain PCSS, bit for bit.

#![warn(missing_docs)]

use encase::ShaderType;
use softshadow_core::{
    cascades::SunCascadeParams,
    gbuffer::create_texture,
    glam::Mat4,
    pass::{ComputePass, FullscreenPass, Pass, Slot},
    reprojection::History,
    shader::{DefValue, ShaderSpec},
    shader_file,
    shadow_map::CentreShadowMap,
    uniform::{uniform_bytes, zeroed_uniform_buffer},
    wgpu, DebugLegend, DebugView, Frame, Gpu, LightKind, MinLimits, Requirements, ShadowInputs,
    ShadowTechnique, TechniqueError, TechniqueSettings, TechniqueStats, VisibilityBuffer,
};

mod info;
mod sun;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "pcss";

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "pcss/pcss.wgsl",
        source: shader_file!("pcss/pcss.wgsl").1,
        permutations: &[
            &[],
            &[("KERNEL_GRID", DefValue::Bool(true))],
            &[("TEMPORAL", DefValue::Bool(true))],
            &[
                ("KERNEL_GRID", DefValue::Bool(true)),
                ("TEMPORAL", DefValue::Bool(true)),
            ],
        ],
    },
    ShaderSpec {
        path: "pcss/temporal.wgsl",
        source: shader_file!("pcss/temporal.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "pcss/sun.wgsl",
        source: shader_file!("pcss/sun.wgsl").1,
        permutations: &[&[], &[("KERNEL_GRID", DefValue::Bool(true))]],
    },
];

softshadow_core::param_choice! {
    /// Filter kernel shape.
    pub enum Kernel {
        /// Vogel (golden-angle) disk rotated per pixel: what engines ship.
        Vogel = "vogel",
        /// Jittered grid over the light's rectangle: exact for a planar occluder parallel to the
        /// light when the blocker depth is right (a box filter of the penumbra width gives the
        /// linear ramp).
        Grid = "grid",
    }
}

softshadow_core::technique_settings! {
    /// Settings of PCSS. Defaults follow common engine practice (16 blocker, 32 filter samples).
    pub struct PcssSettings {
        ..sun: SunCascadeParams;
        /// Shadow-map edge in texels
        shadow_map_size: u32 = 1024, in 64..=4096;
        /// Samples of the blocker search
        blocker_samples: u32 = 16, in 1..=64;
        /// Samples of the percentage-closer filter
        filter_samples: u32 = 32, in 1..=256;
        /// Sample pattern: rotated Vogel disk, or jittered grid over the light rectangle
        kernel: Kernel = Kernel::Vogel;
        /// Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes)
        bias_texels: f32 = 1.5, in 0.0..=16.0;
        /// Smallest filter half extent in texels
        min_filter_texels: f32 = 1.0, in 0.0..=8.0;
        /// Temporal mode: the kernel rotates every frame and a reprojected history averages the frames
        temporal: bool = false;
        /// Temporal mode: frames averaged at most (the current frame weighs at least 1 / this)
        max_history: u32 = 16, in 1..=256;
        /// Temporal mode: the history is clipped to this frame's 3x3 mean +- this many standard deviations
        clamp_sigma: f32 = 1.0, in 0.0..=16.0;
    }
}

#[derive(ShaderType)]
struct PcssUniform {
    blocker_samples: u32,
    filter_samples: u32,
    /// Frame index of the temporal mode (read by the `TEMPORAL` permutation only).
    frame_index: u32,
    bias_texels: f32,
    min_filter_texels: f32,
}

#[derive(ShaderType)]
struct TemporalUniform {
    prev_view_proj: Mat4,
    history_valid: u32,
    max_history: u32,
    clamp_sigma: f32,
}

/// This crate's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![
        softshadow_core::uniform_mirror!(
            PcssUniform {
                blocker_samples, filter_samples, frame_index, bias_texels, min_filter_texels
            } => "pcss/pcss.wgsl", PcssParams
        ),
        softshadow_core::uniform_mirror!(
            PcssUniform {
                blocker_samples, filter_samples, frame_index, bias_texels, min_filter_texels
            } => "pcss/sun.wgsl", PcssParams
        ),
        softshadow_core::uniform_mirror!(
            TemporalUniform {
                prev_view_proj, history_valid, max_history, clamp_sigma
            } => "pcss/temporal.wgsl", TemporalParams
        ),
    ]
}

/// What the temporal mode needs from the device: three storage textures in its pass.
pub fn temporal_requirements() -> Requirements {
    Requirements {
        limits: MinLimits {
            max_storage_textures_per_shader_stage: 3,
            ..MinLimits::default()
        },
        ..Requirements::default()
    }
}

/// Per-size textures of the temporal mode.
struct TemporalTargets {
    /// This frame's rotated PCSS (`R32Float`, drawn by `pcss/filter`).
    raw: wgpu::Texture,
    raw_view: wgpu::TextureView,
    /// (frames averaged, visibility) and the world point each saw.
    history: History,
}

impl TemporalTargets {
    fn new(gpu: &Gpu, width: u32, height: u32) -> Self {
        let raw = create_texture(
            gpu,
            "pcss/raw",
            width,
            height,
            wgpu::TextureFormat::R32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        Self {
            raw_view: view(&raw),
            raw,
            history: History::new(gpu, "pcss", width, height),
        }
    }

    /// Bytes of the textures per pixel: raw 4 and the history.
    const BYTES_PER_PIXEL: u64 = 4 + History::BYTES_PER_PIXEL;
}

/// The temporal mode's pipelines, history and state, made on its first frame (plain PCSS never
/// builds them).
struct Temporal {
    filter_vogel: FullscreenPass,
    filter_grid: FullscreenPass,
    resolve: ComputePass,
    params_buffer: wgpu::Buffer,
    targets: Option<TemporalTargets>,
    /// Rotates the kernel: goes on every temporal frame.
    frame_index: u32,
}

impl Temporal {
    fn new(gpu: &Gpu) -> Result<Self, TechniqueError> {
        softshadow_core::technique::check_requirements(gpu, ID, &temporal_requirements())?;
        // temporal.wgsl: TemporalParams; this frame's PCSS, the history and the positions it
        // saw; then the next history, its positions and the visibility.
        let resolve = Pass::new(gpu, "pcss/temporal", &SHADERS[1])
            .after_frame_group()
            .uniform()
            .repeat(Slot::FLOAT, 3)
            .storage_texture(wgpu::TextureFormat::Rg32Float)
            .storage_texture(wgpu::TextureFormat::Rgba32Float)
            .storage_texture(wgpu::TextureFormat::R32Float)
            .compute("temporal")?;
        let temporal = ("TEMPORAL", DefValue::Bool(true));
        let grid = ("KERNEL_GRID", DefValue::Bool(true));
        Ok(Self {
            filter_vogel: filter_pass(gpu, "pcss/filter temporal", &[temporal])?,
            filter_grid: filter_pass(gpu, "pcss/filter grid temporal", &[grid, temporal])?,
            resolve,
            params_buffer: zeroed_uniform_buffer::<TemporalUniform>(gpu, "pcss/temporal params"),
            targets: None,
            frame_index: 0,
        })
    }

    /// Drops the history: the next temporal frame starts over.
    fn invalidate(&mut self) {
        if let Some(targets) = &mut self.targets {
            targets.history.invalidate();
        }
    }

    /// This frame's rotated PCSS into `raw` (with `filter`, the map and PCSS's uniform given by
    /// the caller), blended into the history and written to `out`. The history is a mean over
    /// one size and one setting: a change of either drops it. A moved light or caster keeps it
    /// (as a TAA history is kept): the neighbourhood clip is what rejects the stale part, and
    /// what it lets through is the lag the motion runs measure. A moved camera keeps it too
    /// (reprojection follows).
    fn render(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
        s: &PcssSettings,
        filter: impl FnOnce(&mut Frame<'_>, &FullscreenPass, &wgpu::TextureView),
    ) -> u32 {
        let (width, height) = (inputs.width, inputs.height);
        if (self.targets.as_ref()).is_none_or(|x| !x.history.fits(width, height)) {
            self.targets = Some(TemporalTargets::new(frame.gpu, width, height));
        }
        if inputs.changes.size || inputs.changes.params {
            self.invalidate();
        }
        let targets = self.targets.as_mut().expect("made above");
        let pass = match s.kernel {
            Kernel::Vogel => &self.filter_vogel,
            Kernel::Grid => &self.filter_grid,
        };
        filter(frame, pass, &targets.raw_view);
        let history = &targets.history;
        frame.gpu.queue.write_buffer(
            &self.params_buffer,
            0,
            &uniform_bytes(&TemporalUniform {
                prev_view_proj: history.prev_view_proj(),
                history_valid: u32::from(history.is_valid()),
                max_history: s.max_history.max(1),
                clamp_sigma: s.clamp_sigma,
            }),
        );
        let (previous, next) = (history.previous(), history.next());
        self.resolve
            .run(frame)
            .frame_group(inputs.frame_bind_group)
            .read(&self.params_buffer)
            .read(&targets.raw_view)
            .read(previous.0)
            .read(previous.1)
            .write(next.0)
            .write(next.1)
            .write(&out.view)
            .dispatch([width.div_ceil(8), height.div_ceil(8), 1]);
        let view_proj = inputs.uniforms.view_proj();
        targets.history.advance(view_proj, s.max_history, true);
        self.frame_index = self.frame_index.wrapping_add(1);
        targets.history.frames()
    }
}

/// The PCSS lookup of one permutation (pcss.wgsl: the map's ShadowView, the map, PcssParams).
fn filter_pass(
    gpu: &Gpu,
    label: &str,
    defs: &[(&str, DefValue)],
) -> Result<FullscreenPass, TechniqueError> {
    Ok(CentreShadowMap::lookup_pass(gpu, label, &SHADERS[0])
        .defs(defs)
        .fullscreen(None)?)
}

fn view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&Default::default())
}

/// The `pcss` technique: a [`ShadowTechnique`] with its settings.
pub struct Pcss {
    /// Its settings; changes take effect on the next frame.
    pub settings: PcssSettings,
    shadow_map: CentreShadowMap,
    /// The lookup with the Vogel kernel, and with the grid (`KERNEL_GRID`): one pipeline per
    /// kernel (docs/DEVICES.md, "Lavapipe's branches").
    filter_vogel: FullscreenPass,
    filter_grid: FullscreenPass,
    params_buffer: wgpu::Buffer,
    /// The temporal mode, once it has run.
    temporal: Option<Temporal>,
    /// The sun's cascades, made by the first frame under the sun.
    sun: Option<sun::PcssSun>,
    stats: TechniqueStats,
}

impl Pcss {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: PcssSettings) -> Result<Self, TechniqueError> {
        Ok(Self {
            shadow_map: CentreShadowMap::new(gpu)?,
            filter_vogel: filter_pass(gpu, "pcss/filter", &[])?,
            filter_grid: filter_pass(
                gpu,
                "pcss/filter grid",
                &[("KERNEL_GRID", DefValue::Bool(true))],
            )?,
            params_buffer: zeroed_uniform_buffer::<PcssUniform>(gpu, "pcss/params"),
            settings,
            temporal: None,
            sun: None,
            stats: TechniqueStats::new(),
        })
    }
}

impl Pcss {
    /// The sun's frame: its cascades and their filter (`sun.rs`).
    fn render_sun(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
    ) -> Result<(), TechniqueError> {
        let gpu = frame.gpu;
        if self.sun.is_none() {
            self.sun = Some(sun::PcssSun::new(gpu)?);
        }
        let s = &self.settings;
        let uniform = PcssUniform {
            blocker_samples: s.blocker_samples,
            filter_samples: s.filter_samples,
            frame_index: 0,
            bias_texels: s.bias_texels,
            min_filter_texels: s.min_filter_texels,
        };
        (gpu.queue).write_buffer(&self.params_buffer, 0, &uniform_bytes(&uniform));
        let sun = self.sun.as_mut().expect("made above");
        self.stats = sun.render(frame, inputs, &self.settings, &self.params_buffer, out)?;
        Ok(())
    }
}

impl ShadowTechnique for Pcss {
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
        let gpu = frame.gpu;
        if inputs.light.kind == LightKind::Sun {
            return self.render_sun(frame, inputs, out);
        }
        if self
            .shadow_map
            .render(
                frame,
                inputs,
                self.settings.shadow_map_size,
                "pcss/shadow_map",
            )
            .is_none()
        {
            out.write_unshadowed(frame, inputs.frame_bind_group, "pcss/no_casters")?;
            if let Some(t) = &mut self.temporal {
                t.invalidate();
            }
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        }
        if self.settings.temporal && self.temporal.is_none() {
            self.temporal = Some(Temporal::new(gpu)?);
        }
        let s = &self.settings;
        // Only the temporal mode's frames move the kernel; plain PCSS draws frame 0's pattern
        // through the permutation without TEMPORAL, which does not read it.
        let temporal = self.temporal.as_mut().filter(|_| s.temporal);
        let uniform = PcssUniform {
            blocker_samples: s.blocker_samples,
            filter_samples: s.filter_samples,
            frame_index: temporal.as_ref().map_or(0, |t| t.frame_index),
            bias_texels: s.bias_texels,
            min_filter_texels: s.min_filter_texels,
        };
        gpu.queue
            .write_buffer(&self.params_buffer, 0, &uniform_bytes(&uniform));
        let pixels = inputs.width as f64 * inputs.height as f64;
        let mut stats = TechniqueStats::from([
            ("shadow_maps".into(), 1.0),
            (
                "max_texel_reads_per_pixel".into(),
                (s.blocker_samples + s.filter_samples) as f64,
            ),
            ("pixels".into(), pixels),
        ]);
        let (map, params, group) = (
            &self.shadow_map,
            &self.params_buffer,
            inputs.frame_bind_group,
        );
        let filter = |frame: &mut Frame<'_>, pass: &FullscreenPass, target: &wgpu::TextureView| {
            map.draw_lookup(frame, pass, "pcss/filter", group, params, target, Some(1.0));
        };
        let Some(t) = temporal else {
            // A history made before `temporal` was switched off is stale when it is switched on.
            if let Some(t) = &mut self.temporal {
                t.invalidate();
            }
            let pass = match s.kernel {
                Kernel::Vogel => &self.filter_vogel,
                Kernel::Grid => &self.filter_grid,
            };
            filter(frame, pass, &out.view);
            self.stats = stats;
            return Ok(());
        };
        let frames = t.render(frame, inputs, out, s, filter);
        stats.insert("history_frames".into(), f64::from(frames));
        stats.insert(
            "texture_bytes".into(),
            pixels * TemporalTargets::BYTES_PER_PIXEL as f64,
        );
        self.stats = stats;
        Ok(())
    }

    fn invalidate_cache(&mut self) {
        self.shadow_map.invalidate();
        if let Some(sun) = &mut self.sun {
            sun.invalidate();
        }
        if let Some(t) = &mut self.temporal {
            t.invalidate();
        }
    }

    fn stats(&self) -> TechniqueStats {
        self.stats.clone()
    }

    fn debug_views(&self) -> Vec<DebugView> {
        let mut views = self.shadow_map.debug_views();
        if let Some(targets) = self
            .temporal
            .as_ref()
            .filter(|_| self.settings.temporal)
            .and_then(|t| t.targets.as_ref())
        {
            let x = targets;
            views.push(DebugView::new(
                "history frames",
                x.history.latest(),
                DebugLegend::Value {
                    meaning: "frames averaged at this pixel".into(),
                    notes: vec![
                        "1: history rejected (another surface, off screen) or dropped".into(),
                        "technique-wide count: stats `history_frames`".into(),
                    ],
                },
            ));
            views.push(DebugView::new(
                "this frame",
                &x.raw,
                DebugLegend::value("visibility of this frame's rotated kernel, before blending"),
            ));
        }
        views
    }
}
