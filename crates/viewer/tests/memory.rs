//! Resident memory across scene and technique switches (issue 16: 4.9 GB stayed resident after
//! `polycount-1m` was left for a 6-triangle scene). Its own test binary, so no other test's
//! allocations share the process. `VIEWER_MEMORY_SCENE=polycount-1m` measures the case
//! (docs/BENCHMARKS.md); the default heavy scene keeps the test quick.

use anyhow::{ensure, Context, Result};
use egui_kittest::{wgpu::WgpuTestRenderer, Harness};
use softshadow_core::{wgpu, Gpu, ParamValue};
use softshadow_viewer::{ViewerApp, ViewerOptions};

/// Resident set size of this process, MiB (Linux `/proc/self/status`).
fn resident_mib() -> Result<f64> {
    let status =
        std::fs::read_to_string("/proc/self/status").context("reading /proc/self/status")?;
    let line = status
        .lines()
        .find(|l| l.starts_with("VmRSS:"))
        .context("no VmRSS line")?;
    let kib: f64 = line
        .split_whitespace()
        .nth(1)
        .context("VmRSS value")?
        .parse()?;
    Ok(kib / 1024.0)
}

#[test]
fn resident_memory_returns_near_its_baseline_across_20_switches() -> Result<()> {
    let heavy = std::env::var("VIEWER_MEMORY_SCENE").unwrap_or_else(|_| "polycount-100k".into());
    let gpu = Gpu::new_headless().context("the memory test needs a GPU adapter")?;
    let render_state = softshadow_viewer::render_state(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    let mut app = ViewerApp::new(
        gpu,
        render_state.renderer.clone(),
        &ViewerOptions {
            scene: "atty-square".into(),
            technique: "hard".into(),
            ..ViewerOptions::default()
        },
    )?;
    app.set_reference_param("samples_per_axis", ParamValue::Int(4));
    app.set_reference_param("shadow_map_size", ParamValue::Int(256));
    app.set_render_size(Some((128, 96)));
    let mut harness = Harness::builder()
        .with_size(egui::vec2(860.0, 420.0))
        .renderer(WgpuTestRenderer::from_render_state(render_state))
        .build_ui_state(|ui, app: &mut ViewerApp| app.ui(ui), app);

    // One switch each way: heavy scene, pcss, light scene, hard.
    let switch = |harness: &mut Harness<ViewerApp>, k: usize| -> Result<()> {
        match k % 4 {
            0 => harness.state_mut().open_scene(&heavy),
            1 => harness.state_mut().select_technique("pcss"),
            2 => harness.state_mut().open_scene("atty-square"),
            _ => harness.state_mut().select_technique("hard"),
        }
        harness.run_steps(2);
        ensure!(
            harness.state().errors().is_empty(),
            "{:?}",
            harness.state().errors()
        );
        Ok(())
    };
    let start = resident_mib()?;
    // The first round builds pipelines and warms the allocators: the baseline is after it, back
    // on the light scene with the first technique.
    for k in 0..4 {
        switch(&mut harness, k)?;
    }
    let baseline = resident_mib()?;
    let mut peak = baseline;
    let mut on_heavy = Vec::new();
    for k in 0..20 {
        switch(&mut harness, k)?;
        let now = resident_mib()?;
        peak = peak.max(now);
        if k % 4 == 0 {
            on_heavy.push(now);
        }
    }
    let end = resident_mib()?;
    println!(
        "{heavy}: start {start:.0} MiB, baseline {baseline:.0} MiB, on the heavy scene {:?} MiB, \
         peak {peak:.0} MiB, end {end:.0} MiB (after 20 switches, back on atty-square / hard)",
        on_heavy.iter().map(|m| m.round()).collect::<Vec<_>>()
    );
    // Back on the light scene, what the heavy one held is released: within 64 MiB of the
    // baseline (measured: see docs/BENCHMARKS.md).
    ensure!(
        end - baseline < 64.0,
        "resident memory grew from {baseline:.0} to {end:.0} MiB across 20 switches"
    );
    Ok(())
}
