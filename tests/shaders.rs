//! Every WGSL file under `shaders/` is composed (naga_oil `#import`) and validated with naga, in
//! every permutation its crate declares. A missing or empty shader folder, or a file that no crate
//! declares (so nothing would validate it), is a failure.

use std::path::Path;

use anyhow::{bail, ensure, Result};

fn wgsl_files(dir: &Path, root: &Path, out: &mut Vec<String>) -> Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_dir() {
            wgsl_files(&path, root, out)?;
        } else if path.extension().is_some_and(|e| e == "wgsl") {
            out.push(
                path.strip_prefix(root)?
                    .to_string_lossy()
                    .replace('\\', "/"),
            );
        }
    }
    Ok(())
}

#[test]
fn every_shader_and_permutation_validates() -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    if !root.is_dir() {
        bail!("shader folder {} is missing", root.display());
    }
    let mut files = Vec::new();
    wgsl_files(&root, &root, &mut files)?;
    ensure!(
        !files.is_empty(),
        "shader folder {} holds no .wgsl file",
        root.display()
    );

    let mut specs = softshadow::registry().all_shaders();
    // The viewer depends on the bench, so its shaders are added here rather than in the registry.
    specs.extend_from_slice(softshadow_viewer::SHADERS);
    let validated = softshadow_core::shader::validate_all(&specs)?;
    ensure!(
        validated >= specs.len(),
        "validated {validated} permutations of {} shaders",
        specs.len()
    );

    let common: Vec<&str> = softshadow_core::shader::COMMON_MODULES
        .iter()
        .map(|(p, _)| *p)
        .collect();
    for file in &files {
        let declared = specs.iter().any(|s| s.path == file) || common.contains(&file.as_str());
        ensure!(
            declared,
            "shaders/{file} is not declared by any crate's SHADERS list, so it is never validated"
        );
    }
    for spec in &specs {
        ensure!(
            files.contains(&spec.path.to_string()),
            "{} is declared but not under shaders/",
            spec.path
        );
    }
    Ok(())
}

#[test]
fn a_broken_shader_is_reported_with_its_path() {
    let broken = softshadow_core::shader::ShaderSpec {
        path: "test/broken.wgsl",
        source: "#import softshadow::frame::load_surface\n@fragment fn fs_main() -> @location(0) vec4<f32> { return undefined_name; }",
        permutations: &[&[]],
    };
    let error = softshadow_core::shader::validate_all(&[broken])
        .unwrap_err()
        .to_string();
    assert!(error.contains("test/broken.wgsl"), "{error}");
}
