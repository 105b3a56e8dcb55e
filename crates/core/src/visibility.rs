//! The visibility buffer: the one output contract of every technique (docs/ARCHITECTURE.md, "The contract").
//!
//! `V(x, y)` = fraction of the area light's surface visible from the surface point seen at pixel
//! (x, y): 1 = fully lit, 0 = umbra. Pixels that see no receiver hold 1. Receiver points at or
//! behind the light plane (which a one-sided light cannot reach) hold 0.

use crate::{fullscreen::FullscreenPipeline, gbuffer::create_texture, Gpu, GpuError};

/// The fullscreen pass of [`VisibilityBuffer::write_unshadowed`] (`core/unshadowed.wgsl`, which
/// reads only group 0), made once per device.
pub(crate) struct UnshadowedPass {
    pipeline: FullscreenPipeline,
    empty_group: wgpu::BindGroup,
}

impl UnshadowedPass {
    fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        let empty = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("core/unshadowed (empty group 1)"),
                entries: &[],
            });
        let spec = crate::shader::CORE_SHADERS
            .iter()
            .find(|s| s.path == "core/unshadowed.wgsl")
            .expect("declared in CORE_SHADERS");
        Ok(Self {
            pipeline: FullscreenPipeline::new(gpu, "core/unshadowed", spec, &[], &empty, None)?,
            empty_group: gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("core/unshadowed (empty group 1)"),
                layout: &empty,
                entries: &[],
            }),
        })
    }
}

/// The visibility buffer's format.
pub const VISIBILITY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

/// The visibility buffer: V per pixel ([module docs](self)).
pub struct VisibilityBuffer {
    /// The texture.
    pub texture: wgpu::Texture,
    /// Its view.
    pub view: wgpu::TextureView,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl VisibilityBuffer {
    /// A buffer for `width` x `height` frames (render target, storage, sampled, copyable).
    pub fn new(gpu: &Gpu, label: &str, width: u32, height: u32) -> Self {
        let texture = create_texture(
            gpu,
            label,
            width,
            height,
            VISIBILITY_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::COPY_DST,
        );
        Self {
            view: texture.create_view(&Default::default()),
            texture,
            width,
            height,
        }
    }

    /// A colour attachment that overwrites (clears to `clear`) the buffer.
    pub fn attachment(&self, clear: f64) -> Option<wgpu::RenderPassColorAttachment<'_>> {
        Some(wgpu::RenderPassColorAttachment {
            view: &self.view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color {
                    r: clear,
                    g: 0.0,
                    b: 0.0,
                    a: 0.0,
                }),
                store: wgpu::StoreOp::Store,
            },
        })
    }

    /// What a technique writes when no caster lies in front of the light, so no shadow pass is
    /// needed: 1 on receivers in front of the light plane and off receivers, 0 on receivers at or
    /// behind it (the contract above; a plain clear to 1 would light those).
    pub fn write_unshadowed(
        &self,
        frame: &mut crate::Frame<'_>,
        frame_bind_group: &wgpu::BindGroup,
        label: &str,
    ) -> Result<(), GpuError> {
        let gpu = frame.gpu;
        let pass = match gpu.unshadowed.get() {
            Some(pass) => pass,
            None => {
                let pass = UnshadowedPass::new(gpu)?;
                gpu.unshadowed.get_or_init(|| pass)
            }
        };
        pass.pipeline.record(
            frame,
            label,
            frame_bind_group,
            &pass.empty_group,
            &[],
            &self.view,
            Some(1.0),
        );
        Ok(())
    }

    /// Copies `source` (same size) into this buffer.
    pub fn copy_from(&self, encoder: &mut wgpu::CommandEncoder, source: &wgpu::Texture) {
        encoder.copy_texture_to_texture(
            source.as_image_copy(),
            self.texture.as_image_copy(),
            wgpu::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
        );
    }

    /// Copies this buffer into `target` (an `R32Float` texture of the same size with
    /// `COPY_DST`).
    pub fn copy_to(&self, encoder: &mut wgpu::CommandEncoder, target: &wgpu::Texture) {
        encoder.copy_texture_to_texture(
            self.texture.as_image_copy(),
            target.as_image_copy(),
            wgpu::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
        );
    }
}
