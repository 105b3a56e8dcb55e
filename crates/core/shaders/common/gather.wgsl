#define_import_path softshadow::gather

// The gather scaffold shared by the techniques that backproject shadow-map blocks onto the light
// (backprojection, bitmask): the receiver's set-up, the depth bands over the search area (each at
// its own level), the walk over the blocks of a level, the micro-patch and micro-quad primitives
// with gap filling and edge refinement, and the contour integral (Guennebaud, Barthe & Paulin 2006
// and 2007; Schwarz & Stamminger 2007, sections 4 and 5; docs/TECHNIQUES.md, `backprojection`).
// A technique keeps only how it accumulates occlusion: it overrides `emit_patch` and `emit_quad`
// (naga_oil virtual functions) to turn each backprojected primitive into its own occlusion (bits
// of a mask, say) and returns the light area it wants summed; the defaults return the clipped area,
// which is what gather backprojection sums.

#import softshadow::frame::{Surface, load_surface, frame, light_cosine, light_kind}
#import softshadow::light::{LIGHT_RECT, rect_disk_area}
#import softshadow::shadow_view::{ShadowView, texel_slope, view_uv}
#import softshadow::search_area::{
    HIERARCHY_NONE, HIERARCHY_EMPTY, Search, TexelRect, gather_level, hierarchy_block,
    VISIBILITY_CONTOUR, contour_edge_area, search_rect, hierarchy_range, rect_is_empty, band_end,
}

// Bound of the gather loops: quads span one block more than patches.
const MAX_GATHER_AXIS: i32 = 257;
const MAX_DEPTH_BANDS: u32 = 8u;
const PRIMITIVE_MICROPATCH: u32 = 0u;
const PRIMITIVE_MICROQUAD: u32 = 1u;

// The gather pass's uniform (softshadow::gather_pass), filled by softshadow_core::gather::
// GatherUniform: the shared settings, then the fields only bitmask reads.
struct GatherParams {
    hierarchy: u32,
    primitive: u32,
    gap_filling: u32,
    // The max_patches setting (backprojection's debug colours).
    max_patches: u32,
    // Most blocks per axis of one gather: max_patches, or the full search's count.
    per_axis: u32,
    bias_texels: f32,
    // Highest hierarchy level built this frame (the same for every layer).
    max_level: i32,
    // Depth bands, each gathered at its own level (1: one level for the whole area).
    depth_bands: u32,
    // Levels a partly occluding block is split down (0: none).
    edge_refine: u32,
    // Adaptive screen resolution: 1 (off), 2 or 4 (coarse pixels per axis), and the penumbra
    // width in screen pixels from which a pixel is interpolated from the coarse pass.
    adaptive_factor: u32,
    adaptive_pixels: f32,
    // Depth layers gathered (backprojection: 1; bitmask: 1 to 4).
    layers: u32,
    // VISIBILITY_SUM or VISIBILITY_CONTOUR (backprojection's setting; bitmask: sum).
    visibility: u32,
    // Used by bitmask only: accumulate and write the area estimate A (post filtering is on), the
    // light samples' rows and columns, and 1 when rows take the rotated-grid offsets.
    with_area: u32,
    rows: u32,
    columns: u32,
    jittered: u32,
}

// What a technique's uniforms say about the gather.
struct GatherSettings {
    // HIERARCHY_NONE (full search), HIERARCHY_HSM or HIERARCHY_MSSM.
    hierarchy: u32,
    // PRIMITIVE_MICROPATCH or PRIMITIVE_MICROQUAD.
    primitive: u32,
    // Extend micro-patches to their occluding left and bottom neighbours (0: off).
    gap_filling: u32,
    // VISIBILITY_SUM (micro-primitives) or VISIBILITY_CONTOUR (contour edges integrated).
    visibility: u32,
    // Highest hierarchy level built this frame.
    max_level: i32,
    // Most blocks per axis of one gather (max_patches, or the full search's count).
    per_axis: i32,
    // Depth bands, each gathered at its own level (1: one level for the whole area).
    depth_bands: u32,
    // Levels a partly occluding block is split down (0: none).
    edge_refine: u32,
}

