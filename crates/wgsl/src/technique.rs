//! The technique of a file: the centre shadow map (core's `CentreShadowMap`, the map `hard` and
//! `pcss` render) and the file's one fullscreen pass, nothing else (docs/WGSL.md, "Cost").

use std::borrow::Cow;

use softshadow_core::{
    cascades::{Cascade, CascadeSettings, SunCascades},
    glam::Vec4,
    params::find_spec,
    pass::{FullscreenPass, Pass, Slot},
    shadow_map::{CentreShadowMap, ShadowViewUniform},
    uniform::{uniform_bytes, zeroed_uniform_buffer},
    wgpu, DebugView, Frame, Gpu, LightKind, ParamError, ParamKind, ParamSet, ParamSpec, ParamValue,
    ShadowInputs, ShadowTechnique, TechniqueError, TechniqueSettings, TechniqueStats,
    VisibilityBuffer,
};

use crate::{
    compile::CompiledFile,
    directives::{Directives, Fit, ScalarType, SHADOW_MAP_SIZE},
};

/// The spec of `shadow_map_size`, the parameter every file technique has (as `hard`'s).
pub(crate) fn shadow_map_size_spec() -> ParamSpec {
    ParamSpec {
        name: Cow::Borrowed(SHADOW_MAP_SIZE),
        description: Cow::Borrowed("Edge of the centre shadow map in texels"),
        kind: ParamKind::Int {
            min: 64,
            max: 4096,
            default: 1024,
        },
    }
}

/// The settings of a file technique: its declared parameters (then `shadow_map_size`) and their
/// current values.
#[derive(Clone, Debug)]
pub struct FileSettings {
    specs: Vec<ParamSpec>,
    types: Vec<ScalarType>,
    values: Vec<ParamValue>,
}

impl FileSettings {
    /// The defaults of `directives`.
    pub fn new(directives: &Directives) -> Self {
        let mut specs: Vec<ParamSpec> = directives.params.iter().map(|p| p.spec.clone()).collect();
        let mut types: Vec<ScalarType> = directives.params.iter().map(|p| p.ty).collect();
        specs.push(shadow_map_size_spec());
        types.push(ScalarType::U32);
        let values = specs.iter().map(ParamSpec::default_value).collect();
        Self {
            specs,
            types,
            values,
        }
    }

    /// The value of `name`, if the file declares it.
    pub fn get(&self, name: &str) -> Option<&ParamValue> {
        let index = self.specs.iter().position(|s| s.name == name)?;
        Some(&self.values[index])
    }

    /// The `Params` uniform block: one 4-byte scalar per parameter in declaration order,
    /// padded to 16 bytes (`compile::params_struct` declares the same layout).
    pub fn uniform_bytes(&self) -> Vec<u8> {
        let mut bytes = Vec::with_capacity(16 * self.values.len().div_ceil(4));
        for (ty, value) in self.types.iter().zip(&self.values) {
            let word: [u8; 4] = match (ty, value) {
                (ScalarType::F32, v) => (v.as_f64().unwrap_or(0.0) as f32).to_ne_bytes(),
                (ScalarType::U32, v) => (v.as_f64().unwrap_or(0.0) as u32).to_ne_bytes(),
                (ScalarType::I32, v) => (v.as_f64().unwrap_or(0.0) as i32).to_ne_bytes(),
                (ScalarType::Bool, v) => u32::from(*v == ParamValue::Bool(true)).to_ne_bytes(),
            };
            bytes.extend_from_slice(&word);
        }
        bytes.resize(bytes.len().div_ceil(16) * 16, 0);
        bytes
    }
}

impl TechniqueSettings for FileSettings {
    fn specs(&self) -> Vec<ParamSpec> {
        self.specs.clone()
    }

    fn param_set(&self) -> ParamSet {
        ParamSet {
            entries: self
                .specs
                .iter()
                .cloned()
                .zip(self.values.iter().cloned())
                .collect(),
        }
    }

    fn set_param(
        &mut self,
        technique: &str,
        name: &str,
        value: ParamValue,
    ) -> Result<(), ParamError> {
        let value = find_spec(technique, &self.specs, name)?.check(value)?;
        let index = self
            .specs
            .iter()
            .position(|s| s.name == name)
            .expect("found above");
        self.values[index] = value;
        Ok(())
    }
}

/// The contract's `ShadowView` of the sun's map (docs/WGSL.md, "The map"): `light_view_proj`
/// world to clip, `window.x` the texel edge in world units, `eye_near_far.z` the near plane and
/// `.w` far - near, what the preamble's `map_*` helpers read under the sun.
fn sun_map_view(cascade: &Cascade, size: u32) -> ShadowViewUniform {
    let n = size as f32;
    let view = &cascade.view;
    ShadowViewUniform {
        light_view_proj: view.view_projection(),
        window: Vec4::new(cascade.texel_world, 0.0, 0.0, 0.0),
        eye_near_far: Vec4::new(0.0, 0.0, view.near, view.far - view.near),
        size: Vec4::new(n, n, 1.0 / n, 1.0 / n),
    }
}

