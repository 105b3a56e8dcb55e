//! `pcss`: percentage-closer soft shadows (Fernando 2005, "Percentage-closer soft shadows").
//!
//! Reads: the casters (one shadow map from the light centre) and the G-buffer.
//! Writes: the visibility buffer. Passes: `pcss/shadow_map`, `pcss/filter` (blocker search,
//! penumbra estimate and percentage-closer filtering in one fullscreen pass).

#![warn(missing_docs)]

use bytemuck::{Pod, Zeroable};
use softshadow_core::{
    fullscreen::{uniform_buffer, FullscreenPipeline},
    shader::{DefValue, ShaderSpec},
    shader_file,
    shadow_map::CentreShadowMap,
    wgpu, DebugView, Frame, Gpu, ShadowInputs, ShadowTechnique, TechniqueError, TechniqueSettings,
    TechniqueStats, VisibilityBuffer,
};

mod info;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "pcss";

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[ShaderSpec {
    path: "pcss/pcss.wgsl",
    source: shader_file!("pcss/pcss.wgsl").1,
    permutations: &[&[], &[("KERNEL_GRID", DefValue::Bool(true))]],
}];

softshadow_core::param_choice! {
    /// Filter kernel shape.
    pub enum Kernel {
        /// Vogel (golden-angle) disk rotated per pixel: what engines ship.
        Vogel = "vogel",
        /// Jittered grid over the light's rectangle: exact for a planar occluder parallel to the
        /// light when the blocker depth is right (a box filter of the penumbra width gives the
        /// linear ramp).
        Grid = "grid",
    }
}

softshadow_core::technique_settings! {
    /// Settings of PCSS. Defaults follow common engine practice (16 blocker, 32 filter samples).
    pub struct PcssSettings {
        /// Shadow-map edge in texels
        shadow_map_size: u32 = 1024, in 64..=4096;
        /// Samples of the blocker search
        blocker_samples: u32 = 16, in 1..=64;
        /// Samples of the percentage-closer filter
        filter_samples: u32 = 32, in 1..=256;
        /// Sample pattern: rotated Vogel disk, or jittered grid over the light rectangle
        kernel: Kernel = Kernel::Vogel;
        /// Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes)
        bias_texels: f32 = 1.5, in 0.0..=16.0;
        /// Smallest filter half extent in texels
        min_filter_texels: f32 = 1.0, in 0.0..=8.0;
    }
}

/// Mirrors `PcssParams` in `shaders/pcss/pcss.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PcssUniform {
    blocker_samples: u32,
    filter_samples: u32,
    _pad0: [u32; 2],
    bias_texels: f32,
    min_filter_texels: f32,
    _pad1: [f32; 2],
}

/// The `pcss` technique: a [`ShadowTechnique`] with its settings.
pub struct Pcss {
    /// Its settings; changes take effect on the next frame.
    pub settings: PcssSettings,
    shadow_map: CentreShadowMap,
    /// The lookup with the Vogel kernel, and with the grid (`KERNEL_GRID`): one pipeline per
    /// kernel (docs/ARCHITECTURE.md, "Lavapipe's branches").
    filter_vogel: FullscreenPipeline,
    filter_grid: FullscreenPipeline,
    layout: wgpu::BindGroupLayout,
    params_buffer: wgpu::Buffer,
    stats: TechniqueStats,
}

impl Pcss {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: PcssSettings) -> Result<Self, TechniqueError> {
        let layout = CentreShadowMap::lookup_layout(gpu, "pcss/filter");
        Ok(Self {
            shadow_map: CentreShadowMap::new(gpu)?,
            filter_vogel: FullscreenPipeline::new(
                gpu,
                "pcss/filter",
                &SHADERS[0],
                &[],
                &layout,
                None,
            )?,
            filter_grid: FullscreenPipeline::new(
                gpu,
                "pcss/filter grid",
                &SHADERS[0],
                &[("KERNEL_GRID", DefValue::Bool(true))],
                &layout,
                None,
            )?,
            params_buffer: uniform_buffer(gpu, "pcss/params", &PcssUniform::zeroed()),
            layout,
            settings,
            stats: TechniqueStats::new(),
        })
    }
}

impl ShadowTechnique for Pcss {
    fn id(&self) -> &str {
        ID
    }

    fn settings(&self) -> &dyn TechniqueSettings {
        &self.settings
    }

    fn settings_mut(&mut self) -> &mut dyn TechniqueSettings {
        &mut self.settings
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
            out.write_unshadowed(frame, inputs.frame_bind_group, "pcss/no_casters")?;
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        }
        let uniform = PcssUniform {
            blocker_samples: s.blocker_samples,
            filter_samples: s.filter_samples,
            _pad0: [0; 2],
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
        let filter = match s.kernel {
            Kernel::Vogel => &self.filter_vogel,
            Kernel::Grid => &self.filter_grid,
        };
        filter.record(
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

    fn invalidate_cache(&mut self) {
        self.shadow_map.invalidate();
    }

    fn stats(&self) -> TechniqueStats {
        self.stats.clone()
    }

    fn debug_views(&self) -> Vec<DebugView> {
        self.shadow_map.debug_views()
    }
}
