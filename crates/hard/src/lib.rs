//! `hard`: one shadow map from the light centre and one depth comparison per pixel.
//!
//! Reads: the casters (depth pass) and the G-buffer. Writes: the visibility buffer (0 or 1).
//! It is the floor of every cost comparison and the limit every soft technique must approach as
//! the light shrinks to a point.

#![warn(missing_docs)]

use encase::ShaderType;
use softshadow_core::{
    cascades::SunCascadeParams,
    pass::FullscreenPass,
    shader::ShaderSpec,
    shader_file,
    shadow_map::CentreShadowMap,
    uniform::{uniform_bytes, zeroed_uniform_buffer},
    wgpu, DebugView, Frame, Gpu, LightKind, ShadowInputs, ShadowTechnique, TechniqueError,
    TechniqueSettings, TechniqueStats, VisibilityBuffer,
};

mod info;
mod sun;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "hard";

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "hard/hard.wgsl",
        source: shader_file!("hard/hard.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "hard/sun.wgsl",
        source: shader_file!("hard/sun.wgsl").1,
        permutations: &[&[]],
    },
];

softshadow_core::technique_settings! {
    /// Settings of the `hard` technique.
    pub struct HardSettings {
        ..sun: SunCascadeParams;
        /// Shadow-map edge in texels
        shadow_map_size: u32 = 1024, in 64..=4096;
        /// Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes)
        bias_texels: f32 = 1.5, in 0.0..=16.0;
    }
}

#[derive(ShaderType)]
struct HardParams {
    bias_texels: f32,
}

/// This crate's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![
        softshadow_core::uniform_mirror!(
            HardParams { bias_texels } => "hard/hard.wgsl", HardParams
        ),
        softshadow_core::uniform_mirror!(
            HardParams { bias_texels } => "hard/sun.wgsl", HardParams
        ),
    ]
}

/// The `hard` technique: a [`ShadowTechnique`] with its settings.
pub struct Hard {
    /// Its settings; changes take effect on the next frame.
    pub settings: HardSettings,
    shadow_map: CentreShadowMap,
    lookup: FullscreenPass,
    params_buffer: wgpu::Buffer,
    /// The sun's cascades, made by the first frame under the sun.
    sun: Option<sun::HardSun>,
    stats: TechniqueStats,
}

impl Hard {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: HardSettings) -> Result<Self, TechniqueError> {
        // hard.wgsl: the map's ShadowView, the map, HardParams.
        let lookup =
            CentreShadowMap::lookup_pass(gpu, "hard/lookup", &SHADERS[0]).fullscreen(None)?;
        Ok(Self {
            shadow_map: CentreShadowMap::new(gpu)?.clipped_to_receivers(),
            lookup,
            params_buffer: zeroed_uniform_buffer::<HardParams>(gpu, "hard/params"),
            settings,
            sun: None,
            stats: TechniqueStats::new(),
        })
    }
}

impl Hard {
    /// The sun's frame: its cascades and their lookup (`sun.rs`).
    fn render_sun(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
    ) -> Result<(), TechniqueError> {
        let gpu = frame.gpu;
        if self.sun.is_none() {
            self.sun = Some(sun::HardSun::new(gpu)?);
        }
        let params = HardParams {
            bias_texels: self.settings.bias_texels,
        };
        (gpu.queue).write_buffer(&self.params_buffer, 0, &uniform_bytes(&params));
        let sun = self.sun.as_mut().expect("made above");
        self.stats = sun.render(frame, inputs, &self.settings, &self.params_buffer, out)?;
        Ok(())
    }
}

impl ShadowTechnique for Hard {
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
        if inputs.light.kind == LightKind::Sun {
            return self.render_sun(frame, inputs, out);
        }
        let size = self.settings.shadow_map_size;
        if self
            .shadow_map
            .render(frame, inputs, size, "hard/shadow_map")
            .is_none()
        {
            // No caster in front of the light: receivers in front of it are lit, no lookup needed.
            out.write_unshadowed(frame, inputs.frame_bind_group, "hard/no_casters")?;
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        }
        gpu.queue.write_buffer(
            &self.params_buffer,
            0,
            &uniform_bytes(&HardParams {
                bias_texels: self.settings.bias_texels,
            }),
        );
        let (lookup, params, group) = (&self.lookup, &self.params_buffer, inputs.frame_bind_group);
        (self.shadow_map).draw_lookup(
            frame,
            lookup,
            "hard/lookup",
            group,
            params,
            &out.view,
            Some(1.0),
        );
        self.stats = TechniqueStats::from([
            ("shadow_maps".into(), 1.0),
            ("shadow_map_texels".into(), (size as f64) * (size as f64)),
        ]);
        Ok(())
    }

    fn invalidate_cache(&mut self) {
        self.shadow_map.invalidate();
        if let Some(sun) = &mut self.sun {
            sun.invalidate();
        }
    }

    fn stats(&self) -> TechniqueStats {
        self.stats.clone()
    }

    fn debug_views(&self) -> Vec<DebugView> {
        self.shadow_map.debug_views()
    }
}
