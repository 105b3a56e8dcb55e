// Viewer colour mapping: turns the renderer's outputs into the one image the viewer shows.
// Writes gamma-space RGBA8 (what egui expects from a user texture): shaded images are
// sRGB-encoded here, visibility and difference bytes are written as the benchmark's PNGs hold
// them (crates/metrics: `visibility_to_gray8`, `difference_image`).
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

struct DisplayParams {
    // 0 shaded, 1 visibility, 2 reference, 3 difference, 4 split (technique | reference).
    mode: u32,
    // 1 when the reference textures hold a (possibly partial) reference.
    reference_ready: u32,
    // Divider of the split view, as a fraction of the width.
    split: f32,
    // |V - V_ref| shown at full colour (metrics::DIFFERENCE_FULL_SCALE).
    full_scale: f32,
}

@group(0) @binding(0) var technique_shaded: texture_2d<f32>;
@group(0) @binding(1) var technique_visibility: texture_2d<f32>;
@group(0) @binding(2) var reference_shaded: texture_2d<f32>;
@group(0) @binding(3) var reference_visibility: texture_2d<f32>;
// G-buffer normal (w = 1 on receivers) and position (w = 1 where geometry was hit).
@group(0) @binding(4) var surface_normal: texture_2d<f32>;
@group(0) @binding(5) var surface_position: texture_2d<f32>;
@group(0) @binding(6) var<uniform> params: DisplayParams;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

const NON_RECEIVER: vec3<f32> = vec3<f32>(128.0, 128.0, 128.0) / 255.0;
const NON_FINITE: vec3<f32> = vec3<f32>(1.0, 0.0, 1.0);
const WAITING: vec3<f32> = vec3<f32>(0.1, 0.1, 0.12);

fn srgb_encode(linear: vec3<f32>) -> vec3<f32> {
    let c = clamp(linear, vec3<f32>(0.0), vec3<f32>(1.0));
    let low = c * 12.92;
    let high = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(high, low, c <= vec3<f32>(0.0031308));
}

// WGSL has no isnan; a NaN fails every comparison, and infinities exceed any finite bound.
fn is_finite(x: f32) -> bool {
    return x == x && abs(x) <= 3.0e38;
}

fn grey(v: f32) -> vec3<f32> {
    if !is_finite(v) {
        return select(vec3<f32>(0.0), vec3<f32>(1.0), v > 0.0 && v == v);
    }
    return vec3<f32>(round(255.0 * clamp(v, 0.0, 1.0)) / 255.0);
}

fn difference(pixel: vec2<i32>) -> vec3<f32> {
    let v = textureLoad(technique_visibility, pixel, 0).r;
    if !is_finite(v) {
        return NON_FINITE;
    }
    let receiver = textureLoad(surface_normal, pixel, 0).w > 0.5
        && textureLoad(surface_position, pixel, 0).w > 0.5;
    if !receiver {
        return NON_RECEIVER;
    }
    if params.reference_ready == 0u {
        return WAITING;
    }
    let d = v - textureLoad(reference_visibility, pixel, 0).r;
    let t = min(abs(d) / params.full_scale, 1.0);
    let c = round(255.0 * (1.0 - t)) / 255.0;
    if d < 0.0 {
        return vec3<f32>(1.0, c, c);
    }
    if d > 0.0 {
        return vec3<f32>(c, c, 1.0);
    }
    return vec3<f32>(1.0);
}

fn reference(pixel: vec2<i32>) -> vec3<f32> {
    if params.reference_ready == 0u {
        return WAITING;
    }
    return srgb_encode(textureLoad(reference_shaded, pixel, 0).rgb);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(in.position.xy);
    var colour: vec3<f32>;
    switch params.mode {
        case 1u: {
            colour = grey(textureLoad(technique_visibility, pixel, 0).r);
        }
        case 2u: {
            colour = reference(pixel);
        }
        case 3u: {
            colour = difference(pixel);
        }
        case 4u: {
            let width = f32(textureDimensions(technique_shaded).x);
            let divider = params.split * width;
            if abs(in.position.x - divider) < 1.0 {
                colour = vec3<f32>(1.0);
            } else if in.position.x < divider {
                colour = srgb_encode(textureLoad(technique_shaded, pixel, 0).rgb);
            } else {
                colour = reference(pixel);
            }
        }
        default: {
            colour = srgb_encode(textureLoad(technique_shaded, pixel, 0).rgb);
        }
    }
    return vec4<f32>(colour, 1.0);
}
