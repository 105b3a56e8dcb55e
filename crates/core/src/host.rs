//! Techniques inside someone else's wgpu renderer.
//!
//! A host renderer (Bevy, rend3, hand-written) has its own device, G-buffer and meshes. With
//! [`crate::Gpu::from_host`] the techniques run on its device; this module takes the rest:
//!
//! - the casters as the host's vertex and index buffers ([`HostMesh`], read once into a
//!   [`SceneGpu`] by [`SceneGpu::from_host`]),
//! - the receiver surface as the host's textures ([`HostSurface`]: world position, or depth with
//!   the inverse view-projection; a normal; an optional receiver mask),
//! - the camera as a view-projection matrix and an eye ([`HostView`]), the light as plain data
//!   ([`crate::AreaLight`]),
//!
//! and [`HostRenderer::record`] writes the visibility into the host's texture ([`HostOutput`]),
//! recording into the host's command encoder. Internally it converts the host surface into the
//! core's surface format (one fullscreen pass, `host/surface`) and runs the same
//! [`crate::ShadowStage`] as the workbench's [`crate::Renderer`].

use std::collections::HashMap;

use glam::{Mat4, Vec3, Vec4};
use wgpu::util::DeviceExt;
use wgpu_profiler::{GpuProfiler, GpuProfilerSettings};

use crate::{
    error::{GpuError, RenderError},
    frame::{Frame, FrameUniforms},
    gbuffer::{create_texture, NORMAL_FORMAT, POSITION_FORMAT},
    readback,
    scene::{Instance, Mesh, Scene},
    scene_gpu::SceneGpu,
    shader::{self, DefValue},
    stage::ShadowStage,
    technique::ShadowTechnique,
    uniform::{uniform_bytes, uniform_size},
    visibility::{VisibilityBuffer, VISIBILITY_FORMAT},
    AreaLight, Gpu,
};

/// One mesh in a host's buffers: positions read from `vertices` at `position_offset` within each
/// `vertex_stride`-byte vertex (three little-endian `f32`), triangles from `indices`.
///
/// Both buffers need `wgpu::BufferUsages::COPY_SRC`: [`SceneGpu::from_host`] reads them once
/// (positions are needed on the CPU to fit shadow-map windows to the casters) and keeps a packed
/// copy that the techniques' depth passes draw.
#[derive(Clone, Copy, Debug)]
pub struct HostMesh<'a> {
    /// The vertex buffer.
    pub vertices: &'a wgpu::Buffer,
    /// Bytes from one vertex to the next.
    pub vertex_stride: u64,
    /// Byte offset of the position (`[f32; 3]`) within a vertex.
    pub position_offset: u64,
    /// Vertices in the buffer (from its start).
    pub vertex_count: u32,
    /// The index buffer (triangle list).
    pub indices: &'a wgpu::Buffer,
    /// `Uint16` or `Uint32`.
    pub index_format: wgpu::IndexFormat,
    /// Indices to read (from the buffer's start): three per triangle.
    pub index_count: u32,
    /// Object to world.
    pub transform: Mat4,
    /// The mesh moves from frame to frame: precomputes over the static casters (PDSM) leave it
    /// out, and moving it does not void them.
    pub dynamic: bool,
}

/// The host's geometry as the techniques see it.
#[derive(Clone, Copy, Debug, Default)]
pub struct HostGeometry<'a> {
    /// Meshes that cast shadows (drawn into shadow maps).
    pub casters: &'a [HostMesh<'a>],
    /// Meshes that receive shadows. Only their bounds are used: `hard` and the reference clip
    /// their shadow maps to where receivers are; without receivers the maps cover every caster.
    /// Which pixels receive is the surface's business ([`HostSurface::receiver_mask`]).
    pub receivers: &'a [HostMesh<'a>],
}

