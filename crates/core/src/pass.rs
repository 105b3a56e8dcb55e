//! The pass builder: a pass is declared by what its shader reads and writes, and its layout,
//! pipeline and bind groups are made from that declaration.
//!
//! ```ignore
//! // Once, when the technique is built:
//! let stats = Pass::new(gpu, "ssm/stats", &SHADERS[4])
//!     .uniform()                 // @binding(0) var<uniform>
//!     .texture(Slot::DEPTH)      // @binding(1) texture_depth_2d
//!     .storage_rw()              // @binding(2) var<storage, read_write>
//!     .compute("main")?;
//! // Every frame:
//! stats.run(frame).read(&params).read(&depth).write(&counters).dispatch([x, y, 1]);
//! ```
//!
//! A pass's own bindings are one bind group, in binding order from 0. With
//! [`PassBuilder::after_frame_group`] that group is group 1 and group 0 is the core frame group
//! (`shaders/common/frame.wgsl`), as for every per-pixel pass; without it, group 0.

use crate::{shader, shader::DefValue, shader::ShaderSpec, Frame, Gpu, GpuError};

/// One binding of a pass, as its shader declares it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// `var<uniform>`.
    Uniform,
    /// `var<uniform>` bound at a dynamic offset into a buffer of `size`-byte views.
    DynamicUniform {
        /// Bytes of one view.
        size: u64,
    },
    /// `var<storage, read>`.
    Storage,
    /// `var<storage, read_write>`.
    StorageReadWrite,
    /// A sampled texture (read with `textureLoad` or a sampler).
    Texture {
        /// What it holds.
        sample: wgpu::TextureSampleType,
        /// 2D, 2D array, ...
        dimension: wgpu::TextureViewDimension,
    },
    /// A write-only 2D storage texture of a format.
    StorageTexture(wgpu::TextureFormat),
    /// A sampler.
    Sampler(wgpu::SamplerBindingType),
    /// A ray-query `acceleration_structure`.
    AccelerationStructure,
}

impl Slot {
    /// `texture_depth_2d`.
    pub const DEPTH: Slot = Slot::texture(wgpu::TextureSampleType::Depth);
    /// `texture_depth_2d_array`.
    pub const DEPTH_ARRAY: Slot = Slot::Texture {
        sample: wgpu::TextureSampleType::Depth,
        dimension: wgpu::TextureViewDimension::D2Array,
    };
    /// `texture_2d<f32>` read with `textureLoad` (32-bit floats are not filterable everywhere).
    pub const FLOAT: Slot = Slot::texture(wgpu::TextureSampleType::Float { filterable: false });
    /// `texture_2d<f32>` read through a filtering sampler.
    pub const FILTERABLE: Slot = Slot::texture(wgpu::TextureSampleType::Float { filterable: true });
    /// `texture_2d<u32>`.
    pub const UINT: Slot = Slot::texture(wgpu::TextureSampleType::Uint);

    /// A 2D texture of `sample`.
    pub const fn texture(sample: wgpu::TextureSampleType) -> Slot {
        Slot::Texture {
            sample,
            dimension: wgpu::TextureViewDimension::D2,
        }
    }

    fn binding_type(self) -> wgpu::BindingType {
        let buffer = |ty, has_dynamic_offset, size: Option<u64>| wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset,
            min_binding_size: size.and_then(wgpu::BufferSize::new),
        };
        match self {
            Slot::Uniform => buffer(wgpu::BufferBindingType::Uniform, false, None),
            Slot::DynamicUniform { size } => {
                buffer(wgpu::BufferBindingType::Uniform, true, Some(size))
            }
            Slot::Storage => buffer(
                wgpu::BufferBindingType::Storage { read_only: true },
                false,
                None,
            ),
            Slot::StorageReadWrite => buffer(
                wgpu::BufferBindingType::Storage { read_only: false },
                false,
                None,
            ),
            Slot::Texture { sample, dimension } => wgpu::BindingType::Texture {
                sample_type: sample,
                view_dimension: dimension,
                multisampled: false,
            },
            Slot::StorageTexture(format) => wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format,
                view_dimension: wgpu::TextureViewDimension::D2,
            },
            Slot::Sampler(kind) => wgpu::BindingType::Sampler(kind),
            Slot::AccelerationStructure => wgpu::BindingType::AccelerationStructure {
                vertex_return: false,
            },
        }
    }

    /// Whether a shader may write through this binding.
    fn writable(self) -> bool {
        matches!(self, Slot::StorageReadWrite | Slot::StorageTexture(_))
    }
}

