//! The `bitmask` descriptor: what the workspace knows about the technique ([`TechniqueInfo`]):
//! its parameters, requirements, shaders, cost model, error bounds and overview settings.

use softshadow_core::{
    cost::rates::{HIERARCHY_TEXEL, LAYER_TEXEL, PIXEL_ITERATION},
    expectations::{at_most, known_failure, ErrorMetric::*, StiffClass::*},
    Cost, CostModel, Expectations, LightKind, LightSupport, MinLimits, Requirements, TechniqueInfo,
};

use crate::{Bitmask, BitmaskSettings, ID, SHADERS};

/// The registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo::new(
        ID,
        "Bitmask soft shadows: backprojected micro-patches or micro-quads OR-ed into a bit field of light samples (occluder fusion), depth-peeled layers, HSM or MSSM search, post filter",
        "Schwarz & Stamminger 2007",
        BitmaskSettings::param_specs(),
        |gpu| Ok(Box::new(Bitmask::new(gpu, BitmaskSettings::default())?)),
    )
    .with_requirements(requirements())
    .with_shaders(SHADERS)
    // A disk, sphere or spot: the pattern's samples inside the disk inscribed in its square
    // (gather.wgsl, `disk_bits`); a sphere as its disk in the light plane.
    .with_light_kinds(LightSupport::all().except(
        LightKind::Sun,
        "its micro-patches are backprojected through a point onto a light plane at a finite distance; the sun is a cone of directions at infinity",
    ))
    // On atty-square with its light made each kind (`AreaLight::as_kind`), defaults, 64²
    // (measured beside each; `hard` measured 0.206 rect, 0.185 disk and spot, 0.156 sphere;
    // the sphere's floor is its disk in the light plane: the reference measures 0.0345 there).
    .with_light_kind_bounds(&[
        (LightKind::Rect, at_most(MaeShadowed, 0.016, 0.0102)),
        (LightKind::Disk, at_most(MaeShadowed, 0.017, 0.0109)),
        (LightKind::Sphere, at_most(MaeShadowed, 0.054, 0.0346)),
        (LightKind::Spot, at_most(MaeShadowed, 0.017, 0.0109)),
    ])
    .with_cost(CostModel::new(
        &["shadow_map_size", "layers", "max_patches", "filter_passes"],
        |q| {
            // The hierarchies pad each layer to a power of two; the gather is bounded by
            // lavapipe's loop budget per pixel (docs/DEVICES.md, "Lavapipe's loop budget").
            let side = q.number("shadow_map_size").max(1.0).log2().ceil().exp2();
            let levels = side.max(2.0).log2().ceil();
            let layers = q.number("layers");
            let maps = layers * side * side * (LAYER_TEXEL + levels * HIERARCHY_TEXEL);
            let gather = 2.0 * q.pixels * layers * q.number("max_patches").powi(2).min(65_535.0);
            let filter = 2.0 * q.pixels * q.number("filter_passes") * 64.0;
            // GPU memory (bytes). Each layer's MSSM holds the levels the light can need
            // (core::hierarchy::needed_levels): all of them here, as for most of the overview's
            // lights; a light whose widest search area is narrower needs fewer, 8 x side² bytes
            // less each per layer (pdsm-cylinder and pdsm-quads: one, 8 % less at 1024², within
            // the tolerance). The uniforms, counters and 1 x 1 stand-ins (about 2 KiB per layer)
            // are left to the tolerance.
            let mssm = if q.choice("hierarchy", "mssm") { 1.0 } else { 0.0 };
            let coarse = if q.choice("hierarchy", "none") {
                0.0
            } else if q.choice("adaptive_resolution", "half") {
                1.0 / 4.0
            } else if q.choice("adaptive_resolution", "quarter") {
                1.0 / 16.0
            } else {
                0.0
            };
            let per_layer =
                // The layer's depth map (Depth32Float: the centre map, then the peeled ones).
                4.0 * q.number("shadow_map_size").powi(2)
                // Its HSM (Rg32Float) over the padded map, every mip: (4 side² - 1) / 3 texels.
                + 8.0 * (4.0 * side * side - 1.0) / 3.0
                // Its MSSM's levels 1.. (Rg32Float, each at the padded size).
                + mssm * 8.0 * levels * side * side
                // Its hierarchy's level slots (16 x 256).
                + 4096.0;
            let gpu_bytes = layers * per_layer
                // The per-pixel images: bitmask, area, filter ping and pong, level (R32Float each).
                + 20.0 * q.pixels
                // Adaptive screen resolution's coarse image (Rg32Float, a texel per 2² or 4²
                // pixels).
                + coarse * 8.0 * q.pixels
                // The depth pass's view slots (core::shadow_map::DepthMapRenderer: 16 x 256).
                + 4096.0;
            Cost::seconds(
                maps + (gather + filter) * PIXEL_ITERATION,
                "layers x padded shadow_map_size² x log2(shadow_map_size)",
            )
            .with_gpu_memory(gpu_bytes, 0.1)
        },
    ))
    .with_expectations(expectations())
    .with_overview(&[("pattern", &["8x8", "16x16-jittered"])])
}