impl SceneGpu {
    /// Reads a host's caster (and receiver) buffers back to the CPU and uploads a packed copy:
    /// the same [`SceneGpu`] the workbench makes from a scene, so every technique draws and fits
    /// its shadow maps the same way. Costs one readback of the buffers: call it when the
    /// geometry changes, not every frame. `name` labels errors.
    pub fn from_host(gpu: &Gpu, name: &str, geometry: &HostGeometry<'_>) -> Result<Self, GpuError> {
        // Light and camera are not read by the upload.
        let mut scene = Scene {
            materials: Vec::new(),
            textures: Vec::new(),
            name: name.to_string(),
            meshes: Vec::new(),
            instances: Vec::new(),
            light: AreaLight::default(),
            camera: crate::Camera::default(),
        };
        for (meshes, casts) in [(geometry.casters, true), (geometry.receivers, false)] {
            for host in meshes {
                let mesh = read_host_mesh(gpu, host, scene.meshes.len())?;
                scene.meshes.push(mesh);
                scene.instances.push(Instance {
                    casts_shadow: casts,
                    receives_shadow: !casts,
                    dynamic: host.dynamic,
                    ..Instance::new(scene.meshes.len() - 1, host.transform)
                });
            }
        }
        Ok(Self::upload(gpu, &scene))
    }
}

fn read_host_mesh(gpu: &Gpu, host: &HostMesh<'_>, number: usize) -> Result<Mesh, GpuError> {
    if host.vertex_stride < host.position_offset + 12 {
        return Err(GpuError::Readback(format!(
            "host mesh {number}: a position at byte {} does not fit in a {}-byte vertex: give the \
             vertex stride and the position offset in bytes",
            host.position_offset, host.vertex_stride
        )));
    }
    let count = host.vertex_count as u64;
    let bytes = if count == 0 {
        Vec::new()
    } else {
        readback::read_buffer(
            gpu,
            host.vertices,
            0,
            (count - 1) * host.vertex_stride + host.position_offset + 12,
        )?
    };
    let f32_at =
        |at: usize| f32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let positions = (0..count as usize)
        .map(|k| {
            let at = k * host.vertex_stride as usize + host.position_offset as usize;
            Vec3::new(f32_at(at), f32_at(at + 4), f32_at(at + 8))
        })
        .collect();
    let index_size = match host.index_format {
        wgpu::IndexFormat::Uint16 => 2,
        wgpu::IndexFormat::Uint32 => 4,
    };
    let raw = readback::read_buffer(gpu, host.indices, 0, host.index_count as u64 * index_size)?;
    let indices: Vec<u32> = match host.index_format {
        wgpu::IndexFormat::Uint16 => raw
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]) as u32)
            .collect(),
        wgpu::IndexFormat::Uint32 => raw
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect(),
    };
    let mut mesh = Mesh {
        texcoords: Vec::new(),
        name: format!("host mesh {number}"),
        positions,
        normals: Vec::new(),
        indices,
    };
    // Out-of-range or degenerate triangles would draw garbage into shadow maps; drop them as the
    // scene loaders do. Normals are not read by depth passes but the upload expects them.
    mesh.repair();
    mesh.ensure_normals();
    Ok(mesh)
}

/// Where the host's receiver positions come from.
#[derive(Clone, Copy, Debug)]
pub enum SurfacePositions<'a> {
    /// A float colour texture (e.g. `Rgba32Float`) holding the world position in xyz and, in w,
    /// 1 where geometry was drawn and 0 elsewhere (clear it to 0).
    World(&'a wgpu::TextureView),
    /// A `Depth32Float` depth buffer (with `TEXTURE_BINDING`) and the inverse of the
    /// view-projection it was drawn with (clip depth in [0, 1], as wgpu's).
    Depth {
        /// The depth buffer.
        depth: &'a wgpu::TextureView,
        /// Inverse of the host camera's view-projection matrix.
        inverse_view_proj: Mat4,
        /// The depth of pixels where nothing was drawn: 1 for a buffer cleared to 1, 0 with
        /// reversed depth.
        background: f32,
    },
}

/// How the host's normal texture stores normals.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum NormalEncoding {
    /// xyz is the normal itself (float formats).
    #[default]
    Signed,
    /// xyz is `normal * 0.5 + 0.5` (unorm formats such as `Rgba8Unorm`).
    Unorm,
}

