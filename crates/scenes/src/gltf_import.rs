//! glTF 2.0 geometry import: `.gltf` with external or embedded (data URI) buffers, and `.glb`.
//!
//! Only geometry is read: positions, normals (computed when missing) and indices (generated for
//! non-indexed primitives) of triangle primitives (lists, strips and fans; strips and fans become
//! lists). Materials, textures, skins and animations are ignored, and images are never loaded,
//! so a model with missing textures still loads. Each triangle primitive becomes one [`Mesh`]; the default scene's node hierarchy
//! (or the first scene, or, without scenes, every mesh at the origin) gives the world transforms.

use std::path::Path;

use glam::{Mat4, Vec3};
use gltf::mesh::Mode;
use softshadow_core::Mesh;

use crate::limits::{
    MAX_FILE_BYTES, MAX_INSTANCES, MAX_NODE_DEPTH, MAX_NODE_VISITS, MAX_TRIANGLES, MAX_VERTICES,
};
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
    /// The lights its nodes carry (`KHR_lights_punctual`, as docs/SCENES.md says), in node
    /// order: a model loaded alone is lit by the first.
    pub lights: Vec<softshadow_core::AreaLight>,
    /// The materials and textures the primitives use.
    pub materials: crate::gltf_materials::GltfMaterials,
    /// Per mesh in `meshes`, its index in `materials.materials` (`None`: glTF's default
    /// material, drawn as before materials were read).
    pub mesh_materials: Vec<Option<usize>>,
}

/// Reads the geometry of a `.gltf` or `.glb` file. See the module documentation.
pub fn load_gltf(path: &Path) -> Result<GltfGeometry, SceneError> {
    let bytes = crate::read_file(path, "glTF file")?;
    parse_gltf(
        &bytes,
        Some(path.parent().unwrap_or_else(|| Path::new("."))),
        path,
    )
}

/// Reads the geometry of `.gltf` / `.glb` bytes; `path` names the file in messages and
/// warnings. Buffers in other files are read from folder `base`; with `None` they are refused.
/// Checks the [`crate::limits`] before reading anything large.
pub fn parse_gltf(
    bytes: &[u8],
    base: Option<&Path>,
    path: &Path,
) -> Result<GltfGeometry, SceneError> {
    let file = Shown(path.display().to_string());
    check_glb_header(bytes, &file)?;
    let (document, blob) = read_document(bytes, &file)?;
    check_buffers(&document, base, &file)?;
    let buffers = gltf::import_buffers(&document, base, blob)
        .map_err(|e| file.malformed(format!("cannot load its buffers ({e})")))?;
    let file_name = path
        .file_name()
        .map_or_else(|| file.0.clone(), |n| n.to_string_lossy().into_owned());

    let mut geometry = GltfGeometry::default();
    let source = crate::gltf_materials::ImageSource {
        buffers: &buffers,
        base,
        file: &file.0,
    };
    geometry.materials =
        crate::gltf_materials::read_materials(&document, &source, &mut geometry.warnings)?;
    let primitives_of = read_meshes(&document, &buffers, &file, &file_name, &mut geometry)?;
    place_instances(&document, &primitives_of, &file, &file_name, &mut geometry)?;
    if geometry.instances.is_empty() {
        return Err(SceneError::GltfNoGeometry { path: file.0 });
    }
    Ok(geometry)
}

/// The file as messages name it.
struct Shown(String);

impl Shown {
    fn malformed(&self, message: String) -> SceneError {
        SceneError::GltfMalformed {
            path: self.0.clone(),
            message: crate::error::one_line(&message),
        }
    }

    fn limit(&self, what: String, limit: String, advice: &str) -> SceneError {
        SceneError::Limit {
            origin: format!("glTF file `{}`", self.0),
            what,
            limit,
            advice: advice.into(),
        }
    }

    fn version(&self, version: String) -> SceneError {
        SceneError::GltfVersion {
            path: self.0.clone(),
            version,
        }
    }
}

