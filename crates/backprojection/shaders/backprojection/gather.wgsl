// Gather backprojection (Guennebaud, Barthe & Paulin 2006)
// with the micro-quads and the multi-scale shadow map of the bitmask soft shadows paper (Schwarz &
// Stamminger 2007, sections 4 and 5). One invocation per screen pixel, in the shared gather pass
// (softshadow::gather_pass, with GATHER_LAYERS = 1: the centre map only):
//   1. search area of the receiver point p (light space) on the centre shadow map, refined twice
//      with the depth hierarchy, with lit and umbra early outs (softshadow::search_area);
//   2. a coarser level when the area holds more than max_patches^2 blocks;
//   3. every micro-primitive of the area is backprojected from p onto the light plane: a point at
//      slope (s, t) and depth z < p.z lands at X = z (s p.z - p.x) / (p.z - z) (same for Y), and
//      the covered light area is accumulated (softshadow::gather's default `emit_patch` /
//      `emit_quad`, or the contour integral); here V = 1 - clamp(area / 4ab, 0, 1).
#import softshadow::gather_pass::{
    PixelResult, gather_pixels, gather_coarse_pixels, params, CLASS_LIT, CLASS_UMBRA,
    CLASS_BACKPROJECTED, CLASS_UPSAMPLED,
}
#import softshadow::frame::light_kind
#import softshadow::light::LIGHT_RECT

// The per-pixel classification (debug view), the gather pass's binding 7.
@group(1) @binding(7) var classification: texture_storage_2d<rgba8unorm, write>;

override fn softshadow::gather_pass::finish_pixel(r0: PixelResult, half_light: vec2<f32>, area: f32) -> PixelResult {
    // The summed light area of the micro-primitives over the light's area (a round light's:
    // pi r^2, half_light = (r, r)).
    var r = r0;
    var light_area = 4.0 * half_light.x * half_light.y;
    if light_kind() != LIGHT_RECT {
        light_area = 3.14159265 * half_light.x * half_light.y;
    }
    r.v = 1.0 - clamp(area / light_area, 0.0, 1.0);
    if !(r.v >= 0.0 && r.v <= 1.0) {
        // NaN guard: never write a non-finite visibility.
        r.v = 1.0;
    }
    return r;
}

override fn softshadow::gather_pass::store_pixel(pixel: vec2<i32>, r: PixelResult) {
    textureStore(classification, pixel, class_colour(r));
}

fn class_colour(r: PixelResult) -> vec4<f32> {
    switch r.kind {
        case CLASS_LIT: {
            return vec4<f32>(0.9, 0.9, 0.85, 1.0);
        }
        case CLASS_UMBRA: {
            return vec4<f32>(0.1, 0.1, 0.35, 1.0);
        }
        case CLASS_BACKPROJECTED: {
            // Red for few micro-primitives, towards blue for max_patches^2 (paper Fig. 8).
            let full = f32(params.max_patches * params.max_patches);
            let t = clamp(f32(r.primitives) / full, 0.0, 1.0);
            return vec4<f32>(1.0 - t, 0.15, t, 1.0);
        }
        case CLASS_UPSAMPLED: {
            return vec4<f32>(0.1, 0.8, 0.2, 1.0);
        }
        default: {
            return vec4<f32>(0.0);
        }
    }
}

@compute @workgroup_size(8, 8)
fn gather(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    gather_pixels(id, local);
}

// The coarse pass of adaptive screen resolution.
@compute @workgroup_size(8, 8)
fn gather_coarse(@builtin(global_invocation_id) id: vec3<u32>) {
    gather_coarse_pixels(id);
}
