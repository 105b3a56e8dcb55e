//! `ssm`: soft shadow maps (Atty, Holzschuch, Lapierre, Hasenfratz, Hansen, Sillion 2006),
//! entirely on the GPU (the paper's own future work, section 6).
//!
//! Reads: the casters (occluder map(s)), the receivers that are not casters (receiver map) and
//! the G-buffer. Writes: the visibility buffer. Passes, in order:
//!
//! 1. `ssm/occluder_map` (and `ssm/occluder_map_back` with `two_pass`): depth of the casters from
//!    the light centre, the window axis-aligned with the light and with its aspect ratio
//!    (section 3.2); the back map keeps the farthest surface (section 3.5).
//! 2. `ssm/receiver_map`: depth of the receivers over the soft shadow map's window.
//! 3. `ssm/scatter` (`ssm/scatter_back`): one instanced quad per occluder-map texel; the vertex
//!    stage builds the micro-patch and its penumbra rectangle (section 3.3), the fragment stage
//!    backprojects the patch onto the light and blends the occluded fraction additively into the
//!    soft shadow map (section 3.4). With `precision = fp16-batched` this runs once per batch of
//!    patches, each batch followed by `ssm/batch_add` into an FP32 total (appendix A).
//! 4. `ssm/project`: the soft shadow map(s), merged by maximum, projected onto the receivers.
//! 5. `ssm/stats`: counters for the report (micro-patches drawn, texels with occlusion).

#![warn(missing_docs)]

pub mod math;

use bytemuck::{Pod, Zeroable};
use softshadow_core::{
    frame::{texture_entry, uniform_entry},
    fullscreen::{uniform_buffer, FullscreenPipeline},
    glam::Vec3,
    scene_gpu::Vertex,
    shader::{create_module, DefValue, ShaderSpec},
    shader_file,
    shadow_map::ShadowViewUniform,
    wgpu, DebugLegend, DebugView, Frame, Gpu, Requirements, ShadowInputs, ShadowTechnique,
    SlopeFrustum, TechniqueError, TechniqueSettings, TechniqueStats, VisibilityBuffer,
};

mod info;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "ssm";

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "ssm/depth.wgsl",
        source: shader_file!("ssm/depth.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "ssm/scatter.wgsl",
        source: shader_file!("ssm/scatter.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "ssm/project.wgsl",
        source: shader_file!("ssm/project.wgsl").1,
        permutations: &[&[], &[("TWO_PASS", DefValue::Bool(true))]],
    },
    ShaderSpec {
        path: "ssm/batch_add.wgsl",
        source: shader_file!("ssm/batch_add.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "ssm/stats.wgsl",
        source: shader_file!("ssm/stats.wgsl").1,
        permutations: &[&[]],
    },
];

const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

softshadow_core::param_choice! {
    /// How the micro-patches' occlusion is summed in the soft shadow map (appendix A).
    pub enum Precision {
        /// FP32 blending (needs `FLOAT32_BLENDABLE`; the paper's "future hardware").
        Fp32 = "fp32",
        /// FP16 blending, as on the paper's GeForce 6800: contributions below 2^-10 of the running
        /// sum are lost, more so with larger occluder maps.
        Fp16 = "fp16",
        /// The paper's workaround: the M = N² patch slots split into floor(sqrt(M)) = N batches
        /// (one occluder-map row each), each summed with FP16 blending, the batch sums added in
        /// FP32.
        Fp16Batched = "fp16-batched",
    }
}

impl Precision {
    /// Format of the soft shadow map that micro-patches are blended into.
    fn scatter_format(self) -> wgpu::TextureFormat {
        match self {
            Precision::Fp32 => wgpu::TextureFormat::R32Float,
            Precision::Fp16 | Precision::Fp16Batched => wgpu::TextureFormat::R16Float,
        }
    }
}

softshadow_core::technique_settings! {
    /// Settings of soft shadow maps. Defaults: the paper's usual 128² occluder map (sections
    /// 4.2.4-5, 5.2), one pass, FP32 blending.
    pub struct SsmSettings {
        /// Occluder-map edge N (N² micro-patches at most)
        occluder_map_size: u32 = 128, in 64..=1024;
        /// Second occluder map of the farthest surfaces, merged by maximum (section 3.5)
        two_pass: bool = false;
        /// Blending precision of the soft shadow map: fp32, fp16, or fp16 in sqrt(M) batches
        /// summed in fp32 (appendix A)
        precision: Precision = Precision::Fp32;
        /// Soft-shadow-map and receiver-map edge in texels
        ssm_size: u32 = 128, in 32..=1024;
        /// Depth tolerance in texel footprints (receiver test and hard fallback on occluders)
        bias_texels: f32 = 1.5, in 0.0..=16.0;
    }
}

/// Mirrors `SsmParams` in `shaders/ssm/*.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct SsmUniform {
    occluder_window: [f32; 4],
    /// near, far, N, depth of an empty texel.
    occluder_depth: [f32; 4],
    ssm_window: [f32; 4],
    /// near, far, R, farthest receiver depth.
    ssm_depth: [f32; 4],
    /// a, b, bias_texels, two_pass.
    light: [f32; 4],
}

