//! Random parameter stress on the GPU (docs/STABILITY.md, "Random parameter stress").
//!
//! Each case takes the next registered technique in turn and draws, from one seeded generator, a
//! value inside the declared range of every one of its parameters, a small scene, a light of random size and
//! placement (degenerate ones included: zero width, aspect 1000, a light almost touching a
//! caster, a light facing up or sideways, an `up` hint parallel to the direction) and a
//! resolution of 32² or 48². It renders two frames (the full work, then one with only the camera
//! moved, which keeps light-space results) and checks each: either the frame succeeded with every
//! visibility value finite and in [0, 1], or it failed with a clear one-line error. A wgpu
//! validation error, a panic, or an invalid visibility value is a [`Finding`].
//!
//! The same seed gives the same cases, so a finding is reproduced with
//! `workbench bench --stress SECONDS --seed SEED` and the case number it names.

use std::{
    collections::{BTreeMap, HashMap},
    panic::AssertUnwindSafe,
};

use softshadow_core::{
    glam::Vec3, AreaLight, GpuError, ParamKind, ParamSpec, ParamValue, RenderError, Renderer,
    Scene, SceneGpu, ShadowTechnique, TechniqueError,
};

use crate::{registry, BenchError};

/// Builtin scenes the stress draws from: a few hundred triangles each, every stiff geometry
/// that matters for light placement (contact, zero thickness, a caster crossing the light plane,
/// repaired input, overlapping casters) and a scene with a dynamic-free PDSM set-up.
pub const SCENES: &[&str] = &[
    "atty-square",
    "stiff-contact",
    "stiff-zero-thickness",
    "stiff-partly-outside",
    "stiff-degenerate",
    "stiff-fusion",
    "pdsm-quads",
];

/// Image sizes the stress draws from.
pub const SIZES: &[(u32, u32)] = &[(32, 32), (48, 48), (48, 32)];

/// A small, fast, seedable generator (SplitMix64): the stress needs reproducible draws, not
/// cryptographic ones, and no dependency.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi].
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform integer in [lo, hi].
    pub fn int(&mut self, lo: i64, hi: i64) -> i64 {
        let span = (hi - lo) as u64 + 1;
        lo + (self.next_u64() % span) as i64
    }

    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }

    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[(self.next_u64() % items.len() as u64) as usize]
    }
}

/// Which part of each declared range the cases draw from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ranges {
    /// The whole declared range of every parameter (`bench --stress`).
    Full,
    /// Integer ranges wider than a factor of 8 above a positive minimum (map sides, sample and
    /// map counts, memory budgets) are cut to `min..=8 min`, so a case takes a second rather
    /// than a minute on a CPU device: the CI test. Every other range is whole.
    Quick,
}

/// A value inside `spec`'s declared range: 1 in 5 draws takes an end of the range exactly; the
/// rest are uniform, or log-uniform where the range spans more than a factor of 8 above a
/// positive minimum (so map sizes 64..4096 are not almost always in the thousands). With
/// [`Ranges::Quick`] such integer ranges end at 8 x their minimum.
pub fn random_value(spec: &ParamSpec, rng: &mut Rng, ranges: Ranges) -> ParamValue {
    match &spec.kind {
        ParamKind::Float { min, max, .. } => {
            let x = if rng.chance(0.2) {
                if rng.chance(0.5) {
                    *min
                } else {
                    *max
                }
            } else if *min > 0.0 && max / min > 8.0 {
                (rng.range(min.ln(), max.ln())).exp().clamp(*min, *max)
            } else {
                rng.range(*min, *max)
            };
            ParamValue::Float(x)
        }
        ParamKind::Int { min, max, .. } => {
            let wide = *min > 0 && *max / *min > 8;
            let max = &if wide && ranges == Ranges::Quick {
                min * 8
            } else {
                *max
            };
            let i = if rng.chance(0.2) {
                if rng.chance(0.5) {
                    *min
                } else {
                    *max
                }
            } else if wide {
                let x = rng
                    .range((*min as f64).ln(), (*max as f64 + 1.0).ln())
                    .exp();
                (x.floor() as i64).clamp(*min, *max)
            } else {
                rng.int(*min, *max)
            };
            ParamValue::Int(i)
        }
        ParamKind::Bool { .. } => ParamValue::Bool(rng.chance(0.5)),
        ParamKind::Choice { options, .. } => ParamValue::Choice(rng.pick(options).to_string()),
    }
}

/// Estimated seconds one case may cost before its parameters are redrawn or clamped (both frames,
/// on lavapipe on the 2-core machine the figures in [`estimate`] were measured on). Without a
/// cap, whole ranges give cases of half an hour (`reference` with 64 x 64 maps of 4096²:
/// 2 x 4096 depth passes of 16.7 M texels), which stall a timed run on one case.
pub const BUDGET_SECONDS: f64 = 20.0;

