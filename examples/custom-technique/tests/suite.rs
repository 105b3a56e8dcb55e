//! The custom technique measured by the workbench as a user's crate would be: the stiff suite and
//! the paper scenes held to the bounds its own crate states, radius 0 equal to `hard`, and the
//! workbench binary of this crate running it beside the built-ins (`list`, `bench`, `report`).

use std::process::Command;

use anyhow::{bail, ensure, Context, Result};
use softshadow::scenes::stiff;
use softshadow_bench::{expectations, Bench, BenchOptions, RunSpec, Status, Sweep};
use softshadow_core::{
    expectations::EXPECTATION_SIZE, Gpu, ParamValue, Registry, Renderer, SceneGpu,
    COST_FLOOR_TECHNIQUE,
};

fn gpu() -> Result<Gpu> {
    Gpu::new_headless().context(
        "these tests need a GPU adapter: install Mesa's lavapipe (apt-get install -y mesa-vulkan-drivers)",
    )
}

/// `fixed-pcf`, the cost floor (the wrong answer its bounds must reject) and the yardstick (the
/// benchmark's reference).
fn registry() -> Result<Registry> {
    let builtins = softshadow::registry();
    let floor = builtins
        .cost_floor()
        .context("the cost floor is built in")?;
    let yardstick = builtins.yardstick()?;
    Ok(Registry::new([
        floor.clone(),
        yardstick.clone(),
        custom_technique::info(),
    ])?)
}

fn bench() -> Result<Bench> {
    Ok(Bench::new(
        gpu()?,
        registry()?,
        BenchOptions {
            frames: 1,
            warmup: 0,
            reference_params: vec![("samples_per_axis".into(), ParamValue::Int(4))],
            images: false,
            exact_samples_per_axis: Some(16),
            camera_only: false,
            ..BenchOptions::default()
        },
    )?)
}

#[test]
fn the_stiff_suite_and_the_paper_scenes_meet_the_bounds_the_crate_states() -> Result<()> {
    let mut bench = bench()?;
    let registry = bench.registry().clone();
    // The suite's runs of this technique and of the cost floor (its baseline).
    let mut specs: Vec<RunSpec> = Sweep::suite("stiff", &registry)?
        .runs
        .into_iter()
        .filter(|r| r.technique == custom_technique::ID || r.technique == COST_FLOOR_TECHNIQUE)
        .collect();
    for scene in ["atty-square", "blob-floating:triangles=20000"] {
        for id in [COST_FLOOR_TECHNIQUE, custom_technique::ID] {
            specs.push(RunSpec {
                scene: scene.into(),
                technique: id.into(),
                params: Vec::new(),
                width: EXPECTATION_SIZE,
                height: EXPECTATION_SIZE,
                path: None,
            });
        }
    }
    let dir = tempfile::tempdir()?;
    let mut runs = Vec::new();
    for (index, spec) in specs.iter().enumerate() {
        let run = bench.run(index, spec, dir.path());
        // A case under a light kind `fixed-pcf` does not support (rect only): refused, nothing
        // promised (`expectations::unpromised` leaves it out too).
        if run.status == Status::Unsupported && spec.technique == custom_technique::ID {
            continue;
        }
        ensure!(
            run.status == Status::Ok,
            "{} / {}: {}",
            spec.technique,
            spec.scene,
            run.message
        );
        runs.push(run);
    }
    let mut failures: Vec<String> = expectations::unpromised(&registry, &stiff::cases())
        .iter()
        .map(ToString::to_string)
        .collect();
    failures.extend(expectations::judge(&registry, &mut runs));
    for run in runs.iter().filter(|r| r.technique == custom_technique::ID) {
        let error = run.error.as_ref().context("error metrics")?;
        let exact = error.vs_exact.as_ref().context("exact answer")?;
        let all_lit = error.all_lit_vs_exact.as_ref().context("all-lit")?;
        eprintln!(
            "MEASURED {:<30} mae_shadowed {:.4} max_abs {:.4} | all-lit {:.4}",
            run.scene, exact.mae_shadowed, exact.max_abs, all_lit.mae_shadowed
        );
        if run.expectation.is_none() {
            failures.push(format!(
                "{}: no verdict: nothing stated in custom_technique::info(), or no exact answer",
                run.scene
            ));
        }
    }
    if !failures.is_empty() {
        bail!("{} problems:\n{}", failures.len(), failures.join("\n"));
    }
    Ok(())
}

