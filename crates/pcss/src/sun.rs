//! `pcss` under the sun: the cascaded orthographic maps of [`SunCascades`] (core's `cascades`;
//! one map fitted to the scene with `cascades` = 1), searched and filtered in world units
//! (`shaders/pcss/sun.wgsl`), so the penumbra keeps its width across cascade boundaries.

use softshadow_core::{
    cascades::{CascadeSettings, SunCascades},
    pass::FullscreenPass,
    shader::DefValue,
    wgpu, Frame, Gpu, ShadowInputs, TechniqueError, TechniqueStats, VisibilityBuffer,
};

use crate::{Kernel, PcssSettings, SHADERS};

/// The sun's maps and the passes that read them (one per kernel).
pub(crate) struct PcssSun {
    cascades: SunCascades,
    filter_vogel: FullscreenPass,
    filter_grid: FullscreenPass,
}

impl PcssSettings {
    /// The cascades these settings ask for.
    pub fn cascade_settings(&self) -> CascadeSettings {
        CascadeSettings {
            count: self.cascades,
            lambda: self.cascade_lambda,
            blend: self.cascade_blend,
            snap: self.cascade_snap,
            ..CascadeSettings::default()
        }
    }
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
        let cascade_settings = settings.cascade_settings();
        let Some(fit) =
            (self.cascades).render(frame, inputs, &cascade_settings, size, "pcss/shadow_map")
        else {
            out.write_unshadowed(frame, inputs.frame_bind_group, "pcss/no_casters")?;
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
        let mut stats = TechniqueStats::from([
            ("shadow_maps".into(), fit.cascades.len() as f64),
            // Two cascades' searches and filters in the blend bands.
            ("max_texel_reads_per_pixel".into(), 2.0 * samples as f64),
            ("pixels".into(), inputs.width as f64 * inputs.height as f64),
        ]);
        for (i, c) in fit.cascades.iter().enumerate() {
            stats.insert(format!("cascade{i}_texel_m"), c.texel_world as f64);
            stats.insert(format!("cascade{i}_far_m"), c.split_far as f64);
        }
        Ok(stats)
    }

    pub(crate) fn invalidate(&mut self) {
        self.cascades.invalidate();
    }
}

#[cfg(test)]
mod tests {
    use softshadow_core::cascades::CASCADE_PARAMS;

    use super::*;

    /// The viewer shows the cascades' parameters under the sun only, by these names.
    #[test]
    fn the_cascade_parameters_are_the_ones_core_names() {
        let specs = PcssSettings::param_specs();
        for name in CASCADE_PARAMS {
            assert!(specs.iter().any(|s| s.name == name), "{name}");
        }
    }
}
