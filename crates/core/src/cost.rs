//! What running a technique is estimated to cost, from its declared parameters: the model the
//! random-parameter stress uses to keep each case within a time and memory budget
//! (docs/STABILITY.md, "Random parameter stress"). Each technique states its own model
//! ([`crate::TechniqueInfo::cost`]) from the device rates below and rates of its own.
//!
//! The model needs the order of magnitude, not a prediction: the rates are lavapipe's on the
//! 2-core machine the project runs on, rounded up.

use std::{borrow::Cow, fmt, sync::Arc};

use crate::ParamValue;

/// Rates of lavapipe on the 2-core machine (release build), from one `workbench bench --size
/// 48x48 --frames 1 --warmup 0 --no-error` run per technique near the large ends of its ranges,
/// rounded up.
pub mod rates {
    /// Seconds per depth-map texel rendered (`hard` at 4096²: 11.6 ns; `reference` 8² maps of
    /// 2048²: 12.4 ns; `adaptive` 128 maps of 1024²: 7.9 ns).
    pub const DEPTH_TEXEL: f64 = 12e-9;
    /// Seconds per depth texel of a peeled layer and of a hierarchy's linearisation (`bitmask`,
    /// 4 layers of 4096²: 24 ns).
    pub const LAYER_TEXEL: f64 = 25e-9;
    /// Seconds per texel per MSSM level (`bitmask`, 4 layers of 4096², 12 levels: 44 ns).
    pub const HIERARCHY_TEXEL: f64 = 45e-9;
    /// Seconds per iteration of a per-pixel loop (PCSS samples, gathers, filters).
    pub const PIXEL_ITERATION: f64 = 5e-9;
    /// Seconds a frame costs whatever the parameters (passes, submission, readback).
    pub const FRAME: f64 = 0.05;
}

/// The parameters of one case and the camera pixels it renders, as a cost model reads them.
#[derive(Clone, Copy, Debug)]
pub struct CostQuery<'a> {
    /// Every parameter of the case (a drawn value for each declared one).
    pub params: &'a [(String, ParamValue)],
    /// Camera pixels of one frame.
    pub pixels: f64,
}

impl CostQuery<'_> {
    /// The value of number parameter `name`, or 1 where there is none (so a product of knobs
    /// does not vanish).
    pub fn number(&self, name: &str) -> f64 {
        self.params
            .iter()
            .find(|(n, _)| n == name)
            .and_then(|(_, v)| v.as_f64())
            .unwrap_or(1.0)
    }

    /// Whether boolean parameter `name` is on.
    pub fn flag(&self, name: &str) -> bool {
        self.params
            .iter()
            .any(|(n, v)| n == name && *v == ParamValue::Bool(true))
    }

    /// Whether choice parameter `name` is `option`.
    pub fn choice(&self, name: &str, option: &str) -> bool {
        self.params
            .iter()
            .any(|(n, v)| n == name && matches!(v, ParamValue::Choice(c) if c == option))
    }
}

/// What a case is estimated to cost.
#[derive(Clone, Debug, PartialEq)]
pub struct Cost {
    /// Estimated wall time of two frames (the full work, then one with only the camera moved),
    /// seconds, without the per-frame overhead ([`rates::FRAME`]).
    pub seconds: f64,
    /// Host memory of a precompute, bytes (0 for techniques without one).
    pub bytes: f64,
    /// GPU memory the technique holds at its peak: the buffers, textures and acceleration
    /// structures it creates, bytes ([`crate::memory`]; 0: not modelled).
    pub gpu_bytes: f64,
    /// How far, as a fraction of [`Cost::gpu_bytes`], the memory counted may differ from it
    /// (uniform buffers, padding and the small resources the model leaves out).
    pub gpu_tolerance: f64,
    /// The term that dominates, in the parameters' names (what a cap says it was for).
    pub dominant: Cow<'static, str>,
}

impl Cost {
    /// `seconds` of GPU work and no host memory, dominated by `dominant`.
    pub fn seconds(seconds: f64, dominant: &'static str) -> Self {
        Self {
            seconds,
            bytes: 0.0,
            gpu_bytes: 0.0,
            gpu_tolerance: 0.0,
            dominant: Cow::Borrowed(dominant),
        }
    }

    /// With `bytes` of GPU memory held at the peak, counted within `tolerance` (a fraction).
    pub fn with_gpu_memory(mut self, bytes: f64, tolerance: f64) -> Self {
        self.gpu_bytes = bytes;
        self.gpu_tolerance = tolerance;
        self
    }
}

impl fmt::Display for Cost {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "about {:.1} s, {:.0} MiB host, {:.0} MiB GPU ({})",
            self.seconds,
            self.bytes / (1u64 << 20) as f64,
            self.gpu_bytes / (1u64 << 20) as f64,
            self.dominant
        )
    }
}

/// The estimate function of a [`CostModel`].
pub type EstimateFn = dyn Fn(&CostQuery<'_>) -> Cost + Send + Sync;

/// How a technique's cost grows with its parameters.
#[derive(Clone)]
pub struct CostModel {
    /// The integer parameters whose size drives the cost, largest effect first: what a cap halves
    /// when a case is over budget. Each must be a declared integer parameter (tested for every
    /// registered technique).
    pub knobs: Vec<Cow<'static, str>>,
    /// The estimate of two frames from the case's parameters.
    pub estimate: Arc<EstimateFn>,
}

impl CostModel {
    /// A model from `knobs` and an estimate function.
    pub fn new(
        knobs: &[&'static str],
        estimate: impl Fn(&CostQuery<'_>) -> Cost + Send + Sync + 'static,
    ) -> Self {
        Self {
            knobs: knobs.iter().map(|k| Cow::Borrowed(*k)).collect(),
            estimate: Arc::new(estimate),
        }
    }

    /// No model: every case is estimated at zero beyond the per-frame overhead (a technique
    /// whose cost does not depend on its parameters, or a file nobody modelled).
    pub fn unmodelled() -> Self {
        Self::new(&[], |_| Cost::seconds(0.0, "not modelled"))
    }

    /// The estimate for `params` at `pixels` camera pixels.
    pub fn estimate(&self, params: &[(String, ParamValue)], pixels: f64) -> Cost {
        (self.estimate)(&CostQuery { params, pixels })
    }
}

impl fmt::Debug for CostModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CostModel")
            .field("knobs", &self.knobs)
            .finish_non_exhaustive()
    }
}
