//! Helpers shared by the GPU test modules in this folder.

use anyhow::{ensure, Context, Result};
use softshadow_bench::{
    motion::{read_frames, FrameRecord},
    results::Run,
    Bench, BenchOptions, RunSpec, Status,
};
use softshadow_core::{glam::Vec3, scene::Fnv1a, Gpu, ParamValue, Scene};
use softshadow_metrics::ErrorReport;

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

/// The exact visibility at `positions`: the closed form where the casters are rectangles parallel
/// to the light, else the CPU ray cast with `samples_per_axis`² light samples (as the benchmark's
/// `error.vs_exact`); 1.0 off the receivers.
pub fn exact_visibility(
    scene: &Scene,
    positions: &[Option<Vec3>],
    receiver: &[bool],
    samples_per_axis: u32,
) -> Vec<f32> {
    softshadow_reference::exact_visibility(scene, positions, receiver, samples_per_axis).0
}

/// `error.vs_exact` of a run made with the error metrics and an exact ground truth.
pub fn vs_exact(run: &Run) -> Result<&ErrorReport> {
    run.error
        .as_ref()
        .context("no error block")?
        .vs_exact
        .as_ref()
        .context("no vs_exact block")
}

/// `error.all_lit_vs_exact`: the error "no shadow at all" (V = 1) would have on the same pixels.
pub fn all_lit_vs_exact(run: &Run) -> Result<ErrorReport> {
    run.error
        .as_ref()
        .context("no error block")?
        .all_lit_vs_exact
        .clone()
        .context("no all_lit_vs_exact block")
}

/// A bench measuring against the exact answer (closed form where the casters are rectangles
/// parallel to the light, else the 32 x 32 ray-traced answer, or a 16 x 16 CPU ray cast on a
/// device without ray queries), one frame per run; the yardstick reference
/// (`error.report`) is not used by the tests that take this, so it is small (4 x 4 at 256^2).
pub fn exact_bench() -> Result<Bench> {
    Ok(Bench::new(
        gpu()?,
        softshadow::registry(),
        BenchOptions {
            frames: 1,
            warmup: 0,
            error: true,
            reference_params: vec![
                ("samples_per_axis".into(), ParamValue::Int(4)),
                ("shadow_map_size".into(), ParamValue::Int(256)),
            ],
            images: false,
            exact_samples_per_axis: Some(16),
            camera_only: false,
            reference_cache: None,
            ..Default::default()
        },
    )?)
}

/// `technique` on `scene` at `size`^2 once per parameter list in `variants` (texts as on the
/// command line), each checked as in [`run_checked`]: the error against the exact answer of each.
pub fn exact_errors(
    bench: &mut Bench,
    scene: &str,
    technique: &str,
    variants: &[&[&str]],
    size: u32,
) -> Result<Vec<ErrorReport>> {
    let mut reports = Vec::new();
    for params in variants {
        let texts: Vec<String> = params.iter().map(|s| s.to_string()).collect();
        let spec = RunSpec {
            scene: scene.into(),
            technique: technique.into(),
            params: softshadow_bench::parse_params(bench.registry(), technique, &texts)?,
            width: size,
            height: size,
            path: None,
        };
        let run = run_checked(bench, &spec)?;
        let report = vs_exact(&run)?.clone();
        eprintln!(
            "{scene} {technique} {params:?}: mae_shadowed {:.4}, mae_all {:.4}, max_abs {:.4}",
            report.mae_shadowed, report.mae_all, report.max_abs
        );
        reports.push(report);
    }
    Ok(reports)
}

/// Runs `spec` along the bench's path; the run and its per-frame records.
pub fn run_path(bench: &mut Bench, spec: &RunSpec) -> Result<(Run, Vec<FrameRecord>)> {
    let dir = tempfile::tempdir()?;
    let run = bench.run(0, spec, dir.path());
    ensure!(
        run.status == Status::Ok,
        "{} {:?} along the path failed: {}",
        spec.technique,
        spec.params,
        run.message
    );
    let motion = run.motion.as_ref().context("a run along a path")?;
    let frames = read_frames(&dir.path().join(&motion.frames_file))?;
    ensure!(frames.len() == motion.frames as usize);
    Ok((run, frames))
}

/// FNV-1a over the bits of every value (core's cache-key hasher): an image's checksum.
pub fn checksum(v: &[f32]) -> u64 {
    let mut hasher = Fnv1a::default();
    hasher.write_f32s(v);
    hasher.finish()
}
