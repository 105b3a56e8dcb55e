//! Alpha-tested casters (issue 40): the masked checkerboard quad over a ground
//! (`softshadow_scenes::materials::masked_checker`, the stiff case `stiff-masked-checker`). The
//! two sampled exact answers, both testing alpha at each hit (the CPU ray cast and the
//! ray-traced one), agree within their sampling errors; every technique's bound on the case (in
//! its crate; the stiff suite holds it to it and to rejecting all-lit and `hard`) also rejects
//! the opaque quad's answer.

use crate::common::gpu;
use anyhow::{ensure, Context, Result};
use softshadow_core::{glam::Vec3, Gpu, Renderer, Scene, SceneGpu};
use softshadow_scenes::materials::masked_checker;

/// Image side: the size every stated bound holds at.
const SIZE: u32 = softshadow_core::expectations::EXPECTATION_SIZE;
/// Light samples per axis of both sampled exact answers.
const SAMPLES: u32 = 16;
/// The checker's cells per side and the light's width: cells 0.2 wide, penumbrae 0.1 wide.
const CELLS: u32 = 6;
const LIGHT_WIDTH: f32 = 0.2;

struct Output {
    receiver: Vec<bool>,
    positions: Vec<Option<Vec3>>,
}

fn render(gpu: &Gpu, scene: &Scene, technique: &str) -> Result<Output> {
    let registry = softshadow::registry();
    let info = registry.get(technique).context("a built-in technique")?;
    let mut technique = (info.create)(gpu)?;
    let scene_gpu = SceneGpu::upload(gpu, scene);
    let mut renderer = Renderer::new(gpu, SIZE, SIZE)?;
    renderer.render(
        &scene_gpu,
        &scene.camera,
        &scene.light,
        technique.as_mut(),
        None,
    )?;
    let v = renderer.read_visibility()?;
    ensure!(
        v.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)),
        "{} on {}: visibility outside [0, 1]",
        info.id,
        scene.name
    );
    Ok(Output {
        receiver: renderer.read_receiver_mask()?,
        positions: renderer.read_world_positions()?,
    })
}

/// Mean |a - b| over the receiver pixels where either is shadowed (below 1).
fn mae_shadowed(a: &[f32], b: &[f32], receiver: &[bool]) -> f64 {
    let (mut sum, mut count) = (0.0, 0usize);
    for ((a, b), r) in a.iter().zip(b).zip(receiver) {
        if *r && (*a < 1.0 || *b < 1.0) {
            sum += (*a as f64 - *b as f64).abs();
            count += 1;
        }
    }
    sum / count.max(1) as f64
}

/// The ray-traced answer with the alpha test (the exact answer a masked scene gets).
fn traced(gpu: &Gpu, scene: &Scene, out: &Output) -> Result<(Vec<f32>, Vec<f32>)> {
    Ok(softshadow_reference::traced::visibility_image_and_error(
        gpu,
        scene,
        &out.positions,
        &out.receiver,
        SAMPLES,
    )?)
}

/// The mean of `e` over the pixels [`mae_shadowed`] of `a` and `b` averages over.
fn mean_where_shadowed(e: &[f32], a: &[f32], b: &[f32], receiver: &[bool]) -> f64 {
    let (mut sum, mut count) = (0.0, 0usize);
    for (((e, a), b), r) in e.iter().zip(a).zip(b).zip(receiver) {
        if *r && (*a < 1.0 || *b < 1.0) {
            sum += *e as f64;
            count += 1;
        }
    }
    sum / count.max(1) as f64
}

#[test]
fn masked_checker_ray_traced_and_ray_cast_agree_and_see_the_holes() -> Result<()> {
    let gpu = gpu()?;
    let scene = masked_checker(LIGHT_WIDTH, CELLS, true);
    let opaque = masked_checker(LIGHT_WIDTH, CELLS, false);
    let out = render(&gpu, &scene, softshadow_core::COST_FLOOR_TECHNIQUE)?;
    // The G-buffer drops the holes: the ground is seen (and is a receiver) through them.
    let opaque_out = render(&gpu, &opaque, softshadow_core::COST_FLOOR_TECHNIQUE)?;
    let seen = |o: &Output| o.receiver.iter().filter(|r| **r).count();
    ensure!(
        seen(&out) > seen(&opaque_out) + 100,
        "receiver pixels: {} with holes, {} opaque: the G-buffer does not see through the mask",
        seen(&out),
        seen(&opaque_out)
    );
    let (traced_v, traced_e) = traced(&gpu, &scene, &out)?;
    let (cast_v, cast_e) = softshadow_reference::raycast::visibility_image_and_error(
        &scene,
        &out.positions,
        &out.receiver,
        SAMPLES,
    );
    let opaque_v = softshadow_reference::raycast::visibility_image(
        &opaque,
        &out.positions,
        &out.receiver,
        SAMPLES,
    );
    let difference = mae_shadowed(&traced_v, &cast_v, &out.receiver);
    let on = |e: &[f32]| mean_where_shadowed(e, &traced_v, &cast_v, &out.receiver);
    let sampling = on(&traced_e) + on(&cast_e);
    let against_opaque = mae_shadowed(&traced_v, &opaque_v, &out.receiver);
    eprintln!(
        "masked checker: traced vs ray cast {difference:.4} (sampling errors summed {sampling:.4}); traced vs opaque quad {against_opaque:.4}"
    );
    ensure!(
        difference <= 2.0 * sampling.max(1e-3),
        "ray-traced and ray-cast answers differ by {difference:.4}, over twice their sampling errors ({sampling:.4})"
    );
    ensure!(
        against_opaque > 0.2,
        "the masked answer is within {against_opaque:.4} of the opaque quad's: the holes are not seen"
    );
    Ok(())
}

