//! `adaptive`: adaptive light-source sampling driven by counts of differing pixels (Schwärzler 2009).
//!
//! Hard shadow maps are placed on the light only where neighbouring maps disagree in camera
//! space. A frame, top to bottom:
//!
//! 1. `adaptive/shadow_map`: depth maps of the casters from the initial samples (the ends of a
//!    linear light, the corners of a rectangular one, or the centres of their halves / quadrants
//!    with `start=centre`), one layer each of a 2D texture array.
//! 2. `adaptive/compare`: for every leaf cell, its pairs of maps (the ends, or the two diagonals)
//!    reprojected at every G-buffer pixel and compared (eq. 3 or eq. 7); differing pixels pass and
//!    are counted per pair, the paper's occlusion query done as an atomic counter (an occlusion
//!    query without Vulkan's precise bit may count anything non-zero: docs/DEVICES.md). The
//!    frame so far is submitted and the counts read back: one CPU-GPU round trip per level.
//! 3. A cell splits when p / (SM_x x SM_y) >= epsilon (eq. 4) for one of its pairs, within
//!    `max_depth` and `max_shadow_maps`; the new samples' maps are rendered and step 2 repeats
//!    over the new cells until no cell splits.
//! 4. `adaptive/evaluate` (one pass over the texture array, section 3.4.2, weights of eq. 5 / 6)
//!    or `adaptive/accumulate` (one pass per map into an accumulation buffer, equal weights,
//!    section 3.4.1) + `adaptive/resolve`.
//!
//! Reads: the casters and the G-buffer. Writes: the visibility buffer. Maps are kept across frames
//! while the light, the casters and the parameters stand still (a camera-only frame redoes the
//! camera-dependent comparisons and renders only maps of samples it has not kept).

#![warn(missing_docs)]

pub mod refine;

use std::collections::{BTreeMap, BTreeSet};

use encase::ShaderType;
use refine::{Cell, Layout, SampleKey, Shape};
use softshadow_core::{
    glam::{UVec4, Vec2, Vec4},
    light_shape::concentric_disk,
    pass::{FullscreenPass, Pass, Slot},
    shader::{DefValue, ShaderSpec},
    shader_file,
    shadow_map::{
        create_depth_maps, fit_caster_view, fit_hard_view, layer_view, DepthMapRenderer,
        ShadowViewUniform,
    },
    uniform::{storage_bytes, uniform_bytes, uniform_size, zeroed_uniform_buffer},
    wgpu, AreaLight, DebugLegend, DebugView, Frame, Gpu, GpuError, LightKind, Requirements,
    ShadowInputs, ShadowTechnique, TechniqueError, TechniqueSettings, TechniqueStats,
    VisibilityBuffer,
};

pub use refine::{Start, Weighting};

/// Light-space position of sample `key`: on the rectangle the layout's lattice point; on a disk,
/// sphere (its disk in the light plane) or spot the same point carried onto the disk by the
/// concentric map, which keeps areas, so the cells' weights (eq. 5 / 6) still hold
/// (docs/LIGHTS.md, "Round lights in the seed techniques").
fn light_point(light: &AreaLight, layout: &Layout, key: SampleKey) -> Vec2 {
    if light.kind == LightKind::Rect {
        return layout.position(key, light.half_extent());
    }
    let unit = layout.position(key, Vec2::splat(0.5)) + Vec2::splat(0.5);
    concentric_disk(unit) * light.radius
}

mod info;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "adaptive";

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "adaptive/compare.wgsl",
        source: shader_file!("adaptive/compare.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "adaptive/evaluate.wgsl",
        source: shader_file!("adaptive/evaluate.wgsl").1,
        permutations: &[&[], &[PCF], &[ACCUMULATE], &[ACCUMULATE, PCF]],
    },
    ShaderSpec {
        path: "adaptive/resolve.wgsl",
        source: shader_file!("adaptive/resolve.wgsl").1,
        permutations: &[&[]],
    },
];

softshadow_core::param_choice! {
    /// Which depth comparison decides that two reprojected maps differ at a pixel.
    pub enum ThresholdMode {
        /// |z_a - z_b| >= gamma, light-space depth in world units (eq. 3).
        Absolute = "absolute",
        /// |1 - z_a / z_b| >= gamma on linear depth (eq. 7, the paper's 2D implementation).
        Relative = "relative",
    }
}

