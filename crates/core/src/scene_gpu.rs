//! The uploaded scene: one vertex buffer in world space and three index lists (all geometry,
//! shadow casters, shadow receivers), plus bounds the light-view fitting needs.

use std::sync::Mutex;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::{
    light::AreaLight,
    material_gpu::{MaterialGpu, MaterialVertex},
    scene::{Aabb, Instance, Mesh},
    Gpu, Scene,
};

/// Vertex as the G-buffer and depth passes read it (`shaders/core/gbuffer.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Vertex {
    /// World position.
    pub position: [f32; 3],
    /// World normal.
    pub normal: [f32; 3],
    /// RGB8 albedo in the low 24 bits; bit 24 = casts shadow, bit 25 = receives shadow.
    pub color_flags: u32,
}

/// [`Vertex::color_flags`] bit of instances that cast shadows.
pub const FLAG_CASTS: u32 = 1 << 24;
/// [`Vertex::color_flags`] bit of instances that receive shadows.
pub const FLAG_RECEIVES: u32 = 1 << 25;

impl Vertex {
    /// The three attributes at locations 0, 1, 2.
    pub const ATTRIBUTES: [wgpu::VertexAttribute; 3] =
        wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Uint32];

    /// All attributes (the G-buffer pass).
    pub fn layout() -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &Self::ATTRIBUTES,
        }
    }

    /// Position only (depth passes).
    pub fn position_layout() -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &Self::ATTRIBUTES[..1],
        }
    }

    /// Position and flags (locations 0 and 2): the receiver-only depth pass drops casters.
    pub fn position_and_flags_layout() -> wgpu::VertexBufferLayout<'static> {
        const POSITION_AND_FLAGS: [wgpu::VertexAttribute; 2] =
            [Vertex::ATTRIBUTES[0], Vertex::ATTRIBUTES[2]];
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &POSITION_AND_FLAGS,
        }
    }
}

/// An index list in [`SceneGpu`]; `None` when empty.
pub struct IndexList {
    /// The `u32` index buffer.
    pub buffer: wgpu::Buffer,
    /// Indices in it.
    pub count: u32,
    /// The same triangles split by whether their material is alpha-tested, so the light-space
    /// depth pass sends only the masked ones through the alpha test; `None` in a scene without
    /// a masked material (and in the lists no depth pass draws).
    pub alpha_split: Option<Box<AlphaSplit>>,
}

impl IndexList {
    /// Uploads `indices` as an index list, `None` when empty.
    fn upload(gpu: &Gpu, label: &str, indices: &[u32], usage: wgpu::BufferUsages) -> Option<Self> {
        (!indices.is_empty()).then(|| IndexList {
            buffer: gpu
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: bytemuck::cast_slice(indices),
                    usage,
                }),
            count: indices.len() as u32,
            alpha_split: None,
        })
    }

    /// Like [`Self::upload`], with the alpha split of `part` when the scene has one.
    fn upload_with_split(
        gpu: &Gpu,
        label: &str,
        indices: &[u32],
        part: Option<&SplitIndices>,
        usage: wgpu::BufferUsages,
    ) -> Option<Self> {
        let list = Self::upload(gpu, label, indices, usage)?;
        let alpha_split = part.map(|p| {
            Box::new(AlphaSplit {
                opaque: Self::upload(gpu, &format!("{label} (opaque)"), &p.opaque, usage),
                masked: Self::upload(gpu, &format!("{label} (masked)"), &p.masked, usage),
            })
        });
        Some(Self {
            alpha_split,
            ..list
        })
    }
}

/// [`SceneGpu::all`] split by material, each part `None` when empty.
pub struct MaterialSplit {
    /// Triangles of instances without a material (drawn with the plain G-buffer pipeline,
    /// which writes what the material pipeline writes for them).
    pub plain: Option<IndexList>,
    /// Triangles of instances with a material.
    pub with_material: Option<IndexList>,
}

/// An [`IndexList`]'s triangles split by alpha test, each part `None` when empty.
pub struct AlphaSplit {
    /// Triangles of opaque materials (drawn with the plain depth pipeline).
    pub opaque: Option<IndexList>,
    /// Triangles of masked materials (drawn with the alpha-tested one).
    pub masked: Option<IndexList>,
}

/// The triangles of one index list split by alpha test, while baking.
#[derive(Default)]
struct SplitIndices {
    opaque: Vec<u32>,
    masked: Vec<u32>,
}

