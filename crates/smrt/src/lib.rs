//! `smrt`: shadow-map ray tracing, after the description of Unreal Engine 5's virtual shadow
//! maps (`r.Shadow.Virtual.SMRT.*`; there is no paper). Per pixel, `ray_count` rays from the
//! receiver point to jittered points of the light rectangle, each marched through one shadow map
//! from the light centre in `samples_per_ray` steps, with the behind-occluder extrapolation that
//! lets a single map give penumbrae (docs/TECHNIQUES.md, `smrt`).
//!
//! Reads: the casters (one shadow map from the light centre) and the G-buffer.
//! Writes: the visibility buffer. Passes: `smrt/shadow_map` (kept while only the camera moves),
//! `smrt/trace` (every ray of every pixel in one fullscreen pass), and `smrt/debug` only while
//! the viewer shows one of its debug views. Under the sun: core's cascades, rays over the sun's
//! cone (`sun.rs`).

#![warn(missing_docs)]

use encase::ShaderType;
use softshadow_core::{
    cascades::SunCascadeParams,
    pass::FullscreenPass,
    shader::{DefValue, ShaderSpec},
    shader_file,
    shadow_map::CentreShadowMap,
    uniform::{uniform_bytes, zeroed_uniform_buffer},
    wgpu, DebugLegend, DebugView, Frame, Gpu, LightKind, ShadowInputs, ShadowTechnique,
    TechniqueError, TechniqueSettings, TechniqueStats, VisibilityBuffer,
};

mod info;
mod sun;
pub use info::info;

/// The technique's id (command line, JSON, GUI).
pub const ID: &str = "smrt";

const DEBUG_STEPS: (&str, DefValue) = ("DEBUG_STEPS", DefValue::Bool(true));
const DEBUG_EXTRAPOLATED: (&str, DefValue) = ("DEBUG_EXTRAPOLATED", DefValue::Bool(true));

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[ShaderSpec {
    path: "smrt/smrt.wgsl",
    source: shader_file!("smrt/smrt.wgsl").1,
    permutations: &[
        &[],
        &[DEBUG_STEPS],
        &[DEBUG_EXTRAPOLATED],
        &[("SUN", DefValue::Bool(true))],
    ],
}];

/// Debug view: samples marched per pixel, all rays together.
pub const STEPS_VIEW: &str = "marched_steps";
/// Debug view: fraction of the pixel's rays that the behind-occluder extrapolation occluded.
pub const EXTRAPOLATED_VIEW: &str = "extrapolated_hits";

softshadow_core::technique_settings! {
    /// Settings of shadow-map ray tracing. The ray and sample counts are Unreal's
    /// `RayCountLocal` / `SamplesPerRayLocal` (there 7 and 8, with a temporal denoiser behind
    /// them); here 32 rays, since nothing denoises.
    pub struct SmrtSettings {
        ..sun: SunCascadeParams;
        /// Shadow-map edge in texels
        shadow_map_size: u32 = 1024, in 64..=4096;
        /// Rays per pixel, to points of the light rectangle (Unreal: r.Shadow.Virtual.SMRT.RayCountLocal)
        ray_count: u32 = 32, in 1..=64;
        /// Steps marched along each ray, uniformly in the map's slopes, the last at the receiver end (Unreal: SamplesPerRayLocal)
        samples_per_ray: u32 = 8, in 1..=64;
        /// Largest depth slope (depth per unit of ray depth) of the surface extrapolated behind an occluder (Unreal: ExtrapolateMaxSlopeLocal); 0 extrapolates at constant depth
        extrapolate_max_slope: f32 = 1.0, in 0.0..=100.0;
        /// Part of the ray marched, from the receiver towards the map's near plane (Unreal: RayLengthScale); below 1 misses casters near the light
        ray_length_scale: f32 = 1.0, in 0.01..=1.0;
        /// Largest angle in degrees a ray spans as seen from the light (its slope extent in the map), the light end cut off (Unreal: MaxRayAngleFromLight); 90 is no limit
        max_ray_angle: f32 = 90.0, in 0.0..=90.0;
        /// Per-ray dither of the receiver end, in shadow-map texels (Unreal: TexelDitherScale)
        texel_dither: f32 = 1.0, in 0.0..=8.0;
        /// Depth bias in texel footprints at each step's depth (scaled by 1/cos on slopes)
        bias_texels: f32 = 1.5, in 0.0..=16.0;
    }
}

#[derive(ShaderType)]
struct SmrtUniform {
    ray_count: u32,
    samples_per_ray: u32,
    bias_texels: f32,
    extrapolate_max_slope: f32,
    ray_length_scale: f32,
    texel_dither: f32,
    max_ray_tan: f32,
}

/// This crate's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![softshadow_core::uniform_mirror!(
        SmrtUniform {
            ray_count, samples_per_ray, bias_texels, extrapolate_max_slope, ray_length_scale,
            texel_dither, max_ray_tan
        } => "smrt/smrt.wgsl", SmrtParams
    )]
}

impl SmrtUniform {
    fn new(s: &SmrtSettings) -> Self {
        // 90 degrees (or more) is no limit; tan would be huge or negative near it.
        let max_ray_tan = if s.max_ray_angle >= 89.99 {
            1e30
        } else {
            s.max_ray_angle.max(0.0).to_radians().tan()
        };
        Self {
            ray_count: s.ray_count,
            samples_per_ray: s.samples_per_ray,
            bias_texels: s.bias_texels,
            extrapolate_max_slope: s.extrapolate_max_slope,
            ray_length_scale: s.ray_length_scale,
            texel_dither: s.texel_dither,
            max_ray_tan,
        }
    }
}

