//! The light kinds ([`LightKind`]) and the one place their shapes are sampled on the CPU
//! ([`AreaLight::sample`]); `shaders/common/frame.wgsl` (`light_sample`) is its WGSL twin, so no
//! technique repeats the shape maths.
//!
//! The contract stays V = fraction of the light's surface visible from the receiver point:
//! - `rect`: the rectangle (`width` x `height`) in the light plane;
//! - `disk`: the disk of `radius` in the light plane;
//! - `sphere`: the sphere of `radius` around `center`; seen from a receiver point it is the disk
//!   of its silhouette (the disk of the tangent cone's circle of contact), and V is the fraction
//!   of that disk's area visible (close to the fraction of the sphere's solid angle: a ray's
//!   share of the disk grows toward the rim by up to sec³ of the disk's half-angle, 1.54x at
//!   twice the radius from the centre);
//! - `spot`: a disk source of `radius` in the light plane (V is the fraction of it visible); its
//!   cone (`cone_inner_degrees`, `cone_outer_degrees`) only shades;
//! - `sun`: at infinity, a cone of directions of `angular_diameter_degrees` around
//!   `-direction` (the light travels along `direction`; `center` is only the origin of light
//!   space); V is the fraction of that cone (solid angle) unobstructed.
//!
//! Every kind but the sun is one-sided: points at or behind the light plane (light-space z <= 0)
//! hold 0, as for the rectangle. For the sphere that is a lamp lighting the half space in front
//! of it (a sphere light with a reflector), which keeps every technique's one-sided maps valid.

use glam::{Mat4, Vec2, Vec3};
use serde::{Deserialize, Serialize};

use crate::AreaLight;

/// The shape of a light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LightKind {
    /// A rectangle of `width` x `height` (the seeds' light).
    #[default]
    Rect = 0,
    /// A disk of `radius`.
    Disk = 1,
    /// A sphere of `radius`: the disk of its silhouette from each receiver point.
    Sphere = 2,
    /// A disk source of `radius` whose cone shades.
    Spot = 3,
    /// A directional light with an angular diameter, at infinity.
    Sun = 4,
}

impl LightKind {
    /// Every kind, in the order of the scene files' documentation.
    pub const ALL: [LightKind; 5] = [
        LightKind::Rect,
        LightKind::Disk,
        LightKind::Sphere,
        LightKind::Spot,
        LightKind::Sun,
    ];

    /// The kind's name in scene files, JSON and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LightKind::Rect => "rect",
            LightKind::Disk => "disk",
            LightKind::Sphere => "sphere",
            LightKind::Spot => "spot",
            LightKind::Sun => "sun",
        }
    }

    /// The kind named `name`, or `None`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The names of every kind, `rect | disk | ...`, for error messages.
    pub fn names() -> String {
        Self::ALL.map(Self::name).join(" | ")
    }
}

impl std::fmt::Display for LightKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Relative epsilon at the receiver end of a shadow segment to a light point: hits within this
/// fraction of the segment's length from the receiver are ignored (its own surface, through
/// rounding).
pub const SEGMENT_EPSILON: f32 = 1e-4;

/// Relative epsilon at the light end of a segment (about 8 f32 ulps of t = 1): nothing sits on
/// the light, but occluders may come within 1e-4 of its distance.
pub const LIGHT_END_EPSILON: f32 = 1e-6;

/// One shadow ray from a receiver point `p` toward a sample of the light: the points
/// `p + t * to_light` for `t` in `(t_min, t_max)` must be free of casters for the sample to be
/// seen. For a light with a position the segment ends at the light point (`to_light` = light
/// point - `p`, `t` in `(SEGMENT_EPSILON, 1 - LIGHT_END_EPSILON)`); for the sun `to_light` is a
/// unit direction, `t_min` the receiver's own rounding scale and `t_max` unbounded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// From the receiver to the light point, or the unit direction to the sun.
    pub to_light: Vec3,
    /// Hits at or before this parameter are ignored.
    pub t_min: f32,
    /// Hits at or after this parameter are ignored.
    pub t_max: f32,
}

