//! Every generated table in docs/ is what its committed results give (docs/results/*.json):
//! a figure typed by hand, or results changed without rewriting the tables, fails here.
//! `workbench docs` rewrites the tables; `workbench docs --rerun` makes the results again.

use std::path::Path;

use anyhow::{ensure, Result};
use softshadow_bench::doc_tables;

#[test]
fn every_generated_table_matches_its_committed_results() -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut drifted = Vec::new();
    let mut tables = 0;
    for entry in std::fs::read_dir(root.join("docs"))? {
        let file = entry?.path();
        if file.extension().is_some_and(|e| e == "md") {
            let text = std::fs::read_to_string(&file)?;
            tables += doc_tables::marked_tables(&text, &file)?.len();
            drifted.extend(doc_tables::drift(&file, root)?);
        }
    }
    ensure!(tables > 0, "no generated table found in docs/");
    ensure!(
        drifted.is_empty(),
        "{} tables differ from their committed results: run `cargo run --release -p workbench -- docs` and commit:\n{}",
        drifted.len(),
        drifted.join("\n")
    );
    Ok(())
}

/// docs/ are documents of the present, read in one sitting (issue 37): the two that grow with
/// every technique and sweep stay under this many lines; history goes to git or CHANGELOG.md,
/// a topic of its own to a document of its own (docs/EXACT.md came out of both).
const MAX_DOCUMENT_LINES: usize = 700;

#[test]
fn the_technique_and_benchmark_documents_stay_short() -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for name in ["docs/BENCHMARKS.md", "docs/TECHNIQUES.md"] {
        let lines = std::fs::read_to_string(root.join(name))?.lines().count();
        ensure!(
            lines < MAX_DOCUMENT_LINES,
            "{name} has {lines} lines, {MAX_DOCUMENT_LINES} at most: move a topic that stands on \
             its own to a document of its own (as docs/EXACT.md), history to CHANGELOG.md"
        );
    }
    Ok(())
}
