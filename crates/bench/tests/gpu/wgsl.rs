//! A WGSL file is a technique (`softshadow-wgsl`, docs/WGSL.md): the example PCF with radius 0
//! is `hard` on five scenes (two under the sun), the PCSS-like example stays within its bounds of
//! the exact answer under a rectangle and the sun (which `hard` and an all-lit answer fail), and
//! broken files, bindings outside the contract and out-of-range parameters are refused with one
//! line naming the file, line and column.

use std::path::{Path, PathBuf};

use crate::common::{all_lit_vs_exact, gpu, run_checked, vs_exact};
use anyhow::{ensure, Context, Result};
use softshadow_bench::{parse_params, Bench, BenchOptions, RunSpec};
use softshadow_core::{ParamValue, Registry, Renderer, SceneGpu, ShadowTechnique};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/wgsl")
        .join(name)
}

/// The built-ins plus the file `name` of `examples/wgsl/`, and its id.
fn registry_with(name: &str) -> Result<(Registry, String)> {
    let mut registry = softshadow::registry();
    let id = softshadow_wgsl::register_file(&mut registry, &example(name))?;
    Ok((registry, id))
}

/// The visibility `technique` draws on `scene` at `size`².
fn visibility(
    gpu: &softshadow_core::Gpu,
    scene: &str,
    technique: &mut dyn ShadowTechnique,
    size: u32,
) -> Result<Vec<f32>> {
    let scene = softshadow_scenes::load(scene)?.scene;
    let scene_gpu = SceneGpu::upload(gpu, &scene);
    let mut renderer = Renderer::new(gpu, size, size)?;
    technique.prepare(
        gpu,
        &renderer.inputs(&scene_gpu, &scene.camera, &scene.light),
    )?;
    renderer.render(&scene_gpu, &scene.camera, &scene.light, technique, None)?;
    Ok(renderer.read_visibility()?)
}