/// The bind group layout of `slots`, bindings 0.. in order, visible to `stages`.
pub fn group_layout(
    gpu: &Gpu,
    label: &str,
    slots: &[Slot],
    stages: wgpu::ShaderStages,
) -> wgpu::BindGroupLayout {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = slots
        .iter()
        .enumerate()
        .map(|(binding, slot)| wgpu::BindGroupLayoutEntry {
            binding: binding as u32,
            // WebGPU allows no writable storage in the vertex stage.
            visibility: if slot.writable() {
                stages - wgpu::ShaderStages::VERTEX
            } else {
                stages
            },
            ty: slot.binding_type(),
            count: None,
        })
        .collect();
    gpu.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries: &entries,
        })
}

/// What a pass binds at one slot for one run.
#[derive(Clone, Copy, Debug)]
pub enum Resource<'a> {
    /// A whole buffer.
    Buffer(&'a wgpu::Buffer),
    /// `size` bytes of a buffer from `offset` (the view of a dynamic uniform).
    BufferRange(&'a wgpu::Buffer, u64, u64),
    /// A texture view.
    View(&'a wgpu::TextureView),
    /// A sampler.
    Sampler(&'a wgpu::Sampler),
    /// A top-level acceleration structure.
    Tlas(&'a wgpu::Tlas),
}

impl<'a> From<&'a wgpu::Buffer> for Resource<'a> {
    fn from(buffer: &'a wgpu::Buffer) -> Self {
        Resource::Buffer(buffer)
    }
}

impl<'a> From<&'a wgpu::TextureView> for Resource<'a> {
    fn from(view: &'a wgpu::TextureView) -> Self {
        Resource::View(view)
    }
}

impl<'a> From<&'a wgpu::Tlas> for Resource<'a> {
    fn from(tlas: &'a wgpu::Tlas) -> Self {
        Resource::Tlas(tlas)
    }
}

impl<'a> From<&'a wgpu::Sampler> for Resource<'a> {
    fn from(sampler: &'a wgpu::Sampler) -> Self {
        Resource::Sampler(sampler)
    }
}

impl Resource<'_> {
    fn binding(&self) -> wgpu::BindingResource<'_> {
        match *self {
            Resource::Buffer(buffer) => buffer.as_entire_binding(),
            Resource::BufferRange(buffer, offset, size) => {
                wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer,
                    offset,
                    size: wgpu::BufferSize::new(size),
                })
            }
            Resource::View(view) => wgpu::BindingResource::TextureView(view),
            Resource::Sampler(sampler) => wgpu::BindingResource::Sampler(sampler),
            Resource::Tlas(tlas) => tlas.as_binding(),
        }
    }

    fn fits(&self, slot: Slot) -> bool {
        match self {
            Resource::Buffer(_) | Resource::BufferRange(..) => matches!(
                slot,
                Slot::Uniform
                    | Slot::DynamicUniform { .. }
                    | Slot::Storage
                    | Slot::StorageReadWrite
            ),
            Resource::View(_) => matches!(slot, Slot::Texture { .. } | Slot::StorageTexture(_)),
            Resource::Sampler(_) => matches!(slot, Slot::Sampler(_)),
            Resource::Tlas(_) => slot == Slot::AccelerationStructure,
        }
    }
}

