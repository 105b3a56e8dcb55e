//! `msm`: moment soft shadows. A moment shadow map (Peters and Klein 2015, "Moment Shadow
//! Mapping": four moments of depth per texel, Hamburger reconstruction with moment bias) used
//! for PCSS-style soft shadows (Peters et al. 2016, "Beyond Hard Shadows": blocker search and
//! filter both over filtered moments), with the exponential variance shadow map (EVSM, two or
//! four components) as the cheaper member of the filterable family, and the light-bleeding
//! reduction engines expose.
//!
//! Reads: the casters (one shadow map from the light centre) and the G-buffer.
//! Writes: the visibility buffer. Passes: `msm/shadow_map`, `msm/moments` (the moment map),
//! `msm/mips` (its mip chain, one pass per level), `msm/filter` (blocker search, penumbra
//! estimate and filter in one fullscreen pass). The first three are kept while only the camera
//! moves. Under the sun: core's cascades with a moment map per cascade (`sun.rs`).

#![warn(missing_docs)]

use encase::ShaderType;
use softshadow_core::{
    cascades::SunCascadeParams,
    glam::Vec2,
    pass::{FullscreenPass, Pass, Slot},
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
pub const ID: &str = "msm";

const EVSM: (&str, DefValue) = ("EVSM", DefValue::Bool(true));
const EVSM4: (&str, DefValue) = ("EVSM4", DefValue::Bool(true));
/// The sun's cascades (`sun.rs`).
const SUN: (&str, DefValue) = ("SUN", DefValue::Bool(true));

/// The technique's WGSL entry files and their permutations (validated by the workspace's naga test).
pub const SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "msm/moments.wgsl",
        source: shader_file!("msm/moments.wgsl").1,
        permutations: &[&[], &[EVSM], &[SUN], &[SUN, EVSM]],
    },
    ShaderSpec {
        path: "msm/downsample.wgsl",
        source: shader_file!("msm/downsample.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "msm/msm.wgsl",
        source: shader_file!("msm/msm.wgsl").1,
        permutations: &[
            &[],
            &[EVSM],
            &[EVSM, EVSM4],
            &[SUN],
            &[SUN, EVSM],
            &[SUN, EVSM, EVSM4],
        ],
    },
];

/// EVSM warp exponents (positive, negative): the largest that keep the squared positive warp of
/// depth in [-1, 1] finite in 32-bit floats (e^80 < 3.4e38) with room for the mip sums.
pub const EVSM_EXPONENTS: [f32; 2] = [40.0, 5.0];

/// Format of the moment map: four 32-bit moments (the 2015 paper's 16-bit quantisation is not
/// needed here).
const MOMENT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

softshadow_core::param_choice! {
    /// Which filterable shadow map.
    pub enum Variant {
        /// Moment shadow map: four moments, Hamburger reconstruction (Peters and Klein 2015).
        Msm4 = "msm4",
        /// Exponential variance shadow map, positive warp only (two moments) in the final test;
        /// the blocker search reads the negative warp, so the map holds four.
        Evsm2 = "evsm2",
        /// Exponential variance shadow map, positive and negative warps (four moments).
        Evsm4 = "evsm4",
    }
}

softshadow_core::technique_settings! {
    /// Settings of moment soft shadows.
    pub struct MsmSettings {
        ..sun: SunCascadeParams;
        /// Filterable shadow map: 4-moment Hamburger (msm4), or EVSM with two or four components
        variant: Variant = Variant::Msm4;
        /// Shadow-map and moment-map edge in texels
        shadow_map_size: u32 = 512, in 64..=4096;
        /// Moment bias: weight of a wide distribution mixed into the moments (3e-5 in Peters and Klein 2015 for 32-bit floats); for EVSM the smallest depth standard deviation
        moment_bias: f32 = 3e-5, in 0.0..=0.01;
        /// Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes)
        bias_texels: f32 = 1.5, in 0.0..=16.0;
        /// Light-bleeding reduction: lit fractions below it become 0, the rest is rescaled to [0, 1] (0.05: darkens the filter's slight overshoot at umbra edges; engines ship 0.1-0.3 for VSM)
        light_bleeding_reduction: f32 = 0.05, in 0.0..=0.95;
        /// Blocker-search rectangle as a fraction of the light seen through the receiver down to the near plane
        blocker_search_scale: f32 = 1.0, in 0.05..=1.0;
        /// Taps per axis of each filtered-moment lookup (trilinear in the mip chain)
        filter_taps: u32 = 4, in 1..=8;
        /// Smallest filter half extent in texels
        min_filter_texels: f32 = 1.0, in 0.0..=8.0;
    }
}

#[derive(ShaderType)]
struct MsmUniform {
    depth_range: Vec2,
    exponents: Vec2,
    moment_bias: f32,
    light_bleeding_reduction: f32,
    bias_texels: f32,
    blocker_search_scale: f32,
    min_filter_texels: f32,
    filter_taps: u32,
    levels: u32,
}