// The receiver point and what the gather needs about the light and the map.
struct Gather {
    view: ShadowView,
    settings: GatherSettings,
    p: vec3<f32>,
    half_light: vec2<f32>,
    // Depth bias at level 0, and scaled by the block edge (see `occluder_range`).
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

// What a gather over one search area did.
struct GatherResult {
    // Sum of what `emit_patch` / `emit_quad` returned (the light area the technique counts).
    area: f32,
    // Level of the first band's gather.
    level: i32,
    // Micro-primitives read.
    primitives: u32,
}

virtual fn emit_patch(g: Gather, lo: vec2<f32>, hi: vec2<f32>) -> f32 {
    // (No comment right above a virtual or override function: naga_oil turns the white space
    // before `virtual fn`, newlines included, into spaces, and the comment swallows the function.)
    // The light area of the backprojected patch [lo, hi] (light-plane coordinates) clipped to
    // the light. A technique overrides it to record the patch its own way (bitmask: the light
    // samples it covers) and returns the area it wants summed.
    let a = g.half_light;
    if light_kind() != LIGHT_RECT {
        // A disk, sphere (its disk in the light plane) or spot: half_light = (r, r).
        return rect_disk_area(lo, hi, a.x);
    }
    let w = max(min(hi.x, a.x) - max(lo.x, -a.x), 0.0);
    let h = max(min(hi.y, a.y) - max(lo.y, -a.y), 0.0);
    return w * h;
}

virtual fn emit_quad(g: Gather, top_left: vec2<f32>, top_right: vec2<f32>, bottom_left: vec2<f32>, bottom_right: vec2<f32>) -> f32 {
    // The light area of the micro-quad between four backprojected block centres (not clamped;
    // all four occlude): the vertices clamped to the light rectangle, shoelace area (bitmask
    // paper sec. 4). Under a disk: the axis-aligned rectangle through its edge centres, as
    // bitmask approximates a quad, inside the disk.
    if light_kind() != LIGHT_RECT {
        let left = 0.5 * (top_left.x + bottom_left.x);
        let right = 0.5 * (top_right.x + bottom_right.x);
        let top = 0.5 * (top_left.y + top_right.y);
        let bottom = 0.5 * (bottom_left.y + bottom_right.y);
        let lo = vec2<f32>(min(left, right), min(top, bottom));
        let hi = vec2<f32>(max(left, right), max(top, bottom));
        return rect_disk_area(lo, hi, g.half_light.x);
    }
    let tl = clamp(top_left, -g.half_light, g.half_light);
    let tr = clamp(top_right, -g.half_light, g.half_light);
    let bl = clamp(bottom_left, -g.half_light, g.half_light);
    let br = clamp(bottom_right, -g.half_light, g.half_light);
    // Shoelace area of a quadrilateral: half the cross product of its diagonals.
    let d0 = br - tl;
    let d1 = bl - tr;
    return 0.5 * abs(d0.x * d1.y - d0.y * d1.x);
}

// What a pixel is before any search: no receiver, behind the light plane (umbra), nearer to the
// light than every caster (lit), or to be searched.
const RECEIVER_NONE: u32 = 0u;
const RECEIVER_BEHIND: u32 = 1u;
const RECEIVER_LIT: u32 = 2u;
const RECEIVER_SEARCH: u32 = 3u;

struct Receiver {
    kind: u32,
    s: Surface,
    // Half extents of the light (a zero-size light is treated as a tiny one: finite areas, the
    // same shadow boundary).
    half_light: vec2<f32>,
    // Depth bias: `bias_texels` texel footprints at the receiver, over the cosine to the light.
    bias: f32,
}

fn receiver_at(view: ShadowView, pixel: vec2<i32>, bias_texels: f32) -> Receiver {
    var r: Receiver;
    r.kind = RECEIVER_NONE;
    r.s = load_surface(pixel);
    if !r.s.is_receiver {
        return r;
    }
    let p = r.s.light;
    if !(p.z > 0.0) {
        // At or behind the light plane: a one-sided light cannot reach it.
        r.kind = RECEIVER_BEHIND;
        return r;
    }
    r.kind = RECEIVER_LIT;
    if p.z <= view.eye_near_far.z {
        // Closer to the light than every caster.
        return r;
    }
    r.kind = RECEIVER_SEARCH;
    r.half_light = max(frame.light_half.xy, vec2<f32>(1.0e-4));
    r.bias = bias_texels * texel_slope(view) * p.z / light_cosine(r.s);
    return r;
}

// The gather of receiver `p` (light space) before its first band: bias, own texel, settings.
fn gather_setup(view: ShadowView, settings: GatherSettings, p: vec3<f32>, half_light: vec2<f32>, bias: f32) -> Gather {
    var g: Gather;
    g.view = view;
    g.settings = settings;
    g.p = p;
    g.half_light = half_light;
    g.map = i32(view.size.x);
    g.bias = bias;
    g.own_texel = vec2<i32>(floor(clamp(view_uv(view, p), vec2<f32>(-1.0), vec2<f32>(2.0)) * f32(g.map)));
    g.prev_level = -1;
    g.band = vec2<f32>(0.0, HIERARCHY_EMPTY);
    return g;
}

// `g` set to gather at `level` within the depth band `band`.
fn at_level(g0: Gather, level: i32, band: vec2<f32>) -> Gather {
    var g = g0;
    g.level = level;
    g.band = band;
    g.block = 1 << u32(level);
    g.blocks = (g.map + g.block - 1) / g.block;
    g.coarse_bias = g.bias * f32(g.block);
    g.own_block = g.own_texel >> vec2<u32>(u32(level));
    return g;
}

// Backprojection factor z / (p.z - z) of an occluding depth z < p.z - bias (clamped: finite).
fn backprojection_scale(g: Gather, z: f32) -> f32 {
    return min(z / max(g.p.z - z, 1.0e-12), 1.0e7);
}

// Slope of level-0 texel edge `e` (column edge -> s, row edge -> t).
fn edge_s(g: Gather, e: i32) -> f32 {
    return g.view.window.x + f32(e) * texel_slope(g.view);
}

fn edge_t(g: Gather, e: i32) -> f32 {
    return g.view.window.w - f32(e) * texel_slope(g.view);
}

// (occluding minimum depth or HIERARCHY_EMPTY, maximum depth minus the receiver's biased depth)
// of `block` of level `level`. A coarse block within one block of the receiver's own texel whose
// depth range reaches the receiver may hold the receiver's own surface, with its minimum up to a
// block's depth variation in front of it: it gets the bias scaled by the block edge (no acne).
// Every other block is a distinct occluder and keeps the level-0 bias (a scaled bias there would
// drop real occluders when texels are wide). Only blocks whose minimum lies in the gather's depth
// band count.
fn occluder_range(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, g: Gather, level: i32, block: vec2<i32>) -> vec2<f32> {
    let range = hierarchy_block(hsm, mssm, g.settings.hierarchy, level, block);
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
            let parent = hierarchy_block(hsm, mssm, g.settings.hierarchy, g.prev_level, block >> vec2<u32>(u32(g.prev_level - level)));
            if parent.x < g.band.x && parent.x < g.p.z - bias {
                z = HIERARCHY_EMPTY;
            }
        }
    }
    return vec2<f32>(z, range.y - (g.p.z - bias));
}

