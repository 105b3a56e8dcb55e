// Shadow-map ray tracing (SMRT), after the description of Unreal Engine 5's virtual shadow maps
// (no paper; docs/TECHNIQUES.md, `smrt`, says what is built and where it differs). One shadow
// map from the light centre; per pixel `ray_count` rays from the receiver point p to points of
// the light rectangle, each marched through the map in `samples_per_ray` steps from the light end
// towards p, uniformly in the map's slope space and clipped to its window. A step compares the
// ray's light-space depth z with the depth d of the nearest caster the map holds at the ray
// point's slope:
//   - in front of it by more than the bias, or no caster there: the step is free; it becomes
//     the history (last free depth z_f, the surface d_f seen there and that surface's depth
//     slope along the march, clamped to +-extrapolate_max_slope);
//   - within the bias of it: on the surface, nothing is learnt;
//   - behind it by more than the bias: the map alone cannot say whether the ray crossed that
//     caster or passed under its silhouette. The ray is occluded when
//       (a) the caster's depth lies inside this step (z_f < d): the ray crossed its surface, or
//       (b) the surface seen at the last free step, extrapolated along its slope, is now in
//           front of the ray (the behind-occluder extrapolation: a caster hidden behind another
//           one is still hit if the ray saw it before going behind);
//     otherwise the ray goes on (it passes under the caster's silhouette: the penumbra).
// The last step is the receiver end of the ray's part inside the window (the receiver itself
// when its slope is inside).
// Light points: a rank-1 lattice (R2) rotated per pixel by interleaved gradient noise, so the
// result is deterministic for a fixed frame. Debug permutations write the marched steps
// (DEBUG_STEPS) or the fraction of rays the extrapolation occluded (DEBUG_EXTRAPOLATED) instead
// of the visibility.
// Under the sun (SUN): core's cascaded orthographic maps; a ray toward a direction of the sun's
// cone moves (z_p - z) tan(theta) across the rays per unit of depth, a straight line in the
// point's cascade, marched from the cascade's near plane to the receiver with the same steps;
// in the blend band at a cascade's far end the next cascade's answer is mixed in.
#import softshadow::frame::{frame, load_surface, light_cosine, light_kind}
#import softshadow::light::{LIGHT_RECT, concentric_disk}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}
#import softshadow::shadow_view::{ShadowView, slope_to_uv, linear_depth, texel_slope, in_map}
#import softshadow::sampling::interleaved_gradient_noise
#import softshadow::cascades::{Cascades, CascadePoint, cascade_count, cascade_pick, cascade_point, cascade_view_depth, cascade_depth_z, cascade_in_map, cascade_texels}

// Mirrors the settings' ranges (src/lib.rs): at most 64 x 64 = 4096 steps per pixel, far under
// lavapipe 22.3's loop budget (docs/DEVICES.md, "Lavapipe's loop budget").
const MAX_RAYS: u32 = 64u;
const MAX_SAMPLES: u32 = 64u;
// Depth of "no caster on this centre ray".
const EMPTY: f32 = 1e30;
// Roberts' R2 sequence: the rank-1 lattice of the plastic number, low discrepancy in 2D for any
// point count.
const R2: vec2<f32> = vec2<f32>(0.7548776662466927, 0.5698402909980532);
const GOLDEN: f32 = 0.6180339887498949;

struct SmrtParams {
    ray_count: u32,
    samples_per_ray: u32,
    bias_texels: f32,
    extrapolate_max_slope: f32,
    ray_length_scale: f32,
    texel_dither: f32,
    // tan of the largest angle a ray spans as seen from the light (1e30: no limit).
    max_ray_tan: f32,
}

#ifdef SUN
@group(1) @binding(0) var<uniform> cascades: Cascades;
@group(1) @binding(1) var maps: texture_depth_2d_array;
@group(1) @binding(2) var<uniform> params: SmrtParams;
#else
@group(1) @binding(0) var<uniform> view: ShadowView;
@group(1) @binding(1) var shadow_map: texture_depth_2d;
@group(1) @binding(2) var<uniform> params: SmrtParams;
#endif

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

