// Percentage-closer filtering with a fixed kernel: (2r + 1)² depth comparisons on the texel grid
// around the receiver's texel, r = `kernel_radius` texels whatever the light's size. Radius 0 is
// one comparison: the hard shadow.
#import softshadow::frame::{load_surface, light_cosine}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}
#import softshadow::shadow_view::{ShadowView, view_uv, linear_depth, texel_slope, in_map}

struct FixedPcfParams {
    kernel_radius: i32,
    bias_texels: f32,
}

@group(1) @binding(0) var<uniform> view: ShadowView;
@group(1) @binding(1) var shadow_map: texture_depth_2d;
@group(1) @binding(2) var<uniform> params: FixedPcfParams;

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
    if s.light.z <= 0.0 {
        // Behind the one-sided light.
        return vec4<f32>(0.0);
    }
    let uv = view_uv(view, s.light);
    let size = vec2<i32>(view.size.xy);
    let centre = vec2<i32>(floor(uv * view.size.xy));
    let bias = params.bias_texels * texel_slope(view) * s.light.z / light_cosine(s);
    var lit = 0.0;
    var taps = 0.0;
    for (var dy = -params.kernel_radius; dy <= params.kernel_radius; dy++) {
        for (var dx = -params.kernel_radius; dx <= params.kernel_radius; dx++) {
            let texel = centre + vec2<i32>(dx, dy);
            taps += 1.0;
            // Every caster projects inside the map, so a tap outside it sees no occluder.
            if any(texel < vec2<i32>(0)) || any(texel >= size) {
                lit += 1.0;
                continue;
            }
            let d = textureLoad(shadow_map, texel, 0);
            if d >= 1.0 || linear_depth(view, d) >= s.light.z - bias {
                lit += 1.0;
            }
        }
    }
    return vec4<f32>(lit / taps);
}
