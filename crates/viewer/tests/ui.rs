//! The viewer driven through its UI with egui_kittest, on the same wgpu device as the renderer
//! (lavapipe here). Snapshots live in `tests/snapshots/`: a missing or different snapshot fails;
//! `UPDATE_SNAPSHOTS=1 cargo test -p softshadow-viewer` writes new ones to review and commit.

use anyhow::{ensure, Context, Result};
use egui::accesskit::Role;
use egui_kittest::{
    kittest::{NodeT, Queryable},
    wgpu::WgpuTestRenderer,
    Harness, SnapshotOptions,
};
use softshadow_bench::results::FrameKind;
use softshadow_core::{wgpu, Gpu, ParamValue};
use softshadow_viewer::{app::LiveExact, ViewMode, ViewerApp, ViewerOptions};

/// A small window: the image area is about 300 x 400 pixels, so every frame stays cheap.
const SIZE: egui::Vec2 = egui::vec2(860.0, 420.0);

fn harness(technique: &str) -> Result<Harness<'static, ViewerApp>> {
    let gpu = Gpu::new_headless().context("the viewer UI tests need a GPU adapter")?;
    // kittest reads its frames back as RGBA8.
    let render_state = softshadow_viewer::render_state(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    let mut app = ViewerApp::new(
        gpu,
        render_state.renderer.clone(),
        &ViewerOptions {
            registry: softshadow::registry(),
            scene: "atty-square".into(),
            technique: technique.into(),
            worker: worker_under_test(),
            ..ViewerOptions::default()
        },
    )?;
    // Each UI frame shows the technique frame it asked for (the window waits at most
    // `FRAME_WAIT`); `a_slow_technique_frame_never_holds_the_ui` tests the window's way.
    app.set_frame_wait(std::time::Duration::MAX);
    // A 4 x 4 reference at 256^2 converges in one frame.
    app.set_reference_param("samples_per_axis", ParamValue::Int(4));
    app.set_reference_param("shadow_map_size", ParamValue::Int(256));
    let harness = Harness::builder()
        .with_size(SIZE)
        .renderer(WgpuTestRenderer::from_render_state(render_state))
        .build_ui_state(|ui, app: &mut ViewerApp| app.ui(ui), app);
    Ok(harness)
}

/// `hard` is the active technique and its passes are in the timing table's rows.
fn ensure_hard_was_timed(harness: &Harness<ViewerApp>) -> Result<()> {
    ensure!(harness.state().technique_id() == "hard");
    let rows: Vec<String> = harness
        .state()
        .timing_rows()
        .into_iter()
        .map(|r| r.name)
        .collect();
    ensure!(
        rows.iter().any(|r| r.starts_with("hard/")),
        "timings of hard: {rows:?}"
    );
    Ok(())
}

#[test]
fn the_technique_picker_switches_the_technique_and_the_timing_table_follows() -> Result<()> {
    let mut harness = harness("hard")?;
    harness.run_steps(3);
    ensure_hard_was_timed(&harness)?;
    harness
        .query_by_label("hard/lookup")
        .context("the table lists hard's pass")?;

    harness
        .get_by_role_and_label(Role::ComboBox, "Technique")
        .click();
    harness.run_steps(2);
    harness.get_by_label("pcss").click();
    harness.run_steps(3);

    let app = harness.state();
    ensure!(
        app.technique_id() == "pcss",
        "active: {}",
        app.technique_id()
    );
    let rows: Vec<String> = app.timing_rows().into_iter().map(|r| r.name).collect();
    ensure!(
        rows.iter().any(|r| r == "pcss/filter") && !rows.iter().any(|r| r.starts_with("hard/")),
        "timings after the switch: {rows:?}"
    );
    // The table on screen lists the new technique's passes.
    harness
        .query_by_label("pcss/filter")
        .context("the timing table shows pcss/filter")?;
    ensure!(harness.query_by_label("hard/lookup").is_none());
    ensure!(
        harness.state().errors().is_empty(),
        "{:?}",
        harness.state().errors()
    );
    Ok(())
}

#[test]
fn parameter_widgets_change_the_technique_parameters() -> Result<()> {
    let mut harness = harness("pcss")?;
    harness.run_steps(2);
    let param = |h: &Harness<ViewerApp>, name: &str| {
        h.state()
            .technique_params()
            .and_then(|p| p.get(name).cloned())
    };
    ensure!(param(&harness, "filter_samples") == Some(ParamValue::Int(32)));

    // A slider generated from the spec (1 to 256).
    harness
        .get_by_role_and_label(Role::Slider, "filter_samples")
        .set_value_accesskit(64.0);
    harness.run_steps(2);
    ensure!(
        param(&harness, "filter_samples") == Some(ParamValue::Int(64)),
        "filter_samples = {:?}",
        param(&harness, "filter_samples")
    );

    // A choice generated from the spec.
    harness
        .get_by_role_and_label(Role::ComboBox, "kernel")
        .click();
    harness.run_steps(2);
    harness.get_by_label("grid").click();
    harness.run_steps(2);
    ensure!(
        param(&harness, "kernel") == Some(ParamValue::Choice("grid".into())),
        "kernel = {:?}",
        param(&harness, "kernel")
    );

    // "Defaults" puts both back.
    harness.get_by_label("Defaults").click();
    harness.run_steps(2);
    ensure!(param(&harness, "filter_samples") == Some(ParamValue::Int(32)));
    ensure!(param(&harness, "kernel") == Some(ParamValue::Choice("vogel".into())));
    Ok(())
}

#[test]
fn a_scene_that_fails_to_load_shows_its_error_and_keeps_the_scene() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let broken = dir.path().join("broken.toml");
    std::fs::write(&broken, "this is = not [ a scene")?;
    let mut harness = harness("hard")?;
    harness.run_steps(1);
    let camera = *harness.state().camera();
    harness
        .state_mut()
        .open_scene(&broken.display().to_string());
    harness.state_mut().open_scene("no-such-scene");
    harness.run_steps(2);
    let app = harness.state();
    ensure!(
        app.scene_spec() == "atty-square",
        "scene: {}",
        app.scene_spec()
    );
    ensure!(*app.camera() == camera);
    ensure!(app.errors().len() == 2, "{:?}", app.errors());
    ensure!(
        app.errors()[0].contains("broken.toml"),
        "{:?}",
        app.errors()
    );
    harness
        .query_by_label_contains("no-such-scene")
        .context("the error is on screen")?;
    Ok(())
}

#[test]
fn enter_in_the_scene_path_field_opens_the_file() -> Result<()> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../assets/scenes/tetrahedron.toml"
    );
    let mut harness = harness("hard")?;
    harness.run_steps(1);
    harness
        .get_by_role_and_label(Role::DisclosureTriangle, "Scene")
        .click();
    harness.run_steps(1);
    // The scene path field is the left panel's text field (the right panel has the sweep's).
    harness
        .query_all_by_role(Role::TextInput)
        .find(|n| n.rect().left() < SIZE.x * 0.5)
        .context("the scene path field")?
        .focus();
    harness.run_steps(1);
    harness
        .query_all_by_role(Role::TextInput)
        .find(|n| n.rect().left() < SIZE.x * 0.5)
        .context("the scene path field")?
        .type_text(path);
    harness.run_steps(1);
    ensure!(
        harness.state().scene_spec() == "atty-square",
        "typing alone opens nothing: {}",
        harness.state().scene_spec()
    );
    // Enter, not the Open button, opens the file.
    harness.key_press(egui::Key::Enter);
    harness.run_steps(2);
    ensure!(
        harness.state().scene_spec().ends_with("tetrahedron.toml"),
        "scene after Enter: {}",
        harness.state().scene_spec()
    );
    ensure!(
        harness.state().errors().is_empty(),
        "{:?}",
        harness.state().errors()
    );
    Ok(())
}

#[test]
fn the_reference_converges_and_the_metrics_and_the_plot_appear() -> Result<()> {
    let mut harness = harness("pcss")?;
    // 16 light samples, one batch: converged after the first frame; the point needs 5 frames
    // timed with the caches dropped.
    harness.run_steps(7);
    let app = harness.state();
    ensure!(
        app.reference_progress().is_complete(),
        "{:?}",
        app.reference_progress()
    );
    let report = app.metrics().context("metrics after convergence")?;
    ensure!(
        report.receiver_pixels > 0 && report.mae_shadowed.is_finite() && report.mae_shadowed < 0.2,
        "{report:?}"
    );
    ensure!(report.flip_mean.is_some());
    ensure!(app.points().len() == 1, "{:?}", app.points());
    harness
        .query_by_label("mae_shadowed")
        .context("metrics shown")?;

    // Another setting adds a second point; moving the light invalidates the reference.
    harness
        .state_mut()
        .set_param("filter_samples", ParamValue::Int(8));
    harness.run_steps(7);
    ensure!(
        harness.state().points().len() == 2,
        "{:?}",
        harness.state().points()
    );
    // A progressive 16 x 16 reference (256 samples, 2 batches of 16 a frame): 8 frames to
    // converge, while one harness step renders one or two frames (egui may run a second pass).
    harness
        .state_mut()
        .set_reference_param("samples_per_axis", ParamValue::Int(16));
    run_until_converged(&mut harness)?;
    ensure!(harness.state().metrics().is_some());
    let points = harness.state().points().len();
    ensure!(points == 2, "{:?}", harness.state().points());

    let mut light = *harness.state().light();
    light.center.x += 0.2;
    let mut state = harness.state().state();
    state.light = light;
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("state.json");
    state.save(&path)?;
    harness.state_mut().load_state(&path);
    harness.run_steps(1);
    let app = harness.state();
    ensure!(*app.light() == light, "the state's light was loaded");
    // The reference restarted: at most two frames of a new accumulation, 64 of 256 samples.
    let progress = app.reference_progress();
    ensure!(
        progress.total == 256 && progress.done > 0 && progress.done <= 64,
        "a moved light restarts the reference: {progress:?}"
    );
    // Old metrics are not current; they stay on screen greyed and labelled stale.
    ensure!(app.metrics().is_none() && app.stale_metrics().is_some());
    ensure!(app.points().is_empty(), "{:?}", app.points());
    harness
        .query_by_label_contains("stale")
        .context("the stale metrics are labelled")?;
    run_until_converged(&mut harness)?;
    ensure!(harness.state().metrics().is_some());
    Ok(())
}

