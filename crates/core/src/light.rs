//! The area light (a rectangle, a disk, a sphere, a spot or the sun: [`LightKind`]) and light
//! space.
//!
//! Light space (the convention of every paper implemented here): the light
//! centre is the origin, the light faces +z, and the light is the rectangle
//! `[-a, a] x [-b, b]` in the plane z = 0 with `a = width / 2`, `b = height / 2`
//! (a disk or a spot's source: the disk of `radius` in that plane; a sphere: centred at the
//! origin; the sun: +z is the direction its light travels).
//! A point's light-space z is therefore its distance in front of the light plane ("linear depth"),
//! which is the same for every sample point on the light.

use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};
use serde::{Deserialize, Serialize};

pub use crate::light_shape::{LightKind, LightSample, SunView};

/// A one-sided, uniformly emitting light of one of the [`LightKind`]s (a rectangle by default).
/// The fields a kind does not use are ignored (and kept, so switching kinds loses nothing).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AreaLight {
    /// Its shape ([`LightKind::Rect`] unless a scene says otherwise).
    #[serde(default)]
    pub kind: LightKind,
    /// Centre of the rectangle, world space.
    pub center: Vec3,
    /// Unit direction the light faces (its normal); light space +z.
    pub direction: Vec3,
    /// Hint for light space +y (the `height` edge). Only its part orthogonal to `direction` counts.
    pub up: Vec3,
    /// Extent along light space x, world units. May be 0 (a point or line light).
    pub width: f32,
    /// Extent along light space y, world units. May be 0.
    pub height: f32,
    /// Radiant intensity scale used by the shading pass.
    pub intensity: f32,
    /// Radius of a disk, a sphere or a spot's source disk, world units. 0: a point light.
    #[serde(default = "default_radius")]
    pub radius: f32,
    /// A spot's inner cone angle from its axis, degrees: full intensity inside it.
    #[serde(default = "default_cone_inner")]
    pub cone_inner_degrees: f32,
    /// A spot's outer cone angle from its axis, degrees: no light outside it (shading only: the
    /// visibility V is still the fraction of the source seen).
    #[serde(default = "default_cone_outer")]
    pub cone_outer_degrees: f32,
    /// The sun's angular diameter, degrees (0.53 for the real one). 0: a hard directional light.
    #[serde(default = "default_angular_diameter")]
    pub angular_diameter_degrees: f32,
}

fn default_radius() -> f32 {
    0.5
}
fn default_cone_inner() -> f32 {
    30.0
}
fn default_cone_outer() -> f32 {
    45.0
}
fn default_angular_diameter() -> f32 {
    0.53
}

impl Default for AreaLight {
    fn default() -> Self {
        Self {
            center: Vec3::new(0.0, 4.0, 0.0),
            direction: Vec3::NEG_Y,
            up: Vec3::Z,
            width: 1.0,
            height: 1.0,
            intensity: 1.0,
            kind: LightKind::Rect,
            radius: default_radius(),
            cone_inner_degrees: default_cone_inner(),
            cone_outer_degrees: default_cone_outer(),
            angular_diameter_degrees: default_angular_diameter(),
        }
    }
}

impl AreaLight {
    /// Looks from `center` towards `target`.
    pub fn looking_at(center: Vec3, target: Vec3, width: f32, height: f32) -> Self {
        let direction = (target - center).normalize_or(Vec3::NEG_Y);
        let up = if direction.y.abs() > 0.9 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        Self {
            center,
            direction,
            up,
            width,
            height,
            ..Self::default()
        }
    }

    /// Half extents `(a, b)` of the rectangle; for a disk, a sphere or a spot `(radius, radius)`
    /// (the square around the disk: a planar light's size for techniques that take one); for the
    /// sun 0 (it has no extent in light space: [`Self::sun_tan_half_angle`]).
    pub fn half_extent(&self) -> Vec2 {
        match self.kind {
            LightKind::Rect => Vec2::new(self.width, self.height) * 0.5,
            LightKind::Disk | LightKind::Sphere | LightKind::Spot => Vec2::splat(self.radius),
            LightKind::Sun => Vec2::ZERO,
        }
    }