/// Host memory one case may need (PDSM's read-back maps and attenuation functions), whatever its
/// own `memory_budget_mib` allows (up to 64 GiB, more than the machines that run this have).
pub const BUDGET_BYTES: f64 = 2.0 * (1u64 << 30) as f64;

/// Fresh draws of a case's parameters before the cap clamps them instead.
pub const REDRAWS: u32 = 8;

/// What a case is estimated to cost, from its technique's declared parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Cost {
    /// Estimated wall time of both frames, seconds (see [`estimate`]).
    pub seconds: f64,
    /// Host memory of the precompute, bytes (PDSM only; 0 elsewhere).
    pub bytes: f64,
    /// The term that dominates, in the parameters' names (what the record says a cap was for).
    pub dominant: &'static str,
}

impl Cost {
    /// Whether the case fits [`BUDGET_SECONDS`] and [`BUDGET_BYTES`].
    pub fn fits(&self) -> bool {
        self.seconds <= BUDGET_SECONDS && self.bytes <= BUDGET_BYTES
    }
}

impl std::fmt::Display for Cost {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "about {:.1} s, {:.0} MiB ({})",
            self.seconds,
            self.bytes / (1u64 << 20) as f64,
            self.dominant
        )
    }
}

// Rates of lavapipe on the 2-core machine (release build, 2026-11-30, with two other sessions'
// builds beside it), from one `workbench bench --size 48x48 --frames 1 --warmup 0 --no-error`
// run per technique near the large ends of its ranges (docs/STABILITY.md, "Random parameter
// stress"), rounded up: the cap needs the order of magnitude, not a prediction.
/// Seconds per depth-map texel rendered (`hard` at 4096²: 11.6 ns; `reference` 8² maps of
/// 2048²: 12.4 ns; `adaptive` 128 maps of 1024²: 7.9 ns).
const DEPTH_TEXEL: f64 = 12e-9;
/// Seconds per depth texel of `bitmask`'s peeled layers and the hierarchies' linearisation
/// (`bitmask`, 4 layers of 4096²: 24 ns).
const LAYER_TEXEL: f64 = 25e-9;
/// Seconds per texel per MSSM level (`bitmask`, 4 layers of 4096², 12 levels: 44 ns).
const HIERARCHY_TEXEL: f64 = 45e-9;
/// Seconds per light sample and sample-map texel of PDSM's maps, readback and the part of its
/// construction that walks them (16 samples of 1024² into a 128² PDSM: 0.75 s).
const PDSM_MAP_TEXEL: f64 = 45e-9;
/// Seconds per step of a PDSM texel's ray through one sample map (section 3.1: the construction
/// is O(k m n²), k samples, m the map edge, n² texels), for maps up to 1024² (4 MiB, in cache);
/// larger maps miss the cache on most steps, so the rate grows with the map's area beyond
/// 1024². Fitted to the table's 64 samples of 1024² into 512² (27.5 s: this gives 24 s with the
/// maps) and to the 30-minute stress run's slowest case, which the earlier samples² x n² model
/// missed: 1 sample, a 4096² map, a 1752² PDSM took 137 s against 1.3 s estimated (this gives
/// 241 s). The paper's 64 samples with 512² maps and PDSM get 11 s (3.7 s measured on the idle
/// machine, linear in the samples: docs/BENCHMARKS.md).
const PDSM_RAY_STEP: f64 = 1.2e-9;
/// Seconds per PDSM texel and light sample to merge that sample's events into the texel's
/// function (section 3.2).
const PDSM_EVENT_MERGE: f64 = 2e-8;
/// Seconds per pair of an occluder-map texel and an SSM texel: each micro-patch's penumbra
/// quad covers part of the SSM (256² by 256²: 13 s, 3 ns, with the scene's default light;
/// larger lights cover more).
const SCATTER_PAIR: f64 = 4e-9;
/// Seconds per iteration of a per-pixel loop (PCSS samples, gathers, filters).
const PIXEL_ITERATION: f64 = 5e-9;
/// Seconds a frame costs whatever the parameters (passes, submission, readback).
const FRAME: f64 = 0.05;

/// The value of an integer or float parameter of a drawn case, as f64.
fn number(params: &[(String, ParamValue)], name: &str) -> Option<f64> {
    params
        .iter()
        .find(|(n, _)| n == name)
        .and_then(|(_, v)| match v {
            ParamValue::Int(i) => Some(*i as f64),
            ParamValue::Float(x) => Some(*x),
            _ => None,
        })
}