/// Refuses a GLB header gltf would mishandle: version 1 and a length below the header's own.
fn check_glb_header(bytes: &[u8], file: &Shown) -> Result<(), SceneError> {
    let header_word = |at: usize| {
        let word = bytes.strip_prefix(b"glTF")?.get(at..at + 4)?;
        Some(u32::from_le_bytes([word[0], word[1], word[2], word[3]]))
    };
    // A version 1 GLB is glTF 1.0's binary form (KHR_binary_glTF); gltf calls it only
    // "unsupported version".
    if header_word(0) == Some(1) {
        return Err(file.version("1.0 (binary, KHR_binary_glTF)".into()));
    }
    // gltf 1.4 subtracts 12 from the GLB header's length unchecked (a panic below 12: found by
    // the `gltf` fuzz target), so that header is checked here first.
    if let Some(length) = header_word(4) {
        if length < 12 {
            return Err(file.malformed(format!(
                "its GLB header gives a length of {length} bytes, less than the 12-byte header"
            )));
        }
    }
    Ok(())
}

/// The glTF 2.0 document of `bytes` and its GLB blob, validated; other versions and required
/// extensions gltf lacks are refused with what they are.
fn read_document(
    bytes: &[u8],
    file: &Shown,
) -> Result<(gltf::Document, Option<Vec<u8>>), SceneError> {
    // gltf-json 1.4's validation reads the POSITION accessor of every primitive by index
    // without a bounds check (a panic on an index past the accessors: found by the `gltf` fuzz
    // target), so those indices are checked here before gltf validates the rest.
    let gltf::Gltf { document, blob } = match gltf::Gltf::from_slice_without_validation(bytes) {
        Ok(gltf) => gltf,
        Err(e) => {
            // glTF 1.0 keeps its objects in dictionaries, so gltf's message for it is a
            // type error ("invalid type: map, expected a sequence").
            if let Some(version) = gltf_1_json_version(bytes) {
                return Err(file.version(version));
            }
            return Err(file.malformed(e.to_string()));
        }
    };
    let root = document.into_json();
    if !root.asset.version.starts_with("2.") {
        return Err(file.version(root.asset.version.clone()));
    }
    // gltf would call these "malformed" ("Unsupported extension"): say which one and what to do.
    if let Some(extension) = root
        .extensions_required
        .iter()
        .find(|e| !gltf::json::extensions::ENABLED_EXTENSIONS.contains(&e.as_str()))
    {
        return Err(SceneError::GltfExtension {
            path: file.0.clone(),
            extension: extension.clone(),
            what: match extension.as_str() {
                "KHR_draco_mesh_compression" => " (Draco-compressed geometry)",
                "EXT_meshopt_compression" => " (meshoptimizer-compressed buffers)",
                "KHR_mesh_quantization" => " (quantized vertex attributes)",
                _ => "",
            }
            .into(),
        });
    }
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
            if let Some(accessor) = primitive.attributes.get(&position) {
                if accessor.value() >= root.accessors.len() {
                    return Err(file.malformed(format!(
                        "mesh {m} primitive {p}: its POSITION attribute names accessor {}, but the file has {} accessors",
                        accessor.value(),
                        root.accessors.len()
                    )));
                }
            }
        }
    }
    let document = gltf::Document::from_json(root).map_err(|e| file.malformed(e.to_string()))?;
    Ok((document, blob))
}

/// Refuses a buffer over [`MAX_FILE_BYTES`], and a buffer in another file without a folder
/// `base` to read it from or that is not a plain file of a readable size.
fn check_buffers(
    document: &gltf::Document,
    base: Option<&Path>,
    file: &Shown,
) -> Result<(), SceneError> {
    for buffer in document.buffers() {
        if buffer.length() as u64 > MAX_FILE_BYTES {
            return Err(file.limit(
                format!("buffer {} ({} bytes)", buffer.index(), buffer.length()),
                format!("{MAX_FILE_BYTES} bytes (limits::MAX_FILE_BYTES)"),
                "split or decimate the model",
            ));
        }
        if let gltf::buffer::Source::Uri(uri) = buffer.source() {
            if !uri.starts_with("data:") {
                let Some(base) = base else {
                    return Err(file.malformed(format!(
                        "buffer {} is in another file (`{uri}`), which is not read here; embed it (save as .glb)",
                        buffer.index()
                    )));
                };
                // A device or pipe named as a buffer would never end: check before gltf reads it.
                let buffer_file = base.join(uri.strip_prefix("file://").unwrap_or(uri));
                if buffer_file.exists() {
                    crate::check_file(&buffer_file, "glTF buffer file")?;
                }
            }
        }
    }
    Ok(())
}