/// A pass's own bind group layout, and the bind groups made for it from what a run binds. They
/// are not kept between runs: a bind group holds its resources alive, and a kept group of
/// resources a technique has since replaced (a rebuilt precompute, a resized target) would hold
/// their memory.
pub struct PassGroup {
    label: String,
    slots: Vec<Slot>,
    layout: wgpu::BindGroupLayout,
}

impl PassGroup {
    /// The layout of `slots` for `stages`.
    pub fn new(gpu: &Gpu, label: &str, slots: &[Slot], stages: wgpu::ShaderStages) -> Self {
        Self {
            label: label.to_string(),
            slots: slots.to_vec(),
            layout: group_layout(gpu, label, slots, stages),
        }
    }

    /// The bind group layout.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// The bind group of `resources` (one per slot, in order).
    ///
    /// # Panics
    /// When the resources do not match the declared slots: a mistake in the technique's code.
    pub fn bind(&self, gpu: &Gpu, resources: &[Resource<'_>]) -> wgpu::BindGroup {
        self.check(resources);
        let entries: Vec<wgpu::BindGroupEntry<'_>> = resources
            .iter()
            .enumerate()
            .map(|(binding, resource)| wgpu::BindGroupEntry {
                binding: binding as u32,
                resource: resource.binding(),
            })
            .collect();
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(&self.label),
            layout: &self.layout,
            entries: &entries,
        })
    }

    fn check(&self, resources: &[Resource<'_>]) {
        assert_eq!(
            resources.len(),
            self.slots.len(),
            "{}: {} resources bound to {} declared slots",
            self.label,
            resources.len(),
            self.slots.len()
        );
        for (binding, (resource, slot)) in resources.iter().zip(&self.slots).enumerate() {
            assert!(
                resource.fits(*slot),
                "{}: binding {binding} is declared {slot:?} but given {resource:?}",
                self.label
            );
        }
    }
}

/// Declares a pass: its shader, defs and slots; finished by [`PassBuilder::compute`] or
/// [`PassBuilder::fullscreen`].
pub struct PassBuilder<'a> {
    gpu: &'a Gpu,
    label: String,
    source: PassSource<'a>,
    defs: Vec<(&'a str, DefValue)>,
    slots: Vec<Slot>,
    after_frame_group: bool,
    material_triangles: bool,
}

/// Where a pass's shader comes from.
enum PassSource<'a> {
    /// A WGSL entry file of the workspace, composed with its defs.
    Spec(&'a ShaderSpec),
    /// A module already composed (a WGSL-file technique).
    Module(Box<naga::Module>),
}

/// Starts declaring a pass named `label` (the name its timings carry) from `spec`.
pub struct Pass;

impl Pass {
    /// A new pass declaration.
    #[allow(clippy::new_ret_no_self)]
    pub fn new<'a>(gpu: &'a Gpu, label: &str, spec: &'a ShaderSpec) -> PassBuilder<'a> {
        PassBuilder {
            gpu,
            label: label.to_string(),
            source: PassSource::Spec(spec),
            defs: Vec::new(),
            slots: Vec::new(),
            after_frame_group: false,
            material_triangles: false,
        }
    }

    /// A new pass declaration over a module already composed (defs do not apply).
    pub fn from_module<'a>(gpu: &'a Gpu, label: &str, module: naga::Module) -> PassBuilder<'a> {
        PassBuilder {
            gpu,
            label: label.to_string(),
            source: PassSource::Module(Box::new(module)),
            defs: Vec::new(),
            slots: Vec::new(),
            after_frame_group: false,
            material_triangles: false,
        }
    }
}

