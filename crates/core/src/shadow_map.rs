//! Depth maps of the shadow casters seen from points on the light plane, and the uniform that
//! lets shaders look them up (`shaders/common/shadow_view.wgsl`). Used by `hard`, `pcss` and the
//! accumulated reference (one map per light sample).

use encase::ShaderType;
use glam::{Mat4, Vec2, Vec3, Vec4};

use crate::{
    frame::{uniform_entry, Frame},
    light::{AreaLight, SlopeFrustum},
    material_gpu::MaterialGpu,
    pass::{FullscreenPass, Pass, PassBuilder, PassGroup, Slot},
    scene_gpu::{IndexList, SceneGpu, Vertex},
    shader,
    shader::ShaderSpec,
    uniform::{uniform_bytes, zeroed_uniform_buffer},
    Gpu, GpuError,
};

/// Format of every shadow map.
pub const SHADOW_DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A shadow map's view as shaders look it up (`ShadowView` in
/// `shaders/common/shadow_view.wgsl`).
#[derive(Clone, Copy, Debug, ShaderType)]
pub struct ShadowViewUniform {
    /// World to the map's clip space.
    pub light_view_proj: Mat4,
    /// The slope window: s_min, s_max, t_min, t_max.
    pub window: Vec4,
    /// Eye (x, y) on the light plane, near and far depth.
    pub eye_near_far: Vec4,
    /// Map edge in texels, its inverse, and two unused values.
    pub size: Vec4,
}

/// The uniform of one depth pass (`DepthView` in `shaders/core/depth.wgsl`), one per 256-byte
/// slot of [`DepthMapRenderer`].
#[derive(Clone, Copy, Debug, ShaderType)]
pub struct DepthView {
    /// World to the map's clip space ([`ShadowViewUniform::light_view_proj`]).
    pub light_view_proj: Mat4,
}

impl ShadowViewUniform {
    /// Every value zero: a slot no map has been drawn into yet.
    pub const ZERO: Self = Self {
        light_view_proj: Mat4::ZERO,
        window: Vec4::ZERO,
        eye_near_far: Vec4::ZERO,
        size: Vec4::ZERO,
    };

    /// The view of a `map_size`² map through `frustum`.
    pub fn new(light: &AreaLight, frustum: &SlopeFrustum, map_size: u32) -> Self {
        let m = frustum.projection() * light.view();
        let n = map_size as f32;
        Self {
            light_view_proj: m,
            window: Vec4::new(frustum.s_min, frustum.s_max, frustum.t_min, frustum.t_max),
            eye_near_far: Vec4::new(frustum.eye.x, frustum.eye.y, frustum.near, frustum.far),
            size: Vec4::new(n, n, 1.0 / n, 1.0 / n),
        }
    }
}

/// The tightest square slope window from `eye` (light-space, on the light plane) over the casters,
/// or `None` when no caster lies in front of the light (then every receiver is lit). For soft
/// techniques, which need every caster (see [`SlopeFrustum::fit_casters`]).
pub fn fit_caster_view(scene: &SceneGpu, light: &AreaLight, eye: Vec2) -> Option<SlopeFrustum> {
    let bounds = scene.light_bounds(light);
    let casters: Vec<Vec3> = bounds.casters?.corners().to_vec();
    let receivers: Vec<Vec3> = bounds
        .receivers
        .map(|r| r.corners().to_vec())
        .unwrap_or_default();
    SlopeFrustum::fit_casters(eye, &casters, bounds.casters_cross_light_plane, &receivers)
}

/// The window of a hard shadow map from `eye`: the casters clipped to the slopes where receivers
/// are (see [`SlopeFrustum::fit_clipped`]), or `None` when no caster can shadow a receiver
/// through `eye`. Used by `hard` and by every sample of the accumulated reference.
pub fn fit_hard_view(scene: &SceneGpu, light: &AreaLight, eye: Vec2) -> Option<SlopeFrustum> {
    let bounds = scene.light_bounds(light);
    let casters: Vec<Vec3> = bounds.casters?.corners().to_vec();
    let receivers: Vec<Vec3> = bounds.receivers?.corners().to_vec();
    SlopeFrustum::fit_clipped(eye, &casters, bounds.casters_cross_light_plane, &receivers)
}

