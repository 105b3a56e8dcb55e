//! The viewer's colour-mapping passes: the renderer's outputs (shaded images, visibility
//! buffers, G-buffer receiver flags) become one gamma-space RGBA8 texture that egui shows
//! directly (registered with `egui_wgpu::Renderer::register_native_texture`, no CPU copy).

use encase::{ShaderType, StorageBuffer};
use softshadow_core::{
    frame::{texture_entry, uniform_entry},
    shader::{self, DefValue},
    uniform::{storage_bytes, uniform_bytes, uniform_size, zeroed_uniform_buffer},
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

#[derive(ShaderType)]
struct DisplayParams {
    mode: u32,
    reference_ready: u32,
    split: f32,
    full_scale: f32,
}

#[derive(ShaderType)]
struct DebugParams {
    /// 0: grey over the value range, 1: the texture's own colours.
    mode: u32,
}

/// The display passes' uniforms, and the value range they read back, against their WGSL structs
/// (tests/shaders.rs).
pub(crate) fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![
        softshadow_core::uniform_mirror!(
            DisplayParams {
                mode, reference_ready, split, full_scale
            } => "viewer/display.wgsl", DisplayParams
        ),
        softshadow_core::uniform_mirror!(
            DebugParams { mode } => "viewer/debug_view.wgsl", DebugParams
        ),
        softshadow_core::uniform_mirror!(
            RangeKeys { lo, hi, count } => "viewer/debug_range.wgsl", Range
        ),
        softshadow_core::uniform_mirror!(
            RangeKeys { lo, hi, count } => "viewer/debug_view.wgsl", Range
        ),
    ]
}

/// The value range of a debug texture as order-preserving u32 keys (`Range` in
/// `shaders/viewer/debug_range.wgsl`, which reduces it, and `debug_view.wgsl`, which reads it).
#[derive(ShaderType)]
struct RangeKeys {
    lo: u32,
    hi: u32,
    count: u32,
}

impl RangeKeys {
    /// Before the reduction: an empty range.
    const EMPTY: Self = Self {
        lo: u32::MAX,
        hi: 0,
        count: 0,
    };
}

/// Inverse of `ordered` in `debug_range.wgsl`.
fn unordered(key: u32) -> f32 {
    f32::from_bits(if key & 0x8000_0000 != 0 {
        key & 0x7fff_ffff
    } else {
        !key
    })
}

/// How a debug image was mapped to the screen, for the legend.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum DebugMapping {
    /// A depth map: caster texels black (`lo`, nearest) to white (`hi`); `count` of them hold a
    /// caster, the rest (dark blue) are empty.
    Depth { lo: f32, hi: f32, count: u32 },
    /// A float image: the red channel black (`lo`) to white (`hi`) over `count` finite texels.
    Float { lo: f32, hi: f32, count: u32 },
    /// A colour image shown as it is.
    Colour,
}

/// A texture the viewer draws into and egui samples.
pub struct DisplayTarget {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
}

impl DisplayTarget {
    pub fn new(gpu: &Gpu, label: &str, width: u32, height: u32) -> Self {
        let texture = softshadow_core::gbuffer::create_texture(
            gpu,
            label,
            width,
            height,
            DISPLAY_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::COPY_DST,
        );
        Self {
            view: texture.create_view(&Default::default()),
            texture,
        }
    }

