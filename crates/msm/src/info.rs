//! The `msm` descriptor: what the workspace knows about the technique ([`TechniqueInfo`]):
//! its parameters, requirements, shaders, cost model, error bounds and overview settings.

use softshadow_core::{
    cost::rates::{DEPTH_TEXEL, LAYER_TEXEL, PIXEL_ITERATION},
    expectations::{at_most, known_failure, ErrorMetric::*, StiffClass::*},
    Cost, CostModel, Expectations, LightKind, LightSupport, TechniqueInfo,
};

use crate::{Msm, MsmSettings, ID, SHADERS};

/// The registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo::new(
        ID,
        "Moment soft shadows: moment shadow map (4 moments, Hamburger) or EVSM, mip-filtered blocker search and penumbra filter",
        "Peters and Klein 2015; Peters et al. 2016",
        MsmSettings::param_specs(),
        |gpu| Ok(Box::new(Msm::new(gpu, MsmSettings::default())?)),
    )
    .with_shaders(SHADERS)
    // A planar light of the disk's diameter (`light_half` = (r, r)); a sphere as its disk in the
    // light plane; the sun through core's cascades, search and filter in world units (`sun.rs`).
    .with_light_kinds(LightSupport::all())
    // On atty-square with its light made each kind (`AreaLight::as_kind`), defaults, 64²
    // (measured beside each; `hard` measured 0.206 rect, 0.185 disk and spot, 0.156 sphere).
    .with_light_kind_bounds(&[
        (LightKind::Rect, at_most(MaeShadowed, 0.049, 0.0314)),
        (LightKind::Disk, at_most(MaeShadowed, 0.064, 0.0412)),
        (LightKind::Sphere, at_most(MaeShadowed, 0.055, 0.0355)),
        (LightKind::Spot, at_most(MaeShadowed, 0.064, 0.0412)),
        // The sun 10 degrees wide, through the cascades (`sun.rs`); `hard` measured 0.114.
        (LightKind::Sun, at_most(MaeShadowed, 0.05, 0.0325)),
    ])
    .with_cost(CostModel::new(&["shadow_map_size", "filter_taps"], |q| {
        // The depth map, the moment map and its mips (4/3 of level 0), then two filtered
        // lookups per pixel of taps² trilinear taps (8 texels each).
        let texels = q.number("shadow_map_size").powi(2);
        let maps = texels * (DEPTH_TEXEL + 4.0 / 3.0 * LAYER_TEXEL);
        let taps = q.number("filter_taps").powi(2);
        let filter = 2.0 * q.pixels * taps * 8.0 * PIXEL_ITERATION;
        // GPU memory (bytes); the uniforms (about 300 bytes) are left to the tolerance.
        let gpu_bytes =
            // The shadow map (Depth32Float).
            4.0 * texels
            // The moment map (Rgba32Float, every variant) and its mip chain: 4/3 of level 0.
            + 16.0 * 4.0 / 3.0 * texels
            // The depth pass's view slots (core::shadow_map::DepthMapRenderer: 16 x 256).
            + 4096.0;
        Cost::seconds(maps + filter, "shadow_map_size²").with_gpu_memory(gpu_bytes, 0.01)
    }))
    .with_expectations(expectations())
    .with_overview(&[("variant", &["msm4", "evsm2", "evsm4"])])
}

/// Bounds against the exact answer (`softshadow_core::expectations`, docs/STABILITY.md).
/// Every stiff case gets the rule for its class (the loosest bound stated on a case of the class,
/// with the case it was measured on beside it) unless it is named.
fn expectations() -> Expectations {
    Expectations::new(&[
        ("stiff-contact", at_most(MaeShadowed, 0.12, 0.0704)),
        ("stiff-wide-light", at_most(MaeShadowed, 0.0092, 0.0037)),
        (
            "stiff-depth-range",
            known_failure(MaeShadowed, 0.2522, 0.025),
        ),
        ("stiff-zero-thickness", at_most(MaeShadowed, 0.027, 0.0109)),
        (
            "stiff-partly-outside",
            known_failure(MaeShadowed, 0.4139, 0.042),
        ),
        ("stiff-aspect-100", at_most(MaeShadowed, 0.11, 0.0468)),
        ("stiff-tiny-patches", at_most(MaeShadowed, 0.1, 0.0439)),
        ("stiff-behind-light", at_most(MaeShadowed, 0.032, 0.0128)),
        ("stiff-light-up", at_most(MaeShadowed, 0.013, 0.0053)),
        ("stiff-fusion", at_most(MaeShadowed, 0.11, 0.0453)),
        ("stiff-large-light", at_most(MaeShadowed, 0.12, 0.0489)),
        // A roof thinner than the depth bias: its underside (facing away from the light, so
        // dark in the image whatever V says) reads lit. The irradiance error is small there.
        ("stiff-thin-roof", known_failure(MaeShadowed, 0.1828, 0.018)),
        // No umbra and a faint penumbra: drawing no shadow (0.0124) is as good.
        ("stiff-disk-huge", known_failure(MaeShadowed, 0.0124, 0.002)),
        ("stiff-spot-narrow", at_most(MaeShadowed, 0.061, 0.0241)),
        // Casters 0.1-0.25 under a light 1.0 across: no shadow drawn (the all-lit answer's error).
        (
            "stiff-sphere-in-ground",
            known_failure(MaeShadowed, 0.3657, 0.037),
        ),
        ("atty-square", at_most(MaeShadowed, 0.078, 0.0314)),
        (
            "blob-floating:triangles=20000",
            at_most(MaeShadowed, 0.13, 0.1076),
        ),
    ])
    .with_rules(&[
        (Unshadowed, at_most(MaxAbs, 1e-6, 0.0)), // stiff-no-occluder
        (PointLight, at_most(MaeShadowed, 0.0027, 0.0011)), // stiff-point-light
        (VanishingDistance, at_most(MaeShadowed, 0.2, 0.1565)), // stiff-near-light
        (LightShape, at_most(MaeShadowed, 0.15, 0.0878)), // stiff-grazing
        (OccluderOverlap, at_most(MaeShadowed, 0.32, 0.2035)), // stiff-light-leak
        (LightPlane, at_most(MaeShadowed, 0.1, 0.0409)), // stiff-receiver-behind-light
        (ThinGeometry, at_most(MaeShadowed, 0.078, 0.0314)), // stiff-degenerate
    ])
}