softshadow_core::param_choice! {
    /// How the maps become visibility.
    pub enum Evaluation {
        /// One pass over a 2D texture array of all maps, weighted (section 3.4.2).
        Array = "array",
        /// One pass per map into an accumulation buffer, equal weights (section 3.4.1).
        Accumulate = "accumulate",
    }
}

softshadow_core::technique_settings! {
    /// Settings of adaptive light-source sampling.
    pub struct AdaptiveSettings {
        /// Refine while differing pixels / shadow-map texels >= epsilon (eq. 4); 0 refines to max_depth
        epsilon: f32 = 0.0005, in 0.0..=1.0;
        /// Depth comparison of the reprojected maps: absolute (eq. 3) or relative (eq. 7)
        threshold_mode: ThresholdMode = ThresholdMode::Relative;
        /// Threshold gamma: world units (absolute) or a fraction of the depth (relative)
        gamma: f32 = 0.01, in 0.0..=1000.0;
        /// Samples start at the cell corners (the paper) or at the centres of its quadrants
        start: Start = Start::Corners;
        /// Subdivision every frame starts from, without comparisons (0: the paper's 4 corners;
        /// 1 adds the centre and edge midpoints, so an occluder that hides the middle of the
        /// light but no corner is still found)
        min_depth: u32 = 1, in 0..=7;
        /// Deepest subdivision of the light (corners: (2^d+1)^2 maps; centre: 2^(d+1) squared)
        max_depth: u32 = 3, in 0..=7;
        /// Most shadow maps rendered in one frame (the refinement stops splitting at this cap)
        max_shadow_maps: u32 = 128, in 2..=512;
        /// Map weights: paper (eq. 5 / eq. 6, normalised), area (each leaf's area shared by its
        /// corners: the trapezoid rule, no edge bias) or off (every map weighs 1/n)
        weights: Weighting = Weighting::Paper;
        /// Evaluation: one pass over a texture array, or one pass per map into an accumulation buffer
        evaluation: Evaluation = Evaluation::Array;
        /// 2x2 percentage-closer filtering of each map (section 3.4.3)
        pcf: bool = false;
        /// Edge of each shadow map in texels (the paper: 512)
        shadow_map_size: u32 = 512, in 64..=2048;
        /// Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes)
        bias_texels: f32 = 1.5, in 0.0..=16.0;
    }
}

#[derive(ShaderType)]
struct Params {
    values: Vec4,
    counts: UVec4,
}

/// This crate's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![
        softshadow_core::uniform_mirror!(
            Params { values, counts } => "adaptive/compare.wgsl", Params
        ),
        softshadow_core::uniform_mirror!(
            Params { values, counts } => "adaptive/evaluate.wgsl", Params
        ),
        softshadow_core::uniform_mirror!(
            Params { values, counts } => "adaptive/resolve.wgsl", Params
        ),
    ]
}

/// Most maps a frame may use: the length of the `views` uniform array in the shaders (512 x 112
/// bytes fits the 64 KiB uniform binding limit), and the top of the `max_shadow_maps` range.
const MAX_MAPS: u32 = 512;

/// Bytes of one compared pair or evaluated map in the item buffers (`vec4<u32>`).
const ITEM_BYTES: u64 = 16;

/// What one refinement level measured.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelReport {
    /// Leaf cells compared at this level.
    pub cells: u32,
    /// Pairs compared (the paper's occlusion queries; counters here).
    pub queries: u32,
    /// Differing pixels summed over the pairs (the counters' values).
    pub differing_pixels: u64,
    /// Cells split after this level.
    pub splits: u32,
}

/// What the last frame did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameReport {
    /// Maps in the final image.
    pub maps_used: u32,
    /// Maps this frame needed (used or compared), kept or rendered.
    pub maps_generated: u32,
    /// Depth passes recorded this frame (maps not kept from an earlier frame).
    pub maps_rendered: u32,
    /// Deepest leaf cell.
    pub depth_reached: u32,
    /// What each refinement level did.
    pub levels: Vec<LevelReport>,
    /// `Frame::submit_and_wait` calls (one per level with comparisons).
    pub round_trips: u32,
    /// Light-space positions (u, v) and weights of the maps in the final image.
    pub samples: Vec<(Vec2, f64)>,
}