/// Under a sphere light the yardstick accumulates (one depth map per point of the sphere,
/// weighed per receiver) and the error section shows metrics, with no word of a missing
/// yardstick.
#[test]
fn under_a_sphere_light_the_yardstick_converges_and_metrics_show() -> Result<()> {
    let mut harness = harness("hard")?;
    let accumulations = harness.state().reference_accumulations();
    let mut state = harness.state().state();
    state.light = state.light.as_kind(softshadow_core::LightKind::Sphere);
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("state.json");
    state.save(&path)?;
    harness.state_mut().load_state(&path);
    run_until_converged(&mut harness)?;
    harness.run_steps(2);
    let app = harness.state();
    ensure!(app.light().kind == softshadow_core::LightKind::Sphere);
    ensure!(
        app.reference_accumulations() > accumulations,
        "a reference accumulates under a sphere"
    );
    ensure!(app.errors().is_empty(), "errors: {:?}", app.errors());
    let metrics = app.metrics().context("metrics under a sphere light")?;
    ensure!(metrics.mae_shadowed.is_finite(), "{metrics:?}");
    ensure!(
        harness.query_by_label_contains("cannot sample").is_none(),
        "no refusal under a sphere"
    );
    Ok(())
}

/// Steps until the reference has converged (at most 40 steps). The progress read before the
/// first step may still be the previous reference's, so there is always one step first.
fn run_until_converged(harness: &mut Harness<ViewerApp>) -> Result<()> {
    for _ in 0..40 {
        harness.step();
        if harness.state().reference_progress().is_complete() {
            return Ok(());
        }
    }
    anyhow::bail!(
        "the reference did not converge: {:?}",
        harness.state().reference_progress()
    )
}

#[test]
fn a_larger_reference_keeps_the_plot_and_the_point_is_remeasured() -> Result<()> {
    let mut harness = harness("hard")?;
    harness.run_steps(2);
    ensure!(
        harness.state().points().len() == 1,
        "{:?}",
        harness.state().points()
    );
    let before = harness.state().points()[0].error;
    // Same scene, light and camera: the restarted reference keeps the plot.
    harness
        .state_mut()
        .set_reference_param("samples_per_axis", ParamValue::Int(16));
    harness.step();
    ensure!(
        !harness.state().reference_progress().is_complete(),
        "{:?}",
        harness.state().reference_progress()
    );
    ensure!(
        harness.state().points().len() == 1,
        "the point survives the restart"
    );
    run_until_converged(&mut harness)?;
    let after = harness.state().points()[0].error;
    println!(
        "hard's mae_shadowed against the 4 x 4 reference {before:.5}, against 16 x 16 {after:.5}"
    );
    // Re-measured against the 16 x 16 reference: the two references differ a little.
    ensure!(
        before != after,
        "{before} == {after}: the point was not re-measured"
    );
    ensure!((before - after).abs() < 0.05, "{before} vs {after}");
    Ok(())
}

#[test]
fn the_timing_panel_shows_the_passes_run_and_the_cost_of_computing() -> Result<()> {
    let mut harness = harness("pcss")?;
    // Building the harness ran 7 frames: the first 5 of the setting dropped pcss's kept shadow
    // map (the cost of computing); then nothing in light space changed, so the kept shadow map
    // is used and its pass is absent.
    harness.step();
    let app = harness.state();
    ensure!(
        !app.passes_run().iter().any(|p| p == "pcss/shadow_map")
            && app.passes_run().iter().any(|p| p == "pcss/filter"),
        "{:?}",
        app.passes_run()
    );
    ensure!(
        app.cost_rows().iter().any(|r| r.name == "pcss/shadow_map"),
        "{:?}",
        app.cost_rows()
    );
    let cost = app.cost_ms().context("cost measured")?;
    ensure!(cost > 0.0, "cost {cost} ms");
    harness
        .query_by_label_contains("kept, not run this frame: pcss/shadow_map")
        .context("the panel says the shadow map was kept")?;
    harness
        .query_by_label_contains("cost of the technique")
        .context("the cost is shown")?;
    ensure!(harness.query_by_label_contains("-0.00").is_none());

    // A new setting: its first frames pay the whole cost again, shadow map included.
    harness
        .state_mut()
        .set_param("filter_samples", ParamValue::Int(16));
    harness.step();
    ensure!(
        harness
            .state()
            .passes_run()
            .iter()
            .any(|p| p == "pcss/shadow_map"),
        "{:?}",
        harness.state().passes_run()
    );
    harness.run_steps(6);

    // A camera-only change (a real drag on the image): the shadow map is still kept.
    let camera = *harness.state().camera();
    let end = press_and_drag(
        &mut harness,
        egui::pos2(SIZE.x * 0.5, SIZE.y * 0.5),
        10.0,
        4,
    );
    let app = harness.state();
    ensure!(*app.camera() != camera, "the drag orbits the camera");
    ensure!(
        !app.passes_run().iter().any(|p| p == "pcss/shadow_map"),
        "camera-only frame: {:?}",
        app.passes_run()
    );
    release(&mut harness, end);
    Ok(())
}

/// A real drag on the image with the primary button: pressed at `start`, moved `dx` to the right
/// `steps` times with a frame after each; returns where the pointer is (still pressed).
fn press_and_drag(
    harness: &mut Harness<ViewerApp>,
    start: egui::Pos2,
    dx: f32,
    steps: u32,
) -> egui::Pos2 {
    harness.hover_at(start);
    harness.event(egui::Event::PointerButton {
        pos: start,
        button: egui::PointerButton::Primary,
        pressed: true,
        modifiers: egui::Modifiers::NONE,
    });
    for step in 1..=steps {
        harness.hover_at(start + egui::vec2(dx * step as f32, 0.0));
        harness.step();
    }
    start + egui::vec2(dx * steps as f32, 0.0)
}

/// Ends a drag of [`press_and_drag`] at `at`, and runs one frame.
fn release(harness: &mut Harness<ViewerApp>, at: egui::Pos2) {
    harness.event(egui::Event::PointerButton {
        pos: at,
        button: egui::PointerButton::Primary,
        pressed: false,
        modifiers: egui::Modifiers::NONE,
    });
    harness.step();
}

/// Snapshot tolerance: lavapipe renders deterministically here, so the threshold is egui's
/// usual per-pixel colour distance (0.6) and at most 0.1 % of the pixels may differ more, to absorb
/// anti-aliasing differences between Mesa versions (Mesa 22.3.6 and 25.0.7 draw both snapshots
/// identically: 0 pixels differ at threshold 0; docs/STABILITY.md). The measurements panel
/// (timings change every run) is masked.
fn snapshot(harness: &mut Harness<ViewerApp>, name: &str) -> Result<()> {
    let panel = harness.get_by_label("GPU time").rect();
    harness.mask(egui::Rect::from_min_max(
        egui::pos2(panel.left() - 6.0, 0.0),
        egui::pos2(SIZE.x, SIZE.y),
    ));
    // The plot panel's points and legend follow the measured times too.
    let plot = harness.get_by_label("Error against time").rect();
    harness.mask(egui::Rect::from_min_max(
        egui::pos2(plot.left() - 6.0, plot.top() - 6.0),
        egui::pos2(SIZE.x, SIZE.y),
    ));
    let pixels = (SIZE.x * SIZE.y) as usize;
    harness.snapshot_options(
        name,
        &SnapshotOptions::new()
            .threshold(0.6)
            .max_failed_pixels(pixels / 1000),
    );
    Ok(())
}

#[test]
fn snapshots_of_the_shaded_and_difference_views() -> Result<()> {
    let mut harness = harness("pcss")?;
    harness.run_steps(3);
    snapshot(&mut harness, "viewer_pcss_shaded")?;
    harness.state_mut().set_view_mode(ViewMode::Difference);
    harness.run_steps(2);
    snapshot(&mut harness, "viewer_pcss_difference")?;
    Ok(())
}

