//! Typed, documented, range-checked technique parameters. The GUI draws widgets from
//! [`ParamSpec`]s, the benchmark sweeps them, and neither needs to know the technique.

use std::{borrow::Cow, fmt};

use serde::{Deserialize, Serialize};

use crate::error::ParamError;

/// The kind and valid range of a parameter.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ParamKind {
    /// A real number in `[min, max]`.
    Float {
        /// Smallest value.
        min: f64,
        /// Largest value.
        max: f64,
        /// Default value.
        default: f64,
        /// The GUI slider is logarithmic.
        logarithmic: bool,
    },
    /// An integer in `[min, max]`.
    Int {
        /// Smallest value.
        min: i64,
        /// Largest value.
        max: i64,
        /// Default value.
        default: i64,
    },
    /// On or off.
    Bool {
        /// Default value.
        default: bool,
    },
    /// One of named options.
    Choice {
        /// The option names.
        options: &'static [&'static str],
        /// Default option.
        default: &'static str,
    },
}

/// One parameter: name, meaning and range.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParamSpec {
    /// Name as used on the command line, in JSON and in the GUI.
    pub name: Cow<'static, str>,
    /// What it does (the doc comment of its declaration).
    pub description: Cow<'static, str>,
    /// Type and range.
    #[serde(flatten)]
    pub kind: ParamKind,
}

/// A parameter value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ParamValue {
    /// For [`ParamKind::Bool`].
    Bool(bool),
    /// For [`ParamKind::Int`].
    Int(i64),
    /// For [`ParamKind::Float`].
    Float(f64),
    /// For [`ParamKind::Choice`]: the option name.
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
    /// The value as a number (`None` for choices).
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            ParamValue::Float(x) => Some(*x),
            ParamValue::Int(i) => Some(*i as f64),
            _ => None,
        }
    }
}

impl ParamSpec {
    /// A float parameter with its range (`log`: the GUI slider is logarithmic).
    pub const fn float(
        name: &'static str,
        description: &'static str,
        min: f64,
        max: f64,
        default: f64,
    ) -> Self {
        Self {
            name: Cow::Borrowed(name),
            description: Cow::Borrowed(description),
            kind: ParamKind::Float {
                min,
                max,
                default,
                logarithmic: false,
            },
        }
    }

    /// An integer parameter with its range.
    pub const fn int(
        name: &'static str,
        description: &'static str,
        min: i64,
        max: i64,
        default: i64,
    ) -> Self {
        Self {
            name: Cow::Borrowed(name),
            description: Cow::Borrowed(description),
            kind: ParamKind::Int { min, max, default },
        }
    }

    /// A boolean parameter.
    pub const fn boolean(name: &'static str, description: &'static str, default: bool) -> Self {
        Self {
            name: Cow::Borrowed(name),
            description: Cow::Borrowed(description),
            kind: ParamKind::Bool { default },
        }
    }

    /// A choice among `options` (the first variant names of a [`param_choice!`](crate::param_choice) enum).
    pub const fn choice(
        name: &'static str,
        description: &'static str,
        options: &'static [&'static str],
        default: &'static str,
    ) -> Self {
        Self {
            name: Cow::Borrowed(name),
            description: Cow::Borrowed(description),
            kind: ParamKind::Choice { options, default },
        }
    }

    /// The declared default.
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
    /// Every parameter with its current value.
    pub entries: Vec<(ParamSpec, ParamValue)>,
}

impl ParamSet {
    /// The value of parameter `name`.
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
            known: specs
                .iter()
                .map(|s| s.name.as_ref())
                .collect::<Vec<_>>()
                .join(", "),
        })
}

