// Accumulated hard shadows, step 2: visibility = lit count / number of samples.
// Counts are whole numbers in f32, so a fully lit pixel resolves to exactly 1.
#import softshadow::frame::{load_surface, light_reaches}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

struct Resolve {
    // x: total number of light samples.
    samples: vec4<f32>,
}

@group(1) @binding(0) var<uniform> resolve: Resolve;
@group(1) @binding(1) var counts: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(in.position.xy);
    let s = load_surface(pixel);
    if !s.is_receiver {
        return vec4<f32>(1.0);
    }
    // Behind a one-sided light's plane (the sun reaches everything).
    if !light_reaches(s) {
        return vec4<f32>(0.0);
    }
    let lit = textureLoad(counts, pixel, 0).r;
    return vec4<f32>(clamp(lit / max(resolve.samples.x, 1.0), 0.0, 1.0));
}
