//! Penumbra deep shadow maps (St-Amour et al. 2005) against the exact answer on the paper's
//! static scenes, convergence in the number of light samples, compression within its bound on
//! real data, dynamic instances (shadowed by the PCF map, receiving the precomputed shadow), the
//! disk cache (bit-identical reload, corrupt files rebuilt with a warning), the memory budget and
//! cancellation. Every test uses its own temporary cache folder. Small sizes keep it fast on
//! lavapipe: 64² images, 64² to 128² PDSMs, 256² maps.

use std::sync::atomic::Ordering;

use crate::common::{exact_visibility, gpu};
use anyhow::{ensure, Context, Result};
use softshadow::pdsm::{Pdsm, PdsmSettings};
use softshadow_core::{
    glam::{Mat4, Vec3},
    Gpu, Instance, RenderError, Renderer, Scene, SceneGpu, ShadowTechnique, TechniqueError,
};
use softshadow_scenes::primitives;

const SIZE: u32 = 64;

fn settings(samples: u32, pdsm_size: u32) -> PdsmSettings {
    PdsmSettings {
        samples,
        pdsm_size,
        shadow_map_size: 256,
        ..PdsmSettings::default()
    }
}

fn technique(gpu: &Gpu, settings: PdsmSettings, cache: &std::path::Path) -> Result<Pdsm> {
    let mut pdsm = Pdsm::new(gpu, settings)?;
    pdsm.cache_dir = Some(cache.to_path_buf());
    Ok(pdsm)
}

/// What one frame gives: visibility, receiver mask, world positions, passes.
struct Frame {
    v: Vec<f32>,
    mask: Vec<bool>,
    positions: Vec<Option<Vec3>>,
    passes: Vec<String>,
}

fn render(gpu: &Gpu, scene: &Scene, pdsm: &mut Pdsm) -> Result<Frame> {
    let scene_gpu = SceneGpu::upload(gpu, scene);
    let mut renderer = Renderer::new(gpu, SIZE, SIZE)?;
    let out = renderer.render(&scene_gpu, &scene.camera, &scene.light, pdsm, None)?;
    let v = renderer.read_visibility()?;
    let stability = softshadow_metrics::stability(&v);
    ensure!(
        stability.nan == 0 && stability.inf == 0 && stability.out_of_range == 0,
        "{stability:?}"
    );
    Ok(Frame {
        v,
        mask: renderer.read_receiver_mask()?,
        positions: renderer.read_world_positions()?,
        passes: out.passes_run,
    })
}

/// Exact visibility: the closed form where the casters are rectangles parallel to the light,
/// else the CPU ray cast with 32 x 32 light samples.
fn exact(scene: &Scene, frame: &Frame) -> Result<Vec<f32>> {
    Ok(exact_visibility(scene, &frame.positions, &frame.mask, 32))
}

fn mae_shadowed(scene: &Scene, frame: &Frame) -> Result<f64> {
    let truth = exact(scene, frame)?;
    let report = softshadow_metrics::compare(&frame.v, &truth, &frame.mask)?;
    ensure!(report.shadowed_pixels > 100, "{report:?}");
    Ok(report.mae_shadowed)
}

/// Mean error over the receiver pixels the exact answer has fully lit.
fn mae_lit(scene: &Scene, frame: &Frame) -> Result<f64> {
    let truth = exact(scene, frame)?;
    let (count, sum) = (0..truth.len())
        .filter(|&i| frame.mask[i] && truth[i] >= 1.0)
        .fold((0usize, 0.0f64), |(n, s), i| {
            (n + 1, s + (frame.v[i] - truth[i]).abs() as f64)
        });
    ensure!(count > 100, "only {count} lit pixels");
    Ok(sum / count as f64)
}

fn builtin(id: &str) -> Result<Scene> {
    softshadow_scenes::builtin(id, &[]).with_context(|| format!("scene {id}"))
}