/// This crate's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![
        softshadow_core::uniform_mirror!(
            SsmUniform {
                occluder_window, occluder_depth, ssm_window, ssm_depth, light
            } => "ssm/project.wgsl", SsmParams
        ),
        softshadow_core::uniform_mirror!(
            SsmUniform {
                occluder_window, occluder_depth, ssm_window, ssm_depth, light
            } => "ssm/scatter.wgsl", SsmParams
        ),
        softshadow_core::uniform_mirror!(
            SsmUniform {
                occluder_window, occluder_depth, ssm_window, ssm_depth, light
            } => "ssm/stats.wgsl", SsmParams
        ),
    ]
}

/// A texture and its default view.
struct Target {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
}

fn target(
    gpu: &Gpu,
    label: &str,
    size: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> Target {
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    });
    Target {
        view: texture.create_view(&Default::default()),
        texture,
    }
}

/// Resources whose size depends on the settings; rebuilt when they change.
struct Resources {
    key: (u32, u32, bool, Precision),
    occluder_front: Target,
    occluder_back: Option<Target>,
    receiver: Target,
    /// What the scatter blends into (FP32 or FP16), one per occluder map.
    ssm_front: Target,
    ssm_back: Option<Target>,
    /// `fp16-batched`: the FP32 totals (the scatter targets then hold one batch).
    sum_front: Option<Target>,
    sum_back: Option<Target>,
    /// One occlusion query per scatter pass.
    queries: wgpu::QuerySet,
    query_capacity: u32,
    resolve: wgpu::Buffer,
    /// Counters at 0, occlusion results at `QUERY_OFFSET`.
    readback: wgpu::Buffer,
}

/// Byte offset of the occlusion-query results in the readback buffer.
const QUERY_OFFSET: u64 = wgpu::QUERY_RESOLVE_BUFFER_ALIGNMENT;

