//! The visibility buffer: the one output contract of every technique (GUIDE.md section 1).
//!
//! `V(x, y)` = fraction of the area light's surface visible from the surface point seen at pixel
//! (x, y): 1 = fully lit, 0 = umbra. Pixels that see no receiver hold 1. Receiver points at or
//! behind the light plane (which a one-sided light cannot reach) hold 0.

use crate::{gbuffer::create_texture, Gpu};

pub const VISIBILITY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

pub struct VisibilityBuffer {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub width: u32,
    pub height: u32,
}

impl VisibilityBuffer {
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

    /// Fills the buffer with 1 (fully lit): what a technique writes when the scene has no caster in
    /// front of the light, so no shadow pass is needed.
    pub fn clear_lit(&self, frame: &mut crate::Frame<'_>, label: &str) {
        frame.render_pass(
            label,
            wgpu::RenderPassDescriptor {
                label: None,
                color_attachments: &[self.attachment(1.0)],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            },
            |_| {},
        );
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
}
