// A PCSS-like technique (after Fernando 2005) on regular grids: blocker search, penumbra estimate, filter.
// In slope space (docs/ARCHITECTURE.md, "Search area"): the light [-a, a] x [-b, b] seen from a
// receiver at depth z_r covers, at depth z, slopes of half extent a (z_r - z) / (z_r z) around
// the receiver's own slope.
// @contract 3
// @param search_grid: u32 = 6 in 1..=16, Blocker-search samples per axis (a regular grid over the search area)
// @param filter_grid: u32 = 8 in 1..=16, Filter samples per axis (a regular grid over the penumbra)
// @param bias_texels: f32 = 1.5 in 0.0..=16.0, Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes)
// @fit casters

// Light-space depth of the nearest caster at `slope`, or -1 where no caster is.
fn caster_depth(slope: vec2<f32>) -> f32 {
    let uv = slope_to_uv(view, slope);
    if !in_map(uv) {
        return -1.0;
    }
    let d = textureLoad(shadow_map, vec2<i32>(uv * view.size.xy), 0);
    if d >= 1.0 {
        return -1.0;
    }
    return linear_depth(view, d);
}

// Point (i, j) of an n x n grid of cell centres over [-1, 1]^2.
fn grid_point(i: u32, j: u32, n: u32) -> vec2<f32> {
    return (vec2<f32>(f32(i), f32(j)) + 0.5) / f32(n) * 2.0 - 1.0;
}

fn visibility(s: Surface, pixel: vec2<i32>) -> f32 {
    if light_kind() == LIGHT_SUN {
        return visibility_sun(s);
    }
    let z_r = s.light.z;
    let centre = view_slope(view, s.light);
    let half_light = frame.light_half.xy;
    let near = view.eye_near_far.z;
    let bias = params.bias_texels * texel_slope(view) * z_r / light_cosine(s);

    // 1. Blocker search over the light seen from the receiver down to the near plane.
    let search = half_light * max(z_r - near, 0.0) / (z_r * near);
    let n = params.search_grid;
    var blocker_sum = 0.0;
    var blockers = 0.0;
    for (var j = 0u; j < n; j += 1u) {
        for (var i = 0u; i < n; i += 1u) {
            let z = caster_depth(centre + grid_point(i, j, n) * search);
            if z > 0.0 && z < z_r - bias {
                blocker_sum += z;
                blockers += 1.0;
            }
        }
    }
    if blockers == 0.0 {
        return 1.0;
    }
    let d_b = blocker_sum / blockers;

    // 2. The light seen from the receiver at the average blocker depth (parallel planes),
    //    at least one texel.
    let extent = max(half_light * (z_r - d_b) / (d_b * z_r), vec2<f32>(texel_slope(view)));

    // 3. Percentage-closer filtering over it.
    let m = params.filter_grid;
    var lit = 0.0;
    for (var j = 0u; j < m; j += 1u) {
        for (var i = 0u; i < m; i += 1u) {
            let z = caster_depth(centre + grid_point(i, j, m) * extent);
            if z < 0.0 || z >= z_r - bias {
                lit += 1.0;
            }
        }
    }
    return lit / f32(m * m);
}

// The same three steps under the sun, on its orthographic map and in world units: the sun's
// cone (tan of its half angle: frame.light_sun.y) seen from the receiver covers, at a depth
// dz above it, a disk of radius dz tan, i.e. dz tan map_uv_per_world(s) in the map.
fn visibility_sun(s: Surface) -> f32 {
    let p = map_point(s);
    let bias = map_bias(s, params.bias_texels);
    let to_uv = frame.light_sun.y * map_uv_per_world(s);
    // 1. Blocker search over the cone down to the map's near plane (view.eye_near_far.z).
    let search = max(p.depth - view.eye_near_far.z, 0.0) * to_uv;
    let n = params.search_grid;
    var blocker_sum = 0.0;
    var blockers = 0.0;
    for (var j = 0u; j < n; j += 1u) {
        for (var i = 0u; i < n; i += 1u) {
            let z = map_depth(p.uv + grid_point(i, j, n) * search);
            if z < p.depth - bias {
                blocker_sum += z;
                blockers += 1.0;
            }
        }
    }
    if blockers == 0.0 {
        return 1.0;
    }
    // 2. The cone at the average blocker depth, at least one texel.
    let extent = max((p.depth - blocker_sum / blockers) * to_uv, view.size.z);
    // 3. Percentage-closer filtering over it.
    let m = params.filter_grid;
    var lit = 0.0;
    for (var j = 0u; j < m; j += 1u) {
        for (var i = 0u; i < m; i += 1u) {
            if map_depth(p.uv + grid_point(i, j, m) * extent) >= p.depth - bias {
                lit += 1.0;
            }
        }
    }
    return lit / f32(m * m);
}