/// A Rust type a technique parameter can have, and how it maps to a [`ParamValue`]. Implemented
/// for `u32`, `f32`, `bool` and every enum declared with [`param_choice!`](crate::param_choice).
pub trait ParamType: Sized + Clone + PartialEq {
    /// The spec for a parameter of this type. `range` is `(min, max)` for numbers (ignored
    /// otherwise); `logarithmic` asks the GUI for a logarithmic slider.
    fn spec(
        name: &'static str,
        description: &'static str,
        default: &Self,
        range: Option<(f64, f64)>,
        logarithmic: bool,
    ) -> ParamSpec;
    /// The value as a [`ParamValue`].
    fn to_value(&self) -> ParamValue;
    /// Converts a value that [`ParamSpec::check`] accepted.
    fn from_value(value: &ParamValue) -> Option<Self>;
}

impl ParamType for u32 {
    fn spec(
        name: &'static str,
        description: &'static str,
        default: &Self,
        range: Option<(f64, f64)>,
        _logarithmic: bool,
    ) -> ParamSpec {
        let (min, max) = range.unwrap_or((0.0, u32::MAX as f64));
        ParamSpec::int(name, description, min as i64, max as i64, *default as i64)
    }
    fn to_value(&self) -> ParamValue {
        ParamValue::Int(*self as i64)
    }
    fn from_value(value: &ParamValue) -> Option<Self> {
        match value {
            ParamValue::Int(i) => u32::try_from(*i).ok(),
            _ => None,
        }
    }
}

impl ParamType for f32 {
    fn spec(
        name: &'static str,
        description: &'static str,
        default: &Self,
        range: Option<(f64, f64)>,
        logarithmic: bool,
    ) -> ParamSpec {
        let (min, max) = range.unwrap_or((f32::MIN as f64, f32::MAX as f64));
        ParamSpec {
            name: Cow::Borrowed(name),
            description: Cow::Borrowed(description),
            kind: ParamKind::Float {
                min,
                max,
                default: *default as f64,
                logarithmic,
            },
        }
    }
    fn to_value(&self) -> ParamValue {
        ParamValue::Float(*self as f64)
    }
    fn from_value(value: &ParamValue) -> Option<Self> {
        value.as_f64().map(|x| x as f32)
    }
}

impl ParamType for bool {
    fn spec(
        name: &'static str,
        description: &'static str,
        default: &Self,
        _range: Option<(f64, f64)>,
        _logarithmic: bool,
    ) -> ParamSpec {
        ParamSpec::boolean(name, description, *default)
    }
    fn to_value(&self) -> ParamValue {
        ParamValue::Bool(*self)
    }
    fn from_value(value: &ParamValue) -> Option<Self> {
        match value {
            ParamValue::Bool(b) => Some(*b),
            _ => None,
        }
    }
}

/// An enum whose variants are the options of a choice parameter (declare it with
/// [`param_choice!`](crate::param_choice)).
pub trait ParamChoice: Copy + PartialEq + 'static {
    /// Option names in declaration order (what the CLI, sweeps and JSON use).
    const NAMES: &'static [&'static str];
    /// This option's name.
    fn name(self) -> &'static str;
    /// The option called `name`.
    fn from_name(name: &str) -> Option<Self>;
}

/// The settings of one technique, declared with [`technique_settings!`](crate::technique_settings):
/// the spec list, current values and range-checked setting all come from one declaration per
/// parameter. Object safe, so the [`ShadowTechnique`](crate::ShadowTechnique) trait can reach
/// it through `settings()` / `settings_mut()`.
pub trait TechniqueSettings {
    /// Specs in declaration order (defaults are those of `Default`).
    fn specs(&self) -> Vec<ParamSpec>;
    /// Current values with their specs.
    fn param_set(&self) -> ParamSet;
    /// Checks `value` against the spec named `name` (type, finiteness, range) and stores it.
    fn set_param(
        &mut self,
        technique: &str,
        name: &str,
        value: ParamValue,
    ) -> Result<(), ParamError>;
}