#[test]
fn static_scenes_match_the_exact_answer() -> Result<()> {
    let gpu = gpu()?;
    let cache = tempfile::tempdir()?;
    // Bounds at 2-3x the values measured with 64 samples, a 128² PDSM, 256² maps, 64² images.
    // The second bound is on the pixels the exact answer has lit (V = 1): the casters' own lit
    // surfaces, where self-shadowing acne shows. Before the tangent-plane taps and the
    // slope-scaled bias the cylinder's lit side read 0.0211 there (and mae_shadowed 0.0301).
    for (id, bound, lit_bound) in [
        // measured 0.0110; lit 0.0000
        ("atty-square", 0.03, 0.001),
        // measured 0.0110; lit 0.0003
        ("pdsm-quads", 0.03, 0.001),
        // measured 0.0377 (curved caster: its outline is snapped to 256² maps, 128² PDSM); lit
        // 0.0001
        ("pdsm-cylinder", 0.08, 0.001),
    ] {
        let scene = builtin(id)?;
        let mut pdsm = technique(&gpu, settings(64, 128), cache.path())?;
        let frame = render(&gpu, &scene, &mut pdsm)?;
        let error = mae_shadowed(&scene, &frame)?;
        let lit = mae_lit(&scene, &frame)?;
        let stats = pdsm.stats();
        eprintln!("{id}: mae_shadowed {error:.4}, mae over lit pixels {lit:.4}, stats {stats:?}");
        ensure!(error < bound, "{id}: mae_shadowed {error} >= {bound}");
        ensure!(
            lit < lit_bound,
            "{id}: mae over lit pixels {lit} >= {lit_bound}"
        );
        ensure!(stats["from_cache"] == 0.0 && stats["events_per_texel_max"] > 0.0);
        ensure!(frame.passes.iter().any(|p| p == "pdsm/sample_maps"));
    }
    Ok(())
}

#[test]
fn error_falls_as_samples_grow() -> Result<()> {
    let gpu = gpu()?;
    let cache = tempfile::tempdir()?;
    let scene = builtin("pdsm-quads")?;
    let mut errors = Vec::new();
    for samples in [4, 16, 64] {
        let mut pdsm = technique(&gpu, settings(samples, 128), cache.path())?;
        let frame = render(&gpu, &scene, &mut pdsm)?;
        errors.push(mae_shadowed(&scene, &frame)?);
    }
    eprintln!("pdsm-quads mae_shadowed for 4, 16, 64 samples: {errors:?}");
    ensure!(
        errors[0] > errors[1] && errors[1] > errors[2],
        "error must fall as samples grow: {errors:?}"
    );
    // The penumbra is sampled k times: the error falls roughly like 1 / sqrt(k) or faster.
    // Measured 0.0809, 0.0263, 0.0120.
    ensure!(errors[2] < 0.5 * errors[0], "{errors:?}");
    Ok(())
}

/// Evaluates texel `i` of a PDSM.
fn texel(data: &softshadow::pdsm::PdsmData, i: usize) -> &[[f32; 2]] {
    &data.vertices[data.offsets[i] as usize..data.offsets[i + 1] as usize]
}

#[test]
fn compression_stays_within_compression_error_at_every_event_depth() -> Result<()> {
    let gpu = gpu()?;
    let cache = tempfile::tempdir()?;
    let scene = builtin("pdsm-cylinder")?;
    // compression_error = 0 keeps every step of the summed events (only collinear vertices go).
    let mut exact_pdsm = technique(
        &gpu,
        PdsmSettings {
            compression_error: 0.0,
            ..settings(64, 64)
        },
        cache.path(),
    )?;
    render(&gpu, &scene, &mut exact_pdsm)?;
    let max_error = 0.05;
    let mut compressed_pdsm = technique(
        &gpu,
        PdsmSettings {
            compression_error: max_error,
            ..settings(64, 64)
        },
        cache.path(),
    )?;
    render(&gpu, &scene, &mut compressed_pdsm)?;
    let (raw, compressed) = (
        exact_pdsm.data().context("built")?,
        compressed_pdsm.data().context("built")?,
    );
    ensure!(raw.stats.max_compression_error == 0.0, "{:?}", raw.stats);
    let mut worst = 0.0f32;
    let mut depths_checked = 0;
    for i in 0..(raw.size * raw.size) as usize {
        let (r, c) = (texel(raw, i), texel(compressed, i));
        worst = worst.max(softshadow::pdsm::function::max_deviation(r, c));
        depths_checked += r.len();
    }
    let (before, after) = (raw.vertices.len(), compressed.vertices.len());
    eprintln!(
        "worst deviation {worst} over {depths_checked} event depths; vertices {before} -> {after}; \
         stats raw {:?} compressed {:?}",
        raw.stats, compressed.stats
    );
    ensure!(depths_checked > 10_000, "{depths_checked}");
    ensure!(worst <= max_error + 1e-6, "deviation {worst} > {max_error}");
    ensure!(
        compressed.stats.max_compression_error <= max_error + 1e-6,
        "{:?}",
        compressed.stats
    );
    // Compression must pay: the paper's park scene goes from 63 to 5 events per texel.
    ensure!(after * 2 < before, "vertices {before} -> {after}");
    Ok(())
}

