#define_import_path softshadow::reprojection

// Reprojection into the history of a temporal technique (temporal PCSS, the ray-traced
// denoiser; softshadow_core::reprojection::History): the pixel's world point projected with the
// previous camera, and whether the history there saw the same point.

#import softshadow::frame::{frame, load_surface}

fn in_frame(p: vec2<i32>) -> bool {
    return all(p >= vec2<i32>(0)) && all(p < vec2<i32>(frame.screen.xy));
}

// World size of one pixel at the surface seen at `pixel`: the distance to the nearer of its
// horizontal neighbours on a receiver (no camera model needed).
fn pixel_footprint(pixel: vec2<i32>, world: vec3<f32>) -> f32 {
    var best = 1e30;
    for (var dx = -1; dx <= 1; dx += 2) {
        let q = pixel + vec2<i32>(dx, 0);
        if in_frame(q) {
            let s = load_surface(q);
            if s.is_receiver {
                best = min(best, length(s.world - world));
            }
        }
    }
    return select(best, 0.0, best >= 1e30);
}

// The pixel of the previous frame that saw `world` through `prev_view_proj`; outside the frame
// (see `in_frame`) when the point was behind that camera.
fn previous_pixel(prev_view_proj: mat4x4<f32>, world: vec3<f32>) -> vec2<i32> {
    let clip = prev_view_proj * vec4<f32>(world, 1.0);
    if clip.w <= 0.0 {
        return vec2<i32>(-1);
    }
    let ndc = clip.xy / clip.w;
    let uv = vec2<f32>(0.5 * ndc.x + 0.5, 0.5 - 0.5 * ndc.y);
    return vec2<i32>(floor(uv * frame.screen.xy));
}

// Whether the history's stored point `prior` (world point, receiver flag) is the point `world`
// seen at `pixel`: a receiver within two pixel footprints.
fn saw_same_point(pixel: vec2<i32>, world: vec3<f32>, prior: vec4<f32>) -> bool {
    let footprint = max(pixel_footprint(pixel, world), 1e-6);
    return prior.w > 0.5 && length(prior.xyz - world) <= 2.0 * footprint;
}