    /// Area of the emitting surface a receiver sees (rect: width x height; disk, spot, sphere:
    /// pi r^2, the sphere's disk seen from far away; sun: 0).
    pub fn area(&self) -> f32 {
        match self.kind {
            LightKind::Rect => self.width * self.height,
            LightKind::Disk | LightKind::Sphere | LightKind::Spot => {
                std::f32::consts::PI * self.radius * self.radius
            }
            LightKind::Sun => 0.0,
        }
    }

    /// Tangent of the sun's angular radius (half its angular diameter).
    pub fn sun_tan_half_angle(&self) -> f32 {
        (self.angular_diameter_degrees.to_radians() * 0.5).tan()
    }

    /// Whether the light has no size (a point light or a hard directional light): one sample
    /// is the exact answer.
    pub fn is_point(&self) -> bool {
        match self.kind {
            LightKind::Rect => self.width <= 0.0 && self.height <= 0.0,
            LightKind::Disk | LightKind::Sphere | LightKind::Spot => self.radius <= 0.0,
            LightKind::Sun => self.angular_diameter_degrees <= 0.0,
        }
    }

    /// Orthonormal basis `(x, y, z)` of light space in world coordinates.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let z = self.direction.normalize_or(Vec3::NEG_Y);
        let mut x = self.up.cross(z);
        if x.length_squared() < 1e-12 {
            x = z.any_orthonormal_vector();
        }
        let x = x.normalize();
        let y = z.cross(x);
        (x, y, z)
    }

    /// World to light space (rigid).
    pub fn view(&self) -> Mat4 {
        let (x, y, z) = self.basis();
        let light_to_world = Mat4::from_cols(
            x.extend(0.0),
            y.extend(0.0),
            z.extend(0.0),
            self.center.extend(1.0),
        );
        light_to_world.inverse()
    }

    /// World position of the light-space point `(u, v, 0)` on the light plane.
    pub fn point_on_light(&self, u: f32, v: f32) -> Vec3 {
        let (x, y, _) = self.basis();
        self.center + x * u + y * v
    }

    /// A world-space point in light space.
    pub fn to_light_space(&self, world: Vec3) -> Vec3 {
        (self.view() * world.extend(1.0)).xyz()
    }

    /// Checks the light is usable; the error says what to change.
    pub fn validate(&self) -> Result<(), String> {
        let finite = self.center.is_finite()
            && self.direction.is_finite()
            && self.up.is_finite()
            && self.width.is_finite()
            && self.height.is_finite()
            && self.intensity.is_finite();
        if !finite {
            return Err(
                "light has a non-finite centre, direction, size or intensity: give finite numbers"
                    .into(),
            );
        }
        if self.direction.length_squared() < 1e-12 {
            return Err(
                "light direction is zero: give the direction the light faces, e.g. [0, -1, 0]"
                    .into(),
            );
        }
        if self.width < 0.0 || self.height < 0.0 {
            return Err(format!(
                "light size {}x{} is negative: width and height must be >= 0",
                self.width, self.height
            ));
        }
        crate::light_shape::validate_shape(self)
    }

    /// Hash of every field (for caches keyed by the light).
    pub fn content_hash(&self) -> u64 {
        let mut h = crate::scene::Fnv1a::default();
        h.write_f32s(&self.center.to_array());
        h.write_f32s(&self.direction.to_array());
        h.write_f32s(&self.up.to_array());
        h.write_f32s(&[self.width, self.height, self.intensity]);
        // A rect light hashes as before the kinds existed (caches on disk stay valid).
        if self.kind != LightKind::Rect {
            h.write_u64(self.kind as u64);
            h.write_f32s(&[
                self.radius,
                self.cone_inner_degrees,
                self.cone_outer_degrees,
                self.angular_diameter_degrees,
            ]);
        }
        h.finish()
    }
}

