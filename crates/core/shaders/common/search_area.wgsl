#define_import_path softshadow::search_area

// The search area of gather backprojection and its refinement with a depth hierarchy
// (Guennebaud, Barthe & Paulin 2006; bitmask soft shadows paper, Schwarz & Stamminger 2007,
// section 5). Shared by every technique that backprojects shadow-map texels (backprojection,
// bitmask). Hierarchies are built by `softshadow_core::hierarchy` (`shaders/core/hierarchy.wgsl`):
//   hsm:  texture_2d<f32> (rg32float, min/max), mip i = min/max over aligned 2^i x 2^i blocks;
//         mip 0 is the linearised shadow map, padded with HIERARCHY_EMPTY to a power of two.
//   mssm: texture_2d_array<f32> (rg32float), layer i - 1 = level i at full resolution: min/max
//         over the 2^i x 2^i neighbourhood [x - 2^i / 2, x + 2^i / 2 - 1] of texel x.
// Level 0 of the MSSM is the HSM's mip 0.

#import softshadow::shadow_view::{ShadowView, view_slope, slope_to_uv}

// Depth stored where no caster was rendered: farther than any receiver, so an empty texel never
// occludes (it only keeps `max` from claiming umbra).
const HIERARCHY_EMPTY: f32 = 1.0e30;

const HIERARCHY_NONE: u32 = 0u;
const HIERARCHY_HSM: u32 = 1u;
const HIERARCHY_MSSM: u32 = 2u;

// Bound of every loop over levels (8192^2 maps need 14 levels).
const MAX_HIERARCHY_LEVELS: i32 = 16;

const SEARCH_LIT: u32 = 0u;
const SEARCH_UMBRA: u32 = 1u;
const SEARCH_GATHER: u32 = 2u;

// Inclusive range of level-0 texels (x = column, y = row; row 0 is t_max). Empty when hi < lo.
struct TexelRect {
    lo: vec2<i32>,
    hi: vec2<i32>,
}

struct Search {
    rect: TexelRect,
    // (min, max) light-space depth over `rect`, as far as the hierarchy knows.
    z_range: vec2<f32>,
    kind: u32,
    // Depth the area was projected to (`search_rect`'s z_star): no texel of it is nearer.
    z_star: f32,
}

fn rect_is_empty(r: TexelRect) -> bool {
    return any(r.hi < r.lo);
}

// Texels that can hold an occluder of the light-space receiver point `p`: the light rectangle
// (half extents `half_light`) projected through `p` onto the plane z = z_star, in slopes centred on
// p's own slope with half extent half_light (p.z - z_star) / (p.z z_star) (docs/ARCHITECTURE.md,
// "Search area"), plus
// half a texel of margin, clamped to the map.
fn search_rect(view: ShadowView, p: vec3<f32>, half_light: vec2<f32>, z_star: f32) -> TexelRect {
    let n = view.size.x;
    let z = max(z_star, 1.0e-6);
    let centre = view_slope(view, p);
    let half = half_light * max(p.z - z, 0.0) / (p.z * z);
    let uv_a = slope_to_uv(view, centre - half);
    let uv_b = slope_to_uv(view, centre + half);
    // Clamp in float first: a huge search area must not overflow the integer conversion.
    let lo = clamp(min(uv_a, uv_b) * n - 0.5, vec2<f32>(-1.0), vec2<f32>(n + 1.0));
    let hi = clamp(max(uv_a, uv_b) * n + 0.5, vec2<f32>(-1.0), vec2<f32>(n + 1.0));
    let last = i32(n) - 1;
    var r: TexelRect;
    r.lo = max(vec2<i32>(floor(lo)), vec2<i32>(0));
    r.hi = min(vec2<i32>(floor(hi)), vec2<i32>(last));
    return r;
}

fn combine_range(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(min(a.x, b.x), max(a.y, b.y));
}

// A range that allows every answer (no early out, no refinement).
fn unknown_range() -> vec2<f32> {
    return vec2<f32>(0.0, HIERARCHY_EMPTY);
}

fn hsm_texel(hsm: texture_2d<f32>, level: i32, texel: vec2<i32>) -> vec2<f32> {
    let size = vec2<i32>(textureDimensions(hsm, level));
    return textureLoad(hsm, clamp(texel, vec2<i32>(0), size - 1), level).xy;
}