/// `pdsm-cylinder` plus a dynamic box floating between the light and the ground in front of the
/// cylinder (it shadows the ground only through the PCF map) and a dynamic box standing in the
/// cylinder's shadow (it receives the precomputed shadow, Fig. 8f). Boxes are offset by `shift`.
fn cylinder_with_dynamic_boxes(shift: f32) -> Result<Scene> {
    let mut scene = builtin("pdsm-cylinder")?;
    let mesh = scene.meshes.len();
    scene
        .meshes
        .push(primitives::cuboid(Vec3::new(0.3, 0.05, 0.3)));
    let receiver = scene.meshes.len();
    scene
        .meshes
        .push(primitives::cuboid(Vec3::new(0.25, 0.3, 0.25)));
    scene.instances.push(Instance {
        dynamic: true,
        ..Instance::new(
            mesh,
            Mat4::from_translation(Vec3::new(0.3 + shift, 0.9, 0.9)),
        )
    });
    scene.instances.push(Instance {
        dynamic: true,
        ..Instance::new(
            receiver,
            Mat4::from_translation(Vec3::new(-0.8 + shift, 0.15, 0.0)),
        )
    });
    Ok(scene)
}

#[test]
fn dynamic_objects_cast_by_pcf_and_receive_the_precomputed_shadow() -> Result<()> {
    let gpu = gpu()?;
    let cache = tempfile::tempdir()?;
    let scene = cylinder_with_dynamic_boxes(0.0)?;
    let mut pdsm = technique(&gpu, settings(64, 128), cache.path())?;
    let frame = render(&gpu, &scene, &mut pdsm)?;
    ensure!(frame.passes.iter().any(|p| p == "pdsm/dynamic_map"));
    let truth = exact(&scene, &frame)?;
    // The same points without the dynamic caster: where it matters, only the PCF map can know.
    let mut static_scene = scene.clone();
    static_scene
        .instances
        .remove(static_scene.instances.len() - 2);
    let without = softshadow_reference::raycast::visibility_image(
        &static_scene,
        &frame.positions,
        &frame.mask,
        32,
    );
    let mut cast = (0usize, 0.0f64);
    let mut received = (0usize, 0.0f64);
    for i in 0..frame.v.len() {
        if !frame.mask[i] {
            continue;
        }
        let error = (frame.v[i] - truth[i]).abs() as f64;
        if without[i] - truth[i] > 0.5 {
            cast = (cast.0 + 1, cast.1 + error);
        }
        let on_box = frame.positions[i]
            .is_some_and(|p| (p.x + 0.8).abs() < 0.13 && p.z.abs() < 0.13 && p.y > 0.01);
        if on_box && truth[i] < 0.9 {
            received = (received.0 + 1, received.1 + error);
        }
    }
    let cast_mae = cast.1 / cast.0.max(1) as f64;
    let received_mae = received.1 / received.0.max(1) as f64;
    eprintln!(
        "dynamic caster: {} pixels, mae {cast_mae:.4}; dynamic receiver in shadow: {} pixels, mae {received_mae:.4}; stats {:?}",
        cast.0,
        received.0,
        pdsm.stats()
    );
    ensure!(cast.0 > 20 && received.0 > 20, "{cast:?} {received:?}");
    // measured 0.175: a 5 x 5 PCF kernel is not the penumbra of the real light (section 5)
    ensure!(cast_mae < 0.4, "dynamic caster mae {cast_mae}");
    // measured 0.0006
    ensure!(received_mae < 0.03, "dynamic receiver mae {received_mae}");

    // Moving the dynamic boxes keeps the precompute: no sample maps, the same PDSM.
    let moved = cylinder_with_dynamic_boxes(0.2)?;
    let before = pdsm.data().context("built")?.clone();
    let scene_gpu = SceneGpu::upload(&gpu, &scene);
    let moved_gpu = SceneGpu::upload(&gpu, &moved);
    let mut renderer = Renderer::new(&gpu, SIZE, SIZE)?;
    renderer.render(&scene_gpu, &scene.camera, &scene.light, &mut pdsm, None)?;
    let out = renderer.render(&moved_gpu, &moved.camera, &moved.light, &mut pdsm, None)?;
    ensure!(
        !out.passes_run.iter().any(|p| p == "pdsm/sample_maps")
            && out.passes_run.iter().any(|p| p == "pdsm/dynamic_map"),
        "{:?}",
        out.passes_run
    );
    ensure!(pdsm.data() == Some(&before));
    ensure!(pdsm.stats()["rebuilt_this_frame"] == 0.0);
    Ok(())
}

