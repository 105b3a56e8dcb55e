//! `raytraced`: ray-traced soft shadows with a denoiser.
//!
//! Reads: the casters (as acceleration structures it builds with [`SceneAccel`]) and the G-buffer.
//! Writes: the visibility buffer. Passes, in order:
//!
//! - `raytraced/accel_build` (only when the casters changed: the static BLAS is kept while the
//!   static casters are, a moved dynamic instance rebuilds the dynamic BLAS and the TLAS);
//! - `raytraced/trace`: `rays_per_pixel` ray queries per receiver pixel toward points of the
//!   light (a rotated R2 sequence that goes on from frame to frame), writing the raw visible
//!   fraction and the mean hit distance;
//! - `raytraced/temporal` (setting `temporal`): the running mean of the raw values over up to
//!   `max_history` frames, reprojected with the previous camera, history rejected where the
//!   pixel saw another surface and dropped when the light, the casters or the settings change;
//!   `raytraced/copy` instead when off;
//! - `raytraced/penumbra` and `raytraced/filter` (setting `spatial`): the penumbra width from the
//!   hit distance and the light size, and an edge-stopping filter of that width;
//!   `raytraced/filter` alone copies when `spatial` is off.
//!
//! Needs `EXPERIMENTAL_RAY_QUERY` ([`softshadow_core::accel::RAY_QUERY`]).

#![warn(missing_docs)]

use encase::ShaderType;
use softshadow_core::{
    accel::RAY_QUERY,
    gbuffer::create_texture,
    glam::Mat4,
    pass::{ComputePass, Pass, Slot},
    reprojection::History,
    shader::ShaderSpec,
    shader_file,
    uniform::{uniform_bytes, zeroed_uniform_buffer},
    wgpu, DebugLegend, DebugView, Frame, Gpu, MinLimits, Requirements, SceneAccel, ShadowInputs,
    ShadowTechnique, TechniqueError, TechniqueSettings, TechniqueStats, VisibilityBuffer,
};

mod info;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "raytraced";

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "raytraced/trace.wgsl",
        source: shader_file!("raytraced/trace.wgsl").1,
        permutations: &[&[], softshadow_core::ray_alpha_test_defs!(2)],
    },
    ShaderSpec {
        path: "raytraced/denoise.wgsl",
        source: shader_file!("raytraced/denoise.wgsl").1,
        permutations: &[&[]],
    },
];

softshadow_core::technique_settings! {
    /// Settings of the `raytraced` technique.
    pub struct RaytracedSettings {
        /// Shadow rays per pixel and frame, toward points of the light that change every frame
        rays_per_pixel: u32 = 4, in 1..=16;
        /// Temporal accumulation: the running mean over frames, reprojected, history rejected on another surface
        temporal: bool = true;
        /// Frames the temporal accumulation averages at most
        max_history: u32 = 32, in 1..=1024;
        /// Spatial filter sized by the penumbra estimate, guided by depth and normal
        spatial: bool = false;
        /// Largest spatial filter radius, pixels
        max_radius: f32 = 12.0, in 1.0..=64.0;
    }
}

#[derive(ShaderType)]
struct TraceParams {
    light_to_world: Mat4,
    rays: u32,
    frame_index: u32,
}

#[derive(ShaderType)]
struct DenoiseParams {
    prev_view_proj: Mat4,
    history_valid: u32,
    max_history: u32,
    max_radius: f32,
    spatial: u32,
}

/// This crate's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![
        softshadow_core::uniform_mirror!(
            TraceParams {
                light_to_world, rays, frame_index
            } => "raytraced/trace.wgsl", TraceParams
        ),
        softshadow_core::uniform_mirror!(
            DenoiseParams {
                prev_view_proj, history_valid, max_history, max_radius, spatial
            } => "raytraced/denoise.wgsl", DenoiseParams
        ),
    ]
}

/// Per-size textures.
struct Targets {
    /// Raw visible fraction and mean hit distance (`Rg32Float`).
    raw: wgpu::Texture,
    raw_view: wgpu::TextureView,
    /// (accumulated visibility, frames) and the world point each saw.
    history: History,
    /// Penumbra filter radius in pixels (`R32Float`).
    radius: wgpu::Texture,
    radius_view: wgpu::TextureView,
}