#ifndef SUN
// Light-space depth of the nearest caster at `slope`, EMPTY outside the map or where it is empty
// (the map's window covers every caster, so nothing lies outside it).
fn caster_depth(slope: vec2<f32>) -> f32 {
    let uv = slope_to_uv(view, slope);
    if !in_map(uv) {
        return EMPTY;
    }
    let d = textureLoad(shadow_map, vec2<i32>(uv * view.size.xy), 0);
    return select(linear_depth(view, d), EMPTY, d >= 1.0);
}
#endif

struct Trace {
    hit: bool,
    // The hit came from the extrapolation (b), not from a crossing (a).
    extrapolated: bool,
    steps: u32,
}

// A ray's march: its result so far and its history (the last free depth z_free, the surface
// depth d_free seen there and that surface's depth slope along the march).
struct March {
    result: Trace,
    z_free: f32,
    d_free: f32,
    slope: f32,
}

// One step at ray depth `z` over the caster depth `d` (EMPTY: none) with depth bias `bias`, as
// the header says; true when the ray is occluded (the march stops).
fn march_step(m: ptr<function, March>, z: f32, d: f32, bias: f32) -> bool {
    (*m).result.steps += 1u;
    if d < EMPTY && abs(z - d) <= bias {
        // On the surface, within the bias (the receiver's own surface near the end, or a
        // caster the ray grazes): neither free nor behind; nothing is learnt.
    } else if d < EMPTY && z - d > bias {
        let crossed = d > (*m).z_free;
        let d_ext = select((*m).d_free + (*m).slope * (z - (*m).z_free), EMPTY, (*m).d_free >= EMPTY);
        let extrapolated = z - d_ext > bias;
        if crossed || extrapolated {
            (*m).result.hit = true;
            (*m).result.extrapolated = !crossed;
            return true;
        }
    } else {
        // Depth slope of the surface seen along the march, from two free steps that both
        // see a caster (none across an empty texel: it has no depth).
        let both = d < EMPTY && (*m).d_free < EMPTY && z > (*m).z_free;
        let mx = params.extrapolate_max_slope;
        (*m).slope = select(0.0, clamp((d - (*m).d_free) / max(z - (*m).z_free, 1e-12), -mx, mx), both);
        (*m).d_free = d;
        (*m).z_free = z;
    }
    return false;
}

// Clips the ray's parameter interval `range` to the map window along one axis, where the ray's
// slope is `s + d * delta` and the window is [lo, hi] (Liang and Barsky's clipping).
fn clip_axis(range: vec2<f32>, s: f32, d: f32, lo: f32, hi: f32) -> vec2<f32> {
    if abs(d) < 1e-30 {
        // Parallel to this axis: inside or outside for the whole ray.
        return select(vec2<f32>(1.0, 0.0), range, s >= lo && s <= hi);
    }
    let a = (lo - s) / d;
    let b = (hi - s) / d;
    return vec2<f32>(max(range.x, min(a, b)), min(range.y, max(a, b)));
}