#[test]
fn every_view_mode_renders_and_a_failing_technique_keeps_the_viewer_running() -> Result<()> {
    let mut harness = harness("pcss")?;
    harness.run_steps(1);
    for mode in ViewMode::ALL {
        harness.get_by_label(mode.label()).click();
        harness.run_steps(2);
        let app = harness.state();
        ensure!(app.view_mode() == mode, "{:?} != {mode:?}", app.view_mode());
        ensure!(
            app.technique_error().is_none() && app.errors().is_empty(),
            "{mode:?}: {:?} {:?}",
            app.technique_error(),
            app.errors()
        );
    }
    // The debug view shows pcss's shadow map (no "cannot show" message).
    ensure!(harness.query_by_label_contains("cannot show").is_none());

    // A technique that cannot start: its error is shown, frames go on, another one works.
    harness.state_mut().select_technique("no-such-technique");
    harness.run_steps(2);
    ensure!(harness.state().technique_params().is_none());
    let error = harness
        .state()
        .technique_error()
        .context("the failure is shown")?
        .to_string();
    ensure!(error.contains("no-such-technique"), "{error}");
    let frames = harness.state().stats().frames;
    harness.run_steps(2);
    ensure!(harness.state().stats().frames == frames + 2);
    harness.state_mut().select_technique("hard");
    harness.run_steps(2);
    ensure!(harness.state().technique_error().is_none());
    Ok(())
}

#[test]
fn an_exported_sweep_benchmarks_the_view_the_viewer_plotted() -> Result<()> {
    let mut harness = harness("pcss")?;
    // A view that is not the scene's own: the benchmark must use the exported camera and light.
    let mut light = *harness.state().light();
    light.center.x += 0.3;
    light.width *= 1.5;
    let mut state = harness.state().state();
    state.light = light;
    state.camera.eye.x += 0.5;
    let dir = tempfile::tempdir()?;
    let state_path = dir.path().join("state.json");
    state.save(&state_path)?;
    harness.state_mut().load_state(&state_path);
    harness.run_steps(7);
    let point = harness
        .state()
        .points()
        .first()
        .cloned()
        .context("a point after 7 frames")?;
    let (width, height) = harness.state().render_size().context("rendered")?;

    let sweep_path = dir.path().join("sweep.toml");
    harness.state_mut().export_sweep(&sweep_path);
    harness.run_steps(1);
    let status = harness
        .state()
        .status()
        .context("the export is confirmed")?;
    ensure!(status.contains("sweep.toml"), "{status}");
    harness
        .query_by_label_contains("points to")
        .context("the confirmation is on screen")?;

    let sweep = softshadow_bench::Sweep::load(&sweep_path, &softshadow::registry())?;
    ensure!(sweep.light == Some(light), "{:?}", sweep.light);
    ensure!(sweep.camera == Some(*harness.state().camera()));
    let gpu = Gpu::new_headless()?;
    let mut bench = softshadow_bench::Bench::new(
        gpu,
        softshadow::registry(),
        softshadow_bench::BenchOptions {
            frames: 1,
            warmup: 0,
            reference_params: sweep.reference_params.clone(),
            images: false,
            exact_samples_per_axis: None,
            camera_only: false,
            ..Default::default()
        },
    )?;
    bench.set_view(sweep.camera, sweep.light);
    ensure!(
        sweep.runs.len() == 1 && (sweep.runs[0].width, sweep.runs[0].height) == (width, height)
    );
    let run = bench.run(0, &sweep.runs[0], dir.path());
    let error = run.error.context(run.message.clone())?.report.mae_shadowed;
    // Same reference settings (4 x 4 light samples, 256^2 maps; the progressive sum is
    // bit-identical to the one-frame one) and the same deterministic technique: the two agree
    // far inside the reference's own noise (its 4 x 4 vs 8 x 8 difference is ~1e-2).
    ensure!(
        (error - point.error).abs() < 1e-4,
        "benchmark {error} vs viewer {}",
        point.error
    );
    // And the scene's own view gives a different error: the override mattered.
    bench.set_view(None, None);
    let own = bench.run(1, &sweep.runs[0], dir.path());
    let own_error = own.error.context(own.message.clone())?.report.mae_shadowed;
    ensure!(
        (own_error - point.error).abs() > 1e-3,
        "own view {own_error} vs exported {}",
        point.error
    );
    Ok(())
}

