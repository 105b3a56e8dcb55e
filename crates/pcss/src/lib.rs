//! `pcss`: percentage-closer soft shadows (Fernando 2005; `shared/notes/ALGORITHMS.md` section 2).
//!
//! Reads: the casters (one shadow map from the light centre) and the G-buffer.
//! Writes: the visibility buffer. Passes: `pcss/shadow_map`, `pcss/filter` (blocker search,
//! penumbra estimate and percentage-closer filtering in one fullscreen pass).

use bytemuck::{Pod, Zeroable};
use softshadow_core::{
    fullscreen::{uniform_buffer, FullscreenPipeline},
    params::{expect_choice, expect_f32, expect_u32, find_spec},
    shader::ShaderSpec,
    shader_file,
    shadow_map::CentreShadowMap,
    wgpu, DebugView, Frame, Gpu, ParamError, ParamSet, ParamSpec, ParamValue, ShadowInputs,
    ShadowTechnique, TechniqueError, TechniqueInfo, TechniqueStats, VisibilityBuffer,
};

pub const ID: &str = "pcss";

pub const SHADERS: &[ShaderSpec] = &[ShaderSpec {
    path: "pcss/pcss.wgsl",
    source: shader_file!("pcss/pcss.wgsl").1,
    permutations: &[&[]],
}];

/// Filter kernel shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// Vogel (golden-angle) disk rotated per pixel: what engines ship.
    Vogel,
    /// Jittered grid over the light's rectangle: exact for a planar occluder parallel to the light
    /// when the blocker depth is right (a box filter of the penumbra width gives the linear ramp).
    Grid,
}

impl Kernel {
    pub const NAMES: &'static [&'static str] = &["vogel", "grid"];
    fn name(self) -> &'static str {
        match self {
            Kernel::Vogel => "vogel",
            Kernel::Grid => "grid",
        }
    }
    fn from_name(name: &str) -> Self {
        if name == "grid" {
            Kernel::Grid
        } else {
            Kernel::Vogel
        }
    }
}

/// Settings of PCSS. Defaults follow common engine practice (16 blocker, 32 filter samples).
#[derive(Clone, Debug, PartialEq)]
pub struct PcssSettings {
    pub shadow_map_size: u32,
    /// Samples of the blocker search (step 1).
    pub blocker_samples: u32,
    /// Samples of the percentage-closer filter (step 3).
    pub filter_samples: u32,
    pub kernel: Kernel,
    /// Depth bias in texel footprints at the receiver.
    pub bias_texels: f32,
    /// Smallest filter half extent, in texels (keeps contact shadows anti-aliased).
    pub min_filter_texels: f32,
}

impl Default for PcssSettings {
    fn default() -> Self {
        Self {
            shadow_map_size: 1024,
            blocker_samples: 16,
            filter_samples: 32,
            kernel: Kernel::Vogel,
            bias_texels: 1.5,
            min_filter_texels: 1.0,
        }
    }
}

pub fn param_specs() -> Vec<ParamSpec> {
    let d = PcssSettings::default();
    vec![
        ParamSpec::int(
            "shadow_map_size",
            "Shadow-map edge in texels",
            64,
            4096,
            d.shadow_map_size as i64,
        ),
        ParamSpec::int(
            "blocker_samples",
            "Samples of the blocker search",
            1,
            64,
            d.blocker_samples as i64,
        ),
        ParamSpec::int(
            "filter_samples",
            "Samples of the percentage-closer filter",
            1,
            256,
            d.filter_samples as i64,
        ),
        ParamSpec::choice(
            "kernel",
            "Sample pattern: rotated Vogel disk, or jittered grid over the light rectangle",
            Kernel::NAMES,
            "vogel",
        ),
        ParamSpec::float(
            "bias_texels",
            "Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes)",
            0.0,
            16.0,
            d.bias_texels as f64,
        ),
        ParamSpec::float(
            "min_filter_texels",
            "Smallest filter half extent in texels",
            0.0,
            8.0,
            d.min_filter_texels as f64,
        ),
    ]
}

