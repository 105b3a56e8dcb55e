//! The `hard` descriptor: what the workspace knows about the technique ([`TechniqueInfo`]):
//! its parameters, requirements, shaders, cost model, error bounds and overview settings.

use softshadow_core::{
    cost::rates::DEPTH_TEXEL,
    expectations::{at_most, known_failure, ErrorMetric::*, StiffClass::*},
    Cost, CostModel, Expectations, LightSupport, TechniqueInfo,
};

use crate::{Hard, HardSettings, ID, SHADERS};

/// The registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo::new(
        ID,
        "Hard shadows: one shadow map from the light centre (cost floor)",
        "Williams 1978",
        HardSettings::param_specs(),
        |gpu| Ok(Box::new(Hard::new(gpu, HardSettings::default())?)),
    )
    .with_shaders(SHADERS)
    // A point at the light's centre: of the rectangle, the disk, the sphere, the spot's source;
    // the sun: cascaded orthographic maps (core's `cascades`).
    .with_light_kinds(LightSupport::all())
    .with_cost(CostModel::new(&["shadow_map_size"], |q| {
        let texels = q.number("shadow_map_size").powi(2);
        // GPU memory (bytes); its uniforms (about 300 bytes: 1.6 % at 64²) are left to the
        // tolerance.
        let gpu_bytes =
            // The shadow map (Depth32Float).
            4.0 * texels
            // The depth pass's view slots (core::shadow_map::DepthMapRenderer: 16 x 256).
            + 4096.0;
        Cost::seconds(texels * DEPTH_TEXEL, "shadow_map_size²").with_gpu_memory(gpu_bytes, 0.02)
    }))
    .with_expectations(expectations())
    .with_overview(&[("shadow_map_size", &["512", "2048"])])
}

/// Bounds against the exact answer (`softshadow_core::expectations`, docs/STABILITY.md). A hard
/// shadow is wrong over every penumbra: its bounds are loose where the penumbra is wide, and
/// where drawing no shadow would be as good it is a known failure.
/// Every stiff case gets the rule for its class (the loosest bound stated on a case of the class,
/// with the case it was measured on beside it) unless it is named.
fn expectations() -> Expectations {
    Expectations::new(&[
        ("stiff-contact", at_most(MaeShadowed, 0.45, 0.1774)),
        (
            "stiff-near-light",
            known_failure(MaeShadowed, 0.7495, 0.075),
        ),
        ("stiff-wide-light", known_failure(MaeShadowed, 0.052, 0.006)),
        (
            "stiff-depth-range",
            known_failure(MaeShadowed, 0.7478, 0.075),
        ),
        (
            "stiff-zero-thickness",
            known_failure(MaeShadowed, 0.217, 0.022),
        ),
        ("stiff-partly-outside", at_most(MaeShadowed, 0.32, 0.1950)),
        (
            "stiff-aspect-100",
            known_failure(MaeShadowed, 0.4277, 0.043),
        ),
        ("stiff-behind-light", at_most(MaeShadowed, 0.38, 0.1505)),
        ("stiff-light-up", at_most(MaeShadowed, 0.19, 0.0733)),
        (
            "stiff-light-leak",
            known_failure(MaeShadowed, 0.4754, 0.048),
        ),
        // Worse than no shadow (0.3359): the penumbrae are wider than the casters.
        (
            "stiff-large-light",
            known_failure(MaeShadowed, 0.4295, 0.043),
        ),
        // A roof thinner than the depth bias: its underside (facing away from the light, so
        // dark in the image whatever V says) reads lit. The irradiance error is small there.
        ("stiff-thin-roof", known_failure(MaeShadowed, 0.1529, 0.015)),
        // The ground inside the sphere is unreached (V = 0); halfway to no shadow (0.3657).
        ("stiff-sphere-in-ground", at_most(MaeShadowed, 0.25, 0.1438)),
        // Halfway to the opaque quad's answer (0.2899: no alpha test in the depth pass).
        ("stiff-masked-checker", at_most(MaeShadowed, 0.23, 0.1712)),
        ("atty-square", at_most(MaeShadowed, 0.32, 0.2063)),
        (
            "blob-floating:triangles=20000",
            at_most(MaeShadowed, 0.35, 0.1511),
        ),
    ])
    .with_rules(&[
        (Unshadowed, at_most(MaxAbs, 1e-6, 0.0)), // stiff-no-occluder
        (PointLight, at_most(MaeShadowed, 0.001, 0.0)), // stiff-point-light
        (VanishingDistance, at_most(MaeShadowed, 0.5, 0.2915)), // stiff-tiny-patches
        (LightShape, at_most(MaeShadowed, 0.39, 0.2252)), // stiff-grazing
        (OccluderOverlap, at_most(MaeShadowed, 0.36, 0.2539)), // stiff-fusion
        (LightPlane, at_most(MaeShadowed, 0.4, 0.1979)), // stiff-receiver-behind-light
        (ThinGeometry, at_most(MaeShadowed, 0.33, 0.2063)), // stiff-degenerate
    ])
}
