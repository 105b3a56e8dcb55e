//! Cascaded shadow maps for the sun: the camera's depth range split into up to four slices, one
//! orthographic [`SunView`] fitted to each, rendered with the shared [`DepthMapRenderer`] into the
//! layers of one `Depth32Float` array, and looked up through `shaders/common/cascades.wgsl`
//! (`softshadow::cascades`).
//!
//! - **Splits**: the practical split scheme of Zhang et al. 2006 ("Parallel-Split Shadow Maps for
//!   Large-scale Virtual Environments", VRCIA 2006) in the weighted form of Zhang, Sun and Nyman
//!   2007 (GPU Gems 3, chapter 10, section 10.2.1): the split distance of slice `i` of `N` is
//!   `lambda C_log + (1 - lambda) C_uni`, the blend of the logarithmic split
//!   `n (f / n)^(i / N)` (the texel density the perspective wants: equal aliasing in every slice)
//!   and the uniform split `n + (f - n) i / N` (which keeps the first slices from being tiny).
//! - **Fit**: each slice's window is the bounding sphere of the frustum slice, seen from the sun
//!   (its size depends on the field of view and the split distances only, so it does not change
//!   as the camera turns: Valient 2008, "Stable Rendering of Cascaded Shadow Maps", ShaderX6),
//!   with its near plane moved towards the sun to the casters' nearest depth, so a
//!   caster outside the slice still shadows it.
//! - **Snapping**: the window's origin moved to whole texels of light space (Valient 2008): a
//!   moving camera then moves the window by whole texels and every caster
//!   rasterises into the same texels, so edges do not crawl.
//! - **Lookup**: the cascade of a point is the first whose far split is beyond the point's view
//!   depth; in the last `blend` fraction of a cascade its answer is mixed linearly with the next
//!   one's, so the boundary leaves no seam; the texel's size in world units is given per cascade,
//!   so search and filter sizes can be stated in world units and a penumbra keeps its width across
//!   boundaries (Bevy's issue tracker reports its PCSS softness tied to the cascade).
//!
//! `CascadeSettings` mirrors Bevy's `CascadeShadowConfig` (`num_cascades`, `minimum_distance`,
//! `maximum_distance`, `overlap_proportion`) with the split parameter `lambda` where Bevy fixes
//! the bounds by a `first_cascade_far_bound`.

use encase::ShaderType;
use glam::{Mat4, Vec3, Vec4};

use crate::{
    frame::Frame,
    light_shape::SunView,
    pass::{FullscreenPass, Pass, PassBuilder, Slot},
    shader::ShaderSpec,
    shadow_map::{create_depth_maps, layer_view, DepthMapRenderer, ShadowViewUniform},
    uniform::{uniform_bytes, zeroed_uniform_buffer},
    AreaLight, Gpu, GpuError, SceneGpu, ShadowInputs, TechniqueError, TechniqueStats,
    VisibilityBuffer,
};

/// The most cascades a [`CascadeUniform`] holds (`MAX_CASCADES` in `cascades.wgsl`).
pub const MAX_CASCADES: usize = 4;

/// The parameter names of [`SunCascadeParams`]. They matter only under the sun: the viewer
/// shows them only then, under a heading of their own.
pub const CASCADE_PARAMS: [&str; 4] = [
    "cascades",
    "cascade_lambda",
    "cascade_blend",
    "cascade_snap",
];

crate::technique_settings! {
    /// The sun's cascades as parameters: the shared group of a technique that draws them
    /// (`..sun: SunCascadeParams;` in its settings: `hard`, `pcss`), turned into
    /// [`CascadeSettings`] by [`SunCascadeParams::settings`].
    pub struct SunCascadeParams {
        /// The sun: cascaded maps over the camera's depth range (1 = one map fitted to the scene)
        cascades: u32 = 4, in 1..=4;
        /// The sun: split scheme, 0 uniform to 1 logarithmic (lambda of Zhang et al.'s practical split scheme)
        cascade_lambda: f32 = 0.75, in 0.0..=1.0;
        /// The sun: fraction of each cascade blended into the next at its far end
        cascade_blend: f32 = 0.125, in 0.0..=0.5;
        /// The sun: snap each cascade's window to whole texels (no crawling edges as the camera moves)
        cascade_snap: bool = true;
    }
}