impl Targets {
    fn new(gpu: &Gpu, width: u32, height: u32) -> Self {
        let usage = wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING;
        let make = |label: &str, format| create_texture(gpu, label, width, height, format, usage);
        let raw = make("raytraced/raw", wgpu::TextureFormat::Rg32Float);
        let radius = make("raytraced/radius", wgpu::TextureFormat::R32Float);
        Self {
            raw_view: view(&raw),
            raw,
            history: History::new(gpu, "raytraced", width, height),
            radius_view: view(&radius),
            radius,
        }
    }

    /// Bytes of the textures per pixel: raw 8, the history, radius 4.
    const BYTES_PER_PIXEL: u64 = 8 + History::BYTES_PER_PIXEL + 4;
}

/// 1 x 1 textures bound where a pass leaves a slot of the shared layout unused.
struct Dummies {
    sampled: wgpu::TextureView,
    rg: wgpu::TextureView,
    rgba: wgpu::TextureView,
    r: wgpu::TextureView,
}

/// The `raytraced` technique: a [`ShadowTechnique`] with its settings.
pub struct Raytraced {
    /// Its settings; changes take effect on the next frame.
    pub settings: RaytracedSettings,
    accel: SceneAccel,
    trace: ComputePass,
    /// The alpha-tested trace, made by the first frame of a scene with a masked caster.
    trace_masked: Option<ComputePass>,
    temporal: ComputePass,
    penumbra: ComputePass,
    filter: ComputePass,
    trace_params: wgpu::Buffer,
    denoise_params: wgpu::Buffer,
    dummies: Dummies,
    targets: Option<Targets>,
    /// Frames traced (the sequence index).
    frame_index: u32,
    stats: TechniqueStats,
}

fn view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&Default::default())
}

impl Raytraced {
    /// What the technique needs from the device: ray queries, and three storage textures per
    /// pass.
    pub fn requirements_static() -> Requirements {
        Requirements {
            features: RAY_QUERY,
            limits: MinLimits {
                max_storage_textures_per_shader_stage: 3,
                ..MinLimits::default()
            },
            ..Requirements::default()
        }
    }

    /// Builds the technique's pipelines on `gpu` with `settings`; fails with a message saying
    /// what to install on a device without ray queries.
    pub fn new(gpu: &Gpu, settings: RaytracedSettings) -> Result<Self, TechniqueError> {
        softshadow_core::technique::check_requirements(gpu, ID, &Self::requirements_static())?;
        let trace = trace_pass(gpu, false)?;
        // denoise.wgsl, one layout for its three entries: DenoiseParams, three inputs, then
        // three outputs (Rg32, Rgba32, R32).
        let denoise = |label, entry| {
            Pass::new(gpu, label, &SHADERS[1])
                .after_frame_group()
                .uniform()
                .repeat(Slot::FLOAT, 3)
                .storage_texture(wgpu::TextureFormat::Rg32Float)
                .storage_texture(wgpu::TextureFormat::Rgba32Float)
                .storage_texture(wgpu::TextureFormat::R32Float)
                .compute(entry)
        };
        let dummy = |format, usage| {
            view(&create_texture(
                gpu,
                "raytraced/unused slot",
                1,
                1,
                format,
                usage,
            ))
        };
        Ok(Self {
            temporal: denoise("raytraced/temporal", "temporal")?,
            penumbra: denoise("raytraced/penumbra", "penumbra")?,
            filter: denoise("raytraced/filter", "spatial_filter")?,
            trace,
            trace_masked: Default::default(),
            trace_params: zeroed_uniform_buffer::<TraceParams>(gpu, "raytraced/trace params"),
            denoise_params: zeroed_uniform_buffer::<DenoiseParams>(gpu, "raytraced/denoise params"),
            dummies: Dummies {
                sampled: dummy(
                    wgpu::TextureFormat::R32Float,
                    wgpu::TextureUsages::TEXTURE_BINDING,
                ),
                rg: dummy(
                    wgpu::TextureFormat::Rg32Float,
                    wgpu::TextureUsages::STORAGE_BINDING,
                ),
                rgba: dummy(
                    wgpu::TextureFormat::Rgba32Float,
                    wgpu::TextureUsages::STORAGE_BINDING,
                ),
                r: dummy(
                    wgpu::TextureFormat::R32Float,
                    wgpu::TextureUsages::STORAGE_BINDING,
                ),
            },
            accel: SceneAccel::new(),
            settings,
            targets: None,
            frame_index: 0,
            stats: TechniqueStats::new(),
        })
    }

