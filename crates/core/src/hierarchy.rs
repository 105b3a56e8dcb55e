//! Depth hierarchies over the centre shadow map, shared by the gather techniques
//! (`backprojection`, later `bitmask`):
//!
//! * the **HSM** (hierarchical shadow map, Guennebaud et al. 2006): a min/max mip pyramid, mip `i`
//!   holding the depth range of aligned `2^i x 2^i` blocks;
//! * the **MSSM** (multi-scale shadow map, bitmask soft shadows paper section 5): every level at
//!   full resolution, level `i` holding the depth range of the `2^i x 2^i` neighbourhood centred on
//!   the texel, clamped to the edge.
//!
//! Both store light-space depth as `Rg32Float` (min, max); texels without a caster hold
//! [`HIERARCHY_EMPTY`]. Level 0 is the HSM's mip 0 (the linearised map, padded to a power of two
//! with empty texels); the MSSM array holds levels 1.. (layer `i - 1` = level `i`). Each build is a
//! timed compute pass through [`Frame::compute_pass`] with one dispatch per level, and only the
//! levels the light size and map resolution can need are built ([`needed_levels`]).
//! Shaders read them with `softshadow::search_area` (`shaders/common/search_area.wgsl`).

use encase::ShaderType;

use crate::{
    frame::{texture_entry, uniform_entry, Frame},
    fullscreen::depth_texture_entry,
    shader,
    uniform::uniform_bytes,
    Gpu, GpuError,
};

/// Depth of a texel without a caster (mirrors `HIERARCHY_EMPTY` in `search_area.wgsl`).
pub const HIERARCHY_EMPTY: f32 = 1.0e30;
/// Texel format of both hierarchies: light-space (min, max) depth.
pub const HIERARCHY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;
/// Loops over levels in the shaders stop here (`MAX_HIERARCHY_LEVELS`).
pub const MAX_HIERARCHY_LEVELS: u32 = 16;

crate::param_choice! {
    /// Which hierarchy to build above level 0.
    pub enum HierarchyKind {
        /// Level 0 only (and HSM levels a full search may need to bound its loop).
        None = "none",
        /// Min/max mip pyramid (Guennebaud et al. 2006).
        Hsm = "hsm",
        /// Multi-scale shadow map (Schwarz & Stamminger 2007, section 5).
        Mssm = "mssm",
    }
}

impl HierarchyKind {
    /// The value of `HIERARCHY_*` in `search_area.wgsl`.
    pub fn shader_value(self) -> u32 {
        match self {
            HierarchyKind::None => 0,
            HierarchyKind::Hsm => 1,
            HierarchyKind::Mssm => 2,
        }
    }
}

crate::param_choice! {
    /// How a gather technique turns the occluding texels of a search area into occluded light
    /// area (docs/TECHNIQUES.md, `backprojection`, "Large penumbrae").
    pub enum Visibility {
        /// Every occluding block is a micro-primitive of its own, backprojected and summed (or
        /// OR-ed) (Guennebaud et al. 2006).
        Sum = "sum",
        /// Only the contour edges between occluding and non-occluding blocks are backprojected
        /// and the occluded area is integrated along them (Guennebaud, Barthe & Paulin 2007):
        /// blocks inside an occluder never overlap on the light.
        Contour = "contour",
    }
}

impl Visibility {
    /// The value of `VISIBILITY_*` in `search_area.wgsl`.
    pub fn shader_value(self) -> u32 {
        match self {
            Visibility::Sum => 0,
            Visibility::Contour => 1,
        }
    }
}

/// Edge of the padded level 0: the next power of two of the map size.
pub fn padded_size(map_size: u32) -> u32 {
    map_size.max(1).next_power_of_two()
}

/// The coarsest level there is (one HSM texel covers the padded map).
pub fn top_level(map_size: u32) -> u32 {
    padded_size(map_size).trailing_zeros()
}

/// Widest search area a receiver can have, in texels: the light projected through a receiver at
/// infinity onto the near plane, `2 max(a, b) / near` in slopes (docs/ARCHITECTURE.md, "Search area"),
/// plus the half-texel margins.
pub fn max_search_texels(
    light_half: glam::Vec2,
    near: f32,
    window_width: f32,
    map_size: u32,
) -> f32 {
    let texel = (window_width / map_size.max(1) as f32).max(f32::MIN_POSITIVE);
    let slopes = 2.0 * light_half.max_element().max(0.0) / near.max(1e-6);
    let texels = slopes / texel + 2.0;
    if texels.is_finite() {
        texels
    } else {
        f32::MAX
    }
}

