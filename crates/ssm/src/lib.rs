//! `ssm`: soft shadow maps (Atty, Holzschuch, Lapierre, Hasenfratz, Hansen, Sillion 2006),
//! entirely on the GPU (the paper's own future work, section 6).
//!
//! Reads: the casters (occluder map(s)), the receivers that are not casters (receiver map) and
//! the G-buffer. Writes: the visibility buffer. Passes, in order:
//!
//! 1. `ssm/occluder_map` (and `ssm/occluder_map_back` with `two_pass`): depth of the casters from
//!    the light centre, the window axis-aligned with the light and with its aspect ratio
//!    (section 3.2); the back map keeps the farthest surface (section 3.5).
//! 2. `ssm/receiver_map`: depth of the receivers over the soft shadow map's window.
//! 3. `ssm/scatter` (`ssm/scatter_back`): one instanced quad per occluder-map texel; the vertex
//!    stage builds the micro-patch and its penumbra rectangle (section 3.3), the fragment stage
//!    backprojects the patch onto the light and blends the occluded fraction additively into the
//!    soft shadow map (section 3.4). With `precision = fp16-batched` this runs once per batch of
//!    patches, each batch followed by `ssm/batch_add` into an FP32 total (appendix A).
//! 4. `ssm/project`: the soft shadow map(s), merged by maximum, projected onto the receivers.
//! 5. `ssm/stats`: counters for the report (micro-patches drawn, texels with occlusion).

#![warn(missing_docs)]

pub mod math;

use encase::ShaderType;
use softshadow_core::{
    glam::{Vec3, Vec4},
    pass::{ComputePass, FullscreenPass, Pass, PassGroup, Slot},
    shader::{create_module, DefValue, ShaderSpec},
    shader_file,
    shadow_map::{CasterDraw, DepthMapRenderer, ShadowViewUniform},
    uniform::{uniform_bytes, zeroed_uniform_buffer},
    wgpu, DebugLegend, DebugView, Frame, Gpu, Requirements, ShadowInputs, ShadowTechnique,
    SlopeFrustum, TechniqueError, TechniqueSettings, TechniqueStats, VisibilityBuffer,
};

mod info;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "ssm";

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "ssm/scatter.wgsl",
        source: shader_file!("ssm/scatter.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "ssm/project.wgsl",
        source: shader_file!("ssm/project.wgsl").1,
        permutations: &[&[], &[("TWO_PASS", DefValue::Bool(true))]],
    },
    ShaderSpec {
        path: "ssm/batch_add.wgsl",
        source: shader_file!("ssm/batch_add.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "ssm/stats.wgsl",
        source: shader_file!("ssm/stats.wgsl").1,
        permutations: &[&[]],
    },
];

const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

softshadow_core::param_choice! {
    /// How the micro-patches' occlusion is summed in the soft shadow map (appendix A).
    pub enum Precision {
        /// FP32 blending (needs `FLOAT32_BLENDABLE`; the paper's "future hardware").
        Fp32 = "fp32",
        /// FP16 blending, as on the paper's GeForce 6800: contributions below 2^-10 of the running
        /// sum are lost, more so with larger occluder maps.
        Fp16 = "fp16",
        /// The paper's workaround: the M = N² patch slots split into floor(sqrt(M)) = N batches
        /// (one occluder-map row each), each summed with FP16 blending, the batch sums added in
        /// FP32.
        Fp16Batched = "fp16-batched",
    }
}

impl Precision {
    /// Format of the soft shadow map that micro-patches are blended into.
    fn scatter_format(self) -> wgpu::TextureFormat {
        match self {
            Precision::Fp32 => wgpu::TextureFormat::R32Float,
            Precision::Fp16 | Precision::Fp16Batched => wgpu::TextureFormat::R16Float,
        }
    }
}

