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
use softshadow_core::{
    expectations::Expect, AreaLight, LightKind, ParamValue, Renderer, SceneGpu, TechniqueInfo,
    COST_FLOOR_TECHNIQUE, LIGHT_KIND_SCENE,
};
use softshadow_metrics::compare;
use softshadow_reference::{raycast, traced};

use crate::common::{all_lit_vs_exact, gpu, vs_exact};

const SCENE: &str = LIGHT_KIND_SCENE;
const SIZE: u32 = 64;

/// The scene's light made `kind` (`AreaLight::as_kind`, what the crates' bounds take).
fn light_of(kind: LightKind) -> Result<AreaLight> {
    Ok(softshadow_scenes::load(SCENE)?.scene.light.as_kind(kind))
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

/// The bound a technique states for `kind` ([`TechniqueInfo::light_kind_bounds`]).
fn bound_for(info: &TechniqueInfo, kind: LightKind) -> Option<(f64, f64)> {
    info.light_kind_bounds
        .iter()
        .find(|(k, _)| *k == kind)
        .and_then(|(_, expect)| match expect {
            Expect::AtMost {
                bound, measured, ..
            } => Some((*bound, *measured)),
            _ => None,
        })
}

/// Each technique within the bound its crate states per kind (`light_kind_bounds`) of the exact
/// answer; `hard` (a point at the light's centre) and an all-lit answer outside every bound; a
/// kind it does not support refused naming technique and kind; and every soft technique that
/// supports a kind other than `rect` states a bound for it.
#[test]
fn techniques_stay_within_their_bounds_per_kind() -> Result<()> {
    let registry = softshadow::registry();
    let mut failures: Vec<String> = Vec::new();
    for info in registry.iter().filter(|i| i.id != COST_FLOOR_TECHNIQUE) {
        for kind in info.light_kinds.supported() {
            if kind != LightKind::Rect && bound_for(info, kind).is_none() {
                failures.push(format!(
                    "{} supports `{kind}` but states no bound for it",
                    info.id
                ));
            }
        }
    }
    for kind in LightKind::ALL {
        let mut bench = bench_lit_by(light_of(kind)?)?;
        let run = bench.run(0, &spec(COST_FLOOR_TECHNIQUE), tempfile::tempdir()?.path());
        // `hard` supports every kind (the sun through core's cascades).
        ensure!(run.status == Status::Ok, "hard / {kind}: {}", run.message);
        let hard = Some(vs_exact(&run)?.mae_shadowed);
        let mut all_lit = None;
        for info in registry.iter().filter(|i| !i.light_kind_bounds.is_empty()) {
            let technique = info.id.as_ref();
            let run = bench.run(0, &spec(technique), tempfile::tempdir()?.path());
            let Some((bound, measured)) = bound_for(info, kind) else {
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
    let mut bench = bench_lit_by(light_of(LightKind::Sun)?)?;
    let run = bench.run(3, &spec("ssm"), tempfile::tempdir()?.path());
    ensure!(run.status == Status::Unsupported, "{:?}", run.status);
    ensure!(
        !run.message.contains('\n')
            && run.message.contains("`ssm`")
            && run.message.contains("`sun`"),
        "{}",
        run.message
    );
    ensure!(run.light_kind.as_deref() == Some("sun"));
    ensure!(run.timing.is_none() && run.passes_run.is_empty() && run.error.is_none());
    Ok(())
}