/// The host's receiver surface: what its G-buffer pass drew, at the frame's size. Every texture
/// needs `TEXTURE_BINDING`; they are read with `textureLoad` (no sampler, any float format).
#[derive(Clone, Copy, Debug)]
pub struct HostSurface<'a> {
    /// World positions, or depth to reconstruct them from.
    pub positions: SurfacePositions<'a>,
    /// World-space normals (need not face the camera, need not be unit length).
    pub normal: &'a wgpu::TextureView,
    /// How `normal` stores them.
    pub normal_encoding: NormalEncoding,
    /// Pixels with red > 0.5 receive shadows; `None`: every drawn pixel does.
    pub receiver_mask: Option<&'a wgpu::TextureView>,
}

/// The host camera: what its G-buffer pass was drawn with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HostView {
    /// Projection times view (world to clip, clip depth in [0, 1]).
    pub view_proj: Mat4,
    /// Camera position in world space.
    pub eye: Vec3,
}

/// Where the visibility goes.
#[derive(Clone, Copy, Debug)]
pub enum HostOutput<'a> {
    /// An `R32Float` texture of the frame's size with `COPY_DST`: copied into.
    Texture(&'a wgpu::Texture),
    /// A view of a colour texture of the frame's size with `RENDER_ATTACHMENT`, of `format` (any
    /// renderable float or unorm format: `R8Unorm`, `R16Float`, `Rgba16Float`, ...): drawn
    /// into, V in every channel and alpha 1.
    View {
        /// The target view.
        view: &'a wgpu::TextureView,
        /// Its format.
        format: wgpu::TextureFormat,
    },
}

/// Uniforms of `shaders/core/host_surface.wgsl`.
#[derive(encase::ShaderType)]
struct SurfaceUniforms {
    inverse_view_proj: Mat4,
    eye: Vec4,
    mode: Vec4,
}

/// The host surface uniform against its WGSL struct (tests/shaders.rs).
pub(crate) fn uniform_mirror() -> crate::shader::uniform_layout::UniformMirror {
    crate::uniform_mirror!(
        SurfaceUniforms { inverse_view_proj, eye, mode } => "core/host_surface.wgsl", HostSurface
    )
}

/// The conversion pass from a host surface to the core's (`host/surface`).
struct SurfaceConversion {
    layout_world: wgpu::BindGroupLayout,
    layout_depth: wgpu::BindGroupLayout,
    pipeline_world: wgpu::RenderPipeline,
    pipeline_depth: wgpu::RenderPipeline,
    /// Bound when the host gives no receiver mask (the shader then ignores it).
    no_mask: wgpu::TextureView,
}

impl SurfaceConversion {
    fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        let spec = shader::CORE_SHADERS
            .iter()
            .find(|s| s.path == "core/host_surface.wgsl")
            .expect("declared in CORE_SHADERS");
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let float = wgpu::TextureSampleType::Float { filterable: false };
        let layout = |label: &str, positions: wgpu::TextureSampleType| {
            gpu.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(label),
                    entries: &[
                        crate::frame::uniform_entry(0, fragment, false),
                        crate::frame::texture_entry(1, fragment, positions),
                        crate::frame::texture_entry(2, fragment, float),
                        crate::frame::texture_entry(3, fragment, float),
                    ],
                })
        };
        let layout_world = layout("host/surface (world)", float);
        let layout_depth = layout("host/surface (depth)", wgpu::TextureSampleType::Depth);
        let pipeline = |layout: &wgpu::BindGroupLayout, defs: &[(&str, DefValue)]| {
            let module = shader::create_module(gpu, spec, defs)?;
            let pipeline_layout =
                gpu.device
                    .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: Some("host/surface"),
                        bind_group_layouts: &[Some(layout)],
                        immediate_size: 0,
                    });
            let target = |format| {
                Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })
            };
            Ok::<_, GpuError>(crate::fullscreen::render_pipeline(
                gpu,
                "host/surface",
                &pipeline_layout,
                &module,
                &[target(POSITION_FORMAT), target(NORMAL_FORMAT)],
            ))
        };
        let pipeline_world = pipeline(&layout_world, &[])?;
        let pipeline_depth = pipeline(&layout_depth, &[("FROM_DEPTH", DefValue::Bool(true))])?;
        let no_mask = gpu
            .device
            .create_texture_with_data(
                &gpu.queue,
                &wgpu::TextureDescriptor {
                    label: Some("host/surface (no receiver mask)"),
                    size: wgpu::Extent3d {
                        width: 1,
                        height: 1,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::R8Unorm,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                },
                Default::default(),
                &[255],
            )
            .create_view(&Default::default());
        Ok(Self {
            layout_world,
            layout_depth,
            pipeline_world,
            pipeline_depth,
            no_mask,
        })
    }
}

