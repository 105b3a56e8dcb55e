//! The CPU ray-cast reference against the closed form (Atty et al. 2006) on `atty-square`, its
//! convergence in the number of light samples, its edge cases, and its BVH against brute force.

use anyhow::Result;
use softshadow_core::{
    glam::{Vec2, Vec3},
    Scene,
};
use softshadow_reference::{
    exact::{visible_fraction, ParallelRect},
    raycast::{ray_triangle, visibility, visibility_image, CasterBvh, SEGMENT_EPSILON},
};
use softshadow_scenes::AttySquare;

/// The occluder of `atty-square` as a light-space rectangle (as in `closed_form.rs`).
fn occluder(params: &AttySquare, scene: &Scene) -> ParallelRect {
    let half = params.occluder_size as f32 / 2.0;
    let cx = params.occluder_offset_x as f32;
    let y = params.occluder_height as f32;
    let corners = [
        scene.light.to_light_space([cx - half, y, -half].into()),
        scene.light.to_light_space([cx + half, y, half].into()),
    ];
    ParallelRect {
        min: corners[0].truncate().min(corners[1].truncate()),
        max: corners[0].truncate().max(corners[1].truncate()),
        z: corners[0].z,
    }
}

/// A 17 x 17 grid of ground points (y = 0) over x in cx +- 2.2, z in +- 2.2: umbra, penumbra and
/// lit for the default sizes.
fn ground_grid(cx: f32) -> Vec<Vec3> {
    let n = 17;
    let mut points = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let x = cx + (i as f32 / (n - 1) as f32 * 2.0 - 1.0) * 2.2;
            let z = (j as f32 / (n - 1) as f32 * 2.0 - 1.0) * 2.2;
            points.push(Vec3::new(x, 0.0, z));
        }
    }
    points
}

struct Errors {
    mae: f64,
    max: f64,
    umbra: usize,
    penumbra: usize,
    lit: usize,
}

fn errors_against_exact(params: &AttySquare, samples_per_axis: u32) -> Result<Errors> {
    let scene = params.scene()?;
    let bvh = CasterBvh::from_scene(&scene);
    let rect = occluder(params, &scene);
    let half = scene.light.half_extent();
    let points = ground_grid(params.occluder_offset_x as f32);
    let (mut sum, mut max) = (0.0f64, 0.0f64);
    let (mut umbra, mut penumbra, mut lit) = (0, 0, 0);
    for (k, p) in points.iter().enumerate() {
        let exact = visible_fraction(half, &[rect], scene.light.to_light_space(*p));
        let ray = visibility(&bvh, &scene.light, samples_per_axis, *p, k as u64);
        let e = (ray - exact).abs();
        sum += e;
        max = max.max(e);
        if exact <= 0.0 {
            umbra += 1;
        } else if exact >= 1.0 {
            lit += 1;
        } else {
            penumbra += 1;
        }
    }
    Ok(Errors {
        mae: sum / points.len() as f64,
        max,
        umbra,
        penumbra,
        lit,
    })
}

#[test]
fn raycast_matches_the_closed_form_for_a_square_parallel_to_the_light() -> Result<()> {
    let variants = [
        ("default", AttySquare::default()),
        (
            "offset_x=0.7",
            AttySquare {
                occluder_offset_x: 0.7,
                ..AttySquare::default()
            },
        ),
        (
            "light_width=0.3",
            AttySquare {
                light_width: 0.3,
                ..AttySquare::default()
            },
        ),
        (
            "light_width=2,occluder_height=0.4",
            AttySquare {
                light_width: 2.0,
                occluder_height: 0.4,
                ..AttySquare::default()
            },
        ),
    ];
    for (name, params) in variants {
        let e = errors_against_exact(&params, 32)?;
        eprintln!(
            "{name}: 32x32 samples, mean abs {:.5}, max abs {:.5} \
             ({} umbra, {} penumbra, {} lit points)",
            e.mae, e.max, e.umbra, e.penumbra, e.lit
        );
        assert!(
            e.umbra > 0 && e.penumbra > 20 && e.lit > 0,
            "{name}: the grid must cover umbra, penumbra and lit"
        );
        // Measured (seeds 0..289): mean abs 0.0002-0.0006, max abs 0.0046-0.0071. Bounds with
        // about 5x margin; the worst case of 32 x 32 stratified sampling is about 2/32 = 0.0625.
        assert!(e.mae < 0.003, "{name}: mean abs error {}", e.mae);
        assert!(e.max < 0.03, "{name}: max abs error {}", e.max);
    }
    Ok(())
}

