//! Issue 6: every registered technique on every stiff case (finite output in [0, 1], status ok,
//! error against the exact ground truth within the expectation written down in
//! docs/STABILITY.md, and every bound rejecting the deliberately wrong answers "no shadow" and
//! `hard`), and convergence: the reference towards the exact answer as its sample count grows,
//! every technique towards `hard` as the light shrinks.
//!
//! Small images (64^2), an 8 x 8 yardstick reference and a 16 x 16 ray cast keep this near a
//! minute on lavapipe; techniques, the `reference` technique included (32 x 32), run with their
//! defaults. The benchmark (`workbench bench --suite stiff`) does the 128^2 runs recorded in
//! STABILITY.md.

use crate::common::{
    all_lit_vs_exact, at_most, check, gpu, known_failure, run_checked, vs_exact, Baseline, Expect,
    Metric,
};
use anyhow::{bail, ensure, Context, Result};
use softshadow_bench::{registry, results::Run, Bench, BenchOptions, RunSpec, Status, Sweep};
use softshadow_core::{ParamValue, Renderer, SceneGpu};

const SIZE: u32 = 64;

fn bench(reference_samples: i64) -> Result<Bench> {
    Ok(Bench::new(
        gpu()?,
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
        },
    )?)
}

use Metric::{MaeShadowed, MaxAbs};

