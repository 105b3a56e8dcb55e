//! A fullscreen-triangle pipeline with the core frame bind group at group 0 and a technique's own
//! bind group at group 1: the shape of every "per-pixel lookup" pass (hard, PCSS, reference, ...).

use crate::{
    shader::DefValue, shader::ShaderSpec, visibility::VISIBILITY_FORMAT, Frame, Gpu, GpuError,
};

/// The fullscreen triangle of `module` (`vs_main`, `fs_main`; no vertex buffers, no depth) drawn
/// into `targets` with `layout`: every fullscreen pass of the core, and the viewer's display
/// passes (their own bind groups, no frame group), build their pipeline here.
pub fn render_pipeline(
    gpu: &Gpu,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    targets: &[Option<wgpu::ColorTargetState>],
) -> wgpu::RenderPipeline {
    render_pipeline_with(gpu, label, layout, module, targets, None)
}

/// [`render_pipeline`] with a depth-stencil state.
fn render_pipeline_with(
    gpu: &Gpu,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    targets: &[Option<wgpu::ColorTargetState>],
    depth_stencil: Option<wgpu::DepthStencilState>,
) -> wgpu::RenderPipeline {
    gpu.device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets,
            }),
            multiview_mask: None,
            cache: None,
        })
}

/// The stencil format of [`FullscreenPipeline::with_stencil`].
pub const STENCIL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Stencil8;

/// A fullscreen-triangle render pipeline: group 0 the frame, group 1 the pass's own.
pub struct FullscreenPipeline {
    /// The pipeline.
    pub pipeline: wgpu::RenderPipeline,
}

impl FullscreenPipeline {
    /// `vs_main` / `fs_main` of `spec`, writing one `R32Float` target with optional blending.
    pub fn new(
        gpu: &Gpu,
        label: &str,
        spec: &ShaderSpec,
        defs: &[(&str, DefValue)],
        group1: &wgpu::BindGroupLayout,
        blend: Option<wgpu::BlendState>,
    ) -> Result<Self, GpuError> {
        Self::with_format(gpu, label, spec, defs, group1, VISIBILITY_FORMAT, blend)
    }

    /// As [`FullscreenPipeline::new`], writing one target of `format`.
    pub fn with_format(
        gpu: &Gpu,
        label: &str,
        spec: &ShaderSpec,
        defs: &[(&str, DefValue)],
        group1: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
        blend: Option<wgpu::BlendState>,
    ) -> Result<Self, GpuError> {
        Self::build(gpu, label, spec, defs, group1, format, blend, None)
    }

    /// As [`FullscreenPipeline::new`], with a `Stencil8` attachment tested and written by
    /// `stencil` (both faces): a pass can mark pixels for a later draw that runs only on them.
    pub fn with_stencil(
        gpu: &Gpu,
        label: &str,
        spec: &ShaderSpec,
        defs: &[(&str, DefValue)],
        group1: &wgpu::BindGroupLayout,
        stencil: wgpu::StencilFaceState,
    ) -> Result<Self, GpuError> {
        let depth_stencil = wgpu::DepthStencilState {
            format: STENCIL_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(wgpu::CompareFunction::Always),
            stencil: wgpu::StencilState {
                front: stencil,
                back: stencil,
                read_mask: 0xff,
                write_mask: 0xff,
            },
            bias: Default::default(),
        };
        let format = VISIBILITY_FORMAT;
        Self::build(
            gpu,
            label,
            spec,
            defs,
            group1,
            format,
            None,
            Some(depth_stencil),
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        gpu: &Gpu,
        label: &str,
        spec: &ShaderSpec,
        defs: &[(&str, DefValue)],
        group1: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
        blend: Option<wgpu::BlendState>,
        depth_stencil: Option<wgpu::DepthStencilState>,
    ) -> Result<Self, GpuError> {
        let module = crate::shader::create_module(gpu, spec, defs)?;
        let layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(&gpu.layouts.frame), Some(group1)],
                immediate_size: 0,
            });
        let target = wgpu::ColorTargetState {
            format,
            blend,
            write_mask: wgpu::ColorWrites::ALL,
        };
        let pipeline =
            render_pipeline_with(gpu, label, &layout, &module, &[Some(target)], depth_stencil);
        Ok(Self { pipeline })
    }

    /// Draws the fullscreen triangle into `target`; `clear` = `Some(v)` clears to `v` first,
    /// `None` keeps (loads) the current contents (for accumulation).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        frame: &mut Frame<'_>,
        label: &str,
        frame_bind_group: &wgpu::BindGroup,
        group1: &wgpu::BindGroup,
        dynamic_offsets: &[u32],
        target: &wgpu::TextureView,
        clear: Option<f64>,
    ) {
        let load = match clear {
            Some(v) => wgpu::LoadOp::Clear(wgpu::Color {
                r: v,
                g: 0.0,
                b: 0.0,
                a: 0.0,
            }),
            None => wgpu::LoadOp::Load,
        };
        frame.render_pass(
            label,
            wgpu::RenderPassDescriptor {
                label: None,
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load,
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            },
            |pass| {
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, frame_bind_group, &[]);
                pass.set_bind_group(1, group1, dynamic_offsets);
                pass.draw(0..3, 0..1);
            },
        );
    }
}

/// Layout entry for a `texture_depth_2d` (or array) read with `textureLoad`.
pub fn depth_texture_entry(binding: u32, array: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Depth,
            view_dimension: if array {
                wgpu::TextureViewDimension::D2Array
            } else {
                wgpu::TextureViewDimension::D2
            },
            multisampled: false,
        },
        count: None,
    }
}
