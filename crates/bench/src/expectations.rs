//! Checks runs against what their technique's crate promises
//! ([`softshadow_core::TechniqueInfo::expectations`]): a run at the expectation settings (its
//! technique's defaults at [`EXPECTATION_SIZE`]², measured against the exact answer) of a case the
//! technique states a bound for gets a [`Verdict`] in results.json. A bound that also accepts a
//! deliberately wrong answer (no shadow at all, or the cost floor's hard shadow for a soft
//! technique) is itself reported: it proves nothing.

use serde::{Deserialize, Serialize};
use softshadow_core::{
    expectations::EXPECTATION_SIZE, ErrorMetric, Expect, Registry, COST_FLOOR_TECHNIQUE,
};
use softshadow_metrics::ErrorReport;

use crate::results::{Run, Status};

/// The value of `metric` in `report`.
pub fn metric_value(metric: ErrorMetric, report: &ErrorReport) -> f64 {
    match metric {
        ErrorMetric::MaeShadowed => report.mae_shadowed,
        ErrorMetric::MaxAbs => report.max_abs,
    }
}

/// A deliberately wrong answer run through the same bound.
#[derive(Clone, Debug)]
pub struct Baseline {
    /// What it is ("all-lit (V = 1)", "hard").
    pub name: String,
    /// Its error against the exact answer.
    pub report: ErrorReport,
}

/// A baseline more than this factor above a technique's measured error must fail its bound.
pub const CLEARLY_WORSE: f64 = 1.1;

/// The problems of `report` against `expect` (empty: it holds), each prefixed with `label`: the
/// value outside the bound, or a bound that accepts a baseline clearly worse than the technique
/// (more than [`CLEARLY_WORSE`] times its measured error and above 1e-3).
pub fn check(
    label: &str,
    expect: Expect,
    report: &ErrorReport,
    baselines: &[Baseline],
) -> Vec<String> {
    let mut problems = Vec::new();
    let metric = expect.metric();
    let value = metric_value(metric, report);
    if !expect.accepts(value) {
        let hint = match expect {
            Expect::KnownFailure { .. } => " (fixed? update the expectation in its crate)",
            Expect::AtMost { .. } => "",
        };
        problems.push(format!(
            "{label}: {} = {value:.4} is outside {}{hint}",
            metric.name(),
            expect.describe()
        ));
    }
    if let Expect::AtMost {
        bound, measured, ..
    } = expect
    {
        for baseline in baselines {
            let b = metric_value(metric, &baseline.report);
            if b > CLEARLY_WORSE * measured && b > 1e-3 && b <= bound {
                problems.push(format!(
                    "{label}: the bound {} <= {bound} accepts the {} answer ({b:.4}): tighten it",
                    metric.name(),
                    baseline.name
                ));
            }
        }
    }
    problems
}

/// A run held against its technique's stated expectation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    /// What the technique's crate states for this case, e.g. `mae_shadowed <= 0.082 (measured
    /// 0.0327)`.
    pub stated: String,
    /// The run's value of the stated metric.
    pub value: f64,
    /// Whether the value meets it and the bound rejects the wrong answers.
    pub met: bool,
    /// What is wrong, when not met.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub problems: Vec<String>,
}

/// Whether `run` was made at the settings the expectations are stated for.
fn at_expectation_settings(run: &Run) -> bool {
    run.status == Status::Ok && run.width == EXPECTATION_SIZE && run.height == EXPECTATION_SIZE
}

/// Fills [`Run::expectation`] of every run that is at the expectation settings with its
/// technique's defaults and has an exact answer, where the technique (found in `registry`)
/// states a bound for its scene. The baselines are the all-lit answer and, for every technique
/// but the cost floor, the cost floor's run of the same scene among `runs` (the stiff suite runs
/// it). Returns the labels and problems of the runs that fail.
pub fn judge(registry: &Registry, runs: &mut [Run]) -> Vec<String> {
    let floor_reports: Vec<(String, ErrorReport)> = runs
        .iter()
        .filter(|r| r.technique == COST_FLOOR_TECHNIQUE && at_expectation_settings(r))
        .filter_map(|r| Some((r.scene.clone(), r.error.as_ref()?.vs_exact.clone()?)))
        .collect();
    let mut failures = Vec::new();
    for run in runs.iter_mut() {
        run.expectation = None;
        if !at_expectation_settings(run) {
            continue;
        }
        let Some(info) = registry.get(&run.technique) else {
            continue;
        };
        let defaults = info
            .params
            .iter()
            .all(|spec| run.params.get(spec.name.as_ref()) == Some(&spec.default_value()));
        let Some(expect) = info.expectations.get(&run.scene) else {
            continue;
        };
        let Some(error) = &run.error else { continue };
        let (Some(report), Some(all_lit)) = (&error.vs_exact, &error.all_lit_vs_exact) else {
            continue;
        };
        if !defaults {
            continue;
        }
        let mut baselines = vec![Baseline {
            name: "all-lit (V = 1)".into(),
            report: all_lit.clone(),
        }];
        if run.technique != COST_FLOOR_TECHNIQUE {
            if let Some((_, floor)) = floor_reports.iter().find(|(s, _)| *s == run.scene) {
                baselines.push(Baseline {
                    name: COST_FLOOR_TECHNIQUE.into(),
                    report: floor.clone(),
                });
            }
        }
        let label = format!("{} / {}", run.technique, run.scene);
        let problems = check(&label, expect, report, &baselines);
        failures.extend(problems.iter().cloned());
        run.expectation = Some(Verdict {
            stated: expect.describe(),
            value: metric_value(expect.metric(), report),
            met: problems.is_empty(),
            problems,
        });
    }
    failures
}
