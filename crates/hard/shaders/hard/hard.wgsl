// Hard shadows: one shadow map from the light centre, one depth comparison per pixel.
// The floor of every cost comparison.
#import softshadow::frame::{load_surface, light_cosine, light_reaches}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}
#import softshadow::shadow_view::{ShadowView, view_uv, linear_depth, texel_slope, in_map}

struct HardParams {
    bias_texels: f32,
}

@group(1) @binding(0) var<uniform> view: ShadowView;
@group(1) @binding(1) var shadow_map: texture_depth_2d;
@group(1) @binding(2) var<uniform> params: HardParams;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver {
        return vec4<f32>(1.0);
    }
    if !light_reaches(s) {
        // Behind the one-sided light.
        return vec4<f32>(0.0);
    }
    let uv = view_uv(view, s.light);
    if !in_map(uv) {
        // Every caster projects inside the map, so nothing outside it can occlude.
        return vec4<f32>(1.0);
    }
    let d = textureLoad(shadow_map, vec2<i32>(uv * view.size.xy), 0);
    if d >= 1.0 {
        return vec4<f32>(1.0);
    }
    // Bias: a number of texel footprints at the receiver's depth, larger on slopes.
    let bias = params.bias_texels * texel_slope(view) * s.light.z / light_cosine(s);
    let lit = linear_depth(view, d) >= s.light.z - bias;
    return vec4<f32>(select(0.0, 1.0, lit));
}
