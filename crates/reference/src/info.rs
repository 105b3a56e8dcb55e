//! The `reference` descriptor: what the workspace knows about the technique ([`TechniqueInfo`]):
//! its parameters, requirements, shaders, cost model, error bounds and overview settings.

use softshadow_core::{
    cost::rates::{DEPTH_TEXEL, PIXEL_ITERATION},
    expectations::{at_most, ErrorMetric::*, StiffClass::*},
    Cost, CostModel, Expectations, LightKind, LightSupport, TechniqueInfo,
};

use crate::{Reference, ReferenceSettings, ID, SHADERS};

/// The registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo::new(
        ID,
        "Reference: accumulated hard shadows from N x N stratified light samples",
        "Heckbert & Herf 1997 (accumulated hard shadows)",
        ReferenceSettings::param_specs(),
        |gpu| Ok(Box::new(Reference::new(gpu, ReferenceSettings::default())?)),
    )
    .with_requirements(Reference::requirements_static())
    .with_shaders(SHADERS)
    // The sun: one orthographic map per direction of its cone (`sun_view`); the sphere: one
    // perspective map per point of its surface, weighed per receiver (`sphere_view`).
    .with_light_kinds(LightSupport::all())
    // On atty-square with its light made each kind (`AreaLight::as_kind`), defaults, 64²
    // (measured beside each; `hard` measured 0.206 rect, 0.185 disk and spot, 0.156 sphere).
    .with_light_kind_bounds(&[
        (LightKind::Rect, at_most(MaeShadowed, 0.01, 0.0016)),
        (LightKind::Disk, at_most(MaeShadowed, 0.01, 0.0021)),
        (LightKind::Spot, at_most(MaeShadowed, 0.01, 0.0021)),
        // One map per point of the sphere (`sphere_view`), about half of them facing a receiver.
        (LightKind::Sphere, at_most(MaeShadowed, 0.01, 0.0042)),
        // The sun 10 degrees wide: 32 x 32 directions of its cone (`sun_view`); `hard` 0.114.
        (LightKind::Sun, at_most(MaeShadowed, 0.01, 0.0062)),
    ])
    .with_cost(CostModel::new(
        &["samples_per_axis", "shadow_map_size"],
        // Both frames redo every map (nothing is kept when the camera moves) and look each up
        // at every camera pixel.
        |q| {
            let samples = q.number("samples_per_axis").powi(2);
            let texels = q.number("shadow_map_size").powi(2);
            // GPU memory (bytes).
            let pow2 = |x: f64| x.log2().ceil().exp2();
            let gpu_bytes =
                // The depth maps of one accumulation pass: a Depth32Float array of BATCH (16)
                // layers, whatever the samples.
                16.0 * 4.0 * texels
                // The summed weights (Rg32Float) and the result (R32Float), per pixel; the
                // result of the frame before is dropped when the cache is (NVIDIA freed it
                // later: 16 bytes).
                + 12.0 * q.pixels
                // The depth pass's view slots: 256 bytes per light sample, rounded up to a power
                // of two, at least 16 (core::shadow_map::DepthMapRenderer).
                + 256.0 * pow2(samples).max(16.0)
                // The batches' uniforms: 2048 bytes per batch of 16 samples, rounded up to a
                // power of two, at least 4.
                + 2048.0 * pow2((samples / 16.0).ceil()).max(4.0);
            Cost::seconds(
                2.0 * samples * (texels * DEPTH_TEXEL + q.pixels * PIXEL_ITERATION),
                "2 frames x samples_per_axis² x (shadow_map_size² + pixels)",
            )
            .with_gpu_memory(gpu_bytes, 0.01)
        },
    ))
    .with_expectations(expectations())
    .with_overview(&[("samples_per_axis", &["4", "8"])])
}

/// Bounds against the exact answer (`softshadow_core::expectations`, docs/STABILITY.md): at its
/// default 32 x 32 samples the reference is within a few thousandths everywhere.
/// Every stiff case gets the rule for its class (the loosest bound stated on a case of the class,
/// with the case it was measured on beside it) unless it is named.
fn expectations() -> Expectations {
    Expectations::new(&[
        ("stiff-contact", at_most(MaeShadowed, 0.0065, 0.0020)),
        ("stiff-near-light", at_most(MaeShadowed, 0.0033, 0.0013)),
        ("stiff-wide-light", at_most(MaeShadowed, 0.003, 0.0012)),
        ("stiff-grazing", at_most(MaeShadowed, 0.004, 0.0016)),
        // The real sun's 0.53 degrees at 3 degrees up: a penumbra under a pixel, so `hard`
        // (0.0015) is nearly exact; the class rule (0.0053) would accept it.
        ("stiff-sun-grazing", at_most(MaeShadowed, 0.0012, 0.0007)),
        ("stiff-depth-range", at_most(MaeShadowed, 0.0038, 0.0015)),
        // The sphere's disk turns from receiver to receiver: every other technique 0.03 or more.
        ("stiff-sphere-near", at_most(MaeShadowed, 0.0085, 0.0054)),
        // Half sunk in the ground; the ground right beside it sees the sphere under a huge
        // angle and reads darker than the ray-traced answer (darker_shadowed 0.013): `raytraced`
        // 0.079, `hard` 0.144, every other technique 0.26 or more.
        (
            "stiff-sphere-in-ground",
            at_most(MaeShadowed, 0.045, 0.0316),
        ),
        ("stiff-zero-thickness", at_most(MaeShadowed, 0.0065, 0.0026)),
        ("stiff-degenerate", at_most(MaeShadowed, 0.004, 0.0016)),
        ("stiff-behind-light", at_most(MaeShadowed, 0.003, 0.0012)),
        (
            "stiff-receiver-behind-light",
            at_most(MaeShadowed, 0.0044, 0.0013),
        ),
        ("stiff-light-up", at_most(MaeShadowed, 0.0015, 5.0e-04)),
        ("stiff-fusion", at_most(MaeShadowed, 0.004, 0.0016)),
        ("stiff-large-light", at_most(MaeShadowed, 0.005, 0.0020)),
        ("atty-square", at_most(MaeShadowed, 0.004, 0.0016)),
        (
            "blob-floating:triangles=20000",
            at_most(MaeShadowed, 0.0125, 0.0050),
        ),
    ])
    .with_rules(&[
        (Unshadowed, at_most(MaxAbs, 1e-6, 0.0)), // stiff-no-occluder
        (PointLight, at_most(MaeShadowed, 0.001, 0.0)), // stiff-point-light
        (VanishingDistance, at_most(MaeShadowed, 0.0083, 0.0033)), // stiff-tiny-patches
        (LightShape, at_most(MaeShadowed, 0.0053, 0.0021)), // stiff-aspect-100
        (OccluderOverlap, at_most(MaeShadowed, 0.0057, 0.0023)), // stiff-light-leak
        (LightPlane, at_most(MaeShadowed, 0.006, 0.0019)), // stiff-partly-outside
        // stiff-thin-roof (issue 38): seen by rays, the roof's underside is in its umbra.
        (ThinGeometry, at_most(MaeShadowed, 0.03, 0.0103)), // stiff-thin-roof
    ])
}
