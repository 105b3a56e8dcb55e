//! CPU scene model: meshes, instances with shadow flags, the rectangular area light and the camera.
//!
//! Everything is in world space with +y up. Techniques never read this directly; they read
//! [`crate::SceneGpu`] (the uploaded form) and the light-space helpers in [`crate::light`].

use glam::{Mat4, Vec2, Vec3};

use crate::{
    camera::Camera,
    light::AreaLight,
    material::{Material, Texture},
};

/// A triangle mesh in object space.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Mesh {
    /// Human-readable name (procedural primitive or glTF mesh name), used in error messages.
    pub name: String,
    /// Vertex positions in object space.
    pub positions: Vec<Vec3>,
    /// One normal per position. May be empty: [`Mesh::ensure_normals`] computes flat-ish vertex normals.
    pub normals: Vec<Vec3>,
    /// Triangle list, three indices per triangle.
    pub indices: Vec<u32>,
    /// Texcoord set 0, one per position, or empty (a mesh whose material has no texture).
    #[serde(default)]
    pub texcoords: Vec<Vec2>,
}

/// What [`Mesh::repair`] removed, so callers can warn with counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MeshRepair {
    /// Triangles dropped because a vertex was NaN or infinite.
    pub non_finite_triangles: usize,
    /// Triangles dropped because they had zero area (repeated or collinear vertices).
    pub degenerate_triangles: usize,
    /// Triangles dropped because an index pointed past the vertex array.
    pub out_of_range_triangles: usize,
}

impl MeshRepair {
    /// Triangles dropped, of every kind.
    pub fn total(&self) -> usize {
        self.non_finite_triangles + self.degenerate_triangles + self.out_of_range_triangles
    }
}

impl Mesh {
    /// Triangles (indices / 3).
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Drops triangles with non-finite vertices, zero area or out-of-range indices, and replaces
    /// non-finite normals. Returns what was dropped so the loader can say which and how many.
    pub fn repair(&mut self) -> MeshRepair {
        let mut report = MeshRepair::default();
        let vertex_count = self.positions.len();
        let mut kept = Vec::with_capacity(self.indices.len());
        for tri in self.indices.chunks_exact(3) {
            if tri.iter().any(|&i| i as usize >= vertex_count) {
                report.out_of_range_triangles += 1;
                continue;
            }
            let [a, b, c] = [0, 1, 2].map(|k| self.positions[tri[k] as usize]);
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                report.non_finite_triangles += 1;
                continue;
            }
            let double_area = (b - a).cross(c - a).length();
            let scale = (b - a)
                .length()
                .max((c - a).length())
                .max(f32::MIN_POSITIVE);
            // Relative test: a sliver whose area is at the level of f32 rounding is degenerate.
            #[allow(clippy::neg_cmp_op_on_partial_ord)] // also true for NaN areas
            if !(double_area > scale * scale * 1e-7) {
                report.degenerate_triangles += 1;
                continue;
            }
            kept.extend_from_slice(tri);
        }
        self.indices = kept;
        // Non-finite positions that no kept triangle references are harmless but would poison
        // bounds computations: pin them to the origin.
        for p in &mut self.positions {
            if !p.is_finite() {
                *p = Vec3::ZERO;
            }
        }
        for t in &mut self.texcoords {
            if !t.is_finite() {
                *t = Vec2::ZERO;
            }
        }
        if self.normals.len() == self.positions.len()
            && self
                .normals
                .iter()
                .any(|n| !n.is_finite() || n.length_squared() < 1e-12)
        {
            self.normals.clear();
        }
        self.ensure_normals();
        report
    }

    /// Computes area-weighted vertex normals when the mesh has none (or the wrong count).
    pub fn ensure_normals(&mut self) {
        if self.normals.len() == self.positions.len() {
            return;
        }
        let mut normals = vec![Vec3::ZERO; self.positions.len()];
        for tri in self.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| self.positions[tri[k] as usize]);
            let n = (b - a).cross(c - a);
            for &i in tri {
                normals[i as usize] += n;
            }
        }
        self.normals = normals
            .into_iter()
            .map(|n| n.try_normalize().unwrap_or(Vec3::Y))
            .collect();
    }
}

