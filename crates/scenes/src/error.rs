//! The one error type of this crate. Every message is a single line that names the problem and
//! says how to fix it, so a CLI can print it as-is.

use thiserror::Error;

/// Why a scene could not be built or loaded.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SceneError {
    /// The spec is neither a builtin id nor a path to a supported file.
    #[error("unknown scene `{spec}`: run `workbench list` to see scene ids, or give a path to a .toml/.gltf/.glb file")]
    UnknownScene {
        /// The spec given.
        spec: String,
    },

    /// A `id:key=value,...` parameter list could not be parsed.
    #[error("scene spec `{spec}`: {detail}; write parameters as `id:key=value,key=value`")]
    BadSpec {
        /// The spec given.
        spec: String,
        /// What is wrong with it.
        detail: String,
    },

    /// A parameter name the builtin scene does not have.
    #[error("unknown parameter `{name}` for scene `{scene}`: known parameters are {known}")]
    UnknownParameter {
        /// The builtin scene.
        scene: String,
        /// The name given.
        name: String,
        /// The names there are.
        known: String,
    },

    /// A parameter value that does not parse as a number.
    #[error("parameter `{name}` = `{value}` for scene `{scene}` is not a number: give a number such as 1.5")]
    ParameterNotANumber {
        /// The builtin scene.
        scene: String,
        /// Parameter name.
        name: String,
        /// The text given.
        value: String,
    },

    /// A NaN or infinite parameter value.
    #[error("parameter `{name}` = {value} is not finite: give a finite number")]
    ParameterNotFinite {
        /// Parameter name.
        name: String,
        /// The value given.
        value: f64,
    },

    /// A parameter outside its allowed range.
    #[error("parameter `{name}` = {value} for scene `{scene}` is out of range: {expected}")]
    ParameterOutOfRange {
        /// The builtin scene.
        scene: String,
        /// Parameter name.
        name: String,
        /// The value given.
        value: f64,
        /// What would be accepted, e.g. "use 0 to 4".
        expected: String,
    },

    /// A scene or glTF file that does not exist. `kind` is "scene file" or "glTF file".
    #[error("{kind} `{path}` not found: check the path")]
    FileNotFound {
        /// "scene file" or "glTF file".
        kind: &'static str,
        /// The path given.
        path: String,
    },

    /// A path that names a folder, device or pipe (reading `/dev/zero` would never end).
    #[error(
        "`{path}` is not a regular file (a folder, device or pipe): give the path of a {kind}"
    )]
    NotAFile {
        /// "scene file" or "glTF file".
        kind: &'static str,
        /// The path given.
        path: String,
    },

    /// Any other I/O failure while reading a file.
    #[error("cannot read `{path}`: {message}; check the file permissions")]
    Io {
        /// The file.
        path: String,
        /// The operating system's message.
        message: String,
    },

    /// A file could not be written ([`crate::gltf_export`]).
    #[error("cannot write `{path}`: {message}")]
    Write {
        /// The file.
        path: String,
        /// What failed, and what to do.
        message: String,
    },

    /// A file with an extension this crate does not read.
    #[error(
        "`{path}` is not a supported scene file: give a .toml scene file or a .gltf/.glb model"
    )]
    UnsupportedFile {
        /// The path given.
        path: String,
    },

    /// A path (an animation over time, [`crate::path`]) that cannot be used.
    #[error("path `{name}`: {message}")]
    Path {
        /// The path's name or file.
        name: String,
        /// What is wrong and how to fix it.
        message: String,
    },

    /// A TOML syntax or schema error (unknown field, wrong type, missing field).
    #[error("scene file `{path}`{}: {message}", line.map(|l| format!(" line {l}")).unwrap_or_default())]
    SceneFile {
        /// The file.
        path: String,
        /// 1-based line of the error, when known.
        line: Option<usize>,
        /// The parser's message.
        message: String,
    },

    /// A semantically invalid `[[object]]` entry (no or several mesh sources, bad primitive size).
    #[error("scene file `{path}` object {index}{}: {message}", name.as_ref().map(|n| format!(" (`{n}`)")).unwrap_or_default())]
    SceneObject {
        /// The file.
        path: String,
        /// 1-based position of the `[[object]]` table in the file.
        index: usize,
        /// The object's `name`, if it has one.
        name: Option<String>,
        /// What is wrong with it.
        message: String,
    },

    /// A glTF file the `gltf` crate rejects (syntax, truncated binary, missing buffer, ...).
    #[error("glTF file `{path}` is malformed: {message}; re-export it as glTF 2.0")]
    GltfMalformed {
        /// The file.
        path: String,
        /// The gltf crate's message.
        message: String,
    },

    /// A glTF 1.0 file (JSON with dictionaries of objects, or a version 1 binary): only glTF 2.0
    /// is read.
    #[error("glTF file `{path}` is glTF {version}, which is not read here (only glTF 2.0): re-export it as glTF 2.0")]
    GltfVersion {
        /// The file.
        path: String,
        /// The version it declares, e.g. "1.0".
        version: String,
    },

    /// A glTF file that requires an extension this loader does not read, such as Draco mesh
    /// compression.
    #[error("glTF file `{path}` requires the extension `{extension}`{what}, which is not read here: re-export it without `{extension}`")]
    GltfExtension {
        /// The file.
        path: String,
        /// The extension's name, e.g. `KHR_draco_mesh_compression`.
        extension: String,
        /// What the extension is, with a leading " (", or empty.
        what: String,
    },

    /// A texture of a glTF material that cannot be read: a missing side-car file, a broken or
    /// unsupported image.
    #[error("glTF file `{path}`: texture {texture} cannot be read: {message}")]
    GltfTexture {
        /// The file.
        path: String,
        /// The image's name and the material whose base colour it is.
        texture: String,
        /// Why, and what to do.
        message: String,
    },

    /// A glTF file without any triangle geometry.
    #[error("glTF file `{path}` contains no triangle meshes: export at least one mesh with triangle primitives")]
    GltfNoGeometry {
        /// The file.
        path: String,
    },

    /// A file over one of the loader limits ([`crate::limits`]).
    #[error("{origin}: {what} is over the limit of {limit}: {advice}")]
    Limit {
        /// Where, e.g. "glTF file `x.glb`".
        origin: String,
        /// What was counted, e.g. "the triangle count (40000000)".
        what: String,
        /// The limit, with its unit, e.g. "32000000 triangles (softshadow_scenes::limits::MAX_TRIANGLES)".
        limit: String,
        /// What to do about it.
        advice: String,
    },

    /// The finished scene failed [`softshadow_core::Scene::validate`]. `origin` says where it
    /// came from (e.g. "scene file `x.toml`" or "builtin scene `atty-square`").
    #[error("{origin}: {message}")]
    Invalid {
        /// Where the scene came from.
        origin: String,
        /// What `validate` said.
        message: String,
    },
}

/// Puts a message on one line (glTF and TOML errors sometimes span several).
pub(crate) fn one_line(message: &str) -> String {
    message.split_whitespace().collect::<Vec<_>>().join(" ")
}
