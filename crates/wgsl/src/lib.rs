//! A WGSL file is a technique: one fullscreen fragment pass over the bindings of a versioned
//! contract (the frame uniforms and receiver surface of group 0, the centre shadow map from the
//! light with its `ShadowView` (under the sun one orthographic map fitted to the scene), the
//! light in the frame uniforms, a uniform block of the file's parameters), writing V; the parameters are declared in the file, one `// @param` line each
//! (docs/WGSL.md).
//!
//! [`load`] reads and checks a file (directives, naga parse and validation, every error one line
//! `file:line:column: message`) and returns its [`TechniqueInfo`]; [`register_file`] adds it to a
//! [`Registry`], which the benchmark, the viewer and the command line then use like any other.

#![warn(missing_docs)]

use std::{
    borrow::Cow,
    path::{Path, PathBuf},
    sync::Arc,
};

use softshadow_core::{Registry, TechniqueInfo};
use thiserror::Error;

pub mod compile;
pub mod directives;
mod technique;
pub mod watch;

pub use technique::{FileSettings, FileTechnique};
pub use watch::WatchedFile;

/// The version of the bindings contract (docs/WGSL.md): changes when a binding, a helper of the
/// preamble or the signature of `visibility` changes.
pub const CONTRACT_VERSION: u32 = 3;

/// A technique file could not be read, parsed, validated or registered.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum WgslError {
    /// The file could not be read.
    #[error(
        "cannot read the technique file {path}: {message}: give the path of a readable .wgsl file"
    )]
    Read {
        /// The path given.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// A `// @` line is malformed.
    #[error("{path}:{line}:{column}: {message}")]
    Directive {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong and what to write instead.
        message: String,
    },
    /// naga refused the WGSL, or it declares a binding outside the contract.
    #[error("{path}:{line}:{column}: {message}")]
    Shader {
        /// The file.
        path: String,
        /// 1-based line in the file.
        line: usize,
        /// 1-based column in the file.
        column: usize,
        /// naga's message (or the contract's).
        message: String,
    },
    /// The file's stem cannot be a technique id.
    #[error("the technique file {path} would have the id `{id}`: name the file with letters, digits, `-` and `_` only (its stem is the id)")]
    BadId {
        /// The file.
        path: String,
        /// Its stem.
        id: String,
    },
    /// Another technique already has the file's id.
    #[error("the technique file {path} has the id `{id}` (its stem), which technique `{id}` from {other} already has: rename the file")]
    Collision {
        /// The file.
        path: String,
        /// Its stem.
        id: String,
        /// Where the registered one comes from.
        other: String,
    },
}

/// A command-line value names a technique file (ends in `.wgsl`), the way `--scene` takes a
/// path to a scene file.
pub fn is_technique_file(value: &str) -> bool {
    value.ends_with(".wgsl")
}

/// How the `source` of a file technique's [`TechniqueInfo`] starts; the path follows.
const SOURCE_PREFIX: &str = "WGSL file ";

/// The `source` of a file technique's [`TechniqueInfo`]: the file, by the path it was given.
fn source_text(path: &Path) -> String {
    format!("{SOURCE_PREFIX}{}", path.display())
}

/// The file a technique was loaded from, if it is a file technique ([`load`]).
pub fn file_of(info: &TechniqueInfo) -> Option<PathBuf> {
    info.source.strip_prefix(SOURCE_PREFIX).map(PathBuf::from)
}

/// Reads, checks and compiles the technique file `path` into a registry entry: id = the file
/// stem, the parameters of its `// @param` lines plus `shadow_map_size`, no cost model and no
/// bounds (it is yours to measure).
pub fn load(path: &Path) -> Result<TechniqueInfo, WgslError> {
    let shown = path.display().to_string();
    let source = std::fs::read_to_string(path).map_err(|e| WgslError::Read {
        path: shown.clone(),
        message: e.to_string(),
    })?;
    from_source(path, &source)
}

/// As [`load`], for the text `source` of the file `path` (already read).
pub fn from_source(path: &Path, source: &str) -> Result<TechniqueInfo, WgslError> {
    let shown = path.display().to_string();
    let id = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    if id.is_empty()
        || !id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        return Err(WgslError::BadId { path: shown, id });
    }
    let directives = directives::parse(&shown, source)?;
    let compiled = Arc::new(compile::compile(&shown, source, &directives)?);
    let mut params: Vec<_> = directives.params.iter().map(|p| p.spec.clone()).collect();
    params.push(technique::shadow_map_size_spec());
    let description =
        first_comment(source).unwrap_or_else(|| format!("The technique of the WGSL file {shown}"));
    let technique_id = id.clone();
    let create_directives = directives.clone();
    Ok(TechniqueInfo::new(
        Cow::Owned(id),
        Cow::Owned(description),
        Cow::Owned(source_text(path)),
        params,
        move |gpu| {
            Ok(Box::new(FileTechnique::new(
                gpu,
                &technique_id,
                &create_directives,
                &compiled,
            )?))
        },
    )
    // Version 2 gives the file the light's kind and shape; version 3 the sun's orthographic map
    // and helpers that read either map (`map_point`, `map_depth`, `map_bias`).
    .with_light_kinds(softshadow_core::LightSupport::all()))
}

/// The file's first comment line that is not a directive: its one-line description.
fn first_comment(source: &str) -> Option<String> {
    source
        .lines()
        .map_while(|l| l.trim_start().strip_prefix("//"))
        .map(str::trim)
        .find(|c| !c.is_empty() && !c.starts_with('@'))
        .map(str::to_string)
}

/// Loads the technique file `path` and adds it to `registry`; returns its id. A file already
/// registered from the same path is not added twice; a file whose stem is the id of another
/// technique is refused.
pub fn register_file(registry: &mut Registry, path: &Path) -> Result<String, WgslError> {
    if let Some(existing) = path
        .file_stem()
        .and_then(|s| registry.get(&s.to_string_lossy()))
    {
        if existing.source == source_text(path) {
            return Ok(existing.id.to_string());
        }
    }
    let info = load(path)?;
    let id = info.id.to_string();
    match registry.add(info) {
        Ok(()) => Ok(id),
        // `add` refuses only an id already there.
        Err(_) => Err(WgslError::Collision {
            path: path.display().to_string(),
            other: registry
                .get(&id)
                .map_or_else(String::new, |t| t.source.to_string()),
            id,
        }),
    }
}

/// Replaces every value in `values` that names a technique file ([`is_technique_file`]) by the
/// id of that file's technique, registering it: what a command line does with its `--technique`
/// values before it looks them up.
pub fn resolve_files(registry: &mut Registry, values: &mut [String]) -> Result<(), WgslError> {
    for value in values.iter_mut() {
        if is_technique_file(value) {
            *value = register_file(registry, &PathBuf::from(value.as_str()))?;
        }
    }
    Ok(())
}