softshadow_core::technique_settings! {
    /// Settings of soft shadow maps. Defaults: the paper's usual 128² occluder map (sections
    /// 4.2.4-5, 5.2), one pass, FP32 blending.
    pub struct SsmSettings {
        /// Occluder-map edge N (N² micro-patches at most)
        occluder_map_size: u32 = 128, in 64..=1024;
        /// Second occluder map of the farthest surfaces, merged by maximum (section 3.5)
        two_pass: bool = false;
        /// Blending precision of the soft shadow map: fp32, fp16, or fp16 in sqrt(M) batches
        /// summed in fp32 (appendix A)
        precision: Precision = Precision::Fp32;
        /// Soft-shadow-map and receiver-map edge in texels
        ssm_size: u32 = 128, in 32..=1024;
        /// Depth tolerance in texel footprints (receiver test and hard fallback on occluders)
        bias_texels: f32 = 1.5, in 0.0..=16.0;
    }
}

#[derive(Debug, ShaderType)]
struct SsmUniform {
    occluder_window: Vec4,
    /// near, far, N, depth of an empty texel.
    occluder_depth: Vec4,
    ssm_window: Vec4,
    /// near, far, R, farthest receiver depth.
    ssm_depth: Vec4,
    /// a, b, bias_texels, two_pass.
    light: Vec4,
    /// x: the radius of a disk, sphere or spot light (its disk in the light plane), 0 under the
    /// rectangle.
    round_light: Vec4,
}

/// This crate's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![
        softshadow_core::uniform_mirror!(
            SsmUniform {
                occluder_window, occluder_depth, ssm_window, ssm_depth, light, round_light
            } => "ssm/project.wgsl", SsmParams
        ),
        softshadow_core::uniform_mirror!(
            SsmUniform {
                occluder_window, occluder_depth, ssm_window, ssm_depth, light, round_light
            } => "ssm/scatter.wgsl", SsmParams
        ),
        softshadow_core::uniform_mirror!(
            SsmUniform {
                occluder_window, occluder_depth, ssm_window, ssm_depth, light, round_light
            } => "ssm/stats.wgsl", SsmParams
        ),
    ]
}

/// The radius of a disk, sphere or spot light (the scatter shader's coverage of a disk), 0 under
/// the rectangle.
fn round_light_radius(light: &softshadow_core::AreaLight) -> f32 {
    match light.kind {
        softshadow_core::LightKind::Rect => 0.0,
        _ => light.radius,
    }
}

/// A texture and its default view.
struct Target {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
}

fn target(
    gpu: &Gpu,
    label: &str,
    size: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> Target {
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    });
    Target {
        view: texture.create_view(&Default::default()),
        texture,
    }
}

/// Resources whose size depends on the settings; rebuilt when they change.
struct Resources {
    key: (u32, u32, bool, Precision),
    occluder_front: Target,
    occluder_back: Option<Target>,
    receiver: Target,
    /// What the scatter blends into (FP32 or FP16), one per occluder map.
    ssm_front: Target,
    ssm_back: Option<Target>,
    /// `fp16-batched`: the FP32 totals (the scatter targets then hold one batch).
    sum_front: Option<Target>,
    sum_back: Option<Target>,
    /// One occlusion query per scatter pass.
    queries: wgpu::QuerySet,
    query_capacity: u32,
    resolve: wgpu::Buffer,
    /// Counters at 0, occlusion results at `QUERY_OFFSET`.
    readback: wgpu::Buffer,
}

/// Byte offset of the occlusion-query results in the readback buffer.
const QUERY_OFFSET: u64 = wgpu::QUERY_RESOLVE_BUFFER_ALIGNMENT;

