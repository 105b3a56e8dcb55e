//! `raytraced` (ray queries and a denoiser): raw rays converge to the exact answer, the denoiser
//! lowers the error of one ray per pixel by a measured factor, temporal accumulation lowers it
//! further on a still camera and restarts when the light moves, a moved dynamic instance moves
//! its shadow, and a device without ray queries gets a message saying what to install. Images
//! are 64² (lavapipe traces about 0.5-1 M rays/s). Measured values are in the comments and in
//! docs/TECHNIQUES.md ("raytraced").

use anyhow::{ensure, Context, Result};
use softshadow::raytraced::{Raytraced, RaytracedSettings};
use softshadow_core::{
    accel::RAY_QUERY, glam::Vec3, Gpu, Renderer, Scene, SceneGpu, ShadowTechnique, TechniqueError,
};
use softshadow_metrics::compare;

use crate::common::gpu;

const SIZE: u32 = 64;

/// A renderer over `scene` and the exact answer on its receivers (closed form where the scene
/// has one, else a 16 x 16 CPU ray cast).
struct Case {
    scene: Scene,
    scene_gpu: SceneGpu,
    renderer: Renderer,
    exact: Vec<f32>,
    mask: Vec<bool>,
}

impl Case {
    fn new(gpu: &Gpu, name: &str) -> Result<Self> {
        let scene = softshadow_scenes::load(name)?.scene;
        Self::from_scene(gpu, scene)
    }

    fn from_scene(gpu: &Gpu, scene: Scene) -> Result<Self> {
        let scene_gpu = SceneGpu::upload(gpu, &scene);
        let mut renderer = Renderer::new(gpu, SIZE, SIZE)?;
        // One frame of `hard` fills the G-buffer the exact answer is computed at.
        let mut hard = softshadow::hard::Hard::new(gpu, Default::default())?;
        renderer.render(&scene_gpu, &scene.camera, &scene.light, &mut hard, None)?;
        let positions = renderer.read_world_positions()?;
        let mask = renderer.read_receiver_mask()?;
        let (exact, _) = softshadow_reference::exact_visibility(&scene, &positions, &mask, 16);
        Ok(Self {
            scene,
            scene_gpu,
            renderer,
            exact,
            mask,
        })
    }

    /// Renders one frame and returns its mae_shadowed against the exact answer.
    fn frame(&mut self, technique: &mut Raytraced) -> Result<f64> {
        self.renderer.render(
            &self.scene_gpu,
            &self.scene.camera,
            &self.scene.light,
            technique,
            None,
        )?;
        let v = self.renderer.read_visibility()?;
        ensure!(
            v.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)),
            "visibility out of [0, 1]"
        );
        Ok(compare(&v, &self.exact, &self.mask)?.mae_shadowed)
    }
}

fn technique(gpu: &Gpu, rays: u32, temporal: bool, spatial: bool) -> Result<Raytraced> {
    Ok(Raytraced::new(
        gpu,
        RaytracedSettings {
            rays_per_pixel: rays,
            temporal,
            spatial,
            max_history: 1024,
            ..Default::default()
        },
    )?)
}

fn history_frames(t: &Raytraced) -> f64 {
    t.stats().get("history_frames").copied().unwrap_or(0.0)
}

/// With the denoiser off, more rays per pixel lower the error, and the running mean of 16 rays
/// over 32 frames on a still camera (512 rays: plain Monte Carlo over the light, no filter) is
/// within 0.01 of the closed form on atty-square and on the stiff rectangle case
/// `stiff-wide-light`, where `hard` is far off.
#[test]
fn raw_rays_converge_to_the_exact_answer() -> Result<()> {
    let gpu = gpu()?;
    for name in ["atty-square", "stiff-wide-light"] {
        let mut case = Case::new(&gpu, name)?;
        let raw_1 = case.frame(&mut technique(&gpu, 1, false, false)?)?;
        let raw_16 = case.frame(&mut technique(&gpu, 16, false, false)?)?;
        let mut accumulating = technique(&gpu, 16, true, false)?;
        let mut accumulated = 1.0;
        for _ in 0..32 {
            accumulated = case.frame(&mut accumulating)?;
        }
        eprintln!("{name}: raw 1 ray {raw_1:.4}, raw 16 rays {raw_16:.4}, 16 x 32 frames {accumulated:.4}");
        ensure!(
            raw_16 < raw_1,
            "{name}: 16 rays {raw_16:.4} not below 1 ray {raw_1:.4}"
        );
        ensure!(
            accumulated <= 0.01,
            "{name}: 512 rays per pixel are {accumulated:.4} off the exact answer"
        );
        ensure!(
            history_frames(&accumulating) == 32.0,
            "history not accumulated"
        );
    }
    Ok(())
}