/// Uniform stride for dynamic offsets (the WebGPU minimum alignment).
const SLOT: u64 = 256;

/// What a light-space depth pass draws and keeps: every technique's caster rasterisation goes
/// through [`DepthMapRenderer`] with one of these, so a change to how casters are drawn is made
/// once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CasterDraw {
    /// The casters' nearest depth (cleared to 1, `Less`): every shadow map.
    Nearest,
    /// The casters' farthest depth (cleared to 0, `Greater`): SSM's back occluder map (Atty et
    /// al. 2006, section 3.5).
    Farthest,
    /// The nearest depth of the receivers that are not casters (cleared to 1, `Less`): SSM's
    /// receiver map (section 3.1).
    ReceiversOnly,
}

impl CasterDraw {
    fn index(self) -> usize {
        self as usize
    }

    fn clear(self) -> f32 {
        match self {
            CasterDraw::Farthest => 0.0,
            CasterDraw::Nearest | CasterDraw::ReceiversOnly => 1.0,
        }
    }
}

/// Renders caster depth into any number of `Depth32Float` views in one call: the one light-space
/// depth pass of the workspace (`shaders/core/depth.wgsl`), one view matrix per slot.
pub struct DepthMapRenderer {
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    /// One pipeline per [`CasterDraw`], made on first use.
    pipelines: [std::sync::OnceLock<wgpu::RenderPipeline>; 3],
    /// The peeling pass: its group (the peeled map's `ShadowView`, the previous layer) and
    /// pipeline, made on first use.
    peel: std::sync::OnceLock<(PassGroup, wgpu::RenderPipeline)>,
    /// The alpha-tested variants (`ALPHA_TEST`), made on first use by a scene with a masked
    /// caster: one per [`CasterDraw`] and the peeling one.
    masked: std::sync::OnceLock<MaskedPipelines>,
    layout: wgpu::BindGroupLayout,
    buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    capacity: u32,
}