/// A perspective light-view window, expressed in *slope space*: a light-space point `(x, y, z)`
/// seen from the eye `(ex, ey, 0)` on the light plane has slopes `s = (x - ex) / z`,
/// `t = (y - ey) / z`. Shadow-map texel `(i, j)` of an `n x n` map covers
/// `s in s_min + (i + [0, 1]) * (s_max - s_min) / n` (and likewise `t`), with texel row 0 at `t_max`
/// (texture v grows downwards).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlopeFrustum {
    /// Eye position on the light plane, light-space (x, y).
    pub eye: Vec2,
    /// Smallest s slope of the window.
    pub s_min: f32,
    /// Largest s slope of the window.
    pub s_max: f32,
    /// Smallest t slope of the window.
    pub t_min: f32,
    /// Largest t slope of the window.
    pub t_max: f32,
    /// Near light-space depth (z).
    pub near: f32,
    /// Far light-space depth (z).
    pub far: f32,
}

impl SlopeFrustum {
    /// Tightest window from `eye` (on the light plane) that covers the light-space points,
    /// made square in slope space so texels are square, with a small margin. Points at or behind
    /// the light plane are ignored (a one-sided light cannot reach them). Returns `None` when
    /// nothing lies in front of the light.
    pub fn fit(eye: Vec2, light_space_points: &[Vec3]) -> Option<Self> {
        let (zmin, zmax) = depth_range(light_space_points)?;
        let window = slope_window(eye, light_space_points, (zmin * 0.5).max(Z_FLOOR))?;
        Some(Self::from_window(eye, window, zmin * 0.98, zmax * 1.02))
    }

    /// A window over `casters` (light-space points, e.g. the corners of their bounds) clipped to
    /// the slopes at which `receivers` are seen from `eye`, for hard shadow maps: a caster seen
    /// at a slope where no receiver is cannot shadow anything through this eye, and clipping
    /// keeps the texels where they are needed when the casters subtend a huge angle (an occluder
    /// next to the light, `stiff-depth-range`). When `casters_cross_light_plane`, the casters'
    /// slopes are unbounded, so the receivers alone bound the window and the near plane drops to
    /// 1e-3 of the far one (`stiff-partly-outside`). Receivers that reach the light plane (a
    /// point at or behind it) have unbounded slopes too: they count only from the nearest
    /// caster's depth on (where a shadow can begin; with casters crossing too, from the larger of
    /// the near plane and 1/16 of the receivers' far depth), so the part behind the plane neither
    /// widens, shifts nor empties the window (`stiff-receiver-behind-light`). `None` when nothing
    /// in front of the light can shadow a receiver.
    pub fn fit_clipped(
        eye: Vec2,
        casters: &[Vec3],
        casters_cross_light_plane: bool,
        receivers: &[Vec3],
    ) -> Option<Self> {
        let (zmin, zmax) = depth_range(casters)?;
        let near = if casters_cross_light_plane {
            (zmax * 1e-3).max(Z_FLOOR)
        } else {
            zmin * 0.98
        };
        let clip = receiver_clip_depth(casters_cross_light_plane, zmin, near, receivers)?;
        let receiver_window = slope_window(eye, receivers, clip)?;
        let window = if casters_cross_light_plane {
            receiver_window
        } else {
            let caster_window = slope_window(eye, casters, (zmin * 0.5).max(Z_FLOOR))?;
            let clipped = [
                caster_window[0].max(receiver_window[0]),
                caster_window[1].min(receiver_window[1]),
                caster_window[2].max(receiver_window[2]),
                caster_window[3].min(receiver_window[3]),
            ];
            if clipped[0] > clipped[1] || clipped[2] > clipped[3] {
                return None;
            }
            clipped
        };
        Some(Self::from_window(eye, window, near, zmax * 1.02))
    }