/// One ray per pixel on atty-square: the spatial filter lowers the raw error by at least 2x,
/// and 16 frames of temporal accumulation on a still camera lower it further.
#[test]
fn the_denoiser_lowers_the_error_of_one_ray_per_pixel() -> Result<()> {
    let gpu = gpu()?;
    let mut case = Case::new(&gpu, "atty-square")?;
    let raw = case.frame(&mut technique(&gpu, 1, false, false)?)?;
    let spatial = case.frame(&mut technique(&gpu, 1, false, true)?)?;
    let mut both = technique(&gpu, 1, true, true)?;
    let mut spatio_temporal = 1.0;
    for _ in 0..16 {
        spatio_temporal = case.frame(&mut both)?;
    }
    eprintln!("1 ray: raw {raw:.4}, spatial {spatial:.4}, spatio-temporal (16 frames) {spatio_temporal:.4}");
    ensure!(
        spatial * 2.0 <= raw,
        "spatial filter: {spatial:.4} against raw {raw:.4}, less than 2x lower"
    );
    ensure!(
        spatio_temporal < spatial,
        "temporal accumulation {spatio_temporal:.4} not below spatial only {spatial:.4}"
    );
    Ok(())
}

/// The history restarts when the light moves (no stale shadow is averaged in): the frame after
/// the move has a history of one frame and its error is that of a first frame, and the error
/// falls again as frames accumulate (the lag: frames to get back within 1.5x of the converged
/// error).
#[test]
fn temporal_accumulation_restarts_when_the_light_moves() -> Result<()> {
    let gpu = gpu()?;
    let mut case = Case::new(&gpu, "atty-square")?;
    let mut t = technique(&gpu, 1, true, true)?;
    for _ in 0..8 {
        case.frame(&mut t)?;
    }
    ensure!(history_frames(&t) == 8.0, "history {}", history_frames(&t));
    // Move the light sideways, and recompute the exact answer for it.
    case.scene.light.center += Vec3::new(0.3, 0.0, 0.1);
    let positions = case.renderer.read_world_positions()?;
    case.exact = softshadow_reference::exact_visibility(&case.scene, &positions, &case.mask, 16).0;
    let first = case.frame(&mut t)?;
    ensure!(
        history_frames(&t) == 1.0,
        "history not reset by the light's move: {}",
        history_frames(&t)
    );
    let mut errors = vec![first];
    for _ in 0..15 {
        errors.push(case.frame(&mut t)?);
    }
    let converged = *errors.last().context("frames")?;
    let lag = errors
        .iter()
        .position(|e| *e <= 1.5 * converged)
        .unwrap_or(errors.len());
    eprintln!("after the light moved: errors {errors:.4?}; lag {lag} frames to within 1.5x");
    ensure!(
        converged < first,
        "no convergence after the move: first {first:.4}, 16th {converged:.4}"
    );
    Ok(())
}