// Minimum depth of `block` (level g.level) if it occludes the receiver, else HIERARCHY_EMPTY.
fn occluder_depth(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, g: Gather, block: vec2<i32>) -> f32 {
    return occluder_range(hsm, mssm, g, g.level, block).x;
}

// Edge refinement: the occluding sub-blocks of a partly occluding block, split into 2^d x 2^d
// blocks of level g.level - d, each a patch at its own minimum depth. A block that holds an
// occluder's edge then covers the light only where its occluding part does, rather than as a
// whole at its minimum depth (the widening that makes coarse levels over-darken).
fn refined_patches(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, g0: Gather, block: vec2<i32>, d: i32) -> f32 {
    // Every occluding sub-block counts, also those deeper than the band: a later band skips the
    // blocks of this one as gathered (`occluder_range`'s parent rule), so a sub-block left to it
    // would be lost.
    var g = g0;
    g.band.y = HIERARCHY_EMPTY;
    let level = g.level - d;
    let n = 1 << u32(d);
    let size = 1 << u32(level);
    var area = 0.0;
    for (var j = 0; j < 8; j = j + 1) {
        if j >= n {
            break;
        }
        var left_z = HIERARCHY_EMPTY;
        if g.settings.gap_filling != 0u {
            left_z = occluder_range(hsm, mssm, g, level, block * n + vec2<i32>(-1, j)).x;
        }
        for (var i = 0; i < 8; i = i + 1) {
            if i >= n {
                break;
            }
            let sub = block * n + vec2<i32>(i, j);
            let z = occluder_range(hsm, mssm, g, level, sub).x;
            if z < HIERARCHY_EMPTY {
                let k = backprojection_scale(g, z);
                let s0 = edge_s(g, min(sub.x * size, g.map));
                let t_bottom = edge_t(g, min((sub.y + 1) * size, g.map));
                var x0 = k * (s0 * g.p.z - g.p.x);
                let x1 = k * (edge_s(g, min((sub.x + 1) * size, g.map)) * g.p.z - g.p.x);
                var y0 = k * (t_bottom * g.p.z - g.p.y);
                let y1 = k * (edge_t(g, min(sub.y * size, g.map)) * g.p.z - g.p.y);
                if g.settings.gap_filling != 0u {
                    // Gap filling between sub-patches at different depths, as between blocks
                    // (`gather_micropatches`): without it, light leaks between the fine patches
                    // of a tilted or curved occluder (stiff-tiny-patches, stiff-near-light).
                    if left_z < HIERARCHY_EMPTY {
                        x0 = min(x0, backprojection_scale(g, left_z) * (s0 * g.p.z - g.p.x));
                    }
                    let below = occluder_range(hsm, mssm, g, level, sub + vec2<i32>(0, 1)).x;
                    if below < HIERARCHY_EMPTY {
                        y0 = min(y0, backprojection_scale(g, below) * (t_bottom * g.p.z - g.p.y));
                    }
                }
                area += emit_patch(g, vec2<f32>(x0, y0), vec2<f32>(x1, y1));
            }
            left_z = z;
        }
    }
    return area;
}