/// Loop iterations one shader invocation may run on lavapipe before Mesa 24.1 (measured on
/// 22.3.6; none on 25.0.7): its loops end silently once their iterations together reach 65535
/// (`LP_MAX_TGSI_LOOP_ITERATIONS` in Mesa's gallivm, one counter shared by every loop of the
/// invocation; docs/DEVICES.md, "Lavapipe's loop budget"). A full search (`hierarchy = none`) must
/// keep its gather under this, or the blocks after the budget are dropped without an error; the
/// rest (about 5,000) is left for the shader's other loops.
pub const LOOP_BUDGET: u32 = 60_000;

/// Blocks per axis a full search (`hierarchy = none`) gathers in each of `passes` gathers of one
/// invocation (depth layers) before it must use coarser blocks: the gather loops run about
/// (n + 2)^2 times for n blocks per axis (micro-quads span one block more, and each loop ends
/// with one test), so n = sqrt([`LOOP_BUDGET`] / passes) - 4: 240 for one pass, 118 for four.
pub fn full_search_patches(passes: u32) -> u32 {
    let per_pass = f64::from(LOOP_BUDGET / passes.max(1));
    (per_pass.sqrt() as u32).saturating_sub(4).max(2)
}

/// Levels above 0 that a frame can read: the range queries over a search area of up to
/// `search_texels` texels (2 x 2 HSM texels / four MSSM samples cover it at level
/// `ceil(log2(search_texels))`), and the gather level that keeps at most `per_axis` blocks per
/// axis (`ceil(log2(search_texels / (per_axis - 1)))`, one block more for alignment). `refine` =
/// false (a full search without a hierarchy) needs only the gather level. Capped at [`top_level`].
pub fn needed_levels(map_size: u32, search_texels: f32, per_axis: u32, refine: bool) -> u32 {
    let search = search_texels.clamp(1.0, 1.0e9) as f64;
    let gather = (search / (per_axis.max(2) - 1) as f64)
        .log2()
        .ceil()
        .max(0.0) as u32;
    let query = if refine {
        search.log2().ceil().max(0.0) as u32
    } else {
        0
    };
    gather.max(query).min(top_level(map_size))
}

/// Uniform stride of the per-level parameters.
const SLOT: u64 = 256;

/// The parameters of one level's dispatch (`LevelParams` in `shaders/core/hierarchy.wgsl`), one
/// per [`SLOT`].
#[derive(ShaderType)]
struct LevelParams {
    level: u32,
}

/// The level uniform against its WGSL struct (tests/shaders.rs).
pub(crate) fn uniform_mirror() -> shader::uniform_layout::UniformMirror {
    crate::uniform_mirror!(LevelParams { level } => "core/hierarchy.wgsl", LevelParams)
}

/// The HSM and MSSM textures of one map size and the pipelines that build them.
pub struct DepthHierarchy {
    linearize: wgpu::ComputePipeline,
    hsm_reduce: wgpu::ComputePipeline,
    mssm_level: wgpu::ComputePipeline,
    fence: wgpu::ComputePipeline,
    /// 1 x 1 target of the fence dispatches.
    fence_target: wgpu::TextureView,
    linearize_layout: wgpu::BindGroupLayout,
    level_layout: wgpu::BindGroupLayout,
    level_params: wgpu::Buffer,
    hsm: Option<Hsm>,
    mssm: Option<Mssm>,
    /// A 1 x 1 x 1 array bound in place of the MSSM when it is not built.
    empty_mssm: wgpu::TextureView,
    built: Built,
    timer: Option<BuildTimer>,
    /// The last build's level passes timed serially (frames timed with
    /// `TimingSource::Serial`), where the encoder timestamps would span submissions.
    serial_build_ms: Option<f64>,
}

struct Hsm {
    map_size: u32,
    texture: wgpu::Texture,
    /// All mips (for lookups).
    view: wgpu::TextureView,
    /// One view per mip (storage target / source of the next level).
    mips: Vec<wgpu::TextureView>,
}