impl DepthMapRenderer {
    /// Builds the depth pass (`shaders/core/depth.wgsl`); its pipelines are made on first use.
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        let module = shader::create_module(gpu, &shader::CORE_SHADERS[1], &[])?;
        let layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("core/depth"),
                entries: &[uniform_entry(0, wgpu::ShaderStages::VERTEX, true)],
            });
        let pipeline_layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("core/depth"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let (buffer, bind_group) = Self::allocate(gpu, &layout, 16);
        Ok(Self {
            module,
            pipeline_layout,
            pipelines: Default::default(),
            peel: Default::default(),
            masked: Default::default(),
            layout,
            buffer,
            bind_group,
            capacity: 16,
        })
    }

    fn pipeline(&self, device: &wgpu::Device, draw: CasterDraw) -> &wgpu::RenderPipeline {
        self.pipelines[draw.index()].get_or_init(|| self.make_pipeline(device, draw))
    }

    fn make_pipeline(&self, device: &wgpu::Device, draw: CasterDraw) -> wgpu::RenderPipeline {
        self.depth_pipeline(device, draw, &self.pipeline_layout, None)
    }

    /// The peeling pipeline: `vs_main` and `fs_peel`, which discards what is not behind the
    /// previous layer.
    fn make_peel(&self, gpu: &Gpu) -> (PassGroup, wgpu::RenderPipeline) {
        let stages = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        let group = PassGroup::new(
            gpu,
            "core/depth peel",
            &[Slot::Uniform, Slot::DEPTH],
            stages,
        );
        let layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("core/depth peel"),
                bind_group_layouts: &[Some(&self.layout), Some(group.layout())],
                immediate_size: 0,
            });
        let pipeline =
            self.depth_pipeline(&gpu.device, CasterDraw::Nearest, &layout, Some("fs_peel"));
        (group, pipeline)
    }

    /// The alpha-tested pipelines over the masked module; `None` when it does not compose (a
    /// bug tests/shaders.rs catches).
    fn masked(&self, gpu: &Gpu) -> Option<&MaskedPipelines> {
        if let Some(m) = self.masked.get() {
            return Some(m);
        }
        let module = shader::create_module(
            gpu,
            &shader::CORE_SHADERS[1],
            crate::material_gpu::DEPTH_ALPHA_TEST,
        )
        .map_err(|e| log::error!("the alpha-tested depth pass does not compose: {e}"))
        .ok()?;
        let material = crate::material_gpu::MaterialGpu::layout_of(gpu);
        let peel_group = PassGroup::new(
            gpu,
            "core/depth peel",
            &[Slot::Uniform, Slot::DEPTH],
            wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
        );
        let pipeline_layout = |peel: Option<&wgpu::BindGroupLayout>| {
            gpu.device
                .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("core/depth (alpha test)"),
                    bind_group_layouts: &[Some(&self.layout), peel, Some(&material)],
                    immediate_size: 0,
                })
        };
        let plain = pipeline_layout(None);
        let peeling = pipeline_layout(Some(peel_group.layout()));
        let make = |draw, layout, fragment| {
            self.depth_pipeline_from(&gpu.device, &module, draw, layout, fragment)
        };
        let pipelines = [
            CasterDraw::Nearest,
            CasterDraw::Farthest,
            CasterDraw::ReceiversOnly,
        ]
        .map(|draw| make(draw, &plain, "fs_masked"));
        let peel = make(CasterDraw::Nearest, &peeling, "fs_peel_masked");
        Some(self.masked.get_or_init(|| MaskedPipelines {
            pipelines,
            peel_group,
            peel,
        }))
    }

    fn depth_pipeline(
        &self,
        device: &wgpu::Device,
        draw: CasterDraw,
        layout: &wgpu::PipelineLayout,
        fragment: Option<&str>,
    ) -> wgpu::RenderPipeline {
        let (entry, vertex, compare) = match draw {
            CasterDraw::Nearest => (
                "vs_main",
                Vertex::position_layout(),
                wgpu::CompareFunction::Less,
            ),
            CasterDraw::Farthest => (
                "vs_main",
                Vertex::position_layout(),
                wgpu::CompareFunction::Greater,
            ),
            CasterDraw::ReceiversOnly => (
                "vs_receiver",
                Vertex::position_and_flags_layout(),
                wgpu::CompareFunction::Less,
            ),
        };
        let buffers = [Some(vertex)];
        let vertex = wgpu::VertexState {
            module: &self.module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            buffers: &buffers,
        };
        let fragment = fragment.map(|entry| wgpu::FragmentState {
            module: &self.module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            targets: &[],
        });
        depth_pipeline_descriptor(device, layout, vertex, fragment, compare)
    }

    /// A pipeline of the alpha-tested module: `vs_masked` (or `vs_receiver_masked`) with the
    /// material vertex buffer in slot 1, and `fragment`.
    fn depth_pipeline_from(
        &self,
        device: &wgpu::Device,
        module: &wgpu::ShaderModule,
        draw: CasterDraw,
        layout: &wgpu::PipelineLayout,
        fragment: &str,
    ) -> wgpu::RenderPipeline {
        let (entry, vertex, compare) = match draw {
            CasterDraw::Nearest => (
                "vs_masked",
                Vertex::position_layout(),
                wgpu::CompareFunction::Less,
            ),
            CasterDraw::Farthest => (
                "vs_masked",
                Vertex::position_layout(),
                wgpu::CompareFunction::Greater,
            ),
            CasterDraw::ReceiversOnly => (
                "vs_receiver_masked",
                Vertex::position_and_flags_layout(),
                wgpu::CompareFunction::Less,
            ),
        };
        let buffers = [
            Some(vertex),
            Some(crate::material_gpu::MaterialVertex::layout()),
        ];
        let vertex = wgpu::VertexState {
            module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            buffers: &buffers,
        };
        let fragment = Some(wgpu::FragmentState {
            module,
            entry_point: Some(fragment),
            compilation_options: Default::default(),
            targets: &[],
        });
        depth_pipeline_descriptor(device, layout, vertex, fragment, compare)
    }
}

