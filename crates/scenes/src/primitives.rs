//! Procedural primitives in object space.
//!
//! Conventions shared by every builder here:
//! * triangles are wound counter-clockwise when seen from outside (from the side the normal
//!   points to), so `(b - a).cross(c - a)` points outwards;
//! * vertex normals are unit length and point outwards;
//! * closed solids ([`cuboid`], [`uv_sphere`], [`blob`], [`cylinder`]) are centred on the origin;
//!   the flat ones ([`plane`], [`two_sided_quad`]) lie in the plane y = 0.

use glam::Vec3;
use softshadow_core::Mesh;

/// Smallest and largest triangle counts [`blob`] accepts (it clamps to this range).
pub const BLOB_TRIANGLES_RANGE: (u32, u32) = (8, 8_000_000);

/// Appends the quad `a, b, c, d` (counter-clockwise around `normal`) as two triangles with four
/// vertices of their own.
pub(crate) fn push_quad(mesh: &mut Mesh, corners: [Vec3; 4], normal: Vec3) {
    let base = mesh.positions.len() as u32;
    mesh.positions.extend_from_slice(&corners);
    mesh.normals.extend_from_slice(&[normal; 4]);
    mesh.indices
        .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
}

/// Corners of a face centred at `center` spanned by the half-extent vectors `u` and `v`, ordered
/// counter-clockwise around `u × v`.
pub(crate) fn face(center: Vec3, u: Vec3, v: Vec3) -> [Vec3; 4] {
    [
        center - u - v,
        center + u - v,
        center + u + v,
        center - u + v,
    ]
}

/// A flat rectangle `size_x` by `size_z` in the plane y = 0, centred on the origin, facing +y
/// (one-sided: 2 triangles).
pub fn plane(size_x: f32, size_z: f32) -> Mesh {
    let mut mesh = named("plane");
    // z × x = +y, so this order is counter-clockwise seen from above.
    push_quad(
        &mut mesh,
        face(
            Vec3::ZERO,
            Vec3::Z * (size_z * 0.5),
            Vec3::X * (size_x * 0.5),
        ),
        Vec3::Y,
    );
    mesh
}

/// A zero-thickness horizontal square/rectangle visible from both sides: the same rectangle as
/// [`plane`] emitted twice, once facing +y and once facing -y (4 triangles, 8 vertices), so that
/// back-face culling never removes it from a shadow map.
pub fn two_sided_quad(size_x: f32, size_z: f32) -> Mesh {
    let mut mesh = named("two-sided quad");
    let (hx, hz) = (Vec3::X * (size_x * 0.5), Vec3::Z * (size_z * 0.5));
    push_quad(&mut mesh, face(Vec3::ZERO, hz, hx), Vec3::Y);
    push_quad(&mut mesh, face(Vec3::ZERO, hx, hz), Vec3::NEG_Y);
    mesh
}

/// A closed axis-aligned box with the given full extents, centred on the origin (12 triangles,
/// flat normals).
pub fn cuboid(size: Vec3) -> Mesh {
    let mut mesh = named("box");
    let h = size * 0.5;
    let (x, y, z) = (Vec3::X * h.x, Vec3::Y * h.y, Vec3::Z * h.z);
    // Each face: (centre, u, v) with u × v along the outward normal.
    let faces = [
        (x, y, z, Vec3::X),
        (-x, z, y, Vec3::NEG_X),
        (y, z, x, Vec3::Y),
        (-y, x, z, Vec3::NEG_Y),
        (z, x, y, Vec3::Z),
        (-z, y, x, Vec3::NEG_Z),
    ];
    for (center, u, v, normal) in faces {
        push_quad(&mut mesh, face(center, u, v), normal);
    }
    mesh
}

