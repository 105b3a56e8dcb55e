//! What the gather techniques (`backprojection`, `bitmask`) share on the CPU beside the depth
//! hierarchies: their settings (`GatherSettings`), the gather pass's uniform (`GatherUniform`),
//! the pass itself (`GatherPass`: its bindings and the coarse-then-full sequence of adaptive
//! screen resolution), the counters it adds up on the GPU and reads back after the frame
//! (`GatherCounts`), and the targets of the view-dependent adaptive screen resolution
//! (docs/TECHNIQUES.md, `backprojection`, "Large penumbrae"). The shaders' side is
//! `softshadow::gather` (the scaffold) and `softshadow::gather_pass` (the pass a technique's
//! gather file configures).

use crate::gbuffer::create_texture;
use crate::hierarchy::{HierarchyKind, Visibility};
use crate::pass::{ComputePass, Pass, Slot};
use crate::shader::{DefValue, ShaderSpec};
use crate::{uniform::storage_bytes, wgpu, Frame, Gpu, GpuError, TechniqueStats};
use encase::{
    internal::{CreateFrom, WriteInto},
    ShaderSize, ShaderType, StorageBuffer,
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
        finite_or(self.adaptive_pixels, 8.0)
    }

    /// `bias_texels` as the shaders read it (1.5 when not finite).
    pub fn bias_texels_value(&self) -> f32 {
        finite_or(self.bias_texels, 1.5)
    }

    /// Most blocks per axis of one gather: `max_patches` (range-checked: a library user may set
    /// any value), or `full_search` without a hierarchy (the technique's full-search count,
    /// [`crate::hierarchy::full_search_patches`]).
    pub fn per_axis(&self, full_search: u32) -> u32 {
        match self.hierarchy {
            HierarchyKind::None => full_search,
            _ => self.max_patches.clamp(4, 32),
        }
    }
}

/// `value` if finite (at least 0), else `default`.
fn finite_or(value: f32, default: f32) -> f32 {
    if value.is_finite() {
        value.max(0.0)
    } else {
        default
    }
}

/// What a technique adds to [`GatherSettings`] in the gather's uniform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GatherExtras {
    /// Depth layers gathered, each over its own hierarchy (backprojection: 1; bitmask: 1 to 4).
    pub layers: u32,
    /// Blocks per axis of a full search (`hierarchy = none`; [`GatherSettings::per_axis`]).
    pub full_search: u32,
    /// How the occluded area is found (backprojection's setting; bitmask sums).
    pub visibility: Visibility,
    /// Used by bitmask only: the light samples' rows and columns, the rotated-grid offsets, and
    /// whether the area estimate is written (its post filter is on).
    pub rows: u32,
    /// See `rows`.
    pub columns: u32,
    /// See `rows`.
    pub jittered: bool,
    /// See `rows`.
    pub with_area: bool,
}

impl Default for GatherExtras {
    /// One layer, the full search of one pass, summed areas, no light samples.
    fn default() -> Self {
        Self {
            layers: 1,
            full_search: crate::hierarchy::full_search_patches(1),
            visibility: Visibility::Sum,
            rows: 0,
            columns: 0,
            jittered: false,
            with_area: false,
        }
    }
}

/// The gather pass's uniform, `GatherParams` in `softshadow::gather`: the shared settings, then
/// the fields only bitmask reads. Made by [`GatherUniform::new`].
#[derive(Clone, Copy, Debug, PartialEq, ShaderType)]
pub struct GatherUniform {
    hierarchy: u32,
    primitive: u32,
    gap_filling: u32,
    max_patches: u32,
    per_axis: u32,
    bias_texels: f32,
    max_level: i32,
    depth_bands: u32,
    edge_refine: u32,
    adaptive_factor: u32,
    adaptive_pixels: f32,
    layers: u32,
    visibility: u32,
    with_area: u32,
    rows: u32,
    columns: u32,
    jittered: u32,
}

