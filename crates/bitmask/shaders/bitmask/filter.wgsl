// One pass of the post filter of bitmask soft shadows (Schwarz & Stamminger 2007, sec. 3.1): the
// bitmask visibility B is point sampled and steps where a sample's bit flips; the area estimate A
// (visibility from the summed backprojected areas, unclamped) is wrong under overlaps but smooth.
// Per receiver pixel and axis, if the central differences of A and B have the same sign and A_0
// lies between A_-1 and A_1, A_0's relative position is imposed on B:
//   B_0^x = (A_0 - A_-1) / (A_1 - A_-1) (B_1 - B_-1) + B_-1,
// likewise in y; of B_0^x and B_0^y the one that changes B_0 less is kept. Neighbours off the
// screen or off the receivers leave that axis alone.
#import softshadow::frame::{frame, load_surface}

@group(1) @binding(0) var area_map: texture_2d<f32>;
@group(1) @binding(1) var src: texture_2d<f32>;
@group(1) @binding(2) var dst: texture_storage_2d<r32float, write>;

fn is_receiver(pixel: vec2<i32>) -> bool {
    let size = vec2<i32>(frame.screen.xy);
    if any(pixel < vec2<i32>(0)) || any(pixel >= size) {
        return false;
    }
    return load_surface(pixel).is_receiver;
}

// B_0 along one axis (`step` = (1, 0) or (0, 1)), or `none` when the rule does not apply.
fn along(pixel: vec2<i32>, step: vec2<i32>, a0: f32, none: f32) -> f32 {
    let before = pixel - step;
    let after = pixel + step;
    if !is_receiver(before) || !is_receiver(after) {
        return none;
    }
    let a_before = textureLoad(area_map, before, 0).x;
    let a_after = textureLoad(area_map, after, 0).x;
    let b_before = textureLoad(src, before, 0).x;
    let b_after = textureLoad(src, after, 0).x;
    let da = a_after - a_before;
    let db = b_after - b_before;
    // Same sign (and neither flat), A_0 strictly between its neighbours.
    if !(da * db > 0.0) || !((a0 - a_before) * (a_after - a0) > 0.0) {
        return none;
    }
    return (a0 - a_before) / da * db + b_before;
}

@compute @workgroup_size(8, 8)
fn filter_pass(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(frame.screen.xy);
    if any(id.xy >= size) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let b0 = textureLoad(src, pixel, 0).x;
    var b = b0;
    if load_surface(pixel).is_receiver {
        let a0 = textureLoad(area_map, pixel, 0).x;
        // A sentinel outside [0, 1] marks "rule does not apply".
        let none = -1.0;
        let bx = along(pixel, vec2<i32>(1, 0), a0, none);
        let by = along(pixel, vec2<i32>(0, 1), a0, none);
        if bx != none && (by == none || abs(bx - b0) <= abs(by - b0)) {
            b = bx;
        } else if by != none {
            b = by;
        }
        // Interpolation between two values in [0, 1] stays there; guard rounding and NaN anyway.
        if !(b >= 0.0 && b <= 1.0) {
            b = clamp(b0, 0.0, 1.0);
        }
    }
    textureStore(dst, pixel, vec4<f32>(b, 0.0, 0.0, 0.0));
}
