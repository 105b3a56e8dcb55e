// The temporal mode of PCSS (setting `temporal`; docs/TECHNIQUES.md, `pcss`, "Temporal mode").
// `pcss/filter` has drawn this frame's PCSS with its kernel rotated for this frame (`raw`); this
// pass blends it into the history of earlier frames, as a TAA resolve does for Bevy's temporal
// shadow filtering, but inside the technique so that what is measured is the technique's own
// answer:
//   1. Reprojection: the pixel's world point projected with the previous camera; the history
//      there is used when it saw the same point (its stored world point within two pixel
//      footprints), else rejected (disocclusion, off screen).
//   2. Rejection of stale values: the history is clipped to this frame's neighbourhood, the mean
//      +- clamp_sigma standard deviations of `raw` over the 3 x 3 receiver pixels around it
//      (variance clipping, Salvi 2016, as Bevy's TAA; for one channel, clipping toward the box
//      centre is a clamp). This is what limits ghosting when the light or a caster moves: the
//      world point is the same there, only its visibility changed.
//   3. Blend: the running mean over up to max_history frames (the current frame's weight is
//      1 / frames, at least 1 / max_history).
// Every pixel writes the visibility; pixels without usable history write `raw` unchanged.
#import softshadow::frame::load_surface
#import softshadow::reprojection::{in_frame, previous_pixel, saw_same_point}

struct TemporalParams {
    // The camera's view-projection of the previous frame.
    prev_view_proj: mat4x4<f32>,
    // 1 when the history may be used (same size and settings, nothing invalidated).
    history_valid: u32,
    // Frames averaged at most.
    max_history: u32,
    // Half width of the clipping box in standard deviations of the neighbourhood.
    clamp_sigma: f32,
}

@group(1) @binding(0) var<uniform> params: TemporalParams;
// This frame's rotated PCSS (R32Float).
@group(1) @binding(1) var raw: texture_2d<f32>;
// The previous frame's history: (frames averaged, visibility), and the world point it saw with
// a receiver flag.
@group(1) @binding(2) var history_in: texture_2d<f32>;
@group(1) @binding(3) var position_in: texture_2d<f32>;
@group(1) @binding(4) var history_out: texture_storage_2d<rg32float, write>;
@group(1) @binding(5) var position_out: texture_storage_2d<rgba32float, write>;
@group(1) @binding(6) var visibility: texture_storage_2d<r32float, write>;

@compute @workgroup_size(8, 8)
fn temporal(@builtin(global_invocation_id) id: vec3<u32>) {
    let pixel = vec2<i32>(id.xy);
    if !in_frame(pixel) {
        return;
    }
    let s = load_surface(pixel);
    let current = textureLoad(raw, pixel, 0).x;
    let shaded = s.is_receiver && s.light.z > 0.0;
    var v = current;
    var frames = 1.0;
    if shaded && params.history_valid == 1u {
        let prev = previous_pixel(params.prev_view_proj, s.world);
        if in_frame(prev) {
            let prior = textureLoad(position_in, prev, 0);
            let history = textureLoad(history_in, prev, 0);
            if saw_same_point(pixel, s.world, prior) && history.x >= 1.0 {
                // 2. The neighbourhood of this frame (receivers in front of the light).
                var sum = 0.0;
                var sum2 = 0.0;
                var count = 0.0;
                for (var dy = -1; dy <= 1; dy++) {
                    for (var dx = -1; dx <= 1; dx++) {
                        let q = pixel + vec2<i32>(dx, dy);
                        if in_frame(q) {
                            let n = load_surface(q);
                            if n.is_receiver && n.light.z > 0.0 {
                                let x = textureLoad(raw, q, 0).x;
                                sum += x;
                                sum2 += x * x;
                                count += 1.0;
                            }
                        }
                    }
                }
                // count >= 1: the pixel itself is a receiver in front of the light.
                let mean = sum / count;
                let sigma = sqrt(max(sum2 / count - mean * mean, 0.0));
                let h = clamp(
                    history.y,
                    mean - params.clamp_sigma * sigma,
                    mean + params.clamp_sigma * sigma,
                );
                // 3. The running mean.
                frames = min(history.x + 1.0, f32(params.max_history));
                v = clamp(mix(h, current, 1.0 / frames), 0.0, 1.0);
            }
        }
    }
    textureStore(history_out, pixel, vec4<f32>(frames, v, 0.0, 0.0));
    textureStore(position_out, pixel, vec4<f32>(s.world, select(0.0, 1.0, shaded)));
    textureStore(visibility, pixel, vec4<f32>(v));
}