/// A closed cylinder around the y axis from y = -height/2 to y = +height/2, with flat caps.
/// The side has smooth radial normals, the caps flat ones (`4 * segments` triangles).
pub fn cylinder(radius: f32, height: f32, segments: u32) -> Mesh {
    let n = segments.max(3);
    let mut mesh = named("cylinder");
    let (y0, y1) = (-height * 0.5, height * 0.5);
    let dir = |j: u32| {
        let phi = std::f32::consts::TAU * (j % n) as f32 / n as f32;
        Vec3::new(phi.cos(), 0.0, phi.sin())
    };
    // Side: column j has a bottom vertex 2j and a top vertex 2j + 1.
    for j in 0..n {
        let d = dir(j);
        mesh.positions.push(d * radius + Vec3::Y * y0);
        mesh.positions.push(d * radius + Vec3::Y * y1);
        mesh.normals.extend_from_slice(&[d, d]);
    }
    for j in 0..n {
        let k = (j + 1) % n;
        let (b0, t0, b1, t1) = (2 * j, 2 * j + 1, 2 * k, 2 * k + 1);
        mesh.indices.extend_from_slice(&[b0, t0, t1, b0, t1, b1]);
    }
    // Caps: a centre vertex and a ring with a flat normal each.
    for (y, normal) in [(y1, Vec3::Y), (y0, Vec3::NEG_Y)] {
        let center = mesh.positions.len() as u32;
        mesh.positions.push(Vec3::Y * y);
        mesh.normals.push(normal);
        for j in 0..n {
            mesh.positions.push(dir(j) * radius + Vec3::Y * y);
            mesh.normals.push(normal);
        }
        for j in 0..n {
            let (p0, p1) = (center + 1 + j, center + 1 + (j + 1) % n);
            if normal.y > 0.0 {
                mesh.indices.extend_from_slice(&[center, p1, p0]);
            } else {
                mesh.indices.extend_from_slice(&[center, p0, p1]);
            }
        }
    }
    mesh
}

/// A closed UV sphere of the given radius with `segments` longitude steps and `segments / 2`
/// latitude bands (`2 * segments * (segments / 2 - 1)` triangles; smooth normals).
pub fn uv_sphere(radius: f32, segments: u32) -> Mesh {
    let segments = segments.max(3);
    let rings = (segments / 2).max(2);
    let mut mesh = latitude_longitude(rings, segments, |_| radius);
    mesh.normals = mesh
        .positions
        .iter()
        .map(|p| p.try_normalize().unwrap_or(Vec3::Y))
        .collect();
    mesh.name = "sphere".into();
    mesh
}

/// Triangle count of a latitude-longitude grid with `rings` bands and `segments` columns.
pub fn latitude_longitude_triangles(rings: u32, segments: u32) -> usize {
    2 * segments as usize * (rings as usize - 1)
}

/// A closed, bumpy, star-shaped "blob": a sphere whose radius varies smoothly with direction by
/// up to ±15 %, deterministic for a given `seed`. Its triangle count is as close to `triangles`
/// as a latitude-longitude grid allows (within a fraction of a percent above a few hundred
/// triangles). Normals are area-weighted vertex normals.
pub fn blob(radius: f32, triangles: u32, seed: u64) -> Mesh {
    let target = triangles.clamp(BLOB_TRIANGLES_RANGE.0, BLOB_TRIANGLES_RANGE.1) as f64;
    // 2 * segments * (rings - 1) triangles with segments ≈ 2 * (rings - 1) for square-ish cells.
    let bands = ((target / 4.0).sqrt().round() as u32).max(1);
    let segments = ((target / (2.0 * bands as f64)).round() as u32).max(3);
    let bumps = Bumps::new(seed);
    let mut mesh = latitude_longitude(bands + 1, segments, |d| radius * bumps.scale(d));
    mesh.name = format!("blob (seed {seed})");
    mesh.ensure_normals();
    mesh
}

/// SplitMix64: a tiny, well-mixed, dependency-free generator; every procedural scene draws from
/// one, so the scenes are the same on every machine.
pub(crate) struct SplitMix64(u64);

impl SplitMix64 {
    pub(crate) fn new(seed: u64) -> Self {
        Self(seed ^ 0x9e37_79b9_7f4a_7c15)
    }

    /// A uniform number in [0, 1) with 24 random bits.
    pub(crate) fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A uniform point in the unit ball (rejection sampling).
    pub(crate) fn in_unit_ball(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.next_f32(), self.next_f32(), self.next_f32()) * 2.0 - 1.0;
            if v.length_squared() <= 1.0 {
                return v;
            }
        }
    }
}

/// A sum of a few random plane waves over the unit sphere, normalised to [-1, 1] and mapped to a
/// radius scale in [0.85, 1.15]. Always positive, so the displaced surface stays star-shaped and
/// cannot self-intersect.
struct Bumps {
    waves: Vec<(Vec3, f32, f32)>,
    total_weight: f32,
}

impl Bumps {
    const AMPLITUDE: f32 = 0.15;