    /// Overwrites the image with `rgba` (row-major bytes of its format and size), as drawn on
    /// another device (the render worker's debug images).
    pub fn write(&self, gpu: &Gpu, rgba: &[u8]) {
        let size = self.texture.size();
        gpu.queue.write_texture(
            self.texture.as_image_copy(),
            rgba,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * size.width),
                rows_per_image: Some(size.height),
            },
            size,
        );
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
    range_depth: wgpu::ComputePipeline,
    range_float: wgpu::ComputePipeline,
    range_depth_layout: wgpu::BindGroupLayout,
    range_float_layout: wgpu::BindGroupLayout,
    range: wgpu::Buffer,
    range_readback: wgpu::Buffer,
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
                        storage_entry(2, stage, true),
                    ],
                })
        };
        let debug_depth_layout = debug_layout("viewer/debug_depth", wgpu::TextureSampleType::Depth);
        let debug_float_layout = debug_layout("viewer/debug_float", float);
        let compute = wgpu::ShaderStages::COMPUTE;
        let range_layout = |label, sample_type| {
            gpu.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(label),
                    entries: &[
                        texture_entry(0, compute, sample_type),
                        storage_entry(1, compute, false),
                    ],
                })
        };
        let range_depth_layout =
            range_layout("viewer/debug_range_depth", wgpu::TextureSampleType::Depth);
        let range_float_layout = range_layout("viewer/debug_range_float", float);
        let range_size = uniform_size::<RangeKeys>();
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
            params: zeroed_uniform_buffer::<DisplayParams>(gpu, "viewer/display"),
            debug_params: zeroed_uniform_buffer::<DebugParams>(gpu, "viewer/debug"),
            debug_depth_layout,
            debug_float_layout,
            range_depth: compute_pipeline(
                gpu,
                "viewer/debug_range_depth",
                &[("DEPTH", DefValue::Bool(true))],
                &range_depth_layout,
            )?,
            range_float: compute_pipeline(
                gpu,
                "viewer/debug_range_float",
                &[],
                &range_float_layout,
            )?,
            range_depth_layout,
            range_float_layout,
            range: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("viewer/debug_range"),
                size: range_size,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            range_readback: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("viewer/debug_range_readback"),
                size: range_size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
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
            &uniform_bytes(&DisplayParams {
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

    /// Draws a technique's debug texture (2D depth or float, layer 0) into `target`, stretched:
    /// a depth map or a one-channel float image is mapped black to white over the range of its
    /// meaningful texels (found by `debug_range.wgsl` in the same encoder; read it with
    /// [`DisplayPass::read_debug_mapping`] once the encoder is submitted), a colour image is
    /// shown as it is.
    pub fn record_debug(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        source: &wgpu::Texture,
        target: &DisplayTarget,
    ) -> Result<DebugKind, String> {
        let DebugPasses {
            kind,
            pipeline,
            layout,
            range,
            range_layout,
            aspect,
        } = self.debug_passes(source.format())?;
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
            &uniform_bytes(&DebugParams {
                mode: u32::from(kind == DebugKind::Colour),
            }),
        );
        gpu.queue
            .write_buffer(&self.range, 0, &storage_bytes(&RangeKeys::EMPTY));
        let view = source.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2),
            aspect,
            base_array_layer: 0,
            array_layer_count: Some(1),
            ..Default::default()
        });
        self.record_range(gpu, encoder, range, range_layout, &view, source);
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
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: self.range.as_entire_binding(),
                },
            ],
        });
        draw(encoder, pipeline, &bind_group, &target.view);
        encoder.copy_buffer_to_buffer(&self.range, 0, &self.range_readback, 0, None);
        Ok(kind)
    }

    /// The pipelines that show a debug texture of `format` and find its range, with what kind of
    /// image it is and the aspect to read.
    fn debug_passes(&self, format: wgpu::TextureFormat) -> Result<DebugPasses<'_>, String> {
        let float_sample = format.sample_type(None, None);
        if format.is_depth_stencil_format() {
            return Ok(DebugPasses {
                kind: DebugKind::Depth,
                pipeline: &self.debug_depth,
                layout: &self.debug_depth_layout,
                range: &self.range_depth,
                range_layout: &self.range_depth_layout,
                aspect: wgpu::TextureAspect::DepthOnly,
            });
        }
        if float_sample != Some(wgpu::TextureSampleType::Float { filterable: true })
            && float_sample != Some(wgpu::TextureSampleType::Float { filterable: false })
        {
            return Err(format!("cannot show a {format:?} debug texture"));
        }
        // Several channels in a unorm format are colours (a classification image); one
        // channel, or float channels, are values to map.
        let colour = format.components() > 1 && !is_float_format(format);
        Ok(DebugPasses {
            kind: if colour {
                DebugKind::Colour
            } else {
                DebugKind::Float
            },
            pipeline: &self.debug_float,
            layout: &self.debug_float_layout,
            range: &self.range_float,
            range_layout: &self.range_float_layout,
            aspect: wgpu::TextureAspect::All,
        })
    }

    /// Records the `range` pass (`debug_range.wgsl`) over `view` (of `source`) into the range
    /// buffer.
    fn record_range(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        range: &wgpu::ComputePipeline,
        range_layout: &wgpu::BindGroupLayout,
        view: &wgpu::TextureView,
        source: &wgpu::Texture,
    ) {
        let range_bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("viewer/debug_range"),
            layout: range_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.range.as_entire_binding(),
                },
            ],
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("viewer/debug_range"),
                timestamp_writes: None,
            });
            pass.set_pipeline(range);
            pass.set_bind_group(0, &range_bind_group, &[]);
            pass.dispatch_workgroups(source.width().div_ceil(8), source.height().div_ceil(8), 1);
        }
    }

    /// The range the last [`DisplayPass::record_debug`] mapped (call after submitting its
    /// encoder; waits for the GPU).
    pub fn read_debug_mapping(&self, gpu: &Gpu, kind: DebugKind) -> Result<DebugMapping, GpuError> {
        if kind == DebugKind::Colour {
            return Ok(DebugMapping::Colour);
        }
        let slice = self.range_readback.slice(..);
        let (sender, receiver) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = sender.send(r);
        });
        gpu.wait_idle()?;
        receiver
            .recv()
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let keys: RangeKeys = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            StorageBuffer::new(&data[..])
                .create()
                .map_err(|e| GpuError::Readback(e.to_string()))?
        };
        self.range_readback.unmap();
        let (lo, hi, count) = if keys.count == 0 {
            (f32::NAN, f32::NAN, 0)
        } else {
            (unordered(keys.lo), unordered(keys.hi), keys.count)
        };
        Ok(match kind {
            DebugKind::Depth => DebugMapping::Depth { lo, hi, count },
            _ => DebugMapping::Float { lo, hi, count },
        })
    }
}