/// A dynamic instance that moves: the acceleration structure follows (the dynamic BLAS is
/// rebuilt, the static one kept), so the shadow is the new one: the image after the move matches
/// the exact answer of the moved scene, not of the old one.
#[test]
fn a_moved_dynamic_instance_moves_its_ray_traced_shadow() -> Result<()> {
    let gpu = gpu()?;
    let mut scene = softshadow_scenes::load("atty-square")?.scene;
    let caster = scene
        .instances
        .iter()
        .position(|i| i.casts_shadow && !i.receives_shadow)
        .context("atty-square has a caster that is not a receiver")?;
    scene.instances[caster].dynamic = true;
    let mut case = Case::from_scene(&gpu, scene.clone())?;
    let mut t = technique(&gpu, 16, false, false)?;
    let before = case.frame(&mut t)?;
    let old_exact = case.exact.clone();
    // Move the caster sideways by a third of the scene, re-upload, recompute the exact answer.
    let shift = 0.5 * (case.scene_gpu.caster_bounds.max - case.scene_gpu.caster_bounds.min).x;
    scene.instances[caster].transform =
        softshadow_core::glam::Mat4::from_translation(Vec3::new(shift, 0.0, 0.0))
            * scene.instances[caster].transform;
    case.scene = scene;
    case.scene_gpu = SceneGpu::upload(&gpu, &case.scene);
    let positions = case.renderer.read_world_positions()?;
    case.exact = softshadow_reference::exact_visibility(&case.scene, &positions, &case.mask, 16).0;
    let shadowed = case
        .exact
        .iter()
        .zip(&case.mask)
        .filter(|(v, m)| **m && **v < 1.0)
        .count();
    ensure!(
        shadowed > 50,
        "the moved shadow is off screen ({shadowed} pixels)"
    );
    let after = case.frame(&mut t)?;
    let built = t.stats().get("accel_structures_built").copied();
    let v = case.renderer.read_visibility()?;
    let vs_old = compare(&v, &old_exact, &case.mask)?.mae_all;
    let vs_new = compare(&v, &case.exact, &case.mask)?.mae_all;
    eprintln!("before {before:.4}, after {after:.4}; mae_all vs the old shadow {vs_old:.4}, vs the new {vs_new:.4}; built {built:?}");
    // Two: the dynamic BLAS and the TLAS (the static BLAS kept).
    ensure!(
        built == Some(2.0),
        "structures built after the move: {built:?}"
    );
    ensure!(
        vs_new * 4.0 < vs_old,
        "the image is not the moved shadow: {vs_new:.4} vs the new, {vs_old:.4} vs the old"
    );
    Ok(())
}

/// A device without ray queries: the technique is listed as unavailable with what to install,
/// and creating it fails with that message (never a panic, never another technique instead).
#[test]
fn without_ray_queries_the_technique_says_what_to_install() -> Result<()> {
    let gpu = Gpu::new_headless_without(RAY_QUERY)?;
    ensure!(!gpu.has_ray_query(), "the device has ray queries");
    let info = softshadow::raytraced::info();
    let why = info
        .unavailable_on(gpu.features())
        .context("listed as available without ray queries")?;
    ensure!(why.contains("Mesa 24.1"), "{why}");
    let error = match Raytraced::new(&gpu, RaytracedSettings::default()) {
        Ok(_) => anyhow::bail!("created without ray queries"),
        Err(e) => e,
    };
    ensure!(
        matches!(error, TechniqueError::MissingFeatures { .. })
            && error.to_string().contains("Mesa 24.1"),
        "{error}"
    );
    // And the adapter's own device has them (this machine's lavapipe is Mesa 25).
    ensure!(
        info.unavailable_on(crate::common::gpu()?.features())
            .is_none(),
        "ray queries missing on the default device"
    );
    Ok(())
}

/// The ray-traced exact answer (`softshadow_reference::traced`) equals the closed form on
/// atty-square and two stiff rectangle cases within 1e-3 mean (over the receivers) at 32 x 32
/// samples per pixel. Measured: mae_all 0.0006, 0.0007, 0.0006 (mae_shadowed 0.0016, 0.0013,
/// 0.0021).
#[test]
fn the_ray_traced_reference_equals_the_closed_form() -> Result<()> {
    let gpu = gpu()?;
    for name in ["atty-square", "stiff-wide-light", "stiff-aspect-100"] {
        let case = Case::new(&gpu, name)?;
        let positions = case.renderer.read_world_positions()?;
        let traced = softshadow_reference::traced::visibility_image(
            &gpu,
            &case.scene,
            &positions,
            &case.mask,
            32,
        )?;
        let report = compare(&traced, &case.exact, &case.mask)?;
        eprintln!(
            "{name}: traced 32x32 vs closed form: mae_all {:.5}, mae_shadowed {:.5}, max_abs {:.4}",
            report.mae_all, report.mae_shadowed, report.max_abs
        );
        ensure!(
            report.mae_all <= 1e-3,
            "{name}: mean error {:.5} over 1e-3",
            report.mae_all
        );
    }
    Ok(())
}