/// The stated expectation per technique and stiff case, with the value measured at 64^2 beside
/// each bound. Keep in step with docs/STABILITY.md.
fn expect(technique: &str, case: &str) -> Option<Expect> {
    // Rule: `mae_shadowed` (the diluted `mae_all` let "no shadow" pass on small shadows);
    // bound = 2.5x the 64^2 measurement (at least measurement + 0.001), lowered to halfway to the
    // nearest wrong answer (all-lit, or `hard` for a soft technique) where that answer is more
    // than 1.5x worse; a technique that is not 1.5x better than drawing no shadow is a known
    // failure, asserted at its value +- 10 % (at least 0.002). On
    // `stiff-no-occluder` every pixel must be 1: `max_abs` <= 1e-6.
    let expectation = match (technique, case) {
        ("hard", "stiff-contact") => at_most(MaeShadowed, 0.45, 0.1777),
        ("hard", "stiff-near-light") => known_failure(MaeShadowed, 0.7495, 0.075),
        ("hard", "stiff-point-light") => at_most(MaeShadowed, 0.001, 0.0),
        ("hard", "stiff-wide-light") => known_failure(MaeShadowed, 0.052, 0.006),
        ("hard", "stiff-grazing") => at_most(MaeShadowed, 0.39, 0.2252),
        ("hard", "stiff-depth-range") => known_failure(MaeShadowed, 0.7478, 0.075),
        ("hard", "stiff-zero-thickness") => known_failure(MaeShadowed, 0.217, 0.022),
        ("hard", "stiff-partly-outside") => at_most(MaeShadowed, 0.32, 0.1988),
        ("hard", "stiff-no-occluder") => at_most(MaxAbs, 1e-6, 0.0),
        ("hard", "stiff-aspect-100") => known_failure(MaeShadowed, 0.4277, 0.043),
        ("hard", "stiff-tiny-patches") => at_most(MaeShadowed, 0.5, 0.2915),
        ("hard", "stiff-degenerate") => at_most(MaeShadowed, 0.33, 0.2063),
        ("hard", "stiff-behind-light") => at_most(MaeShadowed, 0.38, 0.1505),
        ("hard", "stiff-light-up") => at_most(MaeShadowed, 0.19, 0.0733),
        ("hard", "stiff-fusion") => at_most(MaeShadowed, 0.36, 0.2539),
        ("pcss", "stiff-contact") => at_most(MaeShadowed, 0.099, 0.0393),
        ("pcss", "stiff-near-light") => at_most(MaeShadowed, 0.18, 0.0681),
        ("pcss", "stiff-point-light") => at_most(MaeShadowed, 0.0012, 2.0e-04),
        ("pcss", "stiff-wide-light") => known_failure(MaeShadowed, 0.0195, 0.002),
        ("pcss", "stiff-grazing") => at_most(MaeShadowed, 0.095, 0.0379),
        ("pcss", "stiff-depth-range") => known_failure(MaeShadowed, 0.2522, 0.026),
        ("pcss", "stiff-zero-thickness") => at_most(MaeShadowed, 0.087, 0.0347),
        ("pcss", "stiff-partly-outside") => known_failure(MaeShadowed, 0.4217, 0.043),
        ("pcss", "stiff-no-occluder") => at_most(MaxAbs, 1e-6, 0.0),
        ("pcss", "stiff-aspect-100") => at_most(MaeShadowed, 0.14, 0.0548),
        ("pcss", "stiff-tiny-patches") => at_most(MaeShadowed, 0.22, 0.1314),
        ("pcss", "stiff-degenerate") => at_most(MaeShadowed, 0.082, 0.0327),
        ("pcss", "stiff-behind-light") => at_most(MaeShadowed, 0.061, 0.0241),
        ("pcss", "stiff-light-up") => at_most(MaeShadowed, 0.027, 0.0108),
        ("pcss", "stiff-fusion") => at_most(MaeShadowed, 0.13, 0.0508),
        ("ssm", "stiff-contact") => at_most(MaeShadowed, 0.096, 0.0382),
        ("ssm", "stiff-near-light") => at_most(MaeShadowed, 0.005, 0.002),
        ("ssm", "stiff-point-light") => at_most(MaeShadowed, 0.0016, 6.0e-04),
        ("ssm", "stiff-wide-light") => at_most(MaeShadowed, 0.0012, 2.0e-04),
        ("ssm", "stiff-grazing") => at_most(MaeShadowed, 0.014, 0.0054),
        ("ssm", "stiff-depth-range") => at_most(MaeShadowed, 0.011, 0.0044),
        ("ssm", "stiff-zero-thickness") => at_most(MaeShadowed, 0.039, 0.0153),
        ("ssm", "stiff-partly-outside") => at_most(MaeShadowed, 0.36, 0.1417),
        ("ssm", "stiff-no-occluder") => at_most(MaxAbs, 1e-6, 0.0),
        ("ssm", "stiff-aspect-100") => at_most(MaeShadowed, 0.02, 0.008),
        ("ssm", "stiff-tiny-patches") => at_most(MaeShadowed, 0.015, 0.0057),
        ("ssm", "stiff-degenerate") => at_most(MaeShadowed, 0.0088, 0.0035),
        ("ssm", "stiff-behind-light") => at_most(MaeShadowed, 0.0035, 0.0014),
        ("ssm", "stiff-light-up") => at_most(MaeShadowed, 0.002, 8.0e-04),
        ("ssm", "stiff-fusion") => at_most(MaeShadowed, 0.056, 0.0221),
        ("backprojection", "stiff-contact") => at_most(MaeShadowed, 0.16, 0.0624),
        ("backprojection", "stiff-near-light") => at_most(MaeShadowed, 0.0033, 0.0013),
        ("backprojection", "stiff-point-light") => at_most(MaeShadowed, 0.001, 0.0),
        ("backprojection", "stiff-wide-light") => at_most(MaeShadowed, 0.0028, 0.0011),
        ("backprojection", "stiff-grazing") => at_most(MaeShadowed, 0.04, 0.0157),
        ("backprojection", "stiff-depth-range") => known_failure(MaeShadowed, 0.2522, 0.026),
        ("backprojection", "stiff-zero-thickness") => at_most(MaeShadowed, 0.18, 0.0716),
        ("backprojection", "stiff-partly-outside") => at_most(MaeShadowed, 0.32, 0.2026),
        ("backprojection", "stiff-no-occluder") => at_most(MaxAbs, 1e-6, 0.0),
        ("backprojection", "stiff-aspect-100") => at_most(MaeShadowed, 0.039, 0.0155),
        ("backprojection", "stiff-tiny-patches") => at_most(MaeShadowed, 0.0073, 0.0029),
        ("backprojection", "stiff-degenerate") => at_most(MaeShadowed, 0.045, 0.0177),
        ("backprojection", "stiff-behind-light") => at_most(MaeShadowed, 0.018, 0.007),
        ("backprojection", "stiff-light-up") => at_most(MaeShadowed, 0.011, 0.0041),
        ("backprojection", "stiff-fusion") => at_most(MaeShadowed, 0.18, 0.0683),
        ("bitmask", "stiff-contact") => at_most(MaeShadowed, 0.11, 0.0431),
        ("bitmask", "stiff-near-light") => at_most(MaeShadowed, 0.022, 0.0087),
        ("bitmask", "stiff-point-light") => at_most(MaeShadowed, 0.001, 0.0),
        ("bitmask", "stiff-wide-light") => at_most(MaeShadowed, 0.0083, 0.0033),
        ("bitmask", "stiff-grazing") => at_most(MaeShadowed, 0.04, 0.0157),
        ("bitmask", "stiff-depth-range") => known_failure(MaeShadowed, 0.2522, 0.026),
        ("bitmask", "stiff-zero-thickness") => at_most(MaeShadowed, 0.18, 0.0709),
        ("bitmask", "stiff-partly-outside") => at_most(MaeShadowed, 0.16, 0.1135),
        ("bitmask", "stiff-no-occluder") => at_most(MaxAbs, 1e-6, 0.0),
        ("bitmask", "stiff-aspect-100") => at_most(MaeShadowed, 0.044, 0.0176),
        ("bitmask", "stiff-tiny-patches") => at_most(MaeShadowed, 0.039, 0.0154),
        ("bitmask", "stiff-degenerate") => at_most(MaeShadowed, 0.044, 0.0176),
        ("bitmask", "stiff-behind-light") => at_most(MaeShadowed, 0.017, 0.0068),
        ("bitmask", "stiff-light-up") => at_most(MaeShadowed, 0.01, 0.004),
        ("bitmask", "stiff-fusion") => at_most(MaeShadowed, 0.15, 0.0567),
        ("adaptive", "stiff-contact") => at_most(MaeShadowed, 0.15, 0.0568),
        ("adaptive", "stiff-near-light") => at_most(MaeShadowed, 0.12, 0.0443),
        ("adaptive", "stiff-point-light") => at_most(MaeShadowed, 0.001, 0.0),
        ("adaptive", "stiff-wide-light") => known_failure(MaeShadowed, 0.0227, 0.003),
        ("adaptive", "stiff-grazing") => at_most(MaeShadowed, 0.11, 0.0415),
        ("adaptive", "stiff-depth-range") => at_most(MaeShadowed, 0.13, 0.0488),
        ("adaptive", "stiff-zero-thickness") => at_most(MaeShadowed, 0.076, 0.0302),
        ("adaptive", "stiff-partly-outside") => at_most(MaeShadowed, 0.067, 0.0265),
        ("adaptive", "stiff-no-occluder") => at_most(MaxAbs, 1e-6, 0.0),
        ("adaptive", "stiff-aspect-100") => at_most(MaeShadowed, 0.13, 0.0498),
        ("adaptive", "stiff-tiny-patches") => at_most(MaeShadowed, 0.24, 0.1799),
        ("adaptive", "stiff-degenerate") => at_most(MaeShadowed, 0.085, 0.0338),
        ("adaptive", "stiff-behind-light") => at_most(MaeShadowed, 0.076, 0.0304),
        ("adaptive", "stiff-light-up") => at_most(MaeShadowed, 0.029, 0.0113),
        ("adaptive", "stiff-fusion") => at_most(MaeShadowed, 0.079, 0.0313),
        ("pdsm", "stiff-contact") => at_most(MaeShadowed, 0.033, 0.0118),
        ("pdsm", "stiff-near-light") => at_most(MaeShadowed, 0.017, 0.0068),
        ("pdsm", "stiff-point-light") => at_most(MaeShadowed, 0.013, 0.0052),
        ("pdsm", "stiff-wide-light") => at_most(MaeShadowed, 0.024, 0.0094),
        ("pdsm", "stiff-grazing") => at_most(MaeShadowed, 0.035, 0.0134),
        ("pdsm", "stiff-depth-range") => at_most(MaeShadowed, 0.049, 0.0196),
        ("pdsm", "stiff-zero-thickness") => at_most(MaeShadowed, 0.029, 0.0118),
        ("pdsm", "stiff-partly-outside") => at_most(MaeShadowed, 0.032, 0.0123),
        ("pdsm", "stiff-no-occluder") => at_most(MaxAbs, 1e-6, 0.0),
        ("pdsm", "stiff-aspect-100") => at_most(MaeShadowed, 0.063, 0.0245),
        ("pdsm", "stiff-tiny-patches") => at_most(MaeShadowed, 0.033, 0.0130),
        ("pdsm", "stiff-degenerate") => at_most(MaeShadowed, 0.027, 0.0106),
        ("pdsm", "stiff-behind-light") => at_most(MaeShadowed, 0.021, 0.0082),
        ("pdsm", "stiff-light-up") => at_most(MaeShadowed, 0.0083, 0.0033),
        ("pdsm", "stiff-fusion") => at_most(MaeShadowed, 0.031, 0.0120),
        ("reference", "stiff-contact") => at_most(MaeShadowed, 0.011, 0.0044),
        ("reference", "stiff-near-light") => at_most(MaeShadowed, 0.0033, 0.0013),
        ("reference", "stiff-point-light") => at_most(MaeShadowed, 0.001, 0.0),
        ("reference", "stiff-wide-light") => at_most(MaeShadowed, 0.003, 0.0012),
        ("reference", "stiff-grazing") => at_most(MaeShadowed, 0.004, 0.0016),
        ("reference", "stiff-depth-range") => at_most(MaeShadowed, 0.0038, 0.0015),
        ("reference", "stiff-zero-thickness") => at_most(MaeShadowed, 0.0065, 0.0026),
        ("reference", "stiff-partly-outside") => at_most(MaeShadowed, 0.012, 0.0046),
        ("reference", "stiff-no-occluder") => at_most(MaxAbs, 1e-6, 0.0),
        ("reference", "stiff-aspect-100") => at_most(MaeShadowed, 0.0053, 0.0021),
        ("reference", "stiff-tiny-patches") => at_most(MaeShadowed, 0.0083, 0.0033),
        ("reference", "stiff-degenerate") => at_most(MaeShadowed, 0.004, 0.0016),
        ("reference", "stiff-behind-light") => at_most(MaeShadowed, 0.003, 0.0012),
        ("reference", "stiff-light-up") => at_most(MaeShadowed, 0.0015, 5.0e-04),
        ("reference", "stiff-fusion") => at_most(MaeShadowed, 0.004, 0.0016),
        _ => return None,
    };
    Some(expectation)
}