    fn new(seed: u64) -> Self {
        let mut rng = SplitMix64::new(seed);
        let mut next = move || rng.next_f32();
        let waves: Vec<_> = (0..7)
            .map(|k| {
                let axis = loop {
                    let v = Vec3::new(next(), next(), next()) * 2.0 - 1.0;
                    if let Some(n) = v.try_normalize() {
                        break n;
                    }
                };
                let frequency = 2.0 + 2.5 * next() + k as f32 * 0.3;
                let phase = std::f32::consts::TAU * next();
                (axis * frequency, phase, 1.0 / (1.0 + k as f32 * 0.35))
            })
            .collect();
        let total_weight = waves.iter().map(|w| w.2).sum();
        Self {
            waves,
            total_weight,
        }
    }

    fn scale(&self, direction: Vec3) -> f32 {
        let sum: f32 = self
            .waves
            .iter()
            .map(|(k, phase, weight)| weight * (k.dot(direction) + phase).sin())
            .sum();
        1.0 + Self::AMPLITUDE * sum / self.total_weight
    }
}

/// A closed latitude-longitude sphere whose radius in unit direction `d` is `radius(d)`:
/// a north pole, `rings - 1` latitude circles of `segments` vertices, a south pole.
/// Normals are left empty.
fn latitude_longitude(rings: u32, segments: u32, radius: impl Fn(Vec3) -> f32) -> Mesh {
    let rings = rings.max(2);
    let segments = segments.max(3);
    let mut mesh = named("sphere");
    let circles = rings - 1;
    mesh.positions.reserve(2 + (circles * segments) as usize);
    mesh.indices
        .reserve(3 * latitude_longitude_triangles(rings, segments));
    let mut push = |d: Vec3| mesh.positions.push(d * radius(d));
    push(Vec3::Y);
    let azimuths: Vec<(f32, f32)> = (0..segments)
        .map(|j| (std::f32::consts::TAU * j as f32 / segments as f32).sin_cos())
        .collect();
    for i in 1..rings {
        let (sin_t, cos_t) = (std::f32::consts::PI * i as f32 / rings as f32).sin_cos();
        for &(sin_p, cos_p) in &azimuths {
            push(Vec3::new(sin_t * cos_p, cos_t, sin_t * sin_p));
        }
    }
    push(Vec3::NEG_Y);
    let south = 1 + circles * segments;
    let at = |circle: u32, j: u32| 1 + circle * segments + j % segments;
    for j in 0..segments {
        // φ runs from +x towards +z, so seen from outside a circle's edge j + 1 -> j belongs to
        // the counter-clockwise loop of the cell above it, and j -> j + 1 to the cell below.
        mesh.indices.extend_from_slice(&[0, at(0, j + 1), at(0, j)]);
        for c in 0..circles - 1 {
            let (u0, u1, l0, l1) = (at(c, j), at(c, j + 1), at(c + 1, j), at(c + 1, j + 1));
            mesh.indices.extend_from_slice(&[u0, u1, l1, u0, l1, l0]);
        }
        mesh.indices
            .extend_from_slice(&[at(circles - 1, j), at(circles - 1, j + 1), south]);
    }
    mesh
}

