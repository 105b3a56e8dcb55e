//! `backprojection`: gather backprojection soft shadows (Guennebaud, Barthe & Paulin 2006,
//! "Real-time soft shadow mapping by backprojection") with the improvements of the bitmask soft shadows paper
//! (Schwarz & Stamminger 2007): micro-quads (section 4) and the multi-scale shadow map (section 5).
//!
//! Reads: the casters (one shadow map from the light centre) and the G-buffer.
//! Writes: the visibility buffer. Passes: `backprojection/shadow_map`,
//! `backprojection/hierarchy/level0` (linearised depth), `backprojection/hierarchy/hsm` or
//! `.../mssm` (the levels this light and map can need; `.../fence` around them when the build is
//! timed), `backprojection/gather` (per pixel: search
//! area, two refinements with lit / umbra early outs, level choice, backprojection of the
//! micro-primitives and area accumulation; also the counters behind the stats and the debug
//! views).

#![warn(missing_docs)]

use softshadow_core::{
    gather::{
        GatherBindings, GatherBuffers, GatherExtras, GatherPass, GatherSettings, GatherUniform,
    },
    gbuffer::create_texture,
    hierarchy::{max_search_texels, needed_levels, DepthHierarchy, HierarchyKind, Visibility},
    pass::Slot,
    shader::{DefValue, ShaderSpec},
    shader_file,
    shadow_map::CentreShadowMap,
    wgpu, DebugLegend, DebugView, Frame, Gpu, ShadowInputs, ShadowTechnique, TechniqueError,
    TechniqueSettings, TechniqueStats, VisibilityBuffer,
};

mod info;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "backprojection";

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test):
/// its gather over the shared gather pass with one layer of hierarchy (`GATHER_LAYERS`).
pub const SHADERS: &[ShaderSpec] = &[ShaderSpec {
    path: "backprojection/gather.wgsl",
    source: shader_file!("backprojection/gather.wgsl").1,
    permutations: &[&[("GATHER_LAYERS", DefValue::UInt(1))]],
}];

/// Micro-patches per axis a full search (`hierarchy = none`) gathers before it must use coarser
/// blocks: [`softshadow_core::hierarchy::full_search_patches`] of one pass (docs/DEVICES.md,
/// "Lavapipe's loop budget").
pub const FULL_SEARCH_PATCHES: u32 = 240;

/// How a shadow-map texel becomes an occluder (shared with `bitmask`).
pub use softshadow_core::gather::Primitive;

softshadow_core::technique_settings! {
    /// Settings of gather backprojection. Defaults: the MSSM, 16 x 16 micro-patches at most, gap
    /// filling on (the paper's Table 3 uses 12-20 per axis), three depth bands and edge blocks
    /// split two levels down (issue 30; `depth_bands = 1`, `edge_refine = 0` is the 2006 gather).
    pub struct BackprojectionSettings {
        ..gather: GatherSettings;
        /// Occluded area: sum (every micro-primitive backprojected and summed) or contour (only
        /// the edges between occluding and free blocks, integrated; ignores primitive and
        /// gap_filling)
        visibility: Visibility = Visibility::Sum;
    }
}

/// This crate's uniform structs with the WGSL structs they fill, for the layout test in
/// tests/shaders.rs: none of its own (the gather's uniform and counters are core's).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    Vec::new()
}

/// Per-pixel debug images, reallocated with the screen size.
struct DebugTargets {
    size: (u32, u32),
    classification: wgpu::Texture,
    classification_view: wgpu::TextureView,
    level: wgpu::Texture,
    level_view: wgpu::TextureView,
}

/// The `backprojection` technique: a [`ShadowTechnique`] with its settings.
pub struct Backprojection {
    /// Its settings; changes take effect on the next frame.
    pub settings: BackprojectionSettings,
    gpu: Gpu,
    shadow_map: CentreShadowMap,
    hierarchy: DepthHierarchy,
    gather: GatherPass,
    buffers: GatherBuffers,
    debug: Option<DebugTargets>,
    /// Stats known when recording; the GPU counters are added by `stats()`.
    stats: TechniqueStats,
    /// The last frame ran the gather pass (its counters are worth reading).
    gathered: bool,
    /// The last frame rebuilt the hierarchy (rather than keeping it from an earlier frame).
    hierarchy_built: bool,
}

impl Backprojection {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: BackprojectionSettings) -> Result<Self, TechniqueError> {
        Ok(Self {
            settings,
            gpu: gpu.clone(),
            shadow_map: CentreShadowMap::new(gpu)?,
            hierarchy: DepthHierarchy::new(gpu)?,
            // The gather pass with one layer; its own image is the classification.
            gather: GatherPass::new(
                gpu,
                "backprojection/gather",
                &SHADERS[0],
                &[],
                1,
                Slot::StorageTexture(wgpu::TextureFormat::Rgba8Unorm),
            )?,
            buffers: GatherBuffers::new(gpu, "backprojection"),
            debug: None,
            stats: TechniqueStats::new(),
            gathered: false,
            hierarchy_built: false,
        })
    }

    fn ensure_debug_targets(&mut self, width: u32, height: u32) {
        if self.debug.as_ref().map(|d| d.size) == Some((width, height)) {
            return;
        }
        let usage = wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        let classification = create_texture(
            &self.gpu,
            "backprojection/classification",
            width,
            height,
            wgpu::TextureFormat::Rgba8Unorm,
            usage,
        );
        let level = create_texture(
            &self.gpu,
            "backprojection/level",
            width,
            height,
            wgpu::TextureFormat::R32Float,
            usage,
        );
        self.debug = Some(DebugTargets {
            size: (width, height),
            classification_view: classification.create_view(&Default::default()),
            classification,
            level_view: level.create_view(&Default::default()),
            level,
        });
    }
}

