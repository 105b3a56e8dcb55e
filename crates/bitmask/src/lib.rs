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

use bytemuck::{Pod, Zeroable};
use softshadow_core::{
    frame::uniform_entry,
    fullscreen::{depth_texture_entry, uniform_buffer},
    gather::{
        float_texture_entry, storage_texture_entry, AdaptivePass, AdaptiveResolution,
        AdaptiveTargets, GatherCounters,
    },
    gbuffer::create_texture,
    hierarchy::{
        full_search_patches, max_search_texels, needed_levels, DepthHierarchy, HierarchyKind,
    },
    scene_gpu::Vertex,
    shader::{self, DefValue, ShaderSpec},
    shader_file,
    shadow_map::{create_depth_maps, CentreShadowMap, SHADOW_DEPTH_FORMAT},
    wgpu, DebugLegend, DebugView, Frame, Gpu, ShadowInputs, ShadowTechnique, TechniqueError,
    TechniqueSettings, TechniqueStats, VisibilityBuffer,
};

mod info;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "bitmask";

/// Most depth layers (`layers`); the gather pass binds this many hierarchies.
pub const MAX_LAYERS: u32 = 4;

/// The gather's mask sizes in 32-bit words: one pipeline each (`MASK_WORDS` in `gather.wgsl`).
const MASK_WORD_COUNTS: [u32; 3] = [2, 8, 32];

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "bitmask/gather.wgsl",
        source: shader_file!("bitmask/gather.wgsl").1,
        permutations: &[
            &[("MASK_WORDS", DefValue::UInt(2))],
            &[("MASK_WORDS", DefValue::UInt(8))],
            &[("MASK_WORDS", DefValue::UInt(32))],
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

softshadow_core::param_choice! {
    /// How a shadow-map texel becomes an occluder.
    pub enum Primitive {
        /// Each texel is a rectangle parallel to the light at its depth (Guennebaud et al. 2006).
        Micropatch = "micropatch",
        /// Unprojected texel centres are the vertices of quads, each approximated by the
        /// axis-aligned rectangle through its edge centres (paper section 4).
        Microquad = "microquad",
    }
}

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

/// How a pattern's samples are laid out in the mask (`GatherParams` in `gather.wgsl`).
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
        /// Shadow-map edge in texels, every layer (the hierarchies pad it to a power of two)
        shadow_map_size: u32 = 1024, in 64..=4096;
        /// Depth hierarchy for search-area refinement: none (full search), hsm (min/max mip
        /// pyramid), mssm (multi-scale shadow map)
        hierarchy: HierarchyKind = HierarchyKind::Mssm;
        /// Most micro-primitives per axis per pixel and layer; larger search areas use coarser
        /// blocks
        max_patches: u32 = 16, in 4..=32;
        /// Texel interpretation: micropatch (rectangle parallel to the light) or microquad
        /// (texel centres as quad vertices, rectangle through the edge centres)
        primitive: Primitive = Primitive::Micropatch;
        /// Light samples of the occlusion bitmask: 8x8, 16x16, 16x16-jittered (rotated grid) or
        /// 32x32
        pattern: Pattern = Pattern::Jittered16;
        /// Extend micro-patches to their occluding left and bottom neighbours
        gap_filling: bool = true;
        /// Depth layers peeled from the light centre, all OR-ed into the one bitmask
        layers: u32 = 1, in 1..=4;
        /// Post-filter passes driven by the area estimate (0 = off; the paper uses 5)
        filter_passes: u32 = 0, in 0..=8;
        /// Levels a partly occluding micro-patch block (it holds an occluder's edge) is split
        /// down into sub-blocks (0: none; micro-patches with a hierarchy only)
        edge_refine: u32 = 2, in 0..=3;
        /// Depth bands gathered each at its own level, the level following the penumbra of
        /// that depth (1: one level for the whole search area, chosen by its nearest occluder)
        depth_bands: u32 = 3, in 1..=8;
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

/// Mirrors `GatherParams` in `shaders/bitmask/gather.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GatherUniform {
    hierarchy: u32,
    primitive: u32,
    gap_filling: u32,
    max_patches: u32,
    bias_texels: f32,
    max_level: i32,
    layers: u32,
    with_area: u32,
    rows: u32,
    columns: u32,
    jittered: u32,
    edge_refine: u32,
    depth_bands: u32,
    adaptive_factor: u32,
    adaptive_pixels: f32,
    _pad: u32,
}

