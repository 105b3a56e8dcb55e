//! Core of the soft-shadow workbench: GPU context, scene model, camera, area light, G-buffer,
//! the visibility buffer every technique writes, shading, the [`ShadowTechnique`] trait with its
//! typed parameters, GPU timer scopes, readback, and shader composition.
//!
//! Data flow of a frame (see [`renderer::Renderer::render`]):
//! `Scene -> SceneGpu -> G-buffer -> technique -> VisibilityBuffer -> shading`.

#![warn(missing_docs)]

pub mod accel;
pub mod background;
pub mod camera;
pub mod cascades;
pub mod cost;
pub mod disk_cache;
pub mod error;
pub mod expectations;
pub mod frame;
pub mod fullscreen;
pub mod gather;
pub mod gbuffer;
pub mod gpu;
pub mod hierarchy;
pub mod host;
pub mod light;
pub mod light_shape;
pub mod material;
pub mod material_gpu;
pub mod memory;
pub mod params;
pub mod pass;
pub mod readback;
pub mod registry;
pub mod renderer;
pub mod reprojection;
pub mod scene;
pub mod scene_gpu;
pub mod shader;
pub mod shading;
pub mod shadow_map;
pub mod stage;
pub mod technique;
pub mod uniform;
pub mod visibility;

pub use accel::SceneAccel;
pub use camera::Camera;
pub use cost::{Cost, CostModel, CostQuery};
pub use error::{GpuError, ParamError, RenderError, TechniqueError};
pub use expectations::{ErrorMetric, Expect, Expectations, StiffClass};
pub use frame::{
    Frame, FrameChanges, FrameState, FrameUniforms, SerialTimes, ShadowInputs, TimingSource,
};
pub use gpu::Gpu;
pub use hierarchy::{DepthHierarchy, HierarchyKind, Visibility};
pub use light::{AreaLight, LightKind, SlopeFrustum};
pub use material::{AlphaMode, Material, Texture, TextureFilter, TextureWrap};
pub use memory::MemoryUse;
pub use params::{
    ParamChoice, ParamKind, ParamSet, ParamSpec, ParamType, ParamValue, TechniqueSettings,
};
pub use registry::{Registry, RegistryError};
pub use renderer::{FrameOutput, GpuFrameTiming, Renderer};
pub use scene::{Aabb, Instance, Mesh, MeshRepair, Scene};
pub use scene_gpu::SceneGpu;
pub use shading::ShadingMode;
pub use stage::ShadowStage;
pub use technique::{
    BuildControl, BuildProgress, DebugLegend, DebugView, LightSupport, MinLimits, Requirements,
    ShadowTechnique, TechniqueInfo, TechniqueStats, COST_FLOOR_TECHNIQUE, LIGHT_KIND_SCENE,
    YARDSTICK_TECHNIQUE,
};
pub use visibility::VisibilityBuffer;

// Re-exported so technique crates use the same versions.
pub use {bytemuck, encase, glam, puffin, wgpu};

/// The core's uniform structs with the WGSL structs they fill, for the layout test in
/// tests/shaders.rs ([`shader::uniform_layout`]).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<shader::uniform_layout::UniformMirror> {
    use cascades::CascadeUniform;
    use frame::FrameUniforms;
    use material_gpu::MaterialEntry;
    use shadow_map::{DepthView, ShadowViewUniform};
    vec![
        uniform_mirror!(
            FrameUniforms {
                view_proj,
                world_to_light,
                camera_pos,
                light_center,
                light_dir,
                light_half,
                screen,
                light_to_world,
                light_shape,
                light_sun,
            } => "common/frame_types.wgsl", FrameUniforms
        ),
        uniform_mirror!(
            ShadowViewUniform { light_view_proj, window, eye_near_far, size }
                => "common/shadow_view.wgsl", ShadowView
        ),
        uniform_mirror!(DepthView { light_view_proj } => "core/depth.wgsl", DepthView),
        uniform_mirror!(
            MaterialEntry {
                base_color,
                cutoff,
                texel_offset,
                width,
                height,
                wrap_u,
                wrap_v,
                filtering,
                pad,
            } => "common/material.wgsl", MaterialEntry
        ),
        uniform_mirror!(
            CascadeUniform {
                view_proj, split_far, texel_world, near, depth_range, camera_forward, info
            } => "common/cascades.wgsl", Cascades
        ),
        shading::uniform_mirror(),
        hierarchy::uniform_mirror(),
        host::uniform_mirror(),
        gather::GatherUniform::uniform_mirror(),
        gather::GatherCounts::uniform_mirror(),
    ]
}
