// Accumulated hard shadows, step 1: for one batch of point samples on the light, count per pixel
// how many see the surface point (additive blending sums the counts over batches).
// Under the sun (SUN) each sample is a direction of its cone and its map an orthographic view
// along it (`sun_view` in src/lib.rs), the same ShadowView struct carrying: `light_view_proj`
// its world-to-clip, `eye_near_far.xyz` the unit direction toward the sun and `.w` the map's
// depth range (far - near), `window.x` its texel edge in world units.
#import softshadow::frame::{frame, load_surface, light_cosine}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}
#import softshadow::shadow_view::{ShadowView, view_uv, linear_depth, texel_slope, in_map}

const MAX_BATCH: u32 = 16u;

struct Batch {
    // x: number of views in this batch; y: bias in texel footprints (as f32 bits).
    count_bias: vec4<f32>,
    views: array<ShadowView, MAX_BATCH>,
}

@group(1) @binding(0) var<uniform> batch: Batch;
@group(1) @binding(1) var depth_maps: texture_depth_2d_array;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

#ifdef SUN
// 1 where `world` (normal `normal`) sees the sun along the view's direction, else 0.
fn lit_along(view: ShadowView, i: u32, world: vec3<f32>, normal: vec3<f32>, bias_texels: f32) -> f32 {
    let to_sun = view.eye_near_far.xyz;
    let cosine = dot(normal, to_sun);
    // A direction behind the surface's own tangent plane is hidden by the surface itself.
    if cosine <= 0.0 {
        return 0.0;
    }
    let clip = view.light_view_proj * vec4<f32>(world, 1.0);
    let uv = vec2<f32>(clip.x * 0.5 + 0.5, 0.5 - clip.y * 0.5);
    if !in_map(uv) {
        return 1.0;
    }
    let d = textureLoad(depth_maps, vec2<i32>(uv * view.size.xy), i32(i), 0);
    // The bias in world units (texels over the cosine, at most 10 texels), as depth.
    let bias = bias_texels * view.window.x / max(cosine, 0.1) / view.eye_near_far.w;
    return select(0.0, 1.0, d >= 1.0 || d >= clip.z - bias);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver {
        return vec4<f32>(0.0);
    }
    let count = min(u32(batch.count_bias.x), MAX_BATCH);
    var lit = 0.0;
    for (var i = 0u; i < count; i = i + 1u) {
        lit += lit_along(batch.views[i], i, s.world, s.normal, batch.count_bias.y);
    }
    return vec4<f32>(lit);
}
#else
@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver || s.light.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    let count = min(u32(batch.count_bias.x), MAX_BATCH);
    let bias_texels = batch.count_bias.y;
    let slope_factor = s.light.z / light_cosine(s);
    // The surface's normal in light space (the G-buffer's, facing the camera).
    let normal = (frame.world_to_light * vec4<f32>(s.normal, 0.0)).xyz;
    var lit = 0.0;
    for (var i = 0u; i < count; i = i + 1u) {
        let view = batch.views[i];
        // A sample behind the surface's own tangent plane is hidden by the surface itself (a
        // point on a closed part sees it only through the part). The depth test cannot tell:
        // its bias, up to 10x the texel footprint at grazing angles (`light_cosine`), exceeds the
        // thickness of a thin part, whose far side then read lit (a CAD-like model's 16 mm rods
        // and 6 mm slats: pixels off by 1.0 against the ray cast; docs/TECHNIQUES.md,
        // `reference`, "The three yardsticks on a multi-part mesh").
        if dot(normal, vec3<f32>(view.eye_near_far.xy, 0.0) - s.light) <= 0.0 {
            continue;
        }
        let uv = view_uv(view, s.light);
        if !in_map(uv) {
            lit += 1.0;
            continue;
        }
        let d = textureLoad(depth_maps, vec2<i32>(uv * view.size.xy), i32(i), 0);
        let bias = bias_texels * texel_slope(view) * slope_factor;
        if d >= 1.0 || linear_depth(view, d) >= s.light.z - bias {
            lit += 1.0;
        }
    }
    return vec4<f32>(lit);
}
#endif