/// Checks a light's kind-specific values; the error names the field and its range.
pub(crate) fn validate_shape(light: &AreaLight) -> Result<(), String> {
    let values = [
        light.radius,
        light.cone_inner_degrees,
        light.cone_outer_degrees,
        light.angular_diameter_degrees,
    ];
    if values.iter().any(|v| !v.is_finite()) {
        return Err("light radius, cone or angular diameter is not finite: give numbers".into());
    }
    if light.radius < 0.0 {
        return Err(format!(
            "light radius {} is negative: give a radius >= 0 (0 is a point light)",
            light.radius
        ));
    }
    let (inner, outer) = (light.cone_inner_degrees, light.cone_outer_degrees);
    if !(0.0..=90.0).contains(&inner) || !(0.0..=90.0).contains(&outer) {
        return Err(format!(
            "light cone_inner_degrees {inner} / cone_outer_degrees {outer}: each must be in 0..=90 (angles from the spot's axis)"
        ));
    }
    if outer < inner {
        return Err(format!(
            "light cone_outer_degrees {outer} is less than cone_inner_degrees {inner}: give outer >= inner"
        ));
    }
    let sun = light.angular_diameter_degrees;
    if !(0.0..180.0).contains(&sun) {
        return Err(format!(
            "light angular_diameter_degrees {sun}: must be in 0..180 (the real sun is 0.53)"
        ));
    }
    Ok(())
}

