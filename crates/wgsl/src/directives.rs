//! The `// @...` lines of a technique file: its parameters and its shadow-map fit
//! (docs/WGSL.md, "Directives").
//!
//! ```text
//! // @contract 3                                              (required: the contract's version)
//! // @param NAME: TYPE = DEFAULT in MIN..=MAX, DESCRIPTION     (TYPE f32, u32 or i32)
//! // @param NAME: bool = DEFAULT, DESCRIPTION
//! // @fit receivers | casters
//! ```

use std::borrow::Cow;

use softshadow_core::{ParamKind, ParamSpec};

use crate::WgslError;

/// The name of the parameter every file technique has (the centre shadow map's edge in texels).
pub const SHADOW_MAP_SIZE: &str = "shadow_map_size";

/// How the centre shadow map's window is fitted (`softshadow_core::shadow_map`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fit {
    /// Every caster (the default): for a search around the receiver's slope (PCSS-like).
    Casters,
    /// Clipped to the receivers' slopes, as `hard` fits its map: for lookups at the receiver's
    /// own slope and a few texels around it (PCF).
    Receivers,
}

/// The scalar type of a parameter, as it is declared and as it is laid out in `Params`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScalarType {
    /// `f32`.
    F32,
    /// `u32`.
    U32,
    /// `i32`.
    I32,
    /// `bool`, a `u32` in the uniform block (WGSL uniforms hold no `bool`): 1 on, 0 off.
    Bool,
}

impl ScalarType {
    /// The WGSL type of the field in `Params`.
    pub fn wgsl_field_type(self) -> &'static str {
        match self {
            ScalarType::F32 => "f32",
            ScalarType::U32 | ScalarType::Bool => "u32",
            ScalarType::I32 => "i32",
        }
    }
}

/// One `// @param` line.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamDirective {
    /// Its type.
    pub ty: ScalarType,
    /// Its spec (name, description, range, default).
    pub spec: ParamSpec,
    /// Its line in the file (1-based).
    pub line: usize,
}

/// Everything the directives of one file declare.
#[derive(Clone, Debug, PartialEq)]
pub struct Directives {
    /// The parameters in declaration order (the order of the fields of `Params`).
    pub params: Vec<ParamDirective>,
    /// The shadow map's fit.
    pub fit: Fit,
}

/// Reads the directives of `source` (the file `path`, for messages).
pub fn parse(path: &str, source: &str) -> Result<Directives, WgslError> {
    let mut params: Vec<ParamDirective> = Vec::new();
    let mut fit: Option<(Fit, usize)> = None;
    let mut contract = false;
    for (index, text) in source.lines().enumerate() {
        let line = index + 1;
        let Some(comment) = text.trim_start().strip_prefix("//") else {
            continue;
        };
        let comment = comment.trim();
        let error = |column: usize, message: String| WgslError::Directive {
            path: path.to_string(),
            line,
            column,
            message,
        };
        let column = text.find('@').map_or(1, |i| i + 1);
        if let Some(rest) = comment.strip_prefix("@param") {
            let directive = parse_param(rest, line).map_err(|m| error(column, m))?;
            if directive.spec.name == SHADOW_MAP_SIZE {
                return Err(error(
                    column,
                    format!("`{SHADOW_MAP_SIZE}` is every file technique's own parameter: give yours another name"),
                ));
            }
            if let Some(first) = params.iter().find(|p| p.spec.name == directive.spec.name) {
                return Err(error(
                    column,
                    format!(
                        "parameter `{}` is declared twice (first on line {}): give it one line",
                        directive.spec.name, first.line
                    ),
                ));
            }
            params.push(directive);
        } else if let Some(rest) = comment.strip_prefix("@fit") {
            let value = match rest.trim() {
                "casters" => Fit::Casters,
                "receivers" => Fit::Receivers,
                other => {
                    return Err(error(
                        column,
                        format!("`@fit {other}`: write `// @fit casters` or `// @fit receivers`"),
                    ))
                }
            };
            if let Some((_, first)) = fit {
                return Err(error(
                    column,
                    format!("`@fit` is given twice (first on line {first}): keep one"),
                ));
            }
            fit = Some((value, line));
        } else if let Some(rest) = comment.strip_prefix("@contract") {
            if rest.trim() != crate::CONTRACT_VERSION.to_string() {
                return Err(error(column, version_change(rest.trim())));
            }
            contract = true;
        } else if comment.starts_with('@') {
            let word = comment.split_whitespace().next().unwrap_or(comment);
            return Err(error(
                column,
                format!("unknown directive `{word}`: the directives are `// @contract`, `// @param` and `// @fit` (docs/WGSL.md)"),
            ));
        }
    }
    if !contract {
        return Err(WgslError::Directive {
            path: path.to_string(),
            line: 1,
            column: 1,
            message: version_change("1 (no `// @contract` line)"),
        });
    }
    Ok(Directives {
        params,
        fit: fit.map_or(Fit::Casters, |(f, _)| f),
    })
}

