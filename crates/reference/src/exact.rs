//! Exact visibility for occluders that are rectangles parallel to the light (Atty et al. 2006,
//! sections 3.3-3.4): seen from a receiver point, each occluder projects onto the light plane as
//! an axis-aligned rectangle, and the visible fraction is one minus the area of the union of those
//! rectangles clipped to the light, over the light's area.

use rayon::prelude::*;
use softshadow_core::{
    glam::{Vec2, Vec3},
    LightKind, Scene,
};

/// A rectangle `[min, max]` (light-space x, y) in the plane `z` (distance from the light plane).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParallelRect {
    /// Smallest corner (light-space x, y).
    pub min: Vec2,
    /// Largest corner.
    pub max: Vec2,
    /// Distance from the light plane.
    pub z: f32,
}

/// Visible fraction of the light `[-a, a] x [-b, b]` (`half = (a, b)`) from the light-space
/// receiver point `p`, in f64. Occluders not strictly between the light plane and `p` are
/// ignored. A zero-area light is treated as a point: visible unless a rectangle covers its centre.
pub fn visible_fraction(half: Vec2, occluders: &[ParallelRect], p: Vec3) -> f64 {
    if p.z <= 0.0 {
        return 0.0;
    }
    let (a, b) = (half.x as f64, half.y as f64);
    let (px, py, pz) = (p.x as f64, p.y as f64, p.z as f64);
    // Each occluder point o maps to p + (o - p) * pz / (pz - oz) on the plane z = 0.
    let mut shadows: Vec<[f64; 4]> = Vec::new();
    for r in occluders {
        let z = r.z as f64;
        if !(z > 0.0 && z < pz) {
            continue;
        }
        let k = pz / (pz - z);
        let x0 = px + (r.min.x as f64 - px) * k;
        let x1 = px + (r.max.x as f64 - px) * k;
        let y0 = py + (r.min.y as f64 - py) * k;
        let y1 = py + (r.max.y as f64 - py) * k;
        shadows.push([x0.min(x1), x0.max(x1), y0.min(y1), y0.max(y1)]);
    }
    if a <= 0.0 || b <= 0.0 {
        // Point (or line) light: sample its centre.
        let covered = shadows
            .iter()
            .any(|s| s[0] <= 0.0 && 0.0 <= s[1] && s[2] <= 0.0 && 0.0 <= s[3]);
        return if covered { 0.0 } else { 1.0 };
    }
    let clipped: Vec<[f64; 4]> = shadows
        .iter()
        .map(|s| [s[0].max(-a), s[1].min(a), s[2].max(-b), s[3].min(b)])
        .filter(|s| s[0] < s[1] && s[2] < s[3])
        .collect();
    let covered = union_area(&clipped);
    (1.0 - covered / (4.0 * a * b)).clamp(0.0, 1.0)
}

/// Area of a union of axis-aligned rectangles `[x0, x1, y0, y1]`, exact, by coordinate compression
/// (occluder fusion: overlapping shadows must not be counted twice).
pub fn union_area(rects: &[[f64; 4]]) -> f64 {
    if rects.is_empty() {
        return 0.0;
    }
    let mut xs: Vec<f64> = rects.iter().flat_map(|r| [r[0], r[1]]).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    let mut area = 0.0;
    for w in xs.windows(2) {
        let (xa, xb) = (w[0], w[1]);
        let mut spans: Vec<(f64, f64)> = rects
            .iter()
            .filter(|r| r[0] <= xa && r[1] >= xb)
            .map(|r| (r[2], r[3]))
            .collect();
        spans.sort_by(|p, q| p.0.total_cmp(&q.0));
        let mut covered = 0.0;
        let mut current: Option<(f64, f64)> = None;
        for (y0, y1) in spans {
            current = match current {
                Some((c0, c1)) if y0 <= c1 => Some((c0, c1.max(y1))),
                Some((c0, c1)) => {
                    covered += c1 - c0;
                    Some((y0, y1))
                }
                None => Some((y0, y1)),
            };
        }
        if let Some((c0, c1)) = current {
            covered += c1 - c0;
        }
        area += covered * (xb - xa);
    }
    area
}

