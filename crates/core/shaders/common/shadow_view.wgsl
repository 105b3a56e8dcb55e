#define_import_path softshadow::shadow_view

// A perspective shadow map rendered from an eye on the light plane. Everything is in slope
// space: a light-space point (x, y, z) has slopes s = (x - eye.x) / z, t = (y - eye.y) / z.
struct ShadowView {
    light_view_proj: mat4x4<f32>,
    // s_min, s_max, t_min, t_max of the map window.
    window: vec4<f32>,
    // eye.x, eye.y (light space), near, far (light-space z).
    eye_near_far: vec4<f32>,
    // width, height, 1 / width, 1 / height of the map.
    size: vec4<f32>,
}

fn view_slope(v: ShadowView, light_pos: vec3<f32>) -> vec2<f32> {
    return (light_pos.xy - v.eye_near_far.xy) / light_pos.z;
}

// Texture coordinates (v grows downwards: row 0 is t_max).
fn slope_to_uv(v: ShadowView, slope: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(
        (slope.x - v.window.x) / (v.window.y - v.window.x),
        (v.window.w - slope.y) / (v.window.w - v.window.z),
    );
}

fn view_uv(v: ShadowView, light_pos: vec3<f32>) -> vec2<f32> {
    return slope_to_uv(v, view_slope(v, light_pos));
}

// Slope extent of one texel (square texels).
fn texel_slope(v: ShadowView) -> f32 {
    return (v.window.y - v.window.x) * v.size.z;
}

// Hardware depth in [0, 1] back to light-space z. Depth 1 (cleared) maps to `far`.
fn linear_depth(v: ShadowView, d: f32) -> f32 {
    let n = v.eye_near_far.z;
    let f = v.eye_near_far.w;
    return f * n / (f - d * (f - n));
}

fn in_map(uv: vec2<f32>) -> bool {
    return all(uv >= vec2<f32>(0.0)) && all(uv < vec2<f32>(1.0));
}
