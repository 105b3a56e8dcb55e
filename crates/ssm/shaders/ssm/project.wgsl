// Projects the soft shadow map onto the receivers (Atty et al. 2006, section 3.1, last step):
// each camera pixel looks up the occlusion summed at its slope from the light centre,
// bilinearly, and writes V = 1 - clamp(occlusion, 0, 1). With two occluder maps (section 3.5)
// the two soft shadow maps are merged by their maximum.
// A pixel in front of the receiver map's surface is on geometry that is also an occluder (the
// split puts it in the occluder map only): the paper computes no self-shadowing there, and this
// pass falls back to a hard-shadow test against the front occluder map.
#import softshadow::frame::{load_surface, light_cosine}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

// The same struct in every ssm shader.
struct SsmParams {
    occluder_window: vec4<f32>,
    occluder_depth: vec4<f32>,
    ssm_window: vec4<f32>,
    ssm_depth: vec4<f32>,
    light: vec4<f32>,
    // x: the radius of a disk, sphere or spot light (its disk in the light plane), 0 under
    // the rectangle.
    round_light: vec4<f32>,
}

@group(1) @binding(0) var<uniform> params: SsmParams;
@group(1) @binding(1) var receiver_map: texture_depth_2d;
@group(1) @binding(2) var occluder_map: texture_depth_2d;
@group(1) @binding(3) var ssm_front: texture_2d<f32>;
@group(1) @binding(4) var ssm_back: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

fn linear_depth(d: f32, near: f32, far: f32) -> f32 {
    return far * near / (far - d * (far - near));
}

// Map texture coordinates of `slope` in `window` (s_min, s_max, t_min, t_max); row 0 at t_max.
fn window_uv(window: vec4<f32>, slope: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(
        (slope.x - window.x) / (window.y - window.x),
        (window.w - slope.y) / (window.w - window.z),
    );
}

fn in_map(uv: vec2<f32>) -> bool {
    return all(uv >= vec2<f32>(0.0)) && all(uv < vec2<f32>(1.0));
}

// With TWO_PASS (section 3.5) the larger of the two maps' occlusion. A permutation, not the
// uniform `light.w` (docs/DEVICES.md, "Lavapipe's branches").
fn occlusion_at(texel: vec2<i32>) -> f32 {
    let front = textureLoad(ssm_front, texel, 0).r;
#ifdef TWO_PASS
    return max(front, textureLoad(ssm_back, texel, 0).r);
#else
    return front;
#endif
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver {
        return vec4<f32>(1.0);
    }
    let z = s.light.z;
    if z <= 0.0 {
        // Behind the one-sided light.
        return vec4<f32>(0.0);
    }
    let slope = s.light.xy / z;
    let uv = window_uv(params.ssm_window, slope);
    if !in_map(uv) {
        // The soft shadow map holds every penumbra: outside it nothing occludes.
        return vec4<f32>(1.0);
    }
    let r = params.ssm_depth.z;
    let texel_slope = max(params.ssm_window.y - params.ssm_window.x, params.ssm_window.w - params.ssm_window.z) / r;
    let bias_texels = params.light.z;
    let cosine = light_cosine(s);

    let nearest = vec2<i32>(uv * r);
    let d_r = textureLoad(receiver_map, nearest, 0);
    let z_receiver = linear_depth(d_r, params.ssm_depth.x, params.ssm_depth.y);
    if d_r >= 1.0 || z < z_receiver - bias_texels * texel_slope * z / cosine {
        // Not the receiver surface the soft shadow map was computed for: hard shadow from the
        // front occluder map.
        let ouv = window_uv(params.occluder_window, slope);
        if !in_map(ouv) {
            return vec4<f32>(1.0);
        }
        let n = params.occluder_depth.z;
        let d_o = textureLoad(occluder_map, vec2<i32>(ouv * n), 0);
        if d_o >= 1.0 {
            return vec4<f32>(1.0);
        }
        let z_o = linear_depth(d_o, params.occluder_depth.x, params.occluder_depth.y);
        let occluder_texel = max(params.occluder_window.y - params.occluder_window.x, params.occluder_window.w - params.occluder_window.z) / n;
        let lit = z_o >= z - bias_texels * occluder_texel * z / cosine;
        return vec4<f32>(select(0.0, 1.0, lit));
    }

    // Bilinear reconstruction of the soft shadow map (texel centres at integer + 0.5).
    let p = uv * r - 0.5;
    let base = floor(p);
    let f = p - base;
    let last = vec2<i32>(i32(r) - 1);
    let i0 = clamp(vec2<i32>(base), vec2<i32>(0), last);
    let i1 = clamp(vec2<i32>(base) + 1, vec2<i32>(0), last);
    let top = mix(occlusion_at(i0), occlusion_at(vec2<i32>(i1.x, i0.y)), f.x);
    let bottom = mix(occlusion_at(vec2<i32>(i0.x, i1.y)), occlusion_at(i1), f.x);
    let occlusion = mix(top, bottom, f.y);
    return vec4<f32>(1.0 - clamp(occlusion, 0.0, 1.0));
}