/// This crate's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![softshadow_core::uniform_mirror!(
        GatherUniform {
            hierarchy, primitive, gap_filling, max_patches, bias_texels, max_level, layers,
            with_area, rows, columns, jittered, edge_refine, depth_bands, adaptive_factor,
            adaptive_pixels, _pad
        } => "bitmask/gather.wgsl", GatherParams
    )]
}

/// Mirrors `Counters` in `gather.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Counters {
    receivers: u32,
    lit: u32,
    umbra: u32,
    backprojected: u32,
    primitives_lo: u32,
    primitives_hi: u32,
    primitives_max: u32,
    set_bits_lo: u32,
    set_bits_hi: u32,
    upsampled: u32,
    _pad: [u32; 2],
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

/// Depth peeling: layer k keeps the nearest caster surface behind layer k - 1.
struct Peeler {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    /// Layers 1.. (layer 0 is the centre shadow map), of `map_size`.
    maps: Vec<(wgpu::Texture, wgpu::TextureView)>,
    map_size: u32,
}

impl Peeler {
    fn new(gpu: &Gpu) -> Result<Self, TechniqueError> {
        let module = shader::create_module(gpu, &SHADERS[2], &[])?;
        let layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("bitmask/peel"),
                entries: &[
                    wgpu::BindGroupLayoutEntry {
                        binding: 0,
                        visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                        count: None,
                    },
                    depth_texture_entry(1, false),
                ],
            });
        let pipeline_layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("bitmask/peel"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let pipeline = gpu
            .device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("bitmask/peel"),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[Some(Vertex::position_layout())],
                },
                primitive: wgpu::PrimitiveState {
                    // Both faces, as the centre map: back faces are what the second layer finds.
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: SHADOW_DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[],
                }),
                multiview_mask: None,
                cache: None,
            });
        Ok(Self {
            pipeline,
            layout,
            maps: Vec::new(),
            map_size: 0,
        })
    }

    fn ensure_maps(&mut self, gpu: &Gpu, size: u32, count: usize) {
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

    /// Records the pass that peels layer `index + 1` behind `previous` into `self.maps[index]`.
    fn record(
        &self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        shadow_view: &wgpu::Buffer,
        previous: &wgpu::TextureView,
        index: usize,
    ) {
        let bind_group = frame
            .gpu
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("bitmask/peel"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: shadow_view.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(previous),
                    },
                ],
            });
        frame.render_pass(
            "bitmask/peel",
            wgpu::RenderPassDescriptor {
                label: None,
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.maps[index].1,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            },
            |pass| {
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                inputs.scene.draw_casters(pass);
            },
        );
    }
}

/// The `bitmask` technique: a [`ShadowTechnique`] with its settings.
pub struct Bitmask {
    /// Its settings; changes take effect on the next frame.
    pub settings: BitmaskSettings,
    gpu: Gpu,
    shadow_map: CentreShadowMap,
    peeler: Peeler,
    /// One hierarchy per layer, created when a layer is first needed.
    hierarchies: Vec<DepthHierarchy>,
    gather_layout: wgpu::BindGroupLayout,
    gather_pipeline_layout: wgpu::PipelineLayout,
    /// Per entry of `MASK_WORD_COUNTS`, compiled when first used: the gather and the coarse pass
    /// of adaptive screen resolution (entry `gather_coarse`, compiled only when asked for:
    /// llvmpipe compiles a pipeline when it is created).
    gather_pipelines: [Option<(wgpu::ComputePipeline, Option<wgpu::ComputePipeline>)>; 3],
    filter_layout: wgpu::BindGroupLayout,
    filter_pipeline: wgpu::ComputePipeline,
    params_buffer: wgpu::Buffer,
    counters: GatherCounters<Counters>,
    adaptive: AdaptiveTargets,
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

fn compute_layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    let stage = wgpu::ShaderStages::COMPUTE;
    let mut entries = vec![
        uniform_entry(0, stage, false),
        uniform_entry(1, stage, false),
    ];
    for k in 0..MAX_LAYERS {
        entries.push(float_texture_entry(2 + k, wgpu::TextureViewDimension::D2));
        entries.push(float_texture_entry(
            6 + k,
            wgpu::TextureViewDimension::D2Array,
        ));
    }
    for binding in 10..13 {
        entries.push(storage_texture_entry(
            binding,
            wgpu::TextureFormat::R32Float,
        ));
    }
    entries.push(GatherCounters::<Counters>::layout_entry(13));
    entries.extend(AdaptiveTargets::layout_entries(14));
    entries
}

