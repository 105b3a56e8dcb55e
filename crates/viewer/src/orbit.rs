//! Orbit / pan / zoom camera control around a target point.

use softshadow_core::{glam::Vec3, Camera};

/// Spherical coordinates of the eye around `target`; converted to a [`Camera`] every frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    pub target: Vec3,
    /// Radians around +y, 0 looking down -z.
    pub yaw: f32,
    /// Radians above the horizon (kept inside +-89 degrees so `up` never aligns with the view).
    pub pitch: f32,
    pub distance: f32,
}

const MAX_PITCH: f32 = 89.0 * std::f32::consts::PI / 180.0;

impl Orbit {
    /// The orbit that reproduces `camera`'s eye and target.
    pub fn from_camera(camera: &Camera) -> Self {
        let offset = camera.eye - camera.target;
        let distance = offset.length().max(1e-3);
        Self {
            target: camera.target,
            yaw: offset.x.atan2(offset.z),
            pitch: (offset.y / distance).clamp(-1.0, 1.0).asin(),
            distance,
        }
    }

    pub fn eye(&self) -> Vec3 {
        let (sin_yaw, cos_yaw) = self.yaw.sin_cos();
        let (sin_pitch, cos_pitch) = self.pitch.sin_cos();
        self.target + self.distance * Vec3::new(cos_pitch * sin_yaw, sin_pitch, cos_pitch * cos_yaw)
    }

    /// Writes eye, target and up into `camera` (field of view and clip planes are kept).
    pub fn apply(&self, camera: &mut Camera) {
        camera.eye = self.eye();
        camera.target = self.target;
        camera.up = Vec3::Y;
    }

    /// Rotates by a pointer drag of `(dx, dy)` pixels.
    pub fn rotate(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx * 0.008;
        self.pitch = (self.pitch + dy * 0.008).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Moves the target in the view plane by a drag of `(dx, dy)` pixels on an image
    /// `height` pixels tall with vertical field of view `fov_y_degrees`.
    pub fn pan(&mut self, dx: f32, dy: f32, height: f32, fov_y_degrees: f32) {
        let forward = (self.target - self.eye()).normalize_or(Vec3::NEG_Z);
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        let up = right.cross(forward);
        // World units per pixel at the target's distance.
        let scale =
            2.0 * self.distance * (fov_y_degrees.to_radians() * 0.5).tan() / height.max(1.0);
        self.target += (-dx * right + dy * up) * scale;
    }

    /// Zooms by `steps` (positive = closer), multiplicatively so it feels the same at any scale.
    pub fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * (-steps * 0.1).exp()).clamp(1e-2, 1e4);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_the_eye_and_zoom_moves_along_the_view() {
        let camera = Camera::default();
        let orbit = Orbit::from_camera(&camera);
        assert!((orbit.eye() - camera.eye).length() < 1e-4);
        let mut closer = orbit;
        closer.zoom(5.0);
        assert!(closer.distance < orbit.distance);
        let direction = (closer.eye() - camera.target).normalize();
        assert!((direction - (camera.eye - camera.target).normalize()).length() < 1e-4);
        let mut turned = orbit;
        turned.rotate(0.0, 1e6);
        assert!(turned.pitch <= MAX_PITCH);
        let mut moved = orbit;
        moved.apply(&mut Camera::default());
        moved.pan(10.0, 0.0, 100.0, 45.0);
        assert!((moved.target - orbit.target).length() > 0.0);
        assert!((moved.target.y - orbit.target.y).abs() < 1e-5);
    }
}