/// Reads every triangle primitive into `geometry.meshes` (repaired; a primitive that cannot be
/// read is skipped with a warning), checking the vertex and triangle limits before each; returns,
/// for each glTF mesh, the indices of the meshes made from it.
fn read_meshes(
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    file: &Shown,
    file_name: &str,
    geometry: &mut GltfGeometry,
) -> Result<Vec<Vec<usize>>, SceneError> {
    let mut primitives_of: Vec<Vec<usize>> = Vec::new();
    // Triangles of every primitive read so far, checked against the limit before reading more.
    let mut triangles_read = 0usize;
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
            let (vertices, triangles) = primitive_size(&primitive);
            if vertices > MAX_VERTICES {
                return Err(file.limit(
                    format!("mesh `{name}`'s vertex count ({vertices})"),
                    format!("{MAX_VERTICES} vertices per primitive (limits::MAX_VERTICES)"),
                    "decimate the model",
                ));
            }
            triangles_read = triangles_read.saturating_add(triangles);
            if triangles_read > MAX_TRIANGLES {
                return Err(file.limit(
                    format!("the triangle count of its meshes (at least {triangles_read})"),
                    format!("{MAX_TRIANGLES} triangles (limits::MAX_TRIANGLES)"),
                    "decimate the model",
                ));
            }
            match read_primitive(&primitive, buffers, &name) {
                Ok(mut mesh) => {
                    let repair = mesh.repair();
                    geometry
                        .warnings
                        .extend(repair_warnings(&mesh.name, file_name, &repair));
                    if mesh.indices.is_empty() {
                        geometry.warnings.push(format!(
                            "mesh `{name}` from {file_name}: no triangles left after repair"
                        ));
                    }
                    made.push(geometry.meshes.len());
                    geometry.meshes.push(mesh);
                    let material = geometry.materials.of(primitive.material().index());
                    geometry.mesh_materials.push(material);
                }
                Err(reason) => geometry.warnings.push(format!(
                    "mesh `{name}` from {file_name}: skipped a primitive: {reason}"
                )),
            }
        }
        primitives_of.push(made);
    }
    Ok(primitives_of)
}

/// Places the meshes (`primitives_of` each glTF mesh) as the default scene's node hierarchy (or
/// the first scene's) instances them into `geometry.instances`; without a scene, every mesh once
/// at the origin, with a warning.
fn place_instances(
    document: &gltf::Document,
    primitives_of: &[Vec<usize>],
    file: &Shown,
    file_name: &str,
    geometry: &mut GltfGeometry,
) -> Result<(), SceneError> {
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    let Some(scene) = scene else {
        geometry.warnings.push(format!(
            "{file_name} has no scene: placed every mesh once at the origin"
        ));
        for mesh in primitives_of.iter().flatten() {
            geometry.instances.push((*mesh, Mat4::IDENTITY));
        }
        return Ok(());
    };
    let mut walker = Walker {
        primitives_of,
        triangles_of: geometry.meshes.iter().map(Mesh::triangle_count).collect(),
        triangles: 0,
        visits: 0,
        out: &mut geometry.instances,
        lights: &mut geometry.lights,
    };
    for node in scene.nodes() {
        walker.walk(&node, Mat4::IDENTITY, 0).map_err(|e| match e {
            WalkError::Malformed(message) => file.malformed(message),
            WalkError::Limit { what, limit } => file.limit(
                what,
                limit,
                "instance the mesh fewer times (a node graph that reuses children multiplies)",
            ),
        })?;
    }
    Ok(())
}