// The micro-patches of blocks `lo .. lo + count` (level g.level): each block is a patch parallel to
// the light at its minimum depth; with gap filling a patch's left and bottom edges are extended to
// the neighbouring patch's edge when that patch occludes too (Guennebaud et al. 2006).
fn gather_micropatches(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, g: Gather, lo: vec2<i32>, count: vec2<i32>) -> f32 {
    var area = 0.0;
    // Not in a full search: it stays the 2006 gather, the yardstick of the others.
    let refine = select(min(i32(g.settings.edge_refine), g.level), 0, g.settings.hierarchy == HIERARCHY_NONE);
    for (var row = 0; row < MAX_GATHER_AXIS; row = row + 1) {
        if row >= count.y {
            break;
        }
        let by = lo.y + row;
        let t_top = edge_t(g, by * g.block);
        let t_bottom = edge_t(g, min((by + 1) * g.block, g.map));
        var left_z = HIERARCHY_EMPTY;
        if lo.x > 0 {
            left_z = occluder_depth(hsm, mssm, g, vec2<i32>(lo.x - 1, by));
        }
        for (var col = 0; col < MAX_GATHER_AXIS; col = col + 1) {
            if col >= count.x {
                break;
            }
            let bx = lo.x + col;
            let zr = occluder_range(hsm, mssm, g, g.level, vec2<i32>(bx, by));
            let z = zr.x;
            if z < HIERARCHY_EMPTY && refine > 0 && zr.y >= 0.0 {
                // Partly occluding: its occluding sub-blocks only.
                area += refined_patches(hsm, mssm, g, vec2<i32>(bx, by), refine);
            } else if z < HIERARCHY_EMPTY {
                let k = backprojection_scale(g, z);
                let s0 = edge_s(g, bx * g.block);
                let s1 = edge_s(g, min((bx + 1) * g.block, g.map));
                var x0 = k * (s0 * g.p.z - g.p.x);
                let x1 = k * (s1 * g.p.z - g.p.x);
                var y0 = k * (t_bottom * g.p.z - g.p.y);
                let y1 = k * (t_top * g.p.z - g.p.y);
                if g.settings.gap_filling != 0u {
                    if left_z < HIERARCHY_EMPTY {
                        x0 = min(x0, backprojection_scale(g, left_z) * (s0 * g.p.z - g.p.x));
                    }
                    if by + 1 < g.blocks {
                        let below = occluder_depth(hsm, mssm, g, vec2<i32>(bx, by + 1));
                        if below < HIERARCHY_EMPTY {
                            y0 = min(y0, backprojection_scale(g, below) * (t_bottom * g.p.z - g.p.y));
                        }
                    }
                }
                area += emit_patch(g, vec2<f32>(x0, y0), vec2<f32>(x1, y1));
            }
            left_z = z;
        }
    }
    return area;
}

