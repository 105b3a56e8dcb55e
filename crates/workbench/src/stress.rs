//! `bench --stress SECONDS`: the random parameter stress of `softshadow_bench::stress` for as
//! long as asked; the counts go to stdout and `stress.json`.

use std::{path::Path, process::ExitCode, time::Instant};

use anyhow::{Context, Result};
use softshadow_bench::stress::{self, Outcome, Ranges, Stress};
use softshadow_core::{Gpu, Registry};

pub fn run(registry: &Registry, seconds: u64, seed: u64, out: &Path) -> Result<ExitCode> {
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create the output folder `{}`", out.display()))?;
    // PDSM's disk cache would collect one entry per random setting: keep it in `out`.
    if std::env::var_os("SOFTSHADOW_CACHE_DIR").is_none() {
        std::env::set_var("SOFTSHADOW_CACHE_DIR", out.join("pdsm-cache"));
    }
    let gpu = Gpu::new_headless().context("cannot start the GPU")?;
    let mut stress = Stress::new(gpu, registry.clone(), seed, Ranges::Full)?;
    let start = Instant::now();
    let mut last_report = Instant::now();
    while start.elapsed().as_secs() < seconds {
        let case_start = Instant::now();
        let (case, result) = stress.step();
        // One line per case (estimate beside the time taken), so a run's log shows where the
        // time went and how far off the cost model is.
        eprintln!(
            "{case}: {} after {:.1} s (estimated {:.1} s)",
            match &result {
                Ok(Outcome::Ok) => "ok".to_string(),
                Ok(Outcome::ClearError(message)) => format!("clear error: {message}"),
                Err(finding) => format!("FINDING: {}", finding.problem),
            },
            case_start.elapsed().as_secs_f64(),
            case.cost.seconds
        );
        if last_report.elapsed().as_secs() >= 60 {
            last_report = Instant::now();
            let c = &stress.counts;
            eprintln!(
                "{} s: {} cases, {} ok, {} clear errors, {} findings",
                start.elapsed().as_secs(),
                c.cases,
                c.ok,
                c.clear_errors,
                c.findings.len()
            );
        }
        let path = out.join("stress.json");
        let json = serde_json::to_vec_pretty(&summary(&stress, seed, start.elapsed().as_secs()))?;
        softshadow_bench::output::write_atomic(&path, &json)?;
    }
    let c = &stress.counts;
    println!(
        "seed {seed}, {} s: {} cases ({} frames): {} ok, {} clear errors, {} findings",
        start.elapsed().as_secs(),
        c.cases,
        c.frames,
        c.ok,
        c.clear_errors,
        c.findings.len()
    );
    for (technique, (cases, ok)) in &c.per_technique {
        println!("  {technique:<16} {cases} cases, {ok} ok");
    }
    for (message, count) in &c.error_messages {
        println!("  clear error x{count}: {message}");
    }
    println!(
        "  cost cap ({} s, {} MiB a case): {} cases redrawn, {} clamped",
        stress::BUDGET_SECONDS,
        stress::BUDGET_BYTES / (1u64 << 20) as f64,
        c.redrawn,
        c.clamped
    );
    if let Some((seconds, estimate, case)) = &c.slowest {
        println!("  slowest: {seconds:.1} s (estimated {estimate:.1} s): {case}");
    }
    for finding in &c.findings {
        println!("  finding: {finding}");
    }
    println!("wrote {}", out.join("stress.json").display());
    Ok(if c.findings.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(3)
    })
}

fn summary(stress: &Stress, seed: u64, seconds: u64) -> serde_json::Value {
    let c = &stress.counts;
    serde_json::json!({
        "seed": seed,
        "seconds": seconds,
        "cases": c.cases,
        "frames": c.frames,
        "ok": c.ok,
        "clear_errors": c.clear_errors,
        "per_technique": c.per_technique.iter().map(|(t, (cases, ok))| {
            (t.clone(), serde_json::json!({"cases": cases, "ok": ok}))
        }).collect::<serde_json::Map<_, _>>(),
        "per_light": c.per_light,
        "error_messages": c.error_messages,
        "findings": c.findings.iter().map(ToString::to_string).collect::<Vec<_>>(),
        "cost_cap": {
            "budget_seconds": stress::BUDGET_SECONDS,
            "budget_bytes": stress::BUDGET_BYTES,
            "redrawn": c.redrawn,
            "clamped": c.clamped,
            "why": c.cap_reasons,
        },
        "slowest_case": c.slowest.as_ref().map(|(seconds, estimate, case)| {
            serde_json::json!({"seconds": seconds, "estimated_seconds": estimate, "case": case})
        }),
        "most_underestimated_case": c.most_underestimated.as_ref().map(|(seconds, estimate, case)| {
            serde_json::json!({"seconds": seconds, "estimated_seconds": estimate, "case": case})
        }),
    })
}