/// The integer parameters whose size drives each technique's cost, largest effect first: what
/// [`estimate`] reads and what the cap halves when redrawing did not bring a case under budget.
/// (`cost_model_reads_only_declared_integer_parameters` checks every name is declared.)
pub fn cost_knobs(technique: &str) -> &'static [&'static str] {
    match technique {
        "hard" => &["shadow_map_size"],
        "pcss" => &["shadow_map_size", "filter_samples", "blocker_samples"],
        "ssm" => &["occluder_map_size", "ssm_size"],
        "backprojection" => &["shadow_map_size", "max_patches"],
        "bitmask" => &["shadow_map_size", "layers", "max_patches", "filter_passes"],
        "adaptive" => &["shadow_map_size", "max_shadow_maps", "max_depth"],
        "reference" => &["samples_per_axis", "shadow_map_size"],
        "pdsm" => &[
            "samples",
            "shadow_map_size",
            "pdsm_size",
            "dynamic_map_size",
        ],
        _ => &[],
    }
}

/// Estimated cost of running `technique` with `params` at `pixels` camera pixels: two frames
/// (the second keeps light-space results, except `reference`'s, which redoes its maps).
/// Parameters the model does not read (biases, seeds, choices of equal cost) do not change it.
pub fn estimate(technique: &str, params: &[(String, ParamValue)], pixels: f64) -> Cost {
    let n = |name: &str| number(params, name).unwrap_or(1.0);
    let flag = |name: &str| {
        params
            .iter()
            .any(|(p, v)| p == name && *v == ParamValue::Bool(true))
    };
    let choice = |name: &str, option: &str| {
        params
            .iter()
            .any(|(p, v)| p == name && *v == ParamValue::Choice(option.into()))
    };
    let levels = |side: f64| side.max(2.0).log2().ceil();
    let (seconds, bytes, dominant) = match technique {
        "hard" => (
            n("shadow_map_size").powi(2) * DEPTH_TEXEL,
            0.0,
            "shadow_map_size²",
        ),
        "pcss" => {
            let map = n("shadow_map_size").powi(2) * DEPTH_TEXEL;
            let filter =
                2.0 * pixels * (n("blocker_samples") + n("filter_samples")) * PIXEL_ITERATION;
            (map + filter, 0.0, "shadow_map_size²")
        }
        "ssm" => {
            // Every occluder-map texel is a quad over its penumbra in the SSM: at worst (a light
            // as large as the scene) a large part of the SSM.
            let passes = if flag("two_pass") { 2.0 } else { 1.0 };
            let batched = if choice("precision", "fp16-batched") {
                2.0
            } else {
                1.0
            };
            let scatter = passes
                * batched
                * n("occluder_map_size").powi(2)
                * n("ssm_size").powi(2)
                * SCATTER_PAIR;
            (scatter, 0.0, "occluder_map_size² x ssm_size²")
        }
        "backprojection" | "bitmask" => {
            // The hierarchies pad the map to a power of two (2658² is built as 4096²: the
            // 30-minute run's slowest case, 105 s against 8 s estimated without the padding).
            let side = n("shadow_map_size").max(1.0).log2().ceil().exp2();
            let layers = if technique == "bitmask" {
                n("layers")
            } else {
                1.0
            };
            let maps = layers * side * side * (LAYER_TEXEL + levels(side) * HIERARCHY_TEXEL);
            // The gather is bounded by lavapipe's loop budget per pixel (ARCHITECTURE.md).
            let gather = 2.0 * pixels * layers * n("max_patches").powi(2).min(65_535.0);
            let filter = 2.0 * pixels * n("filter_passes") * 64.0;
            (
                maps + (gather + filter) * PIXEL_ITERATION,
                0.0,
                "layers x padded shadow_map_size² x log2(shadow_map_size)",
            )
        }
        "adaptive" => {
            let depth = n("max_depth");
            // Corners: (2^d + 1)² maps; centres: (2^(d+1))²; the cap stops at max_shadow_maps.
            let most = (2f64.powf(depth + 1.0)).powi(2);
            let maps = most.min(n("max_shadow_maps"));
            let compare = 2.0 * maps * pixels * PIXEL_ITERATION;
            (
                maps * n("shadow_map_size").powi(2) * DEPTH_TEXEL + compare,
                0.0,
                "min(max_shadow_maps, maps at max_depth) x shadow_map_size²",
            )
        }
        "reference" => (
            2.0 * n("samples_per_axis").powi(2) * n("shadow_map_size").powi(2) * DEPTH_TEXEL,
            0.0,
            "2 frames x samples_per_axis² x shadow_map_size²",
        ),
        "pdsm" => {
            let settings = softshadow_pdsm::PdsmSettings {
                samples: n("samples") as u32,
                pdsm_size: n("pdsm_size") as u32,
                shadow_map_size: n("shadow_map_size") as u32,
                ..Default::default()
            };
            let (maps_bytes, pdsm_bytes) = softshadow_pdsm::estimate_bytes(&settings);
            let bytes = (maps_bytes + pdsm_bytes) as f64;
            if bytes > n("memory_budget_mib") * (1u64 << 20) as f64 {
                // Refused before building: a clear error that costs nothing.
                (0.0, 0.0, "refused by memory_budget_mib")
            } else {
                let maps = n("samples") * n("shadow_map_size").powi(2) * PDSM_MAP_TEXEL;
                let edge = n("shadow_map_size");
                let step = PDSM_RAY_STEP * (edge / 1024.0).powi(2).max(1.0);
                let build =
                    n("samples") * n("pdsm_size").powi(2) * (edge * step + PDSM_EVENT_MERGE);
                let dynamic = 2.0 * n("dynamic_map_size").powi(2) * DEPTH_TEXEL;
                (
                    maps + build + dynamic,
                    bytes,
                    "samples x (shadow_map_size² + pdsm_size² x shadow_map_size)",
                )
            }
        }
        _ => (0.0, 0.0, "not modelled"),
    };
    Cost {
        seconds: seconds + 2.0 * FRAME,
        bytes,
        dominant,
    }
}

