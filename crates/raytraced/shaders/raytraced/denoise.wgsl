// The denoiser of `raytraced`, in the spirit of NVIDIA's SIGMA and AMD's FidelityFX shadow
// denoiser (docs/TECHNIQUES.md, `raytraced`): temporal accumulation of the raw rays with
// reprojection and history rejection, a penumbra-width estimate from the hit distance and the
// light size, and a spatial filter sized by it and guided by depth and normal. One entry point
// per pass; every pass reads group 0 (the receiver surface) and its own group 1.
#import softshadow::frame::{load_surface, light_reaches, light_penumbra_width}
#import softshadow::reprojection::{in_frame, pixel_footprint, previous_pixel, saw_same_point}

struct DenoiseParams {
    // The camera's view-projection of the previous frame (reprojection).
    prev_view_proj: mat4x4<f32>,
    // 1 when the history may be used (same light, casters and settings).
    history_valid: u32,
    // Frames averaged at most (the history's weight is capped at max_history - 1).
    max_history: u32,
    // Largest filter radius, pixels.
    max_radius: f32,
    // 1 when the spatial filter is on.
    spatial: u32,
}

@group(1) @binding(0) var<uniform> params: DenoiseParams;
// temporal: raw (visible, mean hit distance); history in (visible, frames); history position in.
// penumbra: raw. filter: accumulated (visible, frames), penumbra radius.
@group(1) @binding(1) var input_a: texture_2d<f32>;
@group(1) @binding(2) var input_b: texture_2d<f32>;
@group(1) @binding(3) var input_c: texture_2d<f32>;
@group(1) @binding(4) var output_a: texture_storage_2d<rg32float, write>;
@group(1) @binding(5) var output_b: texture_storage_2d<rgba32float, write>;
@group(1) @binding(6) var output_v: texture_storage_2d<r32float, write>;

// Temporal accumulation (FidelityFX shadow denoiser, "temporal reprojection"; SIGMA's temporal
// stabilisation): the pixel's world point is projected with the previous camera; the history
// there is kept when it saw the same surface (its stored world point within two pixel footprints
// and a normal within ~25 degrees), else rejected. The new value is the running mean of the raw
// values over up to max_history frames.
@compute @workgroup_size(8, 8)
fn temporal(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = vec2<i32>(id.xy);
    if !in_frame(pixel) {
        return;
    }
    let s = load_surface(pixel);
    let raw = textureLoad(input_a, pixel, 0).x;
    var visible = raw;
    var frames = 1.0;
    if s.is_receiver && params.history_valid == 1u {
        let prev = previous_pixel(params.prev_view_proj, s.world);
        if in_frame(prev) {
            let prior = textureLoad(input_c, prev, 0);
            let history = textureLoad(input_b, prev, 0);
            if saw_same_point(pixel, s.world, prior) && history.y >= 1.0 {
                frames = min(history.y + 1.0, f32(params.max_history));
                visible = mix(history.x, raw, 1.0 / frames);
            }
        }
    }
    textureStore(output_a, pixel, vec4<f32>(visible, frames, 0.0, 0.0));
    textureStore(output_b, pixel, vec4<f32>(s.world, select(0.0, 1.0, s.is_receiver)));
}

