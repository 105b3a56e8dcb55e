//! Every WGSL file in a crate's `shaders/` folder (`crates/<crate>/shaders/`) is composed
//! (naga_oil `#import`) and validated with naga, in every permutation its crate declares. No shader
//! folder at all, or a file that no crate declares (so nothing would validate it), is a failure.

use std::{
    collections::{BTreeMap, BTreeSet},
    path::{Path, PathBuf},
};

use anyhow::{bail, ensure, Result};
use encase::ShaderType;
use softshadow_core::glam::{Vec2, Vec4};
use softshadow_core::shader::{
    compose,
    uniform_layout::{self, FieldLayout, UniformMirror},
    ShaderSpec,
};

/// The shaders of the core, of every registered technique and of the viewer.
fn all_specs() -> Vec<ShaderSpec> {
    let mut specs = softshadow::registry().all_shaders();
    // The viewer depends on the bench, so its shaders are added here rather than in the registry.
    specs.extend_from_slice(softshadow_viewer::SHADERS);
    specs
}

fn wgsl_files(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_dir() {
            wgsl_files(&path, out)?;
        } else if path.extension().is_some_and(|e| e == "wgsl") {
            out.push(path);
        }
    }
    Ok(())
}

/// Every `.wgsl` file of the workspace's crates by its key (its path under its crate's
/// `shaders/`, as `shader_file!` names it), with the file; a key two crates use is an error.
fn shader_files_by_key() -> Result<BTreeMap<String, PathBuf>> {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("crates");
    let mut by_key = BTreeMap::new();
    for entry in std::fs::read_dir(&crates)? {
        let shader_dir = entry?.path().join("shaders");
        if !shader_dir.is_dir() {
            continue;
        }
        let mut files = Vec::new();
        wgsl_files(&shader_dir, &mut files)?;
        for file in files {
            let key = file
                .strip_prefix(&shader_dir)?
                .to_string_lossy()
                .replace('\\', "/");
            if let Some(other) = by_key.insert(key.clone(), file.clone()) {
                bail!(
                    "{} and {} have the same key `{key}`: keep a crate's files in a folder named after it",
                    other.display(),
                    file.display()
                );
            }
        }
    }
    ensure!(
        !by_key.is_empty(),
        "no .wgsl file in any {}/*/shaders/ folder",
        crates.display()
    );
    Ok(by_key)
}