impl Resources {
    fn new(gpu: &Gpu, s: &SsmSettings) -> Self {
        let (n, r) = (s.occluder_map_size, s.ssm_size);
        let depth_usage =
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let color_usage = depth_usage | wgpu::TextureUsages::COPY_SRC;
        let batched = s.precision == Precision::Fp16Batched;
        let scatter = s.precision.scatter_format();
        let maps = if s.two_pass { 2 } else { 1 };
        let query_capacity = maps * if batched { n } else { 1 };
        let occluder = |label| target(gpu, label, n, DEPTH_FORMAT, depth_usage);
        let ssm = |label, format| target(gpu, label, r, format, color_usage);
        Self {
            key: (n, r, s.two_pass, s.precision),
            occluder_front: occluder("ssm/occluder_map"),
            occluder_back: s.two_pass.then(|| occluder("ssm/occluder_map_back")),
            receiver: target(gpu, "ssm/receiver_map", r, DEPTH_FORMAT, depth_usage),
            ssm_front: ssm("ssm/soft_shadow_map", scatter),
            ssm_back: s.two_pass.then(|| ssm("ssm/soft_shadow_map_back", scatter)),
            sum_front: batched
                .then(|| ssm("ssm/soft_shadow_map_sum", wgpu::TextureFormat::R32Float)),
            sum_back: (batched && s.two_pass).then(|| {
                ssm(
                    "ssm/soft_shadow_map_sum_back",
                    wgpu::TextureFormat::R32Float,
                )
            }),
            queries: gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("ssm/scatter fragments"),
                ty: wgpu::QueryType::Occlusion,
                count: query_capacity,
            }),
            query_capacity,
            resolve: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ssm/query resolve"),
                size: 8 * query_capacity as u64,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ssm/stats readback"),
                size: QUERY_OFFSET + 8 * query_capacity as u64,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
        }
    }

    /// The soft shadow maps the projection reads (front, back).
    fn final_maps(&self) -> (&Target, &Target) {
        let front = self.sum_front.as_ref().unwrap_or(&self.ssm_front);
        let back = self
            .sum_back
            .as_ref()
            .or(self.ssm_back.as_ref())
            .unwrap_or(front);
        (front, back)
    }
}

/// What the last frame did, for [`ShadowTechnique::stats`].
#[derive(Clone, Debug, Default)]
struct LastFrame {
    stats: TechniqueStats,
    /// Scatter passes whose occlusion queries and counters wait in the readback buffer.
    queries: Option<u32>,
}

/// The `ssm` technique: a [`ShadowTechnique`] with its settings.
pub struct Ssm {
    /// Its settings; changes take effect on the next frame.
    pub settings: SsmSettings,
    gpu: Gpu,
    /// The occluder and receiver maps (core's light-space depth pass; view slots
    /// [`OCCLUDER_SLOT`] and [`RECEIVER_SLOT`]).
    depth: DepthMapRenderer,
    scatter: Scatter,
    /// The projection with one soft shadow map and with two (`TWO_PASS`, section 3.5): one
    /// pipeline each (docs/DEVICES.md, "Lavapipe's branches").
    project: [FullscreenPass; 2],
    batch_add: FullscreenPass,
    count: ComputePass,
    params_front: wgpu::Buffer,
    params_back: wgpu::Buffer,
    counters: wgpu::Buffer,
    resources: Option<Resources>,
    last: LastFrame,
    /// The light-space maps in `resources` are complete and match the last frame's light,
    /// casters and settings.
    light_space_ready: bool,
}

/// View slots of the depth pass.
const OCCLUDER_SLOT: u32 = 0;
const RECEIVER_SLOT: u32 = 1;

/// The scatter pass (section 3.3-3.4): instanced quads blended additively, one pipeline per
/// blend format; its group is the params, the occluder map and the receiver map.
struct Scatter {
    group: PassGroup,
    fp32: wgpu::RenderPipeline,
    fp16: wgpu::RenderPipeline,
}

impl Scatter {
    fn new(gpu: &Gpu) -> Result<Self, TechniqueError> {
        let stages = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        let group = PassGroup::new(
            gpu,
            "ssm/scatter",
            &[Slot::Uniform, Slot::DEPTH, Slot::DEPTH],
            stages,
        );
        let module = create_module(gpu, &SHADERS[0], &[])?;
        let layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("ssm/scatter"),
                bind_group_layouts: &[Some(group.layout())],
                immediate_size: 0,
            });
        let pipeline = |format| scatter_pipeline(gpu, &layout, &module, format);
        Ok(Self {
            fp32: pipeline(wgpu::TextureFormat::R32Float),
            fp16: pipeline(wgpu::TextureFormat::R16Float),
            group,
        })
    }
}