/// Runs techniques on a host renderer's surface, casters and camera, into the host's texture.
/// One per frame size; keep it across frames (techniques keep light-space work between frames
/// as [`crate::FrameChanges`] allows, and the stage remembers each technique's last inputs).
pub struct HostRenderer {
    gpu: Gpu,
    width: u32,
    height: u32,
    /// The host surface in the core's format (what the stage's bind group reads).
    position_view: wgpu::TextureView,
    normal_view: wgpu::TextureView,
    conversion: SurfaceConversion,
    stage: ShadowStage,
    visibility: VisibilityBuffer,
    output_layout: wgpu::BindGroupLayout,
    output_group: wgpu::BindGroup,
    /// `host/output` pipelines by target format, made on first use.
    output_pipelines: HashMap<wgpu::TextureFormat, wgpu::RenderPipeline>,
    /// Passes are not timed here (the host profiles its own frame): timer queries stay off.
    profiler: GpuProfiler,
}

impl HostRenderer {
    /// A renderer for `width` x `height` frames on `gpu` (from [`Gpu::from_host`] or the
    /// workbench's).
    pub fn new(gpu: &Gpu, width: u32, height: u32) -> Result<Self, RenderError> {
        let max = gpu.device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::BadResolution { width, height, max });
        }
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let position = create_texture(gpu, "host/position", width, height, POSITION_FORMAT, usage);
        let normal = create_texture(gpu, "host/normal", width, height, NORMAL_FORMAT, usage);
        let position_view = position.create_view(&Default::default());
        let normal_view = normal.create_view(&Default::default());
        let stage = ShadowStage::new(gpu, &position_view, &normal_view, width, height);
        let visibility = VisibilityBuffer::new(gpu, "host/visibility", width, height);
        let output_layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("host/output"),
                entries: &[crate::frame::texture_entry(
                    0,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Float { filterable: false },
                )],
            });
        let output_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("host/output"),
            layout: &output_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&visibility.view),
            }],
        });
        let profiler = GpuProfiler::new(
            &gpu.device,
            GpuProfilerSettings {
                enable_timer_queries: false,
                enable_debug_groups: false,
                max_num_pending_frames: 4,
            },
        )
        .map_err(|e| GpuError::Profiler(e.to_string()))?;
        Ok(Self {
            gpu: gpu.clone(),
            width,
            height,
            position_view,
            normal_view,
            conversion: SurfaceConversion::new(gpu)?,
            stage,
            visibility,
            output_layout,
            output_group,
            output_pipelines: HashMap::new(),
            profiler,
        })
    }

    /// The frame size.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The visibility of the last frame (`R32Float`), before it was copied to the host's output.
    pub fn visibility(&self) -> &VisibilityBuffer {
        &self.visibility
    }

    /// Records one frame of `technique` into `encoder`: the surface conversion (`host/surface`),
    /// the technique's passes, and the copy into `output` (`host/output`; `None` leaves the
    /// result in [`HostRenderer::visibility`] only). Returns the passes that ran. Submit the
    /// encoder afterwards; techniques that read GPU answers mid-frame (`adaptive`) submit what
    /// the encoder holds at that point and go on in a fresh one.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        casters: &SceneGpu,
        surface: &HostSurface<'_>,
        view: &HostView,
        light: &AreaLight,
        technique: &mut dyn ShadowTechnique,
        output: Option<HostOutput<'_>>,
    ) -> Result<Vec<String>, RenderError> {
        if !(view.view_proj.is_finite() && view.eye.is_finite()) {
            return Err(RenderError::Scene(
                "host view-projection or eye is not finite: give finite numbers".into(),
            ));
        }
        let uniforms =
            FrameUniforms::from_view(view.view_proj, view.eye, light, self.width, self.height);
        let (state, changes) =
            self.stage
                .begin(&self.gpu, casters, light, uniforms, &*technique)?;
        // The stage wrote the uniforms through the queue, which lands before the submission:
        // a second frame recorded into the same encoder would overwrite them. Copying them in
        // encoder order keeps each frame's own (several techniques may share one encoder).
        let staged = self
            .gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("host/frame uniforms"),
                contents: &uniform_bytes(&uniforms),
                usage: wgpu::BufferUsages::COPY_SRC,
            });
        encoder.copy_buffer_to_buffer(
            &staged,
            0,
            self.stage.uniform_buffer(),
            0,
            uniform_size::<FrameUniforms>(),
        );
        let convert = self.surface_bind_group(surface, view)?;
        if let Some(HostOutput::View { format, .. }) = output {
            self.output_pipeline(format)?;
        }
        let mut passes_run = Vec::new();
        let result = {
            let mut frame = Frame::new(&self.gpu, encoder, &self.profiler, &mut passes_run);
            self.surface_pass(&mut frame, surface, &convert);
            let result = self.stage.record(
                &mut frame,
                casters,
                light,
                changes,
                technique,
                &self.visibility,
            );
            if result.is_ok() {
                self.output_pass(&mut frame, output)?;
            }
            result
        };
        // No timer queries: this only closes the profiler's (empty) frame.
        let _ = self.profiler.end_frame();
        while self.profiler.process_finished_frame(1.0).is_some() {}
        result?;
        self.stage.finish(technique.id(), state);
        Ok(passes_run)
    }

    /// The pass `host/surface`: the host's surface converted into the core's format (world
    /// position + hit flag, normal + receiver flag) through the bind group `convert`.
    fn surface_pass(
        &self,
        frame: &mut Frame<'_>,
        surface: &HostSurface<'_>,
        convert: &wgpu::BindGroup,
    ) {
        let pipeline = match surface.positions {
            SurfacePositions::World(_) => &self.conversion.pipeline_world,
            SurfacePositions::Depth { .. } => &self.conversion.pipeline_depth,
        };
        frame.render_pass(
            "host/surface",
            wgpu::RenderPassDescriptor {
                label: None,
                color_attachments: &[cleared(&self.position_view), cleared(&self.normal_view)],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            },
            |pass| {
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, convert, &[]);
                pass.draw(0..3, 0..1);
            },
        );
    }

    /// The pass `host/output`: the visibility copied into the host's `output`, if any.
    fn output_pass(
        &self,
        frame: &mut Frame<'_>,
        output: Option<HostOutput<'_>>,
    ) -> Result<(), RenderError> {
        match output {
            Some(HostOutput::Texture(texture)) => {
                self.check_output(texture)?;
                self.visibility.copy_to(frame.encoder, texture);
                frame.note_pass("host/output");
            }
            Some(HostOutput::View { view, format }) => {
                let pipeline = &self.output_pipelines[&format];
                frame.render_pass(
                    "host/output",
                    wgpu::RenderPassDescriptor {
                        label: None,
                        color_attachments: &[cleared(view)],
                        depth_stencil_attachment: None,
                        timestamp_writes: None,
                        occlusion_query_set: None,
                        multiview_mask: None,
                    },
                    |pass| {
                        pass.set_pipeline(pipeline);
                        pass.set_bind_group(0, &self.output_group, &[]);
                        pass.draw(0..3, 0..1);
                    },
                );
            }
            None => {}
        }
        Ok(())
    }

    /// Runs [`ShadowTechnique::prepare`] (scene-only work, such as the PDSM's precompute) on
    /// these casters and light outside a frame.
    pub fn prepare(
        &self,
        casters: &SceneGpu,
        light: &AreaLight,
        technique: &mut dyn ShadowTechnique,
    ) -> Result<(), RenderError> {
        technique.prepare(&self.gpu, &self.stage.inputs(casters, light))?;
        Ok(())
    }

    fn check_output(&self, texture: &wgpu::Texture) -> Result<(), RenderError> {
        let size_ok = texture.width() == self.width && texture.height() == self.height;
        if texture.format() != VISIBILITY_FORMAT
            || !size_ok
            || !texture.usage().contains(wgpu::TextureUsages::COPY_DST)
        {
            return Err(RenderError::Scene(format!(
                "host output texture is {:?} {}x{} with {:?}: give an R32Float texture of {}x{} \
                 with COPY_DST, or a view (HostOutput::View)",
                texture.format(),
                texture.width(),
                texture.height(),
                texture.usage(),
                self.width,
                self.height
            )));
        }
        Ok(())
    }

    fn surface_bind_group(
        &self,
        surface: &HostSurface<'_>,
        view: &HostView,
    ) -> Result<wgpu::BindGroup, RenderError> {
        let (positions, layout, inverse, background) = match surface.positions {
            SurfacePositions::World(texture) => {
                (texture, &self.conversion.layout_world, Mat4::IDENTITY, 0.0)
            }
            SurfacePositions::Depth {
                depth,
                inverse_view_proj,
                background,
            } => {
                if !inverse_view_proj.is_finite() {
                    return Err(RenderError::Scene(
                        "host inverse view-projection is not finite: invert the matrix the \
                         G-buffer was drawn with"
                            .into(),
                    ));
                }
                (
                    depth,
                    &self.conversion.layout_depth,
                    inverse_view_proj,
                    background,
                )
            }
        };
        let uniforms = SurfaceUniforms {
            inverse_view_proj: inverse,
            eye: view.eye.extend(1.0),
            mode: Vec4::new(
                (surface.normal_encoding == NormalEncoding::Unorm) as u32 as f32,
                surface.receiver_mask.is_some() as u32 as f32,
                background,
                0.0,
            ),
        };
        // A buffer per frame (not a queue write) for the same reason as the frame uniforms.
        let buffer = self
            .gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("host/surface uniforms"),
                contents: &uniform_bytes(&uniforms),
                usage: wgpu::BufferUsages::UNIFORM,
            });
        let texture = |binding, view| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::TextureView(view),
        };
        Ok(self
            .gpu
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("host/surface"),
                layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: buffer.as_entire_binding(),
                    },
                    texture(1, positions),
                    texture(2, surface.normal),
                    texture(3, surface.receiver_mask.unwrap_or(&self.conversion.no_mask)),
                ],
            }))
    }

    fn output_pipeline(&mut self, format: wgpu::TextureFormat) -> Result<(), GpuError> {
        if self.output_pipelines.contains_key(&format) {
            return Ok(());
        }
        let spec = shader::CORE_SHADERS
            .iter()
            .find(|s| s.path == "core/host_output.wgsl")
            .expect("declared in CORE_SHADERS");
        let module = shader::create_module(&self.gpu, spec, &[])?;
        let layout = self
            .gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("host/output"),
                bind_group_layouts: &[Some(&self.output_layout)],
                immediate_size: 0,
            });
        let target = wgpu::ColorTargetState {
            format,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        };
        let pipeline = crate::fullscreen::render_pipeline(
            &self.gpu,
            "host/output",
            &layout,
            &module,
            &[Some(target)],
        );
        self.output_pipelines.insert(format, pipeline);
        Ok(())
    }
}

/// A colour attachment of `view`, cleared to transparent and stored.
fn cleared(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
            store: wgpu::StoreOp::Store,
        },
    })
}
