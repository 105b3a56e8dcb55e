//! `bitmask`: bitmask soft shadows (Schwarz & Stamminger 2007). Like gather backprojection, the
//! texels of a shadow map from the light centre become micro-patches or micro-quads (section 4)
//! that each receiver backprojects onto the light, found through the HSM or the multi-scale shadow
//! map (section 5); instead of summing the covered areas, the light samples each backprojected
//! rectangle covers are OR-ed into a bit field (section 3), so overlapping occluders count once
//! (occluder fusion), and occluders from further depth-peeled layers can be added (section 3.2).
//! `V = 1 - set bits / samples`. An optional post filter (section 3.1) smooths the steps of the
//! point-sampled result with the (smooth, but overlap-blind) area estimate.
//!
//! Reads: the casters and the G-buffer. Writes: the visibility buffer. Passes:
//! `bitmask/shadow_map` (layer 0), `bitmask/peel` (layers 1.., one pass each, summed),
//! `bitmask/hierarchy/*` (layer 0) and `bitmask/peel_hierarchy/*` (the other layers): the depth
//! hierarchies of the core `hierarchy` module; all of these are kept while only the camera
//! moves. Every frame: `bitmask/gather` (per pixel: search, early outs, level choice,
//! backprojection into the bitmask, counters) and `bitmask/filter` (`filter_passes` times).

#![warn(missing_docs)]

use softshadow_core::{
    gather::{
        GatherBindings, GatherBuffers, GatherExtras, GatherPass, GatherSettings, GatherUniform,
    },
    gbuffer::create_texture,
    hierarchy::{
        full_search_patches, max_search_texels, needed_levels, DepthHierarchy, HierarchyKind,
        Visibility,
    },
    pass::{ComputePass, Pass, Slot},
    shader::{DefValue, ShaderSpec},
    shader_file,
    shadow_map::{create_depth_maps, CentreShadowMap},
    wgpu, DebugLegend, DebugView, Frame, Gpu, ShadowInputs, ShadowTechnique, TechniqueError,
    TechniqueSettings, TechniqueStats, VisibilityBuffer,
};

mod info;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "bitmask";

/// Most depth layers (`layers`); the gather pass binds this many hierarchies (`GATHER_LAYERS`).
pub const MAX_LAYERS: u32 = 4;

/// The gather's mask sizes in 32-bit words: one pipeline each (`MASK_WORDS` in `gather.wgsl`).
const MASK_WORD_COUNTS: [u32; 3] = [2, 8, 32];

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "bitmask/gather.wgsl",
        source: shader_file!("bitmask/gather.wgsl").1,
        permutations: &[
            &[("MASK_WORDS", DefValue::UInt(2)), LAYERS_DEF],
            &[("MASK_WORDS", DefValue::UInt(8)), LAYERS_DEF],
            &[("MASK_WORDS", DefValue::UInt(32)), LAYERS_DEF],
        ],
    },
    ShaderSpec {
        path: "bitmask/filter.wgsl",
        source: shader_file!("bitmask/filter.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "bitmask/peel.wgsl",
        source: shader_file!("bitmask/peel.wgsl").1,
        permutations: &[&[]],
    },
];

/// The shared gather pass binds [`MAX_LAYERS`] hierarchies.
const LAYERS_DEF: (&str, DefValue) = ("GATHER_LAYERS", DefValue::UInt(MAX_LAYERS));

/// How a shadow-map texel becomes an occluder (shared with `backprojection`).
pub use softshadow_core::gather::Primitive;

softshadow_core::param_choice! {
    /// Light samples tracked by the occlusion bitmask (paper section 3, Fig. 3).
    pub enum Pattern {
        /// 64 samples on a regular grid.
        Grid8 = "8x8",
        /// 256 samples on a regular grid.
        Grid16 = "16x16",
        /// 256 samples: the 8 x 8 tiling of the 2 x 2 rotated-grid pattern.
        Jittered16 = "16x16-jittered",
        /// 1,024 samples on a regular grid.
        Grid32 = "32x32",
    }
}

