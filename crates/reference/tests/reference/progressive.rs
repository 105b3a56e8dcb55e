//! Progressive accumulation (the viewer's mode) ends bit-identical to the one-frame reference,
//! reports its progress, and restarts when the light moves.

use anyhow::{ensure, Context, Result};
use softshadow_core::{Gpu, Renderer, SceneGpu};
use softshadow_reference::{Reference, ReferenceSettings};
use softshadow_scenes::AttySquare;

#[test]
fn progressive_reference_converges_to_the_one_frame_reference() -> Result<()> {
    let gpu = Gpu::new_headless().context("the progressive reference test needs a GPU adapter")?;
    let scene = AttySquare::default().scene()?;
    let scene_gpu = SceneGpu::upload(&gpu, &scene);
    let mut renderer = Renderer::new(&gpu, 64, 64)?;
    let settings = ReferenceSettings {
        samples_per_axis: 8,
        shadow_map_size: 256,
        ..ReferenceSettings::default()
    };

    let mut one_frame = Reference::new(&gpu, settings.clone())?;
    renderer.render(
        &scene_gpu,
        &scene.camera,
        &scene.light,
        &mut one_frame,
        None,
    )?;
    let expected = renderer.read_visibility()?;

    // 64 samples at 16 per batch, one batch per frame: 4 frames.
    let mut progressive = Reference::new(&gpu, settings)?;
    progressive.set_progressive(Some(1));
    let mut seen = Vec::new();
    for _ in 0..4 {
        renderer.render(
            &scene_gpu,
            &scene.camera,
            &scene.light,
            &mut progressive,
            None,
        )?;
        let p = progressive.progress();
        seen.push((p.done, p.total));
        let partial = renderer.read_visibility()?;
        ensure!(
            partial.iter().all(|v| (0.0..=1.0).contains(v)),
            "a partial reference left [0, 1]"
        );
    }
    ensure!(
        seen == vec![(16, 64), (32, 64), (48, 64), (64, 64)],
        "progress went {seen:?}"
    );
    ensure!(progressive.progress().is_complete());
    let finished = renderer.read_visibility()?;
    ensure!(
        finished == expected,
        "progressive and one-frame references differ"
    );

    // A cached frame stays complete; a moved light starts over.
    renderer.render(
        &scene_gpu,
        &scene.camera,
        &scene.light,
        &mut progressive,
        None,
    )?;
    ensure!(progressive.progress().is_complete());
    let mut light = scene.light;
    light.center.x += 0.1;
    renderer.render(&scene_gpu, &scene.camera, &light, &mut progressive, None)?;
    let p = progressive.progress();
    ensure!(
        (p.done, p.total) == (16, 64),
        "after moving the light: {p:?}"
    );
    Ok(())
}
