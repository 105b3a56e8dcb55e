//! The visibility-buffer contract (docs/ARCHITECTURE.md) for every registered technique:
//! receiver points at or behind the light plane hold exactly 0 (a one-sided light cannot reach
//! them), pixels that see no receiver hold exactly 1, everything else is finite and in [0, 1].
//! Found by hand: with every caster behind the light, the `*/no_casters` shortcut cleared the
//! buffer to 1 and lit receivers behind the light.

use crate::common::gpu;
use anyhow::{ensure, Result};
use softshadow_core::{glam::Vec3, ParamValue, Renderer, Scene, SceneGpu};

const SIZE: u32 = 64;

/// The new user's scene: a light below the ground facing away from everything (every receiver
/// and caster behind it).
fn light_below_facing_away() -> Result<Scene> {
    let mut scene = softshadow_scenes::load("atty-square")?.scene;
    scene.light.center = Vec3::new(0.0, -5.0, 0.0);
    scene.light.direction = Vec3::new(0.0, -1.0, 0.0);
    Ok(scene)
}

#[test]
fn receivers_behind_the_light_hold_zero_and_non_receivers_one_for_every_technique() -> Result<()> {
    let gpu = gpu()?;
    let scenes = [
        (
            "light below, facing away".to_string(),
            light_below_facing_away()?,
        ),
        (
            "stiff-behind-light".to_string(),
            softshadow_scenes::load("stiff-behind-light")?.scene,
        ),
        (
            "stiff-light-up".to_string(),
            softshadow_scenes::load("stiff-light-up")?.scene,
        ),
    ];
    let mut failures = Vec::new();
    for (name, scene) in &scenes {
        let scene_gpu = SceneGpu::upload(&gpu, scene);
        let mut renderer = Renderer::new(&gpu, SIZE, SIZE)?;
        let (camera, light) = (scene.camera, scene.light);
        // Which pixels see a receiver behind the light, from the G-buffer of a first frame.
        let mut probe = softshadow::registry()
            .find("hard")?
            .clone()
            .create_with(&gpu, &[])?;
        renderer.render(&scene_gpu, &camera, &light, probe.as_mut(), None)?;
        let positions = renderer.read_world_positions()?;
        let receivers = renderer.read_receiver_mask()?;
        let behind: Vec<bool> = positions
            .iter()
            .zip(&receivers)
            .map(|(p, &r)| r && p.is_some_and(|p| light.to_light_space(p).z <= 0.0))
            .collect();
        let behind_count = behind.iter().filter(|b| **b).count();
        ensure!(
            behind_count > 100,
            "{name}: only {behind_count} pixels see a receiver behind the light; fix the scene"
        );
        for info in softshadow::registry().iter() {
            let mut technique = info.create_with(&gpu, &[])?;
            if info.id == "reference" {
                technique.set_param("samples_per_axis", ParamValue::Int(4))?;
            }
            technique.prepare(&gpu, &renderer.inputs(&scene_gpu, &camera, &light))?;
            renderer.render(&scene_gpu, &camera, &light, technique.as_mut(), None)?;
            let v = renderer.read_visibility()?;
            let lit_behind = behind
                .iter()
                .zip(&v)
                .filter(|(b, v)| **b && **v != 0.0)
                .count();
            let off_receiver_not_one = receivers
                .iter()
                .zip(&v)
                .filter(|(r, v)| !**r && **v != 1.0)
                .count();
            let bad = v
                .iter()
                .filter(|v| !v.is_finite() || **v < 0.0 || **v > 1.0)
                .count();
            eprintln!(
                "{name:<26} {:<16} behind-light pixels not 0: {lit_behind}/{behind_count}, off-receiver not 1: {off_receiver_not_one}, non-finite or outside [0, 1]: {bad}",
                info.id
            );
            if lit_behind + off_receiver_not_one + bad > 0 {
                failures.push(format!(
                    "{name} / {}: {lit_behind} behind-light pixels not 0, {off_receiver_not_one} off-receiver pixels not 1, {bad} bad values",
                    info.id
                ));
            }
        }
    }
    ensure!(failures.is_empty(), "{}", failures.join("\n"));
    Ok(())
}
