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
    /// A host's device (`Gpu::from_host`) lacks what some technique needs.
    #[error("the device on `{adapter}` lacks what the techniques need: {lacking}. Create it with `required_features: Requirements::all(&techniques).features` and `required_limits: Requirements::all(&techniques).limits.apply_to(wgpu::Limits::default())` (softshadow_core::Requirements), on an adapter that has them")]
    HostDeviceLacks {
        /// The adapter's name.
        adapter: String,
        /// Per technique, the features and limits missing.
        lacking: String,
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
    /// The device lacks features or limits the technique declares in its
    /// [`Requirements`](crate::Requirements).
    #[error("technique `{technique}` needs device features {missing:?} and limits [{limits}], which the device on `{adapter}` lacks: request them when creating the device (`required_features` / `required_limits`, see `Requirements::all`), or use an adapter that has them (lavapipe does)")]
    MissingFeatures {
        /// The technique's id.
        technique: String,
        /// The adapter's name.
        adapter: String,
        /// Features the device was not created with.
        missing: wgpu::Features,
        /// Limits the device falls short of (`name: needs N, device has M`; empty if none).
        limits: String,
    },
    #[error("technique `{technique}` cannot run on scene `{scene}`: {reason}")]
    UnsupportedScene {
        technique: String,
        scene: String,
        reason: String,
    },
    #[error("technique `{technique}`: {message}")]
    Other { technique: String, message: String },
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
