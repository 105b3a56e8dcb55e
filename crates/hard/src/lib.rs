//! `hard`: one shadow map from the light centre and one depth comparison per pixel.
//!
//! Reads: the casters (depth pass) and the G-buffer. Writes: the visibility buffer (0 or 1).
//! It is the floor of every cost comparison and the limit every soft technique must approach as
//! the light shrinks to a point.

use bytemuck::{Pod, Zeroable};
use glam::Vec2;
use softshadow_core::{
    fullscreen::{depth_texture_entry, uniform_buffer, FullscreenPipeline},
    glam,
    frame::uniform_entry,
    params::{expect_f32, expect_u32, find_spec},
    shader::ShaderSpec,
    shader_file,
    shadow_map::{create_depth_maps, fit_caster_view, DepthMapRenderer, ShadowViewUniform},
    Frame, Gpu, ParamError, ParamSet, ParamSpec, ParamValue, ShadowInputs, ShadowTechnique,
    TechniqueError, TechniqueInfo, TechniqueStats, VisibilityBuffer,
};

pub const ID: &str = "hard";

pub const SHADERS: &[ShaderSpec] = &[ShaderSpec {
    path: "hard/hard.wgsl",
    source: shader_file!("hard/hard.wgsl").1,
    permutations: &[&[]],
}];

/// Settings of the `hard` technique.
#[derive(Clone, Debug, PartialEq)]
pub struct HardSettings {
    /// Shadow-map edge in texels.
    pub shadow_map_size: u32,
    /// Depth bias in texel footprints at the receiver (scaled up on slopes).
    pub bias_texels: f32,
}

impl Default for HardSettings {
    fn default() -> Self {
        Self {
            shadow_map_size: 1024,
            bias_texels: 1.5,
        }
    }
}

pub fn param_specs() -> Vec<ParamSpec> {
    let d = HardSettings::default();
    vec![
        ParamSpec::int(
            "shadow_map_size",
            "Shadow-map edge in texels",
            64,
            4096,
            d.shadow_map_size as i64,
        ),
        ParamSpec::float(
            "bias_texels",
            "Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes)",
            0.0,
            16.0,
            d.bias_texels as f64,
        ),
    ]
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct HardParams {
    bias_texels: f32,
    _pad: [f32; 3],
}

pub struct HardShadows {
    pub settings: HardSettings,
    depth: DepthMapRenderer,
    lookup: FullscreenPipeline,
    layout: softshadow_core::wgpu::BindGroupLayout,
    view_buffer: softshadow_core::wgpu::Buffer,
    params_buffer: softshadow_core::wgpu::Buffer,
    map: Option<(u32, softshadow_core::wgpu::Texture, softshadow_core::wgpu::TextureView)>,
    stats: TechniqueStats,
}

pub fn info() -> TechniqueInfo {
    TechniqueInfo {
        id: ID,
        description: "Hard shadows: one shadow map from the light centre (cost floor)",
        source: "Williams 1978",
        params: param_specs,
        create: |gpu| Ok(Box::new(HardShadows::new(gpu, HardSettings::default())?)),
    }
}

impl HardShadows {
    pub fn new(gpu: &Gpu, settings: HardSettings) -> Result<Self, TechniqueError> {
        use softshadow_core::wgpu;
        let stage = wgpu::ShaderStages::FRAGMENT;
        let layout = gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hard/lookup"),
            entries: &[
                uniform_entry(0, stage, false),
                depth_texture_entry(1, false),
                uniform_entry(2, stage, false),
            ],
        });
        Ok(Self {
            depth: DepthMapRenderer::new(gpu)?,
            lookup: FullscreenPipeline::new(gpu, "hard/lookup", &SHADERS[0], &[], &layout, None)?,
            view_buffer: uniform_buffer(gpu, "hard/view", &ShadowViewUniform::zeroed()),
            params_buffer: uniform_buffer(gpu, "hard/params", &HardParams::zeroed()),
            layout,
            settings,
            map: None,
            stats: TechniqueStats::new(),
        })
    }
}

impl ShadowTechnique for HardShadows {
    fn id(&self) -> &'static str {
        ID
    }

    fn params(&self) -> ParamSet {
        let s = &self.settings;
        let values = [
            ParamValue::Int(s.shadow_map_size as i64),
            ParamValue::Float(s.bias_texels as f64),
        ];
        ParamSet {
            entries: param_specs().into_iter().zip(values).collect(),
        }
    }

    fn set_param(&mut self, name: &str, value: ParamValue) -> Result<(), ParamError> {
        let specs = param_specs();
        let spec = find_spec(ID, &specs, name)?;
        let value = spec.check(value)?;
        match spec.name {
            "shadow_map_size" => self.settings.shadow_map_size = expect_u32(&value),
            "bias_texels" => self.settings.bias_texels = expect_f32(&value),
            _ => unreachable!("every spec is matched"),
        }
        Ok(())
    }

    fn render(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
    ) -> Result<(), TechniqueError> {
        use softshadow_core::wgpu;
        let gpu = frame.gpu;
        let size = self.settings.shadow_map_size;
        let Some(frustum) = fit_caster_view(inputs.scene, inputs.light, Vec2::ZERO) else {
            // No caster in front of the light: everything is lit, no shadow map needed.
            out.clear_lit(frame, "hard/no_casters");
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        };
        if self.map.as_ref().map(|m| m.0) != Some(size) {
            let texture = create_depth_maps(gpu, "hard/shadow_map", size, 1);
            let view = texture.create_view(&Default::default());
            self.map = Some((size, texture, view));
        }
        let (_, _, map_view) = self.map.as_ref().expect("created above");
        let view = ShadowViewUniform::new(inputs.light, &frustum, size);
        self.depth.set_views(gpu, &[view]);
        gpu.queue.write_buffer(&self.view_buffer, 0, bytemuck::bytes_of(&view));
        gpu.queue.write_buffer(
            &self.params_buffer,
            0,
            bytemuck::bytes_of(&HardParams {
                bias_texels: self.settings.bias_texels,
                _pad: [0.0; 3],
            }),
        );
        self.depth.record(frame, "hard/shadow_map", inputs.scene, 0, map_view);
        let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hard/lookup"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.view_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(map_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: self.params_buffer.as_entire_binding(),
                },
            ],
        });
        self.lookup.record(
            frame,
            "hard/lookup",
            inputs.frame_bind_group,
            &bind_group,
            &[],
            &out.view,
            Some(1.0),
        );
        self.stats = TechniqueStats::from([
            ("shadow_maps".into(), 1.0),
            ("shadow_map_texels".into(), (size as f64) * (size as f64)),
        ]);
        Ok(())
    }

    fn stats(&self) -> TechniqueStats {
        self.stats.clone()
    }
}