/// GPU resources sized by the settings (map edge, layer capacity); rebuilt when they change.
struct Store {
    size: u32,
    capacity: u32,
    /// The depth maps, one layer per sample (kept alive beside its views).
    _maps: wgpu::Texture,
    layer_views: Vec<wgpu::TextureView>,
    views: wgpu::Buffer,
    /// Compared pairs (one level) or evaluated maps.
    pairs: wgpu::Buffer,
    terms: wgpu::Buffer,
    /// Differing pixels per compared pair (`atomic<u32>` each), cleared before every level.
    counts: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Every layer, as the passes read them.
    array_view: wgpu::TextureView,
    /// Layer of every kept map, by sample key (valid while `kept_layout` matches).
    layers: BTreeMap<SampleKey, u32>,
    /// View uniform of every layer (index = layer).
    layer_uniforms: Vec<ShadowViewUniform>,
    kept_layout: Option<Layout>,
}

/// The `adaptive` technique: a [`ShadowTechnique`] with its settings.
pub struct Adaptive {
    /// Its settings; changes take effect on the next frame.
    pub settings: AdaptiveSettings,
    depth: DepthMapRenderer,
    compare: FullscreenPass,
    /// The evaluation and the accumulation, each without and with PCF (`[off, on]`): a
    /// permutation per setting (docs/DEVICES.md, "Lavapipe's branches").
    evaluate: [FullscreenPass; 2],
    accumulate: [FullscreenPass; 2],
    resolve: FullscreenPass,
    params: wgpu::Buffer,
    store: Option<Store>,
    /// Per pixel, how many pairs differed at the last level compared (debug view and tests).
    differing: Option<VisibilityBuffer>,
    accumulation: Option<VisibilityBuffer>,
    report: FrameReport,
}

/// The defs of `adaptive/evaluate.wgsl`: one pass per map with additive blending, and 2x2 PCF.
const ACCUMULATE: (&str, DefValue) = ("ACCUMULATE", DefValue::Bool(true));
const PCF: (&str, DefValue) = ("PCF", DefValue::Bool(true));