// Penumbra estimate (SIGMA's "penumbra size from hit distance"): an occluder at distance d from
// the receiver, with the light at distance D, spreads the light's width w into a penumbra of
// w d / (D - d) on the receiver (similar triangles, as PCSS's estimate, Fernando 2005, section
// 3). The hit distance is averaged over a fixed 9 x 9 window (stride 2) first, because lit pixels
// and pixels whose rays all missed have none. Written as a filter radius in pixels.
@compute @workgroup_size(8, 8)
fn penumbra(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = vec2<i32>(id.xy);
    if !in_frame(pixel) {
        return;
    }
    let s = load_surface(pixel);
    if !s.is_receiver || !light_reaches(s) {
        textureStore(output_v, pixel, vec4<f32>(0.0));
        return;
    }
    var sum = 0.0;
    var count = 0.0;
    var any_shadow = false;
    for (var dy = -4; dy <= 4; dy++) {
        for (var dx = -4; dx <= 4; dx++) {
            let q = pixel + 2 * vec2<i32>(dx, dy);
            if in_frame(q) {
                let r = textureLoad(input_a, q, 0);
                if r.y > 0.0 {
                    sum += r.y;
                    count += 1.0;
                }
                any_shadow = any_shadow || r.x < 1.0;
            }
        }
    }
    if count == 0.0 || !any_shadow {
        textureStore(output_v, pixel, vec4<f32>(0.0));
        return;
    }
    let d = sum / count;
    let width = light_penumbra_width(s.world, d);
    let footprint = pixel_footprint(pixel, s.world);
    let radius = select(params.max_radius, 0.5 * width / footprint, footprint > 0.0);
    textureStore(output_v, pixel, vec4<f32>(clamp(radius, 0.0, params.max_radius)));
}

// Spatial filter (SIGMA's and FidelityFX's edge-stopping blur): a 7 x 7 grid of taps spread over
// the penumbra radius (shrunk by the square root of the frames already averaged, as the history
// has lowered the noise), each weighted by a Gaussian of its distance, by how far it lies off the
// pixel's tangent plane (depth) and by the agreement of the normals. Writes the visibility buffer.
@compute @workgroup_size(8, 8)
fn spatial_filter(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = vec2<i32>(id.xy);
    if !in_frame(pixel) {
        return;
    }
    let centre = textureLoad(input_a, pixel, 0);
    let s = load_surface(pixel);
    var radius = 0.0;
    if params.spatial == 1u && s.is_receiver && light_reaches(s) {
        radius = textureLoad(input_b, pixel, 0).x / sqrt(max(centre.y, 1.0));
    }
    // Pixel-level classification (FidelityFX's tile classification, per pixel): where the 5 x 5
    // neighbourhood all agrees on fully lit or fully shadowed, there is nothing to denoise, and
    // blurring would only carry the penumbra into the umbra and onto lit ground.
    if radius >= 0.5 && (centre.x == 0.0 || centre.x == 1.0) {
        var uniform_area = true;
        for (var dy = -2; dy <= 2; dy++) {
            for (var dx = -2; dx <= 2; dx++) {
                let q = pixel + vec2<i32>(dx, dy);
                if in_frame(q) && load_surface(q).is_receiver {
                    uniform_area = uniform_area && textureLoad(input_a, q, 0).x == centre.x;
                }
            }
        }
        if uniform_area {
            radius = 0.0;
        }
    }
    if radius < 0.5 {
        textureStore(output_v, pixel, vec4<f32>(centre.x));
        return;
    }
    let footprint = max(pixel_footprint(pixel, s.world), 1e-6);
    let tap_step = radius / 3.0;
    var sum = 0.0;
    var weight = 0.0;
    for (var j = -3; j <= 3; j++) {
        for (var i = -3; i <= 3; i++) {
            let offset = vec2<f32>(f32(i), f32(j)) * tap_step;
            let q = pixel + vec2<i32>(round(offset));
            if !in_frame(q) {
                continue;
            }
            let t = load_surface(q);
            if !t.is_receiver {
                continue;
            }
            let r2 = dot(offset, offset) / (radius * radius);
            let plane = abs(dot(s.normal, t.world - s.world)) / (footprint * max(1.0, length(offset)));
            let w = exp(-2.0 * r2) * exp(-plane * plane) * pow(max(dot(s.normal, t.normal), 0.0), 8.0);
            sum += w * textureLoad(input_a, q, 0).x;
            weight += w;
        }
    }
    textureStore(output_v, pixel, vec4<f32>(select(centre.x, sum / weight, weight > 0.0)));
}
