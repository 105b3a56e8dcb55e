//! What a technique promises about its own error: per case (a `stiff-*` case or a paper scene) a
//! bound on an error measure against the exact answer, with the value measured when the bound
//! was set. The technique's crate states them ([`crate::TechniqueInfo::expectations`]): a rule
//! per [`StiffClass`] (the bound every stiff case of that class gets) and named cases (the paper
//! scenes, and the stiff cases whose bound differs from their class's rule). The workspace's
//! tests and `workbench bench --suite stiff` check every registered technique against its own;
//! a stiff case that neither a rule nor a named case covers fails the suite, naming both.
//!
//! Every bound holds under [`EXPECTATION_SETTINGS`]: the technique's default settings at
//! [`EXPECTATION_SIZE`]² pixels, against the exact answer (closed form where every caster is a
//! rectangle parallel to the light, else the CPU ray cast with 16 x 16 light samples). The rule
//! the built-in bounds follow (docs/STABILITY.md, "Every technique against the truth"): 2.5x the measurement (at
//! least measurement + 0.001), lowered to halfway to the nearest wrong answer (all-lit, or `hard`
//! for a soft technique) where that answer is within reach; every wrong answer more than 1.1x the
//! measurement must fail the bound (the benchmark checks it); a technique that is not 1.5x better
//! than drawing no shadow at all, or no better than `hard`, states a known failure instead. A
//! class's rule is the loosest bound the technique states on a case of that class, with its
//! measurement (the case it was measured on is named beside it).

use std::borrow::Cow;

use serde::Serialize;

/// Image edge, in pixels, at which every stated bound holds.
pub const EXPECTATION_SIZE: u32 = 64;

/// One line saying under which settings the bounds hold (for messages and reports).
pub const EXPECTATION_SETTINGS: &str =
    "default settings at 64x64 against the exact answer (closed form, or a 16 x 16 ray cast)";

/// The error measures a bound can be stated in (over receiver pixels, against the exact
/// answer). Not `mae_all`: a mostly lit ground dilutes it until "no shadow at all" passes a bound
/// on a small shadow.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorMetric {
    /// Mean absolute error over the pixels the exact answer shadows (V < 1).
    MaeShadowed,
    /// Largest absolute error over every receiver pixel.
    MaxAbs,
}

impl ErrorMetric {
    /// The name used in results.json and the report.
    pub fn name(self) -> &'static str {
        match self {
            ErrorMetric::MaeShadowed => "mae_shadowed",
            ErrorMetric::MaxAbs => "max_abs",
        }
    }
}

/// What a stiff case stresses (`crates/scenes/src/stiff.rs` gives every case one). A technique
/// states one rule per class, so that a new case of a known class needs no edit in any
/// technique's crate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StiffClass {
    /// Nothing casts a shadow: V = 1 everywhere (stated in `max_abs`).
    Unshadowed,
    /// A light shrunk to (nearly) a point: the answer is the hard shadow.
    PointLight,
    /// An occluder at, or a hair from, the receiver or the light, or casters whose depths span
    /// orders of magnitude: the distances a penumbra estimate divides by go to zero, or the
    /// precision runs out.
    VanishingDistance,
    /// A light far wider than its occluders, very elongated, or at a grazing angle to the
    /// receiver (the sun near the horizon), a sphere whose disk turns from receiver to receiver,
    /// a narrow spot: penumbrae much larger or more stretched than the paper scenes'.
    LightShape,
    /// Occluders at different depths overlapping: the answer is their union (fusion), which
    /// filtered depths get wrong (light leaks).
    OccluderOverlap,
    /// Geometry on both sides of the one-sided light's plane: receivers behind it hold V = 0,
    /// an occluder crossing it lies partly outside every light frustum.
    LightPlane,
    /// Occluders of zero thickness or thinner than a shadow map's bias, alpha-masked occluders
    /// whose holes (down to one texel) or edge-on cards a light-space pass must see, or input
    /// with broken triangles that loading repairs.
    ThinGeometry,
}

