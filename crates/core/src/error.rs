//! Errors of the core crate. Every message says what went wrong and what to do about it.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found{filter}: on Linux without a GPU install Mesa's lavapipe \
         (`sudo apt-get install -y mesa-vulkan-drivers`), or unset WGPU_BACKEND / WGPU_ADAPTER_NAME"
    )]
    NoAdapter { filter: String },
    #[error("WGPU_ADAPTER_NAME=`{wanted}` matches no adapter; available: {available}. Unset it or pick one of those names")]
    AdapterNameNotFound { wanted: String, available: String },
    #[error("could not create the GPU device on `{adapter}`: {source}. Try another adapter with WGPU_ADAPTER_NAME")]
    Device {
        adapter: String,
        #[source]
        source: wgpu::RequestDeviceError,
    },
    #[error("GPU validation error: {0}. This is a bug in a shader or pass: report it with the scene and technique")]
    Validation(String),
    #[error("GPU device lost or out of memory: {0}. Lower the resolution or shadow-map size and try again")]
    DeviceLost(String),
    #[error("GPU readback failed: {0}")]
    Readback(String),
    #[error("shader `{path}` failed to compose: {message}")]
    Shader { path: String, message: String },
    #[error("the GPU timer could not be created: {0}")]
    Profiler(String),
}

/// Why a parameter could not be set. Messages name the parameter, the value and the valid range.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum ParamError {
    #[error(
        "unknown parameter `{name}` for technique `{technique}`: known parameters are {known}"
    )]
    Unknown {
        technique: String,
        name: String,
        known: String,
    },
    #[error("parameter `{name}` = {value} is out of range: use a value from {min} to {max}")]
    OutOfRange {
        name: String,
        value: String,
        min: String,
        max: String,
    },
    #[error(
        "parameter `{name}` = {value} is not finite: give a finite number from {min} to {max}"
    )]
    NotFinite {
        name: String,
        value: String,
        min: String,
        max: String,
    },
    #[error("parameter `{name}` expects {expected}, got `{value}`")]
    WrongType {
        name: String,
        expected: String,
        value: String,
    },
    #[error("parameter `{name}` = `{value}` is not one of {options}")]
    UnknownChoice {
        name: String,
        value: String,
        options: String,
    },
}

/// A technique failed. The frame is dropped; the caller reports the message and goes on.
#[derive(Debug, Error)]
pub enum TechniqueError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("technique `{technique}` needs adapter features {missing:?}, which `{adapter}` lacks: use an adapter that has them (lavapipe does)")]
    MissingFeatures {
        technique: String,
        adapter: String,
        missing: wgpu::Features,
    },
    #[error("technique `{technique}` cannot run on scene `{scene}`: {reason}")]
    UnsupportedScene {
        technique: String,
        scene: String,
        reason: String,
    },
    #[error("technique `{technique}`: {message}")]
    Other { technique: String, message: String },
    /// The technique's precompute runs off the calling thread
    /// ([`ShadowTechnique::set_background_build`](crate::ShadowTechnique::set_background_build))
    /// and is not done yet: nothing was drawn this frame. Not a failure: call `render` again.
    #[error("technique `{technique}` is still building its precompute ({done} of {total} {unit}); render again to draw once it is done, or cancel it through its BuildControl")]
    Building {
        technique: String,
        done: u32,
        total: u32,
        unit: &'static str,
    },
    /// The precompute was cancelled through the technique's [`BuildControl`](crate::BuildControl).
    #[error("technique `{technique}`: its precompute was cancelled (Ctrl-C in the workbench, Cancel in the viewer); it builds again once the BuildControl's cancel flag is cleared")]
    Cancelled { technique: String },
}

/// Problems with a frame request (resolution, scene).
#[derive(Debug, Error)]
pub enum RenderError {
    #[error("resolution {width}x{height} is invalid: width and height must be 1 to {max} pixels")]
    BadResolution { width: u32, height: u32, max: u32 },
    #[error("invalid scene: {0}")]
    Scene(String),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Technique(#[from] TechniqueError),
}
