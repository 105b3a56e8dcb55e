//! Random parameter stress (docs/STABILITY.md): every registered technique with random values
//! inside its declared parameter ranges, random (also degenerate) lights, 32² to 48². Every case
//! must render with finite visibility in [0, 1] or fail with a clear one-line error; a wgpu
//! validation error, a panic or an invalid value fails the test and names the case.
//! `workbench bench --stress SECONDS` runs the same cases, with whole ranges, for longer.

use anyhow::{ensure, Result};
use softshadow_bench::stress::{Outcome, Ranges, Stress};

use crate::common::gpu;

/// Seed and number of cases of the CI run: five per technique.
const SEED: u64 = 2026;
const CASES_PER_TECHNIQUE: u64 = 5;

#[test]
fn random_parameters_and_lights_give_valid_visibility_or_a_clear_error() -> Result<()> {
    let techniques = softshadow::registry();
    let mut stress = Stress::new(gpu()?, techniques.clone(), SEED, Ranges::Quick)?;
    for _ in 0..CASES_PER_TECHNIQUE * techniques.len() as u64 {
        let (case, result) = stress.step();
        match &result {
            Ok(Outcome::Ok) => eprintln!("{case}: ok"),
            Ok(Outcome::ClearError(message)) => eprintln!("{case}: clear error: {message}"),
            Err(finding) => eprintln!("FINDING {finding}"),
        }
    }
    let counts = &stress.counts;
    let findings: Vec<String> = counts.findings.iter().map(ToString::to_string).collect();
    ensure!(
        findings.is_empty(),
        "{} of {} cases broke a rule:\n{}",
        findings.len(),
        counts.cases,
        findings.join("\n")
    );
    // A technique that refused every case would pass the rule above without being tested.
    for info in &techniques {
        let (cases, ok) = counts
            .per_technique
            .get(info.id.as_ref())
            .copied()
            .unwrap_or((0, 0));
        ensure!(
            ok > 0,
            "{}: none of its {cases} cases rendered (errors: {:?})",
            info.id,
            counts.error_messages
        );
    }
    ensure!(
        counts.per_light.len() == 7,
        "every kind of light is drawn: {:?}",
        counts.per_light
    );
    Ok(())
}