impl StiffClass {
    /// Every class.
    pub const ALL: [StiffClass; 7] = [
        StiffClass::Unshadowed,
        StiffClass::PointLight,
        StiffClass::VanishingDistance,
        StiffClass::LightShape,
        StiffClass::OccluderOverlap,
        StiffClass::LightPlane,
        StiffClass::ThinGeometry,
    ];

    /// The name used in messages (`vanishing-distance`).
    pub fn name(self) -> &'static str {
        match self {
            StiffClass::Unshadowed => "unshadowed",
            StiffClass::PointLight => "point-light",
            StiffClass::VanishingDistance => "vanishing-distance",
            StiffClass::LightShape => "light-shape",
            StiffClass::OccluderOverlap => "occluder-overlap",
            StiffClass::LightPlane => "light-plane",
            StiffClass::ThinGeometry => "thin-geometry",
        }
    }
}

/// What a technique states for one case.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Expect {
    /// `metric` at most `bound`; `measured` is the value at [`EXPECTATION_SIZE`] when the bound
    /// was set (bounds are about 2-3x that, so a regression shows).
    AtMost {
        /// The error measure.
        metric: ErrorMetric,
        /// The largest value accepted.
        bound: f64,
        /// The value measured when the bound was set.
        measured: f64,
    },
    /// A failure by design (the technique's docs say why): `metric` is `value` +- `tolerance`,
    /// asserted as such rather than hidden under a loose bound.
    KnownFailure {
        /// The error measure.
        metric: ErrorMetric,
        /// The value measured.
        value: f64,
        /// How far from `value` a run may land.
        tolerance: f64,
    },
}

/// `metric <= bound` (`measured` when it was set).
pub const fn at_most(metric: ErrorMetric, bound: f64, measured: f64) -> Expect {
    Expect::AtMost {
        metric,
        bound,
        measured,
    }
}

/// A known failure: `metric` within `value +- tolerance`.
pub const fn known_failure(metric: ErrorMetric, value: f64, tolerance: f64) -> Expect {
    Expect::KnownFailure {
        metric,
        value,
        tolerance,
    }
}

impl Expect {
    /// The measure the expectation is stated in.
    pub fn metric(&self) -> ErrorMetric {
        match self {
            Expect::AtMost { metric, .. } | Expect::KnownFailure { metric, .. } => *metric,
        }
    }

    /// Whether `value` (of [`Expect::metric`]) meets the expectation. Non-finite values never do.
    pub fn accepts(&self, value: f64) -> bool {
        value.is_finite()
            && match *self {
                Expect::AtMost { bound, .. } => value <= bound,
                Expect::KnownFailure {
                    value: expected,
                    tolerance,
                    ..
                } => (value - expected).abs() <= tolerance,
            }
    }

    /// The largest value accepted.
    pub fn upper(&self) -> f64 {
        match *self {
            Expect::AtMost { bound, .. } => bound,
            Expect::KnownFailure {
                value, tolerance, ..
            } => value + tolerance,
        }
    }

    /// `mae_shadowed <= 0.082 (measured 0.0327)` or `mae_shadowed = 0.25 +- 0.026 (known failure)`.
    pub fn describe(&self) -> String {
        match *self {
            Expect::AtMost {
                metric,
                bound,
                measured,
            } => format!("{} <= {bound} (measured {measured})", metric.name()),
            Expect::KnownFailure {
                metric,
                value,
                tolerance,
            } => format!("{} = {value} +- {tolerance} (known failure)", metric.name()),
        }
    }
}

/// What a technique states for a case, and whether its class's rule said it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stated {
    /// The expectation.
    pub expect: Expect,
    /// The class whose rule gave it; `None`: the case is named in the technique's table.
    pub by_rule: Option<StiffClass>,
}

