//! Errors of the viewer. Messages say what to do.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum ViewerError {
    #[error(transparent)]
    Gpu(#[from] softshadow_core::GpuError),
    #[error(transparent)]
    Render(#[from] softshadow_core::RenderError),
    #[error(transparent)]
    Technique(#[from] softshadow_core::TechniqueError),
    #[error(transparent)]
    Param(#[from] softshadow_core::ParamError),
    #[error(transparent)]
    Scene(#[from] softshadow_scenes::SceneError),
    #[error(transparent)]
    Bench(#[from] softshadow_bench::BenchError),
    #[error(transparent)]
    Registry(#[from] softshadow_core::RegistryError),
    #[error("the viewer was given no technique to show: pass a registry with at least one (`softshadow::registry()`)")]
    NoTechnique,
    #[error(transparent)]
    Metrics(#[from] softshadow_metrics::MetricsError),
    #[error("viewer state `{path}`: {message}")]
    State { path: String, message: String },
    #[error("cannot open a window: {0}. The viewer needs a display: run it under X11/Wayland, or under `xvfb-run` (apt-get install xvfb) on a machine without one")]
    Window(String),
    #[error("cannot write the screenshot `{path}`: {message}")]
    Screenshot { path: String, message: String },
    #[error("cannot write `{path}`: {message}")]
    Write { path: String, message: String },
    #[error("{0} (see `workbench list` for techniques and parameter ranges)")]
    TechniqueStart(String),
    #[error("--frames must be at least 1")]
    NoFrames,
}
