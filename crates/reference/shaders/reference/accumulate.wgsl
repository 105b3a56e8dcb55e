// Accumulated hard shadows, step 1: for one batch of point samples on the light, count per pixel
// how many see the surface point (additive blending sums the counts over batches).
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