    /// The trace pass: this frame's rays into the raw target.
    fn trace(&self, frame: &mut Frame<'_>, inputs: &ShadowInputs<'_>, rays: u32) {
        let targets = self.targets.as_ref().expect("made by render");
        frame.gpu.queue.write_buffer(
            &self.trace_params,
            0,
            &uniform_bytes(&TraceParams {
                light_to_world: inputs.uniforms.world_to_light().inverse(),
                rays,
                frame_index: self.frame_index,
            }),
        );
        let tlas = self.accel.tlas().expect("updated by render");
        // Masked casters: the alpha-tested trace (made on first use), with the material group.
        let masked = inputs.scene.materials.as_ref().filter(|m| m.masked_casters);
        let materials = masked.map(|m| m.triangles_group(frame.gpu, inputs.scene));
        let masked_pass = materials.as_ref().and(self.trace_masked.as_ref());
        let run = match (masked_pass, &materials) {
            (Some(pass), Some(group)) => pass.run(frame).materials(group),
            _ => self.trace.run(frame),
        };
        run.frame_group(inputs.frame_bind_group)
            .read(&self.trace_params)
            .read(tlas)
            .write(&targets.raw_view)
            .dispatch(workgroups(inputs));
    }

    /// The denoiser: the temporal pass (reprojected history, or a copy without `temporal`),
    /// the penumbra estimate (with `spatial`) and the spatial filter into `out`.
    fn denoise(&self, frame: &mut Frame<'_>, inputs: &ShadowInputs<'_>, out: &VisibilityBuffer) {
        let temporal = self.settings.temporal;
        let targets = self.targets.as_ref().expect("made by render");
        let history = &targets.history;
        frame.gpu.queue.write_buffer(
            &self.denoise_params,
            0,
            &uniform_bytes(&DenoiseParams {
                prev_view_proj: history.prev_view_proj(),
                history_valid: u32::from(temporal && history.is_valid()),
                max_history: if temporal {
                    self.settings.max_history.max(1)
                } else {
                    1
                },
                max_radius: self.settings.max_radius,
                spatial: u32::from(self.settings.spatial),
            }),
        );
        let d = &self.dummies;
        let (raw, radius) = (&targets.raw_view, &targets.radius_view);
        let groups = workgroups(inputs);
        let label = if temporal {
            "raytraced/temporal"
        } else {
            "raytraced/copy"
        };
        let pass = |frame: &mut Frame<'_>,
                    pass: &ComputePass,
                    label,
                    [a, b, c, x, y, z]: [&wgpu::TextureView; 6]| {
            pass.run(frame)
                .named(label)
                .frame_group(inputs.frame_bind_group)
                .read(&self.denoise_params)
                .read(a)
                .read(b)
                .read(c)
                .write(x)
                .write(y)
                .write(z)
                .dispatch(groups);
        };
        let (previous, next) = (history.previous(), history.next());
        let temporal_views = [raw, previous.0, previous.1, next.0, next.1, &d.r];
        pass(frame, &self.temporal, label, temporal_views);
        if self.settings.spatial {
            let views = [raw, &d.sampled, &d.sampled, &d.rg, &d.rgba, radius];
            pass(frame, &self.penumbra, "raytraced/penumbra", views);
        }
        let views = [next.0, radius, &d.sampled, &d.rg, &d.rgba, &out.view];
        pass(frame, &self.filter, "raytraced/filter", views);
    }
}

impl Raytraced {
    /// Drops the denoiser's history: the next frame starts over.
    fn invalidate_history(&mut self) {
        if let Some(targets) = &mut self.targets {
            targets.history.invalidate();
        }
    }
}

/// 8 x 8 workgroups over the frame.
fn workgroups(inputs: &ShadowInputs<'_>) -> [u32; 3] {
    [inputs.width.div_ceil(8), inputs.height.div_ceil(8), 1]
}

