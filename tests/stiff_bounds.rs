//! A technique's bounds on the stiff cases come from a rule per class plus the cases it names
//! (`softshadow_core::expectations`): every built-in promises a bound for every stiff case, a
//! case of a class a technique has no rule for fails naming the case, and every case resolves to
//! the bound stated before the rules came (tests/data/stated_bounds.json).

use std::path::Path;

use anyhow::{ensure, Context, Result};
use softshadow_bench::expectations::{stated_by_case, unpromised, Unpromised};
use softshadow_core::{Expect, Registry, StiffClass, TechniqueInfo};
use softshadow_scenes::{stiff, BuiltinInfo};

/// Every technique's stated bound per case, taken from the per-case tables before the rules
/// came; rewritten from the present tables with `SOFTSHADOW_UPDATE_STATED_BOUNDS=1` after a bound
/// is changed on purpose.
const STATED_BOUNDS: &str = "tests/data/stated_bounds.json";

#[test]
fn every_builtin_promises_a_bound_for_every_stiff_case() -> Result<()> {
    let registry = softshadow::registry();
    let missing = unpromised(&registry, &stiff::cases());
    let lines: Vec<String> = missing.iter().map(ToString::to_string).collect();
    ensure!(lines.is_empty(), "{}", lines.join("\n"));
    for info in &registry {
        for (class, expect) in &info.expectations.rules {
            ensure!(
                matches!(expect, Expect::AtMost { .. }),
                "{}: the rule for {} cases is a known failure: name its case instead",
                info.id,
                class.name()
            );
        }
    }
    Ok(())
}

#[test]
fn a_stiff_case_of_a_class_a_technique_has_no_rule_for_fails_naming_the_case() -> Result<()> {
    let builtins = softshadow::registry();
    let mut floor = builtins.cost_floor().context("the cost floor")?.clone();
    let class = StiffClass::LightPlane;
    let removed = floor
        .expectations
        .rule(class)
        .context("a light-plane rule")?;
    floor.expectations.rules.retain(|(c, _)| *c != class);
    let registry = Registry::new([floor.clone()])?;
    let mut cases = stiff::cases();
    cases.push(stiff::StiffCase {
        class,
        info: BuiltinInfo {
            id: "stiff-new-case",
            description: "a case added after the bounds were stated",
            params: Vec::new(),
        },
    });
    let missing = unpromised(&registry, &cases);
    // The new case, and every case of the class the technique does not name (among them the one
    // the removed rule was measured on).
    let expected: Vec<Unpromised> = cases
        .iter()
        .filter(|case| case.class == class && floor.expectations.get(case.info.id).is_none())
        .map(|case| Unpromised {
            technique: floor.id.to_string(),
            case: case.info.id.into(),
            class,
        })
        .collect();
    ensure!(expected.len() >= 2, "{expected:?}");
    ensure!(missing == expected, "{missing:?} != {expected:?}");
    let message = missing.last().context("the new case")?.to_string();
    for part in [
        "stiff-new-case",
        "light-plane",
        &*floor.id,
        &format!("crates/{}/src/info.rs", floor.id),
    ] {
        ensure!(message.contains(part), "`{part}` not in: {message}");
    }
    // With the rule back, every case of the class is bound by it or named.
    floor.expectations.rules.push((class, removed));
    ensure!(unpromised(&Registry::new([floor])?, &cases).is_empty());
    Ok(())
}

/// `technique -> case -> expectation` as JSON, for every case `info` states a bound for.
fn stated_table(info: &TechniqueInfo) -> Result<serde_json::Value> {
    let mut table = serde_json::Map::new();
    for (case, stated) in stated_by_case(info, &stiff::cases()) {
        table.insert(case, serde_json::to_value(stated.expect)?);
    }
    Ok(serde_json::Value::Object(table))
}

/// One line per case whose expectation differs between two tables of [`stated_table`].
fn case_differences(
    technique: &str,
    now: &serde_json::Value,
    before: &serde_json::Value,
) -> Vec<String> {
    let (Some(now), Some(before)) = (now.as_object(), before.as_object()) else {
        return vec![format!("{technique}: not a table of cases")];
    };
    let mut cases: Vec<&String> = now.keys().chain(before.keys()).collect();
    cases.sort();
    cases.dedup();
    cases
        .into_iter()
        .filter(|case| now.get(*case) != before.get(*case))
        .map(|case| {
            let show =
                |v: Option<&serde_json::Value>| v.map_or("nothing".into(), |v| v.to_string());
            format!(
                "{technique} / {case}: now {}, before {}",
                show(now.get(case)),
                show(before.get(case))
            )
        })
        .collect()
}

#[test]
fn every_case_resolves_to_the_bound_it_had_before_the_rules() -> Result<()> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(STATED_BOUNDS);
    let text = std::fs::read_to_string(&path).with_context(|| format!("{}", path.display()))?;
    let mut snapshot: serde_json::Map<String, serde_json::Value> = serde_json::from_str(&text)?;
    let update = std::env::var_os("SOFTSHADOW_UPDATE_STATED_BOUNDS").is_some();
    let mut differences = Vec::new();
    for info in &softshadow::registry() {
        let now = stated_table(info)?;
        if update {
            snapshot.insert(info.id.to_string(), now);
            continue;
        }
        let before = snapshot
            .get(info.id.as_ref())
            .with_context(|| format!("{} is not in {STATED_BOUNDS}", info.id))?;
        differences.extend(case_differences(&info.id, &now, before));
    }
    if update {
        let json = serde_json::to_string_pretty(&snapshot)?;
        std::fs::write(&path, json + "\n")?;
    }
    ensure!(
        differences.is_empty(),
        "stated bounds differ from {STATED_BOUNDS} (changed on purpose? rerun with \
         SOFTSHADOW_UPDATE_STATED_BOUNDS=1):\n{}",
        differences.join("\n")
    );
    Ok(())
}
