//! Typed, documented, range-checked technique parameters. The GUI draws widgets from
//! [`ParamSpec`]s, the benchmark sweeps them, and neither needs to know the technique.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::error::ParamError;

/// The kind and valid range of a parameter.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ParamKind {
    Float {
        min: f64,
        max: f64,
        default: f64,
        logarithmic: bool,
    },
    Int {
        min: i64,
        max: i64,
        default: i64,
    },
    Bool {
        default: bool,
    },
    Choice {
        options: &'static [&'static str],
        default: &'static str,
    },
}

/// One parameter: name, meaning and range.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParamSpec {
    pub name: &'static str,
    pub description: &'static str,
    #[serde(flatten)]
    pub kind: ParamKind,
}

/// A parameter value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ParamValue {
    Bool(bool),
    Int(i64),
    Float(f64),
    Choice(String),
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamValue::Bool(b) => write!(f, "{b}"),
            ParamValue::Int(i) => write!(f, "{i}"),
            ParamValue::Float(x) => write!(f, "{x}"),
            ParamValue::Choice(s) => write!(f, "{s}"),
        }
    }
}

impl ParamValue {
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            ParamValue::Float(x) => Some(*x),
            ParamValue::Int(i) => Some(*i as f64),
            _ => None,
        }
    }
}

impl ParamSpec {
    pub const fn float(
        name: &'static str,
        description: &'static str,
        min: f64,
        max: f64,
        default: f64,
    ) -> Self {
        Self {
            name,
            description,
            kind: ParamKind::Float {
                min,
                max,
                default,
                logarithmic: false,
            },
        }
    }

    pub const fn int(
        name: &'static str,
        description: &'static str,
        min: i64,
        max: i64,
        default: i64,
    ) -> Self {
        Self {
            name,
            description,
            kind: ParamKind::Int { min, max, default },
        }
    }

    pub const fn boolean(name: &'static str, description: &'static str, default: bool) -> Self {
        Self {
            name,
            description,
            kind: ParamKind::Bool { default },
        }
    }

    pub const fn choice(
        name: &'static str,
        description: &'static str,
        options: &'static [&'static str],
        default: &'static str,
    ) -> Self {
        Self {
            name,
            description,
            kind: ParamKind::Choice { options, default },
        }
    }

    pub fn default_value(&self) -> ParamValue {
        match &self.kind {
            ParamKind::Float { default, .. } => ParamValue::Float(*default),
            ParamKind::Int { default, .. } => ParamValue::Int(*default),
            ParamKind::Bool { default } => ParamValue::Bool(*default),
            ParamKind::Choice { default, .. } => ParamValue::Choice(default.to_string()),
        }
    }

    /// Range as text, for messages and `workbench list`.
    pub fn range_text(&self) -> String {
        match &self.kind {
            ParamKind::Float { min, max, .. } => format!("{min} to {max}"),
            ParamKind::Int { min, max, .. } => format!("{min} to {max}"),
            ParamKind::Bool { .. } => "true or false".into(),
            ParamKind::Choice { options, .. } => options.join(" | "),
        }
    }

    /// Checks type, finiteness and range; converts an int given for a float.
    pub fn check(&self, value: ParamValue) -> Result<ParamValue, ParamError> {
        let name = self.name.to_string();
        let wrong = |expected: &str, value: &ParamValue| ParamError::WrongType {
            name: name.clone(),
            expected: expected.into(),
            value: value.to_string(),
        };
        match (&self.kind, value) {
            (
                ParamKind::Float { min, max, .. },
                v @ (ParamValue::Float(_) | ParamValue::Int(_)),
            ) => {
                let x = v.as_f64().unwrap_or(f64::NAN);
                if !x.is_finite() {
                    return Err(ParamError::NotFinite {
                        name,
                        value: x.to_string(),
                        min: min.to_string(),
                        max: max.to_string(),
                    });
                }
                if x < *min || x > *max {
                    return Err(ParamError::OutOfRange {
                        name,
                        value: x.to_string(),
                        min: min.to_string(),
                        max: max.to_string(),
                    });
                }
                Ok(ParamValue::Float(x))
            }
            (ParamKind::Int { min, max, .. }, ParamValue::Int(i)) => {
                if i < *min || i > *max {
                    return Err(ParamError::OutOfRange {
                        name,
                        value: i.to_string(),
                        min: min.to_string(),
                        max: max.to_string(),
                    });
                }
                Ok(ParamValue::Int(i))
            }
            (ParamKind::Int { .. }, v) => Err(wrong("an integer", &v)),
            (ParamKind::Bool { .. }, ParamValue::Bool(b)) => Ok(ParamValue::Bool(b)),
            (ParamKind::Bool { .. }, v) => Err(wrong("true or false", &v)),
            (ParamKind::Choice { options, .. }, ParamValue::Choice(s)) => {
                if options.contains(&s.as_str()) {
                    Ok(ParamValue::Choice(s))
                } else {
                    Err(ParamError::UnknownChoice {
                        name,
                        value: s,
                        options: options.join(" | "),
                    })
                }
            }
            (ParamKind::Choice { options, .. }, v) => {
                Err(wrong(&format!("one of {}", options.join(" | ")), &v))
            }
            (ParamKind::Float { .. }, v) => Err(wrong("a number", &v)),
        }
    }

    /// Parses command-line text (`--param name=value`) for this parameter and checks it.
    pub fn parse(&self, text: &str) -> Result<ParamValue, ParamError> {
        let text = text.trim();
        let value = match &self.kind {
            ParamKind::Float { .. } => match text.parse::<f64>() {
                Ok(x) => ParamValue::Float(x),
                Err(_) => ParamValue::Choice(text.into()),
            },
            ParamKind::Int { .. } => match text.parse::<i64>() {
                Ok(i) => ParamValue::Int(i),
                Err(_) => ParamValue::Choice(text.into()),
            },
            ParamKind::Bool { .. } => match text {
                "true" | "1" | "on" | "yes" => ParamValue::Bool(true),
                "false" | "0" | "off" | "no" => ParamValue::Bool(false),
                _ => ParamValue::Choice(text.into()),
            },
            ParamKind::Choice { .. } => ParamValue::Choice(text.into()),
        };
        self.check(value)
    }
}