fn scatter_pipeline(
    gpu: &Gpu,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    gpu.device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("ssm/scatter"),
            layout: Some(layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleStrip,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(additive_blend()),
                    write_mask: wgpu::ColorWrites::RED,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
}

/// What SSM needs at `precision`: FP32 blending for `fp32` and for the FP32 totals of
/// `fp16-batched`, and casters that are not also receivers.
fn requirements_for(precision: Precision) -> Requirements {
    Requirements {
        features: if precision == Precision::Fp16 {
            wgpu::Features::empty()
        } else {
            wgpu::Features::FLOAT32_BLENDABLE
        },
        occluder_receiver_split: true,
        ..Requirements::default()
    }
}

fn additive_blend() -> wgpu::BlendState {
    let add = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    wgpu::BlendState {
        color: add,
        alpha: add,
    }
}

impl Ssm {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: SsmSettings) -> Result<Self, TechniqueError> {
        // project.wgsl: params, the receiver map, the occluder map, the soft shadow maps.
        let project = |label, defs| {
            Pass::new(gpu, label, &SHADERS[1])
                .defs(defs)
                .after_frame_group()
                .uniform()
                .repeat(Slot::DEPTH, 2)
                .repeat(Slot::FLOAT, 2)
                .fullscreen(None)
        };
        let two_pass = [("TWO_PASS", DefValue::Bool(true))];
        Ok(Self {
            depth: DepthMapRenderer::new(gpu)?,
            scatter: Scatter::new(gpu)?,
            project: [
                project("ssm/project", &[])?,
                project("ssm/project two_pass", &two_pass)?,
            ],
            batch_add: Pass::new(gpu, "ssm/batch_add", &SHADERS[2])
                .after_frame_group()
                .texture(Slot::FLOAT)
                .fullscreen_into(wgpu::TextureFormat::R32Float, Some(additive_blend()))?,
            // stats.wgsl: params, both occluder maps, both soft shadow maps, the counters.
            count: Pass::new(gpu, "ssm/stats", &SHADERS[3])
                .uniform()
                .repeat(Slot::DEPTH, 2)
                .repeat(Slot::FLOAT, 2)
                .storage_rw()
                .compute("count")?,
            params_front: zeroed_uniform_buffer::<SsmUniform>(gpu, "ssm/params"),
            params_back: zeroed_uniform_buffer::<SsmUniform>(gpu, "ssm/params back"),
            counters: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("ssm/counters"),
                size: 16,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            gpu: gpu.clone(),
            resources: None,
            last: LastFrame::default(),
            light_space_ready: false,
            settings,
        })
    }

    /// Reads the counters and occlusion queries of the last frame (the frame has finished: the
    /// renderer waits for the GPU before stats are asked for).
    fn read_counters(&self, resources: &Resources, queries: u32) -> Option<(u64, u64, u64)> {
        let slice = resources
            .readback
            .slice(..QUERY_OFFSET + 8 * queries as u64);
        let (sender, receiver) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = sender.send(r);
        });
        self.gpu.wait_idle().ok()?;
        receiver.recv().ok()?.ok()?;
        let counts = {
            let data = slice.get_mapped_range().ok()?;
            let word =
                |at: usize| u32::from_le_bytes(data[at..at + 4].try_into().unwrap_or([0; 4]));
            let fragments: u64 = (0..queries as usize)
                .map(|q| {
                    let at = QUERY_OFFSET as usize + 8 * q;
                    u64::from_le_bytes(data[at..at + 8].try_into().unwrap_or([0; 8]))
                })
                .sum();
            (word(0) as u64, word(4) as u64, fragments)
        };
        resources.readback.unmap();
        Some(counts)
    }
}

/// The settings as used: sizes and bias clamped to their documented ranges (a library user may
/// fill the struct directly).
fn clamped(settings: &SsmSettings) -> SsmSettings {
    let s = settings.clone();
    SsmSettings {
        occluder_map_size: s.occluder_map_size.clamp(64, 1024),
        ssm_size: s.ssm_size.clamp(32, 1024),
        bias_texels: if s.bias_texels.is_finite() {
            s.bias_texels.clamp(0.0, 16.0)
        } else {
            1.5
        },
        ..s
    }
}