impl SplitIndices {
    fn part(&mut self, masked: bool) -> &mut Vec<u32> {
        if masked {
            &mut self.masked
        } else {
            &mut self.opaque
        }
    }
}

/// The alpha splits of the index lists the depth pass draws, built for a scene with a masked
/// material.
#[derive(Default)]
struct AlphaSplits {
    casters: SplitIndices,
    static_casters: SplitIndices,
    dynamic_casters: SplitIndices,
    receivers: SplitIndices,
}

/// An uploaded scene: what techniques draw into shadow maps and fit their windows to.
pub struct SceneGpu {
    /// Scene name (for messages).
    pub name: String,
    /// [`Scene::content_hash`] of the uploaded scene.
    pub content_hash: u64,
    /// [`Scene::instances_hash`] of the static instances.
    pub static_hash: u64,
    /// [`Scene::instances_hash`] of the dynamic instances.
    pub dynamic_hash: u64,
    /// Every vertex, world space.
    pub vertices: wgpu::Buffer,
    /// Every triangle.
    pub all: Option<IndexList>,
    /// Every triangle split by whether its instance has a material, in a scene with
    /// [`SceneGpu::materials`]: the G-buffer draws only the second part through its material
    /// pipeline.
    pub all_by_material: Option<MaterialSplit>,
    /// Triangles of instances that cast shadows.
    pub casters: Option<IndexList>,
    /// Casters of static instances only (precomputes such as the PDSM).
    pub static_casters: Option<IndexList>,
    /// Casters of dynamic instances only (drawn per frame beside a static precompute).
    pub dynamic_casters: Option<IndexList>,
    /// Triangles of instances that receive shadows.
    pub receivers: Option<IndexList>,
    /// World bounds of everything.
    pub bounds: Aabb,
    /// World bounds of the casters.
    pub caster_bounds: Aabb,
    /// World bounds of the static instances, and of their casters (precomputes over the static
    /// scene fit their views to these, so a moved dynamic instance does not change them).
    pub static_bounds: Aabb,
    /// World bounds of the static casters.
    pub static_caster_bounds: Aabb,
    /// World bounds of the receivers.
    pub receiver_bounds: Aabb,
    /// Triangles in [`SceneGpu::all`].
    pub triangle_count: usize,
    /// Triangles in [`SceneGpu::casters`].
    pub caster_triangle_count: usize,
    /// Texcoords, material rows, the material table and texels: only for a scene with a masked
    /// or textured material ([`crate::material_gpu::needed`]); `None` keeps every pass as it was.
    pub materials: Option<MaterialGpu>,
    /// World positions of every vertex and the caster and receiver triangles over them (for
    /// tight light-space bounds, [`LightBounds::of_triangles`]).
    positions: Vec<Vec3>,
    caster_indices: Vec<u32>,
    receiver_indices: Vec<u32>,
    light_bounds_cache: Mutex<Option<(u64, LightBounds)>>,
}

/// Light-space bounds of the scene's casters and receivers for one light: of the part of their
/// triangles in front of the light plane (each triangle clipped to z >= 0, so a triangle that
/// crosses the plane counts with the points where its edges cross it, not only with its vertices
/// in front), with what fitting a shadow-map window needs to know about the rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    /// Casters in front of the light plane; `None` when nothing can cast a shadow.
    pub casters: Option<Aabb>,
    /// The casters' part in front reaches the light plane (a caster crosses or touches it): their
    /// slopes from any point of the light are unbounded (the `stiff-partly-outside` case).
    pub casters_cross_light_plane: bool,
    /// Receivers in front of the light plane; `None` when no receiver can be lit.
    pub receivers: Option<Aabb>,
    /// The receivers' part in front reaches the light plane (a large ground under an oblique
    /// light, `stiff-receiver-behind-light`): their slopes are unbounded too, and windows clip
    /// them to the depths where a caster can shadow them ([`crate::SlopeFrustum::fit_clipped`]).
    pub receivers_cross_light_plane: bool,
}