impl SunCascadeParams {
    /// The cascades these parameters ask for.
    pub fn settings(&self) -> CascadeSettings {
        CascadeSettings {
            count: self.cascades,
            lambda: self.cascade_lambda,
            blend: self.cascade_blend,
            snap: self.cascade_snap,
            ..CascadeSettings::default()
        }
    }
}

/// How the sun's cascades are split, blended and stabilised (Bevy's `CascadeShadowConfig`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CascadeSettings {
    /// Cascades, 1 to [`MAX_CASCADES`]. 1 is one map over the whole range.
    pub count: u32,
    /// The split scheme's blend, 0 to 1: 0 splits the range uniformly, 1 logarithmically (the
    /// lambda of Zhang et al.'s practical split scheme, GPU Gems 3 chapter 10, section 10.2.1).
    /// Default 0.75.
    pub lambda: f32,
    /// The farthest view depth (metres) shadowed; points beyond are lit. 0: the camera's far
    /// plane or the farthest receiver (rounded up to a quarter octave, so the range stays put
    /// while the camera walks), whichever is nearer.
    pub max_distance: f32,
    /// The fraction of each cascade's depth range, at its far end, over which its answer blends
    /// into the next cascade's (Bevy's `overlap_proportion`), 0 to 0.5.
    pub blend: f32,
    /// Snap each window's origin to whole texels (stable edges under a moving camera).
    pub snap: bool,
}

impl Default for CascadeSettings {
    fn default() -> Self {
        Self {
            count: 4,
            lambda: 0.75,
            max_distance: 0.0,
            blend: 0.125,
            snap: true,
        }
    }
}

/// The split distances of `count` slices of the view depths `near..far`: `count + 1` values from
/// `near` to `far` (Zhang et al.'s practical split scheme, GPU Gems 3 chapter 10, section 10.2.1,
/// with `lambda` the weight of the logarithmic scheme against the uniform one).
pub fn split_distances(near: f32, far: f32, count: u32, lambda: f32) -> Vec<f32> {
    let count = count.clamp(1, MAX_CASCADES as u32);
    let lambda = lambda.clamp(0.0, 1.0);
    (0..=count)
        .map(|i| {
            let f = i as f32 / count as f32;
            let log = near * (far / near).powf(f);
            let uniform = near + (far - near) * f;
            if i == count {
                far
            } else {
                lambda * log + (1.0 - lambda) * uniform
            }
        })
        .collect()
}

/// The camera's frustum as the cascades need it, read back from the frame's view-projection (so
/// a host's camera works too): the eye, the unit forward axis, the four corner rays scaled to
/// view depth 1, and the near and far view depths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraFrustum {
    /// The eye (world).
    pub eye: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// From the eye to the frustum's four corners at view depth 1.
    pub corners: [Vec3; 4],
    /// Near plane's view depth.
    pub near: f32,
    /// Far plane's view depth.
    pub far: f32,
}

impl CameraFrustum {
    /// The frustum of `view_proj` (wgpu's depth 0..1) seen from `eye`; `None` for a singular or
    /// non-finite matrix.
    pub fn from_view_proj(view_proj: Mat4, eye: Vec3) -> Option<Self> {
        let inverse = view_proj.inverse();
        let at = |x: f32, y: f32, z: f32| inverse.project_point3(Vec3::new(x, y, z));
        let forward = (at(0.0, 0.0, 1.0) - at(0.0, 0.0, 0.0)).normalize_or_zero();
        let near = (at(0.0, 0.0, 0.0) - eye).dot(forward);
        let far = (at(0.0, 0.0, 1.0) - eye).dot(forward);
        let corner = |x: f32, y: f32| {
            let ray = at(x, y, 1.0) - eye;
            ray / ray.dot(forward)
        };
        let frustum = Self {
            eye,
            forward,
            corners: [
                corner(-1.0, -1.0),
                corner(1.0, -1.0),
                corner(-1.0, 1.0),
                corner(1.0, 1.0),
            ],
            near,
            far,
        };
        let finite = frustum.corners.iter().all(|c| c.is_finite());
        (finite && forward != Vec3::ZERO && near > 0.0 && far > near).then_some(frustum)
    }