/// Issue 13: the PDSM's precompute builds off the UI thread. The first frames draw its light
/// sample maps a few at a time, then start the CPU construction on a thread and return while it
/// runs (the panel shows its progress and a Cancel button, no plot point);
/// Cancel stops it and offers Build again. A 512² PDSM keeps it running for seconds, so the
/// frames below see it running; the harness's drop stops the last build.
#[test]
fn the_pdsm_builds_off_the_ui_thread_and_cancel_stops_it() -> Result<()> {
    let gpu = Gpu::new_headless().context("the viewer UI tests need a GPU adapter")?;
    let render_state = softshadow_viewer::render_state(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    let mut app = ViewerApp::new(
        gpu,
        render_state.renderer.clone(),
        &ViewerOptions {
            registry: softshadow::registry(),
            scene: "atty-square".into(),
            technique: "pdsm".into(),
            params: vec![
                ("pdsm_size".into(), ParamValue::Int(512)),
                ("shadow_map_size".into(), ParamValue::Int(256)),
                ("disk_cache".into(), ParamValue::Bool(false)),
            ],
            worker: worker_under_test(),
            ..ViewerOptions::default()
        },
    )?;
    // Each UI frame shows the technique frame it asked for (the window waits at most
    // `FRAME_WAIT`); `a_slow_technique_frame_never_holds_the_ui` tests the window's way.
    app.set_frame_wait(std::time::Duration::MAX);
    app.set_reference_param("samples_per_axis", ParamValue::Int(4));
    app.set_reference_param("shadow_map_size", ParamValue::Int(256));
    let mut harness = Harness::builder()
        .with_size(SIZE)
        .renderer(WgpuTestRenderer::from_render_state(render_state))
        .build_ui_state(|ui, app: &mut ViewerApp| app.ui(ui), app);
    harness.run_steps(1);
    // The first frame draws only a few of the 64 light sample maps (8 of 256²) and returns.
    let progress = harness.state().build_progress();
    ensure!(
        progress.is_some_and(|(done, total)| total == 64 && done < total),
        "the first frame returned before drawing every sample map: {progress:?}"
    );
    ensure!(harness.state().technique_error().is_none());
    ensure!(harness.state().points().is_empty());
    // Later frames draw the rest, then the 512 PDSM rows build on a thread of their own.
    for _ in 0..64 {
        if harness
            .state()
            .build_progress()
            .is_some_and(|(_, total)| total == 512)
        {
            break;
        }
        harness.run_steps(1);
    }
    let progress = harness.state().build_progress();
    ensure!(
        progress.is_some_and(|(_, total)| total == 512),
        "the frame returned while the rows build: {progress:?}"
    );
    ensure!(harness.state().points().is_empty());
    harness.get_by_label("Cancel").click();
    for _ in 0..2_000 {
        harness.run_steps(1);
        if harness.state().build_cancelled() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    ensure!(harness.state().build_cancelled(), "the build was cancelled");
    ensure!(harness.state().build_progress().is_none());
    harness.run_steps(1);
    harness.get_by_label("Build again").click();
    harness.run_steps(1);
    ensure!(
        harness.state().build_progress().is_some(),
        "Build again starts a new build"
    );
    Ok(())
}

/// Small settings for the slow techniques, so a test that visits every technique stays short.
fn small_settings(
) -> std::collections::BTreeMap<String, std::collections::BTreeMap<String, ParamValue>> {
    let mut settings = std::collections::BTreeMap::new();
    let mut set = |technique: &str, values: &[(&str, ParamValue)]| {
        settings.insert(
            technique.to_string(),
            values
                .iter()
                .map(|(name, value)| (name.to_string(), value.clone()))
                .collect(),
        );
    };
    set(
        "reference",
        &[
            ("samples_per_axis", ParamValue::Int(4)),
            ("shadow_map_size", ParamValue::Int(256)),
        ],
    );
    set(
        "pdsm",
        &[
            ("pdsm_size", ParamValue::Int(32)),
            ("samples", ParamValue::Int(4)),
            ("shadow_map_size", ParamValue::Int(128)),
            ("disk_cache", ParamValue::Bool(false)),
        ],
    );
    set("bitmask", &[("shadow_map_size", ParamValue::Int(256))]);
    set(
        "backprojection",
        &[("shadow_map_size", ParamValue::Int(256))],
    );
    set(
        "adaptive",
        &[
            ("shadow_map_size", ParamValue::Int(128)),
            ("max_shadow_maps", ParamValue::Int(8)),
        ],
    );
    settings
}

/// Issue 31: the render size follows the window only (the side panels have fixed widths), so
/// switching through every technique with the picker, opening every section, every view mode,
/// a confirmation and an error never restart the reference.
#[test]
fn switching_techniques_and_opening_sections_never_restarts_the_reference() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let mut harness = harness("hard")?;
    let mut state = harness.state().state();
    state.params = small_settings();
    let state_path = dir.path().join("state.json");
    state.save(&state_path)?;
    harness.state_mut().load_state(&state_path);
    run_until_converged(&mut harness)?;
    let size = harness.state().render_size().context("rendered")?;
    let accumulations = harness.state().reference_accumulations();
    let check = |h: &Harness<ViewerApp>, what: &str| -> Result<()> {
        ensure!(
            h.state().render_size() == Some(size),
            "{what}: render size {:?}, was {size:?}",
            h.state().render_size()
        );
        ensure!(
            h.state().reference_accumulations() == accumulations
                && h.state().reference_progress().is_complete(),
            "{what}: the reference restarted ({} accumulations, was {accumulations}; {:?})",
            h.state().reference_accumulations(),
            h.state().reference_progress()
        );
        Ok(())
    };
    for section in ["Scene", "Light", "Camera", "Files"] {
        harness
            .get_by_role_and_label(Role::DisclosureTriangle, section)
            .click();
        harness.run_steps(2);
        check(&harness, &format!("opening {section}"))?;
    }
    let ids: Vec<String> = softshadow::registry()
        .iter()
        .map(|t| t.id.to_string())
        .collect();
    for id in &ids {
        harness
            .get_by_role_and_label(Role::ComboBox, "Technique")
            .click();
        harness.run_steps(2);
        harness
            .query_all_by_label(id)
            .last()
            .with_context(|| format!("{id} in the picker"))?
            .click();
        harness.run_steps(3);
        ensure!(harness.state().technique_id() == id, "picked {id}");
        check(&harness, &format!("switching to {id}"))?;
    }
    for mode in ViewMode::ALL {
        harness.get_by_label(mode.label()).click();
        harness.run_steps(2);
        check(&harness, &format!("view mode {mode:?}"))?;
    }
    harness
        .state_mut()
        .save_state(&dir.path().join("saved.json"));
    harness.state_mut().open_scene("no-such-scene");
    harness.run_steps(2);
    check(&harness, "a confirmation and an error")?;
    Ok(())
}

/// The rectangles of the left panel's controls, by label.
fn control_rects(harness: &Harness<ViewerApp>) -> Vec<(String, egui::Rect)> {
    [
        "Technique",
        "Defaults",
        "render size",
        "Light",
        "Camera",
        "Files",
        "Save state",
        "Load",
    ]
    .into_iter()
    .filter_map(|label| {
        harness
            .query_all_by_label(label)
            .find(|n| n.rect().left() < SIZE.x * 0.3)
            .map(|n| (label.to_string(), n.rect()))
    })
    .collect()
}

/// Issue 31: a confirmation, an error, a view mode's legend and its own control take space of
/// their own (over the image, or a reserved row): no control of the left panel moves when they
/// appear. Snapshots of both states, the measurements panel masked.
#[test]
fn messages_and_legends_leave_the_controls_where_they_were() -> Result<()> {
    // A fixed folder, not a random temporary one: the confirmation naming it is in the snapshot.
    let dir = std::env::temp_dir().join("softshadow-viewer-messages-test");
    std::fs::create_dir_all(&dir)?;
    let mut harness = harness("pcss")?;
    harness
        .get_by_role_and_label(Role::DisclosureTriangle, "Files")
        .click();
    harness.run_steps(2);
    let before = control_rects(&harness);
    ensure!(before.len() == 6, "every control found: {before:?}");
    snapshot(&mut harness, "viewer_messages_hidden")?;

    harness.state_mut().save_state(&dir.join("state.json"));
    harness.state_mut().open_scene("no-such-scene");
    harness.get_by_label(ViewMode::Difference.label()).click();
    harness.run_steps(2);
    harness
        .query_by_label_contains("saved the state to")
        .context("the confirmation is shown")?;
    harness
        .query_by_label_contains("no-such-scene")
        .context("the error is shown")?;
    harness
        .query_by_label_contains("too dark")
        .context("the difference legend is shown")?;
    ensure!(
        control_rects(&harness) == before,
        "{:?}\nvs\n{before:?}",
        control_rects(&harness)
    );
    snapshot(&mut harness, "viewer_messages_shown")?;

    // The split view's divider and the debug view's picker share one reserved row.
    for mode in [ViewMode::Split, ViewMode::Debug, ViewMode::Shaded] {
        harness.get_by_label(mode.label()).click();
        harness.run_steps(2);
        ensure!(
            control_rects(&harness) == before,
            "{mode:?}: {:?}",
            control_rects(&harness)
        );
    }
    Ok(())
}

/// Issue 31: the plot keeps its points per scene, light and camera: an orbit starts an empty
/// view and keeps the earlier one's point, which the checkbox shows.
#[test]
fn the_plot_keeps_points_across_an_orbit() -> Result<()> {
    let mut harness = harness("hard")?;
    harness.run_steps(2);
    ensure!(
        harness.state().points().len() == 1,
        "{:?}",
        harness.state().points()
    );
    let end = press_and_drag(
        &mut harness,
        egui::pos2(250.0 + 100.0, SIZE.y * 0.5),
        15.0,
        3,
    );
    // The reference waits while the camera moves: the new view has none of its samples (the
    // old view's full count is not shown as this one's).
    ensure!(harness.state().stale_metrics().is_some());
    harness
        .query_by_label_contains("reference 0 / 16 light samples")
        .context("the moved view's progress starts at 0")?;
    release(&mut harness, end);
    ensure!(
        harness.state().points_of_other_views() == 1,
        "the first view's point is kept"
    );
    run_until_converged(&mut harness)?;
    harness.run_steps(6);
    ensure!(
        harness.state().points().len() == 1 && harness.state().points_of_other_views() == 1,
        "a point for the new camera beside the old one: {:?}",
        harness.state().points()
    );
    harness
        .get_by_label_contains("show 1 points of 1 other views")
        .click();
    harness.run_steps(1);
    ensure!(
        harness.state().errors().is_empty(),
        "{:?}",
        harness.state().errors()
    );
    Ok(())
}

/// `hard`, sleeping in every frame: a technique whose frame takes more than a second.
struct Sleepy {
    inner: Box<dyn softshadow_core::ShadowTechnique>,
    sleep: std::time::Duration,
    /// Frames rendered with the caches dropped (the cost frames).
    cost_frames: std::sync::Arc<std::sync::atomic::AtomicUsize>,
    cache_dropped: bool,
}

impl softshadow_core::ShadowTechnique for Sleepy {
    fn id(&self) -> &str {
        "sleepy"
    }
    fn settings(&self) -> &dyn softshadow_core::TechniqueSettings {
        self.inner.settings()
    }
    fn settings_mut(&mut self) -> &mut dyn softshadow_core::TechniqueSettings {
        self.inner.settings_mut()
    }
    fn requirements(&self) -> softshadow_core::Requirements {
        self.inner.requirements()
    }
    fn prepare(
        &mut self,
        gpu: &Gpu,
        inputs: &softshadow_core::ShadowInputs<'_>,
    ) -> Result<(), softshadow_core::TechniqueError> {
        self.inner.prepare(gpu, inputs)
    }
    fn invalidate_cache(&mut self) {
        self.cache_dropped = true;
        self.inner.invalidate_cache();
    }
    fn render(
        &mut self,
        frame: &mut softshadow_core::Frame<'_>,
        inputs: &softshadow_core::ShadowInputs<'_>,
        out: &softshadow_core::VisibilityBuffer,
    ) -> Result<(), softshadow_core::TechniqueError> {
        if std::mem::take(&mut self.cache_dropped) {
            self.cost_frames
                .fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        }
        std::thread::sleep(self.sleep);
        self.inner.render(frame, inputs, out)
    }
}

/// A viewer showing `sleepy` (hard, sleeping `sleep` per frame) on atty-square, each UI frame
/// waiting at most `frame_wait` for the technique's frame; with the counter of its cost frames.
fn sleepy_harness(
    sleep: std::time::Duration,
    frame_wait: std::time::Duration,
) -> Result<(
    Harness<'static, ViewerApp>,
    std::sync::Arc<std::sync::atomic::AtomicUsize>,
)> {
    let cost_frames = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let hard = softshadow::registry()
        .get("hard")
        .context("hard is built in")?
        .clone();
    let counter = cost_frames.clone();
    let create = hard.create.clone();
    let sleepy = softshadow_core::TechniqueInfo::new(
        "sleepy",
        "hard, sleeping for a while every frame",
        "test",
        hard.params.clone(),
        move |gpu| {
            Ok(Box::new(Sleepy {
                inner: create(gpu)?,
                sleep,
                cost_frames: counter.clone(),
                cache_dropped: false,
            }) as Box<dyn softshadow_core::ShadowTechnique>)
        },
    );
    let mut registry = softshadow::registry();
    registry.add(sleepy)?;
    let gpu = Gpu::new_headless().context("the viewer UI tests need a GPU adapter")?;
    let render_state = softshadow_viewer::render_state(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    let mut app = ViewerApp::new(
        gpu,
        render_state.renderer.clone(),
        &ViewerOptions {
            registry,
            scene: "atty-square".into(),
            technique: "sleepy".into(),
            ..ViewerOptions::default()
        },
    )?;
    app.set_frame_wait(frame_wait);
    app.set_reference_param("samples_per_axis", ParamValue::Int(4));
    app.set_reference_param("shadow_map_size", ParamValue::Int(256));
    let harness = Harness::builder()
        .with_size(SIZE)
        .renderer(WgpuTestRenderer::from_render_state(render_state))
        .build_ui_state(|ui, app: &mut ViewerApp| app.ui(ui), app);
    Ok((harness, cost_frames))
}

/// Issue 31: a frame slower than a second is measured once, not five times (five frames of the
/// reference technique froze the viewer for three minutes), and its point still appears.
#[test]
fn a_slow_frame_is_measured_once() -> Result<()> {
    // Each UI frame waits for the technique frame it asked for.
    let (mut harness, cost_frames) = sleepy_harness(
        std::time::Duration::from_millis(1100),
        std::time::Duration::MAX,
    )?;
    harness.run_steps(2);
    let frames = cost_frames.load(std::sync::atomic::Ordering::SeqCst);
    ensure!(frames == 1, "{frames} frames with the caches dropped");
    ensure!(
        harness.state().points().len() == 1,
        "{:?}",
        harness.state().points()
    );
    harness
        .query_by_label_contains("not repeated")
        .context("the panel says why the cost rests on one frame")?;
    // Switching away: the next frame is the other technique's.
    harness.state_mut().select_technique("hard");
    harness.step();
    ensure!(harness.state().technique_id() == "hard");
    ensure!(cost_frames.load(std::sync::atomic::Ordering::SeqCst) == 1);
    Ok(())
}

/// Issue 31: the technique's frames run on the render worker, so while a frame of many seconds
/// runs the UI keeps drawing and answering clicks, the frame shows its progress with Cancel,
/// Cancel stops waiting for it, and a switch to another technique is immediate. Counts UI frames
/// and state changes, not times: the technique sleeps far longer than every step below takes.
#[test]
fn a_slow_technique_frame_never_holds_the_ui() -> Result<()> {
    let (mut harness, _) = sleepy_harness(
        std::time::Duration::from_secs(60),
        softshadow_viewer::app::FRAME_WAIT,
    )?;
    // The UI draws frame after frame while the technique's first frame sleeps.
    harness.run_steps(5);
    ensure!(
        harness.state().technique_frame_running(),
        "five UI frames were drawn while the technique's first frame runs"
    );
    let mut ui_frames = 5;
    while harness.state().slow_frame_seconds().is_none() {
        harness.step();
        ui_frames += 1;
        ensure!(ui_frames < 2000, "the slow frame never showed its progress");
    }
    ensure!(harness.state().points().is_empty());
    // A click is answered mid-frame: the view mode changes.
    harness.get_by_label("Difference").click();
    harness.run_steps(2);
    ensure!(harness.state().view_mode() == ViewMode::Difference);
    ensure!(
        harness.state().slow_frame_seconds().is_some(),
        "the technique's frame is still running"
    );
    harness
        .query_by_label_contains("computing a frame")
        .context("the slow frame shows its progress")?;
    // Cancel stops waiting for it; Render again starts it over.
    harness.get_by_label("Cancel").click();
    harness.run_steps(2);
    ensure!(harness.state().slow_frame_seconds().is_none());
    ensure!(
        harness
            .state()
            .cancelled_frame()
            .is_some_and(|m| m.contains("cancelled")),
        "{:?}",
        harness.state().cancelled_frame()
    );
    harness
        .query_by_label("Render again")
        .context("a cancelled frame offers Render again")?;
    harness.get_by_label("Render again").click();
    harness.run_steps(2);
    ensure!(harness.state().cancelled_frame().is_none());
    // Switching away from the slow technique while its frame runs is immediate: the next
    // technique's frame is shown and timed while the old frame still sleeps.
    harness.state_mut().select_technique("hard");
    harness.state_mut().set_frame_wait(std::time::Duration::MAX);
    harness.run_steps(2);
    ensure!(harness.state().technique_error().is_none());
    ensure_hard_was_timed(&harness)?;
    Ok(())
}

/// `pcf.wgsl` of `examples/wgsl/`.
fn pcf_example() -> Result<String> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/wgsl/pcf.wgsl");
    Ok(std::fs::read_to_string(path)?)
}

#[test]
fn a_saved_wgsl_file_is_reloaded_and_a_broken_one_keeps_the_last_good_image() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("live_pcf.wgsl");
    std::fs::write(&path, pcf_example()?)?;
    let mut registry = softshadow::registry();
    let id = softshadow_wgsl::register_file(&mut registry, &path)?;
    let gpu = Gpu::new_headless().context("the viewer UI tests need a GPU adapter")?;
    let render_state = softshadow_viewer::render_state(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    let mut app = ViewerApp::new(
        gpu,
        render_state.renderer.clone(),
        &ViewerOptions {
            registry,
            scene: "atty-square".into(),
            technique: id.clone(),
            worker: worker_under_test(),
            ..ViewerOptions::default()
        },
    )?;
    // Each UI frame shows the technique frame it asked for (the window waits at most
    // `FRAME_WAIT`); `a_slow_technique_frame_never_holds_the_ui` tests the window's way.
    app.set_frame_wait(std::time::Duration::MAX);
    app.set_reference_param("samples_per_axis", ParamValue::Int(4));
    app.set_reference_param("shadow_map_size", ParamValue::Int(256));
    let mut harness = Harness::builder()
        .with_size(SIZE)
        .renderer(WgpuTestRenderer::from_render_state(render_state))
        .build_ui_state(|ui, app: &mut ViewerApp| app.ui(ui), app);
    harness.run_steps(7);
    let first = harness
        .state()
        .metrics()
        .context("metrics of the first version")?
        .mae_shadowed;
    ensure!(
        harness.state().points().len() == 1,
        "{:?}",
        harness.state().points()
    );

    // Version 2: no shadow at all, with a parameter of its own.
    std::fs::write(
        &path,
        "// Draws no shadow.\n// @param level: f32 = 1.0 in 0.0..=1.0, V everywhere\n\
         fn visibility(s: Surface, pixel: vec2<i32>) -> f32 {\n    return params.level;\n}\n// @contract 3\n",
    )?;
    harness.run_steps(7);
    let app = harness.state();
    ensure!(
        app.technique_params()
            .is_some_and(|p| p.get("level").is_some()),
        "the new version's parameter: {:?}",
        app.technique_params()
    );
    let second = app
        .metrics()
        .context("metrics of the second version")?
        .mae_shadowed;
    ensure!(
        second > first + 0.05,
        "an all-lit version must measure worse than the pcf: {second} against {first}"
    );
    let names: Vec<String> = app.points().iter().map(|p| p.series()).collect();
    ensure!(
        names.len() == 2
            && names.contains(&format!("{id} v1"))
            && names.contains(&format!("{id} v2")),
        "the new version is a new point, the old one stays as v1: {names:?}"
    );
    // Issue 43: each version keeps its legend entry.
    for version in ["v1", "v2"] {
        harness
            .query_by_label(&format!("{id} {version}"))
            .with_context(|| format!("the legend lists {id} {version}"))?;
    }

    // Version 3 does not compile: the error is shown, the last good version keeps drawing.
    std::fs::write(
        &path,
        "// @param level: f32 = 1.0 in 0.0..=1.0, V everywhere\n\
         fn visibility(s: Surface, pixel: vec2<i32>) -> f32 {\n    return params.level +;\n}\n// @contract 3\n",
    )?;
    harness.run_steps(3);
    let shown = format!("{}:3:", path.display());
    harness
        .query_by_label_contains(&shown)
        .with_context(|| format!("the error `{shown}...` is shown in the panel"))?;
    let app = harness.state();
    ensure!(
        app.technique_error().is_none(),
        "{:?}",
        app.technique_error()
    );
    ensure!(
        app.technique_params()
            .is_some_and(|p| p.get("level").is_some()),
        "the last good version stays"
    );
    let kept = app
        .metrics()
        .context("the last good version's metrics")?
        .mae_shadowed;
    ensure!(kept == second, "the image changed: {kept} against {second}");
    ensure!(app.points().len() == 2, "{:?}", app.points());
    Ok(())
}

/// Issue 28: the timeline plays a path over the open scene: the caster moves step by step, each
/// shown frame is measured against its exact answer (error, and flicker against the frame
/// before), Record writes technique beside exact, and closing the path restores the scene. On
/// the `still` path a deterministic technique's flicker is exactly 0.
#[test]
fn the_timeline_plays_a_path_with_live_error_and_flicker_and_records_it() -> Result<()> {
    let mut harness = harness("hard")?;
    harness.state_mut().set_render_size(Some((96, 64)));
    harness.run_steps(2);
    let light = *harness.state().light();

    harness.state_mut().open_path(Some("still"));
    harness.state_mut().set_path_steps(4);
    harness.state_mut().set_playing(true);
    harness.run_steps(6);
    let live = harness.state().live_metrics();
    ensure!(
        live.len() >= 4,
        "live metrics of the still path (looping): {live:?}"
    );
    ensure!(
        live.iter().filter_map(|m| m.flicker).all(|f| f == 0.0),
        "hard flickers on a still path: {live:?}"
    );

    // object-move: atty-square's caster (made dynamic) slides over the floor; it stays parallel
    // to the light, so every frame has a closed form (light-sweep turns the light: none).
    harness.state_mut().open_path(Some("object-move"));
    harness.state_mut().set_path_steps(6);
    harness.state_mut().set_path_looping(false);
    let folder = tempfile::tempdir()?;
    let recorded = folder.path().join("frames");
    harness
        .state_mut()
        .record_path(Some(recorded.to_str().context("utf-8 temp path")?));
    // Paused frames count once per step.
    harness.get_by_label("Path").click();
    harness.run_steps(3);
    harness.state_mut().set_playing(true);
    harness.run_steps(8);
    let (name, step, steps) = harness
        .state()
        .path_position()
        .context("the path stays open")?;
    ensure!(
        name == "object-move" && (step, steps) == (5, 6),
        "{name} {step}/{steps}: played to its end without looping; live {:?}, errors {:?}, technique error {:?}",
        harness.state().live_metrics(),
        harness.state().errors(),
        harness.state().technique_error()
    );
    let live = harness.state().live_metrics();
    ensure!(
        live.len() == 6,
        "one measurement per step: {live:?} ({:?})",
        harness.state().live_message()
    );
    ensure!(
        live.iter()
            .all(|m| m.mae_shadowed.is_finite() && m.mae_shadowed > 0.0),
        "{live:?}"
    );
    ensure!(
        live.iter().filter_map(|m| m.flicker).any(|f| f > 0.0),
        "hard's hard edge moves unlike the exact penumbra as the caster slides: {live:?}"
    );
    harness
        .query_by_label_contains("flicker")
        .context("the timeline shows the live flicker")?;
    harness.state_mut().record_path(None);
    let frame = image::open(recorded.join("frame-0000.png"))?;
    ensure!(
        (frame.width(), frame.height()) == (192, 64),
        "technique beside exact: {}x{}",
        frame.width(),
        frame.height()
    );
    ensure!(
        harness
            .state()
            .status()
            .is_some_and(|s| s.starts_with("recorded") && s.contains("animation.png")),
        "{:?} {:?}",
        harness.state().status(),
        harness.state().errors()
    );
    // Stop joins the frames into one animated PNG, every frame in it.
    let written = std::fs::read_dir(&recorded)?
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.file_name().to_string_lossy().starts_with("frame-"))
        })
        .count() as u32;
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(
        recorded.join("animation.png"),
    )?));
    let reader = decoder.read_info()?;
    let control = reader
        .info()
        .animation_control
        .context("animation.png is animated")?;
    ensure!(
        written >= 6 && control.num_frames == written,
        "{} animation frames of {written} PNG frames",
        control.num_frames
    );
    ensure!((reader.info().width, reader.info().height) == (192, 64));

    // The steps' GPU timings, split as the benchmark splits them: object-move slides the caster
    // (light-space work redone), then holds it (still steps keep that work), never moving only
    // the camera.
    let timings = harness.state().path_timings();
    let light_moving = timings
        .iter()
        .find(|t| t.kind == FrameKind::Light)
        .context("object-move has light-moving steps")?;
    ensure!(
        light_moving.steps >= 4 && light_moving.total_ms > 0.0 && !light_moving.passes.is_empty(),
        "object-move's step timings: {timings:?}"
    );
    ensure!(
        timings.iter().all(|t| t.kind != FrameKind::Camera),
        "{timings:?}"
    );
    if let Some(still) = timings.iter().find(|t| t.kind == FrameKind::Still) {
        ensure!(
            still.passes.len() < light_moving.passes.len(),
            "a still step keeps the light-space passes a moving caster redoes: {timings:?}"
        );
    }
    harness
        .query_by_label_contains("light moving ms")
        .context("the timing panel shows the path's table")?;

    // light-sweep turns the light away from parallel to the caster: no closed form. The live
    // error is measured against the analytic exact answer (a light with area, a small frame,
    // with or without ray queries), with the irradiance error beside it, and the panel says so.
    harness.state_mut().open_path(Some("light-sweep"));
    harness.state_mut().set_path_steps(3);
    harness.state_mut().set_playing(true);
    harness.run_steps(5);
    let live = harness.state().live_metrics();
    ensure!(
        live.len() >= 2
            && live
                .iter()
                .all(|m| m.mae_shadowed.is_finite() && m.mae_shadowed > 0.0),
        "live metrics along light-sweep: {live:?} ({:?})",
        harness.state().live_message()
    );
    ensure!(
        live.iter().any(|m| m.exact == LiveExact::Analytic
            && m.irradiance_mae_shadowed.is_some_and(f64::is_finite)),
        "light-sweep's tilted frames use the analytic exact answer: {live:?}"
    );
    eprintln!(
        "live analytic exact answers at 96x64: {:?}",
        live.iter()
            .map(|m| (m.exact.to_string(), m.exact_ms))
            .collect::<Vec<_>>()
    );
    harness
        .query_by_label_contains("analytic (exact")
        .context("the timeline says which exact answer it used")?;
    harness
        .query_by_label_contains("irradiance error")
        .context("the timeline shows the irradiance error")?;
    // orbit turns only the camera: camera-only steps, never mixed into the light-moving ones.
    harness.state_mut().open_path(Some("orbit"));
    harness.state_mut().set_path_steps(4);
    harness.state_mut().set_playing(true);
    harness.run_steps(5);
    let timings = harness.state().path_timings();
    ensure!(
        timings.iter().all(|t| t.kind == FrameKind::Camera) && !timings.is_empty(),
        "orbit's steps move only the camera: {timings:?}"
    );

    harness.state_mut().open_path(None);
    harness.run_steps(1);
    ensure!(
        *harness.state().light() == light,
        "closing the path restores the light"
    );
    Ok(())
}

