//! Acceleration structures of the shadow casters for ray queries (`Features::EXPERIMENTAL_RAY_QUERY`).
//!
//! Built beside a [`SceneGpu`], only by a technique that asks for them ([`SceneAccel::update`]):
//! one bottom-level structure (BLAS) over the static casters and one over the dynamic casters,
//! both in world space (the scene is baked into world space at upload, docs/ARCHITECTURE.md,
//! "Design decisions"), and a top-level structure (TLAS) of the two as instances with the
//! identity transform. The static BLAS is kept while [`SceneGpu::static_hash`] is unchanged; a
//! moved dynamic instance rebuilds only the dynamic BLAS and the TLAS (two instances: a rebuild
//! costs no more than a refit would).
//!
//! wgpu 30 exposes neither the structures' sizes nor a query for them, so
//! [`SceneAccel::bytes_estimate`] is a model (see [`BYTES_PER_TRIANGLE`]), not a measurement.

use thiserror::Error;

use crate::{scene_gpu::IndexList, Frame, Gpu, SceneGpu};

/// The feature ray-query techniques declare in their
/// [`Requirements::features`](crate::Requirements::features).
pub const RAY_QUERY: wgpu::Features = wgpu::Features::EXPERIMENTAL_RAY_QUERY;

/// What to install when an adapter has no ray queries: the one line `workbench list`, the viewer
/// and results.json show beside a technique that needs them.
pub const RAY_QUERY_HINT: &str = "this adapter has no ray queries (EXPERIMENTAL_RAY_QUERY): install Mesa 24.1 or newer (lavapipe, README \"Set-up\") or use a GPU with ray queries";

/// Environment variable that, set to `1`, creates the device without ray queries even where the
/// adapter offers them (tests of the "unavailable" path; a user comparing without them).
pub const NO_RAY_QUERY_ENV: &str = "SOFTSHADOW_NO_RAY_QUERY";

/// Model of a built structure's size per triangle: a BVH node of 32 bytes per primitive plus the
/// primitive's three positions (36 bytes), rounded up. Lavapipe and GPU drivers differ; wgpu
/// does not report the real size.
pub const BYTES_PER_TRIANGLE: u64 = 72;

/// Building the acceleration structures failed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum AccelError {
    /// The device was created without ray queries.
    #[error("{RAY_QUERY_HINT}")]
    NoRayQuery,
    /// A BLAS would exceed the adapter's limit.
    #[error("scene `{scene}` has {count} caster {what}, over the adapter's max_blas_primitive_count of {limit}: split the mesh into instances of at most {limit} {what} each, or use an adapter with a higher limit")]
    TooLarge {
        /// The scene's name.
        scene: String,
        /// Vertices or triangles.
        what: &'static str,
        /// How many there are.
        count: u64,
        /// `max_blas_primitive_count` of the device.
        limit: u32,
    },
    /// The scene's buffers cannot be read by an acceleration-structure build (a host's buffers
    /// made without `BufferUsages::BLAS_INPUT`).
    #[error("scene `{scene}`: its vertex and index buffers lack BufferUsages::BLAS_INPUT: create them with it to use ray-query techniques")]
    NotBlasInput {
        /// The scene's name.
        scene: String,
    },
}

/// A built BLAS with what it holds.
struct BuiltBlas {
    blas: wgpu::Blas,
    triangles: u32,
}

/// The casters' acceleration structures for ray queries, kept across frames by the technique
/// that owns them.
pub struct SceneAccel {
    static_blas: Option<(u64, Option<BuiltBlas>)>,
    dynamic_blas: Option<(u64, Option<BuiltBlas>)>,
    tlas: Option<wgpu::Tlas>,
    /// Structures built in the last [`SceneAccel::update`] (0 when everything was kept).
    pub last_built: u32,
}

impl Default for SceneAccel {
    fn default() -> Self {
        Self::new()
    }
}

impl SceneAccel {
    /// Nothing built yet.
    pub fn new() -> Self {
        Self {
            static_blas: None,
            dynamic_blas: None,
            tlas: None,
            last_built: 0,
        }
    }

    /// Drops everything (the next update rebuilds).
    pub fn invalidate(&mut self) {
        *self = Self::new();
    }

    /// The TLAS, once [`SceneAccel::update`] succeeded.
    pub fn tlas(&self) -> Option<&wgpu::Tlas> {
        self.tlas.as_ref()
    }

    /// Caster triangles in the structures.
    pub fn triangles(&self) -> u64 {
        [&self.static_blas, &self.dynamic_blas]
            .into_iter()
            .flatten()
            .filter_map(|(_, b)| b.as_ref())
            .map(|b| u64::from(b.triangles))
            .sum()
    }

