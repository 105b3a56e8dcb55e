// Bitmask soft shadows (Schwarz & Stamminger 2007). One invocation per screen pixel:
//   1. per depth layer (layer 0: the centre shadow map; layers 1..: depth peeled from the light
//      centre, sec. 3.2), the search area of the receiver point p with two refinements and the
//      lit / umbra early outs (softshadow::search_area, sec. 5); an umbra layer ends the pixel;
//   2. the level whose blocks number at most max_patches per axis (coarser-level fallback, sec. 5);
//   3. every micro-patch (a block parallel to the light at its minimum depth, with gap filling) or
//      micro-quad (block centres as vertices, approximated by the axis-aligned rectangle through
//      its edge centres, sec. 4) is backprojected from p onto the light plane, X = z (s p.z - p.x)
//      / (p.z - z), and the light samples the rectangle covers are OR-ed into one occlusion
//      bitmask shared by every layer (sec. 3), so overlapping occluders count once;
//   4. V = 1 - countOneBits(mask) / N. With post filtering on, the accumulated area estimate
//      A = 1 - sum(area) / 4ab (unclamped, sec. 3.1) is written alongside for filter.wgsl.
// The light samples lie in `rows` rows of `columns` samples: row r at y = -b + (r + 0.5) 2b / rows,
// sample c at x = -a + (c + offset(r)) 2a / columns. Row r takes `columns` bits starting at bit
// r * columns of the mask (one word holds 32 / columns rows). Patterns: 8x8, 16x16 and 32x32 are
// regular (offset 0.5); 16x16-jittered is the 8x8 tiling of the 2x2 rotated-grid pattern (sec. 3):
// 32 rows of 8 samples, offsets 3/8, 7/8, 1/8, 5/8 of a tile repeating every four rows.
// The per-pixel loop over the layers, the adaptive screen resolution, the counters and the
// entry points' bodies are the shared gather pass's (softshadow::gather_pass, GATHER_LAYERS = 4).
#import softshadow::gather::Gather
#import softshadow::gather_pass::{PixelResult, gather_pixels, gather_coarse_pixels, params}
#import softshadow::frame::light_kind
#import softshadow::light::LIGHT_RECT

// Words of the occlusion bitmask: 2 (8x8), 8 (16x16, 16x16-jittered) or 32 (32x32). One pipeline
// per size keeps the small masks in few registers (paper sec. 6).
const MASK_WORDS: u32 = #{MASK_WORDS}u;

// The area estimate A for the post filter (filter.wgsl), the gather pass's binding 7.
@group(1) @binding(7) var area_map: texture_storage_2d<r32float, write>;

// What one pixel accumulates over its layers.
struct Accumulator {
    mask: array<u32, MASK_WORDS>,
    // Summed light area of the backprojected rectangles (only with params.with_area).
    area: f32,
}

// The pixel's accumulator, filled through the scaffold's `emit_patch` / `emit_quad` overrides.
var<private> acc: Accumulator;

// Bits c_lo..c_hi set (empty when c_hi < c_lo); c_lo, c_hi in 0..31.
fn bit_range(c_lo: i32, c_hi: i32) -> u32 {
    if c_hi < c_lo {
        return 0u;
    }
    let width = u32(c_hi - c_lo + 1);
    // width = 32 shifts by 0 (WGSL takes the shift modulo 32): all ones.
    return (0xffffffffu >> (32u - width)) << u32(c_lo);
}

// Samples of one row (offset `offset` in sample cells) with u0 <= c + offset < u1, as bits.
fn row_bits(u0: f32, u1: f32, offset: f32) -> u32 {
    let last = i32(params.columns) - 1;
    let c_lo = max(i32(ceil(u0 - offset)), 0);
    let c_hi = min(i32(ceil(u1 - offset)) - 1, last);
    return bit_range(c_lo, c_hi);
}

// Offset of the samples of row r within their cells: the 2x2 rotated grid (x = 3/8, 7/8, 1/8,
// 5/8 of a tile for its four rows) or the cell centre.
fn row_offset(r: u32) -> f32 {
    if params.jittered == 0u {
        return 0.5;
    }
    let rgss = array<f32, 4>(0.375, 0.875, 0.125, 0.625);
    return rgss[r & 3u];
}

// Bits of mask word `w` among the mask bits first..last, from the tiled row masks of one word.
fn word_bits(tiled: u32, first: u32, last: u32, w: u32) -> u32 {
    let lo = max(i32(first) - i32(w * 32u), 0);
    let hi = min(i32(last) - i32(w * 32u), 31);
    return tiled & bit_range(lo, hi);
}