    /// The bounding sphere (view depth of its centre, radius) of the slice between view depths
    /// `d0` and `d1`. It depends on the corner rays' spread and the depths only, so it is the same
    /// for every orientation of the camera (Valient 2008).
    pub fn slice_sphere(&self, d0: f32, d1: f32) -> (f32, f32) {
        // k: the tangent of the half diagonal, the corners' distance from the axis at depth 1.
        let k2 = self
            .corners
            .iter()
            .map(|c| (*c - self.forward).length_squared())
            .fold(0.0, f32::max);
        // The centre c on the axis equidistant from the near and far corners:
        // (c - d0)^2 + d0^2 k^2 = (d1 - c)^2 + d1^2 k^2, clamped to the slice.
        let c = ((d0 + d1) * (1.0 + k2) * 0.5).min(d1);
        let radius = ((d1 - c).powi(2) + d1 * d1 * k2)
            .sqrt()
            .max(((c - d0).powi(2) + d0 * d0 * k2).sqrt());
        (c, quantise_up(radius))
    }

    /// The view depth of the farthest of `points` (at least the near plane).
    pub fn farthest_depth(&self, points: &[Vec3]) -> f32 {
        points
            .iter()
            .map(|p| (*p - self.eye).dot(self.forward))
            .fold(self.near, f32::max)
    }
}

/// `x` rounded up to 8 significant bits: the sphere's radius from a matrix read back in f32
/// wobbles in its last bits as the camera turns, and a wobbling window size would make edges
/// crawl; rounded, it changes only when the field of view or the splits do.
fn quantise_up(x: f32) -> f32 {
    if x <= 0.0 || !x.is_finite() {
        return x;
    }
    let step = 2f32.powi(x.log2().floor() as i32 - 7);
    (x / step).ceil() * step
}

/// One cascade: its light view and the slice of view depths it serves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cascade {
    /// The orthographic view of its map.
    pub view: SunView,
    /// View depth where the slice begins.
    pub split_near: f32,
    /// View depth where the slice ends.
    pub split_far: f32,
    /// Edge of one texel of its map, world units.
    pub texel_world: f32,
}

/// Fits the cascades of `settings` for `light` (the sun) to `frustum`: one [`SunView`] per slice,
/// the window the slice's bounding sphere (with a texel of margin for the snap), its origin
/// snapped to whole texels of a `map_size`² map when `settings.snap`, its near plane at the
/// casters' nearest depth (`casters`: points bounding them, e.g. their box's corners) and its far
/// plane at the sphere's far side. `receivers` (points) bound `max_distance` when it is 0. One
/// cascade (`count` 1) is one map fitted to the whole scene instead, whatever the camera.
pub fn fit_cascades(
    light: &AreaLight,
    frustum: &CameraFrustum,
    casters: &[Vec3],
    receivers: &[Vec3],
    settings: &CascadeSettings,
    map_size: u32,
) -> Vec<Cascade> {
    let view = light.view();
    let caster_near = casters
        .iter()
        .map(|p| view.transform_point3(*p).z)
        .fold(f32::INFINITY, f32::min);
    let mut far = frustum.far;
    if settings.max_distance > 0.0 {
        far = far.min(settings.max_distance);
    } else if !receivers.is_empty() {
        // Rounded up to a quarter octave: the farthest receiver moves with the camera, and every
        // change of the range would resize every cascade (and make edges crawl).
        let farthest = frustum.farthest_depth(receivers);
        far = far.min(2f32.powf((farthest.log2() * 4.0).ceil() / 4.0));
    }
    let far = far.max(frustum.near * 1.001);
    if settings.count <= 1 {
        return fitted_map(light, frustum, casters, receivers, map_size)
            .into_iter()
            .collect();
    }
    let splits = split_distances(frustum.near, far, settings.count, settings.lambda);
    let n = map_size.max(4) as f32;
    splits
        .windows(2)
        .map(|w| {
            let (depth, radius) = frustum.slice_sphere(w[0], w[1]);
            let centre = view.transform_point3(frustum.eye + frustum.forward * depth);
            // A texel of margin on each side, so the snapped window still holds the sphere.
            let half = radius * n / (n - 2.0);
            let texel = 2.0 * half / n;
            let (mut x0, mut y0) = (centre.x - half, centre.y - half);
            if settings.snap {
                x0 = (x0 / texel).floor() * texel;
                y0 = (y0 / texel).floor() * texel;
            }
            let far_z = centre.z + radius;
            let near_z = (centre.z - radius).min(caster_near);
            let pad = ((far_z - near_z) * 0.01).max(1e-3);
            Cascade {
                view: SunView {
                    view,
                    window: [x0, x0 + 2.0 * half, y0, y0 + 2.0 * half],
                    near: near_z - pad,
                    far: far_z + pad,
                },
                split_near: w[0],
                split_far: w[1],
                texel_world: texel,
            }
        })
        .collect()
}