fn max_abs_difference(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

/// PCF with radius 0 is `hard` bit for bit: under a rectangle from the centre map, under the
/// sun (contract version 3) from the sun's one map, `hard`'s with `cascades=1`.
#[test]
fn the_example_pcf_with_radius_0_is_hard_on_five_scenes() -> Result<()> {
    let gpu = gpu()?;
    let (registry, id) = registry_with("pcf.wgsl")?;
    let hard_id = softshadow_core::COST_FLOOR_TECHNIQUE;
    for scene in [
        "atty-square",
        "blob-floating:triangles=2000",
        "stiff-receiver-behind-light",
        "atty-square:light=sun",
        "balls-3x3x3:light=sun",
    ] {
        let one_map = [("cascades".into(), ParamValue::Int(1))];
        let hard_params: &[_] = if scene.ends_with("light=sun") {
            &one_map
        } else {
            &[]
        };
        let mut hard = registry.find(hard_id)?.create_with(&gpu, hard_params)?;
        let hard_v = visibility(&gpu, scene, hard.as_mut(), 128)?;
        let one_tap = registry
            .find(&id)?
            .create_with(&gpu, &[("radius".into(), ParamValue::Int(0))])?;
        let mut one_tap = one_tap;
        let one_tap_v = visibility(&gpu, scene, one_tap.as_mut(), 128)?;
        let difference = max_abs_difference(&hard_v, &one_tap_v);
        eprintln!("{scene}: pcf radius 0 against hard: max |dV| = {difference}");
        ensure!(
            difference <= 1e-6,
            "{scene}: pcf radius 0 differs from hard by {difference}"
        );
        // The parameter reaches the shader: a wider kernel softens the edge.
        let mut wide = registry
            .find(&id)?
            .create_with(&gpu, &[("radius".into(), ParamValue::Int(2))])?;
        let wide_v = visibility(&gpu, scene, wide.as_mut(), 128)?;
        let softened = hard_v
            .iter()
            .zip(&wide_v)
            .filter(|(h, w)| (*h - *w).abs() > 1e-3 && **w > 0.0 && **w < 1.0)
            .count();
        ensure!(
            softened > 0,
            "{scene}: pcf radius 2 draws the hard shadow: the parameter does not reach the shader"
        );
    }
    Ok(())
}

/// The bounds of the PCSS-like example (64², `mae_shadowed` against the exact answer), each
/// with the value measured (docs/WGSL.md, "Examples"): on `atty-square` (the closed form) and
/// under the sun 10 degrees wide (contract version 3; the sampled exact answer).
const PCSS_LIKE_BOUNDS: [(&str, f64, f64); 3] = [
    ("atty-square", 0.0255, 0.0232),
    ("atty-square:light=sun", 0.0214, 0.0195),
    // Overlapping balls: the built-in `pcss` measures 0.147 there (docs/LIGHTS.md).
    ("balls-3x3x3:light=sun", 0.175, 0.1599),
];
// Each bound rejects every answer more than CLEARLY_WORSE times its measurement.
const _: () = {
    let mut i = 0;
    while i < PCSS_LIKE_BOUNDS.len() {
        let (_, bound, measured) = PCSS_LIKE_BOUNDS[i];
        assert!(bound <= softshadow_bench::expectations::CLEARLY_WORSE * measured);
        i += 1;
    }
};

#[test]
fn the_example_pcss_like_is_within_its_bounds_which_hard_and_all_lit_fail() -> Result<()> {
    let (registry, id) = registry_with("pcss_like.wgsl")?;
    let mut bench = Bench::new(
        gpu()?,
        registry,
        BenchOptions {
            frames: 1,
            warmup: 0,
            error: true,
            reference_params: vec![
                ("samples_per_axis".into(), ParamValue::Int(4)),
                ("shadow_map_size".into(), ParamValue::Int(256)),
            ],
            images: false,
            exact_samples_per_axis: Some(16),
            camera_only: false,
            reference_cache: None,
            ..Default::default()
        },
    )?;
    for (scene, bound, measured) in PCSS_LIKE_BOUNDS {
        let mut errors = Vec::new();
        for technique in [id.as_str(), softshadow_core::COST_FLOOR_TECHNIQUE] {
            let spec = RunSpec {
                scene: scene.into(),
                technique: technique.into(),
                params: Vec::new(),
                width: 64,
                height: 64,
                path: None,
            };
            let run = run_checked(&mut bench, &spec)?;
            errors.push(vs_exact(&run)?.mae_shadowed);
            if technique == id {
                errors.push(all_lit_vs_exact(&run)?.mae_shadowed);
            }
        }
        let (file, all_lit, hard) = (errors[0], errors[1], errors[2]);
        eprintln!("{scene} 64²: pcss_like {file:.4}, hard {hard:.4}, all-lit {all_lit:.4} (mae_shadowed against the exact answer)");
        ensure!(
            file <= bound,
            "{scene}: pcss_like: mae_shadowed {file:.4} > its bound {bound} (measured {measured})"
        );
        for (name, wrong) in [("hard", hard), ("all-lit", all_lit)] {
            ensure!(
                wrong > bound,
                "{scene}: the bound {bound} accepts the {name} answer ({wrong:.4}): tighten it"
            );
        }
    }
    Ok(())
}

fn load_error(name: &str, text: &str) -> Result<(PathBuf, String, tempfile::TempDir)> {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join(name);
    std::fs::write(&path, text)?;
    let message = match softshadow_wgsl::load(&path) {
        Ok(_) => anyhow::bail!("{name} loaded: it should have been refused"),
        Err(e) => e.to_string(),
    };
    ensure!(!message.contains('\n'), "more than one line: {message}");
    Ok((path, message, dir))
}

#[test]
fn a_file_with_a_syntax_error_is_refused_with_file_line_and_column() -> Result<()> {
    let text =
        std::fs::read_to_string(example("pcf.wgsl"))?.replace("var lit = 0.0;", "var lit = 0.0");
    let line = text
        .lines()
        .position(|l| l.contains("var lit = 0.0"))
        .context("the example changed")?
        + 1;
    let (path, message, _dir) = load_error("broken.wgsl", &text)?;
    eprintln!("{message}");
    let prefix = format!("{}:{}:", path.display(), line);
    let next_line = format!("{}:{}:", path.display(), line + 1);
    ensure!(
        message.starts_with(&prefix) || message.starts_with(&next_line),
        "expected {prefix}COLUMN (the missing `;` or the token after it): {message}"
    );
    Ok(())
}

#[test]
fn a_file_with_a_wrong_binding_is_refused_with_file_line_and_column() -> Result<()> {
    let text = format!(
        "{}\n@group(1) @binding(3) var<uniform> my_extra: vec4<f32>;\n",
        std::fs::read_to_string(example("pcf.wgsl"))?
    );
    let line = text.lines().count();
    let (path, message, _dir) = load_error("extra_binding.wgsl", &text)?;
    eprintln!("{message}");
    let prefix = format!("{}:{line}:", path.display());
    ensure!(message.starts_with(&prefix), "expected {prefix}: {message}");
    ensure!(
        message.contains("@group(1) @binding(3)")
            && message.contains("not a binding of the contract"),
        "{message}"
    );
    Ok(())
}

#[test]
fn a_parameter_out_of_its_declared_range_is_refused_like_any_other() -> Result<()> {
    let (registry, id) = registry_with("pcf.wgsl")?;
    let message = parse_params(&registry, &id, &["radius=9".into()])
        .err()
        .context("radius=9 is outside 0..=8 and was accepted")?
        .to_string();
    ensure!(
        message.contains("`radius` = 9 is out of range: use a value from 0 to 8"),
        "{message}"
    );
    let message = parse_params(&registry, &id, &["bias_texels=NaN".into()])
        .err()
        .context("bias_texels=NaN was accepted")?
        .to_string();
    ensure!(message.contains("not finite"), "{message}");
    // A default outside its own range is refused when the file is read, at its line.
    let (path, message, _dir) = load_error(
        "bad_default.wgsl",
        "// @param radius: u32 = 9 in 0..=8, Radius\nfn visibility(s: Surface, pixel: vec2<i32>) -> f32 { return 1.0; }\n",
    )?;
    ensure!(
        message.starts_with(&format!("{}:1:", path.display()))
            && message.contains("outside its range"),
        "{message}"
    );
    Ok(())
}

#[test]
fn a_file_named_like_a_registered_technique_is_refused() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let path = dir
        .path()
        .join(format!("{}.wgsl", softshadow_core::COST_FLOOR_TECHNIQUE));
    std::fs::copy(example("pcf.wgsl"), &path)?;
    let mut registry = softshadow::registry();
    let message = softshadow_wgsl::register_file(&mut registry, &path)
        .err()
        .context("a file with a built-in's id was registered")?
        .to_string();
    ensure!(message.contains("rename the file"), "{message}");
    // The same file twice is one technique.
    let (mut registry, id) = registry_with("pcf.wgsl")?;
    ensure!(softshadow_wgsl::register_file(&mut registry, &example("pcf.wgsl"))? == id);
    Ok(())
}