/// Radius 0 is one comparison on the map `hard` uses (at `hard`'s map size): the same visibility,
/// pixel for pixel.
#[test]
fn radius_zero_is_the_hard_shadow() -> Result<()> {
    let gpu = gpu()?;
    let registry = registry()?;
    let mut renderer = Renderer::new(&gpu, 96, 96)?;
    for scene_id in ["atty-square", "stiff-fusion"] {
        let scene = softshadow_scenes_load(scene_id)?;
        let scene_gpu = SceneGpu::upload(&gpu, &scene);
        let mut answers = Vec::new();
        for (id, params) in [
            (COST_FLOOR_TECHNIQUE, vec![]),
            (
                custom_technique::ID,
                vec![
                    ("kernel_radius".to_string(), ParamValue::Int(0)),
                    ("shadow_map_size".to_string(), ParamValue::Int(1024)),
                ],
            ),
        ] {
            let mut technique = registry.find(id)?.create_with(&gpu, &params)?;
            renderer.render(
                &scene_gpu,
                &scene.camera,
                &scene.light,
                technique.as_mut(),
                None,
            )?;
            answers.push(renderer.read_visibility()?);
        }
        let worst = answers[0]
            .iter()
            .zip(&answers[1])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        ensure!(
            worst <= 1e-6,
            "{scene_id}: radius 0 differs from hard by {worst}"
        );
    }
    Ok(())
}

/// `fixed-pcf`'s bound for every case it states one for (by name or by its class's rule), as
/// taken from its per-case table before the rules came (tests/stated_bounds.json).
#[test]
fn every_case_resolves_to_the_bound_it_had_before_the_rules() -> Result<()> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/stated_bounds.json");
    let snapshot: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path)?)?;
    let before = snapshot[custom_technique::ID]
        .as_object()
        .context("fixed-pcf's table")?;
    let info = custom_technique::info();
    let now = expectations::stated_by_case(&info, &stiff::cases());
    let mut differences = Vec::new();
    for (case, stated) in &now {
        let stated = serde_json::to_value(stated.expect)?;
        if before.get(case) != Some(&stated) {
            differences.push(format!(
                "{case}: now {stated}, before {:?}",
                before.get(case)
            ));
        }
    }
    for case in before.keys() {
        if !now.iter().any(|(c, _)| c == case) {
            differences.push(format!("{case}: nothing stated now"));
        }
    }
    ensure!(
        differences.is_empty(),
        "{}\n(changed on purpose? update tests/stated_bounds.json)",
        differences.join("\n")
    );
    Ok(())
}

fn softshadow_scenes_load(id: &str) -> Result<softshadow_core::Scene> {
    Ok(softshadow::scenes::load(id)?.scene)
}

/// This crate's binary is the workbench with `fixed-pcf` registered: `list` shows it beside the
/// built-ins, `bench` runs it and holds it to its bound, `report` plots it.
#[test]
fn the_crates_own_workbench_lists_benches_and_reports_it() -> Result<()> {
    let exe = env!("CARGO_BIN_EXE_custom-technique");
    let run = |args: &[&str]| -> Result<String> {
        let output = Command::new(exe)
            .args(args)
            .output()
            .with_context(|| format!("running {exe} {}", args.join(" ")))?;
        ensure!(
            output.status.success(),
            "`{}` failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&output.stderr)
        );
        Ok(String::from_utf8(output.stdout)?)
    };
    let list: serde_json::Value = serde_json::from_str(&run(&["list", "--json"])?)?;
    let ids: Vec<&str> = list["techniques"]
        .as_array()
        .context("techniques")?
        .iter()
        .filter_map(|t| t["id"].as_str())
        .collect();
    for builtin in softshadow::registry().ids() {
        ensure!(ids.contains(&builtin), "{builtin} missing from {ids:?}");
    }
    ensure!(ids.last() == Some(&custom_technique::ID), "{ids:?}");

    let dir = tempfile::tempdir()?;
    let out = dir.path().join("bench");
    let size = format!("{EXPECTATION_SIZE}x{EXPECTATION_SIZE}");
    run(&[
        "bench",
        "--scene",
        "atty-square",
        "--technique",
        custom_technique::ID,
        "--size",
        &size,
        "--frames",
        "1",
        "--warmup",
        "0",
        "--reference-param",
        "samples_per_axis=4",
        "--out",
        out.to_str().context("path")?,
    ])?;
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json"))?)?;
    let run0 = &results["runs"][0];
    ensure!(run0["technique"] == custom_technique::ID, "{run0}");
    ensure!(run0["status"] == "ok", "{run0}");
    ensure!(
        run0["expectation"]["met"] == true,
        "{}",
        run0["expectation"]
    );

    let report = dir.path().join("report.html");
    run(&[
        "report",
        out.to_str().context("path")?,
        "--out",
        report.to_str().context("path")?,
    ])?;
    let html = std::fs::read_to_string(&report)?;
    ensure!(html.contains(custom_technique::ID), "the report names it");
    Ok(())
}