/// The alpha-tested pipelines of [`DepthMapRenderer`].
struct MaskedPipelines {
    /// One per [`CasterDraw`].
    pipelines: [wgpu::RenderPipeline; 3],
    peel_group: PassGroup,
    peel: wgpu::RenderPipeline,
}

/// A depth-only pipeline: both faces, depth written with `compare`.
fn depth_pipeline_descriptor(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    vertex: wgpu::VertexState<'_>,
    fragment: Option<wgpu::FragmentState<'_>>,
    compare: wgpu::CompareFunction,
) -> wgpu::RenderPipeline {
    {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("core/depth"),
            layout: Some(layout),
            vertex,
            primitive: wgpu::PrimitiveState {
                // Both faces: zero-thickness occluders must cast from either side, and the
                // nearest / farthest surface is chosen by the depth test alone.
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: SHADOW_DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(compare),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment,
            multiview_mask: None,
            cache: None,
        })
    }
}

impl DepthMapRenderer {
    fn allocate(
        gpu: &Gpu,
        layout: &wgpu::BindGroupLayout,
        capacity: u32,
    ) -> (wgpu::Buffer, wgpu::BindGroup) {
        let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("core/depth views"),
            size: SLOT * capacity as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("core/depth views"),
            layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &buffer,
                    offset: 0,
                    size: Some(DepthView::min_size()),
                }),
            }],
        });
        (buffer, bind_group)
    }

    /// Writes the view matrices of all maps of this frame. Call once per frame before recording
    /// (queue writes land before the frame's command buffer runs).
    pub fn set_views(&mut self, gpu: &Gpu, views: &[ShadowViewUniform]) {
        let needed = views.len().max(1) as u32;
        if needed > self.capacity {
            let capacity = needed.next_power_of_two();
            let (buffer, bind_group) = Self::allocate(gpu, &self.layout, capacity);
            self.buffer = buffer;
            self.bind_group = bind_group;
            self.capacity = capacity;
        }
        let mut bytes = vec![0u8; SLOT as usize * views.len()];
        for (k, v) in views.iter().enumerate() {
            let view = uniform_bytes(&DepthView {
                light_view_proj: v.light_view_proj,
            });
            let at = k * SLOT as usize;
            bytes[at..at + view.len()].copy_from_slice(&view);
        }
        if !bytes.is_empty() {
            gpu.queue.write_buffer(&self.buffer, 0, &bytes);
        }
    }

    /// Records one depth pass of the casters into `target` using view slot `slot`.
    pub fn record(
        &self,
        frame: &mut Frame<'_>,
        label: &str,
        scene: &SceneGpu,
        slot: u32,
        target: &wgpu::TextureView,
    ) {
        self.record_list(frame, label, scene, scene.casters.as_ref(), slot, target);
    }

    /// Like [`Self::record`] for one index list of `scene` (e.g. `static_casters` for a
    /// precompute, `dynamic_casters` beside it); `None` clears `target` to the far plane.
    pub fn record_list(
        &self,
        frame: &mut Frame<'_>,
        label: &str,
        scene: &SceneGpu,
        list: Option<&IndexList>,
        slot: u32,
        target: &wgpu::TextureView,
    ) {
        self.record_draw(frame, label, scene, list, CasterDraw::Nearest, slot, target);
    }

    /// One depth pass of `draw` over `list` (the casters, or the receivers for
    /// [`CasterDraw::ReceiversOnly`]) into `target` through view slot `slot`.
    #[allow(clippy::too_many_arguments)]
    pub fn record_draw(
        &self,
        frame: &mut Frame<'_>,
        label: &str,
        scene: &SceneGpu,
        list: Option<&IndexList>,
        draw: CasterDraw,
        slot: u32,
        target: &wgpu::TextureView,
    ) {
        // A masked caster (or, for the receiver map, a masked receiver) takes the alpha-tested
        // variant for the masked triangles; every other scene the plain pipeline, as before
        // materials existed.
        let masked = scene.materials.as_ref().filter(|m| match draw {
            CasterDraw::ReceiversOnly => m.masked,
            _ => m.masked_casters,
        });
        let plain = DepthDraw {
            pipeline: self.pipeline(&frame.gpu.device, draw),
            peel_group: None,
            material: None,
        };
        let variant = masked.and_then(|m| Some((self.masked(frame.gpu)?, m)));
        let alpha_tested = variant.map(|(pipelines, m)| DepthDraw {
            pipeline: &pipelines.pipelines[draw.index()],
            peel_group: None,
            material: Some(m),
        });
        let draws = depth_draws(list, plain, alpha_tested);
        self.record_pass(frame, label, scene, &draws, (slot, draw.clear()), target);
    }

    /// One depth-peeling pass (Schwarz & Stamminger 2007, section 3.2) of the casters into
    /// `target` through view slot `slot`: the nearest surface behind `previous`, a map drawn
    /// through the same view, whose `ShadowView` is `peel_view`.
    #[allow(clippy::too_many_arguments)]
    pub fn record_peel(
        &self,
        frame: &mut Frame<'_>,
        label: &str,
        scene: &SceneGpu,
        slot: u32,
        peel_view: &wgpu::Buffer,
        previous: &wgpu::TextureView,
        target: &wgpu::TextureView,
    ) {
        let (group, pipeline) = self.peel.get_or_init(|| self.make_peel(frame.gpu));
        let plain_group = group.bind(frame.gpu, &[peel_view.into(), previous.into()]);
        let plain = DepthDraw {
            pipeline,
            peel_group: Some(&plain_group),
            material: None,
        };
        let masked = scene.materials.as_ref().filter(|m| m.masked_casters);
        let variant = masked.and_then(|m| Some((self.masked(frame.gpu)?, m)));
        let masked_group = variant.map(|(p, _)| {
            p.peel_group
                .bind(frame.gpu, &[peel_view.into(), previous.into()])
        });
        let alpha_tested = variant
            .zip(masked_group.as_ref())
            .map(|((p, m), group)| DepthDraw {
                pipeline: &p.peel,
                peel_group: Some(group),
                material: Some(m),
            });
        let draws = depth_draws(scene.casters.as_ref(), plain, alpha_tested);
        let clear = CasterDraw::Nearest.clear();
        self.record_pass(frame, label, scene, &draws, (slot, clear), target);
    }

    /// Records one depth pass into `target` cleared to the `(slot, clear)` pair's depth: each
    /// of `draws` through view slot `slot`, with its peeling group as group 1 and, for the
    /// alpha-tested pipelines, the material group as group 2 and its vertices in slot 1. No
    /// draw (no casters) leaves `target` cleared.
    fn record_pass(
        &self,
        frame: &mut Frame<'_>,
        label: &str,
        scene: &SceneGpu,
        draws: &[(&IndexList, DepthDraw<'_>)],
        (slot, clear): (u32, f32),
        target: &wgpu::TextureView,
    ) {
        let desc = wgpu::RenderPassDescriptor {
            label: None,
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: target,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(clear),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        };
        frame.render_pass(label, desc, |pass| {
            for (list, draw) in draws {
                pass.set_pipeline(draw.pipeline);
                pass.set_bind_group(0, &self.bind_group, &[slot * SLOT as u32]);
                if let Some(group) = draw.peel_group {
                    pass.set_bind_group(1, group, &[]);
                }
                if let Some(material) = draw.material {
                    let group = crate::material_gpu::DEPTH_MATERIAL_GROUP;
                    pass.set_bind_group(group, material.group(), &[]);
                    pass.set_vertex_buffer(1, material.vertices.slice(..));
                }
                pass.set_vertex_buffer(0, scene.vertices.slice(..));
                pass.set_index_buffer(list.buffer.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..list.count, 0, 0..1);
            }
        });
    }
}

/// How one part of a depth pass is drawn: its pipeline, the peeling group (group 1) and, for
/// the alpha-tested pipelines, the material (group 2, vertex slot 1).
#[derive(Clone, Copy)]
struct DepthDraw<'a> {
    pipeline: &'a wgpu::RenderPipeline,
    peel_group: Option<&'a wgpu::BindGroup>,
    material: Option<&'a MaterialGpu>,
}

