//! Helpers shared by the GPU test modules in this folder.

use anyhow::{ensure, Context, Result};
use softshadow_bench::{results::Run, Bench, RunSpec, Status};
use softshadow_core::{glam::Vec3, Gpu, Scene};

/// The GPU, or an error that says what to install (tests fail, never skip, without one).
/// Also points the PDSM disk cache at a folder of this test process, so tests neither read a
/// user's cache nor leave files in it.
pub fn gpu() -> Result<Gpu> {
    // Once per process: tests run on several threads, and the variable is set before any of
    // them can read it (every test gets its GPU through here first).
    static CACHE_DIR: std::sync::Once = std::sync::Once::new();
    CACHE_DIR.call_once(|| {
        if std::env::var_os("SOFTSHADOW_CACHE_DIR").is_none() {
            let dir =
                std::env::temp_dir().join(format!("softshadow-test-cache-{}", std::process::id()));
            std::env::set_var("SOFTSHADOW_CACHE_DIR", dir);
        }
        // A wgpu validation error panics in the call that caused it, failing its test
        // (docs/STABILITY.md, "Validation errors fail tests").
        std::env::set_var("SOFTSHADOW_GPU_ERRORS", "panic");
    });
    Gpu::new_headless().context(
        "these tests need a GPU adapter: install Mesa's lavapipe (apt-get install -y mesa-vulkan-drivers)",
    )
}

/// Runs `spec` and fails unless it finished with status ok and finite V in [0, 1] everywhere.
pub fn run_checked(bench: &mut Bench, spec: &RunSpec) -> Result<Run> {
    let dir = tempfile::tempdir()?;
    let run = bench.run(0, spec, dir.path());
    let what = format!("{} / {} {:?}", spec.scene, spec.technique, spec.params);
    ensure!(run.status == Status::Ok, "{what} failed: {}", run.message);
    let stability = run.stability.context("stability")?;
    ensure!(
        stability.nan == 0 && stability.inf == 0 && stability.out_of_range == 0,
        "{what}: {stability:?}"
    );
    Ok(run)
}

/// `error.mae_shadowed` of a run made with the error metrics on.
pub fn mae_shadowed(run: &Run) -> f64 {
    run.error
        .as_ref()
        .expect("error metrics requested")
        .report
        .mae_shadowed
}

/// The exact visibility (closed form) at `positions` of a scene whose casters are rectangles
/// parallel to the light, 1.0 off the receivers.
pub fn closed_form(
    scene: &Scene,
    positions: &[Option<Vec3>],
    receiver: &[bool],
) -> Result<Vec<f32>> {
    softshadow_reference::exact::visibility_image(scene, positions, receiver)
        .context("the casters are not rectangles parallel to the light: no closed form")
}