/// What the cost cap did to a case's drawn parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum Capped {
    /// The first draw fitted.
    No,
    /// The first draw was over budget (its estimate); a later draw fitted.
    Redrawn { draws: u32, first: Cost },
    /// No draw fitted: the last one's knobs were halved (those named) until it did.
    Clamped { first: Cost, halved: Vec<String> },
}

/// Draws a value for every parameter in `specs`; while the draw is over the cost cap, draws
/// again (up to [`REDRAWS`] times), then halves the last draw's [`cost_knobs`] (the one farthest
/// above its minimum first) until it fits. Each range still reaches both ends, only not every
/// parameter at its expensive end in one case.
pub fn draw_params(
    technique: &str,
    specs: &[ParamSpec],
    rng: &mut Rng,
    ranges: Ranges,
    pixels: u32,
) -> (Vec<(String, ParamValue)>, Capped) {
    let pixels = pixels as f64;
    let draw = |rng: &mut Rng| -> Vec<(String, ParamValue)> {
        specs
            .iter()
            .map(|spec| (spec.name.to_string(), random_value(spec, rng, ranges)))
            .collect()
    };
    let mut params = draw(rng);
    let first = estimate(technique, &params, pixels);
    if first.fits() {
        return (params, Capped::No);
    }
    for draws in 2..=REDRAWS + 1 {
        params = draw(rng);
        if estimate(technique, &params, pixels).fits() {
            return (params, Capped::Redrawn { draws, first });
        }
    }
    let halved = clamp(technique, specs, &mut params, pixels);
    (params, Capped::Clamped { first, halved })
}

/// Halves `params`' [`cost_knobs`] (the one farthest above its declared minimum, by ratio, each
/// time) until the estimate fits or every knob is at its minimum; returns what it halved.
pub fn clamp(
    technique: &str,
    specs: &[ParamSpec],
    params: &mut [(String, ParamValue)],
    pixels: f64,
) -> Vec<String> {
    let mut halved = Vec::new();
    while !estimate(technique, params, pixels).fits() {
        // The knob farthest above its declared minimum, by ratio.
        let knob = cost_knobs(technique)
            .iter()
            .filter_map(|&name| {
                let ParamKind::Int { min, .. } = specs.iter().find(|s| s.name == name)?.kind else {
                    return None;
                };
                let (index, value) = params.iter().enumerate().find_map(|(i, (n, v))| match v {
                    ParamValue::Int(v) if n == name && *v > min => Some((i, *v)),
                    _ => None,
                })?;
                Some((value as f64 / min.max(1) as f64, index, value, min))
            })
            .max_by(|a, b| a.0.total_cmp(&b.0));
        let Some((_, index, value, min)) = knob else {
            // Every knob at its minimum: the case runs as it is.
            break;
        };
        let lower = (value / 2).max(min);
        halved.push(format!("{} {value} -> {lower}", params[index].0));
        params[index].1 = ParamValue::Int(lower);
    }
    halved
}

/// How the light of a case was placed (so a count per kind can be reported).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum LightKind {
    /// Random size (0 to 2 per side) above the scene, aimed near its target.
    Ordinary,
    /// Width 0 (a line light) or both sides 0 (a point light).
    ZeroWidth,
    /// Aspect ratio 1000 (either way round).
    Aspect1000,
    /// Facing down from 1e-5 to 1e-2 above the top of the casters.
    TouchingCaster,
    /// Any direction (up, sideways, grazing) from anywhere around the scene.
    AnyDirection,
    /// The `up` hint parallel to the direction (light space must pick its own).
    UpParallel,
}

/// One drawn case.
#[derive(Clone, Debug)]
pub struct Case {
    /// 0-based position in the seeded sequence.
    pub number: u64,
    pub technique: &'static str,
    pub params: Vec<(String, ParamValue)>,
    pub scene: &'static str,
    pub light_kind: LightKind,
    pub light: AreaLight,
    pub width: u32,
    pub height: u32,
    /// The estimated cost of `params` (after the cap).
    pub cost: Cost,
    /// What the cost cap did to the first draw.
    pub capped: Capped,
}