impl GatherUniform {
    /// The uniform of a frame with `settings` and `extras` over hierarchies of `max_level`
    /// levels, every value range-checked (a library user may set any).
    pub fn new(settings: &GatherSettings, max_level: u32, extras: &GatherExtras) -> Self {
        let s = settings;
        Self {
            hierarchy: s.hierarchy.shader_value(),
            primitive: s.primitive.shader_value(),
            gap_filling: u32::from(s.gap_filling),
            max_patches: s.max_patches.clamp(4, 32),
            per_axis: s.per_axis(extras.full_search),
            bias_texels: s.bias_texels_value(),
            max_level: max_level as i32,
            depth_bands: s.depth_bands.clamp(1, 8),
            edge_refine: s.edge_refine.min(3),
            adaptive_factor: s.adaptive_factor(),
            adaptive_pixels: s.adaptive_pixels_value(),
            layers: extras.layers,
            visibility: extras.visibility.shader_value(),
            with_area: u32::from(extras.with_area),
            rows: extras.rows,
            columns: extras.columns,
            jittered: u32::from(extras.jittered),
        }
    }

    /// Its layout against `GatherParams`, for the layout test (`crate::uniform_mirrors`).
    pub(crate) fn uniform_mirror() -> crate::shader::uniform_layout::UniformMirror {
        crate::uniform_mirror!(
            GatherUniform {
                hierarchy, primitive, gap_filling, max_patches, per_axis, bias_texels, max_level,
                depth_bands, edge_refine, adaptive_factor, adaptive_pixels, layers, visibility,
                with_area, rows, columns, jittered
            } => "common/gather.wgsl", GatherParams
        )
    }
}

/// What the gather pass adds up per frame (`Counters` in `softshadow::gather_pass`,
/// `atomic<u32>`s there), read back through [`GatherCounters`].
#[derive(Clone, Copy, Debug, Default, ShaderType)]
pub struct GatherCounts {
    /// Receiver pixels.
    pub receivers: u32,
    /// Receiver pixels lit by the early outs.
    pub lit: u32,
    /// Receiver pixels in umbra by the early outs.
    pub umbra: u32,
    /// Pixels that backprojected anything.
    pub backprojected: u32,
    /// Micro-primitives processed, low word.
    pub primitives_lo: u32,
    /// Micro-primitives processed, high word.
    pub primitives_hi: u32,
    /// Most micro-primitives in one pixel.
    pub primitives_max: u32,
    /// Set bits of bitmask's masks over the backprojected pixels, low word (0 elsewhere).
    pub set_bits_lo: u32,
    /// Set bits, high word.
    pub set_bits_hi: u32,
    /// Pixels interpolated from the coarse pass (adaptive screen resolution).
    pub upsampled: u32,
}

impl GatherCounts {
    /// Micro-primitives processed.
    pub fn primitives(&self) -> u64 {
        (u64::from(self.primitives_hi) << 32) | u64::from(self.primitives_lo)
    }

    /// Set bits over the backprojected pixels.
    pub fn set_bits(&self) -> u64 {
        (u64::from(self.set_bits_hi) << 32) | u64::from(self.set_bits_lo)
    }

    /// The stats both gather techniques report: `receiver_pixels`,
    /// `backprojected_pixel_fraction` (paper Fig. 8), `lit_pixel_fraction` and
    /// `umbra_pixel_fraction` (early outs), `upsampled_pixel_fraction`,
    /// `mean_primitives_per_pixel` and `mean_primitives_per_backprojected_pixel`.
    pub fn insert_stats(&self, stats: &mut TechniqueStats) {
        let receivers = self.receivers.max(1) as f64;
        let primitives = self.primitives() as f64;
        let mut insert = |key: &str, value: f64| stats.insert(key.into(), value);
        insert("receiver_pixels", self.receivers as f64);
        insert(
            "backprojected_pixel_fraction",
            self.backprojected as f64 / receivers,
        );
        insert("lit_pixel_fraction", self.lit as f64 / receivers);
        insert("umbra_pixel_fraction", self.umbra as f64 / receivers);
        insert(
            "upsampled_pixel_fraction",
            self.upsampled as f64 / receivers,
        );
        insert("mean_primitives_per_pixel", primitives / receivers);
        insert(
            "mean_primitives_per_backprojected_pixel",
            primitives / self.backprojected.max(1) as f64,
        );
    }