    /// Like [`Self::fit`] over `casters`, for techniques that need every caster (penumbrae reach
    /// receivers from casters seen at other slopes). When `casters_cross_light_plane` their
    /// slopes are unbounded: the window then also covers the receivers' slopes (where the
    /// unbounded part can matter) from half their nearest depth in front of the light on, and
    /// the near plane drops to 1e-3 of the far one. (Not [`Self::fit_clipped`]'s cut: callers
    /// pass the corners of world boxes here, e.g. `pdsm`'s whole static scene, whose corners
    /// reach behind the light without any receiver doing so, and that cut widened `pdsm`'s
    /// window on `stiff-partly-outside` eightfold.)
    pub fn fit_casters(
        eye: Vec2,
        casters: &[Vec3],
        casters_cross_light_plane: bool,
        receivers: &[Vec3],
    ) -> Option<Self> {
        if !casters_cross_light_plane {
            return Self::fit(eye, casters);
        }
        let (zmin, zmax) = depth_range(casters)?;
        let near = (zmax * 1e-3).max(Z_FLOOR);
        let mut window = slope_window(eye, casters, (zmin * 0.5).max(Z_FLOOR))?;
        let clip = depth_range(receivers).map(|(rzmin, _)| (rzmin * 0.5).max(Z_FLOOR));
        if let Some(r) = clip.and_then(|clip| slope_window(eye, receivers, clip)) {
            window = [
                window[0].min(r[0]),
                window[1].max(r[1]),
                window[2].min(r[2]),
                window[3].max(r[3]),
            ];
        }
        Some(Self::from_window(eye, window, near, zmax * 1.02))
    }

    /// Square window around `[s0, s1, t0, t1]` with a 2 % margin and a floor (so a flat scene
    /// still gets a usable window), between `near` and `far`.
    fn from_window(eye: Vec2, window: [f32; 4], near: f32, far: f32) -> Self {
        let [s0, s1, t0, t1] = window;
        let half = ((s1 - s0).max(t1 - t0) * 0.5 * 1.02).max(1e-3);
        let (sc, tc) = ((s0 + s1) * 0.5, (t0 + t1) * 0.5);
        let near = near.max(Z_FLOOR);
        let far = far.max(near * 1.01 + 1e-4);
        Self {
            eye,
            s_min: sc - half,
            s_max: sc + half,
            t_min: tc - half,
            t_max: tc + half,
            near,
            far,
        }
    }

    /// Light space to clip space for this window (off-axis perspective, depth in [0, 1] over
    /// [near, far]).
    pub fn projection(&self) -> Mat4 {
        let (n, f) = (self.near, self.far);
        let (l, r, b, t) = (
            self.s_min * n,
            self.s_max * n,
            self.t_min * n,
            self.t_max * n,
        );
        // Off-axis perspective with z in [0, 1] (wgpu convention), eye at (ex, ey, 0) looking down +z.
        let proj = Mat4::from_cols(
            glam::Vec4::new(2.0 * n / (r - l), 0.0, 0.0, 0.0),
            glam::Vec4::new(0.0, 2.0 * n / (t - b), 0.0, 0.0),
            glam::Vec4::new(-(r + l) / (r - l), -(t + b) / (t - b), f / (f - n), 1.0),
            glam::Vec4::new(0.0, 0.0, -f * n / (f - n), 0.0),
        );
        proj * Mat4::from_translation(Vec3::new(-self.eye.x, -self.eye.y, 0.0))
    }
}

/// Depths closer than this to the light plane are treated as on it.
const Z_FLOOR: f32 = 1e-4;

/// Depth range of the points strictly in front of the light (z > [`Z_FLOOR`]).
fn depth_range(points: &[Vec3]) -> Option<(f32, f32)> {
    let (mut zmin, mut zmax) = (f32::INFINITY, f32::NEG_INFINITY);
    for p in points.iter().filter(|p| p.z > Z_FLOOR) {
        zmin = zmin.min(p.z);
        zmax = zmax.max(p.z);
    }
    zmin.is_finite().then_some((zmin, zmax))
}

