//! The analytic exact answer (`softshadow_reference::analytic`) against the rectangle closed form
//! (Atty et al. 2006, sections 3.3-3.4), the sampled answers converging to it, and hand-made
//! degenerate cases.

use anyhow::{Context, Result};
use softshadow_core::{
    glam::{Mat4, Vec3},
    AreaLight, Camera, Instance, Mesh, Scene,
};
use softshadow_reference::{
    analytic::{AnalyticCasters, Scratch},
    exact,
    raycast::{visibility_and_error, CasterBvh},
};

/// Points spread over the receivers of `scene`: on every `step`-th receiver triangle, a few
/// points at fixed barycentric coordinates (never on an edge), about `budget` in all.
fn receiver_points(scene: &Scene, budget: usize) -> Vec<Vec3> {
    let mut triangles = Vec::new();
    for instance in scene.instances.iter().filter(|i| i.receives_shadow) {
        let mesh = &scene.meshes[instance.mesh];
        for t in mesh.indices.chunks_exact(3) {
            triangles.push([t[0], t[1], t[2]].map(|i| {
                instance
                    .transform
                    .transform_point3(mesh.positions[i as usize])
            }));
        }
    }
    let per_triangle = (budget / triangles.len().max(1)).max(1);
    let step = (triangles.len() * per_triangle / budget.max(1)).max(1);
    let grid = ((2 * per_triangle) as f64).sqrt().ceil() as usize;
    let mut points = Vec::new();
    for tri in triangles.iter().step_by(step) {
        for i in 0..grid {
            for j in 0..grid {
                let (u, v) = (
                    (i as f32 + 0.37) / grid as f32,
                    (j as f32 + 0.21) / grid as f32,
                );
                if u + v < 1.0 {
                    points.push(tri[0] + (tri[1] - tri[0]) * u + (tri[2] - tri[0]) * v);
                }
            }
        }
    }
    points
}

fn analytic_at(scene: &Scene, points: &[Vec3]) -> Result<Vec<f64>> {
    let casters = AnalyticCasters::new(scene, &scene.light)?;
    let mut scratch = Scratch::default();
    Ok(points
        .iter()
        .map(|p| casters.visible_fraction(scene.light.to_light_space(*p), &mut scratch))
        .collect())
}

/// On `atty-square` and every stiff case whose casters are rectangles parallel to the light,
/// the analytic answer equals the closed form within 1e-9 at every receiver point (both start
/// from the same f32 light-space corners; the rest is f64).
#[test]
fn equals_the_closed_form_on_parallel_rectangles() -> Result<()> {
    let ids = std::iter::once("atty-square".to_string()).chain(
        softshadow_scenes::stiff::infos()
            .into_iter()
            .map(|i| i.id.to_string()),
    );
    let mut checked = Vec::new();
    for id in ids {
        let scene = softshadow_scenes::builtin(&id, &[])?;
        let Some(rects) = exact::parallel_rects(&scene) else {
            continue;
        };
        let half = scene.light.half_extent();
        if half.x <= 0.0 || half.y <= 0.0 {
            continue; // a point light: no area to be analytic about
        }
        let points = receiver_points(&scene, 1500);
        let analytic = analytic_at(&scene, &points)?;
        let mut penumbra = 0;
        for (p, a) in points.iter().zip(&analytic) {
            let closed = exact::visible_fraction(half, &rects, scene.light.to_light_space(*p));
            assert!(
                (a - closed).abs() <= 1e-9,
                "{id} at {p}: analytic {a}, closed form {closed}"
            );
            penumbra += (closed > 0.0 && closed < 1.0) as usize;
        }
        checked.push((id, points.len(), penumbra));
    }
    let names: Vec<&str> = checked.iter().map(|c| c.0.as_str()).collect();
    assert!(
        checked.len() >= 8,
        "too few parallel-rectangle scenes: {names:?}"
    );
    let (_, _, penumbra) = checked
        .iter()
        .find(|c| c.0 == "atty-square")
        .context("atty")?;
    assert!(*penumbra > 100, "atty-square: {penumbra} penumbra points");
    Ok(())
}