struct QuadVertex {
    xy: vec2<f32>,
    occludes: bool,
}

// Centre of block `block`, unprojected at the block's depth and backprojected through p (bitmask
// paper sec. 4, Fig. 6); not clamped to the light.
fn quad_vertex(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, g: Gather, block: vec2<i32>) -> QuadVertex {
    var v: QuadVertex;
    let z = occluder_depth(hsm, mssm, g, block);
    v.occludes = z < HIERARCHY_EMPTY;
    let start = block * g.block;
    let centre = vec2<f32>(start) + 0.5 * vec2<f32>(min(vec2<i32>(g.block), vec2<i32>(g.map) - start));
    let slope = vec2<f32>(
        g.view.window.x + centre.x * texel_slope(g.view),
        g.view.window.w - centre.y * texel_slope(g.view),
    );
    v.xy = backprojection_scale(g, z) * (slope * g.p.z - g.p.xy);
    return v;
}

// The micro-quads between the block centres of `lo .. lo + count` (one more vertex per axis): a
// quad counts only when all four vertices occlude (paper sec. 4).
fn gather_microquads(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, g: Gather, lo: vec2<i32>, count: vec2<i32>) -> f32 {
    var area = 0.0;
    for (var row = 0; row < MAX_GATHER_AXIS; row = row + 1) {
        if row >= count.y {
            break;
        }
        let by = lo.y + row;
        var top_left = quad_vertex(hsm, mssm, g, vec2<i32>(lo.x, by));
        var bottom_left = quad_vertex(hsm, mssm, g, vec2<i32>(lo.x, by + 1));
        for (var col = 0; col < MAX_GATHER_AXIS; col = col + 1) {
            if col >= count.x {
                break;
            }
            let bx = lo.x + col + 1;
            let top_right = quad_vertex(hsm, mssm, g, vec2<i32>(bx, by));
            let bottom_right = quad_vertex(hsm, mssm, g, vec2<i32>(bx, by + 1));
            if top_left.occludes && bottom_left.occludes && top_right.occludes && bottom_right.occludes {
                area += emit_quad(g, top_left.xy, top_right.xy, bottom_left.xy, bottom_right.xy);
            }
            top_left = top_right;
            bottom_left = bottom_right;
        }
    }
    return area;
}

// Occluding depth of grid block `block` (`occluder_depth`), HIERARCHY_EMPTY outside the gathered
// blocks `lo .. lo + count`: nothing outside the refined search area reaches the light (it is no
// nearer than the area's nearest depth, whose light pyramid the area is).
fn contour_block(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, g: Gather, lo: vec2<i32>, count: vec2<i32>, block: vec2<i32>) -> f32 {
    if any(block < lo) || any(block >= lo + count) {
        return HIERARCHY_EMPTY;
    }
    return occluder_depth(hsm, mssm, g, block);
}