/// The depth from which receivers count when a window is clipped to them: points nearer the
/// light are moved onto it ([`slope_window`]), which for the corners of a box is exactly the box
/// cut at that depth. `None` when no receiver lies beyond it (nothing can be shadowed).
///
/// Receivers entirely in front of the light are taken whole (half their nearest depth: a clip
/// that cuts nothing). Receivers reaching the light plane have unbounded slopes, so they are cut
/// where shadows can begin: at the casters' nearest depth (a receiver nearer the light than
/// every caster has nothing between it and the light), or, when the casters cross the plane too,
/// at the larger of the map's near plane and [`BOTH_CROSS_RECEIVER_CUT`] of the receivers' far
/// depth (a cut at the near plane alone would widen the window a thousandfold).
fn receiver_clip_depth(
    casters_cross_light_plane: bool,
    casters_zmin: f32,
    near: f32,
    receivers: &[Vec3],
) -> Option<f32> {
    let (rzmin, rzmax) = depth_range(receivers)?;
    let reaches_plane = receivers.iter().any(|p| p.z <= Z_FLOOR);
    let clip = match (reaches_plane, casters_cross_light_plane) {
        (false, _) => (rzmin * 0.5).max(Z_FLOOR),
        (true, false) => casters_zmin,
        (true, true) => near.max(rzmax * BOTH_CROSS_RECEIVER_CUT),
    };
    (rzmax > clip).then_some(clip)
}

/// Where casters and receivers both cross the light plane, receivers nearer the light than this
/// fraction of their far depth are left out of the window (their slopes are unbounded and a
/// shadow there is seen from the light centre at more than 86 degrees off its normal).
const BOTH_CROSS_RECEIVER_CUT: f32 = 1.0 / 16.0;

/// Slope window `[s0, s1, t0, t1]` of `points` seen from `eye`. Points closer than `z_clamp` to
/// the light plane (or behind it) are moved onto the plane `z_clamp`, so the window still covers
/// the part of a box the light can see.
fn slope_window(eye: Vec2, points: &[Vec3], z_clamp: f32) -> Option<[f32; 4]> {
    let mut w = [
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
    ];
    for p in points {
        let z = p.z.max(z_clamp);
        let (s, t) = ((p.x - eye.x) / z, (p.y - eye.y) / z);
        w = [w[0].min(s), w[1].max(s), w[2].min(t), w[3].max(t)];
    }
    (w[0].is_finite() && w[1].is_finite() && w[2].is_finite() && w[3].is_finite()).then_some(w)
}

#[cfg(test)]
mod tests {
    //! Every fit against the cases that broke `hard` (issue 44): receivers crossing the light
    //! plane, casters crossing it, both, and a light facing almost along a receiver. Each case is
    //! a real scene's triangles in light space ([`LightBounds::of_triangles`]), so the boxes the
    //! fits see are the ones `SceneGpu::light_bounds` hands them.
    use super::*;
    use crate::scene_gpu::LightBounds;

    /// A horizontal rectangle `size` (along x, z) at height `y`, centred at (`x`, `z`): 4
    /// positions and 2 triangles appended to `positions` / `indices`.
    fn rectangle(
        positions: &mut Vec<Vec3>,
        indices: &mut Vec<u32>,
        x: f32,
        y: f32,
        z: f32,
        size: Vec2,
    ) {
        let base = positions.len() as u32;
        let h = size * 0.5;
        for (dx, dz) in [(-h.x, -h.y), (h.x, -h.y), (h.x, h.y), (-h.x, h.y)] {
            positions.push(Vec3::new(x + dx, y, z + dz));
        }
        indices.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
    }

    /// A vertical wall in the plane x = `x`, from y = `y0` to `y1`, z in [-0.3, 0.3].
    fn wall(positions: &mut Vec<Vec3>, indices: &mut Vec<u32>, x: f32, y0: f32, y1: f32) {
        let base = positions.len() as u32;
        for (y, z) in [(y0, -0.3), (y0, 0.3), (y1, 0.3), (y1, -0.3)] {
            positions.push(Vec3::new(x, y, z));
        }
        indices.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
    }

    /// Light-space casters' and receivers' box corners and flags, as `fit_hard_view` sees them.
    struct Case {
        bounds: LightBounds,
        casters: Vec<Vec3>,
        receivers: Vec<Vec3>,
        /// Light-space points on casters whose shadow from the light centre falls on a receiver.
        must_cover: Vec<Vec3>,
    }

    fn case(light: &AreaLight, positions: &[Vec3], casters: &[u32], receivers: &[u32]) -> Case {
        let bounds = LightBounds::of_triangles(light, positions, casters, receivers);
        let corners = |b: Option<crate::scene::Aabb>| b.map(|b| b.corners().to_vec());
        Case {
            bounds,
            casters: corners(bounds.casters).unwrap_or_default(),
            receivers: corners(bounds.receivers).unwrap_or_default(),
            must_cover: Vec::new(),
        }
    }