/// One map fitted to the whole scene (`casters` and `receivers`: [`SunView::fit`]), serving every
/// view depth: what `cascades = 1` means. It does not depend on the camera.
fn fitted_map(
    light: &AreaLight,
    frustum: &CameraFrustum,
    casters: &[Vec3],
    receivers: &[Vec3],
    map_size: u32,
) -> Option<Cascade> {
    let points: Vec<Vec3> = casters.iter().chain(receivers).copied().collect();
    let view = SunView::fit(light, &points)?;
    Some(Cascade {
        view,
        split_near: frustum.near,
        split_far: frustum.far,
        texel_world: view.texel_size(map_size),
    })
}

/// The cascades as shaders read them (`Cascades` in `shaders/common/cascades.wgsl`); unused
/// cascades are zero.
#[derive(Clone, Copy, Debug, PartialEq, ShaderType)]
pub struct CascadeUniform {
    /// World to each cascade's clip space.
    pub view_proj: [Mat4; MAX_CASCADES],
    /// View depth where each cascade ends.
    pub split_far: Vec4,
    /// Each cascade's texel edge, world units.
    pub texel_world: Vec4,
    /// Each cascade's near plane (light-space z of depth 0).
    pub near: Vec4,
    /// Each cascade's far minus near plane (depth 1 is `near + depth_range`).
    pub depth_range: Vec4,
    /// xyz: the camera's unit forward axis; w: its near plane's view depth.
    pub camera_forward: Vec4,
    /// x: cascades, y: map edge in texels, z: its inverse, w: the blend fraction.
    pub info: Vec4,
}

impl CascadeUniform {
    /// The uniform of `cascades` in `map_size`² maps, blending over `blend` of each.
    pub fn new(cascades: &[Cascade], frustum: &CameraFrustum, map_size: u32, blend: f32) -> Self {
        let mut u = Self {
            view_proj: [Mat4::ZERO; MAX_CASCADES],
            split_far: Vec4::ZERO,
            texel_world: Vec4::ZERO,
            near: Vec4::ZERO,
            depth_range: Vec4::ZERO,
            camera_forward: frustum.forward.extend(frustum.near),
            info: Vec4::new(
                cascades.len().min(MAX_CASCADES) as f32,
                map_size as f32,
                1.0 / map_size as f32,
                blend.clamp(0.0, 0.5),
            ),
        };
        for (i, c) in cascades.iter().take(MAX_CASCADES).enumerate() {
            u.view_proj[i] = c.view.view_projection();
            u.split_far[i] = c.split_far;
            u.texel_world[i] = c.texel_world;
            u.near[i] = c.view.near;
            u.depth_range[i] = c.view.far - c.view.near;
        }
        u
    }
}