/// The gather's extras: the one layer, the full search's count and the visibility.
fn gather_extras(s: &BackprojectionSettings) -> GatherExtras {
    GatherExtras {
        full_search: FULL_SEARCH_PATCHES,
        visibility: s.visibility,
        ..Default::default()
    }
}

impl Backprojection {
    /// The hierarchy over the centre map, rebuilt only with the map (it is light-space too), of
    /// the levels this light and map can need (core::hierarchy::needed_levels). Returns the
    /// levels and the largest search area in texels.
    fn build_hierarchy(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        frustum: &softshadow_core::SlopeFrustum,
        map_size: u32,
    ) -> (u32, f32) {
        let s = &self.settings.gather;
        let extent = frustum.s_max - frustum.s_min;
        let half = inputs.light.half_extent();
        let search = max_search_texels(half, frustum.near, extent, map_size);
        let per_axis = s.per_axis(FULL_SEARCH_PATCHES);
        let refine = s.hierarchy != HierarchyKind::None;
        let levels = needed_levels(map_size, search, per_axis, refine);
        self.hierarchy_built = self.shadow_map.rebuilt();
        if self.hierarchy_built {
            let depth = self.shadow_map.map_view().expect("rendered above");
            self.hierarchy.build(
                frame,
                depth,
                &self.shadow_map.view_buffer,
                map_size,
                s.hierarchy,
                levels,
                "backprojection/hierarchy",
            );
        }
        (levels, search)
    }

    /// The gather (and first its coarse pass with adaptive resolution) into `out`.
    fn gather(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
    ) -> Result<(), TechniqueError> {
        let debug = self.debug.as_ref().expect("allocated above");
        let hsm = self.hierarchy.hsm_view().expect("built above");
        let bindings = GatherBindings {
            frame_group: inputs.frame_bind_group,
            view: &self.shadow_map.view_buffer,
            visibility: &out.view,
            level: &debug.level_view,
            own: &debug.classification_view,
            layers: vec![(hsm, self.hierarchy.mssm_view())],
        };
        let size = (inputs.width, inputs.height);
        Ok((self.gather).run(frame, &self.buffers, &bindings, size)?)
    }
}

impl ShadowTechnique for Backprojection {
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
        // The settings are range-checked by set_param; a library user may set any value.
        let map_size = (self.settings.gather.shadow_map_size)
            .clamp(1, gpu.device.limits().max_texture_dimension_2d);
        self.gathered = false;
        let label = "backprojection/shadow_map";
        let Some(frustum) = self.shadow_map.render(frame, inputs, map_size, label) else {
            out.write_unshadowed(frame, inputs.frame_bind_group, "backprojection/no_casters")?;
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        };
        let (levels, search) = self.build_hierarchy(frame, inputs, &frustum, map_size);
        let extras = gather_extras(&self.settings);
        let uniform = GatherUniform::new(&self.settings.gather, levels, &extras);
        (self.buffers).prepare(gpu, &uniform, inputs.width, inputs.height);
        self.ensure_debug_targets(inputs.width, inputs.height);
        self.gather(frame, inputs, out)?;
        self.gathered = true;
        self.stats = TechniqueStats::from([
            ("shadow_maps".into(), 1.0),
            ("hierarchy_levels".into(), levels as f64),
            ("max_search_texels".into(), search.min(1e9) as f64),
        ]);
        Ok(())
    }

    fn invalidate_cache(&mut self) {
        self.shadow_map.invalidate();
    }

    /// `backprojected_pixel_fraction` (receiver pixels that needed any backprojection, paper
    /// Fig. 8), `lit_pixel_fraction` and `umbra_pixel_fraction` (early outs),
    /// `mean_primitives_per_pixel` (micro-primitives processed per receiver pixel) and
    /// `mean_primitives_per_backprojected_pixel`, `hierarchy_build_ms` (GPU time of the level
    /// passes, from the hierarchy's own timestamp queries), `hierarchy_levels`.
    fn stats(&self) -> TechniqueStats {
        let mut stats = self.stats.clone();
        if !self.gathered {
            return stats;
        }
        if let Some(c) = self.buffers.counts(&self.gpu) {
            c.insert_stats(&mut stats);
        }
        if self.hierarchy_built {
            if let Some(ms) = self.hierarchy.last_build_ms(&self.gpu) {
                stats.insert("hierarchy_build_ms".into(), ms);
            }
        }
        stats
    }

    /// `shadow_map`, `classification` (Rgba8Unorm: light grey lit, dark blue umbra, red to blue
    /// backprojected with few to max_patches² primitives, transparent off-receiver) and `level`
    /// (R32Float: the gather level, -1 where nothing was backprojected).
    fn debug_views(&self) -> Vec<DebugView> {
        let mut views = self.shadow_map.debug_views();
        if let Some(debug) = &self.debug {
            views.push(DebugView::new(
                "classification",
                &debug.classification,
                classification_legend(),
            ));
            views.push(DebugView::new(
                "level",
                &debug.level,
                softshadow_core::hierarchy::level_legend("gather level"),
            ));
        }
        views
    }
}

/// The colours `class_colour` in `shaders/backprojection/gather.wgsl` writes.
fn classification_legend() -> DebugLegend {
    DebugLegend::Palette(vec![
        ([230, 230, 217], "lit: no blocker found".into()),
        ([26, 26, 89], "umbra".into()),
        (
            [255, 38, 0],
            "backprojected, few primitives (red) ...".into(),
        ),
        (
            [0, 38, 255],
            "... up to max_patches² primitives (blue)".into(),
        ),
        (
            [26, 204, 51],
            "interpolated from the coarse pass (adaptive resolution)".into(),
        ),
        ([0, 0, 0], "off-receiver".into()),
    ])
}
