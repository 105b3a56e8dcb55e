//! Shading pass: one pass serves every technique (GUIDE.md section 1).

use bytemuck::{Pod, Zeroable};

use crate::{
    frame::{texture_entry, uniform_entry, Frame},
    gbuffer::{create_texture, GBuffer},
    shader,
    visibility::VisibilityBuffer,
    Gpu, GpuError,
};

/// sRGB-encoded 8-bit output, so the bytes read back are what a PNG stores.
pub const SHADED_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadingMode {
    Shaded = 0,
    Visibility = 1,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ShadingParams {
    mode: u32,
    _pad: [u32; 3],
}

pub struct ShadingPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
}

impl ShadingPass {
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        let module = shader::create_module(gpu, &shader::CORE_SHADERS[2], &[])?;
        let stage = wgpu::ShaderStages::FRAGMENT;
        let unfilterable = wgpu::TextureSampleType::Float { filterable: false };
        let layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("core/shading"),
                entries: &[
                    texture_entry(0, stage, unfilterable),
                    texture_entry(1, stage, unfilterable),
                    uniform_entry(2, stage, false),
                ],
            });
        let pipeline_layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("core/shading"),
                bind_group_layouts: &[Some(&gpu.layouts.frame), Some(&layout)],
                immediate_size: 0,
            });
        let pipeline = gpu
            .device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("core/shading"),
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
                    targets: &[Some(SHADED_FORMAT.into())],
                }),
                multiview_mask: None,
                cache: None,
            });
        let params = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("core/shading params"),
            size: std::mem::size_of::<ShadingParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(Self {
            pipeline,
            layout,
            params,
        })
    }

    pub fn create_target(gpu: &Gpu, width: u32, height: u32) -> wgpu::Texture {
        create_texture(
            gpu,
            "shaded",
            width,
            height,
            SHADED_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::TEXTURE_BINDING,
        )
    }

    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        frame: &mut Frame<'_>,
        mode: ShadingMode,
        frame_bind_group: &wgpu::BindGroup,
        gbuffer: &GBuffer,
        visibility: &VisibilityBuffer,
        target: &wgpu::TextureView,
    ) {
        let gpu = frame.gpu;
        gpu.queue.write_buffer(
            &self.params,
            0,
            bytemuck::bytes_of(&ShadingParams {
                mode: mode as u32,
                _pad: [0; 3],
            }),
        );
        let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("core/shading"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&gbuffer.albedo_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&visibility.view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: self.params.as_entire_binding(),
                },
            ],
        });
        frame.render_pass(
            "shading",
            wgpu::RenderPassDescriptor {
                label: None,
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
            },
            |pass| {
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, frame_bind_group, &[]);
                pass.set_bind_group(1, &bind_group, &[]);
                pass.draw(0..3, 0..1);
            },
        );
    }
}