#[test]
fn more_light_samples_bring_the_raycast_closer_to_the_exact_answer() -> Result<()> {
    let params = AttySquare::default();
    let mut errors = Vec::new();
    for n in [4, 8, 32] {
        errors.push(errors_against_exact(&params, n)?.mae);
    }
    // Measured: about 0.0178, 0.0050, 0.0006 (roughly 1/N^1.5 to 1/N^2 on average over the grid,
    // most points being umbra or lit and exact).
    eprintln!("mean abs error for 4, 8, 32 samples per axis: {errors:?}");
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
    Ok(())
}

#[test]
fn behind_the_light_is_dark_and_without_casters_everything_is_lit() -> Result<()> {
    let mut scene = AttySquare::default().scene()?;
    let bvh = CasterBvh::from_scene(&scene);
    assert!(bvh.triangle_count() > 0);
    // The light is at y = 2 facing down: y = 3 is behind it, y = 2 is on its plane.
    for p in [Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.3, 2.0, 0.1)] {
        assert_eq!(visibility(&bvh, &scene.light, 8, p, 1), 0.0, "{p}");
    }
    for instance in &mut scene.instances {
        instance.casts_shadow = false;
    }
    let empty = CasterBvh::from_scene(&scene);
    assert_eq!(empty.triangle_count(), 0);
    let points: Vec<Option<Vec3>> = ground_grid(0.0).into_iter().map(Some).collect();
    let mask = vec![true; points.len()];
    let image = visibility_image(&scene, &points, &mask, 4);
    assert!(image.iter().all(|&v| v == 1.0));
    Ok(())
}

#[test]
fn visibility_image_marks_non_receivers_lit_and_matches_visibility() -> Result<()> {
    let scene = AttySquare::default().scene()?;
    let bvh = CasterBvh::from_scene(&scene);
    let p = Vec3::ZERO; // under the occluder centre: umbra
    let positions = [Some(p), Some(p), None, Some(Vec3::new(0.9, 0.0, 0.0))];
    let mask = [true, false, true, true];
    let image = visibility_image(&scene, &positions, &mask, 8);
    assert_eq!(image.len(), 4);
    assert_eq!(image[0], 0.0);
    assert_eq!(image[1], 1.0);
    assert_eq!(image[2], 1.0);
    let direct = visibility(
        &bvh,
        &scene.light,
        8,
        positions[3].unwrap(),
        softshadow_reference::raycast::IMAGE_SEED,
    );
    assert_eq!(image[3], direct as f32);
    assert!(image[3] > 0.0 && image[3] < 1.0, "penumbra: {}", image[3]);
    Ok(())
}

#[test]
fn degenerate_lights_sample_their_centre_line_or_point() -> Result<()> {
    let params = AttySquare::default();
    let mut scene = params.scene()?;
    let bvh = CasterBvh::from_scene(&scene);
    let rect = occluder(&params, &scene);
    // Point light: visibility is 0 or 1 and agrees with the closed form's centre test.
    scene.light.width = 0.0;
    scene.light.height = 0.0;
    for p in ground_grid(0.0) {
        let v = visibility(&bvh, &scene.light, 8, p, 3);
        let exact = visible_fraction(Vec2::ZERO, &[rect], scene.light.to_light_space(p));
        // Points exactly on the hard shadow edge may go either way.
        let on_edge = (p.x.abs() - 1.0).abs() < 1e-3 || (p.z.abs() - 1.0).abs() < 1e-3;
        if !on_edge {
            assert_eq!(v, exact, "{p}");
        }
    }
    // Line light along light-space x (= world x; width 1, height 0) at y = 2. Seen from the
    // ground point (1.2, 0, 0), the occluder edge x = 0.5 at height 1 lines up with light x = -0.2,
    // so light x in [-0.5, -0.2] is hidden: 70 % visible.
    scene.light.width = 1.0;
    let v = visibility(&bvh, &scene.light, 32, Vec3::new(1.2, 0.0, 0.0), 5);
    let lit = 0.7;
    eprintln!("line light at x = 1.2: {v} (expected about {lit})");
    assert!((v - lit).abs() < 0.05, "{v}");
    Ok(())
}