/// One placed copy of a mesh.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Instance {
    /// Index into [`Scene::meshes`].
    pub mesh: usize,
    /// Object-to-world transform.
    pub transform: Mat4,
    /// Linear RGB albedo in [0, 1].
    pub albedo: Vec3,
    /// Rendered into shadow maps / occluder maps (an "occluder" in Atty et al.'s split).
    pub casts_shadow: bool,
    /// Its pixels get a visibility value and count in the error metrics (a "receiver").
    pub receives_shadow: bool,
    /// Moves between frames. Static instances let techniques cache scene-only work (PDSM).
    pub dynamic: bool,
    /// Index into [`Scene::materials`]; `None` draws the flat `albedo`, opaque, as before
    /// materials existed. With a material its base colour replaces `albedo`.
    #[serde(default)]
    pub material: Option<usize>,
}

impl Instance {
    /// An instance of mesh `mesh` placed by `transform`, white, casting and receiving shadows, static.
    pub fn new(mesh: usize, transform: Mat4) -> Self {
        Self {
            mesh,
            transform,
            albedo: Vec3::splat(0.8),
            casts_shadow: true,
            receives_shadow: true,
            dynamic: false,
            material: None,
        }
    }
}

/// A complete scene: geometry, one rectangular area light and a camera.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Scene {
    /// Scene id (procedural) or file stem.
    pub name: String,
    /// The meshes instances refer to by index.
    pub meshes: Vec<Mesh>,
    /// Placed meshes.
    pub instances: Vec<Instance>,
    /// The area light.
    pub light: AreaLight,
    /// The camera the scene was set up with.
    pub camera: Camera,
    /// Materials instances refer to by index ([`Instance::material`]).
    #[serde(default)]
    pub materials: Vec<Material>,
    /// Textures materials refer to by index ([`Material::base_color_texture`]).
    #[serde(default)]
    pub textures: Vec<Texture>,
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (`extend` of any point makes it that point).
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// No point was added.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// Grows the box to contain `p`.
    pub fn extend(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box containing both.
    pub fn union(self, other: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// The eight corners.
    pub fn corners(&self) -> [Vec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            Vec3::new(a.x, a.y, a.z),
            Vec3::new(b.x, a.y, a.z),
            Vec3::new(a.x, b.y, a.z),
            Vec3::new(b.x, b.y, a.z),
            Vec3::new(a.x, a.y, b.z),
            Vec3::new(b.x, a.y, b.z),
            Vec3::new(a.x, b.y, b.z),
            Vec3::new(b.x, b.y, b.z),
        ]
    }
}