/// Measures `raytraced` at its defaults on every stiff case and paper scene (the values its
/// info.rs states), with `hard` and all-lit beside it. Run by hand:
/// `cargo test --workspace --test gpu raytraced::measure -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement, not a check: the stiff suite checks the bounds"]
fn measure_the_expectation_values() -> Result<()> {
    use softshadow_bench::{RunSpec, Sweep};
    let mut bench = crate::common::exact_bench()?;
    let suite = Sweep::suite("stiff", bench.registry())?;
    let mut specs: Vec<RunSpec> = suite
        .runs
        .iter()
        .filter(|s| s.technique == softshadow::raytraced::ID || s.technique == "hard")
        .cloned()
        .collect();
    for scene in ["atty-square", "blob-floating:triangles=20000"] {
        for technique in [softshadow::raytraced::ID, "hard"] {
            specs.push(RunSpec {
                scene: scene.into(),
                technique: technique.into(),
                params: Default::default(),
                width: softshadow_core::expectations::EXPECTATION_SIZE,
                height: softshadow_core::expectations::EXPECTATION_SIZE,
                path: None,
            });
        }
    }
    for spec in &specs {
        let run = crate::common::run_checked(&mut bench, spec)?;
        let report = crate::common::vs_exact(&run)?;
        let all_lit = crate::common::all_lit_vs_exact(&run)?;
        eprintln!(
            "MEASURED {} {} mae_shadowed {:.4} max_abs {:.4} all_lit {:.4} {:.4}",
            spec.technique,
            spec.scene,
            report.mae_shadowed,
            report.max_abs,
            all_lit.mae_shadowed,
            all_lit.max_abs
        );
    }
    Ok(())
}

/// Acceleration-structure build time against triangle count and shadow rays per second on this
/// device (docs/TECHNIQUES.md, `raytraced`). Run by hand:
/// `cargo test --release --workspace --test gpu raytraced::measure_speed -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement of speed, not a check (no time is asserted)"]
fn measure_speed() -> Result<()> {
    let gpu = gpu()?;
    for triangles in [1_000, 10_000, 100_000, 1_000_000] {
        let scene = softshadow_scenes::load(&format!("blob-floating:triangles={triangles}"))?.scene;
        let scene_gpu = SceneGpu::upload(&gpu, &scene);
        gpu.wait_idle()?;
        let mut times = Vec::new();
        for _ in 0..3 {
            let mut accel = softshadow_core::SceneAccel::new();
            let start = std::time::Instant::now();
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            accel.build(&gpu, &mut encoder, &scene_gpu)?;
            gpu.queue.submit([encoder.finish()]);
            gpu.wait_idle()?;
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        // Rays: 64² ground points under the blob, 16 x 16 samples each (1 M rays).
        let mut renderer = Renderer::new(&gpu, 64, 64)?;
        let mut hard = softshadow::hard::Hard::new(&gpu, Default::default())?;
        renderer.render(&scene_gpu, &scene.camera, &scene.light, &mut hard, None)?;
        let positions = renderer.read_world_positions()?;
        let mask = renderer.read_receiver_mask()?;
        let start = std::time::Instant::now();
        softshadow_reference::traced::visibility_image(&gpu, &scene, &positions, &mask, 16)?;
        let seconds = start.elapsed().as_secs_f64();
        let rays = mask.iter().filter(|m| **m).count() as f64 * 256.0;
        eprintln!(
            "SPEED {} caster triangles: BLAS+TLAS build median {:.1} ms (of {times:.1?}); {:.2} M rays in {seconds:.2} s with the build: {:.2} M rays/s",
            scene_gpu.caster_triangle_count,
            times[1],
            rays / 1e6,
            rays / 1e6 / (seconds - times[1] / 1e3).max(1e-3)
        );
    }
    Ok(())
}
