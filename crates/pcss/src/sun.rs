//! `pcss` under the sun: the cascaded orthographic maps of [`SunCascades`] (core's `cascades`;
//! one map fitted to the scene with `cascades` = 1), searched and filtered in world units
//! (`shaders/pcss/sun.wgsl`), so the penumbra keeps its width across cascade boundaries.

use softshadow_core::{
    cascades::SunCascades, pass::FullscreenPass, shader::DefValue, wgpu, Frame, Gpu, ShadowInputs,
    TechniqueError, TechniqueStats, VisibilityBuffer,
};

use crate::{Kernel, PcssSettings, SHADERS};

/// The sun's maps and the passes that read them (one per kernel).
pub(crate) struct PcssSun {
    cascades: SunCascades,
    filter_vogel: FullscreenPass,
    filter_grid: FullscreenPass,
}

impl PcssSun {
    pub(crate) fn new(gpu: &Gpu) -> Result<Self, TechniqueError> {
        // sun.wgsl: the Cascades uniform, the maps, PcssParams.
        let pass = |label: &str, defs: &[(&str, DefValue)]| {
            SunCascades::lookup_pass(gpu, label, &SHADERS[2])
                .defs(defs)
                .fullscreen(None)
        };
        Ok(Self {
            cascades: SunCascades::new(gpu)?,
            filter_vogel: pass("pcss/filter", &[])?,
            filter_grid: pass("pcss/filter grid", &[("KERNEL_GRID", DefValue::Bool(true))])?,
        })
    }

    /// Draws the cascades (`pcss/shadow_map/<i>`) and the filter (`pcss/filter`) with `params`
    /// (the `PcssParams` buffer, written). The temporal mode is not applied under the sun.
    pub(crate) fn render(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        settings: &PcssSettings,
        params: &wgpu::Buffer,
        out: &VisibilityBuffer,
    ) -> Result<TechniqueStats, TechniqueError> {
        let size = settings.shadow_map_size;
        let sun = ("pcss", &settings.sun, size);
        let Some(fit) = (self.cascades).render_or_lit(frame, inputs, sun, out)? else {
            return Ok(TechniqueStats::from([("shadow_maps".into(), 0.0)]));
        };
        let pass = match settings.kernel {
            Kernel::Vogel => &self.filter_vogel,
            Kernel::Grid => &self.filter_grid,
        };
        let group = inputs.frame_bind_group;
        let target = &out.view;
        (self.cascades).draw_lookup(frame, pass, "pcss/filter", group, params, target, Some(1.0));
        let samples = settings.blocker_samples + settings.filter_samples;
        let mut stats = fit.stats(size);
        // Two cascades' searches and filters in the blend bands.
        stats.insert("max_texel_reads_per_pixel".into(), 2.0 * samples as f64);
        stats.insert("pixels".into(), inputs.width as f64 * inputs.height as f64);
        Ok(stats)
    }

    pub(crate) fn invalidate(&mut self) {
        self.cascades.invalidate();
    }
}