impl LightBounds {
    /// The bounds of `caster_indices` and `receiver_indices` (triangle lists over the world-space
    /// `positions`) in the light space of `light`.
    pub fn of_triangles(
        light: &AreaLight,
        positions: &[Vec3],
        caster_indices: &[u32],
        receiver_indices: &[u32],
    ) -> Self {
        let view = light.view();
        let light_space: Vec<Vec3> = positions
            .iter()
            .map(|p| view.transform_point3(*p))
            .collect();
        let casters = clipped_bounds(&light_space, caster_indices);
        let receivers = clipped_bounds(&light_space, receiver_indices);
        let reaches_plane = |b: &Option<Aabb>| b.is_some_and(|b| b.min.z <= LIGHT_PLANE_REACH);
        Self {
            casters_cross_light_plane: reaches_plane(&casters),
            receivers_cross_light_plane: reaches_plane(&receivers),
            casters,
            receivers,
        }
    }
}

/// A box whose nearest point is this close to the light plane reaches it (the depth below which
/// [`crate::SlopeFrustum`] treats points as on the plane).
const LIGHT_PLANE_REACH: f32 = 1e-4;

/// Light-space bounds of the part of the triangles in front of the light plane (z > 0): the
/// vertices in front and, for every edge that crosses the plane, the point where it does.
/// `None` when no triangle has a part in front. Indices past the positions are skipped.
fn clipped_bounds(light_space: &[Vec3], indices: &[u32]) -> Option<Aabb> {
    let mut b = Aabb::EMPTY;
    for triangle in indices.chunks_exact(3) {
        let corner = |k: usize| light_space.get(triangle[k] as usize).copied();
        let (Some(p0), Some(p1), Some(p2)) = (corner(0), corner(1), corner(2)) else {
            continue;
        };
        for (a, c) in [(p0, p1), (p1, p2), (p2, p0)] {
            if a.z > 0.0 {
                b.extend(a);
            }
            if (a.z > 0.0) != (c.z > 0.0) {
                let t = a.z / (a.z - c.z);
                b.extend((a + (c - a) * t).with_z(0.0));
            }
        }
    }
    (!b.is_empty() && b.max.z > 0.0).then_some(b)
}

/// A scene baked into world space on the CPU: what [`SceneGpu::upload`] puts on the device, and
/// the bounds and positions it keeps.
struct Baked {
    vertices: Vec<Vertex>,
    /// Per vertex texcoord and material row, filled only when the scene needs them.
    material_vertices: Option<Vec<MaterialVertex>>,
    /// Index lists into `vertices`.
    all: Vec<u32>,
    /// `all` split by material (plain, with a material), for a scene with materials.
    all_by_material: Option<(Vec<u32>, Vec<u32>)>,
    casters: Vec<u32>,
    static_casters: Vec<u32>,
    dynamic_casters: Vec<u32>,
    receivers: Vec<u32>,
    /// Those lists split by alpha test, for a scene with a masked material.
    alpha_splits: Option<AlphaSplits>,
    bounds: Aabb,
    caster_bounds: Aabb,
    receiver_bounds: Aabb,
    static_bounds: Aabb,
    static_caster_bounds: Aabb,
    /// The world position of every vertex.
    positions: Vec<Vec3>,
}

impl Baked {
    fn new(with_materials: bool, with_alpha_splits: bool) -> Self {
        Self {
            vertices: Vec::new(),
            material_vertices: with_materials.then(Vec::new),
            alpha_splits: with_alpha_splits.then(AlphaSplits::default),
            all: Vec::new(),
            all_by_material: with_materials.then(Default::default),
            casters: Vec::new(),
            static_casters: Vec::new(),
            dynamic_casters: Vec::new(),
            receivers: Vec::new(),
            bounds: Aabb::EMPTY,
            caster_bounds: Aabb::EMPTY,
            receiver_bounds: Aabb::EMPTY,
            static_bounds: Aabb::EMPTY,
            static_caster_bounds: Aabb::EMPTY,
            positions: Vec::new(),
        }
    }

    /// Every instance of `scene` baked.
    fn of(scene: &Scene) -> Self {
        let mut baked = Self::new(
            crate::material_gpu::needed(scene),
            scene.has_masked_instances(),
        );
        for instance in &scene.instances {
            if let Some(mesh) = scene.meshes.get(instance.mesh) {
                let albedo = scene
                    .material_of(instance)
                    .map_or(instance.albedo, |m| m.base_color.truncate());
                let masked = scene.alpha_cutoff_of(instance).is_some();
                baked.add(instance, mesh, albedo, masked);
            }
        }
        baked
    }

