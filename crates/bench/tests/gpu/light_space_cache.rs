//! Light-space work is done once while scene and light stand still (docs/ARCHITECTURE.md, "What
//! a frame may leave out"): for every registered technique, a frame in which only the camera
//! moved gives the visibility a full frame gives at that camera, runs fewer passes where the
//! technique has light-space passes, and moving the light or a dynamic instance brings them back.

use crate::common::gpu;
use anyhow::{ensure, Context, Result};
use softshadow_bench::orbit_camera;
use softshadow_core::{
    glam::{Mat4, Vec3},
    Gpu, Renderer, Scene, SceneGpu, ShadowTechnique,
};

const SIZE: u32 = 64;

/// Techniques whose every pass depends on the camera, with the reason (ARCHITECTURE.md).
fn keeps_nothing(id: &str) -> bool {
    // The reference re-renders its N x N depth maps in batches of 16; keeping 1,024 maps would
    // take 4 GiB, so a moved camera redoes the accumulation.
    id == "reference"
}

/// A technique with its fast test settings (small maps and sample counts keep lavapipe quick).
fn create(gpu: &Gpu, id: &str) -> Result<Box<dyn ShadowTechnique>> {
    let info = softshadow::registry().find(id)?.clone();
    let mut technique = info.create_with(gpu, &[])?;
    if id == "reference" {
        technique.set_param("samples_per_axis", softshadow_core::ParamValue::Int(4))?;
    }
    if id == "raytraced" {
        // Without temporal accumulation its image is a function of camera, light and casters
        // only (the history is what a camera-only frame may not reproduce from scratch).
        technique.set_param("temporal", softshadow_core::ParamValue::Bool(false))?;
    }
    if id == "pdsm" {
        // Builds, not disk-cache loads, so that a fresh instance does what the first frame did.
        technique.set_param("disk_cache", softshadow_core::ParamValue::Bool(false))?;
    }
    Ok(technique)
}

fn render(
    renderer: &mut Renderer,
    scene: &SceneGpu,
    camera: &softshadow_core::Camera,
    light: &softshadow_core::AreaLight,
    technique: &mut dyn ShadowTechnique,
) -> Result<(Vec<String>, Vec<f32>)> {
    let output = renderer.render(scene, camera, light, technique, None)?;
    Ok((output.passes_run, renderer.read_visibility()?))
}