/// World-space caster triangles gathered independently of `CasterBvh`.
fn caster_triangles(scene: &Scene) -> Vec<[Vec3; 3]> {
    let mut out = Vec::new();
    for inst in scene.instances.iter().filter(|i| i.casts_shadow) {
        let mesh = &scene.meshes[inst.mesh];
        for t in mesh.indices.chunks_exact(3) {
            let v = [0, 1, 2].map(|k| {
                inst.transform
                    .transform_point3(mesh.positions[t[k] as usize])
            });
            if v.iter().all(|p| p.is_finite()) {
                out.push(v);
            }
        }
    }
    out
}

#[test]
fn bvh_agrees_with_brute_force_on_random_segments() -> Result<()> {
    let scene = softshadow_scenes::load("blob-floating:triangles=5000")?.scene;
    let bvh = CasterBvh::from_scene(&scene);
    let triangles = caster_triangles(&scene);
    assert_eq!(bvh.triangle_count(), triangles.len());
    assert!(triangles.len() >= 4000, "{}", triangles.len());
    eprintln!(
        "blob-floating: {} caster triangles, {} BVH nodes",
        triangles.len(),
        bvh.node_count()
    );
    // Random segments between points of a box around the blob (centre (0, 1.2, 0), radius 0.6).
    let mut state = 0x1234_5678_9abc_def0u64;
    let mut rand = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 40) as f32) / (1u64 << 24) as f32
    };
    let mut point = || Vec3::new(rand() * 3.0 - 1.5, rand() * 3.0 - 0.3, rand() * 3.0 - 1.5);
    let (mut hits, mut misses) = (0, 0);
    for _ in 0..400 {
        let a = point();
        let b = point();
        let dir = b - a;
        let fast = bvh.any_hit(a, dir, SEGMENT_EPSILON, 1.0 - SEGMENT_EPSILON);
        let brute = triangles.iter().any(|t| {
            ray_triangle(a, dir, t)
                .is_some_and(|t| t > SEGMENT_EPSILON && t < 1.0 - SEGMENT_EPSILON)
        });
        assert_eq!(fast, brute, "segment {a} -> {b}");
        assert_eq!(
            fast,
            bvh.any_hit_brute_force(a, dir, SEGMENT_EPSILON, 1.0 - SEGMENT_EPSILON)
        );
        if fast {
            hits += 1;
        } else {
            misses += 1;
        }
    }
    eprintln!("random segments: {hits} hit, {misses} missed");
    assert!(hits > 40 && misses > 40, "{hits} hits, {misses} misses");
    Ok(())
}

#[test]
fn receivers_on_a_caster_do_not_shadow_themselves_through_rounding() -> Result<()> {
    // blob-floating: the blob casts and receives. Its topmost vertex faces the light; its
    // bottommost vertex faces away, so every segment to the light crosses the blob.
    let scene = softshadow_scenes::load("blob-floating:triangles=5000")?.scene;
    let bvh = CasterBvh::from_scene(&scene);
    let blob = scene
        .instances
        .iter()
        .find(|i| i.casts_shadow)
        .expect("the blob");
    let world: Vec<Vec3> = scene.meshes[blob.mesh]
        .positions
        .iter()
        .map(|p| blob.transform.transform_point3(*p))
        .collect();
    let top = world
        .iter()
        .copied()
        .max_by(|a, b| a.y.total_cmp(&b.y))
        .unwrap();
    let bottom = world
        .iter()
        .copied()
        .min_by(|a, b| a.y.total_cmp(&b.y))
        .unwrap();
    let v_top = visibility(&bvh, &scene.light, 16, top, 7);
    let v_bottom = visibility(&bvh, &scene.light, 16, bottom, 7);
    eprintln!("blob top vertex {top}: {v_top}; bottom vertex {bottom}: {v_bottom}");
    assert!(v_top > 0.9, "top {v_top}");
    assert_eq!(v_bottom, 0.0);
    Ok(())
}