/// A technique defined by a WGSL file.
pub struct FileTechnique {
    id: String,
    settings: FileSettings,
    shadow_map: CentreShadowMap,
    /// Under the sun: one orthographic map fitted to the scene (`hard`'s with `cascades=1`),
    /// and its `ShadowView` ([`sun_map_view`]).
    sun: SunCascades,
    sun_view_buffer: wgpu::Buffer,
    pass: FullscreenPass,
    params_buffer: wgpu::Buffer,
    shadow_map_label: String,
    pass_label: String,
    no_casters_label: String,
    stats: TechniqueStats,
}

impl FileTechnique {
    /// Builds the pipeline of `compiled` (the file of `directives`) on `gpu`.
    pub fn new(
        gpu: &Gpu,
        id: &str,
        directives: &Directives,
        compiled: &CompiledFile,
    ) -> Result<Self, TechniqueError> {
        let pass_label = format!("{id}/pass");
        // The contract's group 1 (docs/WGSL.md): the map's ShadowView, the map, the parameters.
        let pass = Pass::from_module(gpu, &pass_label, compiled.module.clone())
            .after_frame_group()
            .uniform()
            .texture(Slot::DEPTH)
            .uniform()
            .fullscreen(None)?;
        let settings = FileSettings::new(directives);
        let params_buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(&pass_label),
            size: settings.uniform_bytes().len() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let shadow_map = match directives.fit {
            Fit::Casters => CentreShadowMap::new(gpu)?,
            Fit::Receivers => CentreShadowMap::new(gpu)?.clipped_to_receivers(),
        };
        Ok(Self {
            id: id.to_string(),
            settings,
            shadow_map,
            sun: SunCascades::new(gpu)?,
            sun_view_buffer: zeroed_uniform_buffer::<ShadowViewUniform>(gpu, &pass_label),
            pass,
            params_buffer,
            shadow_map_label: format!("{id}/shadow_map"),
            no_casters_label: format!("{id}/no_casters"),
            pass_label,
            stats: TechniqueStats::new(),
        })
    }

    /// Its settings.
    pub fn file_settings(&self) -> &FileSettings {
        &self.settings
    }

    /// Draws (or keeps) the centre shadow map; `false` when no caster is in front of the light.
    fn render_centre_map(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        size: u32,
    ) -> bool {
        let label = &self.shadow_map_label;
        if self.shadow_map.render(frame, inputs, size, label).is_none() {
            return false;
        }
        self.stats = TechniqueStats::from([
            ("shadow_maps".into(), 1.0),
            ("shadow_map_texels".into(), (size as f64) * (size as f64)),
        ]);
        true
    }

    /// Draws (or keeps) the sun's map, one cascade fitted to the scene, and writes its view;
    /// `false` when the scene has no casters.
    fn render_sun_map(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        size: u32,
    ) -> bool {
        let one_map = CascadeSettings {
            count: 1,
            ..CascadeSettings::default()
        };
        let label = &self.shadow_map_label;
        let Some(fit) = self.sun.render(frame, inputs, &one_map, size, label) else {
            return false;
        };
        let Some(cascade) = fit.cascades.first() else {
            return false;
        };
        let view = sun_map_view(cascade, size);
        frame
            .gpu
            .queue
            .write_buffer(&self.sun_view_buffer, 0, &uniform_bytes(&view));
        self.stats = fit.stats(size);
        true
    }
}

impl ShadowTechnique for FileTechnique {
    fn id(&self) -> &str {
        &self.id
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
        let size = match self.settings.get(SHADOW_MAP_SIZE) {
            Some(ParamValue::Int(size)) => *size as u32,
            _ => 1024,
        };
        let drawn = if inputs.light.kind == LightKind::Sun {
            self.render_sun_map(frame, inputs, size)
        } else {
            self.render_centre_map(frame, inputs, size)
        };
        if !drawn {
            // No caster in front of the light: receivers in front of it are lit.
            out.write_unshadowed(frame, inputs.frame_bind_group, &self.no_casters_label)?;
            self.stats = TechniqueStats::from([("shadow_maps".into(), 0.0)]);
            return Ok(());
        }
        frame
            .gpu
            .queue
            .write_buffer(&self.params_buffer, 0, &self.settings.uniform_bytes());
        let (view, map) = match inputs.light.kind {
            LightKind::Sun => (&self.sun_view_buffer, self.sun.layer(0)),
            _ => (&self.shadow_map.view_buffer, self.shadow_map.map_view()),
        };
        let map = map.expect("a map was drawn above");
        self.pass
            .run(frame)
            .named(&self.pass_label)
            .frame_group(inputs.frame_bind_group)
            .read(view)
            .read(map)
            .read(&self.params_buffer)
            .draw(&out.view, Some(1.0));
        Ok(())
    }

    fn invalidate_cache(&mut self) {
        self.shadow_map.invalidate();
        self.sun.invalidate();
    }

    fn stats(&self) -> TechniqueStats {
        self.stats.clone()
    }

    fn debug_views(&self) -> Vec<DebugView> {
        self.shadow_map.debug_views()
    }
}