/// How a pattern's samples are laid out in the mask (`rows`, `columns`, `jittered` of core's
/// `GatherUniform`, read by `gather.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PatternLayout {
    /// Rows of samples across the light's height.
    pub rows: u32,
    /// Samples per row across the light's width (one bit each).
    pub columns: u32,
    /// Rows take the rotated-grid offsets 3/8, 7/8, 1/8, 5/8 (else cell centres).
    pub jittered: bool,
}

impl PatternLayout {
    /// Light samples (bits) in the pattern.
    pub fn samples(self) -> u32 {
        self.rows * self.columns
    }

    /// 32-bit words of the occlusion mask.
    pub fn words(self) -> u32 {
        self.samples() / 32
    }
}

impl Pattern {
    /// Rows, columns and jitter of this pattern.
    pub fn layout(self) -> PatternLayout {
        let (rows, columns, jittered) = match self {
            Pattern::Grid8 => (8, 8, false),
            Pattern::Grid16 => (16, 16, false),
            // 8 x 8 tiles of four samples: 32 distinct rows of 8 samples each.
            Pattern::Jittered16 => (32, 8, true),
            Pattern::Grid32 => (32, 32, false),
        };
        PatternLayout {
            rows,
            columns,
            jittered,
        }
    }
}

softshadow_core::technique_settings! {
    /// Settings of bitmask soft shadows. Defaults: the MSSM, 16 x 16 micro-patches at most, the
    /// jittered 16 x 16 pattern (the paper's best trade-off, section 7), one layer, no filter.
    pub struct BitmaskSettings {
        ..gather: GatherSettings;
        /// Light samples of the occlusion bitmask: 8x8, 16x16, 16x16-jittered (rotated grid) or
        /// 32x32
        pattern: Pattern = Pattern::Jittered16;
        /// Depth layers peeled from the light centre, all OR-ed into the one bitmask
        layers: u32 = 1, in 1..=4;
        /// Post-filter passes driven by the area estimate (0 = off; the paper uses 5)
        filter_passes: u32 = 0, in 0..=8;
    }
}

/// This crate's uniform structs with the WGSL structs they fill, for the layout test in
/// tests/shaders.rs: none of its own (the gather's uniform and counters are core's).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    Vec::new()
}

/// Screen-sized images, reallocated with the screen size: the bitmask result B before filtering,
/// the area estimate A, two ping-pong targets of the filter, and the gather level.
struct ScreenTargets {
    size: (u32, u32),
    bitmask: (wgpu::Texture, wgpu::TextureView),
    area: (wgpu::Texture, wgpu::TextureView),
    ping: [(wgpu::Texture, wgpu::TextureView); 2],
    level: (wgpu::Texture, wgpu::TextureView),
}

/// What the kept light-space work was built with: a change forces a rebuild even when a library
/// user edits the settings between frames.
#[derive(Clone, Copy, PartialEq, Eq)]
struct LightSpaceKey {
    map_size: u32,
    layers: u32,
    hierarchy: HierarchyKind,
    levels: u32,
}

/// Layers 1.. of the depth peeling (layer 0 is the centre shadow map): layer k keeps the
/// nearest caster surface behind layer k - 1, drawn by core's depth pass
/// ([`CentreShadowMap::record_peel`]).
#[derive(Default)]
struct PeelMaps {
    /// Of `map_size`.
    maps: Vec<(wgpu::Texture, wgpu::TextureView)>,
    map_size: u32,
}

impl PeelMaps {
    fn ensure(&mut self, gpu: &Gpu, size: u32, count: usize) {
        if self.map_size != size {
            self.maps.clear();
            self.map_size = size;
        }
        while self.maps.len() < count {
            let texture = create_depth_maps(gpu, "bitmask/peel", size, 1);
            let view = texture.create_view(&Default::default());
            self.maps.push((texture, view));
        }
    }
}