#ifndef SUN
// One ray from `origin` (light space) to the light point (`light_point`, 0), marched from depth
// `z_start` (its light end, at or beyond the map's near plane) to the origin's depth, in `n`
// steps; `jitter` in [0, 1) shifts them; `bias_per_depth` times a step's depth is its depth bias.
//
// In the slope space of a perspective map from `eye` the ray is a straight line: its point at
// depth z has slope s_o + (L - eye) (1/z - 1/z_p), with s_o the origin's own slope. So the march
// runs in inverse depth, uniformly in slope (every step moves the same number of texels, which is
// what decides whether a caster is skipped), clipped to the map's window (outside it there are no
// casters).
fn trace(origin: vec3<f32>, light_point: vec2<f32>, z_start: f32, n: u32, jitter: f32, bias_per_depth: f32) -> Trace {
    var result = Trace(false, false, 0u);
    let eye = view.eye_near_far.xy;
    let v_p = 1.0 / origin.z;
    let s_o = (origin.xy - eye) * v_p;
    let dir = light_point - eye;
    // delta = 1/z - 1/z_p, from 0 (the receiver) to the light end.
    var range = vec2<f32>(0.0, max(1.0 / z_start - v_p, 0.0));
    // Largest angle the ray spans as seen from the light (Unreal's MaxRayAngleFromLight): its
    // slope extent in the map, |dir| delta, at most tan(angle); the light end is cut off.
    let unlimited = range.y;
    range.y = min(range.y, params.max_ray_tan / max(length(dir), 1e-30));
    range = clip_axis(range, s_o.x, dir.x, view.window.x, view.window.y);
    range = clip_axis(range, s_o.y, dir.y, view.window.z, view.window.w);
    if range.x > range.y {
        // The ray never crosses the window: no caster lies on it.
        return result;
    }
    // History: the last free step, initially the light end of the marched part: nothing lies
    // nearer the light. At the near plane a caster may lie at that very depth (the plane is
    // fitted to the casters), so the end is put just in front of it; at the window's border the
    // ray enters the window at that depth and is free up to it.
    let unclipped = range.y >= unlimited;
    let z_free = select(1.0 / (v_p + range.y), z_start * (1.0 - 1e-3), unclipped);
    var m = March(result, z_free, EMPTY, 0.0);
    for (var k = 0u; k < n; k = k + 1u) {
        // From the light end towards the receiver; the last step at the receiver end.
        let w = select((f32(k) + jitter) / f32(n), 1.0, k + 1u == n);
        let delta = mix(range.y, range.x, w);
        let z = 1.0 / (v_p + delta);
        if march_step(&m, z, caster_depth(s_o + dir * delta), bias_per_depth * z) {
            break;
        }
    }
    return m.result;
}

#endif

#ifdef SUN
// Light-space z of the nearest caster at `texel` of cascade `i`, EMPTY outside the map or where
// it is empty.
fn sun_caster_z(i: u32, texel: vec2<f32>) -> f32 {
    if !cascade_in_map(cascades, texel) {
        return EMPTY;
    }
    let d = textureLoad(maps, vec2<i32>(texel), i32(i), 0);
    return select(cascade_depth_z(cascades, i, d), EMPTY, d >= 1.0);
}

// One ray from the point `p` of cascade `i` toward a direction of the sun's cone that moves
// `across` world units across the rays per unit of depth, marched from the cascade's near plane
// (towards the receiver by `ray_length_scale`) to p in `n` steps. With t the depth travelled
// toward the sun, the ray's point lies at z = p.z - t, texel p.texel + t across (in texels).
fn trace_sun(i: u32, p: CascadePoint, across: vec2<f32>, n: u32, jitter: f32, bias: f32) -> Trace {
    let t_max = max(params.ray_length_scale * (p.z - cascades.near[i]), 0.0);
    let per_t = cascade_texels(cascades, i, across);
    var range = vec2<f32>(0.0, t_max);
    range = clip_axis(range, p.texel.x, per_t.x, 0.0, cascades.info.y);
    range = clip_axis(range, p.texel.y, per_t.y, 0.0, cascades.info.y);
    var m = March(Trace(false, false, 0u), p.z - range.y, EMPTY, 0.0);
    if range.x > range.y {
        return m.result;
    }
    if range.y >= t_max {
        // The light end at the near plane, where a caster may lie: just in front of it.
        m.z_free -= 1e-3 * cascades.depth_range[i];
    }
    for (var k = 0u; k < n; k = k + 1u) {
        let w = select((f32(k) + jitter) / f32(n), 1.0, k + 1u == n);
        let t = mix(range.y, range.x, w);
        if march_step(&m, p.z - t, sun_caster_z(i, p.texel + per_t * t), bias) {
            break;
        }
    }
    return m.result;
}