// ----- Issue 43: the plot is the answer, every number true, versions and recordings kept,
// nothing cut -----

/// Issue 43: the plot is a panel of its own under the image (at least a third of the window),
/// hovering a point names its setting, error and cost, and a click restores that setting.
#[test]
fn the_plot_panel_names_a_point_on_hover_and_a_click_restores_its_setting() -> Result<()> {
    let mut harness = harness("pcss")?;
    harness.run_steps(7);
    let heading = harness.get_by_label("Error against time").rect();
    ensure!(
        heading.top() <= SIZE.y * 2.0 / 3.0 && heading.left() >= 250.0,
        "the plot panel spans at least a third of the window's height under the image: {heading:?}"
    );
    harness
        .state_mut()
        .set_param("filter_samples", ParamValue::Int(8));
    harness.run_steps(7);
    let drawn = harness.state().plot_point_positions();
    ensure!(drawn.len() == 2, "two points drawn: {drawn:?}");
    let (at, point) = drawn
        .iter()
        .find(|(_, p)| {
            p.params
                .contains(&("filter_samples".into(), ParamValue::Int(32)))
        })
        .cloned()
        .context("the default setting's point")?;
    harness.hover_at(at);
    harness.run_steps(2);
    harness
        .query_by_label_contains("click: show this setting")
        .context("the hover names the point")?;
    harness
        .query_by_label_contains(&format!("mae_shadowed {:.4}", point.error))
        .context("the hover gives its error")?;
    harness
        .query_by_label_contains("median of 5 clean frames")
        .context("the hover says what the cost rests on")?;
    harness.event(egui::Event::PointerButton {
        pos: at,
        button: egui::PointerButton::Primary,
        pressed: true,
        modifiers: egui::Modifiers::NONE,
    });
    harness.step();
    harness.event(egui::Event::PointerButton {
        pos: at,
        button: egui::PointerButton::Primary,
        pressed: false,
        modifiers: egui::Modifiers::NONE,
    });
    harness.run_steps(2);
    let samples = harness
        .state()
        .technique_params()
        .and_then(|p| p.get("filter_samples").cloned());
    ensure!(
        samples == Some(ParamValue::Int(32)),
        "a click restores the point's setting: {samples:?}"
    );
    Ok(())
}

