// Shading pass: albedo * (ambient + intensity * V * cos), or a view of V itself.
#import softshadow::frame::{frame, load_surface, light_direction, light_reaches, light_cone}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

struct ShadingParams {
    // 0 = shaded, 1 = visibility as grey.
    mode: u32,
}

@group(1) @binding(0) var albedo_texture: texture_2d<f32>;
@group(1) @binding(1) var visibility_texture: texture_2d<f32>;
@group(1) @binding(2) var<uniform> params: ShadingParams;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

const BACKGROUND: vec3<f32> = vec3<f32>(0.18, 0.2, 0.24);

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(in.position.xy);
    let s = load_surface(pixel);
    let v = clamp(textureLoad(visibility_texture, pixel, 0).r, 0.0, 1.0);
    let geometry = textureLoad(albedo_texture, pixel, 0).a > 0.5;
    if params.mode == 1u {
        return vec4<f32>(vec3<f32>(v), 1.0);
    }
    if !geometry {
        return vec4<f32>(BACKGROUND, 1.0);
    }
    let albedo = textureLoad(albedo_texture, pixel, 0).rgb;
    let to_light = light_direction(s.world);
    // Only the side the light faces is lit (one-sided emitter; the sun reaches everything), and
    // a spot only inside its cone.
    let facing = select(0.0, 1.0, light_reaches(s));
    let cosine = max(dot(s.normal, to_light), 0.0) * facing * light_cone(s.world);
    let ambient = frame.light_dir.w;
    let radiance = albedo * (ambient + frame.light_center.w * v * cosine);
    return vec4<f32>(radiance, 1.0);
}