/// What [`SunCascades::render`] drew, for a technique's stats.
#[derive(Clone, Debug, PartialEq)]
pub struct CascadeFit {
    /// The cascades fitted this frame.
    pub cascades: Vec<Cascade>,
    /// The maps were drawn this frame (not kept from the last).
    pub rebuilt: bool,
}

impl CascadeFit {
    /// The stats every technique under the sun reports: `shadow_maps`, `shadow_map_texels` (of
    /// `size`² maps) and each cascade's texel and far split in metres (`cascade<i>_texel_m`,
    /// `cascade<i>_far_m`).
    pub fn stats(&self, size: u32) -> TechniqueStats {
        let maps = self.cascades.len() as f64;
        let mut stats = TechniqueStats::from([
            ("shadow_maps".into(), maps),
            ("shadow_map_texels".into(), maps * (size as f64).powi(2)),
        ]);
        for (i, c) in self.cascades.iter().enumerate() {
            stats.insert(format!("cascade{i}_texel_m"), c.texel_world as f64);
            stats.insert(format!("cascade{i}_far_m"), c.split_far as f64);
        }
        stats
    }
}

/// The sun's cascaded maps of one technique: fitting, the depth passes into the layers of one
/// array, the lookup uniform (`softshadow::cascades`) and the pass that reads them.
pub struct SunCascades {
    depth: DepthMapRenderer,
    /// Map edge, layers, the array texture, its array view and one view per layer.
    maps: Option<(
        u32,
        u32,
        wgpu::Texture,
        wgpu::TextureView,
        Vec<wgpu::TextureView>,
    )>,
    /// `Cascades` uniform of the last maps drawn.
    pub uniform_buffer: wgpu::Buffer,
    /// The cascades drawn, kept while they and the light space stand still.
    kept: Option<(u32, Vec<Cascade>)>,
}

