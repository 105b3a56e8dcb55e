//! The `raytraced` descriptor: what the workspace knows about the technique ([`TechniqueInfo`]):
//! its parameters, requirements, shaders, cost model, error bounds and overview settings.

use softshadow_core::{
    cost::rates::PIXEL_ITERATION,
    expectations::{at_most, known_failure, ErrorMetric::*, StiffClass::*},
    Cost, CostModel, Expectations, LightKind, LightSupport, TechniqueInfo,
};

use crate::{Raytraced, RaytracedSettings, Targets, ID, SHADERS};

/// Seconds per shadow ray on lavapipe (about 0.5-1 M rays/s on 2 cores, docs/TECHNIQUES.md, `raytraced`).
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
    // Its rays sample each kind's shape (core's `light_sample`).
    .with_light_kinds(LightSupport::all())
    // On atty-square with its light made each kind (`AreaLight::as_kind`), defaults, 64²
    // (measured beside each; `hard` measured 0.206 rect, 0.185 disk and spot, 0.156 sphere).
    .with_light_kind_bounds(&[
        (LightKind::Rect, at_most(MaeShadowed, 0.134, 0.086)),
        (LightKind::Disk, at_most(MaeShadowed, 0.128, 0.0821)),
        (LightKind::Sphere, at_most(MaeShadowed, 0.136, 0.0877)),
        (LightKind::Spot, at_most(MaeShadowed, 0.128, 0.0821)),
        (LightKind::Sun, at_most(MaeShadowed, 0.083, 0.0531)),
    ])
    .with_cost(CostModel::new(&["rays_per_pixel"], |q| {
        let rays = 2.0 * q.pixels * q.number("rays_per_pixel") * RAY;
        // The filter's 7 x 7 taps and the penumbra estimate's 9 x 9.
        let denoise = 2.0 * q.pixels * 130.0 * PIXEL_ITERATION;
        // GPU memory (bytes): the per-pixel targets, made whatever the settings (raw Rg32Float,
        // Rg32Float history and Rgba32Float positions both ping-pong, the R32Float radius:
        // 8 + 2 x 8 + 2 x 16 + 4). Left out: the four 1 x 1 stand-ins and the uniforms (about
        // 1.3 KiB on lavapipe, 1 % at 48 x 48); and the acceleration structures, which depend on
        // the scene's casters, not on these parameters (core::accel's estimate: 72 bytes per
        // triangle, 7 MiB for blob-floating's 99,856) and which wgpu-hal 30 does not count on
        // Vulkan at all (its counter covers DX12 only), so the count holds none of them.
        let gpu_bytes = Targets::BYTES_PER_PIXEL as f64 * q.pixels;
        Cost::seconds(rays + denoise, "rays_per_pixel").with_gpu_memory(gpu_bytes, 0.02)
    }))
    .with_expectations(expectations())
    .with_overview(&[("rays_per_pixel", &["1", "4"])])
    .with_varies_per_frame(
        "its rays go to other light points every frame and blend into a history: on a still \
         path its answer changes while the history settles",
    )
    .with_settle_frames_from("max_history")
}

/// Bounds against the exact answer (`softshadow_core::expectations`, docs/STABILITY.md), at the
/// default settings (4 rays per pixel, spatial filter off, temporal accumulation on but without a
/// history: the stiff suite draws one frame with the caches dropped, so these are 4 raw rays), 64²,
/// the exact answer a 16 x 16 ray cast or the closed form. Each bound is 1.5x the measured value
/// plus 0.005, or just under the all-lit or `hard` answer where that is lower. Measured with
/// `cargo test --workspace --test gpu raytraced::measure -- --ignored --nocapture`.
/// Every stiff case gets the rule for its class (the loosest bound stated on a case of the class,
/// with the case it was measured on beside it) unless it is named.
fn expectations() -> Expectations {
    Expectations::new(&[
        ("stiff-contact", at_most(MaeShadowed, 0.13, 0.0802)),
        ("stiff-near-light", at_most(MaeShadowed, 0.089, 0.0561)),
        // Four rays' noise over this faint penumbra costs more than drawing no shadow
        // (all-lit 0.0277); 32 frames of accumulation bring it to 0.0016 (tests/gpu/raytraced.rs).
        (
            "stiff-wide-light",
            known_failure(MaeShadowed, 0.0475, 0.005),
        ),
        ("stiff-grazing", at_most(MaeShadowed, 0.121, 0.0775)),
        ("stiff-depth-range", at_most(MaeShadowed, 0.089, 0.0560)),
        ("stiff-aspect-100", at_most(MaeShadowed, 0.159, 0.1027)),
        ("stiff-degenerate", at_most(MaeShadowed, 0.134, 0.0860)),
        ("stiff-behind-light", at_most(MaeShadowed, 0.114, 0.0727)),
        (
            "stiff-receiver-behind-light",
            at_most(MaeShadowed, 0.122, 0.0778),
        ),
        ("stiff-light-up", at_most(MaeShadowed, 0.052, 0.0317)),
        ("stiff-light-leak", at_most(MaeShadowed, 0.152, 0.0985)),
        // Issue 38's thin roof: seen by rays, the roof's underside is in its umbra.
        ("stiff-thin-roof", at_most(MaeShadowed, 0.03, 0.0089)),
        // Its rays' noise over a faint penumbra costs more than drawing no shadow (0.0124).
        ("stiff-disk-huge", known_failure(MaeShadowed, 0.0232, 0.003)),
        // Halfway to `hard` (0.1268).
        ("stiff-spot-narrow", at_most(MaeShadowed, 0.092, 0.0591)),
        // Thin shadows of edge-on cards: its noise costs as much as drawing none (0.0809).
        (
            "stiff-leaves-edge-on",
            known_failure(MaeShadowed, 0.0771, 0.008),
        ),
        ("atty-square", at_most(MaeShadowed, 0.134, 0.0860)),
        (
            "blob-floating:triangles=20000",
            at_most(MaeShadowed, 0.121, 0.0761),
        ),
    ])
    .with_rules(&[
        (Unshadowed, at_most(MaxAbs, 1e-6, 0.0)), // stiff-no-occluder
        (PointLight, at_most(MaeShadowed, 0.001, 0.0)), // stiff-point-light
        (VanishingDistance, at_most(MaeShadowed, 0.203, 0.1325)), // stiff-tiny-patches
        (LightShape, at_most(MaeShadowed, 0.175, 0.1134)), // stiff-large-light
        (OccluderOverlap, at_most(MaeShadowed, 0.161, 0.1043)), // stiff-fusion
        (LightPlane, at_most(MaeShadowed, 0.135, 0.0891)), // stiff-partly-outside
        (ThinGeometry, at_most(MaeShadowed, 0.153, 0.0990)), // stiff-zero-thickness
    ])
}
