//! Light kinds (issue 39) on the device, on `atty-square` at 64² with its light made each kind
//! (same centre and direction; disk, sphere and spot radius 0.5 = the square's half width; the
//! spot's cone 40 / 60 degrees; the sun 10 degrees wide so its penumbra is as wide as the
//! square's at this scale):
//! - the ray-traced exact answer (ray queries, core's `sample_light`) against the CPU ray cast
//!   (`AreaLight::sample`), within twice their summed sampling errors, per kind;
//! - each technique that supports a kind within a stated bound of the exact answer (measured
//!   value beside each), `hard` and an all-lit answer rejected by every soft bound;
//! - a kind a technique does not support: one line naming technique and kind, no GPU work.

use anyhow::{ensure, Result};
use softshadow_bench::{Bench, BenchOptions, RunSpec, Status};
use softshadow_core::{glam::Vec3, AreaLight, LightKind, ParamValue, Renderer, SceneGpu};
use softshadow_metrics::compare;
use softshadow_reference::{raycast, traced};

use crate::common::{all_lit_vs_exact, gpu, vs_exact};

const SCENE: &str = "atty-square";
const SIZE: u32 = 64;

/// The scene's light made `kind`.
fn light_of(kind: LightKind) -> Result<AreaLight> {
    let base = softshadow_scenes::load(SCENE)?.scene.light;
    Ok(AreaLight {
        kind,
        radius: 0.5 * base.width,
        cone_inner_degrees: 40.0,
        cone_outer_degrees: 60.0,
        angular_diameter_degrees: 10.0,
        ..base
    })
}

/// Mean of `error` over receiver pixels that `v` shadows.
fn mean_error(v: &[f32], error: &[f32], mask: &[bool]) -> f64 {
    let picked: Vec<f64> = (0..v.len())
        .filter(|&i| mask[i] && v[i] < 1.0)
        .map(|i| error[i] as f64)
        .collect();
    picked.iter().sum::<f64>() / picked.len().max(1) as f64
}

/// Per kind: the 32 x 32 ray-traced answer within twice the summed sampling errors of the
/// 16 x 16 CPU ray cast. Measured (mae_shadowed / twice the summed error): rect 0.0046 / 0.0199,
/// disk 0.0046 / 0.0201, sphere 0.0045 / 0.0190, spot 0.0046 / 0.0201, sun 0.0025 / 0.0111.
#[test]
fn the_ray_traced_answer_agrees_with_the_ray_cast_for_every_kind() -> Result<()> {
    let gpu = gpu()?;
    let mut scene = softshadow_scenes::load(SCENE)?.scene;
    let scene_gpu = SceneGpu::upload(&gpu, &scene);
    let mut renderer = Renderer::new(&gpu, SIZE, SIZE)?;
    let mut hard = softshadow::hard::Hard::new(&gpu, Default::default())?;
    renderer.render(&scene_gpu, &scene.camera, &scene.light, &mut hard, None)?;
    let positions = renderer.read_world_positions()?;
    let mask = renderer.read_receiver_mask()?;
    for kind in LightKind::ALL {
        scene.light = light_of(kind)?;
        let (cast, cast_error) = raycast::visibility_image_and_error(&scene, &positions, &mask, 16);
        let (rt, rt_error) =
            traced::visibility_image_and_error(&gpu, &scene, &positions, &mask, 32)?;
        let summed = mean_error(&cast, &cast_error, &mask) + mean_error(&rt, &rt_error, &mask);
        let report = compare(&cast, &rt, &mask)?;
        let shadowed = (0..cast.len())
            .filter(|&i| mask[i] && cast[i] < 1.0)
            .count();
        eprintln!(
            "{kind}: ray cast vs traced mae_shadowed {:.4}, twice the summed error {:.4}, {shadowed} shadowed pixels",
            report.mae_shadowed,
            2.0 * summed
        );
        ensure!(shadowed > 50, "{kind}: only {shadowed} shadowed pixels");
        ensure!(
            report.mae_shadowed <= 2.0 * summed,
            "{kind}: ray cast vs ray-traced mae_shadowed {:.4} over twice the summed sampling error {:.4}",
            report.mae_shadowed,
            2.0 * summed
        );
    }
    Ok(())
}

/// A bench lit by `light`, measuring against the exact answer (32 x 32 ray-traced, or the
/// 16 x 16 ray cast), one frame per run. A bench per light: it keeps one exact answer per scene.
fn bench_lit_by(light: AreaLight) -> Result<Bench> {
    let mut bench = Bench::new(
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
            ..Default::default()
        },
    )?;
    bench.set_view(None, Some(light));
    Ok(bench)
}

