//! The library crates are ready to publish: each has the metadata crates.io shows (description,
//! license, readme, keywords, categories), a README that exists, documents every public item
//! (`#![warn(missing_docs)]`, kept clean by clippy's `-D warnings`), carries every `.wgsl` file
//! of its `shaders/` folder, and `cargo package --workspace` succeeds. Nothing is uploaded and
//! nothing is compiled (`--no-verify`), so this costs a few seconds, not a build; docs/LIBRARY.md
//! lists the `cargo doc` check, which would cost CI a `cargo check` of every dependency.

use std::{path::Path, process::Command};

use anyhow::{ensure, Context, Result};

/// The crates a user adds to their own renderer (docs/LIBRARY.md): every `softshadow-*` package
/// of the workspace but the applications built on them, so a new technique crate is checked
/// without being listed here.
const APPLICATION_CRATES: &[&str] = &["softshadow-bench", "softshadow-viewer"];

fn is_library_crate(name: &str) -> bool {
    name.starts_with("softshadow-") && !APPLICATION_CRATES.contains(&name)
}

fn cargo(args: &[&str], target: &Path) -> Result<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let output = Command::new(&cargo)
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        // Its own target folder: the package step must not wait for (or disturb) the build lock.
        .env("CARGO_TARGET_DIR", target)
        .output()
        .with_context(|| format!("running {cargo} {}", args.join(" ")))?;
    ensure!(
        output.status.success(),
        "`cargo {}` failed:\n{}",
        args.join(" "),
        String::from_utf8_lossy(&output.stderr)
    );
    Ok(String::from_utf8(output.stdout)?)
}

/// The `.wgsl` files under `dir` (none when it does not exist), as paths relative to `root` with
/// `/` separators, as `cargo package --list` prints them.
fn wgsl_files_under(dir: &Path, root: &Path) -> Result<Vec<String>> {
    let mut files = Vec::new();
    if !dir.is_dir() {
        return Ok(files);
    }
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_dir() {
            files.extend(wgsl_files_under(&path, root)?);
        } else if path.extension().is_some_and(|e| e == "wgsl") {
            let relative = path
                .strip_prefix(root)?
                .to_string_lossy()
                .replace('\\', "/");
            files.push(relative);
        }
    }
    Ok(files)
}

#[test]
fn library_crates_have_metadata_docs_and_package() -> Result<()> {
    let target = std::env::temp_dir().join(format!("softshadow-package-{}", std::process::id()));
    let metadata: serde_json::Value = serde_json::from_str(&cargo(
        &[
            "metadata",
            "--no-deps",
            "--format-version",
            "1",
            "--offline",
        ],
        &target,
    )?)?;
    let packages = metadata["packages"]
        .as_array()
        .context("cargo metadata without packages")?;
    let mut problems = Vec::new();
    let libraries: Vec<&serde_json::Value> = packages
        .iter()
        .filter(|p| p["name"].as_str().is_some_and(is_library_crate))
        .collect();
    // The core, scenes, metrics and the eight built-in techniques (the reference among them) at
    // least.
    ensure!(
        libraries.len() >= 11,
        "only {} library crates found by cargo metadata",
        libraries.len()
    );
    let mut library_dirs = Vec::new();
    for package in libraries {
        let name = package["name"].as_str().context("package name")?;
        for field in ["description", "license", "readme", "rust_version"] {
            if !package[field].is_string() {
                problems.push(format!("{name}: no `{field}` in its Cargo.toml"));
            }
        }
        for field in ["keywords", "categories"] {
            if package[field].as_array().is_none_or(|a| a.is_empty()) {
                problems.push(format!("{name}: no `{field}` in its Cargo.toml"));
            }
        }
        let manifest = Path::new(package["manifest_path"].as_str().context("manifest_path")?);
        let dir = manifest.parent().context("manifest folder")?;
        library_dirs.push((name.to_string(), dir.to_path_buf()));
        if !dir.join("README.md").is_file() {
            problems.push(format!("{name}: no README.md beside its Cargo.toml"));
        }
        let lib = std::fs::read_to_string(dir.join("src/lib.rs"))?;
        if !lib.contains("#![warn(missing_docs)]") {
            problems.push(format!(
                "{name}: src/lib.rs lacks `#![warn(missing_docs)]`: add it and document what it reports"
            ));
        }
    }
    ensure!(problems.is_empty(), "{}", problems.join("\n"));

    cargo(
        &[
            "package",
            "--workspace",
            "--no-verify",
            "--allow-dirty",
            "--offline",
        ],
        &target,
    )?;
    // Every WGSL file in a crate's `shaders/` folder must travel with it (`shader_file!` reads
    // them at compile time, so a package without them does not build).
    let mut crates_with_shaders = 0;
    for (name, dir) in &library_dirs {
        let shaders = wgsl_files_under(&dir.join("shaders"), dir)?;
        if shaders.is_empty() {
            continue;
        }
        crates_with_shaders += 1;
        let list = cargo(
            &[
                "package",
                "--list",
                "--allow-dirty",
                "--offline",
                "-p",
                name,
            ],
            &target,
        )?;
        let packaged: Vec<&str> = list.lines().collect();
        for file in &shaders {
            ensure!(
                packaged.contains(&file.as_str()),
                "{name}'s package lacks {file}: check `include`/`exclude` in its Cargo.toml\n{list}"
            );
        }
    }
    // The core and the eleven built-in techniques (the reference among them), at least.
    ensure!(
        crates_with_shaders >= 12,
        "only {crates_with_shaders} library crates have a shaders/ folder with .wgsl files"
    );
    let _ = std::fs::remove_dir_all(&target);
    Ok(())
}
