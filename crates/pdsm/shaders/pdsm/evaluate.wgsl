// Penumbra deep shadow map evaluation (St-Amour et al. 2005, section 4, Algorithm 2): project the
// pixel's surface point into the PDSM (a view from the light centre), evaluate the attenuation
// functions of the four nearest texels and filter them bilinearly. Each texel's function is read
// where the pixel's tangent plane crosses that texel's ray, less a slope-scaled bias (neither is in
// the paper). The functions live in two storage buffers (Fig. 6): `offsets[i]..offsets[i + 1]`
// indexes texel i's (depth, visibility) vertices in `vertices`. Beside them, a texture holds each
// texel's two end vertices and its longest segment (not in the paper): a depth behind every event
// of a texel's ray, in front of all of them, or inside that segment needs only those fetches, and
// the buffers are read only elsewhere. Dynamic casters, absent from the precompute, come from a
// per-frame shadow map with percentage-closer filtering, multiplied in (section 5).
//
// Two draws of this file (`Evaluation` in lib.rs): with ENDS_PASS, a pixel whose four texels the
// ends answer is written and marked in the stencil, the others are discarded; without it, the
// whole evaluation runs where the stencil is still clear (docs/DEVICES.md, "Lavapipe's
// branches").
#import softshadow::frame::{frame, load_surface, light_cosine}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}
#import softshadow::shadow_view::{ShadowView, view_uv, linear_depth, texel_slope, in_map}

struct PdsmParams {
    // s_min, s_max, t_min, t_max of the PDSM window (slopes from the light centre).
    window: vec4<f32>,
    // PDSM edge in texels, bias in sample-map texel footprints, slope extent of one PDSM texel,
    // PCF kernel radius in texels of the dynamic map.
    size_bias: vec4<f32>,
    // 1 when the dynamic-caster map was drawn this frame (the DYNAMIC permutation runs then),
    // slope extent of one light-sample map texel (at most: the PDSM window over the map edge).
    dynamic_map_texel: vec4<f32>,
}

@group(1) @binding(0) var<uniform> params: PdsmParams;
@group(1) @binding(1) var<storage, read> offsets: array<u32>;
@group(1) @binding(2) var<storage, read> vertices: array<vec2<f32>>;
@group(1) @binding(3) var<uniform> dynamic_view: ShadowView;
@group(1) @binding(4) var dynamic_map: texture_depth_2d;
// Two texels per PDSM texel (x = 2i, 2i + 1): its last vertex (depth, visibility) and first
// vertex (depth, visibility), a texel without vertices holding (-FLT_MAX, 1, -FLT_MAX, 1), lit at
// every depth; then its longest segment (start depth, visibility, end depth, visibility), or
// (1, 1, 0, 1), matching no depth, for fewer than two vertices.
@group(1) @binding(5) var ends: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