impl Adaptive {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: AdaptiveSettings) -> Result<Self, TechniqueError> {
        softshadow_core::technique::check_requirements(gpu, ID, &Self::requirements_static())?;
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let additive = Some(wgpu::BlendState {
            color: add,
            alpha: add,
        });
        // compare.wgsl and evaluate.wgsl: Params, every map's ShadowView, the pairs or terms,
        // the maps, the compare pass's differing-pixel counters (unused by the evaluation).
        let maps_pass = |label, spec, defs, blend| {
            Pass::new(gpu, label, spec)
                .defs(defs)
                .after_frame_group()
                .repeat(Slot::Uniform, 3)
                .texture(Slot::DEPTH_ARRAY)
                .storage_rw()
                .fullscreen(blend)
        };
        let evaluate = &SHADERS[1];
        Ok(Self {
            depth: DepthMapRenderer::new(gpu)?,
            compare: maps_pass("adaptive/compare", &SHADERS[0], &[], additive)?,
            evaluate: [
                maps_pass("adaptive/evaluate", evaluate, &[], None)?,
                maps_pass("adaptive/evaluate pcf", evaluate, &[PCF], None)?,
            ],
            accumulate: [
                maps_pass("adaptive/accumulate", evaluate, &[ACCUMULATE], additive)?,
                maps_pass(
                    "adaptive/accumulate pcf",
                    evaluate,
                    &[ACCUMULATE, PCF],
                    additive,
                )?,
            ],
            // resolve.wgsl: Params, the accumulated visibility.
            resolve: Pass::new(gpu, "adaptive/resolve", &SHADERS[2])
                .after_frame_group()
                .uniform()
                .texture(Slot::FLOAT)
                .fullscreen(None)?,
            params: zeroed_uniform_buffer::<Params>(gpu, "adaptive/params"),
            settings,
            store: None,
            differing: None,
            accumulation: None,
            report: FrameReport::default(),
        })
    }

    pub(crate) fn requirements_static() -> Requirements {
        Requirements {
            // Counting differing pairs per pixel (debug view)
            // and the accumulation buffer blend into R32Float.
            features: wgpu::Features::FLOAT32_BLENDABLE,
            // One array layer per kept shadow map, at the default `max_shadow_maps`.
            limits: softshadow_core::MinLimits {
                max_texture_array_layers: 128,
                ..Default::default()
            },
            ..Requirements::default()
        }
    }

    /// What the last frame did: maps, levels, queries, differing pixels, round trips, samples.
    pub fn report(&self) -> &FrameReport {
        &self.report
    }

    /// Per pixel, the number of compared pairs that differed there at the last level compared
    /// (the comparison pass's own output, for checking the counters).
    pub fn differing_texture(&self) -> Option<&wgpu::Texture> {
        self.differing.as_ref().map(|d| &d.texture)
    }

    fn layout_for(&self, half: Vec2) -> Layout {
        Layout {
            shape: Shape::of(half),
            start: self.settings.start,
            max_depth: self.settings.max_depth,
        }
    }

    fn ensure_store(&mut self, gpu: &Gpu) -> Result<(), TechniqueError> {
        let (size, capacity) = (self.settings.shadow_map_size, self.settings.max_shadow_maps);
        if self
            .store
            .as_ref()
            .is_some_and(|s| s.size == size && s.capacity == capacity)
        {
            return Ok(());
        }
        self.store = None;
        self.store = Some(Store::new(gpu, size, capacity)?);
        Ok(())
    }

    fn screen_buffer(
        slot: &mut Option<VisibilityBuffer>,
        gpu: &Gpu,
        label: &str,
        inputs: &ShadowInputs<'_>,
    ) {
        if slot
            .as_ref()
            .is_none_or(|b| b.width != inputs.width || b.height != inputs.height)
        {
            *slot = Some(VisibilityBuffer::new(
                gpu,
                label,
                inputs.width,
                inputs.height,
            ));
        }
    }

    fn write_params(&self, gpu: &Gpu, count: u32) {
        let s = &self.settings;
        let relative = matches!(s.threshold_mode, ThresholdMode::Relative);
        let params = Params {
            values: Vec4::new(
                s.gamma,
                if relative { 1.0 } else { 0.0 },
                s.bias_texels,
                // PCF is a shader permutation (`evaluate`, `accumulate`).
                0.0,
            ),
            counts: UVec4::new(count, 0, 0, 0),
        };
        gpu.queue
            .write_buffer(&self.params, 0, &uniform_bytes(&params));
    }
}

impl Store {
    /// The maps and buffers for `capacity` maps of `size`²; fails with what to lower when the
    /// device cannot hold them.
    fn new(gpu: &Gpu, size: u32, capacity: u32) -> Result<Self, TechniqueError> {
        let maps = allocate_maps(gpu, size, capacity)?;
        let layer_views = (0..capacity).map(|l| layer_view(&maps, l)).collect();
        let buffer = |label, size: u64, usage| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        // Fixed-size uniform arrays (`MAX_MAPS` views, `2 * MAX_MAPS` items in the shaders).
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        // A level compares at most 2 pairs per leaf cell; leaves <= maps.
        let max_pairs = 2 * capacity as u64;
        let view_bytes = uniform_size::<ShadowViewUniform>();
        let counts_usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let readback_usage = wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ;
        Ok(Store {
            size,
            capacity,
            layer_views,
            counts: buffer("adaptive/differing pixels", 4 * max_pairs, counts_usage),
            readback: buffer(
                "adaptive/differing pixels readback",
                4 * max_pairs,
                readback_usage,
            ),
            array_view: maps.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            }),
            _maps: maps,
            views: buffer("adaptive/views", MAX_MAPS as u64 * view_bytes, uniform),
            pairs: buffer("adaptive/pairs", 2 * MAX_MAPS as u64 * ITEM_BYTES, uniform),
            terms: buffer("adaptive/terms", 2 * MAX_MAPS as u64 * ITEM_BYTES, uniform),
            layers: BTreeMap::new(),
            layer_uniforms: vec![ShadowViewUniform::ZERO; capacity as usize],
            kept_layout: None,
        })
    }
}

