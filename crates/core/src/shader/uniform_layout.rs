//! The layout of a WGSL uniform struct and of the Rust struct that fills it, for the test that
//! keeps the two in step (`tests/shaders.rs`, `every_uniform_struct_matches_its_rust_mirror`).
//!
//! A uniform is declared once in Rust with `#[derive(encase::ShaderType)]` ([`crate::uniform`]),
//! which lays it out by WGSL's rules; the shader declares the same fields. Nothing ties the two
//! lists together at build time, and a field added on one side only does not fail validation:
//! the shader just reads the wrong bytes. So each crate lists its structs with
//! [`uniform_mirror!`](crate::uniform_mirror) in a `#[doc(hidden)] pub fn uniform_mirrors()` (the
//! structs are private to their crates, and a unit-test binary per crate would link wgpu once
//! each), and the workspace test compares each with the struct naga lays out from the composed
//! shader: total size, and every field's offset and size by name. Storage structs the CPU writes
//! or reads back (counters) are listed the same way.

use encase::{
    internal::{CreateFrom, WriteInto},
    ShaderType, StorageBuffer,
};
use naga::{proc::Layouter, AddressSpace, Handle, Module, Type, TypeInner};
use naga_oil::compose::Composer;

use super::{compose, ShaderSpec, COMMON_MODULES};
use crate::error::GpuError;

/// One field of a struct: its name, its offset from the start of the struct and its size.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldLayout {
    /// The field's name as written in the source.
    pub name: String,
    /// Offset in bytes from the start of the struct.
    pub offset: u32,
    /// Size in bytes.
    pub size: u32,
}

/// A struct's size and fields, in declaration order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StructLayout {
    /// The struct's name, for messages (a WGSL struct from a common module is named as naga_oil
    /// decorates it until [`display_name`] rewrites it).
    pub name: String,
    /// Size in bytes, trailing padding included.
    pub size: u32,
    /// Every field (padding is none: it lies between them).
    pub fields: Vec<FieldLayout>,
}

/// A Rust uniform struct and the WGSL struct it mirrors. Built with
/// [`uniform_mirror!`](crate::uniform_mirror).
#[derive(Clone, Debug)]
pub struct UniformMirror {
    /// The Rust struct's layout.
    pub rust: StructLayout,
    /// The file under `shaders/` that declares the WGSL struct: an entry shader
    /// (`hard/hard.wgsl`) or a common module (`common/shadow_view.wgsl`, then every shader that
    /// imports it is checked).
    pub wgsl_file: &'static str,
    /// The WGSL struct's name as declared.
    pub wgsl_struct: &'static str,
}

impl UniformMirror {
    /// The name naga gives the WGSL struct in a composed module: as declared in an entry shader,
    /// decorated with the module's import path when it comes from a common module.
    pub fn naga_name(&self) -> String {
        match common_import_path(self.wgsl_file) {
            Some(module) => Composer::decorated_name(Some(module), self.wgsl_struct),
            None => self.wgsl_struct.to_string(),
        }
    }

    /// Whether the WGSL struct is declared in a common module, so every shader importing it holds
    /// the same struct.
    pub fn from_common_module(&self) -> bool {
        common_import_path(self.wgsl_file).is_some()
    }

    /// Whether the struct may appear in a shader composed from `path`: its own file, or any
    /// shader when it comes from a common module (which shader imports it is the naga name's
    /// business).
    pub fn may_appear_in(&self, path: &str) -> bool {
        self.wgsl_file == path || self.from_common_module()
    }
}