impl std::fmt::Display for Case {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let params: Vec<String> = self
            .params
            .iter()
            .map(|(n, v)| format!("{n}={v}"))
            .collect();
        let l = &self.light;
        write!(
            f,
            "case {} ({}x{}): {} [{}] on {} with a {:?} light center {:?} direction {:?} up {:?} size {}x{}",
            self.number,
            self.width,
            self.height,
            self.technique,
            params.join(","),
            self.scene,
            self.light_kind,
            l.center.to_array(),
            l.direction.to_array(),
            l.up.to_array(),
            l.width,
            l.height
        )?;
        match &self.capped {
            Capped::No => Ok(()),
            Capped::Redrawn { draws, first } => {
                write!(
                    f,
                    " (parameters drawn {draws} times: the first was {first})"
                )
            }
            Capped::Clamped { first, halved } => write!(
                f,
                " (clamped: {} halved; the first draw was {first})",
                halved.join(", ")
            ),
        }
    }
}

/// What a case did.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// Both frames rendered; every visibility value finite and in [0, 1].
    Ok,
    /// The technique refused the case with this one-line message.
    ClearError(String),
}

/// A case that broke a rule: the case, then what went wrong.
#[derive(Clone, Debug)]
pub struct Finding {
    pub case: String,
    pub problem: String,
}

impl std::fmt::Display for Finding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.case, self.problem)
    }
}

/// Counts of a stress run.
#[derive(Clone, Debug, Default)]
pub struct Counts {
    pub cases: u64,
    pub ok: u64,
    pub clear_errors: u64,
    /// Frames rendered (two per case that got that far).
    pub frames: u64,
    /// Technique id -> (cases, ok).
    pub per_technique: BTreeMap<String, (u64, u64)>,
    /// Light kind -> cases.
    pub per_light: BTreeMap<String, u64>,
    /// Distinct clear-error messages (numbers stripped) -> how often.
    pub error_messages: BTreeMap<String, u64>,
    pub findings: Vec<Finding>,
    /// Cases whose first draw was over the cost cap and a later draw fitted.
    pub redrawn: u64,
    /// Cases where no draw fitted and the cap halved parameters.
    pub clamped: u64,
    /// Why cases were capped: "technique: dominant term" -> cases.
    pub cap_reasons: BTreeMap<String, u64>,
    /// The slowest case: seconds, its estimate, the case.
    pub slowest: Option<(f64, f64, String)>,
    /// The case that took longest relative to its estimate: seconds, estimate, the case.
    pub most_underestimated: Option<(f64, f64, String)>,
}

impl Counts {
    fn add(&mut self, case: &Case, result: &Result<Outcome, Finding>, seconds: f64) {
        self.cases += 1;
        let first = match &case.capped {
            Capped::No => None,
            Capped::Redrawn { first, .. } => {
                self.redrawn += 1;
                Some(first)
            }
            Capped::Clamped { first, .. } => {
                self.clamped += 1;
                Some(first)
            }
        };
        if let Some(first) = first {
            let why = if first.bytes > BUDGET_BYTES {
                "host memory".to_string()
            } else {
                first.dominant.to_string()
            };
            *self
                .cap_reasons
                .entry(format!("{}: {why}", case.technique))
                .or_default() += 1;
        }
        let estimate = case.cost.seconds;
        if self.slowest.as_ref().is_none_or(|s| seconds > s.0) {
            self.slowest = Some((seconds, estimate, case.to_string()));
        }
        let ratio = |s: f64, e: f64| s / e.max(1e-3);
        if self
            .most_underestimated
            .as_ref()
            .is_none_or(|m| ratio(seconds, estimate) > ratio(m.0, m.1))
        {
            self.most_underestimated = Some((seconds, estimate, case.to_string()));
        }
        *self
            .per_light
            .entry(format!("{:?}", case.light_kind))
            .or_default() += 1;
        let entry = self
            .per_technique
            .entry(case.technique.to_string())
            .or_default();
        entry.0 += 1;
        match result {
            Ok(Outcome::Ok) => {
                self.ok += 1;
                entry.1 += 1;
            }
            Ok(Outcome::ClearError(message)) => {
                self.clear_errors += 1;
                let shape: String = message
                    .chars()
                    .map(|c| if c.is_ascii_digit() { '#' } else { c })
                    .collect();
                *self.error_messages.entry(shape).or_default() += 1;
            }
            Err(finding) => self.findings.push(finding.clone()),
        }
    }
}

