//! The `pcss` descriptor: what the workspace knows about the technique ([`TechniqueInfo`]):
//! its parameters, requirements, shaders, cost model, error bounds and overview settings.

use softshadow_core::{
    cost::rates::{DEPTH_TEXEL, PIXEL_ITERATION},
    expectations::{at_most, known_failure, ErrorMetric::*, StiffClass::*},
    Cost, CostModel, Expectations, LightKind, LightSupport, TechniqueInfo,
};

use crate::{Pcss, PcssSettings, TemporalTargets, ID, SHADERS};

/// The registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo::new(
        ID,
        "PCSS: blocker search, penumbra estimate, percentage-closer filtering",
        "Fernando 2005",
        PcssSettings::param_specs(),
        |gpu| Ok(Box::new(Pcss::new(gpu, PcssSettings::default())?)),
    )
    .with_shaders(SHADERS)
    // A planar light of the disk's diameter (`light_half` = (r, r)); a sphere as its disk in the
    // light plane; the sun through core's cascades with sizes in world units (`sun.rs`).
    .with_light_kinds(LightSupport::all())
    // On atty-square with its light made each kind (`AreaLight::as_kind`), defaults, 64²
    // (measured beside each; `hard` measured 0.206 rect, 0.185 disk and spot, 0.156 sphere).
    .with_light_kind_bounds(&[
        (LightKind::Rect, at_most(MaeShadowed, 0.051, 0.0327)),
        (LightKind::Disk, at_most(MaeShadowed, 0.025, 0.016)),
        (LightKind::Sphere, at_most(MaeShadowed, 0.059, 0.0383)),
        (LightKind::Spot, at_most(MaeShadowed, 0.025, 0.016)),
        // The sun 10 degrees wide, through the cascades (`sun.rs`); `hard` measured 0.114.
        (LightKind::Sun, at_most(MaeShadowed, 0.025, 0.0161)),
    ])
    .with_cost(CostModel::new(
        &["shadow_map_size", "filter_samples", "blocker_samples"],
        |q| {
            let texels = q.number("shadow_map_size").powi(2);
            let samples = q.number("blocker_samples") + q.number("filter_samples");
            let filter = 2.0 * q.pixels * samples * PIXEL_ITERATION;
            // GPU memory (bytes); the uniforms (about 300 bytes) are left to the tolerance.
            let temporal = if q.flag("temporal") { 1.0 } else { 0.0 };
            let gpu_bytes =
                // The shadow map (Depth32Float).
                4.0 * texels
                // The depth pass's view slots (core::shadow_map::DepthMapRenderer: 16 x 256).
                + 4096.0
                // Temporal mode, per pixel: this frame's R32Float, the Rg32Float history and the
                // Rgba32Float positions, both ping-pong (4 + 2 x 8 + 2 x 16).
                + temporal * TemporalTargets::BYTES_PER_PIXEL as f64 * q.pixels;
            Cost::seconds(texels * DEPTH_TEXEL + filter, "shadow_map_size²")
                .with_gpu_memory(gpu_bytes, 0.01)
        },
    ))
    .with_expectations(expectations())
    .with_overview(&[("filter_samples", &["16", "64"])])
    .with_varies_per_frame_when(
        "temporal",
        "true",
        "the temporal mode rotates its kernel every frame and blends the frames into a history: \
         on a still path its answer changes while the history settles",
    )
    .with_settle_frames_from("max_history")
}

/// Bounds against the exact answer (`softshadow_core::expectations`, docs/STABILITY.md).
/// Every stiff case gets the rule for its class (the loosest bound stated on a case of the class,
/// with the case it was measured on beside it) unless it is named.
fn expectations() -> Expectations {
    Expectations::new(&[
        ("stiff-contact", at_most(MaeShadowed, 0.099, 0.0391)),
        ("stiff-near-light", at_most(MaeShadowed, 0.18, 0.0681)),
        (
            "stiff-wide-light",
            known_failure(MaeShadowed, 0.0195, 0.002),
        ),
        ("stiff-grazing", at_most(MaeShadowed, 0.095, 0.0379)),
        (
            "stiff-depth-range",
            known_failure(MaeShadowed, 0.2522, 0.026),
        ),
        (
            "stiff-partly-outside",
            known_failure(MaeShadowed, 0.4139, 0.043),
        ),
        ("stiff-aspect-100", at_most(MaeShadowed, 0.14, 0.0548)),
        ("stiff-degenerate", at_most(MaeShadowed, 0.082, 0.0327)),
        ("stiff-behind-light", at_most(MaeShadowed, 0.061, 0.0241)),
        ("stiff-light-up", at_most(MaeShadowed, 0.027, 0.0108)),
        ("stiff-fusion", at_most(MaeShadowed, 0.13, 0.0508)),
        // A roof thinner than the depth bias: its underside (facing away from the light, so
        // dark in the image whatever V says) reads lit. The irradiance error is small there.
        ("stiff-thin-roof", known_failure(MaeShadowed, 0.1351, 0.015)),
        // No umbra and a faint penumbra: drawing no shadow (0.0124) is as good.
        ("stiff-disk-huge", known_failure(MaeShadowed, 0.0129, 0.002)),
        ("stiff-sphere-near", at_most(MaeShadowed, 0.13, 0.0481)),
        ("stiff-spot-narrow", at_most(MaeShadowed, 0.03, 0.0119)),
        // Casters 0.1-0.25 under a light 1.0 across: the blocker search and the filter cover the
        // whole map and it draws no shadow (its error is the all-lit answer's).
        (
            "stiff-sphere-in-ground",
            known_failure(MaeShadowed, 0.3657, 0.037),
        ),
        // Halfway to no shadow (0.0809).
        ("stiff-leaves-edge-on", at_most(MaeShadowed, 0.056, 0.0331)),
        ("atty-square", at_most(MaeShadowed, 0.082, 0.0327)),
        (
            "blob-floating:triangles=20000",
            at_most(MaeShadowed, 0.12, 0.0828),
        ),
    ])
    .with_rules(&[
        (Unshadowed, at_most(MaxAbs, 1e-6, 0.0)), // stiff-no-occluder
        (PointLight, at_most(MaeShadowed, 0.0012, 2.0e-04)), // stiff-point-light
        (VanishingDistance, at_most(MaeShadowed, 0.22, 0.1314)), // stiff-tiny-patches
        (LightShape, at_most(MaeShadowed, 0.21, 0.1008)), // stiff-large-light
        (OccluderOverlap, at_most(MaeShadowed, 0.36, 0.2800)), // stiff-light-leak
        (LightPlane, at_most(MaeShadowed, 0.081, 0.0322)), // stiff-receiver-behind-light
        (ThinGeometry, at_most(MaeShadowed, 0.087, 0.0347)), // stiff-zero-thickness
    ])
}
