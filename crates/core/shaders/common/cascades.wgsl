#define_import_path softshadow::cascades

// The sun's cascaded shadow maps (softshadow_core::cascades): which cascade serves a world
// point, the blend across the band at each cascade's far end, and each cascade's texel in world
// units, so techniques state search and filter sizes in world units and a penumbra keeps its
// width across a boundary (docs/TECHNIQUES.md, "The sun").

const MAX_CASCADES: u32 = 4u;

struct Cascades {
    // World to each cascade's clip space (orthographic; depth 0..1 over near..far).
    view_proj: array<mat4x4<f32>, 4>,
    // View depth where each cascade ends.
    split_far: vec4<f32>,
    // Each cascade's texel edge, world units.
    texel_world: vec4<f32>,
    // Each cascade's near plane (light-space z at depth 0) and far - near.
    near: vec4<f32>,
    depth_range: vec4<f32>,
    // xyz: the camera's unit forward axis; w: its near plane's view depth.
    camera_forward: vec4<f32>,
    // x: cascades, y: map edge in texels, z: its inverse, w: the blend fraction.
    info: vec4<f32>,
}

// The cascades that serve a point: `first` (its own) and, in the blend band, `next` weighed
// `blend` (0: `first` alone). `first` = the count: beyond the last cascade (lit).
struct CascadePick {
    first: u32,
    blend: f32,
}

// A world point in one cascade: its texel coordinates (continuous), light-space z and layer.
struct CascadePoint {
    texel: vec2<f32>,
    z: f32,
    layer: i32,
}

fn cascade_count(c: Cascades) -> u32 {
    return min(u32(c.info.x), MAX_CASCADES);
}

// The view depth of `world` seen from `eye`.
fn cascade_view_depth(c: Cascades, eye: vec3<f32>, world: vec3<f32>) -> f32 {
    return dot(world - eye, c.camera_forward.xyz);
}

fn cascade_split_near(c: Cascades, i: u32) -> f32 {
    if i == 0u {
        return c.camera_forward.w;
    }
    return c.split_far[i - 1u];
}

// The cascade of a point at `view_depth`, and the weight of the next one in the band: a linear
// ramp over the last `blend` fraction of the cascade's depths, reaching the next cascade's own
// answer at the boundary, so the answer is continuous across it.
fn cascade_pick(c: Cascades, view_depth: f32) -> CascadePick {
    let n = cascade_count(c);
    var pick = CascadePick(n, 0.0);
    for (var i = 0u; i < n; i = i + 1u) {
        if view_depth <= c.split_far[i] {
            pick.first = i;
            break;
        }
    }
    if pick.first + 1u < n {
        let end = c.split_far[pick.first];
        let band = c.info.w * (end - cascade_split_near(c, pick.first));
        if band > 0.0 {
            pick.blend = clamp((view_depth - (end - band)) / band, 0.0, 1.0);
        }
    }
    return pick;
}

// `world` in cascade `i`.
fn cascade_point(c: Cascades, i: u32, world: vec3<f32>) -> CascadePoint {
    let clip = c.view_proj[i] * vec4<f32>(world, 1.0);
    let uv = vec2<f32>(clip.x * 0.5 + 0.5, 0.5 - clip.y * 0.5);
    return CascadePoint(uv * c.info.y, c.near[i] + clip.z * c.depth_range[i], i32(i));
}

// Hardware depth `d` of cascade `i` as light-space z.
fn cascade_depth_z(c: Cascades, i: u32, d: f32) -> f32 {
    return c.near[i] + d * c.depth_range[i];
}

// A light-space offset (world units across the sun's rays) in texels of cascade `i` (y flipped:
// texel row 0 is the window's top).
fn cascade_texels(c: Cascades, i: u32, offset: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(offset.x, -offset.y) / c.texel_world[i];
}

fn cascade_in_map(c: Cascades, texel: vec2<f32>) -> bool {
    return all(texel >= vec2<f32>(0.0)) && all(texel < vec2<f32>(c.info.y));
}
