use super::*;
use crate::{Camera, LightKind};

fn sun() -> AreaLight {
    AreaLight {
        kind: LightKind::Sun,
        center: Vec3::new(400.0, 500.0, 300.0),
        direction: Vec3::new(-0.4, -0.5, -0.3).normalize(),
        angular_diameter_degrees: 0.53,
        ..AreaLight::default()
    }
}

fn camera(eye: Vec3, target: Vec3) -> CameraFrustum {
    let camera = Camera {
        eye,
        target,
        up: Vec3::Y,
        fov_y_degrees: 60.0,
        near: 0.1,
        far: 600.0,
    };
    CameraFrustum::from_view_proj(camera.view_projection(1.5), eye).unwrap()
}

fn street() -> CameraFrustum {
    camera(Vec3::new(2.0, 1.7, 0.0), Vec3::new(0.0, 1.7, -100.0))
}

/// A ground 400 m across and a caster box 30 m tall.
fn scene_points() -> (Vec<Vec3>, Vec<Vec3>) {
    let casters = crate::Aabb {
        min: Vec3::new(-60.0, 0.0, -200.0),
        max: Vec3::new(60.0, 30.0, 200.0),
    };
    let receivers = crate::Aabb {
        min: Vec3::new(-200.0, -5.0, -200.0),
        max: Vec3::new(200.0, 5.0, 200.0),
    };
    (casters.corners().to_vec(), receivers.corners().to_vec())
}

fn settings(count: u32) -> CascadeSettings {
    CascadeSettings {
        count,
        ..CascadeSettings::default()
    }
}

#[test]
fn splits_blend_the_logarithmic_and_the_uniform_scheme() {
    let uniform = split_distances(1.0, 100.0, 4, 0.0);
    let log = split_distances(1.0, 100.0, 4, 1.0);
    for (i, (u, l)) in uniform.iter().zip(&log).enumerate() {
        let f = i as f32 / 4.0;
        assert!((u - (1.0 + 99.0 * f)).abs() < 1e-4, "{uniform:?}");
        assert!((l - 100f32.powf(f)).abs() < 1e-3, "{log:?}");
    }
    let half = split_distances(1.0, 100.0, 4, 0.5);
    for w in half.windows(2) {
        assert!(w[1] > w[0], "{half:?}");
    }
    assert_eq!((half[0], half[4]), (1.0, 100.0));
    assert!((half[1] - 0.5 * (uniform[1] + log[1])).abs() < 1e-4);
}

#[test]
fn the_frustum_is_read_back_from_the_view_projection() {
    let f = street();
    assert!(
        (f.near - 0.1).abs() < 1e-3 && (f.far - 600.0).abs() < 1.0,
        "{f:?}"
    );
    assert!(f.forward.distance(Vec3::new(-0.02, 0.0, -1.0).normalize()) < 1e-3);
    // Vertical half angle 30 degrees: a corner's y offset at depth 1 is tan 30.
    let tan = 30f32.to_radians().tan();
    assert!((f.corners[3].y - tan).abs() < 1e-3, "{:?}", f.corners);
}

#[test]
fn the_slice_sphere_holds_the_slice_and_ignores_the_orientation() {
    let a = street();
    let b = camera(Vec3::new(2.0, 1.7, 0.0), Vec3::new(70.0, 10.0, 40.0));
    for (d0, d1) in [(0.1, 5.0), (5.0, 40.0), (40.0, 300.0)] {
        let (c, r) = a.slice_sphere(d0, d1);
        assert_eq!((c, r), b.slice_sphere(d0, d1), "slice {d0}..{d1}");
        let centre = a.eye + a.forward * c;
        for d in [d0, d1] {
            for k in a.corners {
                let p = a.eye + k * d;
                assert!(
                    p.distance(centre) <= r * (1.0 + 1e-5),
                    "{d}: {p} outside {r}"
                );
            }
        }
    }
}