/// The array of `capacity` maps of `size`². It holds max_shadow_maps maps whatever a frame uses;
/// at the top of the ranges (512 maps of 2048²: 8 GiB) a device runs out of memory. Caught here,
/// that is a clear error for these settings instead of an uncaptured device error (found by the
/// stress).
fn allocate_maps(gpu: &Gpu, size: u32, capacity: u32) -> Result<wgpu::Texture, TechniqueError> {
    let limit = gpu.device.limits().max_texture_array_layers;
    if capacity > limit {
        return Err(TechniqueError::Other {
            technique: ID.into(),
            message: format!(
                "max_shadow_maps = {capacity} exceeds the adapter's {limit} texture array layers: lower it"
            ),
        });
    }
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let maps = create_depth_maps(gpu, "adaptive/shadow_maps", size, capacity);
    if let Some(error) = pollster::block_on(scope.pop()) {
        let gib = capacity as f64 * size as f64 * size as f64 * 4.0 / (1u64 << 30) as f64;
        let cause = error.to_string();
        let cause = cause.lines().next().unwrap_or("out of memory").trim();
        return Err(TechniqueError::Other {
            technique: ID.into(),
            message: format!(
                "the device could not allocate max_shadow_maps = {capacity} maps of {size}² \
                 ({gib:.1} GiB: {cause}): lower max_shadow_maps or shadow_map_size"
            ),
        });
    }
    Ok(maps)
}

/// The hard-map window from light-space `eye` (as the reference fits each of its samples):
/// clipped to the receivers' slopes, or the caster window when no caster can shadow a receiver
/// through `eye` (every receiver is then outside it, so lit).
fn sample_view(
    inputs: &ShadowInputs<'_>,
    eye: Vec2,
    size: u32,
) -> Result<ShadowViewUniform, TechniqueError> {
    let frustum = fit_hard_view(inputs.scene, inputs.light, eye)
        .or_else(|| fit_caster_view(inputs.scene, inputs.light, eye))
        .ok_or_else(|| TechniqueError::Other {
            technique: ID.into(),
            message: format!(
                "no caster window from light sample ({}, {}) although casters exist: report the scene",
                eye.x, eye.y
            ),
        })?;
    Ok(ShadowViewUniform::new(inputs.light, &frustum, size))
}

/// Builds the frame's sample set: keeps layers already rendered for the same layout, assigns
/// free layers to new samples and records their depth passes.
struct Maps<'s> {
    store: &'s mut Store,
    /// Keys used by this frame, in order of first use.
    used: BTreeSet<SampleKey>,
    rendered: u32,
}

impl Maps<'_> {
    /// Layers for `keys`, rendering the maps that are not kept. Fails if there is no free layer
    /// (callers check the budget first).
    fn acquire(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        depth: &mut DepthMapRenderer,
        layout: &Layout,
        keys: &[SampleKey],
    ) -> Result<(), TechniqueError> {
        let mut new = Vec::new();
        for key in keys {
            if !self.used.insert(*key) {
                continue;
            }
            if self.store.layers.contains_key(key) {
                continue;
            }
            // A free layer: never assigned, or holding a kept map this frame does not use.
            let taken: BTreeSet<u32> = self
                .store
                .layers
                .iter()
                .filter(|(k, _)| self.used.contains(k))
                .map(|(_, l)| *l)
                .collect();
            let all: BTreeSet<u32> = self.store.layers.values().copied().collect();
            let layer = (0..self.store.capacity)
                .find(|l| !all.contains(l))
                .or_else(|| (0..self.store.capacity).find(|l| !taken.contains(l)))
                .ok_or_else(|| TechniqueError::Other {
                    technique: ID.into(),
                    message: "out of shadow-map layers (a bug: the budget is checked first)".into(),
                })?;
            self.store.layers.retain(|_, l| *l != layer);
            self.store.layers.insert(*key, layer);
            let eye = light_point(inputs.light, layout, *key);
            self.store.layer_uniforms[layer as usize] = sample_view(inputs, eye, self.store.size)?;
            new.push(layer);
        }
        if new.is_empty() {
            return Ok(());
        }
        let gpu = frame.gpu;
        depth.set_views(gpu, &self.store.layer_uniforms);
        gpu.queue.write_buffer(
            &self.store.views,
            0,
            &storage_bytes(&self.store.layer_uniforms[..]),
        );
        for layer in new {
            depth.record(
                frame,
                "adaptive/shadow_map",
                inputs.scene,
                layer,
                &self.store.layer_views[layer as usize],
            );
            self.rendered += 1;
        }
        Ok(())
    }

    fn layer(&self, key: SampleKey) -> u32 {
        self.store.layers[&key]
    }
}

