#define_import_path softshadow::frame

#import softshadow::frame_types::FrameUniforms
#import softshadow::light::{LightRay, LIGHT_SUN, LIGHT_SPOT, light_kind_of, light_reaches_point, sample_light}

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

// The light's shape, read through `frame` (the maths in light.wgsl, one place for every pass).
fn light_kind() -> u32 {
    return light_kind_of(frame);
}

// Whether the light reaches the surface at all (`light_reaches_point` in light.wgsl).
fn light_reaches(s: Surface) -> bool {
    return light_reaches_point(frame, s.world, s.light);
}

// The shadow ray from `world` to the light sample `u` in [0, 1)^2 (`sample_light` in light.wgsl).
fn light_sample(u: vec2<f32>, world: vec3<f32>) -> LightRay {
    return sample_light(frame, u, world);
}

// The unit direction from `world` to the light for shading (the sun: toward it).
fn light_direction(world: vec3<f32>) -> vec3<f32> {
    if light_kind() == LIGHT_SUN {
        return -frame.light_dir.xyz;
    }
    return normalize(frame.light_center.xyz - world);
}

// A spot's cone falloff at `world` (1 for every other kind): smooth from its inner to its outer
// cone (shading only; the visibility is the fraction of its source seen).
fn light_cone(world: vec3<f32>) -> f32 {
    if light_kind() != LIGHT_SPOT {
        return 1.0;
    }
    let cos_angle = dot(normalize(world - frame.light_center.xyz), frame.light_dir.xyz);
    return smoothstep(frame.light_shape.w, frame.light_shape.z, cos_angle);
}

// The width of the penumbra at `world` cast by an edge `blocker_distance` away from it toward the
// light, by similar triangles: the light's width (a disk's or sphere's diameter) times
// blocker / (light - blocker) distances; for the sun, its angular diameter times the distance
// (2 tan(alpha / 2) d).
fn light_penumbra_width(world: vec3<f32>, blocker_distance: f32) -> f32 {
    if light_kind() == LIGHT_SUN {
        return 2.0 * frame.light_sun.y * blocker_distance;
    }
    let to_light = length(frame.light_center.xyz - world);
    let light_width = 2.0 * max(frame.light_half.x, frame.light_half.y);
    return light_width * blocker_distance / max(to_light - blocker_distance, 1e-4 * to_light);
}
