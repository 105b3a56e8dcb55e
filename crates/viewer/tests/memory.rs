//! Resident memory across scene and technique switches (issue 16: 4.9 GB stayed resident after
//! `polycount-1m` was left for a 6-triangle scene; issue 15: no growth per switch over 10
//! minutes). Its own test binary, so no other test's allocations share the process.
//!
//! - `VIEWER_MEMORY_SCENE=polycount-1m` measures the case (docs/STABILITY.md, "Viewer memory over 10 minutes"); the
//!   default heavy scene keeps the test quick.
//! - `VIEWER_MEMORY_SECONDS=600` keeps switching for that long instead of 20 times and prints a
//!   sample every 5 s (docs/STABILITY.md).

use std::time::{Duration, Instant};

use anyhow::{ensure, Context, Result};
use egui_kittest::{wgpu::WgpuTestRenderer, Harness};
use softshadow_core::{wgpu, Gpu, ParamValue};
use softshadow_viewer::{ViewerApp, ViewerOptions};

/// Growth per switch, over the returns to the baseline's scene and technique, that fails the test.
const MAX_MIB_PER_SWITCH: f64 = 0.5;

/// The driver whose own per-frame leak the slope bound is not asserted on (docs/DEVICES.md,
/// "Mesa 22.3's leak per presented frame").
const KNOWN_LEAKY_DRIVER: &str = "Mesa 22.3";

/// That driver's leak per switch in this test, rounded up: 1.83-1.85 MiB measured (the per-switch
/// slope over the returns; docs/STABILITY.md, "Viewer memory over 10 minutes"); 2.60 in one run
/// under load (docs/DEVICES.md, "Mesa 25 and Mesa 22.3"), which the 64 MiB of the end bound
/// absorbs.
const KNOWN_LEAK_MIB_PER_SWITCH: f64 = 2.0;

/// A value of this process's `/proc/self/status` in MiB (`VmRSS`: resident now; `VmHWM`: the
/// peak resident so far).
fn status_mib(field: &str) -> Result<f64> {
    let status =
        std::fs::read_to_string("/proc/self/status").context("reading /proc/self/status")?;
    let line = status
        .lines()
        .find(|l| l.starts_with(field))
        .with_context(|| format!("no {field} line"))?;
    let kib: f64 = line
        .split_whitespace()
        .nth(1)
        .with_context(|| format!("{field} value"))?
        .parse()?;
    Ok(kib / 1024.0)
}

fn resident_mib() -> Result<f64> {
    status_mib("VmRSS:")
}

/// Least-squares slope of `y` against `x`.
fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    if sxx > 0.0 {
        sxy / sxx
    } else {
        0.0
    }
}

