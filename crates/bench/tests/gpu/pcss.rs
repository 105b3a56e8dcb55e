//! PCSS's temporal mode (setting `temporal`; docs/TECHNIQUES.md, `pcss`, "Temporal mode"): off,
//! it is plain PCSS bit for bit; on, its first frame is plain PCSS and later ones rotate the
//! kernel and blend a history; on a still path its settled error is below plain PCSS's at the
//! same samples per frame (and an all-lit and a `hard` answer fail the bound), on `light-sweep`
//! it lags (reported in the run's JSON), and camera-only frames of `orbit` still keep the shadow
//! map. 64², atty-square (closed form; the CPU ray cast where the light tilts). Measured values
//! are in the comments and in docs/TECHNIQUES.md.

use anyhow::{ensure, Context, Result};
use softshadow::pcss::{Pcss, PcssSettings};
use softshadow_bench::{
    motion::FrameRecord,
    parse_params,
    results::{FrameKind, Run},
    Bench, BenchOptions, RunSpec,
};
use softshadow_core::{Renderer, SceneGpu, ShadowTechnique};

use crate::common::{all_lit_vs_exact, exact_bench, gpu, run_checked, vs_exact};

const SIZE: u32 = 64;
const SCENE: &str = "atty-square";
/// Samples per frame where plain PCSS is noisy (blocker search and filter each).
const FEW: &str = "8";

fn path_bench(path: &str, frames: u32) -> Result<Bench> {
    Ok(Bench::new(
        gpu()?,
        softshadow::registry(),
        BenchOptions {
            frames,
            warmup: 1,
            images: false,
            camera_only: false,
            path: Some(path.into()),
            ..Default::default()
        },
    )?)
}

fn spec(bench: &Bench, params: &[String]) -> Result<RunSpec> {
    Ok(RunSpec {
        scene: SCENE.into(),
        technique: softshadow::pcss::ID.into(),
        params: parse_params(bench.registry(), softshadow::pcss::ID, params)?,
        width: SIZE,
        height: SIZE,
        path: None,
    })
}

/// PCSS with `FEW` samples, temporal on or off, and `extra` settings.
fn few(temporal: bool, extra: &[&str]) -> Vec<String> {
    let mut p = vec![
        format!("blocker_samples={FEW}"),
        format!("filter_samples={FEW}"),
        format!("temporal={temporal}"),
    ];
    p.extend(extra.iter().map(|s| s.to_string()));
    p
}

/// Runs PCSS with `params` along the bench's path; the run and its per-frame records.
fn run_path(bench: &mut Bench, params: &[String]) -> Result<(Run, Vec<FrameRecord>)> {
    let spec = spec(bench, params)?;
    crate::common::run_path(bench, &spec)
}

/// Mean mae_shadowed of the last three frames (the settled error).
fn settled(records: &[FrameRecord]) -> f64 {
    let last = &records[records.len() - 3..];
    last.iter().map(|r| r.error.mae_shadowed).sum::<f64>() / last.len() as f64
}

fn history_frames(t: &Pcss) -> Option<f64> {
    t.stats().get("history_frames").copied()
}