#[test]
fn the_cache_reloads_bit_identical_and_rebuilds_a_corrupt_file_with_a_warning() -> Result<()> {
    let gpu = gpu()?;
    let cache = tempfile::tempdir()?;
    let scene = builtin("pdsm-quads")?;
    let first = {
        let mut pdsm = technique(&gpu, settings(16, 64), cache.path())?;
        let frame = render(&gpu, &scene, &mut pdsm)?;
        ensure!(pdsm.stats()["from_cache"] == 0.0);
        frame.v
    };
    let files: Vec<_> = std::fs::read_dir(cache.path())?.collect::<Result<_, _>>()?;
    ensure!(
        files.len() == 1,
        "one cache file, no temporaries: {files:?}"
    );
    let path = files[0].path();

    let mut pdsm = technique(&gpu, settings(16, 64), cache.path())?;
    let frame = render(&gpu, &scene, &mut pdsm)?;
    ensure!(pdsm.stats()["from_cache"] == 1.0, "{:?}", pdsm.stats());
    ensure!(!frame.passes.iter().any(|p| p == "pdsm/sample_maps"));
    ensure!(
        frame
            .v
            .iter()
            .map(|v| v.to_bits())
            .eq(first.iter().map(|v| v.to_bits())),
        "the loaded PDSM must give bit-identical visibility"
    );

    // Corrupt one byte in the middle, then truncate: each time rebuilt with a warning.
    let mut bytes = std::fs::read(&path)?;
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0xff;
    for damaged in [bytes.clone(), bytes[..middle].to_vec()] {
        std::fs::write(&path, &damaged)?;
        let mut pdsm = technique(&gpu, settings(16, 64), cache.path())?;
        let frame = render(&gpu, &scene, &mut pdsm)?;
        ensure!(pdsm.stats()["from_cache"] == 0.0, "{:?}", pdsm.stats());
        let warnings = pdsm.warnings().join("\n");
        ensure!(
            warnings.contains("cache file refused, rebuilding"),
            "{warnings}"
        );
        ensure!(frame
            .v
            .iter()
            .map(|v| v.to_bits())
            .eq(first.iter().map(|v| v.to_bits())));
        // The rebuilt file is whole again: the next run loads it.
        let mut again = technique(&gpu, settings(16, 64), cache.path())?;
        render(&gpu, &scene, &mut again)?;
        ensure!(again.stats()["from_cache"] == 1.0 && again.warnings().is_empty());
    }
    Ok(())
}

#[test]
fn an_oversized_precompute_fails_before_building_and_names_the_parameter() -> Result<()> {
    let gpu = gpu()?;
    let cache = tempfile::tempdir()?;
    let scene = builtin("pdsm-quads")?;
    let mut pdsm = technique(
        &gpu,
        PdsmSettings {
            samples: 1024,
            shadow_map_size: 2048,
            ..PdsmSettings::default()
        },
        cache.path(),
    )?;
    let error = render(&gpu, &scene, &mut pdsm)
        .err()
        .context("16 GiB of maps must not build")?;
    let message = format!("{error:#}");
    ensure!(
        message.contains("16384 MiB")
            && message.contains("lower `samples` or `shadow_map_size`")
            && message.contains("memory_budget_mib"),
        "{message}"
    );
    Ok(())
}

