//! The `adaptive` descriptor: what the workspace knows about the technique ([`TechniqueInfo`]):
//! its parameters, requirements, shaders, cost model, error bounds and overview settings.

use softshadow_core::{
    cost::rates::{DEPTH_TEXEL, PIXEL_ITERATION},
    expectations::{at_most, known_failure, ErrorMetric::*, StiffClass::*},
    Cost, CostModel, Expectations, LightKind, LightSupport, TechniqueInfo,
};

use crate::{Adaptive, AdaptiveSettings, ID, SHADERS};

/// The registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo::new(
        ID,
        "Adaptive light-source sampling: shadow maps only where neighbouring maps differ on screen (differing-pixel counts, the paper's occlusion queries)",
        "Schwärzler 2009, Real-Time Soft Shadows with Adaptive Light Source Sampling",
        AdaptiveSettings::param_specs(),
        |gpu| Ok(Box::new(Adaptive::new(gpu, AdaptiveSettings::default())?)),
    )
    .with_requirements(Adaptive::requirements_static())
    .with_shaders(SHADERS)
    // A disk, sphere or spot: the sample lattice carried onto the disk by the concentric map
    // (`light_point`); a sphere as its disk in the light plane.
    .with_light_kinds(LightSupport::all().except(
        LightKind::Sun,
        "its depth maps are perspective views from points of a light plane at a finite distance; the sun needs orthographic maps over its cone of directions",
    ))
    // On atty-square with its light made each kind (`AreaLight::as_kind`), defaults, 64²
    // (measured beside each; `hard` measured 0.206 rect, 0.185 disk and spot, 0.156 sphere;
    // the sphere's floor is its disk in the light plane: the reference measures 0.0345 there).
    .with_light_kind_bounds(&[
        (LightKind::Rect, at_most(MaeShadowed, 0.053, 0.0338)),
        (LightKind::Disk, at_most(MaeShadowed, 0.036, 0.0228)),
        (LightKind::Sphere, at_most(MaeShadowed, 0.049, 0.0311)),
        (LightKind::Spot, at_most(MaeShadowed, 0.036, 0.0228)),
    ])
    .with_cost(CostModel::new(
        &["shadow_map_size", "max_shadow_maps", "max_depth"],
        |q| {
            // Corners: (2^d + 1)² maps; centres: (2^(d+1))²; the cap stops at max_shadow_maps.
            let most = 2f64.powf(q.number("max_depth") + 1.0).powi(2);
            let maps = most.min(q.number("max_shadow_maps"));
            let compare = 2.0 * maps * q.pixels * PIXEL_ITERATION;
            // GPU memory (bytes); the parameter uniform (about 200 bytes) is left to the
            // tolerance.
            let capacity = q.number("max_shadow_maps");
            let drawn = if q.choice("start", "corners") {
                (2f64.powf(q.number("max_depth")) + 1.0).powi(2)
            } else {
                most
            };
            let slots = drawn.min(capacity).log2().ceil().exp2().max(16.0);
            let accumulate = if q.choice("evaluation", "accumulate") {
                1.0
            } else {
                0.0
            };
            let gpu_bytes =
                // The shadow maps: a Depth32Float array of max_shadow_maps layers, whatever a
                // frame draws.
                4.0 * capacity * q.number("shadow_map_size").powi(2)
                // The differing pixels' image (R32Float), and the accumulation buffer with
                // evaluation = accumulate.
                + (1.0 + accumulate) * 4.0 * q.pixels
                // The views' uniform array (512 views of 112 bytes), the pairs' and the terms'
                // (1024 items of 16 bytes each).
                + 512.0 * 112.0 + 2.0 * 1024.0 * 16.0
                // The differing-pixel counters and their readback (2 pairs per map, 4 bytes).
                + 2.0 * 8.0 * capacity
                // The depth pass's view slots: 256 bytes per map drawn, rounded up to a power of
                // two, at least 16 (core::shadow_map::DepthMapRenderer; the most maps at
                // max_depth here, fewer where the refinement stops early).
                + 256.0 * slots;
            Cost::seconds(
                maps * q.number("shadow_map_size").powi(2) * DEPTH_TEXEL + compare,
                "min(max_shadow_maps, maps at max_depth) x shadow_map_size²",
            )
            .with_gpu_memory(gpu_bytes, 0.01)
        },
    ))
    .with_expectations(expectations())
    .with_overview(&[("epsilon", &["0.01", "0.002"])])
}