/// Every technique's bound on `stiff-masked-checker` lives in its crate (the stiff suite holds
/// each technique to it, and checks that it rejects all-lit and `hard`); here each bound must
/// also reject the opaque quad's answer: what a light-space pass without the alpha test draws.
#[test]
fn every_bound_on_the_masked_checker_rejects_the_opaque_quads_answer() -> Result<()> {
    let gpu = gpu()?;
    let case = "stiff-masked-checker";
    let scene = softshadow_scenes::load(case)?.scene;
    let mut opaque = scene.clone();
    opaque.materials.clear();
    opaque.textures.clear();
    for instance in &mut opaque.instances {
        instance.material = None;
    }
    let out = render(&gpu, &scene, softshadow_core::COST_FLOOR_TECHNIQUE)?;
    let (exact, _) = traced(&gpu, &scene, &out)?;
    let opaque_v = softshadow_reference::raycast::visibility_image(
        &opaque,
        &out.positions,
        &out.receiver,
        SAMPLES,
    );
    // The bench's measures: over the receiver pixels the exact answer shadows, and the largest.
    let shadowed: Vec<bool> = exact
        .iter()
        .zip(&out.receiver)
        .map(|(e, r)| *r && *e < 1.0)
        .collect();
    let errors: Vec<f64> = (0..exact.len())
        .filter(|&k| shadowed[k])
        .map(|k| (opaque_v[k] as f64 - exact[k] as f64).abs())
        .collect();
    ensure!(!errors.is_empty(), "the exact answer shadows nothing");
    let mae_shadowed = errors.iter().sum::<f64>() / errors.len() as f64;
    let max_abs = errors.iter().copied().fold(0.0, f64::max);
    let class = softshadow_scenes::stiff::class_of(case);
    let mut failures = Vec::new();
    for info in &softshadow::registry() {
        let stated = info
            .expectations
            .resolve(case, class)
            .with_context(|| format!("{} states nothing for {case}", info.id))?;
        let value = match stated.expect.metric() {
            softshadow_core::ErrorMetric::MaeShadowed => mae_shadowed,
            softshadow_core::ErrorMetric::MaxAbs => max_abs,
        };
        eprintln!(
            "{}: {} vs the opaque quad's {value:.4}",
            info.id,
            stated.expect.describe()
        );
        if stated.expect.accepts(value) {
            failures.push(format!(
                "{}: its bound on {case} ({}) accepts the opaque quad's answer ({value:.4})",
                info.id,
                stated.expect.describe()
            ));
        }
    }
    ensure!(failures.is_empty(), "{}", failures.join("\n"));
    Ok(())
}

/// The G-buffer sends only the triangles of instances with a material through its material
/// pipeline: the scene's triangles split into the ground's (plain) and the checker quad's; a
/// scene without materials has no split. (The images are the same bit for bit: the material
/// pipeline writes what the plain one does for a triangle without a material.)
#[test]
fn only_the_triangles_with_a_material_take_the_material_pipeline() -> Result<()> {
    let gpu = gpu()?;
    let count = |list: Option<&softshadow_core::scene_gpu::IndexList>| list.map_or(0, |l| l.count);
    let masked = masked_checker(LIGHT_WIDTH, CELLS, true);
    let quad = &masked.meshes[masked.instances.last().context("the quad")?.mesh];
    let scene = SceneGpu::upload(&gpu, &masked);
    let split = scene
        .all_by_material
        .as_ref()
        .context("a scene with materials is split")?;
    let (plain, with_material) = (
        count(split.plain.as_ref()),
        count(split.with_material.as_ref()),
    );
    ensure!(
        with_material as usize == quad.indices.len()
            && plain + with_material == count(scene.all.as_ref())
            && plain > 0,
        "plain {plain}, with a material {with_material}, the quad's {}, all {}",
        quad.indices.len(),
        count(scene.all.as_ref())
    );
    let opaque = SceneGpu::upload(&gpu, &masked_checker(LIGHT_WIDTH, CELLS, false));
    ensure!(opaque.materials.is_none() && opaque.all_by_material.is_none());
    Ok(())
}