impl Resources {
    fn new(gpu: &Gpu, s: &SsmSettings) -> Self {
        let (n, r) = (s.occluder_map_size, s.ssm_size);
        let depth_usage =
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let color_usage = depth_usage | wgpu::TextureUsages::COPY_SRC;
        let batched = s.precision == Precision::Fp16Batched;
        let scatter = s.precision.scatter_format();
        let maps = if s.two_pass { 2 } else { 1 };
        let query_capacity = maps * if batched { n } else { 1 };
        let occluder = |label| target(gpu, label, n, DEPTH_FORMAT, depth_usage);
        let ssm = |label, format| target(gpu, label, r, format, color_usage);
        Self {
            key: (n, r, s.two_pass, s.precision),
            occluder_front: occluder("ssm/occluder_map"),
            occluder_back: s.two_pass.then(|| occluder("ssm/occluder_map_back")),
            receiver: target(gpu, "ssm/receiver_map", r, DEPTH_FORMAT, depth_usage),
            ssm_front: ssm("ssm/soft_shadow_map", scatter),
            ssm_back: s.two_pass.then(|| ssm("ssm/soft_shadow_map_back", scatter)),
            sum_front: batched
                .then(|| ssm("ssm/soft_shadow_map_sum", wgpu::TextureFormat::R32Float)),
            sum_back: (batched && s.two_pass).then(|| {
                ssm(
                    "ssm/soft_shadow_map_sum_back",
                    wgpu::TextureFormat::R32Float,
                )
            }),
            queries: gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("ssm/scatter fragments"),
                ty: wgpu::QueryType::Occlusion,
                count: query_capacity,
            }),
            query_capacity,
            resolve: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ssm/query resolve"),
                size: 8 * query_capacity as u64,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ssm/stats readback"),
                size: QUERY_OFFSET + 8 * query_capacity as u64,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
        }
    }

    /// The soft shadow maps the projection reads (front, back).
    fn final_maps(&self) -> (&Target, &Target) {
        let front = self.sum_front.as_ref().unwrap_or(&self.ssm_front);
        let back = self
            .sum_back
            .as_ref()
            .or(self.ssm_back.as_ref())
            .unwrap_or(front);
        (front, back)
    }
}

/// What the last frame did, for [`ShadowTechnique::stats`].
#[derive(Clone, Debug, Default)]
struct LastFrame {
    stats: TechniqueStats,
    /// Scatter passes whose occlusion queries and counters wait in the readback buffer.
    queries: Option<u32>,
}

/// The `ssm` technique: a [`ShadowTechnique`] with its settings.
pub struct Ssm {
    /// Its settings; changes take effect on the next frame.
    pub settings: SsmSettings,
    gpu: Gpu,
    occluder_front_pipeline: wgpu::RenderPipeline,
    occluder_back_pipeline: wgpu::RenderPipeline,
    receiver_pipeline: wgpu::RenderPipeline,
    scatter_layout: wgpu::BindGroupLayout,
    scatter_fp32: wgpu::RenderPipeline,
    scatter_fp16: wgpu::RenderPipeline,
    /// The projection with one soft shadow map and with two (`TWO_PASS`, section 3.5): one
    /// pipeline each (docs/DEVICES.md, "Lavapipe's branches").
    project: [FullscreenPipeline; 2],
    project_layout: wgpu::BindGroupLayout,
    batch_add: FullscreenPipeline,
    batch_layout: wgpu::BindGroupLayout,
    stats_pipeline: wgpu::ComputePipeline,
    stats_layout: wgpu::BindGroupLayout,
    occluder_view: wgpu::Buffer,
    occluder_view_group: wgpu::BindGroup,
    receiver_view: wgpu::Buffer,
    receiver_view_group: wgpu::BindGroup,
    params_front: wgpu::Buffer,
    params_back: wgpu::Buffer,
    counters: wgpu::Buffer,
    resources: Option<Resources>,
    last: LastFrame,
    /// The light-space maps in `resources` are complete and match the last frame's light,
    /// casters and settings.
    light_space_ready: bool,
}

/// What SSM needs at `precision`: FP32 blending for `fp32` and for the FP32 totals of
/// `fp16-batched`, and casters that are not also receivers.
fn requirements_for(precision: Precision) -> Requirements {
    Requirements {
        features: if precision == Precision::Fp16 {
            wgpu::Features::empty()
        } else {
            wgpu::Features::FLOAT32_BLENDABLE
        },
        occluder_receiver_split: true,
        ..Requirements::default()
    }
}

fn additive_blend() -> wgpu::BlendState {
    let add = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    wgpu::BlendState {
        color: add,
        alpha: add,
    }
}

fn depth_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    texture_entry(binding, visibility, wgpu::TextureSampleType::Depth)
}

