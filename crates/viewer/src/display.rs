//! The viewer's colour-mapping passes: the renderer's outputs (shaded images, visibility
//! buffers, G-buffer receiver flags) become one gamma-space RGBA8 texture that egui shows
//! directly (registered with `egui_wgpu::Renderer::register_native_texture`, no CPU copy).

use bytemuck::{Pod, Zeroable};
use softshadow_core::{
    frame::{texture_entry, uniform_entry},
    fullscreen::uniform_buffer,
    shader::{self, DefValue},
    wgpu, Gpu, GpuError, Renderer,
};

use crate::SHADERS;

/// What the image area shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ViewMode {
    /// The technique's shaded image.
    #[default]
    Shaded,
    /// The technique's visibility buffer as grey (1 = lit = white).
    Visibility,
    /// The shaded reference.
    Reference,
    /// False-colour `V - V_ref`: red too dark, blue too bright, white exact, grey off-receiver.
    Difference,
    /// Technique on the left, reference on the right of a draggable divider.
    Split,
    /// One of the technique's own debug images.
    Debug,
}

impl ViewMode {
    pub const ALL: [ViewMode; 6] = [
        ViewMode::Shaded,
        ViewMode::Visibility,
        ViewMode::Reference,
        ViewMode::Difference,
        ViewMode::Split,
        ViewMode::Debug,
    ];

    pub fn label(self) -> &'static str {
        match self {
            ViewMode::Shaded => "Shaded",
            ViewMode::Visibility => "Visibility",
            ViewMode::Reference => "Reference",
            ViewMode::Difference => "Difference",
            ViewMode::Split => "Split",
            ViewMode::Debug => "Debug view",
        }
    }

    /// Code of the mode in `display.wgsl` (the debug view has its own pass).
    fn shader_code(self) -> u32 {
        match self {
            ViewMode::Shaded | ViewMode::Debug => 0,
            ViewMode::Visibility => 1,
            ViewMode::Reference => 2,
            ViewMode::Difference => 3,
            ViewMode::Split => 4,
        }
    }
}

/// Format of the textures handed to egui (it samples them as gamma-space `Rgba8Unorm`).
pub const DISPLAY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Mirrors `DisplayParams` in `shaders/viewer/display.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct DisplayParams {
    mode: u32,
    reference_ready: u32,
    split: f32,
    full_scale: f32,
}

/// Mirrors `DebugParams` in `shaders/viewer/debug_view.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct DebugParams {
    contrast: f32,
    _pad: [f32; 3],
}

/// A texture the viewer draws into and egui samples.
pub struct DisplayTarget {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
}

impl DisplayTarget {
    pub fn new(gpu: &Gpu, label: &str, width: u32, height: u32) -> Self {
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DISPLAY_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        Self {
            view: texture.create_view(&Default::default()),
            texture,
        }
    }
}

pub struct DisplayPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    debug_depth: wgpu::RenderPipeline,
    debug_float: wgpu::RenderPipeline,
    debug_depth_layout: wgpu::BindGroupLayout,
    debug_float_layout: wgpu::BindGroupLayout,
    debug_params: wgpu::Buffer,
}

