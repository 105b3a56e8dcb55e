//! The soft-shadow workbench's interactive viewer (`workbench view`): pick a scene and a
//! technique, move the light and the camera, turn the parameters, and see at once what the
//! technique costs on the GPU (per-pass timestamp queries, rolling medians) and how far it is from
//! the progressively accumulated reference.
//!
//! - [`app::ViewerApp`]: state, panels and one GPU frame per egui pass; driven by the window and
//!   by the egui_kittest tests alike.
//! - [`window::run`]: winit + egui-winit + egui-wgpu on the renderer's own wgpu device; the
//!   renderer's outputs reach egui as native textures (no CPU copy).
//! - [`display`]: the colour-mapping passes (`shaders/viewer/`): shaded, visibility, reference,
//!   false-colour difference, split screen, technique debug views.
//! - [`tradeoff`]: error against time, the Pareto front, export as a benchmark sweep file.
//! - [`state`]: save / load of the viewer state (JSON).
//!
//! Reads: scenes (softshadow-scenes), techniques (the bench registry), the reference, metrics.

pub mod app;
pub mod display;
mod error;
pub mod orbit;
pub mod state;
pub mod timing;
pub mod tradeoff;
pub mod window;

use softshadow_core::{
    shader::{DefValue, ShaderSpec},
    shader_file,
};

pub use app::{ViewerApp, ViewerOptions, WorkerCommand};
pub use display::ViewMode;
pub use error::ViewerError;
pub use state::ViewerState;
pub use window::{run, ViewOptions, ViewSummary};

/// The render worker's side of [`ViewerOptions::worker`]: a program the viewer starts with it
/// (`workbench view-worker`) calls this with the viewer's registry, which serves one technique's
/// frames over stdin and stdout until the viewer closes them or kills the process
/// (docs/ARCHITECTURE.md, "The viewer's render worker"). Returns the process's exit code.
pub fn serve_render_worker(registry: &softshadow_core::Registry) -> std::process::ExitCode {
    app::serve_worker(registry)
}

/// Memory hints of the viewer's device: small sub-allocation blocks, and blocks of their own for
/// large buffers, so that a dropped scene's buffers are handed back to the driver at once.
/// wgpu's default (`Performance`) kept the last 64-128 MiB block of lavapipe's one memory type
/// reserved after `polycount-1m` was left, with the pages the scene had touched still resident
/// (docs/DEVICES.md, "Lavapipe's one memory type").
pub const MEMORY_HINTS: softshadow_core::wgpu::MemoryHints =
    softshadow_core::wgpu::MemoryHints::MemoryUsage;

/// The viewer's shaders (validated with every other crate's by the root `tests/shaders.rs`).
pub const SHADERS: &[ShaderSpec] = &[
    ShaderSpec {
        path: "viewer/display.wgsl",
        source: shader_file!("viewer/display.wgsl").1,
        permutations: &[&[]],
    },
    ShaderSpec {
        path: "viewer/debug_view.wgsl",
        source: shader_file!("viewer/debug_view.wgsl").1,
        // `#ifdef DEPTH`: defined for depth textures, absent for float ones.
        permutations: &[&[("DEPTH", DefValue::Bool(true))], &[]],
    },
    ShaderSpec {
        path: "viewer/debug_range.wgsl",
        source: shader_file!("viewer/debug_range.wgsl").1,
        // `#ifdef DEPTH`, as debug_view.wgsl.
        permutations: &[&[("DEPTH", DefValue::Bool(true))], &[]],
    },
];

/// The viewer's uniform structs with the WGSL structs they mirror, for the layout test in
/// tests/shaders.rs (`softshadow_core::shader::uniform_layout`).
#[doc(hidden)]
pub fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    display::uniform_mirrors()
}

/// An egui-wgpu render state on an existing [`softshadow_core::Gpu`], drawing to
/// `target_format`: what egui_kittest's wgpu renderer needs so that the viewer's native textures
/// and the test's egui live on one device.
pub fn render_state(
    gpu: &softshadow_core::Gpu,
    target_format: softshadow_core::wgpu::TextureFormat,
) -> egui_wgpu::RenderState {
    let renderer = egui_wgpu::Renderer::new(
        &gpu.device,
        target_format,
        egui_wgpu::RendererOptions::PREDICTABLE,
    );
    egui_wgpu::RenderState {
        adapter: gpu.adapter.clone(),
        available_adapters: vec![gpu.adapter.clone()],
        // A viewer's Gpu comes from `Gpu::new_headless` / `from_adapter`, which keep the instance;
        // a host context has none, and egui only needs one to enumerate adapters.
        instance: gpu.instance.clone().unwrap_or_default(),
        device: gpu.device.clone(),
        queue: gpu.queue.clone(),
        target_format,
        renderer: std::sync::Arc::new(egui::mutex::RwLock::new(renderer)),
    }
}