// The lit fraction of `world` in cascade `i`: `ray_count` rays over the sun's cone (its disk of
// tangents, the same strata as a round light's), each receiver end dithered by up to
// +-texel_dither / 2 of the cascade's texels. `max_ray_angle` does not apply (parallel rays).
fn rays_in(i: u32, world: vec3<f32>, cosine: f32, pixel: vec2<f32>) -> f32 {
    let origin = cascade_point(cascades, i, world);
    let n = clamp(params.samples_per_ray, 1u, MAX_SAMPLES);
    let rays = clamp(params.ray_count, 1u, MAX_RAYS);
    let bias = params.bias_texels * cascades.texel_world[i] / cosine;
    let noise = vec2<f32>(
        interleaved_gradient_noise(pixel),
        interleaved_gradient_noise(pixel + vec2<f32>(47.0, 17.0)),
    );
    let dither_noise = vec2<f32>(
        interleaved_gradient_noise(pixel + vec2<f32>(101.0, 61.0)),
        interleaved_gradient_noise(pixel + vec2<f32>(23.0, 131.0)),
    );
    var hits = 0u;
    for (var r = 0u; r < rays; r = r + 1u) {
        let across = concentric_disk(fract(noise + f32(r) * R2)) * frame.light_sun.y;
        var p = origin;
        p.texel += (fract(dither_noise + f32(r) * R2) - 0.5) * params.texel_dither;
        let jitter = fract(noise.x * 0.5 + noise.y * 0.5 + f32(r) * GOLDEN);
        hits += select(0u, 1u, trace_sun(i, p, across, n, jitter, bias).hit);
    }
    return clamp(1.0 - f32(hits) / f32(rays), 0.0, 1.0);
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
    var v = rays_in(pick.first, s.world, cosine, in.position.xy);
    if pick.blend > 0.0 {
        v = mix(v, rays_in(pick.first + 1u, s.world, cosine, in.position.xy), pick.blend);
    }
    return vec4<f32>(v);
}
#else
@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver {
        return vec4<f32>(1.0);
    }
    let z_p = s.light.z;
    if z_p <= 0.0 {
        return vec4<f32>(0.0);
    }
    let near = view.eye_near_far.z;
    // The march covers the part of the ray where casters can be: from the near plane (scaled
    // towards the receiver by `ray_length_scale`) to the receiver.
    // A receiver nearer than the near plane has nothing in front of it: every step lands on it.
    let z_start = min(max(z_p - params.ray_length_scale * (z_p - near), near), z_p);
    let texel = texel_slope(view);
    let bias_per_depth = params.bias_texels * texel / light_cosine(s);
    let n = clamp(params.samples_per_ray, 1u, MAX_SAMPLES);
    let rays = clamp(params.ray_count, 1u, MAX_RAYS);
    let half_light = frame.light_half.xy;
    let noise = vec2<f32>(
        interleaved_gradient_noise(in.position.xy),
        interleaved_gradient_noise(in.position.xy + vec2<f32>(47.0, 17.0)),
    );
    let dither_noise = vec2<f32>(
        interleaved_gradient_noise(in.position.xy + vec2<f32>(101.0, 61.0)),
        interleaved_gradient_noise(in.position.xy + vec2<f32>(23.0, 131.0)),
    );
    var hits = 0u;
    var extrapolated = 0u;
    var steps = 0u;
    for (var i = 0u; i < rays; i = i + 1u) {
        let u = fract(noise + f32(i) * R2);
        var light_point = (u * 2.0 - 1.0) * half_light;
        if light_kind() != LIGHT_RECT {
            // A disk (a spot's source; a sphere's disk in the light plane): the same strata on it.
            light_point = concentric_disk(u) * frame.light_shape.y;
        }
        // Texel dither: the ray's receiver end moves by up to +-texel_dither / 2 map texels
        // (footprints at the receiver), a different offset per ray, which turns the map's texel
        // staircase into noise.
        let dither = (fract(dither_noise + f32(i) * R2) - 0.5) * params.texel_dither * texel * z_p;
        let origin = vec3<f32>(s.light.xy + dither, z_p);
        let jitter = fract(noise.x * 0.5 + noise.y * 0.5 + f32(i) * GOLDEN);
        let r = trace(origin, light_point, z_start, n, jitter, bias_per_depth);
        hits += select(0u, 1u, r.hit);
        extrapolated += select(0u, 1u, r.hit && r.extrapolated);
        steps += r.steps;
    }
#ifdef DEBUG_STEPS
    return vec4<f32>(f32(steps));
#else
#ifdef DEBUG_EXTRAPOLATED
    return vec4<f32>(f32(extrapolated) / f32(rays));
#else
    return vec4<f32>(clamp(1.0 - f32(hits) / f32(rays), 0.0, 1.0));
#endif
#endif
}
#endif