impl Scene {
    /// Triangles over every instance.
    pub fn triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes.get(i.mesh).map_or(0, Mesh::triangle_count))
            .sum()
    }

    /// World-space bounds of the instances selected by `filter`.
    pub fn bounds(&self, filter: impl Fn(&Instance) -> bool) -> Aabb {
        let mut bounds = Aabb::EMPTY;
        for instance in self.instances.iter().filter(|i| filter(i)) {
            let Some(mesh) = self.meshes.get(instance.mesh) else {
                continue;
            };
            for &p in &mesh.positions {
                let w = instance.transform.transform_point3(p);
                if w.is_finite() {
                    bounds.extend(w);
                }
            }
        }
        bounds
    }

    /// Checks what the renderer relies on. Returns a message that names the problem and the fix.
    pub fn validate(&self) -> Result<(), String> {
        if self.instances.is_empty() {
            return Err(format!(
                "scene `{}` has no instances: add at least one receiver (e.g. a ground plane)",
                self.name
            ));
        }
        for (k, instance) in self.instances.iter().enumerate() {
            if instance.mesh >= self.meshes.len() {
                return Err(format!(
                    "scene `{}`: instance {k} refers to mesh {} but there are only {} meshes",
                    self.name,
                    instance.mesh,
                    self.meshes.len()
                ));
            }
            if !instance.transform.is_finite() {
                return Err(format!(
                    "scene `{}`: instance {k} has a non-finite transform: fix its translation/rotation/scale",
                    self.name
                ));
            }
        }
        self.validate_materials()?;
        if !self.instances.iter().any(|i| i.receives_shadow) {
            return Err(format!(
                "scene `{}` has no shadow receiver: mark at least one instance `receives_shadow = true`",
                self.name
            ));
        }
        self.light.validate()?;
        self.camera.validate()?;
        Ok(())
    }

    /// The material of `instance`, if it has one in range.
    pub fn material_of(&self, instance: &Instance) -> Option<&Material> {
        instance.material.and_then(|m| self.materials.get(m))
    }

    /// The alpha cut-off `instance` is drawn with, or `None` when it is opaque (no material, or
    /// an opaque one). A mask without texture still cuts where its factor's alpha is below it.
    pub fn alpha_cutoff_of(&self, instance: &Instance) -> Option<f32> {
        self.material_of(instance)
            .and_then(|m| m.alpha_mode.effective_cutoff())
    }

    /// Some shadow caster has a masked (or blended, cast as masked) material: the light-space
    /// passes must test alpha ([`crate::material`]). Without one every pass runs as it did
    /// before materials existed.
    pub fn has_masked_casters(&self) -> bool {
        self.instances
            .iter()
            .any(|i| i.casts_shadow && self.alpha_cutoff_of(i).is_some())
    }

    /// Some instance has a masked material (caster or not): the G-buffer must test alpha.
    pub fn has_masked_instances(&self) -> bool {
        self.instances
            .iter()
            .any(|i| self.alpha_cutoff_of(i).is_some())
    }

    /// Some instance's material has a base colour texture: the G-buffer samples it.
    pub fn has_textured_instances(&self) -> bool {
        self.instances.iter().any(|i| {
            self.material_of(i)
                .is_some_and(|m| m.base_color_texture.is_some())
        })
    }

    /// Checks materials, textures and texcoords: indices in range, cut-offs in [0, 1], colours
    /// finite, texel bytes matching the size, one texcoord per position on textured meshes.
    fn validate_materials(&self) -> Result<(), String> {
        let name = &self.name;
        for (k, t) in self.textures.iter().enumerate() {
            if t.width == 0 || t.height == 0 || t.rgba8.len() != t.byte_len() {
                return Err(format!(
                    "scene `{name}`: texture {k} (`{}`) is {}x{} but holds {} bytes, not width*height*4: re-export the image as RGBA8",
                    t.name, t.width, t.height, t.rgba8.len()
                ));
            }
        }
        for (k, m) in self.materials.iter().enumerate() {
            if !m.base_color.is_finite() {
                return Err(format!(
                    "scene `{name}`: material {k} (`{}`) has a non-finite base_color: give four numbers in [0, 1]",
                    m.name
                ));
            }
            if let Some(cutoff) = m.alpha_mode.effective_cutoff() {
                if !(0.0..=1.0).contains(&cutoff) {
                    return Err(format!(
                        "scene `{name}`: material {k} (`{}`) has alpha_cutoff {cutoff}: give a value in [0, 1] (0.5 is usual)",
                        m.name
                    ));
                }
            }
            if let Some(t) = m.base_color_texture {
                if t >= self.textures.len() {
                    return Err(format!(
                        "scene `{name}`: material {k} (`{}`) refers to texture {t} but there are only {} textures",
                        m.name,
                        self.textures.len()
                    ));
                }
            }
        }
        for (k, instance) in self.instances.iter().enumerate() {
            let Some(m) = instance.material else { continue };
            let Some(material) = self.materials.get(m) else {
                return Err(format!(
                    "scene `{name}`: instance {k} refers to material {m} but there are only {} materials",
                    self.materials.len()
                ));
            };
            let mesh = &self.meshes[instance.mesh];
            if material.base_color_texture.is_some() && mesh.texcoords.len() != mesh.positions.len()
            {
                return Err(format!(
                    "scene `{name}`: mesh `{}` has {} texcoords for {} positions but its material `{}` has a texture: give one texcoord per vertex (glTF TEXCOORD_0)",
                    mesh.name,
                    mesh.texcoords.len(),
                    mesh.positions.len(),
                    material.name
                ));
            }
        }
        Ok(())
    }

    /// A stable 64-bit content hash (geometry, flags, light, camera) for caches such as the
    /// reference. FNV-1a over the raw bits: cheap and deterministic across runs.
    pub fn content_hash(&self) -> u64 {
        let mut h = Fnv1a::default();
        h.write_str(&self.name);
        for mesh in &self.meshes {
            h.write_mesh(mesh);
        }
        for inst in &self.instances {
            h.write_u64(inst.mesh as u64);
            h.write_f32s(&inst.transform.to_cols_array());
            h.write_f32s(&inst.albedo.to_array());
            h.write_u64(
                inst.casts_shadow as u64
                    | (inst.receives_shadow as u64) << 1
                    | (inst.dynamic as u64) << 2,
            );
            // Hashed only when present, so a scene without materials keeps its old hash (and
            // its cached references).
            if let Some(material) = self.material_of(inst) {
                h.write_material(material, &self.textures);
            }
        }
        h.write_u64(self.light.content_hash());
        h.write_u64(self.camera.content_hash());
        h.finish()
    }

    /// Hash of the geometry of the static (`dynamic == false`) or the dynamic instances only:
    /// meshes, transforms and flags. Light-space caches key on these (a moved dynamic
    /// instance changes only the dynamic hash; PDSM-like precomputes depend on the static one).
    pub fn instances_hash(&self, dynamic: bool) -> u64 {
        let mut h = Fnv1a::default();
        for inst in self.instances.iter().filter(|i| i.dynamic == dynamic) {
            h.write_mesh(&self.meshes[inst.mesh]);
            h.write_f32s(&inst.transform.to_cols_array());
            h.write_u64(inst.casts_shadow as u64 | (inst.receives_shadow as u64) << 1);
            // A masked caster's holes are part of its shadow.
            if let Some(material) = self.material_of(inst) {
                h.write_material(material, &self.textures);
            }
        }
        h.finish()
    }
}

