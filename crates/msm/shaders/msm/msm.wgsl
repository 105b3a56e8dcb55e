// Moment soft shadows (Peters et al. 2016, "Beyond Hard Shadows", soft shadows: PCSS with its
// blocker search and filter both answered by filtered moments instead of per-texel depth tests),
// in the slope space of one perspective map from the light centre (as pcss.wgsl):
//   1. Mean moments over the blocker-search rectangle (the light seen through the receiver down
//      to the near plane, scaled by `blocker_search_scale`) give the fraction of blockers and
//      their mean depth d_b.
//   2. Penumbra half extent (parallel planes, Fernando 2005): a (z_r - d_b) / (d_b z_r) slopes.
//   3. Mean moments over that rectangle give the lit fraction.
// Mean moments over a rectangle come from the moment map's mip chain: filter_taps^2 trilinear
// taps at the level whose texels are the tap spacing (docs/TECHNIQUES.md, msm).
// Lit fraction from moments:
//   msm (default): Hamburger 4MSM with moment bias (Peters and Klein 2015, Section 4.1,
//     Algorithm 2), its sharpest lower bound on the shadow.
//   EVSM: Chebyshev's upper bound on the lit fraction of the exponentially warped depth
//     (Lauritzen and McCool 2008), the positive warp (EVSM2) or the smaller of both (EVSM4);
//     the blocker search uses the negative warp in both (the map holds both warps).
// Then light-bleeding reduction: lit' = clamp((lit - r) / (1 - r), 0, 1) (Lauritzen 2007, GPU
// Gems 3 chapter 8).
// Under the sun (SUN): the same steps in each of core's cascades (one moment map per cascade,
// the layers of one array), with the sun a cone of half-angle alpha / 2: the search is the
// cone cut at the cascade's near plane, the penumbra half width tan(alpha / 2) (z_r - d_b), both
// in world units turned into the cascade's texels (as pcss/sun.wgsl), so the softness does not
// jump at a boundary; in the blend band the next cascade's answer is mixed in.
#import softshadow::frame::{frame, load_surface, light_cosine}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}
#import softshadow::shadow_view::{ShadowView, view_slope, slope_to_uv, texel_slope}
#import softshadow::cascades::{Cascades, cascade_count, cascade_pick, cascade_point, cascade_view_depth, cascade_texels}

struct MsmParams {
    depth_range: vec2<f32>,
    exponents: vec2<f32>,
    moment_bias: f32,
    light_bleeding_reduction: f32,
    bias_texels: f32,
    blocker_search_scale: f32,
    min_filter_texels: f32,
    filter_taps: u32,
    levels: u32,
}

const MAX_FILTER_TAPS: u32 = 8u;
// Below this fraction of blockers the blocker search finds none: the pixel is lit.
const NO_BLOCKER: f32 = 1e-3;

#ifdef SUN
@group(1) @binding(0) var<uniform> cascades: Cascades;
@group(1) @binding(1) var moments: texture_2d_array<f32>;
@group(1) @binding(2) var<uniform> params: MsmParams;
// The cascade whose moment map the lookups below read.
var<private> cascade_layer: i32;
#else
@group(1) @binding(0) var<uniform> view: ShadowView;
@group(1) @binding(1) var moments: texture_2d<f32>;
@group(1) @binding(2) var<uniform> params: MsmParams;
#endif

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

// Kept equal to moments.wgsl's.
fn moments_of(z: f32) -> vec4<f32> {
#ifdef EVSM
    let x = 2.0 * z - 1.0;
    let positive = exp(params.exponents.x * x);
    let negative = -exp(-params.exponents.y * x);
    return vec4<f32>(positive, positive * positive, negative, negative * negative);
#else
    let z2 = z * z;
    return vec4<f32>(z, z2, z2 * z, z2 * z2);
#endif
}

// Texel `p` of mip `level`; outside the map there is no caster (the map's window covers every
// caster, docs/ARCHITECTURE.md "Light space and shadow maps"), so an empty texel's moments.
fn level_texel(level: i32, p: vec2<i32>) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(moments, level));
    if any(p < vec2<i32>(0)) || any(p >= size) {
        return moments_of(1.0);
    }
#ifdef SUN
    return textureLoad(moments, p, cascade_layer, level);
#else
    return textureLoad(moments, p, level);
#endif
}

// Bilinear interpolation of mip `level` at `p` (level-0 texel units).
fn bilinear(level: i32, p: vec2<f32>) -> vec4<f32> {
    let q = p / f32(1 << u32(level)) - 0.5;
    let base = floor(q);
    let f = q - base;
    let i = vec2<i32>(base);
    let top = mix(level_texel(level, i), level_texel(level, i + vec2<i32>(1, 0)), f.x);
    let bottom = mix(level_texel(level, i + vec2<i32>(0, 1)), level_texel(level, i + vec2<i32>(1, 1)), f.x);
    return mix(top, bottom, f.y);
}