/// The draws of one depth pass over `list`: all of it with `plain` when there is no
/// `alpha_tested` variant; else its opaque triangles with `plain` and only the masked ones
/// through the alpha test (a list without a split all through the alpha test).
fn depth_draws<'a>(
    list: Option<&'a IndexList>,
    plain: DepthDraw<'a>,
    alpha_tested: Option<DepthDraw<'a>>,
) -> Vec<(&'a IndexList, DepthDraw<'a>)> {
    let Some(list) = list else {
        return Vec::new();
    };
    match (alpha_tested, list.alpha_split.as_deref()) {
        (None, _) => vec![(list, plain)],
        (Some(tested), None) => vec![(list, tested)],
        (Some(tested), Some(split)) => [
            (split.opaque.as_ref(), plain),
            (split.masked.as_ref(), tested),
        ]
        .into_iter()
        .filter_map(|(part, draw)| Some((part?, draw)))
        .collect(),
    }
}

/// A square shadow depth texture with `layers` array layers.
pub fn create_depth_maps(gpu: &Gpu, label: &str, size: u32, layers: u32) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: SHADOW_DEPTH_FORMAT,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    })
}

/// A view of one layer (for rendering into it).
pub fn layer_view(texture: &wgpu::Texture, layer: u32) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2),
        base_array_layer: layer,
        array_layer_count: Some(1),
        ..Default::default()
    })
}