/// The mean |ray cast - analytic| over receiver points where either shadows, and the mean of the
/// ray cast's stated standard error over the same points.
fn raycast_error(scene: &Scene, points: &[Vec3], analytic: &[f64], n: u32) -> (f64, f64) {
    let bvh = CasterBvh::from_scene(scene);
    let (mut diff, mut stated, mut count) = (0.0, 0.0, 0);
    for (p, a) in points.iter().zip(analytic) {
        let (v, e) = visibility_and_error(&bvh, &scene.light, n, *p, 1);
        if v < 1.0 || *a < 1.0 {
            diff += (v - a).abs();
            stated += e;
            count += 1;
        }
    }
    (diff / count.max(1) as f64, stated / count.max(1) as f64)
}

/// The CPU ray cast at 16 x 16, 32 x 32 and 64 x 64 light samples lies within its own stated
/// sampling error of the analytic answer on meshes (blob-floating, balls-3x3x3, cad-bracket),
/// and its error shrinks with the sample count. (The ray-traced answer's twin of this test is
/// in the bench's GPU tests.)
#[test]
fn the_ray_cast_converges_to_it_within_its_stated_error() -> Result<()> {
    let cad = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../assets/scenes/cad-bracket.toml"
    );
    let scenes = [
        softshadow_scenes::builtin("blob-floating", &[])?,
        softshadow_scenes::builtin("balls-3x3x3", &[])?,
        softshadow_scenes::load_scene_file(cad)?.scene,
    ];
    for scene in &scenes {
        let points = receiver_points(scene, 400);
        let analytic = analytic_at(scene, &points)?;
        let shadowed = analytic.iter().filter(|a| **a < 1.0).count();
        assert!(shadowed > 40, "{}: {shadowed} shadowed points", scene.name);
        let mut previous = f64::INFINITY;
        for n in [16, 32, 64] {
            let (error, stated) = raycast_error(scene, &points, &analytic, n);
            assert!(
                error <= stated,
                "{} at {n} x {n}: mean error {error:.5} over its stated {stated:.5}",
                scene.name
            );
            assert!(
                error < previous,
                "{} at {n} x {n}: {error} after {previous}",
                scene.name
            );
            previous = error;
        }
    }
    Ok(())
}

/// A down-facing 1 x 1 light at height 2 over the origin and `triangles` as one caster.
fn scene_of(triangles: &[[Vec3; 3]]) -> Scene {
    let mesh = Mesh {
        texcoords: Vec::new(),
        name: "casters".into(),
        positions: triangles.iter().flatten().copied().collect(),
        normals: Vec::new(),
        indices: (0..3 * triangles.len() as u32).collect(),
    };
    Scene {
        materials: Vec::new(),
        textures: Vec::new(),
        name: "degenerate".into(),
        meshes: vec![mesh],
        instances: vec![Instance::new(0, Mat4::IDENTITY)],
        light: AreaLight {
            center: Vec3::new(0.0, 2.0, 0.0),
            ..AreaLight::default()
        },
        camera: Camera::default(),
    }
}

