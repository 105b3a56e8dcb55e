//! `hard` under the sun: the cascaded orthographic maps of [`SunCascades`] (core's
//! `cascades`; one map fitted to the scene with `cascades` = 1) and one depth comparison per
//! pixel in its cascade (`shaders/hard/sun.wgsl`).

use softshadow_core::{
    cascades::{CascadeSettings, SunCascades},
    pass::FullscreenPass,
    wgpu, Frame, Gpu, ShadowInputs, TechniqueError, TechniqueStats, VisibilityBuffer,
};

use crate::{HardSettings, SHADERS};

/// The sun's maps and the pass that reads them.
pub(crate) struct HardSun {
    cascades: SunCascades,
    lookup: FullscreenPass,
}

impl HardSettings {
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

impl HardSun {
    pub(crate) fn new(gpu: &Gpu) -> Result<Self, TechniqueError> {
        // sun.wgsl: the Cascades uniform, the maps, HardParams.
        let lookup = SunCascades::lookup_pass(gpu, "hard/lookup", &SHADERS[1]).fullscreen(None)?;
        Ok(Self {
            cascades: SunCascades::new(gpu)?,
            lookup,
        })
    }

    /// Draws the cascades (`hard/shadow_map/<i>`) and the lookup (`hard/lookup`) with `params`
    /// (the `HardParams` buffer, written).
    pub(crate) fn render(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        settings: &HardSettings,
        params: &wgpu::Buffer,
        out: &VisibilityBuffer,
    ) -> Result<TechniqueStats, TechniqueError> {
        let size = settings.shadow_map_size;
        let cascade_settings = settings.cascade_settings();
        let Some(fit) =
            (self.cascades).render(frame, inputs, &cascade_settings, size, "hard/shadow_map")
        else {
            out.write_unshadowed(frame, inputs.frame_bind_group, "hard/no_casters")?;
            return Ok(TechniqueStats::from([("shadow_maps".into(), 0.0)]));
        };
        let group = inputs.frame_bind_group;
        (self.cascades).draw_lookup(
            frame,
            &self.lookup,
            "hard/lookup",
            group,
            params,
            &out.view,
            Some(1.0),
        );
        let maps = fit.cascades.len() as f64;
        let mut stats = TechniqueStats::from([
            ("shadow_maps".into(), maps),
            ("shadow_map_texels".into(), maps * (size as f64).powi(2)),
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
        let specs = HardSettings::param_specs();
        for name in CASCADE_PARAMS {
            assert!(specs.iter().any(|s| s.name == name), "{name}");
        }
    }
}