/// The `bitmask` technique: a [`ShadowTechnique`] with its settings.
pub struct Bitmask {
    /// Its settings; changes take effect on the next frame.
    pub settings: BitmaskSettings,
    gpu: Gpu,
    shadow_map: CentreShadowMap,
    peel: PeelMaps,
    /// One hierarchy per layer, created when a layer is first needed.
    hierarchies: Vec<DepthHierarchy>,
    /// The gather pass per entry of `MASK_WORD_COUNTS`, compiled when first used.
    gather_passes: [Option<GatherPass>; 3],
    filter: ComputePass,
    buffers: GatherBuffers,
    targets: Option<ScreenTargets>,
    kept: Option<LightSpaceKey>,
    /// Stats known when recording; the GPU counters are added by `stats()`.
    stats: TechniqueStats,
    /// The last frame ran the gather pass (its counters are worth reading).
    gathered: bool,
    /// Layers whose hierarchy the last frame rebuilt (0 when it kept them).
    rebuilt_layers: usize,
    /// The last frame filtered (the `bitmask` and `area` debug views hold its B and A).
    filtered: bool,
}

impl Bitmask {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: BitmaskSettings) -> Result<Self, TechniqueError> {
        // filter.wgsl (paper section 3.1): the area estimate, the source, the destination.
        let filter = Pass::new(gpu, "bitmask/filter", &SHADERS[1])
            .after_frame_group()
            .repeat(Slot::FLOAT, 2)
            .storage_texture(wgpu::TextureFormat::R32Float)
            .compute("filter_pass")?;
        Ok(Self {
            settings,
            gpu: gpu.clone(),
            shadow_map: CentreShadowMap::new(gpu)?,
            peel: PeelMaps::default(),
            hierarchies: Vec::new(),
            gather_passes: [None, None, None],
            filter,
            buffers: GatherBuffers::new(gpu, "bitmask"),
            targets: None,
            kept: None,
            stats: TechniqueStats::new(),
            gathered: false,
            rebuilt_layers: 0,
            filtered: false,
        })
    }

    /// The index in `gather_passes` of the pass for a mask of `words` 32-bit words, compiled on
    /// first use: the shared gather pass over every layer's hierarchy, its own image the area
    /// estimate A.
    fn gather_pass(&mut self, words: u32) -> Result<usize, TechniqueError> {
        let index = MASK_WORD_COUNTS
            .iter()
            .position(|&w| w == words)
            .expect("every pattern has 2, 8 or 32 words");
        if self.gather_passes[index].is_none() {
            self.gather_passes[index] = Some(GatherPass::new(
                &self.gpu,
                "bitmask/gather",
                &SHADERS[0],
                &[("MASK_WORDS", DefValue::UInt(words))],
                MAX_LAYERS,
                Slot::StorageTexture(wgpu::TextureFormat::R32Float),
            )?);
        }
        Ok(index)
    }

    fn ensure_targets(&mut self, width: u32, height: u32) {
        if self.targets.as_ref().map(|t| t.size) == Some((width, height)) {
            return;
        }
        let usage = wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        let make = |label: &str| {
            let texture = create_texture(
                &self.gpu,
                label,
                width,
                height,
                wgpu::TextureFormat::R32Float,
                usage,
            );
            let view = texture.create_view(&Default::default());
            (texture, view)
        };
        self.targets = Some(ScreenTargets {
            size: (width, height),
            bitmask: make("bitmask/bitmask"),
            area: make("bitmask/area"),
            ping: [make("bitmask/filter ping"), make("bitmask/filter pong")],
            level: make("bitmask/level"),
        });
    }

    /// Renders layers 1.. by depth peeling and builds every layer's hierarchy.
    fn build_light_space(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        key: LightSpaceKey,
    ) {
        let layers = key.layers as usize;
        while self.hierarchies.len() < layers {
            // DepthHierarchy::new only fails on shader composition, which the first one passed.
            match DepthHierarchy::new(frame.gpu) {
                Ok(h) => self.hierarchies.push(h),
                Err(_) => break,
            }
        }
        self.peel
            .ensure(frame.gpu, key.map_size, layers.saturating_sub(1));
        let centre = self.shadow_map.map_view().expect("rendered by the caller");
        for k in 1..layers {
            let previous = if k == 1 {
                centre
            } else {
                &self.peel.maps[k - 2].1
            };
            let target = &self.peel.maps[k - 1].1;
            self.shadow_map
                .record_peel(frame, "bitmask/peel", inputs.scene, previous, target);
        }
        for (k, hierarchy) in self.hierarchies.iter_mut().enumerate().take(layers) {
            let (depth, label) = if k == 0 {
                (centre, "bitmask/hierarchy")
            } else {
                (&self.peel.maps[k - 1].1, "bitmask/peel_hierarchy")
            };
            hierarchy.build(
                frame,
                depth,
                &self.shadow_map.view_buffer,
                key.map_size,
                key.hierarchy,
                key.levels,
                label,
            );
        }
        self.rebuilt_layers = layers.min(self.hierarchies.len());
    }
}

