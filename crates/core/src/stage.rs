//! The one path from "a receiver surface, casters, a view and a light" to a technique's passes.
//!
//! A [`ShadowStage`] owns the frame uniforms and bind group 0 over a receiver surface in the
//! core's format (world position + hit flag, normal + receiver flag; `shaders/common/frame.wgsl`)
//! and remembers each technique's last inputs to hand it [`FrameChanges`]. The workbench's
//! [`crate::Renderer`] runs it over its own G-buffer; [`crate::host::HostRenderer`] runs it over
//! textures converted from a host renderer's G-buffer. Neither has a path the other lacks.

use std::collections::HashMap;

use crate::{
    error::RenderError,
    frame::{Frame, FrameChanges, FrameState, FrameUniforms, ShadowInputs},
    scene_gpu::SceneGpu,
    technique::{check_requirements, ShadowTechnique},
    uniform::{uniform_buffer, uniform_bytes},
    visibility::VisibilityBuffer,
    AreaLight, Camera, Gpu,
};

/// Frame uniforms, bind group 0 over a receiver surface, and each technique's last inputs.
pub struct ShadowStage {
    uniforms: wgpu::Buffer,
    frame_bind_group: wgpu::BindGroup,
    width: u32,
    height: u32,
    last_uniforms: FrameUniforms,
    /// The inputs of the last frame drawn with each technique id, for [`FrameChanges`].
    last_states: HashMap<String, FrameState>,
}

impl ShadowStage {
    /// A stage over `position` (Rgba32Float: xyz world, w = 1 where geometry was drawn) and
    /// `normal` (Rgba16Float or Rgba32Float: xyz normal facing the camera, w = 1 on receivers),
    /// both `width` x `height`.
    pub fn new(
        gpu: &Gpu,
        position: &wgpu::TextureView,
        normal: &wgpu::TextureView,
        width: u32,
        height: u32,
    ) -> Self {
        let last_uniforms =
            FrameUniforms::new(&Camera::default(), &AreaLight::default(), width, height);
        let uniforms = uniform_buffer(gpu, "core/frame uniforms", &last_uniforms);
        let frame_bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("core/frame"),
            layout: &gpu.layouts.frame,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniforms.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(position),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(normal),
                },
            ],
        });
        Self {
            uniforms,
            frame_bind_group,
            width,
            height,
            last_uniforms,
            last_states: HashMap::new(),
        }
    }

    /// The uniform buffer of bind group 0 (the workbench's G-buffer pass binds it alone).
    pub fn uniform_buffer(&self) -> &wgpu::Buffer {
        &self.uniforms
    }

    /// Bind group 0 of technique passes ([`crate::frame::CoreLayouts::frame`]).
    pub fn frame_bind_group(&self) -> &wgpu::BindGroup {
        &self.frame_bind_group
    }

    /// What a technique reads, with `changes` = everything (for
    /// [`ShadowTechnique::prepare`] outside a frame: the uniforms are those of the last frame).
    pub fn inputs<'a>(&'a self, scene: &'a SceneGpu, light: &'a AreaLight) -> ShadowInputs<'a> {
        ShadowInputs {
            changes: FrameChanges::ALL,
            scene,
            light,
            frame_bind_group: &self.frame_bind_group,
            uniforms: self.last_uniforms,
            width: self.width,
            height: self.height,
        }
    }

    /// Checks the light and the technique's requirements, writes `uniforms` (the write lands
    /// before the next submission) and returns the frame's state with what changed since the
    /// technique's last frame on this stage. Pass the state to [`ShadowStage::finish`] once the
    /// frame has succeeded.
    pub fn begin(
        &mut self,
        gpu: &Gpu,
        scene: &SceneGpu,
        light: &AreaLight,
        uniforms: FrameUniforms,
        technique: &dyn ShadowTechnique,
    ) -> Result<(FrameState, FrameChanges), RenderError> {
        light.validate().map_err(RenderError::Scene)?;
        check_requirements(gpu, technique.id(), &technique.requirements())?;
        let state = FrameState {
            view_proj: uniforms.view_proj(),
            eye: uniforms.eye(),
            light: *light,
            static_hash: scene.static_hash,
            dynamic_hash: scene.dynamic_hash,
            size: (self.width, self.height),
            params: technique.params(),
        };
        // A failed frame leaves nothing to compare with: the next one sees everything changed.
        let changes = state.changes_since(self.last_states.remove(technique.id()).as_ref());
        self.last_uniforms = uniforms;
        gpu.queue
            .write_buffer(&self.uniforms, 0, &uniform_bytes(&self.last_uniforms));
        Ok((state, changes))
    }

    /// Writes `uniforms` for a frame that runs no technique here (its visibility was computed
    /// elsewhere: [`crate::Renderer::show_visibility`]); the write lands before the next
    /// submission. The technique states kept for [`FrameChanges`] are left as they are.
    pub fn write_uniforms(&mut self, gpu: &Gpu, uniforms: FrameUniforms) {
        self.last_uniforms = uniforms;
        gpu.queue
            .write_buffer(&self.uniforms, 0, &uniform_bytes(&self.last_uniforms));
    }

    /// Records the technique's passes into `frame`, writing `out`.
    pub fn record(
        &self,
        frame: &mut Frame<'_>,
        scene: &SceneGpu,
        light: &AreaLight,
        changes: FrameChanges,
        technique: &mut dyn ShadowTechnique,
        out: &VisibilityBuffer,
    ) -> Result<(), RenderError> {
        let mut inputs = self.inputs(scene, light);
        inputs.changes = changes;
        technique.render(frame, &inputs, out)?;
        Ok(())
    }

    /// Remembers the inputs of a frame that succeeded, for the technique's next
    /// [`FrameChanges`].
    pub fn finish(&mut self, technique: &str, state: FrameState) {
        self.last_states.insert(technique.to_string(), state);
    }
}