/// Declares an enum usable as a choice parameter: variants with their option names.
///
/// ```
/// softshadow_core::param_choice! {
///     /// How texels become occluders.
///     pub enum Primitive {
///         /// A rectangle parallel to the light.
///         Micropatch = "micropatch",
///         /// Texel centres as quad corners.
///         Microquad = "microquad",
///     }
/// }
/// use softshadow_core::params::ParamChoice;
/// assert_eq!(Primitive::from_name("microquad"), Some(Primitive::Microquad));
/// assert_eq!(Primitive::NAMES, &["micropatch", "microquad"]);
/// ```
#[macro_export]
macro_rules! param_choice {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $text:literal ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        $vis enum $name {
            $( $(#[$vmeta])* $variant ),+
        }

        impl $name {
            /// Option names in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($text),+];
            /// The option name of this variant.
            pub fn name(self) -> &'static str {
                match self { $( $name::$variant => $text ),+ }
            }
            /// The variant named `name`, if any.
            pub fn from_name(name: &str) -> Option<Self> {
                match name { $( $text => Some($name::$variant), )+ _ => None }
            }
        }

        impl $crate::params::ParamChoice for $name {
            const NAMES: &'static [&'static str] = &[$($text),+];
            fn name(self) -> &'static str {
                $name::name(self)
            }
            fn from_name(name: &str) -> Option<Self> {
                $name::from_name(name)
            }
        }

        impl $crate::params::ParamType for $name {
            fn spec(
                name: &'static str,
                description: &'static str,
                default: &Self,
                _range: Option<(f64, f64)>,
                _logarithmic: bool,
            ) -> $crate::params::ParamSpec {
                $crate::params::ParamSpec::choice(name, description, &[$($text),+], default.name())
            }
            fn to_value(&self) -> $crate::params::ParamValue {
                $crate::params::ParamValue::Choice(self.name().to_string())
            }
            fn from_value(value: &$crate::params::ParamValue) -> Option<Self> {
                match value {
                    $crate::params::ParamValue::Choice(s) => $name::from_name(s),
                    _ => None,
                }
            }
        }
    };
}