#[test]
fn every_technique_survives_every_stiff_case_within_its_stated_bound() -> Result<()> {
    let mut bench = bench(8)?;
    let suite = Sweep::suite("stiff")?;
    let dir = tempfile::tempdir()?;
    let mut failures = Vec::new();
    let mut runs: Vec<(RunSpec, Run)> = Vec::new();
    for (index, spec) in suite.runs.iter().enumerate() {
        let spec = RunSpec {
            width: SIZE,
            height: SIZE,
            ..spec.clone()
        };
        let run = bench.run(index, &spec, dir.path());
        let label = format!("{} / {}", spec.technique, spec.scene);
        if run.status != Status::Ok {
            failures.push(format!("{label}: failed: {}", run.message));
            continue;
        }
        let stability = run.stability.context("stability")?;
        if stability.nan + stability.inf + stability.out_of_range > 0 {
            failures.push(format!("{label}: {stability:?}"));
        }
        runs.push((spec, run));
    }
    for (spec, run) in &runs {
        let label = format!("{} / {}", spec.technique, spec.scene);
        let report = vs_exact(run)?;
        let error = run.error.as_ref().context("error block")?;
        let all_lit = all_lit_vs_exact(run)?;
        eprintln!(
            "MEASURED {:<16} {:<22} mae_all {:.4} mae_shadowed {:.4} max_abs {:.4} | all-lit {:.4} {:.4} {:.4} | {}",
            spec.technique,
            spec.scene,
            report.mae_all,
            report.mae_shadowed,
            report.max_abs,
            all_lit.mae_all,
            all_lit.mae_shadowed,
            all_lit.max_abs,
            error.exact.clone().unwrap_or_default()
        );
        let mut baselines = vec![Baseline {
            name: "all-lit (V = 1)",
            report: all_lit,
        }];
        if spec.technique != "hard" {
            if let Some((_, hard)) = runs
                .iter()
                .find(|(s, _)| s.technique == "hard" && s.scene == spec.scene)
            {
                baselines.push(Baseline {
                    name: "hard",
                    report: vs_exact(hard)?.clone(),
                });
            }
        }
        match expect(&spec.technique, &spec.scene) {
            None => failures.push(format!(
                "{label}: no expectation stated: add one to docs/STABILITY.md and to stiff.rs"
            )),
            Some(expectation) => failures.extend(check(&label, expectation, report, &baselines)),
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
        technique: "hard".into(),
        params: vec![],
        width: SIZE,
        height: SIZE,
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
            technique: "hard".into(),
            params: vec![],
            width: SIZE,
            height: SIZE,
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
    let hard = registry::find("hard")?;
    let mut failures = Vec::new();
    for info in registry::techniques() {
        if info.id == "hard" {
            continue;
        }
        let mut distances = Vec::new();
        for width in widths {
            let scene = softshadow_scenes::load(&format!("atty-square:light_width={width}"))?.scene;
            let scene_gpu = SceneGpu::upload(&gpu, &scene);
            let mut hard = (hard.create)(&gpu)?;
            renderer.render(&scene_gpu, &scene.camera, &scene.light, hard.as_mut(), None)?;
            let v_hard = renderer.read_visibility()?;
            let mut technique = (info.create)(&gpu)?;
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
