// Adaptive light-source sampling, end of the accumulation-buffer evaluation (section 3.4.1):
// visibility = summed lit fractions / number of maps (equal weights).
#import softshadow::frame::load_surface
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

struct Params {
    values: vec4<f32>,
    // x: number of maps accumulated.
    counts: vec4<u32>,
}

@group(1) @binding(0) var<uniform> params: Params;
@group(1) @binding(1) var accumulated: texture_2d<f32>;

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
    if s.light.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    let sum = textureLoad(accumulated, pixel, 0).r;
    return vec4<f32>(clamp(sum / f32(max(params.counts.x, 1u)), 0.0, 1.0));
}