// Mean moments over the rectangle `centre_texel` +- `half_texels` (level-0 texels):
// filter_taps^2 taps on a regular grid, each interpolated between the two mip levels around the
// tap spacing.
fn box_moments_texels(centre_texel: vec2<f32>, half_texels: vec2<f32>) -> vec4<f32> {
    let taps = clamp(params.filter_taps, 1u, MAX_FILTER_TAPS);
    let spacing = 2.0 * max(half_texels.x, half_texels.y) / f32(taps);
    let level = clamp(log2(max(spacing, 1.0)), 0.0, f32(params.levels - 1u));
    let fine = i32(floor(level));
    let coarse = min(fine + 1, i32(params.levels) - 1);
    let t = level - f32(fine);
    var sum = vec4<f32>(0.0);
    for (var j = 0u; j < taps; j += 1u) {
        for (var i = 0u; i < taps; i += 1u) {
            let cell = (vec2<f32>(f32(i), f32(j)) + 0.5) / f32(taps) * 2.0 - 1.0;
            let p = centre_texel + cell * half_texels;
            sum += mix(bilinear(fine, p), bilinear(coarse, p), t);
        }
    }
    return sum / f32(taps * taps);
}

#ifndef SUN
// Mean moments over the slope rectangle `centre` +- `half_extent`.
fn box_moments(centre: vec2<f32>, half_extent: vec2<f32>) -> vec4<f32> {
    let centre_texel = slope_to_uv(view, centre) * view.size.xy;
    return box_moments_texels(centre_texel, half_extent / texel_slope(view));
}
#endif

// Avoids dividing by zero while keeping the sign.
fn nonzero(x: f32) -> f32 {
    return select(x, select(-1e-20, 1e-20, x >= 0.0), abs(x) < 1e-20);
}

// Hamburger 4MSM (Peters and Klein 2015, Section 4.1, Algorithm 2): the distribution with three
// atoms, one at the receiver depth z_f, whose first moments are the biased moments b. Returns
// (fraction of the distribution strictly in front of z_f: the shadow, mean depth of that part).
fn hamburger(filtered: vec4<f32>, z_f: f32) -> vec2<f32> {
    // Moment bias: a convex combination with the moments of a wide distribution (the paper's
    // alpha, 3e-5 for 32-bit floats).
    let b = mix(filtered, vec4<f32>(0.5), params.moment_bias);
    // Hankel matrix [[1, b1, b2], [b1, b2, b3], [b2, b3, b4]] = L D L^T.
    let d22 = nonzero(b.y - b.x * b.x);
    let l32 = (b.z - b.x * b.y) / d22;
    let d33 = nonzero(b.w - b.y * b.y - l32 * l32 * d22);
    // Solve B c = (1, z_f, z_f^2): c0 + c1 z + c2 z^2 vanishes at the two other atoms.
    let y1 = (z_f - b.x) / d22;
    let y2 = (z_f * z_f - b.y - l32 * (z_f - b.x)) / d33;
    let c2 = nonzero(y2);
    let c1 = y1 - l32 * y2;
    let c0 = 1.0 - b.x * c1 - b.y * y2;
    let discriminant = max(c1 * c1 - 4.0 * c0 * c2, 0.0);
    let root = sqrt(discriminant);
    let za = (-c1 - root) / (2.0 * c2);
    let zb = (-c1 + root) / (2.0 * c2);
    let z1 = min(za, zb);
    let z2 = max(za, zb);
    // Weight of an atom at u of the distribution on {u, v, w}: E[(z - v)(z - w)] / ((u - v)(u - w)).
    if z2 < z_f {
        // Both other atoms in front: the shadow is 1 - w(z_f).
        let w0 = (b.y - b.x * (z1 + z2) + z1 * z2) / nonzero((z_f - z1) * (z_f - z2));
        let shadow = clamp(1.0 - w0, 0.0, 1.0);
        let mean = (b.x - w0 * z_f) / max(1.0 - w0, 1e-6);
        return vec2<f32>(shadow, clamp(mean, 0.0, z_f));
    }
    if z1 < z_f {
        let w1 = (b.y - b.x * (z_f + z2) + z_f * z2) / nonzero((z1 - z_f) * (z1 - z2));
        return vec2<f32>(clamp(w1, 0.0, 1.0), clamp(z1, 0.0, z_f));
    }
    return vec2<f32>(0.0, z_f);
}

// Chebyshev's upper bound on the fraction of a distribution with `mean` and `second` moment at
// or behind `r` (Lauritzen and McCool 2008, with a minimum variance).
fn chebyshev_lit(mean: f32, second: f32, r: f32, min_variance: f32) -> f32 {
    let variance = max(second - mean * mean, min_variance);
    let d = r - mean;
    return select(variance / (variance + d * d), 1.0, d <= 0.0);
}