/// What kind of debug image [`DisplayPass::record_debug`] drew.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DebugKind {
    Depth,
    Float,
    Colour,
}

fn is_float_format(format: wgpu::TextureFormat) -> bool {
    matches!(
        format,
        wgpu::TextureFormat::R16Float
            | wgpu::TextureFormat::Rg16Float
            | wgpu::TextureFormat::Rgba16Float
            | wgpu::TextureFormat::R32Float
            | wgpu::TextureFormat::Rg32Float
            | wgpu::TextureFormat::Rgba32Float
    )
}

fn storage_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    read_only: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn compute_pipeline(
    gpu: &Gpu,
    label: &str,
    defs: &[(&str, DefValue)],
    layout: &wgpu::BindGroupLayout,
) -> Result<wgpu::ComputePipeline, GpuError> {
    let module = shader::create_module(gpu, &SHADERS[2], defs)?;
    let pipeline_layout = gpu
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(layout)],
            immediate_size: 0,
        });
    Ok(gpu
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(label),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("cs_main"),
            compilation_options: Default::default(),
            cache: None,
        }))
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
    let target = wgpu::ColorTargetState {
        format: DISPLAY_FORMAT,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    };
    Ok(softshadow_core::fullscreen::render_pipeline(
        gpu,
        label,
        &pipeline_layout,
        &module,
        &[Some(target)],
    ))
}

/// The passes that show one kind of debug texture ([`DisplayPass::record_debug`]).
struct DebugPasses<'a> {
    kind: DebugKind,
    pipeline: &'a wgpu::RenderPipeline,
    layout: &'a wgpu::BindGroupLayout,
    /// Finds the range of the meaningful texels.
    range: &'a wgpu::ComputePipeline,
    range_layout: &'a wgpu::BindGroupLayout,
    aspect: wgpu::TextureAspect,
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_preserving_keys_round_trip_and_sort_like_floats() {
        // The CPU mirror of `ordered` in debug_range.wgsl.
        let ordered = |x: f32| {
            let bits = x.to_bits();
            if bits & 0x8000_0000 != 0 {
                !bits
            } else {
                bits | 0x8000_0000
            }
        };
        let values = [-3.5f32, -1.0, -0.0, 0.0, 1e-6, 0.25, 0.999, 1.0, 4.0];
        for pair in values.windows(2) {
            assert!(ordered(pair[0]) <= ordered(pair[1]), "{pair:?}");
        }
        for x in values {
            assert_eq!(unordered(ordered(x)).to_bits(), x.to_bits());
        }
    }
}
