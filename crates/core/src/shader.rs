//! Shader composition: every WGSL file lives in its crate's `shaders/` folder, shared code under
//! the core's `shaders/common/` is imported with naga_oil's `#import` (the one composition
//! mechanism), and each crate lists its shaders and their permutations in a [`ShaderSpec`] so
//! `cargo test` can validate all of them.

use std::collections::HashMap;

use naga_oil::compose::{
    ComposableModuleDescriptor, Composer, NagaModuleDescriptor, ShaderDefValue, ShaderLanguage,
    ShaderType,
};

use crate::{error::GpuError, Gpu};

// Test support: the layouts of WGSL uniform structs and their Rust mirrors (tests/shaders.rs).
#[doc(hidden)]
pub mod uniform_layout;

/// Includes `shaders/<path>` of the calling crate as a `(path, source)` pair. The path is the
/// shader's key in errors and tests: a built-in crate keeps its files in a folder named after it
/// (`crates/pcss/shaders/pcss/pcss.wgsl` is `pcss/pcss.wgsl`), so keys stay distinct across
/// crates, and a packaged crate carries its WGSL.
#[macro_export]
macro_rules! shader_file {
    ($path:literal) => {
        (
            $path,
            include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/", $path)),
        )
    };
}

/// A shader-def value, constructible in `const` tables.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DefValue {
    /// A boolean def (`#ifdef NAME`).
    Bool(bool),
    /// A signed integer def.
    Int(i32),
    /// An unsigned integer def.
    UInt(u32),
}

impl From<DefValue> for ShaderDefValue {
    fn from(v: DefValue) -> Self {
        match v {
            DefValue::Bool(b) => ShaderDefValue::Bool(b),
            DefValue::Int(i) => ShaderDefValue::Int(i),
            DefValue::UInt(u) => ShaderDefValue::UInt(u),
        }
    }
}

/// One set of shader defs.
pub type Permutation = &'static [(&'static str, DefValue)];

/// A WGSL entry file and every permutation the code can build from it.
#[derive(Clone, Copy, Debug)]
pub struct ShaderSpec {
    /// Path under its crate's `shaders/`, e.g. `pcss/pcss.wgsl` (`crates/pcss/shaders/pcss/pcss.wgsl`).
    pub path: &'static str,
    /// The WGSL source.
    pub source: &'static str,
    /// At least one (use `&[&[]]` for "no defs").
    pub permutations: &'static [Permutation],
}

/// The importable modules, under the core's `shaders/common/`.
pub const COMMON_MODULES: &[(&str, &str)] = &[
    shader_file!("common/frame_types.wgsl"),
    shader_file!("common/light.wgsl"),
    shader_file!("common/frame.wgsl"),
    shader_file!("common/fullscreen.wgsl"),
    shader_file!("common/shadow_view.wgsl"),
    shader_file!("common/cascades.wgsl"),
    shader_file!("common/sampling.wgsl"),
    shader_file!("common/search_area.wgsl"),
    shader_file!("common/gather.wgsl"),
    shader_file!("common/gather_pass.wgsl"),
    shader_file!("common/reprojection.wgsl"),
    shader_file!("common/material.wgsl"),
];

/// The core crate's own entry shaders.
pub const CORE_SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "core/gbuffer.wgsl",
        source: shader_file!("core/gbuffer.wgsl").1,
        permutations: &[&[], crate::gbuffer::GBUFFER_MATERIALS],
    },
    ShaderSpec {
        path: "core/depth.wgsl",
        source: shader_file!("core/depth.wgsl").1,
        permutations: &[&[], crate::material_gpu::DEPTH_ALPHA_TEST],
    },
    ShaderSpec {
        path: "core/shading.wgsl",
        source: shader_file!("core/shading.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "core/hierarchy.wgsl",
        source: shader_file!("core/hierarchy.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "core/unshadowed.wgsl",
        source: shader_file!("core/unshadowed.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "core/host_surface.wgsl",
        source: shader_file!("core/host_surface.wgsl").1,
        permutations: &[&[], &[("FROM_DEPTH", DefValue::Bool(true))]],
    },
    ShaderSpec {
        path: "core/host_output.wgsl",
        source: shader_file!("core/host_output.wgsl").1,
        permutations: &[&[]],
    },
];

fn composer() -> Result<Composer, GpuError> {
    // naga_oil validates the composed module with its own capabilities, which lack ray queries
    // by default; wgpu validates again against what the device has (crate::accel).
    let mut composer = Composer::default().with_capabilities(
        naga::valid::Capabilities::default() | naga::valid::Capabilities::RAY_QUERY,
    );
    // Modules import each other, so add them in dependency order (the list above is ordered).
    for (path, source) in COMMON_MODULES {
        composer
            .add_composable_module(ComposableModuleDescriptor {
                source,
                file_path: path,
                language: ShaderLanguage::Wgsl,
                ..Default::default()
            })
            .map_err(|e| GpuError::Shader {
                path: path.to_string(),
                message: e.emit_to_string(&Composer::default()),
            })?;
    }
    Ok(composer)
}

/// Composes and validates one permutation into a naga module.
pub fn compose(spec: &ShaderSpec, defs: &[(&str, DefValue)]) -> Result<naga::Module, GpuError> {
    let mut composer = composer()?;
    let shader_defs: HashMap<String, ShaderDefValue> = defs
        .iter()
        .map(|(k, v)| (k.to_string(), (*v).into()))
        .collect();
    composer
        .make_naga_module(NagaModuleDescriptor {
            source: spec.source,
            file_path: spec.path,
            shader_type: ShaderType::Wgsl,
            shader_defs,
            ..Default::default()
        })
        .map_err(|e| GpuError::Shader {
            path: spec.path.to_string(),
            message: e.emit_to_string(&composer),
        })
}

/// Composes one permutation and creates the wgpu shader module.
pub fn create_module(
    gpu: &Gpu,
    spec: &ShaderSpec,
    defs: &[(&str, DefValue)],
) -> Result<wgpu::ShaderModule, GpuError> {
    let module = compose(spec, defs)?;
    Ok(gpu
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(spec.path),
            source: wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(module)),
        }))
}

/// Validates every permutation of every spec with naga. Used by the crates' tests.
pub fn validate_all(specs: &[ShaderSpec]) -> Result<usize, GpuError> {
    let mut count = 0;
    for spec in specs {
        if spec.permutations.is_empty() {
            return Err(GpuError::Shader {
                path: spec.path.into(),
                message: "no permutation listed: use `&[&[]]` for a shader without defs".into(),
            });
        }
        for permutation in spec.permutations {
            let module = compose(spec, permutation)?;
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::all(),
            )
            .validate(&module)
            .map_err(|e| GpuError::Shader {
                path: format!("{} {:?}", spec.path, permutation),
                message: e.emit_to_string(spec.source),
            })?;
            count += 1;
        }
    }
    Ok(count)
}
