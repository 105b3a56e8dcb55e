//! Checks runs against what their technique's crate promises
//! ([`softshadow_core::TechniqueInfo::expectations`]): a run at the expectation settings (its
//! technique's defaults at [`EXPECTATION_SIZE`]², measured against the exact answer) of a case the
//! technique states a bound for gets a [`Verdict`] in results.json. A bound that also accepts a
//! deliberately wrong answer (no shadow at all, or the cost floor's hard shadow for a soft
//! technique) is itself reported: it proves nothing. A stiff case the technique neither names
//! nor has a rule for its class for ([`unpromised`]) fails the stiff suite.

use serde::{Deserialize, Serialize};
use softshadow_core::{
    expectations::{Stated, EXPECTATION_SIZE},
    ErrorMetric, Expect, Registry, StiffClass, TechniqueInfo, COST_FLOOR_TECHNIQUE,
};
use softshadow_metrics::ErrorReport;
use softshadow_scenes::stiff::StiffCase;

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

/// The problems of `report` against `stated` (empty: it holds), each prefixed with `label`: the
/// value outside the bound, or a bound that accepts a baseline clearly worse than the technique
/// (more than [`CLEARLY_WORSE`] times its measured error and above 1e-3). A class's rule was
/// measured on another case, so under a rule the run's own value stands for the measurement
/// where it is the smaller.
pub fn check(
    label: &str,
    stated: Stated,
    report: &ErrorReport,
    baselines: &[Baseline],
) -> Vec<String> {
    let mut problems = Vec::new();
    let expect = stated.expect;
    let metric = expect.metric();
    let value = metric_value(metric, report);
    let by_rule = stated
        .by_rule
        .map(|class| format!(" (the rule for {} cases)", class.name()))
        .unwrap_or_default();
    if !expect.accepts(value) {
        let hint = match expect {
            Expect::KnownFailure { .. } => " (fixed? update the expectation in its crate)",
            Expect::AtMost { .. } => "",
        };
        problems.push(format!(
            "{label}: {} = {value:.4} is outside {}{by_rule}{hint}",
            metric.name(),
            expect.describe()
        ));
    }
    if let Expect::AtMost {
        bound, measured, ..
    } = expect
    {
        let (measured, fix) = match stated.by_rule {
            Some(_) => (measured.min(value), "name the case with a bound of its own"),
            None => (measured, "tighten it"),
        };
        for baseline in baselines {
            let b = metric_value(metric, &baseline.report);
            if b > CLEARLY_WORSE * measured && b > 1e-3 && b <= bound {
                problems.push(format!(
                    "{label}: the bound {} <= {bound}{by_rule} accepts the {} answer ({b:.4}): {fix}",
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
    let stiff_cases = softshadow_scenes::stiff::cases();
    let class_of = |scene: &str| {
        stiff_cases
            .iter()
            .find(|case| case.info.id == scene)
            .map(|case| case.class)
    };
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
        let Some(stated) = info.expectations.resolve(&run.scene, class_of(&run.scene)) else {
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
        let problems = check(&label, stated, report, &baselines);
        failures.extend(problems.iter().cloned());
        run.expectation = Some(Verdict {
            stated: stated.expect.describe(),
            value: metric_value(stated.expect.metric(), report),
            met: problems.is_empty(),
            problems,
        });
    }
    failures
}

/// A stiff case a technique promises nothing for: it neither names the case nor states a rule
/// for its class.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unpromised {
    /// The technique's id.
    pub technique: String,
    /// The case's id.
    pub case: String,
    /// The case's class.
    pub class: StiffClass,
}

impl std::fmt::Display for Unpromised {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Self {
            technique,
            case,
            class,
        } = self;
        let class = class.name();
        write!(
            f,
            "{technique} promises nothing for {case} (class {class}): add a rule for {class} \
             cases, or name {case}, in its `expectations()` (crates/{technique}/src/info.rs for a \
             built-in)"
        )
    }
}

/// Every pair of a technique in `registry` and a case among `cases` (the stiff family:
/// [`softshadow_scenes::stiff::cases`]) that the technique promises nothing for, leaving out the
/// cases whose light kind it does not support (the suite records those runs as unsupported).
pub fn unpromised(registry: &Registry, cases: &[StiffCase]) -> Vec<Unpromised> {
    let mut missing = Vec::new();
    let kinds: Vec<_> = cases.iter().map(StiffCase::light_kind).collect();
    for info in registry {
        for (case, kind) in cases.iter().zip(&kinds) {
            let id = case.info.id;
            if !info.light_kinds.supports(*kind) {
                continue;
            }
            if info.expectations.resolve(id, Some(case.class)).is_none() {
                missing.push(Unpromised {
                    technique: info.id.to_string(),
                    case: id.to_string(),
                    class: case.class,
                });
            }
        }
    }
    missing
}

/// What `info` states for every case among `cases` (the stiff family) it promises something for
/// (leaving out the cases whose light kind it does not support), then for the other cases it
/// names (the paper scenes): the table its verdicts follow.
pub fn stated_by_case(info: &TechniqueInfo, cases: &[StiffCase]) -> Vec<(String, Stated)> {
    let supported = cases
        .iter()
        .filter(|case| info.light_kinds.supports(case.light_kind()));
    let stiff = supported.filter_map(|case| {
        let stated = info.expectations.resolve(case.info.id, Some(case.class))?;
        Some((case.info.id.to_string(), stated))
    });
    let named = info
        .expectations
        .case_names()
        .filter(|name| !cases.iter().any(|case| case.info.id == *name))
        .filter_map(|name| Some((name.to_string(), info.expectations.resolve(name, None)?)));
    stiff.chain(named).collect()
}

#[cfg(test)]
mod tests {
    use softshadow_core::expectations::at_most;

    use super::*;

    fn report(mae_shadowed: f64) -> ErrorReport {
        let json = format!(
            r#"{{"mae_shadowed":{mae_shadowed},"mae_all":0,"rmse":0,"max_abs":0,"p99_abs":0,"shadowed_pixels":1,"receiver_pixels":1,"flip_mean":null}}"#
        );
        serde_json::from_str(&json).unwrap()
    }

    /// A rule measured on a harder case than this one: the wrong answer lies within its bound but
    /// far above this run's error, so the rule proves nothing here, while the same bound stated
    /// for this case with that measurement passes as before.
    #[test]
    fn under_a_rule_the_wrong_answers_are_held_against_the_runs_own_error() {
        let expect = at_most(ErrorMetric::MaeShadowed, 0.2, 0.1);
        let all_lit = [Baseline {
            name: "all-lit (V = 1)".into(),
            report: report(0.05),
        }];
        let named = Stated {
            expect,
            by_rule: None,
        };
        assert!(check("t / case", named, &report(0.02), &all_lit).is_empty());
        let by_rule = Stated {
            by_rule: Some(StiffClass::LightPlane),
            ..named
        };
        let problems = check("t / case", by_rule, &report(0.02), &all_lit);
        assert_eq!(problems.len(), 1, "{problems:?}");
        assert!(
            problems[0].contains("the rule for light-plane cases")
                && problems[0].contains("accepts the all-lit (V = 1) answer")
                && problems[0].contains("name the case"),
            "{problems:?}"
        );
        // A run as bad as the rule's measurement is held as the named case is.
        assert!(check("t / case", by_rule, &report(0.1), &all_lit).is_empty());
    }
}
