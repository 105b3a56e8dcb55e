#define_import_path softshadow::frame_types

// Per-frame constants shared by every pass.
struct FrameUniforms {
    view_proj: mat4x4<f32>,
    // World space to light space: light centre at the origin, light facing +z,
    // light rectangle [-a, a] x [-b, b] in the plane z = 0.
    world_to_light: mat4x4<f32>,
    camera_pos: vec4<f32>,
    // xyz: light centre (world); w: intensity.
    light_center: vec4<f32>,
    // xyz: direction the light faces (world); w: ambient term of the shading pass.
    light_dir: vec4<f32>,
    // x = a, y = b (half width and half height; a disk, sphere or spot: the radius twice),
    // z = light area (4ab; pi r^2), w unused.
    light_half: vec4<f32>,
    // width, height, 1 / width, 1 / height of the visibility buffer.
    screen: vec4<f32>,
    // Light space to world.
    light_to_world: mat4x4<f32>,
    // x: kind (0 rect, 1 disk, 2 sphere, 3 spot, 4 sun: `light_kind()` in frame.wgsl),
    // y: radius (disk, sphere, spot), z / w: cos of a spot's inner / outer cone angle.
    light_shape: vec4<f32>,
    // The sun: x = sin(angular diameter / 4), y = tan(angular diameter / 2),
    // z = cos(angular diameter / 2); w unused.
    light_sun: vec4<f32>,
}