/// What a file written for contract version `written_for` must change (docs/WGSL.md).
fn version_change(written_for: &str) -> String {
    format!(
        "written for contract version {written_for}; this is version {}: `frame` carries the light's kind and shape (since 2: `light_kind()`, `light_reaches(s)`, `light_sample(u, world)`), so a file that reads `frame.light_half` as a rectangle must check `light_kind()`; under the sun `view` and `shadow_map` are an orthographic map (since 3), which `map_point(s)`, `map_depth(uv)` and `map_bias(s, texels)` read as they read the perspective one: use them (or check for `LIGHT_SUN`), then add the line `// @contract {}` (docs/WGSL.md)",
        crate::CONTRACT_VERSION,
        crate::CONTRACT_VERSION
    )
}

const GRAMMAR: &str = "write `// @param NAME: TYPE = DEFAULT in MIN..=MAX, DESCRIPTION` (TYPE f32, u32 or i32) or `// @param NAME: bool = DEFAULT, DESCRIPTION`";

/// `NAME: TYPE = DEFAULT [in MIN..=MAX][, DESCRIPTION]` (what follows `@param`).
// Long: a parser of one line of the grammar, each error message beside the part it checks.
fn parse_param(text: &str, line: usize) -> Result<ParamDirective, String> {
    let (name, rest) = text
        .split_once(':')
        .ok_or_else(|| format!("no `:` after the name: {GRAMMAR}"))?;
    let name = name.trim();
    let valid_name = name
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !valid_name {
        return Err(format!(
            "`{name}` is not a parameter name: use letters, digits and `_`, starting with a letter"
        ));
    }
    let (ty, rest) = rest
        .split_once('=')
        .ok_or_else(|| format!("no `= DEFAULT` for `{name}`: {GRAMMAR}"))?;
    let ty = match ty.trim() {
        "f32" => ScalarType::F32,
        "u32" => ScalarType::U32,
        "i32" => ScalarType::I32,
        "bool" => ScalarType::Bool,
        other => {
            return Err(format!(
                "`{name}` has type `{other}`: the types are f32, u32, i32 and bool"
            ))
        }
    };
    let (value_part, description) = match rest.split_once(',') {
        Some((v, d)) => (v.trim(), d.trim()),
        None => (rest.trim(), ""),
    };
    let description: Cow<'static, str> = if description.is_empty() {
        Cow::Owned(format!("`{name}` (no description in the file)"))
    } else {
        Cow::Owned(description.to_string())
    };
    let name: Cow<'static, str> = Cow::Owned(name.to_string());
    let kind = if ty == ScalarType::Bool {
        let default = match value_part {
            "true" => true,
            "false" => false,
            other => {
                return Err(format!(
                    "`{name}`: bool default `{other}` is not true or false"
                ))
            }
        };
        ParamKind::Bool { default }
    } else {
        let (default, range) = value_part
            .split_once(" in ")
            .ok_or_else(|| format!("`{name}` has no range (`in MIN..=MAX`): {GRAMMAR}"))?;
        let (min, max) = range
            .split_once("..=")
            .ok_or_else(|| format!("`{name}`: the range `{}` is not `MIN..=MAX`", range.trim()))?;
        let (default, min, max) = (default.trim(), min.trim(), max.trim());
        match ty {
            ScalarType::F32 => {
                let number = |what: &str, text: &str| -> Result<f64, String> {
                    text.parse::<f32>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .map(f64::from)
                        .ok_or_else(|| format!("`{name}`: {what} `{text}` is not a finite f32"))
                };
                let (default, min, max) = (
                    number("default", default)?,
                    number("min", min)?,
                    number("max", max)?,
                );
                check_range(&name, default, min, max)?;
                ParamKind::Float {
                    min,
                    max,
                    default,
                    logarithmic: false,
                }
            }
            ScalarType::U32 | ScalarType::I32 => {
                let type_name = ty.wgsl_field_type();
                let number = |what: &str, text: &str| -> Result<i64, String> {
                    let value = if ty == ScalarType::U32 {
                        text.parse::<u32>().map(i64::from).ok()
                    } else {
                        text.parse::<i32>().map(i64::from).ok()
                    };
                    value.ok_or_else(|| format!("`{name}`: {what} `{text}` is not a {type_name}"))
                };
                let (default, min, max) = (
                    number("default", default)?,
                    number("min", min)?,
                    number("max", max)?,
                );
                check_range(&name, default, min, max)?;
                ParamKind::Int { min, max, default }
            }
            ScalarType::Bool => unreachable!("handled above"),
        }
    };
    Ok(ParamDirective {
        ty,
        spec: ParamSpec {
            name,
            description,
            kind,
        },
        line,
    })
}

