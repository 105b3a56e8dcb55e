//! Issue 6: every registered technique on every stiff case (finite output in [0, 1], status ok,
//! error against the exact ground truth within the bound its crate states, and every bound
//! rejecting the deliberately wrong answers "no shadow" and `hard`), and convergence: the
//! reference towards the exact answer as its sample count grows, every technique towards `hard`
//! as the light shrinks.
//!
//! Small images (64^2, the expectation size), an 8 x 8 yardstick reference and the ray-traced
//! exact answer (32 x 32; a 16 x 16 CPU ray cast without ray queries)
//! keep this near a minute on lavapipe; techniques, the `reference` technique included (32 x 32),
//! run with their defaults. `workbench bench --suite stiff` makes the same runs and verdicts.

use crate::common::{gpu, run_checked, vs_exact};
use anyhow::{bail, ensure, Context, Result};
use softshadow_bench::{expectations, results::Run, Bench, BenchOptions, RunSpec, Status, Sweep};
use softshadow_core::{
    expectations::EXPECTATION_SIZE, ParamValue, Renderer, SceneGpu, COST_FLOOR_TECHNIQUE,
};
use softshadow_scenes::stiff;

const SIZE: u32 = EXPECTATION_SIZE;

fn bench(reference_samples: i64) -> Result<Bench> {
    Ok(Bench::new(
        gpu()?,
        softshadow::registry(),
        BenchOptions {
            frames: 1,
            warmup: 0,
            error: true,
            reference_params: vec![
                (
                    "samples_per_axis".into(),
                    ParamValue::Int(reference_samples),
                ),
                ("shadow_map_size".into(), ParamValue::Int(512)),
            ],
            images: false,
            exact_samples_per_axis: Some(16),
            camera_only: false,
            reference_cache: None,
            ..Default::default()
        },
    )?)
}

/// Every registered technique on every stiff case, held against the bound its crate states
/// (`TechniqueInfo::expectations`: the case by name, or its class's rule): a technique that
/// promises nothing for a case fails, naming both (after the runs, whose measurements it prints).
#[test]
fn every_technique_survives_every_stiff_case_within_its_stated_bound() -> Result<()> {
    let mut bench = bench(8)?;
    let suite = Sweep::suite("stiff", bench.registry())?;
    let dir = tempfile::tempdir()?;
    let unpromised = expectations::unpromised(bench.registry(), &stiff::cases());
    let mut failures: Vec<String> = unpromised.iter().map(ToString::to_string).collect();
    let mut runs: Vec<Run> = Vec::new();
    for (index, spec) in suite.runs.iter().enumerate() {
        let run = bench.run(index, spec, dir.path());
        let label = format!("{} / {}", spec.technique, spec.scene);
        // A case whose light kind the technique does not support: refused with its reason
        // (`TechniqueInfo::light_kinds`), no bound to hold.
        if run.status == Status::Unsupported {
            eprintln!("UNSUPPORTED {label}: {}", run.message);
            continue;
        }
        if run.status != Status::Ok {
            failures.push(format!("{label}: failed: {}", run.message));
            continue;
        }
        let stability = run.stability.context("stability")?;
        if stability.nan + stability.inf + stability.out_of_range > 0 {
            failures.push(format!("{label}: {stability:?}"));
        }
        runs.push(run);
    }
    failures.extend(expectations::judge(bench.registry(), &mut runs));
    for run in &runs {
        let report = vs_exact(run)?;
        let all_lit = run
            .error
            .as_ref()
            .and_then(|e| e.all_lit_vs_exact.clone())
            .context("all_lit_vs_exact")?;
        eprintln!(
            "MEASURED {:<16} {:<22} mae_all {:.4} mae_shadowed {:.4} max_abs {:.4} | all-lit {:.4} {:.4} {:.4} | {}",
            run.technique,
            run.scene,
            report.mae_all,
            report.mae_shadowed,
            report.max_abs,
            all_lit.mae_all,
            all_lit.mae_shadowed,
            all_lit.max_abs,
            run.error.as_ref().and_then(|e| e.exact.clone()).unwrap_or_default()
        );
        let promised = !unpromised
            .iter()
            .any(|u| u.technique == run.technique && u.case == run.scene);
        if run.expectation.is_none() && promised {
            failures.push(format!(
                "{} / {}: no verdict: no error against the exact answer",
                run.technique, run.scene
            ));
        }
    }
    if !failures.is_empty() {
        bail!("{} problems:\n{}", failures.len(), failures.join("\n"));
    }
    Ok(())
}