/// Lists a Rust uniform struct's fields for [`UniformMirror`]:
/// `uniform_mirror!(HardParams { bias_texels } => "hard/hard.wgsl", HardParams)`.
///
/// Every field of the Rust struct must be listed, or the call does not compile (it destructures
/// the struct without `..`; rustc then says "pattern requires `..`"). The struct derives
/// `encase::ShaderType`; each field's offset and size are encase's ([`probe`], [`probed_field`]).
#[doc(hidden)]
#[macro_export]
macro_rules! uniform_mirror {
    ($rust:ident { $($field:ident),+ $(,)? } => $file:literal, $wgsl:ident) => {{
        // Never called: only there so that a field missing from the list is a compile error.
        #[allow(dead_code)]
        fn every_field_is_listed(value: &$rust) {
            let $rust { $($field: _),+ } = value;
        }
        let probe: $rust = $crate::shader::uniform_layout::probe();
        $crate::shader::uniform_layout::UniformMirror {
            rust: $crate::shader::uniform_layout::StructLayout {
                name: stringify!($rust).to_string(),
                size: $crate::uniform::uniform_size::<$rust>() as u32,
                fields: vec![$(
                    $crate::shader::uniform_layout::probed_field(stringify!($field), &probe.$field)
                ),+],
            },
            wgsl_file: $file,
            wgsl_struct: stringify!($wgsl),
        }
    }};
}

/// A `T` read from bytes whose every 4-byte word holds its own index, so that each field holds
/// the index of the word it starts at ([`probed_field`]).
///
/// encase exposes its offsets by field index only (`ShaderType::METADATA`, hidden), which would
/// tie the test to the order of [`uniform_mirror!`](crate::uniform_mirror)'s list; reading the
/// probe names each field's offset whatever that order.
pub fn probe<T: ShaderType + CreateFrom>() -> T {
    let words = (crate::uniform::uniform_size::<T>() / 4) as u32;
    let bytes: Vec<u8> = (0..words).flat_map(u32::to_le_bytes).collect();
    StorageBuffer::new(bytes)
        .create()
        .expect("the bytes are the struct's size")
}

/// The layout of one field of a [`probe`]: its offset is the index its first word holds (times
/// 4), its size the field type's.
pub fn probed_field<F: ShaderType + WriteInto>(name: &str, field: &F) -> FieldLayout {
    let bytes = crate::uniform::storage_bytes(field);
    let first_word = u32::from_le_bytes(bytes[..4].try_into().expect("every field has 4 bytes"));
    FieldLayout {
        name: name.to_string(),
        offset: 4 * first_word,
        size: F::min_size().get() as u32,
    }
}

/// The `#define_import_path` of a common module given by its file (`common/frame.wgsl`), or
/// `None` for any other file.
fn common_import_path(file: &str) -> Option<&'static str> {
    let (_, source) = COMMON_MODULES.iter().find(|(path, _)| *path == file)?;
    source.lines().find_map(|line| {
        line.trim()
            .strip_prefix("#define_import_path")
            .map(str::trim)
    })
}

/// A struct name from a composed module as a reader knows it:
/// `ShadowView (common/shadow_view.wgsl)` for one naga_oil decorated with a common module's import
/// path, unchanged otherwise.
pub fn display_name(naga_name: &str) -> String {
    for (file, _) in COMMON_MODULES {
        if let Some(module) = common_import_path(file) {
            let suffix = Composer::decorated_name(Some(module), "");
            if let Some(item) = naga_name.strip_suffix(suffix.as_str()) {
                return format!("{item} ({file})");
            }
        }
    }
    naga_name.to_string()
}

/// Whether naga's name for a struct is `declared`, as written in an entry shader or decorated
/// with a common module's import path.
fn is_named(naga_name: &str, declared: &str) -> bool {
    naga_name == declared
        || COMMON_MODULES.iter().any(|(file, _)| {
            common_import_path(file)
                .is_some_and(|module| naga_name == Composer::decorated_name(Some(module), declared))
        })
}

/// The layout naga gives the struct type `ty`, or `None` when it is not a struct.
fn layout_of(module: &Module, layouter: &Layouter, ty: Handle<Type>) -> Option<StructLayout> {
    let TypeInner::Struct { members, span } = &module.types[ty].inner else {
        return None;
    };
    Some(StructLayout {
        name: module.types[ty].name.clone().unwrap_or_default(),
        size: *span,
        fields: members
            .iter()
            .map(|m| FieldLayout {
                name: m.name.clone().unwrap_or_default(),
                offset: m.offset,
                size: layouter[m.ty].size,
            })
            .collect(),
    })
}

