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
    frame::{storage_texture_entry, texture_entry, uniform_entry},
    gbuffer::create_texture,
    glam::Mat4,
    shader::{self, ShaderSpec},
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
        permutations: &[&[]],
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
    width: u32,
    height: u32,
    /// Raw visible fraction and mean hit distance (`Rg32Float`).
    raw: wgpu::Texture,
    /// Accumulated visibility and frames (`Rg32Float`), ping-pong.
    history: [wgpu::Texture; 2],
    /// World point and receiver flag the history saw (`Rgba32Float`), ping-pong.
    position: [wgpu::Texture; 2],
    /// Penumbra filter radius in pixels (`R32Float`).
    radius: wgpu::Texture,
}

impl Targets {
    fn new(gpu: &Gpu, width: u32, height: u32) -> Self {
        let usage = wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING;
        let make = |label: &str, format| create_texture(gpu, label, width, height, format, usage);
        Self {
            width,
            height,
            raw: make("raytraced/raw", wgpu::TextureFormat::Rg32Float),
            history: [
                make("raytraced/history 0", wgpu::TextureFormat::Rg32Float),
                make("raytraced/history 1", wgpu::TextureFormat::Rg32Float),
            ],
            position: [
                make("raytraced/position 0", wgpu::TextureFormat::Rgba32Float),
                make("raytraced/position 1", wgpu::TextureFormat::Rgba32Float),
            ],
            radius: make("raytraced/radius", wgpu::TextureFormat::R32Float),
        }
    }