fn max_abs_difference(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

fn same_passes(a: &[String], b: &[String]) -> bool {
    let mut a = a.to_vec();
    let mut b = b.to_vec();
    a.sort();
    b.sort();
    a == b
}

/// `atty-square` with its occluder marked dynamic, and the same scene with the occluder moved.
fn scene_with_a_dynamic_occluder() -> Result<(Scene, Scene)> {
    let mut scene = softshadow_scenes::load("atty-square")?.scene;
    let occluder = scene
        .instances
        .iter()
        .position(|i| i.casts_shadow && !i.receives_shadow)
        .or_else(|| scene.instances.iter().position(|i| i.casts_shadow))
        .context("atty-square has no caster")?;
    scene.instances[occluder].dynamic = true;
    let mut moved = scene.clone();
    moved.instances[occluder].transform =
        Mat4::from_translation(Vec3::new(0.05, 0.0, 0.0)) * moved.instances[occluder].transform;
    Ok((scene, moved))
}

#[test]
fn a_camera_only_frame_matches_a_full_frame_and_keeps_light_space_passes() -> Result<()> {
    let gpu = gpu()?;
    let (scene, moved) = scene_with_a_dynamic_occluder()?;
    let scene_gpu = SceneGpu::upload(&gpu, &scene);
    let moved_gpu = SceneGpu::upload(&gpu, &moved);
    ensure!(
        scene_gpu.static_hash == moved_gpu.static_hash
            && scene_gpu.dynamic_hash != moved_gpu.dynamic_hash,
        "moving the dynamic occluder must change only the dynamic hash"
    );
    let camera = scene.camera;
    let orbited = orbit_camera(&camera, 4);
    let mut moved_light = scene.light;
    moved_light.center += Vec3::new(0.02, 0.0, 0.0);
    let mut failures = Vec::new();
    for info in softshadow::registry().iter() {
        let id = info.id.as_ref();
        let mut renderer = Renderer::new(&gpu, SIZE, SIZE)?;
        let mut technique = create(&gpu, id)?;
        technique.prepare(&gpu, &renderer.inputs(&scene_gpu, &camera, &scene.light))?;
        let (full_passes, _) = render(
            &mut renderer,
            &scene_gpu,
            &camera,
            &scene.light,
            technique.as_mut(),
        )?;
        let (camera_passes, camera_only) = render(
            &mut renderer,
            &scene_gpu,
            &orbited,
            &scene.light,
            technique.as_mut(),
        )?;
        // The same camera from scratch: a new instance has nothing kept.
        let mut fresh = create(&gpu, id)?;
        fresh.prepare(&gpu, &renderer.inputs(&scene_gpu, &orbited, &scene.light))?;
        let (fresh_passes, from_scratch) = render(
            &mut renderer,
            &scene_gpu,
            &orbited,
            &scene.light,
            fresh.as_mut(),
        )?;
        let difference = max_abs_difference(&camera_only, &from_scratch);
        eprintln!(
            "{id:<16} full {full_passes:?}\n{:<16} camera-only {camera_passes:?}, max |dV| {difference:e}",
            ""
        );
        if difference > 1e-6 {
            failures.push(format!(
                "{id}: camera-only frame differs from a full frame by {difference}"
            ));
        }
        if !same_passes(&fresh_passes, &full_passes) {
            failures.push(format!(
                "{id}: a fresh instance ran {fresh_passes:?}, the first frame {full_passes:?}"
            ));
        }
        if keeps_nothing(id) {
            if !same_passes(&camera_passes, &full_passes) {
                failures.push(format!(
                    "{id}: documented to keep nothing, but ran {camera_passes:?}"
                ));
            }
        } else if camera_passes.len() >= full_passes.len()
            || !camera_passes.iter().all(|p| full_passes.contains(p))
        {
            failures.push(format!(
                "{id}: camera-only frame ran {camera_passes:?}, not fewer than {full_passes:?}"
            ));
        }

        // Moving the light brings the light-space passes back.
        let (light_passes, after_light) = render(
            &mut renderer,
            &scene_gpu,
            &orbited,
            &moved_light,
            technique.as_mut(),
        )?;
        let mut fresh = create(&gpu, id)?;
        fresh.prepare(&gpu, &renderer.inputs(&scene_gpu, &orbited, &moved_light))?;
        let (_, light_from_scratch) = render(
            &mut renderer,
            &scene_gpu,
            &orbited,
            &moved_light,
            fresh.as_mut(),
        )?;
        let difference = max_abs_difference(&after_light, &light_from_scratch);
        if difference > 1e-6 {
            failures.push(format!(
                "{id}: after moving the light the image differs from a fresh one by {difference}"
            ));
        }
        // raytraced's acceleration structures hold the casters only: a moved light keeps them.
        let expected_after_light: Vec<String> = full_passes
            .iter()
            .filter(|p| !(id == "raytraced" && p.as_str() == "raytraced/accel_build"))
            .cloned()
            .collect();
        if !same_passes(&light_passes, &expected_after_light) {
            failures.push(format!(
                "{id}: after moving the light ran {light_passes:?}, expected {expected_after_light:?}"
            ));
        }
        // So does moving a dynamic instance (after a camera-only frame at the new light), and the
        // image is the one a fresh instance computes for the moved scene. (The occluder is the
        // scene's only caster, so the PDSM's static precompute is empty here; crates/bench/tests/
        // pdsm.rs checks that moving a dynamic instance keeps a non-empty one.)
        render(
            &mut renderer,
            &scene_gpu,
            &camera,
            &moved_light,
            technique.as_mut(),
        )?;
        let (dynamic_passes, after_move) = render(
            &mut renderer,
            &moved_gpu,
            &camera,
            &moved_light,
            technique.as_mut(),
        )?;
        // PDSM keeps its static precompute when only a dynamic instance moves (St-Amour et al.
        // 2005, section 5: the dynamic casters get a map of their own), so the CPU passes that
        // upload the static PDSM and evaluate its debug views do not run again; every other
        // technique redoes its full frame.
        let expected_after_move: Vec<String> = full_passes
            .iter()
            .filter(|p| {
                !(id == "pdsm" && ["pdsm/upload", "pdsm/debug_views"].contains(&p.as_str()))
            })
            .cloned()
            .collect();
        if !same_passes(&dynamic_passes, &expected_after_move) {
            failures.push(format!(
                "{id}: after moving a dynamic instance ran {dynamic_passes:?}, expected {expected_after_move:?}"
            ));
        }
        let mut fresh = create(&gpu, id)?;
        fresh.prepare(&gpu, &renderer.inputs(&moved_gpu, &camera, &moved_light))?;
        let (_, moved_from_scratch) = render(
            &mut renderer,
            &moved_gpu,
            &camera,
            &moved_light,
            fresh.as_mut(),
        )?;
        let difference = max_abs_difference(&after_move, &moved_from_scratch);
        if difference > 1e-6 {
            failures.push(format!(
                "{id}: after moving a dynamic instance the image differs from a fresh one by {difference}"
            ));
        }
        // invalidate_cache forces the full work even when nothing changed.
        technique.invalidate_cache();
        let (invalidated, _) = render(
            &mut renderer,
            &moved_gpu,
            &camera,
            &moved_light,
            technique.as_mut(),
        )?;
        if !same_passes(&invalidated, &full_passes) {
            failures.push(format!(
                "{id}: after invalidate_cache ran {invalidated:?}, expected {full_passes:?}"
            ));
        }
    }
    ensure!(failures.is_empty(), "{}", failures.join("\n"));
    Ok(())
}