#[test]
fn a_cancelled_build_fails_and_progress_counts_every_row() -> Result<()> {
    let gpu = gpu()?;
    let cache = tempfile::tempdir()?;
    let scene = builtin("pdsm-quads")?;
    let mut pdsm = technique(&gpu, settings(4, 64), cache.path())?;
    let control = pdsm.build_control();
    control.cancel.store(true, Ordering::Relaxed);
    let error = render(&gpu, &scene, &mut pdsm).err().context("cancelled")?;
    ensure!(format!("{error:#}").contains("cancelled"), "{error:#}");
    ensure!(pdsm.data().is_none());
    control.cancel.store(false, Ordering::Relaxed);
    render(&gpu, &scene, &mut pdsm)?;
    ensure!(control.done.load(Ordering::Relaxed) == 64);
    Ok(())
}

/// The construction target (64 samples, 512² PDSM, 512² maps) on `pdsm-cylinder`, with
/// the paper's compression statistics (section 5). Prints figures for docs/TECHNIQUES.md (`pdsm`); asserts
/// only what the build must satisfy, never a time. Slow in the dev profile: run it on purpose,
/// `cargo test --release -p softshadow-bench --test gpu pdsm:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn construction_at_the_paper_settings() -> Result<()> {
    let gpu = gpu()?;
    let cache = tempfile::tempdir()?;
    let scene = builtin("pdsm-cylinder")?;
    for (samples, pdsm_size, shadow_map_size) in [(64, 512, 512), (16, 512, 512), (64, 256, 512)] {
        let mut pdsm = technique(
            &gpu,
            PdsmSettings {
                samples,
                pdsm_size,
                shadow_map_size,
                disk_cache: false,
                ..PdsmSettings::default()
            },
            cache.path(),
        )?;
        let frame = render(&gpu, &scene, &mut pdsm)?;
        let stats = pdsm.stats();
        eprintln!(
            "k={samples} pdsm={pdsm_size}² maps={shadow_map_size}²: construction {:.0} ms, \
             events/texel mean {:.2} max {}, vertices/texel mean {:.2} max {}, GPU {:.2} MiB, \
             compression error {:.4}",
            stats["construction_ms"],
            stats["events_per_texel_mean"],
            stats["events_per_texel_max"],
            stats["vertices_per_texel_mean"],
            stats["vertices_per_texel_max"],
            stats["pdsm_gpu_bytes"] / (1 << 20) as f64,
            stats["compression_max_error"],
        );
        ensure!(stats["compression_max_error"] <= 0.02 + 1e-6);
        ensure!(frame.passes.iter().any(|p| p == "pdsm/sample_maps"));
    }
    Ok(())
}

/// The technique error of a failed frame.
fn technique_error(error: &anyhow::Error) -> Option<&TechniqueError> {
    match error.downcast_ref::<RenderError>()? {
        RenderError::Technique(e) => Some(e),
        _ => None,
    }
}