    /// Bytes of the textures per pixel: raw 8, history 2 x 8, position 2 x 16, radius 4.
    const BYTES_PER_PIXEL: u64 = 8 + 16 + 32 + 4;
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
    trace_layout: wgpu::BindGroupLayout,
    trace: wgpu::ComputePipeline,
    denoise_layout: wgpu::BindGroupLayout,
    temporal: wgpu::ComputePipeline,
    penumbra: wgpu::ComputePipeline,
    filter: wgpu::ComputePipeline,
    trace_params: wgpu::Buffer,
    denoise_params: wgpu::Buffer,
    dummies: Dummies,
    targets: Option<Targets>,
    /// Frames traced (the sequence index).
    frame_index: u32,
    /// The ping-pong slot written last.
    current: usize,
    /// The history holds frames usable by the next one.
    history_valid: bool,
    /// Frames averaged in the history since it was last reset (the lag after a change).
    history_frames: u32,
    prev_view_proj: Mat4,
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
        let device = &gpu.device;
        let compute = wgpu::ShaderStages::COMPUTE;
        let float = wgpu::TextureSampleType::Float { filterable: false };
        let trace_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("raytraced/trace"),
            entries: &[
                uniform_entry(0, compute, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: compute,
                    ty: wgpu::BindingType::AccelerationStructure {
                        vertex_return: false,
                    },
                    count: None,
                },
                storage_texture_entry(2, wgpu::TextureFormat::Rg32Float),
            ],
        });
        let denoise_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("raytraced/denoise"),
            entries: &[
                uniform_entry(0, compute, false),
                texture_entry(1, compute, float),
                texture_entry(2, compute, float),
                texture_entry(3, compute, float),
                storage_texture_entry(4, wgpu::TextureFormat::Rg32Float),
                storage_texture_entry(5, wgpu::TextureFormat::Rgba32Float),
                storage_texture_entry(6, wgpu::TextureFormat::R32Float),
            ],
        });
        let pipeline = |spec: &ShaderSpec,
                        layout: &wgpu::BindGroupLayout,
                        entry: &str|
         -> Result<wgpu::ComputePipeline, TechniqueError> {
            let module = shader::create_module(gpu, spec, &[])?;
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(entry),
                bind_group_layouts: &[Some(&gpu.layouts.frame), Some(layout)],
                immediate_size: 0,
            });
            Ok(
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry),
                    layout: Some(&pipeline_layout),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                }),
            )
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
            temporal: pipeline(&SHADERS[1], &denoise_layout, "temporal")?,
            penumbra: pipeline(&SHADERS[1], &denoise_layout, "penumbra")?,
            filter: pipeline(&SHADERS[1], &denoise_layout, "spatial_filter")?,
            trace: pipeline(&SHADERS[0], &trace_layout, "trace")?,
            trace_layout,
            denoise_layout,
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
            current: 0,
            history_valid: false,
            history_frames: 0,
            prev_view_proj: Mat4::IDENTITY,
            stats: TechniqueStats::new(),
        })
    }

    /// A bind group of the denoise layout over `views` (inputs 1-3, outputs 4-6).
    fn denoise_group(
        &self,
        gpu: &Gpu,
        label: &str,
        views: [&wgpu::TextureView; 6],
    ) -> wgpu::BindGroup {
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: self.denoise_params.as_entire_binding(),
        }];
        for (k, v) in views.iter().enumerate() {
            entries.push(wgpu::BindGroupEntry {
                binding: k as u32 + 1,
                resource: wgpu::BindingResource::TextureView(v),
            });
        }
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: &self.denoise_layout,
            entries: &entries,
        })
    }
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
            self.history_valid = false;
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
        if self
            .targets
            .as_ref()
            .is_none_or(|t| t.width != width || t.height != height)
        {
            self.targets = Some(Targets::new(gpu, width, height));
            self.history_valid = false;
        }
        // The history is a mean over one light, one set of casters and one setting: any change
        // of those drops it (the camera may move: reprojection follows it).
        let changes = inputs.changes;
        if changes.light_space() || changes.size || !self.settings.temporal {
            self.history_valid = false;
        }
        let targets = self.targets.as_ref().expect("made above");
        let rays = self.settings.rays_per_pixel.clamp(1, 16);
        gpu.queue.write_buffer(
            &self.trace_params,
            0,
            &uniform_bytes(&TraceParams {
                light_to_world: inputs.uniforms.world_to_light().inverse(),
                rays,
                frame_index: self.frame_index,
            }),
        );
        let tlas = self.accel.tlas().expect("updated above");
        let trace_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("raytraced/trace"),
            layout: &self.trace_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.trace_params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: tlas.as_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&view(&targets.raw)),
                },
            ],
        });
        let groups = (width.div_ceil(8), height.div_ceil(8));
        frame.compute_pass("raytraced/trace", |pass| {
            pass.set_pipeline(&self.trace);
            pass.set_bind_group(0, inputs.frame_bind_group, &[]);
            pass.set_bind_group(1, &trace_group, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        });

        let (prev, cur) = (self.current, 1 - self.current);
        let temporal = self.settings.temporal;
        gpu.queue.write_buffer(
            &self.denoise_params,
            0,
            &uniform_bytes(&DenoiseParams {
                prev_view_proj: self.prev_view_proj,
                history_valid: u32::from(temporal && self.history_valid),
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
        let raw = view(&targets.raw);
        let (history_prev, history_cur) =
            (view(&targets.history[prev]), view(&targets.history[cur]));
        let (position_prev, position_cur) =
            (view(&targets.position[prev]), view(&targets.position[cur]));
        let radius = view(&targets.radius);
        let temporal_group = self.denoise_group(
            gpu,
            "raytraced/temporal",
            [
                &raw,
                &history_prev,
                &position_prev,
                &history_cur,
                &position_cur,
                &d.r,
            ],
        );
        let label = if temporal {
            "raytraced/temporal"
        } else {
            "raytraced/copy"
        };
        frame.compute_pass(label, |pass| {
            pass.set_pipeline(&self.temporal);
            pass.set_bind_group(0, inputs.frame_bind_group, &[]);
            pass.set_bind_group(1, &temporal_group, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        });
        if self.settings.spatial {
            let penumbra_group = self.denoise_group(
                gpu,
                "raytraced/penumbra",
                [&raw, &d.sampled, &d.sampled, &d.rg, &d.rgba, &radius],
            );
            frame.compute_pass("raytraced/penumbra", |pass| {
                pass.set_pipeline(&self.penumbra);
                pass.set_bind_group(0, inputs.frame_bind_group, &[]);
                pass.set_bind_group(1, &penumbra_group, &[]);
                pass.dispatch_workgroups(groups.0, groups.1, 1);
            });
        }
        let filter_group = self.denoise_group(
            gpu,
            "raytraced/filter",
            [&history_cur, &radius, &d.sampled, &d.rg, &d.rgba, &out.view],
        );
        frame.compute_pass("raytraced/filter", |pass| {
            pass.set_pipeline(&self.filter);
            pass.set_bind_group(0, inputs.frame_bind_group, &[]);
            pass.set_bind_group(1, &filter_group, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        });

        self.history_frames = if temporal && self.history_valid {
            (self.history_frames + 1).min(self.settings.max_history.max(1))
        } else {
            1
        };
        self.history_valid = temporal;
        self.current = cur;
        self.prev_view_proj = inputs.uniforms.view_proj();
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
            ("history_frames".into(), f64::from(self.history_frames)),
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
        self.history_valid = false;
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
                &t.history[self.current],
                DebugLegend::Value {
                    meaning: "visibility accumulated over frames".into(),
                    notes: vec!["frames averaged: stats `history_frames`".into()],
                },
            ),
        ]
    }
}