/// Declares a technique's settings struct, one line per parameter: its doc comment (also the
/// parameter's description in the GUI, `workbench list` and results.json), its type, its default
/// and, for numbers, its range (`in min..=max`, optionally followed by `log` for a logarithmic
/// slider: `epsilon: f32 = 0.01, in 0.0001..=1.0 log;`).
/// Generates the struct with public fields, `Default`, and [`TechniqueSettings`] (spec list,
/// values, range-checked `set_param`).
///
/// ```
/// softshadow_core::technique_settings! {
///     /// Settings of an example technique.
///     pub struct ExampleSettings {
///         /// Shadow-map edge in texels.
///         shadow_map_size: u32 = 1024, in 64..=4096;
///         /// Depth bias in texels.
///         bias_texels: f32 = 1.5, in 0.0..=16.0;
///         /// Jitter the samples.
///         jitter: bool = true;
///     }
/// }
/// use softshadow_core::params::{TechniqueSettings, ParamValue};
/// let mut s = ExampleSettings::default();
/// assert_eq!(s.shadow_map_size, 1024);
/// s.set_param("example", "bias_texels", ParamValue::Float(2.0)).unwrap();
/// assert_eq!(s.bias_texels, 2.0);
/// assert!(s.set_param("example", "shadow_map_size", ParamValue::Int(1)).is_err());
/// assert_eq!(s.specs()[0].description, "Shadow-map edge in texels.");
/// ```
///
/// A group of parameters several techniques share (the gather settings of `backprojection` and
/// `bitmask`, say) is itself declared with this macro and included first, as `..name: Type;`:
/// its parameters come first, under their own names, and live in the field `name`.
///
/// ```
/// softshadow_core::technique_settings! {
///     /// Shared by two example techniques.
///     pub struct SharedSettings {
///         /// Shadow-map edge in texels.
///         shadow_map_size: u32 = 1024, in 64..=4096;
///     }
/// }
/// softshadow_core::technique_settings! {
///     /// One of them.
///     pub struct OneSettings {
///         ..shared: SharedSettings;
///         /// Jitter the samples.
///         jitter: bool = true;
///     }
/// }
/// use softshadow_core::params::{TechniqueSettings, ParamValue};
/// let mut s = OneSettings::default();
/// s.set_param("one", "shadow_map_size", ParamValue::Int(512)).unwrap();
/// assert_eq!(s.shared.shadow_map_size, 512);
/// assert_eq!(s.specs()[0].name, "shadow_map_size");
/// assert_eq!(s.specs()[1].name, "jitter");
/// ```
#[macro_export]
macro_rules! technique_settings {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $( .. $group:ident : $group_ty:ty ; )?
            $(
                $(#[doc = $doc:literal])*
                $field:ident : $ty:ty = $default:expr
                    $(, in $min:literal ..= $max:literal $($log:ident)?)? ;
            )+
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug, PartialEq)]
        $vis struct $name {
            $( #[doc = "The shared group's parameters (listed first)."] pub $group: $group_ty, )?
            $( $(#[doc = $doc])* pub $field: $ty, )+
        }

        impl Default for $name {
            fn default() -> Self {
                Self {
                    $( $group: <$group_ty as Default>::default(), )?
                    $( $field: $default, )+
                }
            }
        }

        impl $name {
            /// Parameter specs with this struct's defaults (for `TechniqueInfo::params`): the
            /// shared group's first, then its own in declaration order.
            pub fn param_specs() -> Vec<$crate::params::ParamSpec> {
                let defaults = Self::default();
                #[allow(unused_mut)]
                let mut specs: Vec<$crate::params::ParamSpec> = Vec::new();
                $( specs.extend(<$group_ty>::param_specs()); )?
                specs.extend([ $(
                    <$ty as $crate::params::ParamType>::spec(
                        stringify!($field),
                        concat!($($doc),*).trim_ascii(),
                        &defaults.$field,
                        $crate::technique_settings!(@range $($min, $max)?),
                        $crate::technique_settings!(@log $($($log)?)?),
                    ),
                )+ ]);
                specs
            }
        }

        impl $crate::params::TechniqueSettings for $name {
            fn specs(&self) -> Vec<$crate::params::ParamSpec> {
                Self::param_specs()
            }

            fn param_set(&self) -> $crate::params::ParamSet {
                #[allow(unused_mut)]
                let mut values: Vec<$crate::params::ParamValue> = Vec::new();
                $(
                    let group = $crate::params::TechniqueSettings::param_set(&self.$group);
                    values.extend(group.entries.into_iter().map(|(_, value)| value));
                )?
                values.extend([ $( $crate::params::ParamType::to_value(&self.$field), )+ ]);
                $crate::params::ParamSet {
                    entries: Self::param_specs().into_iter().zip(values).collect(),
                }
            }

            fn set_param(
                &mut self,
                technique: &str,
                name: &str,
                value: $crate::params::ParamValue,
            ) -> Result<(), $crate::ParamError> {
                $(
                    if <$group_ty>::param_specs().iter().any(|spec| spec.name == name) {
                        return $crate::params::TechniqueSettings::set_param(
                            &mut self.$group,
                            technique,
                            name,
                            value,
                        );
                    }
                )?
                let specs = Self::param_specs();
                let spec = $crate::params::find_spec(technique, &specs, name)?;
                let value = spec.check(value)?;
                $(
                    if spec.name == stringify!($field) {
                        self.$field = <$ty as $crate::params::ParamType>::from_value(&value)
                            .ok_or_else(|| $crate::ParamError::WrongType {
                                name: name.to_string(),
                                expected: spec.range_text(),
                                value: value.to_string(),
                            })?;
                        return Ok(());
                    }
                )+
                unreachable!("find_spec returned a declared parameter")
            }
        }
    };
    (@range $min:literal, $max:literal) => { Some(($min as f64, $max as f64)) };
    (@range) => { None };
    (@log log) => { true };
    (@log) => { false };
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