#[test]
fn every_slice_lies_in_its_cascade_with_the_casters_in_depth() {
    let f = street();
    let (casters, receivers) = scene_points();
    let cascades = fit_cascades(&sun(), &f, &casters, &receivers, &settings(4), 1024);
    assert_eq!(cascades.len(), 4);
    for c in &cascades {
        let m = c.view.view_projection();
        for d in [c.split_near, c.split_far] {
            for k in f.corners {
                let q = m.project_point3(f.eye + k * d);
                assert!(q.x.abs() <= 1.0 && q.y.abs() <= 1.0, "{c:?}: {q}");
                assert!((0.0..=1.0).contains(&q.z), "{c:?}: depth {}", q.z);
            }
        }
        // The casters' top, towards the sun from the slice, is not clipped by the near plane.
        let top = m.project_point3(Vec3::new(0.0, 30.0, -20.0));
        assert!(top.z >= 0.0, "{top}");
    }
    // Texels grow with distance: the near cascade is the sharpest.
    for w in cascades.windows(2) {
        assert!(w[1].texel_world > w[0].texel_world, "{cascades:?}");
    }
    // The last cascade ends at the farthest receiver, not at the camera's far plane.
    let last = cascades[3].split_far;
    assert!(last < 340.0 && last > 200.0, "{last}");
}

#[test]
fn snapped_windows_move_by_whole_texels_as_the_camera_walks() {
    let (casters, receivers) = scene_points();
    let n = 512;
    let fit = |z: f32, snap: bool| {
        let f = camera(Vec3::new(2.0, 1.7, z), Vec3::new(0.0, 1.7, z - 100.0));
        let s = CascadeSettings {
            snap,
            ..settings(3)
        };
        fit_cascades(&sun(), &f, &casters, &receivers, &s, n)
    };
    let start = fit(0.0, true);
    for step in 1..20 {
        let moved = fit(-0.37 * step as f32, true);
        for (a, b) in start.iter().zip(&moved) {
            assert_eq!(a.texel_world, b.texel_world);
            for k in [0, 2] {
                let texels = (b.view.window[k] - a.view.window[k]) / a.texel_world;
                assert!(
                    (texels - texels.round()).abs() < 1e-2,
                    "step {step}: {texels}"
                );
            }
        }
    }
    // Unsnapped, the origin slides by fractions of a texel.
    let a = fit(0.0, false);
    let fractions: Vec<f32> = (1..5)
        .map(|step| {
            let b = fit(-0.37 * step as f32, false);
            let texels = (b[0].view.window[2] - a[0].view.window[2]) / a[0].texel_world;
            (texels - texels.round()).abs()
        })
        .collect();
    assert!(fractions.iter().any(|f| *f > 1e-2), "{fractions:?}");
}

#[test]
fn one_cascade_is_one_map_fitted_to_the_scene() {
    let (casters, receivers) = scene_points();
    let a = fit_cascades(&sun(), &street(), &casters, &receivers, &settings(1), 1024);
    let b = camera(Vec3::new(50.0, 3.0, 50.0), Vec3::new(0.0, 0.0, 0.0));
    let b = fit_cascades(&sun(), &b, &casters, &receivers, &settings(1), 1024);
    assert_eq!(a.len(), 1);
    assert_eq!(a[0].view, b[0].view);
    let m = a[0].view.view_projection();
    for p in receivers {
        let q = m.project_point3(p);
        assert!(q.x.abs() <= 1.0 && q.y.abs() <= 1.0 && (0.0..=1.0).contains(&q.z));
    }
}

#[test]
fn the_uniform_holds_each_cascade() {
    let (casters, receivers) = scene_points();
    let f = street();
    let cascades = fit_cascades(&sun(), &f, &casters, &receivers, &settings(2), 256);
    let u = CascadeUniform::new(&cascades, &f, 256, 0.2);
    assert_eq!(u.info, Vec4::new(2.0, 256.0, 1.0 / 256.0, 0.2));
    assert_eq!(u.split_far.y, cascades[1].split_far);
    assert_eq!(u.view_proj[2], Mat4::ZERO);
    assert_eq!(
        u.depth_range.x,
        cascades[0].view.far - cascades[0].view.near
    );
}

/// The viewer's list of cascade parameters is the shared group's.
#[test]
fn the_cascade_parameter_names_are_the_groups() {
    let names: Vec<String> = SunCascadeParams::param_specs()
        .iter()
        .map(|s| s.name.to_string())
        .collect();
    assert_eq!(names, CASCADE_PARAMS);
}