struct Mssm {
    map_size: u32,
    levels: u32,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    layers: Vec<wgpu::TextureView>,
}

/// What the last build produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Built {
    /// Which hierarchy.
    pub kind: HierarchyKind,
    /// Highest level built (0 = only the linearised map).
    pub levels: u32,
    /// Edge of the shadow map it was built over.
    pub map_size: u32,
}

/// Timestamps around the level passes (needs `TIMESTAMP_QUERY_INSIDE_ENCODERS`).
struct BuildTimer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// A build was timed and not yet read.
    pending: bool,
}

impl BuildTimer {
    /// Two timestamp queries and their resolve and readback buffers; `None` without
    /// `TIMESTAMP_QUERY_INSIDE_ENCODERS`.
    fn new(gpu: &Gpu) -> Option<Self> {
        let needed =
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
        let device = &gpu.device;
        gpu.features().contains(needed).then(|| BuildTimer {
            queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("core/hierarchy build time"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("core/hierarchy build time resolve"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("core/hierarchy build time readback"),
                size: 16,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            pending: false,
        })
    }
}

impl DepthHierarchy {
    /// Builds the pipelines (`shaders/core/hierarchy.wgsl`); textures are made by the first build.
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        let spec = shader::CORE_SHADERS
            .iter()
            .find(|s| s.path == "core/hierarchy.wgsl")
            .expect("listed in CORE_SHADERS");
        let module = shader::create_module(gpu, spec, &[])?;
        let stage = wgpu::ShaderStages::COMPUTE;
        let storage = wgpu::BindGroupLayoutEntry {
            binding: 4,
            visibility: stage,
            ty: wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format: HIERARCHY_FORMAT,
                view_dimension: wgpu::TextureViewDimension::D2,
            },
            count: None,
        };
        let device = &gpu.device;
        let linearize_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("core/hierarchy linearize"),
            entries: &[
                uniform_entry(0, stage, false),
                depth_texture_entry(1, false),
                storage,
            ],
        });
        let level_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("core/hierarchy level"),
            entries: &[
                texture_entry(
                    2,
                    stage,
                    wgpu::TextureSampleType::Float { filterable: false },
                ),
                uniform_entry(3, stage, false),
                storage,
            ],
        });
        let pipeline = |layout: &wgpu::BindGroupLayout, entry: &str| {
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(entry),
                bind_group_layouts: &[Some(layout)],
                immediate_size: 0,
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let linearize = pipeline(&linearize_layout, "linearize");
        let hsm_reduce = pipeline(&level_layout, "hsm_reduce");
        let mssm_level = pipeline(&level_layout, "mssm_level");
        let fence = pipeline(&level_layout, "fence");
        let fence_target =
            create_texture(gpu, "core/hierarchy fence", 1, 1, 1).create_view(&Default::default());
        let mut slots = vec![0u8; (SLOT * MAX_HIERARCHY_LEVELS as u64) as usize];
        for level in 0..MAX_HIERARCHY_LEVELS {
            let params = uniform_bytes(&LevelParams { level });
            let at = (level as u64 * SLOT) as usize;
            slots[at..at + params.len()].copy_from_slice(&params);
        }
        let level_params = {
            use wgpu::util::DeviceExt;
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("core/hierarchy levels"),
                contents: &slots,
                usage: wgpu::BufferUsages::UNIFORM,
            })
        };
        let empty_mssm = create_texture(gpu, "core/mssm (not built)", 1, 1, 1).create_view(
            &wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            },
        );
        let timer = BuildTimer::new(gpu);
        Ok(Self {
            linearize,
            hsm_reduce,
            mssm_level,
            fence,
            fence_target,
            linearize_layout,
            level_layout,
            level_params,
            hsm: None,
            mssm: None,
            empty_mssm,
            built: Built {
                kind: HierarchyKind::None,
                levels: 0,
                map_size: 0,
            },
            timer,
            serial_build_ms: None,
        })
    }

    /// Linearises `depth` (a `Depth32Float` map of `map_size`², described by the `ShadowView`
    /// uniform `shadow_view`) into level 0 as the pass `{label}/level0`, then builds levels
    /// `1..=levels` of `kind` as the pass `{label}/hsm` or `{label}/mssm`. `levels` is capped at
    /// [`top_level`]; the HSM of [`HierarchyKind::None`] is built up to `levels` too (a full search
    /// may need coarse blocks to bound its loop).
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        &mut self,
        frame: &mut Frame<'_>,
        depth: &wgpu::TextureView,
        shadow_view: &wgpu::Buffer,
        map_size: u32,
        kind: HierarchyKind,
        levels: u32,
        label: &str,
    ) {
        let gpu = frame.gpu;
        self.ensure_hsm(gpu, map_size);
        let hsm = self.hsm.as_ref().expect("allocated above");
        let padded = padded_size(map_size);
        let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("core/hierarchy linearize"),
            layout: &self.linearize_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: shadow_view.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(depth),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&hsm.mips[0]),
                },
            ],
        });
        frame.compute_pass(&format!("{label}/level0"), |pass| {
            pass.set_pipeline(&self.linearize);
            pass.set_bind_group(0, &bind_group, &[]);
            let groups = padded.div_ceil(8);
            pass.dispatch_workgroups(groups, groups, 1);
        });
        self.build_levels(frame, map_size, kind, levels, label);
    }

    /// Builds levels `1..=levels` of `kind` from the current level 0 (what [`DepthHierarchy::build`]
    /// does after linearising; tests call it after writing level 0 themselves through
    /// [`DepthHierarchy::hsm_texture`]). Allocates the textures for `map_size` if needed.
    pub fn build_levels(
        &mut self,
        frame: &mut Frame<'_>,
        map_size: u32,
        kind: HierarchyKind,
        levels: u32,
        label: &str,
    ) {
        let gpu = frame.gpu;
        let levels = levels.min(top_level(map_size));
        self.ensure_hsm(gpu, map_size);
        if kind == HierarchyKind::Mssm {
            self.ensure_mssm(gpu, map_size, levels);
        }
        let hsm = self.hsm.as_ref().expect("allocated above");
        let padded = padded_size(map_size);
        let pipeline = if kind == HierarchyKind::Mssm {
            &self.mssm_level
        } else {
            &self.hsm_reduce
        };
        let dispatches = self.level_dispatches(gpu, kind, levels, padded);
        // Timestamps after a dependent dispatch (docs/DEVICES.md, "Lavapipe's timestamps").
        // With serial timing the level pass is submitted and waited for on its own, so its wall
        // time is the build time and timestamps in two submissions would add the round trips.
        let serial = frame.is_timed_serially();
        let timed = self.timer.is_some() && !serial;
        let first_source = &hsm.mips[0];
        let last_target = match (kind, levels) {
            (_, 0) => &hsm.mips[0],
            (HierarchyKind::Mssm, _) => {
                &self.mssm.as_ref().expect("allocated above").layers[levels as usize - 1]
            }
            _ => &hsm.mips[levels as usize],
        };
        let fences = [
            self.level_bind_group(gpu, first_source, &self.fence_target, 0),
            self.level_bind_group(gpu, last_target, &self.fence_target, 0),
        ];
        let fence = |frame: &mut Frame<'_>, bind_group: &wgpu::BindGroup| {
            frame.compute_pass(&format!("{label}/fence"), |pass| {
                pass.set_pipeline(&self.fence);
                pass.set_bind_group(0, bind_group, &[]);
                pass.dispatch_workgroups(1, 1, 1);
            });
        };
        if timed {
            fence(frame, &fences[0]);
        }
        if let Some(timer) = self.timer.as_ref().filter(|_| timed) {
            frame.encoder.write_timestamp(&timer.queries, 0);
        }
        self.serial_build_ms = serial.then_some(0.0);
        if !dispatches.is_empty() {
            let name = if kind == HierarchyKind::Mssm {
                "mssm"
            } else {
                "hsm"
            };
            let pass = format!("{label}/{name}");
            let before = frame.serial_pass_ms(&pass);
            frame.compute_pass(&pass, |pass| {
                for (bind_group, edge) in &dispatches {
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, bind_group, &[]);
                    let groups = edge.div_ceil(8);
                    pass.dispatch_workgroups(groups, groups, 1);
                }
            });
            if let (Some(before), Some(after)) = (before, frame.serial_pass_ms(&pass)) {
                self.serial_build_ms = Some(after - before);
            }
        }
        if timed {
            fence(frame, &fences[1]);
        }
        if let Some(timer) = self.timer.as_mut().filter(|_| timed) {
            frame.encoder.write_timestamp(&timer.queries, 1);
            frame
                .encoder
                .resolve_query_set(&timer.queries, 0..2, &timer.resolve, 0);
            frame
                .encoder
                .copy_buffer_to_buffer(&timer.resolve, 0, &timer.readback, 0, 16);
            timer.pending = true;
        }
        self.built = Built {
            kind,
            levels,
            map_size,
        };
    }

    /// The level passes of `levels` levels of `kind` over a padded map of edge `padded`: (bind
    /// group, edge of the target) per level. The HSM reduces each level from the one below; the
    /// MSSM builds every level at full size from the one below (level 1 from the HSM's level 0).
    fn level_dispatches(
        &self,
        gpu: &Gpu,
        kind: HierarchyKind,
        levels: u32,
        padded: u32,
    ) -> Vec<(wgpu::BindGroup, u32)> {
        let hsm = self.hsm.as_ref().expect("allocated by build_levels");
        let mut dispatches = Vec::new();
        match (kind, levels) {
            (_, 0) => {}
            (HierarchyKind::None | HierarchyKind::Hsm, _) => {
                for level in 1..=levels {
                    let bind_group = self.level_bind_group(
                        gpu,
                        &hsm.mips[level as usize - 1],
                        &hsm.mips[level as usize],
                        level,
                    );
                    dispatches.push((bind_group, (padded >> level).max(1)));
                }
            }
            (HierarchyKind::Mssm, _) => {
                let mssm = self.mssm.as_ref().expect("allocated by build_levels");
                for level in 1..=levels {
                    let src = if level == 1 {
                        &hsm.mips[0]
                    } else {
                        &mssm.layers[level as usize - 2]
                    };
                    let dst = &mssm.layers[level as usize - 1];
                    let bind_group = self.level_bind_group(gpu, src, dst, level);
                    dispatches.push((bind_group, padded));
                }
            }
        }
        dispatches
    }

    /// The bind group of one level pass (or a fence): level `src` read, `dst` written, the level
    /// number's uniform slot.
    fn level_bind_group(
        &self,
        gpu: &Gpu,
        src: &wgpu::TextureView,
        dst: &wgpu::TextureView,
        level: u32,
    ) -> wgpu::BindGroup {
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("core/hierarchy level"),
            layout: &self.level_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(src),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &self.level_params,
                        offset: level as u64 * SLOT,
                        size: Some(LevelParams::min_size()),
                    }),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(dst),
                },
            ],
        })
    }

    fn ensure_hsm(&mut self, gpu: &Gpu, map_size: u32) {
        if self.hsm.as_ref().map(|h| h.map_size) == Some(map_size) {
            return;
        }
        let padded = padded_size(map_size);
        let mip_count = top_level(map_size) + 1;
        let texture = create_texture(gpu, "core/hsm", padded, mip_count, 1);
        let mips = (0..mip_count)
            .map(|mip| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    base_mip_level: mip,
                    mip_level_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        self.hsm = Some(Hsm {
            map_size,
            view: texture.create_view(&Default::default()),
            texture,
            mips,
        });
    }

    fn ensure_mssm(&mut self, gpu: &Gpu, map_size: u32, levels: u32) {
        let fits = self
            .mssm
            .as_ref()
            .is_some_and(|m| m.map_size == map_size && m.levels >= levels);
        if fits || levels == 0 {
            return;
        }
        let padded = padded_size(map_size);
        let texture = create_texture(gpu, "core/mssm", padded, 1, levels);
        let layers = (0..levels)
            .map(|layer| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: layer,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        self.mssm = Some(Mssm {
            map_size,
            levels,
            texture,
            view,
            layers,
        });
    }

    /// What the last build produced.
    pub fn built(&self) -> Built {
        self.built
    }

    /// The HSM with all its mips (`texture_2d<f32>`), or `None` before the first build.
    pub fn hsm_view(&self) -> Option<&wgpu::TextureView> {
        self.hsm.as_ref().map(|h| &h.view)
    }

    /// The HSM texture (mip pyramid), once built.
    pub fn hsm_texture(&self) -> Option<&wgpu::Texture> {
        self.hsm.as_ref().map(|h| &h.texture)
    }

    /// The MSSM levels 1.. (`texture_2d_array<f32>`); a 1 x 1 x 1 placeholder when the last build
    /// was not an MSSM (shaders then never read it).
    pub fn mssm_view(&self) -> &wgpu::TextureView {
        match (&self.mssm, self.built.kind) {
            (Some(m), HierarchyKind::Mssm) if self.built.levels > 0 => &m.view,
            _ => &self.empty_mssm,
        }
    }

    /// The MSSM texture (array of full-resolution levels 1..), once built.
    pub fn mssm_texture(&self) -> Option<&wgpu::Texture> {
        self.mssm.as_ref().map(|m| &m.texture)
    }

    /// GPU time of the level passes of the last build, in ms, from the build's own timestamp
    /// queries, or in a serially timed frame the level pass's wall time. `None` without
    /// `TIMESTAMP_QUERY_INSIDE_ENCODERS` (and not serial), or before the first build.
    /// Call after the frame was submitted and finished (it maps a buffer and waits).
    pub fn last_build_ms(&self, gpu: &Gpu) -> Option<f64> {
        if self.serial_build_ms.is_some() {
            return self.serial_build_ms;
        }
        let timer = self.timer.as_ref().filter(|t| t.pending)?;
        let slice = timer.readback.slice(..);
        let (sender, receiver) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = sender.send(r);
        });
        gpu.wait_idle().ok()?;
        receiver.recv().ok()?.ok()?;
        let ticks = {
            let data = slice.get_mapped_range().ok()?;
            let start = u64::from_le_bytes(data[0..8].try_into().ok()?);
            let end = u64::from_le_bytes(data[8..16].try_into().ok()?);
            end.saturating_sub(start)
        };
        timer.readback.unmap();
        Some(ticks as f64 * gpu.queue.get_timestamp_period() as f64 * 1e-6)
    }
}

