//! G-buffer: what the camera sees, per pixel. Techniques read position and normal through
//! bind group 0 (`shaders/common/frame.wgsl`).

use crate::{
    frame::Frame,
    scene_gpu::{SceneGpu, Vertex},
    shader, Gpu,
};

/// Format of [`GBuffer::position`].
pub const POSITION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Format of [`GBuffer::normal`].
pub const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Format of [`GBuffer::albedo`].
pub const ALBEDO_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Format of [`GBuffer::depth`].
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The workbench's G-buffer: what the camera sees, per pixel.
pub struct GBuffer {
    /// xyz world position, w = 1 where geometry was hit.
    pub position: wgpu::Texture,
    /// xyz normal (facing the camera), w = 1 for shadow receivers.
    pub normal: wgpu::Texture,
    /// rgb albedo, a = 1 where geometry was hit.
    pub albedo: wgpu::Texture,
    /// Depth of the G-buffer pass.
    pub depth: wgpu::Texture,
    /// View of [`GBuffer::position`].
    pub position_view: wgpu::TextureView,
    /// View of [`GBuffer::normal`].
    pub normal_view: wgpu::TextureView,
    /// View of [`GBuffer::albedo`].
    pub albedo_view: wgpu::TextureView,
    /// View of [`GBuffer::depth`].
    pub depth_view: wgpu::TextureView,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// A 2D texture of one mip level and one layer.
pub fn create_texture(
    gpu: &Gpu,
    label: &str,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

impl GBuffer {
    /// The G-buffer textures for `width` x `height` frames.
    pub fn new(gpu: &Gpu, width: u32, height: u32) -> Self {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        let position = create_texture(
            gpu,
            "gbuffer position",
            width,
            height,
            POSITION_FORMAT,
            usage,
        );
        let normal = create_texture(gpu, "gbuffer normal", width, height, NORMAL_FORMAT, usage);
        let albedo = create_texture(gpu, "gbuffer albedo", width, height, ALBEDO_FORMAT, usage);
        let depth = create_texture(gpu, "gbuffer depth", width, height, DEPTH_FORMAT, usage);
        Self {
            position_view: position.create_view(&Default::default()),
            normal_view: normal.create_view(&Default::default()),
            albedo_view: albedo.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            position,
            normal,
            albedo,
            depth,
            width,
            height,
        }
    }
}

/// The G-buffer pass.
pub struct GBufferPass {
    pipeline: wgpu::RenderPipeline,
    /// The `MATERIALS` variant (textured albedo, alpha test), made on first use by a scene with
    /// materials on the device ([`SceneGpu::materials`]).
    materials: std::sync::OnceLock<Option<wgpu::RenderPipeline>>,
}

/// The G-buffer's material group (group 0 is the frame uniform).
pub const GBUFFER_MATERIAL_GROUP: u32 = 1;

/// The G-buffer's material permutation (`shaders/core/gbuffer.wgsl`).
pub const GBUFFER_MATERIALS: crate::shader::Permutation = &[
    ("MATERIALS", crate::shader::DefValue::Bool(true)),
    (
        "MATERIAL_GROUP",
        crate::shader::DefValue::UInt(GBUFFER_MATERIAL_GROUP),
    ),
];

impl GBufferPass {
    /// Builds the pipeline (`shaders/core/gbuffer.wgsl`).
    pub fn new(gpu: &Gpu) -> Result<Self, crate::GpuError> {
        let module = shader::create_module(gpu, &shader::CORE_SHADERS[0], &[])?;
        let layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("core/gbuffer"),
                bind_group_layouts: &[Some(&gpu.layouts.frame_uniform)],
                immediate_size: 0,
            });
        let pipeline = Self::pipeline(gpu, &module, &layout, false);
        Ok(Self {
            pipeline,
            materials: Default::default(),
        })
    }

    /// The `MATERIALS` pipeline; `None` (logged) if it does not compose, a bug the shader
    /// tests catch.
    fn material_pipeline(&self, gpu: &Gpu) -> Option<&wgpu::RenderPipeline> {
        self.materials
            .get_or_init(|| {
                let module =
                    shader::create_module(gpu, &shader::CORE_SHADERS[0], GBUFFER_MATERIALS)
                        .map_err(|e| log::error!("the G-buffer's material variant: {e}"))
                        .ok()?;
                let material = crate::material_gpu::MaterialGpu::layout_of(gpu);
                let layout = gpu
                    .device
                    .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: Some("core/gbuffer (materials)"),
                        bind_group_layouts: &[Some(&gpu.layouts.frame_uniform), Some(&material)],
                        immediate_size: 0,
                    });
                Some(Self::pipeline(gpu, &module, &layout, true))
            })
            .as_ref()
    }

    /// The pipeline of `module`: `vs_main` / `fs_main`, or with `materials` `vs_material` /
    /// `fs_material` and the material vertices in slot 1.
    fn pipeline(
        gpu: &Gpu,
        module: &wgpu::ShaderModule,
        layout: &wgpu::PipelineLayout,
        materials: bool,
    ) -> wgpu::RenderPipeline {
        let (vs, fs) = if materials {
            ("vs_material", "fs_material")
        } else {
            ("vs_main", "fs_main")
        };
        let all_buffers = [
            Some(Vertex::layout()),
            Some(crate::material_gpu::MaterialVertex::layout()),
        ];
        let buffers = if materials {
            &all_buffers[..]
        } else {
            &all_buffers[..1]
        };
        let target = |format| {
            Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })
        };
        gpu.device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("core/gbuffer"),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState {
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[
                        target(POSITION_FORMAT),
                        target(NORMAL_FORMAT),
                        target(ALBEDO_FORMAT),
                    ],
                }),
                multiview_mask: None,
                cache: None,
            })
    }

    /// Records the pass (`gbuffer`) drawing every instance of `scene` into `gbuffer`.
    pub fn record(
        &self,
        frame: &mut Frame<'_>,
        gbuffer: &GBuffer,
        uniform_bind_group: &wgpu::BindGroup,
        scene: &SceneGpu,
    ) {
        let frame_gpu = frame.gpu;
        let clear = |view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })
        };
        frame.render_pass(
            "gbuffer",
            wgpu::RenderPassDescriptor {
                label: None,
                color_attachments: &[
                    clear(&gbuffer.position_view),
                    clear(&gbuffer.normal_view),
                    clear(&gbuffer.albedo_view),
                ],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &gbuffer.depth_view,
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
                pass.set_bind_group(0, uniform_bind_group, &[]);
                pass.set_pipeline(&self.pipeline);
                let material = scene.materials.as_ref().and_then(|m| {
                    let pipeline = self.material_pipeline(frame_gpu)?;
                    Some((m, pipeline, scene.all_by_material.as_ref()?))
                });
                let Some((m, pipeline, split)) = material else {
                    scene.draw_all(pass);
                    return;
                };
                // Only the triangles with a material pay for the material pipeline (a
                // million-triangle plain mesh beside one textured grate drew through it).
                scene.draw_list(pass, split.plain.as_ref());
                pass.set_pipeline(pipeline);
                pass.set_bind_group(GBUFFER_MATERIAL_GROUP, m.group(), &[]);
                pass.set_vertex_buffer(1, m.vertices.slice(..));
                scene.draw_list(pass, split.with_material.as_ref());
            },
        );
    }
}