    /// Modelled bytes of the structures ([`BYTES_PER_TRIANGLE`] per triangle, 64 per instance).
    pub fn bytes_estimate(&self) -> u64 {
        self.triangles() * BYTES_PER_TRIANGLE + 2 * 64
    }

    /// Builds what `scene` needs and is not kept: the static BLAS when the static casters
    /// changed, the dynamic one when the dynamic casters changed, and then the TLAS. The build is
    /// recorded into the frame's encoder as the CPU-timed pass `label` (serial timing waits for
    /// it; with timestamps only the recording is timed). Returns whether anything was built.
    pub fn update(
        &mut self,
        frame: &mut Frame<'_>,
        scene: &SceneGpu,
        label: &str,
    ) -> Result<bool, AccelError> {
        if self.is_current(frame.gpu, scene)? {
            self.last_built = 0;
            return Ok(false);
        }
        let start = frame.begin_cpu_pass();
        let gpu = frame.gpu;
        self.record(gpu, frame.encoder, scene)?;
        frame.end_cpu_pass(label, start);
        Ok(true)
    }

    /// Whether the structures are those of `scene` already (an error when the device has no
    /// ray queries).
    fn is_current(&self, gpu: &Gpu, scene: &SceneGpu) -> Result<bool, AccelError> {
        if !gpu.features().contains(RAY_QUERY) {
            return Err(AccelError::NoRayQuery);
        }
        let static_ok = matches!(&self.static_blas, Some((h, _)) if *h == scene.static_hash);
        let dynamic_ok = matches!(&self.dynamic_blas, Some((h, _)) if *h == scene.dynamic_hash);
        Ok(static_ok && dynamic_ok && self.tlas.is_some())
    }

    /// Records the build of what `scene` needs and is not kept into `encoder` (outside a
    /// [`Frame`]: a ray-traced exact answer, a benchmark of build times). Returns whether
    /// anything was built.
    pub fn build(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        scene: &SceneGpu,
    ) -> Result<bool, AccelError> {
        if self.is_current(gpu, scene)? {
            self.last_built = 0;
            return Ok(false);
        }
        self.record(gpu, encoder, scene)?;
        Ok(true)
    }

    fn record(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        scene: &SceneGpu,
    ) -> Result<(), AccelError> {
        let static_ok = matches!(&self.static_blas, Some((h, _)) if *h == scene.static_hash);
        let dynamic_ok = matches!(&self.dynamic_blas, Some((h, _)) if *h == scene.dynamic_hash);
        check_limits(gpu, scene)?;
        // (is it the static one, the BLAS, its size, its triangles) for each BLAS to build.
        let mut made = Vec::new();
        for (is_static, ok, list, what) in [
            (
                true,
                static_ok,
                scene.static_casters.as_ref(),
                "static casters",
            ),
            (
                false,
                dynamic_ok,
                scene.dynamic_casters.as_ref(),
                "dynamic casters",
            ),
        ] {
            if !ok {
                made.push((is_static, make_blas(gpu, scene, list, what), list));
            }
        }
        let build_entries: Vec<wgpu::BlasBuildEntry<'_>> = made
            .iter()
            .filter_map(|(_, blas, list)| Some((blas.as_ref()?, (*list)?)))
            .map(|((blas, size), list)| wgpu::BlasBuildEntry {
                blas: &blas.blas,
                geometry: wgpu::BlasGeometries::TriangleGeometries(vec![
                    wgpu::BlasTriangleGeometry {
                        size,
                        vertex_buffer: &scene.vertices,
                        first_vertex: 0,
                        vertex_stride: std::mem::size_of::<crate::scene_gpu::Vertex>() as u64,
                        index_buffer: Some(&list.buffer),
                        first_index: Some(0),
                        transform_buffer: None,
                        transform_buffer_offset: None,
                    },
                ]),
            })
            .collect();
        // The TLAS: every BLAS there is (kept or new), with the identity transform (the
        // geometry is in world space).
        let mut tlas = gpu.device.create_tlas(&wgpu::CreateTlasDescriptor {
            label: Some("scene casters (TLAS)"),
            max_instances: 2,
            flags: wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE,
            update_mode: wgpu::AccelerationStructureUpdateMode::Build,
        });
        const IDENTITY: [f32; 12] = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let kept = [
            static_ok.then_some(&self.static_blas),
            dynamic_ok.then_some(&self.dynamic_blas),
        ];
        let kept_blas = kept
            .into_iter()
            .zip([true, false])
            .filter_map(|(b, is_static)| Some((is_static, b?.as_ref()?.1.as_ref()?)))
            .map(|(is_static, b)| (is_static, &b.blas));
        let new_blas = made
            .iter()
            .filter_map(|(is_static, b, _)| b.as_ref().map(|(b, _)| (*is_static, &b.blas)));
        // The custom data says which caster list the instance's primitive indices count in
        // (`BLAS_STATIC` / `BLAS_DYNAMIC`): the alpha test reads the hit triangle's texcoords
        // through it.
        for (slot, (is_static, blas)) in kept_blas.chain(new_blas).enumerate() {
            let which = if is_static { BLAS_STATIC } else { BLAS_DYNAMIC };
            tlas[slot] = Some(wgpu::TlasInstance::new(blas, IDENTITY, which, 0xff));
        }
        encoder.build_acceleration_structures(build_entries.iter(), std::iter::once(&tlas));
        drop(build_entries);
        self.last_built = made.len() as u32 + 1;
        for (is_static, blas, _) in made {
            let entry = Some(if is_static {
                scene.static_hash
            } else {
                scene.dynamic_hash
            })
            .map(|h| (h, blas.map(|(b, _)| b)));
            if is_static {
                self.static_blas = entry;
            } else {
                self.dynamic_blas = entry;
            }
        }
        self.tlas = Some(tlas);
        Ok(())
    }
}

