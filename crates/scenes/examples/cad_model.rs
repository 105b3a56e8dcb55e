//! Writes `assets/models/cad-bracket.gltf`: a small CAD-like assembly of many thin parts that
//! shadow each other (a tessellated base plate on four legs, thin ribs standing on it, a cover
//! plate resting on the ribs with a hairline gap, a pair of shim plates stacked with a 4 mm gap,
//! a louvre of thin tilted slats and a row of thin rods), one glTF mesh per part, as a CAD export
//! would have them. The yardsticks' test on it is `multi_part_mesh` in the bench's GPU tests
//! (docs/TECHNIQUES.md, `reference`, "The three yardsticks on a multi-part mesh").
//!
//! `cargo run -p softshadow-scenes --example cad_model -- assets/models/cad-bracket.gltf`

use std::f32::consts::TAU;

use glam::{Mat3, Vec3};
use serde_json::json;

/// One part: world-space positions (metres, y up) and a triangle list.
#[derive(Default)]
struct Part {
    name: String,
    positions: Vec<Vec3>,
    indices: Vec<u32>,
}

impl Part {
    fn new(name: &str) -> Self {
        Self {
            name: name.into(),
            ..Default::default()
        }
    }

    /// A grid of `nu x nv` quads over the parallelogram `origin + s u + t v`, s, t in [0, 1],
    /// wound counter-clockwise seen from `u x v`.
    fn grid(&mut self, origin: Vec3, u: Vec3, v: Vec3, nu: u32, nv: u32) {
        let base = self.positions.len() as u32;
        for j in 0..=nv {
            for i in 0..=nu {
                self.positions
                    .push(origin + u * (i as f32 / nu as f32) + v * (j as f32 / nv as f32));
            }
        }
        for j in 0..nv {
            for i in 0..nu {
                let a = base + j * (nu + 1) + i;
                let (b, c, d) = (a + 1, a + nu + 1, a + nu + 2);
                self.indices.extend_from_slice(&[a, b, d, a, d, c]);
            }
        }
    }

    /// A closed box centred at `centre` with edges `size` along the columns of `rotation`, each
    /// face tessellated into quads of about `cell` metres (as CAD exporters do).
    fn cuboid(&mut self, centre: Vec3, size: Vec3, rotation: Mat3, cell: f32) {
        let h = size * 0.5;
        let axes = [rotation.x_axis, rotation.y_axis, rotation.z_axis];
        let steps = |len: f32| ((len / cell).ceil() as u32).max(1);
        for (k, axis) in axes.iter().enumerate() {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            for sign in [1.0f32, -1.0] {
                let normal = *axis * sign;
                // u x v = normal: (a, b) for +, (b, a) for -.
                let (ua, va) = if sign > 0.0 { (a, b) } else { (b, a) };
                let u = axes[ua] * size[ua];
                let v = axes[va] * size[va];
                let origin = centre + normal * h[k] - axes[ua] * h[ua] - axes[va] * h[va];
                self.grid(origin, u, v, steps(size[ua]), steps(size[va]));
            }
        }
    }

    /// A closed cylinder of `radius` from `a` to `b` with `segments` sides.
    fn cylinder(&mut self, a: Vec3, b: Vec3, radius: f32, segments: u32) {
        let axis = (b - a).normalize();
        let side = axis.any_orthonormal_vector();
        let other = axis.cross(side);
        let ring = |angle: f32| side * angle.cos() * radius + other * angle.sin() * radius;
        let base = self.positions.len() as u32;
        self.positions.push(a);
        self.positions.push(b);
        for s in 0..segments {
            let offset = ring(s as f32 / segments as f32 * TAU);
            self.positions.push(a + offset);
            self.positions.push(b + offset);
        }
        for s in 0..segments {
            let (i0, i1) = (base + 2 + 2 * s, base + 2 + 2 * ((s + 1) % segments));
            // Side quad, the two caps' triangles.
            self.indices
                .extend_from_slice(&[i0, i1, i1 + 1, i0, i1 + 1, i0 + 1]);
            self.indices.extend_from_slice(&[base, i1, i0]);
            self.indices.extend_from_slice(&[base + 1, i0 + 1, i1 + 1]);
        }
    }
}