impl ShadowTechnique for Raytraced {
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
        let (width, height) = (inputs.width, inputs.height);
        if !inputs.scene.has_casters() {
            out.write_unshadowed(frame, inputs.frame_bind_group, "raytraced/no_casters")?;
            self.invalidate_history();
            self.stats = TechniqueStats::from([("rays_per_pixel".into(), 0.0)]);
            return Ok(());
        }
        self.accel
            .update(frame, inputs.scene, "raytraced/accel_build")
            .map_err(|e| TechniqueError::UnsupportedScene {
                technique: ID.into(),
                scene: inputs.scene.name.clone(),
                reason: e.to_string(),
            })?;
        if (self.targets.as_ref()).is_none_or(|t| !t.history.fits(width, height)) {
            self.targets = Some(Targets::new(gpu, width, height));
        }
        // The history is a mean over one light, one set of casters and one setting: any change
        // of those drops it (the camera may move: reprojection follows it).
        let changes = inputs.changes;
        if changes.light_space() || changes.size || !self.settings.temporal {
            self.invalidate_history();
        }
        let rays = self.settings.rays_per_pixel.clamp(1, 16);
        let masked = inputs
            .scene
            .materials
            .as_ref()
            .is_some_and(|m| m.masked_casters);
        if masked && self.trace_masked.is_none() {
            self.trace_masked = Some(trace_pass(frame.gpu, true)?);
        }
        self.trace(frame, inputs, rays);
        self.denoise(frame, inputs, out);
        let temporal = self.settings.temporal;
        let history = &mut self.targets.as_mut().expect("made above").history;
        let max_history = self.settings.max_history;
        history.advance(inputs.uniforms.view_proj(), max_history, temporal);
        let history_frames = history.frames();
        // The sequence goes on only while frames are averaged: without accumulation a new
        // pattern each frame would only flicker, and a still frame stays the same image.
        if temporal {
            self.frame_index = self.frame_index.wrapping_add(1);
        }
        let pixels = f64::from(width) * f64::from(height);
        self.stats = TechniqueStats::from([
            ("rays_per_pixel".into(), f64::from(rays)),
            // An upper bound: pixels that see no receiver, or one behind the light, cast none.
            ("rays_cast_at_most".into(), pixels * f64::from(rays)),
            ("history_frames".into(), f64::from(history_frames)),
            ("accel_triangles".into(), self.accel.triangles() as f64),
            (
                "accel_bytes_estimate".into(),
                self.accel.bytes_estimate() as f64,
            ),
            (
                "accel_structures_built".into(),
                f64::from(self.accel.last_built),
            ),
            (
                "texture_bytes".into(),
                pixels * Targets::BYTES_PER_PIXEL as f64,
            ),
        ]);
        Ok(())
    }

    fn invalidate_cache(&mut self) {
        self.accel.invalidate();
        self.invalidate_history();
    }

    fn stats(&self) -> TechniqueStats {
        self.stats.clone()
    }

    fn debug_views(&self) -> Vec<DebugView> {
        let Some(t) = &self.targets else {
            return Vec::new();
        };
        vec![
            DebugView::new(
                "raw rays",
                &t.raw,
                DebugLegend::value("visible fraction of this frame's rays"),
            ),
            DebugView::new(
                "penumbra estimate",
                &t.radius,
                DebugLegend::Value {
                    meaning: "spatial filter radius, pixels".into(),
                    notes: vec!["0: lit, umbra or no hit nearby (not filtered)".into()],
                },
            ),
            DebugView::new(
                "history",
                t.history.latest(),
                DebugLegend::Value {
                    meaning: "visibility accumulated over frames".into(),
                    notes: vec!["frames averaged: stats `history_frames`".into()],
                },
            ),
        ]
    }
}

/// The trace pass (trace.wgsl: TraceParams, the scene, the raw result); with `masked` its
/// alpha-tested variant, whose candidate loop tests each hit's material (issue 40).
fn trace_pass(gpu: &Gpu, masked: bool) -> Result<ComputePass, TechniqueError> {
    let builder = Pass::new(gpu, "raytraced/trace", &SHADERS[0])
        .after_frame_group()
        .uniform()
        .slot(Slot::AccelerationStructure)
        .storage_texture(wgpu::TextureFormat::Rg32Float);
    let builder = if masked {
        builder.material_triangles()
    } else {
        builder
    };
    Ok(builder.compute("trace")?)
}