/// TLAS custom data of the BLAS over [`SceneGpu::static_casters`].
pub const BLAS_STATIC: u32 = 0;
/// TLAS custom data of the BLAS over [`SceneGpu::dynamic_casters`].
pub const BLAS_DYNAMIC: u32 = 1;

/// Refuses a scene whose casters exceed the adapter's `max_blas_primitive_count` (wgpu checks the
/// vertex count of a geometry against it, too: the whole vertex buffer is one geometry's).
fn check_limits(gpu: &Gpu, scene: &SceneGpu) -> Result<(), AccelError> {
    let limit = gpu.device.limits().max_blas_primitive_count;
    let vertices = scene.vertices.size() / std::mem::size_of::<crate::scene_gpu::Vertex>() as u64;
    let triangles = scene.caster_triangle_count as u64;
    for (what, count) in [("vertices", vertices), ("triangles", triangles)] {
        if count > u64::from(limit) {
            return Err(AccelError::TooLarge {
                scene: scene.name.clone(),
                what,
                count,
                limit,
            });
        }
    }
    for buffer in [
        Some(&scene.vertices),
        scene.casters.as_ref().map(|l| &l.buffer),
    ]
    .into_iter()
    .flatten()
    {
        if !buffer.usage().contains(wgpu::BufferUsages::BLAS_INPUT) {
            return Err(AccelError::NotBlasInput {
                scene: scene.name.clone(),
            });
        }
    }
    Ok(())
}

/// A BLAS over the triangles of `list` (none for an empty list), with its size descriptor.
fn make_blas(
    gpu: &Gpu,
    scene: &SceneGpu,
    list: Option<&IndexList>,
    what: &str,
) -> Option<(BuiltBlas, wgpu::BlasTriangleGeometrySizeDescriptor)> {
    let list = list?;
    let vertex_count =
        (scene.vertices.size() / std::mem::size_of::<crate::scene_gpu::Vertex>() as u64) as u32;
    let size = wgpu::BlasTriangleGeometrySizeDescriptor {
        vertex_format: wgpu::VertexFormat::Float32x3,
        vertex_count,
        index_format: Some(wgpu::IndexFormat::Uint32),
        index_count: Some(list.count),
        // Opaque: a hit ends the shadow ray (no any-hit shader to run). With a masked caster
        // every triangle is a candidate the shader tests alpha on (rayQueryConfirmIntersection).
        flags: if scene.materials.as_ref().is_some_and(|m| m.masked_casters) {
            wgpu::AccelerationStructureGeometryFlags::empty()
        } else {
            wgpu::AccelerationStructureGeometryFlags::OPAQUE
        },
    };
    let blas = gpu.device.create_blas(
        &wgpu::CreateBlasDescriptor {
            label: Some(&format!("scene {what} (BLAS)")),
            flags: wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE,
            update_mode: wgpu::AccelerationStructureUpdateMode::Build,
        },
        wgpu::BlasGeometrySizeDescriptors::Triangles {
            descriptors: vec![size.clone()],
        },
    );
    Some((
        BuiltBlas {
            blas,
            triangles: list.count / 3,
        },
        size,
    ))
}
