//! glTF 2.0 geometry import: `.gltf` with external or embedded (data URI) buffers, and `.glb`.
//!
//! Only geometry is read: positions, normals (computed when missing) and indices (generated for
//! non-indexed primitives) of triangle-list primitives. Materials, textures, skins and
//! animations are ignored, and images are never loaded, so a model with missing textures still
//! loads. Each triangle primitive becomes one [`Mesh`]; the default scene's node hierarchy
//! (or the first scene, or, without scenes, every mesh at the origin) gives the world transforms.

use std::path::Path;

use glam::{Mat4, Vec3};
use gltf::mesh::Mode;
use softshadow_core::Mesh;

use crate::{repair_warnings, SceneError};

/// Geometry read from a glTF file.
#[derive(Clone, Debug, Default)]
pub struct GltfGeometry {
    /// One mesh per triangle primitive, already repaired.
    pub meshes: Vec<Mesh>,
    /// One entry per use of a mesh by a node: (index into `meshes`, node world transform).
    pub instances: Vec<(usize, Mat4)>,
    /// Skipped primitives, repaired triangles and similar, one line each.
    pub warnings: Vec<String>,
}

/// Node hierarchies deeper than this are treated as malformed (guards against cycles).
const MAX_NODE_DEPTH: usize = 256;

/// Reads the geometry of a `.gltf` or `.glb` file. See the module documentation.
pub fn load_gltf(path: &Path) -> Result<GltfGeometry, SceneError> {
    let shown = path.display().to_string();
    let bytes = crate::read_file(path, "glTF file")?;
    let malformed = |message: String| SceneError::GltfMalformed {
        path: shown.clone(),
        message: crate::error::one_line(&message),
    };
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice(&bytes).map_err(|e| malformed(e.to_string()))?;
    let base = path.parent().unwrap_or_else(|| Path::new("."));
    let buffers = gltf::import_buffers(&document, Some(base), blob)
        .map_err(|e| malformed(format!("cannot load its buffers ({e})")))?;
    let file_name = path
        .file_name()
        .map_or_else(|| shown.clone(), |n| n.to_string_lossy().into_owned());

    let mut geometry = GltfGeometry::default();
    // For each glTF mesh, the indices of the meshes made from its triangle primitives.
    let mut primitives_of: Vec<Vec<usize>> = Vec::new();
    for gmesh in document.meshes() {
        let mesh_name = gmesh
            .name()
            .map_or_else(|| format!("mesh{}", gmesh.index()), str::to_string);
        let primitive_count = gmesh.primitives().len();
        let mut made = Vec::new();
        for primitive in gmesh.primitives() {
            let name = if primitive_count > 1 {
                format!("{mesh_name}/{}", primitive.index())
            } else {
                mesh_name.clone()
            };
            match read_primitive(&primitive, &buffers, &name) {
                Ok(mut mesh) => {
                    let repair = mesh.repair();
                    geometry
                        .warnings
                        .extend(repair_warnings(&mesh.name, &file_name, &repair));
                    if mesh.indices.is_empty() {
                        geometry.warnings.push(format!(
                            "mesh `{name}` from {file_name}: no triangles left after repair"
                        ));
                    }
                    made.push(geometry.meshes.len());
                    geometry.meshes.push(mesh);
                }
                Err(reason) => geometry.warnings.push(format!(
                    "mesh `{name}` from {file_name}: skipped a primitive: {reason}"
                )),
            }
        }
        primitives_of.push(made);
    }

    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    match scene {
        Some(scene) => {
            for node in scene.nodes() {
                walk(
                    &node,
                    Mat4::IDENTITY,
                    0,
                    &primitives_of,
                    &mut geometry.instances,
                )
                .map_err(malformed)?;
            }
        }
        None => {
            geometry.warnings.push(format!(
                "{file_name} has no scene: placed every mesh once at the origin"
            ));
            for mesh in primitives_of.iter().flatten() {
                geometry.instances.push((*mesh, Mat4::IDENTITY));
            }
        }
    }
    if geometry.instances.is_empty() {
        return Err(SceneError::GltfNoGeometry { path: shown });
    }
    Ok(geometry)
}

/// Adds the instances of `node` and its descendants, composing transforms parent * child.
fn walk(
    node: &gltf::Node<'_>,
    parent: Mat4,
    depth: usize,
    primitives_of: &[Vec<usize>],
    out: &mut Vec<(usize, Mat4)>,
) -> Result<(), String> {
    if depth > MAX_NODE_DEPTH {
        return Err(format!(
            "node hierarchy deeper than {MAX_NODE_DEPTH} levels (a cycle?)"
        ));
    }
    let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
    if let Some(mesh) = node.mesh() {
        for &m in primitives_of.get(mesh.index()).into_iter().flatten() {
            out.push((m, world));
        }
    }
    for child in node.children() {
        walk(&child, world, depth + 1, primitives_of, out)?;
    }
    Ok(())
}

/// Reads one primitive into a mesh, or says why it was skipped.
fn read_primitive(
    primitive: &gltf::Primitive<'_>,
    buffers: &[gltf::buffer::Data],
    name: &str,
) -> Result<Mesh, String> {
    let mode = primitive.mode();
    if mode != Mode::Triangles {
        return Err(format!(
            "mode {mode:?} is not supported (only triangle lists are read; triangulate on export)"
        ));
    }
    let reader = primitive.reader(|buffer| buffers.get(buffer.index()).map(|d| &d.0[..]));
    if primitive.get(&gltf::Semantic::Positions).is_none() {
        return Err("it has no POSITION attribute".into());
    }
    let positions: Vec<Vec3> = reader
        .read_positions()
        .ok_or("its POSITION data lies outside its buffer")?
        .map(Vec3::from)
        .collect();
    let normals: Vec<Vec3> = match primitive.get(&gltf::Semantic::Normals) {
        Some(_) => reader
            .read_normals()
            .ok_or("its NORMAL data lies outside its buffer")?
            .map(Vec3::from)
            .collect(),
        None => Vec::new(),
    };
    let indices: Vec<u32> = match primitive.indices() {
        Some(_) => reader
            .read_indices()
            .ok_or("its index data lies outside its buffer")?
            .into_u32()
            .collect(),
        None => (0..positions.len() as u32).collect(),
    };
    if indices.len() % 3 != 0 {
        return Err(format!(
            "its {} indices are not a multiple of 3",
            indices.len()
        ));
    }
    let mut mesh = Mesh {
        name: name.into(),
        positions,
        normals,
        indices,
    };
    // A wrong normal count is replaced by computed normals (after repair, in the caller).
    if mesh.normals.len() != mesh.positions.len() {
        mesh.normals.clear();
    }
    Ok(mesh)
}