impl<'a> PassBuilder<'a> {
    /// Shader defs of the permutation to build.
    pub fn defs(mut self, defs: &[(&'a str, DefValue)]) -> Self {
        self.defs.extend_from_slice(defs);
        self
    }

    /// Group 0 is the core frame group (frame uniforms, G-buffer); the pass's own is group 1.
    pub fn after_frame_group(mut self) -> Self {
        self.after_frame_group = true;
        self
    }

    /// A ray-query pass's alpha-tested variant: the group after the pass's own is
    /// `softshadow::material` with `MATERIAL_TRIANGLES` (`crate::material_gpu`), and the module
    /// is composed with `ALPHA_TEST`. Run it with [`PassRun::materials`].
    pub fn material_triangles(mut self) -> Self {
        self.material_triangles = true;
        self
    }

    /// The next binding is `slot`.
    pub fn slot(mut self, slot: Slot) -> Self {
        self.slots.push(slot);
        self
    }

    /// The next binding is a `var<uniform>`.
    pub fn uniform(self) -> Self {
        self.slot(Slot::Uniform)
    }

    /// The next binding is a `var<storage, read>`.
    pub fn storage(self) -> Self {
        self.slot(Slot::Storage)
    }

    /// The next binding is a `var<storage, read_write>`.
    pub fn storage_rw(self) -> Self {
        self.slot(Slot::StorageReadWrite)
    }

    /// The next binding is a texture (see [`Slot::DEPTH`], [`Slot::FLOAT`], ...).
    pub fn texture(self, slot: Slot) -> Self {
        self.slot(slot)
    }

    /// The next binding is a write-only storage texture of `format`.
    pub fn storage_texture(self, format: wgpu::TextureFormat) -> Self {
        self.slot(Slot::StorageTexture(format))
    }

    /// The next `count` bindings are all `slot`.
    pub fn repeat(mut self, slot: Slot, count: usize) -> Self {
        self.slots.extend(std::iter::repeat_n(slot, count));
        self
    }

    /// The material group's index, for a pass built [`Self::material_triangles`].
    fn material_group(&self) -> Option<u32> {
        self.material_triangles
            .then_some(if self.after_frame_group { 2 } else { 1 })
    }

    fn module(&self) -> Result<wgpu::ShaderModule, GpuError> {
        match &self.source {
            PassSource::Spec(spec) => {
                let mut defs = self.defs.clone();
                if let Some(group) = self.material_group() {
                    defs.extend_from_slice(crate::ray_alpha_test_defs!(group));
                }
                shader::create_module(self.gpu, spec, &defs)
            }
            PassSource::Module(module) => {
                Ok(self
                    .gpu
                    .device
                    .create_shader_module(wgpu::ShaderModuleDescriptor {
                        label: Some(&self.label),
                        source: wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(
                            (**module).clone(),
                        )),
                    }))
            }
        }
    }

    fn pipeline_layout(&self, group: &PassGroup) -> wgpu::PipelineLayout {
        let frame = Some(&self.gpu.layouts.frame);
        let own = Some(group.layout());
        let mut groups = if self.after_frame_group {
            vec![frame, own]
        } else {
            vec![own]
        };
        let material = self
            .material_triangles
            .then(|| crate::material_gpu::MaterialGpu::triangles_layout_of(self.gpu));
        if material.is_some() {
            groups.push(material.as_ref());
        }
        self.gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(&self.label),
                bind_group_layouts: &groups,
                immediate_size: 0,
            })
    }

    /// A compute pass running `entry`.
    pub fn compute(self, entry: &str) -> Result<ComputePass, GpuError> {
        let group = PassGroup::new(
            self.gpu,
            &self.label,
            &self.slots,
            wgpu::ShaderStages::COMPUTE,
        );
        let module = self.module()?;
        let pipeline = self
            .gpu
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(&self.label),
                layout: Some(&self.pipeline_layout(&group)),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
        Ok(ComputePass {
            material_group: self.material_group(),
            label: self.label,
            group,
            pipeline,
            after_frame_group: self.after_frame_group,
        })
    }

    /// A fullscreen-triangle pass (`vs_main`, `fs_main`) writing one visibility target
    /// (`R32Float`), blended with `blend` when given.
    pub fn fullscreen(self, blend: Option<wgpu::BlendState>) -> Result<FullscreenPass, GpuError> {
        self.fullscreen_into(crate::visibility::VISIBILITY_FORMAT, blend)
    }

    /// A fullscreen-triangle pass (`vs_main`, `fs_main`) writing one target of `format`.
    pub fn fullscreen_into(
        self,
        format: wgpu::TextureFormat,
        blend: Option<wgpu::BlendState>,
    ) -> Result<FullscreenPass, GpuError> {
        let target = wgpu::ColorTargetState {
            format,
            blend,
            write_mask: wgpu::ColorWrites::ALL,
        };
        let stages = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        let group = PassGroup::new(self.gpu, &self.label, &self.slots, stages);
        let module = self.module()?;
        let pipeline = crate::fullscreen::render_pipeline(
            self.gpu,
            &self.label,
            &self.pipeline_layout(&group),
            &module,
            &[Some(target)],
        );
        Ok(FullscreenPass {
            label: self.label,
            group,
            pipeline,
            after_frame_group: self.after_frame_group,
        })
    }
}

