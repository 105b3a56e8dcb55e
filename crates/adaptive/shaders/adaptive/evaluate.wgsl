// Adaptive light-source sampling, evaluation (Schwärzler, section 3.4). Without ACCUMULATE: one
// pass over the texture array of all maps, V = sum of weight_i * lit_i (section 3.4.2). With
// ACCUMULATE: one instance (one pass) per map, each adding its lit fraction to an accumulation
// buffer by additive blending; `resolve.wgsl` divides by the number of maps (section 3.4.1, equal
// weights, as the paper's deferred variant must). With PCF: the bilinear mix of the four nearest
// texels' tests (section 3.4.3), a permutation rather than a uniform flag (docs/DEVICES.md,
// "Lavapipe's branches").
#import softshadow::frame::{load_surface, light_cosine}
#import softshadow::shadow_view::{ShadowView, view_uv, linear_depth, texel_slope, in_map}

struct Params {
    // x: unused; y: unused; z: bias in texel footprints; w: unused.
    values: vec4<f32>,
    // x: number of items (maps evaluated).
    counts: vec4<u32>,
}

@group(1) @binding(0) var<uniform> params: Params;
// A uniform array, not a storage buffer (docs/DEVICES.md, "Lavapipe's branches").
@group(1) @binding(1) var<uniform> views: array<ShadowView, 512>;
// Evaluated maps: (layer, weight as f32 bits, -, -).
@group(1) @binding(2) var<uniform> items: array<vec4<u32>, 1024>;
@group(1) @binding(3) var depth_maps: texture_depth_2d_array;

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

// 1 when the texel is empty, outside the map or holds a caster behind `reference`.
fn lit_texel(view: ShadowView, layer: u32, texel: vec2<i32>, reference: f32) -> f32 {
    if any(texel < vec2<i32>(0)) || any(texel >= vec2<i32>(view.size.xy)) {
        return 1.0;
    }
    let d = textureLoad(depth_maps, texel, i32(layer), 0);
    if d >= 1.0 || linear_depth(view, d) >= reference {
        return 1.0;
    }
    return 0.0;
}

// Hard-shadow test of map `layer` at the receiver point `p` (1 = lit), or the bilinear mix of
// the four nearest texels' tests with PCF on.
fn lit(layer: u32, p: vec3<f32>, slope_factor: f32) -> f32 {
    let view = views[layer];
    let reference = p.z - params.values.z * texel_slope(view) * slope_factor;
    let uv = view_uv(view, p);
#ifdef PCF
    let f = uv * view.size.xy - 0.5;
    let base = floor(f);
    let t = f - base;
    let b = vec2<i32>(base);
    let top = mix(
        lit_texel(view, layer, b, reference),
        lit_texel(view, layer, b + vec2<i32>(1, 0), reference),
        t.x,
    );
    let bottom = mix(
        lit_texel(view, layer, b + vec2<i32>(0, 1), reference),
        lit_texel(view, layer, b + vec2<i32>(1, 1), reference),
        t.x,
    );
    return mix(top, bottom, t.y);
#else
    if !in_map(uv) {
        return 1.0;
    }
    return lit_texel(view, layer, vec2<i32>(uv * view.size.xy), reference);
#endif
}

@fragment
fn fs_main(in: Vertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
#ifdef ACCUMULATE
    if !s.is_receiver || s.light.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    let slope_factor = s.light.z / light_cosine(s);
    return vec4<f32>(lit(items[in.item].x, s.light, slope_factor), 0.0, 0.0, 0.0);
#else
    if !s.is_receiver {
        return vec4<f32>(1.0);
    }
    if s.light.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    let slope_factor = s.light.z / light_cosine(s);
    var v = 0.0;
    for (var k = 0u; k < params.counts.x; k = k + 1u) {
        let item = items[k];
        v += bitcast<f32>(item.y) * lit(item.x, s.light, slope_factor);
    }
    return vec4<f32>(clamp(v, 0.0, 1.0), 0.0, 0.0, 0.0);
#endif
}