/// The debug image (screen sized, `R32Float`), drawn only while a debug view is shown.
struct DebugImage {
    size: (u32, u32),
    texture: wgpu::Texture,
    view: wgpu::TextureView,
}

/// The `smrt` technique: a [`ShadowTechnique`] with its settings.
pub struct Smrt {
    /// Its settings; changes take effect on the next frame.
    pub settings: SmrtSettings,
    shadow_map: CentreShadowMap,
    trace: FullscreenPass,
    /// The trace writing the marched steps, and the extrapolated fraction: permutations, so the
    /// visibility pass carries no debug code (docs/DEVICES.md, "Lavapipe's branches").
    debug_steps: FullscreenPass,
    debug_extrapolated: FullscreenPass,
    params_buffer: wgpu::Buffer,
    debug: Option<DebugImage>,
    /// The debug view the viewer shows, if one of ours.
    shown: Option<&'static str>,
    /// The sun's cascades, made by the first frame under the sun.
    sun: Option<sun::SmrtSun>,
    stats: TechniqueStats,
}

impl Smrt {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: SmrtSettings) -> Result<Self, TechniqueError> {
        let pipeline = |label, defs: &[(&str, DefValue)]| {
            CentreShadowMap::lookup_pass(gpu, label, &SHADERS[0])
                .defs(defs)
                .fullscreen(None)
        };
        Ok(Self {
            shadow_map: CentreShadowMap::new(gpu)?,
            trace: pipeline("smrt/trace", &[])?,
            debug_steps: pipeline("smrt/debug steps", &[DEBUG_STEPS])?,
            debug_extrapolated: pipeline("smrt/debug extrapolated", &[DEBUG_EXTRAPOLATED])?,
            params_buffer: zeroed_uniform_buffer::<SmrtUniform>(gpu, "smrt/params"),
            debug: None,
            shown: None,
            sun: None,
            settings,
            stats: TechniqueStats::new(),
        })
    }

    /// Makes the debug image of `width` x `height` (again, when the size changed).
    fn ensure_debug_image(&mut self, gpu: &Gpu, width: u32, height: u32) {
        if self
            .debug
            .as_ref()
            .is_none_or(|d| d.size != (width, height))
        {
            let texture = softshadow_core::gbuffer::create_texture(
                gpu,
                "smrt/debug",
                width,
                height,
                wgpu::TextureFormat::R32Float,
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
            );
            let view = texture.create_view(&Default::default());
            self.debug = Some(DebugImage {
                size: (width, height),
                texture,
                view,
            });
        }
    }
}

impl ShadowTechnique for Smrt {
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
        let s = self.settings.clone();
        if inputs.light.kind == LightKind::Sun {
            if self.sun.is_none() {
                self.sun = Some(sun::SmrtSun::new(gpu)?);
            }
            let uniform = uniform_bytes(&SmrtUniform::new(&s));
            gpu.queue.write_buffer(&self.params_buffer, 0, &uniform);
            let sun = self.sun.as_mut().expect("made above");
            self.stats = sun.render(frame, inputs, &s, &self.params_buffer, out)?;
            return Ok(());
        }
        if self
            .shadow_map
            .render(frame, inputs, s.shadow_map_size, "smrt/shadow_map")
            .is_none()
        {
            out.write_unshadowed(frame, inputs.frame_bind_group, "smrt/no_casters")?;
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        }
        gpu.queue.write_buffer(
            &self.params_buffer,
            0,
            &uniform_bytes(&SmrtUniform::new(&s)),
        );
        let (map, params) = (&self.shadow_map, &self.params_buffer);
        let group = inputs.frame_bind_group;
        map.draw_lookup(
            frame,
            &self.trace,
            "smrt/trace",
            group,
            params,
            &out.view,
            Some(1.0),
        );
        // The debug image exists from the first frame (the views must be listed to be chosen;
        // one R32Float image of the screen), but is drawn only while a view is shown.
        self.ensure_debug_image(gpu, inputs.width, inputs.height);
        if let Some(shown) = self.shown {
            let pipeline = if shown == STEPS_VIEW {
                &self.debug_steps
            } else {
                &self.debug_extrapolated
            };
            let target = &self.debug.as_ref().expect("made above").view;
            let (map, params) = (&self.shadow_map, &self.params_buffer);
            map.draw_lookup(
                frame,
                pipeline,
                "smrt/debug",
                group,
                params,
                target,
                Some(0.0),
            );
        }
        let rays = s.ray_count.clamp(1, 64) as f64;
        let samples = s.samples_per_ray.clamp(1, 64) as f64;
        let pixels = inputs.width as f64 * inputs.height as f64;
        self.stats = TechniqueStats::from([
            ("shadow_maps".into(), 1.0),
            ("rays_per_pixel".into(), rays),
            ("max_steps_per_pixel".into(), rays * samples),
            ("max_texel_reads_per_pixel".into(), rays * samples),
            ("pixels".into(), pixels),
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

    fn show_debug_view(&mut self, name: Option<&str>) {
        self.shown = match name {
            Some(STEPS_VIEW) => Some(STEPS_VIEW),
            Some(EXTRAPOLATED_VIEW) => Some(EXTRAPOLATED_VIEW),
            _ => None,
        };
    }

    fn debug_views(&self) -> Vec<DebugView> {
        let mut views = self.shadow_map.debug_views();
        if let Some(debug) = &self.debug {
            views.push(DebugView::new(
                STEPS_VIEW,
                &debug.texture,
                DebugLegend::value(
                    "samples marched per pixel, all rays (a ray stops at its first hit)",
                ),
            ));
            views.push(DebugView::new(
                EXTRAPOLATED_VIEW,
                &debug.texture,
                DebugLegend::value(
                    "fraction of rays occluded by the behind-occluder extrapolation (not by crossing a surface)",
                ),
            ));
        }
        views
    }
}
