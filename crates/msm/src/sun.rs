//! `msm` under the sun: core's cascaded orthographic maps ([`SunCascades`]; one map fitted to the
//! scene with `cascades` = 1), one moment map per cascade (the layers of one array, each with its
//! mip chain) and the blocker search and filter in world units (`shaders/msm/msm.wgsl`, `SUN`),
//! so the penumbra keeps its width across cascade boundaries.

use softshadow_core::{
    cascades::SunCascades,
    pass::{FullscreenPass, Pass, Slot},
    shader::DefValue,
    shadow_map::layer_view,
    wgpu, Frame, Gpu, ShadowInputs, TechniqueError, TechniqueStats, VisibilityBuffer,
};

use crate::{MsmSettings, Variant, EVSM, EVSM4, MOMENT_FORMAT, SHADERS, SUN};

/// The moment maps of the cascades: one array texture, a layer per cascade, with mips.
struct SunMomentMaps {
    size: u32,
    layers: u32,
    evsm: bool,
    /// Per layer, one 2D view per level (render targets and the downsampling's sources).
    levels: Vec<Vec<wgpu::TextureView>>,
    /// Every layer and level, as the filter reads them.
    array: wgpu::TextureView,
}

impl SunMomentMaps {
    fn new(gpu: &Gpu, size: u32, layers: u32, evsm: bool) -> Self {
        let level_count = size.ilog2() + 1;
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("msm/sun_moment_maps"),
            size: wgpu::Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: layers,
            },
            mip_level_count: level_count,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: MOMENT_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let view = |layer, level| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("msm/sun_moment_map level"),
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_mip_level: level,
                mip_level_count: Some(1),
                base_array_layer: layer,
                array_layer_count: Some(1),
                ..Default::default()
            })
        };
        let levels = (0..layers)
            .map(|layer| (0..level_count).map(|level| view(layer, level)).collect())
            .collect();
        let array = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        Self {
            size,
            layers,
            evsm,
            levels,
            array,
        }
    }
}

/// The sun's cascades, their moment maps and the passes that make and read them.
pub(crate) struct MsmSun {
    cascades: SunCascades,
    moments_msm: FullscreenPass,
    moments_evsm: FullscreenPass,
    filter_msm4: FullscreenPass,
    filter_evsm2: FullscreenPass,
    filter_evsm4: FullscreenPass,
    maps: Option<SunMomentMaps>,
}

impl MsmSun {
    pub(crate) fn new(gpu: &Gpu) -> Result<Self, TechniqueError> {
        // moments.wgsl (SUN): one cascade's depth layer, MsmParams.
        let moments = |label, defs: &[(&str, DefValue)]| {
            Pass::new(gpu, label, &SHADERS[0])
                .defs(defs)
                .after_frame_group()
                .texture(Slot::DEPTH)
                .uniform()
                .fullscreen_into(MOMENT_FORMAT, None)
        };
        // msm.wgsl (SUN): the Cascades uniform, the moment maps' array, MsmParams.
        let filter = |label, defs: &[(&str, DefValue)]| {
            Pass::new(gpu, label, &SHADERS[2])
                .defs(defs)
                .after_frame_group()
                .uniform()
                .texture(Slot::Texture {
                    sample: wgpu::TextureSampleType::Float { filterable: false },
                    dimension: wgpu::TextureViewDimension::D2Array,
                })
                .uniform()
                .fullscreen(None)
        };
        Ok(Self {
            cascades: SunCascades::new(gpu)?,
            moments_msm: moments("msm/moments sun", &[SUN])?,
            moments_evsm: moments("msm/moments sun evsm", &[SUN, EVSM])?,
            filter_msm4: filter("msm/filter sun", &[SUN])?,
            filter_evsm2: filter("msm/filter sun evsm2", &[SUN, EVSM])?,
            filter_evsm4: filter("msm/filter sun evsm4", &[SUN, EVSM, EVSM4])?,
            maps: None,
        })
    }

    /// Draws the cascades (`msm/shadow_map/<i>`), their moment maps and mips (`msm/moments`,
    /// `msm/mips`, only when the cascades were redrawn) and the filter (`msm/filter`) with
    /// `params` (the `MsmParams` buffer, written); `downsample` is the crate's mip pass.
    pub(crate) fn render(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        settings: &MsmSettings,
        (params, downsample): (&wgpu::Buffer, &FullscreenPass),
        out: &VisibilityBuffer,
    ) -> Result<TechniqueStats, TechniqueError> {
        let size = settings.shadow_map_size;
        let sun = ("msm", &settings.sun, size);
        let Some(fit) = (self.cascades).render_or_lit(frame, inputs, sun, out)? else {
            return Ok(TechniqueStats::from([("shadow_maps".into(), 0.0)]));
        };
        let layers = fit.cascades.len() as u32;
        let evsm = settings.variant != Variant::Msm4;
        let kept = (self.maps.as_ref())
            .is_some_and(|m| (m.size, m.layers, m.evsm) == (size, layers, evsm));
        if fit.rebuilt || !kept {
            self.build_moment_maps(frame, inputs, params, downsample, (size, layers, evsm));
        }
        let maps = self.maps.as_ref().expect("built above");
        let filter = match settings.variant {
            Variant::Msm4 => &self.filter_msm4,
            Variant::Evsm2 => &self.filter_evsm2,
            Variant::Evsm4 => &self.filter_evsm4,
        };
        filter
            .run(frame)
            .named("msm/filter")
            .frame_group(inputs.frame_bind_group)
            .read(&self.cascades.uniform_buffer)
            .read(&maps.array)
            .read(params)
            .draw(&out.view, Some(1.0));
        let mut stats = fit.stats(size);
        let taps = settings.filter_taps.clamp(1, 8) as f64;
        // Two cascades' two lookups in the blend bands, taps² trilinear taps of 8 texels each.
        stats.insert("max_texel_reads_per_pixel".into(), 4.0 * taps * taps * 8.0);
        stats.insert("pixels".into(), inputs.width as f64 * inputs.height as f64);
        Ok(stats)
    }

    /// Each cascade's moment map from its depth layer, then its mip chain.
    fn build_moment_maps(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        params: &wgpu::Buffer,
        downsample: &FullscreenPass,
        (size, layers, evsm): (u32, u32, bool),
    ) {
        let fits = self.maps.as_ref();
        if fits.is_none_or(|m| (m.size, m.layers, m.evsm) != (size, layers, evsm)) {
            self.maps = Some(SunMomentMaps::new(frame.gpu, size, layers, evsm));
        }
        let maps = self.maps.as_ref().expect("made above");
        let Some(depth) = self.cascades.maps_texture() else {
            return;
        };
        let pass = if evsm {
            &self.moments_evsm
        } else {
            &self.moments_msm
        };
        let group = inputs.frame_bind_group;
        for (layer, levels) in maps.levels.iter().enumerate() {
            let depth_layer = layer_view(depth, layer as u32);
            pass.run(frame)
                .named("msm/moments")
                .frame_group(group)
                .read(&depth_layer)
                .read(params)
                .draw(&levels[0], Some(0.0));
            for (source, target) in levels.iter().zip(&levels[1..]) {
                downsample
                    .run(frame)
                    .named("msm/mips")
                    .frame_group(group)
                    .read(source)
                    .draw(target, Some(0.0));
            }
        }
    }

    pub(crate) fn invalidate(&mut self) {
        self.cascades.invalidate();
    }
}