// Depth range over `r` from the HSM: the finest level at which `r` spans at most 2 x 2 texels,
// four reads (Guennebaud et al. 2006). Conservative: the texels cover more than `r`.
fn hsm_range(hsm: texture_2d<f32>, r: TexelRect, max_level: i32) -> vec2<f32> {
    for (var level = 0; level < MAX_HIERARCHY_LEVELS; level = level + 1) {
        if level > max_level {
            break;
        }
        let lo = r.lo >> vec2<u32>(u32(level));
        let hi = r.hi >> vec2<u32>(u32(level));
        if all(hi - lo <= vec2<i32>(1)) {
            return combine_range(
                combine_range(hsm_texel(hsm, level, lo), hsm_texel(hsm, level, vec2<i32>(hi.x, lo.y))),
                combine_range(hsm_texel(hsm, level, vec2<i32>(lo.x, hi.y)), hsm_texel(hsm, level, hi)),
            );
        }
    }
    return unknown_range();
}

// MSSM level `level` at `texel` (level 0 is the HSM's mip 0), clamped to the edge (paper sec. 5).
fn mssm_texel(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, level: i32, texel: vec2<i32>) -> vec2<f32> {
    if level == 0 {
        return hsm_texel(hsm, 0, texel);
    }
    let size = vec2<i32>(textureDimensions(mssm));
    return textureLoad(mssm, clamp(texel, vec2<i32>(0), size - 1), level - 1, 0).xy;
}

// Depth range over `r` from the MSSM: four samples of the level whose 2^k x 2^k neighbourhoods,
// placed flush with the corners of `r`, cover it (paper sec. 5). With 2^k <= the larger extent the
// samples stay inside `r` along that axis, so the bound is exact there.
fn mssm_range(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, r: TexelRect, max_level: i32) -> vec2<f32> {
    let extent = max(r.hi.x - r.lo.x, r.hi.y - r.lo.y) + 1;
    for (var level = 0; level < MAX_HIERARCHY_LEVELS; level = level + 1) {
        if level > max_level {
            break;
        }
        let size = 1 << u32(level);
        if 2 * size >= extent {
            // Neighbourhood of texel x: [x - size / 2, x - size / 2 + size - 1].
            let first = r.lo + vec2<i32>(size / 2);
            let last = r.hi - vec2<i32>(size - 1) + vec2<i32>(size / 2);
            return combine_range(
                combine_range(mssm_texel(hsm, mssm, level, first), mssm_texel(hsm, mssm, level, vec2<i32>(last.x, first.y))),
                combine_range(mssm_texel(hsm, mssm, level, vec2<i32>(first.x, last.y)), mssm_texel(hsm, mssm, level, last)),
            );
        }
    }
    return unknown_range();
}

// (min, max) over the aligned block `block` of level `level` (2^level x 2^level level-0 texels):
// the grid the HSM imposes, which the MSSM also samples at coarse levels so that neighbouring
// pixels use the same micro-primitives (paper sec. 5). `none` and `hsm` read the HSM.
fn hierarchy_block(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, hierarchy: u32, level: i32, block: vec2<i32>) -> vec2<f32> {
    if hierarchy == HIERARCHY_MSSM && level > 0 {
        let size = 1 << u32(level);
        return mssm_texel(hsm, mssm, level, block * size + vec2<i32>(size / 2));
    }
    return hsm_texel(hsm, level, block);
}

// The coarsest-needed level: the finest level at which `r` covers at most `per_axis` blocks per
// axis (bitmask paper sec. 5 / Guennebaud: bound the micro-primitives per pixel).
fn gather_level(r: TexelRect, per_axis: i32, max_level: i32) -> i32 {
    for (var level = 0; level < MAX_HIERARCHY_LEVELS; level = level + 1) {
        let lo = r.lo >> vec2<u32>(u32(level));
        let hi = r.hi >> vec2<u32>(u32(level));
        if all(hi - lo < vec2<i32>(per_axis)) || level >= max_level {
            return level;
        }
    }
    return max_level;
}

fn hierarchy_range(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, hierarchy: u32, r: TexelRect, max_level: i32) -> vec2<f32> {
    if hierarchy == HIERARCHY_MSSM {
        return mssm_range(hsm, mssm, r, max_level);
    }
    return hsm_range(hsm, r, max_level);
}