/// The windows of one frame: the occluder map's over the casters (section 3.2) and the soft
/// shadow map's over the receivers, with the farthest receiver depth.
struct Windows {
    occluder: SlopeFrustum,
    ssm: SlopeFrustum,
    z_far: f32,
}

impl Windows {
    /// `None` when no caster is in front of the light.
    fn fit(inputs: &ShadowInputs<'_>) -> Option<Self> {
        let half = inputs.light.half_extent();
        let bounds = inputs.scene.light_bounds(inputs.light);
        let receiver_corners: Vec<Vec3> = bounds
            .receivers
            .map(|r| r.corners().to_vec())
            .unwrap_or_default();
        let occluder = math::occluder_frustum(
            &bounds.casters?.corners(),
            bounds.casters_cross_light_plane,
            &receiver_corners,
            math::light_aspect(half),
        )?;
        let (ssm, z_far) = math::ssm_frustum(&occluder, &receiver_corners, half);
        Some(Self {
            occluder,
            ssm,
            z_far,
        })
    }
}

/// The stats of a frame that drew the light-space maps with `queries` scatter passes.
fn light_space_stats(s: &SsmSettings, queries: u32) -> TechniqueStats {
    let maps = if s.two_pass { 2.0 } else { 1.0 };
    let (n, r) = (s.occluder_map_size as f64, s.ssm_size as f64);
    TechniqueStats::from([
        ("occluder_maps".into(), maps),
        ("occluder_map_texels".into(), maps * n * n),
        ("ssm_texels".into(), r * r),
        ("scatter_passes".into(), queries as f64),
    ])
}

impl Ssm {
    /// The depth pass's views and both params uniforms (front and back occluder map).
    fn write_uniforms(
        &mut self,
        gpu: &Gpu,
        inputs: &ShadowInputs<'_>,
        w: &Windows,
        s: &SsmSettings,
    ) {
        let (n, r) = (s.occluder_map_size, s.ssm_size);
        let occluder_view = ShadowViewUniform::new(inputs.light, &w.occluder, n);
        let receiver_view = ShadowViewUniform::new(inputs.light, &w.ssm, r);
        self.depth.set_views(gpu, &[occluder_view, receiver_view]);
        let half = inputs.light.half_extent();
        let params = |empty_depth: f32| SsmUniform {
            occluder_window: window(&w.occluder),
            occluder_depth: Vec4::new(w.occluder.near, w.occluder.far, n as f32, empty_depth),
            ssm_window: window(&w.ssm),
            ssm_depth: Vec4::new(w.ssm.near, w.ssm.far, r as f32, w.z_far),
            light: Vec4::new(
                half.x,
                half.y,
                s.bias_texels,
                if s.two_pass { 1.0 } else { 0.0 },
            ),
            round_light: Vec4::new(round_light_radius(inputs.light), 0.0, 0.0, 0.0),
        };
        gpu.queue
            .write_buffer(&self.params_front, 0, &uniform_bytes(&params(1.0)));
        gpu.queue
            .write_buffer(&self.params_back, 0, &uniform_bytes(&params(0.0)));
    }