/// The GPU state of a stress run: one renderer per size, scenes uploaded once, one technique
/// object per id (re-parameterised for every case, as the viewer's sliders do).
pub struct Stress {
    gpu: softshadow_core::Gpu,
    rng: Rng,
    ranges: Ranges,
    next_case: u64,
    scenes: HashMap<&'static str, (Scene, SceneGpu)>,
    renderers: HashMap<(u32, u32), Renderer>,
    techniques: HashMap<&'static str, Box<dyn ShadowTechnique>>,
    pub counts: Counts,
}

impl Stress {
    pub fn new(gpu: softshadow_core::Gpu, seed: u64, ranges: Ranges) -> Result<Self, BenchError> {
        let mut scenes = HashMap::new();
        for &id in SCENES {
            let scene = softshadow_scenes::load(id)?.scene;
            let uploaded = SceneGpu::upload(&gpu, &scene);
            scenes.insert(id, (scene, uploaded));
        }
        Ok(Self {
            gpu,
            rng: Rng::new(seed),
            ranges,
            next_case: 0,
            scenes,
            renderers: HashMap::new(),
            techniques: HashMap::new(),
            counts: Counts::default(),
        })
    }

    /// Draws the next case of the seeded sequence.
    pub fn draw(&mut self) -> Case {
        let rng = &mut self.rng;
        let techniques = registry::techniques();
        // In turn, so that every technique gets its share however few the cases.
        let info = techniques[(self.next_case % techniques.len() as u64) as usize];
        let scene = *rng.pick(SCENES);
        let (width, height) = *rng.pick(SIZES);
        let (light_kind, light) = random_light(&self.scenes[scene].0, rng);
        let specs = (info.params)();
        let (params, capped) = draw_params(info.id, &specs, rng, self.ranges, width * height);
        let cost = estimate(info.id, &params, (width * height) as f64);
        let number = self.next_case;
        self.next_case += 1;
        Case {
            number,
            technique: info.id,
            params,
            scene,
            light_kind,
            light,
            width,
            height,
            cost,
            capped,
        }
    }

    /// Draws and runs one case, adds it to [`Stress::counts`] and returns it with its result.
    pub fn step(&mut self) -> (Case, Result<Outcome, Finding>) {
        let case = self.draw();
        let start = std::time::Instant::now();
        let result = std::panic::catch_unwind(AssertUnwindSafe(|| self.run(&case)))
            .unwrap_or_else(|panic| {
                let message = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "a panic without a message".into());
                // The technique may be half-updated: start it afresh.
                self.techniques.remove(case.technique);
                Err(format!("panicked: {message}"))
            })
            .map_err(|problem| Finding {
                case: case.to_string(),
                problem,
            });
        self.counts
            .add(&case, &result, start.elapsed().as_secs_f64());
        (case, result)
    }

    fn run(&mut self, case: &Case) -> Result<Outcome, String> {
        let gpu = self.gpu.clone();
        let info = registry::find(case.technique).map_err(|e| e.to_string())?;
        let technique = match self.techniques.entry(case.technique) {
            std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::hash_map::Entry::Vacant(e) => {
                e.insert((info.create)(&gpu).map_err(|e| e.to_string())?)
            }
        };
        for (name, value) in &case.params {
            // Every value was drawn inside its declared range: refusing one is a finding.
            technique
                .set_param(name, value.clone())
                .map_err(|e| format!("refused an in-range value: {e}"))?;
        }
        let renderer = match self.renderers.entry((case.width, case.height)) {
            std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::hash_map::Entry::Vacant(e) => {
                e.insert(Renderer::new(&gpu, case.width, case.height).map_err(|e| e.to_string())?)
            }
        };
        let (scene, scene_gpu) = &self.scenes[case.scene];
        let camera = scene.camera;
        let prepared = technique.prepare(&gpu, &renderer.inputs(scene_gpu, &camera, &case.light));
        if let Err(e) = prepared {
            return classify(RenderError::Technique(e), &gpu, &mut self.techniques, case);
        }
        let moved = crate::orbit_camera(&camera, 0);
        for (k, camera) in [camera, moved].iter().enumerate() {
            if k == 0 {
                technique.invalidate_cache();
            }
            if let Err(e) =
                renderer.render(scene_gpu, camera, &case.light, technique.as_mut(), None)
            {
                return classify(e, &gpu, &mut self.techniques, case);
            }
            self.counts.frames += 1;
            let visibility = renderer.read_visibility().map_err(|e| e.to_string())?;
            let s = softshadow_metrics::stability(&visibility);
            if s.nan + s.inf + s.out_of_range > 0 {
                return Err(format!(
                    "frame {} wrote {} NaN, {} Inf and {} out-of-range visibility values",
                    k + 1,
                    s.nan,
                    s.inf,
                    s.out_of_range
                ));
            }
        }
        Ok(Outcome::Ok)
    }
}