    /// Adds `mesh` placed by `instance`: its vertices in world space with the instance's albedo
    /// and flags, its triangles in the index lists it belongs to (and their alpha split's
    /// `masked` part when the instance's material is alpha-tested), its points in the bounds.
    fn add(&mut self, instance: &Instance, mesh: &Mesh, albedo: Vec3, masked: bool) {
        let base = self.vertices.len() as u32;
        let normal_matrix = instance.transform.inverse().transpose();
        let color_flags = color_flags(instance, albedo);
        if let Some(material_vertices) = &mut self.material_vertices {
            let material = instance.material.map_or(0, |m| m as u32 + 1);
            material_vertices.extend((0..mesh.positions.len()).map(|k| MaterialVertex {
                uv: mesh.texcoords.get(k).map_or([0.0; 2], |t| t.to_array()),
                material,
            }));
        }
        for (k, p) in mesh.positions.iter().enumerate() {
            let world = instance.transform.transform_point3(*p);
            let n = mesh.normals.get(k).copied().unwrap_or(Vec3::Y);
            let world_n = normal_matrix.transform_vector3(n).normalize_or(Vec3::Y);
            self.vertices.push(Vertex {
                position: world.to_array(),
                normal: world_n.to_array(),
                color_flags,
            });
            self.bounds.extend(world);
            if !instance.dynamic {
                self.static_bounds.extend(world);
                if instance.casts_shadow {
                    self.static_caster_bounds.extend(world);
                }
            }
            self.positions.push(world);
            if instance.casts_shadow {
                self.caster_bounds.extend(world);
            }
            if instance.receives_shadow {
                self.receiver_bounds.extend(world);
            }
        }
        let indices = mesh.indices.iter().map(|i| base + i);
        if let Some(splits) = &mut self.alpha_splits {
            splits.add(instance, indices.clone(), masked);
        }
        self.all.extend(indices.clone());
        if let Some((plain, with_material)) = &mut self.all_by_material {
            let part = if instance.material.is_some() {
                with_material
            } else {
                plain
            };
            part.extend(indices.clone());
        }
        if instance.casts_shadow {
            self.casters.extend(indices.clone());
            if instance.dynamic {
                self.dynamic_casters.extend(indices.clone());
            } else {
                self.static_casters.extend(indices.clone());
            }
        }
        if instance.receives_shadow {
            self.receivers.extend(indices);
        }
    }
}

impl AlphaSplits {
    /// Adds `instance`'s triangles to the part (`masked` or opaque) of each list it belongs to.
    fn add(
        &mut self,
        instance: &Instance,
        indices: impl Iterator<Item = u32> + Clone,
        masked: bool,
    ) {
        if instance.casts_shadow {
            self.casters.part(masked).extend(indices.clone());
            let own = if instance.dynamic {
                &mut self.dynamic_casters
            } else {
                &mut self.static_casters
            };
            own.part(masked).extend(indices.clone());
        }
        if instance.receives_shadow {
            self.receivers.part(masked).extend(indices);
        }
    }
}

/// A vertex's `color_flags` for `instance`: `albedo` (its own, or its material's base colour)
/// as RGB8, and whether it casts and receives shadows.
fn color_flags(instance: &Instance, albedo: Vec3) -> u32 {
    let albedo = albedo.clamp(Vec3::ZERO, Vec3::ONE);
    let mut color_flags = (albedo.x * 255.0).round() as u32
        | ((albedo.y * 255.0).round() as u32) << 8
        | ((albedo.z * 255.0).round() as u32) << 16;
    if instance.casts_shadow {
        color_flags |= FLAG_CASTS;
    }
    if instance.receives_shadow {
        color_flags |= FLAG_RECEIVES;
    }
    color_flags
}