fn create_texture(gpu: &Gpu, label: &str, size: u32, mips: u32, layers: u32) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: layers,
        },
        mip_level_count: mips,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: HIERARCHY_FORMAT,
        usage: wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

/// The legend of a gather technique's `level` debug view (the level each pixel gathered at).
pub fn level_legend(meaning: &'static str) -> crate::DebugLegend {
    crate::DebugLegend::Value {
        meaning: meaning.into(),
        notes: vec!["-1 (black when present): nothing was backprojected there".into()],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_searches_stay_within_lavapipes_loop_budget() {
        assert_eq!(full_search_patches(1), 240);
        assert_eq!(full_search_patches(4), 118);
        for passes in 1..=8 {
            let n = full_search_patches(passes);
            // Micro-quads: n + 1 quads per axis, each loop one test more.
            assert!(passes * (n + 2) * (n + 2) <= LOOP_BUDGET, "{passes}: {n}");
        }
    }

    #[test]
    fn levels_follow_the_search_area_and_stop_at_the_top() {
        assert_eq!(top_level(1024), 10);
        assert_eq!(top_level(1000), 10);
        assert_eq!(padded_size(1000), 1024);
        // A 100-texel search area: queries need level 7 (128 >= 100).
        assert_eq!(needed_levels(1024, 100.0, 16, true), 7);
        // Without refinement only the gather level: 100 / 15 -> 2^3.
        assert_eq!(needed_levels(1024, 100.0, 16, false), 3);
        assert_eq!(needed_levels(1024, 10.0, 256, false), 0);
        // Huge lights: capped at the top level.
        assert_eq!(needed_levels(256, f32::MAX, 4, true), 8);
        assert_eq!(needed_levels(256, f32::NAN, 4, true), 0);
    }

    #[test]
    fn the_widest_search_area_grows_with_the_light_and_shrinks_with_the_near_plane() {
        let small = max_search_texels(glam::Vec2::splat(0.5), 1.0, 1.0, 256);
        let large = max_search_texels(glam::Vec2::splat(1.0), 1.0, 1.0, 256);
        let far = max_search_texels(glam::Vec2::splat(0.5), 2.0, 1.0, 256);
        assert!((small - 258.0).abs() < 1e-3, "{small}");
        assert!(large > small && far < small);
        assert!(max_search_texels(glam::Vec2::splat(1.0), 0.0, 1.0, 256).is_finite());
    }
}
