//! Issue 37: restructuring the passes (a pass builder, one caster pass, uniforms declared once,
//! shaders moved into their crates) must not change an image. Every registered technique and
//! every example WGSL technique, at its defaults, renders three frames of two scenes (a planar
//! caster and a curved one, 64²); the checksums of the visibility after each frame are those
//! taken before the restructuring (Mesa 25.0.7's lavapipe). Three frames, so that the temporal
//! paths (history, reprojection, sample rotation) are covered too. Another driver compiles the
//! shaders differently, so the comparison runs on that driver only; elsewhere it prints them.

use std::path::Path;

use crate::common::{checksum, gpu};
use anyhow::{ensure, Context, Result};
use softshadow_core::{Renderer, SceneGpu};

const SIZE: u32 = 64;
const FRAMES: usize = 3;
const SCENES: &[&str] = &["stiff-large-light", "blob-floating:triangles=2000"];
const WGSL_EXAMPLES: &[&str] = &["one_tap.wgsl", "pcf.wgsl", "pcss_like.wgsl"];
/// Settings beside the defaults whose passes the defaults leave out (technique, settings).
const VARIANTS: &[(&str, &[&str])] = &[("pcss", &["temporal=true"])];

/// The checksums before the restructuring, as "scene technique frame checksum" lines.
const BEFORE: &str = include_str!("image_checksums.txt");

/// Every technique's checksum line for every scene and frame, in registry order.
fn checksum_lines() -> Result<Vec<String>> {
    let gpu = gpu()?;
    let mut registry = softshadow::registry();
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/wgsl");
    for file in WGSL_EXAMPLES {
        softshadow_wgsl::register_file(&mut registry, &examples.join(file))?;
    }
    let mut lines = Vec::new();
    for scene_name in SCENES {
        let scene = softshadow_scenes::load(scene_name)?.scene;
        let scene_gpu = SceneGpu::upload(&gpu, &scene);
        let defaults = registry.iter().map(|info| (info.id.to_string(), &[][..]));
        let variants = VARIANTS.iter().map(|(id, s)| (id.to_string(), *s));
        let runs: Vec<(String, &[&str])> = defaults.chain(variants).collect();
        for (id, settings) in runs {
            let id = id.as_str();
            let texts: Vec<String> = settings.iter().map(|s| s.to_string()).collect();
            let parsed = softshadow_bench::parse_params(&registry, id, &texts)?;
            let info = registry.find(id)?;
            let mut technique = info.create_with(&gpu, &parsed).context(id.to_string())?;
            let mut renderer = Renderer::new(&gpu, SIZE, SIZE)?;
            let name = [id]
                .iter()
                .chain(settings)
                .copied()
                .collect::<Vec<_>>()
                .join(",");
            for frame in 0..FRAMES {
                renderer.render(
                    &scene_gpu,
                    &scene.camera,
                    &scene.light,
                    technique.as_mut(),
                    None,
                )?;
                let sum = checksum(&renderer.read_visibility()?);
                lines.push(format!("{scene_name} {name} {frame} {sum:#018x}"));
            }
        }
    }
    Ok(lines)
}

#[test]
fn every_technique_at_its_defaults_keeps_its_images_bit_for_bit() -> Result<()> {
    let lines = checksum_lines()?;
    eprintln!("checksums:\n{}", lines.join("\n"));
    let summary = gpu()?.summary();
    if summary.mesa_version() != Some((25, 0)) {
        eprintln!(
            "not Mesa 25.0's lavapipe ({}): not compared",
            summary.driver
        );
        return Ok(());
    }
    let before: Vec<&str> = BEFORE.lines().filter(|l| !l.is_empty()).collect();
    let changed: Vec<String> = lines
        .iter()
        .filter(|line| !before.contains(&line.as_str()))
        .cloned()
        .collect();
    ensure!(
        changed.is_empty() && lines.len() == before.len(),
        "{} of {} images changed (or were added/removed) against image_checksums.txt:\n{}",
        changed.len(),
        before.len(),
        changed.join("\n")
    );
    Ok(())
}