/// Issue 43: a technique that keeps a history (pcss with `temporal`) is plotted with the error
/// of its settled frame, labelled, not its first frame's.
#[test]
fn a_technique_with_a_history_is_plotted_once_settled() -> Result<()> {
    let mut harness = harness("pcss")?;
    harness
        .state_mut()
        .set_param("temporal", ParamValue::Bool(true));
    harness
        .state_mut()
        .set_param("max_history", ParamValue::Int(4));
    let temporal = |h: &Harness<ViewerApp>| {
        h.state()
            .points()
            .iter()
            .find(|p| {
                p.params
                    .contains(&("temporal".into(), ParamValue::Bool(true)))
            })
            .cloned()
    };
    // Five cost frames (each drops the history), then still frames until four are averaged.
    harness.run_steps(6);
    ensure!(
        temporal(&harness).is_none(),
        "no point before the history settled: {:?}",
        harness.state().points()
    );
    for _ in 0..12 {
        harness.step();
        if temporal(&harness).is_some() {
            break;
        }
    }
    let point = temporal(&harness).context("a point once settled")?;
    ensure!(point.settled_after == Some(4), "{point:?}");
    harness
        .query_by_label_contains("settled")
        .context("the plot labels it settled")?;
    Ok(())
}

/// Issue 43: "show N points of other views" means this scene's other cameras and lights, never
/// another scene's points.
#[test]
fn other_views_are_the_same_scenes_only() -> Result<()> {
    let mut harness = harness("hard")?;
    harness.run_steps(2);
    ensure!(harness.state().points().len() == 1);
    harness.state_mut().open_scene("stiff-contact");
    harness.run_steps(2);
    ensure!(
        harness.state().points_of_other_views() == 0,
        "another scene's point counted as another view: {}",
        harness.state().points_of_other_views()
    );
    ensure!(harness
        .query_by_label_contains("show 0 points of 0 other views")
        .is_some());
    Ok(())
}