/// The version of a glTF 1.0 JSON file that gltf could not parse: its `asset.version` when that
/// is not 2.x, or "1.0" when it keeps meshes, nodes, accessors or buffers in dictionaries (glTF
/// 1.0's layout; glTF 2.0 uses arrays). `None` for anything else, or for a GLB.
fn gltf_1_json_version(bytes: &[u8]) -> Option<String> {
    let json: serde_json::Value = serde_json::from_slice(bytes).ok()?;
    if let Some(version) = json["asset"]["version"].as_str() {
        return (!version.starts_with("2.")).then(|| version.to_string());
    }
    ["meshes", "nodes", "accessors", "buffers"]
        .iter()
        .any(|key| json[key].is_object())
        .then(|| "1.0".to_string())
}

/// (vertices, triangles) a primitive declares, from its accessors' counts (nothing is read).
fn primitive_size(primitive: &gltf::Primitive<'_>) -> (usize, usize) {
    let vertices = primitive
        .get(&gltf::Semantic::Positions)
        .map_or(0, |a| a.count());
    let indices = primitive.indices().map_or(vertices, |a| a.count());
    let triangles = match primitive.mode() {
        Mode::TriangleStrip | Mode::TriangleFan => indices.saturating_sub(2),
        _ => indices / 3,
    };
    (vertices, triangles)
}

/// Triangle-list indices of a triangle strip or fan, in the order and winding of the glTF 2.0
/// specification (3.7.2.1, "Topology types"): strip triangle i is (v[i], v[i + 1 + i % 2],
/// v[i + 2 - i % 2]), fan triangle i is (v[i + 1], v[i + 2], v[0]). Triangles that repeat an
/// index are left out: exporters join strips with them on purpose, so they are not damage to
/// report as repair would.
fn list_from(mode: Mode, indices: &[u32]) -> Vec<u32> {
    let count = indices.len().saturating_sub(2);
    let triangle = |i: usize| match mode {
        Mode::TriangleStrip => [indices[i], indices[i + 1 + i % 2], indices[i + 2 - i % 2]],
        _ => [indices[i + 1], indices[i + 2], indices[0]],
    };
    (0..count)
        .map(triangle)
        .filter(|[a, b, c]| a != b && b != c && a != c)
        .flatten()
        .collect()
}

enum WalkError {
    Malformed(String),
    Limit { what: String, limit: String },
}

/// Collects node uses of meshes, counting instances and their triangles against the limits (a
/// node graph that reuses children can name 2^depth instances in a few hundred bytes).
struct Walker<'a> {
    primitives_of: &'a [Vec<usize>],
    triangles_of: Vec<usize>,
    triangles: usize,
    visits: usize,
    out: &'a mut Vec<(usize, Mat4)>,
    lights: &'a mut Vec<softshadow_core::AreaLight>,
}

impl Walker<'_> {
    /// Adds the instances of `node` and its descendants, composing transforms parent * child.
    fn walk(&mut self, node: &gltf::Node<'_>, parent: Mat4, depth: usize) -> Result<(), WalkError> {
        if depth > MAX_NODE_DEPTH {
            return Err(WalkError::Malformed(format!(
                "node hierarchy deeper than {MAX_NODE_DEPTH} levels (limits::MAX_NODE_DEPTH; a cycle?)"
            )));
        }
        self.visits += 1;
        if self.visits > MAX_NODE_VISITS {
            return Err(WalkError::Limit {
                what: format!("the number of node visits (more than {MAX_NODE_VISITS})"),
                limit: format!("{MAX_NODE_VISITS} node visits (limits::MAX_NODE_VISITS)"),
            });
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(light) = node.light() {
            let light =
                crate::gltf_lights::light_of(&light, world).map_err(WalkError::Malformed)?;
            self.lights.push(light);
        }
        if let Some(mesh) = node.mesh() {
            for &m in self.primitives_of.get(mesh.index()).into_iter().flatten() {
                if self.out.len() >= MAX_INSTANCES {
                    return Err(WalkError::Limit {
                        what: format!(
                            "the number of mesh uses by nodes (more than {MAX_INSTANCES})"
                        ),
                        limit: format!("{MAX_INSTANCES} instances (limits::MAX_INSTANCES)"),
                    });
                }
                self.triangles = self.triangles.saturating_add(self.triangles_of[m]);
                if self.triangles > MAX_TRIANGLES {
                    return Err(WalkError::Limit {
                        what: format!(
                            "the triangle count of its node uses (at least {})",
                            self.triangles
                        ),
                        limit: format!("{MAX_TRIANGLES} triangles (limits::MAX_TRIANGLES)"),
                    });
                }
                self.out.push((m, world));
            }
        }
        for child in node.children() {
            self.walk(&child, world, depth + 1)?;
        }
        Ok(())
    }
}

