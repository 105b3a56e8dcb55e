//! Everything the workspace knows about a technique comes from its crate: no string literal
//! naming a registered technique's id (`"pcss"`, or a pass name `"pcss/filter"`) stands in
//! non-test code outside that technique's crate (`crates/<id>`). Two are allowed, each named once
//! by a constant: the yardstick and the cost floor (`softshadow_core::YARDSTICK_TECHNIQUE`,
//! `COST_FLOOR_TECHNIQUE`); and the facade's feature gates (`#[cfg(feature = "pcss")]`), which
//! are the registry line a built-in technique adds.

use std::path::{Path, PathBuf};

use anyhow::{ensure, Result};

/// The two allowed literals: the lines that name the constants.
const ALLOWED: &[&str] = &[
    "pub const YARDSTICK_TECHNIQUE: &str = \"reference\";",
    "pub const COST_FLOOR_TECHNIQUE: &str = \"hard\";",
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_dir() {
            rust_files(&path, out)?;
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    Ok(())
}

/// The non-test lines of a source file: everything before its first `#[cfg(test)]` module
/// (test modules stand at the end of a file in this workspace), without comments.
fn code_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .take_while(|(_, line)| line.trim() != "#[cfg(test)]")
        .filter(|(_, line)| !line.trim_start().starts_with("//"))
        .map(|(k, line)| (k + 1, line))
}

/// The places in `text` (non-test code) whose string literals name `id`.
fn literals_naming(text: &str, id: &str) -> Vec<(usize, String)> {
    let exact = format!("\"{id}\"");
    let pass = format!("\"{id}/");
    code_lines(text)
        .filter(|(_, line)| line.contains(&exact) || line.contains(&pass))
        .filter(|(_, line)| !ALLOWED.contains(&line.trim()))
        .filter(|(_, line)| !line.trim_start().starts_with("#[cfg(feature ="))
        .map(|(k, line)| (k, line.trim().to_string()))
        .collect()
}

#[test]
fn no_technique_id_is_spelled_outside_its_crate() -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files)?;
    for parent in ["crates", "examples"] {
        for entry in std::fs::read_dir(root.join(parent))? {
            let src = entry?.path().join("src");
            if src.is_dir() {
                rust_files(&src, &mut files)?;
            }
        }
    }
    ensure!(files.len() > 50, "only {} source files found", files.len());
    let registry = softshadow::registry();
    let mut found = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file)?;
        let shown = file.strip_prefix(root)?.display().to_string();
        for id in registry.ids() {
            if file.starts_with(root.join("crates").join(id)) {
                continue;
            }
            for (line, code) in literals_naming(&text, id) {
                found.push(format!("{shown}:{line}: `{id}` in {code}"));
            }
        }
    }
    ensure!(
        found.is_empty(),
        "{} string literals name a technique outside its crate: move what they say into the technique's `info()` (softshadow_core::TechniqueInfo), or use YARDSTICK_TECHNIQUE / COST_FLOOR_TECHNIQUE:\n{}",
        found.len(),
        found.join("\n")
    );
    Ok(())
}

/// The scan finds what it looks for: a literal and a pass name outside a test module, not a
/// comment, a test module, an allowed constant or a feature gate.
#[test]
fn the_scan_sees_literals_and_pass_names_but_not_tests_or_comments() {
    let text = "let a = \"pcss\";\n\
                let b = frame.pass(\"pcss/filter\");\n\
                // \"pcss\" in a comment\n\
                #[cfg(feature = \"pcss\")]\n\
                pub const COST_FLOOR_TECHNIQUE: &str = \"hard\";\n\
                let c = \"pcss-like\";\n\
                #[cfg(test)]\n\
                mod tests { const T: &str = \"pcss\"; }\n";
    let found = literals_naming(text, "pcss");
    assert_eq!(
        found.iter().map(|(line, _)| *line).collect::<Vec<_>>(),
        [1, 2]
    );
    assert!(literals_naming(text, "hard").is_empty());
}
