//! The `smrt` descriptor: what the workspace knows about the technique ([`TechniqueInfo`]):
//! its parameters, requirements, shaders, cost model, error bounds and overview settings.

use softshadow_core::{
    cost::rates::{DEPTH_TEXEL, PIXEL_ITERATION},
    expectations::{at_most, known_failure, ErrorMetric::*, StiffClass::*},
    Cost, CostModel, Expectations, LightKind, LightSupport, TechniqueInfo,
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
    // Its rays go to points of the rectangle or of the disk (a sphere's disk in the light plane).
    // The sun: rays over its cone marched through core's cascades (`sun.rs`).
    .with_light_kinds(LightSupport::all())
    // On atty-square with its light made each kind (`AreaLight::as_kind`), defaults, 64²
    // (measured beside each; `hard` measured 0.206 rect, 0.185 disk and spot, 0.156 sphere).
    .with_light_kind_bounds(&[
        (LightKind::Rect, at_most(MaeShadowed, 0.042, 0.0273)),
        (LightKind::Disk, at_most(MaeShadowed, 0.039, 0.0249)),
        (LightKind::Sphere, at_most(MaeShadowed, 0.065, 0.0421)),
        (LightKind::Spot, at_most(MaeShadowed, 0.039, 0.0249)),
        // The sun 10 degrees wide, through the cascades (`sun.rs`); `hard` measured 0.114.
        (LightKind::Sun, at_most(MaeShadowed, 0.046, 0.0297)),
    ])
    .with_cost(CostModel::new(
        &["shadow_map_size", "ray_count", "samples_per_ray"],
        |q| {
            // The map, then at most rays x samples texel reads per pixel (a ray stops at its
            // first hit, so lit pixels pay all of them).
            let texels = q.number("shadow_map_size").powi(2);
            let steps = q.number("ray_count") * q.number("samples_per_ray");
            let trace = q.pixels * steps * PIXEL_ITERATION;
            // GPU memory (bytes); the uniforms (about 350 bytes: 1.2 % at 64²) are left to the
            // tolerance.
            let gpu_bytes =
                // The shadow map (Depth32Float).
                4.0 * texels
                // The depth pass's view slots (core::shadow_map::DepthMapRenderer: 16 x 256).
                + 4096.0
                // The per-pixel debug image (R32Float), made whether or not it is shown.
                + 4.0 * q.pixels;
            Cost::seconds(texels * DEPTH_TEXEL + trace, "shadow_map_size²")
                .with_gpu_memory(gpu_bytes, 0.02)
        },
    ))
    .with_expectations(expectations())
    .with_overview(&[("ray_count", &["8", "32"])])
}

/// Bounds against the exact answer (`softshadow_core::expectations`, docs/STABILITY.md): 2.5x the
/// value measured at the defaults (32 rays of 8 steps, 1024² map), lowered to halfway to `hard`
/// or to no shadow where that is nearer. Ray noise is most of the error (16 rays: about 1.5x).
/// Every stiff case gets the rule for its class (the loosest bound stated on a case of the class,
/// with the case it was measured on beside it) unless it is named.
fn expectations() -> Expectations {
    Expectations::new(&[
        ("stiff-contact", at_most(MaeShadowed, 0.087, 0.0350)),
        ("stiff-near-light", at_most(MaeShadowed, 0.073, 0.0290)),
        // Halfway to no shadow (0.0277).
        ("stiff-wide-light", at_most(MaeShadowed, 0.021, 0.0150)),
        ("stiff-grazing", at_most(MaeShadowed, 0.079, 0.0317)),
        // The map fitted over a caster 1e-3 from the light has texels too coarse for the other
        // caster: no better than no shadow, as pcss and msm (docs/TECHNIQUES.md, smrt).
        (
            "stiff-depth-range",
            known_failure(MaeShadowed, 0.2522, 0.025),
        ),
        ("stiff-aspect-100", at_most(MaeShadowed, 0.099, 0.0395)),
        ("stiff-degenerate", at_most(MaeShadowed, 0.068, 0.0273)),
        ("stiff-behind-light", at_most(MaeShadowed, 0.053, 0.0210)),
        (
            "stiff-receiver-behind-light",
            at_most(MaeShadowed, 0.078, 0.0313),
        ),
        ("stiff-light-up", at_most(MaeShadowed, 0.025, 0.0100)),
        ("stiff-fusion", at_most(MaeShadowed, 0.11, 0.0455)),
        // A roof thinner than the depth bias: its underside (facing away from the light, so
        // dark in the image whatever V says) reads lit. The irradiance error is small there.
        ("stiff-thin-roof", known_failure(MaeShadowed, 0.1349, 0.015)),
        // No umbra and a faint penumbra: drawing no shadow (0.0124) is better.
        ("stiff-disk-huge", known_failure(MaeShadowed, 0.0148, 0.002)),
        ("stiff-spot-narrow", at_most(MaeShadowed, 0.053, 0.0209)),
        // The real sun's 0.53 degrees at 3 degrees up: a penumbra under a pixel, so `hard`
        // (0.0015) is nearly exact; the class rule (0.15) would accept it.
        ("stiff-sun-grazing", at_most(MaeShadowed, 0.0013, 0.0009)),
        // Casters 0.1-0.25 under a light 1.0 across, the ground inside the sphere unreached: little
        // better than no shadow (0.3657), worse than `hard` (0.1438).
        (
            "stiff-sphere-in-ground",
            known_failure(MaeShadowed, 0.3238, 0.033),
        ),
        ("atty-square", at_most(MaeShadowed, 0.068, 0.0273)),
        // Halfway to hard (0.1540).
        (
            "blob-floating:triangles=20000",
            at_most(MaeShadowed, 0.1, 0.0533),
        ),
    ])
    .with_rules(&[
        (Unshadowed, at_most(MaxAbs, 1e-6, 0.0)), // stiff-no-occluder
        (PointLight, at_most(MaeShadowed, 0.001, 0.0)), // stiff-point-light
        (VanishingDistance, at_most(MaeShadowed, 0.12, 0.0491)), // stiff-tiny-patches
        (LightShape, at_most(MaeShadowed, 0.15, 0.0614)), // stiff-large-light
        (OccluderOverlap, at_most(MaeShadowed, 0.15, 0.0602)), // stiff-light-leak
        // stiff-partly-outside: halfway to hard (0.1988).
        (LightPlane, at_most(MaeShadowed, 0.16, 0.1230)), // stiff-partly-outside
        (ThinGeometry, at_most(MaeShadowed, 0.077, 0.0308)), // stiff-zero-thickness
    ])
}