/// A technique's expectations: named cases (a scene spec as `workbench bench --scene` takes it:
/// `stiff-contact`, `blob-floating:triangles=20000`) and one rule per stiff class, which every
/// stiff case of the class not named gets.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Expectations {
    /// `(case, expectation)` in the order stated.
    pub cases: Vec<(Cow<'static, str>, Expect)>,
    /// `(class, expectation)` in the order stated: bounds ([`Expect::AtMost`]); a known failure
    /// belongs to a named case.
    pub rules: Vec<(StiffClass, Expect)>,
}

impl Expectations {
    /// From a table of named cases written in the technique's crate.
    pub fn new(cases: &[(&'static str, Expect)]) -> Self {
        Self {
            cases: cases
                .iter()
                .map(|(case, expect)| (Cow::Borrowed(*case), *expect))
                .collect(),
            rules: Vec::new(),
        }
    }

    /// With these rules, one per stiff class.
    pub fn with_rules(mut self, rules: &[(StiffClass, Expect)]) -> Self {
        self.rules = rules.to_vec();
        self
    }

    /// The expectation stated for the named case `case`, if any (rules aside).
    pub fn get(&self, case: &str) -> Option<Expect> {
        self.cases
            .iter()
            .find(|(c, _)| c == case)
            .map(|(_, expect)| *expect)
    }

    /// The rule stated for `class`, if any.
    pub fn rule(&self, class: StiffClass) -> Option<Expect> {
        self.rules
            .iter()
            .find(|(c, _)| *c == class)
            .map(|(_, expect)| *expect)
    }

    /// What is stated for `case` of class `class` (`None` for a scene that is no stiff case):
    /// the case by name, else its class's rule.
    pub fn resolve(&self, case: &str, class: Option<StiffClass>) -> Option<Stated> {
        if let Some(expect) = self.get(case) {
            return Some(Stated {
                expect,
                by_rule: None,
            });
        }
        let class = class?;
        self.rule(class).map(|expect| Stated {
            expect,
            by_rule: Some(class),
        })
    }

    /// The named cases, in the order stated.
    pub fn case_names(&self) -> impl Iterator<Item = &str> {
        self.cases.iter().map(|(c, _)| c.as_ref())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_and_known_failures_accept_what_they_say_and_never_nan() {
        let bound = at_most(ErrorMetric::MaeShadowed, 0.1, 0.04);
        assert!(bound.accepts(0.1) && bound.accepts(0.0));
        assert!(!bound.accepts(0.1001) && !bound.accepts(f64::NAN));
        let failure = known_failure(ErrorMetric::MaeShadowed, 0.25, 0.02);
        assert!(failure.accepts(0.231) && failure.accepts(0.269));
        assert!(!failure.accepts(0.2) && !failure.accepts(0.3) && !failure.accepts(f64::INFINITY));
        assert!((failure.upper() - 0.27).abs() < 1e-12);
        let table = Expectations::new(&[("stiff-contact", bound), ("atty-square", failure)]);
        assert_eq!(table.get("atty-square"), Some(failure));
        assert_eq!(table.get("stiff-fusion"), None);
        assert_eq!(
            table.case_names().collect::<Vec<_>>(),
            ["stiff-contact", "atty-square"]
        );
    }

    #[test]
    fn a_named_case_comes_before_its_class_rule_and_a_class_without_one_has_nothing() {
        let named = at_most(ErrorMetric::MaeShadowed, 0.05, 0.02);
        let rule = at_most(ErrorMetric::MaeShadowed, 0.2, 0.08);
        let table = Expectations::new(&[("stiff-contact", named)])
            .with_rules(&[(StiffClass::VanishingDistance, rule)]);
        let class = Some(StiffClass::VanishingDistance);
        let stated = |case| table.resolve(case, class);
        assert_eq!(
            stated("stiff-contact"),
            Some(Stated {
                expect: named,
                by_rule: None
            })
        );
        assert_eq!(
            stated("stiff-near-light"),
            Some(Stated {
                expect: rule,
                by_rule: class
            })
        );
        assert_eq!(
            table.resolve("stiff-fusion", Some(StiffClass::OccluderOverlap)),
            None
        );
        // A scene outside the stiff family gets no rule.
        assert_eq!(table.resolve("atty-square", None), None);
    }
}