    fn covers(f: &SlopeFrustum, p: Vec3) -> bool {
        let (s, t) = ((p.x - f.eye.x) / p.z, (p.y - f.eye.y) / p.z);
        (f.s_min..=f.s_max).contains(&s) && (f.t_min..=f.t_max).contains(&t)
    }

    /// The scene: a 2 x 2 square at height 1 over a ground from x = `x0` to `x1` (14
    /// deep along z), under a light at (6, 3, 0) aimed at (-3, 0, 0): the light plane cuts the
    /// ground at x = 7, so a ground to x = 7 ends on it and a longer one reaches behind it.
    fn oblique(x0: f32, x1: f32) -> Case {
        let light = AreaLight::looking_at(
            Vec3::new(6.0, 3.0, 0.0),
            Vec3::new(-3.0, 0.0, 0.0),
            1.0,
            1.0,
        );
        let (mut positions, mut receivers, mut casters) = (Vec::new(), Vec::new(), Vec::new());
        let ground = Vec2::new(x1 - x0, 14.0);
        rectangle(
            &mut positions,
            &mut receivers,
            (x0 + x1) * 0.5,
            0.0,
            0.0,
            ground,
        );
        rectangle(
            &mut positions,
            &mut casters,
            0.0,
            1.0,
            0.0,
            Vec2::splat(2.0),
        );
        let mut c = case(&light, &positions, &casters, &receivers);
        c.must_cover = positions[4..]
            .iter()
            .map(|p| light.to_light_space(*p))
            .collect();
        c
    }

    fn hard_fit(c: &Case) -> Option<SlopeFrustum> {
        SlopeFrustum::fit_clipped(
            Vec2::ZERO,
            &c.casters,
            c.bounds.casters_cross_light_plane,
            &c.receivers,
        )
    }

    fn caster_fit(c: &Case) -> Option<SlopeFrustum> {
        SlopeFrustum::fit_casters(
            Vec2::ZERO,
            &c.casters,
            c.bounds.casters_cross_light_plane,
            &c.receivers,
        )
    }

    #[test]
    fn clipped_bounds_count_where_a_triangle_crosses_the_plane() {
        let light = AreaLight::looking_at(Vec3::Y, Vec3::ZERO, 1.0, 1.0);
        // One triangle from 1 below the light (y = 0) to 1 above it (y = 2), x from -1 to 3.
        let positions = [
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(3.0, 2.0, 0.0),
            Vec3::new(-1.0, 2.0, 0.0),
        ];
        let b = LightBounds::of_triangles(&light, &positions, &[0, 1, 2], &[0, 1, 2]);
        let r = b
            .receivers
            .expect("half the triangle is in front of the light");
        assert!(b.receivers_cross_light_plane && b.casters_cross_light_plane);
        assert_eq!(r.min.z, 0.0);
        assert!((r.max.z - 1.0).abs() < 1e-6);
        // Its vertices in front span x = -1 only; where its edges cross the plane, x = -1 to 1.
        assert!((r.max.x - r.min.x - 2.0).abs() < 1e-5, "{r:?}");
        // Entirely behind: nothing; out-of-range indices: skipped.
        let behind = LightBounds::of_triangles(&light, &positions, &[], &[1, 2, 9]);
        assert_eq!(
            (behind.receivers, behind.receivers_cross_light_plane),
            (None, false)
        );
        let touching = [
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ];
        let touching = LightBounds::of_triangles(&light, &touching, &[0, 1, 2], &[]);
        assert_eq!(
            touching.casters, None,
            "a triangle touching the plane from behind"
        );
    }

