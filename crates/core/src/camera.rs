//! Perspective camera.

use glam::{Mat4, Vec3};
use serde::{Deserialize, Serialize};

/// A perspective camera looking from `eye` at `target`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Camera position in world space.
    pub eye: Vec3,
    /// The point looked at.
    pub target: Vec3,
    /// Up direction (need not be orthogonal to the view direction, must not be parallel to it).
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub fov_y_degrees: f32,
    /// Near clipping distance.
    pub near: f32,
    /// Far clipping distance.
    pub far: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            eye: Vec3::new(0.0, 5.0, 6.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_degrees: 45.0,
            near: 0.05,
            far: 100.0,
        }
    }
}

impl Camera {
    /// World to view (right-handed, looking down -z).
    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }

    /// Right-handed perspective with depth in [0, 1].
    pub fn projection(&self, aspect: f32) -> Mat4 {
        glam::camera::rh::proj::directx::perspective(
            self.fov_y_degrees.to_radians(),
            aspect,
            self.near,
            self.far,
        )
    }

    /// Projection times view for frames of width / height `aspect`.
    pub fn view_projection(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }

    /// Checks the camera is usable; the error says what to change.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.eye.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return Err("camera eye, target or up is not finite: give finite numbers".into());
        }
        if (self.target - self.eye).length_squared() < 1e-12 {
            return Err("camera eye and target coincide: move the target away from the eye".into());
        }
        if (self.target - self.eye).cross(self.up).length_squared() < 1e-12 {
            return Err(
                "camera up is parallel to the view direction: pick another up vector".into(),
            );
        }
        if !(self.fov_y_degrees > 1.0 && self.fov_y_degrees < 179.0) {
            return Err(format!(
                "camera fov_y_degrees = {} is out of range: use 1 to 179",
                self.fov_y_degrees
            ));
        }
        if !(self.near > 0.0 && self.far > self.near && self.far.is_finite()) {
            return Err(format!(
                "camera near = {}, far = {}: need 0 < near < far < infinity",
                self.near, self.far
            ));
        }
        Ok(())
    }

    /// Hash of every field (for caches keyed by the view).
    pub fn content_hash(&self) -> u64 {
        let mut h = crate::scene::Fnv1a::default();
        h.write_f32s(&self.eye.to_array());
        h.write_f32s(&self.target.to_array());
        h.write_f32s(&self.up.to_array());
        h.write_f32s(&[self.fov_y_degrees, self.near, self.far]);
        h.finish()
    }
}