fn check_range<T: PartialOrd + std::fmt::Display>(
    name: &str,
    default: T,
    min: T,
    max: T,
) -> Result<(), String> {
    if min > max {
        return Err(format!(
            "`{name}`: the range {min}..={max} is empty: write the smaller bound first"
        ));
    }
    if default < min || default > max {
        return Err(format!(
            "`{name}`: the default {default} is outside its range {min}..={max}: change one of them"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_parses_with_its_range_and_description() {
        let directives = parse(
            "a.wgsl",
            "// @param radius: f32 = 2.0 in 0.0..=16.0, Kernel radius in texels\n\
             fn f() {}\n\
             //   @param taps: u32 = 4 in 1..=64\n\
             // @param offset: i32 = -1 in -4..=4, Offset\n\
             // @param on: bool = true, Switch\n\
             // @fit receivers\n\
             // @contract 3\n",
        )
        .unwrap();
        assert_eq!(directives.fit, Fit::Receivers);
        let names: Vec<_> = directives
            .params
            .iter()
            .map(|p| p.spec.name.as_ref())
            .collect();
        assert_eq!(names, ["radius", "taps", "offset", "on"]);
        assert_eq!(
            directives.params[0].spec.kind,
            ParamKind::Float {
                min: 0.0,
                max: 16.0,
                default: 2.0,
                logarithmic: false
            }
        );
        assert_eq!(
            directives.params[0].spec.description,
            "Kernel radius in texels"
        );
        assert_eq!(directives.params[1].line, 3);
        assert_eq!(
            directives.params[2].spec.kind,
            ParamKind::Int {
                min: -4,
                max: 4,
                default: -1
            }
        );
        assert_eq!(
            directives.params[3].spec.kind,
            ParamKind::Bool { default: true }
        );
        assert_eq!(
            parse("b.wgsl", "fn f() {}\n// @contract 3").unwrap().fit,
            Fit::Casters
        );
        // A version 1 file (no `@contract` line) and a version 2 file are told what changed.
        for (source, version) in [
            ("fn f() {}", "1"),
            ("// @contract 1\nfn f() {}", "1"),
            ("// @contract 2\nfn f() {}", "2"),
        ] {
            let message = parse("old.wgsl", source).unwrap_err().to_string();
            assert!(
                message.contains(&format!("written for contract version {version}"))
                    && message.contains("light_kind()")
                    && message.contains("map_point(s)")
                    && message.contains("// @contract 3"),
                "{message}"
            );
        }
    }

    #[test]
    fn a_bad_directive_names_file_line_and_column_and_what_to_do() {
        let cases = [
            ("// @param r: f32 = 20.0 in 0.0..=16.0", "outside its range"),
            ("// @param r: f32 = 1.0 in 4.0..=1.0", "is empty"),
            ("// @param r: f64 = 1.0 in 0.0..=2.0", "the types are"),
            ("// @param r: u32 = -1 in 0..=2", "is not a u32"),
            ("// @param r: f32 = 1.0", "has no range"),
            ("// @param r: f32 = nan in 0.0..=2.0", "not a finite f32"),
            (
                "// @param 2r: f32 = 1.0 in 0.0..=2.0",
                "not a parameter name",
            ),
            (
                "// @param shadow_map_size: u32 = 64 in 64..=128",
                "another name",
            ),
            ("// @fit everything", "@fit casters"),
            ("// @parm r: f32 = 1.0 in 0.0..=2.0", "unknown directive"),
        ];
        for (line, expected) in cases {
            let source = format!("fn f() {{}}\n  {line}\n");
            let message = parse("dir/x.wgsl", &source).unwrap_err().to_string();
            assert!(message.starts_with("dir/x.wgsl:2:6: "), "{message}");
            assert!(message.contains(expected), "{line}: {message}");
            assert!(!message.contains('\n'), "{message}");
        }
        let twice = "// @param r: f32 = 1.0 in 0.0..=2.0\n// @param r: u32 = 1 in 0..=2\n";
        let message = parse("x.wgsl", twice).unwrap_err().to_string();
        assert!(message.contains("first on line 1"), "{message}");
    }
}