fn layouter(module: &Module) -> Result<Layouter, GpuError> {
    let mut layouter = Layouter::default();
    layouter
        .update(module.to_ctx())
        .map_err(|e| GpuError::Shader {
            path: "naga layouter".into(),
            message: e.to_string(),
        })?;
    Ok(layouter)
}

/// Every struct a `var<uniform>` of `module` holds: the variable's own type, the element of an
/// array, and the structs nested in those, each once. Names are naga's (see [`display_name`]).
pub fn uniform_structs(module: &Module) -> Result<Vec<StructLayout>, GpuError> {
    structs_held(module, |space| space == AddressSpace::Uniform)
}

/// Every struct a `var<storage>` of `module` holds, found as [`uniform_structs`] finds them.
pub fn storage_structs(module: &Module) -> Result<Vec<StructLayout>, GpuError> {
    structs_held(module, |space| {
        matches!(space, AddressSpace::Storage { .. })
    })
}

fn structs_held(
    module: &Module,
    in_space: impl Fn(AddressSpace) -> bool,
) -> Result<Vec<StructLayout>, GpuError> {
    let layouter = layouter(module)?;
    let mut pending: Vec<Handle<Type>> = module
        .global_variables
        .iter()
        .filter(|(_, var)| in_space(var.space))
        .map(|(_, var)| var.ty)
        .collect();
    let mut seen = Vec::new();
    let mut out = Vec::new();
    while let Some(ty) = pending.pop() {
        if seen.contains(&ty) {
            continue;
        }
        seen.push(ty);
        match &module.types[ty].inner {
            TypeInner::Array { base, .. } => pending.push(*base),
            TypeInner::Struct { members, .. } => {
                pending.extend(members.iter().map(|m| m.ty));
                out.extend(layout_of(module, &layouter, ty));
            }
            _ => {}
        }
    }
    Ok(out)
}

/// The layout of the struct named `name` (as declared) in one permutation of a shader, composed
/// as the renderer composes it. A struct from a common module is found under its declared name
/// too. `None` when the composed module has no such struct (naga drops unused types).
pub fn wgsl_struct_layout(
    spec: &ShaderSpec,
    defs: super::Permutation,
    name: &str,
) -> Result<Option<StructLayout>, GpuError> {
    let module = compose(spec, defs)?;
    let layouter = layouter(&module)?;
    let found = module
        .types
        .iter()
        .filter(|(_, ty)| ty.name.as_deref().is_some_and(|n| is_named(n, name)))
        .find_map(|(handle, _)| layout_of(&module, &layouter, handle));
    Ok(found)
}

/// Every difference between a Rust struct and the WGSL struct it mirrors, one line each naming
/// both structs and the field: the total size, a field on one side only, a field at another
/// offset or of another size. Empty when they agree.
pub fn compare(rust: &StructLayout, wgsl: &StructLayout) -> Vec<String> {
    let pair = format!("Rust `{}` / WGSL `{}`", rust.name, wgsl.name);
    let mut errors = Vec::new();
    if rust.size != wgsl.size {
        errors.push(format!(
            "{pair}: size {} bytes in Rust, {} in WGSL",
            rust.size, wgsl.size
        ));
    }
    for w in &wgsl.fields {
        match rust.fields.iter().find(|r| r.name == w.name) {
            None => errors.push(format!(
                "{pair}: field `{}` (offset {}, {} bytes) is in WGSL only",
                w.name, w.offset, w.size
            )),
            Some(r) => {
                if r.offset != w.offset {
                    errors.push(format!(
                        "{pair}: field `{}` at offset {} in Rust, {} in WGSL",
                        w.name, r.offset, w.offset
                    ));
                }
                if r.size != w.size {
                    errors.push(format!(
                        "{pair}: field `{}` is {} bytes in Rust, {} in WGSL",
                        w.name, r.size, w.size
                    ));
                }
            }
        }
    }
    for r in &rust.fields {
        if !wgsl.fields.iter().any(|w| w.name == r.name) {
            errors.push(format!(
                "{pair}: field `{}` (offset {}, {} bytes) is in Rust only",
                r.name, r.offset, r.size
            ));
        }
    }
    errors
}
