//! What the gather techniques (`backprojection`, `bitmask`) share on the CPU beside the depth
//! hierarchies: their settings (`GatherSettings`), the per-pass counters a gather adds up on the
//! GPU and reads back after the frame, and the targets of the view-dependent adaptive screen
//! resolution (`shaders/common/gather.wgsl`, docs/TECHNIQUES.md, `backprojection`, "Large
//! penumbrae"). The shaders' own scaffold is `softshadow::gather`.

use crate::gbuffer::create_texture;
use crate::hierarchy::HierarchyKind;
use crate::pass::Slot;
use crate::{uniform::storage_bytes, wgpu, Frame, Gpu};
use encase::{
    internal::{CreateFrom, WriteInto},
    ShaderSize, StorageBuffer,
};
use std::marker::PhantomData;

crate::param_choice! {
    /// How a shadow-map texel becomes an occluder.
    pub enum Primitive {
        /// Each texel is a rectangle parallel to the light at its depth (Guennebaud et al. 2006).
        Micropatch = "micropatch",
        /// Unprojected texel centres are the vertices of quads, each approximated by the
        /// axis-aligned rectangle through its edge centres (Schwarz & Stamminger 2007, section 4).
        Microquad = "microquad",
    }
}

impl Primitive {
    /// The value the gather shaders read (`GatherParams.primitive`).
    pub fn shader_value(self) -> u32 {
        match self {
            Primitive::Micropatch => 0,
            Primitive::Microquad => 1,
        }
    }
}

crate::technique_settings! {
    /// The settings `backprojection` and `bitmask` share (`..gather: GatherSettings;` in
    /// theirs): the map, its hierarchy, the micro-primitives, the depth bands and edge blocks,
    /// the adaptive screen resolution and the bias. Defaults: the MSSM, 16 x 16 micro-patches at
    /// most, gap filling on, three depth bands and edge blocks split two levels down.
    pub struct GatherSettings {
        /// Shadow-map edge in texels (the hierarchies pad it to a power of two)
        shadow_map_size: u32 = 1024, in 64..=4096;
        /// Depth hierarchy for search-area refinement: none (full search), hsm (min/max mip
        /// pyramid), mssm (multi-scale shadow map)
        hierarchy: HierarchyKind = HierarchyKind::Mssm;
        /// Most micro-primitives per axis per pixel (and layer); larger search areas use coarser
        /// blocks
        max_patches: u32 = 16, in 4..=32;
        /// Texel interpretation: micropatch (rectangle parallel to the light) or microquad
        /// (texel centres as quad vertices)
        primitive: Primitive = Primitive::Micropatch;
        /// Extend micro-patches to their occluding left and bottom neighbours
        gap_filling: bool = true;
        /// Depth bands gathered each at its own level, the level following the penumbra of
        /// that depth (1: one level for the whole search area, chosen by its nearest occluder)
        depth_bands: u32 = 3, in 1..=8;
        /// Levels a partly occluding block (it holds an occluder's edge) is split down into
        /// sub-blocks (0: none; micro-patches summed with a hierarchy only)
        edge_refine: u32 = 2, in 0..=3;
        /// View-dependent adaptive screen resolution: off, or pixels with a wide penumbra
        /// interpolated (edge-aware) from a gather at half or quarter resolution
        adaptive_resolution: AdaptiveResolution = AdaptiveResolution::Off;
        /// Penumbra width in screen pixels from which adaptive resolution interpolates a pixel
        adaptive_pixels: f32 = 8.0, in 1.0..=256.0;
        /// Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes and by the
        /// block size)
        bias_texels: f32 = 1.5, in 0.0..=16.0;
    }
}

impl GatherSettings {
    /// The adaptive resolution's factor (1: off). Not with the full search: it stays the
    /// yardstick, and its unrefined area says nothing about the penumbra.
    pub fn adaptive_factor(&self) -> u32 {
        match self.hierarchy {
            HierarchyKind::None => 1,
            _ => self.adaptive_resolution.factor(),
        }
    }

    /// `adaptive_pixels` as the shaders read it (8 when not finite).
    pub fn adaptive_pixels_value(&self) -> f32 {
        if self.adaptive_pixels.is_finite() {
            self.adaptive_pixels.max(0.0)
        } else {
            8.0
        }
    }
}

crate::param_choice! {
    /// View-dependent adaptive screen resolution (Guennebaud, Barthe & Paulin 2007): pixels whose
    /// penumbra is wide on screen are interpolated, edge-aware, from a coarser gather.
    pub enum AdaptiveResolution {
        /// Every pixel gathered at full resolution.
        Off = "off",
        /// Wide penumbrae from a gather of every second pixel per axis.
        Half = "half",
        /// Wide penumbrae from a gather of every fourth pixel per axis.
        Quarter = "quarter",
    }
}

impl AdaptiveResolution {
    /// Full-resolution pixels per coarse pixel along an axis (1 when off).
    pub fn factor(self) -> u32 {
        match self {
            AdaptiveResolution::Off => 1,
            AdaptiveResolution::Half => 2,
            AdaptiveResolution::Quarter => 4,
        }
    }
}