/// What one frame gathers with: the settings range-checked (a library user may set any value)
/// and what follows from them.
struct Plan {
    layers: u32,
    /// The micro-patches per axis of a full search over `layers` layers.
    full_search: u32,
    /// Most blocks per axis of one gather (`GatherSettings::per_axis`).
    per_axis: u32,
    filter_passes: u32,
    map_size: u32,
    pattern: PatternLayout,
}

impl Plan {
    fn of(s: &BitmaskSettings, gpu: &Gpu) -> Self {
        let layers = s.layers.clamp(1, MAX_LAYERS);
        // A bitmask block costs two iterations of the loop budget, so a layer counts as two
        // passes (docs/DEVICES.md, "Lavapipe's loop budget").
        let full_search = full_search_patches(2 * layers);
        let g = &s.gather;
        Self {
            layers,
            full_search,
            per_axis: g.per_axis(full_search),
            filter_passes: s.filter_passes.min(8),
            map_size: (g.shadow_map_size).clamp(1, gpu.device.limits().max_texture_dimension_2d),
            pattern: s.pattern.layout(),
        }
    }
}

/// The gather's uniform for a frame of `plan` over `layers` built layers of `levels` levels.
fn gather_uniform(s: &BitmaskSettings, plan: &Plan, levels: u32, layers: usize) -> GatherUniform {
    let extras = GatherExtras {
        layers: layers as u32,
        full_search: plan.full_search,
        visibility: Visibility::Sum,
        rows: plan.pattern.rows,
        columns: plan.pattern.columns,
        jittered: plan.pattern.jittered,
        with_area: plan.filter_passes > 0,
    };
    GatherUniform::new(&s.gather, levels, &extras)
}

impl Bitmask {
    /// The centre map and, when it was redrawn or the settings changed under it, the peeled
    /// layers and every layer's hierarchy. `None` when no caster is in front of the light; else
    /// the kept work's key and the largest search area in texels.
    fn light_space(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        plan: &Plan,
    ) -> Option<(LightSpaceKey, f32)> {
        let s = &self.settings.gather;
        let map_size = plan.map_size;
        let frustum = (self.shadow_map).render(frame, inputs, map_size, "bitmask/shadow_map")?;
        // Only the levels this light and map can need (core::hierarchy::needed_levels).
        let extent = frustum.s_max - frustum.s_min;
        let half = inputs.light.half_extent();
        let search = max_search_texels(half, frustum.near, extent, map_size);
        let refine = s.hierarchy != HierarchyKind::None;
        let levels = needed_levels(map_size, search, plan.per_axis, refine);
        let key = LightSpaceKey {
            map_size,
            layers: plan.layers,
            hierarchy: s.hierarchy,
            levels,
        };
        let mut rebuild = self.shadow_map.rebuilt();
        if !rebuild && self.kept != Some(key) {
            // Settings changed under a kept map (a library user editing fields): redo it all.
            self.shadow_map.invalidate();
            (self.shadow_map).render(frame, inputs, map_size, "bitmask/shadow_map");
            rebuild = true;
        }
        if rebuild {
            self.build_light_space(frame, inputs, key);
            self.kept = Some(key);
        }
        Some((key, search))
    }