/// Reads `count` differing-pixel counts from `readback` (the frame was just submitted and
/// waited for).
fn read_counts(gpu: &Gpu, readback: &wgpu::Buffer, count: u32) -> Result<Vec<u64>, GpuError> {
    let slice = readback.slice(..4 * count as u64);
    let (sender, receiver) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = sender.send(r);
    });
    gpu.wait_idle()?;
    receiver
        .recv()
        .map_err(|e| GpuError::Readback(e.to_string()))?
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    let counts = {
        let data = slice
            .get_mapped_range()
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        data.chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap_or([0; 4])) as u64)
            .collect()
    };
    readback.unmap();
    Ok(counts)
}

impl ShadowTechnique for Adaptive {
    fn id(&self) -> &str {
        ID
    }

    fn requirements(&self) -> Requirements {
        Self::requirements_static()
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
        self.report = FrameReport::default();
        if fit_caster_view(inputs.scene, inputs.light, Vec2::ZERO).is_none() {
            // No caster in front of the light: receivers in front of it are lit, no map needed.
            out.write_unshadowed(frame, inputs.frame_bind_group, "adaptive/no_casters")?;
            return Ok(());
        }
        self.ensure_store(gpu)?;
        Self::screen_buffer(&mut self.differing, gpu, "adaptive/differing", inputs);
        let layout = self.layout_for(inputs.light.half_extent());
        let s = self.settings.clone();
        let map_texels = (s.shadow_map_size as f64) * (s.shadow_map_size as f64);
        let mut store = self.store.take().expect("ensured above");
        // Maps depend on the light, the casters and the parameters only: keep them otherwise.
        if inputs.changes.light_space() || store.kept_layout != Some(layout) {
            store.layers.clear();
        }
        store.kept_layout = Some(layout);
        let result = self.refine(frame, inputs, &layout, &mut store, map_texels);
        let result = result
            .and_then(|leaves| self.evaluate_maps(frame, inputs, &layout, &store, &leaves, out));
        if result.is_err() {
            // A failed frame keeps nothing: the next one starts from scratch.
            store.layers.clear();
        }
        self.store = Some(store);
        result
    }

    fn invalidate_cache(&mut self) {
        if let Some(store) = self.store.as_mut() {
            store.layers.clear();
        }
    }

    fn stats(&self) -> TechniqueStats {
        let r = &self.report;
        let mut stats = TechniqueStats::from([
            ("maps_used".into(), r.maps_used as f64),
            ("maps_generated".into(), r.maps_generated as f64),
            ("maps_rendered".into(), r.maps_rendered as f64),
            ("depth_reached".into(), r.depth_reached as f64),
            ("levels".into(), r.levels.len() as f64),
            (
                "queries".into(),
                r.levels.iter().map(|l| l.queries as f64).sum(),
            ),
            ("round_trips".into(), r.round_trips as f64),
        ]);
        for (k, level) in r.levels.iter().enumerate() {
            stats.insert(
                format!("differing_pixels_level{k}"),
                level.differing_pixels as f64,
            );
        }
        stats
    }

    fn debug_views(&self) -> Vec<DebugView> {
        self.differing
            .as_ref()
            .map(|d| {
                DebugView::new(
                    "differing_pairs",
                    &d.texture,
                    DebugLegend::value(
                        "pairs of neighbouring shadow maps that differ at the pixel (eq. 3 / eq. 7)",
                    ),
                )
            })
            .into_iter()
            .collect()
    }
}

/// One refinement level's comparisons: the cells compared and, per cell in order, its pairs'
/// differing-pixel counts, with the texels of one map.
struct Level<'a> {
    active: &'a [Cell],
    counts: &'a [u64],
    map_texels: f64,
}

