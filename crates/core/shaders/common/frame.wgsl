#define_import_path softshadow::frame

#import softshadow::frame_types::FrameUniforms

// Group 0 of every technique pass that reads the G-buffer (`CoreLayouts::frame`).
@group(0) @binding(0) var<uniform> frame: FrameUniforms;
@group(0) @binding(1) var gbuffer_position: texture_2d<f32>;
@group(0) @binding(2) var gbuffer_normal: texture_2d<f32>;

struct Surface {
    world: vec3<f32>,
    normal: vec3<f32>,
    // The surface point in light space (z = distance in front of the light plane).
    light: vec3<f32>,
    // The pixel sees geometry flagged `receives_shadow`.
    is_receiver: bool,
}

fn load_surface(pixel: vec2<i32>) -> Surface {
    let p = textureLoad(gbuffer_position, pixel, 0);
    let n = textureLoad(gbuffer_normal, pixel, 0);
    var s: Surface;
    s.world = p.xyz;
    s.normal = n.xyz;
    s.light = (frame.world_to_light * vec4<f32>(p.xyz, 1.0)).xyz;
    s.is_receiver = p.w > 0.5 && n.w > 0.5;
    return s;
}

// Cosine between the surface normal and the direction to the light centre, clamped to a floor;
// used to scale depth biases with the receiver's slope.
fn light_cosine(s: Surface) -> f32 {
    let to_light = normalize(frame.light_center.xyz - s.world);
    return max(abs(dot(s.normal, to_light)), 0.1);
}