/// What the technique needs from the device at any of its settings.
pub(crate) fn requirements() -> Requirements {
    Requirements {
        // The gather pass writes three storage textures (within WebGPU's default of 4).
        limits: MinLimits {
            max_storage_textures_per_shader_stage: 3,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Bounds against the exact answer (`softshadow_core::expectations`, docs/STABILITY.md).
/// Every stiff case gets the rule for its class (the loosest bound stated on a case of the class,
/// with the case it was measured on beside it) unless it is named.
fn expectations() -> Expectations {
    Expectations::new(&[
        ("stiff-near-light", at_most(MaeShadowed, 0.022, 0.0087)),
        ("stiff-wide-light", at_most(MaeShadowed, 0.0083, 0.0033)),
        ("stiff-grazing", at_most(MaeShadowed, 0.032, 0.0128)),
        (
            "stiff-depth-range",
            known_failure(MaeShadowed, 0.2522, 0.026),
        ),
        ("stiff-zero-thickness", at_most(MaeShadowed, 0.015, 0.006)),
        ("stiff-aspect-100", at_most(MaeShadowed, 0.044, 0.0175)),
        ("stiff-tiny-patches", at_most(MaeShadowed, 0.039, 0.0154)),
        ("stiff-behind-light", at_most(MaeShadowed, 0.016, 0.0064)),
        (
            "stiff-receiver-behind-light",
            at_most(MaeShadowed, 0.023, 0.0090),
        ),
        ("stiff-light-up", at_most(MaeShadowed, 0.0093, 0.0037)),
        ("stiff-fusion", at_most(MaeShadowed, 0.056, 0.0224)),
        // A roof thinner than the depth bias: its underside (facing away from the light, so
        // dark in the image whatever V says) reads lit. The irradiance error is small there.
        ("stiff-thin-roof", known_failure(MaeShadowed, 0.1325, 0.015)),
        ("stiff-texel-holes", at_most(MaeShadowed, 0.12, 0.0460)),
        ("atty-square", at_most(MaeShadowed, 0.026, 0.0102)),
        (
            "blob-floating:triangles=20000",
            at_most(MaeShadowed, 0.11, 0.0534),
        ),
        ("stiff-disk-huge", at_most(MaeShadowed, 0.007, 0.0027)),
        // A sphere light half sunk in the ground, casters 0.1-0.25 under its centre: its disk in
        // the light plane stands in for the cap each receiver sees; worse than `hard` (0.1438).
        (
            "stiff-sphere-in-ground",
            known_failure(MaeShadowed, 0.2972, 0.03),
        ),
    ])
    .with_rules(&[
        (Unshadowed, at_most(MaxAbs, 1e-6, 0.0)), // stiff-no-occluder
        (PointLight, at_most(MaeShadowed, 0.001, 0.0)), // stiff-point-light
        (VanishingDistance, at_most(MaeShadowed, 0.043, 0.0164)), // stiff-contact
        (LightShape, at_most(MaeShadowed, 0.11, 0.0416)), // stiff-large-light
        (OccluderOverlap, at_most(MaeShadowed, 0.086, 0.0343)), // stiff-light-leak
        (LightPlane, at_most(MaeShadowed, 0.16, 0.0751)), // stiff-partly-outside
        (ThinGeometry, at_most(MaeShadowed, 0.026, 0.0102)), // stiff-degenerate
    ])
}