// Search area of receiver `p` (light space) with two refinements: start at the near plane, bound
// the depth range over the area, classify (lit if no texel is closer than `threshold`, umbra if
// every texel is: then the occluding height field spans the whole light pyramid), and shrink the
// area to the nearest depth found (docs/ARCHITECTURE.md, "Search area"; Schwarz & Stamminger 2007
// sec. 5); the final area is bounded and
// classified once more. `hierarchy = none` returns the
// unrefined area for a full search.
fn refine_search(
    view: ShadowView,
    hsm: texture_2d<f32>,
    mssm: texture_2d_array<f32>,
    hierarchy: u32,
    max_level: i32,
    p: vec3<f32>,
    half_light: vec2<f32>,
    threshold: f32,
) -> Search {
    var s: Search;
    var z_star = view.eye_near_far.z;
    s.rect = search_rect(view, p, half_light, z_star);
    s.z_star = z_star;
    s.z_range = unknown_range();
    s.kind = SEARCH_GATHER;
    if rect_is_empty(s.rect) {
        s.kind = SEARCH_LIT;
        return s;
    }
    if hierarchy == HIERARCHY_NONE {
        return s;
    }
    for (var step = 0; step < 2; step = step + 1) {
        s.z_range = hierarchy_range(hsm, mssm, hierarchy, s.rect, max_level);
        if s.z_range.x >= threshold {
            s.kind = SEARCH_LIT;
            return s;
        }
        if s.z_range.y < threshold {
            s.kind = SEARCH_UMBRA;
            return s;
        }
        z_star = max(z_star, s.z_range.x);
        s.rect = search_rect(view, p, half_light, z_star);
        s.z_star = z_star;
        if rect_is_empty(s.rect) {
            s.kind = SEARCH_LIT;
            return s;
        }
    }
    // One more bound over the final area: four reads that can still spare the gather.
    s.z_range = hierarchy_range(hsm, mssm, hierarchy, s.rect, max_level);
    if s.z_range.x >= threshold {
        s.kind = SEARCH_LIT;
    } else if s.z_range.y < threshold {
        s.kind = SEARCH_UMBRA;
    }
    return s;
}

const VISIBILITY_SUM: u32 = 0u;
const VISIBILITY_CONTOUR: u32 = 1u;

// Antiderivative of g(y) = b - clamp(y, -b, b), the part of the light column [-b, b] above height
// y, with G(-b) = 0.
fn column_above_integral(y: f32, b: f32) -> f32 {
    let c = clamp(y, -b, b);
    return 2.0 * b * (min(y, -b) + b) + b * (c + b) - 0.5 * (c * c - b * b);
}

// Contour-based visibility (Guennebaud, Barthe & Paulin 2007): the signed light area a
// backprojected contour edge `e0 -> e1` (light-plane coordinates, occluded side on its left)
// contributes: the integral over x in [e0.x, e1.x] clipped to [-a, a] of the light column above
// the edge, b - clamp(y(x), -b, b). Over a closed contour the sum is the occluded area of the light
// [-a, a] x [-b, b]: at every x the edges the vertical line crosses enter (+) and leave (-) the
// occluded intervals (Green's theorem in the form of a sum of signed trapezoids). Vertical edges
// contribute nothing.
fn contour_edge_area(e0: vec2<f32>, e1: vec2<f32>, half_light: vec2<f32>) -> f32 {
    let a = half_light.x;
    let b = half_light.y;
    let dx = e1.x - e0.x;
    if dx == 0.0 {
        return 0.0;
    }
    let u = select(e1, e0, dx > 0.0);
    let v = select(e0, e1, dx > 0.0);
    let x0 = max(u.x, -a);
    let x1 = min(v.x, a);
    if !(x1 > x0) {
        return 0.0;
    }
    let slope = (v.y - u.y) / (v.x - u.x);
    let y0 = u.y + slope * (x0 - u.x);
    let y1 = u.y + slope * (x1 - u.x);
    var mean: f32;
    if abs(y1 - y0) <= 1.0e-3 * b {
        // g is linear between its kinks: the midpoint is its mean up to |y1 - y0| / 2.
        mean = b - clamp(0.5 * (y0 + y1), -b, b);
    } else {
        mean = (column_above_integral(y1, b) - column_above_integral(y0, b)) / (y1 - y0);
    }
    return sign(dx) * (x1 - x0) * mean;
}

// Depth bands (the multi-resolution strategy of Guennebaud, Barthe & Paulin 2007, in this
// project's form): the texels that can occlude p at depth z >= z_lo lie in the search area of
// z_lo, whose half extent grows with 1/z - 1/p.z. The band [z_lo, z_hi) ends where that area is
// `shrink` times smaller, so the next band's area, gathered with the same number of blocks, uses
// blocks `shrink` times finer: the level follows the penumbra width of each depth rather than
// that of the nearest occluder.
fn band_end(p_z: f32, z_lo: f32, shrink: f32) -> f32 {
    let inv = 1.0 / max(z_lo, 1.0e-12) - 1.0 / p_z;
    return 1.0 / (1.0 / p_z + max(inv, 0.0) / shrink);
}