fn float_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    texture_entry(
        binding,
        visibility,
        wgpu::TextureSampleType::Float { filterable: false },
    )
}

fn view_entry(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: wgpu::BindingResource::TextureView(view),
    }
}

fn layout(gpu: &Gpu, label: &str, entries: &[wgpu::BindGroupLayoutEntry]) -> wgpu::BindGroupLayout {
    gpu.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries,
        })
}

/// Position and flags: the receiver-map vertex stage drops caster triangles.
const RECEIVER_ATTRIBUTES: [wgpu::VertexAttribute; 2] =
    [Vertex::ATTRIBUTES[0], Vertex::ATTRIBUTES[2]];

impl Ssm {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: SsmSettings) -> Result<Self, TechniqueError> {
        let device = &gpu.device;
        let depth_module = create_module(gpu, &SHADERS[0], &[])?;
        let view_layout = layout(
            gpu,
            "ssm/depth view",
            &[uniform_entry(0, wgpu::ShaderStages::VERTEX, false)],
        );
        let depth_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("ssm/depth"),
                bind_group_layouts: &[Some(&view_layout)],
                immediate_size: 0,
            });
        let receiver_layout = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &RECEIVER_ATTRIBUTES,
        };
        let depth_pipeline = |label: &str,
                              entry: &str,
                              buffers: wgpu::VertexBufferLayout<'_>,
                              compare: wgpu::CompareFunction| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&depth_pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &depth_module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    buffers: &[Some(buffers)],
                },
                primitive: wgpu::PrimitiveState {
                    // Both faces: zero-thickness occluders cast from either side, and the
                    // nearest / farthest surface is chosen by the depth test alone.
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(compare),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: None,
                multiview_mask: None,
                cache: None,
            })
        };
        let less = wgpu::CompareFunction::Less;
        let occluder_front_pipeline = depth_pipeline(
            "ssm/occluder_map",
            "vs_occluder",
            Vertex::position_layout(),
            less,
        );
        let occluder_back_pipeline = depth_pipeline(
            "ssm/occluder_map_back",
            "vs_occluder",
            Vertex::position_layout(),
            wgpu::CompareFunction::Greater,
        );
        let receiver_pipeline =
            depth_pipeline("ssm/receiver_map", "vs_receiver", receiver_layout, less);

        let vertex_fragment = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        let scatter_layout = layout(
            gpu,
            "ssm/scatter",
            &[
                uniform_entry(0, vertex_fragment, false),
                depth_entry(1, wgpu::ShaderStages::VERTEX),
                depth_entry(2, wgpu::ShaderStages::FRAGMENT),
            ],
        );
        let scatter_module = create_module(gpu, &SHADERS[1], &[])?;
        let scatter_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("ssm/scatter"),
                bind_group_layouts: &[Some(&scatter_layout)],
                immediate_size: 0,
            });
        let scatter_pipeline = |format: wgpu::TextureFormat| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("ssm/scatter"),
                layout: Some(&scatter_pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &scatter_module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleStrip,
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &scatter_module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: Some(additive_blend()),
                        write_mask: wgpu::ColorWrites::RED,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let scatter_fp32 = scatter_pipeline(wgpu::TextureFormat::R32Float);
        let scatter_fp16 = scatter_pipeline(wgpu::TextureFormat::R16Float);

        let fragment = wgpu::ShaderStages::FRAGMENT;
        let project_layout = layout(
            gpu,
            "ssm/project",
            &[
                uniform_entry(0, fragment, false),
                depth_entry(1, fragment),
                depth_entry(2, fragment),
                float_entry(3, fragment),
                float_entry(4, fragment),
            ],
        );
        let project = [
            FullscreenPipeline::new(gpu, "ssm/project", &SHADERS[2], &[], &project_layout, None)?,
            FullscreenPipeline::new(
                gpu,
                "ssm/project two_pass",
                &SHADERS[2],
                &[("TWO_PASS", DefValue::Bool(true))],
                &project_layout,
                None,
            )?,
        ];
        let batch_layout = layout(gpu, "ssm/batch_add", &[float_entry(0, fragment)]);
        let batch_add = FullscreenPipeline::with_format(
            gpu,
            "ssm/batch_add",
            &SHADERS[3],
            &[],
            &batch_layout,
            wgpu::TextureFormat::R32Float,
            Some(additive_blend()),
        )?;

        let compute = wgpu::ShaderStages::COMPUTE;
        let stats_layout = layout(
            gpu,
            "ssm/stats",
            &[
                uniform_entry(0, compute, false),
                depth_entry(1, compute),
                depth_entry(2, compute),
                float_entry(3, compute),
                float_entry(4, compute),
                wgpu::BindGroupLayoutEntry {
                    binding: 5,
                    visibility: compute,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: false },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        );
        let stats_module = create_module(gpu, &SHADERS[4], &[])?;
        let stats_pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("ssm/stats"),
            layout: Some(
                &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("ssm/stats"),
                    bind_group_layouts: &[Some(&stats_layout)],
                    immediate_size: 0,
                }),
            ),
            module: &stats_module,
            entry_point: Some("count"),
            compilation_options: Default::default(),
            cache: None,
        });

        let view_buffer = |label| uniform_buffer(gpu, label, &[[0f32; 4]; 4]);
        let view_group = |label, buffer: &wgpu::Buffer| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &view_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffer.as_entire_binding(),
                }],
            })
        };
        let occluder_view = view_buffer("ssm/occluder view");
        let receiver_view = view_buffer("ssm/receiver view");
        Ok(Self {
            occluder_view_group: view_group("ssm/occluder view", &occluder_view),
            receiver_view_group: view_group("ssm/receiver view", &receiver_view),
            occluder_view,
            receiver_view,
            params_front: uniform_buffer(gpu, "ssm/params", &SsmUniform::zeroed()),
            params_back: uniform_buffer(gpu, "ssm/params back", &SsmUniform::zeroed()),
            counters: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ssm/counters"),
                size: 16,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            gpu: gpu.clone(),
            occluder_front_pipeline,
            occluder_back_pipeline,
            receiver_pipeline,
            scatter_layout,
            scatter_fp32,
            scatter_fp16,
            project,
            project_layout,
            batch_add,
            batch_layout,
            stats_pipeline,
            stats_layout,
            resources: None,
            last: LastFrame::default(),
            light_space_ready: false,
            settings,
        })
    }

    /// Reads the counters and occlusion queries of the last frame (the frame has finished: the
    /// renderer waits for the GPU before stats are asked for).
    fn read_counters(&self, resources: &Resources, queries: u32) -> Option<(u64, u64, u64)> {
        let slice = resources
            .readback
            .slice(..QUERY_OFFSET + 8 * queries as u64);
        let (sender, receiver) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = sender.send(r);
        });
        self.gpu.wait_idle().ok()?;
        receiver.recv().ok()?.ok()?;
        let counts = {
            let data = slice.get_mapped_range().ok()?;
            let word =
                |at: usize| u32::from_le_bytes(data[at..at + 4].try_into().unwrap_or([0; 4]));
            let fragments: u64 = (0..queries as usize)
                .map(|q| {
                    let at = QUERY_OFFSET as usize + 8 * q;
                    u64::from_le_bytes(data[at..at + 8].try_into().unwrap_or([0; 8]))
                })
                .sum();
            (word(0) as u64, word(4) as u64, fragments)
        };
        resources.readback.unmap();
        Some(counts)
    }
}