impl Adaptive {
    /// Steps 1-3: initial maps, then compare / read back / split per level. Returns the leaves.
    fn refine(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        layout: &Layout,
        store: &mut Store,
        map_texels: f64,
    ) -> Result<BTreeSet<Cell>, TechniqueError> {
        let max_depth = self.settings.max_depth;
        let mut maps = Maps {
            store,
            used: BTreeSet::new(),
            rendered: 0,
        };
        let mut leaves = self.initial_maps(frame, inputs, layout, &mut maps)?;
        // Cells at max_depth cannot split: comparing them would cost a round trip for nothing.
        let splittable = |cells: Vec<Cell>| -> Vec<Cell> {
            cells.into_iter().filter(|c| c.depth < max_depth).collect()
        };
        let mut active = splittable(leaves.iter().copied().collect());
        self.write_params(frame.gpu, 0);
        while !active.is_empty() {
            let (pairs, counts) = self.compare_level(frame, inputs, layout, &maps, &active)?;
            let level = Level {
                active: &active,
                counts: &counts,
                map_texels,
            };
            let next = self.split_level(frame, inputs, layout, &mut maps, level, &mut leaves)?;
            self.report.levels.push(LevelReport {
                cells: active.len() as u32,
                queries: pairs,
                differing_pixels: counts.iter().sum(),
                splits: (next.len() / layout.children(Cell::ROOT).len()) as u32,
            });
            active = splittable(next);
        }
        self.report.maps_generated = maps.used.len() as u32;
        self.report.maps_rendered = maps.rendered;
        self.report.depth_reached = leaves.iter().map(|c| c.depth).max().unwrap_or(0);
        Ok(leaves)
    }

    /// Step 1: the uniform subdivision to `min_depth` (the paper: depth 0, the 4 corners) and
    /// its maps. Returns its cells.
    fn initial_maps(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        layout: &Layout,
        maps: &mut Maps<'_>,
    ) -> Result<BTreeSet<Cell>, TechniqueError> {
        let s = &self.settings;
        let mut leaves = BTreeSet::from([Cell::ROOT]);
        // min_depth above max_depth subdivides only to max_depth; the error names the depth used.
        let start_depth = s.min_depth.min(s.max_depth);
        for _ in 0..start_depth {
            leaves = leaves.iter().flat_map(|c| layout.children(*c)).collect();
        }
        let initial: Vec<SampleKey> = leaves
            .iter()
            .flat_map(|c| layout.samples(*c))
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect();
        let budget = s.max_shadow_maps as usize;
        if initial.len() > budget {
            let depth = if start_depth == s.min_depth {
                format!("min_depth = {}", s.min_depth)
            } else {
                format!(
                    "min_depth = {} (limited to max_depth = {})",
                    s.min_depth, s.max_depth
                )
            };
            return Err(TechniqueError::Other {
                technique: ID.into(),
                message: format!(
                    "{depth} starts with {} shadow maps, more than max_shadow_maps = {budget}: lower min_depth or raise max_shadow_maps",
                    initial.len(),
                ),
            });
        }
        maps.acquire(frame, inputs, &mut self.depth, layout, &initial)?;
        Ok(leaves)
    }

    /// Step 2: all comparisons of this level's `active` cells in one pass, one counter per
    /// pair, read back. Returns the pairs compared and their differing-pixel counts.
    fn compare_level(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        layout: &Layout,
        maps: &Maps<'_>,
        active: &[Cell],
    ) -> Result<(u32, Vec<u64>), TechniqueError> {
        let gpu = frame.gpu;
        let mut pairs: Vec<[u32; 4]> = Vec::new();
        for cell in active {
            for (a, b) in layout.pairs(*cell) {
                pairs.push([maps.layer(a), maps.layer(b), 0, 0]);
            }
        }
        let count = pairs.len() as u32;
        let store = &*maps.store;
        gpu.queue
            .write_buffer(&store.pairs, 0, bytemuck::cast_slice(&pairs));
        frame
            .encoder
            .clear_buffer(&store.counts, 0, Some(4 * count as u64));
        let differing = self.differing.as_ref().expect("made in render");
        self.compare
            .run(frame)
            .frame_group(inputs.frame_bind_group)
            .read(&self.params)
            .read(&store.views)
            .read(&store.pairs)
            .read(&store.array_view)
            .write(&store.counts)
            .instances(0..count)
            .draw(&differing.view, Some(0.0));
        frame
            .encoder
            .copy_buffer_to_buffer(&store.counts, 0, &store.readback, 0, 4 * count as u64);
        frame.submit_and_wait()?;
        self.report.round_trips += 1;
        Ok((count, read_counts(gpu, &store.readback, count)?))
    }