// One texel's piecewise-linear function at `depth` (constant beyond its ends; no vertices = lit).
// The ends texture answers the two constant parts in one fetch: most receivers lie behind every
// caster of their ray (depth >= last vertex) and caster tops in front of all of them; a second
// fetch answers the longest segment. Elsewhere the buffers are read: a binary search for the
// first vertex deeper than `depth` (at a step's own depth the value after the step, as in the CPU
// `function::evaluate`). Every answer is the one the search would give, bit for bit. In the
// ENDS_PASS draw a depth the fetches do not answer returns -1 instead of searching.
fn texel_visibility(texel: vec2<i32>, depth: f32) -> f32 {
    let n = i32(params.size_bias.x);
    let c = clamp(texel, vec2<i32>(0), vec2<i32>(n - 1));
    let e = textureLoad(ends, vec2<i32>(2 * c.x, c.y), 0);
    let g = textureLoad(ends, vec2<i32>(2 * c.x + 1, c.y), 0);
    // Chosen with `select`, in the order the cases take precedence, not by early returns
    // (docs/DEVICES.md, "Lavapipe's branches").
    // Inside the longest segment: the search's own result (it brackets such a depth by the
    // segment's two vertices). A receiver's point usually lies in the gap before its own events.
    let in_segment = depth >= g.x && depth < g.z;
    var v = select(-1.0, mix(g.y, g.w, (depth - g.x) / (g.z - g.x)), in_segment);
    v = select(v, e.w, depth < e.z);
    v = select(v, e.y, depth >= e.x);
#ifndef ENDS_PASS
    if !(depth >= e.x || depth < e.z || in_segment) {
        // Between the texel's first and last vertex, outside the segment: the binary search.
        let index = u32(c.y * n + c.x);
        let start = offsets[index];
        let end = offsets[index + 1u];
        // Fewer than two vertices is unreachable for finite depths (an empty texel and a single
        // vertex are answered above).
        v = e.y;
        if end - start >= 2u {
            // Invariant: vertices[lo].x <= depth < vertices[hi].x.
            var lo = start;
            var hi = end - 1u;
            while hi - lo > 1u {
                let mid = (lo + hi) / 2u;
                if depth < vertices[mid].x {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            let previous = vertices[lo];
            let next = vertices[hi];
            v = mix(previous.y, next.y, (depth - previous.x) / (next.x - previous.x));
        }
    }
#endif
    // With ENDS_PASS, -1 where the ends do not answer: the second draw searches that pixel.
    return v;
}

#ifdef DYNAMIC
// Only in the DYNAMIC permutation, drawn when there are dynamic casters (docs/DEVICES.md,
// "Lavapipe's branches").
fn dynamic_visibility(light_pos: vec3<f32>, cosine: f32) -> f32 {
    let uv = view_uv(dynamic_view, light_pos);
    if !in_map(uv) {
        return 1.0;
    }
    let radius = i32(params.size_bias.w);
    let bias = params.size_bias.y * texel_slope(dynamic_view) * light_pos.z / cosine;
    let centre = vec2<i32>(uv * dynamic_view.size.xy);
    let last = vec2<i32>(dynamic_view.size.xy) - 1;
    var lit = 0.0;
    var total = 0.0;
    for (var dy = -radius; dy <= radius; dy++) {
        for (var dx = -radius; dx <= radius; dx++) {
            let texel = clamp(centre + vec2<i32>(dx, dy), vec2<i32>(0), last);
            let d = textureLoad(dynamic_map, texel, 0);
            let unoccluded = d >= 1.0 || linear_depth(dynamic_view, d) >= light_pos.z - bias;
            lit += select(0.0, 1.0, unoccluded);
            total += 1.0;
        }
    }
    return lit / total;
}
#endif

// The depth at which the plane `dot(normal, x) = plane` (light space) crosses the ray of PDSM
// texel `texel` (through its centre, from the light centre), kept within two texel footprints of
// `depth` so a grazing plane does not reach far along the ray.
fn tap_depth(texel: vec2<i32>, normal: vec3<f32>, plane: f32, depth: f32) -> f32 {
    let w = params.window;
    let n = params.size_bias.x;
    let centre = (vec2<f32>(texel) + 0.5) / n;
    let ray = vec3<f32>(mix(w.x, w.y, centre.x), mix(w.w, w.z, centre.y), 1.0);
    let facing = dot(normal, ray);
    let reach = 2.0 * params.size_bias.z * depth / max(abs(normal.z), 0.1);
    if abs(facing) < 1e-6 {
        return depth;
    }
    return clamp(plane / facing, depth - reach, depth + reach);
}

// Texel `texel`'s function at its tangent-plane depth (`tap_depth`), scaled by `bias`.
fn tap(texel: vec2<i32>, normal: vec3<f32>, plane: f32, depth: f32, bias: f32) -> f32 {
    return texel_visibility(texel, tap_depth(texel, normal, plane, depth) * bias);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver {
        return vec4<f32>(1.0);
    }
    if s.light.z <= 0.0 {
        // Behind the one-sided light.
        return vec4<f32>(0.0);
    }
    let cosine = light_cosine(s);
    let slope = s.light.xy / s.light.z;
    let w = params.window;
    let n = params.size_bias.x;
    // Texel coordinates with texel centres at integers (row 0 at t_max).
    let p = vec2<f32>(
        (slope.x - w.x) / (w.y - w.x) * n - 0.5,
        (w.w - slope.y) / (w.w - w.z) * n - 0.5,
    );
    if any(p < vec2<f32>(-0.5)) || any(p > vec2<f32>(n - 0.5)) {
        // Outside the window no static caster can shadow (the window is fitted to cover every
        // point they shadow): only dynamic casters remain.
#ifdef DYNAMIC
        return vec4<f32>(dynamic_visibility(s.light, cosine));
#else
        return vec4<f32>(1.0);
#endif
    }
    let base = floor(p);
    let f = p - base;
    let t = vec2<i32>(base);
    // Each tap's ray leaves the pixel's point by up to a texel: read its function where the
    // pixel's tangent plane crosses that ray, not at the pixel's own depth, or a lit surface
    // facing the light reads half of its taps as behind its own first event (acne).
    let normal = (frame.world_to_light * vec4<f32>(s.normal, 0.0)).xyz;
    let plane = dot(normal, s.light);
    // Slope-scaled bias: the events of a caster's own surface come from sample-map texels, whose
    // depth is that of their centre, so they lie up to a map texel's footprint times the
    // surface's slope (tan of its angle to the light) in front of it; the 1 keeps a bias where a
    // curved caster faces the light (specks on the balls' tops without it). At most 2 % of the depth:
    // with a light near a large receiver the map texels are wide, and a bias of their size moved
    // `stiff-near-light`'s ground in front of its caster (mae 0.17 against 0.007).
    let tangent = sqrt(max(1.0 - cosine * cosine, 0.0)) / cosine;
    let bias = 1.0 - min(params.size_bias.y * params.dynamic_map_texel.y * (1.0 + tangent), 0.02);
    let v00 = tap(t, normal, plane, s.light.z, bias);
    let v10 = tap(t + vec2<i32>(1, 0), normal, plane, s.light.z, bias);
    let v01 = tap(t + vec2<i32>(0, 1), normal, plane, s.light.z, bias);
    let v11 = tap(t + vec2<i32>(1, 1), normal, plane, s.light.z, bias);
#ifdef ENDS_PASS
    if min(min(v00, v10), min(v01, v11)) < 0.0 {
        // Inside a penumbra: left unmarked for the second draw.
        discard;
    }
#endif
    var v = mix(mix(v00, v10, f.x), mix(v01, v11, f.x), f.y);
#ifdef DYNAMIC
    v *= dynamic_visibility(s.light, cosine);
#endif
    return vec4<f32>(clamp(v, 0.0, 1.0));
}
