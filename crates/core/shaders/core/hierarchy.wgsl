// Depth hierarchies over a shadow map (crates/core/src/hierarchy.rs), one compute dispatch per level:
//   linearize:  hardware depth -> light-space z as (min, max) = (z, z); HIERARCHY_EMPTY where no
//               caster was rendered and in the padding up to the next power of two;
//   hsm_reduce: HSM mip i = min/max of the 2 x 2 children in mip i - 1 (Guennebaud et al. 2006);
//   mssm_level: MSSM level i = min/max of four level-(i - 1) texels whose neighbourhoods tile the
//               2^i x 2^i neighbourhood centred on the texel, clamped to the edge (bitmask paper
//               sec. 5, Fig. 7).
#import softshadow::shadow_view::{ShadowView, linear_depth}
#import softshadow::search_area::{HIERARCHY_EMPTY, combine_range}

struct LevelParams {
    level: u32,
}

@group(0) @binding(0) var<uniform> view: ShadowView;
@group(0) @binding(1) var depth_map: texture_depth_2d;
@group(0) @binding(2) var src: texture_2d<f32>;
@group(0) @binding(3) var<uniform> level_params: LevelParams;
@group(0) @binding(4) var dst: texture_storage_2d<rg32float, write>;

@compute @workgroup_size(8, 8)
fn linearize(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= textureDimensions(dst)) {
        return;
    }
    var z = HIERARCHY_EMPTY;
    if all(id.xy < textureDimensions(depth_map)) {
        let d = textureLoad(depth_map, vec2<i32>(id.xy), 0);
        if d < 1.0 {
            z = linear_depth(view, d);
        }
    }
    textureStore(dst, vec2<i32>(id.xy), vec4<f32>(z, z, 0.0, 0.0));
}

fn src_texel(p: vec2<i32>) -> vec2<f32> {
    let size = vec2<i32>(textureDimensions(src));
    return textureLoad(src, clamp(p, vec2<i32>(0), size - 1), 0).xy;
}

@compute @workgroup_size(8, 8)
fn hsm_reduce(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= textureDimensions(dst)) {
        return;
    }
    let p = vec2<i32>(id.xy) * 2;
    let r = combine_range(
        combine_range(src_texel(p), src_texel(p + vec2<i32>(1, 0))),
        combine_range(src_texel(p + vec2<i32>(0, 1)), src_texel(p + vec2<i32>(1, 1))),
    );
    textureStore(dst, vec2<i32>(id.xy), vec4<f32>(r, 0.0, 0.0));
}

@compute @workgroup_size(8, 8)
fn mssm_level(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= textureDimensions(dst)) {
        return;
    }
    // Level i covers [x - size / 2, x + size / 2 - 1]; its halves are the neighbourhoods of the
    // level-(i - 1) texels at x + low and x + high.
    let size = 1 << level_params.level;
    let half = size / 2;
    let low = -half + half / 2;
    let high = half / 2;
    let p = vec2<i32>(id.xy);
    let r = combine_range(
        combine_range(src_texel(p + vec2<i32>(low, low)), src_texel(p + vec2<i32>(high, low))),
        combine_range(src_texel(p + vec2<i32>(low, high)), src_texel(p + vec2<i32>(high, high))),
    );
    textureStore(dst, vec2<i32>(id.xy), vec4<f32>(r, 0.0, 0.0));
}

// One texel read of `src` into a 1 x 1 target: wgpu puts a barrier before it, so the build
// timestamps around it measure the levels (docs/DEVICES.md, "Lavapipe's timestamps").
@compute @workgroup_size(1)
fn fence() {
    textureStore(dst, vec2<i32>(0), vec4<f32>(textureLoad(src, vec2<i32>(0), 0).xy, 0.0, 0.0));
}