/// A compute pass: its pipeline and its own group.
pub struct ComputePass {
    label: String,
    group: PassGroup,
    pipeline: wgpu::ComputePipeline,
    after_frame_group: bool,
    /// The material group's index ([`PassBuilder::material_triangles`]).
    material_group: Option<u32>,
}

/// A fullscreen-triangle pass: its pipeline and its own group.
pub struct FullscreenPass {
    label: String,
    group: PassGroup,
    pipeline: wgpu::RenderPipeline,
    after_frame_group: bool,
}

/// One run of a pass being declared: what it reads and writes this time, then dispatched or
/// drawn.
pub struct PassRun<'f, 'g, 'r, P> {
    frame: &'f mut Frame<'g>,
    pass: &'r P,
    frame_group: Option<&'r wgpu::BindGroup>,
    resources: Vec<Resource<'r>>,
    writes: Vec<bool>,
    dynamic_offsets: Vec<u32>,
    label: Option<&'r str>,
    instances: std::ops::Range<u32>,
    materials: Option<&'r wgpu::BindGroup>,
}

impl<'f, 'g, 'r, P: HasGroup> PassRun<'f, 'g, 'r, P> {
    /// The core frame group (group 0) for a pass built [`PassBuilder::after_frame_group`].
    pub fn frame_group(mut self, group: &'r wgpu::BindGroup) -> Self {
        self.frame_group = Some(group);
        self
    }

    /// The next binding, read by the pass.
    pub fn read(mut self, resource: impl Into<Resource<'r>>) -> Self {
        self.resources.push(resource.into());
        self.writes.push(false);
        self
    }

    /// The next binding, written by the pass.
    pub fn write(mut self, resource: impl Into<Resource<'r>>) -> Self {
        self.resources.push(resource.into());
        self.writes.push(true);
        self
    }

    /// Times and names this run `label` instead of the pass's own name.
    pub fn named(mut self, label: &'r str) -> Self {
        self.label = Some(label);
        self
    }

    /// Draws these instances of the fullscreen triangle (the shader reads `instance_index`).
    pub fn instances(mut self, instances: std::ops::Range<u32>) -> Self {
        self.instances = instances;
        self
    }

    /// The material group of a pass built [`PassBuilder::material_triangles`]
    /// ([`crate::material_gpu::MaterialGpu::triangles_group`]).
    pub fn materials(mut self, group: &'r wgpu::BindGroup) -> Self {
        self.materials = Some(group);
        self
    }

    /// Dynamic offsets of the pass's own group.
    pub fn offsets(mut self, offsets: &[u32]) -> Self {
        self.dynamic_offsets.extend_from_slice(offsets);
        self
    }

    /// The bind groups to set: the frame group (when the pass has one) and its own.
    fn groups(&self) -> (Option<&'r wgpu::BindGroup>, wgpu::BindGroup) {
        let group = self.pass.group();
        for (binding, (&write, slot)) in self.writes.iter().zip(&group.slots).enumerate() {
            assert!(
                !write || slot.writable(),
                "{}: binding {binding} is written but declared {slot:?}",
                group.label
            );
        }
        assert_eq!(
            self.frame_group.is_some(),
            self.pass.after_frame_group(),
            "{}: the frame group is given if and only if the pass was built after_frame_group",
            group.label
        );
        (
            self.frame_group,
            group.bind(self.frame.gpu, &self.resources),
        )
    }
}