#[test]
fn resident_memory_returns_near_its_baseline_across_20_switches() -> Result<()> {
    let heavy = std::env::var("VIEWER_MEMORY_SCENE").unwrap_or_else(|_| "polycount-100k".into());
    let duration = std::env::var("VIEWER_MEMORY_SECONDS")
        .ok()
        .map(|s| s.parse().map(Duration::from_secs))
        .transpose()
        .context("VIEWER_MEMORY_SECONDS")?;
    // The viewer's own memory hints, as the window uses them.
    let gpu = Gpu::new_headless_with(softshadow_viewer::MEMORY_HINTS)
        .context("the memory test needs a GPU adapter")?;
    let device = gpu.device.clone();
    let driver = gpu.summary().driver;
    // What wgpu's allocator holds: allocated by live resources / reserved in memory blocks.
    let gpu_memory = move || {
        device.generate_allocator_report().map_or_else(
            || "no allocator report".to_string(),
            |r| {
                format!(
                    "wgpu allocated {:.0} MiB, reserved {:.0} MiB in {} blocks",
                    r.total_allocated_bytes as f64 / 1048576.0,
                    r.total_reserved_bytes as f64 / 1048576.0,
                    r.blocks.len()
                )
            },
        )
    };
    let render_state = softshadow_viewer::render_state(&gpu, wgpu::TextureFormat::Rgba8Unorm);
    let mut app = ViewerApp::new(
        gpu,
        render_state.renderer.clone(),
        &ViewerOptions {
            registry: softshadow::registry(),
            scene: "atty-square".into(),
            technique: "hard".into(),
            ..ViewerOptions::default()
        },
    )?;
    // Each UI frame shows the technique frame it asked for (the window waits at most
    // `FRAME_WAIT`); `a_slow_technique_frame_never_holds_the_ui` tests the window's way.
    app.set_frame_wait(std::time::Duration::MAX);
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
    println!("baseline {baseline:.0} MiB; {}", gpu_memory());
    let began = Instant::now();
    let mut last_sample = began;
    let mut on_heavy = Vec::new();
    // Resident memory each time the light scene and `hard` are back (the baseline's state).
    let mut back = Vec::new();
    let mut k = 0;
    loop {
        let done = match duration {
            Some(d) => began.elapsed() >= d && k % 4 == 0,
            None => k == 20,
        };
        if done {
            break;
        }
        switch(&mut harness, k)?;
        let now = resident_mib()?;
        match k % 4 {
            0 => on_heavy.push(now),
            3 => back.push((k as f64 + 1.0, now)),
            _ => {}
        }
        if duration.is_some() && last_sample.elapsed() >= Duration::from_secs(5) {
            last_sample = Instant::now();
            println!(
                "sample: {:.0} s, {} switches, resident {now:.0} MiB, peak {:.0} MiB; {}",
                began.elapsed().as_secs_f64(),
                k + 1,
                status_mib("VmHWM:")?,
                gpu_memory()
            );
        }
        k += 1;
    }
    let end = resident_mib()?;
    let peak = status_mib("VmHWM:")?;
    let per_switch = slope(&back);
    println!(
        "{heavy}: start {start:.0} MiB, baseline {baseline:.0} MiB, on the heavy scene {:?} MiB, \
         peak {peak:.0} MiB, end {end:.0} MiB after {k} switches over {:.0} s (back on \
         atty-square / hard); slope {per_switch:.3} MiB per switch over the {} returns; {}",
        on_heavy.iter().map(|m| m.round()).collect::<Vec<_>>(),
        began.elapsed().as_secs_f64(),
        back.len(),
        gpu_memory()
    );
    // Back on the light scene, what the heavy one held is released: within 64 MiB of the
    // baseline (docs/STABILITY.md, "Viewer memory over 10 minutes"), plus, on Mesa 22.3, the driver's own leak
    // over the run. Without that allowance the leak alone (about 37 MiB over 20 switches, more
    // on a loaded machine) failed the bound in one CI run of three.
    let leaky_driver = driver.contains(KNOWN_LEAKY_DRIVER);
    let driver_leak = if leaky_driver {
        KNOWN_LEAK_MIB_PER_SWITCH * k as f64
    } else {
        0.0
    };
    ensure!(
        end - baseline < 64.0 + driver_leak,
        "resident memory grew from {baseline:.0} to {end:.0} MiB across {k} switches (bound 64 \
         MiB plus {driver_leak:.0} MiB for the known leak of {driver})"
    );
    // No growth per switch (issue 15). Mesa 22.3's lavapipe leaks about 1 MiB per frame inside
    // the driver, 1.85 MiB per switch here (docs/DEVICES.md, "Mesa 22.3's leak per presented
    // frame"); flat on Mesa 25 (about 0 per switch). 0.5 MiB per switch catches that leak.
    if per_switch >= MAX_MIB_PER_SWITCH && leaky_driver {
        println!(
            "growth {per_switch:.2} MiB per switch on {driver}: the known lavapipe 22.3 leak, not \
             asserted; install mesa-vulkan-drivers from bookworm-backports (docs/DEVICES.md)"
        );
    } else {
        ensure!(
            per_switch < MAX_MIB_PER_SWITCH,
            "resident memory grows {per_switch:.2} MiB per switch (over {} returns to the \
             baseline's scene and technique) on {driver}",
            back.len()
        );
    }
    Ok(())
}