/// Counters of type `T` (a `ShaderType` struct of `u32`s, `atomic<u32>` in WGSL) that a gather
/// pass adds up per workgroup, and their copy the CPU reads after the frame.
pub struct GatherCounters<T> {
    buffer: wgpu::Buffer,
    readback: wgpu::Buffer,
    _counters: PhantomData<T>,
}

impl<T: ShaderSize + WriteInto + CreateFrom + Default> GatherCounters<T> {
    const SIZE: u64 = T::SHADER_SIZE.get();

    /// Both buffers, labelled `<label>` and `<label> readback`.
    pub fn new(gpu: &Gpu, label: &str) -> Self {
        let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: Self::SIZE,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let readback = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(&format!("{label} readback")),
            size: Self::SIZE,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            buffer,
            readback,
            _counters: PhantomData,
        }
    }

    /// The counters' buffer (a `var<storage, read_write>` of the gather).
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    /// Sets every counter to zero (before the pass).
    pub fn clear(&self, gpu: &Gpu) {
        gpu.queue
            .write_buffer(&self.buffer, 0, &storage_bytes(&T::default()));
    }

    /// Records the copy to the readback buffer (after the pass).
    pub fn copy_out(&self, frame: &mut Frame<'_>) {
        frame
            .encoder
            .copy_buffer_to_buffer(&self.buffer, 0, &self.readback, 0, Self::SIZE);
    }

    /// The counters of the last frame (waits for the GPU); `None` if the map failed.
    pub fn read(&self, gpu: &Gpu) -> Option<T> {
        let slice = self.readback.slice(..);
        let (sender, receiver) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = sender.send(r);
        });
        gpu.wait_idle().ok()?;
        receiver.recv().ok()?.ok()?;
        let counters = {
            let data = slice.get_mapped_range().ok()?;
            StorageBuffer::new(&data[..Self::SIZE as usize])
                .create()
                .ok()?
        };
        self.readback.unmap();
        Some(counters)
    }
}

/// The coarse image of adaptive screen resolution (`Rg32Float`, one texel per `factor` x `factor`
/// pixels: V and the area estimate) and two 1 x 1 stand-ins, so that each pass binds the coarse
/// image on one side only: the coarse pass writes it and reads a stand-in, the full-resolution
/// pass reads it and writes a stand-in (a texture cannot be read and written in one dispatch).
pub struct AdaptiveTargets {
    label: String,
    stand_in_read: wgpu::TextureView,
    stand_in_write: wgpu::TextureView,
    coarse: Option<((u32, u32), wgpu::TextureView)>,
}

/// Which pass the adaptive bindings are for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdaptivePass {
    /// The coarse gather: writes the coarse image.
    Coarse,
    /// The full-resolution gather: reads it (a stand-in when adaptive resolution is off).
    Full,
}

impl AdaptiveTargets {
    const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;

    /// The stand-ins, labelled under `label`.
    pub fn new(gpu: &Gpu, label: &str) -> Self {
        let usage = wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING;
        let stand_in = |name: &str| {
            create_texture(gpu, &format!("{label}/{name}"), 1, 1, Self::FORMAT, usage)
                .create_view(&Default::default())
        };
        Self {
            label: label.to_string(),
            stand_in_read: stand_in("coarse stand-in (read)"),
            stand_in_write: stand_in("coarse stand-in (write)"),
            coarse: None,
        }
    }

    /// Coarse pixels per axis for a `width` x `height` image at `factor`, or `None` when off.
    pub fn coarse_size(width: u32, height: u32, factor: u32) -> Option<(u32, u32)> {
        (factor > 1).then(|| (width.div_ceil(factor), height.div_ceil(factor)))
    }

    /// Allocates the coarse image for this frame (dropped when `factor` is 1); its size.
    pub fn prepare(
        &mut self,
        gpu: &Gpu,
        width: u32,
        height: u32,
        factor: u32,
    ) -> Option<(u32, u32)> {
        let size = Self::coarse_size(width, height, factor);
        match size {
            None => self.coarse = None,
            Some(size) if self.coarse.as_ref().map(|c| c.0) != Some(size) => {
                let texture = create_texture(
                    gpu,
                    &format!("{}/coarse", self.label),
                    size.0,
                    size.1,
                    Self::FORMAT,
                    wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
                );
                self.coarse = Some((size, texture.create_view(&Default::default())));
            }
            Some(_) => {}
        }
        size
    }

    /// The pass builder's slots of the two bindings: the coarse result read, and written.
    pub const SLOTS: [Slot; 2] = [Slot::FLOAT, Slot::StorageTexture(Self::FORMAT)];

    /// The views bound at [`AdaptiveTargets::SLOTS`] for `pass`: (read, written).
    pub fn views(&self, pass: AdaptivePass) -> (&wgpu::TextureView, &wgpu::TextureView) {
        let coarse = self.coarse.as_ref().map(|c| &c.1);
        match (pass, coarse) {
            (AdaptivePass::Coarse, Some(c)) => (&self.stand_in_read, c),
            (AdaptivePass::Full, Some(c)) => (c, &self.stand_in_write),
            (_, None) => (&self.stand_in_read, &self.stand_in_write),
        }
    }
}