/// The degenerate-geometry case is repaired, and the run says which triangles and how many.
#[test]
fn degenerate_input_is_repaired_with_a_warning_in_the_results() -> Result<()> {
    let mut bench = bench(4)?;
    let spec = RunSpec {
        scene: "stiff-degenerate".into(),
        technique: COST_FLOOR_TECHNIQUE.into(),
        params: vec![],
        width: SIZE,
        height: SIZE,
        path: None,
    };
    let run = run_checked(&mut bench, &spec)?;
    let warnings = run.warnings.join("\n");
    ensure!(
        warnings.contains("occluder with bad triangles")
            && warnings.contains("2 degenerate, 2 non-finite and 1 out-of-range triangles"),
        "{warnings}"
    );
    Ok(())
}

/// The reference's error against the exact union-of-rectangles answer falls as its samples per
/// axis grow (occluder fusion, `stiff-fusion`), as recorded in `error.reference_vs_exact`.
#[test]
fn the_reference_converges_to_the_exact_answer() -> Result<()> {
    let mut errors = Vec::new();
    for samples in [2, 4, 8, 16] {
        let mut bench = bench(samples)?;
        let spec = RunSpec {
            scene: "stiff-fusion".into(),
            technique: COST_FLOOR_TECHNIQUE.into(),
            params: vec![],
            width: SIZE,
            height: SIZE,
            path: None,
        };
        let run = run_checked(&mut bench, &spec)?;
        let error = run.error.as_ref().context("error block")?;
        ensure!(error.exact.as_deref() == Some("closed-form"), "{error:?}");
        let e = error
            .reference_vs_exact
            .as_ref()
            .context("reference_vs_exact")?
            .mae_shadowed;
        eprintln!("reference {samples}x{samples}: mae_shadowed vs exact {e:.4}");
        errors.push(e);
    }
    for pair in errors.windows(2) {
        ensure!(pair[1] < pair[0], "not decreasing: {errors:?}");
    }
    ensure!(errors[3] < 0.01, "16x16 reference error {}", errors[3]);
    Ok(())
}

/// As the light shrinks to a point, every technique approaches `hard` (the point-light answer):
/// the mean |V - V_hard| over receiver pixels falls with the light width and is small at 0.01.
#[test]
fn every_technique_approaches_hard_shadows_as_the_light_shrinks() -> Result<()> {
    let gpu = gpu()?;
    let mut renderer = Renderer::new(&gpu, SIZE, SIZE)?;
    let widths = [0.5, 0.1, 0.01];
    let registry = softshadow::registry();
    let hard = registry
        .cost_floor()
        .context("the cost floor is registered")?;
    let mut failures = Vec::new();
    for info in &registry {
        if info.id == COST_FLOOR_TECHNIQUE {
            continue;
        }
        let mut distances = Vec::new();
        for width in widths {
            let scene = softshadow_scenes::load(&format!("atty-square:light_width={width}"))?.scene;
            let scene_gpu = SceneGpu::upload(&gpu, &scene);
            let mut hard = hard.create(&gpu)?;
            renderer.render(&scene_gpu, &scene.camera, &scene.light, hard.as_mut(), None)?;
            let v_hard = renderer.read_visibility()?;
            let mut technique = info.create(&gpu)?;
            renderer.render(
                &scene_gpu,
                &scene.camera,
                &scene.light,
                technique.as_mut(),
                None,
            )?;
            let v = renderer.read_visibility()?;
            let mask = renderer.read_receiver_mask()?;
            let report = softshadow_metrics::compare(&v, &v_hard, &mask)?;
            distances.push(report.mae_all);
        }
        eprintln!(
            "{}: mean |V - V_hard| at light widths {widths:?}: {distances:?}",
            info.id
        );
        // Strictly closer to hard at every step.
        if !(distances[0] > distances[1] && distances[1] > distances[2]) {
            failures.push(format!("{}: not converging: {distances:?}", info.id));
        }
        // At width 0.01 the penumbra is 0.01 wide on the ground, under a pixel (~0.06) at 64^2.
        if distances[2] > 0.01 {
            failures.push(format!(
                "{}: {:.4} from hard at light width 0.01",
                info.id, distances[2]
            ));
        }
    }
    if !failures.is_empty() {
        bail!("{}", failures.join("\n"));
    }
    Ok(())
}
