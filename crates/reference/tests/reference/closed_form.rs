//! The accumulated reference against the exact answer for a square occluder parallel to the light
//! above a parallel receiver (Atty et al. 2006, sections 3.3-3.4): one minus the area of the
//! intersection of the light with the occluder's projection from the receiver point.

use anyhow::{Context, Result};
use softshadow_core::{Gpu, Renderer, SceneGpu};
use softshadow_reference::{
    exact::{visible_fraction, ParallelRect},
    Reference, ReferenceSettings,
};
use softshadow_scenes::AttySquare;

/// Renders the reference on `atty-square` and returns (V, V_exact, receiver mask).
fn reference_and_exact(
    settings: ReferenceSettings,
    size: u32,
) -> Result<(Vec<f32>, Vec<f32>, Vec<bool>)> {
    let gpu = Gpu::new_headless().context("the reference test needs a GPU adapter")?;
    let params = AttySquare::default();
    let scene = params.scene()?;
    let scene_gpu = SceneGpu::upload(&gpu, &scene);
    let mut renderer = Renderer::new(&gpu, size, size)?;
    let mut reference = Reference::new(&gpu, settings)?;
    renderer.render(
        &scene_gpu,
        &scene.camera,
        &scene.light,
        &mut reference,
        None,
    )?;
    let v = renderer.read_visibility()?;
    let mask = renderer.read_receiver_mask()?;
    let positions = renderer.read_world_positions()?;

    // The occluder in light space: map its world corners through the light view.
    let half = params.occluder_size as f32 / 2.0;
    let cx = params.occluder_offset_x as f32;
    let y = params.occluder_height as f32;
    let corners = [
        scene.light.to_light_space([cx - half, y, -half].into()),
        scene.light.to_light_space([cx + half, y, half].into()),
    ];
    let occluder = ParallelRect {
        min: corners[0].truncate().min(corners[1].truncate()),
        max: corners[0].truncate().max(corners[1].truncate()),
        z: corners[0].z,
    };
    let light_half = scene.light.half_extent();
    let exact: Vec<f32> = positions
        .iter()
        .map(|p| match p {
            Some(p) => {
                visible_fraction(light_half, &[occluder], scene.light.to_light_space(*p)) as f32
            }
            None => 1.0,
        })
        .collect();
    Ok((v, exact, mask))
}

#[test]
fn reference_matches_the_closed_form_for_a_square_parallel_to_the_light() -> Result<()> {
    // 16 x 16 jittered samples, 512^2 depth maps, 128^2 image: small enough for CI on lavapipe.
    let settings = ReferenceSettings {
        samples_per_axis: 16,
        shadow_map_size: 512,
        ..ReferenceSettings::default()
    };
    let (v, exact, mask) = reference_and_exact(settings, 128)?;
    let report = softshadow_metrics::compare(&v, &exact, &mask)?;
    eprintln!("reference vs exact: {report:?}");
    assert!(
        report.shadowed_pixels > 1000,
        "the shadow must be in view: {report:?}"
    );
    // Stated bounds (docs/TECHNIQUES.md): stratified 16 x 16 sampling errs by at most about 2/16
    // at a penumbra pixel, and on average far less; the depth maps add texel-sized edge error.
    assert!(
        report.mae_shadowed < 0.01,
        "mae_shadowed {}",
        report.mae_shadowed
    );
    assert!(report.max_abs < 0.05, "max_abs {}", report.max_abs);
    Ok(())
}

#[test]
fn more_light_samples_bring_the_reference_closer_to_the_exact_answer() -> Result<()> {
    let mut errors = Vec::new();
    for n in [2, 4, 16] {
        let settings = ReferenceSettings {
            samples_per_axis: n,
            shadow_map_size: 512,
            ..ReferenceSettings::default()
        };
        let (v, exact, mask) = reference_and_exact(settings, 96)?;
        errors.push(softshadow_metrics::compare(&v, &exact, &mask)?.mae_shadowed);
    }
    eprintln!("mae_shadowed for 2, 4, 16 samples per axis: {errors:?}");
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
    Ok(())
}

#[test]
fn a_cached_reference_is_copied_not_recomputed() -> Result<()> {
    let gpu = Gpu::new_headless()?;
    let scene = AttySquare::default().scene()?;
    let scene_gpu = SceneGpu::upload(&gpu, &scene);
    let mut renderer = Renderer::new(&gpu, 64, 64)?;
    let mut reference = Reference::new(
        &gpu,
        ReferenceSettings {
            samples_per_axis: 4,
            shadow_map_size: 256,
            ..Default::default()
        },
    )?;
    let first = renderer.render(
        &scene_gpu,
        &scene.camera,
        &scene.light,
        &mut reference,
        None,
    )?;
    let v1 = renderer.read_visibility()?;
    assert!(first.passes_run.iter().any(|p| p == "reference/depth"));
    let second = renderer.render(
        &scene_gpu,
        &scene.camera,
        &scene.light,
        &mut reference,
        None,
    )?;
    assert_eq!(second.passes_run, ["gbuffer", "reference/cached_copy"]);
    assert_eq!(renderer.read_visibility()?, v1);
    // Moving the light invalidates the cache.
    let mut light = scene.light;
    light.width *= 0.5;
    let third = renderer.render(&scene_gpu, &scene.camera, &light, &mut reference, None)?;
    assert!(third.passes_run.iter().any(|p| p == "reference/depth"));
    Ok(())
}
