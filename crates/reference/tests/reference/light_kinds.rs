//! The CPU ray cast under each light kind against closed forms (issue 39, item 2):
//! - a disk light over a parallel coaxial polygonal "disk" occluder, receiver on the axis: the
//!   occluder's shadow of the light is concentric, so the hidden fraction is the ratio of the
//!   occluder's area, scaled by the central projection from the receiver, to the light's area;
//! - a sphere light over the same occluder: the same ratio on the sphere's silhouette disk;
//! - the sun over a half-plane edge: the penumbra runs from -d tan(alpha/2) to +d tan(alpha/2)
//!   around the edge's shadow (width = distance x angular diameter for small angles), and V is
//!   the fraction of the sun's disk past the edge (a circular segment);
//! - a spot light casts as its source disk (the cone only shades).
//!
//! Each sampled answer is the mean of 16 independent jittered estimates; the closed form must lie
//! within 1e-4 plus three standard errors of that mean.

use softshadow_core::{glam::Vec3, AreaLight, LightKind};
use softshadow_reference::raycast::{visibility, visibility_and_error, CasterBvh};

/// Sides of the polygon standing for the disk occluder.
const SIDES: usize = 96;

/// A regular `SIDES`-gon of circumradius `radius` in the plane y = `height`, centred on the y
/// axis (a fan of triangles), and its exact area.
fn polygon(radius: f32, height: f32) -> (CasterBvh, f64) {
    let corner = |k: usize| {
        let a = k as f32 / SIDES as f32 * std::f32::consts::TAU;
        Vec3::new(radius * a.cos(), height, radius * a.sin())
    };
    let centre = Vec3::new(0.0, height, 0.0);
    let triangles = (0..SIDES)
        .map(|k| [centre, corner(k), corner(k + 1)])
        .collect();
    let n = SIDES as f64;
    let area = 0.5 * n * (radius as f64).powi(2) * (std::f64::consts::TAU / n).sin();
    (CasterBvh::from_triangles(triangles), area)
}

/// A light of `kind` centred at height `height` above the origin, facing down.
fn down(kind: LightKind, height: f32, radius: f32) -> AreaLight {
    AreaLight {
        kind,
        center: Vec3::new(0.0, height, 0.0),
        direction: Vec3::NEG_Y,
        up: Vec3::Z,
        radius,
        ..AreaLight::default()
    }
}

/// Mean of 16 estimates with `n`² samples (seeds 0..16) at `p`, and the standard error of the
/// mean from their spread.
fn sampled_mean(bvh: &CasterBvh, light: &AreaLight, n: u32, p: Vec3) -> (f64, f64) {
    let runs: Vec<f64> = (0..16u64)
        .map(|seed| visibility(bvh, light, n, p, seed))
        .collect();
    let mean = runs.iter().sum::<f64>() / runs.len() as f64;
    let var = runs.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (runs.len() - 1) as f64;
    (mean, (var / runs.len() as f64).sqrt())
}

fn assert_close(what: &str, exact: f64, (mean, se): (f64, f64)) {
    assert!(
        (mean - exact).abs() <= 1e-4 + 3.0 * se,
        "{what}: exact {exact:.6}, sampled {mean:.6} +- {se:.2e}"
    );
}

#[test]
fn a_disk_light_over_a_coaxial_disk_hides_the_projected_area_ratio() {
    // Light radius R at height H; occluder circumradius a at height h; receiver at the origin.
    // A ray to the light point at radius rho crosses height h at rho h / H: blocked inside the
    // polygon, so the hidden part of the light is the polygon scaled by H / h.
    let (big_r, big_h) = (0.6f32, 4.0f32);
    for (a, h) in [(0.2f32, 2.0f32), (0.1, 1.0), (0.25, 3.0), (0.05, 2.5)] {
        let (bvh, area) = polygon(a, h);
        let scale = (big_h / h) as f64;
        let hidden = area * scale * scale / (std::f64::consts::PI * (big_r as f64).powi(2));
        assert!(
            hidden < 1.0,
            "the projected occluder must lie inside the light"
        );
        let exact = 1.0 - hidden;
        for kind in [LightKind::Disk, LightKind::Spot] {
            let light = down(kind, big_h, big_r);
            let sampled = sampled_mean(&bvh, &light, 32, Vec3::ZERO);
            assert_close(&format!("{kind} a={a} h={h}"), exact, sampled);
        }
    }
}