// ORs the light samples inside the light-space rectangle [lo, hi] into the mask (sec. 3: scale,
// bias and integer conversion map the extent to bit ranges); adds its clipped area when asked.
// Loop free on purpose: the gather spends the loop budget (docs/DEVICES.md, "Lavapipe's
// loop budget").
fn cover_rect(g: Gather, lo: vec2<f32>, hi: vec2<f32>) -> f32 {
    // The area goes straight into the accumulator (in the order the rectangles come): the scaffold's
    // sum of what this returns is not used.
    let a = g.half_light;
    // Clamped first: a backprojected coordinate can be huge (p next to the occluder).
    let c0 = clamp(lo, -2.0 * a, 2.0 * a);
    let c1 = clamp(hi, -2.0 * a, 2.0 * a);
    if params.with_area != 0u {
        let w = max(min(c1.x, a.x) - max(c0.x, -a.x), 0.0);
        let h = max(min(c1.y, a.y) - max(c0.y, -a.y), 0.0);
        acc.area += w * h;
    }
    let cells = vec2<f32>(f32(params.columns), f32(params.rows));
    let u0 = (c0 + a) / (2.0 * a) * cells;
    let u1 = (c1 + a) / (2.0 * a) * cells;
    // Rows r with u0.y <= r + 0.5 < u1.y.
    let r_lo = max(i32(ceil(u0.y - 0.5)), 0);
    let r_hi = min(i32(ceil(u1.y - 0.5)) - 1, i32(params.rows) - 1);
    if r_hi < r_lo {
        return 0.0;
    }
    // The row masks: one for regular patterns, four (the rotated grid's offsets) when jittered.
    let m0 = row_bits(u0.x, u1.x, row_offset(0u));
    let m1 = row_bits(u0.x, u1.x, row_offset(1u));
    let m2 = row_bits(u0.x, u1.x, row_offset(2u));
    let m3 = row_bits(u0.x, u1.x, row_offset(3u));
    if (m0 | m1 | m2 | m3) == 0u {
        return 0.0;
    }
    // The row masks tiled over one word: a word holds 32 / columns rows, starting at a multiple
    // of four rows when columns = 8, so its row j takes offset j (only 8-column rows are jittered).
    var tiled = m0;
    if params.columns == 8u {
        tiled = m0 | (m1 << 8u) | (m2 << 16u) | (m3 << 24u);
    } else if params.columns == 16u {
        tiled = m0 | (m0 << 16u);
    }
    // Rows r_lo..r_hi are the mask bits first..last; every word takes its part of them.
    let first = u32(r_lo) * params.columns;
    let last = (u32(r_hi) + 1u) * params.columns - 1u;
    acc.mask[0] |= word_bits(tiled, first, last, 0u);
    acc.mask[1] |= word_bits(tiled, first, last, 1u);
#if MASK_WORDS >= 8
    acc.mask[2] |= word_bits(tiled, first, last, 2u);
    acc.mask[3] |= word_bits(tiled, first, last, 3u);
    acc.mask[4] |= word_bits(tiled, first, last, 4u);
    acc.mask[5] |= word_bits(tiled, first, last, 5u);
    acc.mask[6] |= word_bits(tiled, first, last, 6u);
    acc.mask[7] |= word_bits(tiled, first, last, 7u);
#endif
#if MASK_WORDS >= 32
    acc.mask[8] |= word_bits(tiled, first, last, 8u);
    acc.mask[9] |= word_bits(tiled, first, last, 9u);
    acc.mask[10] |= word_bits(tiled, first, last, 10u);
    acc.mask[11] |= word_bits(tiled, first, last, 11u);
    acc.mask[12] |= word_bits(tiled, first, last, 12u);
    acc.mask[13] |= word_bits(tiled, first, last, 13u);
    acc.mask[14] |= word_bits(tiled, first, last, 14u);
    acc.mask[15] |= word_bits(tiled, first, last, 15u);
    acc.mask[16] |= word_bits(tiled, first, last, 16u);
    acc.mask[17] |= word_bits(tiled, first, last, 17u);
    acc.mask[18] |= word_bits(tiled, first, last, 18u);
    acc.mask[19] |= word_bits(tiled, first, last, 19u);
    acc.mask[20] |= word_bits(tiled, first, last, 20u);
    acc.mask[21] |= word_bits(tiled, first, last, 21u);
    acc.mask[22] |= word_bits(tiled, first, last, 22u);
    acc.mask[23] |= word_bits(tiled, first, last, 23u);
    acc.mask[24] |= word_bits(tiled, first, last, 24u);
    acc.mask[25] |= word_bits(tiled, first, last, 25u);
    acc.mask[26] |= word_bits(tiled, first, last, 26u);
    acc.mask[27] |= word_bits(tiled, first, last, 27u);
    acc.mask[28] |= word_bits(tiled, first, last, 28u);
    acc.mask[29] |= word_bits(tiled, first, last, 29u);
    acc.mask[30] |= word_bits(tiled, first, last, 30u);
    acc.mask[31] |= word_bits(tiled, first, last, 31u);
#endif
    return 0.0;
}