/// Reads one primitive into a mesh, or says why it was skipped.
/// Checks what gltf 1.4's readers assume of an accessor without checking it: its element type
/// (a mismatch trips a debug assertion, or an `unreachable!` for index types), at least one
/// element and one sparse value (they compute `count - 1`) and a byte stride no smaller than an
/// element (an element would run past its slice). Found by the `gltf` fuzz target: a VEC2
/// POSITION accessor.
fn check_accessor(
    accessor: &gltf::Accessor<'_>,
    what: &str,
    dimensions: gltf::accessor::Dimensions,
    types: &[gltf::accessor::DataType],
) -> Result<(), String> {
    if accessor.dimensions() != dimensions || !types.contains(&accessor.data_type()) {
        return Err(format!(
            "its {what} accessor holds {:?} of {:?}, where glTF requires {dimensions:?} of {}",
            accessor.dimensions(),
            accessor.data_type(),
            types
                .iter()
                .map(|t| format!("{t:?}"))
                .collect::<Vec<_>>()
                .join(" or ")
        ));
    }
    if accessor.count() == 0 {
        return Err(format!("its {what} accessor has no elements"));
    }
    if accessor.sparse().is_some_and(|sparse| sparse.count() == 0) {
        return Err(format!("its {what} accessor is sparse with no values"));
    }
    let element = accessor.size();
    if let Some(stride) = accessor.view().and_then(|view| view.stride()) {
        if stride < element {
            return Err(format!(
                "its {what} accessor's byte stride ({stride}) is smaller than one element ({element} bytes)"
            ));
        }
    }
    Ok(())
}

fn read_primitive(
    primitive: &gltf::Primitive<'_>,
    buffers: &[gltf::buffer::Data],
    name: &str,
) -> Result<Mesh, String> {
    let mode = primitive.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        return Err(format!(
            "mode {mode:?} is not supported (only triangles, triangle strips and fans are read)"
        ));
    }
    let reader = primitive.reader(|buffer| buffers.get(buffer.index()).map(|d| &d.0[..]));
    let Some(position) = primitive.get(&gltf::Semantic::Positions) else {
        return Err("it has no POSITION attribute".into());
    };
    use gltf::accessor::{DataType, Dimensions};
    check_accessor(&position, "POSITION", Dimensions::Vec3, &[DataType::F32])?;
    if let Some(normal) = primitive.get(&gltf::Semantic::Normals) {
        check_accessor(&normal, "NORMAL", Dimensions::Vec3, &[DataType::F32])?;
    }
    if let Some(indices) = primitive.indices() {
        let unsigned = [DataType::U8, DataType::U16, DataType::U32];
        check_accessor(&indices, "index", Dimensions::Scalar, &unsigned)?;
    }
    if let Some(texcoord) = primitive.get(&gltf::Semantic::TexCoords(0)) {
        let types = [DataType::F32, DataType::U8, DataType::U16];
        check_accessor(&texcoord, "TEXCOORD_0", Dimensions::Vec2, &types)?;
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
    // Texcoord set 0 (section 3.7.2.1); normalized integer sets become floats in [0, 1].
    let texcoords: Vec<glam::Vec2> = match primitive.get(&gltf::Semantic::TexCoords(0)) {
        Some(_) => reader
            .read_tex_coords(0)
            .ok_or("its TEXCOORD_0 data lies outside its buffer")?
            .into_f32()
            .map(glam::Vec2::from)
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
    let indices = match mode {
        Mode::TriangleStrip | Mode::TriangleFan => list_from(mode, &indices),
        _ => indices,
    };
    if indices.len() % 3 != 0 {
        return Err(format!(
            "its {} indices are not a multiple of 3",
            indices.len()
        ));
    }
    let mut mesh = Mesh {
        texcoords,
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