/// Each degenerate case gives a finite value in [0, 1] equal to a 64 x 64 ray cast within three
/// times the ray cast's stated error (plus its last sample's width, 1 / 4096).
#[test]
fn degenerate_cases_match_a_dense_ray_cast() -> Result<()> {
    let v = Vec3::new;
    // The receiver point of every case is the origin (or on the named caster).
    let cases: [(&str, Vec<[Vec3; 3]>, Vec3); 6] = [
        (
            "a triangle through the point (its plane contains it)",
            vec![[v(-0.5, 0.0, 0.0), v(0.5, 0.0, 0.0), v(0.0, 1.5, 0.0)]],
            v(0.0, 0.0, 0.0),
        ),
        (
            "a triangle seen edge-on from the point",
            vec![[v(0.1, 0.5, 0.0), v(0.4, 0.5, 0.0), v(0.2, 1.0, 0.0)]],
            v(0.0, 0.0, 0.0),
        ),
        (
            "a triangle edge-on to the light",
            vec![[v(-0.3, 0.5, 0.2), v(0.3, 0.5, 0.2), v(0.0, 1.2, 0.2)]],
            v(0.0, 0.0, 0.0),
        ),
        (
            "a caster sharing an edge with the receiver (contact)",
            vec![[v(-0.5, 0.0, 0.1), v(0.5, 0.0, 0.1), v(0.0, 1.0, 0.4)]],
            v(0.0, 0.0, 0.1005),
        ),
        (
            "the point on a caster, another caster above it",
            vec![
                [v(-1.0, 0.5, -1.0), v(1.0, 0.5, -1.0), v(0.0, 0.5, 1.0)],
                [v(-0.2, 1.0, -0.2), v(0.3, 1.0, -0.2), v(0.0, 1.0, 0.3)],
            ],
            v(0.0, 0.5, 0.0),
        ),
        (
            "the light's edge on a polygon's edge (a caster edge over x = 0.25 at half height)",
            vec![[v(0.25, 1.0, -2.0), v(0.25, 1.0, 2.0), v(3.0, 1.0, 0.0)]],
            v(0.0, 0.0, 0.0),
        ),
    ];
    for (name, triangles, point) in cases {
        let scene = scene_of(&triangles);
        let a = analytic_at(&scene, &[point])?[0];
        let bvh = CasterBvh::from_scene(&scene);
        let (cast, stated) = visibility_and_error(&bvh, &scene.light, 64, point, 1);
        assert!(a.is_finite() && (0.0..=1.0).contains(&a), "{name}: {a}");
        assert!(
            (a - cast).abs() <= 3.0 * stated + 1.0 / 4096.0,
            "{name}: analytic {a}, ray cast {cast} +- {stated}"
        );
    }
    // The light's edge case is exact: the caster's edge projects through the origin onto
    // x = 0.5, the light's edge, so the light is wholly visible; moved by 0.1 towards the
    // light's centre it hides a 0.2-wide strip (x from 0.3 to 0.5): V = 0.8.
    let edge = scene_of(&[[v(0.15, 1.0, -2.0), v(0.15, 1.0, 2.0), v(3.0, 1.0, 0.0)]]);
    let a = analytic_at(&edge, &[Vec3::ZERO])?[0];
    assert!((a - 0.8).abs() < 1e-6, "{a}");
    Ok(())
}

/// A cancelled analytic answer stops with `Cancelled`; one left alone counts every receiver
/// pixel as done and ends its build (the progress bar's source).
#[test]
fn the_analytic_answer_counts_its_progress_and_can_be_cancelled() -> Result<()> {
    use softshadow_core::BuildControl;
    use softshadow_reference::analytic::{light_seen_image, AnalyticError};
    let scene = softshadow_scenes::load("blob-floating:triangles=2000")?.scene;
    let points: Vec<Option<Vec3>> = receiver_points(&scene, 300).into_iter().map(Some).collect();
    let mask = vec![true; points.len()];
    let control = BuildControl::default();
    light_seen_image(&scene, &points, None, &mask, Some(&control))?;
    assert_eq!(control.progress(), None, "the build ended");
    let done = control.done.load(std::sync::atomic::Ordering::Relaxed) as usize;
    assert_eq!(done, points.len());
    control.cancel();
    let cancelled = light_seen_image(&scene, &points, None, &mask, Some(&control));
    assert_eq!(cancelled.unwrap_err(), AnalyticError::Cancelled);
    Ok(())
}