#[test]
fn every_shader_and_permutation_validates() -> Result<()> {
    let files = shader_files_by_key()?;

    let specs = all_specs();
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
    for (key, file) in &files {
        let declared = specs.iter().any(|s| s.path == key) || common.contains(&key.as_str());
        ensure!(
            declared,
            "{} is not declared by any crate's SHADERS list, so it is never validated",
            file.display()
        );
    }
    for spec in &specs {
        ensure!(
            files.contains_key(spec.path),
            "{} is declared but is in no crate's shaders/ folder",
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

/// Every crate's Rust uniform structs (and the storage structs the CPU writes or reads) with the
/// WGSL structs they fill (each crate lists its own in a hidden `uniform_mirrors()`, where its
/// private structs are visible; the facade gathers the built-ins').
fn all_mirrors() -> Vec<UniformMirror> {
    let mut mirrors = softshadow_core::uniform_mirrors();
    mirrors.extend(softshadow::builtin_uniform_mirrors());
    mirrors.extend(softshadow_viewer::uniform_mirrors());
    mirrors
}

/// Every struct held by a `var<uniform>` in any shader, in every permutation, has the size and
/// field offsets of its Rust struct (encase's layout of it); so does every `var<storage>` struct
/// with a Rust struct listed. A uniform struct without one, or a listed struct that no shader
/// holds, fails too.
#[test]
fn every_uniform_struct_matches_its_rust_mirror() -> Result<()> {
    let mirrors = all_mirrors();
    let mut used = vec![false; mirrors.len()];
    // A set: a struct from a common module is met again in every shader that imports it.
    let mut errors = BTreeSet::new();
    let mut compared = 0;
    for spec in all_specs() {
        for permutation in spec.permutations {
            let module = compose(&spec, permutation)?;
            let uniform = uniform_layout::uniform_structs(&module)?;
            let storage = uniform_layout::storage_structs(&module)?;
            let held = (uniform.into_iter().map(|s| (s, true)))
                .chain(storage.into_iter().map(|s| (s, false)));
            for (mut wgsl, in_uniform) in held {
                let matching: Vec<usize> = (0..mirrors.len())
                    .filter(|&i| {
                        mirrors[i].may_appear_in(spec.path) && mirrors[i].naga_name() == wgsl.name
                    })
                    .collect();
                wgsl.name = uniform_layout::display_name(&wgsl.name);
                if matching.is_empty() && in_uniform {
                    errors.insert(format!(
                        "{}: uniform struct `{}` has no Rust struct to compare with: derive \
                         encase::ShaderType for the one that fills it and list it with \
                         softshadow_core::uniform_mirror! in its crate's uniform_mirrors()",
                        spec.path, wgsl.name
                    ));
                }
                for i in matching {
                    used[i] = true;
                    compared += 1;
                    // A common module's struct is the same in every shader importing it: name its
                    // file once rather than every shader and permutation.
                    let place = if mirrors[i].from_common_module() {
                        mirrors[i].wgsl_file.to_string()
                    } else {
                        format!("{} {permutation:?}", spec.path)
                    };
                    for error in uniform_layout::compare(&mirrors[i].rust, &wgsl) {
                        errors.insert(format!("{place}: {error}"));
                    }
                }
            }
        }
    }
    for (mirror, used) in mirrors.iter().zip(used) {
        if !used {
            errors.insert(format!(
                "Rust `{}` is listed for `{}` in {}, but no shader holds that struct in a uniform \
                 or storage buffer",
                mirror.rust.name, mirror.wgsl_struct, mirror.wgsl_file
            ));
        }
    }
    ensure!(
        errors.is_empty(),
        "{} uniform layout mismatch(es):\n{}",
        errors.len(),
        errors.into_iter().collect::<Vec<_>>().join("\n")
    );
    ensure!(compared >= mirrors.len(), "compared only {compared} pairs");
    Ok(())
}

/// The comparison names the struct and the field when a field is added on one side only, moved,
/// or resized, and when the sizes differ; the Rust side is encase's layout of a real struct.
#[test]
fn a_uniform_mirror_out_of_step_is_reported_with_the_field() -> Result<()> {
    // A WGSL struct as a shader would declare it, reflected the way the real ones are.
    let spec = ShaderSpec {
        path: "test/params.wgsl",
        source: "struct Params {
    scale: f32,
    count: u32,
    added: f32,
    direction: vec4<f32>,
}
@group(0) @binding(0) var<uniform> params: Params;
@fragment fn fs_main() -> @location(0) vec4<f32> {
    return params.direction * params.scale;
}",
        permutations: &[&[]],
    };
    let wgsl = uniform_layout::wgsl_struct_layout(&spec, &[], "Params")?
        .expect("the struct is in the module");
    let field = |name: &str, offset, size| FieldLayout {
        name: name.into(),
        offset,
        size,
    };
    assert_eq!(wgsl.size, 32);
    assert_eq!(wgsl.fields[2], field("added", 8, 4));

    // A deliberately stale Rust struct: `added` is missing. The vec4 still starts at 16 and the
    // sizes agree, so only the field list tells.
    #[derive(ShaderType)]
    struct StaleParams {
        scale: f32,
        count: u32,
        direction: Vec4,
    }
    let stale = softshadow_core::uniform_mirror!(
        StaleParams { scale, count, direction } => "test/params.wgsl", Params
    );
    assert_eq!(
        uniform_layout::compare(&stale.rust, &wgsl),
        ["Rust `StaleParams` / WGSL `Params`: field `added` (offset 8, 4 bytes) is in WGSL only"]
    );
    // The offsets are encase's by field name, whatever the order of the list.
    let listed_backwards = softshadow_core::uniform_mirror!(
        StaleParams { direction, count, scale } => "test/params.wgsl", Params
    );
    assert_eq!(listed_backwards.rust.fields[1], field("count", 4, 4));
    assert_eq!(listed_backwards.rust.fields[0], field("direction", 16, 16));

    // Added in Rust only, which also grows the struct (a vec4 rounds it up to 16 bytes).
    #[derive(ShaderType)]
    struct GrownParams {
        scale: f32,
        count: u32,
        added: f32,
        direction: Vec4,
        extra: f32,
    }
    let grown = softshadow_core::uniform_mirror!(
        GrownParams { scale, count, added, direction, extra } => "test/params.wgsl", Params
    );
    assert_eq!(
        uniform_layout::compare(&grown.rust, &wgsl),
        [
            "Rust `GrownParams` / WGSL `Params`: size 48 bytes in Rust, 32 in WGSL",
            "Rust `GrownParams` / WGSL `Params`: field `extra` (offset 32, 4 bytes) is in Rust only",
        ]
    );

    // Two fields swapped on one side; and one of another size.
    #[derive(ShaderType)]
    struct MovedParams {
        count: u32,
        scale: f32,
        added: Vec2,
        direction: Vec4,
    }
    let moved = softshadow_core::uniform_mirror!(
        MovedParams { count, scale, added, direction } => "test/params.wgsl", Params
    );
    assert_eq!(
        uniform_layout::compare(&moved.rust, &wgsl),
        [
            "Rust `MovedParams` / WGSL `Params`: field `scale` at offset 4 in Rust, 0 in WGSL",
            "Rust `MovedParams` / WGSL `Params`: field `count` at offset 0 in Rust, 4 in WGSL",
            "Rust `MovedParams` / WGSL `Params`: field `added` is 8 bytes in Rust, 4 in WGSL",
        ]
    );

    // And a matching pair has nothing to say.
    #[derive(ShaderType)]
    struct MatchingParams {
        scale: f32,
        count: u32,
        added: f32,
        direction: Vec4,
    }
    let matching = softshadow_core::uniform_mirror!(
        MatchingParams { scale, count, added, direction } => "test/params.wgsl", Params
    );
    assert!(uniform_layout::compare(&matching.rust, &wgsl).is_empty());
    Ok(())
}
