//! The history of a temporal technique (temporal PCSS, the ray-traced denoiser): per pixel a value
//! and the frames it averages (`Rg32Float`), and the world point it saw with a receiver flag
//! (`Rgba32Float`), both ping-pong, with the previous frame's camera to reproject into them. The
//! shaders' side is `softshadow::reprojection` (`shaders/common/reprojection.wgsl`).

use glam::Mat4;

use crate::{gbuffer::create_texture, Gpu};

/// A reprojected per-pixel history.
pub struct History {
    size: (u32, u32),
    /// (value, frames) or (frames, value), as the technique's shader stores them; ping-pong.
    values: [wgpu::Texture; 2],
    value_views: [wgpu::TextureView; 2],
    /// World point and receiver flag the history saw; ping-pong.
    position_views: [wgpu::TextureView; 2],
    /// The slot written last.
    current: usize,
    valid: bool,
    frames: u32,
    prev_view_proj: Mat4,
}

impl History {
    /// Bytes per pixel: values 2 x 8, positions 2 x 16.
    pub const BYTES_PER_PIXEL: u64 = 16 + 32;

    /// An empty (invalid) history of `width` x `height`, its textures named `label/...`.
    pub fn new(gpu: &Gpu, label: &str, width: u32, height: u32) -> Self {
        let usage = wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING;
        let make = |name: &str, format| {
            create_texture(
                gpu,
                &format!("{label}/{name}"),
                width,
                height,
                format,
                usage,
            )
        };
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let values = [
            make("history 0", wgpu::TextureFormat::Rg32Float),
            make("history 1", wgpu::TextureFormat::Rg32Float),
        ];
        let positions = [
            make("position 0", wgpu::TextureFormat::Rgba32Float),
            make("position 1", wgpu::TextureFormat::Rgba32Float),
        ];
        Self {
            size: (width, height),
            value_views: [view(&values[0]), view(&values[1])],
            position_views: [view(&positions[0]), view(&positions[1])],
            values,
            current: 0,
            valid: false,
            frames: 0,
            prev_view_proj: Mat4::IDENTITY,
        }
    }

    /// Whether the history is `width` x `height`.
    pub fn fits(&self, width: u32, height: u32) -> bool {
        self.size == (width, height)
    }

    /// Drops what it holds: the next frame starts over.
    pub fn invalidate(&mut self) {
        self.valid = false;
    }

    /// Whether it holds frames the next one may use.
    pub fn is_valid(&self) -> bool {
        self.valid
    }

    /// Frames averaged since it was last dropped.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// The previous frame's camera (view-projection), to reproject with.
    pub fn prev_view_proj(&self) -> Mat4 {
        self.prev_view_proj
    }

    /// What this frame reads: the values and positions written last.
    pub fn previous(&self) -> (&wgpu::TextureView, &wgpu::TextureView) {
        let k = self.current;
        (&self.value_views[k], &self.position_views[k])
    }

    /// What this frame writes: the other slot.
    pub fn next(&self) -> (&wgpu::TextureView, &wgpu::TextureView) {
        let k = 1 - self.current;
        (&self.value_views[k], &self.position_views[k])
    }

    /// The values written last (a debug view).
    pub fn latest(&self) -> &wgpu::Texture {
        &self.values[self.current]
    }

    /// After this frame's pass wrote [`History::next`]: it becomes the history, seen by a camera
    /// of `view_proj`. `accumulated` says whether the pass averaged frames (else the history
    /// holds this one frame, and is not used by the next); frames count up to `max_history`.
    pub fn advance(&mut self, view_proj: Mat4, max_history: u32, accumulated: bool) {
        self.frames = if accumulated && self.valid {
            (self.frames + 1).min(max_history.max(1))
        } else {
            1
        };
        self.valid = accumulated;
        self.current = 1 - self.current;
        self.prev_view_proj = view_proj;
    }
}