/// One depth pass into `target`, cleared to `clear`.
fn depth_pass(
    frame: &mut Frame<'_>,
    label: &str,
    pipeline: &wgpu::RenderPipeline,
    view_group: &wgpu::BindGroup,
    target: &wgpu::TextureView,
    clear: f32,
    draw: impl FnOnce(&mut wgpu::RenderPass<'_>),
) {
    frame.render_pass(
        label,
        wgpu::RenderPassDescriptor {
            label: None,
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: target,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(clear),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        },
        |pass| {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, view_group, &[]);
            draw(pass);
        },
    );
}

fn window(f: &SlopeFrustum) -> [f32; 4] {
    [f.s_min, f.s_max, f.t_min, f.t_max]
}

impl ShadowTechnique for Ssm {
    fn id(&self) -> &str {
        ID
    }

    fn requirements(&self) -> Requirements {
        requirements_for(self.settings.precision)
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
        let s = self.settings.clone();
        // Sizes come from a `Settings` struct a library user may fill directly: clamp them to the
        // documented ranges rather than trusting them.
        let n = s.occluder_map_size.clamp(64, 1024);
        let r = s.ssm_size.clamp(32, 1024);
        let s = SsmSettings {
            occluder_map_size: n,
            ssm_size: r,
            bias_texels: if s.bias_texels.is_finite() {
                s.bias_texels.clamp(0.0, 16.0)
            } else {
                1.5
            },
            ..s
        };
        let half = inputs.light.half_extent();
        let bounds = inputs.scene.light_bounds(inputs.light);
        let receiver_corners: Vec<Vec3> = bounds
            .receivers
            .map(|r| r.corners().to_vec())
            .unwrap_or_default();
        let occluder = bounds.casters.and_then(|c| {
            math::occluder_frustum(
                &c.corners(),
                bounds.casters_cross_light_plane,
                &receiver_corners,
                math::light_aspect(half),
            )
        });
        let Some(occluder) = occluder else {
            // No caster in front of the light: receivers in front of it are lit.
            out.write_unshadowed(frame, inputs.frame_bind_group, "ssm/no_casters")?;
            self.last = LastFrame {
                stats: TechniqueStats::from([
                    ("micro_patches_drawn".into(), 0.0),
                    ("ssm_texels_touched".into(), 0.0),
                ]),
                queries: None,
            };
            return Ok(());
        };
        let (ssm, z_far) = math::ssm_frustum(&occluder, &receiver_corners, half);

        let key = (n, r, s.two_pass, s.precision);
        if self.resources.as_ref().map(|res| res.key) != Some(key) {
            self.resources = Some(Resources::new(gpu, &s));
            self.light_space_ready = false;
        }
        // Everything but the projection is light-space (occluder, receiver and soft shadow
        // maps, counters): kept while light, casters and settings stand still.
        let rebuild = inputs.changes.light_space() || !self.light_space_ready;
        self.light_space_ready = false;
        let res = self.resources.as_ref().expect("created above");

        // Uniforms.
        let occluder_view = ShadowViewUniform::new(inputs.light, &occluder, n);
        let receiver_view = ShadowViewUniform::new(inputs.light, &ssm, r);
        gpu.queue.write_buffer(
            &self.occluder_view,
            0,
            bytemuck::bytes_of(&occluder_view.light_view_proj),
        );
        gpu.queue.write_buffer(
            &self.receiver_view,
            0,
            bytemuck::bytes_of(&receiver_view.light_view_proj),
        );
        let params = |empty_depth: f32| SsmUniform {
            occluder_window: window(&occluder),
            occluder_depth: [occluder.near, occluder.far, n as f32, empty_depth],
            ssm_window: window(&ssm),
            ssm_depth: [ssm.near, ssm.far, r as f32, z_far],
            light: [
                half.x,
                half.y,
                s.bias_texels,
                if s.two_pass { 1.0 } else { 0.0 },
            ],
        };
        gpu.queue
            .write_buffer(&self.params_front, 0, bytemuck::bytes_of(&params(1.0)));
        gpu.queue
            .write_buffer(&self.params_back, 0, bytemuck::bytes_of(&params(0.0)));

        let mut query = 0u32;
        let texels = n * n;
        if rebuild {
            // 1. Occluder map(s): nearest surfaces (cleared to 1, Less) and, for two passes, the
            //    farthest (cleared to 0, Greater), section 3.5.
            let scene = inputs.scene;
            depth_pass(
                frame,
                "ssm/occluder_map",
                &self.occluder_front_pipeline,
                &self.occluder_view_group,
                &res.occluder_front.view,
                1.0,
                |pass| scene.draw_casters(pass),
            );
            if let Some(back) = &res.occluder_back {
                depth_pass(
                    frame,
                    "ssm/occluder_map_back",
                    &self.occluder_back_pipeline,
                    &self.occluder_view_group,
                    &back.view,
                    0.0,
                    |pass| scene.draw_casters(pass),
                );
            }
            // 2. Receiver map over the soft shadow map's window.
            depth_pass(
                frame,
                "ssm/receiver_map",
                &self.receiver_pipeline,
                &self.receiver_view_group,
                &res.receiver.view,
                1.0,
                |pass| scene.draw_receivers(pass),
            );

            // 3. Scatter, per occluder map.
            let scatter_pipeline = match s.precision {
                Precision::Fp32 => &self.scatter_fp32,
                Precision::Fp16 | Precision::Fp16Batched => &self.scatter_fp16,
            };
            let mut maps: Vec<(&Target, &Target, Option<&Target>, &wgpu::Buffer, &str)> = vec![(
                &res.occluder_front,
                &res.ssm_front,
                res.sum_front.as_ref(),
                &self.params_front,
                "",
            )];
            if let (Some(occluder_back), Some(ssm_back)) = (&res.occluder_back, &res.ssm_back) {
                maps.push((
                    occluder_back,
                    ssm_back,
                    res.sum_back.as_ref(),
                    &self.params_back,
                    "_back",
                ));
            }
            for (occluder_map, scatter_target, sum, params_buffer, suffix) in maps {
                let group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("ssm/scatter"),
                    layout: &self.scatter_layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: params_buffer.as_entire_binding(),
                        },
                        view_entry(1, &occluder_map.view),
                        view_entry(2, &res.receiver.view),
                    ],
                });
                let batch_group = sum.map(|_| {
                    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("ssm/batch_add"),
                        layout: &self.batch_layout,
                        entries: &[view_entry(0, &scatter_target.view)],
                    })
                });
                // Appendix A: N batches of one occluder-map row (floor(sqrt(N²)) = N), or one draw.
                let batches: Vec<std::ops::Range<u32>> = if sum.is_some() {
                    (0..n).map(|row| row * n..(row + 1) * n).collect()
                } else {
                    std::iter::once(0..texels).collect()
                };
                let scatter_label = format!("ssm/scatter{suffix}");
                let add_label = format!("ssm/batch_add{suffix}");
                for (b, instances) in batches.into_iter().enumerate() {
                    frame.render_pass(
                        &scatter_label,
                        wgpu::RenderPassDescriptor {
                            label: None,
                            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                                view: &scatter_target.view,
                                depth_slice: None,
                                resolve_target: None,
                                ops: wgpu::Operations {
                                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                                    store: wgpu::StoreOp::Store,
                                },
                            })],
                            depth_stencil_attachment: None,
                            timestamp_writes: None,
                            occlusion_query_set: Some(&res.queries),
                            multiview_mask: None,
                        },
                        |pass| {
                            pass.set_pipeline(scatter_pipeline);
                            pass.set_bind_group(0, &group, &[]);
                            pass.begin_occlusion_query(query);
                            pass.draw(0..4, instances);
                            pass.end_occlusion_query();
                        },
                    );
                    query += 1;
                    if let (Some(sum), Some(batch_group)) = (sum, &batch_group) {
                        self.batch_add.record(
                            frame,
                            &add_label,
                            inputs.frame_bind_group,
                            batch_group,
                            &[],
                            &sum.view,
                            (b == 0).then_some(0.0),
                        );
                    }
                }
            }
        }

        // 4. Projection onto the receivers.
        let (final_front, final_back) = res.final_maps();
        let project_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("ssm/project"),
            layout: &self.project_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.params_front.as_entire_binding(),
                },
                view_entry(1, &res.receiver.view),
                view_entry(2, &res.occluder_front.view),
                view_entry(3, &final_front.view),
                view_entry(4, &final_back.view),
            ],
        });
        self.project[usize::from(self.settings.two_pass)].record(
            frame,
            "ssm/project",
            inputs.frame_bind_group,
            &project_group,
            &[],
            &out.view,
            Some(1.0),
        );

        if rebuild {
            // 5. Counters: micro-patches and texels with occlusion (compute), fragments blended
            //    (occlusion queries over the scatter passes).
            let stats_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("ssm/stats"),
                layout: &self.stats_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: self.params_front.as_entire_binding(),
                    },
                    view_entry(1, &res.occluder_front.view),
                    view_entry(
                        2,
                        &res.occluder_back
                            .as_ref()
                            .unwrap_or(&res.occluder_front)
                            .view,
                    ),
                    view_entry(3, &final_front.view),
                    view_entry(4, &final_back.view),
                    wgpu::BindGroupEntry {
                        binding: 5,
                        resource: self.counters.as_entire_binding(),
                    },
                ],
            });
            frame.encoder.clear_buffer(&self.counters, 0, None);
            let groups = n.max(r).div_ceil(8);
            frame.compute_pass("ssm/stats", |pass| {
                pass.set_pipeline(&self.stats_pipeline);
                pass.set_bind_group(0, &stats_group, &[]);
                pass.dispatch_workgroups(groups, groups, 1);
            });
            frame
                .encoder
                .copy_buffer_to_buffer(&self.counters, 0, &res.readback, 0, 8);
            debug_assert!(query <= res.query_capacity);
            frame
                .encoder
                .resolve_query_set(&res.queries, 0..query, &res.resolve, 0);
            frame.encoder.copy_buffer_to_buffer(
                &res.resolve,
                0,
                &res.readback,
                QUERY_OFFSET,
                8 * query as u64,
            );

            let maps = if s.two_pass { 2.0 } else { 1.0 };
            self.last = LastFrame {
                stats: TechniqueStats::from([
                    ("occluder_maps".into(), maps),
                    ("occluder_map_texels".into(), maps * texels as f64),
                    ("ssm_texels".into(), (r as f64) * (r as f64)),
                    ("scatter_passes".into(), query as f64),
                ]),
                queries: Some(query),
            };
        }
        self.light_space_ready = true;
        Ok(())
    }

    fn invalidate_cache(&mut self) {
        self.light_space_ready = false;
    }

    fn stats(&self) -> TechniqueStats {
        let mut stats = self.last.stats.clone();
        if let (Some(queries), Some(res)) = (self.last.queries, &self.resources) {
            if let Some((patches, texels, fragments)) = self.read_counters(res, queries) {
                stats.insert("micro_patches_drawn".into(), patches as f64);
                stats.insert("ssm_texels_shadowed".into(), texels as f64);
                stats.insert("ssm_texels_touched".into(), fragments as f64);
            }
        }
        stats
    }

    fn debug_views(&self) -> Vec<DebugView> {
        let Some(res) = &self.resources else {
            return Vec::new();
        };
        let (final_front, _) = res.final_maps();
        let mut views = vec![
            DebugView::new(
                "shadow_map",
                &res.occluder_front.texture,
                DebugLegend::Depth,
            ),
            DebugView::new("receiver_map", &res.receiver.texture, DebugLegend::Depth),
            DebugView::new(
                "soft_shadow_map",
                &final_front.texture,
                DebugLegend::value("visibility stored in the soft shadow map"),
            ),
        ];
        if let Some(back) = &res.occluder_back {
            views.push(DebugView::new(
                "occluder_map_back",
                &back.texture,
                DebugLegend::Depth,
            ));
        }
        views
    }
}