/// The current values of a technique's parameters, in declaration order.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParamSet {
    pub entries: Vec<(ParamSpec, ParamValue)>,
}

impl ParamSet {
    pub fn get(&self, name: &str) -> Option<&ParamValue> {
        self.entries
            .iter()
            .find(|(s, _)| s.name == name)
            .map(|(_, v)| v)
    }

    /// `name -> value`, sorted by name (for results.json).
    pub fn to_map(&self) -> std::collections::BTreeMap<String, ParamValue> {
        self.entries
            .iter()
            .map(|(s, v)| (s.name.to_string(), v.clone()))
            .collect()
    }
}

/// Finds `name` in `specs` or says which names exist.
pub fn find_spec<'a>(
    technique: &str,
    specs: &'a [ParamSpec],
    name: &str,
) -> Result<&'a ParamSpec, ParamError> {
    specs
        .iter()
        .find(|s| s.name == name)
        .ok_or_else(|| ParamError::Unknown {
            technique: technique.into(),
            name: name.into(),
            known: specs.iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
        })
}

/// Typed access for `Settings` structs.
pub fn expect_f32(value: &ParamValue) -> f32 {
    value.as_f64().unwrap_or(0.0) as f32
}
pub fn expect_u32(value: &ParamValue) -> u32 {
    match value {
        ParamValue::Int(i) => (*i).max(0) as u32,
        other => other.as_f64().unwrap_or(0.0).max(0.0) as u32,
    }
}
pub fn expect_bool(value: &ParamValue) -> bool {
    matches!(value, ParamValue::Bool(true))
}
pub fn expect_choice(value: &ParamValue) -> &str {
    match value {
        ParamValue::Choice(s) => s,
        _ => "",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_types_and_non_finite_values_are_rejected_with_the_range() {
        let spec = ParamSpec::float("bias", "depth bias", 0.0, 8.0, 1.0);
        assert_eq!(spec.parse("2.5"), Ok(ParamValue::Float(2.5)));
        assert_eq!(spec.parse("3"), Ok(ParamValue::Float(3.0)));
        let err = spec.parse("9").unwrap_err().to_string();
        assert!(
            err.contains("out of range") && err.contains("0 to 8"),
            "{err}"
        );
        let err = spec.parse("NaN").unwrap_err().to_string();
        assert!(err.contains("not finite"), "{err}");
        assert!(spec.parse("inf").is_err());
        assert!(spec
            .parse("abc")
            .unwrap_err()
            .to_string()
            .contains("expects a number"));
        let int = ParamSpec::int("samples", "", 1, 64, 32);
        assert!(int.parse("1.5").is_err());
        assert!(int.parse("65").is_err());
        let choice = ParamSpec::choice("kernel", "", &["vogel", "poisson"], "vogel");
        assert!(choice
            .parse("box")
            .unwrap_err()
            .to_string()
            .contains("vogel | poisson"));
        let flag = ParamSpec::boolean("jitter", "", true);
        assert_eq!(flag.parse("off"), Ok(ParamValue::Bool(false)));
    }
}
