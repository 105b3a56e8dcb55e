//! `hard` under the sun: the cascaded orthographic maps of [`SunCascades`] (core's
//! `cascades`; one map fitted to the scene with `cascades` = 1) and one depth comparison per
//! pixel in its cascade (`shaders/hard/sun.wgsl`).

use softshadow_core::{
    cascades::SunCascades, pass::FullscreenPass, wgpu, Frame, Gpu, ShadowInputs, TechniqueError,
    TechniqueStats, VisibilityBuffer,
};

use crate::{HardSettings, SHADERS};

/// The sun's maps and the pass that reads them.
pub(crate) struct HardSun {
    cascades: SunCascades,
    lookup: FullscreenPass,
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
        let sun = ("hard", &settings.sun, size);
        let Some(fit) = (self.cascades).render_or_lit(frame, inputs, sun, out)? else {
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
        Ok(fit.stats(size))
    }

    pub(crate) fn invalidate(&mut self) {
        self.cascades.invalidate();
    }
}