/// Background builds (the viewer): the first frame starts the CPU construction on its own thread
/// and returns at once with "building" (nothing drawn); a later frame uploads the same PDSM a
/// synchronous build gives; `invalidate_cache` keeps it in memory; a cancel ends the build with
/// "cancelled" until the flag is cleared. No time is asserted: frames are polled until done.
#[test]
fn a_background_build_returns_at_once_draws_when_done_and_cancels() -> Result<()> {
    let gpu = gpu()?;
    let cache = tempfile::tempdir()?;
    let scene = builtin("pdsm-quads")?;
    let uncached = PdsmSettings {
        disk_cache: false,
        ..settings(16, 64)
    };
    let mut sync = technique(&gpu, uncached.clone(), cache.path())?;
    render(&gpu, &scene, &mut sync)?;

    let mut pdsm = technique(&gpu, uncached, cache.path())?;
    pdsm.set_background_build(true);
    let control = pdsm.build_control();
    // The sample maps take two frames (256² maps: 8 per frame), then the rows build on a thread.
    let first = render(&gpu, &scene, &mut pdsm).err().context("building")?;
    ensure!(
        matches!(
            technique_error(&first),
            Some(TechniqueError::Building {
                done: 8,
                total: 16,
                unit: "light sample maps",
                ..
            })
        ),
        "{first:#}"
    );
    ensure!(pdsm.data().is_none() && control.progress() == Some((8, 16)));
    let second = render(&gpu, &scene, &mut pdsm).err().context("building")?;
    ensure!(
        matches!(
            technique_error(&second),
            Some(TechniqueError::Building {
                total: 64,
                unit: "PDSM rows",
                ..
            })
        ),
        "{second:#}"
    );
    ensure!(pdsm.data().is_none() && control.progress().is_some());
    let frame = poll_until_drawn(&gpu, &scene, &mut pdsm)?;
    ensure!(
        pdsm.data() == sync.data(),
        "the same PDSM as a synchronous build"
    );
    ensure!(control.progress().is_none());
    ensure!(control.done.load(Ordering::Relaxed) == 64);
    ensure!(!frame.passes.iter().any(|p| p == "pdsm/build"));
    // Set aside in memory, not rebuilt, by invalidate_cache.
    pdsm.invalidate_cache();
    let again = render(&gpu, &scene, &mut pdsm)?;
    ensure!(!again.passes.iter().any(|p| p == "pdsm/sample_maps"));

    // Other inputs start another build; cancel it.
    pdsm.settings.samples = 4;
    let started = render(&gpu, &scene, &mut pdsm).err().context("building")?;
    ensure!(matches!(
        technique_error(&started),
        Some(TechniqueError::Building { .. })
    ));
    control.cancel();
    let cancelled = loop {
        match render(&gpu, &scene, &mut pdsm) {
            Err(e) if matches!(technique_error(&e), Some(TechniqueError::Building { .. })) => {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
            other => break other.err().context("a cancelled build draws nothing")?,
        }
    };
    ensure!(
        matches!(
            technique_error(&cancelled),
            Some(TechniqueError::Cancelled { .. })
        ),
        "{cancelled:#}"
    );
    ensure!(pdsm.data().is_none() && control.progress().is_none());
    let still = render(&gpu, &scene, &mut pdsm)
        .err()
        .context("still cancelled")?;
    ensure!(matches!(
        technique_error(&still),
        Some(TechniqueError::Cancelled { .. })
    ));
    control.clear_cancel();
    ensure!(render(&gpu, &scene, &mut pdsm).is_err(), "builds again");
    poll_until_drawn(&gpu, &scene, &mut pdsm)?;
    ensure!(pdsm.data().is_some_and(|d| d.size == 64));
    Ok(())
}

/// The map of the static casters from the light centre feeds only the `shadow_map` debug view:
/// it is always listed (so a viewer can choose it) but drawn only while shown, once per PDSM,
/// and again by a full-cost frame (`invalidate_cache`) only while shown.
#[test]
fn the_centre_map_is_drawn_only_while_its_debug_view_is_shown() -> Result<()> {
    let gpu = gpu()?;
    let cache = tempfile::tempdir()?;
    let scene = builtin("pdsm-quads")?;
    let mut pdsm = technique(&gpu, settings(4, 32), cache.path())?;
    let drawn = |frame: &Frame| frame.passes.iter().any(|p| p == "pdsm/centre_map");
    let stat = |pdsm: &Pdsm| pdsm.stats().get("centre_map_passes").copied();
    let first = render(&gpu, &scene, &mut pdsm)?;
    ensure!(!drawn(&first), "{:?}", first.passes);
    ensure!(stat(&pdsm) == Some(0.0));
    ensure!(pdsm.debug_views().iter().any(|v| v.name == "shadow_map"));

    pdsm.show_debug_view(Some("shadow_map"));
    let shown = render(&gpu, &scene, &mut pdsm)?;
    ensure!(drawn(&shown) && stat(&pdsm) == Some(1.0));
    let kept = render(&gpu, &scene, &mut pdsm)?;
    ensure!(!drawn(&kept), "drawn once per PDSM");
    pdsm.invalidate_cache();
    let full_cost = render(&gpu, &scene, &mut pdsm)?;
    ensure!(
        drawn(&full_cost),
        "a full-cost frame redraws it while shown"
    );

    pdsm.show_debug_view(Some("vertices_per_texel"));
    pdsm.invalidate_cache();
    let other = render(&gpu, &scene, &mut pdsm)?;
    ensure!(
        !drawn(&other) && stat(&pdsm) == Some(0.0),
        "{:?}",
        other.passes
    );
    Ok(())
}

/// Renders until the background build is done and the frame is drawn.
fn poll_until_drawn(gpu: &Gpu, scene: &Scene, pdsm: &mut Pdsm) -> Result<Frame> {
    loop {
        match render(gpu, scene, pdsm) {
            Err(e) if matches!(technique_error(&e), Some(TechniqueError::Building { .. })) => {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
            other => return other,
        }
    }
}

/// The evaluation's two draws (ends first, the search only where they leave a pixel) give the
/// image of one full draw at every pixel, bit for bit, with and without dynamic casters: the
/// split saves time and changes nothing (a pixel the first draw wrongly kept would read 1).
#[test]
fn the_two_draw_evaluation_matches_one_full_draw_bit_for_bit() -> Result<()> {
    let gpu = gpu()?;
    let cache = tempfile::tempdir()?;
    for scene in [builtin("pdsm-cylinder")?, cylinder_with_dynamic_boxes(0.0)?] {
        let mut pdsm = technique(&gpu, settings(16, 128), cache.path())?;
        let split = render(&gpu, &scene, &mut pdsm)?;
        pdsm.set_two_draw_evaluation(false);
        let full = render(&gpu, &scene, &mut pdsm)?;
        let differing = split
            .v
            .iter()
            .zip(&full.v)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        ensure!(differing == 0, "{differing} pixels differ");
        // Not trivially equal: the scene has partial shadow the search must produce.
        let partial = full.v.iter().filter(|v| **v > 0.05 && **v < 0.95).count();
        ensure!(partial > 100, "only {partial} penumbra pixels");
    }
    Ok(())
}

/// A benchmark run shows what the precompute costs: its cold first frame builds the PDSM
/// (`cold.stats`: not from the cache, with its construction time), while the timed frames, which
/// drop their caches, load it from the disk cache the cold frame filled.
#[test]
fn a_benchmark_run_reports_the_cold_build_beside_the_cached_frames() -> Result<()> {
    use softshadow_bench::{Bench, BenchOptions, RunSpec, Status};
    let out = tempfile::tempdir()?;
    // In a benchmark the technique caches in the test process's folder (`gpu()` sets it); this
    // test's own PDSM size (a key no other test builds) keeps it from loading another's entry.
    let mut bench = Bench::new(
        gpu()?,
        softshadow::registry(),
        BenchOptions {
            frames: 2,
            warmup: 1,
            error: false,
            images: false,
            exact_samples_per_axis: None,
            camera_only: false,
            ..BenchOptions::default()
        },
    )?;
    let spec = RunSpec {
        scene: "pdsm-quads".into(),
        technique: softshadow::pdsm::ID.into(),
        params: softshadow_bench::parse_params(
            bench.registry(),
            softshadow::pdsm::ID,
            &[
                "pdsm_size=68".into(),
                "samples=4".into(),
                "shadow_map_size=128".into(),
            ],
        )?,
        width: 32,
        height: 32,
        path: None,
    };
    let run = bench.run(0, &spec, out.path());
    ensure!(run.status == Status::Ok, "{}", run.message);
    let cold = run.cold.as_ref().context("the cold frame is reported")?;
    ensure!(
        cold.stats.get("from_cache") == Some(&0.0)
            && cold
                .stats
                .get("construction_ms")
                .is_some_and(|ms| *ms > 0.0),
        "cold frame: {:?}",
        cold.stats
    );
    let cold_passes = cold.timing.passes_run.clone().unwrap_or_default();
    ensure!(
        cold_passes.iter().any(|p| p == "pdsm/build"),
        "{cold_passes:?}"
    );
    ensure!(
        run.stats.get("from_cache") == Some(&1.0),
        "timed frames: {:?}",
        run.stats
    );
    Ok(())
}