impl PassRun<'_, '_, '_, ComputePass> {
    /// Records the pass with `workgroups` workgroups.
    pub fn dispatch(self, workgroups: [u32; 3]) {
        let (frame_group, own) = self.groups();
        let pass = self.pass;
        let label = self.label.unwrap_or(&pass.label);
        self.frame.compute_pass(label, |cpass| {
            cpass.set_pipeline(&pass.pipeline);
            let mut index = 0;
            if let Some(frame_group) = frame_group {
                cpass.set_bind_group(0, frame_group, &[]);
                index = 1;
            }
            cpass.set_bind_group(index, &own, &self.dynamic_offsets);
            assert_eq!(
                self.materials.is_some(),
                pass.material_group.is_some(),
                "{label}: the material group is given if and only if the pass was built material_triangles"
            );
            if let (Some(materials), Some(group)) = (self.materials, pass.material_group) {
                cpass.set_bind_group(group, materials, &[]);
            }
            cpass.dispatch_workgroups(workgroups[0], workgroups[1], workgroups[2]);
        });
    }
}

impl PassRun<'_, '_, '_, FullscreenPass> {
    /// Draws the fullscreen triangle into `target`; `clear` = `Some(v)` clears it to `v` first,
    /// `None` keeps its contents (for accumulation).
    pub fn draw(self, target: &wgpu::TextureView, clear: Option<f64>) {
        let (frame_group, own) = self.groups();
        let pass = self.pass;
        let load = match clear {
            Some(v) => wgpu::LoadOp::Clear(wgpu::Color {
                r: v,
                g: 0.0,
                b: 0.0,
                a: 0.0,
            }),
            None => wgpu::LoadOp::Load,
        };
        let attachment = wgpu::RenderPassColorAttachment {
            view: target,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load,
                store: wgpu::StoreOp::Store,
            },
        };
        let desc = wgpu::RenderPassDescriptor {
            label: None,
            color_attachments: &[Some(attachment)],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        };
        let label = self.label.unwrap_or(&pass.label);
        self.frame.render_pass(label, desc, |rpass| {
            rpass.set_pipeline(&pass.pipeline);
            let mut index = 0;
            if let Some(frame_group) = frame_group {
                rpass.set_bind_group(0, frame_group, &[]);
                index = 1;
            }
            rpass.set_bind_group(index, &own, &self.dynamic_offsets);
            rpass.draw(0..3, self.instances.clone());
        });
    }
}

/// A built pass: its own group, and whether group 0 is the frame group.
pub trait HasGroup {
    /// The pass's own group.
    fn group(&self) -> &PassGroup;
    /// Whether group 0 is the core frame group.
    fn after_frame_group(&self) -> bool;
}

macro_rules! built_pass {
    ($pass:ty) => {
        impl HasGroup for $pass {
            fn group(&self) -> &PassGroup {
                &self.group
            }
            fn after_frame_group(&self) -> bool {
                self.after_frame_group
            }
        }

        impl $pass {
            /// Starts a run of the pass in `frame`: then `.read(..)`, `.write(..)` in binding
            /// order, and record it.
            pub fn run<'f, 'g, 'r>(
                &'r self,
                frame: &'f mut Frame<'g>,
            ) -> PassRun<'f, 'g, 'r, Self> {
                PassRun {
                    frame,
                    pass: self,
                    frame_group: None,
                    resources: Vec::new(),
                    writes: Vec::new(),
                    dynamic_offsets: Vec::new(),
                    label: None,
                    instances: 0..1,
                    materials: None,
                }
            }

            /// The name its timings carry.
            pub fn label(&self) -> &str {
                &self.label
            }
        }
    };
}

built_pass!(ComputePass);
built_pass!(FullscreenPass);