impl Bitmask {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: BitmaskSettings) -> Result<Self, TechniqueError> {
        let device = &gpu.device;
        let gather_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("bitmask/gather"),
            entries: &compute_layout_entries(),
        });
        let gather_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("bitmask/gather"),
                bind_group_layouts: &[Some(&gpu.layouts.frame), Some(&gather_layout)],
                immediate_size: 0,
            });
        let stage = wgpu::ShaderStages::COMPUTE;
        let filter_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("bitmask/filter"),
            entries: &[
                softshadow_core::frame::texture_entry(
                    0,
                    stage,
                    wgpu::TextureSampleType::Float { filterable: false },
                ),
                softshadow_core::frame::texture_entry(
                    1,
                    stage,
                    wgpu::TextureSampleType::Float { filterable: false },
                ),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: stage,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: wgpu::TextureFormat::R32Float,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    count: None,
                },
            ],
        });
        let filter_module = shader::create_module(gpu, &SHADERS[1], &[])?;
        let filter_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("bitmask/filter"),
                bind_group_layouts: &[Some(&gpu.layouts.frame), Some(&filter_layout)],
                immediate_size: 0,
            });
        let filter_pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("bitmask/filter"),
            layout: Some(&filter_pipeline_layout),
            module: &filter_module,
            entry_point: Some("filter_pass"),
            compilation_options: Default::default(),
            cache: None,
        });
        Ok(Self {
            settings,
            gpu: gpu.clone(),
            shadow_map: CentreShadowMap::new(gpu)?,
            peeler: Peeler::new(gpu)?,
            hierarchies: Vec::new(),
            gather_layout,
            gather_pipeline_layout,
            gather_pipelines: [None, None, None],
            filter_layout,
            filter_pipeline,
            params_buffer: uniform_buffer(gpu, "bitmask/params", &GatherUniform::zeroed()),
            counters: GatherCounters::new(gpu, "bitmask/counters"),
            adaptive: AdaptiveTargets::new(gpu, "bitmask"),
            targets: None,
            kept: None,
            stats: TechniqueStats::new(),
            gathered: false,
            rebuilt_layers: 0,
            filtered: false,
        })
    }

    /// The gather pipeline for a mask of `words` 32-bit words (compiled on first use).
    fn gather_pipeline(
        &mut self,
        words: u32,
        coarse: bool,
    ) -> Result<&(wgpu::ComputePipeline, Option<wgpu::ComputePipeline>), TechniqueError> {
        let index = MASK_WORD_COUNTS
            .iter()
            .position(|&w| w == words)
            .expect("every pattern has 2, 8 or 32 words");
        let missing = match &self.gather_pipelines[index] {
            None => true,
            Some((_, c)) => coarse && c.is_none(),
        };
        if missing {
            let module = shader::create_module(
                &self.gpu,
                &SHADERS[0],
                &[("MASK_WORDS", DefValue::UInt(words))],
            )?;
            let pipeline = |entry_point| {
                self.gpu
                    .device
                    .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some("bitmask/gather"),
                        layout: Some(&self.gather_pipeline_layout),
                        module: &module,
                        entry_point: Some(entry_point),
                        compilation_options: Default::default(),
                        cache: None,
                    })
            };
            let gather = match self.gather_pipelines[index].take() {
                Some((gather, _)) => gather,
                None => pipeline("gather"),
            };
            let coarse = coarse.then(|| pipeline("gather_coarse"));
            self.gather_pipelines[index] = Some((gather, coarse));
        }
        Ok(self.gather_pipelines[index]
            .as_ref()
            .expect("compiled above"))
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
        self.peeler
            .ensure_maps(frame.gpu, key.map_size, layers.saturating_sub(1));
        let centre = self.shadow_map.map_view().expect("rendered by the caller");
        for k in 1..layers {
            let previous = if k == 1 {
                centre
            } else {
                &self.peeler.maps[k - 2].1
            };
            self.peeler
                .record(frame, inputs, &self.shadow_map.view_buffer, previous, k - 1);
        }
        for (k, hierarchy) in self.hierarchies.iter_mut().enumerate().take(layers) {
            let (depth, label) = if k == 0 {
                (centre, "bitmask/hierarchy")
            } else {
                (&self.peeler.maps[k - 1].1, "bitmask/peel_hierarchy")
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
        let s = self.settings.clone();
        // The settings are range-checked by set_param; a library user may set any value.
        let layers = s.layers.clamp(1, MAX_LAYERS);
        // A bitmask block costs two iterations of the loop budget, so a layer counts as two
        // passes (docs/DEVICES.md, "Lavapipe's loop budget").
        let full_search = full_search_patches(2 * layers);
        let max_patches = match s.hierarchy {
            HierarchyKind::None => full_search,
            _ => s.max_patches.clamp(4, 32),
        };
        let filter_passes = s.filter_passes.min(8);
        let map_size = s
            .shadow_map_size
            .clamp(1, gpu.device.limits().max_texture_dimension_2d);
        self.gathered = false;
        self.rebuilt_layers = 0;
        self.filtered = false;

        // Kept light-space work must match what these settings would build.
        let mut key = LightSpaceKey {
            map_size,
            layers,
            hierarchy: s.hierarchy,
            levels: 0,
        };
        let Some(frustum) = self
            .shadow_map
            .render(frame, inputs, map_size, "bitmask/shadow_map")
        else {
            out.write_unshadowed(frame, inputs.frame_bind_group, "bitmask/no_casters")?;
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        };
        // Only the levels this light and map can need (core::hierarchy::needed_levels).
        let search = max_search_texels(
            inputs.light.half_extent(),
            frustum.near,
            frustum.s_max - frustum.s_min,
            map_size,
        );
        key.levels = match s.hierarchy {
            HierarchyKind::None => needed_levels(map_size, search, full_search, false),
            _ => needed_levels(map_size, search, max_patches, true),
        };
        let mut rebuild = self.shadow_map.rebuilt();
        if !rebuild && self.kept != Some(key) {
            // Settings changed under a kept map (a library user editing fields): redo it all.
            self.shadow_map.invalidate();
            self.shadow_map
                .render(frame, inputs, map_size, "bitmask/shadow_map");
            rebuild = true;
        }
        if rebuild {
            self.build_light_space(frame, inputs, key);
            self.kept = Some(key);
        }
        let built_layers = self.hierarchies.len().min(layers as usize);
        if built_layers == 0 {
            return Err(TechniqueError::Other {
                technique: ID.into(),
                message: "the depth hierarchy could not be created: check the GPU adapter".into(),
            });
        }

        let pattern = s.pattern.layout();
        // Not with the full search: it stays the yardstick, and its unrefined area says nothing
        // about the penumbra.
        let adaptive_factor = match s.hierarchy {
            HierarchyKind::None => 1,
            _ => s.adaptive_resolution.factor(),
        };
        let uniform = GatherUniform {
            hierarchy: s.hierarchy.shader_value(),
            primitive: match s.primitive {
                Primitive::Micropatch => 0,
                Primitive::Microquad => 1,
            },
            gap_filling: u32::from(s.gap_filling),
            max_patches,
            bias_texels: if s.bias_texels.is_finite() {
                s.bias_texels.max(0.0)
            } else {
                1.5
            },
            max_level: key.levels as i32,
            layers: built_layers as u32,
            with_area: u32::from(filter_passes > 0),
            rows: pattern.rows,
            columns: pattern.columns,
            jittered: u32::from(pattern.jittered),
            edge_refine: s.edge_refine.min(3),
            depth_bands: s.depth_bands.clamp(1, 8),
            adaptive_factor,
            adaptive_pixels: if s.adaptive_pixels.is_finite() {
                s.adaptive_pixels.max(0.0)
            } else {
                8.0
            },
            _pad: 0,
        };
        gpu.queue
            .write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&uniform));
        self.counters.clear(gpu);
        let coarse_size = self
            .adaptive
            .prepare(gpu, inputs.width, inputs.height, adaptive_factor);
        self.ensure_targets(inputs.width, inputs.height);
        self.gather_pipeline(pattern.words(), coarse_size.is_some())?;
        let pipeline_index = MASK_WORD_COUNTS
            .iter()
            .position(|&w| w == pattern.words())
            .expect("compiled above");
        let pipeline = self.gather_pipelines[pipeline_index]
            .as_ref()
            .expect("compiled above");
        let targets = self.targets.as_ref().expect("allocated above");

        let layer = |k: usize| &self.hierarchies[k.min(built_layers - 1)];
        let mut entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: self.shadow_map.view_buffer.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: self.params_buffer.as_entire_binding(),
            },
        ];
        for k in 0..MAX_LAYERS as usize {
            entries.push(wgpu::BindGroupEntry {
                binding: 2 + k as u32,
                resource: wgpu::BindingResource::TextureView(
                    layer(k).hsm_view().expect("built with the map"),
                ),
            });
            entries.push(wgpu::BindGroupEntry {
                binding: 6 + k as u32,
                resource: wgpu::BindingResource::TextureView(layer(k).mssm_view()),
            });
        }
        // Without filtering the bitmask result is the output; with it, B goes to its own image.
        let b_view = if filter_passes > 0 {
            &targets.bitmask.1
        } else {
            &out.view
        };
        entries.extend([
            wgpu::BindGroupEntry {
                binding: 10,
                resource: wgpu::BindingResource::TextureView(b_view),
            },
            wgpu::BindGroupEntry {
                binding: 11,
                resource: wgpu::BindingResource::TextureView(&targets.area.1),
            },
            wgpu::BindGroupEntry {
                binding: 12,
                resource: wgpu::BindingResource::TextureView(&targets.level.1),
            },
            wgpu::BindGroupEntry {
                binding: 13,
                resource: self.counters.binding(),
            },
        ]);
        let bind_group = |pass| {
            let mut entries = entries.clone();
            entries.extend(self.adaptive.entries(14, pass));
            gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("bitmask/gather"),
                layout: &self.gather_layout,
                entries: &entries,
            })
        };
        if let (Some((w, h)), Some(coarse_pipeline)) = (coarse_size, &pipeline.1) {
            let coarse = bind_group(AdaptivePass::Coarse);
            frame.compute_pass("bitmask/gather_coarse", |pass| {
                pass.set_pipeline(coarse_pipeline);
                pass.set_bind_group(0, inputs.frame_bind_group, &[]);
                pass.set_bind_group(1, &coarse, &[]);
                pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
            });
        }
        let bind_group = bind_group(AdaptivePass::Full);
        let groups = (inputs.width.div_ceil(8), inputs.height.div_ceil(8));
        frame.compute_pass("bitmask/gather", |pass| {
            pass.set_pipeline(&pipeline.0);
            pass.set_bind_group(0, inputs.frame_bind_group, &[]);
            pass.set_bind_group(1, &bind_group, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        });

        // Post filter (paper section 3.1): B -> ping -> pong -> ... -> out.
        for pass_index in 0..filter_passes as usize {
            let src = if pass_index == 0 {
                &targets.bitmask.1
            } else {
                &targets.ping[(pass_index - 1) % 2].1
            };
            let dst = if pass_index + 1 == filter_passes as usize {
                &out.view
            } else {
                &targets.ping[pass_index % 2].1
            };
            let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("bitmask/filter"),
                layout: &self.filter_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(&targets.area.1),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(src),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(dst),
                    },
                ],
            });
            frame.compute_pass("bitmask/filter", |pass| {
                pass.set_pipeline(&self.filter_pipeline);
                pass.set_bind_group(0, inputs.frame_bind_group, &[]);
                pass.set_bind_group(1, &bind_group, &[]);
                pass.dispatch_workgroups(groups.0, groups.1, 1);
            });
        }
        self.filtered = filter_passes > 0;

        self.counters.copy_out(frame);
        self.gathered = true;
        self.stats = TechniqueStats::from([
            ("shadow_maps".into(), built_layers as f64),
            ("hierarchy_levels".into(), key.levels as f64),
            ("max_search_texels".into(), search.min(1e9) as f64),
            ("light_samples".into(), pattern.samples() as f64),
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
        if let Some(c) = self.counters.read(&self.gpu) {
            let receivers = c.receivers.max(1) as f64;
            let backprojected = c.backprojected.max(1) as f64;
            let primitives = (((c.primitives_hi as u64) << 32) | c.primitives_lo as u64) as f64;
            let set_bits = (((c.set_bits_hi as u64) << 32) | c.set_bits_lo as u64) as f64;
            let samples = self.settings.pattern.layout().samples() as f64;
            stats.insert("receiver_pixels".into(), c.receivers as f64);
            stats.insert(
                "backprojected_pixel_fraction".into(),
                c.backprojected as f64 / receivers,
            );
            stats.insert("lit_pixel_fraction".into(), c.lit as f64 / receivers);
            stats.insert("umbra_pixel_fraction".into(), c.umbra as f64 / receivers);
            stats.insert(
                "upsampled_pixel_fraction".into(),
                c.upsampled as f64 / receivers,
            );
            stats.insert("mean_primitives_per_pixel".into(), primitives / receivers);
            stats.insert("max_primitives_per_pixel".into(), c.primitives_max as f64);
            stats.insert(
                "mean_primitives_per_backprojected_pixel".into(),
                primitives / backprojected,
            );
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
        for (k, (texture, _)) in self.peeler.maps.iter().enumerate().take(layers - 1) {
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
        if let Err(e) = shader::validate_all(SHADERS) {
            panic!("{e}");
        }
    }

    #[test]
    fn uniform_sizes_match_the_shader() {
        assert_eq!(std::mem::size_of::<GatherUniform>(), 64);
        assert_eq!(std::mem::size_of::<Counters>(), 48);
    }
}