/// `sleepy_harness` with a second technique, `watcher` (hard), that counts its cost frames run
/// while `sleepy` sleeps: a frame sharing the CPU with an abandoned one.
fn watched_sleepy_harness(
    sleep: std::time::Duration,
) -> Result<(
    Harness<'static, ViewerApp>,
    std::sync::Arc<std::sync::atomic::AtomicUsize>,
)> {
    use std::sync::{atomic::AtomicBool, atomic::AtomicUsize, Arc};
    let sleeping = Arc::new(AtomicBool::new(false));
    let overlapped = Arc::new(AtomicUsize::new(0));
    let hard = softshadow::registry()
        .get("hard")
        .context("hard is built in")?
        .clone();
    let mut registry = softshadow::registry();
    for (id, sleep) in [("sleepy", sleep), ("watcher", std::time::Duration::ZERO)] {
        let create = hard.create.clone();
        let (sleeping, overlapped) = (sleeping.clone(), overlapped.clone());
        registry.add(softshadow_core::TechniqueInfo::new(
            id,
            "hard, sleeping a while or watching who sleeps",
            "test",
            hard.params.clone(),
            move |gpu| {
                Ok(Box::new(Watched {
                    inner: create(gpu)?,
                    sleep,
                    sleeping: sleeping.clone(),
                    overlapped: overlapped.clone(),
                    cache_dropped: false,
                })
                    as Box<dyn softshadow_core::ShadowTechnique>)
            },
        ))?;
    }
    let gpu = Gpu::new_headless().context("the viewer UI tests need a GPU adapter")?;
    let render_state = softshadow_viewer::render_state(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    let mut app = ViewerApp::new(
        gpu,
        render_state.renderer.clone(),
        &ViewerOptions {
            registry,
            scene: "atty-square".into(),
            technique: "watcher".into(),
            ..ViewerOptions::default()
        },
    )?;
    app.set_frame_wait(softshadow_viewer::app::FRAME_WAIT);
    app.set_reference_param("samples_per_axis", ParamValue::Int(4));
    app.set_reference_param("shadow_map_size", ParamValue::Int(256));
    let harness = Harness::builder()
        .with_size(SIZE)
        .renderer(WgpuTestRenderer::from_render_state(render_state))
        .build_ui_state(|ui, app: &mut ViewerApp| app.ui(ui), app);
    Ok((harness, overlapped))
}

/// `hard` that sleeps (`sleepy`) or notes cost frames run while another sleeps (`watcher`).
struct Watched {
    inner: Box<dyn softshadow_core::ShadowTechnique>,
    sleep: std::time::Duration,
    sleeping: std::sync::Arc<std::sync::atomic::AtomicBool>,
    overlapped: std::sync::Arc<std::sync::atomic::AtomicUsize>,
    cache_dropped: bool,
}

impl softshadow_core::ShadowTechnique for Watched {
    fn id(&self) -> &str {
        if self.sleep.is_zero() {
            "watcher"
        } else {
            "sleepy"
        }
    }
    fn settings(&self) -> &dyn softshadow_core::TechniqueSettings {
        self.inner.settings()
    }
    fn settings_mut(&mut self) -> &mut dyn softshadow_core::TechniqueSettings {
        self.inner.settings_mut()
    }
    fn requirements(&self) -> softshadow_core::Requirements {
        self.inner.requirements()
    }
    fn prepare(
        &mut self,
        gpu: &Gpu,
        inputs: &softshadow_core::ShadowInputs<'_>,
    ) -> Result<(), softshadow_core::TechniqueError> {
        self.inner.prepare(gpu, inputs)
    }
    fn invalidate_cache(&mut self) {
        self.cache_dropped = true;
        self.inner.invalidate_cache();
    }
    fn render(
        &mut self,
        frame: &mut softshadow_core::Frame<'_>,
        inputs: &softshadow_core::ShadowInputs<'_>,
        out: &softshadow_core::VisibilityBuffer,
    ) -> Result<(), softshadow_core::TechniqueError> {
        use std::sync::atomic::Ordering::SeqCst;
        let cost = std::mem::take(&mut self.cache_dropped);
        if self.sleep.is_zero() {
            if cost && self.sleeping.load(SeqCst) {
                self.overlapped.fetch_add(1, SeqCst);
            }
        } else {
            self.sleeping.store(true, SeqCst);
            std::thread::sleep(self.sleep);
            self.sleeping.store(false, SeqCst);
        }
        self.inner.render(frame, inputs, out)
    }
}

/// Issue 43: a technique picked while another's frame runs shows its frames at once, but its
/// cost rests only on frames that ran alone; the banner says what the metrics wait for (not a
/// complete reference "re-accumulating"); a running frame's progress is estimated from the same
/// setting's earlier frames or not at all; Cancel keeps the measured cost.
#[test]
fn costs_rest_on_frames_that_ran_alone_and_banners_say_what_happens_now() -> Result<()> {
    let (mut harness, overlapped) = watched_sleepy_harness(std::time::Duration::from_millis(2500))?;
    let run_until = |h: &mut Harness<ViewerApp>, what: &str, done: &dyn Fn(&ViewerApp) -> bool| {
        for _ in 0..3000 {
            if done(h.state()) {
                return Ok(());
            }
            h.step();
        }
        anyhow::bail!("{what}: not reached")
    };
    run_until(&mut harness, "watcher's point", &|a| a.points().len() == 1)?;
    // sleepy's first frame: nothing of it to go by.
    harness.state_mut().select_technique("sleepy");
    run_until(&mut harness, "a slow frame", &|a| {
        a.slow_frame_seconds().is_some()
    })?;
    // The messages' area appears a frame after it is first laid out.
    harness.run_steps(2);
    harness
        .query_by_label_contains("no earlier frame of this setting")
        .with_context(|| {
            format!(
                "a first frame has no estimate: {:?}",
                harness
                    .query_all_by_label_contains(" ")
                    .map(|n| format!("{:?}", n.accesskit_node().value()))
                    .collect::<Vec<_>>()
            )
        })?;
    harness
        .query_by_label_contains("waiting for sleepy's frame of this setting")
        .context("the stale metrics say what they wait for")?;
    ensure!(harness.query_by_label_contains("re-accumulating").is_none());
    // Back to the watcher while sleepy sleeps: its frames show, its cost frames wait.
    harness.state_mut().select_technique("watcher");
    run_until(&mut harness, "watcher's frame", &|a| {
        a.timing_rows().iter().any(|r| r.name.starts_with("hard/"))
    })?;
    run_until(&mut harness, "watcher's cost", &|a| {
        a.cost_ms().is_some() && a.points().len() == 1
    })?;
    let overlapped = overlapped.load(std::sync::atomic::Ordering::SeqCst);
    ensure!(
        overlapped == 0,
        "{overlapped} cost frames ran beside an abandoned frame"
    );
    let point = harness.state().points()[0].clone();
    ensure!(point.cost_frames == 5, "{point:?}");
    // sleepy again: its one slow cost frame measured, then Cancel on a later frame keeps it.
    harness.state_mut().select_technique("sleepy");
    run_until(&mut harness, "sleepy's point", &|a| {
        a.points().iter().any(|p| p.technique == "sleepy")
    })?;
    run_until(&mut harness, "a later slow frame", &|a| {
        a.slow_frame_seconds().is_some()
    })?;
    harness.run_steps(2);
    harness.get_by_label("Cancel").click();
    harness.run_steps(2);
    ensure!(
        harness.state().cost_ms().is_some(),
        "Cancel keeps the measured cost"
    );
    harness
        .query_by_label_contains("cost of the technique")
        .context("the cost stays on screen")?;
    Ok(())
}

/// Issue 43: Record on a paused path plays it from its first step, writes exactly one frame per
/// step and stops at the path's end, loop or not.
#[test]
fn record_writes_one_frame_per_step_from_a_paused_path_and_stops_at_its_end() -> Result<()> {
    let mut harness = harness("hard")?;
    harness.state_mut().set_render_size(Some((96, 64)));
    // orbit turns the camera at every step: no two steps show the same frame.
    harness.state_mut().open_path(Some("orbit"));
    harness.state_mut().set_path_steps(6);
    harness.state_mut().set_path_looping(true);
    harness.state_mut().scrub_to(3);
    harness.run_steps(3);
    let folder = tempfile::tempdir()?;
    let recorded = folder.path().join("frames");
    harness
        .state_mut()
        .record_path(Some(recorded.to_str().context("utf-8 temp path")?));
    harness.run_steps(14);
    let status = harness.state().status().unwrap_or_default().to_string();
    ensure!(
        status.starts_with("recorded 6 frames"),
        "the recording stopped by itself after one pass: {status:?} {:?}",
        harness.state().errors()
    );
    let mut frames = Vec::new();
    for step in 0..6 {
        frames.push(image::open(recorded.join(format!("frame-{step:04}.png")))?.to_rgba8());
    }
    ensure!(!recorded.join("frame-0006.png").exists());
    for pair in frames.windows(2) {
        ensure!(pair[0] != pair[1], "two steps recorded the same frame");
    }
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(
        recorded.join("animation.png"),
    )?));
    let control = decoder.read_info()?.info().animation_control;
    ensure!(control.map(|c| c.num_frames) == Some(6), "{control:?}");
    Ok(())
}