/// Off, the temporal settings change nothing and PCSS is what it was; on, the first frame (no
/// history, the kernel at frame 0) is plain PCSS bit for bit and the second is not (the kernel
/// turned and the history blended in).
#[test]
fn temporal_off_is_plain_pcss_bit_for_bit_and_its_first_frame_too() -> Result<()> {
    let gpu = gpu()?;
    let scene = softshadow_scenes::load(SCENE)?.scene;
    let scene_gpu = SceneGpu::upload(&gpu, &scene);
    let mut renderer = Renderer::new(&gpu, SIZE, SIZE)?;
    let mut frame = |t: &mut Pcss| -> Result<Vec<f32>> {
        renderer.render(&scene_gpu, &scene.camera, &scene.light, t, None)?;
        Ok(renderer.read_visibility()?)
    };
    let few = PcssSettings {
        blocker_samples: 8,
        filter_samples: 8,
        ..Default::default()
    };
    let mut plain = Pcss::new(&gpu, few.clone())?;
    let v_plain = frame(&mut plain)?;
    ensure!(
        frame(&mut plain)? == v_plain,
        "plain PCSS changed by itself"
    );
    ensure!(
        history_frames(&plain).is_none(),
        "plain PCSS has no history"
    );
    let mut off = Pcss::new(
        &gpu,
        PcssSettings {
            max_history: 3,
            clamp_sigma: 5.0,
            ..few.clone()
        },
    )?;
    ensure!(
        frame(&mut off)? == v_plain,
        "the temporal settings changed PCSS with `temporal` off"
    );
    ensure!(off.debug_views().len() == plain.debug_views().len());

    let mut temporal = Pcss::new(
        &gpu,
        PcssSettings {
            temporal: true,
            ..few.clone()
        },
    )?;
    let first = frame(&mut temporal)?;
    ensure!(
        first == v_plain,
        "the temporal mode's first frame is not plain PCSS"
    );
    ensure!(history_frames(&temporal) == Some(1.0));
    let second = frame(&mut temporal)?;
    let changed = second.iter().zip(&v_plain).filter(|(a, b)| a != b).count();
    eprintln!(
        "second temporal frame: {changed} of {} pixels changed",
        second.len()
    );
    ensure!(changed > 0, "the kernel did not turn");
    ensure!(history_frames(&temporal) == Some(2.0));
    let names: Vec<String> = temporal.debug_views().into_iter().map(|d| d.name).collect();
    ensure!(
        names.iter().any(|n| n == "history frames") && names.iter().any(|n| n == "this frame"),
        "{names:?}"
    );
    // Switched off again: plain PCSS, and its debug views only.
    temporal.settings.temporal = false;
    ensure!(frame(&mut temporal)? == v_plain);
    ensure!(temporal.debug_views().len() == plain.debug_views().len());
    Ok(())
}

/// On a still path the temporal mode's last frames are closer to the exact answer than plain
/// PCSS at the same samples per frame, within a bound that "no shadow" and `hard` fail; its
/// flicker is not zero (its descriptor says so at `temporal=true`, not at the defaults).
#[test]
fn temporal_pcss_settles_below_plain_pcss_on_a_still_path() -> Result<()> {
    let info = softshadow::registry().find(softshadow::pcss::ID)?.clone();
    ensure!(info.varies_per_frame_at(&[]).is_none());
    let on = [(
        "temporal".to_string(),
        softshadow_core::ParamValue::Bool(true),
    )];
    ensure!(info.varies_per_frame_at(&on).is_some());

    let frames = 16;
    let mut bench = path_bench("still", frames)?;
    let (_, plain) = run_path(&mut bench, &few(false, &[]))?;
    let (run, temporal) = run_path(&mut bench, &few(true, &[]))?;
    let (plain_settled, temporal_settled) = (settled(&plain), settled(&temporal));
    let flicker = run
        .motion
        .as_ref()
        .and_then(|m| m.flicker.clone())
        .context("flicker")?;
    let errors: Vec<String> = temporal
        .iter()
        .map(|r| format!("{:.4}", r.error.mae_shadowed))
        .collect();
    eprintln!(
        "still, {FEW} samples: plain {plain_settled:.4}, temporal settled {temporal_settled:.4} (per frame {errors:?}), temporal flicker mean {:.4}",
        flicker.mean
    );
    ensure!(
        temporal[0].error.mae_shadowed == plain[0].error.mae_shadowed,
        "the first frame is plain PCSS"
    );
    ensure!(
        temporal_settled < 0.9 * plain_settled,
        "temporal {temporal_settled:.4} not below plain {plain_settled:.4}"
    );
    ensure!(flicker.mean > 0.0, "the kernel turns every frame");

    // Measured (loaded machine; errors do not depend on the load): plain 0.0557, temporal
    // settled 0.0373 (16 frames; plain PCSS at 16 + 16 samples: 0.0373), flicker 0.0025.
    // The bound is the 1.1x rule over the measured value.
    let bound = 0.041;
    ensure!(
        temporal_settled <= bound,
        "{temporal_settled:.4} above {bound}"
    );
    let mut still = exact_bench()?;
    let hard_spec = RunSpec {
        scene: SCENE.into(),
        technique: softshadow_core::COST_FLOOR_TECHNIQUE.into(),
        params: Vec::new(),
        width: SIZE,
        height: SIZE,
        path: None,
    };
    let hard = run_checked(&mut still, &hard_spec)?;
    let hard_error = vs_exact(&hard)?.mae_shadowed;
    let all_lit = all_lit_vs_exact(&hard)?.mae_shadowed;
    eprintln!("bound {bound}: hard {hard_error:.4}, all lit {all_lit:.4}");
    // Measured: hard 0.2063, all lit 0.4339.
    ensure!(hard_error > bound && all_lit > bound);
    // The still bench's extra frame sees what the descriptor says: the temporal mode's answer
    // changes with nothing moving, plain PCSS's does not.
    for (temporal, varies) in [(false, false), (true, true)] {
        let spec = spec(&still, &few(temporal, &[]))?;
        let run = run_checked(&mut still, &spec)?;
        let flicker = run.still_flicker.context("still flicker")?;
        eprintln!("still bench, temporal={temporal}: still flicker {flicker:.5}");
        ensure!((flicker > 0.0) == varies, "temporal={temporal}: {flicker}");
    }
    Ok(())
}

