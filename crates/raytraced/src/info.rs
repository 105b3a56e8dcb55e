//! The `raytraced` descriptor: what the workspace knows about the technique ([`TechniqueInfo`]):
//! its parameters, requirements, shaders, cost model, error bounds and overview settings.

use softshadow_core::{
    cost::rates::PIXEL_ITERATION,
    expectations::{at_most, ErrorMetric::*},
    Cost, CostModel, Expectations, TechniqueInfo,
};

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
/// default settings (4 rays per pixel, spatial filter on, temporal accumulation on but without a
/// history: the stiff suite draws one frame with the caches dropped), 64², the exact answer a
/// 16 x 16 ray cast or the closed form. Each bound is 1.5x the measured value plus 0.005, or just
/// under the all-lit or `hard` answer where that is lower (stiff-wide-light). Measured with
/// `cargo test --workspace --test gpu raytraced::measure -- --ignored --nocapture`.
fn expectations() -> Expectations {
    Expectations::new(&[
        ("stiff-contact", at_most(MaeShadowed, 0.087, 0.0547)),
        ("stiff-near-light", at_most(MaeShadowed, 0.036, 0.0211)),
        ("stiff-point-light", at_most(MaeShadowed, 0.001, 0.0)),
        ("stiff-wide-light", at_most(MaeShadowed, 0.024, 0.0133)),
        ("stiff-grazing", at_most(MaeShadowed, 0.131, 0.0846)),
        ("stiff-depth-range", at_most(MaeShadowed, 0.04, 0.0235)),
        ("stiff-zero-thickness", at_most(MaeShadowed, 0.104, 0.0666)),
        ("stiff-partly-outside", at_most(MaeShadowed, 0.129, 0.0830)),
        ("stiff-no-occluder", at_most(MaxAbs, 1e-6, 0.0)),
        ("stiff-aspect-100", at_most(MaeShadowed, 0.137, 0.0884)),
        ("stiff-tiny-patches", at_most(MaeShadowed, 0.049, 0.0298)),
        ("stiff-degenerate", at_most(MaeShadowed, 0.101, 0.0645)),
        ("stiff-behind-light", at_most(MaeShadowed, 0.101, 0.0643)),
        ("stiff-light-up", at_most(MaeShadowed, 0.063, 0.0390)),
        ("stiff-fusion", at_most(MaeShadowed, 0.105, 0.0668)),
        ("stiff-light-leak", at_most(MaeShadowed, 0.144, 0.0929)),
        ("atty-square", at_most(MaeShadowed, 0.101, 0.0645)),
        (
            "blob-floating:triangles=20000",
            at_most(MaeShadowed, 0.067, 0.0417),
        ),
    ])
}
