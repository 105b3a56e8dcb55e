//! The `raytraced` descriptor: what the workspace knows about the technique ([`TechniqueInfo`]):
//! its parameters, requirements, shaders, cost model, error bounds and overview settings.

use softshadow_core::{cost::rates::PIXEL_ITERATION, Cost, CostModel, Expectations, TechniqueInfo};

use crate::{Raytraced, RaytracedSettings, ID, SHADERS};

/// Seconds per shadow ray on lavapipe (about 0.5-1 M rays/s on 2 cores, docs/BENCHMARKS.md).
const RAY: f64 = 2e-6;

/// The registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo::new(
        ID,
        "Ray-traced soft shadows: a few ray queries per pixel toward the light and a SIGMA / FidelityFX-style denoiser",
        "ray queries; denoiser after NVIDIA SIGMA and AMD FidelityFX Denoiser (shadows)",
        RaytracedSettings::param_specs(),
        |gpu| Ok(Box::new(Raytraced::new(gpu, RaytracedSettings::default())?)),
    )
    .with_requirements(Raytraced::requirements_static())
    .with_shaders(SHADERS)
    .with_cost(CostModel::new(&["rays_per_pixel"], |q| {
        let rays = 2.0 * q.pixels * q.number("rays_per_pixel") * RAY;
        // The filter's 7 x 7 taps and the penumbra estimate's 9 x 9.
        let denoise = 2.0 * q.pixels * 130.0 * PIXEL_ITERATION;
        Cost::seconds(rays + denoise, "rays_per_pixel")
    }))
    .with_expectations(expectations())
    .with_overview(&[("rays_per_pixel", &["1", "4"])])
}

/// Bounds against the exact answer (`softshadow_core::expectations`, docs/STABILITY.md), at the
/// default settings: 4 rays per pixel, temporal accumulation (which the stiff suite's single
/// frames do not reach: one frame each) and the spatial filter.
fn expectations() -> Expectations {
    Expectations::new(&[])
}