impl SceneGpu {
    /// Uploads a scene. Instances are baked into world space (one vertex buffer, no per-draw state).
    pub fn upload(gpu: &Gpu, scene: &Scene) -> Self {
        puffin::profile_function!();
        let mut baked = Baked::of(scene);
        let materials = baked
            .material_vertices
            .take()
            .map(|v| MaterialGpu::upload(gpu, scene, &v));
        let Baked {
            vertices,
            material_vertices: _,
            all,
            all_by_material,
            casters,
            static_casters,
            dynamic_casters,
            receivers,
            alpha_splits,
            bounds,
            caster_bounds,
            receiver_bounds,
            static_bounds,
            static_caster_bounds,
            positions,
        } = baked;
        let device = &gpu.device;
        // Ray-query techniques build acceleration structures from these buffers (crate::accel).
        let blas_input = if gpu.has_ray_query() {
            wgpu::BufferUsages::BLAS_INPUT
        } else {
            wgpu::BufferUsages::empty()
        };
        let vertex_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("scene vertices"),
            contents: if vertices.is_empty() {
                &[0u8; 28]
            } else {
                bytemuck::cast_slice(&vertices)
            },
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE | blas_input,
        });
        let usage = wgpu::BufferUsages::INDEX | wgpu::BufferUsages::STORAGE | blas_input;
        let list = |label: &str, indices: &[u32]| IndexList::upload(gpu, label, indices, usage);
        let splits = alpha_splits.as_ref();
        let make = |label: &str, indices: &[u32], part: Option<&SplitIndices>| {
            IndexList::upload_with_split(gpu, label, indices, part, usage)
        };
        Self {
            name: scene.name.clone(),
            content_hash: scene.content_hash(),
            static_hash: scene.instances_hash(false),
            dynamic_hash: scene.instances_hash(true),
            vertices: vertex_buffer,
            triangle_count: all.len() / 3,
            caster_triangle_count: casters.len() / 3,
            materials,
            all: list("scene indices (all)", &all),
            all_by_material: all_by_material.map(|(plain, with_material)| MaterialSplit {
                plain: list("scene indices (all, plain)", &plain),
                with_material: list("scene indices (all, with a material)", &with_material),
            }),
            casters: make(
                "scene indices (casters)",
                &casters,
                splits.map(|s| &s.casters),
            ),
            static_casters: make(
                "scene indices (static casters)",
                &static_casters,
                splits.map(|s| &s.static_casters),
            ),
            dynamic_casters: make(
                "scene indices (dynamic casters)",
                &dynamic_casters,
                splits.map(|s| &s.dynamic_casters),
            ),
            receivers: make(
                "scene indices (receivers)",
                &receivers,
                splits.map(|s| &s.receivers),
            ),
            bounds,
            caster_bounds,
            static_bounds,
            static_caster_bounds,
            receiver_bounds,
            positions,
            caster_indices: casters,
            receiver_indices: receivers,
            light_bounds_cache: Mutex::new(None),
        }
    }

    /// Whether any instance casts shadows.
    pub fn has_casters(&self) -> bool {
        self.casters.is_some()
    }

    /// Light-space bounds of the part of the casters in front of the light plane, or `None` when
    /// no caster is in front of the light (nothing can cast a shadow). Cached per light.
    pub fn caster_bounds_in_light(&self, light: &AreaLight) -> Option<Aabb> {
        self.light_bounds(light).casters
    }

    /// Light-space bounds of casters and receivers for `light`. Cached per light.
    pub fn light_bounds(&self, light: &AreaLight) -> LightBounds {
        let key = light.content_hash();
        if let Ok(cache) = self.light_bounds_cache.lock() {
            if let Some((k, b)) = *cache {
                if k == key {
                    return b;
                }
            }
        }
        let result = LightBounds::of_triangles(
            light,
            &self.positions,
            &self.caster_indices,
            &self.receiver_indices,
        );
        if let Ok(mut cache) = self.light_bounds_cache.lock() {
            *cache = Some((key, result));
        }
        result
    }

    /// Draws the casters (position-only pipelines).
    pub fn draw_casters(&self, pass: &mut wgpu::RenderPass<'_>) {
        if let Some(list) = &self.casters {
            pass.set_vertex_buffer(0, self.vertices.slice(..));
            pass.set_index_buffer(list.buffer.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..list.count, 0, 0..1);
        }
    }

    /// Draws the receivers.
    pub fn draw_receivers(&self, pass: &mut wgpu::RenderPass<'_>) {
        if let Some(list) = &self.receivers {
            pass.set_vertex_buffer(0, self.vertices.slice(..));
            pass.set_index_buffer(list.buffer.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..list.count, 0, 0..1);
        }
    }

    /// Draws everything (the G-buffer pass).
    pub fn draw_all(&self, pass: &mut wgpu::RenderPass<'_>) {
        self.draw_list(pass, self.all.as_ref());
    }

    /// Draws the triangles of `list` (one of this scene's), if any.
    pub fn draw_list(&self, pass: &mut wgpu::RenderPass<'_>, list: Option<&IndexList>) {
        if let Some(list) = list {
            pass.set_vertex_buffer(0, self.vertices.slice(..));
            pass.set_index_buffer(list.buffer.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..list.count, 0, 0..1);
        }
    }
}
