// One level of the moment map's mip chain: the mean of the 2 x 2 texels of the level above
// (clamped to its edge when its size is odd). Moments are linear in the depth distribution, so
// the mean of moments is the moments of the union (what makes moment maps filterable).
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

@group(1) @binding(0) var source: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let last = vec2<i32>(textureDimensions(source)) - 1;
    let corner = vec2<i32>(in.position.xy) * 2;
    var sum = vec4<f32>(0.0);
    for (var dy = 0; dy < 2; dy += 1) {
        for (var dx = 0; dx < 2; dx += 1) {
            sum += textureLoad(source, min(corner + vec2<i32>(dx, dy), last), 0);
        }
    }
    return sum * 0.25;
}