    /// The gather (and first its coarse pass with adaptive resolution) into B, or straight
    /// into `out` without a filter.
    fn gather(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
        plan: &Plan,
        built_layers: usize,
    ) -> Result<(), TechniqueError> {
        let index = self.gather_pass(plan.pattern.words())?;
        let targets = self.targets.as_ref().expect("allocated above");
        // Layers past those built bind the last one (the shader reads only `layers`).
        let layer = |k: usize| &self.hierarchies[k.min(built_layers - 1)];
        let hsm = |k: usize| layer(k).hsm_view().expect("built with the map");
        let bindings = GatherBindings {
            frame_group: inputs.frame_bind_group,
            view: &self.shadow_map.view_buffer,
            // Without filtering the bitmask result is the output; with it, B has its own image.
            visibility: if plan.filter_passes > 0 {
                &targets.bitmask.1
            } else {
                &out.view
            },
            level: &targets.level.1,
            own: &targets.area.1,
            layers: (0..MAX_LAYERS as usize)
                .map(|k| (hsm(k), layer(k).mssm_view()))
                .collect(),
        };
        let pass = self.gather_passes[index].as_mut().expect("compiled above");
        let size = (inputs.width, inputs.height);
        Ok(pass.run(frame, &self.buffers, &bindings, size)?)
    }

    /// The post filter (paper section 3.1): B -> ping -> pong -> ... -> out.
    fn filter(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
        passes: u32,
    ) {
        let targets = self.targets.as_ref().expect("allocated above");
        let passes = passes as usize;
        for pass_index in 0..passes {
            let src = if pass_index == 0 {
                &targets.bitmask.1
            } else {
                &targets.ping[(pass_index - 1) % 2].1
            };
            let dst = if pass_index + 1 == passes {
                &out.view
            } else {
                &targets.ping[pass_index % 2].1
            };
            self.filter
                .run(frame)
                .frame_group(inputs.frame_bind_group)
                .read(&targets.area.1)
                .read(src)
                .write(dst)
                .dispatch([inputs.width.div_ceil(8), inputs.height.div_ceil(8), 1]);
        }
        self.filtered = passes > 0;
    }
}

impl ShadowTechnique for Bitmask {
    fn requirements(&self) -> softshadow_core::Requirements {
        info::requirements()
    }

    fn id(&self) -> &str {
        ID
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
        let plan = Plan::of(&self.settings, gpu);
        self.gathered = false;
        self.rebuilt_layers = 0;
        self.filtered = false;
        let Some((key, search)) = self.light_space(frame, inputs, &plan) else {
            out.write_unshadowed(frame, inputs.frame_bind_group, "bitmask/no_casters")?;
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        };
        let built_layers = self.hierarchies.len().min(plan.layers as usize);
        if built_layers == 0 {
            return Err(TechniqueError::Other {
                technique: ID.into(),
                message: "the depth hierarchy could not be created: check the GPU adapter".into(),
            });
        }
        let uniform = gather_uniform(&self.settings, &plan, key.levels, built_layers);
        (self.buffers).prepare(gpu, &uniform, inputs.width, inputs.height);
        self.ensure_targets(inputs.width, inputs.height);
        self.gather(frame, inputs, out, &plan, built_layers)?;
        self.filter(frame, inputs, out, plan.filter_passes);
        self.gathered = true;
        self.stats = TechniqueStats::from([
            ("shadow_maps".into(), built_layers as f64),
            ("hierarchy_levels".into(), key.levels as f64),
            ("max_search_texels".into(), search.min(1e9) as f64),
            ("light_samples".into(), plan.pattern.samples() as f64),
        ]);
        Ok(())
    }

