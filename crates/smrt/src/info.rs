//! The `smrt` descriptor: what the workspace knows about the technique ([`TechniqueInfo`]):
//! its parameters, requirements, shaders, cost model, error bounds and overview settings.

use softshadow_core::{
    cost::rates::{DEPTH_TEXEL, PIXEL_ITERATION},
    expectations::{at_most, known_failure, ErrorMetric::*},
    Cost, CostModel, Expectations, TechniqueInfo,
};

use crate::{Smrt, SmrtSettings, ID, SHADERS};

/// The registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo::new(
        ID,
        "Shadow-map ray tracing: rays to jittered light points marched through one shadow map, behind-occluder extrapolation (Unreal Engine 5's SMRT)",
        "Unreal Engine 5 virtual shadow maps, SMRT (no paper)",
        SmrtSettings::param_specs(),
        |gpu| Ok(Box::new(Smrt::new(gpu, SmrtSettings::default())?)),
    )
    .with_shaders(SHADERS)
    .with_cost(CostModel::new(
        &["shadow_map_size", "ray_count", "samples_per_ray"],
        |q| {
            // The map, then at most rays x samples texel reads per pixel (a ray stops at its
            // first hit, so lit pixels pay all of them).
            let map = q.number("shadow_map_size").powi(2) * DEPTH_TEXEL;
            let steps = q.number("ray_count") * q.number("samples_per_ray");
            let trace = q.pixels * steps * PIXEL_ITERATION;
            Cost::seconds(map + trace, "shadow_map_size²")
        },
    ))
    .with_expectations(expectations())
    .with_overview(&[("ray_count", &["8", "32"])])
}

/// Bounds against the exact answer (`softshadow_core::expectations`, docs/STABILITY.md).
fn expectations() -> Expectations {
    Expectations::new(&[
        ("stiff-contact", at_most(MaeShadowed, 0.12, 0.05)),
        ("stiff-near-light", at_most(MaeShadowed, 0.2, 0.08)),
        ("stiff-point-light", at_most(MaeShadowed, 0.0027, 0.0011)),
        ("stiff-wide-light", at_most(MaeShadowed, 0.0092, 0.0037)),
        ("stiff-grazing", at_most(MaeShadowed, 0.15, 0.06)),
        (
            "stiff-depth-range",
            known_failure(MaeShadowed, 0.2522, 0.025),
        ),
        ("stiff-zero-thickness", at_most(MaeShadowed, 0.087, 0.0347)),
        (
            "stiff-partly-outside",
            known_failure(MaeShadowed, 0.4217, 0.042),
        ),
        ("stiff-no-occluder", at_most(MaxAbs, 1e-6, 0.0)),
        ("stiff-aspect-100", at_most(MaeShadowed, 0.14, 0.0548)),
        ("stiff-tiny-patches", at_most(MaeShadowed, 0.22, 0.1314)),
        ("stiff-degenerate", at_most(MaeShadowed, 0.082, 0.0327)),
        ("stiff-behind-light", at_most(MaeShadowed, 0.061, 0.0241)),
        ("stiff-light-up", at_most(MaeShadowed, 0.027, 0.0108)),
        ("stiff-fusion", at_most(MaeShadowed, 0.13, 0.0508)),
        ("stiff-light-leak", at_most(MaeShadowed, 0.36, 0.1)),
        ("atty-square", at_most(MaeShadowed, 0.082, 0.0327)),
        (
            "blob-floating:triangles=20000",
            at_most(MaeShadowed, 0.12, 0.0829),
        ),
    ])
}