// The shadowed fraction and mean blocker depth (normalised) of `filtered` for a receiver at z_f.
fn shadow_and_blocker_depth(filtered: vec4<f32>, z_f: f32) -> vec2<f32> {
#ifdef EVSM
    let x_f = 2.0 * z_f - 1.0;
    let c = params.exponents;
    let r = vec2<f32>(exp(c.x * x_f), -exp(-c.y * x_f));
    // Minimum variance: the moment bias as a depth standard deviation, carried through the
    // warp's slope c r.
    let deviation = params.moment_bias * c * r;
    let lit_positive = chebyshev_lit(filtered.x, filtered.y, r.x, deviation.x * deviation.x);
    let lit_negative = chebyshev_lit(filtered.z, filtered.w, r.y, deviation.y * deviation.y);
#ifdef EVSM4
    let shadow = 1.0 - min(lit_positive, lit_negative);
#else
    let shadow = 1.0 - lit_positive;
#endif
    // The blocker depth from the negative warp, whose mean the near blockers dominate (the
    // positive warp's mean is dominated by empty texels at depth 1): its mean is the blockers'
    // and the lit part's (at z_f) weighted (variance soft shadow maps, Yang et al. 2010).
    let blockers = 1.0 - lit_negative;
    let warped = (filtered.z - lit_negative * r.y) / max(blockers, 1e-6);
    let x_b = -log(clamp(-warped, -r.y, exp(c.y))) / c.y;
    return vec2<f32>(shadow, clamp(0.5 * (x_b + 1.0), 0.0, z_f));
#else
    return hamburger(filtered, z_f);
#endif
}

// Light-bleeding reduction, and a NaN (which compares false) made shadow rather than reaching
// the metrics.
fn reduce_bleeding(lit: f32) -> f32 {
    let reduction = params.light_bleeding_reduction;
    let v = clamp((lit - reduction) / (1.0 - reduction), 0.0, 1.0);
    return select(0.0, v, v == v);
}

#ifdef SUN
// Steps 1 to 3 for `world` in cascade `i`, sizes in world units (the sun's cone).
fn msm_in(i: u32, world: vec3<f32>, cosine: f32) -> f32 {
    cascade_layer = i32(i);
    let p = cascade_point(cascades, i, world);
    let texel = cascades.texel_world[i];
    let near = cascades.near[i];
    let range = cascades.depth_range[i];
    let tan_half = frame.light_sun.y;
    let bias = params.bias_texels * texel / cosine;
    let z_f = clamp((p.z - bias - near) / range, 0.0, 1.0);

    // 1. Blocker search: the sun's cone from the receiver cut at the cascade's near plane.
    let search = tan_half * max(p.z - near, 0.0) * params.blocker_search_scale;
    let found = shadow_and_blocker_depth(box_moments_texels(p.texel, abs(cascade_texels(cascades, i, vec2<f32>(search)))), z_f);
    if found.x < NO_BLOCKER {
        return 1.0;
    }
    let d_b = near + found.y * range;

    // 2. Penumbra half width, world units, at least `min_filter_texels` of this cascade.
    let extent = max(tan_half * max(p.z - d_b, 0.0), params.min_filter_texels * texel);

    // 3. Filtered moments over the penumbra.
    let filtered = box_moments_texels(p.texel, abs(cascade_texels(cascades, i, vec2<f32>(extent))));
    return reduce_bleeding(1.0 - shadow_and_blocker_depth(filtered, z_f).x);
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
    var v = msm_in(pick.first, s.world, cosine);
    if pick.blend > 0.0 {
        v = mix(v, msm_in(pick.first + 1u, s.world, cosine), pick.blend);
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
    let z_r = s.light.z;
    if z_r <= 0.0 {
        return vec4<f32>(0.0);
    }
    let centre = view_slope(view, s.light);
    let half_light = frame.light_half.xy;
    let near = view.eye_near_far.z;
    let range = params.depth_range;
    let scale = range.y - range.x;
    let bias = params.bias_texels * texel_slope(view) * z_r / light_cosine(s);
    let z_f = clamp((z_r - bias - range.x) / scale, 0.0, 1.0);

    // 1. Blocker search.
    let search = half_light * max(z_r - near, 0.0) / (z_r * near) * params.blocker_search_scale;
    let found = shadow_and_blocker_depth(box_moments(centre, search), z_f);
    if found.x < NO_BLOCKER {
        return vec4<f32>(1.0);
    }
    let d_b = max(range.x + found.y * scale, near);

    // 2. Penumbra extent in slopes, at least `min_filter_texels` texels.
    let min_extent = params.min_filter_texels * texel_slope(view);
    let extent = max(half_light * max(z_r - d_b, 0.0) / (d_b * z_r), vec2<f32>(min_extent));

    // 3. Filtered moments over the penumbra, then light-bleeding reduction.
    let lit = 1.0 - shadow_and_blocker_depth(box_moments(centre, extent), z_f).x;
    return vec4<f32>(reduce_bleeding(lit));
}
#endif