fn parts() -> Vec<Part> {
    let id = Mat3::IDENTITY;
    let mut parts = Vec::new();
    // Base plate: 1.6 x 1.0, 30 mm thick, top at y = 0.35.
    let mut base = Part::new("base-plate");
    base.cuboid(
        Vec3::new(0.0, 0.335, 0.0),
        Vec3::new(1.6, 0.03, 1.0),
        id,
        0.1,
    );
    parts.push(base);
    // Four legs under it.
    let mut legs = Part::new("legs");
    for (x, z) in [(-0.7, -0.4), (0.7, -0.4), (-0.7, 0.4), (0.7, 0.4)] {
        legs.cylinder(Vec3::new(x, 0.0, z), Vec3::new(x, 0.32, z), 0.03, 24);
    }
    parts.push(legs);
    // Eight ribs, 12 mm thick and 200 mm tall, standing on the left half of the plate.
    let mut ribs = Part::new("ribs");
    for k in 0..8 {
        let x = -0.72 + k as f32 * 0.09;
        ribs.cuboid(
            Vec3::new(x, 0.45, 0.0),
            Vec3::new(0.012, 0.2, 0.9),
            id,
            0.05,
        );
    }
    parts.push(ribs);
    // A cover plate resting on the ribs with a 2 mm gap, 15 mm thick.
    let mut cover = Part::new("cover");
    cover.cuboid(
        Vec3::new(-0.42, 0.5595, 0.1),
        Vec3::new(0.5, 0.015, 0.6),
        id,
        0.05,
    );
    parts.push(cover);
    // Two shims, 5 mm thick, stacked with a 4 mm gap, on the right half of the plate.
    let mut shims = Part::new("shims");
    shims.cuboid(
        Vec3::new(0.35, 0.3625, -0.2),
        Vec3::new(0.4, 0.005, 0.3),
        id,
        0.05,
    );
    shims.cuboid(
        Vec3::new(0.4, 0.3715, -0.15),
        Vec3::new(0.4, 0.005, 0.3),
        id,
        0.05,
    );
    parts.push(shims);
    // A louvre of 14 slats, 6 mm thick, tilted 35 degrees, above the right half.
    let mut louvre = Part::new("louvre");
    let tilt = Mat3::from_rotation_x(35f32.to_radians());
    for k in 0..14 {
        let z = -0.45 + k as f32 * 0.065;
        louvre.cuboid(
            Vec3::new(0.4, 0.8, z),
            Vec3::new(0.6, 0.006, 0.06),
            tilt,
            0.1,
        );
    }
    parts.push(louvre);
    // Six thin rods across the whole assembly.
    let mut rods = Part::new("rods");
    for k in 0..6 {
        let z = -0.375 + k as f32 * 0.15;
        let y = 0.66 + 0.02 * k as f32;
        rods.cylinder(Vec3::new(-0.8, y, z), Vec3::new(0.8, y, z), 0.008, 16);
    }
    parts.push(rods);
    parts
}

fn base64(bytes: &[u8]) -> String {
    const TABLE: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(TABLE[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "assets/models/cad-bracket.gltf".into());
    let parts = parts();
    let mut buffer = Vec::new();
    let (mut views, mut accessors, mut meshes, mut nodes) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut triangles = 0;
    for part in &parts {
        let (min, max) = part.positions.iter().fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let offset = buffer.len();
        for p in &part.positions {
            for c in p.to_array() {
                buffer.extend_from_slice(&c.to_le_bytes());
            }
        }
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": buffer.len() - offset, "target": 34962}));
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5126, "count": part.positions.len(), "type": "VEC3", "min": min.to_array(), "max": max.to_array()}));
        let offset = buffer.len();
        for i in &part.indices {
            buffer.extend_from_slice(&i.to_le_bytes());
        }
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": buffer.len() - offset, "target": 34963}));
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5125, "count": part.indices.len(), "type": "SCALAR"}));
        meshes.push(json!({"name": part.name, "primitives": [{"attributes": {"POSITION": accessors.len() - 2}, "indices": accessors.len() - 1, "mode": 4}]}));
        nodes.push(json!({"name": part.name, "mesh": meshes.len() - 1}));
        triangles += part.indices.len() / 3;
    }
    let gltf = json!({
        "asset": {"version": "2.0", "generator": "softshadow-scenes example cad_model"},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "buffers": [{"byteLength": buffer.len(), "uri": format!("data:application/octet-stream;base64,{}", base64(&buffer))}],
        "bufferViews": views,
        "accessors": accessors,
    });
    std::fs::write(&out, serde_json::to_string_pretty(&gltf)? + "\n")?;
    println!("{out}: {} parts, {triangles} triangles", parts.len());
    Ok(())
}