// Block corner `corner` (level-0 texel edges corner * block), unprojected at depth `z` and
// backprojected through p onto the light plane.
fn contour_vertex(g: Gather, corner: vec2<i32>, z: f32) -> vec2<f32> {
    let e = min(corner * g.block, vec2<i32>(g.map));
    let slope = vec2<f32>(edge_s(g, e.x), edge_t(g, e.y));
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
fn contour_area(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, g: Gather, lo: vec2<i32>, count: vec2<i32>) -> f32 {
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
                contour_block(hsm, mssm, g, lo, count, vec2<i32>(c, r - 2)),
                contour_block(hsm, mssm, g, lo, count, vec2<i32>(c, r - 1)),
                contour_block(hsm, mssm, g, lo, count, vec2<i32>(c, r)),
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

// The gather over the refined search area `search` (kind SEARCH_GATHER) of the receiver set up in
// `g0`. Depth bands (`band_end`): each band gathers its own search area at the level that keeps it
// within per_axis blocks; the last band (or a full search) takes every depth that is left.
fn gather_search_area(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, g0: Gather, search: Search) -> GatherResult {
    let st = g0.settings;
    let p = g0.p;
    var g = g0;
    var out: GatherResult;
    out.area = 0.0;
    out.level = -1;
    out.primitives = 0u;
    var rect = search.rect;
    var z_lo = search.z_star;
    let bands = select(max(st.depth_bands, 1u), 1u, st.hierarchy == HIERARCHY_NONE);
    for (var band = 0u; band < MAX_DEPTH_BANDS; band = band + 1u) {
        if band >= bands {
            break;
        }
        let level = gather_level(rect, st.per_axis, st.max_level);
        var z_hi = HIERARCHY_EMPTY;
        if band + 1u < bands && level > 0 {
            z_hi = band_end(p.z, z_lo, f32(1 << u32(min(level, 2))));
        }
        g = at_level(g, level, vec2<f32>(select(0.0, z_lo, band > 0u), z_hi));
        let lo = rect.lo >> vec2<u32>(u32(g.level));
        let hi = rect.hi >> vec2<u32>(u32(g.level));
        var count: vec2<i32>;
        // The contour integral clips its edges to the rectangle: a round light sums micro-primitives.
        if st.visibility == VISIBILITY_CONTOUR && light_kind() == LIGHT_RECT {
            count = clamp(hi - lo + 1, vec2<i32>(0), vec2<i32>(st.per_axis));
            out.area += contour_area(hsm, mssm, g, lo, count);
        } else if st.primitive == PRIMITIVE_MICROQUAD {
            // Quads between block centres lo - 1 .. hi + 1 that lie inside the map.
            let quad_lo = max(lo - 1, vec2<i32>(0));
            let quad_hi = min(hi, vec2<i32>(g.blocks - 2));
            count = clamp(quad_hi - quad_lo + 1, vec2<i32>(0), vec2<i32>(st.per_axis + 1));
            out.area += gather_microquads(hsm, mssm, g, quad_lo, count);
        } else {
            count = clamp(hi - lo + 1, vec2<i32>(0), vec2<i32>(st.per_axis));
            out.area += gather_micropatches(hsm, mssm, g, lo, count);
        }
        out.primitives += u32(count.x * count.y);
        if band == 0u {
            out.level = g.level;
        }
        g.prev_level = g.level;
        if z_hi >= HIERARCHY_EMPTY {
            break;
        }
        // The next band's area, refined once by the nearest depth in it; nothing nearer than the
        // receiver there: no later band can occlude either (their areas lie inside it).
        z_lo = z_hi;
        rect = search_rect(g.view, p, g.half_light, z_lo);
        if rect_is_empty(rect) {
            break;
        }
        let range = hierarchy_range(hsm, mssm, st.hierarchy, rect, st.max_level);
        if range.x >= p.z - g.bias {
            break;
        }
        if range.x > z_lo {
            rect = search_rect(g.view, p, g.half_light, range.x);
            if rect_is_empty(rect) {
                break;
            }
        }
    }
    return out;
}

// View-dependent adaptive screen resolution (Guennebaud, Barthe & Paulin 2007's third remedy, in
// this project's form; docs/TECHNIQUES.md, `backprojection`, "Large penumbrae"). A pixel whose
// penumbra is wide on screen is not gathered: a first pass (`gather_coarse`) gathers every
// `factor`-th pixel per axis whose penumbra is wide, and the full-resolution pass interpolates
// them, weighted by the bilinear weights, where all the samples it needs lie on the pixel's own
// surface (same normal, on its tangent plane): edge-aware, so a silhouette or a crease is never
// blurred across. Where any sample is missing or off the surface the pixel is gathered itself.
const ADAPTIVE_INVALID: f32 = -1.0;

// Screen pixels across the penumbra at receiver `s` of an occluder at light-space depth `z_b`:
// its width on the plane of the receiver parallel to the light, 2 min(a, b) (p.z - z_b) / z_b
// (similar triangles), over the world size of one pixel there (the distance to the nearest
// receiving neighbour along x or y). 0 where no neighbour tells the pixel size.
fn penumbra_pixels(s: Surface, pixel: vec2<i32>, z_b: f32, half_light: vec2<f32>) -> f32 {
    let p = s.light;
    let width = 2.0 * min(half_light.x, half_light.y) * max(p.z - z_b, 0.0) / max(z_b, 1.0e-6);
    var size = 1.0e30;
    let last = vec2<i32>(frame.screen.xy) - 1;
    let offsets = array<vec2<i32>, 4>(vec2<i32>(1, 0), vec2<i32>(-1, 0), vec2<i32>(0, 1), vec2<i32>(0, -1));
    for (var i = 0; i < 4; i = i + 1) {
        let q = clamp(pixel + offsets[i], vec2<i32>(0), last);
        let n = load_surface(q);
        let d = length(n.world - s.world);
        if n.is_receiver && d > 0.0 {
            size = min(size, d);
        }
    }
    if size >= 1.0e30 {
        return 0.0;
    }
    return width / size;
}

// The coarse sample `c` (the full-resolution pixel c * factor) of a pixel on surface `s` if it is
// usable: gathered (not ADAPTIVE_INVALID) and on the pixel's own surface. (value, weight ok).
fn coarse_sample(coarse: texture_2d<f32>, c: vec2<i32>, factor: i32, s: Surface) -> vec3<f32> {
    let dims = vec2<i32>(textureDimensions(coarse));
    let q = c * factor;
    if any(c >= dims) || any(q >= vec2<i32>(frame.screen.xy)) {
        return vec3<f32>(0.0, 0.0, 0.0);
    }
    let value = textureLoad(coarse, c, 0).xy;
    let t = load_surface(q);
    let d = t.world - s.world;
    // Same surface: normals within about 18 degrees, and the sample within about 3 degrees of the
    // pixel's tangent plane (a step in depth is another surface).
    let same = t.is_receiver && dot(t.normal, s.normal) > 0.95
        && abs(dot(d, s.normal)) <= 0.05 * length(d) + 1.0e-6;
    if value.x == ADAPTIVE_INVALID || !same {
        return vec3<f32>(0.0, 0.0, 0.0);
    }
    return vec3<f32>(value, 1.0);
}

// The pixel's (V, area estimate) interpolated from the coarse samples around it, and 1 in z when
// every sample with a bilinear weight was usable (else z = 0: gather the pixel itself).
fn upsample_coarse(coarse: texture_2d<f32>, pixel: vec2<i32>, factor: i32, s: Surface) -> vec3<f32> {
    let c0 = pixel / factor;
    let t = vec2<f32>(pixel - c0 * factor) / f32(factor);
    var sum = vec2<f32>(0.0);
    for (var k = 0; k < 4; k = k + 1) {
        let o = vec2<i32>(k & 1, k >> 1u);
        let w = select(1.0 - t.x, t.x, o.x == 1) * select(1.0 - t.y, t.y, o.y == 1);
        if w > 0.0 {
            let v = coarse_sample(coarse, c0 + o, factor, s);
            if v.z == 0.0 {
                return vec3<f32>(0.0);
            }
            sum += w * v.xy;
        }
    }
    return vec3<f32>(sum, 1.0);
}

// What adaptive screen resolution makes of a pixel whose search found occluders nearest at
// `z_b`: x = ADAPTIVE_GATHER (gather it), ADAPTIVE_SKIP (coarse pass, narrow penumbra: left to
// the full pass) or ADAPTIVE_UPSAMPLED (full pass, wide penumbra, interpolated: (V, A) in y, z).
const ADAPTIVE_GATHER: f32 = 0.0;
const ADAPTIVE_SKIP: f32 = 1.0;
const ADAPTIVE_UPSAMPLED: f32 = 2.0;

fn adaptive_choice(coarse_in: texture_2d<f32>, r: Receiver, pixel: vec2<i32>, z_b: f32, factor: u32, min_pixels: f32, coarse: bool) -> vec3<f32> {
    if factor <= 1u {
        return vec3<f32>(ADAPTIVE_GATHER, 0.0, 0.0);
    }
    // A wide penumbra (by the nearest blocker found) is interpolated from the coarse pass.
    let wide = penumbra_pixels(r.s, pixel, z_b, r.half_light) >= min_pixels;
    if coarse && !wide {
        return vec3<f32>(ADAPTIVE_SKIP, 0.0, 0.0);
    }
    if !coarse && wide {
        let u = upsample_coarse(coarse_in, pixel, i32(factor), r.s);
        if u.z > 0.0 {
            return vec3<f32>(ADAPTIVE_UPSAMPLED, u.xy);
        }
    }
    return vec3<f32>(ADAPTIVE_GATHER, 0.0, 0.0);
}