/// One shadow map from the light centre, fitted to the casters, with its lookup uniform
/// (`ShadowView`): the shared first pass of `hard` and `pcss`.
pub struct CentreShadowMap {
    depth: DepthMapRenderer,
    map: Option<(u32, wgpu::Texture, wgpu::TextureView)>,
    /// Fit with [`fit_hard_view`] (hard shadows) instead of [`fit_caster_view`].
    clip_to_receivers: bool,
    /// `ShadowView` uniform of the last rendered map.
    pub view_buffer: wgpu::Buffer,
    /// The fit of the map kept from an earlier frame (`Some(None)`: no casters), while the
    /// light, the casters and the size stand still.
    kept: Option<(u32, Option<SlopeFrustum>)>,
    /// The last `render` drew the map (rather than keeping the earlier one).
    rebuilt: bool,
}

impl CentreShadowMap {
    /// The renderer of the map; the texture is made by the first render.
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        Ok(Self {
            depth: DepthMapRenderer::new(gpu)?,
            map: None,
            clip_to_receivers: false,
            view_buffer: zeroed_uniform_buffer::<ShadowViewUniform>(gpu, "centre shadow view"),
            kept: None,
            rebuilt: false,
        })
    }

    /// Fits the map to the receivers' slopes too ([`fit_hard_view`]): for techniques that only
    /// look up the map at each receiver's own slope (hard shadows).
    pub fn clipped_to_receivers(mut self) -> Self {
        self.clip_to_receivers = true;
        self
    }

    /// Renders the casters into a `size`² map as the pass `label` and returns the window it
    /// used. Returns `None` (and renders nothing) when no caster is in front of the light.
    /// Keeps the map of an earlier frame, recording nothing, while `inputs.changes` says the
    /// light, the casters and the technique's parameters stand still and `size` is the same;
    /// [`CentreShadowMap::rebuilt`] says which happened.
    pub fn render(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &crate::ShadowInputs<'_>,
        size: u32,
        label: &str,
    ) -> Option<SlopeFrustum> {
        if let Some((kept_size, frustum)) = self.kept {
            if kept_size == size && !inputs.changes.light_space() {
                self.rebuilt = false;
                return frustum;
            }
        }
        self.rebuilt = true;
        let fit = if self.clip_to_receivers {
            fit_hard_view
        } else {
            fit_caster_view
        };
        self.kept = Some((size, None));
        let frustum = fit(inputs.scene, inputs.light, Vec2::ZERO)?;
        self.kept = Some((size, Some(frustum)));
        let gpu = frame.gpu;
        if self.map.as_ref().map(|m| m.0) != Some(size) {
            let texture = create_depth_maps(gpu, label, size, 1);
            let view = texture.create_view(&Default::default());
            self.map = Some((size, texture, view));
        }
        let view = ShadowViewUniform::new(inputs.light, &frustum, size);
        self.depth.set_views(gpu, &[view]);
        gpu.queue
            .write_buffer(&self.view_buffer, 0, &uniform_bytes(&view));
        let (_, _, map_view) = self.map.as_ref().expect("created above");
        self.depth.record(frame, label, inputs.scene, 0, map_view);
        Some(frustum)
    }

    /// Peels the next caster layer behind `previous` (a map drawn through this map's view:
    /// itself, or the last layer peeled) into `target` (Schwarz & Stamminger 2007, section 3.2).
    pub fn record_peel(
        &self,
        frame: &mut Frame<'_>,
        label: &str,
        scene: &SceneGpu,
        previous: &wgpu::TextureView,
        target: &wgpu::TextureView,
    ) {
        let view = &self.view_buffer;
        (self.depth).record_peel(frame, label, scene, 0, view, previous, target);
    }

    /// The last [`CentreShadowMap::render`] drew the map (it did not keep an earlier one).
    pub fn rebuilt(&self) -> bool {
        self.rebuilt
    }

    /// Drops the kept map: the next `render` draws it whatever the changes say.
    pub fn invalidate(&mut self) {
        self.kept = None;
    }

    /// Declares the usual pass that reads this map (`hard.wgsl`, `pcss.wgsl`, ...): group 1 is
    /// binding 0 = its `ShadowView` uniform, 1 = the `texture_depth_2d`, 2 = the technique's own
    /// parameter uniform. Run it with [`CentreShadowMap::draw_lookup`].
    pub fn lookup_pass<'a>(gpu: &'a Gpu, label: &str, spec: &'a ShaderSpec) -> PassBuilder<'a> {
        Pass::new(gpu, label, spec)
            .after_frame_group()
            .uniform()
            .texture(Slot::DEPTH)
            .uniform()
    }

    /// Draws `pass` (from [`CentreShadowMap::lookup_pass`]) over the last rendered map with
    /// `params` into `target`, timed as `label`; `clear` as [`crate::pass::PassRun::draw`].
    /// Draws nothing before the first map.
    #[allow(clippy::too_many_arguments)]
    pub fn draw_lookup(
        &self,
        frame: &mut Frame<'_>,
        pass: &FullscreenPass,
        label: &str,
        frame_group: &wgpu::BindGroup,
        params: &wgpu::Buffer,
        target: &wgpu::TextureView,
        clear: Option<f64>,
    ) {
        let Some(map) = self.map_view() else {
            return;
        };
        pass.run(frame)
            .named(label)
            .frame_group(frame_group)
            .read(&self.view_buffer)
            .read(map)
            .read(params)
            .draw(target, clear);
    }

    /// The depth view of the last rendered map.
    pub fn map_view(&self) -> Option<&wgpu::TextureView> {
        self.map.as_ref().map(|m| &m.2)
    }

    /// The map drawn by the last render, if any.
    pub fn map_texture(&self) -> Option<&wgpu::Texture> {
        self.map.as_ref().map(|m| &m.1)
    }

    /// The last map as a debug view (`shadow_map`, Depth32Float), for the viewer.
    pub fn debug_views(&self) -> Vec<crate::DebugView> {
        self.map_texture()
            .map(|texture| crate::DebugView::new("shadow_map", texture, crate::DebugLegend::Depth))
            .into_iter()
            .collect()
    }
}