/// This crate's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![
        softshadow_core::uniform_mirror!(
            MsmUniform {
                depth_range, exponents, moment_bias, light_bleeding_reduction, bias_texels,
                blocker_search_scale, min_filter_texels, filter_taps, levels
            } => "msm/moments.wgsl", MsmParams
        ),
        softshadow_core::uniform_mirror!(
            MsmUniform {
                depth_range, exponents, moment_bias, light_bleeding_reduction, bias_texels,
                blocker_search_scale, min_filter_texels, filter_taps, levels
            } => "msm/msm.wgsl", MsmParams
        ),
    ]
}

impl MsmUniform {
    /// The uniform of `s` with light-space depths `depth_range` mapped to 0 and 1 (unused under
    /// the sun: each cascade maps its own near..far).
    fn new(s: &MsmSettings, depth_range: Vec2) -> Self {
        Self {
            depth_range,
            exponents: Vec2::from(EVSM_EXPONENTS),
            moment_bias: s.moment_bias,
            light_bleeding_reduction: s.light_bleeding_reduction,
            bias_texels: s.bias_texels,
            blocker_search_scale: s.blocker_search_scale,
            min_filter_texels: s.min_filter_texels,
            filter_taps: s.filter_taps,
            levels: s.shadow_map_size.ilog2() + 1,
        }
    }
}

/// The moment map with its mip chain.
struct MomentMap {
    size: u32,
    evsm: bool,
    texture: wgpu::Texture,
    /// One view per level (render targets, and the downsampling's sources).
    levels: Vec<wgpu::TextureView>,
    /// Every level, as the filter reads them.
    all_levels: wgpu::TextureView,
}

impl MomentMap {
    fn new(gpu: &Gpu, size: u32, evsm: bool) -> Self {
        let level_count = size.ilog2() + 1;
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("msm/moment_map"),
            size: wgpu::Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: 1,
            },
            mip_level_count: level_count,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: MOMENT_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let levels: Vec<wgpu::TextureView> = (0..level_count)
            .map(|level| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("msm/moment_map level"),
                    base_mip_level: level,
                    mip_level_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        Self {
            size,
            evsm,
            all_levels: texture.create_view(&Default::default()),
            texture,
            levels,
        }
    }
}

/// The `msm` technique: a [`ShadowTechnique`] with its settings.
pub struct Msm {
    /// Its settings; changes take effect on the next frame.
    pub settings: MsmSettings,
    shadow_map: CentreShadowMap,
    /// The moment map pass: four moments, and EVSM's warped moments (`EVSM`).
    moments_msm: FullscreenPass,
    moments_evsm: FullscreenPass,
    downsample: FullscreenPass,
    /// The filter per variant: one pipeline each (docs/DEVICES.md, "Lavapipe's branches").
    filter_msm4: FullscreenPass,
    filter_evsm2: FullscreenPass,
    filter_evsm4: FullscreenPass,
    params_buffer: wgpu::Buffer,
    moment_map: Option<MomentMap>,
    /// The sun's cascades and moment maps, made by the first frame under the sun.
    sun: Option<sun::MsmSun>,
    stats: TechniqueStats,
}

impl Msm {
    /// Builds the technique's pipelines on `gpu` with `settings`.
    pub fn new(gpu: &Gpu, settings: MsmSettings) -> Result<Self, TechniqueError> {
        let moments = |label, defs: &[(&str, DefValue)]| {
            CentreShadowMap::lookup_pass(gpu, label, &SHADERS[0])
                .defs(defs)
                .fullscreen_into(MOMENT_FORMAT, None)
        };
        // msm.wgsl: the map's ShadowView, the moment map's levels, MsmParams.
        let filter = |label, defs: &[(&str, DefValue)]| {
            Pass::new(gpu, label, &SHADERS[2])
                .defs(defs)
                .after_frame_group()
                .uniform()
                .texture(Slot::FLOAT)
                .uniform()
                .fullscreen(None)
        };
        Ok(Self {
            shadow_map: CentreShadowMap::new(gpu)?,
            moments_msm: moments("msm/moments", &[])?,
            moments_evsm: moments("msm/moments evsm", &[EVSM])?,
            // downsample.wgsl: the level above.
            downsample: Pass::new(gpu, "msm/mips", &SHADERS[1])
                .after_frame_group()
                .texture(Slot::FLOAT)
                .fullscreen_into(MOMENT_FORMAT, None)?,
            filter_msm4: filter("msm/filter", &[])?,
            filter_evsm2: filter("msm/filter evsm2", &[EVSM])?,
            filter_evsm4: filter("msm/filter evsm4", &[EVSM, EVSM4])?,
            params_buffer: zeroed_uniform_buffer::<MsmUniform>(gpu, "msm/params"),
            moment_map: None,
            sun: None,
            settings,
            stats: TechniqueStats::new(),
        })
    }

