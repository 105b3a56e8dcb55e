//! `hard`: one shadow map from the light centre and one depth comparison per pixel.
//!
//! Reads: the casters (depth pass) and the G-buffer. Writes: the visibility buffer (0 or 1).
//! It is the floor of every cost comparison and the limit every soft technique must approach as
//! the light shrinks to a point.

use bytemuck::{Pod, Zeroable};
use softshadow_core::{
    fullscreen::{uniform_buffer, FullscreenPipeline},
    params::{expect_f32, expect_u32, find_spec},
    shader::ShaderSpec,
    shader_file,
    shadow_map::CentreShadowMap,
    wgpu, DebugView, Frame, Gpu, ParamError, ParamSet, ParamSpec, ParamValue, ShadowInputs,
    ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats, VisibilityBuffer,
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
    shadow_map: CentreShadowMap,
    lookup: FullscreenPipeline,
    layout: wgpu::BindGroupLayout,
    params_buffer: wgpu::Buffer,
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
        let layout = CentreShadowMap::lookup_layout(gpu, "hard/lookup");
        Ok(Self {
            shadow_map: CentreShadowMap::new(gpu)?.clipped_to_receivers(),
            lookup: FullscreenPipeline::new(gpu, "hard/lookup", &SHADERS[0], &[], &layout, None)?,
            params_buffer: uniform_buffer(gpu, "hard/params", &HardParams::zeroed()),
            layout,
            settings,
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
        let gpu = frame.gpu;
        let size = self.settings.shadow_map_size;
        if self
            .shadow_map
            .render(frame, inputs, size, "hard/shadow_map")
            .is_none()
        {
            // No caster in front of the light: everything is lit, no lookup needed.
            out.clear_lit(frame, "hard/no_casters");
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        }
        gpu.queue.write_buffer(
            &self.params_buffer,
            0,
            bytemuck::bytes_of(&HardParams {
                bias_texels: self.settings.bias_texels,
                _pad: [0.0; 3],
            }),
        );
        let bind_group = self
            .shadow_map
            .lookup_bind_group(gpu, &self.layout, &self.params_buffer)
            .expect("rendered above");
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

    fn debug_views(&self) -> Vec<DebugView> {
        self.shadow_map.debug_views()
    }
}