/// The scene's casters as rectangles parallel to the light, when every caster instance is one:
/// all its referenced vertices share one light-space depth (within 1e-5 relative) and sit on the
/// corners of its light-space bounding rectangle, and its triangles cover that rectangle a whole
/// number of times (1 for a quad, 2 for a two-sided quad or a flattened box). `None` when any
/// caster is something else (or has an alpha mask), or the light is not a rectangle: use a
/// sampled answer then.
/// `Some(vec![])` without casters.
pub fn parallel_rects(scene: &Scene) -> Option<Vec<ParallelRect>> {
    // A masked caster is a rectangle with holes, and the closed form is the rectangle light's.
    if scene.has_masked_casters() || scene.light.kind != LightKind::Rect {
        return None;
    }
    let mut rects = Vec::new();
    for instance in scene.instances.iter().filter(|i| i.casts_shadow) {
        let mesh = scene.meshes.get(instance.mesh)?;
        if mesh.indices.is_empty() {
            continue;
        }
        let corners: Vec<Vec3> = mesh
            .indices
            .iter()
            .map(|&i| {
                let p = mesh.positions.get(i as usize)?;
                Some(
                    scene
                        .light
                        .to_light_space(instance.transform.transform_point3(*p)),
                )
            })
            .collect::<Option<_>>()?;
        let (min, max) = corners.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let size = (max - min).truncate();
        let scale = size.max_element().max(max.z.abs()).max(1e-6);
        let flat = max.z - min.z <= 1e-5 * scale; // false for NaN too
        if !flat || size.min_element() <= 1e-6 * scale {
            return None;
        }
        let on_corner = |p: &Vec3| {
            let tol = 1e-5 * scale;
            ((p.x - min.x).abs() <= tol || (p.x - max.x).abs() <= tol)
                && ((p.y - min.y).abs() <= tol || (p.y - max.y).abs() <= tol)
        };
        if !corners.iter().all(on_corner) {
            return None;
        }
        let covered: f64 = corners
            .chunks_exact(3)
            .map(|t| {
                let (a, b, c) = (t[0].truncate(), t[1].truncate(), t[2].truncate());
                0.5 * ((b - a).perp_dot(c - a) as f64).abs()
            })
            .sum();
        let times = covered / (size.x as f64 * size.y as f64);
        if (times - times.round()).abs() > 1e-3 || times.round() < 1.0 {
            return None;
        }
        rects.push(ParallelRect {
            min: min.truncate(),
            max: max.truncate(),
            z: 0.5 * (min.z + max.z),
        });
    }
    Some(rects)
}