    /// Renders the moment map and its mip chain from the shadow map just drawn.
    fn build_moment_map(&mut self, frame: &mut Frame<'_>, inputs: &ShadowInputs<'_>) {
        let gpu = frame.gpu;
        let size = self.settings.shadow_map_size;
        let evsm = self.settings.variant != Variant::Msm4;
        if self
            .moment_map
            .as_ref()
            .is_none_or(|m| m.size != size || m.evsm != evsm)
        {
            self.moment_map = Some(MomentMap::new(gpu, size, evsm));
        }
        let map = self.moment_map.as_ref().expect("created above");
        let pass = if evsm {
            &self.moments_evsm
        } else {
            &self.moments_msm
        };
        let (group, params) = (inputs.frame_bind_group, &self.params_buffer);
        let target = &map.levels[0];
        (self.shadow_map).draw_lookup(frame, pass, "msm/moments", group, params, target, Some(0.0));
        for (source, target) in map.levels.iter().zip(&map.levels[1..]) {
            self.downsample
                .run(frame)
                .frame_group(group)
                .read(source)
                .draw(target, Some(0.0));
        }
    }
}

impl Msm {
    /// The sun's frame: its cascades, their moment maps and the filter (`sun.rs`).
    fn render_sun(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
    ) -> Result<(), TechniqueError> {
        let gpu = frame.gpu;
        if self.sun.is_none() {
            self.sun = Some(sun::MsmSun::new(gpu)?);
        }
        let uniform = MsmUniform::new(&self.settings, Vec2::new(0.0, 1.0));
        (gpu.queue).write_buffer(&self.params_buffer, 0, &uniform_bytes(&uniform));
        let sun = self.sun.as_mut().expect("made above");
        let passes = (&self.params_buffer, &self.downsample);
        self.stats = sun.render(frame, inputs, &self.settings, passes, out)?;
        Ok(())
    }
}

impl ShadowTechnique for Msm {
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
        if inputs.light.kind == LightKind::Sun {
            return self.render_sun(frame, inputs, out);
        }
        let gpu = frame.gpu;
        let s = self.settings.clone();
        let Some(frustum) =
            self.shadow_map
                .render(frame, inputs, s.shadow_map_size, "msm/shadow_map")
        else {
            out.write_unshadowed(frame, inputs.frame_bind_group, "msm/no_casters")?;
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        };
        // Depth is normalised from the map's near plane to the farthest receiver (or caster), so
        // no receiver lies behind an empty texel's depth 1, and empty texels lie just behind the
        // farthest receivers, as a ground drawn into the map would (EVSM's positive warp
        // magnifies every depth beyond the receiver: empty texels far behind would dominate it).
        let receivers_far = inputs
            .scene
            .light_bounds(inputs.light)
            .receivers
            .map_or(frustum.far, |r| r.max.z);
        let far = frustum.far.max(receivers_far) + 1e-4;
        let uniform = MsmUniform::new(&s, Vec2::new(frustum.near, far));
        gpu.queue
            .write_buffer(&self.params_buffer, 0, &uniform_bytes(&uniform));
        let evsm = s.variant != Variant::Msm4;
        let kept = self
            .moment_map
            .as_ref()
            .is_some_and(|m| m.size == s.shadow_map_size && m.evsm == evsm);
        if self.shadow_map.rebuilt() || !kept {
            self.build_moment_map(frame, inputs);
        }
        let map = self.moment_map.as_ref().expect("built above");
        let filter = match s.variant {
            Variant::Msm4 => &self.filter_msm4,
            Variant::Evsm2 => &self.filter_evsm2,
            Variant::Evsm4 => &self.filter_evsm4,
        };
        filter
            .run(frame)
            .named("msm/filter")
            .frame_group(inputs.frame_bind_group)
            .read(&self.shadow_map.view_buffer)
            .read(&map.all_levels)
            .read(&self.params_buffer)
            .draw(&out.view, Some(1.0));
        let taps = s.filter_taps.clamp(1, 8) as f64;
        let pixels = inputs.width as f64 * inputs.height as f64;
        self.stats = TechniqueStats::from([
            ("shadow_maps".into(), 1.0),
            ("moment_map_levels".into(), map.levels.len() as f64),
            // Two lookups (blocker search, filter), taps² trilinear taps of 8 texels each.
            ("max_texel_reads_per_pixel".into(), 2.0 * taps * taps * 8.0),
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

    fn debug_views(&self) -> Vec<DebugView> {
        let mut views = self.shadow_map.debug_views();
        if let Some(map) = &self.moment_map {
            let meaning = if map.evsm {
                "e^(c+ (2z - 1)): positively warped depth (EVSM), level 0"
            } else {
                "first moment: normalised depth z, level 0"
            };
            views.push(DebugView::new(
                "moment_map",
                &map.texture,
                DebugLegend::value(meaning),
            ));
        }
        views
    }
}