    /// Its layout against `Counters`, for the layout test (`crate::uniform_mirrors`).
    pub(crate) fn uniform_mirror() -> crate::shader::uniform_layout::UniformMirror {
        crate::uniform_mirror!(
            GatherCounts {
                receivers, lit, umbra, backprojected, primitives_lo, primitives_hi, primitives_max,
                set_bits_lo, set_bits_hi, upsampled
            } => "common/gather_pass.wgsl", Counters
        )
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

/// What a technique's gather passes share from frame to frame: the uniform's buffer, the
/// counters and the coarse image of adaptive resolution.
pub struct GatherBuffers {
    params: wgpu::Buffer,
    counters: GatherCounters<GatherCounts>,
    adaptive: AdaptiveTargets,
}

impl GatherBuffers {
    /// The buffers, labelled `<label>/params`, `<label>/counters` and under `label`.
    pub fn new(gpu: &Gpu, label: &str) -> Self {
        Self {
            params: crate::uniform::zeroed_uniform_buffer::<GatherUniform>(
                gpu,
                &format!("{label}/params"),
            ),
            counters: GatherCounters::new(gpu, &format!("{label}/counters")),
            adaptive: AdaptiveTargets::new(gpu, label),
        }
    }

    /// Before the frame's gather: writes its uniform, clears the counters and sizes the coarse
    /// image for a `width` x `height` image at the uniform's adaptive factor.
    pub fn prepare(&mut self, gpu: &Gpu, uniform: &GatherUniform, width: u32, height: u32) {
        let bytes = crate::uniform::uniform_bytes(uniform);
        gpu.queue.write_buffer(&self.params, 0, &bytes);
        self.counters.clear(gpu);
        (self.adaptive).prepare(gpu, width, height, uniform.adaptive_factor);
    }

    /// The counts of the last gather (waits for the GPU); `None` if the read failed.
    pub fn counts(&self, gpu: &Gpu) -> Option<GatherCounts> {
        self.counters.read(gpu)
    }
}

/// What the gather pass binds in one frame (`softshadow::gather_pass`), beside
/// [`GatherBuffers`].
pub struct GatherBindings<'a> {
    /// The core frame group (group 0).
    pub frame_group: &'a wgpu::BindGroup,
    /// The centre map's `ShadowView`.
    pub view: &'a wgpu::Buffer,
    /// Where V goes.
    pub visibility: &'a wgpu::TextureView,
    /// The gather level per pixel (`R32Float`).
    pub level: &'a wgpu::TextureView,
    /// The technique's own image (binding 7, the slot given to [`GatherPass::new`]).
    pub own: &'a wgpu::TextureView,
    /// Each bound layer's (HSM, MSSM), as many as the pass's layers.
    pub layers: Vec<(&'a wgpu::TextureView, &'a wgpu::TextureView)>,
}

/// The gather pass of one technique's gather file over `softshadow::gather_pass`: its
/// full-resolution entry `gather` and, compiled when adaptive resolution first asks for it
/// (llvmpipe compiles a pipeline when it is created: not for every technique made), the coarse
/// entry `gather_coarse`.
pub struct GatherPass {
    label: String,
    spec: &'static ShaderSpec,
    defs: Vec<(&'static str, DefValue)>,
    own: Slot,
    layers: u32,
    full: ComputePass,
    coarse: Option<ComputePass>,
}

impl GatherPass {
    /// The pass labelled `label` (`<label>_coarse` for the coarse one) of `spec` with `defs`,
    /// binding `layers` hierarchies (the def `GATHER_LAYERS`, 1 or 4) and the technique's own
    /// image as `own`.
    pub fn new(
        gpu: &Gpu,
        label: &str,
        spec: &'static ShaderSpec,
        defs: &[(&'static str, DefValue)],
        layers: u32,
        own: Slot,
    ) -> Result<Self, GpuError> {
        let mut defs = defs.to_vec();
        defs.push(("GATHER_LAYERS", DefValue::UInt(layers)));
        let full = Self::declare(gpu, label, spec, &defs, layers, own, "gather")?;
        Ok(Self {
            label: label.to_string(),
            spec,
            defs,
            own,
            layers,
            full,
            coarse: None,
        })
    }

    /// The bindings of `softshadow::gather_pass`, entry `entry`.
    fn declare(
        gpu: &Gpu,
        label: &str,
        spec: &'static ShaderSpec,
        defs: &[(&'static str, DefValue)],
        layers: u32,
        own: Slot,
        entry: &str,
    ) -> Result<ComputePass, GpuError> {
        let r32 = wgpu::TextureFormat::R32Float;
        let mut pass = Pass::new(gpu, label, spec)
            .defs(defs)
            .after_frame_group()
            .uniform()
            .uniform()
            .storage_texture(r32)
            .storage_texture(r32)
            .storage_rw()
            .slot(AdaptiveTargets::SLOTS[0])
            .slot(AdaptiveTargets::SLOTS[1])
            .slot(own);
        for _ in 0..layers {
            pass = pass.texture(Slot::FLOAT).texture(FLOAT_ARRAY);
        }
        pass.compute(entry)
    }

    /// Runs the gather into a `width` x `height` image: first, when `buffers` hold a coarse
    /// image this frame ([`GatherBuffers::prepare`]), the coarse pass writing it, then the
    /// full-resolution pass reading it; then the counters' copy for [`GatherBuffers::counts`].
    pub fn run(
        &mut self,
        frame: &mut Frame<'_>,
        buffers: &GatherBuffers,
        bindings: &GatherBindings<'_>,
        (width, height): (u32, u32),
    ) -> Result<(), GpuError> {
        if let Some(((w, h), _)) = buffers.adaptive.coarse {
            if self.coarse.is_none() {
                let label = format!("{}_coarse", self.label);
                let coarse = Self::declare(
                    frame.gpu,
                    &label,
                    self.spec,
                    &self.defs,
                    self.layers,
                    self.own,
                    "gather_coarse",
                )?;
                self.coarse = Some(coarse);
            }
            let coarse = self.coarse.as_ref().expect("compiled above");
            let which = AdaptivePass::Coarse;
            Self::dispatch(frame, coarse, buffers, which, bindings, (w, h));
        }
        let full = AdaptivePass::Full;
        Self::dispatch(frame, &self.full, buffers, full, bindings, (width, height));
        buffers.counters.copy_out(frame);
        Ok(())
    }

    fn dispatch(
        frame: &mut Frame<'_>,
        pass: &ComputePass,
        buffers: &GatherBuffers,
        which: AdaptivePass,
        b: &GatherBindings<'_>,
        (w, h): (u32, u32),
    ) {
        let (coarse_read, coarse_write) = buffers.adaptive.views(which);
        let mut run = (pass.run(frame))
            .frame_group(b.frame_group)
            .read(b.view)
            .read(&buffers.params)
            .write(b.visibility)
            .write(b.level)
            .write(buffers.counters.buffer())
            .read(coarse_read)
            .write(coarse_write)
            .write(b.own);
        for (hsm, mssm) in &b.layers {
            run = run.read(*hsm).read(*mssm);
        }
        run.dispatch([w.div_ceil(8), h.div_ceil(8), 1]);
    }
}

/// A `texture_2d_array<f32>` read with `textureLoad` (the MSSM levels).
const FLOAT_ARRAY: Slot = Slot::Texture {
    sample: wgpu::TextureSampleType::Float { filterable: false },
    dimension: wgpu::TextureViewDimension::D2Array,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_uniform_takes_the_full_search_count_only_without_a_hierarchy() {
        let extras = GatherExtras {
            full_search: 99,
            ..Default::default()
        };
        let mssm = GatherSettings::default();
        let uniform = GatherUniform::new(&mssm, 5, &extras);
        assert_eq!((uniform.max_patches, uniform.per_axis), (16, 16));
        let none = GatherSettings {
            hierarchy: HierarchyKind::None,
            ..Default::default()
        };
        let uniform = GatherUniform::new(&none, 5, &extras);
        assert_eq!((uniform.max_patches, uniform.per_axis), (16, 99));
        assert_eq!(uniform.max_level, 5);
    }

    #[test]
    fn the_uniform_range_checks_what_a_library_user_may_set() {
        let wild = GatherSettings {
            max_patches: 1000,
            bias_texels: f32::NAN,
            adaptive_pixels: f32::INFINITY,
            depth_bands: 0,
            edge_refine: 9,
            ..Default::default()
        };
        let u = GatherUniform::new(&wild, 0, &GatherExtras::default());
        assert_eq!((u.max_patches, u.per_axis), (32, 32));
        assert_eq!((u.bias_texels, u.adaptive_pixels), (1.5, 8.0));
        assert_eq!((u.depth_bands, u.edge_refine), (1, 3));
        assert_eq!(GatherExtras::default().full_search, 240);
    }
}