    /// 1. The occluder map(s): nearest surfaces and, for two passes, the farthest (section 3.5).
    /// 2. The receiver map over the soft shadow map's window.
    fn draw_depth_maps(&self, frame: &mut Frame<'_>, inputs: &ShadowInputs<'_>, res: &Resources) {
        let scene = inputs.scene;
        let casters = scene.casters.as_ref();
        let front = &res.occluder_front.view;
        let draw = |frame: &mut Frame<'_>, label, list, draw, slot, target| {
            self.depth
                .record_draw(frame, label, scene, list, draw, slot, target)
        };
        draw(
            frame,
            "ssm/occluder_map",
            casters,
            CasterDraw::Nearest,
            OCCLUDER_SLOT,
            front,
        );
        if let Some(back) = &res.occluder_back {
            let (label, farthest) = ("ssm/occluder_map_back", CasterDraw::Farthest);
            draw(frame, label, casters, farthest, OCCLUDER_SLOT, &back.view);
        }
        let receivers = scene.receivers.as_ref();
        let receiver = &res.receiver.view;
        let only = CasterDraw::ReceiversOnly;
        draw(
            frame,
            "ssm/receiver_map",
            receivers,
            only,
            RECEIVER_SLOT,
            receiver,
        );
    }

    /// 3. The scatter, per occluder map; returns the scatter passes drawn (one occlusion query
    ///    each).
    fn scatter(
        &self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        res: &Resources,
        s: &SsmSettings,
    ) -> u32 {
        let mut maps = vec![(
            &res.occluder_front,
            &res.ssm_front,
            res.sum_front.as_ref(),
            &self.params_front,
            "",
        )];
        if let (Some(occluder_back), Some(ssm_back)) = (&res.occluder_back, &res.ssm_back) {
            let sum = res.sum_back.as_ref();
            maps.push((occluder_back, ssm_back, sum, &self.params_back, "_back"));
        }
        let mut query = 0u32;
        for (occluder_map, target, sum, params, suffix) in maps {
            let group = self.scatter.group.bind(
                frame.gpu,
                &[
                    params.into(),
                    (&occluder_map.view).into(),
                    (&res.receiver.view).into(),
                ],
            );
            let n = s.occluder_map_size;
            // Appendix A: N batches of one occluder-map row (floor(sqrt(N²)) = N), or one draw.
            let batches: Vec<std::ops::Range<u32>> = if sum.is_some() {
                (0..n).map(|row| row * n..(row + 1) * n).collect()
            } else {
                std::iter::once(0..n * n).collect()
            };
            let add_label = format!("ssm/batch_add{suffix}");
            for (b, instances) in batches.into_iter().enumerate() {
                let label = format!("ssm/scatter{suffix}");
                self.scatter_batch(frame, &label, res, s, &group, target, instances, query);
                query += 1;
                if let Some(sum) = sum {
                    self.batch_add
                        .run(frame)
                        .named(&add_label)
                        .frame_group(inputs.frame_bind_group)
                        .read(&target.view)
                        .draw(&sum.view, (b == 0).then_some(0.0));
                }
            }
        }
        query
    }

    /// One scatter draw of `instances` micro-patches into `target`, counted by occlusion query
    /// `query`.
    #[allow(clippy::too_many_arguments)]
    fn scatter_batch(
        &self,
        frame: &mut Frame<'_>,
        label: &str,
        res: &Resources,
        s: &SsmSettings,
        group: &wgpu::BindGroup,
        target: &Target,
        instances: std::ops::Range<u32>,
        query: u32,
    ) {
        let pipeline = match s.precision {
            Precision::Fp32 => &self.scatter.fp32,
            Precision::Fp16 | Precision::Fp16Batched => &self.scatter.fp16,
        };
        let desc = wgpu::RenderPassDescriptor {
            label: None,
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &target.view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: Some(&res.queries),
            multiview_mask: None,
        };
        frame.render_pass(label, desc, |pass| {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.begin_occlusion_query(query);
            pass.draw(0..4, instances);
            pass.end_occlusion_query();
        });
    }

    /// 4. The projection onto the receivers.
    fn project(
        &self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        res: &Resources,
        out: &VisibilityBuffer,
    ) {
        let (final_front, final_back) = res.final_maps();
        self.project[usize::from(self.settings.two_pass)]
            .run(frame)
            .named("ssm/project")
            .frame_group(inputs.frame_bind_group)
            .read(&self.params_front)
            .read(&res.receiver.view)
            .read(&res.occluder_front.view)
            .read(&final_front.view)
            .read(&final_back.view)
            .draw(&out.view, Some(1.0));
    }

    /// 5. The counters: micro-patches and texels with occlusion (compute), fragments blended
    ///    (the occlusion queries of the `queries` scatter passes), copied for readback.
    fn count(&self, frame: &mut Frame<'_>, res: &Resources, s: &SsmSettings, queries: u32) {
        let (final_front, final_back) = res.final_maps();
        let back = res.occluder_back.as_ref().unwrap_or(&res.occluder_front);
        frame.encoder.clear_buffer(&self.counters, 0, None);
        let groups = s.occluder_map_size.max(s.ssm_size).div_ceil(8);
        self.count
            .run(frame)
            .read(&self.params_front)
            .read(&res.occluder_front.view)
            .read(&back.view)
            .read(&final_front.view)
            .read(&final_back.view)
            .write(&self.counters)
            .dispatch([groups, groups, 1]);
        frame
            .encoder
            .copy_buffer_to_buffer(&self.counters, 0, &res.readback, 0, 8);
        debug_assert!(queries <= res.query_capacity);
        frame
            .encoder
            .resolve_query_set(&res.queries, 0..queries, &res.resolve, 0);
        frame.encoder.copy_buffer_to_buffer(
            &res.resolve,
            0,
            &res.readback,
            QUERY_OFFSET,
            8 * queries as u64,
        );
    }
}