/// Bounds against the exact answer (`softshadow_core::expectations`, docs/STABILITY.md).
/// Every stiff case gets the rule for its class (the loosest bound stated on a case of the class,
/// with the case it was measured on beside it) unless it is named.
fn expectations() -> Expectations {
    Expectations::new(&[
        ("stiff-contact", at_most(MaeShadowed, 0.15, 0.0568)),
        ("stiff-near-light", at_most(MaeShadowed, 0.12, 0.0443)),
        (
            "stiff-wide-light",
            known_failure(MaeShadowed, 0.0227, 0.003),
        ),
        ("stiff-grazing", at_most(MaeShadowed, 0.11, 0.0415)),
        ("stiff-depth-range", at_most(MaeShadowed, 0.13, 0.0488)),
        ("stiff-zero-thickness", at_most(MaeShadowed, 0.076, 0.0302)),
        ("stiff-partly-outside", at_most(MaeShadowed, 0.067, 0.0259)),
        (
            "stiff-receiver-behind-light",
            at_most(MaeShadowed, 0.066, 0.0263),
        ),
        ("stiff-light-up", at_most(MaeShadowed, 0.029, 0.0113)),
        ("stiff-fusion", at_most(MaeShadowed, 0.079, 0.0313)),
        ("stiff-large-light", at_most(MaeShadowed, 0.105, 0.0419)),
        // A roof thinner than the depth bias: its underside (facing away from the light, so
        // dark in the image whatever V says) reads lit. The irradiance error is small there.
        ("stiff-thin-roof", known_failure(MaeShadowed, 0.1573, 0.016)),
        ("stiff-leaves-edge-on", at_most(MaeShadowed, 0.041, 0.0162)),
        ("atty-square", at_most(MaeShadowed, 0.085, 0.0338)),
        (
            "blob-floating:triangles=20000",
            at_most(MaeShadowed, 0.065, 0.0261),
        ),
        // No umbra and a faint penumbra: drawing no shadow (0.0124) is as good.
        ("stiff-disk-huge", known_failure(MaeShadowed, 0.0153, 0.002)),
        // A sphere light half sunk in the ground, casters 0.1-0.25 under its centre: its disk in
        // the light plane stands in for the cap each receiver sees; no shadow drawn (the all-lit answer's error).
        (
            "stiff-sphere-in-ground",
            known_failure(MaeShadowed, 0.3657, 0.037),
        ),
        // The class rule (0.13) would accept `hard` (0.1268).
        ("stiff-spot-narrow", at_most(MaeShadowed, 0.11, 0.074)),
    ])
    .with_rules(&[
        (Unshadowed, at_most(MaxAbs, 1e-6, 0.0)), // stiff-no-occluder
        (PointLight, at_most(MaeShadowed, 0.001, 0.0)), // stiff-point-light
        (VanishingDistance, at_most(MaeShadowed, 0.24, 0.1799)), // stiff-tiny-patches
        (LightShape, at_most(MaeShadowed, 0.13, 0.0498)), // stiff-aspect-100
        (OccluderOverlap, at_most(MaeShadowed, 0.11, 0.0463)), // stiff-light-leak
        (LightPlane, at_most(MaeShadowed, 0.076, 0.0304)), // stiff-behind-light
        (ThinGeometry, at_most(MaeShadowed, 0.085, 0.0338)), // stiff-degenerate
    ])
}