/// Exact per-pixel visibility for a scene whose casters are all [`parallel_rects`]: 1.0 where
/// the position is `None` or the pixel is not a receiver, else [`visible_fraction`] of the
/// light-space point. `None` when the casters are not all rectangles parallel to the light.
pub fn visibility_image(
    scene: &Scene,
    positions: &[Option<Vec3>],
    receiver_mask: &[bool],
) -> Option<Vec<f32>> {
    // The closed form clips to the light rectangle; other kinds are sampled.
    if scene.light.kind != softshadow_core::LightKind::Rect {
        return None;
    }
    let rects = parallel_rects(scene)?;
    let half = scene.light.half_extent();
    Some(
        positions
            .par_iter()
            .enumerate()
            .map(|(i, p)| match p {
                Some(p) if receiver_mask.get(i).copied().unwrap_or(false) => {
                    visible_fraction(half, &rects, scene.light.to_light_space(*p)) as f32
                }
                _ => 1.0,
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_answers() {
        let half = Vec2::splat(0.5);
        let square = ParallelRect {
            min: Vec2::splat(-0.5),
            max: Vec2::splat(0.5),
            z: 1.0,
        };
        // Under the centre of the occluder, halfway between light and receiver: its shadow on the
        // light is [-1, 1]^2, covering the whole light.
        assert_eq!(
            visible_fraction(half, &[square], Vec3::new(0.0, 0.0, 2.0)),
            0.0
        );
        // Far to the side: fully lit.
        assert_eq!(
            visible_fraction(half, &[square], Vec3::new(5.0, 0.0, 2.0)),
            1.0
        );
        // Receiver at x = 1: the shadow spans x in [1 - 1.5*2, 1 - 0.5*2] = [-2, 0]: half the light.
        let v = visible_fraction(half, &[square], Vec3::new(1.0, 0.0, 2.0));
        assert!((v - 0.5).abs() < 1e-12, "{v}");
        // Occluder at or beyond the receiver casts nothing.
        assert_eq!(
            visible_fraction(half, &[square], Vec3::new(0.0, 0.0, 1.0)),
            1.0
        );
        // Behind the light plane.
        assert_eq!(
            visible_fraction(half, &[square], Vec3::new(0.0, 0.0, -1.0)),
            0.0
        );
    }

    /// Cases the first `cargo mutants` run found untested (docs/STABILITY.md, "Mutation
    /// testing"): an occluder in the light plane, a scale other than 2, a light of area other
    /// than 1, a line light, a shadow that misses the light in y only beside one that covers half.
    #[test]
    fn planes_scales_light_shapes_and_misses() {
        let square = |z| ParallelRect {
            min: Vec2::splat(-0.5),
            max: Vec2::splat(0.5),
            z,
        };
        let unit = Vec2::splat(0.5);
        // In the light plane (z = 0) is not strictly between light and receiver: ignored.
        assert_eq!(
            visible_fraction(unit, &[square(0.0)], Vec3::new(0.0, 0.0, 2.0)),
            1.0
        );
        // Receiver at (1, 0, 3), occluder at z = 1: scale 3 / (3 - 1) = 1.5, shadow x in
        // [1 - 1.5 * 1.5, 1 - 0.5 * 1.5] = [-1.25, 0.25]: 0.75 of the light's width covered.
        let v = visible_fraction(unit, &[square(1.0)], Vec3::new(1.0, 0.0, 3.0));
        assert!((v - 0.25).abs() < 1e-12, "{v}");
        // A 2 x 1 light (area 2): the shadow [-2, 0] x [-1, 1] covers [-1, 0] x [-0.5, 0.5].
        let wide = Vec2::new(1.0, 0.5);
        let v = visible_fraction(wide, &[square(1.0)], Vec3::new(1.0, 0.0, 2.0));
        assert!((v - 0.5).abs() < 1e-12, "{v}");
        // A line light (zero height) is sampled at its centre: covered, or not.
        let line = Vec2::new(0.5, 0.0);
        assert_eq!(
            visible_fraction(line, &[square(1.0)], Vec3::new(0.0, 0.0, 2.0)),
            0.0
        );
        assert_eq!(
            visible_fraction(line, &[square(1.0)], Vec3::new(5.0, 0.0, 2.0)),
            1.0
        );
        // Beside a shadow covering half the light (x in [-1, 0]), one that spans the light in x
        // but lies beyond it in y (y in [5, 7]) covers nothing and must not subtract.
        let half_cover = ParallelRect {
            min: Vec2::new(-0.5, -0.5),
            max: Vec2::new(0.0, 0.5),
            z: 1.0,
        };
        let below = ParallelRect {
            min: Vec2::new(-0.5, 2.5),
            max: Vec2::new(0.5, 3.5),
            z: 1.0,
        };
        let v = visible_fraction(unit, &[half_cover, below], Vec3::new(0.0, 0.0, 2.0));
        assert!((v - 0.5).abs() < 1e-12, "{v}");
    }

    /// atty-square with its casters replaced by one two-triangle quad whose corners are the
    /// given light-space points (the first four; a fifth vertex, if given, replaces the last
    /// triangle's third corner).
    fn scene_with_quad(corners: &[Vec3]) -> Scene {
        let mut indices = vec![0, 1, 2, 0, 2, 3];
        if corners.len() > 4 {
            indices[5] = 4;
        }
        scene_with_caster(corners, indices)
    }

    /// atty-square with its casters replaced by one mesh of the given light-space vertices and
    /// triangles.
    fn scene_with_caster(corners: &[Vec3], indices: Vec<u32>) -> Scene {
        let mut scene = softshadow_scenes::load("atty-square").unwrap().scene;
        let (x, y, z) = scene.light.basis();
        let centre = scene.light.center;
        let world: Vec<Vec3> = corners
            .iter()
            .map(|p| centre + x * p.x + y * p.y + z * p.z)
            .collect();
        scene.meshes.push(softshadow_core::Mesh {
            texcoords: Vec::new(),
            name: "quad".into(),
            positions: world,
            normals: Vec::new(),
            indices,
        });
        let mesh = scene.meshes.len() - 1;
        for instance in scene.instances.iter_mut().filter(|i| i.casts_shadow) {
            instance.casts_shadow = false;
        }
        scene.instances.push(softshadow_core::Instance {
            material: None,
            mesh,
            transform: softshadow_core::glam::Mat4::IDENTITY,
            albedo: Vec3::ONE,
            casts_shadow: true,
            receives_shadow: false,
            dynamic: false,
        });
        scene
    }

    /// The tolerances of [`parallel_rects`] scale with the caster's size (found by `cargo
    /// mutants`: at size 1 a tolerance `1e-5 * scale` and `1e-5 / scale` agree). A 1000-wide
    /// quad tilted by 0.005 in depth is flat (tolerance 0.01); one with a corner 5 off its
    /// rectangle, or 0.0005 wide, or with a vertex in the middle of an edge, is not a rectangle.
    #[test]
    fn rectangle_tolerances_scale_with_the_caster() {
        let quad = |w: f32, h: f32| {
            vec![
                Vec3::new(-w, -h, 2.0),
                Vec3::new(w, -h, 2.0),
                Vec3::new(w, h, 2.0),
                Vec3::new(-w, h, 2.0),
            ]
        };
        let flat = parallel_rects(&scene_with_quad(&quad(500.0, 500.0))).unwrap();
        assert_eq!(flat.len(), 1);
        let close = |a: f32, b: f32| (a - b).abs() < 1e-2;
        assert!(
            close(flat[0].min.x, -500.0)
                && close(flat[0].min.y, -500.0)
                && close(flat[0].max.x, 500.0)
                && close(flat[0].max.y, 500.0)
                && close(flat[0].z, 2.0),
            "{:?} {:?} {}",
            flat[0].min,
            flat[0].max,
            flat[0].z
        );
        let mut tilted = quad(500.0, 500.0);
        tilted[2].z += 0.005;
        let tilted = parallel_rects(&scene_with_quad(&tilted)).unwrap();
        // Its depth is the middle of its depth range.
        assert!(
            tilted.len() == 1 && (tilted[0].z - 2.0025).abs() < 5e-4,
            "{}",
            tilted[0].z
        );
        // One triangle covers half the rectangle; three equal corners cover none of it.
        let mut half = quad(500.0, 500.0);
        half.push(half[0]);
        assert!(parallel_rects(&scene_with_quad(&half)).is_none());
        let mut off_corner = quad(500.0, 500.0);
        off_corner[2].x -= 5.0;
        assert!(parallel_rects(&scene_with_quad(&off_corner)).is_none());
        let sliver = quad(500.0, 0.00025);
        assert!(parallel_rects(&scene_with_quad(&sliver)).is_none());
        // The last triangle's third corner in the middle of the top edge: on an x edge's line
        // only, not a corner.
        let mut mid_edge = quad(500.0, 500.0);
        mid_edge.push(Vec3::new(0.0, 500.0, 2.0));
        assert!(parallel_rects(&scene_with_quad(&mid_edge)).is_none());
    }

    /// The corner test itself, where the triangles' coverage cannot decide (the second `cargo
    /// mutants` pass: a tolerance of `1e-5 + scale` or `1e-5 / scale`, or "on an x edge *or* a y
    /// edge", went unnoticed because every off-corner case above also covers the rectangle a
    /// fractional number of times).
    #[test]
    fn corners_are_checked_within_the_size_relative_tolerance() {
        let (w, h) = (500.0, 500.0);
        // A corner 0.005 inside its rectangle at size 1000 is within the tolerance 1e-5 * 1000 =
        // 0.01 (1e-5 / 1000 would reject it); the coverage moves by about 2.5e-6 only.
        let near = vec![
            Vec3::new(-w, -h, 2.0),
            Vec3::new(w, -h, 2.0),
            Vec3::new(w - 0.005, h, 2.0),
            Vec3::new(-w, h, 2.0),
        ];
        let rects = parallel_rects(&scene_with_quad(&near)).unwrap();
        assert_eq!(rects.len(), 1);
        // Three triangles fanned around the middle of the top edge, m = (0, h): (m, bl, br) is
        // half the rectangle, (m, br, tr) and (m, tl, bl) a quarter each, so they cover it exactly
        // once; only the corner test rejects m, which lies on a y edge but on no x edge.
        let fan = vec![
            Vec3::new(-w, -h, 2.0), // bl
            Vec3::new(w, -h, 2.0),  // br
            Vec3::new(w, h, 2.0),   // tr
            Vec3::new(-w, h, 2.0),  // tl
            Vec3::new(0.0, h, 2.0), // m
        ];
        assert!(
            parallel_rects(&scene_with_caster(&fan, vec![4, 0, 1, 4, 1, 2, 4, 3, 0])).is_none()
        );
        // The same fan with m moved to the corner tr is a rectangle covered once (the third
        // triangle is then the quad's second half, the second one degenerate).
        let mut fan_on_corner = fan.clone();
        fan_on_corner[4] = fan[2];
        let rects = parallel_rects(&scene_with_caster(
            &fan_on_corner,
            vec![4, 0, 1, 4, 1, 2, 4, 3, 0],
        ))
        .unwrap();
        assert_eq!(rects.len(), 1);
    }

    /// The per-pixel image: the closed form on receivers, 1.0 on pixels without a position or
    /// outside the receiver mask.
    #[test]
    fn visibility_image_fills_receivers_only() {
        let scene = softshadow_scenes::load("atty-square").unwrap().scene;
        let rects = parallel_rects(&scene).unwrap();
        let half = scene.light.half_extent();
        let (x, y, z) = scene.light.basis();
        let under = scene.light.center + z * 3.0 + x * 0.1 + y * 0.05;
        let expected = visible_fraction(half, &rects, scene.light.to_light_space(under)) as f32;
        assert!(
            expected < 1.0,
            "the test point must be shadowed: {expected}"
        );
        let image = visibility_image(
            &scene,
            &[Some(under), None, Some(under), Some(under)],
            &[true, true, false],
        )
        .unwrap();
        assert_eq!(image, vec![expected, 1.0, 1.0, 1.0]);
    }

    #[test]
    fn union_counts_overlap_once() {
        let a = [0.0, 2.0, 0.0, 2.0];
        let b = [1.0, 3.0, 1.0, 3.0];
        assert!((union_area(&[a, b]) - 7.0).abs() < 1e-12);
        assert!((union_area(&[a, a]) - 4.0).abs() < 1e-12);
        // Spans of one strip that do not touch stay apart: 1 + 1, not the 3 of their hull.
        let low = [0.0, 1.0, 0.0, 1.0];
        let high = [0.0, 1.0, 2.0, 3.0];
        assert!((union_area(&[low, high]) - 2.0).abs() < 1e-12);
        // The same away from y = 0 (a span's length is y1 - y0, not y1 + y0): 1 + 1 again.
        let low = [0.0, 1.0, 1.0, 2.0];
        let high = [0.0, 1.0, 3.0, 4.0];
        assert!((union_area(&[low, high]) - 2.0).abs() < 1e-12);
        assert_eq!(union_area(&[]), 0.0);
    }
}