/// Shirley and Chiu's concentric map of the unit square onto the unit disk ("A Low Distortion
/// Map Between Disk and Square", 1997): area-preserving and continuous, so stratified square
/// samples stay stratified on the disk.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let a = u * 2.0 - Vec2::ONE;
    if a.x == 0.0 && a.y == 0.0 {
        return Vec2::ZERO;
    }
    let quarter = std::f32::consts::FRAC_PI_4;
    let (r, theta) = if a.x.abs() > a.y.abs() {
        (a.x, quarter * (a.y / a.x))
    } else {
        (a.y, 2.0 * quarter - quarter * (a.x / a.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Two unit vectors orthogonal to the unit `n` and to each other (Duff et al., "Building an
/// Orthonormal Basis, Revisited", JCGT 2017); `frame.wgsl` has the same.
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

impl AreaLight {
    /// Whether the light can reach `point` at all: every kind but the sun is one-sided (the point
    /// must lie in front of the light plane); the sun reaches everything.
    pub fn reaches(&self, point: Vec3) -> bool {
        if !point.is_finite() {
            return false;
        }
        if self.kind == LightKind::Sun {
            return true;
        }
        let (_, _, z) = self.basis();
        let depth = (point - self.center).dot(z);
        if self.kind == LightKind::Sphere && (point - self.center).length() <= self.radius {
            return false;
        }
        depth > 0.0
    }

    /// The shadow ray from `point` to the light sample `u` in `[0, 1)^2` (uniform `u` gives
    /// samples uniform over the light's surface as seen from `point`: the module docs). Call
    /// only where [`Self::reaches`] holds.
    pub fn sample(&self, u: Vec2, point: Vec3) -> LightSample {
        let (x, y, z) = self.basis();
        let segment = |light_point: Vec3| LightSample {
            to_light: light_point - point,
            t_min: SEGMENT_EPSILON,
            t_max: 1.0 - LIGHT_END_EPSILON,
        };
        match self.kind {
            LightKind::Rect => {
                let s = (u * 2.0 - Vec2::ONE) * self.half_extent();
                segment(self.center + x * s.x + y * s.y)
            }
            LightKind::Disk | LightKind::Spot => {
                let d = concentric_disk(u) * self.radius;
                segment(self.center + x * d.x + y * d.y)
            }
            LightKind::Sphere => {
                let w = point - self.center;
                let dist = w.length();
                let n = w / dist;
                // The circle where the tangent cone from `point` touches the sphere.
                let ratio = (self.radius / dist).min(1.0);
                let centre = self.center + n * (self.radius * ratio);
                let radius = self.radius * (1.0 - ratio * ratio).max(0.0).sqrt();
                let (a, b) = orthonormal_basis(n);
                let d = concentric_disk(u) * radius;
                segment(centre + a * d.x + b * d.y)
            }
            LightKind::Sun => {
                let d = concentric_disk(u);
                let rho = d.length();
                // Area-preserving from the disk to the cap of half-angle alpha:
                // sin(theta / 2) = rho sin(alpha / 2), so 1 - cos(theta) = rho^2 (1 - cos(alpha)).
                let half_alpha = self.angular_diameter_degrees.to_radians() * 0.5;
                let theta = 2.0 * (rho * (half_alpha * 0.5).sin()).asin();
                let around = if rho > 0.0 { d / rho } else { Vec2::X };
                let dir = -z * theta.cos() + (x * around.x + y * around.y) * theta.sin();
                LightSample {
                    to_light: dir,
                    t_min: SEGMENT_EPSILON * point.abs().max_element().max(1.0),
                    t_max: f32::MAX,
                }
            }
        }
    }

    /// This light made `kind`, as the light-kind bounds take it
    /// ([`TechniqueInfo::light_kind_bounds`](crate::TechniqueInfo::light_kind_bounds)): same
    /// centre and direction; a disk, sphere or spot of radius half the rectangle's width; a spot's
    /// cone 40 / 60 degrees; the sun 10 degrees wide (a penumbra as wide as a unit light's at a
    /// few units).
    pub fn as_kind(&self, kind: LightKind) -> AreaLight {
        AreaLight {
            kind,
            radius: 0.5 * self.width,
            cone_inner_degrees: 40.0,
            cone_outer_degrees: 60.0,
            angular_diameter_degrees: 10.0,
            ..*self
        }
    }

    /// The direction from `point` to the light's centre (unit; the sun: toward it), for shading.
    pub fn direction_to_light(&self, point: Vec3) -> Vec3 {
        match self.kind {
            LightKind::Sun => -self.direction.normalize_or(Vec3::NEG_Y),
            _ => (self.center - point).normalize_or(Vec3::Y),
        }
    }
}

/// An orthographic light view for the sun (or any directional light): light space of the sun's
/// basis (+z the direction its light travels), a square window over the points it must cover and
/// a depth range. What a shadow-map technique renders the sun's map with (its depth pass takes
/// [`Self::view_projection`]); cascades split the camera's range and fit one per split.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunView {
    /// World to the sun's light space ([`AreaLight::view`]).
    pub view: Mat4,
    /// Window `[x_min, x_max, y_min, y_max]` in light-space units (square).
    pub window: [f32; 4],
    /// Nearest light-space z covered.
    pub near: f32,
    /// Farthest light-space z covered.
    pub far: f32,
}

impl SunView {
    /// The square window over `world_points` (e.g. the corners of the casters' and receivers'
    /// bounds) with a 2 % margin, depth from the nearest to the farthest point. `None` for no
    /// finite point.
    pub fn fit(light: &AreaLight, world_points: &[Vec3]) -> Option<Self> {
        let view = light.view();
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for p in world_points.iter().filter(|p| p.is_finite()) {
            let q = view.transform_point3(*p);
            lo = lo.min(q);
            hi = hi.max(q);
        }
        if !lo.is_finite() || !hi.is_finite() {
            return None;
        }
        let half = ((hi.x - lo.x).max(hi.y - lo.y) * 0.5 * 1.02).max(1e-3);
        let (cx, cy) = ((lo.x + hi.x) * 0.5, (lo.y + hi.y) * 0.5);
        let pad = ((hi.z - lo.z) * 0.01).max(1e-3);
        Some(Self {
            view,
            window: [cx - half, cx + half, cy - half, cy + half],
            near: lo.z - pad,
            far: hi.z + pad,
        })
    }

    /// World to clip: orthographic, depth in [0, 1] over [near, far] (wgpu's convention), texture
    /// row 0 at `y_max`.
    pub fn view_projection(&self) -> Mat4 {
        let [l, r, b, t] = self.window;
        let (n, f) = (self.near, self.far);
        let ortho = Mat4::from_cols(
            glam::Vec4::new(2.0 / (r - l), 0.0, 0.0, 0.0),
            glam::Vec4::new(0.0, 2.0 / (t - b), 0.0, 0.0),
            glam::Vec4::new(0.0, 0.0, 1.0 / (f - n), 0.0),
            glam::Vec4::new(-(r + l) / (r - l), -(t + b) / (t - b), -n / (f - n), 1.0),
        );
        ortho * self.view
    }

    /// Edge of one texel of an `n x n` map, light-space units.
    pub fn texel_size(&self, n: u32) -> f32 {
        (self.window[1] - self.window[0]) / n.max(1) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn concentric_map_is_in_the_disk_and_preserves_area() {
        // 64 x 64 strata centres: every image in the disk, and the fraction inside radius 0.5 is
        // the area ratio 1/4 (area-preserving).
        let n = 64;
        let mut inside_half = 0;
        for k in 0..n * n {
            let u = Vec2::new((k % n) as f32 + 0.5, (k / n) as f32 + 0.5) / n as f32;
            let d = concentric_disk(u);
            assert!(d.length() <= 1.0 + 1e-6, "{u} -> {d}");
            inside_half += (d.length() < 0.5) as u32;
        }
        let fraction = inside_half as f32 / (n * n) as f32;
        assert!((fraction - 0.25).abs() < 0.01, "{fraction}");
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [
            Vec3::X,
            Vec3::NEG_Z,
            Vec3::new(0.3, -0.4, 0.866).normalize(),
        ] {
            let (a, b) = orthonormal_basis(n);
            for (p, q) in [(a, b), (a, n), (b, n)] {
                assert!(p.dot(q).abs() < 1e-6);
            }
            assert!((a.length() - 1.0).abs() < 1e-6 && (b.length() - 1.0).abs() < 1e-6);
        }
    }

    fn light(kind: LightKind) -> AreaLight {
        AreaLight {
            kind,
            radius: 0.5,
            ..AreaLight::default()
        }
    }

    #[test]
    fn samples_lie_on_each_shape() {
        let p = Vec3::new(0.3, 0.0, -0.2);
        for k in 0..16 {
            let u = Vec2::new((k % 4) as f32 + 0.5, (k / 4) as f32 + 0.5) / 4.0;
            let disk = light(LightKind::Disk).sample(u, p);
            let q = p + disk.to_light;
            assert!(
                (q.y - 4.0).abs() < 1e-5 && q.x.hypot(q.z) <= 0.5 + 1e-5,
                "{q}"
            );
            let sphere = light(LightKind::Sphere).sample(u, p);
            let q = p + sphere.to_light;
            // On the sphere's circle of contact (or inside its disk): within the radius of the
            // centre, and the segment from p touches the sphere no earlier than the disk.
            assert!((q - Vec3::Y * 4.0).length() <= 0.5 + 1e-5, "{q}");
            let sun = AreaLight {
                kind: LightKind::Sun,
                angular_diameter_degrees: 10.0,
                ..AreaLight::default()
            }
            .sample(u, p);
            let cos = sun.to_light.dot(Vec3::Y);
            assert!(cos >= 5f32.to_radians().cos() - 1e-6, "{}", sun.to_light);
            assert!((sun.to_light.length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn bad_values_are_refused_naming_the_field() {
        let bad = |f: fn(&mut AreaLight)| {
            let mut l = AreaLight::default();
            f(&mut l);
            l.validate().unwrap_err()
        };
        assert!(bad(|l| l.radius = -1.0).contains("radius"));
        assert!(bad(|l| {
            l.cone_inner_degrees = 40.0;
            l.cone_outer_degrees = 20.0
        })
        .contains("cone_outer_degrees"));
        assert!(bad(|l| l.angular_diameter_degrees = 180.0).contains("angular_diameter_degrees"));
        assert!(AreaLight::default().validate().is_ok());
    }

    #[test]
    fn sun_view_covers_its_points() {
        let sun = AreaLight {
            kind: LightKind::Sun,
            direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
            ..AreaLight::default()
        };
        let points = [Vec3::new(-5.0, 0.0, -5.0), Vec3::new(5.0, 2.0, 5.0)];
        let v = SunView::fit(&sun, &points).unwrap();
        for p in points {
            let c = v.view_projection().project_point3(p);
            assert!(
                c.x.abs() <= 1.0 && c.y.abs() <= 1.0 && (0.0..=1.0).contains(&c.z),
                "{c}"
            );
        }
    }
}