    fn invalidate_cache(&mut self) {
        self.shadow_map.invalidate();
        self.kept = None;
    }

    /// `backprojected_pixel_fraction` (receiver pixels that backprojected anything, paper Fig.
    /// 8), `lit_pixel_fraction` and `umbra_pixel_fraction` (early outs),
    /// `mean_primitives_per_pixel` and `max_primitives_per_pixel` (micro-primitives processed
    /// per receiver pixel, all layers), `mean_primitives_per_backprojected_pixel`,
    /// `mean_set_bits` and `mean_set_bit_fraction` (occlusion bitmask of the backprojected
    /// pixels), `light_samples`, `shadow_maps` (layers), `hierarchy_levels`,
    /// `hierarchy_build_ms` (GPU time of the level passes of the layers rebuilt this frame).
    fn stats(&self) -> TechniqueStats {
        let mut stats = self.stats.clone();
        if !self.gathered {
            return stats;
        }
        if let Some(c) = self.buffers.counts(&self.gpu) {
            c.insert_stats(&mut stats);
            let backprojected = c.backprojected.max(1) as f64;
            let set_bits = c.set_bits() as f64;
            let samples = self.settings.pattern.layout().samples() as f64;
            stats.insert("max_primitives_per_pixel".into(), c.primitives_max as f64);
            stats.insert("mean_set_bits".into(), set_bits / backprojected);
            stats.insert(
                "mean_set_bit_fraction".into(),
                set_bits / backprojected / samples,
            );
        }
        if self.rebuilt_layers > 0 {
            let ms: Option<f64> = self.hierarchies[..self.rebuilt_layers]
                .iter()
                .map(|h| h.last_build_ms(&self.gpu))
                .sum();
            if let Some(ms) = ms {
                stats.insert("hierarchy_build_ms".into(), ms);
            }
        }
        stats
    }

    /// `shadow_map` (layer 0), `peel_layer_1`.. (Depth32Float, the peeled layers), `level`
    /// (R32Float: the coarsest gather level over the layers, -1 where nothing was
    /// backprojected) and, while filtering, `bitmask` (B before the filter) and `area` (the area
    /// estimate A, unclamped visibility). Without filtering B is the output itself.
    fn debug_views(&self) -> Vec<DebugView> {
        let mut views = self.shadow_map.debug_views();
        let layers = self.kept.map_or(1, |k| k.layers as usize);
        for (k, (texture, _)) in self.peel.maps.iter().enumerate().take(layers - 1) {
            views.push(DebugView::new(
                format!("peel_layer_{}", k + 1),
                texture,
                DebugLegend::Depth,
            ));
        }
        if let Some(targets) = &self.targets {
            views.push(DebugView::new(
                "level",
                &targets.level.0,
                softshadow_core::hierarchy::level_legend("coarsest gather level over the layers"),
            ));
            if self.filtered {
                views.push(DebugView::new(
                    "bitmask",
                    &targets.bitmask.0,
                    DebugLegend::value("visibility from the bit field B, before the filter"),
                ));
                views.push(DebugView::new(
                    "area",
                    &targets.area.0,
                    DebugLegend::value("area estimate A (unclamped visibility)"),
                ));
            }
        }
        views
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_pattern_fills_whole_words() {
        for name in Pattern::NAMES {
            let layout = Pattern::from_name(name).unwrap().layout();
            assert_eq!(layout.samples() % 32, 0, "{name}");
            assert!(MASK_WORD_COUNTS.contains(&layout.words()), "{name}");
            // A row never straddles two words.
            assert_eq!(32 % layout.columns, 0, "{name}");
        }
        assert_eq!(Pattern::Jittered16.layout().samples(), 256);
        assert_eq!(Pattern::Grid32.layout().words(), 32);
    }

    #[test]
    fn shaders_validate_in_every_permutation() {
        if let Err(e) = softshadow_core::shader::validate_all(SHADERS) {
            panic!("{e}");
        }
    }
}