    #[test]
    fn hard_fit_over_receivers_crossing_the_plane_covers_the_shadow_and_ignores_what_is_behind() {
        let inside = oblique(-7.0, 1.0);
        let on_plane = oblique(-7.0, 7.0);
        let behind = oblique(-7.0, 30.0);
        assert!(!inside.bounds.receivers_cross_light_plane);
        assert!(
            on_plane.bounds.receivers_cross_light_plane
                && behind.bounds.receivers_cross_light_plane
        );
        assert!(!behind.bounds.casters_cross_light_plane);
        for (name, c) in [
            ("inside", &inside),
            ("on the plane", &on_plane),
            ("behind", &behind),
        ] {
            let f = hard_fit(c).unwrap_or_else(|| panic!("{name}: no window"));
            for p in &c.must_cover {
                assert!(covers(&f, *p), "{name}: {f:?} misses caster point {p}");
            }
            // Clipping to the receivers never widens the casters' own window.
            let own = SlopeFrustum::fit(Vec2::ZERO, &c.casters).unwrap();
            assert!(
                f.s_max - f.s_min <= own.s_max - own.s_min + 1e-6,
                "{name}: {f:?} wider than {own:?}"
            );
        }
        // The part behind the plane neither widens, shifts nor empties the window.
        let (a, b) = (hard_fit(&on_plane).unwrap(), hard_fit(&behind).unwrap());
        let (a, b) = (
            [a.s_min, a.s_max, a.t_min, a.t_max, a.near, a.far],
            [b.s_min, b.s_max, b.t_min, b.t_max, b.near, b.far],
        );
        assert!(
            a.iter()
                .zip(&b)
                .all(|(x, y)| (x - y).abs() <= 1e-4 * x.abs().max(1.0)),
            "{a:?} / {b:?}"
        );
    }

    #[test]
    fn caster_fit_and_plain_fit_over_receivers_crossing_the_plane() {
        let c = oblique(-7.0, 30.0);
        let f = caster_fit(&c).expect("the square casts");
        assert!(c.must_cover.iter().all(|p| covers(&f, *p)), "{f:?}");
        assert_eq!(Some(f), SlopeFrustum::fit(Vec2::ZERO, &c.casters));
        // A plain fit of the receivers' box reaching the plane: finite, covering its far half.
        let r = SlopeFrustum::fit(Vec2::ZERO, &c.receivers).expect("receivers in front");
        assert!([r.s_min, r.s_max, r.t_min, r.t_max, r.near, r.far]
            .iter()
            .all(|v| v.is_finite()));
        let deep = c.bounds.receivers.unwrap().max.z;
        assert!(r.far >= deep && r.near > 0.0, "{r:?}");
    }

    /// A wall from y = 1 to 3 at x = 0.8 beside a downward light at height 2 (the wall crosses the
    /// light plane), over a ground of side `ground` at height `ground_y`.
    /// A downward light at height 2 (light-space x = world x, depth = 2 - world y).
    fn down_light() -> AreaLight {
        AreaLight {
            center: Vec3::Y * 2.0,
            direction: Vec3::NEG_Y,
            up: Vec3::Z,
            ..AreaLight::default()
        }
    }

    /// Light-space points of the wall from [`wall_case`] whose shadow falls on the 8 x 8 ground.
    fn wall_points_shadowing_the_ground() -> Vec<Vec3> {
        [0.9f32, 0.6, 0.45]
            .iter()
            .map(|&depth| Vec3::new(0.8, 0.0, depth))
            .collect()
    }

    /// `stiff-partly-outside`: a wall from y = 1 to 3 at x = 0.8 beside the downward light at
    /// height 2 (the wall crosses the light plane), over an 8 x 8 ground.
    fn wall_case() -> Case {
        let (mut positions, mut receivers, mut casters) = (Vec::new(), Vec::new(), Vec::new());
        rectangle(
            &mut positions,
            &mut receivers,
            0.0,
            0.0,
            0.0,
            Vec2::splat(8.0),
        );
        wall(&mut positions, &mut casters, 0.8, 1.0, 3.0);
        let mut c = case(&down_light(), &positions, &casters, &receivers);
        c.must_cover = wall_points_shadowing_the_ground();
        c
    }

    #[test]
    fn fits_over_casters_crossing_the_plane() {
        let c = wall_case();
        assert!(c.bounds.casters_cross_light_plane && !c.bounds.receivers_cross_light_plane);
        for (name, f) in [("hard", hard_fit(&c)), ("casters", caster_fit(&c))] {
            let f = f.unwrap_or_else(|| panic!("{name}: no window"));
            assert!(
                f.near <= f.far * 1.1e-3,
                "{name}: near {} far {}",
                f.near,
                f.far
            );
            for p in &c.must_cover {
                assert!(covers(&f, *p), "{name}: {f:?} misses wall point {p}");
            }
        }
    }

