// A technique's debug image (shadow map, ...) as gamma-space grey for the viewer. Depth maps
// hold hardware depth (empty texels and the far plane white); `contrast` (1 = raw depth)
// stretches 1 - d for maps whose depths crowd near 1.
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

struct DebugParams {
    contrast: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

#ifdef DEPTH
@group(0) @binding(0) var source: texture_depth_2d;
#else
@group(0) @binding(0) var source: texture_2d<f32>;
#endif
@group(0) @binding(1) var<uniform> params: DebugParams;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let size = vec2<f32>(textureDimensions(source));
    let texel = vec2<i32>(min(in.uv * size, size - vec2<f32>(1.0)));
#ifdef DEPTH
    let d = textureLoad(source, texel, 0);
    let value = 1.0 - clamp((1.0 - d) * params.contrast, 0.0, 1.0);
#else
    let value = clamp(textureLoad(source, texel, 0).r * params.contrast, 0.0, 1.0);
#endif
    return vec4<f32>(vec3<f32>(value), 1.0);
}