impl SunCascades {
    /// The renderer; its maps are made by the first [`Self::render`].
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        Ok(Self {
            depth: DepthMapRenderer::new(gpu)?,
            maps: None,
            uniform_buffer: zeroed_uniform_buffer::<CascadeUniform>(gpu, "sun cascades"),
            kept: None,
        })
    }

    /// The cascades of `settings` for this frame's camera (from `inputs.uniforms`) fitted and,
    /// unless the same cascades were drawn last time and the light space stands still, drawn
    /// into `size`² layers as the passes `label/0..` . `None` (nothing drawn) when the scene has
    /// no casters or the frame's camera is unusable.
    pub fn render(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        settings: &CascadeSettings,
        size: u32,
        label: &str,
    ) -> Option<CascadeFit> {
        let scene: &SceneGpu = inputs.scene;
        if !scene.has_casters() || scene.caster_bounds.is_empty() {
            self.kept = None;
            return None;
        }
        let frustum =
            CameraFrustum::from_view_proj(inputs.uniforms.view_proj(), inputs.uniforms.eye())?;
        let casters = scene.caster_bounds.corners();
        let receivers = if scene.receiver_bounds.is_empty() {
            Vec::new()
        } else {
            scene.receiver_bounds.corners().to_vec()
        };
        let cascades = fit_cascades(inputs.light, &frustum, &casters, &receivers, settings, size);
        let uniform = CascadeUniform::new(&cascades, &frustum, size, settings.blend);
        let gpu = frame.gpu;
        gpu.queue
            .write_buffer(&self.uniform_buffer, 0, &uniform_bytes(&uniform));
        let same = self.kept.as_ref() == Some(&(size, cascades.clone()));
        if same && !inputs.changes.light_space() {
            return Some(CascadeFit {
                cascades,
                rebuilt: false,
            });
        }
        self.draw(frame, scene, &cascades, size, label);
        self.kept = Some((size, cascades.clone()));
        Some(CascadeFit {
            cascades,
            rebuilt: true,
        })
    }

    /// [`Self::render`] for technique `technique` (the passes `<technique>/shadow_map/<i>`), with
    /// the sun's parameters `params` and `size`² maps; when nothing is drawn (no casters, or no
    /// usable camera) `out` is written lit (`<technique>/no_casters`) and the fit is `None`.
    pub fn render_or_lit(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        (technique, params, size): (&str, &SunCascadeParams, u32),
        out: &VisibilityBuffer,
    ) -> Result<Option<CascadeFit>, TechniqueError> {
        let label = format!("{technique}/shadow_map");
        let fit = self.render(frame, inputs, &params.settings(), size, &label);
        if fit.is_none() {
            let group = inputs.frame_bind_group;
            out.write_unshadowed(frame, group, &format!("{technique}/no_casters"))?;
        }
        Ok(fit)
    }

    fn draw(
        &mut self,
        frame: &mut Frame<'_>,
        scene: &SceneGpu,
        cascades: &[Cascade],
        size: u32,
        label: &str,
    ) {
        let gpu = frame.gpu;
        let layers = cascades.len().max(1) as u32;
        if self.maps.as_ref().map(|m| (m.0, m.1)) != Some((size, layers)) {
            let texture = create_depth_maps(gpu, label, size, layers);
            let array = texture.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            });
            let views = (0..layers).map(|l| layer_view(&texture, l)).collect();
            self.maps = Some((size, layers, texture, array, views));
        }
        let views: Vec<ShadowViewUniform> = cascades
            .iter()
            .map(|c| ShadowViewUniform {
                light_view_proj: c.view.view_projection(),
                ..ShadowViewUniform::ZERO
            })
            .collect();
        self.depth.set_views(gpu, &views);
        let (_, _, _, _, layer_views) = self.maps.as_ref().expect("made above");
        for (i, target) in layer_views.iter().enumerate().take(cascades.len()) {
            let pass = format!("{label}/{i}");
            self.depth.record(frame, &pass, scene, i as u32, target);
        }
    }

    /// Drops the kept maps: the next render draws them.
    pub fn invalidate(&mut self) {
        self.kept = None;
    }

    /// The depth view of cascade `i` of the last maps drawn (a `texture_depth_2d`), if any.
    pub fn layer(&self, i: usize) -> Option<&wgpu::TextureView> {
        self.maps
            .as_ref()
            .and_then(|(_, _, _, _, layers)| layers.get(i))
    }

    /// Declares a pass that reads the cascades: group 1 is binding 0 = the `Cascades` uniform,
    /// 1 = the `texture_depth_2d_array`, 2 = the technique's parameter uniform. Run it with
    /// [`Self::draw_lookup`].
    pub fn lookup_pass<'a>(gpu: &'a Gpu, label: &str, spec: &'a ShaderSpec) -> PassBuilder<'a> {
        Pass::new(gpu, label, spec)
            .after_frame_group()
            .uniform()
            .texture(Slot::DEPTH_ARRAY)
            .uniform()
    }

    /// Draws `pass` (from [`Self::lookup_pass`]) over the last maps with `params` into `target`,
    /// timed as `label`. Draws nothing before the first maps.
    #[allow(clippy::too_many_arguments)]
    pub fn draw_lookup(
        &self,
        frame: &mut Frame<'_>,
        pass: &FullscreenPass,
        label: &str,
        frame_group: &wgpu::BindGroup,
        params: &wgpu::Buffer,
        target: &wgpu::TextureView,
        clear: Option<f64>,
    ) {
        let Some((_, _, _, array, _)) = self.maps.as_ref() else {
            return;
        };
        pass.run(frame)
            .named(label)
            .frame_group(frame_group)
            .read(&self.uniform_buffer)
            .read(array)
            .read(params)
            .draw(target, clear);
    }

    /// The maps' array texture, for debug views.
    pub fn maps_texture(&self) -> Option<&wgpu::Texture> {
        self.maps.as_ref().map(|m| &m.2)
    }

    /// Bytes of GPU memory `count` cascades of `size`² take (`Depth32Float`).
    pub fn map_bytes(size: u32, count: u32) -> f64 {
        4.0 * (size as f64).powi(2) * count.max(1) as f64
    }
}

#[cfg(test)]
mod tests;