impl DisplayPass {
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        let stage = wgpu::ShaderStages::FRAGMENT;
        let float = wgpu::TextureSampleType::Float { filterable: false };
        let layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("viewer/display"),
                entries: &[
                    texture_entry(0, stage, float),
                    texture_entry(1, stage, float),
                    texture_entry(2, stage, float),
                    texture_entry(3, stage, float),
                    texture_entry(4, stage, float),
                    texture_entry(5, stage, float),
                    uniform_entry(6, stage, false),
                ],
            });
        let display = pipeline(gpu, "viewer/display", &SHADERS[0], &[], &layout)?;
        let debug_layout = |label, sample_type| {
            gpu.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(label),
                    entries: &[
                        texture_entry(0, stage, sample_type),
                        uniform_entry(1, stage, false),
                    ],
                })
        };
        let debug_depth_layout = debug_layout("viewer/debug_depth", wgpu::TextureSampleType::Depth);
        let debug_float_layout = debug_layout("viewer/debug_float", float);
        Ok(Self {
            debug_depth: pipeline(
                gpu,
                "viewer/debug_depth",
                &SHADERS[1],
                &[("DEPTH", DefValue::Bool(true))],
                &debug_depth_layout,
            )?,
            debug_float: pipeline(
                gpu,
                "viewer/debug_float",
                &SHADERS[1],
                &[],
                &debug_float_layout,
            )?,
            pipeline: display,
            layout,
            params: uniform_buffer(gpu, "viewer/display", &DisplayParams::zeroed()),
            debug_params: uniform_buffer(gpu, "viewer/debug", &DebugParams::zeroed()),
            debug_depth_layout,
            debug_float_layout,
        })
    }

    /// Colour-maps the technique renderer's outputs (and the reference renderer's, same size)
    /// into `target` in view `mode` (`split`: divider of the split view, fraction of the width).
    /// `reference` is `None` until the reference has rendered once.
    pub fn record(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        technique: &Renderer,
        reference: Option<&Renderer>,
        (mode, split): (ViewMode, f32),
        target: &DisplayTarget,
    ) {
        gpu.queue.write_buffer(
            &self.params,
            0,
            bytemuck::bytes_of(&DisplayParams {
                mode: mode.shader_code(),
                reference_ready: u32::from(reference.is_some()),
                split: split.clamp(0.0, 1.0),
                full_scale: softshadow_metrics::DIFFERENCE_FULL_SCALE,
            }),
        );
        // Without a reference yet, its bindings read the technique's textures (never shown:
        // `reference_ready` is 0).
        let reference = reference.unwrap_or(technique);
        let technique_shaded = technique.shaded.create_view(&Default::default());
        let reference_shaded = reference.shaded.create_view(&Default::default());
        let views = [
            &technique_shaded,
            &technique.visibility.view,
            &reference_shaded,
            &reference.visibility.view,
            &technique.gbuffer.normal_view,
            &technique.gbuffer.position_view,
        ];
        let mut entries: Vec<wgpu::BindGroupEntry> = views
            .iter()
            .enumerate()
            .map(|(i, view)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: wgpu::BindingResource::TextureView(view),
            })
            .collect();
        entries.push(wgpu::BindGroupEntry {
            binding: 6,
            resource: self.params.as_entire_binding(),
        });
        let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("viewer/display"),
            layout: &self.layout,
            entries: &entries,
        });
        draw(encoder, &self.pipeline, &bind_group, &target.view);
    }

    /// Draws a technique's debug texture (2D depth or float, layer 0) into `target`, stretched.
    /// Returns an error message for a texture this pass cannot show.
    pub fn record_debug(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        source: &wgpu::Texture,
        contrast: f32,
        target: &DisplayTarget,
    ) -> Result<(), String> {
        let format = source.format();
        let (pipeline, layout, aspect) = if format.is_depth_stencil_format() {
            (
                &self.debug_depth,
                &self.debug_depth_layout,
                wgpu::TextureAspect::DepthOnly,
            )
        } else if format.sample_type(None, None)
            == Some(wgpu::TextureSampleType::Float { filterable: true })
            || format.sample_type(None, None)
                == Some(wgpu::TextureSampleType::Float { filterable: false })
        {
            (
                &self.debug_float,
                &self.debug_float_layout,
                wgpu::TextureAspect::All,
            )
        } else {
            return Err(format!("cannot show a {format:?} debug texture"));
        };
        if source.dimension() != wgpu::TextureDimension::D2
            || !source
                .usage()
                .contains(wgpu::TextureUsages::TEXTURE_BINDING)
        {
            return Err("the debug texture is not a sampled 2D texture".into());
        }
        gpu.queue.write_buffer(
            &self.debug_params,
            0,
            bytemuck::bytes_of(&DebugParams {
                contrast,
                _pad: [0.0; 3],
            }),
        );
        let view = source.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2),
            aspect,
            base_array_layer: 0,
            array_layer_count: Some(1),
            ..Default::default()
        });
        let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("viewer/debug"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.debug_params.as_entire_binding(),
                },
            ],
        });
        draw(encoder, pipeline, &bind_group, &target.view);
        Ok(())
    }
}

fn pipeline(
    gpu: &Gpu,
    label: &str,
    spec: &shader::ShaderSpec,
    defs: &[(&str, DefValue)],
    layout: &wgpu::BindGroupLayout,
) -> Result<wgpu::RenderPipeline, GpuError> {
    let module = shader::create_module(gpu, spec, defs)?;
    let pipeline_layout = gpu
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(layout)],
            immediate_size: 0,
        });
    Ok(gpu
        .device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: DISPLAY_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        }))
}

fn draw(
    encoder: &mut wgpu::CommandEncoder,
    pipeline: &wgpu::RenderPipeline,
    bind_group: &wgpu::BindGroup,
    target: &wgpu::TextureView,
) {
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("viewer/display"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: target,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[]);
    pass.draw(0..3, 0..1);
}
