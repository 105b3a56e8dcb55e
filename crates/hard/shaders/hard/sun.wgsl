// Hard shadows from the sun: the cascaded orthographic maps of softshadow::cascades (one map
// fitted to the scene with `cascades` = 1), one depth comparison per pixel in the point's
// cascade, mixed with the next cascade's over the blend band at its far end.
#import softshadow::frame::{frame, load_surface}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}
#import softshadow::cascades::{Cascades, cascade_count, cascade_pick, cascade_point, cascade_view_depth, cascade_depth_z, cascade_in_map}

struct HardParams {
    bias_texels: f32,
}

@group(1) @binding(0) var<uniform> cascades: Cascades;
@group(1) @binding(1) var maps: texture_depth_2d_array;
@group(1) @binding(2) var<uniform> params: HardParams;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

// 1 where `world` is lit in cascade `i`, else 0; the bias is `bias_texels` of the cascade's
// texels in world units, divided by the cosine to the sun.
fn lit_in(i: u32, world: vec3<f32>, cosine: f32) -> f32 {
    let p = cascade_point(cascades, i, world);
    if !cascade_in_map(cascades, p.texel) {
        return 1.0;
    }
    let d = textureLoad(maps, vec2<i32>(p.texel), p.layer, 0);
    if d >= 1.0 {
        return 1.0;
    }
    let bias = params.bias_texels * cascades.texel_world[i] / cosine;
    return select(0.0, 1.0, cascade_depth_z(cascades, i, d) >= p.z - bias);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver {
        return vec4<f32>(1.0);
    }
    let pick = cascade_pick(cascades, cascade_view_depth(cascades, frame.camera_pos.xyz, s.world));
    if pick.first >= cascade_count(cascades) {
        // Beyond the shadowed range.
        return vec4<f32>(1.0);
    }
    let cosine = max(abs(dot(s.normal, frame.light_dir.xyz)), 0.1);
    var v = lit_in(pick.first, s.world, cosine);
    if pick.blend > 0.0 {
        v = mix(v, lit_in(pick.first + 1u, s.world, cosine), pick.blend);
    }
    return vec4<f32>(v);
}