/// FNV-1a hasher used for cache keys (deterministic, unlike `DefaultHasher` across Rust versions).
#[derive(Clone, Copy, Debug)]
pub struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Fnv1a(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a {
    /// Hashes raw bytes.
    pub fn write_bytes(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 ^= *b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    /// Hashes a number.
    pub fn write_u64(&mut self, v: u64) {
        self.write_bytes(&v.to_le_bytes());
    }
    /// Hashes floats by their bits.
    pub fn write_f32s(&mut self, v: &[f32]) {
        for x in v {
            self.write_bytes(&x.to_bits().to_le_bytes());
        }
    }
    /// Vertex count, positions and indices of `mesh` (what its shadow depends on).
    pub fn write_mesh(&mut self, mesh: &Mesh) {
        self.write_u64(mesh.positions.len() as u64);
        for p in &mesh.positions {
            self.write_f32s(&p.to_array());
        }
        for i in &mesh.indices {
            self.write_u64(*i as u64);
        }
        // Only when present, so meshes without texcoords keep their old hashes.
        if !mesh.texcoords.is_empty() {
            self.write_u64(mesh.texcoords.len() as u64);
            for t in &mesh.texcoords {
                self.write_f32s(&t.to_array());
            }
        }
    }
    /// What of `material` a shadow or an image depends on: colour, alpha mode, texture texels,
    /// and the texcoords are hashed with the mesh ([`Fnv1a::write_mesh`]).
    pub fn write_material(&mut self, material: &Material, textures: &[Texture]) {
        self.write_f32s(&material.base_color.to_array());
        let (mode, cutoff) = match material.alpha_mode {
            crate::material::AlphaMode::Opaque => (0, 0.0),
            crate::material::AlphaMode::Mask { cutoff } => (1, cutoff),
            crate::material::AlphaMode::Blend => (2, 0.0),
        };
        self.write_u64(mode | (material.double_sided as u64) << 8);
        self.write_f32s(&[cutoff]);
        if let Some(t) = material.base_color_texture.and_then(|t| textures.get(t)) {
            self.write_u64(t.width as u64 | (t.height as u64) << 32);
            self.write_u64(t.filter as u64 | (t.wrap[0] as u64) << 8 | (t.wrap[1] as u64) << 16);
            self.write_bytes(&t.rgba8);
        }
    }
    /// Hashes a string (with its length, so concatenations differ).
    pub fn write_str(&mut self, s: &str) {
        self.write_u64(s.len() as u64);
        self.write_bytes(s.as_bytes());
    }
    /// The hash so far.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh(positions: Vec<Vec3>, indices: Vec<u32>) -> Mesh {
        Mesh {
            name: "test".into(),
            positions,
            normals: Vec::new(),
            indices,
            texcoords: Vec::new(),
        }
    }

    /// Each triangle is one case of the repair's tests; the counts and the kept list pin every
    /// comparison (written for the mutants `cargo mutants` left alive, docs/STABILITY.md).
    #[test]
    fn repair_drops_exactly_the_bad_triangles_and_counts_each_kind() {
        let v = Vec3::new;
        let nan = f32::NAN;
        let inf = f32::INFINITY;
        let positions = vec![
            // 0..3: an ordinary triangle at the origin (a vertex with zero coordinates).
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(0.0, 1.0, 0.0),
            // 3..6: thin but valid (height 1e-3, length 1) far from the origin.
            v(100.0, 0.0, 0.0),
            v(101.0, 0.0, 0.0),
            v(100.5, 1e-3, 0.0),
            // 6..9: thin but valid with a vertex near the origin (height 1e-3, length 1).
            v(1e-3, 1e-3, 1e-3),
            v(1.0 + 1e-3, 1e-3, 1e-3),
            v(0.5, 2e-3, 1e-3),
            // 9..12: tiny but valid (legs 1e-5).
            v(5.0, 5.0, 5.0),
            v(5.0 + 1e-5, 5.0, 5.0),
            v(5.0, 5.0 + 1e-5, 5.0),
            // 12..15: collinear, off the axes.
            v(1.0, 0.0, 0.0),
            v(1.0, 1.0, 0.0),
            v(1.0, 2.0, 0.0),
            // 15: one point (a triangle of three equal indices).
            v(2.0, 3.0, 4.0),
            // 16, 17: non-finite.
            v(nan, 0.0, 0.0),
            v(0.0, inf, 0.0),
        ];
        let indices = vec![
            0, 1, 2, // kept
            3, 4, 5, // kept
            6, 7, 8, // kept
            9, 10, 11, // kept
            12, 13, 14, // degenerate
            15, 15, 15, // degenerate
            16, 1, 2, // non-finite (first vertex)
            0, 1, 17, // non-finite (last vertex)
            0, 18, 2, // out of range
            99, 1, 2, // out of range
        ];
        let mut m = mesh(positions.clone(), indices);
        let report = m.repair();
        assert_eq!(
            report,
            MeshRepair {
                non_finite_triangles: 2,
                degenerate_triangles: 2,
                out_of_range_triangles: 2,
            }
        );
        assert_eq!(report.total(), 6);
        assert_eq!(m.indices, vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]);
        // Finite positions are untouched; the non-finite ones are pinned to the origin.
        assert_eq!(m.positions[..16], positions[..16]);
        assert_eq!(m.positions[16], Vec3::ZERO);
        assert_eq!(m.positions[17], Vec3::ZERO);
        // Normals were computed (the mesh had none): +z for the kept triangles in the z = 0 plane.
        assert_eq!(m.normals.len(), m.positions.len());
        assert!(
            (m.normals[0] - Vec3::Z).length() < 1e-6,
            "{:?}",
            m.normals[0]
        );
    }

    #[test]
    fn repair_keeps_good_normals_and_recomputes_bad_ones() {
        let triangle = || mesh(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![0, 1, 2]);
        // Good normals (not the geometric ones) are kept as given.
        let given = vec![Vec3::X, Vec3::X, Vec3::new(0.0, 0.6, 0.8)];
        let mut m = triangle();
        m.normals = given.clone();
        assert_eq!(m.repair().total(), 0);
        assert_eq!(m.normals, given);
        // A normal whose squared length is exactly the 1e-12 threshold is still good.
        let at_threshold = (0..4000)
            .map(|k| f32::from_bits(1e-6f32.to_bits() - 2000 + k))
            .find(|x| x * x == 1e-12)
            .expect("an f32 whose square is 1e-12");
        let mut m = triangle();
        m.normals = vec![Vec3::X, Vec3::new(at_threshold, 0.0, 0.0), Vec3::X];
        m.repair();
        assert_eq!(m.normals[1], Vec3::new(at_threshold, 0.0, 0.0));
        // One NaN, one infinite or one zero normal: all are recomputed (+z here).
        for bad in [
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::new(0.0, f32::INFINITY, 0.0),
            Vec3::ZERO,
        ] {
            let mut m = triangle();
            m.normals = vec![Vec3::X, bad, Vec3::X];
            m.repair();
            assert_eq!(m.normals, vec![Vec3::Z; 3], "after {bad:?}");
        }
        // Normals of the wrong count are replaced too.
        let mut m = triangle();
        m.normals = vec![Vec3::X];
        m.repair();
        assert_eq!(m.normals, vec![Vec3::Z; 3]);
    }
}
