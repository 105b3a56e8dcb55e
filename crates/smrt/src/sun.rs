//! `smrt` under the sun: core's cascaded orthographic maps ([`SunCascades`]; one map fitted to
//! the scene with `cascades` = 1), each ray toward a direction of the sun's cone marched through
//! the point's cascade (`shaders/smrt/smrt.wgsl`, `SUN`).

use softshadow_core::{
    cascades::SunCascades, pass::FullscreenPass, shader::DefValue, wgpu, Frame, Gpu, ShadowInputs,
    TechniqueError, TechniqueStats, VisibilityBuffer,
};

use crate::{SmrtSettings, SHADERS};

/// The sun's maps and the pass that marches them.
pub(crate) struct SmrtSun {
    cascades: SunCascades,
    trace: FullscreenPass,
}

impl SmrtSun {
    pub(crate) fn new(gpu: &Gpu) -> Result<Self, TechniqueError> {
        // smrt.wgsl (SUN): the Cascades uniform, the maps, SmrtParams.
        let trace = SunCascades::lookup_pass(gpu, "smrt/trace", &SHADERS[0])
            .defs(&[("SUN", DefValue::Bool(true))])
            .fullscreen(None)?;
        Ok(Self {
            cascades: SunCascades::new(gpu)?,
            trace,
        })
    }

    /// Draws the cascades (`smrt/shadow_map/<i>`) and the trace (`smrt/trace`) with `params`
    /// (the `SmrtParams` buffer, written). The debug views are not drawn under the sun.
    pub(crate) fn render(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        settings: &SmrtSettings,
        params: &wgpu::Buffer,
        out: &VisibilityBuffer,
    ) -> Result<TechniqueStats, TechniqueError> {
        let size = settings.shadow_map_size;
        let sun = ("smrt", &settings.sun, size);
        let Some(fit) = (self.cascades).render_or_lit(frame, inputs, sun, out)? else {
            return Ok(TechniqueStats::from([("shadow_maps".into(), 0.0)]));
        };
        let group = inputs.frame_bind_group;
        let target = &out.view;
        (self.cascades).draw_lookup(
            frame,
            &self.trace,
            "smrt/trace",
            group,
            params,
            target,
            Some(1.0),
        );
        let rays = settings.ray_count.clamp(1, 64) as f64;
        let samples = settings.samples_per_ray.clamp(1, 64) as f64;
        let mut stats = fit.stats(size);
        // Two cascades' rays in the blend bands.
        stats.insert("rays_per_pixel".into(), rays);
        stats.insert("max_steps_per_pixel".into(), 2.0 * rays * samples);
        stats.insert("max_texel_reads_per_pixel".into(), 2.0 * rays * samples);
        stats.insert("pixels".into(), inputs.width as f64 * inputs.height as f64);
        Ok(stats)
    }

    pub(crate) fn invalidate(&mut self) {
        self.cascades.invalidate();
    }
}
