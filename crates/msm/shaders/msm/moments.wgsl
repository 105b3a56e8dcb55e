// The moment map, texel by texel from the shadow map from the light centre (same size).
// Depth z is light-space depth normalised to [0, 1] over `depth_range` (empty texels: 1, beyond
// every receiver, so they never shadow).
//   moment shadow maps (Peters and Klein 2015): b = (z, z^2, z^3, z^4);
//   EVSM (the EVSM permutation; Lauritzen and McCool 2008, exponential variance shadow maps):
//     x = 2 z - 1, (e^(c+ x), e^(2 c+ x), -e^(-c- x), e^(-2 c- x)).
// Under the sun (SUN): from one cascade's orthographic map (a layer of core's cascades), whose
// hardware depth is already linear over the cascade's near..far: z = d.
// Keep `moments_of` equal to the one in msm.wgsl.
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}
#import softshadow::shadow_view::{ShadowView, linear_depth}

struct MsmParams {
    // Light-space depth that maps to 0 (the map's near plane) and to 1 (beyond every receiver).
    depth_range: vec2<f32>,
    // EVSM exponents c+ and c-.
    exponents: vec2<f32>,
    moment_bias: f32,
    light_bleeding_reduction: f32,
    bias_texels: f32,
    blocker_search_scale: f32,
    min_filter_texels: f32,
    filter_taps: u32,
    levels: u32,
}

#ifdef SUN
@group(1) @binding(0) var shadow_map: texture_depth_2d;
@group(1) @binding(1) var<uniform> params: MsmParams;
#else
@group(1) @binding(0) var<uniform> view: ShadowView;
@group(1) @binding(1) var shadow_map: texture_depth_2d;
@group(1) @binding(2) var<uniform> params: MsmParams;
#endif

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

fn moments_of(z: f32) -> vec4<f32> {
#ifdef EVSM
    let x = 2.0 * z - 1.0;
    let positive = exp(params.exponents.x * x);
    let negative = -exp(-params.exponents.y * x);
    return vec4<f32>(positive, positive * positive, negative, negative * negative);
#else
    let z2 = z * z;
    return vec4<f32>(z, z2, z2 * z, z2 * z2);
#endif
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let d = textureLoad(shadow_map, vec2<i32>(in.position.xy), 0);
#ifdef SUN
    return moments_of(d);
#else
    let range = params.depth_range;
    let z = clamp((linear_depth(view, d) - range.x) / (range.y - range.x), 0.0, 1.0);
    return moments_of(select(z, 1.0, d >= 1.0));
#endif
}
