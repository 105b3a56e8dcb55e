// Accumulated hard shadows, step 2: visibility = weight of the samples that see the point / weight
// of all (accumulate.wgsl). Unweighted, both are whole numbers in f32, so a fully lit pixel
// resolves to exactly 1.
#import softshadow::frame::{load_surface, light_reaches}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

@group(1) @binding(0) var weight_sums: texture_2d<f32>;

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
    let sums = textureLoad(weight_sums, pixel, 0).rg;
    // No sample faces the point (a sphere's, all on its far side): none sees it.
    if sums.y <= 0.0 {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(clamp(sums.x / sums.y, 0.0, 1.0));
}