/// Behind a moving light the history lags: on `light-sweep` the frames right after the light
/// stops are worse than the settled ones, and the run's JSON says by how much and for how long.
#[test]
fn temporal_pcss_lags_behind_a_light_sweep_and_reports_it() -> Result<()> {
    let mut bench = path_bench("light-sweep", 20)?;
    let (run, records) = run_path(&mut bench, &few(true, &[]))?;
    let motion = run.motion.as_ref().expect("checked");
    let lag = motion
        .lag
        .as_ref()
        .context("light-sweep ends with 6 still frames at 20 frames")?;
    eprintln!("light-sweep, temporal, {FEW} samples: {lag:?}");
    ensure!(records[lag.last_moving_frame as usize].kind == FrameKind::Light);
    ensure!(
        lag.extra_error > 0.0 && lag.frames_to_settle > 0,
        "no lag: {lag:?}"
    );
    // The neighbourhood clip is the rejection: without it in effect (16 standard deviations)
    // the old light's shadow stays in the history longer. Measured: extra error 0.0046 at the
    // default 1, 0.0114 at 16.
    let (unclipped, _) = run_path(&mut bench, &few(true, &["clamp_sigma=16"]))?;
    let unclipped_lag = unclipped
        .motion
        .as_ref()
        .and_then(|m| m.lag.clone())
        .context("lag")?;
    eprintln!("without the clip: {unclipped_lag:?}");
    ensure!(
        unclipped_lag.extra_error > 1.5 * lag.extra_error,
        "the clip rejects nothing: {} against {}",
        unclipped_lag.extra_error,
        lag.extra_error
    );
    let json = serde_json::to_value(&run)?;
    let reported = &json["motion"]["lag"];
    ensure!(
        reported["extra_error"].as_f64() == Some(lag.extra_error)
            && reported["frames_to_settle"].as_u64() == Some(u64::from(lag.frames_to_settle)),
        "{reported}"
    );
    Ok(())
}

/// The temporal mode keeps the shadow map while only the camera moves (`orbit`), as plain PCSS
/// does, runs its resolve every frame, and keeps its history through the camera's motion, where
/// reprojection makes it better than plain PCSS at the same samples, not worse.
#[test]
fn camera_only_frames_of_temporal_pcss_keep_the_shadow_map() -> Result<()> {
    let frames = 8;
    let mut bench = path_bench("orbit", frames)?;
    let (run, records) = run_path(&mut bench, &few(true, &[]))?;
    let (plain, _) = run_path(&mut bench, &few(false, &[]))?;
    let error = |r: &Run| r.motion.as_ref().map(|m| m.error.mean).unwrap_or(f64::NAN);
    eprintln!(
        "orbit, {FEW} samples, {frames} frames: error plain {:.4}, temporal {:.4}",
        error(&plain),
        error(&run)
    );
    // Measured: plain 0.0550, temporal 0.0438.
    ensure!(error(&run) < error(&plain));
    ensure!(records[0].passes_run.iter().any(|p| p == "pcss/shadow_map"));
    for r in &records[1..] {
        ensure!(r.kind == FrameKind::Camera, "{:?}", r.kind);
        ensure!(
            !r.passes_run.iter().any(|p| p == "pcss/shadow_map"),
            "frame {}: {:?}",
            r.frame,
            r.passes_run
        );
        ensure!(r.passes_run.iter().any(|p| p == "pcss/temporal"));
    }
    ensure!(
        run.stats.get("history_frames") == Some(&f64::from(frames)),
        "{:?}",
        run.stats
    );
    Ok(())
}