override fn softshadow::gather::emit_patch(g: Gather, lo: vec2<f32>, hi: vec2<f32>) -> f32 {
    // The scaffold's micro-patches (with gap filling and edge refinement) set the light samples
    // they cover (softshadow::gather). No comment right above: see `emit_patch` there.
    return cover_rect(g, lo, hi);
}

override fn softshadow::gather::emit_quad(g: Gather, top_left: vec2<f32>, top_right: vec2<f32>, bottom_left: vec2<f32>, bottom_right: vec2<f32>) -> f32 {
    // A micro-quad (all four vertices occlude) is approximated by the axis-aligned rectangle
    // through the centres of its edges (sec. 4, Fig. 6 right); its vertices are not clamped to
    // the light, so the rectangle keeps its true extent.
    let left = 0.5 * (top_left.x + bottom_left.x);
    let right = 0.5 * (top_right.x + bottom_right.x);
    let top = 0.5 * (top_left.y + top_right.y);
    let bottom = 0.5 * (bottom_left.y + bottom_right.y);
    return cover_rect(
        g,
        vec2<f32>(min(left, right), min(top, bottom)),
        vec2<f32>(max(left, right), max(top, bottom)),
    );
}

override fn softshadow::gather_pass::begin_pixel() {
    // The area estimate restarts with every pixel (the mask starts empty: one pixel per
    // invocation).
    acc.area = 0.0;
}

fn set_bits() -> u32 {
    var n = 0u;
    for (var w = 0u; w < MASK_WORDS; w = w + 1u) {
        n += countOneBits(acc.mask[w]);
    }
    return n;
}

// Under a disk, sphere or spot light (half_light = (r, r)): the pattern's samples inside the
// disk inscribed in its square, row by row (row r's chord |x| <= sqrt(1 - y^2) in units of r, as
// sample cells), and how many of them are set. A sphere is its disk in the light plane, as for
// every shadow-map technique here (docs/LIGHTS.md, "Round lights in the seed techniques").
fn disk_bits() -> vec2<u32> {
    var covered = 0u;
    var inside = 0u;
    let columns = params.columns;
    for (var r = 0u; r < params.rows; r = r + 1u) {
        let y = (f32(r) + 0.5) / f32(params.rows) * 2.0 - 1.0;
        let half_chord = sqrt(max(1.0 - y * y, 0.0)) * 0.5 * f32(columns);
        let centre = 0.5 * f32(columns);
        let chord = row_bits(centre - half_chord, centre + half_chord, row_offset(r));
        let first = r * columns;
        let row_mask = bit_range(0, i32(columns) - 1);
        let row = (acc.mask[first / 32u] >> (first % 32u)) & row_mask;
        covered += countOneBits(row & chord);
        inside += countOneBits(chord);
    }
    return vec2<u32>(covered, max(inside, 1u));
}

override fn softshadow::gather_pass::finish_pixel(r0: PixelResult, half_light: vec2<f32>, area: f32) -> PixelResult {
    // V = 1 - set bits / samples (sec. 3); the area estimate from the summed rectangles (`acc`:
    // `area`, the sum of what cover_rect returned, is 0).
    var r = r0;
    if light_kind() == LIGHT_RECT {
        let samples = params.rows * params.columns;
        r.set_bits = set_bits();
        r.v = 1.0 - f32(r.set_bits) / f32(samples);
    } else {
        let bits = disk_bits();
        r.set_bits = bits.x;
        r.v = 1.0 - f32(bits.x) / f32(bits.y);
    }
    let light_area = 4.0 * half_light.x * half_light.y;
    r.area_v = 1.0 - acc.area / light_area;
    if !(r.v >= 0.0 && r.v <= 1.0) {
        // NaN guard: never write a non-finite visibility.
        r.v = 1.0;
    }
    if !(abs(r.area_v) < 1.0e30) {
        r.area_v = 0.0;
    }
    return r;
}

override fn softshadow::gather_pass::store_pixel(pixel: vec2<i32>, r: PixelResult) {
    // The area estimate for the post filter (filter.wgsl), only while it is on.
    if params.with_area != 0u {
        textureStore(area_map, pixel, vec4<f32>(r.area_v, 0.0, 0.0, 0.0));
    }
}

@compute @workgroup_size(8, 8)
fn gather(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    gather_pixels(id, local);
}

// The coarse pass of adaptive screen resolution.
@compute @workgroup_size(8, 8)
fn gather_coarse(@builtin(global_invocation_id) id: vec3<u32>) {
    gather_coarse_pixels(id);
}