/// Mirrors `PcssParams` in `shaders/pcss/pcss.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PcssUniform {
    blocker_samples: u32,
    filter_samples: u32,
    kernel: u32,
    _pad0: u32,
    bias_texels: f32,
    min_filter_texels: f32,
    _pad1: [f32; 2],
}

pub struct Pcss {
    pub settings: PcssSettings,
    shadow_map: CentreShadowMap,
    filter: FullscreenPipeline,
    layout: wgpu::BindGroupLayout,
    params_buffer: wgpu::Buffer,
    stats: TechniqueStats,
}

pub fn info() -> TechniqueInfo {
    TechniqueInfo {
        id: ID,
        description: "PCSS: blocker search, penumbra estimate, percentage-closer filtering",
        source: "Fernando 2005",
        params: param_specs,
        create: |gpu| Ok(Box::new(Pcss::new(gpu, PcssSettings::default())?)),
    }
}

impl Pcss {
    pub fn new(gpu: &Gpu, settings: PcssSettings) -> Result<Self, TechniqueError> {
        let layout = CentreShadowMap::lookup_layout(gpu, "pcss/filter");
        Ok(Self {
            shadow_map: CentreShadowMap::new(gpu)?,
            filter: FullscreenPipeline::new(gpu, "pcss/filter", &SHADERS[0], &[], &layout, None)?,
            params_buffer: uniform_buffer(gpu, "pcss/params", &PcssUniform::zeroed()),
            layout,
            settings,
            stats: TechniqueStats::new(),
        })
    }
}

impl ShadowTechnique for Pcss {
    fn id(&self) -> &'static str {
        ID
    }

    fn params(&self) -> ParamSet {
        let s = &self.settings;
        let values = [
            ParamValue::Int(s.shadow_map_size as i64),
            ParamValue::Int(s.blocker_samples as i64),
            ParamValue::Int(s.filter_samples as i64),
            ParamValue::Choice(s.kernel.name().into()),
            ParamValue::Float(s.bias_texels as f64),
            ParamValue::Float(s.min_filter_texels as f64),
        ];
        ParamSet {
            entries: param_specs().into_iter().zip(values).collect(),
        }
    }

    fn set_param(&mut self, name: &str, value: ParamValue) -> Result<(), ParamError> {
        let specs = param_specs();
        let spec = find_spec(ID, &specs, name)?;
        let value = spec.check(value)?;
        let s = &mut self.settings;
        match spec.name {
            "shadow_map_size" => s.shadow_map_size = expect_u32(&value),
            "blocker_samples" => s.blocker_samples = expect_u32(&value),
            "filter_samples" => s.filter_samples = expect_u32(&value),
            "kernel" => s.kernel = Kernel::from_name(expect_choice(&value)),
            "bias_texels" => s.bias_texels = expect_f32(&value),
            "min_filter_texels" => s.min_filter_texels = expect_f32(&value),
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
        let s = &self.settings;
        if self
            .shadow_map
            .render(frame, inputs, s.shadow_map_size, "pcss/shadow_map")
            .is_none()
        {
            out.clear_lit(frame, "pcss/no_casters");
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        }
        let uniform = PcssUniform {
            blocker_samples: s.blocker_samples,
            filter_samples: s.filter_samples,
            kernel: match s.kernel {
                Kernel::Vogel => 0,
                Kernel::Grid => 1,
            },
            _pad0: 0,
            bias_texels: s.bias_texels,
            min_filter_texels: s.min_filter_texels,
            _pad1: [0.0; 2],
        };
        gpu.queue
            .write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&uniform));
        let bind_group = self
            .shadow_map
            .lookup_bind_group(gpu, &self.layout, &self.params_buffer)
            .expect("rendered above");
        self.filter.record(
            frame,
            "pcss/filter",
            inputs.frame_bind_group,
            &bind_group,
            &[],
            &out.view,
            Some(1.0),
        );
        let pixels = inputs.width as f64 * inputs.height as f64;
        self.stats = TechniqueStats::from([
            ("shadow_maps".into(), 1.0),
            (
                "max_texel_reads_per_pixel".into(),
                (s.blocker_samples + s.filter_samples) as f64,
            ),
            ("pixels".into(), pixels),
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