    #[test]
    fn fits_over_casters_and_receivers_both_crossing_the_plane() {
        // stiff-partly-outside with a receiver wall at x = -1.5 through the light plane too. The
        // caster wall's shadow on the ground stays in the window, which stays within 16 times
        // the ground's window at its depth (receivers nearer than 1/16 of it are cut).
        let (mut positions, mut receivers, mut casters) = (Vec::new(), Vec::new(), Vec::new());
        rectangle(
            &mut positions,
            &mut receivers,
            0.0,
            0.0,
            0.0,
            Vec2::splat(8.0),
        );
        wall(&mut positions, &mut receivers, -1.5, 1.0, 3.0);
        wall(&mut positions, &mut casters, 0.8, 1.0, 3.0);
        let mut c = case(&down_light(), &positions, &casters, &receivers);
        c.must_cover = wall_points_shadowing_the_ground();
        assert!(c.bounds.casters_cross_light_plane && c.bounds.receivers_cross_light_plane);
        let ground_window = 8.0 / 2.0;
        for (name, f) in [("hard", hard_fit(&c)), ("casters", caster_fit(&c))] {
            let f = f.unwrap_or_else(|| panic!("{name}: no window"));
            assert!(c.must_cover.iter().all(|p| covers(&f, *p)), "{name}: {f:?}");
            assert!(
                f.s_max - f.s_min <= 16.0 * ground_window * 1.05,
                "{name}: {f:?} too wide"
            );
        }
    }

    #[test]
    fn fits_under_a_light_facing_almost_along_the_receiver() {
        // The light 0.5 above a 10 x 8 ground (x from -5 to 5), at x = 4, tilted 1 degree down
        // from the horizontal, facing a wall from y = 0.05 to 0.35 at x = 2: the ground runs
        // from behind the light plane to 9 deep, seen at 1 degree.
        let tilt = 1f32.to_radians();
        let direction = Vec3::new(-tilt.cos(), -tilt.sin(), 0.0);
        let light = AreaLight {
            center: Vec3::new(4.0, 0.5, 0.0),
            direction,
            up: Vec3::Y,
            width: 0.2,
            height: 0.2,
            ..AreaLight::default()
        };
        let (mut positions, mut receivers, mut casters) = (Vec::new(), Vec::new(), Vec::new());
        rectangle(
            &mut positions,
            &mut receivers,
            0.0,
            0.0,
            0.0,
            Vec2::new(10.0, 8.0),
        );
        wall(&mut positions, &mut casters, 2.0, 0.05, 0.35);
        let c = case(&light, &positions, &casters, &receivers);
        assert!(c.bounds.receivers_cross_light_plane && !c.bounds.casters_cross_light_plane);
        let corners: Vec<Vec3> = positions[4..]
            .iter()
            .map(|p| light.to_light_space(*p))
            .collect();
        for (name, f) in [("hard", hard_fit(&c)), ("casters", caster_fit(&c))] {
            let f = f.unwrap_or_else(|| panic!("{name}: no window"));
            // Every corner of the wall shadows the ground behind it (at x = 1.8 and -2.7).
            assert!(corners.iter().all(|p| covers(&f, *p)), "{name}: {f:?}");
            assert!([f.s_min, f.s_max, f.t_min, f.t_max]
                .iter()
                .all(|v| v.is_finite()));
        }
        // A light whose plane holds the ground (facing up from it): no receiver can be lit.
        let up = AreaLight {
            center: Vec3::ZERO,
            direction: Vec3::Y,
            up: Vec3::Z,
            ..light
        };
        let flat =
            LightBounds::of_triangles(&up, &positions, &[4, 5, 6, 4, 6, 7], &[0, 1, 2, 0, 2, 3]);
        assert_eq!(
            (flat.receivers, flat.receivers_cross_light_plane),
            (None, false)
        );
    }
}