/// A failed frame is a clear error when it is a technique's own one-line refusal or a device
/// out of memory (the technique is then rebuilt); a validation error is a finding.
fn classify(
    error: RenderError,
    gpu: &softshadow_core::Gpu,
    techniques: &mut HashMap<&'static str, Box<dyn ShadowTechnique>>,
    case: &Case,
) -> Result<Outcome, String> {
    let _ = gpu.take_errors();
    techniques.remove(case.technique);
    let message = error.to_string();
    let validation = matches!(
        error,
        RenderError::Gpu(GpuError::Validation(_))
            | RenderError::Technique(TechniqueError::Gpu(GpuError::Validation(_)))
    );
    if validation {
        return Err(format!("wgpu validation error: {message}"));
    }
    if message.trim().is_empty() || message.contains('\n') {
        return Err(format!("an error that is not one clear line: {message:?}"));
    }
    Ok(Outcome::ClearError(message))
}

/// A random light for `scene` (see [`LightKind`]).
pub fn random_light(scene: &Scene, rng: &mut Rng) -> (LightKind, AreaLight) {
    let casters = scene.bounds(|i| i.casts_shadow);
    let all = scene.bounds(|_| true);
    let (center, extent) = if all.is_empty() {
        (Vec3::ZERO, 1.0)
    } else {
        (
            (all.min + all.max) * 0.5,
            (all.max - all.min).max_element().max(1e-3),
        )
    };
    let kinds = [
        LightKind::Ordinary,
        LightKind::ZeroWidth,
        LightKind::Aspect1000,
        LightKind::TouchingCaster,
        LightKind::AnyDirection,
        LightKind::UpParallel,
    ];
    let kind = *rng.pick(&kinds);
    let mut width = rng.range(0.0, 2.0) as f32;
    let mut height = rng.range(0.0, 2.0) as f32;
    let above = |rng: &mut Rng| {
        center
            + Vec3::new(
                rng.range(-0.5, 0.5) as f32 * extent,
                rng.range(0.5, 2.0) as f32 * extent,
                rng.range(-0.5, 0.5) as f32 * extent,
            )
    };
    let aim = |from: Vec3, rng: &mut Rng| {
        let target = center
            + Vec3::new(
                rng.range(-0.3, 0.3) as f32,
                0.0,
                rng.range(-0.3, 0.3) as f32,
            ) * extent;
        (target - from).try_normalize().unwrap_or(Vec3::NEG_Y)
    };
    let random_unit = |rng: &mut Rng| loop {
        let v = Vec3::new(
            rng.range(-1.0, 1.0) as f32,
            rng.range(-1.0, 1.0) as f32,
            rng.range(-1.0, 1.0) as f32,
        );
        if let Some(n) = v.try_normalize() {
            break n;
        }
    };
    let (light_center, direction, up) = match kind {
        LightKind::Ordinary | LightKind::ZeroWidth | LightKind::Aspect1000 => {
            let c = above(rng);
            (c, aim(c, rng), Vec3::Z)
        }
        LightKind::TouchingCaster => {
            let top = if casters.is_empty() {
                center
            } else {
                Vec3::new(
                    rng.range(casters.min.x as f64, casters.max.x as f64) as f32,
                    casters.max.y,
                    rng.range(casters.min.z as f64, casters.max.z as f64) as f32,
                )
            };
            let gap = 10f64.powf(rng.range(-5.0, -2.0)) as f32;
            (top + Vec3::Y * gap, Vec3::NEG_Y, Vec3::Z)
        }
        LightKind::AnyDirection => {
            let c = center + random_unit(rng) * extent * rng.range(0.2, 2.0) as f32;
            (c, random_unit(rng), random_unit(rng))
        }
        LightKind::UpParallel => {
            let c = above(rng);
            let d = aim(c, rng);
            (c, d, if rng.chance(0.5) { d } else { -d })
        }
    };
    match kind {
        LightKind::ZeroWidth => {
            width = 0.0;
            if rng.chance(0.5) {
                height = 0.0;
            }
        }
        LightKind::Aspect1000 => {
            let long = rng.range(0.1, 4.0) as f32;
            if rng.chance(0.5) {
                (width, height) = (long, long / 1000.0);
            } else {
                (width, height) = (long / 1000.0, long);
            }
        }
        _ => {}
    }
    let light = AreaLight {
        center: light_center,
        direction,
        up,
        width,
        height,
        intensity: 1.0,
    };
    (kind, light)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn int_spec(specs: &[ParamSpec], name: &str) -> Option<(i64, i64)> {
        match specs.iter().find(|s| s.name == name)?.kind {
            ParamKind::Int { min, max, .. } => Some((min, max)),
            _ => None,
        }
    }

    #[test]
    fn cost_model_reads_only_declared_integer_parameters() {
        for info in registry::techniques() {
            let specs = (info.params)();
            let knobs = cost_knobs(info.id);
            assert!(!knobs.is_empty(), "{}: no cost knobs", info.id);
            for knob in knobs {
                assert!(
                    int_spec(&specs, knob).is_some(),
                    "{}: cost knob `{knob}` is not a declared integer parameter",
                    info.id
                );
            }
            let defaults: Vec<_> = specs
                .iter()
                .map(|s| (s.name.to_string(), s.default_value()))
                .collect();
            let cost = estimate(info.id, &defaults, 48.0 * 48.0);
            assert_ne!(cost.dominant, "not modelled", "{}", info.id);
            assert!(
                cost.seconds.is_finite() && cost.seconds > 0.0,
                "{}: {cost}",
                info.id
            );
        }
    }

    /// The case that held the first 30-minute run for over 15 minutes is over the cap, and
    /// clamping brings it under by halving its knobs, never below their minimum.
    #[test]
    fn the_reference_at_64_squared_samples_of_4096_maps_is_clamped_under_the_budget() {
        let params = vec![
            ("samples_per_axis".to_string(), ParamValue::Int(64)),
            ("shadow_map_size".to_string(), ParamValue::Int(4096)),
        ];
        let cost = estimate("reference", &params, 48.0 * 48.0);
        assert!(!cost.fits(), "{cost}");
        let specs = (registry::find("reference").unwrap().params)();
        let mut clamped = params.clone();
        let halved = clamp("reference", &specs, &mut clamped, 48.0 * 48.0);
        assert!(!halved.is_empty());
        assert!(
            estimate("reference", &clamped, 48.0 * 48.0).fits(),
            "{clamped:?}"
        );
        for (name, value) in &clamped {
            let (min, _) = int_spec(&specs, name).unwrap();
            let ParamValue::Int(v) = value else {
                panic!("{value:?}")
            };
            assert!(*v >= min && *v < 4096, "{name} = {v}");
        }
    }

    /// The PDSM case that took 137 s in the 30-minute rerun (1 sample, a 4096² map, a 1752²
    /// PDSM: the map edge, not the samples, made it slow) is over the cap; the paper's settings
    /// (64 samples, 512² maps and PDSM, 3.7 s measured) are under it.
    #[test]
    fn pdsm_cost_grows_with_the_map_edge() {
        let specs = (registry::find("pdsm").unwrap().params)();
        let with = |samples: i64, map: i64, pdsm: i64| -> Vec<(String, ParamValue)> {
            specs
                .iter()
                .map(|s| {
                    let value = match s.name {
                        "samples" => ParamValue::Int(samples),
                        "shadow_map_size" => ParamValue::Int(map),
                        "pdsm_size" => ParamValue::Int(pdsm),
                        "memory_budget_mib" => ParamValue::Int(1 << 14),
                        _ => s.default_value(),
                    };
                    (s.name.to_string(), value)
                })
                .collect()
        };
        let slow = estimate("pdsm", &with(1, 4096, 1752), 48.0 * 48.0);
        assert!(!slow.fits() && slow.seconds > 100.0, "{slow}");
        let paper = estimate("pdsm", &with(64, 512, 512), 48.0 * 48.0);
        assert!(paper.seconds > 3.7 && paper.fits(), "{paper}");
    }

    /// Capped draws fit the budget, yet every integer range still reaches both of its ends over
    /// a few thousand draws: the cap separates expensive ends, it does not remove them.
    #[test]
    fn capped_draws_fit_and_still_reach_both_ends_of_every_range() {
        let mut rng = Rng::new(7);
        for info in registry::techniques() {
            let specs = (info.params)();
            let mut seen: HashMap<String, (bool, bool)> = HashMap::new();
            let mut capped = 0;
            for _ in 0..3000 {
                let (params, cap) = draw_params(info.id, &specs, &mut rng, Ranges::Full, 48 * 48);
                let cost = estimate(info.id, &params, 48.0 * 48.0);
                match &cap {
                    Capped::No | Capped::Redrawn { .. } => {
                        assert!(cost.fits(), "{}: {cost} after {cap:?}", info.id)
                    }
                    // Clamping stops when every knob is at its minimum.
                    Capped::Clamped { .. } => capped += 1,
                }
                for (name, value) in &params {
                    if let (Some((min, max)), ParamValue::Int(v)) = (int_spec(&specs, name), value)
                    {
                        assert!((min..=max).contains(v), "{}: {name} = {v}", info.id);
                        let e = seen.entry(name.clone()).or_default();
                        e.0 |= *v == min;
                        e.1 |= *v == max;
                    }
                }
            }
            assert!(capped < 3000, "{}: every draw clamped", info.id);
            for (name, (low, high)) in seen {
                assert!(
                    low && high,
                    "{}: `{name}` never drawn at its minimum ({low}) or maximum ({high})",
                    info.id
                );
            }
        }
    }
}
