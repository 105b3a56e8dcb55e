//! The rectangular area light and light space.
//!
//! Light space (the convention of every paper implemented here): the light
//! centre is the origin, the light faces +z, and the light is the rectangle
//! `[-a, a] x [-b, b]` in the plane z = 0 with `a = width / 2`, `b = height / 2`.
//! A point's light-space z is therefore its distance in front of the light plane ("linear depth"),
//! which is the same for every sample point on the light.

use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};
use serde::{Deserialize, Serialize};

/// A one-sided, uniformly emitting rectangular light.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AreaLight {
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

    /// Half extents `(a, b)` of the rectangle.
    pub fn half_extent(&self) -> Vec2 {
        Vec2::new(self.width, self.height) * 0.5
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
        Ok(())
    }

    /// Hash of every field (for caches keyed by the light).
    pub fn content_hash(&self) -> u64 {
        let mut h = crate::scene::Fnv1a::default();
        h.write_f32s(&self.center.to_array());
        h.write_f32s(&self.direction.to_array());
        h.write_f32s(&self.up.to_array());
        h.write_f32s(&[self.width, self.height, self.intensity]);
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
    /// 1e-3 of the far one (`stiff-partly-outside`). `None` when nothing in front of the light
    /// can shadow a receiver.
    pub fn fit_clipped(
        eye: Vec2,
        casters: &[Vec3],
        casters_cross_light_plane: bool,
        receivers: &[Vec3],
    ) -> Option<Self> {
        let (zmin, zmax) = depth_range(casters)?;
        let (rzmin, _) = depth_range(receivers)?;
        let receiver_window = slope_window(eye, receivers, (rzmin * 0.5).max(Z_FLOOR))?;
        let (window, near) = if casters_cross_light_plane {
            (receiver_window, (zmax * 1e-3).max(Z_FLOOR))
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
            (clipped, zmin * 0.98)
        };
        Some(Self::from_window(eye, window, near, zmax * 1.02))
    }

    /// Like [`Self::fit`] over `casters`, for techniques that need every caster (penumbrae reach
    /// receivers from casters seen at other slopes). When `casters_cross_light_plane` their
    /// slopes are unbounded: the window then also covers the receivers' slopes (where the
    /// unbounded part can matter) and the near plane drops to 1e-3 of the far one.
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
        let mut window = slope_window(eye, casters, (zmin * 0.5).max(Z_FLOOR))?;
        if let Some((rzmin, _)) = depth_range(receivers) {
            if let Some(r) = slope_window(eye, receivers, (rzmin * 0.5).max(Z_FLOOR)) {
                window = [
                    window[0].min(r[0]),
                    window[1].max(r[1]),
                    window[2].min(r[2]),
                    window[3].max(r[3]),
                ];
            }
        }
        Some(Self::from_window(
            eye,
            window,
            (zmax * 1e-3).max(Z_FLOOR),
            zmax * 1.02,
        ))
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