    /// Step 3: split where a pair differs on at least epsilon of the map's texels (eq. 4), most
    /// differing first while the map budget lasts, rendering the new maps; the cells split are
    /// replaced by their children in `leaves`. Returns the children.
    fn split_level(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        layout: &Layout,
        maps: &mut Maps<'_>,
        Level {
            active,
            counts,
            map_texels,
        }: Level<'_>,
        leaves: &mut BTreeSet<Cell>,
    ) -> Result<Vec<Cell>, TechniqueError> {
        let epsilon = self.settings.epsilon as f64;
        let budget = self.settings.max_shadow_maps as usize;
        let per_cell = counts.len() / active.len();
        let mut candidates: Vec<(u64, Cell)> = active
            .iter()
            .enumerate()
            .map(|(c, cell)| {
                let cell_counts = &counts[c * per_cell..(c + 1) * per_cell];
                (cell_counts.iter().copied().max().unwrap_or(0), *cell)
            })
            .filter(|(p, _)| *p as f64 / map_texels >= epsilon)
            .collect();
        candidates.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut next = Vec::new();
        for (_, cell) in candidates {
            let children = layout.children(cell);
            let keys: Vec<SampleKey> = children
                .iter()
                .flat_map(|c| layout.samples(*c))
                .collect::<BTreeSet<_>>()
                .into_iter()
                .filter(|k| !maps.used.contains(k))
                .collect();
            if maps.used.len() + keys.len() > budget {
                continue;
            }
            maps.acquire(frame, inputs, &mut self.depth, layout, &keys)?;
            leaves.remove(&cell);
            leaves.extend(children.iter().copied());
            next.extend(children);
        }
        Ok(next)
    }

    /// Step 4: visibility from the leaves' maps.
    fn evaluate_maps(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        layout: &Layout,
        store: &Store,
        leaves: &BTreeSet<Cell>,
        out: &VisibilityBuffer,
    ) -> Result<(), TechniqueError> {
        let gpu = frame.gpu;
        let weights = layout.weights(leaves, self.settings.weights);
        let terms: Vec<[u32; 4]> = weights
            .iter()
            .map(|(key, w)| [store.layers[key], (*w as f32).to_bits(), 0, 0])
            .collect();
        self.report.maps_used = terms.len() as u32;
        self.report.samples = weights
            .iter()
            .map(|(key, w)| (light_point(inputs.light, layout, *key), *w))
            .collect();
        let count = terms.len() as u32;
        gpu.queue
            .write_buffer(&store.terms, 0, bytemuck::cast_slice(&terms));
        self.write_params(gpu, count);
        let pcf = usize::from(self.settings.pcf);
        let draw_maps = |frame: &mut Frame<'_>,
                         pass: &FullscreenPass,
                         instances,
                         target: &wgpu::TextureView,
                         clear| {
            pass.run(frame)
                .frame_group(inputs.frame_bind_group)
                .read(&self.params)
                .read(&store.views)
                .read(&store.terms)
                .read(&store.array_view)
                .write(&store.counts)
                .instances(instances)
                .draw(target, clear)
        };
        match self.settings.evaluation {
            Evaluation::Array => draw_maps(frame, &self.evaluate[pcf], 0..1, &out.view, Some(1.0)),
            Evaluation::Accumulate => {
                Self::screen_buffer(&mut self.accumulation, gpu, "adaptive/accumulation", inputs);
                let accumulation = self.accumulation.as_ref().expect("made above");
                // One render pass per map, as the paper's deferred variant (section 3.4.1).
                for k in 0..count {
                    let clear = (k == 0).then_some(0.0);
                    let target = &accumulation.view;
                    draw_maps(frame, &self.accumulate[pcf], k..k + 1, target, clear);
                }
                self.resolve
                    .run(frame)
                    .frame_group(inputs.frame_bind_group)
                    .read(&self.params)
                    .read(&accumulation.view)
                    .draw(&out.view, Some(1.0));
            }
        }
        Ok(())
    }
}