fn window(f: &SlopeFrustum) -> Vec4 {
    Vec4::new(f.s_min, f.s_max, f.t_min, f.t_max)
}

impl ShadowTechnique for Ssm {
    fn id(&self) -> &str {
        ID
    }

    fn requirements(&self) -> Requirements {
        requirements_for(self.settings.precision)
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
        let s = clamped(&self.settings);
        let Some(windows) = Windows::fit(inputs) else {
            // No caster in front of the light: receivers in front of it are lit.
            out.write_unshadowed(frame, inputs.frame_bind_group, "ssm/no_casters")?;
            self.last = LastFrame {
                stats: TechniqueStats::from([
                    ("micro_patches_drawn".into(), 0.0),
                    ("ssm_texels_touched".into(), 0.0),
                ]),
                queries: None,
            };
            return Ok(());
        };
        let key = (s.occluder_map_size, s.ssm_size, s.two_pass, s.precision);
        if self.resources.as_ref().map(|res| res.key) != Some(key) {
            self.resources = Some(Resources::new(gpu, &s));
            self.light_space_ready = false;
        }
        // Everything but the projection is light-space (occluder, receiver and soft shadow
        // maps, counters): kept while light, casters and settings stand still.
        let rebuild = inputs.changes.light_space() || !self.light_space_ready;
        self.light_space_ready = false;
        self.write_uniforms(gpu, inputs, &windows, &s);
        let res = self.resources.as_ref().expect("created above");
        let mut queries = 0;
        if rebuild {
            self.draw_depth_maps(frame, inputs, res);
            queries = self.scatter(frame, inputs, res, &s);
        }
        self.project(frame, inputs, res, out);
        if rebuild {
            self.count(frame, res, &s, queries);
            self.last = LastFrame {
                stats: light_space_stats(&s, queries),
                queries: Some(queries),
            };
        }
        self.light_space_ready = true;
        Ok(())
    }

    fn invalidate_cache(&mut self) {
        self.light_space_ready = false;
    }

    fn stats(&self) -> TechniqueStats {
        let mut stats = self.last.stats.clone();
        if let (Some(queries), Some(res)) = (self.last.queries, &self.resources) {
            if let Some((patches, texels, fragments)) = self.read_counters(res, queries) {
                stats.insert("micro_patches_drawn".into(), patches as f64);
                stats.insert("ssm_texels_shadowed".into(), texels as f64);
                stats.insert("ssm_texels_touched".into(), fragments as f64);
            }
        }
        stats
    }

    fn debug_views(&self) -> Vec<DebugView> {
        let Some(res) = &self.resources else {
            return Vec::new();
        };
        let (final_front, _) = res.final_maps();
        let mut views = vec![
            DebugView::new(
                "shadow_map",
                &res.occluder_front.texture,
                DebugLegend::Depth,
            ),
            DebugView::new("receiver_map", &res.receiver.texture, DebugLegend::Depth),
            DebugView::new(
                "soft_shadow_map",
                &final_front.texture,
                DebugLegend::value("visibility stored in the soft shadow map"),
            ),
        ];
        if let Some(back) = &res.occluder_back {
            views.push(DebugView::new(
                "occluder_map_back",
                &back.texture,
                DebugLegend::Depth,
            ));
        }
        views
    }
}