#[test]
fn a_sphere_light_hides_the_ratio_on_its_silhouette_disk() {
    // Seen from a point at distance d from its centre, a sphere of radius r shows the disk of
    // radius r sqrt(1 - r^2 / d^2) at distance d - r^2 / d: a ray through that disk at radius
    // rho crosses the occluder's plane (distance h) at rho h / (d - r^2 / d).
    let (r, d) = (0.8f32, 3.0f32);
    let light = down(LightKind::Sphere, d, r);
    let disk_distance = (d - r * r / d) as f64;
    let disk_radius = (r * (1.0 - r * r / (d * d)).sqrt()) as f64;
    for (a, h) in [(0.2f32, 1.5f32), (0.1, 1.0), (0.3, 2.0)] {
        let (bvh, area) = polygon(a, h);
        let scale = disk_distance / h as f64;
        let hidden = area * scale * scale / (std::f64::consts::PI * disk_radius * disk_radius);
        assert!(hidden < 1.0);
        let sampled = sampled_mean(&bvh, &light, 32, Vec3::ZERO);
        assert_close(&format!("sphere a={a} h={h}"), 1.0 - hidden, sampled);
    }
    // A receiver inside the sphere, or behind its plane, is not lit.
    let (bvh, _) = polygon(0.2, 1.0);
    assert_eq!(
        visibility(&bvh, &light, 8, Vec3::new(0.0, 2.9, 0.0), 1),
        0.0
    );
    assert_eq!(
        visibility(&bvh, &light, 8, Vec3::new(0.0, 3.5, 0.0), 1),
        0.0
    );
}

/// A half-plane occluder (x < 0) at height `h`, 200 wide.
fn half_plane(h: f32) -> CasterBvh {
    let c = |x, z| Vec3::new(x, h, z);
    CasterBvh::from_triangles(vec![
        [c(-100.0, -100.0), c(0.0, -100.0), c(0.0, 100.0)],
        [c(-100.0, -100.0), c(0.0, 100.0), c(-100.0, 100.0)],
    ])
}

#[test]
fn the_suns_penumbra_is_distance_times_angular_diameter() {
    let h = 10.0f32;
    let sun = AreaLight {
        kind: LightKind::Sun,
        direction: Vec3::NEG_Y,
        angular_diameter_degrees: 0.53,
        ..AreaLight::default()
    };
    let bvh = half_plane(h);
    let half_width = h as f64 * (0.53f64.to_radians() / 2.0).tan();
    // Width = distance x angular diameter (2 h tan(alpha / 2) = h alpha to 1e-5 relative).
    let width = 2.0 * half_width;
    assert!((width - h as f64 * 0.53f64.to_radians()).abs() < 1e-5 * width);
    // Outside the penumbra: exact 0 / 1 with no sampling error.
    for (s, expect) in [(-1.05, 0.0), (1.05, 1.0), (-3.0, 0.0), (3.0, 1.0)] {
        let p = Vec3::new((s * half_width) as f32, 0.0, 0.3);
        let (v, e) = visibility_and_error(&bvh, &sun, 16, p, 7);
        assert_eq!((v, e), (expect, 0.0), "s = {s}");
    }
    // Inside: the fraction of the sun's disk past the edge, a circular segment.
    for s in [-0.8f64, -0.4, 0.0, 0.3, 0.7, 0.95] {
        let exact = ((-s).acos() + s * (1.0 - s * s).sqrt()) / std::f64::consts::PI;
        let p = Vec3::new((s * half_width) as f32, 0.0, 0.3);
        let sampled = sampled_mean(&bvh, &sun, 32, p);
        assert_close(&format!("sun s={s}"), exact, sampled);
    }
}

#[test]
fn a_rect_light_samples_as_before_and_sizes_zero_are_points() {
    let bvh = half_plane(2.0);
    let rect = AreaLight {
        center: Vec3::new(0.0, 4.0, 0.0),
        direction: Vec3::NEG_Y,
        up: Vec3::Z,
        width: 1.0,
        height: 1.0,
        ..AreaLight::default()
    };
    // The edge's shadow of a 1-wide light at twice the occluder's height: V = (x + 0.5) / 1
    // across [-0.5, 0.5] on the ground (half the light's width, by similar triangles).
    for x in [-0.3f32, 0.0, 0.25] {
        let (mean, se) = sampled_mean(&bvh, &rect, 32, Vec3::new(x, 0.0, 0.1));
        assert!(
            (mean - (x as f64 + 0.5)).abs() <= 1e-4 + 3.0 * se,
            "{x}: {mean}"
        );
    }
    // Size 0: one sample, a hard edge, for every kind.
    for kind in LightKind::ALL {
        let light = AreaLight {
            kind,
            radius: 0.0,
            width: 0.0,
            height: 0.0,
            angular_diameter_degrees: 0.0,
            ..rect
        };
        assert!(light.is_point(), "{kind}");
        let lit = visibility(&bvh, &light, 16, Vec3::new(0.01, 0.0, 0.1), 3);
        let dark = visibility(&bvh, &light, 16, Vec3::new(-0.01, 0.0, 0.1), 3);
        assert_eq!((lit, dark), (1.0, 0.0), "{kind}");
    }
}