/// Issue 43: every label and button of the side panels is inside its panel for every
/// technique, at 1280 x 800 and 1000 x 700 (long parameter names wrap, msm's view modes wrap);
/// the debug image picker names the view shown after a switch; the output paths default to the
/// viewer's own folder.
#[test]
fn nothing_is_cut_at_1280x800_and_1000x700() -> Result<()> {
    let mut harness = harness("backprojection")?;
    let mut state = harness.state().state();
    state.params = small_settings();
    let dir = tempfile::tempdir()?;
    let state_path = dir.path().join("state.json");
    state.save(&state_path)?;
    harness.state_mut().load_state(&state_path);
    harness.state_mut().set_render_size(Some((64, 48)));
    harness.state_mut().set_view_mode(ViewMode::Debug);
    harness.state_mut().set_debug_view(3);
    harness.run_steps(2);
    harness.state_mut().select_technique("pcss");
    harness.run_steps(2);
    let picker = harness.get_by_role_and_label(Role::ComboBox, "Debug image");
    ensure!(
        picker
            .accesskit_node()
            .value()
            .is_some_and(|v| !v.is_empty() && v != "none"),
        "the debug image picker names the view shown: {:?}",
        picker.accesskit_node().value()
    );
    harness.state_mut().set_view_mode(ViewMode::Shaded);
    // Tall enough that the Files header is on screen to be clicked, once laid out anew.
    harness.set_size(egui::vec2(1280.0, 800.0));
    harness.run_steps(3);
    harness
        .get_by_role_and_label(Role::DisclosureTriangle, "Files")
        .click();
    harness.run_steps(2);
    let output = softshadow_viewer::app::output_dir().display().to_string();
    let fields: Vec<String> = harness
        .query_all_by_role(Role::TextInput)
        .filter_map(|n| n.accesskit_node().value())
        .collect();
    ensure!(
        fields.iter().filter(|f| f.starts_with(&output)).count() >= 3,
        "screenshot, state and sweep default under {output}: {fields:?} {:?}",
        harness
            .query_all_by_role(Role::DisclosureTriangle)
            .map(|n| format!(
                "{:?} {:?} {:?}",
                n.accesskit_node().label(),
                n.accesskit_node().data().is_expanded(),
                n.rect()
            ))
            .collect::<Vec<_>>()
    );
    let ids: Vec<String> = softshadow::registry()
        .iter()
        .map(|t| t.id.to_string())
        .collect();
    for size in [egui::vec2(1280.0, 800.0), egui::vec2(1000.0, 700.0)] {
        harness.set_size(size);
        for id in &ids {
            harness.state_mut().select_technique(id);
            harness.run_steps(2);
            let left = softshadow_viewer::app::LEFT_PANEL_WIDTH;
            let right = size.x - softshadow_viewer::app::RIGHT_PANEL_WIDTH;
            for node in harness.query_all_by_role(Role::Label).chain(
                harness
                    .query_all_by_role(Role::Button)
                    .chain(harness.query_all_by_role(Role::Slider)),
            ) {
                let r = node.rect();
                let cut = (r.left() < left && r.right() > left + 0.5)
                    || (r.left() >= right && r.right() > size.x + 0.5);
                ensure!(
                    !cut,
                    "{id} at {size:?}: `{}` {r:?} is cut at its panel's edge",
                    node.accesskit_node().label().unwrap_or_default()
                );
            }
        }
    }
    Ok(())
}

/// Set in the environment of the render worker processes the tests below start: the test
/// binary run again is then the worker ([`render_worker_child`]).
const WORKER_CHILD_ENV: &str = "SOFTSHADOW_VIEWER_TEST_WORKER";

/// Not a test of its own: the render worker process of the tests that use one. Run as a test
/// of this binary (`--exact render_worker_child`) with [`WORKER_CHILD_ENV`] set, it serves the
/// built-in registry's techniques over stdin and stdout, as `workbench view-worker` does;
/// otherwise it does nothing.
#[test]
fn render_worker_child() {
    if std::env::var_os(WORKER_CHILD_ENV).is_some() {
        let code = softshadow_viewer::serve_render_worker(&softshadow::registry());
        std::process::exit(if code == std::process::ExitCode::SUCCESS {
            0
        } else {
            1
        });
    }
}

/// A render worker process: this test binary run again as [`render_worker_child`].
fn worker_process() -> softshadow_viewer::WorkerCommand {
    softshadow_viewer::WorkerCommand {
        program: std::env::current_exe()
            .expect("the test binary's path")
            .into_os_string(),
        args: [
            "render_worker_child",
            "--exact",
            "--nocapture",
            "--test-threads=1",
        ]
        .map(Into::into)
        .to_vec(),
        env: vec![(WORKER_CHILD_ENV.into(), "1".into())],
    }
}

/// The render worker of the tests on the built-in techniques: a thread, or with
/// `SOFTSHADOW_VIEWER_TEST_WORKERS=process` a process per technique, as `workbench view` has
/// (the tests that register a technique of their own keep the thread: the child's registry is
/// the built-in one).
fn worker_under_test() -> Option<softshadow_viewer::WorkerCommand> {
    let wanted = std::env::var("SOFTSHADOW_VIEWER_TEST_WORKERS");
    (wanted.as_deref() == Ok("process")).then(worker_process)
}

/// The viewer on `technique` of `registry` with a render worker process per technique (this
/// test binary's [`render_worker_child`]), waiting for each technique frame at most `wait`.
fn process_harness(
    registry: softshadow_core::Registry,
    technique: &str,
    wait: std::time::Duration,
) -> Result<Harness<'static, ViewerApp>> {
    let gpu = Gpu::new_headless().context("the viewer UI tests need a GPU adapter")?;
    let render_state = softshadow_viewer::render_state(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    let mut app = ViewerApp::new(
        gpu,
        render_state.renderer.clone(),
        &ViewerOptions {
            registry,
            scene: "atty-square".into(),
            technique: technique.into(),
            worker: Some(worker_process()),
            ..ViewerOptions::default()
        },
    )?;
    app.set_frame_wait(wait);
    app.set_reference_param("samples_per_axis", ParamValue::Int(4));
    app.set_reference_param("shadow_map_size", ParamValue::Int(256));
    Ok(Harness::builder()
        .with_size(SIZE)
        .renderer(WgpuTestRenderer::from_render_state(render_state))
        .build_ui_state(|ui, app: &mut ViewerApp| app.ui(ui), app))
}

/// Issue 42: a WGSL file whose `visibility` never returns runs in its worker process; the
/// window keeps answering, Cancel kills the process, and `hard` is then shown and timed. (A
/// literal `loop {}` is removed by lavapipe's compiler and returns; this loop's exit depends on
/// a parameter, so it is kept, and never taken.)
#[test]
fn a_never_ending_wgsl_file_is_cancelled_and_hard_is_shown_and_timed() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("forever.wgsl");
    std::fs::write(
        &path,
        "// Never returns: the loop's exit needs V < 0.\n\
         // @param step: f32 = 1.0 in 0.0..=1.0, What V grows by each turn\n\
         fn visibility(s: Surface, pixel: vec2<i32>) -> f32 {\n\
         \x20   var v = 0.0;\n\
         \x20   loop {\n\
         \x20       v = v + params.step;\n\
         \x20       if v < 0.0 { break; }\n\
         \x20   }\n\
         \x20   return v;\n\
         }\n\
         // @contract 3\n",
    )?;
    let mut registry = softshadow::registry();
    let id = softshadow_wgsl::register_file(&mut registry, &path)?;
    let mut harness = process_harness(registry, &id, softshadow_viewer::app::FRAME_WAIT)?;
    let started = std::time::Instant::now();
    while harness.state().slow_frame_seconds().is_none() {
        harness.step();
        ensure!(
            started.elapsed().as_secs() < 120,
            "the never-ending frame never showed its progress"
        );
    }
    // The window answers while the frame runs: a click changes the view mode.
    harness.get_by_label("Difference").click();
    harness.run_steps(2);
    ensure!(harness.state().view_mode() == ViewMode::Difference);
    ensure!(harness.state().technique_frame_running());
    harness.get_by_label("Cancel").click();
    let cancelled = std::time::Instant::now();
    harness.run_steps(2);
    ensure!(harness.state().cancelled_frame().is_some());
    harness
        .get_by_role_and_label(Role::ComboBox, "Technique")
        .click();
    harness.run_steps(2);
    harness.get_by_label("hard").click();
    harness.state_mut().set_frame_wait(std::time::Duration::MAX);
    let mut steps = 0;
    while harness.state().first_frame_ms().is_none() || ensure_hard_was_timed(&harness).is_err() {
        harness.step();
        steps += 1;
        ensure!(
            steps < 200,
            "hard was never shown and timed after the Cancel"
        );
    }
    eprintln!(
        "hard shown and timed {:.0} ms after the Cancel (its first frame {:.0} ms after it was picked)",
        cancelled.elapsed().as_secs_f64() * 1e3,
        harness.state().first_frame_ms().unwrap_or_default()
    );
    ensure!(harness.state().technique_error().is_none());
    ensure!(harness.state().worker_processes_started() == 2);
    Ok(())
}

/// Issue 42: a render worker whose device is lost (`SOFTSHADOW_FAULT=lost:K`'s way) shows the
/// driver's message, and the viewer starts a new worker, which renders and times the technique.
#[test]
fn a_lost_device_shows_its_message_and_a_new_worker_renders() -> Result<()> {
    let mut harness = process_harness(softshadow::registry(), "hard", std::time::Duration::MAX)?;
    harness.run_steps(2);
    ensure_hard_was_timed(&harness)?;
    // The next worker (the session's second, K = 1) loses its device before its first frame.
    harness.state_mut().set_faults("lost:1")?;
    harness.state_mut().select_technique("pcss");
    let mut steps = 0;
    while harness.state().first_frame_ms().is_none() {
        harness.step();
        steps += 1;
        ensure!(steps < 50, "no worker rendered pcss after the lost device");
    }
    let errors = harness.state().errors().join("\n");
    ensure!(
        errors.contains("lost") && errors.contains("a new render worker was started"),
        "the loss is shown: {errors}"
    );
    eprintln!("shown: {errors}");
    ensure!(harness.state().worker_processes_started() == 3);
    ensure!(harness.state().technique_id() == "pcss");
    ensure!(harness.state().technique_error().is_none());
    harness.run_steps(2);
    ensure!(harness
        .state()
        .timing_rows()
        .iter()
        .any(|r| r.name.starts_with("pcss/")));
    Ok(())
}