fn named(name: &str) -> Mesh {
    Mesh {
        name: name.into(),
        ..Mesh::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn triangles(mesh: &Mesh) -> impl Iterator<Item = [Vec3; 3]> + '_ {
        mesh.indices
            .chunks_exact(3)
            .map(|t| [0, 1, 2].map(|k| mesh.positions[t[k] as usize]))
    }

    /// Every directed edge appears once and its reverse once (closed, consistently wound),
    /// comparing positions so that split vertices (flat normals) still count as shared.
    fn assert_closed(mesh: &Mesh) {
        let key = |p: Vec3| p.to_array().map(|c| (c * 1e5).round() as i64);
        let mut edges: HashMap<_, i32> = HashMap::new();
        for [a, b, c] in triangles(mesh) {
            for (p, q) in [(a, b), (b, c), (c, a)] {
                *edges.entry((key(p), key(q))).or_default() += 1;
            }
        }
        for ((p, q), count) in &edges {
            assert_eq!(*count, 1, "{}: directed edge used {count} times", mesh.name);
            assert_eq!(
                edges.get(&(*q, *p)),
                Some(&1),
                "{}: edge without a reversed twin (open or flipped)",
                mesh.name
            );
        }
    }

    fn signed_volume(mesh: &Mesh) -> f32 {
        triangles(mesh)
            .map(|[a, b, c]| a.dot(b.cross(c)) / 6.0)
            .sum()
    }

    fn assert_outward_convex(mesh: &Mesh) {
        for [a, b, c] in triangles(mesh) {
            let n = (b - a).cross(c - a);
            assert!(
                n.dot((a + b + c) / 3.0) > 0.0,
                "{}: inward triangle",
                mesh.name
            );
        }
        for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
            assert!(
                (n.length() - 1.0).abs() < 1e-4,
                "{}: normal not unit",
                mesh.name
            );
            assert!(n.dot(*p) > 0.0, "{}: inward vertex normal", mesh.name);
        }
    }

    #[test]
    fn plane_faces_up() {
        let m = plane(8.0, 4.0);
        assert_eq!(m.triangle_count(), 2);
        for [a, b, c] in triangles(&m) {
            assert!((b - a).cross(c - a).normalize().abs_diff_eq(Vec3::Y, 1e-6));
        }
        let max = m.positions.iter().fold(Vec3::ZERO, |acc, p| acc.max(*p));
        assert_eq!(max, Vec3::new(4.0, 0.0, 2.0));
    }

    #[test]
    fn two_sided_quad_has_both_windings() {
        let m = two_sided_quad(1.0, 1.0);
        assert_eq!(m.triangle_count(), 4);
        let ups = triangles(&m)
            .filter(|[a, b, c]| (b - a).cross(c - a).y > 0.0)
            .count();
        assert_eq!(ups, 2);
        for (i, n) in m.normals.iter().enumerate() {
            assert_eq!(n.y, if i < 4 { 1.0 } else { -1.0 });
        }
    }

    #[test]
    fn closed_solids_are_closed_and_outward() {
        let solids = [
            cuboid(Vec3::new(1.0, 2.0, 3.0)),
            uv_sphere(0.5, 24),
            cylinder(0.25, 1.4, 20),
        ];
        for m in &solids {
            assert_closed(m);
            assert_outward_convex(m);
            assert!(signed_volume(m) > 0.0);
            assert_eq!(m.normals.len(), m.positions.len());
        }
        let v = signed_volume(&solids[0]);
        assert!((v - 6.0).abs() < 1e-4, "box volume {v}");
        assert_eq!(solids[0].triangle_count(), 12);
        assert_eq!(solids[2].triangle_count(), 80);
        assert_eq!(
            solids[1].triangle_count(),
            latitude_longitude_triangles(12, 24)
        );
    }

    #[test]
    fn blob_is_closed_deterministic_and_near_target() {
        for target in [250u32, 1000, 25_000, 100_000] {
            let m = blob(0.6, target, 7);
            let err = (m.triangle_count() as f64 - target as f64).abs() / target as f64;
            assert!(err < 0.05, "target {target}: got {}", m.triangle_count());
            if target <= 25_000 {
                assert_closed(&m);
            }
            assert!(signed_volume(&m) > 0.0);
            for p in &m.positions {
                let r = p.length();
                assert!(
                    p.is_finite() && r > 0.6 * 0.84 && r < 0.6 * 1.16,
                    "radius {r}"
                );
            }
        }
        let (a, b, c) = (blob(0.5, 2000, 1), blob(0.5, 2000, 1), blob(0.5, 2000, 2));
        assert_eq!(a.positions, b.positions);
        assert_ne!(a.positions, c.positions);
        // Bumpy: the radius really varies.
        let radii: Vec<f32> = a.positions.iter().map(|p| p.length()).collect();
        let (lo, hi) = radii
            .iter()
            .fold((f32::MAX, 0.0f32), |(l, h), r| (l.min(*r), h.max(*r)));
        assert!(hi - lo > 0.05, "blob is not bumpy: {lo}..{hi}");
    }

    #[test]
    fn primitives_survive_repair_untouched() {
        for mut m in [
            plane(1.0, 1.0),
            two_sided_quad(0.6, 0.6),
            cuboid(Vec3::ONE),
            uv_sphere(0.18, 16),
            cylinder(0.25, 1.4, 32),
            blob(0.4, 250, 3),
            blob(0.4, 250_000, 3),
        ] {
            let before = m.triangle_count();
            assert_eq!(m.repair().total(), 0, "{}", m.name);
            assert_eq!(m.triangle_count(), before);
        }
    }
}