fn spec(technique: &str) -> RunSpec {
    RunSpec {
        scene: SCENE.into(),
        technique: technique.into(),
        params: Vec::new(),
        width: SIZE,
        height: SIZE,
        path: None,
    }
}

/// Bounds on mae_shadowed against the exact answer per technique and kind, at defaults, 64²,
/// with the value measured beside each (`None`: the kind is not supported).
const BOUNDS: &[(&str, [Option<(f64, f64)>; 5])] = &[
    // (bound, measured) for rect, disk, sphere, spot, sun; the bounds are about 1.55 times the
    // measured values, as the crates' own (raytraced's atty-square bound is 0.134 for 0.0860,
    // the rect value here: the rect light renders as before). `hard` measured 0.206 (rect),
    // 0.185 (disk, spot), 0.156 (sphere); all lit 0.434, 0.451, 0.326, 0.451, 0.749 (sun).
    (
        "raytraced",
        [
            Some((0.134, 0.0860)),
            Some((0.128, 0.0821)),
            Some((0.136, 0.0877)),
            Some((0.128, 0.0821)),
            Some((0.083, 0.0531)),
        ],
    ),
    (
        "reference",
        [
            Some((0.01, 0.0016)),
            Some((0.01, 0.0021)),
            None,
            Some((0.01, 0.0021)),
            None,
        ],
    ),
];

/// Each supporting technique within its bound of the exact answer per kind; `hard` (a point at
/// the light's centre) and an all-lit answer outside every bound.
#[test]
fn supporting_techniques_stay_within_their_bounds_per_kind() -> Result<()> {
    let mut failures: Vec<String> = Vec::new();
    for (k, kind) in LightKind::ALL.into_iter().enumerate() {
        let mut bench = bench_lit_by(light_of(kind)?)?;
        let run = bench.run(0, &spec("hard"), tempfile::tempdir()?.path());
        // `hard` supports every kind (the sun through core's cascades).
        ensure!(run.status == Status::Ok, "hard / {kind}: {}", run.message);
        let hard = Some(vs_exact(&run)?.mae_shadowed);
        let mut all_lit = None;
        for (technique, bounds) in BOUNDS {
            let run = bench.run(0, &spec(technique), tempfile::tempdir()?.path());
            let Some((bound, measured)) = bounds[k] else {
                ensure!(
                    run.status == Status::Unsupported
                        && run.message.contains(technique)
                        && run.message.contains(kind.name()),
                    "{technique} / {kind}: {:?} {}",
                    run.status,
                    run.message
                );
                continue;
            };
            ensure!(
                run.status == Status::Ok,
                "{technique} / {kind}: {}",
                run.message
            );
            let mae = vs_exact(&run)?.mae_shadowed;
            let lit = *all_lit.get_or_insert(all_lit_vs_exact(&run)?.mae_shadowed);
            eprintln!("{technique} / {kind}: mae_shadowed {mae:.4} (bound {bound}, measured {measured}); hard {hard:?}, all lit {lit:.4}");
            if mae > bound {
                failures.push(format!(
                    "{technique} / {kind}: {mae:.4} over its bound {bound}"
                ));
            }
            if lit <= bound {
                failures.push(format!(
                    "{technique} / {kind}: all lit ({lit:.4}) passes {bound}"
                ));
            }
            if hard.is_some_and(|hard| hard <= bound) {
                failures.push(format!(
                    "{technique} / {kind}: hard ({hard:?}) passes {bound}"
                ));
            }
        }
    }
    ensure!(failures.is_empty(), "{}", failures.join("; "));
    Ok(())
}

/// A run of a kind its technique does not support: `unsupported` with one line naming technique
/// and kind, and no GPU work (no timing, no pass run, no error measured).
#[test]
fn an_unsupported_kind_is_refused_without_gpu_work() -> Result<()> {
    let mut sun = light_of(LightKind::Sun)?;
    sun.direction = Vec3::new(0.2, -1.0, 0.1).normalize();
    let mut bench = bench_lit_by(sun)?;
    let run = bench.run(3, &spec("reference"), tempfile::tempdir()?.path());
    ensure!(run.status == Status::Unsupported, "{:?}", run.status);
    ensure!(
        !run.message.contains('\n')
            && run.message.contains("`reference`")
            && run.message.contains("`sun`"),
        "{}",
        run.message
    );
    ensure!(run.light_kind.as_deref() == Some("sun"));
    ensure!(run.timing.is_none() && run.passes_run.is_empty() && run.error.is_none());
    Ok(())
}
