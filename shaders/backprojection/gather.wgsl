// Gather backprojection (Guennebaud, Barthe & Paulin 2006)
// with the micro-quads and the multi-scale shadow map of the bitmask soft shadows paper (Schwarz &
// Stamminger 2007, sections 4 and 5). One invocation per screen pixel:
//   1. search area of the receiver point p (light space) on the centre shadow map, refined twice
//      with the depth hierarchy, with lit and umbra early outs (softshadow::search_area);
//   2. a coarser level when the area holds more than max_patches^2 blocks;
//   3. every micro-primitive of the area is backprojected from p onto the light plane: a point at
//      slope (s, t) and depth z < p.z lands at X = z (s p.z - p.x) / (p.z - z) (same for Y), and
//      the covered light area is accumulated; V = 1 - clamp(area / 4ab, 0, 1).
// Counters (receivers, lit, umbra, backprojected pixels, primitives) are summed per workgroup and
// added to a storage buffer that the CPU reads after the frame.
#import softshadow::frame::{frame, load_surface, light_cosine}
#import softshadow::shadow_view::{ShadowView, texel_slope, view_uv}
#import softshadow::search_area::{
    HIERARCHY_NONE, HIERARCHY_EMPTY, SEARCH_LIT, SEARCH_UMBRA, TexelRect,
    refine_search, gather_level, hierarchy_block, VISIBILITY_CONTOUR, contour_edge_area,
    search_rect, hierarchy_range, rect_is_empty, band_end,
}

// `hierarchy = none` gathers level-0 texels over the unrefined area, up to this many per axis:
// softshadow_core::hierarchy::full_search_patches(1) (docs/ARCHITECTURE.md, "Lavapipe's loop budget").
const FULL_SEARCH_PATCHES: i32 = 240;
// Bound of the gather loops: quads span one block more than patches.
const MAX_GATHER_AXIS: i32 = 257;
const PRIMITIVE_MICROQUAD: u32 = 1u;

// Classification written to the debug view and counted.
const CLASS_NONE: u32 = 0u;
const CLASS_LIT: u32 = 1u;
const CLASS_UMBRA: u32 = 2u;
const CLASS_BACKPROJECTED: u32 = 3u;

