//! Shading pass: one pass serves every technique (docs/ARCHITECTURE.md, "The contract").

use encase::ShaderType;

use crate::{
    frame::{texture_entry, uniform_entry, Frame},
    fullscreen::FullscreenPipeline,
    gbuffer::{create_texture, GBuffer},
    shader,
    uniform::{uniform_bytes, zeroed_uniform_buffer},
    visibility::VisibilityBuffer,
    Gpu, GpuError,
};

/// sRGB-encoded 8-bit output, so the bytes read back are what a PNG stores.
pub const SHADED_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// What the shading pass draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadingMode {
    /// Albedo lit by the area light through the visibility, plus ambient.
    Shaded = 0,
    /// The visibility as grey.
    Visibility = 1,
}

#[derive(ShaderType)]
struct ShadingParams {
    mode: u32,
}

/// The shading uniform against its WGSL struct (tests/shaders.rs).
pub(crate) fn uniform_mirror() -> shader::uniform_layout::UniformMirror {
    crate::uniform_mirror!(ShadingParams { mode } => "core/shading.wgsl", ShadingParams)
}

/// The shading pass: albedo * (ambient + V * intensity * cos), or V as grey.
pub struct ShadingPass {
    pipeline: FullscreenPipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
}

impl ShadingPass {
    /// Builds the pipeline (`shaders/core/shading.wgsl`).
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
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
        // Same fullscreen shape as every technique lookup pass, writing the sRGB colour target.
        let pipeline = FullscreenPipeline::with_format(
            gpu,
            "core/shading",
            &shader::CORE_SHADERS[2],
            &[],
            &layout,
            SHADED_FORMAT,
            None,
        )?;
        let params = zeroed_uniform_buffer::<ShadingParams>(gpu, "core/shading params");
        Ok(Self {
            pipeline,
            layout,
            params,
        })
    }

    /// The target the shading pass writes (`SHADED_FORMAT`, readable back).
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

    /// Records the pass (`shading`) from the G-buffer and `visibility` into `target`.
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
            &uniform_bytes(&ShadingParams { mode: mode as u32 }),
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
        // The fragment shader writes every pixel with alpha 1, so the clear value never shows.
        self.pipeline.record(
            frame,
            "shading",
            frame_bind_group,
            &bind_group,
            &[],
            target,
            Some(0.0),
        );
    }
}
