//! The rectangular area light and light space.
//!
//! Light space (the convention of every paper here and of `shared/notes/ALGORITHMS.md`): the light
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

    pub fn to_light_space(&self, world: Vec3) -> Vec3 {
        (self.view() * world.extend(1.0)).xyz()
    }

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
    pub s_min: f32,
    pub s_max: f32,
    pub t_min: f32,
    pub t_max: f32,
    /// Near and far light-space depths (z).
    pub near: f32,
    pub far: f32,
}

impl SlopeFrustum {
    /// Tightest window from `eye` (on the light plane) that covers the light-space points,
    /// made square in slope space so texels are square, with a small margin. Points at or behind
    /// the light plane are ignored (a one-sided light cannot reach them). Returns `None` when
    /// nothing lies in front of the light.
    pub fn fit(eye: Vec2, light_space_points: &[Vec3]) -> Option<Self> {
        let z_floor = 1e-4_f32;
        let mut zmin = f32::INFINITY;
        let mut zmax = f32::NEG_INFINITY;
        for p in light_space_points {
            if p.z > z_floor {
                zmin = zmin.min(p.z);
                zmax = zmax.max(p.z);
            }
        }
        if !zmin.is_finite() {
            return None;
        }
        // Corners behind the light plane are clamped onto a plane just in front of it, so the
        // window still covers the part of the box the light can see.
        let z_clamp = (zmin * 0.5).max(z_floor);
        let (mut s0, mut s1, mut t0, mut t1) = (
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
        );
        for p in light_space_points {
            let z = p.z.max(z_clamp);
            let s = (p.x - eye.x) / z;
            let t = (p.y - eye.y) / z;
            s0 = s0.min(s);
            s1 = s1.max(s);
            t0 = t0.min(t);
            t1 = t1.max(t);
        }
        // Square window, 2 % margin, and a floor so a flat scene still gets a usable window.
        let half = ((s1 - s0).max(t1 - t0) * 0.5 * 1.02).max(1e-3);
        let (sc, tc) = ((s0 + s1) * 0.5, (t0 + t1) * 0.5);
        let near = (zmin * 0.98).max(z_floor);
        let far = (zmax * 1.02).max(near * 1.01 + 1e-4);
        Some(Self {
            eye,
            s_min: sc - half,
            s_max: sc + half,
            t_min: tc - half,
            t_max: tc + half,
            near,
            far,
        })
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