struct GatherParams {
    hierarchy: u32,
    primitive: u32,
    gap_filling: u32,
    max_patches: u32,
    bias_texels: f32,
    // Highest hierarchy level built this frame.
    max_level: i32,
    // VISIBILITY_SUM (micro-primitives summed) or VISIBILITY_CONTOUR.
    visibility: u32,
    // Depth bands, each gathered at its own level (1: one level for the whole area).
    depth_bands: u32,
    // Levels a partly occluding block is split down (0: none).
    edge_refine: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct Counters {
    receivers: atomic<u32>,
    lit: atomic<u32>,
    umbra: atomic<u32>,
    backprojected: atomic<u32>,
    // Micro-primitives processed, as a 64-bit count (low word, high word).
    primitives_lo: atomic<u32>,
    primitives_hi: atomic<u32>,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> view: ShadowView;
@group(1) @binding(1) var hsm: texture_2d<f32>;
@group(1) @binding(2) var mssm: texture_2d_array<f32>;
@group(1) @binding(3) var<uniform> params: GatherParams;
@group(1) @binding(4) var visibility: texture_storage_2d<r32float, write>;
@group(1) @binding(5) var classification: texture_storage_2d<rgba8unorm, write>;
@group(1) @binding(6) var level_map: texture_storage_2d<r32float, write>;
@group(1) @binding(7) var<storage, read_write> counters: Counters;

var<workgroup> group_receivers: atomic<u32>;
var<workgroup> group_lit: atomic<u32>;
var<workgroup> group_umbra: atomic<u32>;
var<workgroup> group_backprojected: atomic<u32>;
var<workgroup> group_primitives: atomic<u32>;

struct PixelResult {
    v: f32,
    kind: u32,
    level: i32,
    primitives: u32,
}

// The receiver point and what the gather needs about the light and the map.
struct Gather {
    p: vec3<f32>,
    half_light: vec2<f32>,
    // Depth bias at level 0, and scaled by the block edge (see `occluder_depth`).
    bias: f32,
    coarse_bias: f32,
    // Block of this level that holds the receiver's own texel, and that texel.
    own_block: vec2<i32>,
    own_texel: vec2<i32>,
    level: i32,
    // Edge of a block in level-0 texels, and the map edge in texels.
    block: i32,
    map: i32,
    // Blocks of this level that hold real texels, per axis.
    blocks: i32,
    // Depth band [x, y) of this gather: blocks whose minimum lies outside it belong to another.
    band: vec2<f32>,
    // Level of the previous band's gather (-1 for the first band).
    prev_level: i32,
}

// Backprojection factor z / (p.z - z) of an occluding depth z < p.z - bias (clamped: finite).
fn backprojection_scale(g: Gather, z: f32) -> f32 {
    return min(z / max(g.p.z - z, 1.0e-12), 1.0e7);
}

// Minimum depth of `block` if it occludes the receiver, else HIERARCHY_EMPTY. A coarse block
// within one block of the receiver's own texel whose depth range reaches the receiver may hold
// the receiver's own surface, with its minimum up to a block's depth variation in front of it:
// it gets the bias scaled by the block edge (no acne). Every other block is a distinct occluder
// and keeps the level-0 bias (a scaled bias there would drop real occluders when texels are wide).
fn occluder_depth(g: Gather, block: vec2<i32>) -> f32 {
    return occluder_range(g, g.level, block).x;
}

// (occluding minimum depth or HIERARCHY_EMPTY, maximum depth) of `block` of level `level`, with
// the bias rule of `occluder_depth` at that level's block size.
fn occluder_range(g: Gather, level: i32, block: vec2<i32>) -> vec2<f32> {
    let range = hierarchy_block(hsm, mssm, params.hierarchy, level, block);
    var bias = g.bias;
    let coarse_bias = g.bias * f32(1 << u32(level));
    let own = g.own_texel >> vec2<u32>(u32(level));
    if level > 0 && all(abs(block - own) <= vec2<i32>(1)) && range.y >= g.p.z - coarse_bias {
        bias = coarse_bias;
    }
    var z = HIERARCHY_EMPTY;
    if range.x < g.p.z - bias && range.x >= g.band.x && range.x < g.band.y {
        z = range.x;
        if g.prev_level > level {
            // An earlier band gathered the block of its own level that holds this one, as a whole
            // at its minimum depth, if that minimum lies before this band: not counted twice.
            let parent = hierarchy_block(hsm, mssm, params.hierarchy, g.prev_level, block >> vec2<u32>(u32(g.prev_level - level)));
            if parent.x < g.band.x && parent.x < g.p.z - bias {
                z = HIERARCHY_EMPTY;
            }
        }
    }
    return vec2<f32>(z, range.y - (g.p.z - bias));
}

// Light area of the occluding sub-blocks of a partly occluding block (edge refinement): the block
// split into 2^d x 2^d blocks of level g.level - d, each a patch at its own minimum depth. A block
// that holds an occluder's edge then covers the light only where its occluding part does, rather
// than as a whole at its minimum depth (the widening that makes coarse levels over-darken).
fn refined_patches(g: Gather, block: vec2<i32>, d: i32) -> f32 {
    let a = g.half_light;
    let level = g.level - d;
    let n = 1 << u32(d);
    let size = 1 << u32(level);
    var area = 0.0;
    for (var j = 0; j < 8; j = j + 1) {
        if j >= n {
            break;
        }
        for (var i = 0; i < 8; i = i + 1) {
            if i >= n {
                break;
            }
            let sub = block * n + vec2<i32>(i, j);
            let z = occluder_range(g, level, sub).x;
            if z < HIERARCHY_EMPTY {
                let k = backprojection_scale(g, z);
                let x0 = k * (edge_s(min(sub.x * size, g.map)) * g.p.z - g.p.x);
                let x1 = k * (edge_s(min((sub.x + 1) * size, g.map)) * g.p.z - g.p.x);
                let y0 = k * (edge_t(min((sub.y + 1) * size, g.map)) * g.p.z - g.p.y);
                let y1 = k * (edge_t(min(sub.y * size, g.map)) * g.p.z - g.p.y);
                let w = max(min(x1, a.x) - max(x0, -a.x), 0.0);
                let h = max(min(y1, a.y) - max(y0, -a.y), 0.0);
                area += w * h;
            }
        }
    }
    return area;
}

// Slope of level-0 texel edge `e` (column edge -> s, row edge -> t).
fn edge_s(e: i32) -> f32 {
    return view.window.x + f32(e) * texel_slope(view);
}

fn edge_t(e: i32) -> f32 {
    return view.window.w - f32(e) * texel_slope(view);
}

// Light area covered by the micro-patches of `rect` (blocks of level g.level): each block is a
// patch parallel to the light at its minimum depth; with gap filling a patch's left and bottom
// edges are extended to the neighbouring patch's edge when that patch occludes too (Guennebaud et
// al. 2006; docs/TECHNIQUES.md, `backprojection`).
fn micropatch_area(g: Gather, lo: vec2<i32>, count: vec2<i32>) -> f32 {
    let a = g.half_light;
    var area = 0.0;
    for (var row = 0; row < MAX_GATHER_AXIS; row = row + 1) {
        if row >= count.y {
            break;
        }
        let by = lo.y + row;
        let t_top = edge_t(by * g.block);
        let t_bottom = edge_t(min((by + 1) * g.block, g.map));
        var left_z = HIERARCHY_EMPTY;
        if lo.x > 0 {
            left_z = occluder_depth(g, vec2<i32>(lo.x - 1, by));
        }
        for (var col = 0; col < MAX_GATHER_AXIS; col = col + 1) {
            if col >= count.x {
                break;
            }
            let bx = lo.x + col;
            let zr = occluder_range(g, g.level, vec2<i32>(bx, by));
            let z = zr.x;
            // Not in a full search: it stays the 2006 gather, the yardstick of the others.
            let refine = select(min(i32(params.edge_refine), g.level), 0, params.hierarchy == HIERARCHY_NONE);
            if z < HIERARCHY_EMPTY && refine > 0 && zr.y >= 0.0 {
                // Partly occluding: its occluding sub-blocks only.
                area += refined_patches(g, vec2<i32>(bx, by), refine);
            } else if z < HIERARCHY_EMPTY {
                let k = backprojection_scale(g, z);
                let s0 = edge_s(bx * g.block);
                let s1 = edge_s(min((bx + 1) * g.block, g.map));
                var x0 = k * (s0 * g.p.z - g.p.x);
                let x1 = k * (s1 * g.p.z - g.p.x);
                var y0 = k * (t_bottom * g.p.z - g.p.y);
                let y1 = k * (t_top * g.p.z - g.p.y);
                if params.gap_filling != 0u {
                    if left_z < HIERARCHY_EMPTY {
                        x0 = min(x0, backprojection_scale(g, left_z) * (s0 * g.p.z - g.p.x));
                    }
                    if by + 1 < g.blocks {
                        let below = occluder_depth(g, vec2<i32>(bx, by + 1));
                        if below < HIERARCHY_EMPTY {
                            y0 = min(y0, backprojection_scale(g, below) * (t_bottom * g.p.z - g.p.y));
                        }
                    }
                }
                let w = max(min(x1, a.x) - max(x0, -a.x), 0.0);
                let h = max(min(y1, a.y) - max(y0, -a.y), 0.0);
                area += w * h;
            }
            left_z = z;
        }
    }
    return area;
}

// Occluding depth of grid block `block` (`occluder_depth`), HIERARCHY_EMPTY outside the gathered
// blocks `lo .. lo + count`: nothing outside the refined search area reaches the light (it is no
// nearer than the area's nearest depth, whose light pyramid the area is).
fn contour_block(g: Gather, lo: vec2<i32>, count: vec2<i32>, block: vec2<i32>) -> f32 {
    if any(block < lo) || any(block >= lo + count) {
        return HIERARCHY_EMPTY;
    }
    return occluder_depth(g, block);
}

// Block corner `corner` (level-0 texel edges corner * block), unprojected at depth `z` and
// backprojected through p onto the light plane.
fn contour_vertex(g: Gather, corner: vec2<i32>, z: f32) -> vec2<f32> {
    let e = min(corner * g.block, vec2<i32>(g.map));
    let slope = vec2<f32>(edge_s(e.x), edge_t(e.y));
    return backprojection_scale(g, z) * (slope * g.p.z - g.p.xy);
}

// Contour-based visibility (Guennebaud, Barthe & Paulin 2007): the occluded light area from the
// edges between occluding and non-occluding blocks of `lo .. lo + count` only. Each edge runs
// between two block corners; a corner lies at the minimum depth of the occluding blocks around it
// (so the edges of one contour share their backprojected ends and close), and the area is
// integrated along the backprojected edges (`contour_edge_area`). Blocks inside an occluder add
// nothing, so neighbouring micro-patches can no longer overlap on the light (the over-darkening of
// summed patches) nor leave gaps between them (what gap filling patches up).
// One pass over the corners, column by column within a row (rows grow downwards, t decreasing):
// at corner (c, r) the blocks (c, r - 2 .. r) are read and the blocks of column c - 1 are kept, so
// that the corner depths of (c, r - 1) and (c, r) are known; corner (c - 1, r) is carried over.
fn contour_area(g: Gather, lo: vec2<i32>, count: vec2<i32>) -> f32 {
    var area = 0.0;
    for (var row = 0; row < MAX_GATHER_AXIS; row = row + 1) {
        if row > count.y {
            break;
        }
        let r = lo.y + row;
        // Column c - 1: blocks at rows r - 2, r - 1, r.
        var left = vec3<f32>(HIERARCHY_EMPTY);
        var left_corner = HIERARCHY_EMPTY;
        for (var col = 0; col < MAX_GATHER_AXIS; col = col + 1) {
            if col > count.x {
                break;
            }
            let c = lo.x + col;
            let here = vec3<f32>(
                contour_block(g, lo, count, vec2<i32>(c, r - 2)),
                contour_block(g, lo, count, vec2<i32>(c, r - 1)),
                contour_block(g, lo, count, vec2<i32>(c, r)),
            );
            let corner = min(min(left.y, left.z), min(here.y, here.z));
            let corner_above = min(min(left.x, left.y), min(here.x, here.y));
            // Horizontal edge from corner (c - 1, r) to (c, r), between blocks (c - 1, r - 1)
            // above and (c - 1, r) below: directed +s when the occluder is above (on its left).
            let above = left.y < HIERARCHY_EMPTY;
            let below = left.z < HIERARCHY_EMPTY;
            if above != below {
                let p0 = contour_vertex(g, vec2<i32>(c - 1, r), left_corner);
                let p1 = contour_vertex(g, vec2<i32>(c, r), corner);
                area += select(-1.0, 1.0, above) * contour_edge_area(p0, p1, g.half_light);
            }
            // Vertical edge from corner (c, r) up to (c, r - 1), between blocks (c - 1, r - 1) and
            // (c, r - 1): vertical in the light plane only when both corners share a depth.
            let on_left = left.y < HIERARCHY_EMPTY;
            let on_right = here.y < HIERARCHY_EMPTY;
            if on_left != on_right {
                let p0 = contour_vertex(g, vec2<i32>(c, r), corner);
                let p1 = contour_vertex(g, vec2<i32>(c, r - 1), corner_above);
                // Upwards (+t) keeps an occluder on the left on its left.
                area += select(-1.0, 1.0, on_left) * contour_edge_area(p0, p1, g.half_light);
            }
            left = here;
            left_corner = corner;
        }
    }
    return area;
}

struct QuadVertex {
    xy: vec2<f32>,
    occludes: bool,
}

// Centre of block `block`, unprojected at the block's depth and backprojected through p, clamped to
// the light rectangle (bitmask paper sec. 4, Fig. 6).
fn quad_vertex(g: Gather, block: vec2<i32>) -> QuadVertex {
    var v: QuadVertex;
    let z = occluder_depth(g, block);
    v.occludes = z < HIERARCHY_EMPTY;
    let start = block * g.block;
    let centre = vec2<f32>(start) + 0.5 * vec2<f32>(min(vec2<i32>(g.block), vec2<i32>(g.map) - start));
    let slope = vec2<f32>(
        view.window.x + centre.x * texel_slope(view),
        view.window.w - centre.y * texel_slope(view),
    );
    let k = backprojection_scale(g, z);
    v.xy = clamp(k * (slope * g.p.z - g.p.xy), -g.half_light, g.half_light);
    return v;
}

// Light area covered by the micro-quads between the block centres of `lo .. lo + count` (one
// more vertex per axis): a quad counts only when all four vertices occlude (paper sec. 4).
fn microquad_area(g: Gather, lo: vec2<i32>, count: vec2<i32>) -> f32 {
    var area = 0.0;
    for (var row = 0; row < MAX_GATHER_AXIS; row = row + 1) {
        if row >= count.y {
            break;
        }
        let by = lo.y + row;
        var top_left = quad_vertex(g, vec2<i32>(lo.x, by));
        var bottom_left = quad_vertex(g, vec2<i32>(lo.x, by + 1));
        for (var col = 0; col < MAX_GATHER_AXIS; col = col + 1) {
            if col >= count.x {
                break;
            }
            let bx = lo.x + col + 1;
            let top_right = quad_vertex(g, vec2<i32>(bx, by));
            let bottom_right = quad_vertex(g, vec2<i32>(bx, by + 1));
            if top_left.occludes && bottom_left.occludes && top_right.occludes && bottom_right.occludes {
                // Shoelace area of a quadrilateral: half the cross product of its diagonals.
                let d0 = bottom_right.xy - top_left.xy;
                let d1 = bottom_left.xy - top_right.xy;
                area += 0.5 * abs(d0.x * d1.y - d0.y * d1.x);
            }
            top_left = top_right;
            bottom_left = bottom_right;
        }
    }
    return area;
}

fn shade_pixel(pixel: vec2<i32>) -> PixelResult {
    var r: PixelResult;
    r.v = 1.0;
    r.kind = CLASS_NONE;
    r.level = -1;
    r.primitives = 0u;
    let s = load_surface(pixel);
    if !s.is_receiver {
        return r;
    }
    let p = s.light;
    if !(p.z > 0.0) {
        // At or behind the light plane: a one-sided light cannot reach it.
        r.v = 0.0;
        r.kind = CLASS_UMBRA;
        return r;
    }
    r.kind = CLASS_LIT;
    if p.z <= view.eye_near_far.z {
        // Closer to the light than every caster.
        return r;
    }
    var g: Gather;
    g.p = p;
    // A zero-size light is treated as a tiny one (finite areas, same shadow boundary).
    g.half_light = max(frame.light_half.xy, vec2<f32>(1.0e-4));
    let bias = params.bias_texels * texel_slope(view) * p.z / light_cosine(s);
    let search = refine_search(view, hsm, mssm, params.hierarchy, params.max_level, p, g.half_light, p.z - bias);
    if search.kind == SEARCH_LIT {
        return r;
    }
    if search.kind == SEARCH_UMBRA {
        r.v = 0.0;
        r.kind = CLASS_UMBRA;
        return r;
    }
    var per_axis = i32(params.max_patches);
    if params.hierarchy == HIERARCHY_NONE {
        per_axis = FULL_SEARCH_PATCHES;
    }
    g.map = i32(view.size.x);
    g.bias = bias;
    let own_texel = vec2<i32>(floor(clamp(view_uv(view, p), vec2<f32>(-1.0), vec2<f32>(2.0)) * f32(g.map)));
    var rect = search.rect;
    var z_lo = search.z_star;
    var area = 0.0;
    var primitives = 0u;
    g.prev_level = -1;
    // Depth bands (`band_end`): each gathers its own search area at the level that keeps it within
    // per_axis blocks; the last band (or a full search) takes every depth that is left.
    let bands = select(max(params.depth_bands, 1u), 1u, params.hierarchy == HIERARCHY_NONE);
    for (var band = 0u; band < 8u; band = band + 1u) {
        if band >= bands {
            break;
        }
        g.level = gather_level(rect, per_axis, params.max_level);
        var z_hi = HIERARCHY_EMPTY;
        if band + 1u < bands && g.level > 0 {
            z_hi = band_end(p.z, z_lo, f32(1 << u32(min(g.level, 2))));
        }
        g.band = vec2<f32>(select(0.0, z_lo, band > 0u), z_hi);
        g.block = 1 << u32(g.level);
        g.blocks = (g.map + g.block - 1) / g.block;
        g.coarse_bias = bias * f32(g.block);
        g.own_block = own_texel >> vec2<u32>(u32(g.level));
        g.own_texel = own_texel;
        let lo = rect.lo >> vec2<u32>(u32(g.level));
        let hi = rect.hi >> vec2<u32>(u32(g.level));
        var count: vec2<i32>;
        if params.visibility == VISIBILITY_CONTOUR {
            count = clamp(hi - lo + 1, vec2<i32>(0), vec2<i32>(per_axis));
            area += contour_area(g, lo, count);
        } else if params.primitive == PRIMITIVE_MICROQUAD {
            // Quads between block centres lo - 1 .. hi + 1 that lie inside the map.
            let quad_lo = max(lo - 1, vec2<i32>(0));
            let quad_hi = min(hi, vec2<i32>(g.blocks - 2));
            count = clamp(quad_hi - quad_lo + 1, vec2<i32>(0), vec2<i32>(per_axis + 1));
            area += microquad_area(g, quad_lo, count);
        } else {
            count = clamp(hi - lo + 1, vec2<i32>(0), vec2<i32>(per_axis));
            area += micropatch_area(g, lo, count);
        }
        primitives += u32(count.x * count.y);
        if band == 0u {
            r.level = g.level;
        }
        g.prev_level = g.level;
        if z_hi >= HIERARCHY_EMPTY {
            break;
        }
        // The next band's area, refined once by the nearest depth in it; nothing nearer than the
        // receiver there: no later band can occlude either (their areas lie inside it).
        z_lo = z_hi;
        rect = search_rect(view, p, g.half_light, z_lo);
        if rect_is_empty(rect) {
            break;
        }
        let range = hierarchy_range(hsm, mssm, params.hierarchy, rect, params.max_level);
        if range.x >= p.z - bias {
            break;
        }
        if range.x > z_lo {
            rect = search_rect(view, p, g.half_light, range.x);
            if rect_is_empty(rect) {
                break;
            }
        }
    }
    let light_area = 4.0 * g.half_light.x * g.half_light.y;
    r.v = 1.0 - clamp(area / light_area, 0.0, 1.0);
    if !(r.v >= 0.0 && r.v <= 1.0) {
        // NaN guard: never write a non-finite visibility.
        r.v = 1.0;
    }
    r.kind = CLASS_BACKPROJECTED;
    r.primitives = primitives;
    return r;
}

fn class_colour(r: PixelResult) -> vec4<f32> {
    switch r.kind {
        case CLASS_LIT: {
            return vec4<f32>(0.9, 0.9, 0.85, 1.0);
        }
        case CLASS_UMBRA: {
            return vec4<f32>(0.1, 0.1, 0.35, 1.0);
        }
        case CLASS_BACKPROJECTED: {
            // Red for few micro-primitives, towards blue for max_patches^2 (paper Fig. 8).
            let full = f32(params.max_patches * params.max_patches);
            let t = clamp(f32(r.primitives) / full, 0.0, 1.0);
            return vec4<f32>(1.0 - t, 0.15, t, 1.0);
        }
        default: {
            return vec4<f32>(0.0);
        }
    }
}

@compute @workgroup_size(8, 8)
fn gather(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    if local == 0u {
        atomicStore(&group_receivers, 0u);
        atomicStore(&group_lit, 0u);
        atomicStore(&group_umbra, 0u);
        atomicStore(&group_backprojected, 0u);
        atomicStore(&group_primitives, 0u);
    }
    workgroupBarrier();
    let size = vec2<u32>(frame.screen.xy);
    if all(id.xy < size) {
        let pixel = vec2<i32>(id.xy);
        let r = shade_pixel(pixel);
        textureStore(visibility, pixel, vec4<f32>(r.v, 0.0, 0.0, 0.0));
        textureStore(classification, pixel, class_colour(r));
        textureStore(level_map, pixel, vec4<f32>(f32(r.level), 0.0, 0.0, 0.0));
        if r.kind != CLASS_NONE {
            atomicAdd(&group_receivers, 1u);
        }
        if r.kind == CLASS_LIT {
            atomicAdd(&group_lit, 1u);
        }
        if r.kind == CLASS_UMBRA {
            atomicAdd(&group_umbra, 1u);
        }
        if r.kind == CLASS_BACKPROJECTED {
            atomicAdd(&group_backprojected, 1u);
            atomicAdd(&group_primitives, r.primitives);
        }
    }
    workgroupBarrier();
    if local == 0u {
        atomicAdd(&counters.receivers, atomicLoad(&group_receivers));
        atomicAdd(&counters.lit, atomicLoad(&group_lit));
        atomicAdd(&counters.umbra, atomicLoad(&group_umbra));
        atomicAdd(&counters.backprojected, atomicLoad(&group_backprojected));
        let added = atomicLoad(&group_primitives);
        let before = atomicAdd(&counters.primitives_lo, added);
        if before > 0xffffffffu - added {
            atomicAdd(&counters.primitives_hi, 1u);
        }
    }
}
