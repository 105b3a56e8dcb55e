// A technique's debug image for the viewer. Depth maps: caster texels from black (nearest) to
// white (farthest) over the range `debug_range.wgsl` found, empty texels dark blue. Float images
// (mode 0): the red channel from black (smallest) to white (largest finite value), NaN / inf
// magenta. Colour images (mode 1, e.g. a classification): shown as they are.
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

struct DebugParams {
    // 0: grey over the range, 1: the texture's own colours.
    mode: u32,
}

struct Range {
    lo: u32,
    hi: u32,
    count: u32,
}

#ifdef DEPTH
@group(0) @binding(0) var source: texture_depth_2d;
#else
@group(0) @binding(0) var source: texture_2d<f32>;
#endif
@group(0) @binding(1) var<uniform> params: DebugParams;
@group(0) @binding(2) var<storage, read> range: Range;

const EMPTY: vec3<f32> = vec3<f32>(0.08, 0.12, 0.35);
const INVALID: vec3<f32> = vec3<f32>(1.0, 0.0, 1.0);

// Inverse of `ordered` in debug_range.wgsl.
fn unordered(u: u32) -> f32 {
    return bitcast<f32>(select(~u, u & 0x7fffffffu, (u & 0x80000000u) != 0u));
}

fn grey(value: f32) -> vec3<f32> {
    let lo = unordered(range.lo);
    let hi = unordered(range.hi);
    // A flat image (one value) shows mid grey rather than dividing by zero.
    let t = select(0.5, (value - lo) / (hi - lo), hi > lo);
    return vec3<f32>(clamp(t, 0.0, 1.0));
}

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
    let colour = select(grey(d), EMPTY, d >= 1.0 || range.count == 0u);
#else
    let texture_value = textureLoad(source, texel, 0);
    var colour = texture_value.rgb;
    if params.mode == 0u {
        let r = texture_value.r;
        colour = select(INVALID, grey(r), abs(r) <= 3.0e38);
    }
#endif
    return vec4<f32>(colour, 1.0);
}
