//! Errors of the core crate. Every message says what went wrong and what to do about it.

use thiserror::Error;

/// GPU context, device and shader problems.
#[derive(Debug, Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found{filter}: on Linux without a GPU install Mesa's lavapipe \
         (`sudo apt-get install -y mesa-vulkan-drivers`), or unset WGPU_BACKEND / WGPU_ADAPTER_NAME"
    )]
    /// No adapter at all (or none matching `WGPU_BACKEND`).
    NoAdapter {
        /// ` for WGPU_BACKEND=...` when the variable is set.
        filter: String,
    },
    #[error("WGPU_ADAPTER_NAME=`{wanted}` matches no adapter; available: {available}. Unset it or pick one of those names")]
    /// `WGPU_ADAPTER_NAME` matches no adapter.
    AdapterNameNotFound {
        /// The variable's value.
        wanted: String,
        /// Names of the adapters there are.
        available: String,
    },
    #[error("could not create the GPU device on `{adapter}`: {source}. Try another adapter with WGPU_ADAPTER_NAME")]
    /// The adapter refused to create a device.
    Device {
        /// The adapter's name.
        adapter: String,
        /// What wgpu said.
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
    /// A wgpu validation error (a bug).
    Validation(String),
    #[error("GPU device lost or out of memory: {0}. Lower the resolution or shadow-map size and try again")]
    /// The device was lost or ran out of memory.
    DeviceLost(String),
    #[error("GPU readback failed: {0}")]
    /// Reading a texture or buffer back failed.
    Readback(String),
    #[error("shader `{path}` failed to compose: {message}")]
    /// A shader did not compose or validate.
    Shader {
        /// Path under its crate's `shaders/`, e.g. `pcss/pcss.wgsl`.
        path: String,
        /// naga_oil's or naga's message.
        message: String,
    },
    /// A new device was asked of a context made from a host's device ([`crate::Gpu::from_host`]).
    #[error("cannot make a new device for a host's GPU context: the host owns its device; create a new one and wrap it with Gpu::from_host again")]
    HostContext,
    #[error("the GPU timer could not be created: {0}")]
    /// The GPU profiler could not be created.
    Profiler(String),
}

/// Why a parameter could not be set. Messages name the parameter, the value and the valid range.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum ParamError {
    #[error(
        "unknown parameter `{name}` for technique `{technique}`: known parameters are {known}"
    )]
    /// No parameter of that name.
    Unknown {
        /// The technique's id.
        technique: String,
        /// The name given.
        name: String,
        /// The names there are.
        known: String,
    },
    #[error("parameter `{name}` = {value} is out of range: use a value from {min} to {max}")]
    /// A number outside the declared range.
    OutOfRange {
        /// Parameter name.
        name: String,
        /// The value given.
        value: String,
        /// Smallest accepted value.
        min: String,
        /// Largest accepted value.
        max: String,
    },
    #[error(
        "parameter `{name}` = {value} is not finite: give a finite number from {min} to {max}"
    )]
    /// NaN or infinity.
    NotFinite {
        /// Parameter name.
        name: String,
        /// The value given.
        value: String,
        /// Smallest accepted value.
        min: String,
        /// Largest accepted value.
        max: String,
    },
    #[error("parameter `{name}` expects {expected}, got `{value}`")]
    /// A value of the wrong type (text that is not a number, say).
    WrongType {
        /// Parameter name.
        name: String,
        /// What the parameter takes.
        expected: String,
        /// The value given.
        value: String,
    },
    #[error("parameter `{name}` = `{value}` is not one of {options}")]
    /// A choice that is not one of the options.
    UnknownChoice {
        /// Parameter name.
        name: String,
        /// The value given.
        value: String,
        /// The options there are.
        options: String,
    },
}

/// A technique failed. The frame is dropped; the caller reports the message and goes on.
#[derive(Debug, Error)]
pub enum TechniqueError {
    #[error(transparent)]
    /// A GPU problem.
    Gpu(#[from] GpuError),
    #[error(transparent)]
    /// A parameter problem.
    Param(#[from] ParamError),
    /// The device lacks features or limits the technique declares in its
    /// [`Requirements`](crate::Requirements).
    #[error("technique `{technique}` needs device features {missing:?} and limits [{limits}], which the device on `{adapter}` lacks: {hint}")]
    MissingFeatures {
        /// The technique's id.
        technique: String,
        /// The adapter's name.
        adapter: String,
        /// Features the device was not created with.
        missing: wgpu::Features,
        /// Limits the device falls short of (`name: needs N, device has M`; empty if none).
        limits: String,
        /// What to do about it ([`crate::technique::missing_hint`]).
        hint: String,
    },
    #[error("technique `{technique}` cannot run on scene `{scene}`: {reason}")]
    /// The scene is outside what the technique handles.
    UnsupportedScene {
        /// The technique's id.
        technique: String,
        /// The scene's name.
        scene: String,
        /// Why, and what to do.
        reason: String,
    },
    #[error("technique `{technique}`: {message}")]
    /// Any other failure.
    Other {
        /// The technique's id.
        technique: String,
        /// What went wrong and what to do.
        message: String,
    },
    /// The technique's precompute runs off the calling thread
    /// ([`ShadowTechnique::set_background_build`](crate::ShadowTechnique::set_background_build))
    /// and is not done yet: nothing was drawn this frame. Not a failure: call `render` again.
    #[error("technique `{technique}` is still building its precompute ({done} of {total} {unit}); render again to draw once it is done, or cancel it through its BuildControl")]
    Building {
        /// The technique's id.
        technique: String,
        /// Units of work finished.
        done: u32,
        /// Units of work in all.
        total: u32,
        /// What a unit is (e.g. "rows").
        unit: &'static str,
    },
    /// The precompute was cancelled through the technique's [`BuildControl`](crate::BuildControl).
    #[error("technique `{technique}`: its precompute was cancelled (Ctrl-C in the workbench, Cancel in the viewer); it builds again once the BuildControl's cancel flag is cleared")]
    Cancelled {
        /// The technique's id.
        technique: String,
    },
}

/// Problems with a frame request (resolution, scene).
#[derive(Debug, Error)]
pub enum RenderError {
    #[error("resolution {width}x{height} is invalid: width and height must be 1 to {max} pixels")]
    /// Width or height out of range.
    BadResolution {
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
        /// Largest accepted edge.
        max: u32,
    },
    #[error(
        "a visibility of {got} values cannot be shown at {width}x{height}: render it at the \
         renderer's size (width x height values, row-major)"
    )]
    /// [`crate::Renderer::show_visibility`] was given a buffer of another size.
    VisibilitySize {
        /// Values given.
        got: usize,
        /// The renderer's width.
        width: u32,
        /// The renderer's height.
        height: u32,
    },
    #[error("invalid scene: {0}")]
    /// The scene, camera or light is invalid.
    Scene(String),
    #[error(transparent)]
    /// A GPU problem.
    Gpu(#[from] GpuError),
    #[error(transparent)]
    /// The technique failed.
    Technique(#[from] TechniqueError),
    #[error("{0}")]
    /// A failure in another process (the viewer's render worker), as its message there.
    Remote(String),
}
