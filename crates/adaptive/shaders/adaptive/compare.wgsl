// Adaptive light-source sampling, comparison step (Schwärzler, sections 3.3.2-3.3.3): two
// neighbouring shadow maps are reprojected into camera space at every G-buffer pixel and compared;
// pixels where they differ add one to their pair's counter: the differing pixels p of eq. 4, the
// paper's occlusion query (a query without Vulkan's precise bit may count any non-zero number,
// docs/DEVICES.md). One instance per compared pair; the pair is `items[instance]`.
#import softshadow::frame::{load_surface, light_cosine}
#import softshadow::shadow_view::{ShadowView, view_uv, linear_depth, texel_slope, in_map}

struct Params {
    // x: gamma; y: 1 = relative threshold (eq. 7), 0 = absolute (eq. 3); z: bias in texel
    // footprints; w: unused here.
    values: vec4<f32>,
    // x: number of items (unused here).
    counts: vec4<u32>,
}

@group(1) @binding(0) var<uniform> params: Params;
// The view of every map, indexed by its layer in `depth_maps`.
// A uniform array, not a storage buffer (docs/DEVICES.md, "Lavapipe's branches").
@group(1) @binding(1) var<uniform> views: array<ShadowView, 512>;
// Compared pairs: (layer a, layer b, -, -).
@group(1) @binding(2) var<uniform> items: array<vec4<u32>, 1024>;
@group(1) @binding(3) var depth_maps: texture_depth_2d_array;
// Differing pixels per pair (index = instance), cleared before the pass.
@group(1) @binding(4) var<storage, read_write> differing_pixels: array<atomic<u32>>;

struct Vertex {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) item: u32,
}

@vertex
fn vs_main(@builtin(vertex_index) index: u32, @builtin(instance_index) item: u32) -> Vertex {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    var out: Vertex;
    out.position = vec4<f32>(uv * vec2<f32>(2.0, -2.0) + vec2<f32>(-1.0, 1.0), 0.0, 1.0);
    out.item = item;
    return out;
}

// Light-space depth of the first surface map `layer` sees on its way to the receiver point `p`:
// the caster in front of it, or the receiver itself. The paper's maps hold the receivers too;
// ours hold casters only, so an empty texel or a caster behind the receiver stands for `p.z`.
fn first_surface_depth(layer: u32, p: vec3<f32>, slope_factor: f32) -> f32 {
    let view = views[layer];
    let uv = view_uv(view, p);
    if !in_map(uv) {
        return p.z;
    }
    let d = textureLoad(depth_maps, vec2<i32>(uv * view.size.xy), i32(layer), 0);
    if d >= 1.0 {
        return p.z;
    }
    let z = linear_depth(view, d);
    let bias = params.values.z * texel_slope(view) * slope_factor;
    if z >= p.z - bias {
        return p.z;
    }
    return z;
}

@fragment
fn fs_main(in: Vertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver || s.light.z <= 0.0 {
        discard;
    }
    let pair = items[in.item];
    let slope_factor = s.light.z / light_cosine(s);
    let a = first_surface_depth(pair.x, s.light, slope_factor);
    let b = first_surface_depth(pair.y, s.light, slope_factor);
    let gamma = params.values.x;
    var equal: bool;
    if params.values.y > 0.5 {
        // Eq. 7 on linear depth; b > 0 (a near plane or the receiver, both in front of the light).
        equal = abs(1.0 - a / b) < gamma;
    } else {
        // Eq. 3.
        equal = abs(a - b) < gamma;
    }
    if equal {
        discard;
    }
    atomicAdd(&differing_pixels[in.item], 1u);
    // Additive blending: per pixel, the number of pairs of this level that differ there.
    return vec4<f32>(1.0, 0.0, 0.0, 0.0);
}
